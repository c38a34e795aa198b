//! Bifurcation diagrams whose speed range is derived from the vehicle.
//!
//! With the speed range omitted ([`DiagramSettings`] without `v_min_mps` / `v_max_mps`),
//! straight running is continued from the lowest speed of the [`SpeedLimits`] until its
//! first Hopf point (V_crit), and the cycle branch born there is continued through its fold
//! until it has turned and passed (1 + `beyond_hopf`)·V_Hopf, or until a stated limit ends
//! it: the lowest or the maximum speed of the limits, the simulations' validity guard (loss
//! of control, checked on every cycle), or the point budget `max_cycle_points`. Whatever the
//! vehicle's V_crit, the work is bounded by the limits and the budget. Numbers in the
//! settings still win: with both given, [`vehicle_diagram`] is exactly
//! [`super::bifurcation_diagram_until`] on that range.
//!
//! The outcomes that are physics, not errors, are values here: no Hopf point below the
//! maximum speed ([`NoHopf`]), a supercritical Hopf point, a fold outside the searched
//! range, a branch ended by the guard ([`BranchEnd`] and [`Diagram::fold_reason`]).

use continuation::{
    Branch, Continuation, ContinuationOptions, Criticality, Decision, EquilibriumSystem, HopfPoint,
    Location, PeriodicOrbitSystem, SpecialKind, Stop, criticality,
};
use serde::{Deserialize, Serialize};
use sway_model::config::Absent;
use sway_model::vehicle::Vehicle;

use super::{
    BranchPointTest, ClosedLoop, CycleExtent, Diagram, DiagramOptions, DiagramSpec, LoopLaw, SPEED,
    collocation, fold_of, num, root_finder, summarise,
};
use crate::SwayError;
use crate::sim::LossOfControl;
use sway_model::speeds::SpeedLimits;

/// Default of [`DiagramSpec::beyond_hopf`] in [`DiagramSettings`]: the cycle branch is followed to 1.3·V_Hopf.
pub const BEYOND_HOPF: f64 = 0.3;

/// Width of the straight-running margin below the lowest speed of the cycle branch in the
/// derived figure range, as a fraction of V_Hopf.
pub const MARGIN_BELOW: f64 = 0.2;

/// The diagram settings as a config gives them (`[continuation]` of `fig3a.toml`'s
/// `[diagram]`, of `fig4b.toml`): [`DiagramOptions`] with the speed range optional.
///
/// `v_min_mps` omitted: derived from the vehicle: straight running starts at the lowest
/// speed of the limits; the figure starts 0.2·V_Hopf below the lowest speed of the cycle
/// branch. `v_max_mps` omitted: derived from the vehicle: the cycle branch ends once it has
/// passed (1 + `beyond_hopf`)·V_Hopf (or at the maximum speed, the guard, the budget).
pub type DiagramSettings = DiagramSpec<Option<f64>, f64>;

impl Default for DiagramSettings {
    /// fig3a's settings ([`DiagramOptions::default`]) with the range derived
    fn default() -> Self {
        Self::from_options(&DiagramOptions::default(), None)
    }
}

impl From<&DiagramOptions> for DiagramSettings {
    /// the same settings with the options' explicit range
    fn from(o: &DiagramOptions) -> Self {
        Self::from_options(o, Some((o.v_min_mps, o.v_max_mps)))
    }
}

impl From<&DiagramSettings> for DiagramSettings {
    fn from(o: &DiagramSettings) -> Self {
        o.clone()
    }
}

impl DiagramSettings {
    /// The closed-loop diagrams' settings (`fig4b`): mesh L = 40, largest step 0.5, range
    /// derived.
    pub fn closed_loop() -> Self {
        Self::from_options(&DiagramOptions::closed_loop(), None)
    }

    /// The settings of `o` on `range` \[m/s\] (None: the range derived from the vehicle).
    pub fn from_options(o: &DiagramOptions, range: Option<(f64, f64)>) -> Self {
        o.with_range(range.map(|r| r.0), range.map(|r| r.1), BEYOND_HOPF)
    }

    /// These settings on the speed range [v_min, v_max] \[m/s\].
    pub fn options(&self, v_min_mps: f64, v_max_mps: f64) -> DiagramOptions {
        self.with_range(v_min_mps, v_max_mps, Absent)
    }

    /// The speeds searched \[m/s\]: the config's numbers, else the limits'.
    pub fn searched(&self, limits: &SpeedLimits) -> (f64, f64) {
        (
            self.v_min_mps.unwrap_or(limits.min_speed_mps),
            self.v_max_mps.unwrap_or(limits.max_speed_mps),
        )
    }
}

/// Why a cycle branch ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "end", rename_all = "snake_case")]
pub enum BranchEnd {
    /// it passed the speed where the diagram ends, (1 + beyond_hopf)·V_Hopf
    Complete {
        /// speed of its last point \[m/s\]
        speed_mps: f64,
    },
    /// it left the searched speed range
    SpeedRange {
        /// speed of its last point \[m/s\]
        speed_mps: f64,
        /// the end of the range it left \[m/s\]
        limit_mps: f64,
    },
    /// it was continued only to its fold of cycles, the first fold where V has a local
    /// minimum ([`CycleExtent::FirstFold`])
    FirstFold,
    /// the validity guard stopped it: the model is not physical on this cycle
    Guard {
        /// the tripped condition
        condition: LossOfControl,
        /// speed of the cycle \[m/s\]
        speed_mps: f64,
        /// max |θ| on the cycle \[deg\]
        amplitude_deg: f64,
    },
    /// it used its point budget (`max_cycle_points`)
    PointBudget {
        /// points computed
        points: usize,
    },
    /// the continuation step fell below its minimum
    StepUnderflow {
        /// speed of its last point \[m/s\]
        speed_mps: f64,
    },
    /// the cycles shrank back onto straight running: a second Hopf point (a Hopf bubble,
    /// [`HopfBubble`])
    RejoinsStraightRunning {
        /// where the cycles vanish (their squared amplitude extrapolated to zero) \[m/s\]
        speed_mps: f64,
        /// the largest max |θ| on the branch \[deg\]
        amplitude_deg: f64,
    },
}

/// A cycle branch that never leaves straight running's neighbourhood: born at one Hopf point,
/// it shrinks back onto straight running at another (a Hopf bubble: where a root pair
/// crosses the axis and returns, or, past a fold, below its own Hopf point). Its cycles are
/// tiny; the sway that matters starts at the next loss of stability above both, which the
/// diagram follows instead.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HopfBubble {
    /// the Hopf point the branch is born at \[m/s\]
    pub opens_mps: f64,
    /// where its cycles rejoin straight running (above or below `opens_mps`) \[m/s\]
    pub closes_mps: f64,
    /// the largest max |θ| of its cycles \[deg\]
    pub amplitude_deg: f64,
}

/// A cycle branch whose max |θ| falls below this fraction of its largest value has met
/// straight running again ([`BranchEnd::RejoinsStraightRunning`]): near a Hopf point the
/// squared amplitude is linear in V, so it reaches zero within a step from there.
const REJOIN_FRACTION: f64 = 0.02;

/// At most this many windows of instability are passed over before the diagram keeps the
/// cycles of the last one.
const MAX_BUBBLES: usize = 4;

impl BranchEnd {
    /// One sentence for the summary and the console.
    pub fn reason(&self) -> String {
        match *self {
            BranchEnd::Complete { speed_mps } => {
                format!("the cycle branch was followed to {speed_mps:.3} m/s")
            }
            BranchEnd::SpeedRange {
                speed_mps,
                limit_mps,
            } => format!(
                "the cycle branch left the searched speed range at {speed_mps:.3} m/s (limit {limit_mps} m/s)"
            ),
            BranchEnd::FirstFold => "the cycle branch was followed to its first fold".into(),
            BranchEnd::Guard {
                condition,
                speed_mps,
                amplitude_deg,
            } => format!(
                "the cycle branch ends where the validity guard stops it (loss of control: {}) at {speed_mps:.3} m/s, max |θ| = {amplitude_deg:.2}°",
                condition.as_str()
            ),
            BranchEnd::PointBudget { points } => format!(
                "the cycle branch used its point budget ({points} points, max_cycle_points)"
            ),
            BranchEnd::StepUnderflow { speed_mps } => format!(
                "the cycle branch could not be continued beyond {speed_mps:.3} m/s (step below its minimum)"
            ),
            BranchEnd::RejoinsStraightRunning {
                speed_mps,
                amplitude_deg,
            } => format!(
                "the cycle branch shrinks back onto straight running at {speed_mps:.3} m/s, a second Hopf point (max |θ| ≤ {amplitude_deg:.2e}°)"
            ),
        }
    }
}

impl Diagram {
    /// Why the diagram has no fold of cycles (None if it has one): a supercritical Hopf
    /// point, or the cycle branch ended before it folded ([`BranchEnd::reason`]).
    pub fn fold_reason(&self) -> Option<String> {
        if self.fold.is_some() {
            return None;
        }
        let upper = super::upper_fold(&self.cycles).map(|i| self.cycle_summary[i].speed_mps);
        let reason = match (self.criticality, upper) {
            (Criticality::Supercritical, Some(v_up)) => format!(
                "supercritical Hopf point at {:.4} m/s, but its stable cycles fold back at {v_up:.4} m/s and the branch returns, unstable, to lower speeds: no lower fold of cycles in the searched range ({})",
                self.hopf.parameter,
                self.cycle_branch_end.reason()
            ),
            (Criticality::Supercritical, None) if self.bubbles.is_empty() => format!(
                "supercritical Hopf point: stable sway cycles grow from V_crit = {:.4} m/s; no fold of cycles and no bistable range",
                self.hopf.parameter
            ),
            (Criticality::Supercritical, None) => format!(
                "supercritical Hopf point: stable sway cycles grow from V = {:.4} m/s; no fold of cycles",
                self.hopf.parameter
            ),
            _ => format!(
                "no fold of cycles in the searched range: {} before it folded",
                self.cycle_branch_end.reason()
            ),
        };
        Some(match self.bubbles_note() {
            Some(note) => format!("{reason} ({note})"),
            None => reason,
        })
    }

    /// The windows of instability passed over, in one clause (None without any).
    pub fn bubbles_note(&self) -> Option<String> {
        let windows: Vec<String> = self
            .bubbles
            .iter()
            .map(|b| {
                format!(
                    "the cycles of the Hopf point at {:.4} m/s rejoin straight running at {:.4} m/s (max |θ| {:.1e}°)",
                    b.opens_mps, b.closes_mps, b.amplitude_deg
                )
            })
            .collect();
        (!windows.is_empty()).then(|| format!("passed over below: {}", windows.join("; ")))
    }
}

/// A diagram without a Hopf point: what straight running does instead.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoHopf {
    /// straight running is stable on the whole searched range up to this speed \[m/s\]
    /// (None: it is unstable already at the lowest speed)
    pub stable_up_to_mps: Option<f64>,
    /// the lowest speed searched \[m/s\]
    pub searched_from_mps: f64,
    /// where straight running loses stability through a real eigenvalue instead
    /// (a static divergence, ω = 0: a pitchfork of the symmetric vehicle) \[m/s\]; None
    /// when it does not in the searched range
    pub divergence_v_mps: Option<f64>,
    /// why there is no diagram
    pub reason: String,
}

/// The result of [`vehicle_diagram`].
#[derive(Debug, Clone, PartialEq)]
pub enum DiagramOutcome {
    /// the diagram (its fold may still be missing: [`Diagram::fold_reason`])
    Computed(Box<Diagram>),
    /// no Hopf point of straight running in the searched range
    NoHopf(NoHopf),
}

impl DiagramOutcome {
    /// The diagram, if there is one.
    pub fn diagram(&self) -> Option<&Diagram> {
        match self {
            DiagramOutcome::Computed(d) => Some(d),
            DiagramOutcome::NoHopf(_) => None,
        }
    }
}

/// How straight running first loses stability on the searched range.
#[derive(Debug, Clone, PartialEq)]
pub enum FirstLoss {
    /// a complex pair crosses: the Hopf point where the sway cycles start
    Hopf(HopfPoint),
    /// a real eigenvalue crosses zero (static divergence) at this speed \[m/s\]
    Divergence(f64),
    /// stable on the whole range
    None,
}

/// Straight running continued from `v_lo` until just past the point where it first loses
/// stability (or to `v_hi`), in steps of 0.5 m/s as [`super::straight_running`]; the branch
/// and that first loss: a Hopf point, or a real eigenvalue through zero (a vehicle can
/// diverge statically before it sways).
pub fn straight_running_to_first_loss<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    params: &[f64],
    (v_lo, v_hi): (f64, f64),
    root_degree: usize,
) -> Result<(Branch, FirstLoss), SwayError> {
    let ctx = format!(
        "straight running (D = {} s, τ = {} s)",
        params[super::GAIN],
        params[super::DELAY]
    );
    let cont = equilibrium_continuation(v_lo, v_hi);
    let mut p = params.to_vec();
    p[SPEED] = v_lo;
    let mut eq = EquilibriumSystem::new(problem, p, SPEED, root_finder(root_degree))
        .map_err(num(ctx.clone()))?;
    let dir = eq.parameter_direction();
    let mut start = vec![0.0; N + 1];
    start[N] = v_lo;
    let mut branch = cont
        .start(&mut eq, &start, &dir)
        .map_err(num(format!("{ctx} at V = {v_lo} m/s")))?;
    let n = ((v_hi - v_lo) / 0.5).ceil() as usize + 8;
    // stop at the first regular point after the first loss of stability
    let mut past_loss = |b: &Branch| match first_loss_index(b) {
        Some(i) if b.points.len() > i + 1 => Decision::Stop,
        _ => Decision::Continue,
    };
    let stop = cont
        .extend_observed(&mut eq, &mut branch, n, &mut past_loss)
        .map_err(num(ctx.clone()))?;
    if let Stop::StepSizeUnderflow { .. } = stop {
        let v = branch.points.last().map_or(v_lo, |p| p.parameter);
        return Err(SwayError::numerical(
            ctx,
            continuation::Error::InvalidInput(format!(
                "straight running could not be continued beyond {v} m/s"
            )),
        ));
    }
    let loss = match branch
        .special_points()
        .find(|(_, sp)| loses_stability(sp.kind))
    {
        Some((ih, sp)) if sp.kind == SpecialKind::Hopf && sp.location == Location::Located => {
            FirstLoss::Hopf(
                eq.hopf_point(&branch.points[ih].u, sp.transversality.unwrap_or(1.0))
                    .map_err(num(format!("{ctx}: Hopf point")))?,
            )
        }
        // only detected (the engine's test function, the complex pair nearest the axis,
        // followed another pair: a second pair close to the axis, as near a double-Hopf
        // corner): the grid point lies up to one step (0.5 m/s) past the crossing, where
        // a subcritical branch has no small cycle. Locate it on the spectrum.
        Some((ih, sp)) if sp.kind == SpecialKind::Hopf && ih > 0 => {
            let (a, b) = (&branch.points[ih - 1].u, &branch.points[ih].u);
            let (u, transversality) =
                locate_hopf(&mut eq, a, b).map_err(num(format!("{ctx}: Hopf point")))?;
            FirstLoss::Hopf(
                eq.hopf_point(&u, transversality)
                    .map_err(num(format!("{ctx}: Hopf point")))?,
            )
        }
        Some((ih, sp)) if sp.kind == SpecialKind::Hopf => FirstLoss::Hopf(
            eq.hopf_point(&branch.points[ih].u, sp.transversality.unwrap_or(1.0))
                .map_err(num(format!("{ctx}: Hopf point")))?,
        ),
        Some((_, sp)) => FirstLoss::Divergence(sp.parameter),
        None => FirstLoss::None,
    };
    Ok((branch, loss))
}

/// Relative tolerance on the speed of a Hopf point located by [`locate_hopf`].
const HOPF_LOCATION_TOLERANCE: f64 = 1e-12;

/// The rightmost real part of the complex characteristic roots (Im λ > 0) at `u` \[1/s\]:
/// the Hopf test function that follows the crossing pair (whichever pair is rightmost)
/// rather than the pair nearest the imaginary axis.
fn complex_abscissa<S: continuation::CharacteristicRoots, P: continuation::Problem>(
    eq: &mut EquilibriumSystem<'_, P, S>,
    u: &[f64],
) -> continuation::Result<f64> {
    eq.spectrum(u)?
        .iter()
        .filter(|z| z.im > 1e-8)
        .map(|z| z.re)
        .max_by(f64::total_cmp)
        .ok_or_else(|| {
            continuation::Error::InvalidInput("no complex characteristic root to locate".into())
        })
}

/// The Hopf point of straight running between its points `a` (stable) and `b` (a complex
/// pair past the axis), located on the speed where the rightmost complex root crosses the
/// axis (Illinois regula falsi on the speed, to [`HOPF_LOCATION_TOLERANCE`]·V; the states
/// interpolated linearly, x = 0 for the symmetric vehicle). Returns the point u = (x, V*)
/// and the transversality d Re λ/dV across [a, b] \[1/m\].
fn locate_hopf<S: continuation::CharacteristicRoots, P: continuation::Problem>(
    eq: &mut EquilibriumSystem<'_, P, S>,
    a: &[f64],
    b: &[f64],
) -> continuation::Result<(Vec<f64>, f64)> {
    let ip = a.len() - 1;
    let at = |s: f64| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x + s * (y - x)).collect() };
    let (ga, gb) = (complex_abscissa(eq, a)?, complex_abscissa(eq, b)?);
    let dv = b[ip] - a[ip];
    let transversality = if dv != 0.0 { (gb - ga) / dv } else { 1.0 };
    if ga * gb > 0.0 {
        // no sign change of the rightmost complex root: keep the detected point (with the
        // engine's default transversality, as before)
        return Ok((b.to_vec(), 1.0));
    }
    let (mut s0, mut g0, mut s1, mut g1) = (0.0_f64, ga, 1.0_f64, gb);
    let mut side = 0i8;
    for _ in 0..100 {
        if (s1 - s0).abs() * dv.abs() <= HOPF_LOCATION_TOLERANCE * b[ip].abs() {
            break;
        }
        let s = s1 - g1 * (s1 - s0) / (g1 - g0);
        let g = complex_abscissa(eq, &at(s))?;
        if g == 0.0 {
            return Ok((at(s), transversality));
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
    }
    // the end of the last bracket nearer the axis
    let s = if g0.abs() < g1.abs() { s0 } else { s1 };
    Ok((at(s), transversality))
}

/// Special points of an equilibrium branch where an eigenvalue crosses the imaginary axis.
fn loses_stability(kind: SpecialKind) -> bool {
    matches!(
        kind,
        SpecialKind::Hopf
            | SpecialKind::RealCrossing
            | SpecialKind::BranchPoint
            | SpecialKind::Fold
    )
}

/// The index of the first point where `b` loses (or changes) stability.
fn first_loss_index(b: &Branch) -> Option<usize> {
    b.special_points()
        .find(|(_, sp)| loses_stability(sp.kind))
        .map(|(i, _)| i)
}

fn equilibrium_continuation(v_lo: f64, v_hi: f64) -> Continuation {
    Continuation::new(ContinuationOptions {
        initial_step: 0.5,
        max_step: 0.5,
        parameter_range: (v_lo, v_hi),
        ..Default::default()
    })
}

/// The first tripped validity condition on the cycle `u` of `sys` (checked at the
/// collocation nodes, with the delayed state read off the periodic profile).
pub fn cycle_loss_of_control<P: Vehicle<N>, const N: usize>(
    sys: &PeriodicOrbitSystem<'_, ClosedLoop<'_, P, N>>,
    problem: &ClosedLoop<'_, P, N>,
    u: &[f64],
) -> Option<LossOfControl> {
    let law = problem.law();
    let speed = u[u.len() - 1];
    let p = [speed, law.gains.yaw_rate, law.delay_s];
    let period = sys.period(u);
    let times = sys.node_times();
    let mut buf = [[0.0; N]; 3];
    let [now, delayed, dx] = &mut buf;
    let mut args = Vec::with_capacity(2 * N);
    for (g, &s) in times.iter().enumerate() {
        now.copy_from_slice(&u[N * g..N * g + N]);
        args.clear();
        args.extend_from_slice(now);
        if law.is_delayed() {
            sys.eval(u, s - law.delay_s / period, delayed, dx);
            args.extend_from_slice(delayed);
        }
        if let Some(c) = problem.loss_of_control(&args, &p) {
            return Some(c);
        }
    }
    None
}

/// A cycle branch with its system, criticality and why it ended.
type StoppedCycles<'a, P, const N: usize> = (
    PeriodicOrbitSystem<'a, ClosedLoop<'a, P, N>>,
    Branch,
    Criticality,
    BranchEnd,
);

/// The cycle branch from `hopf`, continued on `o`'s speed range for at most `max_points`
/// points, stopped by the first of: V ≥ `v_stop`, the first fold (`extent`), the validity
/// guard. Returns the system, the branch, its criticality and why it ended.
fn cycles_with_stop_rules<'a, P: Vehicle<N>, const N: usize>(
    problem: &'a ClosedLoop<'a, P, N>,
    params: &[f64],
    hopf: &HopfPoint,
    o: &DiagramOptions,
    v_stop: Option<f64>,
    extent: CycleExtent,
) -> Result<StoppedCycles<'a, P, N>, SwayError> {
    let ctx = format!(
        "cycles from the Hopf point V = {} m/s (D = {} s, τ = {} s)",
        hopf.parameter,
        params[super::GAIN],
        params[super::DELAY]
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
    // a second system on the same (fixed) mesh evaluates the profiles for the guard
    let guard_sys =
        PeriodicOrbitSystem::new(problem, p, SPEED, collocation(o)).map_err(num(ctx.clone()))?;
    let mut cycles = super::first_cycle(&cont, &mut po, hopf, o.hopf_amplitude)
        .map_err(num(format!("{ctx}: first cycle")))?;
    let mut end = None;
    // (V, max |θ|) of the branch's points so far, for the rejoin test
    let mut amplitudes: Vec<(f64, f64)> = Vec::new();
    let mut rejoined = false;
    let mut rules = |b: &Branch| {
        let Some(last) = b.points.last() else {
            return Decision::Continue;
        };
        let theta_max = guard_sys.max_abs(&last.u, trailer_model::HITCH_ANGLE);
        amplitudes.push((last.parameter, theta_max));
        if collapsed(&amplitudes) {
            rejoined = true;
            return Decision::Stop;
        }
        if let Some(condition) = cycle_loss_of_control(&guard_sys, problem, &last.u) {
            end = Some(BranchEnd::Guard {
                condition,
                speed_mps: last.parameter,
                amplitude_deg: theta_max.to_degrees(),
            });
            return Decision::Stop;
        }
        if extent == CycleExtent::FirstFold && super::lower_fold(b).is_some() {
            end = Some(BranchEnd::FirstFold);
            return Decision::Stop;
        }
        if v_stop.is_some_and(|v| last.parameter >= v) {
            end = Some(BranchEnd::Complete {
                speed_mps: last.parameter,
            });
            return Decision::Stop;
        }
        Decision::Continue
    };
    let stop = cont
        .extend_observed(&mut po, &mut cycles, o.max_cycle_points, &mut rules)
        .map_err(num(format!("{ctx}: cycle branch")))?;
    let last_v = cycles.points.last().map_or(hopf.parameter, |p| p.parameter);
    if rejoined {
        end = rejoin_end(problem, params, o.root_degree, &amplitudes);
    }
    let end = match stop {
        Stop::Observer => end.unwrap_or(BranchEnd::Complete { speed_mps: last_v }),
        Stop::MaxPoints => BranchEnd::PointBudget {
            points: cycles.points.len(),
        },
        Stop::ParameterRange => BranchEnd::SpeedRange {
            speed_mps: last_v,
            limit_mps: if last_v < o.v_min_mps {
                o.v_min_mps
            } else {
                o.v_max_mps
            },
        },
        Stop::StepSizeUnderflow { .. } => BranchEnd::StepUnderflow { speed_mps: last_v },
    };
    let crit = criticality(hopf, &cycles).ok_or_else(|| {
        SwayError::numerical(
            ctx.clone(),
            continuation::Error::InvalidInput(
                "the cycle branch does not leave the Hopf point".into(),
            ),
        )
    })?;
    Ok((po, cycles, crit, end))
}

/// The next Hopf point of straight running above `from` \[m/s\] (where a Hopf bubble's
/// cycles rejoined it, or their Hopf point if higher): straight running continued from just
/// past it (by 1e-3 of the speed, where it is stable again) to its next loss of stability
/// below `v_hi`. None when it stays stable, diverges statically or is unstable there.
///
/// # Errors
/// As [`straight_running_to_first_loss`].
fn next_hopf_point<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    params: &[f64],
    (from, v_hi): (f64, f64),
    root_degree: usize,
) -> Result<Option<HopfPoint>, SwayError> {
    let from = from * (1.0 + 1e-3);
    if from >= v_hi {
        return Ok(None);
    }
    let (branch, loss) =
        straight_running_to_first_loss(problem, params, (from, v_hi), root_degree)?;
    let stable_start = branch.points.first().and_then(|p| p.is_stable()) == Some(true);
    Ok(match loss {
        FirstLoss::Hopf(h) if stable_start => Some(h),
        _ => None,
    })
}

/// [`BranchEnd::RejoinsStraightRunning`] of a branch whose (V, max |θ| \[rad\]) per point are
/// `amplitudes`, if its last cycle has collapsed ([`rejoins_straight_running`]): the speed
/// is the Hopf point of straight running located on its spectrum ([`rejoin_hopf_speed`]),
/// else the extrapolated one.
pub(super) fn rejoin_end<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    params: &[f64],
    root_degree: usize,
    amplitudes: &[(f64, f64)],
) -> Option<BranchEnd> {
    let r = rejoins_straight_running(amplitudes)?;
    Some(BranchEnd::RejoinsStraightRunning {
        speed_mps: rejoin_hopf_speed(problem, params, root_degree, r.bracket)
            .unwrap_or(r.estimate_mps),
        amplitude_deg: r.amplitude_rad.to_degrees(),
    })
}

/// The Hopf point of straight running near the speeds of `bracket` (the last cycle of a
/// Hopf bubble and its collapsed successor), located where the rightmost complex root crosses
/// the axis ([`locate_hopf`]); None without a sign change within 8 bracket lengths.
fn rejoin_hopf_speed<P: Vehicle<N>, const N: usize>(
    problem: &ClosedLoop<'_, P, N>,
    params: &[f64],
    root_degree: usize,
    (v_in, v_out): (f64, f64),
) -> Option<f64> {
    let mut p = params.to_vec();
    p[SPEED] = v_in;
    let mut eq = EquilibriumSystem::new(problem, p, SPEED, root_finder(root_degree)).ok()?;
    let point = |v: f64| {
        let mut u = vec![0.0; N + 1];
        u[N] = v;
        u
    };
    // the collapsed cycle may still lie short of the Hopf point: the bracket is widened
    // (doubled, up to 8 times its length) until the complex abscissa changes sign
    (0..4).find_map(|k| {
        let v_far = v_in + f64::from(1 << k) * (v_out - v_in);
        let (u, _) = locate_hopf(&mut eq, &point(v_in), &point(v_far)).ok()?;
        (u[N] != v_far).then_some(u[N])
    })
}

/// Whether the last cycle of a branch with (V, max |θ|) per point `amplitudes` has shrunk
/// back onto straight running ([`rejoins_straight_running`]).
pub(super) fn collapsed(amplitudes: &[(f64, f64)]) -> bool {
    rejoins_straight_running(amplitudes).is_some()
}

/// A cycle branch that has shrunk back onto straight running ([`rejoins_straight_running`]).
struct Rejoin {
    /// where the squared amplitude of the last two cycles above the threshold extrapolates
    /// to zero \[m/s\]
    estimate_mps: f64,
    /// the largest max |θ| on the branch \[rad\]
    amplitude_rad: f64,
    /// (V of the last cycle above the threshold, V of the collapsed one) \[m/s\]
    bracket: (f64, f64),
}

/// A [`Rejoin`] when the last of a branch's (V, max |θ|) has fallen below
/// [`REJOIN_FRACTION`] of the largest (the collapsed point may lie past the Hopf point, on
/// straight running seen as a cycle of any period).
fn rejoins_straight_running(amplitudes: &[(f64, f64)]) -> Option<Rejoin> {
    let &(v_last, a_last) = amplitudes.last()?;
    let a_max = amplitudes.iter().map(|p| p.1).fold(0.0, f64::max);
    if amplitudes.len() < 3 || a_last >= REJOIN_FRACTION * a_max {
        return None;
    }
    let above: Vec<_> = amplitudes
        .iter()
        .rev()
        .filter(|p| p.1 >= REJOIN_FRACTION * a_max)
        .take(2)
        .collect();
    let estimate_mps = match above[..] {
        [&(v1, a1), &(v0, a0)] if a0 > a1 => {
            let v = v1 + (v1 - v0) * a1 * a1 / (a0 * a0 - a1 * a1);
            // between the last cycle above and the collapsed point
            if (v - v1) * (v_last - v1) >= 0.0 && (v - v1).abs() <= (v_last - v1).abs() {
                v
            } else {
                v_last
            }
        }
        _ => v_last,
    };
    Some(Rejoin {
        estimate_mps,
        amplitude_rad: a_max,
        bracket: (above.first().map_or(v_last, |p| p.0), v_last),
    })
}

/// The bifurcation diagram of `model` with `feedback`, on the speed range of `settings`
/// or, where it omits one, on the range derived from the vehicle (module docs); bounded by
/// `limits` (lowest and maximum speed) and the point budget.
///
/// With both ends given this is [`super::bifurcation_diagram_until`] on them (no Hopf point
/// in a given range stays an error: the user's range is to be widened). With an end
/// derived, no Hopf point below the maximum speed is the outcome [`DiagramOutcome::NoHopf`].
///
/// # Errors
/// [`SwayError::Numerical`] saying which stage failed.
pub fn vehicle_diagram<P: Vehicle<N>, const N: usize>(
    model: &P,
    law: LoopLaw,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
    extent: CycleExtent,
) -> Result<DiagramOutcome, SwayError> {
    ranged_diagram(model, law, settings, limits, extent, true)
}

/// [`vehicle_diagram`] for a caller that needs the cycle branch only (its fold):
/// straight running ends just past its first loss of stability instead of being continued
/// to the figure's end (the diagram's `equilibria` are not drawn).
///
/// # Errors
/// As [`vehicle_diagram`].
pub fn cycle_diagram<P: Vehicle<N>, const N: usize>(
    model: &P,
    law: LoopLaw,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
    extent: CycleExtent,
) -> Result<DiagramOutcome, SwayError> {
    ranged_diagram(model, law, settings, limits, extent, false)
}

fn ranged_diagram<P: Vehicle<N>, const N: usize>(
    model: &P,
    law: LoopLaw,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
    extent: CycleExtent,
    figure_equilibria: bool,
) -> Result<DiagramOutcome, SwayError> {
    if let (Some(lo), Some(hi)) = (settings.v_min_mps, settings.v_max_mps) {
        let d = super::bifurcation_diagram_until(model, law, &settings.options(lo, hi), extent)?;
        return Ok(DiagramOutcome::Computed(Box::new(d)));
    }
    let (lo, hi) = settings.searched(limits);
    let problem = ClosedLoop::new(model, law);
    let params = problem.parameters(lo);
    let (mut equilibria, loss) =
        straight_running_to_first_loss(&problem, &params, (lo, hi), settings.root_degree)?;
    let start_unstable = equilibria.points.first().and_then(|p| p.is_stable()) == Some(false);
    let hopf = match &loss {
        FirstLoss::Hopf(h) if !start_unstable => Some(h.clone()),
        _ => None,
    };
    let Some(hopf) = hopf else {
        let which = if settings.v_max_mps.is_some() {
            "v_max_mps"
        } else {
            "the maximum speed, --max-speed"
        };
        let ctl = if law.gains.yaw_rate == 0.0 {
            String::new()
        } else {
            format!(" with D = {} s, τ = {} s", law.gains.yaw_rate, law.delay_s)
        };
        return Ok(DiagramOutcome::NoHopf(match loss {
            _ if start_unstable => NoHopf {
                stable_up_to_mps: None,
                searched_from_mps: lo,
                divergence_v_mps: None,
                reason: format!(
                    "straight running{ctl} is unstable already at {lo} m/s (the lowest speed searched): no Hopf point to start the sway cycles from"
                ),
            },
            FirstLoss::Divergence(v) => NoHopf {
                stable_up_to_mps: Some(v),
                searched_from_mps: lo,
                divergence_v_mps: Some(v),
                reason: format!(
                    "straight running{ctl} loses stability at {v:.4} m/s through a real eigenvalue (static divergence, ω = 0), not through a Hopf point: no sway cycles start there"
                ),
            },
            _ => NoHopf {
                stable_up_to_mps: Some(hi),
                searched_from_mps: lo,
                divergence_v_mps: None,
                reason: format!(
                    "straight running{ctl} is stable at every speed up to {hi} m/s ({which}): no Hopf point, no sway cycles"
                ),
            },
        }));
    };
    let search = settings.options(lo, hi);
    let v_stop = |vh: f64| match settings.v_max_mps {
        Some(_) => None,
        None => Some((1.0 + settings.beyond_hopf) * vh),
    };
    let (mut hopf, mut bubbles) = (hopf, Vec::new());
    let (mut po, mut cycles, mut crit, mut end) = cycles_with_stop_rules(
        &problem,
        &params,
        &hopf,
        &search,
        v_stop(hopf.parameter),
        extent,
    )?;
    // a Hopf bubble (cycles that rejoin straight running): the sway starts at the next Hopf
    // point above it, if straight running loses stability again in the range
    while let BranchEnd::RejoinsStraightRunning {
        speed_mps: closes,
        amplitude_deg,
    } = end
    {
        if bubbles.len() == MAX_BUBBLES {
            break;
        }
        // on upwards: cycles that turned back rejoin straight running below their Hopf point
        let from = closes.max(hopf.parameter);
        let Some(next) = next_hopf_point(&problem, &params, (from, hi), settings.root_degree)?
        else {
            break;
        };
        if next.parameter <= hopf.parameter {
            break;
        }
        bubbles.push(HopfBubble {
            opens_mps: hopf.parameter,
            closes_mps: closes,
            amplitude_deg,
        });
        (po, cycles, crit, end) = cycles_with_stop_rules(
            &problem,
            &params,
            &next,
            &search,
            v_stop(next.parameter),
            extent,
        )?;
        hopf = next;
    }
    let vh = hopf.parameter;
    let cycle_summary: Vec<_> = cycles
        .points
        .iter()
        .map(|p| summarise(&po, &p.u, p.stability.as_ref()))
        .collect();
    let (v_low, v_high) = cycle_summary.iter().fold((vh, vh), |(a, b), c| {
        (a.min(c.speed_mps), b.max(c.speed_mps))
    });
    let plot_lo = settings
        .v_min_mps
        .unwrap_or_else(|| (v_low - MARGIN_BELOW * vh).max(lo));
    let plot_hi = settings
        .v_max_mps
        .unwrap_or_else(|| v_high.max(1.1 * vh).min(hi));
    // straight running on to the figure's end (equilibria.csv)
    if figure_equilibria && plot_hi > vh {
        let cont = equilibrium_continuation(lo, plot_hi);
        let mut p = params.clone();
        p[SPEED] = vh;
        let mut eq = EquilibriumSystem::new(&problem, p, SPEED, root_finder(settings.root_degree))
            .map_err(num("straight running beyond the Hopf point".into()))?;
        // from its last point: just past the first loss, below `vh` past a window
        let v_from = equilibria.points.last().map_or(vh, |p| p.parameter.min(vh));
        let n = ((plot_hi - v_from) / 0.5).ceil() as usize + 4;
        cont.extend(&mut eq, &mut equilibria, n)
            .map_err(num("straight running beyond the Hopf point".into()))?;
    }
    let fold = fold_of(&cycles, &cycle_summary);
    Ok(DiagramOutcome::Computed(Box::new(Diagram {
        bubbles,
        law,
        options: settings.options(plot_lo, plot_hi),
        equilibria,
        hopf,
        cycles,
        cycle_summary,
        criticality: crit,
        fold,
        searched_mps: [lo, hi],
        cycle_branch_end: end,
    })))
}
