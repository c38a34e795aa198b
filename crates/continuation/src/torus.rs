//! Torus (Neimark–Sacker) bifurcations of periodic orbits: located on cycle branches and
//! continued in two parameters (p1, p2) as torus curves, for ODEs and constant-delay DDEs,
//! on the collocation discretisation of [`PeriodicOrbitSystem`]; started either at a
//! [`SpecialKind::Torus`] point of a cycle branch or at a double-Hopf point of a Hopf curve.
//!
//! # Defining system (extended system, periodic Floquet mode)
//!
//! A cycle x(s) of period T (scaled time s = t/T) has a Floquet multiplier μ = e^{iθ} on
//! the unit circle when the variational equation y'(s) = T Σ_j J_j(s) y(s − τ_j/T),
//! J_j = ∂f/∂x(t−τ_j) along the cycle (j = 0: the current state, τ_0 = 0), has a solution
//! with y(s + 1) = e^{iθ} y(s). Writing y(s) = e^{iθs} q(s) with q 1-periodic (the form
//! DDE-Biftool's torus continuation uses), q lives on the same periodic mesh as the cycle:
//!
//! (T1)  q'(s) + iθ q(s) = T Σ_j J_j(s) e^{−iθτ_j/T} q(s − τ_j/T).
//!
//! The unknowns are u = [x, T, p1, p2, a, b, θ] (3·n·L·m + 4) with q = a + ib; the equations
//! (3·n·L·m + 3) are
//!
//! - (T2) the cycle: collocation residual R(x, T; p1, p2) = 0 and phase condition;
//! - (T1) at the collocation points, real and imaginary parts;
//! - (T3) ⟨q_ref, q⟩ = 1 (two real equations; ⟨a, b⟩ = Σ conj(a_g) b_g /(L·m) over the
//!   nodes; q_ref = the mode of the last accepted point normalised, so the length and the
//!   phase of q are fixed).
//!
//! With p2 fixed the system is square: its solution is the torus point of the cycle
//! branch in p1 ([`TorusCurveSystem::start_at_torus`]); with p2 free it is a curve.
//! The Jacobian is exact and sparse: second derivatives of f along the stacked mode Q =
//! [q(s), e^{−iθτ_j/T} q(s − τ_j/T), …] from [`Problem::second_derivative`],
//! ∂J/∂p from [`Problem::jacobian_dp`], the motion of the delayed points with T and with a
//! delay depending on p1 or p2 ([`Problem::delay_dp`]), ∂/∂θ of e^{iθ}-terms. θ and θ + 2π
//! are different solutions of (T1) (q differs by e^{−2πis}); near a double-Hopf point the
//! unreduced θ = 2πω_j/ω_i makes q constant. The reported multiplier angle φ is θ
//! reduced to \[0, π\] and the rotation number is φ/2π ∈ \[0, ½\].
//!
//! For a right-hand side with kinks ([`Problem::n_switching`]) J(s) jumps, and (T1)
//! converges only like h² unless the mesh has points at the switching times: build the
//! system with [`TorusCurveSystem::with_mesh`] on such a mesh (see
//! [`PeriodicOrbitSystem::switching_times`]), or expect the curve to differ from the
//! torus points detected on cycle branches (whose monodromy puts mesh points there) at
//! O(h²).
//!
//! # Starting
//!
//! - At a torus point of a cycle branch ([`TorusCurveSystem::from_torus`]): θ0 = arg μ of
//!   the critical multiplier, the mode by inverse iteration on the (T1) block (a bordered
//!   sparse solve repeated with the last iterate as right-hand side, the route of
//!   BifurcationKit's collocation Neimark–Sacker start), then Newton with p2 fixed.
//! - At a double-Hopf point ([`TorusCurveSystem::from_double_hopf`]), without normal-form
//!   coefficients: the cycle of family i is guessed as for a Hopf point,
//!   x* + A·Re(v_i e^{2πis}), period 2π/ω_i (see [`PeriodicOrbitSystem::hopf_guess`]), the
//!   mode as the constant q = v_j with θ = 2πω_j/ω_i, p = p*; the corrector keeps the
//!   amplitude A along v_i fixed and finds the O(A²) shift of (p1, p2), T and θ (the
//!   torus curve T_i of the normal form, Kuznetsov, *Elements of Applied Bifurcation
//!   Theory*, §8.6: it emanates from the double-Hopf point for every generic point). Its
//!   tangent points away from the double-Hopf point. Continuing back, the curve ends there
//!   ([`TorusCurveStop::DoubleHopfEnd`], amplitude → 0), which tests the start. The cycle
//!   families themselves are started with [`DoubleHopfPoint::hopf_point`] and
//!   [`PeriodicOrbitSystem::hopf_guess`].
//!
//! # Stops along a torus curve
//!
//! [`TorusCurveSystem::extend_curve`] stops at a double-Hopf end (amplitude below
//! [`TorusCurveOptions::min_amplitude`] and decreasing; the end is extrapolated to zero
//! amplitude linearly in amplitude²) and at the strong resonances 1:1 (φ → 0, the curve
//! meets a fold-of-cycles curve) and 1:2 (φ → π, it meets a period-doubling curve):
//! when φ comes within [`TorusCurveOptions::resonance_tolerance`] of 0 or π, or θ passes
//! a multiple of π in a step.
//! The weaker resonances 1:3, 1:4 (where Arnold tongues start) are passed and listed by
//! [`TorusCurveSystem::resonances`].
//!
//! With [`TorusCurveOptions::multipliers`] every point stores the cycle's Floquet
//! multipliers without the critical pair; a change of the number outside the unit circle
//! is *detected* (not located) as [`SpecialKind::Fold`] (fold–Neimark–Sacker),
//! [`SpecialKind::PeriodDoubling`] or [`SpecialKind::Torus`] (a second pair). The engine's
//! turning points of the curve in p1 are *located* and also labelled `Fold`.

use crate::collocation::{MAX_DEGREE, lagrange};
use crate::cycle_curve::{
    CycleCurveSystem, CycleExtension, CycleRows, Out, extend_checked, generic_start,
    inverse_iteration, second_derivative_matrix, set_reference_mode,
};
use crate::engine::{Branch, Continuation, ContinuationSystem, Stop};
use crate::equilibrium::HopfPoint;
use crate::error::{Error, Result};
use crate::hopf_curve::HopfCurveSystem;
use crate::linalg::Entry;
use crate::periodic::{Loc, PeriodicOrbitSystem};
use crate::problem::Problem;
use crate::roots::CharacteristicRoots;
use crate::stability::{Location, SpecialKind, SpecialPoint, Stability};
use crate::{BranchPoint, Codim2Point, CollocationOptions};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Options of torus curves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorusCurveOptions {
    /// [`TorusCurveSystem::extend_curve`] stops when the cycle's amplitude (half the
    /// peak-to-peak range of the profile's node values, largest over the components) falls
    /// below this while decreasing: the curve approaches a double-Hopf point [state units]
    pub min_amplitude: f64,
    /// [`TorusCurveSystem::extend_curve`] stops at a strong resonance when the multiplier
    /// angle φ comes within this of 0 (1:1) or π (1:2), or passes 0 or π in a step \[rad\]
    pub resonance_tolerance: f64,
    /// compute the Floquet multipliers of the cycle at every point, stored as the point's
    /// stability without the critical pair e^{±iθ} (so `unstable` counts the other
    /// multipliers outside the unit circle, and a change of that count between two points
    /// is detected as [`SpecialKind::Fold`] (fold–Neimark–Sacker, a real multiplier
    /// through 1), [`SpecialKind::PeriodDoubling`] (through −1) or [`SpecialKind::Torus`]
    /// (a second pair: double Neimark–Sacker)); costs one monodromy computation per point
    pub multipliers: bool,
}

impl Default for TorusCurveOptions {
    fn default() -> Self {
        Self {
            min_amplitude: 1e-2,
            resonance_tolerance: 1e-3,
            multipliers: true,
        }
    }
}

/// A torus (Neimark–Sacker) point of a cycle: the cycle has the Floquet multipliers
/// e^{±iφ} on the unit circle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorusPoint {
    /// periodic-orbit unknowns [x, T, p1] of the cycle (for [`PeriodicOrbitSystem`] on the
    /// same mesh)
    pub orbit: Vec<f64>,
    /// period T of the cycle [time units]
    pub period: f64,
    /// all parameters at the point
    pub parameters: Vec<f64>,
    /// angle φ ∈ \[0, π\] of the critical multiplier pair e^{±iφ} \[rad\]
    pub multiplier_angle: f64,
    /// rotation number φ/2π ∈ \[0, ½\]
    pub rotation_number: f64,
}

/// What a torus curve reports at each point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorusCurvePoint {
    /// the two free parameters (p1, p2)
    pub parameters: [f64; 2],
    /// period T of the cycle [time units]
    pub period: f64,
    /// angle φ ∈ \[0, π\] of the critical multiplier pair e^{±iφ} \[rad\]
    pub multiplier_angle: f64,
    /// rotation number φ/2π ∈ \[0, ½\]
    pub rotation_number: f64,
    /// the unreduced θ of (T1): the second frequency of the torus is θ/T (mod 2π/T)
    /// \[rad\]
    pub theta: f64,
    /// amplitude of the cycle (half the peak-to-peak range of the node values, largest
    /// over the components) [state units]
    pub amplitude: f64,
}

/// Where a torus curve ends at a double-Hopf point, extrapolated from the last two points
/// to zero amplitude (linearly in amplitude²).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DoubleHopfEnd {
    /// index in the branch of the last computed point
    pub index: usize,
    /// amplitude of the cycle at that point [state units]
    pub amplitude: f64,
    /// estimated (p1, p2) of the double-Hopf point
    pub parameters: [f64; 2],
    /// estimated period 2π/ω_i of the vanishing cycle [time units]
    pub period: f64,
    /// estimated frequencies (ω_i of the vanishing cycle, θ/T of the mode) \[rad per time
    /// unit\]
    pub omegas: [f64; 2],
}

/// Why [`TorusCurveSystem::extend_curve`] stopped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum TorusCurveStop {
    /// the continuation engine stopped (points computed, parameter range, step underflow)
    Continuation(Stop),
    /// the cycle shrank below `min_amplitude`: the curve ends at a double-Hopf point
    DoubleHopfEnd(DoubleHopfEnd),
    /// the multiplier angle reached a strong resonance 1:`order` (order 1: φ → 0, order 2:
    /// φ → π) at the last point (index `index`)
    StrongResonance {
        /// index in the branch of the last point
        index: usize,
        /// q of the resonance 1:q (1 or 2)
        order: u32,
        /// multiplier angle φ at that point \[rad\]
        angle: f64,
    },
}

/// A resonance 1:q (q = 1, 2, 3, 4) passed between two consecutive points of a torus curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Resonance {
    /// index of the point after the passage
    pub index: usize,
    /// q of the resonance 1:q: φ crossed 2π/q (q = 1: φ near 0)
    pub order: u32,
    /// (p1, p2) linearly interpolated at the crossing
    pub parameters: [f64; 2],
}

/// Multiplier angle φ ∈ \[0, π\] of e^{iθ}.
pub fn multiplier_angle(theta: f64) -> f64 {
    let t = theta.rem_euclid(2.0 * PI);
    if t > PI { 2.0 * PI - t } else { t }
}

/// A double-Hopf point of an equilibrium: two pairs ±iω1, ±iω2 on the imaginary axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DoubleHopfPoint {
    /// all parameters at the point
    pub parameters: Vec<f64>,
    /// the equilibrium x*
    pub state: Vec<f64>,
    /// the two frequencies (ω1, ω2) \[rad per time unit\]
    pub omegas: [f64; 2],
    /// critical eigenvectors v_i (Δ(iω_i) v_i = 0, ‖v_i‖ = 1, largest component real)
    pub eigenvectors: [Vec<Complex64>; 2],
}

impl DoubleHopfPoint {
    /// The point at the equilibrium `state` and `parameters` with the frequencies `omegas`;
    /// the eigenvectors are computed as the null vectors of the characteristic matrices
    /// Δ(iω_i) = iω_i I − Σ_j A_j e^{−iω_i τ_j} (smallest singular value).
    pub fn new<P: Problem>(
        problem: &P,
        parameters: Vec<f64>,
        state: Vec<f64>,
        omegas: [f64; 2],
    ) -> Result<Self> {
        let n = problem.dim();
        if state.len() != n {
            return Err(Error::InvalidInput(format!(
                "double-Hopf point: state of length {} for a system of dimension {n}",
                state.len()
            )));
        }
        let eigenvectors = [
            null_vector(problem, &parameters, &state, omegas[0])?,
            null_vector(problem, &parameters, &state, omegas[1])?,
        ];
        Ok(Self {
            parameters,
            state,
            omegas,
            eigenvectors,
        })
    }

    /// The double-Hopf point `point` located on the Hopf curve `curve` of `hc` (as listed
    /// by [`HopfCurveSystem::codim2_points`]): ω1 is the continued pair's, ω2 the crossing
    /// pair's frequency.
    pub fn from_hopf_curve<P: Problem, R: CharacteristicRoots>(
        problem: &P,
        hc: &HopfCurveSystem<'_, P, R>,
        curve: &Branch,
        point: &Codim2Point,
    ) -> Result<Self> {
        let pt = curve
            .points
            .get(point.index)
            .ok_or(Error::InvalidInput(format!(
                "double-Hopf point index {} beyond the curve's {} points",
                point.index,
                curve.points.len()
            )))?;
        if point.kind != SpecialKind::DoubleHopf || point.omegas.len() != 2 {
            return Err(Error::InvalidInput(format!(
                "not a double-Hopf point with two frequencies: {:?} {:?}",
                point.kind, point.omegas
            )));
        }
        let omegas = [hc.omega(&pt.u).abs(), point.omegas[1].abs()];
        Self::new(
            problem,
            hc.parameters_at(&pt.u),
            hc.state(&pt.u).to_vec(),
            omegas,
        )
    }

    /// The Hopf point of pair `family` (0 or 1) with `ip` as its parameter, for branch
    /// switching onto that cycle family with [`PeriodicOrbitSystem::hopf_guess`] (the
    /// transversality is unknown here and set to 0).
    pub fn hopf_point(&self, family: usize, ip: usize) -> HopfPoint {
        let i = family.min(1);
        HopfPoint {
            parameter: self.parameters[ip],
            state: self.state.clone(),
            omega: self.omegas[i],
            eigenvector: self.eigenvectors[i].clone(),
            transversality: 0.0,
        }
    }
}

/// null vector of Δ(iω) at the equilibrium x (‖v‖ = 1, largest component real)
fn null_vector<P: Problem>(
    problem: &P,
    p: &[f64],
    x: &[f64],
    omega: f64,
) -> Result<Vec<Complex64>> {
    let n = problem.dim();
    let k = problem.n_delays();
    let nc = n * (k + 1);
    let args: Vec<f64> = (0..=k).flat_map(|_| x.iter().copied()).collect();
    let mut jac = vec![0.0; n * nc];
    problem.jacobian(&args, p, &mut jac);
    let lambda = Complex64::new(0.0, omega);
    let delta = DMatrix::<Complex64>::from_fn(n, n, |r, c| {
        let mut v = if r == c {
            lambda
        } else {
            Complex64::new(0.0, 0.0)
        };
        for d in 0..=k {
            let tau = if d == 0 { 0.0 } else { problem.delay(d - 1, p) };
            v -= jac[r * nc + d * n + c] * (-lambda * tau).exp();
        }
        v
    });
    let svd = delta.svd(false, true);
    let vt = svd.v_t.ok_or(Error::Eigen {
        size: n,
        message: "SVD of the characteristic matrix at the double-Hopf point".into(),
    })?;
    let kmin = (0..n)
        .min_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]))
        .unwrap_or(0);
    let v: Vec<Complex64> = (0..n).map(|j| vt[(kmin, j)].conj()).collect();
    let big = (0..n)
        .max_by(|&i, &j| v[i].norm().total_cmp(&v[j].norm()))
        .unwrap_or(0);
    let phase = v[big].conj() / v[big].norm();
    Ok(v.into_iter().map(|z| z * phase).collect())
}

/// Per-collocation-point scratch (allocated once).
#[derive(Debug)]
struct Scratch {
    jac: Vec<f64>,
    /// B_a = f_XX[Q_a, ·], B_b = f_XX[Q_b, ·] (n × n(k+1), row-major)
    ba: Vec<f64>,
    bb: Vec<f64>,
    /// stacked Re and Im of Q = [q(s), e^{−iθτ_j/T} q(s_j), …]
    qa: Vec<f64>,
    qb: Vec<f64>,
    /// Re and Im of W_j = e^{−iθτ_j/T} (q' + iθ q)(s_j) (n per delay)
    wa: Vec<f64>,
    wb: Vec<f64>,
    unit: Vec<f64>,
    col: Vec<f64>,
    fp: Vec<f64>,
    /// f_Xp[Q_a], f_Xp[Q_b] for p1 (first n) and p2 (next n)
    fxa: Vec<f64>,
    fxb: Vec<f64>,
    /// ∂(T1)/∂(T, θ, p1, p2) of one point's n rows
    border: Vec<[f64; 8]>,
    /// cos and sin of θτ_j/T
    cs: Vec<(f64, f64)>,
    delays: Vec<f64>,
    dtau: [Vec<f64>; 2],
    locs: Vec<Loc>,
}

/// Torus (Neimark–Sacker) points of periodic orbits in two free parameters, as a
/// [`ContinuationSystem`]; see the [module documentation](self) for the equations.
///
/// A [`CycleCurveSystem`]: its constructors and the getters of the cycle are those of every
/// two-parameter cycle curve; the mode, θ, the starts and the stops are its own.
///
/// Unknowns u = [x (n·L·m), T, p1, p2, a (n·L·m), b (n·L·m), θ]; the curve's `parameter`
/// is p1, its `secondary_parameter` p2.
///
/// Cost (benches/torus.rs, release, 2 cores shared with other jobs, load ≈ 7): on the
/// 4-dimensional delayed test bed with τ/T ≈ 0.4, one Newton step takes 7.7, 25, 61 and
/// 710 ms for L = 10, 20, 40 and 80 (degree 4); the sparse LU dominates (assembly 0.6 ms
/// at L = 10), and the delayed coupling reaching 40 % of the period back fills the factors
/// at large L. A torus curve of 40 points at L = 10 takes 1.0 s (with the Floquet
/// multipliers of every point 1.05 s).
///
/// # Example: the torus curve of a cycle of two oscillators
///
/// ```
/// use continuation::*;
/// use continuation_textbook::TorusTestBed;
/// use continuation::torus::*;
///
/// # fn main() -> Result<()> {
/// // ODE: z1' = (μ + i(1 + 0.2|z1|²) − |z1|² + 0.3|z2|²) z1, z2' = (ν + 1.3i + 0.5|z1|² − |z2|²) z2;
/// // cycle 1 (|z1|² = μ) has its torus curve on ν = −0.5 μ: at ν = −0.15, μ* = 0.3
/// let bed = TorusTestBed::ode();
/// let (mu, nu) = (0.2, -0.15);
/// let period = 2.0 * std::f64::consts::PI / (1.0 + 0.2 * mu);
/// let colloc = CollocationOptions { intervals: 10, ..Default::default() };
/// let mut po = PeriodicOrbitSystem::new(&bed, vec![mu, nu, 0.0], 0, colloc)?;
/// let r = mu.sqrt();
/// let tp = 2.0 * std::f64::consts::PI;
/// let u0 = po.unknowns_from(|s| vec![r * (tp * s).cos(), r * (tp * s).sin(), 0.0, 0.0], period, mu);
/// po.set_reference(&u0);
/// let mut dir = vec![0.0; u0.len()];
/// dir[po.parameter_index()] = 1.0;
/// let cont = Continuation::new(ContinuationOptions { initial_step: 0.05, max_step: 0.05, ..Default::default() });
/// let mut cycles = cont.start(&mut po, &u0, &dir)?;
/// cont.extend(&mut po, &mut cycles, 8)?;
/// let (i, _) = cycles.first(SpecialKind::Torus).expect("torus point");
///
/// // located with ν fixed (the square system), then continued in (μ, ν)
/// let (mut torus, mut curve) =
///     TorusCurveSystem::start_at_torus(&cont, &po, &cycles.points[i], 1, TorusCurveOptions::default())?;
/// let tp0 = torus.torus_point(&curve.points[0].u);
/// assert!((tp0.parameters[0] - 0.3).abs() < 1e-6);
/// torus.extend_curve(&cont, &mut curve, 5)?;
/// for pt in &curve.points {
///     let c = torus.curve_point(&pt.u);
///     assert!((c.parameters[1] + 0.5 * c.parameters[0]).abs() < 1e-6);
/// }
/// # Ok(())
/// # }
/// ```
pub type TorusCurveSystem<'a, P> = CycleCurveSystem<'a, P, TorusExtension>;

/// The part of a [`TorusCurveSystem`] that is its own: the options and the mode of the
/// last accepted point.
#[derive(Debug)]
pub struct TorusExtension {
    options: TorusCurveOptions,
    /// the mode q_ref = a_ref + i b_ref of the last accepted point (⟨q_ref, q_ref⟩ = 1)
    a_ref: Vec<f64>,
    b_ref: Vec<f64>,
    s: Scratch,
}

impl CycleExtension for TorusExtension {
    type Options = TorusCurveOptions;

    fn new(options: TorusCurveOptions, n: usize, k: usize, np: usize) -> Self {
        let nc = n * (k + 1);
        let s = Scratch {
            jac: vec![0.0; n * nc],
            ba: vec![0.0; n * nc],
            bb: vec![0.0; n * nc],
            qa: vec![0.0; nc],
            qb: vec![0.0; nc],
            wa: vec![0.0; n * k],
            wb: vec![0.0; n * k],
            unit: vec![0.0; nc],
            col: vec![0.0; n],
            fp: vec![0.0; n],
            fxa: vec![0.0; 2 * n],
            fxb: vec![0.0; 2 * n],
            border: vec![[0.0; 8]; n],
            cs: vec![(1.0, 0.0); k],
            delays: vec![0.0; k],
            dtau: [vec![0.0; k], vec![0.0; k]],
            locs: vec![Loc::ZERO; k],
        };
        Self {
            options,
            a_ref: vec![0.0; np],
            b_ref: vec![0.0; np],
            s,
        }
    }
}

impl<'a, P: Problem> TorusCurveSystem<'a, P> {
    /// Start from a torus point `point` of a branch of `po` (a [`SpecialKind::Torus`]
    /// point, located or detected; its critical multiplier gives θ0). `ip2` is the second
    /// free parameter (its value taken from `po`'s parameters). The mode is found by
    /// inverse iteration. Returns the system (same mesh and problem), the initial guess and
    /// the direction +p2 for [`Continuation::start`], whose corrector then keeps p2 fixed:
    /// its first point is the torus point of the branch (see
    /// [`TorusCurveSystem::start_at_torus`]).
    pub fn from_torus(
        po: &PeriodicOrbitSystem<'a, P>,
        point: &BranchPoint,
        ip2: usize,
        options: TorusCurveOptions,
    ) -> Result<(Self, Vec<f64>, Vec<f64>)> {
        let np = po.period_index();
        let mut sys = Self::at_branch_point(po, point, ip2, options, "from_torus")?;
        let crit = point
            .special
            .as_ref()
            .and_then(|sp| sp.critical)
            .or_else(|| {
                point
                    .stability
                    .as_ref()
                    .and_then(|s| s.critical(SpecialKind::Torus))
            })
            .ok_or(Error::InvalidInput(
                "from_torus: the point has no critical multiplier (compute the stability)".into(),
            ))?;
        let mut guess = point.u.clone();
        guess.push(sys.base.po.params[ip2]);
        guess.extend(std::iter::repeat_n(0.0, 2 * np));
        guess.push(crit.arg().abs());
        sys.mode_by_inverse_iteration(&mut guess)?;
        sys.accept(&guess);
        let direction = sys.base.p2_direction(guess.len());
        Ok((sys, guess, direction))
    }

    /// [`TorusCurveSystem::from_torus`] and the correction with p2 fixed: the returned
    /// branch holds one point, the torus point of the cycle branch (to the Newton
    /// tolerance; see [`TorusCurveSystem::torus_point`]), with the curve's tangent
    /// oriented towards increasing p2; extend it with [`TorusCurveSystem::extend_curve`].
    pub fn start_at_torus(
        cont: &Continuation,
        po: &PeriodicOrbitSystem<'a, P>,
        point: &BranchPoint,
        ip2: usize,
        options: TorusCurveOptions,
    ) -> Result<(Self, Branch)> {
        let (mut sys, guess, dir) = Self::from_torus(po, point, ip2, options)?;
        let branch = cont.start(&mut sys, &guess, &dir)?;
        Ok((sys, branch))
    }

    /// Start at a double-Hopf point `hh` on the torus curve of cycle family `family` (0:
    /// the cycles of frequency ω1, which lose stability to the mode of ω2; 1: the other
    /// way round), with `free` = [p1, p2] and the cycle amplitude `amplitude` along the
    /// eigenvector (‖v‖ = 1; see the module documentation). Returns the system on a
    /// uniform mesh of `collocation.intervals` intervals, the guess and the direction of
    /// growing amplitude for [`Continuation::start`]; the first point's tangent then points
    /// away from the double-Hopf point. On another mesh: [`TorusCurveSystem::with_mesh`]
    /// and [`TorusCurveSystem::double_hopf_guess`].
    pub fn from_double_hopf(
        problem: &'a P,
        hh: &DoubleHopfPoint,
        free: [usize; 2],
        family: usize,
        amplitude: f64,
        collocation: CollocationOptions,
        options: TorusCurveOptions,
    ) -> Result<(Self, Vec<f64>, Vec<f64>)> {
        let mut sys = Self::new(
            problem,
            hh.parameters.clone(),
            (free[0], free[1]),
            collocation,
            options,
        )?;
        let (guess, direction) = sys.double_hopf_guess(hh, family, amplitude)?;
        Ok((sys, guess, direction))
    }

    /// The guess and start direction of [`TorusCurveSystem::from_double_hopf`] for this
    /// system (its mesh and free parameters; all parameters are set to `hh`'s). Sets the
    /// references.
    pub fn double_hopf_guess(
        &mut self,
        hh: &DoubleHopfPoint,
        family: usize,
        amplitude: f64,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.base.po.dim();
        if family > 1 {
            return Err(Error::InvalidInput(format!(
                "double-Hopf start: cycle family {family} (0 or 1)"
            )));
        }
        if hh.state.len() != n
            || hh.eigenvectors.iter().any(|v| v.len() != n)
            || hh.parameters.len() != self.base.po.params.len()
        {
            return Err(Error::InvalidInput(format!(
                "double-Hopf start: point of dimension {} with {} parameters for a system of dimension {n} with {}",
                hh.state.len(),
                hh.parameters.len(),
                self.base.po.params.len()
            )));
        }
        self.base.po.params.clone_from(&hh.parameters);
        let hopf = hh.hopf_point(family, self.base.po.ip);
        let (orbit, cycle_dir) = self.base.po.hopf_guess(&hopf, amplitude);
        let other = 1 - family;
        let v = &hh.eigenvectors[other];
        let nodes = self.base.po.n_nodes();
        let mut guess = orbit;
        guess.push(hh.parameters[self.base.ip2]);
        guess.extend((0..nodes).flat_map(|_| v.iter().map(|z| z.re)));
        guess.extend((0..nodes).flat_map(|_| v.iter().map(|z| z.im)));
        guess.push(2.0 * PI * hh.omegas[other] / hh.omegas[family]);
        self.normalise_mode(&mut guess)?;
        self.accept(&guess);
        let mut direction = cycle_dir;
        direction.resize(guess.len(), 0.0);
        Ok((guess, direction))
    }

    /// index of θ in u
    fn theta_index(&self) -> usize {
        3 * self.np() + 3
    }

    /// scale the mode (a, b) of u to ⟨q, q⟩ = 1
    fn normalise_mode(&self, u: &mut [f64]) -> Result<()> {
        let np = self.np();
        let (a, b) = (&u[np + 3..2 * np + 3], &u[2 * np + 3..3 * np + 3]);
        let norm = (self.base.mean_dot(a, a) + self.base.mean_dot(b, b)).sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(Error::InvalidInput(
                "torus: the mode is zero or not finite".into(),
            ));
        }
        u[np + 3..3 * np + 3].iter_mut().for_each(|v| *v /= norm);
        Ok(())
    }

    /// The mode of u's cycle at u's θ by inverse iteration on the (T1) block (real form,
    /// 2·n·L·m square; nearly singular at a torus point): four solves from a fixed start.
    fn mode_by_inverse_iteration(&mut self, u: &mut [f64]) -> Result<()> {
        let np = self.np();
        // a fixed, generic start
        for (i, v) in u[np + 3..3 * np + 3].iter_mut().enumerate() {
            *v = generic_start(i);
        }
        let mut entries = Vec::new();
        self.jacobian(u, &mut entries)?;
        let (r0, c0, size) = (np + 1, np + 3, 2 * np);
        let mut z = u[c0..c0 + size].to_vec();
        inverse_iteration(entries, (r0, c0, size), &mut z, "torus mode")?;
        u[c0..c0 + size].copy_from_slice(&z);
        self.normalise_mode(u)
    }

    /// the Floquet mode q = a + ib of (T1) as (a, b), node values like the profile
    pub fn mode<'u>(&self, u: &'u [f64]) -> (&'u [f64], &'u [f64]) {
        let np = self.np();
        (&u[np + 3..2 * np + 3], &u[2 * np + 3..3 * np + 3])
    }

    /// the unreduced θ of (T1) \[rad\]
    pub fn theta(&self, u: &[f64]) -> f64 {
        u[self.theta_index()]
    }

    /// The torus point at u: the cycle, its period, all parameters, the multiplier angle
    /// and the rotation number.
    pub fn torus_point(&self, u: &[f64]) -> TorusPoint {
        let phi = multiplier_angle(self.theta(u));
        TorusPoint {
            orbit: self.orbit(u).to_vec(),
            period: self.period(u),
            parameters: self.parameters(u),
            multiplier_angle: phi,
            rotation_number: phi / (2.0 * PI),
        }
    }

    /// What the curve reports at u (parameters, period, angle, rotation number, amplitude).
    pub fn curve_point(&self, u: &[f64]) -> TorusCurvePoint {
        let np = self.np();
        let phi = multiplier_angle(self.theta(u));
        TorusCurvePoint {
            parameters: [u[np + 1], u[np + 2]],
            period: self.period(u),
            multiplier_angle: phi,
            rotation_number: phi / (2.0 * PI),
            theta: self.theta(u),
            amplitude: self.amplitude(u),
        }
    }

    /// Continue the torus curve by up to `max_points` points (like [`Continuation::extend`]),
    /// stopping at a double-Hopf end or a strong resonance 1:1 or 1:2 (see the module
    /// documentation).
    pub fn extend_curve(
        &mut self,
        cont: &Continuation,
        branch: &mut Branch,
        max_points: usize,
    ) -> Result<TorusCurveStop> {
        let stop = extend_checked(self, cont, branch, max_points, |sys, branch, _| {
            let last = branch.points.len() - 1;
            let amplitude = sys.amplitude(&branch.points[last].u);
            let shrinking = last > 0 && amplitude < sys.amplitude(&branch.points[last - 1].u);
            if amplitude < sys.ext.options.min_amplitude && shrinking {
                return Ok(Some(TorusCurveStop::DoubleHopfEnd(sys.mark_end(branch))));
            }
            Ok((last > 0)
                .then(|| sys.strong_resonance(&branch.points[last - 1].u, &branch.points[last].u))
                .flatten()
                .map(|(order, _)| TorusCurveStop::StrongResonance {
                    index: last,
                    order,
                    angle: multiplier_angle(sys.theta(&branch.points[last].u)),
                }))
        })?;
        Ok(stop.map_or_else(|end| end, TorusCurveStop::Continuation))
    }

    /// A strong resonance between the points `a` and `b` of a curve: 1:1 (q = 1) or 1:2
    /// (q = 2) when φ at b is within [`TorusCurveOptions::resonance_tolerance`] of 0 or π,
    /// or when θ passed a multiple kπ between them (q = 1 for even k). Returns q and the
    /// fraction of the step a → b at the resonance.
    fn strong_resonance(&self, a: &[f64], b: &[f64]) -> Option<(u32, f64)> {
        let (ta, tb) = (self.theta(a), self.theta(b));
        let phi = multiplier_angle(tb);
        let tol = self.ext.options.resonance_tolerance;
        if phi < tol {
            return Some((1, 1.0));
        }
        if phi > PI - tol {
            return Some((2, 1.0));
        }
        let k = (ta.min(tb) / PI).ceil();
        if k * PI < ta.max(tb) {
            let order = if (k as i64).rem_euclid(2) == 0 { 1 } else { 2 };
            return Some((order, (k * PI - ta) / (tb - ta)));
        }
        None
    }

    /// The resonances passed along `branch`: 1:3 and 1:4 (the multiplier angle φ crossed
    /// 2π/3 or π/2; Arnold tongues start there) and the strong resonances 1:1 and 1:2 (see
    /// [`TorusCurveSystem::extend_curve`]), with (p1, p2) linearly interpolated in φ or θ.
    pub fn resonances(&self, branch: &Branch) -> Vec<Resonance> {
        let np = self.np();
        let mut out = Vec::new();
        for (j, w) in branch.points.windows(2).enumerate() {
            let (fa, fb) = (
                multiplier_angle(self.theta(&w[0].u)),
                multiplier_angle(self.theta(&w[1].u)),
            );
            let at =
                |t: f64| [1, 2].map(|o| w[0].u[np + o] + t * (w[1].u[np + o] - w[0].u[np + o]));
            for (order, target) in [(3, 2.0 * PI / 3.0), (4, PI / 2.0)] {
                if (fa - target) * (fb - target) < 0.0 {
                    out.push(Resonance {
                        index: j + 1,
                        order,
                        parameters: at((target - fa) / (fb - fa)),
                    });
                }
            }
            if let Some((order, t)) = self.strong_resonance(&w[0].u, &w[1].u) {
                out.push(Resonance {
                    index: j + 1,
                    order,
                    parameters: at(t),
                });
            }
        }
        out
    }

    /// mark the last point as the (detected) end at a double-Hopf point
    fn mark_end(&self, branch: &mut Branch) -> DoubleHopfEnd {
        let np = self.np();
        let last = branch.points.len() - 1;
        let (est, amplitude) = self.base.extrapolate_to_zero_amplitude(branch, |p| {
            [p.u[np + 1], p.u[np + 2], p.u[np], self.theta(&p.u)]
        });
        let omega = 2.0 * PI / est[2];
        let end = DoubleHopfEnd {
            index: last,
            amplitude,
            parameters: [est[0], est[1]],
            period: est[2],
            omegas: [omega, est[3] / est[2]],
        };
        branch.points[last].special = Some(SpecialPoint {
            kind: SpecialKind::DoubleHopf,
            location: Location::Detected,
            parameter: est[0],
            critical: Some(Complex64::new(0.0, end.omegas[1])),
            transversality: None,
        });
        end
    }
}

/// one collocation point's place and the values its Jacobian entries need
struct At {
    i: usize,
    c: usize,
    row0: usize,
    period: f64,
    theta: f64,
}

impl<P: Problem> TorusCurveSystem<'_, P> {
    /// delays, their parameter derivatives and e^{−iθτ_j/T} at u (after `sync`)
    fn prepare_delays(&mut self, period: f64, theta: f64) {
        let problem = self.base.po.problem;
        let params = &self.base.po.params;
        for d in 0..problem.n_delays() {
            let tau = problem.delay(d, params);
            self.ext.s.delays[d] = tau;
            self.ext.s.dtau[0][d] = problem.delay_dp(d, params, self.base.po.ip);
            self.ext.s.dtau[1][d] = problem.delay_dp(d, params, self.base.ip2);
            let ph = theta * tau / period;
            self.ext.s.cs[d] = (ph.cos(), ph.sin());
        }
    }

    /// arguments, J, Q = [q(s), Φ_j q(s_j)] and W_j = Φ_j (q' + iθq)(s_j) at collocation
    /// point c of interval i
    fn prepare_point(&mut self, u: &[f64], at: &At) {
        let n = self.base.po.dim();
        let m = self.base.po.degree();
        let np = self.np();
        let (a_off, b_off) = (np + 3, 2 * np + 3);
        self.base.po.fill_args(
            &u[..np + 2],
            at.i,
            at.c,
            at.period,
            &self.ext.s.delays,
            &mut self.ext.s.locs,
        );
        let po = &self.base.po;
        let s = &mut self.ext.s;
        po.problem.jacobian(&po.args, &po.params, &mut s.jac);
        for kk in 0..n {
            let (mut qa, mut qb) = (0.0, 0.0);
            for j in 0..=m {
                let g = po.node(at.i, j) * n + kk;
                let lv = po.basis.val[at.c * (m + 1) + j];
                qa += lv * u[a_off + g];
                qb += lv * u[b_off + g];
            }
            s.qa[kk] = qa;
            s.qb[kk] = qb;
        }
        let (mut l, mut dl) = ([0.0; MAX_DEGREE + 1], [0.0; MAX_DEGREE + 1]);
        for d in 0..s.delays.len() {
            let loc = s.locs[d];
            let hd = po.mesh[loc.base + 1] - po.mesh[loc.base];
            lagrange(m, loc.xi, &mut l, &mut dl);
            let (cd, sd) = s.cs[d];
            for kk in 0..n {
                let (mut ra, mut rb, mut da, mut db) = (0.0, 0.0, 0.0, 0.0);
                for j in 0..=m {
                    let g = po.node(loc.base, j) * n + kk;
                    ra += l[j] * u[a_off + g];
                    rb += l[j] * u[b_off + g];
                    da += dl[j] * u[a_off + g] / hd;
                    db += dl[j] * u[b_off + g] / hd;
                }
                let q = (d + 1) * n + kk;
                s.qa[q] = cd * ra + sd * rb;
                s.qb[q] = cd * rb - sd * ra;
                let (za, zb) = (da - at.theta * rb, db + at.theta * ra);
                s.wa[d * n + kk] = cd * za + sd * zb;
                s.wb[d * n + kk] = cd * zb - sd * za;
            }
        }
    }

    /// (T1) residual rows or their Jacobian entries (with the cycle's p2 column), point by
    /// point; `r` is the slice of the 2·n·L·m (T1) rows
    fn eigen_rows(&mut self, u: &[f64], mut out: Out<'_>) -> Result<()> {
        let n = self.base.po.dim();
        let m = self.base.po.degree();
        let np = self.np();
        let nc = n * (self.base.po.problem.n_delays() + 1);
        let (period, theta) = (u[np], self.theta(u));
        self.prepare_delays(period, theta);
        for i in 0..self.base.po.intervals() {
            let h = self.base.po.mesh[i + 1] - self.base.po.mesh[i];
            for c in 0..m {
                let at = At {
                    i,
                    c,
                    row0: (i * m + c) * n,
                    period,
                    theta,
                };
                self.prepare_point(u, &at);
                match &mut out {
                    Out::Residual(r) => {
                        let (po, s) = (&self.base.po, &self.ext.s);
                        for rr in 0..n {
                            let (mut da, mut db) = (0.0, 0.0);
                            for j in 0..=m {
                                let g = po.node(i, j) * n + rr;
                                let dv = po.basis.der[c * (m + 1) + j] / h;
                                da += dv * u[np + 3 + g];
                                db += dv * u[2 * np + 3 + g];
                            }
                            let row = &s.jac[rr * nc..(rr + 1) * nc];
                            let ja: f64 = row.iter().zip(&s.qa).map(|(x, y)| x * y).sum();
                            let jb: f64 = row.iter().zip(&s.qb).map(|(x, y)| x * y).sum();
                            r[at.row0 + rr] = da - theta * s.qb[rr] - period * ja;
                            r[np + at.row0 + rr] = db + theta * s.qa[rr] - period * jb;
                        }
                    }
                    Out::Jacobian(entries) => {
                        self.second_derivatives()?;
                        self.push_mode_columns(&at, h, entries);
                        self.push_border_columns(&at, entries)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// B_a = f_XX[Q_a, ·] and B_b = f_XX[Q_b, ·], column by column
    fn second_derivatives(&mut self) -> Result<()> {
        let (po, s) = (&self.base.po, &mut self.ext.s);
        let (problem, args, params) = (po.problem, &po.args, &po.params);
        second_derivative_matrix(
            problem,
            args,
            params,
            &s.qa,
            &mut s.unit,
            &mut s.col,
            &mut s.ba,
        )?;
        second_derivative_matrix(
            problem,
            args,
            params,
            &s.qb,
            &mut s.unit,
            &mut s.col,
            &mut s.bb,
        )
    }

    /// entries of the (T1) rows in the columns of a, b (the mode) and x (the cycle)
    fn push_mode_columns(&self, at: &At, h: f64, entries: &mut Vec<Entry>) {
        let (po, s) = (&self.base.po, &self.ext.s);
        let n = po.dim();
        let m = po.degree();
        let np = self.np();
        let nc = s.qa.len();
        let (ra, rb) = (np + 1 + at.row0, 2 * np + 1 + at.row0);
        let (a_off, b_off) = (np + 3, 2 * np + 3);
        let (t, theta) = (at.period, at.theta);
        for j in 0..=m {
            let g = po.node(at.i, j) * n;
            let lv = po.basis.val[at.c * (m + 1) + j];
            let dv = po.basis.der[at.c * (m + 1) + j] / h;
            for r in 0..n {
                for kk in 0..n {
                    let diag = if r == kk { dv } else { 0.0 };
                    let v = diag - t * s.jac[r * nc + kk] * lv;
                    entries.push(Entry::new(ra + r, a_off + g + kk, v));
                    entries.push(Entry::new(rb + r, b_off + g + kk, v));
                    entries.push(Entry::new(ra + r, g + kk, -t * s.ba[r * nc + kk] * lv));
                    entries.push(Entry::new(rb + r, g + kk, -t * s.bb[r * nc + kk] * lv));
                }
                entries.push(Entry::new(ra + r, b_off + g + r, -theta * lv));
                entries.push(Entry::new(rb + r, a_off + g + r, theta * lv));
            }
        }
        let (mut l, mut dl) = ([0.0; MAX_DEGREE + 1], [0.0; MAX_DEGREE + 1]);
        for (d, &(cd, sd)) in s.cs.iter().enumerate() {
            let loc = s.locs[d];
            lagrange(m, loc.xi, &mut l, &mut dl);
            for (j, &lj) in l.iter().enumerate().take(m + 1) {
                let g = po.node(loc.base, j) * n;
                for r in 0..n {
                    for kk in 0..n {
                        let q = r * nc + (d + 1) * n + kk;
                        let tj = -t * s.jac[q] * lj;
                        entries.push(Entry::new(ra + r, a_off + g + kk, tj * cd));
                        entries.push(Entry::new(ra + r, b_off + g + kk, tj * sd));
                        entries.push(Entry::new(rb + r, a_off + g + kk, -tj * sd));
                        entries.push(Entry::new(rb + r, b_off + g + kk, tj * cd));
                        entries.push(Entry::new(ra + r, g + kk, -t * s.ba[q] * lj));
                        entries.push(Entry::new(rb + r, g + kk, -t * s.bb[q] * lj));
                    }
                }
            }
        }
    }

    /// entries in the columns of T, p1, p2 and θ: of the (T1) rows, and the cycle's p2
    /// column
    fn push_border_columns(&mut self, at: &At, entries: &mut Vec<Entry>) -> Result<()> {
        let n = self.base.po.dim();
        let np = self.np();
        self.parameter_derivatives()?;
        let mut border = std::mem::take(&mut self.ext.s.border);
        self.border_values(at, &mut border);
        let (po, s) = (&self.base.po, &self.ext.s);
        let nc = s.qa.len();
        let (ra, rb) = (np + 1 + at.row0, 2 * np + 1 + at.row0);
        let cols = [
            np,
            np,
            3 * np + 3,
            3 * np + 3,
            np + 1,
            np + 1,
            np + 2,
            np + 2,
        ];
        for (r, b) in border.iter().enumerate() {
            for (i, (&col, &v)) in cols.iter().zip(b).enumerate() {
                let row = if i % 2 == 0 { ra } else { rb };
                entries.push(Entry::new(row + r, col, v));
            }
            // the cycle's p2 column: −T f_p2 + Σ_d J_d x_s(s_d) ∂τ_d/∂p2
            let mut c2 = -at.period * s.fp[r];
            for (d, dtau) in s.dtau[1].iter().enumerate() {
                let jx: f64 = (0..n)
                    .map(|kk| s.jac[r * nc + (d + 1) * n + kk] * po.dx[d * n + kk])
                    .sum();
                c2 += jx * dtau;
            }
            entries.push(Entry::new(at.row0 + r, np + 2, c2));
        }
        self.ext.s.border = border;
        Ok(())
    }

    /// f_Xp[Q_a], f_Xp[Q_b] for p1 and p2 and f_p2 at the current arguments
    fn parameter_derivatives(&mut self) -> Result<()> {
        let (po, s) = (&self.base.po, &mut self.ext.s);
        let n = po.dim();
        let (problem, args, params) = (po.problem, &po.args, &po.params);
        for (i, ip) in [po.ip, self.base.ip2].into_iter().enumerate() {
            let range = i * n..(i + 1) * n;
            problem.jacobian_dp(args, params, ip, &s.qa, &mut s.fxa[range.clone()])?;
            problem.jacobian_dp(args, params, ip, &s.qb, &mut s.fxb[range])?;
        }
        problem.dfdp(args, params, self.base.ip2, &mut s.fp);
        Ok(())
    }

    /// per row r of the point: ∂(T1)/∂(T, θ, p1, p2), real and imaginary parts
    /// ([Re_T, Im_T, Re_θ, Im_θ, Re_p1, Im_p1, Re_p2, Im_p2])
    fn border_values(&self, at: &At, border: &mut [[f64; 8]]) {
        let (po, s) = (&self.base.po, &self.ext.s);
        let n = po.dim();
        let nc = s.qa.len();
        let k = s.delays.len();
        let t = at.period;
        // J_d·v_d for the delay blocks of J and a per-delay vector v (n per delay)
        let jd = |r: usize, d: usize, v: &[f64]| -> f64 {
            (0..n)
                .map(|kk| s.jac[r * nc + (d + 1) * n + kk] * v[d * n + kk])
                .sum::<f64>()
        };
        // ∂(J·Q)/∂(shift δ_d of the delayed points): B·[0, x_s(s_d) δ_d] + Σ_d δ_d J_d W_d
        let shift = |r: usize, delta: &dyn Fn(usize) -> f64| -> (f64, f64) {
            let (mut ea, mut eb) = (0.0, 0.0);
            for d in 0..k {
                let dd = delta(d);
                for kk in 0..n {
                    let q = r * nc + (d + 1) * n + kk;
                    let xs = po.dx[d * n + kk] * dd;
                    ea += s.ba[q] * xs;
                    eb += s.bb[q] * xs;
                }
                ea += dd * jd(r, d, &s.wa);
                eb += dd * jd(r, d, &s.wb);
            }
            (ea, eb)
        };
        for (r, b) in border.iter_mut().enumerate() {
            let row = &s.jac[r * nc..(r + 1) * nc];
            let ja: f64 = row.iter().zip(&s.qa).map(|(x, y)| x * y).sum();
            let jb: f64 = row.iter().zip(&s.qb).map(|(x, y)| x * y).sum();
            // T: explicit factor, delayed points s − τ_d/T, and Φ_d = e^{−iθτ_d/T}
            let (sa, sb) = shift(r, &|d| s.delays[d] / (t * t));
            b[0] = -ja - t * sa;
            b[1] = -jb - t * sb;
            // θ: i q(s) + i Σ_d τ_d J_d Φ_d q(s_d)
            let (mut ta, mut tb) = (-s.qb[r], s.qa[r]);
            for (d, &tau) in s.delays.iter().enumerate() {
                ta -= tau * jd(r, d, &s.qb[n..]);
                tb += tau * jd(r, d, &s.qa[n..]);
            }
            b[2] = ta;
            b[3] = tb;
            // p1, p2: ∂J/∂p and delays that depend on p (δ_d = −∂τ_d/∂p / T)
            for (i, dtau) in s.dtau.iter().enumerate() {
                let (pa, pb) = shift(r, &|d| -dtau[d] / t);
                b[4 + 2 * i] = -t * (pa + s.fxa[i * n + r]);
                b[5 + 2 * i] = -t * (pb + s.fxb[i * n + r]);
            }
        }
    }
}

impl CycleRows for TorusExtension {
    /// u = [x, T, p1, p2, a, b, θ]
    fn n_unknowns(np: usize) -> usize {
        3 * np + 4
    }

    /// the cycle x and the mode (a, b) interleaved node by node (each node's state of x,
    /// then of a, then of b), the border (T, θ, p1, p2) last: the Jacobian is then banded
    /// like the cycle's, in blocks three times as wide
    fn column_blocks(np: usize) -> (Vec<usize>, Vec<usize>) {
        (
            vec![np + 3, 2 * np + 3],
            vec![np, 3 * np + 3, np + 1, np + 2],
        )
    }

    /// (T1), real and imaginary parts, and (T3)
    fn residual_rows<P: Problem>(
        sys: &mut TorusCurveSystem<'_, P>,
        u: &[f64],
        r_mode: &mut [f64],
    ) -> Result<()> {
        let np = sys.np();
        sys.eigen_rows(u, Out::Residual(&mut r_mode[..2 * np]))?;
        let (a, b) = sys.mode(u);
        let (base, e) = (&sys.base, &sys.ext);
        let re = base.mean_dot(&e.a_ref, a) + base.mean_dot(&e.b_ref, b) - 1.0;
        let im = base.mean_dot(&e.a_ref, b) - base.mean_dot(&e.b_ref, a);
        r_mode[2 * np] = re;
        r_mode[2 * np + 1] = im;
        Ok(())
    }

    fn jacobian_rows<P: Problem>(
        sys: &mut TorusCurveSystem<'_, P>,
        u: &[f64],
        entries: &mut Vec<Entry>,
    ) -> Result<()> {
        let np = sys.np();
        sys.eigen_rows(u, Out::Jacobian(entries))?;
        let w = 1.0 / sys.base.po.n_nodes() as f64;
        let (row_re, row_im) = (3 * np + 1, 3 * np + 2);
        for (g, (&ar, &br)) in sys.ext.a_ref.iter().zip(&sys.ext.b_ref).enumerate() {
            entries.push(Entry::new(row_re, np + 3 + g, ar * w));
            entries.push(Entry::new(row_re, 2 * np + 3 + g, br * w));
            entries.push(Entry::new(row_im, 2 * np + 3 + g, ar * w));
            entries.push(Entry::new(row_im, np + 3 + g, -br * w));
        }
        Ok(())
    }

    fn set_reference<P: Problem>(sys: &mut TorusCurveSystem<'_, P>, u: &[f64]) {
        let (a, b) = sys.mode(u);
        let norm = (sys.base.mean_dot(a, a) + sys.base.mean_dot(b, b)).sqrt();
        set_reference_mode(&mut sys.ext.a_ref, a, norm);
        set_reference_mode(&mut sys.ext.b_ref, b, norm);
    }

    /// the cycle's multipliers with the critical pair e^{±iθ} removed
    fn stability<P: Problem>(
        sys: &mut TorusCurveSystem<'_, P>,
        u: &[f64],
    ) -> Result<Option<Stability>> {
        let pair = Complex64::from_polar(1.0, sys.theta(u));
        sys.stability_without(u, sys.ext.options.multipliers, &[pair, pair.conj()])
    }

    /// a change of the number of unstable multipliers (the critical pair removed): the
    /// multiplier that crossed says which codimension-two point lies between
    fn classify(a: &Stability, b: &Stability) -> Option<SpecialKind> {
        Stability::multiplier_crossing(a, b)
    }
}
