//! Periodic orbits of ODEs and constant-delay DDEs by orthogonal collocation, their Floquet
//! multipliers, and branch switching from a Hopf point.
//!
//! Time is scaled by the period: s = t/T ∈ [0, 1), x'(s) = T f(x(s), x(s − τ1/T), …; p),
//! with delayed values read off the periodic profile (s − τ/T taken modulo 1, so any ratio
//! τ/T works). The profile is continuous and piecewise polynomial of degree m on L mesh
//! intervals, represented by its values at m + 1 equispaced nodes per interval (shared
//! end nodes, node L·m ≡ node 0). Collocation at the m Gauss–Legendre points of each
//! interval plus the integral phase condition ∫₀¹ ⟨x(s) − x_ref(s), x_ref'(s)⟩ ds = 0 give
//! n·L·m + 1 equations for the n·L·m + 2 unknowns u = [profile, T, p].
//!
//! The free parameter may be a delay: when p moves τ_j (see [`Problem::delay_dp`]) the
//! delayed value x(s − τ_j/T) moves along the profile, and the Jacobian column of p contains
//! ∂τ_j/∂p · J_j(s) x'(s − τ_j/T) besides −T ∂f/∂p.

use crate::block_forward::BlockLowerTriangular;
use crate::collocation::{Basis, MAX_DEGREE, lagrange};
use crate::engine::{ContinuationSystem, NewtonMatrix};
use crate::equilibrium::HopfPoint;
use crate::error::{Error, Result};
use crate::linalg::{Entry, MeshStructure, by_decreasing_modulus, eigenvalues};
use crate::linear_solver::{Factorisation, KRYLOV_MIN_SIZE, LinearSolver, SparseLu};
use crate::problem::Problem;
use crate::stability::{SpecialKind, Stability};
use faer::Mat;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// How many times the kinks of a delay equation's cycle are carried along the delays
/// when the Floquet computation puts mesh points at them (see
/// [`PeriodicOrbitSystem::floquet_multipliers`]): a kink of f at t (a jump of x''') gives a
/// jump of x'''' at t + τ/T, which inside a mesh interval limits degree-4 collocation to
/// O(h⁴); the next generation, a jump of x⁽⁵⁾, is below the collocation's error.
const KINK_GENERATIONS: usize = 2;

/// A kink within this fraction of its mesh interval of an interior mesh point moves that
/// point (otherwise the kink is inserted as a new mesh point).
const KINK_MOVE: f64 = 0.5;

/// How the mesh of a periodic orbit is chosen where a caller refines a point
/// item 2; see [`PeriodicOrbitSystem::adapted_mesh`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MeshAdaptation {
    /// the mesh as given (uniform unless the caller passes one)
    Fixed,
    /// the error density equidistributed and the cycle's kinks on mesh points
    #[default]
    Adapted,
}

/// When the Floquet multipliers of a branch's cycles are computed.
///
/// They cost a dense eigenvalue problem of the size of the discretised monodromy operator
/// (n·(Q·m + 1) for a delay that reaches Q mesh intervals back) at every point: for a
/// delay of the order of the period, most of a branch's cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FloquetMultipliers {
    /// at every point of a branch: its stability, period-doubling and torus points
    #[default]
    EveryPoint,
    /// only when asked ([`PeriodicOrbitSystem::floquet_multipliers`]): the branch's
    /// points carry no stability and no period-doubling or torus points are detected;
    /// folds (from the tangent) and branch points (from the determinant) are. For a
    /// search that needs only the branch's shape, such as the speed of a fold of cycles.
    OnRequest,
}

/// Discretisation of periodic orbits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CollocationOptions {
    /// number of mesh intervals L
    pub intervals: usize,
    /// polynomial degree m (1..=8); m Gauss–Legendre points per interval
    pub degree: usize,
    /// weights of the arclength metric
    pub weights: ArclengthWeights,
    /// how many Floquet multipliers (largest modulus) to keep per point
    pub multipliers_kept: usize,
    /// whether the multipliers are computed at every point of a branch
    #[serde(default)]
    pub floquet_multipliers: FloquetMultipliers,
}

impl Default for CollocationOptions {
    fn default() -> Self {
        Self {
            intervals: 40,
            degree: 4,
            weights: ArclengthWeights::default(),
            multipliers_kept: 12,
            floquet_multipliers: FloquetMultipliers::EveryPoint,
        }
    }
}

/// Weights of the pseudo-arclength metric for periodic orbits: the profile counts as its
/// mean square over the period (each node value weighted by `profile / (L·m)`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ArclengthWeights {
    /// weight of the profile (mean square)
    pub profile: f64,
    /// weight of the period
    pub period: f64,
    /// weight of the free parameter
    pub parameter: f64,
}

impl Default for ArclengthWeights {
    fn default() -> Self {
        Self {
            profile: 1.0,
            period: 1.0,
            parameter: 1.0,
        }
    }
}

/// Periodic-orbit boundary value problem as a continuation system.
#[derive(Debug)]
pub struct PeriodicOrbitSystem<'a, P: Problem> {
    pub(crate) problem: &'a P,
    pub(crate) params: Vec<f64>,
    pub(crate) ip: usize,
    pub(crate) mesh: Vec<f64>,
    pub(crate) basis: Basis,
    pub(crate) options: CollocationOptions,
    /// phase condition: coefficients for the profile and constant
    pub(crate) phase_row: Vec<f64>,
    phase_const: f64,
    /// how the bordered Newton systems are solved
    pub(crate) linear_solver: LinearSolver,
    // scratch
    /// stacked arguments [x(s), x(s − τ1/T), …] of the last `fill_args`
    pub(crate) args: Vec<f64>,
    jac: Vec<f64>,
    fbuf: Vec<f64>,
    fp: Vec<f64>,
    /// dx/ds at the delayed points of the last `fill_args` (n per delay)
    pub(crate) dx: Vec<f64>,
}

/// location of a point of the (extended) mesh
#[derive(Debug, Clone, Copy)]
pub(crate) struct Loc {
    /// interval index (in the extended mesh may be negative or ≥ L)
    q: i64,
    /// base interval q mod L
    pub(crate) base: usize,
    /// local coordinate
    pub(crate) xi: f64,
}

impl Loc {
    /// placeholder before `fill_args` writes the real locations
    pub(crate) const ZERO: Loc = Loc {
        q: 0,
        base: 0,
        xi: 0.0,
    };
}

impl<'a, P: Problem> PeriodicOrbitSystem<'a, P> {
    /// New system on a uniform mesh. `params`: all parameters (entry `ip` is the free one).
    pub fn new(
        problem: &'a P,
        params: Vec<f64>,
        ip: usize,
        options: CollocationOptions,
    ) -> Result<Self> {
        let l = options.intervals;
        let mesh = (0..=l).map(|i| i as f64 / l as f64).collect();
        Self::with_mesh(problem, params, ip, mesh, options)
    }

    /// New system on a given mesh 0 = s_0 < s_1 < … < s_L = 1 (`options.intervals` ignored).
    pub fn with_mesh(
        problem: &'a P,
        params: Vec<f64>,
        ip: usize,
        mesh: Vec<f64>,
        mut options: CollocationOptions,
    ) -> Result<Self> {
        if ip >= params.len() {
            return Err(Error::InvalidInput(format!(
                "free parameter index {ip} out of range ({} parameters)",
                params.len()
            )));
        }
        if options.degree == 0 || options.degree > MAX_DEGREE {
            return Err(Error::InvalidInput(format!(
                "collocation degree {} not in 1..={MAX_DEGREE}",
                options.degree
            )));
        }
        let ok = mesh.len() >= 2
            && mesh[0] == 0.0
            && (mesh[mesh.len() - 1] - 1.0).abs() < 1e-15
            && mesh.windows(2).all(|w| w[1] > w[0]);
        if !ok {
            return Err(Error::InvalidInput(
                "mesh must increase strictly from 0 to 1 with at least one interval".into(),
            ));
        }
        options.intervals = mesh.len() - 1;
        let n = problem.dim();
        let k = problem.n_delays();
        let nprof = n * options.intervals * options.degree;
        Ok(Self {
            problem,
            params,
            ip,
            mesh,
            basis: Basis::new(options.degree),
            options,
            phase_row: vec![0.0; nprof],
            phase_const: 0.0,
            linear_solver: LinearSolver::default(),
            args: vec![0.0; n * (k + 1)],
            jac: vec![0.0; n * n * (k + 1)],
            fbuf: vec![0.0; n],
            fp: vec![0.0; n],
            dx: vec![0.0; n * k.max(1)],
        })
    }

    /// How the bordered Newton systems of this system (and of the curve systems started
    /// from it) are solved (default [`LinearSolver::Auto`]).
    pub fn set_linear_solver(&mut self, solver: LinearSolver) {
        self.linear_solver = solver;
    }

    /// the linear solver of the Newton systems
    pub fn linear_solver(&self) -> LinearSolver {
        self.linear_solver
    }

    /// The mesh structure of a system built on this cycle: profile-sized column blocks at
    /// `column_blocks` and collocation row blocks at `row_blocks` (None unless the linear
    /// solver is [`LinearSolver::Krylov`] or [`LinearSolver::Auto`]).
    pub(crate) fn structure(
        &self,
        column_blocks: Vec<usize>,
        row_blocks: Vec<usize>,
    ) -> Option<MeshStructure> {
        let (min_size, block_forward) = match self.linear_solver {
            LinearSolver::SparseLu => return None,
            LinearSolver::Krylov => (0, false),
            LinearSolver::BlockForward => (usize::MAX, true),
            LinearSolver::Auto => (KRYLOV_MIN_SIZE, true),
        };
        Some(MeshStructure {
            n: self.dim(),
            m: self.degree(),
            intervals: self.intervals(),
            column_blocks,
            row_blocks,
            min_size,
            block_forward,
            basis: self.basis.val.clone(),
        })
    }

    /// state dimension n
    pub fn dim(&self) -> usize {
        self.problem.dim()
    }
    /// number of mesh intervals L
    pub fn intervals(&self) -> usize {
        self.options.intervals
    }
    /// polynomial degree m
    pub fn degree(&self) -> usize {
        self.options.degree
    }
    /// the mesh s_0 … s_L
    pub fn mesh(&self) -> &[f64] {
        &self.mesh
    }
    /// number of profile nodes L·m
    pub fn n_nodes(&self) -> usize {
        self.options.intervals * self.options.degree
    }
    /// index of the period in u
    pub fn period_index(&self) -> usize {
        self.dim() * self.n_nodes()
    }
    /// the period T of u [time units]
    pub fn period(&self, u: &[f64]) -> f64 {
        u[self.period_index()]
    }
    /// amplitude of the profile of u: half the peak-to-peak range of the node values,
    /// largest over the components [state units]
    pub fn amplitude(&self, u: &[f64]) -> f64 {
        let n = self.dim();
        let np = self.period_index();
        (0..n)
            .map(|k| {
                let (lo, hi) = u[k..np]
                    .iter()
                    .step_by(n)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                        (a.min(x), b.max(x))
                    });
                0.5 * (hi - lo)
            })
            .fold(0.0, f64::max)
    }
    /// node positions s of the profile (length L·m)
    pub fn node_times(&self) -> Vec<f64> {
        let m = self.degree();
        (0..self.n_nodes())
            .map(|g| {
                let i = g / m;
                let j = g % m;
                self.mesh[i] + (self.mesh[i + 1] - self.mesh[i]) * j as f64 / m as f64
            })
            .collect()
    }

    /// unknowns u = [profile, T, p] from a function s ↦ x(s) sampled at the nodes
    pub fn unknowns_from(
        &self,
        profile: impl Fn(f64) -> Vec<f64>,
        period: f64,
        parameter: f64,
    ) -> Vec<f64> {
        let mut u: Vec<f64> = self.node_times().into_iter().flat_map(profile).collect();
        u.push(period);
        u.push(parameter);
        u
    }

    fn locate_periodic(&self, s: f64) -> Loc {
        let s = s.rem_euclid(1.0);
        let l = self.options.intervals;
        let i = match self.mesh.binary_search_by(|v| v.total_cmp(&s)) {
            Ok(i) => i.min(l - 1),
            Err(i) => (i - 1).min(l - 1),
        };
        let xi = (s - self.mesh[i]) / (self.mesh[i + 1] - self.mesh[i]);
        Loc {
            q: i as i64,
            base: i,
            xi,
        }
    }

    pub(crate) fn node(&self, base: usize, j: usize) -> usize {
        (base * self.degree() + j) % self.n_nodes()
    }

    /// profile x(s) (s taken modulo 1) of the unknowns u, written to `x`; derivative dx/ds to `dx`
    pub fn eval(&self, u: &[f64], s: f64, x: &mut [f64], dx: &mut [f64]) {
        let n = self.dim();
        let m = self.degree();
        let loc = self.locate_periodic(s);
        let h = self.mesh[loc.base + 1] - self.mesh[loc.base];
        let mut l = [0.0; MAX_DEGREE + 1];
        let mut dl = [0.0; MAX_DEGREE + 1];
        lagrange(m, loc.xi, &mut l, &mut dl);
        x[..n].iter_mut().for_each(|v| *v = 0.0);
        dx[..n].iter_mut().for_each(|v| *v = 0.0);
        for j in 0..=m {
            let g = self.node(loc.base, j);
            for k in 0..n {
                x[k] += l[j] * u[g * n + k];
                dx[k] += dl[j] * u[g * n + k] / h;
            }
        }
    }

    /// maximum over one period of |x_component(s)| (dense sampling plus golden-section refinement)
    pub fn max_abs(&self, u: &[f64], component: usize) -> f64 {
        self.maximum(u, |x| x[component].abs()).1
    }

    /// (s*, g(x(s*))): the maximum over one period of a function `g` of the profile x(s),
    /// sampled at 4 points per node, then refined by golden-section search to ~1e-12 of the
    /// period around the best sample
    fn maximum(&self, u: &[f64], g: impl Fn(&[f64]) -> f64) -> (f64, f64) {
        let n = self.dim();
        let mut x = vec![0.0; n];
        let mut dx = vec![0.0; n];
        let mut f = |s: f64| {
            self.eval(u, s, &mut x, &mut dx);
            g(&x)
        };
        let samples = 4 * self.n_nodes();
        let (mut best_s, mut best) = (0.0, f(0.0));
        for i in 1..samples {
            let s = i as f64 / samples as f64;
            let v = f(s);
            if v > best {
                best = v;
                best_s = s;
            }
        }
        let ds = 1.0 / samples as f64;
        let (mut a, mut b) = (best_s - ds, best_s + ds);
        let ratio = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..60 {
            let c = b - ratio * (b - a);
            let d = a + ratio * (b - a);
            if f(c) > f(d) {
                b = d;
            } else {
                a = c;
            }
        }
        let s = 0.5 * (a + b);
        let v = f(s);
        if v >= best { (s, v) } else { (best_s, best) }
    }

    /// The phase s* ∈ [0, 1) at which profile component `component` is largest: a canonical
    /// phase of the cycle (see [`PeriodicOrbitSystem::shifted`]).
    pub fn canonical_phase(&self, u: &[f64], component: usize) -> f64 {
        self.maximum(u, |x| x[component]).0.rem_euclid(1.0)
    }

    /// The profile part (first n·L·m entries) of `u` shifted in phase by `shift`: the
    /// returned nodes hold x(s + shift). Entries after the profile (period, parameters) are
    /// copied. Shifting by [`PeriodicOrbitSystem::canonical_phase`] puts the maximum of that
    /// component at s = 0, so corrections of the same cycle started from guesses of
    /// different phase, with the shifted solution as the phase reference, solve the same
    /// discretised problem (the discrete cycle depends on its phase relative to the mesh at
    /// the level of the discretisation error).
    pub fn shifted(&self, u: &[f64], shift: f64) -> Vec<f64> {
        let np = self.period_index();
        let times = self.node_times().into_iter().map(|s| s + shift);
        let mut out = self.profile_at(u, times);
        out.extend_from_slice(&u[np..]);
        out
    }

    /// the profile x(s) of the unknowns u at the times s of `times`, one state after the
    /// other (see [`PeriodicOrbitSystem::eval`])
    fn profile_at(&self, u: &[f64], times: impl IntoIterator<Item = f64>) -> Vec<f64> {
        let n = self.dim();
        let mut x = vec![0.0; n];
        let mut dx = vec![0.0; n];
        times
            .into_iter()
            .flat_map(|s| {
                self.eval(u, s, &mut x, &mut dx);
                x.clone()
            })
            .collect()
    }

    /// the same system (problem, parameters, free parameter and options) on `mesh`
    fn on_mesh(&self, mesh: Vec<f64>) -> Result<Self> {
        Self::with_mesh(
            self.problem,
            self.params.clone(),
            self.ip,
            mesh,
            self.options.clone(),
        )
    }

    /// The same system (problem, free parameter, mesh and options) at `params`, with its
    /// phase reference set to the profile `orbit`: the cycle of a two-parameter curve's
    /// point as a one-parameter cycle system.
    pub fn at(&self, params: Vec<f64>, orbit: &[f64]) -> Result<Self> {
        let mut po = Self::with_mesh(
            self.problem,
            params,
            self.ip,
            self.mesh.clone(),
            self.options.clone(),
        )?;
        po.linear_solver = self.linear_solver;
        po.set_reference(orbit);
        Ok(po)
    }

    /// Set the phase-condition reference to the profile of `u`.
    pub fn set_reference(&mut self, u: &[f64]) {
        let n = self.dim();
        let m = self.degree();
        let mut x = vec![0.0; n];
        let mut dx = vec![0.0; n];
        self.phase_row.iter_mut().for_each(|v| *v = 0.0);
        self.phase_const = 0.0;
        for i in 0..self.intervals() {
            let h = self.mesh[i + 1] - self.mesh[i];
            for c in 0..m {
                let s = self.mesh[i] + h * self.basis.xi[c];
                self.eval(u, s, &mut x, &mut dx);
                let wc = self.basis.w[c] * h;
                for j in 0..=m {
                    let g = self.node(i, j);
                    let lj = self.basis.val[c * (m + 1) + j];
                    for k in 0..n {
                        self.phase_row[g * n + k] += wc * lj * dx[k];
                    }
                }
                self.phase_const -= wc * (0..n).map(|k| x[k] * dx[k]).sum::<f64>();
            }
        }
    }

    pub(crate) fn set_params(&mut self, u: &[f64]) {
        self.params[self.ip] = u[u.len() - 1];
    }

    pub(crate) fn delays(&self) -> Vec<f64> {
        (0..self.problem.n_delays())
            .map(|j| self.problem.delay(j, &self.params))
            .collect()
    }

    /// Fill `args` with x(s_c) and the delayed values for collocation point c of interval i;
    /// returns the locations of the delayed values (periodic wrapping).
    pub(crate) fn fill_args(
        &mut self,
        u: &[f64],
        i: usize,
        c: usize,
        period: f64,
        delays: &[f64],
        locs: &mut [Loc],
    ) {
        let n = self.dim();
        let m = self.degree();
        let h = self.mesh[i + 1] - self.mesh[i];
        let s = self.mesh[i] + h * self.basis.xi[c];
        for k in 0..n {
            self.args[k] = (0..=m)
                .map(|j| self.basis.val[c * (m + 1) + j] * u[self.node(i, j) * n + k])
                .sum();
        }
        let mut l = [0.0; MAX_DEGREE + 1];
        let mut dl = [0.0; MAX_DEGREE + 1];
        for (d, &tau) in delays.iter().enumerate() {
            let loc = self.locate_periodic(s - tau / period);
            let hd = self.mesh[loc.base + 1] - self.mesh[loc.base];
            lagrange(m, loc.xi, &mut l, &mut dl);
            for k in 0..n {
                let mut v = 0.0;
                let mut dv = 0.0;
                for j in 0..=m {
                    let x = u[self.node(loc.base, j) * n + k];
                    v += l[j] * x;
                    dv += dl[j] * x / hd;
                }
                self.args[(d + 1) * n + k] = v;
                self.dx[d * n + k] = dv;
            }
            locs[d] = loc;
        }
    }

    /// Times s ∈ [0, 1) where a switching function of the problem changes sign along the
    /// profile of u (the kinks of a piecewise-smooth right-hand side), located by sampling
    /// and bisection to 1e-13.
    pub fn switching_times(&mut self, u: &[f64]) -> Vec<f64> {
        let ns = self.problem.n_switching();
        if ns == 0 {
            return Vec::new();
        }
        let n = self.dim();
        let k = self.problem.n_delays();
        self.set_params(u);
        let period = self.period(u);
        let delays = self.delays();
        let mut args = vec![0.0; n * (k + 1)];
        let mut x = vec![0.0; n];
        let mut dx = vec![0.0; n];
        let mut g = vec![0.0; ns];
        let mut eval_g = |s: f64, g: &mut [f64]| {
            self.eval(u, s, &mut x, &mut dx);
            args[..n].copy_from_slice(&x);
            for (d, &tau) in delays.iter().enumerate() {
                self.eval(u, s - tau / period, &mut x, &mut dx);
                args[(d + 1) * n..(d + 2) * n].copy_from_slice(&x);
            }
            self.problem.switching(&args, &self.params, g);
        };
        let samples = 2 * self.n_nodes();
        let mut prev = vec![0.0; ns];
        eval_g(0.0, &mut prev);
        let mut out = Vec::new();
        for i in 1..=samples {
            let s1 = i as f64 / samples as f64;
            eval_g(s1, &mut g);
            for j in 0..ns {
                if prev[j] * g[j] < 0.0 || (g[j] == 0.0 && prev[j] != 0.0) {
                    // bisection on [s0, s1] for function j
                    let (mut a, mut b) = (s1 - 1.0 / samples as f64, s1);
                    let ga = prev[j];
                    let mut tmp = vec![0.0; ns];
                    for _ in 0..60 {
                        let mid = 0.5 * (a + b);
                        eval_g(mid, &mut tmp);
                        if tmp[j] * ga > 0.0 {
                            a = mid;
                        } else {
                            b = mid;
                        }
                        if b - a < 1e-13 {
                            break;
                        }
                    }
                    out.push((0.5 * (a + b)).rem_euclid(1.0));
                }
            }
            prev.copy_from_slice(&g);
        }
        out.sort_by(f64::total_cmp);
        out
    }

    /// Floquet multipliers of the periodic orbit u (eigenvalues of the discretised
    /// monodromy operator, sorted by decreasing modulus, at most `multipliers_kept`).
    ///
    /// The linearised equation y'(s) = T·(A0(s) y(s) + Σ_j A_j(s) y(s − τ_j/T)) is
    /// collocated on the orbit's mesh. For a problem with switching functions (kinks of
    /// the right-hand side) the cycle is first corrected on a mesh with points at its
    /// switching times and, for a delay equation, at those times carried along the delays
    /// twice (where the kinks reappear in higher derivatives), and the monodromy computed
    /// there (one factorisation and a chord step or two per cycle, and the multipliers
    /// read off a factorisation of that system's Newton matrix at the corrected cycle):
    /// without, the multipliers of a
    /// piecewise-smooth problem converge only like a low power of h, and the trivial
    /// multiplier of a cycle computed on one mesh but linearised on another is off by the
    /// cycle's error on the second mesh (3.5e-5 on the trailer's sway branch at L = 40).
    /// Measured on the trailer's delayed closed loop (τ = 0.2 s, D = 0.1 s): the trivial
    /// multiplier within 1.6e-7 of 1 on L = 40 (2.5e-4 with mesh points at the switching
    /// times only, L = 20). The linearised equation is solved for the node values on
    /// [0, 1] given those on the history interval [−τ_max/T, 0] (ODE: the single node at
    /// s = 0); the map from history to the shifted history [1 − τ_max/T, 1] is the discretised
    /// monodromy operator (ODE: the monodromy matrix). Where a block-forward factorisation
    /// of the Newton matrix at u exists (the kink-resolved cycle's; on a continuation
    /// branch of a smooth problem the corrector's, through
    /// [`ContinuationSystem::stability_from`]) and every delay is shorter than the period
    /// less two mesh intervals, the operator is read off it (the block-forward solver's
    /// copies as the history) instead of assembled: the same numbers to rounding (1e-13 on
    /// the trailer's cycles).
    pub fn floquet_multipliers(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        self.floquet_multipliers_from(u, None)
    }

    /// [`PeriodicOrbitSystem::floquet_multipliers`], read off `newton` (a factorisation of
    /// this system's Newton matrix at u) where the problem is smooth
    fn floquet_multipliers_from(
        &mut self,
        u: &[f64],
        newton: Option<&SparseLu>,
    ) -> Result<Vec<Complex64>> {
        if self.problem.n_switching() == 0 {
            return self.monodromy_multipliers(u, newton);
        }
        match self.kink_resolved(u) {
            Ok((mut sys, orbit, newton)) => sys.monodromy_multipliers(&orbit, Some(&newton)),
            Err(_) => {
                // the correction failed: the switching times only inserted into the mesh
                // (the cycle's polynomial pieces unchanged, split there)
                let hmin = self
                    .mesh
                    .windows(2)
                    .map(|w| w[1] - w[0])
                    .fold(f64::INFINITY, f64::min);
                let mut fmesh = self.mesh.clone();
                for s in self.switching_times(u) {
                    if fmesh.iter().all(|q| (q - s).abs() > 1e-6 * hmin) && s > 0.0 && s < 1.0 {
                        fmesh.push(s);
                    }
                }
                fmesh.sort_by(f64::total_cmp);
                let mut target = self.on_mesh(fmesh)?;
                let orbit = self.remesh(u, &target);
                target.monodromy_multipliers(&orbit, None)
            }
        }
    }

    /// The times s ∈ [0, 1) where the profile of u has kinks: the switching times
    /// ([`PeriodicOrbitSystem::switching_times`], where f is only C¹) and, for a delay
    /// equation, those times carried along the delays up to `generations` times
    /// (t + Σ τ_j/T mod 1 over at most `generations` delays): x(s − τ/T) enters f, so a
    /// derivative jump of x at t reappears one order higher at t + τ/T. Sorted.
    fn kink_times(&mut self, u: &[f64], generations: usize) -> Vec<f64> {
        let mut times = self.switching_times(u);
        let period = self.period(u);
        let shifts: Vec<f64> = self.delays().iter().map(|tau| tau / period).collect();
        let mut generation = times.clone();
        for _ in 0..generations {
            let next: Vec<f64> = generation
                .iter()
                .flat_map(|t| shifts.iter().map(move |d| (t + d).rem_euclid(1.0)))
                .collect();
            times.extend_from_slice(&next);
            generation = next;
        }
        times.sort_by(f64::total_cmp);
        times
    }

    /// The mesh s_0 … s_L with the times `times` resolved: the interior mesh point nearest
    /// to a time (within [`KINK_MOVE`] of its interval) is moved there unless another time
    /// moved it already, otherwise the time is inserted (times within 1e-9 of the interval
    /// length of a mesh point are resolved already). Moving keeps the kink mesh as small as
    /// the orbit's: measured on the delayed closed loop (τ = 0.2 s, D = 0.1 s, L = 40, 18
    /// kink times) the trivial multiplier within 1.6e-7 of 1 (9.4e-8 moving only within a
    /// fifth of an interval and inserting the others).
    fn mesh_with_points(mesh: &[f64], times: &[f64]) -> Vec<f64> {
        let mut out = mesh.to_vec();
        let mut moved = vec![false; out.len()];
        let mut inserted = Vec::new();
        let l = mesh.len() - 1;
        for &t in times.iter().filter(|&&t| t > 0.0 && t < 1.0) {
            let i = match mesh.binary_search_by(|v| v.total_cmp(&t)) {
                Ok(_) => continue,
                Err(i) => i - 1,
            };
            let h = mesh[i + 1] - mesh[i];
            let (near, d) = if t - mesh[i] < mesh[i + 1] - t {
                (i, t - mesh[i])
            } else {
                (i + 1, mesh[i + 1] - t)
            };
            if d <= 1e-9 * h {
                continue;
            }
            if near > 0 && near < l && d < KINK_MOVE * h && !moved[near] {
                out[near] = t;
                moved[near] = true;
            } else {
                inserted.push(t);
            }
        }
        out.extend(inserted);
        out.sort_by(f64::total_cmp);
        out.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        out
    }

    /// A mesh of `intervals` intervals adapted to the cycle u: the
    /// collocation error of degree m on an interval of length h is ≈ C·h^(m+1)·|x^(m+1)|,
    /// so the mesh equidistributes the error density |x^(m+1)(s)|^(1/(m+1)) (estimated
    /// from the jumps of the piecewise constant m-th derivative between neighbouring
    /// intervals, each component scaled by its amplitude, as AUTO and DDE-Biftool do), with
    /// a floor of a fifth of its mean so that no interval grows beyond ~5× the uniform one;
    /// then the cycle's switching times (the kinks of f) are made mesh points (the nearest
    /// point moved there, or one inserted: the mesh may end with a few more intervals than
    /// asked for). On such a mesh a piecewise-smooth cycle keeps the collocation's order.
    ///
    /// Measured on the fold of cycles of the trailer (degree 4; L = 40 against L = 160,
    /// both adapted): open loop 9.6e-13 relative (uniform mesh: 1.5e-6); delayed closed
    /// loop τ = 0.2 s, D = 0.1 s: 5e-10 (equidistribution without the kinks: 6e-7 off).
    /// The kinks' images along the delays (mesh points at t + τ/T, as the Floquet
    /// computation uses) are not added: with them the delayed loop's fold moved by 5e-4
    /// and did not converge with L — unexplained, see the notes.
    pub fn adapted_mesh(&mut self, u: &[f64], intervals: usize) -> Vec<f64> {
        let density = self.error_density(u);
        let mesh = equidistributed(&self.mesh, &density, intervals.max(1));
        let kinks = self.switching_times(u);
        Self::mesh_with_points(&mesh, &kinks)
    }

    /// The error density |x^(m+1)|^(1/(m+1)) per mesh interval (see
    /// [`PeriodicOrbitSystem::adapted_mesh`]), largest over the components scaled by their
    /// amplitude.
    fn error_density(&self, u: &[f64]) -> Vec<f64> {
        let (n, m, l) = (self.dim(), self.degree(), self.intervals());
        let np = self.period_index();
        let scale: Vec<f64> = (0..n)
            .map(|k| {
                let a = u[k..np]
                    .iter()
                    .step_by(n)
                    .fold(0.0f64, |a, x| a.max(x.abs()));
                if a > 0.0 { a } else { 1.0 }
            })
            .collect();
        // the m-th derivative on interval i: m^m Δ^m x / h^m (equispaced nodes j/m)
        let mut binomial = vec![1.0; m + 1];
        for j in 1..=m {
            binomial[j] = binomial[j - 1] * (m + 1 - j) as f64 / j as f64;
        }
        let h: Vec<f64> = self.mesh.windows(2).map(|w| w[1] - w[0]).collect();
        let derivative: Vec<f64> = (0..l)
            .flat_map(|i| {
                let factor = (m as f64 / h[i]).powi(m as i32);
                let (binomial, scale) = (&binomial, &scale);
                (0..n).map(move |k| {
                    let diff: f64 = (0..=m)
                        .map(|j| {
                            let sign = if (m - j) % 2 == 0 { 1.0 } else { -1.0 };
                            sign * binomial[j] * u[self.node(i, j) * n + k]
                        })
                        .sum();
                    factor * diff / scale[k]
                })
            })
            .collect();
        (0..l)
            .map(|i| {
                let (prev, next) = ((i + l - 1) % l, (i + 1) % l);
                let slope = |a: usize, b: usize, k: usize| {
                    (derivative[b * n + k] - derivative[a * n + k]).abs() / (0.5 * (h[a] + h[b]))
                };
                let d = (0..n)
                    .map(|k| 0.5 * (slope(prev, i, k) + slope(i, next, k)))
                    .fold(0.0f64, f64::max);
                d.powf(1.0 / (m + 1) as f64)
            })
            .collect()
    }

    /// The cycle u corrected on a mesh with points at its kinks: the orbit mesh with the
    /// kink times of u resolved ([`PeriodicOrbitSystem::kink_times`],
    /// [`PeriodicOrbitSystem::mesh_with_points`]), the cycle interpolated there and corrected
    /// by chord Newton with the parameter fixed. On such a mesh the collocation keeps its
    /// order (a kink inside an interval limits it to O(h³)), and the corrected cycle solves
    /// the discretisation on which its monodromy is computed, so that the trivial
    /// multiplier is 1 to that order. One round suffices: the corrected cycle's kinks differ
    /// from u's by the cycle's error (≲ 1e-4 of the period), and a kink that far inside an
    /// interval costs the collocation its cube, below 1e-12. The interpolated cycle is
    /// within the collocation error (~1e-7) of the corrected one, so that one factorisation
    /// and a chord step or two converge (a factorisation kept from the neighbouring cycle
    /// of a branch was tried: its kink mesh differs topologically often enough that the
    /// chord iteration diverged and cost more than it saved). Returns the system on the
    /// kink mesh and the corrected cycle.
    fn kink_resolved(&mut self, u: &[f64]) -> Result<(Self, Vec<f64>, SparseLu)> {
        let times = self.kink_times(u, KINK_GENERATIONS);
        let mesh = Self::mesh_with_points(&self.mesh, &times);
        let mut target = self.on_mesh(mesh)?;
        target.linear_solver = self.linear_solver;
        let v = self.remesh(u, &target);
        target.set_reference(&v);
        let nu = v.len();
        let mut e = vec![0.0; nu];
        e[nu - 1] = 1.0;
        let (v, newton) = crate::engine::correct_with_chord(&mut target, &v, &e, 1e-10, 12)?;
        Ok((target, v, newton))
    }

    /// Floquet multipliers from the discretised monodromy operator on this system's mesh
    /// (see [`PeriodicOrbitSystem::floquet_multipliers`]): read off `newton`, a block-forward
    /// factorisation of this system's Newton matrix at u, where there is one and every delay
    /// is shorter than the period less two of the longest mesh intervals
    /// ([`crate::block_forward::ForwardMonodromy`]), else from the initial-value collocation
    /// assembled here.
    fn monodromy_multipliers(
        &mut self,
        u: &[f64],
        newton: Option<&SparseLu>,
    ) -> Result<Vec<Complex64>> {
        self.set_params(u);
        let kept = self.options.multipliers_kept.max(self.dim());
        let longest_step = self
            .mesh
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(0.0, f64::max);
        let period = self.period(u);
        let delays = self.delays();
        let tau_max = delays.iter().fold(0.0f64, |a, &b| a.max(b / period));
        let delays_fit = delays.is_empty() || tau_max < 1.0 - 2.0 * longest_step;
        if let Some(monodromy) = newton.and_then(SparseLu::forward_monodromy)
            && delays_fit
        {
            let dim = monodromy.dim();
            let dense = || {
                let m = monodromy.dense();
                Ok(Mat::<f64>::from_fn(dim, dim, |r, c| m[r * dim + c]))
            };
            return dominant_multipliers(dim, kept, dense, |v, w| monodromy.apply(v, w));
        }
        let n = self.dim();
        let m = self.degree();
        let k = self.problem.n_delays();
        let fmesh = self.mesh.clone();
        let l = fmesh.len() - 1;
        let locate = |s: f64| -> Loc {
            let kk = s.floor();
            let r = s - kk;
            let (kk, r) = if r >= 1.0 { (kk + 1.0, 0.0) } else { (kk, r) };
            let i = match fmesh.binary_search_by(|v| v.total_cmp(&r)) {
                Ok(i) => i.min(l - 1),
                Err(i) => (i - 1).min(l - 1),
            };
            Loc {
                q: i as i64 + kk as i64 * l as i64,
                base: i,
                xi: (r - fmesh[i]) / (fmesh[i + 1] - fmesh[i]),
            }
        };
        // number of history intervals Q: start(−Q) ≤ −τ_max/T
        let start = |q: i64| -> f64 {
            q.div_euclid(l as i64) as f64 + fmesh[q.rem_euclid(l as i64) as usize]
        };
        let mut qh: i64 = 0;
        while start(-qh) > -tau_max + 1e-13 {
            qh += 1;
        }
        let nh = qh as usize * m + 1; // history nodes (extended indices 0..nh)
        let np = l * m; // nodes solved for
        let ext = |q: i64, j: usize| -> usize { ((q + qh) as usize) * m + j };
        let mut ap: Vec<Entry> = Vec::new();
        // the history's coupling, moved to the right-hand side: (row, history column, value)
        let mut ah: Vec<(usize, usize, f64)> = Vec::new();
        let nc = n * (k + 1);
        let mut l_d = [0.0; MAX_DEGREE + 1];
        let mut dl_d = [0.0; MAX_DEGREE + 1];
        let mut x = vec![0.0; n];
        let mut dx = vec![0.0; n];
        let push =
            |row: usize, e: usize, kk: usize, v: f64, ap: &mut Vec<Entry>, ah: &mut Vec<_>| {
                if e < nh {
                    ah.push((row, e * n + kk, -v));
                } else {
                    ap.push(Entry::new(row, (e - nh) * n + kk, v));
                }
            };
        for i in 0..l {
            let h = fmesh[i + 1] - fmesh[i];
            for c in 0..m {
                let s = fmesh[i] + h * self.basis.xi[c];
                self.eval(u, s, &mut x, &mut dx);
                self.args[..n].copy_from_slice(&x);
                for (d, &tau) in delays.iter().enumerate() {
                    self.eval(u, s - tau / period, &mut x, &mut dx);
                    self.args[(d + 1) * n..(d + 2) * n].copy_from_slice(&x);
                }
                self.problem
                    .jacobian(&self.args, &self.params, &mut self.jac);
                let row0 = (i * m + c) * n;
                for j in 0..=m {
                    let e = ext(i as i64, j);
                    let lv = self.basis.val[c * (m + 1) + j];
                    let dv = self.basis.der[c * (m + 1) + j] / h;
                    for r in 0..n {
                        for kk in 0..n {
                            let mut v = -period * self.jac[r * nc + kk] * lv;
                            if r == kk {
                                v += dv;
                            }
                            push(row0 + r, e, kk, v, &mut ap, &mut ah);
                        }
                    }
                }
                for (d, &tau) in delays.iter().enumerate() {
                    let mut loc = locate(s - tau / period);
                    if loc.q < -qh {
                        // rounding at the left end of the history interval
                        loc.q = -qh;
                        loc.xi = 0.0;
                    }
                    lagrange(m, loc.xi, &mut l_d, &mut dl_d);
                    for j in 0..=m {
                        let e = ext(loc.q, j);
                        for r in 0..n {
                            for kk in 0..n {
                                let v = -period * self.jac[r * nc + (d + 1) * n + kk] * l_d[j];
                                push(row0 + r, e, kk, v, &mut ap, &mut ah);
                            }
                        }
                    }
                }
            }
        }
        if !ap.iter().all(|e| e.val.is_finite()) {
            return Err(Error::NonFinite {
                parameter: u[u.len() - 1],
            });
        }
        let monodromy = Monodromy::new(n, m, np, nh, ap, ah);
        dominant_multipliers(
            monodromy.dim(),
            kept,
            || monodromy.dense(),
            |v, w| monodromy.apply(v, w),
        )
    }

    /// Interpolate the solution `u` of this system onto the mesh of `target`
    /// (for mesh refinement); period and parameter are copied.
    pub fn remesh(&self, u: &[f64], target: &PeriodicOrbitSystem<'_, P>) -> Vec<f64> {
        let mut v = self.profile_at(u, target.node_times());
        v.push(self.period(u));
        v.push(u[u.len() - 1]);
        v
    }

    /// Initial guess and start direction for branch switching at a Hopf point: the profile
    /// x* + A·Re(v e^{2πis}) with the critical eigenvector v, period 2π/ω, parameter p*.
    /// Pass both to [`crate::Continuation::start`]: the corrector keeps the amplitude along
    /// v fixed and solves for the parameter and period (this also works for non-smooth Hopf
    /// points where the amplitude grows linearly with |p − p*|). Sets the phase reference.
    pub fn hopf_guess(&mut self, hopf: &HopfPoint, amplitude: f64) -> (Vec<f64>, Vec<f64>) {
        let two_pi = 2.0 * std::f64::consts::PI;
        let v = hopf.eigenvector.clone();
        let dir = |s: f64| -> Vec<f64> {
            let e = Complex64::new(0.0, two_pi * s).exp();
            v.iter().map(|z| (z * e).re).collect()
        };
        let guess = self.unknowns_from(
            |s| {
                dir(s)
                    .iter()
                    .zip(&hopf.state)
                    .map(|(d, x)| x + amplitude * d)
                    .collect()
            },
            two_pi / hopf.omega,
            hopf.parameter,
        );
        let mut direction = self.unknowns_from(dir, 0.0, 0.0);
        let nu = direction.len();
        direction[nu - 2] = 0.0;
        direction[nu - 1] = 0.0;
        self.set_reference(&guess);
        (guess, direction)
    }
}

impl<P: Problem> ContinuationSystem for PeriodicOrbitSystem<'_, P> {
    fn n_unknowns(&self) -> usize {
        self.dim() * self.n_nodes() + 2
    }
    fn parameter_index(&self) -> usize {
        self.dim() * self.n_nodes() + 1
    }

    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        let n = self.dim();
        let m = self.degree();
        self.set_params(u);
        let period = self.period(u);
        let delays = self.delays();
        let mut locs = vec![Loc::ZERO; delays.len()];
        for i in 0..self.intervals() {
            let h = self.mesh[i + 1] - self.mesh[i];
            for c in 0..m {
                self.fill_args(u, i, c, period, &delays, &mut locs);
                self.problem.rhs(&self.args, &self.params, &mut self.fbuf);
                let row0 = (i * m + c) * n;
                for k in 0..n {
                    let d: f64 = (0..=m)
                        .map(|j| self.basis.der[c * (m + 1) + j] * u[self.node(i, j) * n + k])
                        .sum();
                    r[row0 + k] = d / h - period * self.fbuf[k];
                }
            }
        }
        let np = self.n_nodes() * n;
        r[np] = self
            .phase_row
            .iter()
            .zip(&u[..np])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            + self.phase_const;
        if r[..=np].iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                parameter: u[u.len() - 1],
            })
        }
    }

    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let n = self.dim();
        let m = self.degree();
        let k = self.problem.n_delays();
        self.set_params(u);
        let period = self.period(u);
        let delays = self.delays();
        // ∂τ_d/∂p of the free parameter: a delay may be the free parameter
        let dtau: Vec<f64> = (0..k)
            .map(|d| self.problem.delay_dp(d, &self.params, self.ip))
            .collect();
        let it = self.period_index();
        let ipu = it + 1;
        let nc = n * (k + 1);
        let mut locs = vec![Loc::ZERO; k];
        let mut l_d = [0.0; MAX_DEGREE + 1];
        let mut dl_d = [0.0; MAX_DEGREE + 1];
        for i in 0..self.intervals() {
            let h = self.mesh[i + 1] - self.mesh[i];
            for c in 0..m {
                self.fill_args(u, i, c, period, &delays, &mut locs);
                self.problem.rhs(&self.args, &self.params, &mut self.fbuf);
                self.problem
                    .jacobian(&self.args, &self.params, &mut self.jac);
                self.problem
                    .dfdp(&self.args, &self.params, self.ip, &mut self.fp);
                let row0 = (i * m + c) * n;
                for j in 0..=m {
                    let g = self.node(i, j);
                    let lv = self.basis.val[c * (m + 1) + j];
                    let dv = self.basis.der[c * (m + 1) + j] / h;
                    for r in 0..n {
                        for kk in 0..n {
                            let mut v = -period * self.jac[r * nc + kk] * lv;
                            if r == kk {
                                v += dv;
                            }
                            entries.push(Entry::new(row0 + r, g * n + kk, v));
                        }
                    }
                }
                for d in 0..k {
                    let loc = locs[d];
                    lagrange(m, loc.xi, &mut l_d, &mut dl_d);
                    for j in 0..=m {
                        let g = self.node(loc.base, j);
                        for r in 0..n {
                            for kk in 0..n {
                                let v = -period * self.jac[r * nc + (d + 1) * n + kk] * l_d[j];
                                entries.push(Entry::new(row0 + r, g * n + kk, v));
                            }
                        }
                    }
                }
                for r in 0..n {
                    // ∂/∂T: −f − T Σ_d J_d x'(s_d) τ_d/T²;
                    // ∂/∂p: −T f_p + Σ_d J_d x'(s_d) ∂τ_d/∂p (x(s − τ(p)/T) moves with τ)
                    let mut dt = -self.fbuf[r];
                    let mut dp = -period * self.fp[r];
                    for (d, &tau) in delays.iter().enumerate() {
                        let jd: f64 = (0..n)
                            .map(|kk| self.jac[r * nc + (d + 1) * n + kk] * self.dx[d * n + kk])
                            .sum();
                        dt -= jd * tau / period;
                        dp += jd * dtau[d];
                    }
                    entries.push(Entry::new(row0 + r, it, dt));
                    entries.push(Entry::new(row0 + r, ipu, dp));
                }
            }
        }
        let np = self.n_nodes() * n;
        for (j, &v) in self.phase_row.iter().enumerate() {
            if v != 0.0 {
                entries.push(Entry::new(np, j, v));
            }
        }
        if entries.iter().all(|e| e.val.is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                parameter: u[u.len() - 1],
            })
        }
    }

    /// natural order: the unknowns are stored interval by interval, the border (period,
    /// parameter) last, so the LU's fill stays inside the band of the delay couplings and the
    /// periodic wrap-around border (measured faster than COLAMD, see benches/collocation.rs)
    fn column_order(&self) -> Option<Vec<usize>> {
        Some((0..self.n_unknowns()).collect())
    }

    /// an ODE's collocation is banded in the natural order (up to the periodic wrap and
    /// the borders); a delay equation's reaches τ/T of the period back
    fn banded(&self) -> bool {
        self.problem.n_delays() == 0
    }

    fn mesh_structure(&self) -> Option<MeshStructure> {
        self.structure(vec![0], vec![0])
    }

    fn weights(&self) -> Vec<f64> {
        let w = self.options.weights;
        let np = self.dim() * self.n_nodes();
        let mut v = vec![w.profile / self.n_nodes() as f64; np + 2];
        v[np] = w.period;
        v[np + 1] = w.parameter;
        v
    }

    fn accept(&mut self, u: &[f64]) {
        self.set_reference(u);
    }

    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        self.stability_from(u, NewtonMatrix::default())
    }

    fn stability_from(&mut self, u: &[f64], newton: NewtonMatrix<'_>) -> Result<Option<Stability>> {
        if self.options.floquet_multipliers == FloquetMultipliers::OnRequest {
            return Ok(None);
        }
        Ok(Some(Stability::from_multipliers(
            self.floquet_multipliers_from(u, newton.0)?,
        )))
    }

    fn classify(&self, a: &Stability, b: &Stability) -> Option<SpecialKind> {
        Stability::multiplier_crossing(a, b)
    }

    fn test_function(&mut self, kind: SpecialKind, u: &[f64]) -> Result<Option<f64>> {
        let s = Stability::from_multipliers(self.floquet_multipliers(u)?);
        Ok(match kind {
            SpecialKind::PeriodDoubling | SpecialKind::Torus => {
                s.critical(kind).map(|z| z.norm() - 1.0)
            }
            _ => None,
        })
    }
}

/// The mesh of `intervals` intervals on which the piecewise constant `density` (one value
/// per interval of `mesh`, floored at a fifth of its mean) has equal integrals.
fn equidistributed(mesh: &[f64], density: &[f64], intervals: usize) -> Vec<f64> {
    let h: Vec<f64> = mesh.windows(2).map(|w| w[1] - w[0]).collect();
    let mean: f64 = density.iter().zip(&h).map(|(d, h)| d * h).sum();
    let floor = 0.2 * mean;
    let phi: Vec<f64> = density
        .iter()
        .map(|&d| if d.is_finite() { d.max(floor) } else { floor })
        .collect();
    let total: f64 = phi.iter().zip(&h).map(|(p, h)| p * h).sum();
    if !(total > 0.0 && total.is_finite()) {
        return (0..=intervals)
            .map(|i| i as f64 / intervals as f64)
            .collect();
    }
    let mut out = Vec::with_capacity(intervals + 1);
    out.push(0.0);
    let (mut i, mut below) = (0, 0.0);
    for k in 1..intervals {
        let target = total * k as f64 / intervals as f64;
        while i + 1 < h.len() && below + phi[i] * h[i] < target {
            below += phi[i] * h[i];
            i += 1;
        }
        let s = mesh[i] + (target - below) / phi[i];
        out.push(s.clamp(mesh[i], mesh[i + 1]));
    }
    out.push(1.0);
    out.dedup_by(|a, b| *a - *b <= 1e-12);
    out
}

/// The `kept` multipliers of largest modulus of a discretised monodromy operator of size
/// `dim`, sorted by decreasing modulus: all eigenvalues of its matrix (`dense`) below
/// [`ARNOLDI_MIN_SIZE`], else Arnoldi's on its products (`apply`).
fn dominant_multipliers(
    dim: usize,
    kept: usize,
    dense: impl FnOnce() -> Result<Mat<f64>>,
    apply: impl FnMut(&[f64], &mut [f64]),
) -> Result<Vec<Complex64>> {
    let mut mu = if dim < ARNOLDI_MIN_SIZE {
        eigenvalues(&dense()?)?
    } else {
        crate::linalg::dominant_eigenvalues(dim, kept, apply)?
    };
    mu.sort_by(by_decreasing_modulus);
    mu.truncate(kept);
    Ok(mu)
}

/// Monodromy matrices of at least this size are not formed: their dominant eigenvalues come
/// from Arnoldi's method on the operator (one block forward solve per product), so the cost
/// grows linearly in the mesh for a fixed τ/T instead of cubically. Measured on the
/// closed-loop diagram (τ = 0.2 s, D = 0.1 s; operators of size 28–52 at L = 40, 68–124
/// at L = 120): from 128 down to 40, L = 120 2.56 → 2.17 s, L = 40 0.67 → 0.64 s (24 and
/// 60 within the noise of 40).
const ARNOLDI_MIN_SIZE: usize = 40;

/// The monodromy operator of a cycle's collocation: the history (nh nodes of n components
/// on [−τ_max/T, 0]) carried over one period by the initial-value collocation (np nodes
/// after the history, block lower triangular in the natural order).
struct Monodromy {
    n: usize,
    np: usize,
    nh: usize,
    /// the collocation, factorised by blocks (None if a block is singular)
    lu: Option<BlockLowerTriangular>,
    /// the collocation's triplets (for the sparse fallback where a block is singular)
    ap: Vec<Entry>,
    /// the history's coupling on the right-hand side, by rows
    history: crate::linalg::Csr,
}

impl Monodromy {
    fn new(
        n: usize,
        m: usize,
        np: usize,
        nh: usize,
        ap: Vec<Entry>,
        history: Vec<(usize, usize, f64)>,
    ) -> Self {
        let size = n * np;
        let lu = BlockLowerTriangular::new(size, m * n, ap.iter().map(|e| (e.row, e.col, e.val)));
        Self {
            n,
            np,
            nh,
            lu,
            ap,
            history: crate::linalg::Csr::by_rows(size, &history),
        }
    }

    /// the size of the history: n·nh
    fn dim(&self) -> usize {
        self.n * self.nh
    }

    /// the new history from the solved profile x and the old history h (both row-major,
    /// `cols` columns side by side): the nodes still inside the old history shift
    fn new_history(&self, x: &[f64], h: &[f64], cols: usize, out: &mut [f64]) {
        let n = self.n;
        for e_new in 0..self.nh {
            let e_old = e_new + self.np;
            for r in 0..n {
                let dst = &mut out[(e_new * n + r) * cols..(e_new * n + r + 1) * cols];
                let src = if e_old < self.nh {
                    &h[(e_old * n + r) * cols..(e_old * n + r + 1) * cols]
                } else {
                    let row = (e_old - self.nh) * n + r;
                    &x[row * cols..(row + 1) * cols]
                };
                dst.copy_from_slice(src);
            }
        }
    }

    /// w = M v: one block forward solve (NaN if a block is singular)
    fn apply(&self, v: &[f64], w: &mut [f64]) {
        let mut x = vec![0.0; self.n * self.np];
        self.history.mul_add(v, &mut x);
        match &self.lu {
            Some(lu) => lu.solve_rows(&mut x, 1),
            None => x.iter_mut().for_each(|v| *v = f64::NAN),
        }
        self.new_history(&x, v, 1, w);
    }

    /// the dense monodromy matrix
    fn dense(&self) -> Result<Mat<f64>> {
        let (size, dim) = (self.n * self.np, self.dim());
        let what = "monodromy (collocation)";
        let mut x = vec![0.0; size * dim];
        for r in 0..size {
            for (c, v) in self.history.row(r) {
                x[r * dim + c] += v;
            }
        }
        match &self.lu {
            Some(lu) => lu.solve_rows(&mut x, dim),
            None => {
                // a singular block: the sparse LU of the whole collocation
                let lu = SparseLu::new(size, &self.ap, Factorisation::Fast(None), what)?;
                let mut b = Mat::<f64>::from_fn(size, dim, |r, c| x[r * dim + c]);
                lu.solve_mat(&mut b, what)?;
                x.iter_mut()
                    .enumerate()
                    .for_each(|(q, v)| *v = b[(q / dim, q % dim)]);
            }
        }
        if !x.iter().all(|v| v.is_finite()) {
            return Err(Error::SingularSystem {
                size,
                what: what.into(),
            });
        }
        let identity: Vec<f64> = (0..dim * dim)
            .map(|q| f64::from(u8::from(q / dim == q % dim)))
            .collect();
        let mut rows = vec![0.0; dim * dim];
        self.new_history(&x, &identity, dim, &mut rows);
        Ok(Mat::<f64>::from_fn(dim, dim, |r, c| rows[r * dim + c]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// z' = (iω + 1 − |z|²) z − κ (z(t − τ) − e^{−iωτ} z(t)) for z = x + iy, τ = r·2π/ω:
    /// the circle z = e^{iωt} is a cycle of period T = 2π/ω (z(t − τ) = e^{−iωτ} z(t)
    /// cancels the coupling), with τ/T = r. At r = 1/2 the coupling is −κ(z(t − τ) + z).
    struct PhaseCoupled {
        omega: f64,
        kappa: f64,
        /// τ/T
        r: f64,
    }

    impl PhaseCoupled {
        /// cos ωτ, sin ωτ
        fn rotation(&self) -> (f64, f64) {
            let (s, c) = (2.0 * PI * self.r).sin_cos();
            (c, s)
        }
    }

    impl Problem for PhaseCoupled {
        fn dim(&self) -> usize {
            2
        }
        fn n_delays(&self) -> usize {
            1
        }
        fn delay(&self, _j: usize, _p: &[f64]) -> f64 {
            self.r * 2.0 * PI / self.omega
        }
        fn rhs(&self, z: &[f64], _p: &[f64], f: &mut [f64]) {
            let (x, y, xd, yd) = (z[0], z[1], z[2], z[3]);
            let (c, s) = self.rotation();
            let r2 = x * x + y * y;
            // e^{−iωτ} z = (x c + y s) + i(y c − x s)
            f[0] = -self.omega * y + x * (1.0 - r2) - self.kappa * (xd - (x * c + y * s));
            f[1] = self.omega * x + y * (1.0 - r2) - self.kappa * (yd - (y * c - x * s));
        }
        fn jacobian(&self, z: &[f64], _p: &[f64], j: &mut [f64]) {
            let (x, y) = (z[0], z[1]);
            let (c, s) = self.rotation();
            let r2 = x * x + y * y;
            let k = self.kappa;
            j.copy_from_slice(&[
                1.0 - r2 - 2.0 * x * x + k * c,
                -self.omega - 2.0 * x * y + k * s,
                -k,
                0.0,
                self.omega - 2.0 * x * y - k * s,
                1.0 - r2 - 2.0 * y * y + k * c,
                0.0,
                -k,
            ]);
        }
        fn dfdp(&self, _z: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
            out.iter_mut().for_each(|v| *v = 0.0);
        }
    }

    use std::f64::consts::PI;

    /// The cycle of `problem` on L = 24, m = 4, corrected, and the factorisation of its
    /// Newton matrix at the solution: the multipliers read off it and those of the
    /// assembled initial-value collocation, nonzero ones only.
    fn both_multipliers(problem: &PhaseCoupled) -> (Vec<Complex64>, Vec<Complex64>, bool) {
        let options = CollocationOptions {
            intervals: 24,
            degree: 4,
            ..CollocationOptions::default()
        };
        let period = 2.0 * PI / problem.omega;
        let mut sys = PeriodicOrbitSystem::new(problem, vec![0.0], 0, options).unwrap();
        let guess = sys.unknowns_from(
            |s| vec![(2.0 * PI * s).cos(), (2.0 * PI * s).sin()],
            period,
            0.0,
        );
        sys.set_reference(&guess);
        let nu = guess.len();
        let mut fixed = vec![0.0; nu];
        fixed[nu - 1] = 1.0;
        let (u, newton) = crate::engine::correct_with_chord(&mut sys, &guess, &fixed, 1e-12, 12)
            .expect("the circle is a cycle");
        let forward = newton.forward_monodromy().is_some();
        let nonzero = |mu: Vec<Complex64>| -> Vec<Complex64> {
            mu.into_iter().filter(|m| m.norm() > 1e-8).collect()
        };
        (
            nonzero(sys.monodromy_multipliers(&u, Some(&newton)).unwrap()),
            nonzero(sys.monodromy_multipliers(&u, None).unwrap()),
            forward,
        )
    }

    /// The block-forward solver on a genuine delayed cycle's Newton matrix with a border
    /// too large to form its Schur complement (PhaseCoupled, K ≥ ITERATIVE_MIN_BORDER),
    /// against nalgebra's dense LU of the same matrix (independent): the determinant from
    /// the Arnoldi process on E = S + I — sign exact, log |det| to 1e-9 relative — and the
    /// solution to 1e-10 relative. How many products that takes follows the spectrum of
    /// the period map, |μ_k| ~ (κ/ω_k)^(T/τ) for the k-th characteristic root ω_k of the
    /// delayed term: at τ/T = 0.1 a Krylov space small against K holds E's range
    /// (measured 6 vectors for K = 60), at τ/T = 1/2 the multipliers fall
    /// off only like k⁻² and the process runs to the whole space (K = 196: exact, at the
    /// cost of the dense complement). Measured errors 5e-16 in log |det|, 4e-15 in x.
    #[test]
    fn krylov_determinant_on_a_delayed_cycle() {
        use nalgebra::{DMatrix, DVector};
        for (r, intervals) in [(0.1, 64), (0.5, 48)] {
            let problem = PhaseCoupled {
                omega: 2.0,
                kappa: 0.3,
                r,
            };
            let options = CollocationOptions {
                intervals,
                degree: 4,
                ..CollocationOptions::default()
            };
            let period = 2.0 * PI / problem.omega;
            let mut sys = PeriodicOrbitSystem::new(&problem, vec![0.0], 0, options).unwrap();
            let u = sys.unknowns_from(
                |s| vec![(2.0 * PI * s).cos(), (2.0 * PI * s).sin()],
                period,
                0.0,
            );
            sys.set_reference(&u);
            let nu = u.len();
            let mut entries = Vec::new();
            sys.jacobian(&u, &mut entries).unwrap();
            // the arclength row along the period and the parameter
            entries.push(Entry::new(nu - 1, nu - 2, 0.6));
            entries.push(Entry::new(nu - 1, nu - 1, 0.8));
            let structure = sys.mesh_structure().expect("mesh structure");
            let lu = crate::block_forward::PeriodicForwardLu::new(nu, &entries, &structure, true)
                .expect("block-forward shape");
            let (k, krylov_size) = lu.border_and_krylov_size();
            assert!(
                k >= crate::block_forward::ITERATIVE_MIN_BORDER,
                "τ/T = {r}: K = {k}"
            );
            if r < 0.2 {
                let size = krylov_size.expect("the determinant from a Krylov space");
                assert!(
                    size < k / 4,
                    "τ/T = {r}: Krylov space of {size} for K = {k}"
                );
            }
            let mut a = DMatrix::<f64>::zeros(nu, nu);
            for e in &entries {
                a[(e.row, e.col)] += e.val;
            }
            let dense = a.lu();
            // log |det| and sign from the factors (det itself under- or overflows)
            let diagonal = dense.u().diagonal();
            let log_det: f64 = diagonal.iter().map(|v| v.abs().ln()).sum();
            let sign = diagonal
                .iter()
                .fold(dense.p().determinant::<f64>(), |s, v| s * v.signum());
            let d = lu.determinant().expect("determinant asked for");
            assert_eq!(d.sign, sign, "τ/T = {r}");
            let rel = (d.log_abs - log_det).abs() / log_det.abs().max(1.0);
            assert!(rel < 1e-9, "τ/T = {r}: log |det| off by {rel:e}");
            let b: Vec<f64> = (0..nu).map(|i| (i as f64 * 0.37).sin()).collect();
            let mut x = b.clone();
            lu.solve(&mut x);
            let reference = dense.solve(&DVector::from_vec(b)).expect("regular");
            let err = (DVector::from_vec(x) - &reference).amax() / reference.amax();
            assert!(err < 1e-10, "τ/T = {r}: solution error {err:e}");
        }
    }

    /// The multipliers read off the Newton matrix's block-forward factorisation
    /// ([`crate::block_forward::ForwardMonodromy`]) against those of the initial-value
    /// collocation assembled separately (an independent formulation of the same discrete
    /// operator), for τ/T = 0.5 and 0.9 (the condition admits up to 1 − 2/24 ≈ 0.917):
    /// equal to 1e-9 relative (measured 4e-16 and 8e-15); the trivial multiplier within
    /// 1e-6 of 1 and, at τ/T = 1/2, the radial one within 1e-7 of its closed form
    /// (collocation errors at L = 24, m = 4; measured 2e-15 and 2.5e-13). At τ/T = 0.95 the
    /// operator is assembled: read off the factorisation there (a delayed value interpolated
    /// within the reading row's neighbour interval) the second multiplier came out 0.746
    /// instead of 0.727.
    #[test]
    fn multipliers_from_the_newton_factorisation_equal_the_assembled_monodromy() {
        for r in [0.5, 0.9, 0.95] {
            let problem = PhaseCoupled {
                omega: 2.0,
                kappa: 0.3,
                r,
            };
            let (a, b, forward) = both_multipliers(&problem);
            assert!(
                forward,
                "τ/T = {r}: the block-forward solver factorised the Newton matrix"
            );
            assert_eq!(a.len(), b.len(), "τ/T = {r}: {a:?} vs {b:?}");
            assert!(a.len() >= 3, "τ/T = {r}: {a:?}");
            for (x, y) in a.iter().zip(&b) {
                assert!(
                    (x - y).norm() <= 1e-9 * y.norm().max(1e-3),
                    "τ/T = {r}: {x} vs {y}"
                );
            }
            assert!(
                (a[0] - 1.0).norm() < 1e-6,
                "τ/T = {r}: trivial multiplier {}",
                a[0]
            );
        }
        let problem = PhaseCoupled {
            omega: 2.0,
            kappa: 0.3,
            r: 0.5,
        };
        let period = 2.0 * PI / problem.omega;
        let (a, _, _) = both_multipliers(&problem);
        // the radial mode (co-rotating frame, w = 1 + ρ): ρ' = −2ρ − κ(ρ − ρ(t − τ)), whose
        // real characteristic root solves λ = −2 − κ + κ e^{−λτ}; its multiplier e^{λT}
        let (kappa, tau) = (problem.kappa, problem.r * period);
        let mut lambda = -1.0f64;
        for _ in 0..50 {
            let g = lambda + 2.0 + kappa - kappa * (-lambda * tau).exp();
            lambda -= g / (1.0 + kappa * tau * (-lambda * tau).exp());
        }
        let radial = (lambda * period).exp();
        assert!(
            (a[1].re - radial).abs() < 1e-7 && a[1].im == 0.0,
            "radial multiplier {} against e^(λT) = {radial}",
            a[1]
        );
    }
}
