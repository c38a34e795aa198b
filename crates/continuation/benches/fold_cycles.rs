//! Fold-of-cycles curves: cost of one Newton step of the extended defining system versus the
//! number of mesh intervals L, and of a whole curve of 80 points, on a 4-dimensional delayed
//! problem: two coupled Bautin oscillators with delayed cubic terms (the in-phase rotating
//! waves have folds of cycles).
//!
//! Issue 23 item 1 (criterion medians, release, 2-core machine at load 2–4 from a parallel
//! build): one fold-of-cycles Newton step at L = 20 / 40 / 80 / 160 —
//! - block-forward solver (`LinearSolver::Auto`, GMRES on the Schur complement from K ≥ 80
//!   border unknowns): 1.4 / 3.1 / 5.4 / 12.4 ms: L = 160 costs 4.0× L = 40 (target ≤ 5×);
//! - the dense Schur complement throughout: 2.0 / 3.4 / 10.7 / 40.4 ms (11.9×: K grows
//!   with L, the Z = A⁻¹C columns with it);
//! - the sparse LU of the whole system: 6.8 / 33.6 / 215 / 1647 ms; GMRES preconditioned
//!   by the delay-free part (`LinearSolver::Krylov`): 20.5 / 49.1 / 110 / 225 ms.
//!
//! The starting point was 6.1 / 22.8 / 137 / 757 ms. With the block-forward
//! layouts kept per pattern (stop 38, idle machine): 0.84 / 1.74 / 3.40 / 7.27 ms, L = 160
//! 4.2× L = 40.
//!
//! Stop 41 (GMRES and the Arnoldi determinant from K = 40 on, the forward solves by
//! columns; 2026-12-05): 0.73 / 1.51 / 3.23 / 7.55 ms (5.0×) in a slow spell of the host;
//! L = 40 and 160 again, twice: 1.56 / 7.72 and 1.54 / 7.54 ms (4.95×, 4.88×); an hour
//! earlier, with the forward solves dividing by the pivots, 0.74 / 1.46 / 3.18 / 6.78 ms
//! (4.6×). L = 40 got 1.2× faster than stop 38's, L = 160 did not: the ratio is at the
//! target's edge. The cycle's own step: 0.22 / 0.39 / 0.82 / 1.80 ms.
use continuation::*;
use continuation_textbook::DelayedBautin;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::f64::consts::PI;
use std::hint::black_box;

const MU2: f64 = 1.0;
/// mesh of the whole-curve benchmark (the rotating waves are resolved to ~1e-7 on it)
const CURVE_INTERVALS: usize = 20;
const TAU: f64 = 0.5;

/// the fold of the in-phase cycles at (μ2, τ) = (1, 0.5) on L intervals, as the start of
/// a fold-of-cycles curve in (μ1, μ2): system, corrected first point
fn fold_start(
    problem: &DelayedBautin,
    l: usize,
    multipliers: bool,
) -> (FoldOfCyclesSystem<'_, DelayedBautin>, Vec<f64>, Vec<f64>) {
    // in-phase rotating wave of radius 1: ω = 1 − μ2 sin ωτ, μ1 = 1 − μ2 cos ωτ
    let mut w: f64 = 1.0;
    for _ in 0..100 {
        w -= (w - 1.0 + MU2 * (w * TAU).sin()) / (1.0 + MU2 * TAU * (w * TAU).cos());
    }
    let mu1 = 1.0 - MU2 * (w * TAU).cos();
    let col = CollocationOptions {
        intervals: l,
        ..Default::default()
    };
    let mut po = PeriodicOrbitSystem::new(problem, vec![mu1, MU2, TAU], 0, col).expect("system");
    let u0 = po.unknowns_from(
        |s| {
            let (c, sn) = ((2.0 * PI * s).cos(), (2.0 * PI * s).sin());
            vec![c, sn, c, sn]
        },
        2.0 * PI / w,
        mu1,
    );
    po.set_reference(&u0);
    let mut dir = vec![0.0; u0.len()];
    dir[po.parameter_index()] = -1.0;
    let cont = Continuation::new(ContinuationOptions {
        initial_step: 0.05,
        max_step: 0.1,
        ..Default::default()
    });
    let mut br = cont.start(&mut po, &u0, &dir).expect("cycle");
    cont.extend(&mut po, &mut br, 60).expect("cycle branch");
    let (i, _) = br.first(SpecialKind::Fold).expect("fold of cycles");
    let opts = FoldCyclesOptions {
        multipliers,
        ..Default::default()
    };
    let (mut sys, guess, dir) =
        FoldOfCyclesSystem::from_fold(&po, &br.points[i], 1, opts).expect("fold system");
    let first = cont
        .start(&mut sys, &guess, &dir)
        .expect("fold curve start");
    let u = first.points[0].u.clone();
    let t = first.points[0].tangent.clone();
    sys.accept(&u);
    (sys, u, t)
}

fn bench(c: &mut Criterion) {
    let problem = DelayedBautin::coupled(0.1);
    let mut group = c.benchmark_group("fold_cycles_4d_dde");
    group.sample_size(10);
    for &l in &[20usize, 40, 80, 160] {
        let (mut sys, u, t) = fold_start(&problem, l, false);
        // the default solver (LinearSolver::Auto: block elimination), GMRES preconditioned
        // by the delay-free part, and the sparse LU of the whole system
        for (solver, suffix) in [
            (LinearSolver::Auto, ""),
            (LinearSolver::Krylov, "_krylov"),
            (LinearSolver::SparseLu, "_sparse_lu"),
        ] {
            sys.set_linear_solver(solver);
            let name = format!("newton_step{suffix}");
            group.bench_with_input(BenchmarkId::new(name, l), &l, |b, _| {
                b.iter(|| newton_step(&mut sys, black_box(&u), &t).expect("step"))
            });
            // the fold's cycle as a one-parameter cycle system: one Newton step of the
            // plain periodic-orbit collocation of the delay equation, bordered with the
            // branch's tangent at the fold, the null vector (v, v_T, 0) (the parameter
            // direction is tangent to the fold's hyperplane there: that border is singular)
            let mut po = sys.periodic_system(&u).expect("cycle system");
            po.set_linear_solver(solver);
            let orbit = sys.orbit(&u).to_vec();
            let mut e = sys.null_vector(&u).to_vec();
            e.push(0.0);
            let name = format!("cycle_newton_step{suffix}");
            group.bench_with_input(BenchmarkId::new(name, l), &l, |b, _| {
                b.iter(|| newton_step(&mut po, black_box(&orbit), &e).expect("step"))
            });
        }
        sys.set_linear_solver(LinearSolver::Auto);
    }
    for multipliers in [false, true] {
        let (mut sys, u, t) = fold_start(&problem, CURVE_INTERVALS, multipliers);
        let cont = Continuation::new(ContinuationOptions {
            initial_step: 0.05,
            max_step: 0.1,
            ..Default::default()
        });
        let name = if multipliers {
            "curve_80_points_with_multipliers"
        } else {
            "curve_80_points"
        };
        group.bench_function(BenchmarkId::new(name, CURVE_INTERVALS), |b| {
            b.iter(|| {
                let mut curve = cont.start(&mut sys, &u, &t).expect("start");
                let stop = sys.extend_curve(&cont, &mut curve, 80).expect("curve");
                assert!(curve.points.len() > 80, "{stop:?}");
                curve
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
