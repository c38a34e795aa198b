//! The structured solver of the collocation systems (`LinearSolver::Krylov`: the mesh-local
//! part by sparse LU, the delayed couplings by preconditioned GMRES) against the sparse LU
//! of the whole system (`LinearSolver::SparseLu`, an independent direct solve) on the same
//! systems: periodic orbits, folds of cycles, torus and period-doubling points of delay
//! equations, one Newton step and whole branches.
mod common;
use common::cont;
use continuation::*;
use continuation_textbook::{DelayedBautin, TorusTestBed};
use std::f64::consts::PI;

fn colloc(intervals: usize) -> CollocationOptions {
    CollocationOptions {
        intervals,
        ..Default::default()
    }
}

/// max |a − b| / max |b|
fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// the Newton update of `sys` at u along the tangent e_p with each solver (the system's
/// solver is set by `set`)
fn both_updates<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    set: impl Fn(&mut S, LinearSolver),
) -> (Vec<f64>, Vec<f64>) {
    let mut t = vec![0.0; u.len()];
    t[sys.parameter_index()] = 1.0;
    set(sys, LinearSolver::Krylov);
    let krylov = newton_step(sys, u, &t).unwrap();
    set(sys, LinearSolver::SparseLu);
    let direct = newton_step(sys, u, &t).unwrap();
    (krylov, direct)
}

/// a non-solution near the in-phase rotating wave of the coupled delayed Bautin oscillators
fn perturbed_wave(po: &PeriodicOrbitSystem<'_, DelayedBautin>, mu1: f64) -> Vec<f64> {
    po.unknowns_from(
        |s| {
            let (c, sn) = ((2.0 * PI * s).cos(), (2.0 * PI * s).sin());
            vec![c + 0.05 * sn * sn, sn, 0.9 * c, sn + 0.1 * c * sn]
        },
        7.0,
        mu1,
    )
}

#[test]
fn krylov_newton_steps_equal_sparse_lu_on_delayed_cycles() {
    // reference: the sparse LU of the whole bordered system; GMRES solves to a relative
    // residual of 1e-12, so the updates agree to ~1e-12 times the condition number:
    // required 1e-8 relative. τ = 0.5 and τ = 2.5 (the delay reaches a third of the
    // period back) on L = 20 and 60.
    let problem = DelayedBautin::coupled(0.1);
    for (tau, l) in [(0.5, 20), (2.5, 20), (2.5, 60)] {
        let mut po = PeriodicOrbitSystem::new(&problem, vec![0.5, 1.0, tau], 0, colloc(l)).unwrap();
        let u = perturbed_wave(&po, 0.5);
        po.set_reference(&po.shifted(&u, 0.01));
        let (k, d) = both_updates(&mut po, &u, |s, l| s.set_linear_solver(l));
        let diff = relative_difference(&k, &d);
        assert!(diff < 1e-8, "τ {tau}, L {l}: {diff:e}");
    }
}

#[test]
fn krylov_newton_steps_equal_sparse_lu_on_extended_systems() {
    // reference as above (1e-8 relative): the fold-of-cycles system (null vector), the
    // torus system (complex mode) and the period-doubling system (antiperiodic mode) of
    // delay equations at generic points (not solutions)
    let bautin = DelayedBautin::coupled(0.1);
    let po = PeriodicOrbitSystem::new(&bautin, vec![0.5, 1.0, 2.5], 0, colloc(24)).unwrap();
    let orbit = perturbed_wave(&po, 0.5);
    let np = po.period_index();
    let generic = |len: usize, seed: f64| -> Vec<f64> {
        (0..len)
            .map(|i| 0.3 + 0.2 * ((i as f64) * seed).sin())
            .collect()
    };

    let mut fold = FoldOfCyclesSystem::new(
        &bautin,
        vec![0.5, 1.0, 2.5],
        (0, 1),
        colloc(24),
        FoldCyclesOptions::default(),
    )
    .unwrap();
    let mut u = fold.unknowns(&orbit, 1.0, &generic(np + 1, 0.618)).unwrap();
    fold.accept(&u);
    u[np + 5] += 0.01;
    let (k, d) = both_updates(&mut fold, &u, |s, l| s.set_linear_solver(l));
    let diff = relative_difference(&k, &d);
    assert!(diff < 1e-8, "fold of cycles: {diff:e}");

    let mut pd = PeriodDoublingCurveSystem::new(
        &bautin,
        vec![0.5, 1.0, 2.5],
        (0, 2),
        colloc(24),
        PeriodDoublingOptions::default(),
    )
    .unwrap();
    let mut u = orbit.clone();
    u.push(2.5);
    u.extend(generic(np, 0.377));
    pd.accept(&u);
    u[np + 7] -= 0.02;
    let (k, d) = both_updates(&mut pd, &u, |s, l| s.set_linear_solver(l));
    let diff = relative_difference(&k, &d);
    assert!(diff < 1e-8, "period doubling: {diff:e}");

    let bed = TorusTestBed::delayed();
    let mut torus = TorusCurveSystem::new(
        &bed,
        vec![0.2, 0.3, 2.5],
        (0, 2),
        colloc(24),
        TorusCurveOptions::default(),
    )
    .unwrap();
    let mut u = Vec::new();
    for g in 0..24 * 4 {
        let s = g as f64 / 96.0;
        u.extend([
            0.4 * (2.0 * PI * s).cos(),
            0.45 * (2.0 * PI * s).sin(),
            0.2 * (2.0 * PI * s + 1.0).cos(),
            0.1 * (4.0 * PI * s).sin(),
        ]);
    }
    let np = u.len();
    u.extend([6.1, 0.2, 2.5]);
    u.extend(generic(2 * np, 0.618));
    u.push(2.3);
    torus.accept(&u);
    u[np + 4] += 0.01;
    let (k, d) = both_updates(&mut torus, &u, |s, l| s.set_linear_solver(l));
    let diff = relative_difference(&k, &d);
    assert!(diff < 1e-8, "torus: {diff:e}");
}

#[test]
fn krylov_and_sparse_lu_branches_agree_to_the_newton_tolerance() {
    // reference: the cycle branch and the fold-of-cycles curve of the coupled delayed
    // Bautin oscillators (τ = 0.5) computed with the sparse LU; with GMRES the same points
    // (same step sequence) to 1e-8 (Newton tolerance 1e-10, updates solved to 1e-12
    // relative). The branch-point test is off, so that both use their own solver.
    let problem = DelayedBautin::coupled(0.1);
    let mut w: f64 = 1.0;
    for _ in 0..100 {
        w -= (w - 1.0 + (w * 0.5).sin()) / (1.0 + 0.5 * (w * 0.5).cos());
    }
    let mu1 = 1.0 - (w * 0.5).cos();
    let c = Continuation::new(ContinuationOptions {
        branch_points: false,
        ..cont(0.05, 0.1).options
    });
    let mut results = Vec::new();
    for solver in [LinearSolver::Krylov, LinearSolver::SparseLu] {
        let mut po =
            PeriodicOrbitSystem::new(&problem, vec![mu1, 1.0, 0.5], 0, colloc(16)).unwrap();
        po.set_linear_solver(solver);
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
        let mut br = c.start(&mut po, &u0, &dir).unwrap();
        c.extend(&mut po, &mut br, 60).unwrap();
        let (i, _) = br.first(SpecialKind::Fold).expect("fold of cycles");
        let options = FoldCyclesOptions {
            multipliers: false,
            ..Default::default()
        };
        let (mut fold, guess, dir) =
            FoldOfCyclesSystem::from_fold(&po, &br.points[i], 1, options).unwrap();
        let mut curve = c.start(&mut fold, &guess, &dir).unwrap();
        c.extend(&mut fold, &mut curve, 5).unwrap();
        results.push((br, curve));
    }
    let ((b1, c1), (b2, c2)) = (&results[0], &results[1]);
    for (a, b) in [(b1, b2), (c1, c2)] {
        assert_eq!(a.points.len(), b.points.len());
        for (p, q) in a.points.iter().zip(&b.points) {
            let diff = relative_difference(&p.u, &q.u);
            assert!(diff < 1e-8, "{diff:e}");
        }
    }
}
