//! Inputs held between integration calls (co-simulation): `input_jump` after each change.
//! References: closed-form solutions of piecewise-constant forcing.

use dde::{DdeProblem, DdeSolver, NoObserver, OdeProblem, OdeSolver, Options};
use nalgebra::SVector;

/// x' = −x + u with u held per call.
struct Lag {
    u: f64,
}

impl OdeProblem<1> for Lag {
    fn rhs(&self, _t: f64, x: &SVector<f64, 1>, dx: &mut SVector<f64, 1>) {
        dx[0] = -x[0] + self.u;
    }
}

/// x' = −x(t − 1) + u, x = 0 for t ≤ 0, u held per call.
struct DelayedLag {
    u: f64,
    delays: [f64; 1],
}

impl DdeProblem<1> for DelayedLag {
    fn delays(&self) -> &[f64] {
        &self.delays
    }
    fn history(&self, _t: f64) -> SVector<f64, 1> {
        SVector::zeros()
    }
    fn rhs(&self, _t: f64, _x: &SVector<f64, 1>, xd: &[SVector<f64, 1>], dx: &mut SVector<f64, 1>) {
        dx[0] = -xd[0][0] + self.u;
    }
}

#[test]
fn ode_with_an_input_switched_between_calls_matches_the_closed_form() {
    // u = 1 on [0, 0.5), 0 after: x = 1 − e^{−t}, then x(0.5)·e^{−(t − 0.5)}; tolerance
    // 1e-9 absolute at rtol 1e-10 (without `input_jump` the carried derivative of u = 1
    // would start the second call: an O(h) error in its first step)
    let mut p = Lag { u: 1.0 };
    let opts = Options::with_tolerances(1e-10, 1e-12);
    let mut s = OdeSolver::new(&p, 0.0, SVector::zeros(), opts).unwrap();
    s.integrate(&p, 0.5, &[], &mut NoObserver).unwrap();
    p.u = 0.0;
    s.input_jump();
    s.integrate(&p, 2.0, &[], &mut NoObserver).unwrap();
    let exact = (1.0 - (-0.5f64).exp()) * (-1.5f64).exp();
    assert!(
        (s.state()[0] - exact).abs() < 1e-9,
        "{} vs {exact}",
        s.state()[0]
    );
}

#[test]
fn dde_with_an_input_switched_between_calls_matches_the_method_of_steps() {
    // u = 1 on [0, 0.3), 0 after, x' = −x(t − 1) + u, x ≡ 0 before 0. By steps: on [0, 0.3]
    // x = t; on [0.3, 1] x = 0.3; on [1, 1.3] x' = −(t − 1): x = 0.3 − (t − 1)²/2; on
    // [1.3, 2] x' = −0.3: x(2) = 0.3 − 0.045 − 0.21 = 0.045. Tolerance 1e-9 (the jump at
    // 0.3 read back at 1.3 is a breakpoint that `input_jump` schedules).
    let mut p = DelayedLag {
        u: 1.0,
        delays: [1.0],
    };
    let opts = Options::with_tolerances(1e-10, 1e-12);
    let mut s = DdeSolver::new(&p, 0.0, opts).unwrap();
    s.integrate(&p, 0.3, &[], &mut NoObserver).unwrap();
    p.u = 0.0;
    s.input_jump();
    assert!(s.breakpoints().iter().any(|&b| (b - 1.3).abs() < 1e-12));
    s.integrate(&p, 2.0, &[], &mut NoObserver).unwrap();
    assert!((s.state()[0] - 0.045).abs() < 1e-9, "{}", s.state()[0]);
}
