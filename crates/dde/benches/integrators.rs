//! Work per step of the Dormand–Prince integrator on two generic problems:
//! the Van der Pol oscillator (ODE, μ = 1) and the delayed logistic (Hutchinson) equation.

use criterion::{Criterion, criterion_group, criterion_main};
use dde::{DdeProblem, DdeSolver, NoObserver, OdeProblem, OdeSolver, Options};
use nalgebra::SVector;
use std::hint::black_box;

struct VanDerPol {
    mu: f64,
}
impl OdeProblem<2> for VanDerPol {
    fn rhs(&self, _t: f64, x: &SVector<f64, 2>, dx: &mut SVector<f64, 2>) {
        dx[0] = x[1];
        dx[1] = self.mu * (1.0 - x[0] * x[0]) * x[1] - x[0];
    }
}

/// x'(t) = r x(t) (1 − x(t − 1)), x ≡ 0.5 on [−1, 0]; r = 1.4 gives a stable limit cycle.
struct DelayedLogistic {
    r: f64,
}
impl DdeProblem<1> for DelayedLogistic {
    fn delays(&self) -> &[f64] {
        &[1.0]
    }
    fn history(&self, _t: f64) -> SVector<f64, 1> {
        SVector::from([0.5])
    }
    fn rhs(&self, _t: f64, x: &SVector<f64, 1>, xd: &[SVector<f64, 1>], dx: &mut SVector<f64, 1>) {
        dx[0] = self.r * x[0] * (1.0 - xd[0][0]);
    }
}

fn benches(c: &mut Criterion) {
    let opts = Options::with_tolerances(1e-8, 1e-10);
    let vdp = VanDerPol { mu: 1.0 };
    {
        let mut s = OdeSolver::new(&vdp, 0.0, SVector::from([2.0, 0.0]), opts.clone()).unwrap();
        s.integrate(&vdp, 100.0, &[], &mut NoObserver).unwrap();
        eprintln!("van der Pol, 100 time units: {:?}", s.stats());
    }
    c.bench_function("van_der_pol_ode_100", |b| {
        b.iter(|| {
            let mut s = OdeSolver::new(&vdp, 0.0, SVector::from([2.0, 0.0]), opts.clone()).unwrap();
            s.integrate(&vdp, black_box(100.0), &[], &mut NoObserver)
                .unwrap();
            *s.state()
        })
    });
    let dl = DelayedLogistic { r: 1.4 };
    {
        let mut s = DdeSolver::new(&dl, 0.0, opts.clone()).unwrap();
        s.integrate(&dl, 100.0, &[], &mut NoObserver).unwrap();
        eprintln!("delayed logistic, 100 time units: {:?}", s.stats());
    }
    c.bench_function("delayed_logistic_dde_100", |b| {
        b.iter(|| {
            let mut s = DdeSolver::new(&dl, 0.0, opts.clone()).unwrap();
            s.integrate(&dl, black_box(100.0), &[], &mut NoObserver)
                .unwrap();
            *s.state()
        })
    });
}

criterion_group!(integrators, benches);
criterion_main!(integrators);
