//! Helpers shared by the integration tests (the problems are in `continuation_textbook`).
#![allow(dead_code)]

use continuation::*;
use nalgebra::DMatrix;

/// continuation with the given initial and maximal step, other options default
pub fn cont(step: f64, max_step: f64) -> Continuation {
    Continuation::new(ContinuationOptions {
        initial_step: step,
        max_step,
        ..Default::default()
    })
}

/// the equilibrium branch from the unknowns `u0` (x, then p\[ip\]), continued `steps`
/// steps in parameter `ip` (steps 0.05 to 0.1)
pub fn equilibrium_branch<'a, P: Problem>(
    problem: &'a P,
    p: Vec<f64>,
    ip: usize,
    u0: &[f64],
    steps: usize,
) -> (EquilibriumSystem<'a, P, ChebyshevRoots>, Branch) {
    let c = cont(0.05, 0.1);
    let mut eq = EquilibriumSystem::new(problem, p, ip, ChebyshevRoots::default()).unwrap();
    let dir = eq.parameter_direction();
    let br = continued(&c, &mut eq, u0, &dir, steps);
    (eq, br)
}

/// Hopf point of an equilibrium branch x = 0 continued in parameter `ip` from `p[ip]`
pub fn hopf_on_branch<P: Problem>(problem: &P, p: Vec<f64>, ip: usize, steps: usize) -> HopfPoint {
    let mut u0 = vec![0.0; problem.dim()];
    u0.push(p[ip]);
    let (mut eq, br) = equilibrium_branch(problem, p, ip, &u0, steps);
    let (i, sp) = br.first(SpecialKind::Hopf).expect("a Hopf point");
    assert_eq!(sp.location, Location::Located);
    eq.hopf_point(&br.points[i].u, sp.transversality.unwrap())
        .unwrap()
}

/// collocation on `intervals` mesh intervals, other options default
pub fn colloc(intervals: usize) -> CollocationOptions {
    CollocationOptions {
        intervals,
        ..Default::default()
    }
}

/// the cycles born at `hopf` (first amplitude 0.05), continued `steps` steps in p\[0\] on
/// `intervals` mesh intervals
pub fn cycles_from_hopf<'a, P: Problem>(
    c: &Continuation,
    problem: &'a P,
    p: Vec<f64>,
    intervals: usize,
    hopf: &HopfPoint,
    steps: usize,
) -> (PeriodicOrbitSystem<'a, P>, Branch) {
    let mut po = PeriodicOrbitSystem::new(problem, p, 0, colloc(intervals)).unwrap();
    let (guess, dir) = po.hopf_guess(hopf, 0.05);
    let mut br = c.start(&mut po, &guess, &dir).unwrap();
    c.extend(&mut po, &mut br, steps).unwrap();
    (po, br)
}

/// dense Jacobian of a continuation system from its triplets
pub fn dense_jacobian<S: ContinuationSystem>(sys: &mut S, u: &[f64]) -> DMatrix<f64> {
    let nu = sys.n_unknowns();
    let mut entries = Vec::new();
    sys.jacobian(u, &mut entries).unwrap();
    let mut j = DMatrix::zeros(nu - 1, nu);
    for e in entries {
        j[(e.row, e.col)] += e.val;
    }
    j
}

/// central differences of the residual, h = 1e-6 (1 + |u_i|)
pub fn fd_jacobian_of<S: ContinuationSystem>(sys: &mut S, u: &[f64]) -> DMatrix<f64> {
    let nu = sys.n_unknowns();
    let mut j = DMatrix::zeros(nu - 1, nu);
    let (mut rp, mut rm) = (vec![0.0; nu - 1], vec![0.0; nu - 1]);
    let mut x = u.to_vec();
    for col in 0..nu {
        let h = 1e-6 * (1.0 + u[col].abs());
        x[col] = u[col] + h;
        sys.residual(&x, &mut rp).unwrap();
        x[col] = u[col] - h;
        sys.residual(&x, &mut rm).unwrap();
        x[col] = u[col];
        for row in 0..nu - 1 {
            j[(row, col)] = (rp[row] - rm[row]) / (2.0 * h);
        }
    }
    j
}

/// the two-parameter curve system made by `new` (`HopfCurveSystem::new`,
/// `FoldCurveSystem::new`) for `problem` in the free parameters `free`, the remaining
/// spectrum from the default Chebyshev roots
pub fn curve_system<'a, P: Problem, S>(
    new: fn(&'a P, Vec<f64>, [usize; 2], ChebyshevRoots) -> Result<S>,
    problem: &'a P,
    p: Vec<f64>,
    free: [usize; 2],
) -> S {
    new(problem, p, free, ChebyshevRoots::default()).unwrap()
}

/// the branch of `sys` started at `guess` in the direction `dir` and continued `steps`
/// steps with `c`
pub fn continued<S: ContinuationSystem>(
    c: &Continuation,
    sys: &mut S,
    guess: &[f64],
    dir: &[f64],
    steps: usize,
) -> Branch {
    let mut br = c.start(sys, guess, dir).unwrap();
    c.extend(sys, &mut br, steps).unwrap();
    br
}

/// the one codimension-two point of a curve, of kind `kind` and at |p1| < `tol.0`,
/// |p2| < `tol.1`
pub fn only_codim2(points: Vec<Codim2Point>, kind: SpecialKind, tol: (f64, f64)) -> Codim2Point {
    assert_eq!(points.len(), 1, "{points:?}");
    let c2 = single_codim2(points, kind);
    assert!(c2.p1.abs() < tol.0 && c2.p2.abs() < tol.1, "{c2:?}");
    c2
}

/// the one codimension-two point of kind `kind` among `points`
pub fn single_codim2(points: Vec<Codim2Point>, kind: SpecialKind) -> Codim2Point {
    let mut of_kind: Vec<_> = points.into_iter().filter(|c| c.kind == kind).collect();
    assert_eq!(of_kind.len(), 1, "{of_kind:?}");
    of_kind.remove(0)
}
