//! Period-doubling (flip) points of periodic orbits continued in two parameters (p1, p2),
//! for ODEs and constant-delay DDEs, on the collocation discretisation of
//! [`PeriodicOrbitSystem`] and the shared core of the extended cycle systems.
//!
//! The equations are documented on [`PeriodDoublingCurveSystem`].

use crate::cycle_curve::{CycleCurve, ModeScratch, Out, RealMode, inverse_iteration, uniform_mesh};
use crate::engine::ContinuationSystem;
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::periodic::PeriodicOrbitSystem;
use crate::problem::Problem;
use crate::stability::{SpecialKind, Stability};
use crate::{BranchPoint, CollocationOptions};
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
#[derive(Debug)]
pub struct PeriodDoublingCurveSystem<'a, P: Problem> {
    base: CycleCurve<'a, P>,
    options: PeriodDoublingOptions,
    /// the normalised mode of the last accepted point (length n·L·m)
    v_ref: Vec<f64>,
    s: ModeScratch,
}

impl<'a, P: Problem> PeriodDoublingCurveSystem<'a, P> {
    /// New system on the mesh `mesh` (0 = s_0 < … < s_L = 1); `params`: all parameters,
    /// `free` = (p1, p2) the primary and secondary free parameter. Set the references with
    /// [`ContinuationSystem::accept`] before correcting a guess (or use
    /// [`PeriodDoublingCurveSystem::from_period_doubling`]).
    pub fn with_mesh(
        problem: &'a P,
        params: Vec<f64>,
        free: (usize, usize),
        mesh: Vec<f64>,
        collocation: CollocationOptions,
        options: PeriodDoublingOptions,
    ) -> Result<Self> {
        Ok(Self::on(
            CycleCurve::new(problem, params, free, mesh, collocation)?,
            options,
        ))
    }

    /// New system on a uniform mesh of `collocation.intervals` intervals.
    pub fn new(
        problem: &'a P,
        params: Vec<f64>,
        free: (usize, usize),
        collocation: CollocationOptions,
        options: PeriodDoublingOptions,
    ) -> Result<Self> {
        let mesh = uniform_mesh(collocation.intervals);
        Self::with_mesh(problem, params, free, mesh, collocation, options)
    }

    fn on(base: CycleCurve<'a, P>, options: PeriodDoublingOptions) -> Self {
        let problem = base.po.problem;
        let s = ModeScratch::new(problem.dim(), problem.n_delays());
        let v_ref = vec![0.0; base.np()];
        Self {
            base,
            options,
            v_ref,
            s,
        }
    }

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
        let base = CycleCurve::from_branch_point(po, point, ip2, "from_period_doubling")?;
        let mut sys = Self::on(base, options);
        let np = sys.np();
        let mut guess = point.u.clone();
        guess.push(sys.base.po.params[ip2]);
        // a fixed, generic start (deterministic), then inverse iteration
        guess.extend((0..np).map(|i| 1.0 + 0.5 * ((i as f64) * 0.754_877_666_246_692_7).fract()));
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
        let mut direction = vec![0.0; guess.len()];
        direction[np + 2] = 1.0;
        Ok((sys, guess, direction))
    }

    /// n·L·m: number of profile unknowns
    fn np(&self) -> usize {
        self.base.np()
    }

    /// ⟨a, b⟩ = Σ a_i b_i /(L·m) on profile-sized vectors
    fn mean_dot(&self, a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>() / self.base.po.n_nodes() as f64
    }

    /// scale the mode of u to ⟨v, v⟩ = 1
    fn normalise(&self, u: &mut [f64]) -> Result<()> {
        let np = self.np();
        let v = &u[np + 3..];
        let norm = self.mean_dot(v, v).sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(Error::InvalidInput(
                "period doubling: the mode is zero or not finite".into(),
            ));
        }
        u[np + 3..].iter_mut().for_each(|x| *x /= norm);
        Ok(())
    }

    /// the periodic-orbit unknowns [x, T, p1] of the point's cycle
    pub fn orbit<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        self.base.orbit(u)
    }

    /// the antiperiodic Floquet mode v of (PD1): node values on [0, 1) like the profile
    /// (v(s + 1) = −v(s))
    pub fn mode<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[self.np() + 3..]
    }

    /// the period T of the cycle [time units] (the doubled orbit born here has period ≈ 2T)
    pub fn period(&self, u: &[f64]) -> f64 {
        u[self.np()]
    }

    /// all parameters at the point u
    pub fn parameters(&self, u: &[f64]) -> Vec<f64> {
        self.base.parameters(u)
    }

    /// amplitude of the cycle: half the peak-to-peak range of the node values, largest
    /// over the components [state units]
    pub fn amplitude(&self, u: &[f64]) -> f64 {
        self.base.po.amplitude(u)
    }

    /// The periodic-orbit system of the cycle at the parameters of u (free parameter p1,
    /// same mesh, phase reference set to the cycle).
    pub fn periodic_system(&self, u: &[f64]) -> Result<PeriodicOrbitSystem<'a, P>> {
        self.base.periodic_system(u)
    }

    /// How the bordered Newton systems are solved (default: that of the cycle system the
    /// curve was started from, [`crate::LinearSolver::Auto`] unless set there).
    pub fn set_linear_solver(&mut self, solver: crate::LinearSolver) {
        self.base.po.set_linear_solver(solver);
    }

    /// Floquet multipliers of the cycle at u (sorted by decreasing modulus; one of them is
    /// −1, one the trivial multiplier 1)
    pub fn multipliers(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        self.base.multipliers(u)
    }
}

impl<P: Problem> ContinuationSystem for PeriodDoublingCurveSystem<'_, P> {
    fn n_unknowns(&self) -> usize {
        2 * self.np() + 3
    }
    fn parameter_index(&self) -> usize {
        self.np() + 1
    }
    fn secondary_parameter_index(&self) -> Option<usize> {
        Some(self.np() + 2)
    }

    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        let np = self.np();
        self.base.sync(u);
        let (r_cycle, r_mode) = r.split_at_mut(np + 1);
        self.base.po.residual(&u[..np + 2], r_cycle)?;
        self.base.real_mode_rows(
            u,
            RealMode::Antiperiodic,
            &mut self.s,
            Out::Residual(&mut r_mode[..np]),
        )?;
        r_mode[np] = self.mean_dot(&self.v_ref, &u[np + 3..]) - 1.0;
        if r_mode.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                parameter: u[np + 1],
            })
        }
    }

    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let np = self.np();
        self.base.sync(u);
        self.base.po.jacobian(&u[..np + 2], entries)?;
        let start = entries.len();
        self.base.real_mode_rows(
            u,
            RealMode::Antiperiodic,
            &mut self.s,
            Out::Jacobian(entries),
        )?;
        let w = 1.0 / self.base.po.n_nodes() as f64;
        for (g, &v) in self.v_ref.iter().enumerate() {
            entries.push(Entry::new(2 * np + 1, np + 3 + g, v * w));
        }
        if entries[start..].iter().all(|e| e.val.is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                parameter: u[np + 1],
            })
        }
    }

    /// the cycle x and the mode v interleaved node by node, the border (T, p1, p2) last
    fn column_order(&self) -> Option<Vec<usize>> {
        let np = self.np();
        Some(
            self.base
                .interleaved_order(&[np + 3], &[np, np + 1, np + 2]),
        )
    }

    /// the cycle's weights ([`PeriodicOrbitSystem`]), p2 weighted like p1, the mode not
    /// at all
    fn weights(&self) -> Vec<f64> {
        self.base.weights(2 * self.np() + 3)
    }

    /// the cycle and the mode on the mesh (see [`crate::LinearSolver::Krylov`])
    fn mesh_structure(&self) -> Option<crate::linalg::MeshStructure> {
        let np = self.np();
        self.base.po.structure(vec![0, np + 3], vec![0, np + 1])
    }

    fn accept(&mut self, u: &[f64]) {
        let np = self.np();
        self.base.sync(u);
        self.base.po.set_reference(&u[..np + 2]);
        let v = &u[np + 3..];
        let norm = self.mean_dot(v, v).sqrt();
        if norm > 0.0 && norm.is_finite() {
            self.v_ref
                .iter_mut()
                .zip(v)
                .for_each(|(r, x)| *r = x / norm);
        }
    }

    /// the cycle's multipliers with the critical −1 removed, so that a change of the number
    /// outside the unit circle marks a codimension-two point of the curve
    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        if !self.options.multipliers {
            return Ok(None);
        }
        let mut mu = self.multipliers(u)?;
        let minus_one = Complex64::new(-1.0, 0.0);
        if let Some(i) = mu
            .iter()
            .enumerate()
            .min_by(|a, b| {
                (a.1 - minus_one)
                    .norm()
                    .total_cmp(&(b.1 - minus_one).norm())
            })
            .map(|(i, _)| i)
        {
            mu.remove(i);
        }
        Ok(Some(Stability::from_multipliers(mu)))
    }

    fn classify(&self, a: &Stability, b: &Stability) -> Option<SpecialKind> {
        Stability::multiplier_crossing(a, b)
    }
}
