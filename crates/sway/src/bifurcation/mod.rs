//! Bifurcation analysis of straight running and trailer sway (paper §IV, Fig. 3a and 4b):
//! the vehicle model wired into the general-purpose [`continuation`] crate.
//!
//! The closed loop of eq. (8), x'(t) = f(x(t), δ(t) = −D·ψ̇(t−τ); V), on the reduced state
//! x = [σ1, σ2, σ3, θ] is a [`continuation::Problem`] ([`ClosedLoop`]) with parameters
//! p = [V, D, τ], any of which may be free (exact first and second derivatives); it is a
//! DDE for τ > 0 (whatever D) and an ODE for τ = 0 (the open loop is D = τ = 0).
//! Straight running x = 0 is continued in V, its Hopf point located, the cycle branch
//! started from it with a finite amplitude (the Hopf point is non-smooth: the brush tire is
//! only C¹ at α = 0) and continued through the fold.
//!
//! ```no_run
//! use sway::bifurcation::{DiagramOptions, LoopLaw, bifurcation_diagram};
//! use trailer_model::{Model, VehicleParams};
//! let model = Model::new(VehicleParams::default()).unwrap();
//! let d = bifurcation_diagram(&model, LoopLaw::OPEN_LOOP, &DiagramOptions::default()).unwrap();
//! println!("Hopf at {} m/s, fold at {:?} m/s", d.hopf.parameter, d.fold.map(|f| f.speed_mps));
//! ```

use continuation::{
    ArclengthWeights, Branch, ChebyshevRoots, CollocationOptions, Continuation,
    ContinuationOptions, Criticality, Decision, EquilibriumSystem, FloquetMultipliers, HopfPoint,
    PeriodicOrbitSystem, Refinement, SpecialKind, criticality, points_at_parameter,
};
use serde::{Deserialize, Serialize};
use sway_model::config::{Absent, Omittable};
use sway_model::vehicle::Vehicle;
use trailer_model::HITCH_ANGLE;

use crate::SwayError;

pub mod chart;
mod closed_loop;
pub mod corners;
pub(crate) mod ranged;
pub use closed_loop::{ClosedLoop, DELAY, GAIN, SPEED};
pub use ranged::{
    BEYOND_HOPF, BranchEnd, DiagramOutcome, DiagramSettings, HopfBubble, MARGIN_BELOW, NoHopf,
    cycle_diagram, cycle_loss_of_control, vehicle_diagram,
};
pub use sway_model::law::LoopLaw;

/// The settings of the bifurcation diagram of one feedback setting, with the ends of its
/// speed range as `S` and the derived end of its cycle branch as `B`: [`DiagramOptions`] on
/// a given range (`S` = f64, `B` = [`Absent`]: none), [`DiagramSettings`] as a config gives them
/// (`S` = `Option<f64>`: an omitted end derived from the vehicle; `B` = f64). An omitted
/// value is not serialised ([`Omittable`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiagramSpec<S: Omittable, B: Omittable> {
    /// lowest speed of the diagram \[m/s\] (start of the straight-running branch; in
    /// [`DiagramSettings`] omitted: derived from the vehicle)
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub v_min_mps: S,
    /// highest speed of the diagram \[m/s\] (in [`DiagramSettings`] omitted: derived from
    /// the vehicle)
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub v_max_mps: S,
    /// with `v_max_mps` omitted, the cycle branch is followed until V ≥ (1 + this)·V_Hopf
    /// \[-\] ([`DiagramSettings`]; a given range has none)
    #[serde(skip_serializing_if = "Omittable::is_omitted")]
    pub beyond_hopf: B,
    /// mesh intervals L of the periodic orbits
    pub intervals: usize,
    /// collocation degree m
    pub degree: usize,
    /// amplitude of the first cycle along the critical eigenvector (unit norm in
    /// [σ1 m/s, σ2 1/s, σ3 1/s, θ rad])
    pub hopf_amplitude: f64,
    /// first continuation step (weighted arclength)
    pub initial_step: f64,
    /// largest continuation step
    pub max_step: f64,
    /// at most this many cycle points (the point budget)
    pub max_cycle_points: usize,
    /// degree of the Chebyshev collocation for characteristic roots (delayed case)
    pub root_degree: usize,
    /// whether the cycle branch watches for branch points of cycles (symmetry breaking,
    /// transcritical): "watch" (default) or "ignore" (cheaper: the engine then factorises
    /// with supernodes, which give no determinant)
    pub cycle_branch_points: BranchPointTest,
    /// whether the cycles' Floquet multipliers (their stability) are computed at every
    /// point: "every_point" (default) or "on_request" (for a search that needs only the
    /// branch's shape, e.g. a fold-of-cycles speed: no stability, much cheaper at long
    /// delays)
    pub floquet_multipliers: FloquetMultipliers,
}

/// Options of the bifurcation diagram of one feedback setting on a given speed range.
pub type DiagramOptions = DiagramSpec<f64, Absent>;

impl<S: Omittable, B: Omittable> DiagramSpec<S, B> {
    /// These settings with the speed range `v_min_mps`, `v_max_mps` and the derived end
    /// `beyond_hopf` in place of theirs.
    pub fn with_range<T: Omittable, C: Omittable>(
        &self,
        v_min_mps: T,
        v_max_mps: T,
        beyond_hopf: C,
    ) -> DiagramSpec<T, C> {
        DiagramSpec {
            v_min_mps,
            v_max_mps,
            beyond_hopf,
            intervals: self.intervals,
            degree: self.degree,
            hopf_amplitude: self.hopf_amplitude,
            initial_step: self.initial_step,
            max_step: self.max_step,
            max_cycle_points: self.max_cycle_points,
            root_degree: self.root_degree,
            cycle_branch_points: self.cycle_branch_points,
            floquet_multipliers: self.floquet_multipliers,
        }
    }
}

/// Whether a branch watches the sign of the bordered determinant for branch points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BranchPointTest {
    /// detect and locate branch points
    #[default]
    Watch,
    /// step over them unnoticed
    Ignore,
}

impl DiagramOptions {
    /// The closed-loop diagrams' settings (`fig4b`, the nonlinear chart's tests):
    /// 25–60 m/s, mesh L = 40, largest step 0.5, the rest as [`DiagramOptions::default`].
    pub fn closed_loop() -> Self {
        Self {
            v_min_mps: 25.0,
            v_max_mps: 60.0,
            intervals: 40,
            max_step: 0.5,
            ..Self::default()
        }
    }
}

impl Default for DiagramOptions {
    fn default() -> Self {
        Self {
            v_min_mps: 25.0,
            v_max_mps: 45.0,
            beyond_hopf: Absent,
            intervals: 60,
            degree: 4,
            hopf_amplitude: 1e-3,
            initial_step: 0.02,
            max_step: 0.25,
            max_cycle_points: 600,
            root_degree: 24,
            cycle_branch_points: BranchPointTest::Watch,
            floquet_multipliers: FloquetMultipliers::EveryPoint,
        }
    }
}

/// The fold of the cycle branch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FoldPoint {
    /// speed at the fold \[m/s\]
    pub speed_mps: f64,
    /// max |θ| on the cycle at the fold \[deg\]
    pub amplitude_deg: f64,
    /// period at the fold \[s\]
    pub period_s: f64,
}

/// One point of the cycle branch, in the paper's quantities.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CycleSummary {
    /// speed V \[m/s\]
    pub speed_mps: f64,
    /// max |θ| over the cycle \[deg\]
    pub amplitude_deg: f64,
    /// period \[s\]
    pub period_s: f64,
    /// linearly stable (all nontrivial Floquet multipliers inside the unit circle)
    pub stable: bool,
    /// largest modulus of the nontrivial Floquet multipliers
    pub max_multiplier: f64,
}

/// Which cycle [`Diagram::cycle_at`] picks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CycleKind {
    /// the stable cycle of largest amplitude (sway)
    Stable,
    /// the unstable cycle of smallest amplitude (the threshold of perturbations)
    Unstable,
}

/// The cycle of a kind at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleAt {
    /// the speed \[m/s\]
    pub speed_mps: f64,
    /// the cycle (None: none of that kind at this speed)
    pub cycle: Option<CycleSummary>,
    /// why there is none
    pub reason: Option<String>,
}

/// A computed bifurcation diagram of one feedback setting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagram {
    /// the feedback law (D, τ, actuator, hitch gains); not serialised (a deserialised
    /// diagram has the open loop)
    #[serde(skip)]
    pub law: LoopLaw,
    /// the options used
    pub options: DiagramOptions,
    /// straight running (x = 0) versus V, with stability and the Hopf point
    pub equilibria: Branch,
    /// the Hopf point
    pub hopf: HopfPoint,
    /// the cycles born at the Hopf point (unknowns of the collocation system)
    pub cycles: Branch,
    /// the cycle branch in the paper's quantities, in continuation order
    pub cycle_summary: Vec<CycleSummary>,
    /// criticality of the Hopf bifurcation (from the computed branch)
    pub criticality: Criticality,
    /// the fold of cycles: the first fold of the cycle branch where V has a local minimum
    /// (the lower end of the cycles; a fold where they turn back to lower speeds is not it)
    pub fold: Option<FoldPoint>,
    /// the speeds searched \[m/s\]: straight running from the first, the cycle branch
    /// within both
    pub searched_mps: [f64; 2],
    /// why the cycle branch ended
    pub cycle_branch_end: BranchEnd,
    /// windows of instability below `hopf` whose cycles rejoin straight running (a Hopf
    /// bubble each, passed over: `hopf` and `cycles` are those of the next loss of
    /// stability); empty on a range the settings give
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bubbles: Vec<HopfBubble>,
}

fn num(context: String) -> impl FnOnce(continuation::Error) -> SwayError {
    move |e| SwayError::numerical(context, e)
}

#[doc(hidden)] // pub for tests/unit
pub fn collocation(o: &DiagramOptions) -> CollocationOptions {
    CollocationOptions {
        intervals: o.intervals,
        degree: o.degree,
        weights: ArclengthWeights::default(),
        multipliers_kept: 12,
        floquet_multipliers: o.floquet_multipliers,
    }
}

impl Diagram {
    /// The collocation system the cycle branch was computed with (to evaluate its points).
    pub fn cycle_system<'a, P: Vehicle<N>, const N: usize>(
        &self,
        problem: &'a ClosedLoop<'a, P, N>,
    ) -> Result<PeriodicOrbitSystem<'a, ClosedLoop<'a, P, N>>, SwayError> {
        PeriodicOrbitSystem::new(
            problem,
            problem.parameters(self.hopf.parameter),
            SPEED,
            collocation(&self.options),
        )
        .map_err(num("cycle system".into()))
    }

    /// The cycle branch's collocation system on another mesh 0 = s_0 < … < s_L = 1 (same
    /// degree and options), e.g. one adapted to a cycle of the branch
    /// ([`PeriodicOrbitSystem::adapted_mesh`]).
    pub fn cycle_system_on<'a, P: Vehicle<N>, const N: usize>(
        &self,
        problem: &'a ClosedLoop<'a, P, N>,
        mesh: Vec<f64>,
    ) -> Result<PeriodicOrbitSystem<'a, ClosedLoop<'a, P, N>>, SwayError> {
        PeriodicOrbitSystem::with_mesh(
            problem,
            problem.parameters(self.hopf.parameter),
            SPEED,
            mesh,
            collocation(&self.options),
        )
        .map_err(num("cycle system on an adapted mesh".into()))
    }

    /// The cycles at speed V \[m/s\] (all crossings of the branch), corrected at fixed V.
    pub fn cycles_at<P: Vehicle<N>, const N: usize>(
        &self,
        model: &P,
        speed: f64,
    ) -> Result<Vec<CycleSummary>, SwayError> {
        let problem = ClosedLoop::new(model, self.law);
        let mut sys = self.cycle_system(&problem)?;
        let cont = Continuation::default();
        let pts = points_at_parameter(&cont, &mut sys, &self.cycles, speed)
            .map_err(num(format!("cycles at V = {speed} m/s")))?;
        Ok(pts
            .iter()
            .map(|p| summarise(&sys, &p.u, p.stability.as_ref()))
            .collect())
    }

    /// The cycle of `kind` at speed V \[m/s\]: of the crossings of the branch with V, the
    /// stable one of largest amplitude (the sway) or the unstable one of smallest amplitude
    /// (the perturbation threshold); None (with the reason) if the branch has none there.
    ///
    /// # Errors
    /// Numerical failures of the correction at fixed V.
    pub fn cycle_at<P: Vehicle<N>, const N: usize>(
        &self,
        model: &P,
        speed: f64,
        kind: CycleKind,
    ) -> Result<CycleAt, SwayError> {
        let cycles = self.cycles_at(model, speed)?;
        let pick = match kind {
            CycleKind::Stable => cycles
                .iter()
                .filter(|c| c.stable)
                .max_by(|a, b| a.amplitude_deg.total_cmp(&b.amplitude_deg)),
            CycleKind::Unstable => cycles
                .iter()
                .filter(|c| !c.stable)
                .min_by(|a, b| a.amplitude_deg.total_cmp(&b.amplitude_deg)),
        };
        let (lo, hi) = self
            .cycle_summary
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), c| {
                (a.min(c.speed_mps), b.max(c.speed_mps))
            });
        Ok(CycleAt {
            speed_mps: speed,
            cycle: pick.copied(),
            reason: pick.is_none().then(|| {
                format!(
                    "no {} cycle at {speed:.3} m/s on the computed cycle branch ({lo:.3}–{hi:.3} m/s)",
                    match kind {
                        CycleKind::Stable => "stable",
                        CycleKind::Unstable => "unstable",
                    }
                )
            }),
        })
    }

    /// The speed ranges: (stable below, bistable, unstable above) as
    /// (fold V, Hopf V) for a subcritical Hopf with a fold; None otherwise.
    pub fn bistable_range(&self) -> Option<(f64, f64)> {
        match (self.criticality, self.fold) {
            (Criticality::Subcritical, Some(f)) => Some((f.speed_mps, self.hopf.parameter)),
            _ => None,
        }
    }
}

fn summarise<P: Vehicle<N>, const N: usize>(
    sys: &PeriodicOrbitSystem<'_, ClosedLoop<'_, P, N>>,
    u: &[f64],
    st: Option<&continuation::Stability>,
) -> CycleSummary {
    let max_multiplier = st.map_or(f64::NAN, |s| {
        s.nontrivial().map(|z| z.norm()).fold(0.0, f64::max)
    });
    CycleSummary {
        speed_mps: u[u.len() - 1],
        amplitude_deg: sys.max_abs(u, HITCH_ANGLE).to_degrees(),
        period_s: sys.period(u),
        stable: st.is_some_and(|s| s.is_stable()),
        max_multiplier,
    }
}

/// the characteristic-root finder of straight running
fn root_finder(degree: usize) -> ChebyshevRoots {
    ChebyshevRoots {
        degree,
        count: 8,
        refinement: Refinement::Newton,
    }
}

/// the first fold of a cycle branch, in the paper's quantities
fn fold_of(cycles: &Branch, summary: &[CycleSummary]) -> Option<FoldPoint> {
    lower_fold(cycles).map(|i| {
        let c = summary[i];
        FoldPoint {
            speed_mps: c.speed_mps,
            amplitude_deg: c.amplitude_deg,
            period_s: c.period_s,
        }
    })
}

/// How V turns at a flagged fold of a cycle branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Turn {
    /// V has a local minimum: the lower end of a range of coexisting cycles, the fold of
    /// cycles of the paper (below it no kick triggers sway from this branch)
    Lower,
    /// V has a local maximum: the branch turns back to lower speeds (a supercritical Hopf
    /// point whose stable cycles fold back, unstable, over straight running)
    Upper,
}

/// How V turns at point `i` of `points` (None where it runs on through the flagged point:
/// the fold test, the tangent's V component changing sign, also fires where the oriented
/// tangent flips at a singular point of the collocation system that is no turning point).
/// A missing neighbour (the branch's first or last point) does not contradict either.
fn turn_at(points: &[continuation::BranchPoint], i: usize) -> Option<Turn> {
    let v = points[i].parameter;
    let neighbours = [
        i.checked_sub(1).and_then(|k| points.get(k)),
        points.get(i + 1),
    ];
    let lower = neighbours.iter().flatten().all(|p| p.parameter >= v);
    let upper = neighbours.iter().flatten().all(|p| p.parameter <= v);
    match (lower, upper) {
        (true, false) | (true, true) => Some(Turn::Lower),
        (false, true) => Some(Turn::Upper),
        (false, false) => None,
    }
}

/// The index of the first flagged fold of `cycles` at which V has a local minimum (the fold
/// of cycles: [`Turn::Lower`]); an upper fold before it is passed over.
pub(crate) fn lower_fold(cycles: &Branch) -> Option<usize> {
    fold_turning(cycles, Turn::Lower)
}

/// The index of the first flagged fold of `cycles` at which V has a local maximum.
pub(crate) fn upper_fold(cycles: &Branch) -> Option<usize> {
    fold_turning(cycles, Turn::Upper)
}

fn fold_turning(cycles: &Branch, turn: Turn) -> Option<usize> {
    cycles
        .special_points()
        .filter(|(_, s)| s.kind == SpecialKind::Fold)
        .map(|(i, _)| i)
        .find(|&i| turn_at(&cycles.points, i) == Some(turn))
}

/// Straight running x = 0 of `problem` continued in V from `v_min` to `v_max` (steps of
/// 0.5 m/s) at the gain and delay of `params` = [V, D, τ], and its first Hopf point (located
/// by the engine, with its critical eigenvector and transversality).
///
/// # Errors
/// [`SwayError::Numerical`] if there is no Hopf point in the range or a step fails.
pub fn straight_running<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    params: &[f64],
    (v_min, v_max): (f64, f64),
    root_degree: usize,
) -> Result<(Branch, HopfPoint), SwayError> {
    let ctx = format!(
        "straight running (D = {} s, τ = {} s)",
        params[GAIN], params[DELAY]
    );
    let cont_eq = Continuation::new(ContinuationOptions {
        initial_step: 0.5,
        max_step: 0.5,
        parameter_range: (v_min, v_max),
        ..Default::default()
    });
    let mut p = params.to_vec();
    p[SPEED] = v_min;
    let mut eq = EquilibriumSystem::new(problem, p, SPEED, root_finder(root_degree))
        .map_err(num(ctx.clone()))?;
    let dir = eq.parameter_direction();
    let mut start = vec![0.0; N + 1];
    start[N] = v_min;
    let mut equilibria = cont_eq
        .start(&mut eq, &start, &dir)
        .map_err(num(format!("{ctx} at V = {v_min} m/s")))?;
    let n_eq = ((v_max - v_min) / 0.5).ceil() as usize + 8;
    cont_eq
        .extend(&mut eq, &mut equilibria, n_eq)
        .map_err(num(ctx.clone()))?;
    let (ih, sp) = equilibria.first(SpecialKind::Hopf).ok_or_else(|| {
        SwayError::numerical(
            ctx.clone(),
            continuation::Error::InvalidInput(format!(
                "no Hopf point of straight running in [{v_min}, {v_max}] m/s; widen the speed range"
            )),
        )
    })?;
    let hopf = eq
        .hopf_point(&equilibria.points[ih].u, sp.transversality.unwrap_or(1.0))
        .map_err(num(format!("{ctx}: Hopf point")))?;
    Ok((equilibria, hopf))
}

/// How far a cycle branch is continued.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CycleExtent {
    /// until it leaves the speed range or has `max_cycle_points` points (the diagrams)
    WholeRange,
    /// until the fold of cycles, the first fold where V has a local minimum (past a fold
    /// where the cycles of a supercritical Hopf point turn back), or as
    /// [`CycleExtent::WholeRange`] if there is none: enough to start a fold-of-cycles curve
    FirstFold,
}

/// The first cycle of the branch born at `hopf`, at `amplitude` along the critical
/// eigenvector; where Newton does not converge from it (a branch that bends sharply, or a
/// Hopf bubble smaller than the amplitude: the normal form's guess is good only closer to
/// the Hopf point), again at a tenth and a hundredth of it.
pub(crate) fn first_cycle<'a, P: Vehicle<N>, const N: usize>(
    cont: &Continuation,
    po: &mut PeriodicOrbitSystem<'a, ClosedLoop<'a, P, N>>,
    hopf: &HopfPoint,
    amplitude: f64,
) -> continuation::Result<Branch> {
    let mut first = Err(continuation::Error::InvalidInput(String::new()));
    for shrink in [1.0, 0.1, 0.01] {
        let (guess, dir) = po.hopf_guess(hopf, shrink * amplitude);
        first = cont.start(po, &guess, &dir);
        if first.is_ok() {
            break;
        }
    }
    first
}

/// The cycle branch born at `hopf` continued in V for at most `max_points` points (or
/// until it leaves [v_min, v_max]) as far as `extent` says, and the criticality it shows.
///
/// # Errors
/// [`SwayError::Numerical`] if the first cycle cannot be found or the branch does not
/// leave the Hopf point.
pub fn cycles_from_hopf<'a, P: Vehicle<N>, const N: usize>(
    problem: &'a ClosedLoop<'a, P, N>,
    params: &[f64],
    hopf: &HopfPoint,
    o: &DiagramOptions,
    max_points: usize,
    extent: CycleExtent,
) -> Result<
    (
        PeriodicOrbitSystem<'a, ClosedLoop<'a, P, N>>,
        Branch,
        Criticality,
    ),
    SwayError,
> {
    let ctx = format!(
        "cycles from the Hopf point V = {} m/s (D = {} s, τ = {} s)",
        hopf.parameter, params[GAIN], params[DELAY]
    );
    let cont = Continuation::new(ContinuationOptions {
        initial_step: o.initial_step,
        max_step: o.max_step,
        parameter_range: (o.v_min_mps, o.v_max_mps),
        branch_points: o.cycle_branch_points == BranchPointTest::Watch,
        ..Default::default()
    });
    let mut p = params.to_vec();
    p[SPEED] = hopf.parameter;
    let mut po = PeriodicOrbitSystem::new(problem, p.clone(), SPEED, collocation(o))
        .map_err(num(ctx.clone()))?;
    // a second system on the same mesh measures the cycles: a branch that shrinks back onto
    // straight running (a Hopf bubble) stops there instead of following it as a "cycle"
    let gauge =
        PeriodicOrbitSystem::new(problem, p, SPEED, collocation(o)).map_err(num(ctx.clone()))?;
    let mut amplitudes: Vec<(f64, f64)> = Vec::new();
    let mut rejoin = |b: &Branch| {
        let Some(last) = b.points.last() else {
            return Decision::Continue;
        };
        amplitudes.push((last.parameter, gauge.max_abs(&last.u, HITCH_ANGLE)));
        if ranged::collapsed(&amplitudes) {
            Decision::Stop
        } else {
            Decision::Continue
        }
    };
    let mut cycles = first_cycle(&cont, &mut po, hopf, o.hopf_amplitude)
        .map_err(num(format!("{ctx}: first cycle")))?;
    match extent {
        CycleExtent::WholeRange => {
            cont.extend_observed(&mut po, &mut cycles, max_points, &mut rejoin)
                .map_err(num(format!("{ctx}: cycle branch")))?;
        }
        CycleExtent::FirstFold => {
            // in chunks (a resumed branch continues exactly as an uninterrupted one)
            const CHUNK: usize = 8;
            while cycles.points.len() < max_points && lower_fold(&cycles).is_none() {
                let chunk = CHUNK.min(max_points - cycles.points.len());
                let stop = cont
                    .extend_observed(&mut po, &mut cycles, chunk, &mut rejoin)
                    .map_err(num(format!("{ctx}: cycle branch")))?;
                if stop != continuation::Stop::MaxPoints {
                    break;
                }
            }
        }
    }
    let crit = criticality(hopf, &cycles).ok_or_else(|| {
        SwayError::numerical(
            ctx.clone(),
            continuation::Error::InvalidInput(
                "the cycle branch does not leave the Hopf point".into(),
            ),
        )
    })?;
    Ok((po, cycles, crit))
}

/// Computes the bifurcation diagram of straight running and sway for one feedback law
/// (`LoopLaw::OPEN_LOOP`, the paper's [`LoopLaw::paper`] or any law continuation takes,
/// [`ClosedLoop`]):
/// the straight-running branch on [v_min, v_max] with its Hopf point, then the cycle branch
/// from the Hopf point until it leaves [v_min, v_max] (through the fold, if any).
///
/// # Errors
/// [`SwayError::Numerical`] saying which stage failed (no Hopf point in the range, Newton
/// divergence, ...).
pub fn bifurcation_diagram<P: Vehicle<N>, const N: usize>(
    model: &P,
    law: LoopLaw,
    options: &DiagramOptions,
) -> Result<Diagram, SwayError> {
    bifurcation_diagram_until(model, law, options, CycleExtent::WholeRange)
}

/// [`bifurcation_diagram`] with the cycle branch continued as far as `extent` says.
///
/// # Errors
/// As [`bifurcation_diagram`].
pub fn bifurcation_diagram_until<P: Vehicle<N>, const N: usize>(
    model: &P,
    law: LoopLaw,
    options: &DiagramOptions,
    extent: CycleExtent,
) -> Result<Diagram, SwayError> {
    let o = options;
    let problem = ClosedLoop::new(model, law);
    let params = problem.parameters(o.v_min_mps);
    let (equilibria, hopf) =
        straight_running(&problem, &params, (o.v_min_mps, o.v_max_mps), o.root_degree)?;
    let (po, cycles, crit) =
        cycles_from_hopf(&problem, &params, &hopf, o, o.max_cycle_points, extent)?;
    let cycle_summary: Vec<CycleSummary> = cycles
        .points
        .iter()
        .map(|p| summarise(&po, &p.u, p.stability.as_ref()))
        .collect();
    let fold = fold_of(&cycles, &cycle_summary);
    let last_v = cycle_summary.last().map_or(hopf.parameter, |c| c.speed_mps);
    let amplitudes: Vec<(f64, f64)> = cycle_summary
        .iter()
        .map(|c| (c.speed_mps, c.amplitude_deg.to_radians()))
        .collect();
    let rejoin = ranged::rejoin_end(&problem, &params, o.root_degree, &amplitudes);
    let cycle_branch_end = if let Some(end) = rejoin {
        end
    } else if last_v < o.v_min_mps || last_v > o.v_max_mps {
        BranchEnd::SpeedRange {
            speed_mps: last_v,
            limit_mps: if last_v < o.v_min_mps {
                o.v_min_mps
            } else {
                o.v_max_mps
            },
        }
    } else if extent == CycleExtent::FirstFold && fold.is_some() {
        BranchEnd::FirstFold
    } else if cycle_summary.len() >= o.max_cycle_points {
        BranchEnd::PointBudget {
            points: cycle_summary.len(),
        }
    } else {
        BranchEnd::StepUnderflow { speed_mps: last_v }
    };
    Ok(Diagram {
        law,
        options: o.clone(),
        equilibria,
        hopf,
        cycles,
        cycle_summary,
        criticality: crit,
        fold,
        searched_mps: [o.v_min_mps, o.v_max_mps],
        cycle_branch_end,
        bubbles: Vec::new(),
    })
}
