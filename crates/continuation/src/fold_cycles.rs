//! Folds of periodic orbits (limit points of cycles) continued in two parameters (p1, p2),
//! for ODEs and constant-delay DDEs, on the collocation discretisation of
//! [`PeriodicOrbitSystem`].
//!
//! The equations, special points and an example are documented on [`FoldOfCyclesSystem`].

use crate::BranchPoint;
use crate::cycle_curve::{
    CycleCurve, CycleCurveSystem, CycleExtension, CycleRows, ModeScratch, Out, RealMode,
    extend_checked, set_reference_mode,
};
use crate::engine::{Branch, Continuation, ContinuationSystem, Stop};
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::periodic::PeriodicOrbitSystem;
use crate::problem::Problem;
use crate::stability::{Location, SpecialKind, SpecialPoint, Stability};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Options of fold-of-cycles curves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoldCyclesOptions {
    /// [`FoldOfCyclesSystem::extend_curve`] stops when the cycle's amplitude (half the
    /// peak-to-peak range of the profile's node values, largest over the components) falls
    /// below this: the curve approaches a generalised Hopf point [state units]
    pub min_amplitude: f64,
    /// compute the Floquet multipliers of the fold's cycle at every point (stored as the
    /// point's stability); costs one monodromy computation per point
    pub multipliers: bool,
}

impl Default for FoldCyclesOptions {
    fn default() -> Self {
        Self {
            min_amplitude: 1e-2,
            multipliers: true,
        }
    }
}

/// Where a fold-of-cycles curve ends on a Hopf curve (a generalised Hopf / Bautin point),
/// extrapolated from the last two points to zero amplitude (linearly in amplitude²).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HopfEnd {
    /// index in the branch of the last computed point (marked `CriticalityChange`)
    pub index: usize,
    /// amplitude of the cycle at that point [state units]
    pub amplitude: f64,
    /// estimated (p1, p2) of the generalised Hopf point
    pub parameters: [f64; 2],
    /// estimated period 2π/ω of the vanishing cycle [time units]
    pub period: f64,
    /// estimated Hopf frequency ω [rad per time unit]
    pub omega: f64,
}

/// Why [`FoldOfCyclesSystem::extend_curve`] stopped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum FoldCyclesStop {
    /// the continuation engine stopped (points computed, parameter range, step underflow)
    Continuation(Stop),
    /// the cycle shrank below `min_amplitude`: the curve ends at a generalised Hopf point
    HopfEnd(HopfEnd),
}

/// Fold-of-cycles (limit point of cycles) defining system in two free parameters, as a
/// [`ContinuationSystem`].
///
/// A [`CycleCurveSystem`]: its constructors and the getters of the cycle are those of every
/// two-parameter cycle curve; the null vector, the start at a fold and the end at a
/// generalised Hopf point are its own.
///
/// # Defining system (the doubled / extended system)
///
/// With the collocation residual R(x, T; p) (n·L·m equations, x the profile, T the period)
/// and the phase condition φ·x + φ0 = 0, a cycle is a fold (limit point) in p1 when the
/// Jacobian A = ∂(R, phase)/∂(x, T) is singular. The unknowns are
///
/// u = [x, T, p1, p2, v, v_T]   (2·n·L·m + 4 unknowns)
///
/// and the equations (2·n·L·m + 3)
///
/// - R(x, T; p1, p2) = 0, φ·x + φ0 = 0 (the cycle),
/// - ∂R/∂(x, T) · (v, v_T) = 0, φ·v = 0 (the null vector of A: the direction in which the
///   cycle family folds back),
/// - ⟨v_ref, (v, v_T)⟩ = 1 (normalisation against the null vector of the last accepted
///   point; ⟨a, b⟩ = Σ a_i b_i /(L·m) + a_T b_T).
///
/// The Jacobian is exact: it contains the second derivatives of R along (v, v_T), built from
/// [`Problem::second_derivative`], [`Problem::jacobian_dp`] and, for delays, the first and
/// second s-derivatives of the profile at the delayed points (x(s − τ(p)/T) moves with T and
/// with a delay that depends on p1 or p2, see [`Problem::delay_dp`]). It is assembled sparse
/// (faer sparse LU in the engine). Cost of a Newton step: assembly and residual are O(L);
/// the sparse LU is O(L) for ODEs, but for DDEs the periodic wrap-around together with the
/// delayed coupling (reaching back τ/T of the period, i.e. ∝ L mesh intervals) fills the
/// factors, as it does for a single cycle. Measured (benches/fold_cycles.rs, release, 2
/// cores): on a 4-dimensional DDE with τ/T ≈ 0.08, 7.5, 27, 178 and 1230 ms for L = 20, 40,
/// 80 and 160 (≈ L^2.7) with the engine's supernodal factors; a simplicial LU in the band
/// order of [`ContinuationSystem::column_order`] was 15–40 % faster at this small τ/T, but
/// 3× slower on the delayed closed loop of the trailer at τ/T ≈ 0.2.
///
/// # Special points
///
/// - [`SpecialKind::CuspOfCycles`]: two folds of cycles meet; the curve has a cusp in the
///   (p1, p2) plane, i.e. *both* dp1/ds and dp2/ds change sign. The engine locates turning
///   points in p1 (labelled [`SpecialKind::Fold`]); [`FoldOfCyclesSystem::extend_curve`]
///   relabels one as a cusp of cycles when p2 turns in the same step. A turning point in p1
///   alone keeps the label `Fold` (the curve is only vertical in the (p1, p2) plane there).
/// - [`SpecialKind::CriticalityChange`]: the fold-of-cycles curve ends on a Hopf curve at a
///   generalised Hopf (Bautin) point where the cycle shrinks to the equilibrium (amplitude
///   → 0, period → 2π/ω). [`FoldOfCyclesSystem::extend_curve`] stops when the amplitude falls
///   below [`FoldCyclesOptions::min_amplitude`], marks the last point with a *detected*
///   `CriticalityChange` and returns [`FoldCyclesStop::HopfEnd`], whose [`HopfEnd`] holds
///   the end point extrapolated to zero amplitude (linearly in amplitude², exact for the
///   normal form's leading order): p1, p2, the period 2π/ω and ω.
///
/// At every point the cycle, its period and its Floquet multipliers are available:
/// [`FoldOfCyclesSystem::orbit`], [`FoldOfCyclesSystem::period`],
/// [`FoldOfCyclesSystem::periodic_system`] (a [`PeriodicOrbitSystem`] at the point's
/// parameters) and, with [`FoldCyclesOptions::multipliers`], the multipliers stored as the
/// point's `stability` (one of them is the trivial multiplier 1, another the fold's
/// multiplier, also ≈ 1).
///
/// # Example: folds of cycles of the Bautin normal form
///
/// z' = (μ1 + i) z + μ2 |z|² z − |z|⁴ z has cycles of radius r with μ1 + μ2 r² − r⁴ = 0;
/// their folds lie on μ1 = −μ2²/4 and end at the Bautin point (0, 0).
///
/// ```
/// use continuation::*;
///
/// struct Bautin;
/// impl Problem for Bautin {
///     fn dim(&self) -> usize { 2 }
///     fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
///         let r2 = x[0] * x[0] + x[1] * x[1];
///         let g = p[0] + p[1] * r2 - r2 * r2;
///         f[0] = g * x[0] - x[1];
///         f[1] = x[0] + g * x[1];
///     }
///     fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) { fd_jacobian(self, x, p, j) }
///     fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
///         let r2 = x[0] * x[0] + x[1] * x[1];
///         let s = if ip == 0 { 1.0 } else { r2 };
///         out[0] = s * x[0];
///         out[1] = s * x[1];
///     }
///     fn second_derivative(&self, x: &[f64], p: &[f64], a: &[f64], b: &[f64], out: &mut [f64]) -> Result<()> {
///         fd_second_derivative(self, x, p, a, b, out) // finite differences, chosen explicitly
///     }
///     fn jacobian_dp(&self, x: &[f64], p: &[f64], ip: usize, a: &[f64], out: &mut [f64]) -> Result<()> {
///         fd_jacobian_dp(self, x, p, ip, a, out)
///     }
/// }
///
/// # fn main() -> Result<()> {
/// let tp = 2.0 * std::f64::consts::PI;
/// let colloc = CollocationOptions { intervals: 10, ..Default::default() };
/// // the cycle r = 1 at μ1 = 0, μ2 = 1, continued down in μ1 to its fold at μ1 = −1/4
/// let mut po = PeriodicOrbitSystem::new(&Bautin, vec![0.0, 1.0], 0, colloc)?;
/// let u0 = po.unknowns_from(|s| vec![(tp * s).cos(), (tp * s).sin()], tp, 0.0);
/// po.set_reference(&u0);
/// let mut down = vec![0.0; u0.len()];
/// down[po.parameter_index()] = -1.0;
/// let cont = Continuation::new(ContinuationOptions { initial_step: 0.05, max_step: 0.1, ..Default::default() });
/// let mut cycles = cont.start(&mut po, &u0, &down)?;
/// cont.extend(&mut po, &mut cycles, 20)?;
/// let (i, _) = cycles.first(SpecialKind::Fold).expect("fold of cycles");
///
/// // the fold continued in (μ1, μ2) towards small μ2: it ends at the Bautin point
/// let options = FoldCyclesOptions { min_amplitude: 0.03, ..Default::default() };
/// let (mut fold, guess, dir) = FoldOfCyclesSystem::from_fold(&po, &cycles.points[i], 1, options)?;
/// let back: Vec<f64> = dir.iter().map(|d| -d).collect();
/// let mut curve = cont.start(&mut fold, &guess, &back)?;
/// let stop = fold.extend_curve(&cont, &mut curve, 300)?;
/// for pt in &curve.points {
///     let (mu1, mu2) = (pt.parameter, pt.secondary_parameter.unwrap());
///     assert!((mu1 + mu2 * mu2 / 4.0).abs() < 1e-6);
/// }
/// let FoldCyclesStop::HopfEnd(end) = stop else { panic!("{stop:?}") };
/// assert!(end.parameters[0].abs() < 1e-4 && end.parameters[1].abs() < 1e-3);
/// assert!((end.omega - 1.0).abs() < 1e-3);
/// # Ok(())
/// # }
/// ```
pub type FoldOfCyclesSystem<'a, P> = CycleCurveSystem<'a, P, FoldExtension>;

/// The part of a [`FoldOfCyclesSystem`] that is its own: the options and the null vector of
/// the last accepted point.
#[derive(Debug)]
pub struct FoldExtension {
    options: FoldCyclesOptions,
    /// normalised null vector of the last accepted point (length n·L·m + 1)
    v_ref: Vec<f64>,
    s: ModeScratch,
}

impl CycleExtension for FoldExtension {
    type Options = FoldCyclesOptions;

    fn new(options: FoldCyclesOptions, n: usize, delays: usize, np: usize) -> Self {
        Self {
            options,
            v_ref: vec![0.0; np + 1],
            s: ModeScratch::new(n, delays),
        }
    }
}

impl<'a, P: Problem> FoldOfCyclesSystem<'a, P> {
    /// Start from a fold of cycles `point` located on a branch of `po` (a
    /// [`SpecialKind::Fold`] point; its tangent, with zero parameter component, is the null
    /// vector). `ip2` is the second free parameter (its value taken from `po`'s parameters).
    /// Returns the system (same mesh and problem), the initial guess and the start direction
    /// +p2 for [`Continuation::start`] (negate it to go towards decreasing p2).
    pub fn from_fold(
        po: &PeriodicOrbitSystem<'a, P>,
        point: &BranchPoint,
        ip2: usize,
        options: FoldCyclesOptions,
    ) -> Result<(Self, Vec<f64>, Vec<f64>)> {
        let np = po.period_index();
        if point.tangent.len() != np + 2 {
            return Err(Error::InvalidInput(format!(
                "from_fold: the point's tangent has {} entries, the periodic-orbit system {}",
                point.tangent.len(),
                np + 2
            )));
        }
        let mut sys = Self::at_branch_point(po, point, ip2, options, "from_fold")?;
        let p2 = sys.base.po.params[ip2];
        let guess = sys.unknowns(&point.u, p2, &point.tangent[..=np])?;
        let direction = sys.base.p2_direction(guess.len());
        sys.accept(&guess);
        Ok((sys, guess, direction))
    }

    /// Unknowns [x, T, p1, p2, v, v_T] from periodic-orbit unknowns `orbit` = [x, T, p1], the
    /// second parameter and a null-vector guess (v, v_T) (normalised here).
    pub fn unknowns(&self, orbit: &[f64], p2: f64, null_vector: &[f64]) -> Result<Vec<f64>> {
        let np = self.np();
        if orbit.len() != np + 2 || null_vector.len() != np + 1 {
            return Err(Error::InvalidInput(format!(
                "unknowns: orbit has {} (expected {}) and null vector {} (expected {}) entries",
                orbit.len(),
                np + 2,
                null_vector.len(),
                np + 1
            )));
        }
        let norm = self.inner(null_vector, null_vector).sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(Error::InvalidInput(
                "unknowns: the null vector is zero or not finite".into(),
            ));
        }
        let mut u = orbit.to_vec();
        u.push(p2);
        u.extend(null_vector.iter().map(|v| v / norm));
        Ok(u)
    }

    /// ⟨a, b⟩ = Σ a_i b_i /(L·m) + a_T b_T on (profile, period) vectors
    fn inner(&self, a: &[f64], b: &[f64]) -> f64 {
        let np = self.np();
        self.base.mean_dot(&a[..np], &b[..np]) + a[np] * b[np]
    }

    /// The point u with the cycle and the null vector shifted in phase so that profile
    /// component `component` of the cycle is largest at s = 0 (see
    /// [`PeriodicOrbitSystem::canonical_phase`]). Correcting again from it, after
    /// [`ContinuationSystem::accept`], makes folds located from guesses of different phase
    /// solutions of the same discretised system.
    pub fn canonical(&self, u: &[f64], component: usize) -> Vec<f64> {
        let np = self.np();
        let po = &self.base.po;
        let shift = po.canonical_phase(self.orbit(u), component);
        let mut out = po.shifted(self.orbit(u), shift);
        out.push(u[np + 2]);
        out.extend(po.shifted(self.null_vector(u), shift));
        out
    }

    /// the null vector (v, v_T) of the linearised periodic problem at the fold
    pub fn null_vector<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[self.np() + 3..]
    }

    /// The point u carried to a mesh of `intervals` intervals adapted to its cycle
    /// ([`PeriodicOrbitSystem::adapted_mesh`]: the error density equidistributed, the
    /// cycle's kinks on mesh points): the system on that mesh (same problem, parameters,
    /// options and linear solver) and u interpolated there (cycle and null vector, null
    /// vector renormalised), with the references set. Correct the returned guess with p2
    /// fixed to get the fold on the adapted mesh; a second round from that fold puts the
    /// mesh points on its own kinks (they move by the first round's correction, ≲ 1e-4 of
    /// the period).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] if the adapted mesh is degenerate.
    pub fn adapted(&self, u: &[f64], intervals: usize) -> Result<(Self, Vec<f64>)> {
        let np = self.np();
        let po = &self.base.po;
        let mut at = self.periodic_system(u)?;
        let mesh = at.adapted_mesh(self.orbit(u), intervals);
        let collocation = po.options.clone();
        let mut base = CycleCurve::new(
            po.problem,
            self.parameters(u),
            (po.ip, self.base.ip2),
            mesh,
            collocation,
        )?;
        base.po.set_linear_solver(po.linear_solver());
        let mut sys = Self::on(base, self.ext.options.clone());
        let target = &sys.base.po;
        let orbit = po.remesh(self.orbit(u), target);
        // the null vector (v, v_T) as a profile with a dummy parameter entry
        let mut null = self.null_vector(u).to_vec();
        null.push(0.0);
        let mut null = po.remesh(&null, target);
        null.pop();
        let guess = sys.unknowns(&orbit, u[np + 2], &null)?;
        sys.accept(&guess);
        Ok((sys, guess))
    }

    /// Continue the fold-of-cycles curve by up to `max_points` points (like
    /// [`Continuation::extend`]), relabelling turning points in p1 where p2 turns too as
    /// [`SpecialKind::CuspOfCycles`] and stopping at a generalised Hopf point (see the type's
    /// documentation).
    pub fn extend_curve(
        &mut self,
        cont: &Continuation,
        branch: &mut Branch,
        max_points: usize,
    ) -> Result<FoldCyclesStop> {
        let stop = extend_checked(self, cont, branch, max_points, |sys, branch, before| {
            sys.label_cusps(branch, before);
            let last = &branch.points[branch.points.len() - 1];
            Ok((sys.amplitude(&last.u) < sys.ext.options.min_amplitude)
                .then(|| sys.mark_hopf_end(branch)))
        })?;
        Ok(match stop {
            Ok(stop) => FoldCyclesStop::Continuation(stop),
            Err(end) => FoldCyclesStop::HopfEnd(end),
        })
    }

    /// turning points in p1 (points from index `from` on) where p2 turns in the same step
    /// are cusps of cycles
    fn label_cusps(&self, branch: &mut Branch, from: usize) {
        let i2 = self.np() + 2;
        for j in from.max(1)..branch.points.len() {
            let Some(sp) = branch.points[j].special.as_ref() else {
                continue;
            };
            if sp.kind != SpecialKind::Fold {
                continue;
            }
            let after = if sp.location == Location::Located {
                j + 1
            } else {
                j
            };
            let Some(b) = branch.points.get(after) else {
                continue;
            };
            if branch.points[j - 1].tangent[i2] * b.tangent[i2] < 0.0
                && let Some(sp) = branch.points[j].special.as_mut()
            {
                sp.kind = SpecialKind::CuspOfCycles;
            }
        }
    }

    /// mark the last point as the (detected) end at a generalised Hopf point
    fn mark_hopf_end(&self, branch: &mut Branch) -> HopfEnd {
        let np = self.np();
        let last = branch.points.len() - 1;
        let (est, amplitude) = self
            .base
            .extrapolate_to_zero_amplitude(branch, |p| [p.u[np + 1], p.u[np + 2], p.u[np]]);
        let omega = 2.0 * std::f64::consts::PI / est[2];
        let end = HopfEnd {
            index: last,
            amplitude,
            parameters: [est[0], est[1]],
            period: est[2],
            omega,
        };
        branch.points[last].special = Some(SpecialPoint {
            kind: SpecialKind::CriticalityChange,
            location: Location::Detected,
            parameter: est[0],
            critical: Some(Complex64::new(0.0, omega)),
            transversality: None,
        });
        end
    }
}

impl CycleRows for FoldExtension {
    /// u = [x, T, p1, p2, v, v_T]
    fn n_unknowns(np: usize) -> usize {
        2 * np + 4
    }

    /// x and v interleaved node by node (each node's state of the cycle, then of the null
    /// vector), the borders (T, v_T, p1, p2) last: the doubled Jacobian [[A, 0], [B(v), A]]
    /// is then banded like A, and the fill of simplicial factors stays in that band (large
    /// systems are factorised with supernodes in COLAMD order instead, see the engine)
    fn column_blocks(np: usize) -> (Vec<usize>, Vec<usize>) {
        (vec![np + 3], vec![np, 2 * np + 3, np + 1, np + 2])
    }

    /// ∂R/∂(x, T)·(v, v_T), φ·v and the normalisation ⟨v_ref, (v, v_T)⟩ − 1
    fn residual_rows<P: Problem>(
        sys: &mut FoldOfCyclesSystem<'_, P>,
        u: &[f64],
        r_null: &mut [f64],
    ) -> Result<()> {
        let np = sys.np();
        sys.base.real_mode_rows(
            u,
            RealMode::Periodic,
            &mut sys.ext.s,
            Out::Residual(&mut r_null[..np]),
        )?;
        let v = &u[np + 3..];
        r_null[np] = sys
            .base
            .po
            .phase_row
            .iter()
            .zip(v)
            .map(|(a, b)| a * b)
            .sum();
        r_null[np + 1] = sys.inner(&sys.ext.v_ref, v) - 1.0;
        Ok(())
    }

    /// the null-vector rows contain A itself: the cycle's (x, T) columns, shifted
    fn repeat_cycle_entries(np: usize, entries: &mut Vec<Entry>, cycle: usize) {
        for idx in cycle..entries.len() {
            let (row, col, val) = (entries[idx].row, entries[idx].col, entries[idx].val);
            if col <= np {
                entries.push(Entry::new(row + np + 1, col + np + 3, val));
            }
        }
    }

    fn jacobian_rows<P: Problem>(
        sys: &mut FoldOfCyclesSystem<'_, P>,
        u: &[f64],
        entries: &mut Vec<Entry>,
    ) -> Result<()> {
        let np = sys.np();
        sys.base.real_mode_rows(
            u,
            RealMode::Periodic,
            &mut sys.ext.s,
            Out::Jacobian(entries),
        )?;
        let w = 1.0 / sys.base.po.n_nodes() as f64;
        for (i, &v) in sys.ext.v_ref[..np].iter().enumerate() {
            entries.push(Entry::new(2 * np + 2, np + 3 + i, v * w));
        }
        entries.push(Entry::new(2 * np + 2, 2 * np + 3, sys.ext.v_ref[np]));
        Ok(())
    }

    fn set_reference<P: Problem>(sys: &mut FoldOfCyclesSystem<'_, P>, u: &[f64]) {
        let np = sys.np();
        let v = &u[np + 3..];
        let norm = sys.inner(v, v).sqrt();
        set_reference_mode(&mut sys.ext.v_ref, v, norm);
    }

    /// all the cycle's multipliers (the fold's own, ≈ 1, among them)
    fn stability<P: Problem>(
        sys: &mut FoldOfCyclesSystem<'_, P>,
        u: &[f64],
    ) -> Result<Option<Stability>> {
        sys.stability_without(u, sys.ext.options.multipliers, &[])
    }
}
