//! Helpers shared by the integration tests (the problems are in `continuation::textbook`).
#![allow(dead_code)]

use continuation::*;

/// continuation with the given initial and maximal step, other options default
pub fn cont(step: f64, max_step: f64) -> Continuation {
    Continuation::new(ContinuationOptions {
        initial_step: step,
        max_step,
        ..Default::default()
    })
}

/// Hopf point of an equilibrium branch x = 0 continued in parameter `ip` from `p[ip]`
pub fn hopf_on_branch<P: Problem>(problem: &P, p: Vec<f64>, ip: usize, steps: usize) -> HopfPoint {
    let c = cont(0.05, 0.1);
    let p0 = p[ip];
    let mut eq = EquilibriumSystem::new(problem, p, ip, ChebyshevRoots::default()).unwrap();
    let dir = eq.parameter_direction();
    let mut u0 = vec![0.0; problem.dim()];
    u0.push(p0);
    let mut br = c.start(&mut eq, &u0, &dir).unwrap();
    c.extend(&mut eq, &mut br, steps).unwrap();
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
