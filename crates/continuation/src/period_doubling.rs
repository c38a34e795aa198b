//! Period-doubling (flip) points of periodic orbits continued in two parameters (p1, p2),
//! for ODEs and constant-delay DDEs, on the collocation discretisation of
//! [`PeriodicOrbitSystem`] and the shared core of the extended cycle systems.
//!
//! The equations are documented on [`PeriodDoublingCurveSystem`].

use crate::BranchPoint;
use crate::cycle_curve::{
    CycleCurveSystem, CycleExtension, CycleRows, ModeScratch, Out, RealMode, generic_start,
    inverse_iteration, set_reference_mode,
};
use crate::engine::ContinuationSystem;
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::periodic::PeriodicOrbitSystem;
use crate::problem::Problem;
use crate::stability::{SpecialKind, Stability};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Options of period-doubling curves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PeriodDoublingOptions {
    /// compute the Floquet multipliers of the cycle at every point (stored as the point's
    /// stability; one of them is the critical −1); costs one monodromy computation per point
    pub multipliers: bool,
}

impl Default for PeriodDoublingOptions {
    fn default() -> Self {
        Self { multipliers: true }
    }
}

/// Period-doubling (flip) points of cycles in two free parameters, as a
/// [`ContinuationSystem`].
///
/// A [`CycleCurveSystem`]: its constructors and the getters of the cycle are those of every
/// two-parameter cycle curve (the doubled orbit born at a point has about twice the
/// [`PeriodDoublingCurveSystem::period`]); the mode and the start are its own.
///
/// # Defining system (the doubled system with the antiperiodic mode)
///
/// A cycle x(s) of period T (scaled time s = t/T) has the Floquet multiplier −1 when the
/// variational equation
///
/// (PD1)  v'(s) = T Σ_j J_j(s) v(s − τ_j/T),   J_j = ∂f/∂x(t − τ_j) along the cycle,
///
/// has an antiperiodic solution, v(s + 1) = −v(s) (the mode of the doubled orbit). v is
/// stored by its node values on [0, 1) of the cycle's mesh; the node at s = 1 is −v(0) and
/// a delayed value v(s − τ/T) read w periods back is (−1)^w times the value read off the
/// mesh. The unknowns are u = [x, T, p1, p2, v] (2·n·L·m + 3), the equations
/// (2·n·L·m + 2):
///
/// - (PD2) the cycle: collocation residual R(x, T; p1, p2) = 0 and the phase condition;
/// - (PD1) at the collocation points;
/// - (PD3) ⟨v_ref, v⟩ = 1 (⟨a, b⟩ = Σ a_i b_i /(L·m); v_ref the mode of the last accepted
///   point, normalised).
///
/// No phase condition on v is needed: the antiperiodic problem has no trivial solution
/// (the derivative of the cycle is periodic). The Jacobian is exact (second derivatives
/// along the mode from [`Problem::second_derivative`], [`Problem::jacobian_dp`], the motion
/// of the delayed points with T and with delays that depend on p1 or p2), built by the
/// same code as the fold-of-cycles null-vector rows with the antiperiodic signs.
///
/// Start at a [`SpecialKind::PeriodDoubling`] point of a cycle branch with
/// [`PeriodDoublingCurveSystem::from_period_doubling`] (the mode by inverse iteration on
/// the (PD1) block).
pub type PeriodDoublingCurveSystem<'a, P> = CycleCurveSystem<'a, P, PeriodDoublingExtension>;

/// The part of a [`PeriodDoublingCurveSystem`] that is its own: the options and the mode of
/// the last accepted point.
#[derive(Debug)]
pub struct PeriodDoublingExtension {
    options: PeriodDoublingOptions,
    /// the normalised mode of the last accepted point (length n·L·m)
    v_ref: Vec<f64>,
    s: ModeScratch,
}

impl CycleExtension for PeriodDoublingExtension {
    type Options = PeriodDoublingOptions;

    fn new(options: PeriodDoublingOptions, n: usize, delays: usize, np: usize) -> Self {
        Self {
            options,
            v_ref: vec![0.0; np],
            s: ModeScratch::new(n, delays),
        }
    }
}

impl<'a, P: Problem> PeriodDoublingCurveSystem<'a, P> {
    /// Start from a period-doubling `point` of a branch of `po` (located or detected: the
    /// mode is found by inverse iteration on the (PD1) block at the point's cycle). `ip2`
    /// is the second free parameter (its value taken from `po`'s parameters). Returns the
    /// system (same mesh and problem), the initial guess and the direction +p2 for
    /// [`crate::Continuation::start`], whose corrector then keeps p2 fixed: its first point
    /// is the period-doubling point of the branch.
    pub fn from_period_doubling(
        po: &PeriodicOrbitSystem<'a, P>,
        point: &BranchPoint,
        ip2: usize,
        options: PeriodDoublingOptions,
    ) -> Result<(Self, Vec<f64>, Vec<f64>)> {
        let mut sys = Self::at_branch_point(po, point, ip2, options, "from_period_doubling")?;
        let np = sys.np();
        let mut guess = point.u.clone();
        guess.push(sys.base.po.params[ip2]);
        // a fixed, generic start, then inverse iteration
        guess.extend((0..np).map(generic_start));
        let mut entries = Vec::new();
        sys.jacobian(&guess, &mut entries)?;
        let mut z = guess[np + 3..].to_vec();
        inverse_iteration(
            entries,
            (np + 1, np + 3, np),
            &mut z,
            "period-doubling mode",
        )?;
        guess[np + 3..].copy_from_slice(&z);
        sys.normalise(&mut guess)?;
        sys.accept(&guess);
        let direction = sys.base.p2_direction(guess.len());
        Ok((sys, guess, direction))
    }

    /// scale the mode of u to ⟨v, v⟩ = 1
    fn normalise(&self, u: &mut [f64]) -> Result<()> {
        let np = self.np();
        let v = &u[np + 3..];
        let norm = self.base.mean_dot(v, v).sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(Error::InvalidInput(
                "period doubling: the mode is zero or not finite".into(),
            ));
        }
        u[np + 3..].iter_mut().for_each(|x| *x /= norm);
        Ok(())
    }

    /// the antiperiodic Floquet mode v of (PD1): node values on [0, 1) like the profile
    /// (v(s + 1) = −v(s))
    pub fn mode<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[self.np() + 3..]
    }
}

impl CycleRows for PeriodDoublingExtension {
    /// u = [x, T, p1, p2, v]
    fn n_unknowns(np: usize) -> usize {
        2 * np + 3
    }

    /// the cycle x and the mode v interleaved node by node, the border (T, p1, p2) last
    fn column_blocks(np: usize) -> (Vec<usize>, Vec<usize>) {
        (vec![np + 3], vec![np, np + 1, np + 2])
    }

    /// (PD1) at the collocation points and (PD3)
    fn residual_rows<P: Problem>(
        sys: &mut PeriodDoublingCurveSystem<'_, P>,
        u: &[f64],
        r_mode: &mut [f64],
    ) -> Result<()> {
        let np = sys.np();
        sys.base.real_mode_rows(
            u,
            RealMode::Antiperiodic,
            &mut sys.ext.s,
            Out::Residual(&mut r_mode[..np]),
        )?;
        r_mode[np] = sys.base.mean_dot(&sys.ext.v_ref, &u[np + 3..]) - 1.0;
        Ok(())
    }

    fn jacobian_rows<P: Problem>(
        sys: &mut PeriodDoublingCurveSystem<'_, P>,
        u: &[f64],
        entries: &mut Vec<Entry>,
    ) -> Result<()> {
        let np = sys.np();
        sys.base.real_mode_rows(
            u,
            RealMode::Antiperiodic,
            &mut sys.ext.s,
            Out::Jacobian(entries),
        )?;
        let w = 1.0 / sys.base.po.n_nodes() as f64;
        for (g, &v) in sys.ext.v_ref.iter().enumerate() {
            entries.push(Entry::new(2 * np + 1, np + 3 + g, v * w));
        }
        Ok(())
    }

    fn set_reference<P: Problem>(sys: &mut PeriodDoublingCurveSystem<'_, P>, u: &[f64]) {
        let np = sys.np();
        let v = &u[np + 3..];
        let norm = sys.base.mean_dot(v, v).sqrt();
        set_reference_mode(&mut sys.ext.v_ref, v, norm);
    }

    /// the cycle's multipliers with the critical −1 removed, so that a change of the number
    /// outside the unit circle marks a codimension-two point of the curve
    fn stability<P: Problem>(
        sys: &mut PeriodDoublingCurveSystem<'_, P>,
        u: &[f64],
    ) -> Result<Option<Stability>> {
        let minus_one = Complex64::new(-1.0, 0.0);
        sys.stability_without(u, sys.ext.options.multipliers, &[minus_one])
    }

    fn classify(a: &Stability, b: &Stability) -> Option<SpecialKind> {
        Stability::multiplier_crossing(a, b)
    }
}
