//! Cost of a Hopf curve of ≥ 100 points of a 4-dimensional DDE with one delay (two coupled
//! damped oscillators with delayed position feedback), continued in the feedback gain k and
//! the delay τ (from 1 to about 7), with the remaining spectrum (Chebyshev collocation of
//! degree N, 8 rightmost roots, Newton-refined) at every point and codimension-two points
//! (two double-Hopf points) located. The spectrum dominates the cost: N = 30 (the default)
//! and N = 20 (enough for the rightmost roots here: |λ|τ ≲ 15) are measured.
use continuation::*;
use continuation_textbook::DelayedOscillators;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

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
