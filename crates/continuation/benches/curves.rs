//! Cost of a Hopf curve of ≥ 100 points of a 4-dimensional DDE with one delay (two coupled
//! damped oscillators with delayed position feedback), continued in the feedback gain k and
//! the delay τ (from 1 to about 7), with the remaining spectrum (Chebyshev collocation of
//! degree N, 8 rightmost roots, Newton-refined) at every point and codimension-two points
//! (two double-Hopf points) located. The spectrum dominates the cost: N = 30 (the default)
//! and N = 20 (enough for the rightmost roots here: |λ|τ ≲ 15) are measured.
use continuation::*;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

/// q_i'' = −2ζ q_i' − q_i − k q_i(t − τ) + ε (q_j − q_i) − q_i³, state [q1, q1', q2, q2'],
/// p = [k, τ]
struct DelayedOscillators {
    zeta: f64,
    eps: f64,
}

impl Problem for DelayedOscillators {
    fn dim(&self) -> usize {
        4
    }
    fn n_delays(&self) -> usize {
        1
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[1]
    }
    fn delay_dp(&self, _j: usize, _p: &[f64], ip: usize) -> f64 {
        if ip == 1 { 1.0 } else { 0.0 }
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        let (z, e, k) = (self.zeta, self.eps, p[0]);
        f[0] = x[1];
        f[1] = -2.0 * z * x[1] - x[0] - k * x[4] + e * (x[2] - x[0]) - x[0].powi(3);
        f[2] = x[3];
        f[3] = -2.0 * z * x[3] - x[2] - k * x[6] + e * (x[0] - x[2]) - x[2].powi(3);
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        let (z, e, k) = (self.zeta, self.eps, p[0]);
        j.iter_mut().for_each(|v| *v = 0.0);
        j[1] = 1.0;
        j[8] = -1.0 - e - 3.0 * x[0] * x[0];
        j[8 + 1] = -2.0 * z;
        j[8 + 2] = e;
        j[8 + 4] = -k;
        j[16 + 3] = 1.0;
        j[24] = e;
        j[24 + 2] = -1.0 - e - 3.0 * x[2] * x[2];
        j[24 + 3] = -2.0 * z;
        j[24 + 6] = -k;
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        if ip == 0 {
            out[1] = -x[4];
            out[3] = -x[6];
        }
    }
    fn second_derivative(
        &self,
        x: &[f64],
        _p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out.iter_mut().for_each(|v| *v = 0.0);
        out[1] = -6.0 * x[0] * a[0] * b[0];
        out[3] = -6.0 * x[2] * a[2] * b[2];
        Ok(())
    }
    fn jacobian_dp(
        &self,
        _x: &[f64],
        _p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out.iter_mut().for_each(|v| *v = 0.0);
        if ip == 0 {
            out[1] = -a[4];
            out[3] = -a[6];
        }
        Ok(())
    }
}

fn cont() -> Continuation {
    Continuation::new(ContinuationOptions {
        initial_step: 0.05,
        max_step: 0.1,
        parameter_range: (-10.0, 10.0),
        ..Default::default()
    })
}

/// the first Hopf point of the equilibrium 0 at τ = 1, continued in k from 0
fn hopf_point(problem: &DelayedOscillators) -> HopfPoint {
    let c = cont();
    let mut eq = EquilibriumSystem::new(problem, vec![0.0, 1.0], 0, ChebyshevRoots::default())
        .expect("system");
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[0.0; 5], &dir).expect("start");
    c.extend(&mut eq, &mut br, 60).expect("branch");
    let (i, sp) = br.first(SpecialKind::Hopf).expect("a Hopf point");
    eq.hopf_point(&br.points[i].u, sp.transversality.expect("located"))
        .expect("Hopf point")
}

fn hopf_curve(
    problem: &DelayedOscillators,
    hopf: &HopfPoint,
    points: usize,
    degree: usize,
) -> Branch {
    let c = cont();
    let roots = ChebyshevRoots {
        degree,
        ..Default::default()
    };
    let mut hc = HopfCurveSystem::new(problem, vec![0.0, 1.0], [0, 1], roots).expect("system");
    let (guess, dir) = hc.start_at_hopf(hopf, 0).expect("start data");
    let mut curve = c.start(&mut hc, &guess, &dir).expect("start");
    c.extend(&mut hc, &mut curve, points).expect("curve");
    curve
}

fn bench(c: &mut Criterion) {
    let problem = DelayedOscillators {
        zeta: 0.1,
        eps: 0.2,
    };
    let hopf = hopf_point(&problem);
    let mut group = c.benchmark_group("hopf_curve_4d_dde_100_points");
    group.sample_size(10);
    for degree in [30, 20] {
        let curve = hopf_curve(&problem, &hopf, 100, degree);
        assert!(curve.points.len() > 100);
        assert_eq!(
            curve
                .special_points()
                .filter(|(_, s)| s.kind == SpecialKind::DoubleHopf)
                .count(),
            2
        );
        group.bench_function(format!("chebyshev_degree_{degree}"), |b| {
            b.iter(|| hopf_curve(black_box(&problem), &hopf, 100, degree))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
