//! The nonlinear stability chart of one delay τ: curves of Hopf points V_hopf(D)
//! and of folds of cycles V_fold(D) of the closed loop (eq. 8) continued in the (D, V)
//! plane, the criticality of the Hopf points along the Hopf curves, and the
//! codimension-two points on the curves.
//!
//! Pipeline for one τ (no plotting, no I/O):
//! 1. at each seed gain D_s the first Hopf point of straight running in V
//!    ([`straight_running`]), refined and continued as a curve of Hopf points in (D, V)
//!    with [`HopfCurveSystem`] (both directions, until it leaves the (D, V) box); a seed
//!    lying on an already computed curve is skipped;
//! 2. the criticality of the Hopf points at sample points of every curve, from the
//!    direction of a short cycle branch started there ([`cycles_from_hopf`]);
//! 3. at the first seed, the cycle branch through its fold (the `fig4b` diagram); the fold
//!    refined and continued in (V, D) with [`FoldOfCyclesSystem`] until it leaves the box,
//!    ends on the Hopf curve (criticality change) or meets a cusp of cycles;
//! 4. the codimension-two points located on the curves.
//!
//! [`critical_speeds`] is the same machinery at one (τ, D): the Hopf and fold speeds that
//! `fig4b` reports, corrected on the two-parameter defining systems at fixed D.

use continuation::{
    Branch, BranchPoint, ChebyshevRoots, Continuation, ContinuationOptions, ContinuationSystem,
    Criticality, FoldCyclesOptions, FoldCyclesStop, FoldOfCyclesSystem, HopfCurveSystem, HopfPoint,
    MeshAdaptation, NewtonUpdate, PeriodicOrbitSystem, Refinement, SpecialKind, Stop,
};
use serde::{Deserialize, Serialize};
use sway_model::vehicle::Vehicle;
use trailer_model::HITCH_ANGLE;

use super::{
    BranchPointTest, ClosedLoop, CycleExtent, Diagram, DiagramOptions, GAIN, LoopLaw, SPEED,
    bifurcation_diagram_until, cycles_from_hopf, straight_running,
};
use crate::SwayError;
use crate::charts::auto_range::{
    BoxKeys, Derivation, SpeedBounds, SpeedGainBox, nonlinear_box, seed_gains,
};
use crate::parallel::{Split, join, map, try_map};
use sway_model::config::Omittable;
use sway_model::vehicle::LoopModel;

/// The settings of the nonlinear chart of one delay, with the (D, V) box as `B` and the
/// seed gains as `S`: [`ChartOptions`] with both given (`B` = f64, `S` = `Vec<f64>`),
/// [`ChartConfig`] as a config's `[chart]` table gives them (`Option`s: an omitted one is
/// derived from the vehicle, [`ChartConfig::resolve`]). An omitted value is not serialised
/// ([`Omittable`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ChartSpec<B: Omittable, S: Omittable> {
    /// speed range of the curves [v_min, v_max] \[m/s\]
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub v_min_mps: B,
    /// upper end of the speed range \[m/s\]
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub v_max_mps: B,
    /// gain range of the curves [d_min, d_max] \[s\]
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub d_min_s: B,
    /// upper end of the gain range \[s\]
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub d_max_s: B,
    /// gains at which Hopf curves are started \[s\] (the first one also starts the
    /// fold-of-cycles curve); a seed on an already computed curve is skipped; in a config
    /// omitted: the middle, the top and the bottom of the gain range
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub seed_gains_s: S,
    /// first and largest continuation step along the Hopf curves (weighted arclength in
    /// the unknowns [x, v, ω, D, V]; dominated by V \[m/s\])
    pub hopf_step: f64,
    /// largest step along the Hopf curves
    pub hopf_max_step: f64,
    /// at most this many points per Hopf curve and direction
    pub hopf_max_points: usize,
    /// first continuation step along the fold-of-cycles curves
    pub fold_step: f64,
    /// largest step along the fold-of-cycles curves
    pub fold_max_step: f64,
    /// at most this many points per fold-of-cycles curve and direction
    pub fold_max_points: usize,
    /// a step along a curve is rejected when the (weighted) tangent turns by more than
    /// arccos of this; the reported speeds are corrected at fixed D, so this only sets how
    /// densely the curves are sampled (0.8: 37°)
    pub curve_min_tangent_cosine: f64,
    /// the step along a curve grows when Newton needs fewer iterations than this
    pub curve_target_newton_iterations: usize,
    /// how the corrector along a curve updates its Jacobian (the chord method after two
    /// full iterations: the factorisations of the delay-coupled fold-of-cycles system
    /// dominate the chart's cost)
    pub curve_newton: NewtonUpdate,
    /// criticality sampled at this many points per Hopf curve (at least 2)
    pub criticality_samples: usize,
    /// cycle points used to judge the criticality at a sample
    pub criticality_cycle_points: usize,
    /// a fold-of-cycles curve ends on the Hopf curve when the cycle's amplitude (largest
    /// half peak-to-peak range of a state component) falls below this
    pub fold_min_amplitude: f64,
    /// cycles: collocation mesh, degree, first amplitude, steps (its speed range is
    /// replaced by the box's [v_min, v_max])
    pub cycles: DiagramOptions,
    /// the mesh of the fold speeds read at a fixed gain ([`critical_speeds`],
    /// [`NonlinearChart::fold_speed_at`]): `adapted` (default) corrects the fold again on
    /// meshes of `cycles.intervals` intervals adapted to its cycle (error density
    /// equidistributed, the tyre's kinks on mesh points, see
    /// [`continuation::PeriodicOrbitSystem::adapted_mesh`]): the fold of Table I at L = 40 then
    /// agrees with L = 160 to 1e-8 relative instead of ~1e-6; `fixed` keeps the uniform mesh
    pub fold_mesh: MeshAdaptation,
}

/// Options of the nonlinear chart of one delay: the box and the seeds given.
pub type ChartOptions = ChartSpec<f64, Vec<f64>>;

/// The `[chart]` table of a config (shared by `chart_nonlinear`, `corners` and
/// `gain_design`): [`ChartOptions`] with the box and the seeds optional (derived from the
/// vehicle where omitted).
pub type ChartConfig = ChartSpec<Option<f64>, Option<Vec<f64>>>;

impl<B: Omittable, S: Omittable> ChartSpec<B, S> {
    /// These settings with the box `v_min_mps`, `v_max_mps`, `d_min_s`, `d_max_s` and the
    /// seeds `seed_gains_s` in place of theirs.
    pub fn with_box<C: Omittable, T: Omittable>(
        &self,
        v_min_mps: C,
        v_max_mps: C,
        d_min_s: C,
        d_max_s: C,
        seed_gains_s: T,
    ) -> ChartSpec<C, T> {
        ChartSpec {
            v_min_mps,
            v_max_mps,
            d_min_s,
            d_max_s,
            seed_gains_s,
            hopf_step: self.hopf_step,
            hopf_max_step: self.hopf_max_step,
            hopf_max_points: self.hopf_max_points,
            fold_step: self.fold_step,
            fold_max_step: self.fold_max_step,
            fold_max_points: self.fold_max_points,
            curve_min_tangent_cosine: self.curve_min_tangent_cosine,
            curve_target_newton_iterations: self.curve_target_newton_iterations,
            curve_newton: self.curve_newton,
            criticality_samples: self.criticality_samples,
            criticality_cycle_points: self.criticality_cycle_points,
            fold_min_amplitude: self.fold_min_amplitude,
            cycles: self.cycles.clone(),
            fold_mesh: self.fold_mesh,
        }
    }
}

impl Default for ChartConfig {
    fn default() -> Self {
        Self::from_options(&ChartOptions::default(), false)
    }
}

impl ChartConfig {
    /// The table of `o`, with the box and the seeds given (`given`) or left to derive.
    pub fn from_options(o: &ChartOptions, given: bool) -> Self {
        let g = |x: f64| given.then_some(x);
        o.with_box(
            g(o.v_min_mps),
            g(o.v_max_mps),
            g(o.d_min_s),
            g(o.d_max_s),
            given.then(|| o.seed_gains_s.clone()),
        )
    }

    /// The box keys as given.
    pub fn box_keys(&self) -> BoxKeys {
        BoxKeys {
            v_min_mps: self.v_min_mps,
            v_max_mps: self.v_max_mps,
            d_min_s: self.d_min_s,
            d_max_s: self.d_max_s,
        }
    }

    /// The chart options with box `b` and seeds `seeds`.
    pub fn options(&self, b: &SpeedGainBox, seeds: Vec<f64>) -> ChartOptions {
        self.with_box(b.v_min_mps, b.v_max_mps, b.d_min_s, b.d_max_s, seeds)
    }

    /// The chart options over `delays` \[s\]: the given box keys and seeds, the others
    /// derived ([`nonlinear_box`], [`seed_gains`]); keys named with `prefix`.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] from the derivation.
    pub fn resolve<M: LoopModel + ?Sized>(
        &self,
        model: &M,
        delays: &[f64],
        b: &SpeedBounds,
        prefix: &str,
    ) -> Result<(ChartOptions, Derivation), SwayError> {
        let (bx, mut der) = nonlinear_box(model, &self.box_keys(), delays, b, prefix)?;
        let seeds = match &self.seed_gains_s {
            Some(s) => s.clone(),
            None => {
                der.derived_keys.push(format!("{prefix}seed_gains_s"));
                seed_gains((bx.d_min_s, bx.d_max_s))
            }
        };
        Ok((self.options(&bx, seeds), der))
    }
}

impl Default for ChartOptions {
    fn default() -> Self {
        Self {
            v_min_mps: 5.0,
            v_max_mps: 70.0,
            d_min_s: -0.1,
            d_max_s: 0.3,
            seed_gains_s: vec![0.1, 0.3, -0.1],
            hopf_step: 0.1,
            hopf_max_step: 1.0,
            hopf_max_points: 400,
            fold_step: 0.1,
            fold_max_step: 2.0,
            fold_max_points: 300,
            curve_min_tangent_cosine: 0.8,
            curve_target_newton_iterations: 4,
            curve_newton: NewtonUpdate::Chord { full: 2 },
            criticality_samples: 5,
            criticality_cycle_points: 3,
            fold_min_amplitude: 1e-3,
            cycles: DiagramOptions {
                intervals: 40,
                max_step: 0.5,
                ..DiagramOptions::default()
            },
            fold_mesh: MeshAdaptation::Adapted,
        }
    }
}

impl ChartOptions {
    /// The chart options that correct a diagram computed with `o` (same mesh, roots and
    /// speed range; curve settings at their defaults), as `fig4b` uses them.
    pub fn correcting(o: &DiagramOptions) -> Self {
        Self {
            v_min_mps: o.v_min_mps,
            v_max_mps: o.v_max_mps,
            cycles: o.clone(),
            ..Self::default()
        }
    }

    /// the cycle branches' options: the box's speed range, and no branch-point test (the
    /// chart reads the fold and the criticality off its cycle branches, nothing else; without
    /// the test the engine factorises with supernodes, 2× faster at τ = 0.4 s)
    #[doc(hidden)] // pub for tests/unit
    pub fn cycle_options(&self) -> DiagramOptions {
        DiagramOptions {
            v_min_mps: self.v_min_mps,
            v_max_mps: self.v_max_mps,
            cycle_branch_points: BranchPointTest::Ignore,
            ..self.cycles.clone()
        }
    }

    fn in_box(&self, d: f64, v: f64) -> bool {
        d >= self.d_min_s && d <= self.d_max_s && v >= self.v_min_mps && v <= self.v_max_mps
    }

    fn roots(&self) -> ChebyshevRoots {
        ChebyshevRoots {
            degree: self.cycles.root_degree,
            count: 8,
            refinement: Refinement::Newton,
        }
    }
}

/// One point of a Hopf curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HopfCurvePoint {
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// frequency ω of the critical pair \[rad/s\]
    pub omega_rad_s: f64,
}

/// The criticality of the Hopf point at one point of a Hopf curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CriticalitySample {
    /// index of the point in [`HopfCurve::points`]
    pub index: usize,
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// from the direction of the cycle branch born there
    pub criticality: Criticality,
}

/// A curve of Hopf points in the (D, V) plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HopfCurve {
    /// the seed gain it was started at \[s\]
    pub seed_d_s: f64,
    /// the continuation towards decreasing and increasing D from the seed (unknowns of
    /// [`HopfCurveSystem`] with free parameters [D, V])
    pub branches: [Branch; 2],
    /// the points in order along the curve (from the decreasing-D end to the other end)
    pub points: Vec<HopfCurvePoint>,
    /// criticality at sample points, in curve order
    pub criticality: Vec<CriticalitySample>,
    /// how each direction ended (decreasing D first)
    #[serde(default)]
    pub ends: Vec<CurveEnd>,
}

impl HopfCurve {
    /// Criticality of the curve point `i`: that of the nearest sample (None without
    /// samples).
    pub fn criticality_at(&self, i: usize) -> Option<Criticality> {
        self.criticality
            .iter()
            .min_by_key(|s| s.index.abs_diff(i))
            .map(|s| s.criticality)
    }
}

/// One point of a fold-of-cycles curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FoldCurvePoint {
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// period of the fold's cycle \[s\]
    pub period_s: f64,
    /// max |θ| on the fold's cycle \[deg\]
    pub amplitude_deg: f64,
}

/// A curve of folds of cycles in the (D, V) plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoldCurve {
    /// the seed gain \[s\]
    pub seed_d_s: f64,
    /// the continuation towards decreasing and increasing D from the seed (unknowns of
    /// [`FoldOfCyclesSystem`] with free parameters [V, D])
    pub branches: [Branch; 2],
    /// the points in order along the curve
    pub points: Vec<FoldCurvePoint>,
    /// how each direction ended (decreasing D first)
    #[serde(default)]
    pub ends: Vec<CurveEnd>,
}

/// How one direction of a chart's curve ended (serialised with its `reason`). A curve
/// that cannot go on is a result: its points so far are kept, its end says why it stops.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum CurveEnd {
    /// it left the chart's (D, V) box or its parameter range (the whole curve in the box)
    LeftBox {
        /// gain of its last point \[s\]
        d_s: f64,
        /// speed of its last point \[m/s\]
        v_mps: f64,
    },
    /// it used its point budget (`hopf_max_points`, `fold_max_points`)
    Budget {
        /// points computed in this direction
        points: usize,
    },
    /// it ended at a codimension-two point where such a curve ends (a fold-of-cycles curve
    /// on the Hopf curve where the criticality changes)
    SingularPoint {
        /// which point
        kind: Codim2Kind,
        /// its gain \[s\]
        d_s: f64,
        /// its speed \[m/s\]
        v_mps: f64,
    },
    /// the continuation step fell below its minimum (a singular point of the extended
    /// system the engine does not classify, or a curve too sharp to follow)
    StepUnderflow {
        /// gain of its last point \[s\]
        d_s: f64,
        /// speed of its last point \[m/s\]
        v_mps: f64,
    },
    /// the Newton corrector failed (after the engine's step reductions)
    CorrectorFailure {
        /// gain of its last point \[s\] (None: no point in this direction)
        d_s: Option<f64>,
        /// speed of its last point \[m/s\]
        v_mps: Option<f64>,
        /// the corrector's free parameter where it failed
        parameter: f64,
        /// iterations done
        iterations: usize,
        /// max-norm of the residual at the last iterate
        residual: f64,
        /// max-norm of the last update
        update: f64,
    },
    /// another numerical failure (a singular linear system, a non-finite value, …)
    Failure {
        /// gain of its last point \[s\] (None: no point in this direction)
        d_s: Option<f64>,
        /// speed of its last point \[m/s\]
        v_mps: Option<f64>,
        /// the error
        message: String,
    },
}

impl CurveEnd {
    /// Whether the curve ended before its box, budget or natural end (step underflow,
    /// corrector or other numerical failure): the part of the chart beyond it is unknown.
    pub fn is_early(&self) -> bool {
        matches!(
            self,
            Self::StepUnderflow { .. } | Self::CorrectorFailure { .. } | Self::Failure { .. }
        )
    }

    /// The end of a direction that failed with `e` after its last point at (D, V) (None:
    /// no point in this direction).
    pub fn failed(last: Option<(f64, f64)>, e: &continuation::Error) -> Self {
        let (d_s, v_mps) = (last.map(|l| l.0), last.map(|l| l.1));
        match *e {
            continuation::Error::NewtonDivergence {
                parameter,
                iterations,
                residual,
                update,
            } => Self::CorrectorFailure {
                d_s,
                v_mps,
                parameter,
                iterations,
                residual,
                update,
            },
            _ => Self::failure(last, e),
        }
    }

    /// A failure described by its message, after the last point `last` (D, V).
    fn failure(last: Option<(f64, f64)>, e: &impl std::fmt::Display) -> Self {
        Self::Failure {
            d_s: last.map(|l| l.0),
            v_mps: last.map(|l| l.1),
            message: e.to_string(),
        }
    }

    /// The end of a direction (or a read-off) that failed with the engine error `e`:
    /// the continuation error inside it where there is one.
    pub fn from_error(last: Option<(f64, f64)>, e: &SwayError) -> Self {
        let inner = match e {
            SwayError::Numerical { cause, .. } => cause.downcast_ref::<continuation::Error>(),
            _ => None,
        };
        match inner {
            Some(c) => Self::failed(last, c),
            None => Self::failure(last, e),
        }
    }

    /// One line for the console and the notes.
    pub fn describe(&self) -> String {
        let at = |d: Option<f64>, v: Option<f64>| match (d, v) {
            (Some(d), Some(v)) => format!(" after D = {d:.4} s, V = {v:.3} m/s"),
            _ => " at its start".into(),
        };
        match self {
            Self::LeftBox { d_s, v_mps } => {
                format!("left the box at D = {d_s:.4} s, V = {v_mps:.3} m/s")
            }
            Self::Budget { points } => format!("used its budget of {points} points"),
            Self::SingularPoint { kind, d_s, v_mps } => {
                format!(
                    "ends at a {} point, D = {d_s:.4} s, V = {v_mps:.3} m/s",
                    kind.name()
                )
            }
            Self::StepUnderflow { d_s, v_mps } => format!(
                "stopped: the step fell below its minimum at D = {d_s:.4} s, V = {v_mps:.3} m/s"
            ),
            Self::CorrectorFailure {
                d_s,
                v_mps,
                parameter,
                iterations,
                residual,
                update,
            } => format!(
                "stopped{}: the Newton corrector did not converge at parameter {parameter:.6} after {iterations} iterations (residual {residual:.1e}, last update {update:.1e})",
                at(*d_s, *v_mps)
            ),
            Self::Failure {
                d_s,
                v_mps,
                message,
            } => format!("stopped{}: {message}", at(*d_s, *v_mps)),
        }
    }
}

/// A curve (or a point read off one) of the chart that ended early, as `summary.json`
/// reports it under `curves_ended_early`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EndedCurve {
    /// which curve and direction
    pub curve: String,
    /// how it ended
    pub end: CurveEnd,
}

/// The kinds of codimension-two points of the chart (serialised as in `summary.json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Codim2Kind {
    /// two critical pairs ±iω1, ±iω2 on a Hopf curve
    DoubleHopf,
    /// a zero eigenvalue and a pair ±iω
    ZeroHopf,
    /// a double zero eigenvalue
    BogdanovTakens,
    /// the Hopf point changes criticality (a fold-of-cycles curve ends on the Hopf curve)
    CriticalityChange,
    /// two folds of cycles meet
    CuspOfCycles,
}

impl Codim2Kind {
    fn from_special(kind: SpecialKind) -> Option<Self> {
        Some(match kind {
            SpecialKind::DoubleHopf => Self::DoubleHopf,
            SpecialKind::ZeroHopf => Self::ZeroHopf,
            SpecialKind::BogdanovTakens => Self::BogdanovTakens,
            SpecialKind::CriticalityChange => Self::CriticalityChange,
            SpecialKind::CuspOfCycles => Self::CuspOfCycles,
            _ => return None,
        })
    }

    /// the name used in `summary.json`
    pub fn name(&self) -> &'static str {
        match self {
            Self::DoubleHopf => "double_hopf",
            Self::ZeroHopf => "zero_hopf",
            Self::BogdanovTakens => "bogdanov_takens",
            Self::CriticalityChange => "criticality_change",
            Self::CuspOfCycles => "cusp_of_cycles",
        }
    }
}

/// A codimension-two point of the chart.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Codim2 {
    /// what it is
    pub kind: Codim2Kind,
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// the critical frequencies \[rad/s\] (both at a double-Hopf point), ascending: the
    /// same point found on either of its two Hopf curves reads the same
    pub omega_rad_s: Vec<f64>,
}

/// The nonlinear chart of one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NonlinearChart {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// the options used
    pub options: ChartOptions,
    /// the Hopf curves
    pub hopf_curves: Vec<HopfCurve>,
    /// the fold-of-cycles curves
    pub fold_curves: Vec<FoldCurve>,
    /// codimension-two points on the curves
    pub codim2_points: Vec<Codim2>,
    /// seeds that were skipped or failed, with the reason
    pub notes: Vec<String>,
    /// why there is no Hopf curve (None: there is one)
    #[serde(default)]
    pub hopf_reason: Option<String>,
    /// why there is no fold-of-cycles curve (None: there is one)
    #[serde(default)]
    pub fold_reason: Option<String>,
    /// curves that ended early (and speeds that could not be read off them), with how
    #[serde(default)]
    pub curves_ended_early: Vec<EndedCurve>,
    /// the fold-of-cycles curve is incomplete (ended early or could not be computed): the
    /// stable cells it does not reach are [`Region::Unknown`], never safe
    #[serde(default)]
    pub fold_incomplete: bool,
}

/// The Hopf and fold speeds of one feedback setting, each corrected on its two-parameter
/// defining system at the fixed gain (the points the chart's curves pass through).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CriticalSpeeds {
    /// the Hopf point as located on the straight-running branch (start of the correction)
    pub located_hopf: HopfPoint,
    /// Hopf speed \[m/s\]
    pub hopf_v_mps: f64,
    /// Hopf frequency \[rad/s\]
    pub hopf_omega_rad_s: f64,
    /// criticality (from the cycle branch)
    pub criticality: Criticality,
    /// the fold of cycles, if the branch has one in the speed range
    pub fold: Option<FoldCurvePoint>,
    /// corrections that failed (the Hopf speed then is the located one, the fold None),
    /// with how they ended
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub curves_ended_early: Vec<EndedCurve>,
}

fn num(context: String) -> impl FnOnce(continuation::Error) -> SwayError {
    move |e| SwayError::numerical(context, e)
}

fn invalid(context: String, message: String) -> SwayError {
    SwayError::numerical(context, continuation::Error::InvalidInput(message))
}

impl ChartOptions {
    /// The continuation of a curve with first step `step`, largest step `max_step`, the
    /// primary parameter in `range`, and the chart's step control.
    fn continuation(&self, step: f64, max_step: f64, range: (f64, f64)) -> Continuation {
        Continuation::new(ContinuationOptions {
            initial_step: step,
            max_step,
            parameter_range: range,
            min_tangent_cosine: self.curve_min_tangent_cosine,
            target_newton_iterations: self.curve_target_newton_iterations,
            newton: self.curve_newton,
            ..Default::default()
        })
    }
}

#[doc(hidden)] // pub for tests/unit
pub type HopfSystem<'a, P, const N: usize> =
    HopfCurveSystem<'a, ClosedLoop<'a, P, N>, ChebyshevRoots>;

/// Extends `branch` in chunks until it stops, leaves the box (through the secondary
/// parameter, which the engine does not watch) or has `max_points` points; how it ended
/// (a failure keeps the points so far: `at` gives (D, V) of a point).
fn extend_in_box<S: ContinuationSystem>(
    cont: &Continuation,
    sys: &mut S,
    branch: &mut Branch,
    max_points: usize,
    inside: impl Fn(&BranchPoint) -> bool,
    at: impl Fn(&BranchPoint) -> (f64, f64),
) -> CurveEnd {
    const CHUNK: usize = 8;
    let last = |b: &Branch| b.points.last().map(&at);
    loop {
        if branch.points.len() >= max_points {
            return CurveEnd::Budget {
                points: branch.points.len(),
            };
        }
        let stop = match cont.extend(sys, branch, CHUNK) {
            Ok(stop) => stop,
            Err(e) => return CurveEnd::failed(last(branch), &e),
        };
        let (d_s, v_mps) = last(branch).unwrap_or((f64::NAN, f64::NAN));
        let out = branch.points.last().is_some_and(|p| !inside(p));
        match stop {
            Stop::MaxPoints if !out => {}
            Stop::StepSizeUnderflow { .. } => return CurveEnd::StepUnderflow { d_s, v_mps },
            _ => return CurveEnd::LeftBox { d_s, v_mps },
        }
    }
}

/// Both directions of a curve from the corrected start `guess` along ±`dir`, each extended
/// by `extend` (which says how it ended). A direction whose start fails keeps the other
/// direction's first point (both start at the seed) and ends with the failure; None if
/// both starts fail (the first failure).
fn both_directions<S: ContinuationSystem>(
    cont: &Continuation,
    sys: &mut S,
    guess: &[f64],
    dir: &[f64],
    at: impl Fn(&BranchPoint) -> (f64, f64),
    mut extend: impl FnMut(&mut S, &mut Branch) -> CurveEnd,
) -> Result<([Branch; 2], Vec<CurveEnd>), continuation::Error> {
    // each direction started and extended in turn (the system's state as before this
    // tolerated failures: the results of complete curves do not change)
    let mut started: Vec<Result<Branch, continuation::Error>> = Vec::new();
    let mut ends = Vec::new();
    for sign in [-1.0, 1.0] {
        sys.accept(guess);
        let dir: Vec<f64> = dir.iter().map(|v| sign * v).collect();
        let mut b = cont.start(sys, guess, &dir);
        ends.push(match &mut b {
            Ok(b) => extend(sys, b),
            Err(e) => CurveEnd::failed(None, e),
        });
        started.push(b);
    }
    let seed = match (&started[0], &started[1]) {
        (Ok(b), _) | (Err(_), Ok(b)) => b.points[0].clone(),
        (Err(e), Err(_)) => return Err(e.clone()),
    };
    let branches: Vec<Branch> = started
        .into_iter()
        .map(|b| {
            b.unwrap_or_else(|_| Branch {
                points: vec![seed.clone()],
                state: continuation::ContinuationState {
                    step: cont.options.initial_step,
                    accepted_steps: 0,
                    rejected_steps: 0,
                },
            })
        })
        .collect();
    for (end, b) in ends.iter_mut().zip(&branches) {
        if let CurveEnd::CorrectorFailure { d_s, v_mps, .. } | CurveEnd::Failure { d_s, v_mps, .. } =
            end
            && d_s.is_none()
        {
            let (d, v) = at(&b.points[0]);
            (*d_s, *v_mps) = (Some(d), Some(v));
        }
    }
    let branches: [Branch; 2] = branches
        .try_into()
        .map_err(|_| continuation::Error::InvalidInput("two directions expected".into()))?;
    Ok((branches, ends))
}

/// Points of a curve where the unknown `index` equals `value`: every bracketing pair of
/// consecutive points, linearly interpolated and corrected with that unknown fixed.
fn curve_points_at<S: ContinuationSystem>(
    sys: &mut S,
    branches: &[Branch],
    index: usize,
    value: f64,
) -> Result<Vec<Vec<f64>>, continuation::Error> {
    let cont = Continuation::default();
    let mut out = Vec::new();
    for b in branches {
        for w in b.points.windows(2) {
            // a point within rounding of `value` counts as on it (a curve's seed at D = 0
            // comes out of the corrector as ±1e-18 or so): taken as the start of its
            // window, skipped as the end of one
            let (a, c) = (w[0].u[index], w[1].u[index]);
            let tol = 1e-12 * value.abs().max(1.0);
            let (at_a, at_c) = ((a - value).abs() <= tol, (c - value).abs() <= tol);
            if at_c || a == c || (!at_a && (a - value) * (c - value) > 0.0) {
                continue;
            }
            let t = if at_a { 0.0 } else { (value - a) / (c - a) };
            let guess: Vec<f64> = w[0]
                .u
                .iter()
                .zip(&w[1].u)
                .map(|(x, y)| x + t * (y - x))
                .collect();
            let mut e = vec![0.0; guess.len()];
            e[index] = 1.0;
            sys.accept(&guess);
            out.push(cont.start(sys, &guess, &e)?.points.remove(0).u);
        }
    }
    Ok(out)
}

/// The fold of cycles `u` corrected by `cont` (with parameter `fixed` held) in its
/// canonical phase (θ largest at s = 0), to the fixed point: the discrete fold depends on
/// the cycle's phase relative to the mesh (the C¹ tyre's kinks), and one correction from
/// the canonical shift of a guess ends at the phase of that guess's maximum, not at the
/// corrected cycle's. Repeating shift and correction until V stops moving gives the same
/// discrete fold from any guess (measured: one pass left 4e-6 relative between the fold of
/// a cycle branch and the same fold read off a fold-of-cycles curve at L = 20; the passes
/// converge geometrically).
fn corrected_in_canonical_phase<P: Vehicle<N>, const N: usize>(
    cont: &Continuation,
    sys: &mut FoldSystem<'_, P, N>,
    u: &[f64],
    fixed: usize,
) -> Result<Vec<f64>, continuation::Error> {
    const PASSES: usize = 8;
    let (iv, _) = fold_indices(sys);
    let mut u = u.to_vec();
    for pass in 0..PASSES {
        let canonical = sys.canonical(&u, HITCH_ANGLE);
        sys.accept(&canonical);
        let mut e = vec![0.0; canonical.len()];
        e[fixed] = 1.0;
        let next = cont.start(sys, &canonical, &e)?.points.remove(0).u;
        let moved = (next[iv] - u[iv]).abs();
        u = next;
        if pass > 0 && moved <= 1e-13 * u[iv].abs() {
            break;
        }
    }
    Ok(u)
}

/// The two branches of a curve joined in curve order: the first reversed, then the second
/// without its first point (both start at the seed).
fn joined(branches: &[Branch; 2]) -> impl Iterator<Item = &BranchPoint> {
    branches[0]
        .points
        .iter()
        .rev()
        .chain(branches[1].points.iter().skip(1))
}

/// The Hopf-curve system of the closed loop with free parameters [D, V] (D primary),
/// the gain set to `d` (where [`HopfCurveSystem::start_at_hopf`] starts).
#[doc(hidden)] // pub for tests/unit
pub fn hopf_system<'a, P: Vehicle<N>, const N: usize>(
    problem: &'a ClosedLoop<'a, P, N>,
    d: f64,
    o: &ChartOptions,
) -> Result<HopfSystem<'a, P, N>, SwayError> {
    let mut params = problem.parameters(0.0);
    params[GAIN] = d;
    HopfCurveSystem::new(problem, params, [GAIN, SPEED], o.roots())
        .map_err(num("Hopf curve system".into()))
}

/// D, V and ω of the Hopf-curve unknowns [x (N), Re v (N), Im v (N), ω, D, V]: the last three
fn hopf_d(u: &[f64]) -> f64 {
    u[u.len() - 2]
}
fn hopf_v(u: &[f64]) -> f64 {
    u[u.len() - 1]
}
fn hopf_omega(u: &[f64]) -> f64 {
    u[u.len() - 3]
}
/// index of D in the Hopf-curve unknowns of an N-state loop
const fn hopf_d_index(n: usize) -> usize {
    3 * n + 1
}

fn hopf_curve_point(u: &[f64]) -> HopfCurvePoint {
    HopfCurvePoint {
        d_s: hopf_d(u),
        v_mps: hopf_v(u),
        omega_rad_s: hopf_omega(u),
    }
}

/// The Hopf curve through the located Hopf point `hopf` at gain `d`, both directions; a
/// direction that cannot go on ends with its reason ([`HopfCurve::ends`]).
fn hopf_curve<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    d: f64,
    hopf: &HopfPoint,
    o: &ChartOptions,
) -> Result<HopfCurve, SwayError> {
    let ctx = format!("Hopf curve from D = {d} s, V = {} m/s", hopf.parameter);
    let mut sys = hopf_system(problem, d, o)?;
    let cont = o.continuation(o.hopf_step, o.hopf_max_step, (o.d_min_s, o.d_max_s));
    let inside = |p: &BranchPoint| o.in_box(hopf_d(&p.u), hopf_v(&p.u));
    let at = |p: &BranchPoint| (hopf_d(&p.u), hopf_v(&p.u));
    let (guess, dir) = sys.start_at_hopf(hopf, SPEED).map_err(num(ctx.clone()))?;
    let (branches, ends) = both_directions(&cont, &mut sys, &guess, &dir, at, |sys, b| {
        extend_in_box(&cont, sys, b, o.hopf_max_points, inside, at)
    })
    .map_err(num(ctx))?;
    let points = joined(&branches).map(|p| hopf_curve_point(&p.u)).collect();
    Ok(HopfCurve {
        seed_d_s: d,
        branches,
        points,
        criticality: Vec::new(),
        ends,
    })
}

/// Criticality of the Hopf point at (D, V) of a curve with frequency ω: the Hopf point
/// re-located on straight running near V (so that the transversality is known), then a
/// short cycle branch from it. None if the located point is another mode (ω differs by
/// more than 1 %).
fn criticality_at<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    p: &HopfCurvePoint,
    o: &ChartOptions,
) -> Result<Option<Criticality>, SwayError> {
    let mut params = problem.parameters(p.v_mps);
    params[GAIN] = p.d_s;
    let half = 0.3;
    // a point whose Hopf point cannot be re-located (e.g. a curve grazing the box's speed
    // range) keeps an unknown criticality instead of failing the chart
    let Ok((_, hopf)) = straight_running(
        problem,
        &params,
        (p.v_mps - half, p.v_mps + half),
        o.cycles.root_degree,
    ) else {
        return Ok(None);
    };
    if (hopf.omega - p.omega_rad_s.abs()).abs() > 0.01 * p.omega_rad_s.abs() {
        return Ok(None);
    }
    let co = o.cycle_options();
    let (_, _, crit) = cycles_from_hopf(
        problem,
        &params,
        &hopf,
        &co,
        o.criticality_cycle_points,
        CycleExtent::WholeRange,
    )?;
    Ok(Some(crit))
}

/// Samples the criticality at evenly spaced points of the curve inside the box.
fn sample_criticality<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    curve: &HopfCurve,
    o: &ChartOptions,
) -> Result<Vec<CriticalitySample>, SwayError> {
    let inside: Vec<usize> = (0..curve.points.len())
        .filter(|&i| o.in_box(curve.points[i].d_s, curve.points[i].v_mps))
        .collect();
    if inside.is_empty() {
        return Ok(Vec::new());
    }
    let k = o.criticality_samples.max(2);
    let mut picks: Vec<usize> = (0..k)
        .map(|j| inside[j * (inside.len() - 1) / (k - 1)])
        .collect();
    picks.dedup();
    let samples = try_map(&picks, Split::Adaptive, &|_, &i| {
        let p = curve.points[i];
        Ok::<_, SwayError>(criticality_at(problem, &p, o)?.map(|c| CriticalitySample {
            index: i,
            d_s: p.d_s,
            v_mps: p.v_mps,
            criticality: c,
        }))
    })?;
    Ok(samples.into_iter().flatten().collect())
}

/// Lowest speed of the Hopf curves at gain `d`, each crossing corrected at fixed D.
fn lowest_hopf_speed<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    curves: &[HopfCurve],
    d: f64,
    o: &ChartOptions,
) -> Result<Option<f64>, SwayError> {
    let mut sys = hopf_system(problem, d, o)?;
    let mut best: Option<f64> = None;
    for c in curves {
        let pts = curve_points_at(&mut sys, &c.branches, hopf_d_index(N), d)
            .map_err(num(format!("Hopf curve at D = {d} s")))?;
        for u in pts {
            let v = hopf_v(&u);
            if v >= o.v_min_mps && v <= o.v_max_mps {
                best = Some(best.map_or(v, |b: f64| b.min(v)));
            }
        }
    }
    Ok(best)
}

/// A seed lies on a computed curve: same frequency (1 %) and within 0.5 m/s of a curve
/// point interpolated at its gain.
fn on_curve(curves: &[HopfCurve], d: f64, hopf: &HopfPoint) -> bool {
    curves.iter().any(|c| {
        c.points.windows(2).any(|w| {
            let (a, b) = (w[0], w[1]);
            if (a.d_s - d) * (b.d_s - d) > 0.0 || a.d_s == b.d_s {
                return false;
            }
            let t = (d - a.d_s) / (b.d_s - a.d_s);
            let v = a.v_mps + t * (b.v_mps - a.v_mps);
            let w = a.omega_rad_s.abs() + t * (b.omega_rad_s.abs() - a.omega_rad_s.abs());
            (v - hopf.parameter).abs() < 0.5 && (w - hopf.omega).abs() < 0.01 * w
        })
    })
}

/// Fold-of-cycles system unknowns [x, T, V, D, v, v_T]: index of V and D
fn fold_indices<P: Vehicle<N>, const N: usize>(
    sys: &FoldOfCyclesSystem<'_, ClosedLoop<'_, P, N>>,
) -> (usize, usize) {
    let ip = sys.parameter_index();
    (ip, ip + 1)
}

fn fold_curve_point<P: Vehicle<N>, const N: usize>(
    sys: &FoldOfCyclesSystem<'_, ClosedLoop<'_, P, N>>,
    u: &[f64],
) -> Result<FoldCurvePoint, continuation::Error> {
    let (iv, id) = fold_indices(sys);
    let po = sys.periodic_system(u)?;
    Ok(FoldCurvePoint {
        d_s: u[id],
        v_mps: u[iv],
        period_s: sys.period(u),
        amplitude_deg: po.max_abs(sys.orbit(u), HITCH_ANGLE).to_degrees(),
    })
}

fn fold_options(o: &ChartOptions) -> FoldCyclesOptions {
    FoldCyclesOptions {
        min_amplitude: o.fold_min_amplitude,
        multipliers: false,
    }
}

/// The Hopf point `hopf` (located on straight running at the gain of `problem`'s
/// parameters) corrected on the Hopf-curve system at fixed D; returns the unknowns.
fn corrected_hopf<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    d: f64,
    hopf: &HopfPoint,
    o: &ChartOptions,
) -> Result<Vec<f64>, SwayError> {
    let ctx = format!("Hopf point at D = {d} s, τ = {} s", problem.law().delay_s);
    let mut hs = hopf_system(problem, d, o)?;
    let (guess, dir) = hs.start_at_hopf(hopf, SPEED).map_err(num(ctx.clone()))?;
    let mut b = Continuation::default()
        .start(&mut hs, &guess, &dir)
        .map_err(num(ctx))?;
    Ok(b.points.remove(0).u)
}

type FoldSystem<'a, P, const N: usize> = FoldOfCyclesSystem<'a, ClosedLoop<'a, P, N>>;

/// The fold u of `sys` (corrected at fixed D) corrected again at that D on meshes adapted
/// to its cycle ([`FoldOfCyclesSystem::adapted`], as many intervals as `o.cycles`): up to
/// [`FOLD_MESH_ROUNDS`] rounds, until V moves by less than 1e-12 relative (the second round
/// puts the mesh points on the kinks of the first round's fold). The system on the last
/// mesh and the fold there; None with [`MeshAdaptation::Fixed`] or when the first round
/// fails (a refinement that does not converge keeps the uniform mesh's fold: the caller's
/// value stands, to its mesh's accuracy).
fn on_fold_mesh<'a, P: Vehicle<N>, const N: usize>(
    sys: &FoldSystem<'a, P, N>,
    u: &[f64],
    o: &ChartOptions,
) -> Option<FoldAt<'a, P, N>> {
    if o.fold_mesh == MeshAdaptation::Fixed {
        return None;
    }
    let cont = Continuation::default();
    let mut current: Option<FoldAt<'a, P, N>> = None;
    for _ in 0..FOLD_MESH_ROUNDS {
        let (from, at) = current
            .as_ref()
            .map_or((sys, u), |(s, v)| (s, v.as_slice()));
        // V and D sit after the profile: their indices move with the mesh's size
        let v_before = at[fold_indices(from).0];
        let round = from
            .adapted(at, o.cycles.intervals)
            .and_then(|(mut next, guess)| {
                let (_, id) = fold_indices(&next);
                let mut fixed_d = vec![0.0; guess.len()];
                fixed_d[id] = 1.0;
                let fold = cont.start(&mut next, &guess, &fixed_d)?.points.remove(0).u;
                Ok((next, fold))
            });
        let Ok((next, fold)) = round else {
            break;
        };
        let v = fold[fold_indices(&next).0];
        let converged = (v - v_before).abs() <= 1e-12 * v.abs();
        current = Some((next, fold));
        if converged {
            break;
        }
    }
    current
}

/// A fold of cycles on its own mesh: the system and the point.
type FoldAt<'a, P, const N: usize> = (FoldSystem<'a, P, N>, Vec<f64>);

/// Most mesh-adaptation rounds of a fold (see [`on_fold_mesh`]).
const FOLD_MESH_ROUNDS: usize = 3;

/// A fold of cycles corrected at fixed D: its system, the point and the direction +D.
struct CorrectedFold<'a, P: Vehicle<N>, const N: usize> {
    sys: FoldSystem<'a, P, N>,
    u: Vec<f64>,
    direction: Vec<f64>,
}

/// The fold of the cycle branch of `diagram` corrected on the fold-of-cycles system at the
/// diagram's gain, finally from the cycle's canonical phase. None if the cycle branch has
/// no fold (no flagged fold at which V has a local minimum, `lower_fold`). Where the
/// corrector diverges on the branch's mesh, once more on a mesh adapted to the fold's
/// cycle ([`fold_started_at`]).
fn corrected_fold<'a, P: Vehicle<N>, const N: usize>(
    problem: &'a ClosedLoop<'a, P, N>,
    diagram: &Diagram,
    o: &ChartOptions,
) -> Result<Option<CorrectedFold<'a, P, N>>, SwayError> {
    let fb = diagram.law;
    let ctx = format!(
        "fold of cycles at D = {} s, τ = {} s",
        fb.gains.yaw_rate, fb.delay_s
    );
    // the fold of cycles: the first flagged fold at which V has a local minimum
    // (`super::lower_fold`; a fold flag where V runs on is no turning point, and the
    // fold-of-cycles system has no solution near it)
    let Some(i) = super::lower_fold(&diagram.cycles) else {
        return Ok(None);
    };
    let cont = o.continuation(o.fold_step, o.fold_max_step, (o.v_min_mps, o.v_max_mps));
    let (mut sys, first, dir) = fold_started_at(problem, diagram, i, &cont, o, &ctx)?;
    let (_, id) = fold_indices(&sys);
    let u =
        corrected_in_canonical_phase(&cont, &mut sys, &first.points[0].u, id).map_err(num(ctx))?;
    Ok(Some(CorrectedFold {
        sys,
        u,
        direction: dir,
    }))
}

/// The fold-of-cycles system started at the lower fold `i` of `diagram`'s cycle branch, on
/// the branch's mesh or, where that corrector diverges (the mesh may be the cause: a kink of
/// the cycle inside an interval), once more on a mesh adapted to the fold's cycle
/// ([`fold_started_adapted`]). The error of the branch's mesh, with the retry's.
fn fold_started_at<'a, P: Vehicle<N>, const N: usize>(
    problem: &'a ClosedLoop<'a, P, N>,
    diagram: &Diagram,
    i: usize,
    cont: &Continuation,
    o: &ChartOptions,
    ctx: &str,
) -> Result<(FoldSystem<'a, P, N>, Branch, Vec<f64>), SwayError> {
    let mut po = diagram.cycle_system(problem)?;
    let fold = &diagram.cycles.points[i];
    match fold_started(&po, fold, cont, o) {
        Err(e @ continuation::Error::NewtonDivergence { .. }) => {
            fold_started_adapted(problem, diagram, &mut po, fold, cont, o).map_err(|retry| {
                SwayError::numerical(
                    format!("{ctx} (also on a mesh adapted to its cycle: {retry})"),
                    e,
                )
            })
        }
        started => started.map_err(num(ctx.to_string())),
    }
}

/// [`fold_started`] on a mesh of `o.cycles.intervals` intervals adapted to the cycle of the
/// branch point `fold` of `po` (error density equidistributed, the cycle's kinks on mesh
/// points: [`PeriodicOrbitSystem::adapted_mesh`]), the point and its tangent interpolated
/// there.
fn fold_started_adapted<'a, P: Vehicle<N>, const N: usize>(
    problem: &'a ClosedLoop<'a, P, N>,
    diagram: &Diagram,
    po: &mut PeriodicOrbitSystem<'a, ClosedLoop<'a, P, N>>,
    fold: &BranchPoint,
    cont: &Continuation,
    o: &ChartOptions,
) -> Result<(FoldSystem<'a, P, N>, Branch, Vec<f64>), continuation::Error> {
    let mesh = po.adapted_mesh(&fold.u, o.cycles.intervals);
    let adapted = diagram
        .cycle_system_on(problem, mesh)
        .map_err(|e| continuation::Error::InvalidInput(e.to_string()))?;
    let moved = BranchPoint {
        u: po.remesh(&fold.u, &adapted),
        tangent: po.remesh(&fold.tangent, &adapted),
        ..fold.clone()
    };
    fold_started(&adapted, &moved, cont, o)
}

/// The fold-of-cycles system started at the fold `point` of the cycle branch of `po` and its
/// first corrected point (at the branch's gain): the system, the first point's branch and
/// the start direction +D.
fn fold_started<'a, P: Vehicle<N>, const N: usize>(
    po: &PeriodicOrbitSystem<'a, ClosedLoop<'a, P, N>>,
    point: &BranchPoint,
    cont: &Continuation,
    o: &ChartOptions,
) -> Result<(FoldSystem<'a, P, N>, Branch, Vec<f64>), continuation::Error> {
    let (mut sys, guess, dir) = FoldOfCyclesSystem::from_fold(po, point, GAIN, fold_options(o))?;
    let first = cont.start(&mut sys, &guess, &dir)?;
    Ok((sys, first, dir))
}

/// The Hopf and fold speeds of a one-parameter diagram read off the two-parameter
/// defining systems at the diagram's fixed D (what `fig4b` reports; the chart's curves
/// pass through them). Uses the diagram's located Hopf point and cycle fold as guesses.
/// The loop is the diagram's (its feedback and [`super::LoopLaw`]); D is the free second
/// parameter of the defining systems, the hitch gains stay fixed.
///
/// # Errors
/// [`SwayError::Numerical`] naming the failing stage.
pub fn critical_speeds<P: Vehicle<N>, const N: usize>(
    model: &P,
    diagram: &Diagram,
    o: &ChartOptions,
) -> Result<CriticalSpeeds, SwayError> {
    let problem = ClosedLoop::new(model, diagram.law);
    let d = diagram.law.gains.yaw_rate;
    // the two corrections are independent: side by side
    let (hu, fold) =
        crate::parallel::join(&|| corrected_hopf(&problem, d, &diagram.hopf, o), &|| {
            fold_on(&problem, diagram, o)
        });
    // a correction that fails is a result: the located Hopf point stands for the Hopf
    // speed, the fold is unknown; both say why
    let mut ended = Vec::new();
    let mut failed = |what: &str, e: &SwayError| {
        ended.push(EndedCurve {
            curve: format!("{what} corrected at D = {d} s"),
            end: CurveEnd::from_error(None, e),
        });
    };
    let (hopf_v_mps, hopf_omega_rad_s) = match &hu {
        Ok(u) => (hopf_v(u), hopf_omega(u)),
        Err(e) => {
            failed("Hopf point", e);
            (diagram.hopf.parameter, diagram.hopf.omega)
        }
    };
    let fold = fold.unwrap_or_else(|e| {
        failed("fold of cycles", &e);
        None
    });
    Ok(CriticalSpeeds {
        located_hopf: diagram.hopf.clone(),
        hopf_v_mps,
        hopf_omega_rad_s,
        criticality: diagram.criticality,
        fold,
        curves_ended_early: ended,
    })
}

/// The fold of cycles of a one-parameter diagram as [`critical_speeds`] reads it off the
/// fold-of-cycles system at the diagram's fixed D (on its adapted mesh), without the Hopf
/// point's correction: for callers that need the fold only (`control_design`'s V_fold).
/// None if the cycle branch has no fold.
///
/// # Errors
/// [`SwayError::Numerical`] naming the failing stage.
pub fn fold_of_cycles<P: Vehicle<N>, const N: usize>(
    model: &P,
    diagram: &Diagram,
    o: &ChartOptions,
) -> Result<Option<FoldCurvePoint>, SwayError> {
    let problem = ClosedLoop::new(model, diagram.law);
    fold_on(&problem, diagram, o)
}

/// The corrected fold of `diagram`'s cycle branch on `problem` (its loop), on the fold's
/// adapted mesh.
fn fold_on<'a, P: Vehicle<N>, const N: usize>(
    problem: &'a ClosedLoop<'a, P, N>,
    diagram: &Diagram,
    o: &ChartOptions,
) -> Result<Option<FoldCurvePoint>, SwayError> {
    Ok(match corrected_fold(problem, diagram, o)? {
        Some(f) => {
            let ctx = || "fold of cycles".to_string();
            let point = match on_fold_mesh(&f.sys, &f.u, o) {
                Some((sys, u)) => fold_curve_point(&sys, &u),
                None => fold_curve_point(&f.sys, &f.u),
            };
            Some(point.map_err(num(ctx()))?)
        }
        None => None,
    })
}

/// A fold-of-cycles curve with the codimension-two points it ends at or passes, or why
/// there is none (a physical outcome).
type FoldStage = Result<(FoldCurve, Vec<Codim2>), String>;

/// The fold-of-cycles curve started at the fold of the cycle branch at gain `d` (if the
/// Hopf point there is subcritical and the branch folds in the speed range), both
/// directions; with the codimension-two points it ends at or passes. Without a curve, the
/// reason: no Hopf point of straight running at `d` in the speed range (stable there), a
/// supercritical Hopf point, a cycle branch that does not fold in the speed range.
fn fold_curve<P: Vehicle<N>, const N: usize>(
    model: &P,
    tau: f64,
    d: f64,
    o: &ChartOptions,
) -> Result<FoldStage, SwayError> {
    let fb = LoopLaw::paper(d, tau);
    let range = format!("[{}, {}] m/s", o.v_min_mps, o.v_max_mps);
    let diagram = match bifurcation_diagram_until(
        model,
        fb,
        &o.cycle_options(),
        CycleExtent::FirstFold,
    ) {
        Ok(diagram) => diagram,
        Err(e) if e.to_string().contains("no Hopf point") => {
            return Ok(Err(format!(
                "no fold-of-cycles curve: straight running has no Hopf point in {range} at the first seed gain D = {d} s (stable there)"
            )));
        }
        Err(e) => return Err(e),
    };
    if diagram.criticality != Criticality::Subcritical {
        return Ok(Err(format!(
            "no fold-of-cycles curve: the Hopf point at D = {d} s, V = {:.4} m/s is supercritical (the cycles grow from it without folding)",
            diagram.hopf.parameter
        )));
    }
    let problem = ClosedLoop::new(model, fb);
    let Some(CorrectedFold {
        mut sys,
        u: u0,
        direction: dir,
    }) = corrected_fold(&problem, &diagram, o)?
    else {
        return Ok(Err(match &diagram.fold {
            Some(f) => format!(
                "no fold-of-cycles curve: the cycle branch from the Hopf point at D = {d} s has a singular point at V = {:.4} m/s where V does not turn (not a fold: a branch point of the discretised cycles; a finer chart.cycles.intervals may pass it)",
                f.speed_mps
            ),
            None => format!(
                "no fold-of-cycles curve: the cycle branch from the Hopf point at D = {d} s does not fold in {range}"
            ),
        }));
    };
    let ctx = format!("fold-of-cycles curve from D = {d} s, τ = {tau} s");
    let cont = o.continuation(o.fold_step, o.fold_max_step, (o.v_min_mps, o.v_max_mps));
    let (iv, id) = fold_indices(&sys);
    let at = |p: &BranchPoint| (p.u[id], p.u[iv]);
    let mut codim2 = Vec::new();
    let extend = |sys: &mut FoldSystem<'_, P, N>, b: &mut Branch| {
        let end = extend_fold_curve(&cont, sys, b, o, &mut codim2);
        codim2.extend(b.special_points().filter_map(|(i, sp)| {
            let located = sp.location == continuation::Location::Located;
            (sp.kind == SpecialKind::CuspOfCycles && located).then(|| Codim2 {
                kind: Codim2Kind::CuspOfCycles,
                d_s: b.points[i].u[id],
                v_mps: b.points[i].u[iv],
                omega_rad_s: Vec::new(),
            })
        }));
        end
    };
    let (branches, ends) =
        both_directions(&cont, &mut sys, &u0, &dir, at, extend).map_err(num(ctx.clone()))?;
    let points = joined(&branches)
        .map(|p| fold_curve_point(&sys, &p.u))
        .collect::<Result<Vec<_>, _>>()
        .map_err(num(ctx))?;
    Ok(Ok((
        FoldCurve {
            seed_d_s: d,
            branches,
            points,
            ends,
        },
        codim2,
    )))
}

/// Extends one direction of a fold-of-cycles curve until it leaves the box, ends on the
/// Hopf curve (pushed to `codim2`), uses its budget or cannot go on; how it ended.
fn extend_fold_curve<P: Vehicle<N>, const N: usize>(
    cont: &Continuation,
    sys: &mut FoldSystem<'_, P, N>,
    b: &mut Branch,
    o: &ChartOptions,
    codim2: &mut Vec<Codim2>,
) -> CurveEnd {
    let (iv, id) = fold_indices(sys);
    let last = |b: &Branch| b.points.last().map(|p| (p.u[id], p.u[iv]));
    loop {
        if b.points.len() >= o.fold_max_points {
            return CurveEnd::Budget {
                points: b.points.len(),
            };
        }
        let stop = match sys.extend_curve(cont, b, 8) {
            Ok(stop) => stop,
            Err(e) => return CurveEnd::failed(last(b), &e),
        };
        let (d_s, v_mps) = last(b).unwrap_or((f64::NAN, f64::NAN));
        let out = !o.in_box(d_s, v_mps);
        match stop {
            FoldCyclesStop::HopfEnd(end) => {
                let (d_s, v_mps) = (end.parameters[1], end.parameters[0]);
                codim2.push(Codim2 {
                    kind: Codim2Kind::CriticalityChange,
                    d_s,
                    v_mps,
                    omega_rad_s: vec![end.omega],
                });
                return CurveEnd::SingularPoint {
                    kind: Codim2Kind::CriticalityChange,
                    d_s,
                    v_mps,
                };
            }
            FoldCyclesStop::Continuation(Stop::MaxPoints) if !out => {}
            FoldCyclesStop::Continuation(Stop::StepSizeUnderflow { .. }) => {
                return CurveEnd::StepUnderflow { d_s, v_mps };
            }
            _ => return CurveEnd::LeftBox { d_s, v_mps },
        }
    }
}

/// Codimension-two points the Hopf-curve system located on a curve.
#[doc(hidden)] // pub for tests/unit
pub fn hopf_codim2<P: Vehicle<N>, const N: usize>(
    sys: &HopfSystem<'_, P, N>,
    curve: &HopfCurve,
) -> Vec<Codim2> {
    curve
        .branches
        .iter()
        .flat_map(|b| sys.codim2_points(b))
        .filter_map(|c| {
            Some(Codim2 {
                kind: Codim2Kind::from_special(c.kind)?,
                d_s: c.p1,
                v_mps: c.p2,
                omega_rad_s: ascending(c.omegas.iter().map(|w| w.abs()).collect()),
            })
        })
        .collect()
}

/// `v` sorted ascending.
fn ascending(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v
}

/// Drops repeated points (the same kind within 1e-3 s and 1e-2 m/s: found on two curves
/// or on both directions from a seed) and sorts by kind, then D.
#[doc(hidden)] // pub for tests/unit
pub fn dedup_codim2(mut points: Vec<Codim2>) -> Vec<Codim2> {
    let mut out: Vec<Codim2> = Vec::new();
    points.sort_by(|a, b| a.d_s.total_cmp(&b.d_s));
    for p in points {
        let dup = out.iter().any(|q| {
            q.kind == p.kind && (q.d_s - p.d_s).abs() < 1e-3 && (q.v_mps - p.v_mps).abs() < 1e-2
        });
        if !dup {
            out.push(p);
        }
    }
    out.sort_by_key(|p| p.kind.name());
    out
}

/// The Hopf curves of one delay τ \[s\] (step 1 of the pipeline, without criticality):
/// one curve per seed gain whose first Hopf point is not on an earlier curve, and notes on
/// the skipped seeds.
///
/// # Errors
/// [`SwayError::Numerical`] if a curve fails; a seed without a Hopf point in the speed
/// range is only noted.
pub fn hopf_curves<P: Vehicle<N>, const N: usize>(
    model: &P,
    tau: f64,
    o: &ChartOptions,
) -> Result<(Vec<HopfCurve>, Vec<String>), SwayError> {
    let problem = ClosedLoop::new(model, LoopLaw::paper(0.0, tau));
    let mut notes = Vec::new();
    let mut curves: Vec<HopfCurve> = Vec::new();
    for &d in &o.seed_gains_s {
        let mut params = problem.parameters(o.v_min_mps);
        params[GAIN] = d;
        let range = (o.v_min_mps, o.v_max_mps);
        let hopf = match straight_running(&problem, &params, range, o.cycles.root_degree) {
            Ok((_, h)) => h,
            Err(e) => {
                notes.push(format!("seed D = {d} s: {e}"));
                continue;
            }
        };
        if on_curve(&curves, d, &hopf) {
            notes.push(format!(
                "seed D = {d} s: Hopf point V = {:.3} m/s lies on a computed curve",
                hopf.parameter
            ));
            continue;
        }
        match hopf_curve(&problem, d, &hopf, o) {
            Ok(c) => curves.push(c),
            // a curve that cannot start is noted: the linear chart still says where
            // straight running is unstable
            Err(e) => notes.push(format!(
                "seed D = {d} s: the Hopf curve from V = {:.3} m/s could not start: {e}",
                hopf.parameter
            )),
        }
    }
    Ok((curves, notes))
}

/// The lowest speed \[m/s\] of `curves` (Hopf curves of delay τ \[s\]) at gain D \[s\],
/// each crossing corrected at fixed D on the Hopf-curve system; None if no curve crosses D
/// in the speed range.
///
/// # Errors
/// [`SwayError::Numerical`] if a correction fails.
pub fn hopf_speed_at<P: Vehicle<N>, const N: usize>(
    model: &P,
    tau: f64,
    curves: &[HopfCurve],
    d: f64,
    o: &ChartOptions,
) -> Result<Option<f64>, SwayError> {
    let problem = ClosedLoop::new(model, LoopLaw::paper(0.0, tau));
    lowest_hopf_speed(&problem, curves, d, o)
}

/// Computes the nonlinear chart of one delay τ \[s\] (see the module documentation).
///
/// # Errors
/// [`SwayError::Numerical`] naming the failing stage; a seed gain without a Hopf point in
/// the speed range is not an error (it is recorded in [`NonlinearChart::notes`]).
pub fn nonlinear_chart<P: Vehicle<N>, const N: usize>(
    model: &P,
    tau: f64,
    o: &ChartOptions,
) -> Result<NonlinearChart, SwayError> {
    let Some(&first_seed) = o.seed_gains_s.first() else {
        return Err(invalid(
            format!("nonlinear chart τ = {tau} s"),
            "no seed gain; give at least one in seed_gains_s".into(),
        ));
    };
    let problem = ClosedLoop::new(model, LoopLaw::paper(first_seed, tau));
    // the Hopf curves with their criticality and the fold-of-cycles curve are independent:
    // computed side by side (each deterministic, so the result does not depend on threads)
    let (hopf_stage, fold_stage) = join(
        &|| -> Result<_, SwayError> {
            let (mut curves, mut notes) = hopf_curves(model, tau, o)?;
            let criticality = map(&curves, Split::Adaptive, &|_, c| {
                sample_criticality(&problem, c, o)
            });
            for (c, samples) in curves.iter_mut().zip(criticality) {
                // criticality that cannot be computed stays unknown (no samples)
                match samples {
                    Ok(samples) => c.criticality = samples,
                    Err(e) => notes.push(format!(
                        "Hopf curve from D = {} s: criticality unknown: {e}",
                        c.seed_d_s
                    )),
                }
            }
            Ok((curves, notes))
        },
        &|| fold_curve(model, tau, first_seed, o),
    );
    let (hopf_curves, notes) = hopf_stage?;
    let mut ended: Vec<EndedCurve> = Vec::new();
    for c in &hopf_curves {
        ended.extend(early_ends(
            &format!("Hopf curve from D = {} s", c.seed_d_s),
            &c.ends,
        ));
    }
    let sys = hopf_system(&problem, first_seed, o)?;
    let mut codim2: Vec<Codim2> = hopf_curves
        .iter()
        .flat_map(|c| hopf_codim2(&sys, c))
        .collect();
    let mut fold_curves = Vec::new();
    let mut fold_reason = None;
    let mut fold_incomplete = false;
    match fold_stage {
        Ok(Ok((f, c2))) => {
            let name = format!("fold-of-cycles curve from D = {} s", f.seed_d_s);
            let early = early_ends(&name, &f.ends);
            fold_incomplete = !early.is_empty();
            ended.extend(early);
            fold_curves.push(f);
            codim2.extend(c2);
        }
        Ok(Err(reason)) => fold_reason = Some(reason),
        // the fold-of-cycles curve could not be computed: the bistable band is unknown
        // (never painted safe), the rest of the chart stands
        Err(e) => {
            let end = CurveEnd::from_error(None, &e);
            fold_reason = Some(format!(
                "the fold-of-cycles curve from D = {first_seed} s could not be computed: {e}"
            ));
            fold_incomplete = true;
            ended.push(EndedCurve {
                curve: format!("fold-of-cycles curve from D = {first_seed} s"),
                end,
            });
        }
    }
    let hopf_reason = hopf_curves.is_empty().then(|| {
        format!(
            "no Hopf curve: straight running has no Hopf point in [{}, {}] m/s at the seed gains {:?} s (stable at these gains)",
            o.v_min_mps, o.v_max_mps, o.seed_gains_s
        )
    });
    codim2.retain(|c| o.in_box(c.d_s, c.v_mps));
    Ok(NonlinearChart {
        tau_s: tau,
        options: o.clone(),
        hopf_curves,
        fold_curves,
        codim2_points: dedup_codim2(codim2),
        notes,
        hopf_reason,
        fold_reason,
        curves_ended_early: ended,
        fold_incomplete,
    })
}

/// The directions of the curve `name` that ended early ([`CurveEnd::is_early`]).
fn early_ends(name: &str, ends: &[CurveEnd]) -> Vec<EndedCurve> {
    let directions = ["towards decreasing D", "towards increasing D"];
    ends.iter()
        .zip(directions)
        .filter(|(e, _)| e.is_early())
        .map(|(e, dir)| EndedCurve {
            curve: format!("{name}, {dir}"),
            end: e.clone(),
        })
        .collect()
}

impl NonlinearChart {
    /// The chart of delay τ \[s\] that could not be computed (`e`): no curves, the reason
    /// as its ended curve and its notes, the fold-of-cycles curve incomplete (its stable
    /// cells [`Region::Unknown`]).
    pub fn not_computed(tau: f64, options: &ChartOptions, e: &SwayError) -> Self {
        Self {
            tau_s: tau,
            options: options.clone(),
            hopf_curves: Vec::new(),
            fold_curves: Vec::new(),
            codim2_points: Vec::new(),
            notes: vec![format!("nonlinear chart not computed: {e}")],
            hopf_reason: Some(format!("the Hopf curves could not be computed: {e}")),
            fold_reason: Some(format!(
                "the fold-of-cycles curve could not be computed: {e}"
            )),
            curves_ended_early: vec![EndedCurve {
                curve: format!("nonlinear chart τ = {tau} s"),
                end: CurveEnd::from_error(None, e),
            }],
            fold_incomplete: true,
        }
    }

    fn problem<'a, P: Vehicle<N>, const N: usize>(&self, model: &'a P) -> ClosedLoop<'a, P, N> {
        ClosedLoop::new(model, LoopLaw::paper(0.0, self.tau_s))
    }

    /// The lowest speed \[m/s\] of the Hopf curves at gain D \[s\] (each crossing corrected
    /// at fixed D on the Hopf-curve system); None if no curve crosses D in the speed range.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if a correction fails.
    pub fn hopf_speed_at<P: Vehicle<N>, const N: usize>(
        &self,
        model: &P,
        d: f64,
    ) -> Result<Option<f64>, SwayError> {
        hopf_speed_at(model, self.tau_s, &self.hopf_curves, d, &self.options)
    }

    /// The lowest speed \[m/s\] of the fold-of-cycles curves at gain D \[s\] (corrected at
    /// fixed D on the fold-of-cycles system); None if no curve crosses D in the speed range.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if a correction fails.
    pub fn fold_speed_at<P: Vehicle<N>, const N: usize>(
        &self,
        model: &P,
        d: f64,
    ) -> Result<Option<f64>, SwayError> {
        let problem = self.problem(model);
        let o = &self.options;
        let mut best: Option<f64> = None;
        for c in &self.fold_curves {
            let Some(p0) = c.branches[1].points.first() else {
                continue;
            };
            let mut params = problem.parameters(p0.parameter);
            params[GAIN] = c.seed_d_s;
            let mut sys = FoldOfCyclesSystem::new(
                &problem,
                params,
                (SPEED, GAIN),
                super::collocation(&o.cycles),
                fold_options(o),
            )
            .map_err(num("fold-of-cycles system".into()))?;
            let (iv, id) = fold_indices(&sys);
            let ctx = || format!("fold-of-cycles curve at D = {d} s");
            let pts = curve_points_at(&mut sys, &c.branches, id, d).map_err(num(ctx()))?;
            for u in pts {
                let u = corrected_in_canonical_phase(&Continuation::default(), &mut sys, &u, id)
                    .map_err(num(ctx()))?;
                // the adapted mesh may have more intervals: its own indices
                let v = on_fold_mesh(&sys, &u, o)
                    .map_or(u[iv], |(adapted, w)| w[fold_indices(&adapted).0]);
                if v >= o.v_min_mps && v <= o.v_max_mps {
                    best = Some(best.map_or(v, |b: f64| b.min(v)));
                }
            }
        }
        Ok(best)
    }
}

/// What straight running does at a point of the (V, D) plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Region {
    /// stable, and no computed cycle coexists (below the fold-of-cycles curve, or below a
    /// supercritical Hopf curve): safe against any perturbation as far as the cycles tell
    Safe,
    /// stable, but beyond the fold-of-cycles curve: a large enough kick triggers sway
    Bistable,
    /// unstable (beyond a Hopf curve): sway starts by itself
    SelfExcited,
    /// stable, but the fold-of-cycles curve this cell depends on ended early or could not
    /// be computed ([`NonlinearChart::fold_incomplete`]): safe or bistable is not known
    Unknown,
}

impl NonlinearChart {
    /// The lowest fold-of-cycles speed at gain D \[s\] interpolated linearly between the
    /// computed curve points (for shading; [`NonlinearChart::fold_speed_at`] is exact).
    pub fn fold_speed_interpolated(&self, d: f64) -> Option<f64> {
        self.fold_curves
            .iter()
            .flat_map(|c| c.points.windows(2))
            .filter_map(|w| {
                let (a, b) = (w[0], w[1]);
                if (a.d_s - d) * (b.d_s - d) > 0.0 || a.d_s == b.d_s {
                    return None;
                }
                let t = (d - a.d_s) / (b.d_s - a.d_s);
                Some(a.v_mps + t * (b.v_mps - a.v_mps))
            })
            .reduce(f64::min)
    }

    /// The regions on the cells of a linear stability chart of the same τ (the `fig4a`
    /// computation: exact counts of unstable roots): self-excited where straight running is
    /// unstable, bistable where it is stable at or beyond the fold-of-cycles curve, unknown
    /// where it is stable at a gain the incomplete fold-of-cycles curve does not reach, safe
    /// elsewhere. Indexed like the chart's cells, `iv·d.len() + id`.
    pub fn regions(&self, linear: &stability::StabilityChart) -> Vec<Region> {
        let fold: Vec<Option<f64>> = linear
            .d
            .iter()
            .map(|&d| self.fold_speed_interpolated(d))
            .collect();
        let mut out = Vec::with_capacity(linear.cells.len());
        for (iv, &v) in linear.v.iter().enumerate() {
            for (id, f) in fold.iter().enumerate() {
                out.push(if !linear.cell(iv, id).is_stable() {
                    Region::SelfExcited
                } else if f.is_some_and(|f| v >= f) {
                    Region::Bistable
                } else if f.is_none() && self.fold_incomplete {
                    Region::Unknown
                } else {
                    Region::Safe
                });
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use trailer_model::{Model, VehicleParams};

    #[test]
    fn the_fold_started_on_an_adapted_mesh_is_the_fold_of_the_branch_mesh() {
        // reference: the fold of cycles of Table I's open loop started on the branch's
        // uniform mesh (L = 40, degree 4; its error is 1.5e-6 relative, see
        // `PeriodicOrbitSystem::adapted_mesh`). The retry's start on the adapted mesh must
        // find the same fold to that accuracy: 1e-5 relative.
        let model = Model::new(VehicleParams::default()).expect("Table I");
        let diagram =
            super::super::bifurcation_diagram(&model, LoopLaw::OPEN_LOOP, &Default::default())
                .expect("open-loop diagram");
        let o = ChartOptions::correcting(&diagram.options);
        let problem = ClosedLoop::new(&model, diagram.law);
        let i = super::super::lower_fold(&diagram.cycles).expect("Table I's cycles fold");
        let cont = o.continuation(o.fold_step, o.fold_max_step, (o.v_min_mps, o.v_max_mps));
        let mut po = diagram.cycle_system(&problem).unwrap();
        let fold = &diagram.cycles.points[i];
        let speed = |(sys, first, _): (FoldSystem<'_, Model, 4>, Branch, Vec<f64>)| {
            first.points[0].u[fold_indices(&sys).0]
        };
        let uniform = speed(fold_started(&po, fold, &cont, &o).unwrap());
        let adapted =
            speed(fold_started_adapted(&problem, &diagram, &mut po, fold, &cont, &o).unwrap());
        assert!(
            ((adapted - uniform) / uniform).abs() < 1e-5,
            "adapted {adapted} vs uniform {uniform} m/s"
        );
        // and both are the located fold of the cycle branch, to the branch's step
        assert!(
            (uniform - fold.parameter).abs() < 1e-3,
            "{uniform} vs {}",
            fold.parameter
        );
    }
}
