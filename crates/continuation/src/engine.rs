//! Pseudo-arclength continuation engine (method), branch and solver state (data).
//!
//! The engine never owns the system: [`Continuation::start`] and [`Continuation::extend`]
//! borrow it, and a [`Branch`] (points + [`ContinuationState`]) is plain serialisable data,
//! so a branch can be saved, loaded and extended later. An [`Observer`] passed to
//! [`Continuation::extend_observed`] sees every accepted point and may stop the run.
//!
//! Every Newton step (the corrector's and [`newton_step`]) is one bordered solve: assembly
//! of [G_u; (w∘t)ᵀ], sparse LU, solve. The same LU gives the tangent and the sign of the
//! bordered determinant, whose change with a non-turning tangent marks a branch point.

use crate::error::{Error, Result};
use crate::linalg::{Determinant, Entry};
use crate::linear_solver::{Factorisation, SUPERNODAL_MIN_SIZE, SparseLu};
use crate::stability::{Location, SpecialKind, SpecialPoint, Stability};
use serde::{Deserialize, Serialize};

/// A nonlinear system G(u) = 0 with N equations in N + 1 unknowns (one of them the free
/// parameter), ready for pseudo-arclength continuation.
pub trait ContinuationSystem {
    /// number of unknowns N + 1 (N equations)
    fn n_unknowns(&self) -> usize;
    /// index of the free parameter in `u`
    fn parameter_index(&self) -> usize;
    /// index in `u` of a second free parameter, for two-parameter curves of codimension-one
    /// points (Hopf, fold, fold of cycles); None for one-parameter branches
    fn secondary_parameter_index(&self) -> Option<usize> {
        None
    }
    /// whether the engine watches the bordered determinant for branch points of this system
    /// (when [`ContinuationOptions::branch_points`] is on). Default: on one-parameter branches
    /// only; on a two-parameter curve a singular bordered Jacobian marks a codimension-two
    /// point of the curve (e.g. a zero-Hopf point of an equilibrium that exists for every
    /// parameter, where ∂f/∂p = 0), which the system classifies itself.
    fn detects_branch_points(&self) -> bool {
        self.secondary_parameter_index().is_none()
    }
    /// residual G(u) (length N)
    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()>;
    /// Jacobian ∂G/∂u (N × (N+1)) appended to `entries` as triplets (duplicates are summed)
    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()>;
    /// weights of the arclength metric ‖u‖² = Σ w_i u_i² (length N + 1)
    fn weights(&self) -> Vec<f64>;
    /// A fill-reducing column elimination order for the simplicial sparse LU of the
    /// bordered Jacobian [G_u; bᵀ] (forward array of length N + 1: the k-th eliminated
    /// column is `order[k]`), from the system's known structure; None: COLAMD. Used where
    /// the engine needs the determinant (branch-point test); elsewhere the engine orders by
    /// COLAMD and lets faer choose simplicial or supernodal factors.
    fn column_order(&self) -> Option<Vec<usize>> {
        None
    }
    /// Whether the bordered Jacobian is banded in [`ContinuationSystem::column_order`] up
    /// to its borders (an ODE's collocation: each interval couples with its neighbours
    /// only): the simplicial LU in that order is then the fast one for every solve (and
    /// gives the determinant for free), the supernodal factors' symbolic analysis costs
    /// more than it saves (measured 4× on the trailer's open-loop cycle branch, L = 60).
    fn banded(&self) -> bool {
        false
    }
    /// where the unknowns and equations sit on a collocation mesh, for the structured
    /// solver of the bordered Newton systems ([`crate::LinearSolver::Krylov`]); None: one
    /// sparse LU of the whole system
    fn mesh_structure(&self) -> Option<crate::linalg::MeshStructure> {
        None
    }
    /// called on every accepted point (e.g. to update a phase-condition reference)
    fn accept(&mut self, _u: &[f64]) {}
    /// stability of the solution `u` (None if the system does not compute it)
    fn stability(&mut self, _u: &[f64]) -> Result<Option<Stability>> {
        Ok(None)
    }
    /// stability of the solution `u` given the corrector's factorisation of the bordered
    /// Newton matrix where it was made within the Newton tolerance of u: a system that can
    /// read its stability off that factorisation (a periodic orbit's Floquet multipliers)
    /// overrides this; by default [`ContinuationSystem::stability`]
    fn stability_from(&mut self, u: &[f64], newton: NewtonMatrix<'_>) -> Result<Option<Stability>> {
        let _ = newton;
        self.stability(u)
    }
    /// which special point, if any, lies between two stabilities
    fn classify(&self, _a: &Stability, _b: &Stability) -> Option<SpecialKind> {
        None
    }
    /// a test function that changes sign at a special point of this kind
    /// (None: the kind is only detected, not located)
    fn test_function(&mut self, _kind: SpecialKind, _u: &[f64]) -> Result<Option<f64>> {
        Ok(None)
    }
}

/// What to do with special points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SpecialPoints {
    /// detect and locate them (a located point is inserted into the branch)
    Locate,
    /// only flag the first point after the crossing
    Detect,
    /// do nothing
    Ignore,
}

/// Options of the continuation method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContinuationOptions {
    /// first step length (weighted arclength)
    pub initial_step: f64,
    /// smallest step before giving up
    pub min_step: f64,
    /// largest step
    pub max_step: f64,
    /// Newton stops when the max-norm of the update is below this
    pub newton_tolerance: f64,
    /// maximum Newton iterations per corrector
    pub max_newton_iterations: usize,
    /// the step grows when Newton needs fewer iterations than this, shrinks when more
    pub target_newton_iterations: usize,
    /// factor of step growth after an easy step
    pub step_growth: f64,
    /// factor of step reduction after a failed or rejected step
    pub step_reduction: f64,
    /// minimum cosine between consecutive tangents (weighted metric); sharper turns are rejected
    pub min_tangent_cosine: f64,
    /// stop when the parameter leaves this range
    pub parameter_range: (f64, f64),
    /// special points
    pub special_points: SpecialPoints,
    /// location stops when successive parameter estimates differ by less than this
    pub location_tolerance: f64,
    /// maximum iterations of a location
    pub max_location_iterations: usize,
    /// watch the sign of the bordered determinant for branch points (pitchfork,
    /// transcritical); off: such points are stepped over unnoticed, as before this test existed
    #[serde(default = "branch_points_default")]
    pub branch_points: bool,
    /// how the corrector updates its Jacobian (default: a new factorisation every iteration)
    #[serde(default)]
    pub newton: NewtonUpdate,
    /// a corrector whose updates stagnate above `newton_tolerance` while the residual's
    /// max-norm is at or below `stagnation_residual`·(1 + |parameter|) (rounding level of an
    /// ill-conditioned or nearly singular system) accepts its best iterate and records it
    /// ([`BranchPoint::stagnation`]) instead of failing; 0 turns this off
    #[serde(default = "stagnation_residual_default")]
    pub stagnation_residual: f64,
}

/// A corrector that stopped at rounding level without its update converging: the numbers
/// of its accepted iterate (the system is ill-conditioned or nearly singular there).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stagnation {
    /// max-norm of the residual at the accepted iterate
    pub residual: f64,
    /// max-norm of the last Newton update (above the tolerance)
    pub update: f64,
}

fn stagnation_residual_default() -> f64 {
    1e-11
}

/// How the Newton corrector treats the Jacobian between iterations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NewtonUpdate {
    /// assemble and factorise the bordered Jacobian at every iterate (quadratic
    /// convergence)
    #[default]
    Full,
    /// after `full` iterations with new factorisations, keep the last one (chord method:
    /// linear convergence with a rate of the order of the last update, so one or two cheap
    /// iterations finish what Newton started); worth it when the factorisation dominates,
    /// as for large delay-coupled collocation systems. The tangent then comes from that
    /// factorisation, accurate to the size of the update it was made at.
    Chord {
        /// iterations with a new factorisation before it is kept (at least 1)
        full: usize,
    },
}

fn branch_points_default() -> bool {
    true
}

impl Default for ContinuationOptions {
    fn default() -> Self {
        Self {
            initial_step: 1e-2,
            min_step: 1e-9,
            max_step: 1.0,
            newton_tolerance: 1e-10,
            max_newton_iterations: 10,
            target_newton_iterations: 3,
            step_growth: 1.5,
            step_reduction: 0.5,
            min_tangent_cosine: 0.95,
            parameter_range: (f64::NEG_INFINITY, f64::INFINITY),
            special_points: SpecialPoints::Locate,
            location_tolerance: 1e-10,
            max_location_iterations: 60,
            branch_points: true,
            newton: NewtonUpdate::Full,
            stagnation_residual: stagnation_residual_default(),
        }
    }
}

/// Solver state of a branch: everything needed to continue it later.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContinuationState {
    /// the next step length to try
    pub step: f64,
    /// accepted steps so far
    pub accepted_steps: usize,
    /// rejected steps so far
    pub rejected_steps: usize,
}

/// One solution on a branch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BranchPoint {
    /// unknowns (layout defined by the system), including the parameter
    pub u: Vec<f64>,
    /// value of the free parameter
    pub parameter: f64,
    /// value of the second free parameter on a two-parameter curve (None on a branch)
    #[serde(default)]
    pub secondary_parameter: Option<f64>,
    /// unit tangent (weighted metric), oriented in the direction of continuation
    pub tangent: Vec<f64>,
    /// stability (eigenvalues or Floquet multipliers)
    pub stability: Option<Stability>,
    /// special point at (Located) or just before (Detected) this point
    pub special: Option<SpecialPoint>,
    /// Newton iterations the corrector needed
    pub newton_iterations: usize,
    /// the corrector stagnated at rounding level here (accepted, see
    /// [`ContinuationOptions::stagnation_residual`]); None: converged
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stagnation: Option<Stagnation>,
}

impl BranchPoint {
    /// stable according to the recorded stability (None if unknown)
    pub fn is_stable(&self) -> Option<bool> {
        self.stability.as_ref().map(|s| s.is_stable())
    }
}

/// Why [`Continuation::extend`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Stop {
    /// the requested number of points was computed
    MaxPoints,
    /// the parameter left `parameter_range`
    ParameterRange,
    /// the step fell below `min_step` (the branch ends, or something is wrong)
    StepSizeUnderflow {
        /// the step that failed
        step: f64,
    },
    /// the [`Observer`] asked to stop (user stop rule)
    Observer,
}

/// What an [`Observer`] tells the engine after an accepted point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Decision {
    /// go on
    Continue,
    /// stop now; [`Continuation::extend_observed`] returns [`Stop::Observer`]
    Stop,
}

/// Called by [`Continuation::extend_observed`] after every point added to the branch
/// (accepted steps and located special points), as argmin's observers are: for progress
/// reports, checkpoints (the branch so far is plain serialisable data) and user stop rules.
///
/// Closures `FnMut(&Branch) -> Decision` are observers.
pub trait Observer {
    /// `branch`: the branch so far, the new point last; `branch.state` is the solver state
    fn observe(&mut self, branch: &Branch) -> Decision;
}

impl<F: FnMut(&Branch) -> Decision> Observer for F {
    fn observe(&mut self, branch: &Branch) -> Decision {
        self(branch)
    }
}

/// The observer that does nothing (what [`Continuation::extend`] uses).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoObserver;

impl Observer for NoObserver {
    fn observe(&mut self, _branch: &Branch) -> Decision {
        Decision::Continue
    }
}

/// A branch of solutions: points and the state needed to continue it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Branch {
    /// points in continuation order
    pub points: Vec<BranchPoint>,
    /// continuation state
    pub state: ContinuationState,
}

impl Branch {
    /// the special points with their indices
    pub fn special_points(&self) -> impl Iterator<Item = (usize, &SpecialPoint)> {
        self.points
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.special.as_ref().map(|s| (i, s)))
    }

    /// first special point of a kind
    pub fn first(&self, kind: SpecialKind) -> Option<(usize, &SpecialPoint)> {
        self.special_points().find(|(_, s)| s.kind == kind)
    }
}

/// The pseudo-arclength continuation method (options only; no problem, no state).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Continuation {
    /// options
    pub options: ContinuationOptions,
}

/// The corrector's factorisation of the bordered Newton matrix [G_u(u); bᵀ] at a point within
/// the Newton tolerance of the solution u it is handed with (see
/// [`ContinuationSystem::stability_from`]); empty where the corrector's last factorisation
/// lies farther (chord iterations) or was not made by this crate's solvers.
#[derive(Clone, Copy, Default)]
pub struct NewtonMatrix<'a>(pub(crate) Option<&'a SparseLu>);

impl std::fmt::Debug for NewtonMatrix<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = if self.0.is_some() {
            "factorised"
        } else {
            "none"
        };
        f.debug_tuple("NewtonMatrix").field(&what).finish()
    }
}

/// result of one corrector run
struct Corrected {
    u: Vec<f64>,
    tangent: Vec<f64>,
    iterations: usize,
    /// the factorisation the tangent came from, where it was made within the Newton
    /// tolerance of u
    newton: Option<SparseLu>,
    /// determinant of the bordered Jacobian of the last Newton iteration (None when the
    /// engine does not watch this system for branch points)
    determinant: Option<Determinant>,
    /// the corrector stagnated at rounding level (None: converged)
    stagnation: Option<Stagnation>,
}

/// One assembled, factorised and solved bordered Newton system at `u`:
///
/// ```text
/// [ G_u(u) ] Δu = − [ G(u)       ]
/// [ bᵀ     ]        [ constraint ]
/// ```
struct BorderedStep {
    lu: SparseLu,
    update: Vec<f64>,
    residual_norm: f64,
}

/// Whether a factorisation must provide the determinant (the branch-point test watches its
/// sign); without, the faster factors of [`Factorisation::Fast`] are used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum NeedsDeterminant {
    Yes,
    No,
}

/// The one bordered solve shared by [`newton_step`] and the corrector: residual and sparse
/// Jacobian of the system, the border row `border` (entries b_i = w_i t_i), sparse LU and
/// solve. `entries` is a reusable buffer.
fn bordered_step<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    border: &[f64],
    constraint: f64,
    entries: &mut Vec<Entry>,
    determinant: NeedsDeterminant,
    what: &str,
) -> Result<BorderedStep> {
    let residual = bordered_residual(sys, u, constraint)?;
    let lu = bordered_lu(sys, u, border, entries, determinant, what)?;
    solved(lu, residual, what)
}

/// The factorised bordered Jacobian [G_u(u); bᵀ] (`entries` is a reusable buffer).
fn bordered_lu<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    border: &[f64],
    entries: &mut Vec<Entry>,
    determinant: NeedsDeterminant,
    what: &str,
) -> Result<SparseLu> {
    let nu = sys.n_unknowns();
    bordered_jacobian(sys, u, border, entries)?;
    let order = sys.column_order();
    let factorisation = match determinant {
        _ if sys.banded() => Factorisation::Banded(order.as_deref()),
        NeedsDeterminant::No => Factorisation::Fast(order.as_deref()),
        NeedsDeterminant::Yes => Factorisation::WithDeterminant(order.as_deref()),
    };
    let structure = sys.mesh_structure();
    SparseLu::structured(nu, entries, factorisation, structure.as_ref(), what)
}

/// The Newton update −J⁻¹ r from the factorisation `lu` and the residual `(r, ‖r‖∞)`.
fn solved(lu: SparseLu, (r, residual_norm): (Vec<f64>, f64), what: &str) -> Result<BorderedStep> {
    let mut update: Vec<f64> = r.iter().map(|v| -v).collect();
    lu.solve(&mut update, what)?;
    Ok(BorderedStep {
        lu,
        update,
        residual_norm,
    })
}

/// The residual of the bordered system at `u` (with `constraint` as its last entry) and
/// its max-norm.
fn bordered_residual<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    constraint: f64,
) -> Result<(Vec<f64>, f64)> {
    let nu = sys.n_unknowns();
    let mut r = vec![0.0; nu];
    sys.residual(u, &mut r[..nu - 1])?;
    r[nu - 1] = constraint;
    let residual_norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if residual_norm.is_finite() {
        Ok((r, residual_norm))
    } else {
        Err(Error::NonFinite {
            parameter: u[sys.parameter_index()],
        })
    }
}

/// A chord step ([`NewtonUpdate::Chord`]): the residual at `u` solved with a kept
/// factorisation of the bordered Jacobian at an earlier iterate.
fn chord_step<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    constraint: f64,
    lu: SparseLu,
    what: &str,
) -> Result<BorderedStep> {
    let residual = bordered_residual(sys, u, constraint)?;
    solved(lu, residual, what)
}

/// The Newton iterations of one correction: the bordered Jacobian's border, the triplet
/// buffer, and how far (max-norm, the sum of the updates) the iterates have travelled
/// since the factorisation in use was made.
struct Iterations<'b> {
    border: &'b [f64],
    determinant: NeedsDeterminant,
    what: &'static str,
    entries: Vec<Entry>,
    moved: f64,
}

impl<'b> Iterations<'b> {
    fn new(border: &'b [f64], determinant: NeedsDeterminant, what: &'static str) -> Self {
        Self {
            border,
            determinant,
            what,
            entries: Vec::new(),
            moved: 0.0,
        }
    }

    /// One iteration at `u`: a chord step with `kept` where given, else a step with a new
    /// factorisation (the distance travelled starts again). Returns the step and its
    /// update's max-norm.
    fn step<S: ContinuationSystem>(
        &mut self,
        sys: &mut S,
        u: &[f64],
        constraint: f64,
        kept: Option<SparseLu>,
    ) -> Result<(BorderedStep, f64)> {
        let step = match kept {
            Some(lu) => chord_step(sys, u, constraint, lu, &format!("{} (chord)", self.what))?,
            None => {
                self.moved = 0.0;
                bordered_step(
                    sys,
                    u,
                    self.border,
                    constraint,
                    &mut self.entries,
                    self.determinant,
                    self.what,
                )?
            }
        };
        let size = step.update.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        self.moved += size;
        Ok((step, size))
    }

    /// a new factorisation at `u` with `determinant` (the distance travelled starts again)
    fn factorise<S: ContinuationSystem>(
        &mut self,
        sys: &mut S,
        u: &[f64],
        determinant: NeedsDeterminant,
        what: &str,
    ) -> Result<SparseLu> {
        self.moved = 0.0;
        bordered_lu(sys, u, self.border, &mut self.entries, determinant, what)
    }
}

/// triplets of the bordered Jacobian [G_u(u); bᵀ] into `entries` (cleared first)
fn bordered_jacobian<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    border: &[f64],
    entries: &mut Vec<Entry>,
) -> Result<()> {
    entries.clear();
    sys.jacobian(u, entries)?;
    let last_row = sys.n_unknowns() - 1;
    for (i, &b) in border.iter().enumerate() {
        if b != 0.0 {
            entries.push(Entry::new(last_row, i, b));
        }
    }
    Ok(())
}

fn weighted_dot(w: &[f64], a: &[f64], b: &[f64]) -> f64 {
    w.iter().zip(a).zip(b).map(|((w, a), b)| w * a * b).sum()
}

fn normalise(w: &[f64], t: &mut [f64]) {
    let n = weighted_dot(w, t, t).sqrt();
    if n > 0.0 {
        t.iter_mut().for_each(|v| *v /= n);
    }
}

/// the border row w∘t of the arclength condition
fn border(w: &[f64], t: &[f64]) -> Vec<f64> {
    w.iter().zip(t).map(|(w, t)| w * t).collect()
}

/// `a + s·t`
fn along(a: &[f64], t: &[f64], s: f64) -> Vec<f64> {
    a.iter().zip(t).map(|(u, t)| u + s * t).collect()
}

/// A scalar test function whose zero the location looks for.
#[derive(Debug, Clone, Copy)]
enum TestFunction {
    /// the parameter component of the tangent (fold)
    Fold,
    /// det of the bordered Jacobian [G_u; (w∘t_a)ᵀ] divided by |det| at the bracket's start
    /// (branch point: the determinant changes sign while the tangent does not turn)
    BranchPoint {
        /// log |det| at the start of the bracket
        log_scale: f64,
        /// sign of det at the start of the bracket
        start_sign: f64,
    },
    /// the system's own test function of this kind
    System(SpecialKind),
}

impl TestFunction {
    fn kind(self) -> SpecialKind {
        match self {
            TestFunction::Fold => SpecialKind::Fold,
            TestFunction::BranchPoint { .. } => SpecialKind::BranchPoint,
            TestFunction::System(k) => k,
        }
    }

    /// value on a corrected point (None: the system has no test function of this kind)
    fn value<S: ContinuationSystem>(self, sys: &mut S, c: &Corrected) -> Result<Option<f64>> {
        Ok(match self {
            TestFunction::Fold => Some(c.tangent[sys.parameter_index()]),
            TestFunction::BranchPoint { log_scale, .. } => c
                .determinant
                .map(|d| d.sign * (d.log_abs - log_scale).exp()),
            TestFunction::System(k) => sys.test_function(k, &c.u)?,
        })
    }
}

/// bracket of a special point between the accepted points `a` and `b` (step `ds` from `a`)
struct Bracket<'p> {
    a: &'p BranchPoint,
    ds: f64,
    ga: f64,
    gb: f64,
}

impl Continuation {
    /// Method with the given options.
    pub fn new(options: ContinuationOptions) -> Self {
        Self { options }
    }

    /// whether the branch-point test watches `sys` (then factorisations keep the determinant)
    fn needs_determinant<S: ContinuationSystem>(&self, sys: &S) -> NeedsDeterminant {
        if self.options.branch_points && sys.detects_branch_points() {
            NeedsDeterminant::Yes
        } else {
            NeedsDeterminant::No
        }
    }

    /// Newton corrector for G(u) = 0, Σ w_i t_i (u_i − pred_i) = 0.
    /// Returns the solution, the new unit tangent (oriented along `t`) and the iterations.
    fn correct<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        pred: &[f64],
        t: &[f64],
        w: &[f64],
    ) -> Result<Corrected> {
        let ip = sys.parameter_index();
        let b = border(w, t);
        let mut u = pred.to_vec();
        let mut last_update = f64::INFINITY;
        let mut res_norm = f64::INFINITY;
        let refactorise = |it: usize| match self.options.newton {
            NewtonUpdate::Full => true,
            NewtonUpdate::Chord { full } => it <= full.max(1),
        };
        let mut kept: Option<SparseLu> = None;
        // small or banded systems: the one (simplicial) factorisation gives the
        // determinant anyway
        let iteration_determinant = if u.len() < SUPERNODAL_MIN_SIZE || sys.banded() {
            self.needs_determinant(sys)
        } else {
            NeedsDeterminant::No
        };
        let mut iterations = Iterations::new(&b, iteration_determinant, "Newton corrector");
        // the iterate with the smallest residual and that residual (for a stagnated
        // corrector; one buffer, reused)
        let (mut best_u, mut best_res) = (Vec::with_capacity(u.len()), f64::INFINITY);
        for it in 1..=self.options.max_newton_iterations {
            let constraint = (0..u.len()).map(|i| b[i] * (u[i] - pred[i])).sum();
            let chord = kept.take().filter(|_| !refactorise(it));
            let (step, upd) = iterations.step(sys, &u, constraint, chord)?;
            res_norm = step.residual_norm;
            if res_norm < best_res {
                best_u.clear();
                best_u.extend_from_slice(&u);
                best_res = res_norm;
            }
            u.iter_mut().zip(&step.update).for_each(|(a, b)| *a += b);
            let tolerance = self.options.newton_tolerance * (1.0 + u[ip].abs());
            if upd <= tolerance {
                // the iterations use the fast factorisation (supernodal where large); where
                // the branch-point test needs the determinant, the bordered Jacobian is
                // factorised once more at the converged point with it (its tangent too)
                let lu = match (self.needs_determinant(sys), iteration_determinant) {
                    (NeedsDeterminant::Yes, NeedsDeterminant::No) => iterations.factorise(
                        sys,
                        &u,
                        NeedsDeterminant::Yes,
                        "Newton corrector (determinant)",
                    )?,
                    _ => step.lu,
                };
                let at_solution = iterations.moved <= tolerance;
                return Self::corrected(lu, u, w, it, at_solution, None);
            }
            kept = Some(step.lu);
            if it > 2 && upd > 2.0 * last_update {
                break;
            }
            last_update = upd;
        }
        // stagnated at rounding level: the best iterate, with its numbers recorded
        if !best_u.is_empty()
            && best_res <= self.options.stagnation_residual * (1.0 + best_u[ip].abs())
            && last_update.is_finite()
        {
            let (ub, rb) = (best_u, best_res);
            let det = self.needs_determinant(sys);
            let lu = iterations.factorise(sys, &ub, det, "Newton corrector (stagnated)")?;
            let stagnation = Stagnation {
                residual: rb,
                update: last_update,
            };
            let its = self.options.max_newton_iterations;
            return Self::corrected(lu, ub, w, its, true, Some(stagnation));
        }
        Err(Error::NewtonDivergence {
            parameter: u[ip],
            iterations: self.options.max_newton_iterations,
            residual: res_norm,
            update: last_update,
        })
    }

    /// the converged corrector's tangent from the same factorisation: [J; w∘t] τ = e_N
    /// (kept for the stability where `at_solution`: made within the Newton tolerance of u)
    fn corrected(
        lu: SparseLu,
        u: Vec<f64>,
        w: &[f64],
        iterations: usize,
        at_solution: bool,
        stagnation: Option<Stagnation>,
    ) -> Result<Corrected> {
        let nu = u.len();
        let mut tau = vec![0.0; nu];
        tau[nu - 1] = 1.0;
        lu.solve(&mut tau, "tangent")?;
        normalise(w, &mut tau);
        Ok(Corrected {
            u,
            tangent: tau,
            iterations,
            determinant: lu.determinant(),
            newton: at_solution.then_some(lu),
            stagnation,
        })
    }

    /// determinant of the bordered Jacobian [G_u(u); (w∘t)ᵀ] (one assembly and LU)
    fn bordered_determinant<S: ContinuationSystem>(
        sys: &mut S,
        u: &[f64],
        t: &[f64],
        w: &[f64],
    ) -> Result<Determinant> {
        // factorised as the corrector does (the block-forward solver where the system has
        // the mesh structure, det A · det S: a plain sparse LU filled in with a delayed
        // loop's wrap-around, 7 % of the closed-loop diagram at L = 120)
        let (mut entries, border) = (Vec::new(), border(w, t));
        let yes = NeedsDeterminant::Yes;
        bordered_lu(sys, u, &border, &mut entries, yes, "branch-point test")?
            .determinant()
            .ok_or(Error::SingularSystem {
                size: u.len(),
                what: "branch-point test: no determinant".into(),
            })
    }

    fn make_point<S: ContinuationSystem>(&self, sys: &mut S, c: Corrected) -> Result<BranchPoint> {
        let stability = sys.stability_from(&c.u, NewtonMatrix(c.newton.as_ref()))?;
        let ip = sys.parameter_index();
        let secondary_parameter = sys.secondary_parameter_index().map(|i| c.u[i]);
        Ok(BranchPoint {
            parameter: c.u[ip],
            secondary_parameter,
            u: c.u,
            tangent: c.tangent,
            stability,
            special: None,
            newton_iterations: c.iterations,
            stagnation: c.stagnation,
        })
    }

    /// Start a branch: correct `guess` under the constraint that its projection on
    /// `direction` stays fixed (Σ w_i d_i (u_i − guess_i) = 0); the tangent is oriented so that
    /// it has a positive component along `direction`.
    ///
    /// For an equilibrium, `direction` = the unit vector of the parameter; for branch
    /// switching onto cycles, the direction of growing amplitude.
    pub fn start<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        guess: &[f64],
        direction: &[f64],
    ) -> Result<Branch> {
        let nu = sys.n_unknowns();
        if guess.len() != nu || direction.len() != nu {
            return Err(Error::InvalidInput(format!(
                "start: guess has {} and direction {} entries, the system has {nu} unknowns",
                guess.len(),
                direction.len()
            )));
        }
        let w = sys.weights();
        let mut d = direction.to_vec();
        normalise(&w, &mut d);
        let c = self.correct(sys, guess, &d, &w)?;
        sys.accept(&c.u);
        let p = self.make_point(sys, c)?;
        Ok(Branch {
            points: vec![p],
            state: ContinuationState {
                step: self.options.initial_step,
                accepted_steps: 0,
                rejected_steps: 0,
            },
        })
    }

    /// Continue `branch` by up to `max_points` new points (located special points count too).
    ///
    /// Equivalent to [`Continuation::extend_observed`] with [`NoObserver`].
    pub fn extend<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        branch: &mut Branch,
        max_points: usize,
    ) -> Result<Stop> {
        self.extend_observed(sys, branch, max_points, &mut NoObserver)
    }

    /// Continue `branch` by up to `max_points` new points (located special points count too),
    /// calling `observer` after every point added; it may stop the run ([`Stop::Observer`]).
    ///
    /// Branch points (pitchfork, transcritical) are detected by a sign change of the
    /// determinant of the bordered Jacobian [G_u; (w∘t)ᵀ] while the tangent does not turn,
    /// located as [`SpecialKind::BranchPoint`], and stepped over; see
    /// [`Continuation::switch_branch`] for the crossing branch.
    pub fn extend_observed<S: ContinuationSystem, O: Observer + ?Sized>(
        &self,
        sys: &mut S,
        branch: &mut Branch,
        max_points: usize,
        observer: &mut O,
    ) -> Result<Stop> {
        let w = sys.weights();
        let last = Self::last_point(sys, branch)?.clone();
        sys.accept(&last.u);
        // sign of det [G_u; (w∘t)ᵀ] at the last point (0: not watched or not available)
        let mut sign_a = match self.needs_determinant(sys) {
            NeedsDeterminant::Yes => {
                Self::bordered_determinant(sys, &last.u, &last.tangent, &w).map_or(0.0, |d| d.sign)
            }
            NeedsDeterminant::No => 0.0,
        };
        let o = &self.options;
        let mut added = 0;
        while added < max_points {
            // a cancelled computation stops here (`cancel::run` catches it)
            cancel::checkpoint();
            let a = branch.points.last().cloned().ok_or(Error::EmptyBranch)?;
            if a.parameter < o.parameter_range.0 || a.parameter > o.parameter_range.1 {
                return Ok(Stop::ParameterRange);
            }
            let ds = branch.state.step;
            if ds < o.min_step {
                return Ok(Stop::StepSizeUnderflow { step: ds });
            }
            let Some(c) = self.predict_correct(sys, &a, ds, &w) else {
                branch.state.step *= o.step_reduction;
                branch.state.rejected_steps += 1;
                continue;
            };
            let next = self.next_step(ds, c.iterations);
            let det_b = c.determinant;
            let mut b = self.make_point(sys, c)?;
            branch.state.accepted_steps += 1;
            let located = self.special_between(sys, &a, &mut b, ds, sign_a, det_b, &w)?;
            sign_a = det_b.map_or(0.0, |d| d.sign);
            if let Some(p) = located {
                branch.points.push(p);
                added += 1;
                if observer.observe(branch) == Decision::Stop {
                    return Ok(Stop::Observer);
                }
            }
            sys.accept(&b.u);
            branch.points.push(b);
            added += 1;
            branch.state.step = next;
            if observer.observe(branch) == Decision::Stop {
                return Ok(Stop::Observer);
            }
        }
        Ok(Stop::MaxPoints)
    }

    /// the last point of a branch, checked against the system's size
    fn last_point<'b, S: ContinuationSystem>(
        sys: &S,
        branch: &'b Branch,
    ) -> Result<&'b BranchPoint> {
        let last = branch.points.last().ok_or(Error::EmptyBranch)?;
        if last.u.len() != sys.n_unknowns() {
            return Err(Error::InvalidInput(format!(
                "branch points have {} unknowns, the system has {}",
                last.u.len(),
                sys.n_unknowns()
            )));
        }
        Ok(last)
    }

    /// predictor along a's tangent and corrector; None if the step is to be rejected
    /// (Newton failed, or the tangent turned more than `min_tangent_cosine` allows)
    fn predict_correct<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        a: &BranchPoint,
        ds: f64,
        w: &[f64],
    ) -> Option<Corrected> {
        let o = &self.options;
        let pred = along(&a.u, &a.tangent, ds);
        match self.correct(sys, &pred, &a.tangent, w) {
            Ok(c)
                if weighted_dot(w, &c.tangent, &a.tangent) >= o.min_tangent_cosine
                    || ds <= 2.0 * o.min_step =>
            {
                Some(c)
            }
            _ => None,
        }
    }

    /// step control from the Newton iteration count
    fn next_step(&self, ds: f64, iterations: usize) -> f64 {
        let o = &self.options;
        let next = if iterations < o.target_newton_iterations {
            ds * o.step_growth
        } else if iterations > o.target_newton_iterations {
            ds * o.step_reduction.max(0.7)
        } else {
            ds
        };
        next.min(o.max_step)
    }

    /// Special points between the accepted points `a` and `b`: `b` is flagged (detected) or
    /// the located point is returned (to be inserted before `b`).
    #[allow(clippy::too_many_arguments)]
    fn special_between<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        a: &BranchPoint,
        b: &mut BranchPoint,
        ds: f64,
        sign_a: f64,
        det_b: Option<Determinant>,
        w: &[f64],
    ) -> Result<Option<BranchPoint>> {
        if self.options.special_points == SpecialPoints::Ignore {
            return Ok(None);
        }
        let Some(test) = self.test_between(sys, a, b, sign_a, det_b, w)? else {
            return Ok(None);
        };
        let kind = test.kind();
        let ga = match test {
            TestFunction::Fold => Some(a.tangent[sys.parameter_index()]),
            TestFunction::BranchPoint { start_sign, .. } => Some(start_sign),
            TestFunction::System(k) => sys.test_function(k, &a.u)?,
        };
        let (SpecialPoints::Locate, Some(ga)) = (self.options.special_points, ga) else {
            b.special = Some(self.detected(kind, b));
            return Ok(None);
        };
        let gb = match test {
            TestFunction::Fold => b.tangent[sys.parameter_index()],
            TestFunction::BranchPoint { log_scale, .. } => {
                det_b.map_or(0.0, |d| d.sign * (d.log_abs - log_scale).exp())
            }
            TestFunction::System(k) => sys.test_function(k, &b.u)?.unwrap_or(ga),
        };
        if ga * gb >= 0.0 {
            b.special = Some(self.detected(kind, b));
            return Ok(None);
        }
        let bracket = Bracket { a, ds, ga, gb };
        let mut point = match self.locate(sys, test, &bracket, w) {
            Ok(p) => p,
            // a special point that cannot be located (its corrector fails or the location
            // does not converge near a singular point) is still reported as detected, and
            // the branch goes on: the point is a result, its location an approximation
            Err(_) => {
                b.special = Some(self.detected(kind, b));
                return Ok(None);
            }
        };
        let dp = b.parameter - a.parameter;
        if let Some(sp) = point.special.as_mut()
            && matches!(test, TestFunction::System(_))
            && dp != 0.0
        {
            sp.transversality = Some((gb - ga) / dp);
        }
        Ok(Some(point))
    }

    /// Which test function changes sign between `a` and `b`, if any: a fold (the tangent's
    /// parameter component changes sign), a branch point (the bordered determinant changes
    /// sign, confirmed with a's determinant recomputed on the same border as b's), or a kind
    /// the system classifies from the two stabilities.
    fn test_between<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        a: &BranchPoint,
        b: &BranchPoint,
        sign_a: f64,
        det_b: Option<Determinant>,
        w: &[f64],
    ) -> Result<Option<TestFunction>> {
        let sign_b = det_b.map_or(0.0, |d| d.sign);
        let ip = sys.parameter_index();
        if a.tangent[ip] * b.tangent[ip] < 0.0 {
            return Ok(Some(TestFunction::Fold));
        }
        if self.options.branch_points
            && sys.detects_branch_points()
            && sign_a * sign_b < 0.0
            && let Ok(det_a) = Self::bordered_determinant(sys, &a.u, &a.tangent, w)
            && det_a.sign * sign_b < 0.0
        {
            return Ok(Some(TestFunction::BranchPoint {
                log_scale: det_a.log_abs,
                start_sign: det_a.sign,
            }));
        }
        Ok(match (&a.stability, &b.stability) {
            (Some(sa), Some(sb)) => sys.classify(sa, sb).map(TestFunction::System),
            _ => None,
        })
    }

    fn detected(&self, kind: SpecialKind, b: &BranchPoint) -> SpecialPoint {
        SpecialPoint {
            kind,
            location: Location::Detected,
            parameter: b.parameter,
            critical: b.stability.as_ref().and_then(|s| s.critical(kind)),
            transversality: None,
        }
    }

    /// corrector at step `s` along a's tangent, for the location. At a branch point the
    /// bordered Jacobian is singular, and so it is at a codimension-two point of a curve
    /// where another branch crosses (e.g. a zero-Hopf point of a symmetric system, where a
    /// Hopf curve of the nontrivial equilibria meets the trivial one): an exactly singular
    /// system there is retried a hair (1e-10 of the step) further on and reported as
    /// converged (`true`): the zero of the test function is where the system is singular.
    fn correct_at<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        bracket: &Bracket<'_>,
        s: f64,
        w: &[f64],
    ) -> Result<(Corrected, bool)> {
        let a = bracket.a;
        match self.correct(sys, &along(&a.u, &a.tangent, s), &a.tangent, w) {
            Err(Error::SingularSystem { .. }) => {
                let nudged = along(&a.u, &a.tangent, s + 1e-10 * bracket.ds);
                Ok((self.correct(sys, &nudged, &a.tangent, w)?, true))
            }
            r => Ok((r?, false)),
        }
    }

    /// Locate the zero of a test function between `a` (step 0) and the step `ds`
    /// (Illinois variant of regula falsi on the step length along a's tangent).
    fn locate<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        test: TestFunction,
        bracket: &Bracket<'_>,
        w: &[f64],
    ) -> Result<BranchPoint> {
        let kind = test.kind();
        let a = bracket.a;
        let ip = sys.parameter_index();
        let failed = |p1: f64, iterations: usize| Error::LocationFailed {
            kind: kind.to_string(),
            p0: a.parameter,
            p1,
            iterations,
        };
        let (mut s0, mut g0, mut s1, mut g1) = (0.0, bracket.ga, bracket.ds, bracket.gb);
        let mut side = 0i8;
        let mut p_prev = f64::NAN;
        let mut best: Option<Corrected> = None;
        let mut was_singular = false;
        for it in 0..self.options.max_location_iterations {
            let s = s1 - g1 * (s1 - s0) / (g1 - g0);
            let (c, singular) = match self.correct_at(sys, bracket, s, w) {
                Ok(r) => r,
                // singular at the special point and, where the curve turns there (a
                // Bogdanov–Takens point of a symmetric system: ω → 0 where x = 0 has a
                // zero root for every parameter), again after the nudge: the last iterate,
                // converged within rounding of it, is the located point
                Err(Error::SingularSystem { .. }) if best.is_some() => {
                    was_singular = true;
                    break;
                }
                Err(e) => return Err(e),
            };
            was_singular |= singular;
            let g = test.value(sys, &c)?.ok_or_else(|| failed(c.u[ip], it))?;
            let p = c.u[ip];
            let done = singular
                || (p - p_prev).abs() <= self.options.location_tolerance
                || g == 0.0
                || (s1 - s0).abs() < 1e-15 * bracket.ds;
            p_prev = p;
            best = Some(c);
            if done {
                break;
            }
            if g * g1 < 0.0 {
                (s0, g0) = (s1, g1);
                side = 0;
            } else {
                if side == 1 {
                    g0 *= 0.5;
                }
                side = 1;
            }
            (s1, g1) = (s, g);
            if it + 1 == self.options.max_location_iterations {
                return Err(failed(p, it + 1));
            }
        }
        let mut c = best.ok_or_else(|| failed(a.parameter, 0))?;
        if kind == SpecialKind::BranchPoint || was_singular {
            // the tangent solve is singular at a branch point: keep the branch's direction
            c.tangent = a.tangent.clone();
        }
        let mut point = self.make_point(sys, c)?;
        point.special = Some(SpecialPoint {
            kind,
            location: Location::Located,
            parameter: point.parameter,
            critical: point.stability.as_ref().and_then(|s| s.critical(kind)),
            transversality: None,
        });
        Ok(point)
    }

    /// Direction of the branch crossing at the branch point `point` (a point of a branch of
    /// `sys` located as [`SpecialKind::BranchPoint`]): the null vector φ of G_u orthogonal
    /// (weighted metric) to the branch's tangent, unit length, its largest entry positive.
    ///
    /// At a simple branch point the null space of G_u is spanned by the tangents of the two
    /// crossing branches; φ is the null vector of the bordered Jacobian [G_u; (w∘t)ᵀ], found
    /// by two steps of inverse iteration with its LU. The hyperplane through the branch point
    /// orthogonal to φ holds the old branch's tangent, so a corrector constrained to
    /// φ·(u − u*) = h finds the crossing branch (pitchfork and transcritical alike).
    pub fn branch_direction<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        point: &BranchPoint,
    ) -> Result<Vec<f64>> {
        let w = sys.weights();
        let b = border(&w, &point.tangent);
        let mut entries = Vec::new();
        // exactly at the branch point the LU may break down: step a hair along the branch
        let what = "branch direction";
        let no = NeedsDeterminant::No;
        let step = match bordered_step(sys, &point.u, &b, 0.0, &mut entries, no, what) {
            Err(Error::SingularSystem { .. }) => {
                let u = along(&point.u, &point.tangent, 1e-9);
                bordered_step(sys, &u, &b, 0.0, &mut entries, no, what)?
            }
            r => r?,
        };
        let nu = point.u.len();
        // a fixed, generic start vector (deterministic)
        let mut phi: Vec<f64> = (0..nu)
            .map(|i| 0.5 + ((i + 1) as f64 * 0.618_033_988_749_895).fract())
            .collect();
        for _ in 0..2 {
            step.lu.solve(&mut phi, "branch direction")?;
            normalise(&w, &mut phi);
        }
        let along_t = weighted_dot(&w, &phi, &point.tangent);
        phi.iter_mut()
            .zip(&point.tangent)
            .for_each(|(p, t)| *p -= along_t * t);
        normalise(&w, &mut phi);
        let big = phi
            .iter()
            .fold(0.0f64, |m, v| if v.abs() > m.abs() { *v } else { m });
        if big < 0.0 {
            phi.iter_mut().for_each(|v| *v = -*v);
        }
        Ok(phi)
    }

    /// Start the branch that crosses at the branch point `point`: the corrector runs on the
    /// hyperplane at weighted distance `amplitude` along [`Continuation::branch_direction`]
    /// (the sign of `amplitude` chooses the side); the new branch is oriented away from the
    /// branch point and can be extended as usual.
    pub fn switch_branch<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        point: &BranchPoint,
        amplitude: f64,
    ) -> Result<Branch> {
        let phi = self.branch_direction(sys, point)?;
        let guess = along(&point.u, &phi, amplitude);
        let direction: Vec<f64> = phi.iter().map(|v| v * amplitude.signum()).collect();
        self.start(sys, &guess, &direction)
    }
}

/// One Newton step for the bordered system G(u) = 0, Σ w_i t_i (u_i − u_i) = 0 at `u`:
/// assembly of the residual and the sparse Jacobian, sparse LU and solve (the same bordered
/// solve the corrector runs). Returns the update Δu. (Exposed for benchmarks and tests.)
pub fn newton_step<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    tangent: &[f64],
) -> Result<Vec<f64>> {
    let w = sys.weights();
    let mut entries = Vec::new();
    let step = bordered_step(
        sys,
        u,
        &border(&w, tangent),
        0.0,
        &mut entries,
        NeedsDeterminant::No,
        "Newton step",
    )?;
    Ok(step.update)
}

/// Newton's method on the bordered system G(u) = 0, Σ w_i t_i (u_i − u0_i) = 0 from `u0`
/// with chord iterations: a factorisation is kept while the updates shrink at least
/// fourfold per iteration (the rate of the chord method is of the order of the update the
/// factorisation was made at) and renewed otherwise. Converged when the largest update is
/// at most `tolerance` times max(1, max |u_i|). Used where the same system is corrected
/// from a close guess many times (the cycles the Floquet computation re-solves on a
/// kink-resolved mesh). Returns the solution and a factorisation of the bordered Jacobian
/// made within `tolerance` (relative, max-norm) of it: the last one used where the
/// iterates moved at most that far since it was made, else a new one at the solution (the
/// Floquet multipliers are read off it, and a Jacobian 1e-4 away moves the trivial
/// multiplier of the trailer's cycles by as much).
pub(crate) fn correct_with_chord<S: ContinuationSystem>(
    sys: &mut S,
    u0: &[f64],
    tangent: &[f64],
    tolerance: f64,
    max_iterations: usize,
) -> Result<(Vec<f64>, SparseLu)> {
    let w = sys.weights();
    let b = border(&w, tangent);
    let mut u = u0.to_vec();
    let mut kept: Option<SparseLu> = None;
    let mut iterations = Iterations::new(&b, NeedsDeterminant::No, "Newton");
    let mut last = f64::INFINITY;
    let (mut size, mut residual) = (f64::NAN, f64::NAN);
    for _ in 0..max_iterations {
        let constraint = (0..u.len()).map(|i| b[i] * (u[i] - u0[i])).sum();
        let step;
        (step, size) = iterations.step(sys, &u, constraint, kept.take())?;
        residual = step.residual_norm;
        u.iter_mut().zip(&step.update).for_each(|(a, d)| *a += d);
        let scale = u.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        if size <= tolerance * scale {
            let lu = if iterations.moved <= tolerance * scale {
                step.lu
            } else {
                iterations.factorise(sys, &u, NeedsDeterminant::No, "Newton (at the solution)")?
            };
            return Ok((u, lu));
        }
        if size > 2.0 * last {
            // diverging (a guess this close converges monotonically): stop before the
            // iterates leave the cycle's neighbourhood (measured on the closed-loop
            // diagram at L = 120: a correction whose first update was 0.13 went on to
            // 1e46 in 12 iterations, its Jacobians reading the delay ahead — K ≈ 950
            // border unknowns — each factorised densely once GMRES gave up)
            break;
        }
        if size <= 0.25 * last {
            kept = Some(step.lu);
        }
        last = size;
    }
    Err(Error::NewtonDivergence {
        parameter: u[sys.parameter_index()],
        iterations: max_iterations,
        residual,
        update: size,
    })
}

/// Solutions on `branch` at the parameter value `p`: for every pair of consecutive points
/// that brackets `p`, the linear interpolant is corrected with the parameter fixed.
pub fn points_at_parameter<S: ContinuationSystem>(
    cont: &Continuation,
    sys: &mut S,
    branch: &Branch,
    p: f64,
) -> Result<Vec<BranchPoint>> {
    let ip = sys.parameter_index();
    let nu = sys.n_unknowns();
    let mut out = Vec::new();
    let mut e = vec![0.0; nu];
    e[ip] = 1.0;
    for w in branch.points.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if (a.parameter - p) * (b.parameter - p) > 0.0
            || a.parameter == b.parameter
            || (b.parameter == p)
        {
            continue;
        }
        let t = (p - a.parameter) / (b.parameter - a.parameter);
        let guess: Vec<f64> = a.u.iter().zip(&b.u).map(|(x, y)| x + t * (y - x)).collect();
        sys.accept(&guess);
        let mut pt = cont.start(sys, &guess, &e)?.points.remove(0);
        pt.tangent = a
            .tangent
            .iter()
            .zip(&b.tangent)
            .map(|(x, y)| x + t * (y - x))
            .collect();
        out.push(pt);
    }
    Ok(out)
}
