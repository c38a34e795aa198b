//! Work per step of the Runge–Kutta integrators (Dormand–Prince 5(4) and DOP853) on two
//! generic problems: the Van der Pol oscillator (ODE, μ = 1) and the delayed logistic
//! (Hutchinson) equation, at rtol 1e-8.
#[path = "../tests/common/mod.rs"]
mod common;

use common::{DelayedLogistic, VanDerPol};
use criterion::{Criterion, criterion_group, criterion_main};
use dde::{DdeSolver, Method, NoObserver, OdeSolver, Options};
use nalgebra::SVector;
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    for method in [Method::Dopri5, Method::Dop853] {
        pair(c, method);
    }
}

fn pair(c: &mut Criterion, method: Method) {
    let opts = Options::with_tolerances(1e-8, 1e-10).with_method(method);
    let suffix = match method {
        Method::Dopri5 => "",
        Method::Dop853 => "_dop853",
    };
    let vdp = VanDerPol { mu: 1.0 };
    {
        let mut s = OdeSolver::new(&vdp, 0.0, SVector::from([2.0, 0.0]), opts.clone()).unwrap();
        s.integrate(&vdp, 100.0, &[], &mut NoObserver).unwrap();
        eprintln!("van der Pol, 100 time units, {method:?}: {:?}", s.stats());
    }
    c.bench_function(&format!("van_der_pol_ode_100{suffix}"), |b| {
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
        eprintln!(
            "delayed logistic, 100 time units, {method:?}: {:?}",
            s.stats()
        );
    }
    c.bench_function(&format!("delayed_logistic_dde_100{suffix}"), |b| {
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
