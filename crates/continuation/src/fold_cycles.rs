//! Folds of periodic orbits (limit points of cycles) continued in two parameters (p1, p2),
//! for ODEs and constant-delay DDEs, on the collocation discretisation of
//! [`PeriodicOrbitSystem`].
//!
//! The equations, special points and an example are documented on [`FoldOfCyclesSystem`].

use crate::collocation::{MAX_DEGREE, lagrange_d2};
use crate::engine::{Branch, Continuation, ContinuationSystem, Stop};
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::periodic::{Loc, PeriodicOrbitSystem};
use crate::problem::Problem;
use crate::stability::{Location, SpecialKind, SpecialPoint, Stability};
use crate::{BranchPoint, CollocationOptions};
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

/// Per-collocation-point scratch of the second-order terms (allocated once).
#[derive(Debug)]
struct Scratch {
    f: Vec<f64>,
    jac: Vec<f64>,
    /// B = f_XX[Xv, ·] (n × n(k+1), row-major)
    b: Vec<f64>,
    /// Xv = X'·(v, v_T): the stacked arguments' derivative along the null vector
    xv: Vec<f64>,
    unit: Vec<f64>,
    col: Vec<f64>,
    fp1: Vec<f64>,
    fp2: Vec<f64>,
    fxp1: Vec<f64>,
    fxp2: Vec<f64>,
    /// v_s and x_ss at the delayed points (n per delay)
    vs: Vec<f64>,
    xss: Vec<f64>,
    locs: Vec<Loc>,
}

/// where the second-order terms go
enum Out<'b> {
    /// A·(v, v_T) (n·L·m values)
    Residual(&'b mut [f64]),
    /// Jacobian rows of A·(v, v_T) and the p2 column of R
    Jacobian(&'b mut Vec<Entry>),
}

/// Fold-of-cycles (limit point of cycles) defining system in two free parameters, as a
/// [`ContinuationSystem`].
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
#[derive(Debug)]
pub struct FoldOfCyclesSystem<'a, P: Problem> {
    po: PeriodicOrbitSystem<'a, P>,
    ip2: usize,
    options: FoldCyclesOptions,
    /// normalised null vector of the last accepted point (length n·L·m + 1)
    v_ref: Vec<f64>,
    s: Scratch,
}

impl<'a, P: Problem> FoldOfCyclesSystem<'a, P> {
    /// New system on the mesh `mesh` (0 = s_0 < … < s_L = 1); `params`: all parameters, `ip1`
    /// the primary and `ip2` the secondary free parameter. Set references with
    /// [`ContinuationSystem::accept`] before correcting a guess (or use
    /// [`FoldOfCyclesSystem::from_fold`]).
    pub fn with_mesh(
        problem: &'a P,
        params: Vec<f64>,
        (ip1, ip2): (usize, usize),
        mesh: Vec<f64>,
        collocation: CollocationOptions,
        options: FoldCyclesOptions,
    ) -> Result<Self> {
        if ip2 >= params.len() || ip2 == ip1 {
            return Err(Error::InvalidInput(format!(
                "secondary parameter index {ip2} must differ from the primary {ip1} and be below {}",
                params.len()
            )));
        }
        let po = PeriodicOrbitSystem::with_mesh(problem, params, ip1, mesh, collocation)?;
        let n = problem.dim();
        let k = problem.n_delays();
        let nc = n * (k + 1);
        let s = Scratch {
            f: vec![0.0; n],
            jac: vec![0.0; n * nc],
            b: vec![0.0; n * nc],
            xv: vec![0.0; nc],
            unit: vec![0.0; nc],
            col: vec![0.0; n],
            fp1: vec![0.0; n],
            fp2: vec![0.0; n],
            fxp1: vec![0.0; n],
            fxp2: vec![0.0; n],
            vs: vec![0.0; n * k],
            xss: vec![0.0; n * k],
            locs: vec![Loc::ZERO; k],
        };
        let v_ref = vec![0.0; po.period_index() + 1];
        Ok(Self {
            po,
            ip2,
            options,
            v_ref,
            s,
        })
    }

    /// New system on a uniform mesh of `collocation.intervals` intervals.
    pub fn new(
        problem: &'a P,
        params: Vec<f64>,
        (ip1, ip2): (usize, usize),
        collocation: CollocationOptions,
        options: FoldCyclesOptions,
    ) -> Result<Self> {
        let l = collocation.intervals.max(1);
        let mesh = (0..=l).map(|i| i as f64 / l as f64).collect();
        Self::with_mesh(problem, params, (ip1, ip2), mesh, collocation, options)
    }

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
        if point.u.len() != np + 2 || point.tangent.len() != np + 2 {
            return Err(Error::InvalidInput(format!(
                "from_fold: the point has {} unknowns, the periodic-orbit system {}",
                point.u.len(),
                np + 2
            )));
        }
        let mut params = po.params.clone();
        params[po.ip] = point.parameter;
        let mut sys = Self::with_mesh(
            po.problem,
            params,
            (po.ip, ip2),
            po.mesh.clone(),
            po.options.clone(),
            options,
        )?;
        let p2 = sys.po.params[ip2];
        let guess = sys.unknowns(&point.u, p2, &point.tangent[..=np])?;
        let mut direction = vec![0.0; guess.len()];
        direction[np + 2] = 1.0;
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

    /// n·L·m: number of profile unknowns
    fn np(&self) -> usize {
        self.po.period_index()
    }

    /// ⟨a, b⟩ = Σ a_i b_i /(L·m) + a_T b_T on (profile, period) vectors
    fn inner(&self, a: &[f64], b: &[f64]) -> f64 {
        let np = self.np();
        let prof: f64 = a[..np].iter().zip(&b[..np]).map(|(x, y)| x * y).sum();
        prof / self.po.n_nodes() as f64 + a[np] * b[np]
    }

    fn sync(&mut self, u: &[f64]) {
        let np = self.np();
        self.po.params[self.ip2] = u[np + 2];
        self.po.set_params(&u[..np + 2]);
    }

    /// The point u with the cycle and the null vector shifted in phase so that profile
    /// component `component` of the cycle is largest at s = 0 (see
    /// [`PeriodicOrbitSystem::canonical_phase`]). Correcting again from it, after
    /// [`ContinuationSystem::accept`], makes folds located from guesses of different phase
    /// solutions of the same discretised system.
    pub fn canonical(&self, u: &[f64], component: usize) -> Vec<f64> {
        let np = self.np();
        let shift = self.po.canonical_phase(self.orbit(u), component);
        let mut out = self.po.shifted(self.orbit(u), shift);
        out.push(u[np + 2]);
        out.extend(self.po.shifted(self.null_vector(u), shift));
        out
    }

    /// the periodic-orbit unknowns [x, T, p1] of the fold's cycle
    pub fn orbit<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[..self.np() + 2]
    }

    /// the null vector (v, v_T) of the linearised periodic problem at the fold
    pub fn null_vector<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[self.np() + 3..]
    }

    /// the period T of the fold's cycle [time units]
    pub fn period(&self, u: &[f64]) -> f64 {
        u[self.np()]
    }

    /// all parameters at the point u
    pub fn parameters(&self, u: &[f64]) -> Vec<f64> {
        let np = self.np();
        let mut p = self.po.params.clone();
        p[self.po.ip] = u[np + 1];
        p[self.ip2] = u[np + 2];
        p
    }

    /// amplitude of the fold's cycle: half the peak-to-peak range of the node values,
    /// largest over the components [state units]
    pub fn amplitude(&self, u: &[f64]) -> f64 {
        self.po.amplitude(u)
    }

    /// The periodic-orbit system of the fold's cycle at the parameters of u (free parameter
    /// p1, same mesh, phase reference set to the cycle): continue the cycle branch through
    /// the fold from here, or evaluate the cycle with [`PeriodicOrbitSystem::eval`].
    pub fn periodic_system(&self, u: &[f64]) -> Result<PeriodicOrbitSystem<'a, P>> {
        self.po.at(self.parameters(u), self.orbit(u))
    }

    /// Floquet multipliers of the fold's cycle (sorted by decreasing modulus; the trivial
    /// multiplier and the fold's multiplier are both ≈ 1)
    pub fn multipliers(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        self.sync(u);
        let np = self.np();
        self.po.floquet_multipliers(&u[..np + 2])
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
        let mut added = 0;
        while added < max_points {
            let before = branch.points.len();
            let stop = cont.extend(self, branch, 1)?;
            added += branch.points.len() - before;
            self.label_cusps(branch, before);
            let amplitude = match branch.points.last() {
                Some(last) => self.amplitude(&last.u),
                None => return Err(Error::EmptyBranch),
            };
            if amplitude < self.options.min_amplitude {
                return Ok(FoldCyclesStop::HopfEnd(self.mark_hopf_end(branch)));
            }
            if stop != Stop::MaxPoints {
                return Ok(FoldCyclesStop::Continuation(stop));
            }
        }
        Ok(FoldCyclesStop::Continuation(Stop::MaxPoints))
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
        let b = &branch.points[last];
        let rho_b = self.amplitude(&b.u).powi(2);
        let values = |p: &BranchPoint| [p.u[np + 1], p.u[np + 2], p.u[np]];
        let vb = values(b);
        let est = match last.checked_sub(1).map(|i| &branch.points[i]) {
            Some(a) => {
                let rho_a = self.amplitude(&a.u).powi(2);
                let va = values(a);
                if rho_a > rho_b {
                    let t = rho_b / (rho_a - rho_b);
                    [0, 1, 2].map(|i| vb[i] - t * (va[i] - vb[i]))
                } else {
                    vb
                }
            }
            None => vb,
        };
        let omega = 2.0 * std::f64::consts::PI / est[2];
        let end = HopfEnd {
            index: last,
            amplitude: rho_b.sqrt(),
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

    /// A·(v, v_T) (residual) or its derivative with respect to (x, T, p1, p2) together with
    /// the p2 column of R (Jacobian), collocation point by collocation point.
    fn second_order(&mut self, u: &[f64], mut out: Out<'_>) -> Result<()> {
        let n = self.po.dim();
        let m = self.po.degree();
        let problem = self.po.problem;
        let k = problem.n_delays();
        let nc = n * (k + 1);
        let np = self.np();
        let period = u[np];
        let (ip1, ip2) = (self.po.ip, self.ip2);
        let delays = self.po.delays();
        let dtau1: Vec<f64> = (0..k)
            .map(|d| problem.delay_dp(d, &self.po.params, ip1))
            .collect();
        let dtau2: Vec<f64> = (0..k)
            .map(|d| problem.delay_dp(d, &self.po.params, ip2))
            .collect();
        let vt = u[2 * np + 3];
        let (mut l, mut dl, mut ddl) = (
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
        );
        for i in 0..self.po.intervals() {
            let h = self.po.mesh[i + 1] - self.po.mesh[i];
            for c in 0..m {
                self.po
                    .fill_args(&u[..np + 2], i, c, period, &delays, &mut self.s.locs);
                let params = &self.po.params;
                let args = &self.po.args;
                problem.rhs(args, params, &mut self.s.f);
                problem.jacobian(args, params, &mut self.s.jac);
                // Xv: v at s_c, and v(s_d) + x_s(s_d)·(τ_d/T²)·v_T at the delayed points
                for kk in 0..n {
                    self.s.xv[kk] = (0..=m)
                        .map(|j| {
                            self.po.basis.val[c * (m + 1) + j]
                                * u[np + 3 + self.po.node(i, j) * n + kk]
                        })
                        .sum();
                }
                for (d, &tau) in delays.iter().enumerate() {
                    let loc = self.s.locs[d];
                    let hd = self.po.mesh[loc.base + 1] - self.po.mesh[loc.base];
                    lagrange_d2(m, loc.xi, &mut l, &mut dl, &mut ddl);
                    for kk in 0..n {
                        let (mut vd, mut vs, mut xss) = (0.0, 0.0, 0.0);
                        for j in 0..=m {
                            let g = self.po.node(loc.base, j) * n + kk;
                            vd += l[j] * u[np + 3 + g];
                            vs += dl[j] * u[np + 3 + g] / hd;
                            xss += ddl[j] * u[g] / (hd * hd);
                        }
                        let xs = self.po.dx[d * n + kk];
                        self.s.xv[(d + 1) * n + kk] = vd + xs * tau / (period * period) * vt;
                        self.s.vs[d * n + kk] = vs;
                        self.s.xss[d * n + kk] = xss;
                    }
                }
                let row0 = (i * m + c) * n;
                match &mut out {
                    Out::Residual(r) => {
                        for rr in 0..n {
                            let dv: f64 = (0..=m)
                                .map(|j| {
                                    self.po.basis.der[c * (m + 1) + j]
                                        * u[np + 3 + self.po.node(i, j) * n + rr]
                                })
                                .sum();
                            let jxv: f64 = (0..nc)
                                .map(|col| self.s.jac[rr * nc + col] * self.s.xv[col])
                                .sum();
                            r[row0 + rr] = dv / h - vt * self.s.f[rr] - period * jxv;
                        }
                    }
                    Out::Jacobian(entries) => {
                        let at = Point {
                            i,
                            c,
                            row0,
                            period,
                            vt,
                            delays: &delays,
                            dtau: [&dtau1, &dtau2],
                        };
                        self.push_second_order(&at, entries)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// Jacobian entries of one collocation point (the scratch holds f, J, Xv, v_s, x_ss and
    /// `po` the arguments, x_s and the delayed locations).
    fn push_second_order(&mut self, at: &Point<'_>, entries: &mut Vec<Entry>) -> Result<()> {
        let n = self.po.dim();
        let m = self.po.degree();
        let problem = self.po.problem;
        let k = problem.n_delays();
        let nc = n * (k + 1);
        let np = self.np();
        let (ip1, ip2) = (self.po.ip, self.ip2);
        let (t, vt) = (at.period, at.vt);
        let params = &self.po.params;
        let args = &self.po.args;
        let s = &mut self.s;
        // B = f_XX[Xv, ·], column by column
        for col in 0..nc {
            s.unit.iter_mut().for_each(|e| *e = 0.0);
            s.unit[col] = 1.0;
            problem.second_derivative(args, params, &s.xv, &s.unit, &mut s.col)?;
            for r in 0..n {
                s.b[r * nc + col] = s.col[r];
            }
        }
        problem.dfdp(args, params, ip1, &mut s.fp1);
        problem.dfdp(args, params, ip2, &mut s.fp2);
        problem.jacobian_dp(args, params, ip1, &s.xv, &mut s.fxp1)?;
        problem.jacobian_dp(args, params, ip2, &s.xv, &mut s.fxp2)?;
        let xs = &self.po.dx;
        let dot = |mat: &[f64], r: usize, d: usize, vec: &[f64]| -> f64 {
            (0..n)
                .map(|kk| mat[r * nc + (d + 1) * n + kk] * vec[d * n + kk])
                .sum::<f64>()
        };
        let row_a = np + 1 + at.row0;
        for r in 0..n {
            // R's column of p2: −T f_p2 + Σ_d J_d x_s(s_d) ∂τ_d/∂p2
            let mut c_r2 = -t * s.fp2[r];
            // A·(v, v_T) differentiated by T, p1, p2
            let jxv: f64 = (0..nc).map(|col| s.jac[r * nc + col] * s.xv[col]).sum();
            let mut c_t = -jxv;
            let mut c_p = [
                -vt * s.fp1[r] - t * s.fxp1[r],
                -vt * s.fp2[r] - t * s.fxp2[r],
            ];
            for (d, &tau) in at.delays.iter().enumerate() {
                let jx = dot(&s.jac, r, d, xs);
                let bx = dot(&s.b, r, d, xs);
                let jvs = dot(&s.jac, r, d, &s.vs);
                let jxss = dot(&s.jac, r, d, &s.xss);
                let st = tau / (t * t);
                let dst_dt = -2.0 * tau / (t * t * t);
                c_t -= vt * jx * st
                    + t * bx * st
                    + t * (jvs * st + vt * (jxss * st * st + jx * dst_dt));
                c_r2 += jx * at.dtau[1][d];
                for (cp, dtau) in c_p.iter_mut().zip(at.dtau) {
                    let sp = -dtau[d] / t;
                    let dst_dp = dtau[d] / (t * t);
                    *cp -= vt * jx * sp
                        + t * bx * sp
                        + t * (jvs * sp + vt * (jxss * st * sp + jx * dst_dp));
                }
            }
            entries.push(Entry::new(at.row0 + r, np + 2, c_r2));
            entries.push(Entry::new(row_a + r, np, c_t));
            entries.push(Entry::new(row_a + r, np + 1, c_p[0]));
            entries.push(Entry::new(row_a + r, np + 2, c_p[1]));
        }
        // profile columns at s_c: −v_T J_0 − T B_0
        let basis = &self.po.basis;
        for j in 0..=m {
            let g = self.po.node(at.i, j);
            let lv = basis.val[at.c * (m + 1) + j];
            for r in 0..n {
                for kk in 0..n {
                    let v = (-vt * s.jac[r * nc + kk] - t * s.b[r * nc + kk]) * lv;
                    entries.push(Entry::new(row_a + r, g * n + kk, v));
                }
            }
        }
        // profile columns at the delayed points: (−v_T J_d − T B_d) ℓ_j − T v_T (τ_d/T²) J_d ℓ'_j
        let (mut l, mut dl) = ([0.0; MAX_DEGREE + 1], [0.0; MAX_DEGREE + 1]);
        let mut ddl = [0.0; MAX_DEGREE + 1];
        for (d, &tau) in at.delays.iter().enumerate() {
            let loc = s.locs[d];
            let hd = self.po.mesh[loc.base + 1] - self.po.mesh[loc.base];
            lagrange_d2(m, loc.xi, &mut l, &mut dl, &mut ddl);
            let st = tau / (t * t);
            for j in 0..=m {
                let g = self.po.node(loc.base, j);
                for r in 0..n {
                    for kk in 0..n {
                        let q = r * nc + (d + 1) * n + kk;
                        let v = (-vt * s.jac[q] - t * s.b[q]) * l[j]
                            - t * vt * st * s.jac[q] * dl[j] / hd;
                        entries.push(Entry::new(row_a + r, g * n + kk, v));
                    }
                }
            }
        }
        Ok(())
    }
}

/// where the second-order terms of one collocation point are assembled
struct Point<'d> {
    i: usize,
    c: usize,
    row0: usize,
    period: f64,
    vt: f64,
    delays: &'d [f64],
    dtau: [&'d [f64]; 2],
}

impl<P: Problem> ContinuationSystem for FoldOfCyclesSystem<'_, P> {
    fn n_unknowns(&self) -> usize {
        2 * self.np() + 4
    }
    fn parameter_index(&self) -> usize {
        self.np() + 1
    }
    fn secondary_parameter_index(&self) -> Option<usize> {
        Some(self.np() + 2)
    }

    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        let np = self.np();
        self.sync(u);
        let (r_cycle, r_null) = r.split_at_mut(np + 1);
        self.po.residual(&u[..np + 2], r_cycle)?;
        self.second_order(u, Out::Residual(&mut r_null[..np]))?;
        let v = &u[np + 3..];
        r_null[np] = self.po.phase_row.iter().zip(v).map(|(a, b)| a * b).sum();
        r_null[np + 1] = self.inner(&self.v_ref, v) - 1.0;
        if r_null.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                parameter: u[np + 1],
            })
        }
    }

    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let np = self.np();
        self.sync(u);
        let start = entries.len();
        self.po.jacobian(&u[..np + 2], entries)?;
        // the null-vector rows contain A itself: the cycle's (x, T) columns, shifted
        for idx in start..entries.len() {
            let (row, col, val) = (entries[idx].row, entries[idx].col, entries[idx].val);
            if col <= np {
                entries.push(Entry::new(row + np + 1, col + np + 3, val));
            }
        }
        let second = entries.len();
        self.second_order(u, Out::Jacobian(entries))?;
        let w = 1.0 / self.po.n_nodes() as f64;
        for (i, &v) in self.v_ref[..np].iter().enumerate() {
            entries.push(Entry::new(2 * np + 2, np + 3 + i, v * w));
        }
        entries.push(Entry::new(2 * np + 2, 2 * np + 3, self.v_ref[np]));
        if entries[second..].iter().all(|e| e.val.is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                parameter: u[np + 1],
            })
        }
    }

    /// mesh-node order with the cycle x and the null vector v interleaved node by node
    /// ([x_0, v_0, x_1, v_1, …]) and the border (T, v_T, p1, p2) last: the doubled Jacobian
    /// [[A, 0], [B(v), A]] is then banded like A, and the LU fills only that band (half the
    /// Newton-step cost of COLAMD at L = 20, a third at L = 80, see benches/fold_cycles.rs)
    /// x and v interleaved node by node (each node's state of the cycle, then of the null
    /// vector), the borders (T, v_T, p1, p2) last: the fill of simplicial factors stays in
    /// the band of the delay couplings (large systems are factorised with supernodes in
    /// COLAMD order instead, see the engine)
    fn column_order(&self) -> Option<Vec<usize>> {
        let np = self.np();
        let n = self.po.dim();
        let mut order = Vec::with_capacity(2 * np + 4);
        for g in 0..np / n {
            order.extend(g * n..(g + 1) * n);
            order.extend(np + 3 + g * n..np + 3 + (g + 1) * n);
        }
        order.extend([np, 2 * np + 3, np + 1, np + 2]);
        Some(order)
    }

    fn weights(&self) -> Vec<f64> {
        let np = self.np();
        let w = self.po.weights();
        let mut v = vec![0.0; 2 * np + 4];
        v[..np + 2].copy_from_slice(&w);
        v[np + 2] = w[np + 1];
        v
    }

    fn accept(&mut self, u: &[f64]) {
        let np = self.np();
        self.sync(u);
        self.po.set_reference(&u[..np + 2]);
        let v = &u[np + 3..];
        let norm = self.inner(v, v).sqrt();
        if norm > 0.0 && norm.is_finite() {
            self.v_ref
                .iter_mut()
                .zip(v)
                .for_each(|(r, x)| *r = x / norm);
        }
    }

    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        if !self.options.multipliers {
            return Ok(None);
        }
        Ok(Some(Stability::from_multipliers(self.multipliers(u)?)))
    }
}
