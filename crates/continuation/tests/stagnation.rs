//! A corrector that stagnates at rounding level is converged, not failed: Newton on the
//! triple root of x³ = 0 (G(x, p) = x³, continued in p) converges only linearly (each
//! update −x/3), so its update stays above the tolerance while the residual x³ reaches
//! rounding level. The corrector accepts its best iterate and records the stagnation.
//!
//! Reference: the exact root x = 0 — the accepted |x| is at most the cube root of the
//! recorded residual (exactly, up to rounding: the residual is |x|³) — and the recorded
//! numbers (residual ≤ the threshold 1e-11·(1 + |p|), update above the Newton tolerance).
//! With the acceptance turned off (`stagnation_residual = 0`) the same correction is the
//! divergence error with its numbers, as before.

use continuation::{Continuation, ContinuationOptions, ContinuationSystem, Entry, Error};

/// G(x, p) = x³; unknowns [x, p].
struct TripleRoot;

impl ContinuationSystem for TripleRoot {
    fn n_unknowns(&self) -> usize {
        2
    }
    fn parameter_index(&self) -> usize {
        1
    }
    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> continuation::Result<()> {
        r[0] = u[0].powi(3);
        Ok(())
    }
    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> continuation::Result<()> {
        entries.push(Entry::new(0, 0, 3.0 * u[0] * u[0]));
        Ok(())
    }
    fn weights(&self) -> Vec<f64> {
        vec![1.0, 1.0]
    }
}

#[test]
fn a_corrector_stagnating_at_rounding_level_accepts_and_records_it() {
    let cont = Continuation::new(ContinuationOptions {
        max_newton_iterations: 40,
        ..Default::default()
    });
    let b = cont
        .start(&mut TripleRoot, &[1e-2, 0.0], &[0.0, 1.0])
        .expect("accepted at rounding level");
    let p = &b.points[0];
    let s = p.stagnation.expect("the stagnation is recorded");
    assert!(s.residual <= 1e-11, "residual {:e}", s.residual);
    assert!(
        s.update > 1e-10,
        "update {:e} above the tolerance",
        s.update
    );
    // |x|³ is the residual: the accepted point is within its cube root of the root x = 0
    assert!(
        p.u[0].abs() <= s.residual.cbrt() * (1.0 + 1e-12),
        "x = {:e}",
        p.u[0]
    );
    assert_eq!(p.parameter, 0.0);

    let strict = Continuation::new(ContinuationOptions {
        max_newton_iterations: 40,
        stagnation_residual: 0.0,
        ..Default::default()
    });
    match strict.start(&mut TripleRoot, &[1e-2, 0.0], &[0.0, 1.0]) {
        Err(Error::NewtonDivergence {
            residual, update, ..
        }) => {
            assert!(residual <= 1e-11 && update > 1e-10);
        }
        other => panic!("expected the divergence error, got {other:?}"),
    }
}
