//! Mitigation optimisation: the braking-and-steering intervention that ends
//! trailer sway fastest from **any** phase of the sway cycle.
//!
//! **Start.** The open loop settles on the sway cycle at V0 ([`sway_cycle`]); its period P
//! is the time between two upward zero crossings of θ. The intervention starts at phase
//! φ ∈ \[0, 1) (time φ·P after an upward crossing); N phases are equally spaced
//! ([`PhaseStarts`]). Each run starts a lead-in of τ (the feedback delay) *before* the
//! intervention, on the cycle, with the controller off: when the controller switches on,
//! the delayed yaw rate ψ̇(t − τ) it reads is the cycle's own past, not a constant history
//! (runs with a constant history x(t) = x(0) for t ≤ 0 never read it).
//!
//! **Decision variables** ([`Intervention`], vector layout [`DecisionBounds`]): braking
//! ΔV (bounded so that V0 + ΔV ≥ the minimum final speed, 25 m/s by default), ramp duration
//! T, ramp shape (discrete: [`RampShape`]), steering gain D at the hardware delay τ,
//! controller switch-on time t_on and on-duration (off at t_on + duration, never when that
//! reaches the horizon), all times relative to the intervention start. An optional
//! steering-angle limit δ_max is a fixed hardware setting ([`ActuatorLimits`]): the
//! saturation keeps |δ| ≤ δ_max by construction.
//!
//! **Objective** ([`phase_cost`]): the settle time (from the intervention until |θ| stays
//! below 1°) at every phase, worst case over the phases, within a 40 s horizon.
//! **Constraints by an exact penalty**: a phase that is infeasible costs more than the
//! horizon H, so any feasible design beats any infeasible one —
//! not settled: H + final amplitude \[deg\]; loss of control: 2H + (H − time of the loss);
//! peak |θ| above the limit (45°): max(cost, H) + (peak − limit) \[deg\]. The final speed
//! is a bound, δ_max a saturation. [`optimise()`] minimises the worst case with the generic
//! [`sway_model::optimise::minimise`] (Nelder–Mead per ramp shape, seeded multi-start).

use dde::{Direction, Event, EventAction, EventHit, Observer, OdeSolver};
use nalgebra::SVector;
use serde::{Deserialize, Serialize};
use trailer_model::{HITCH_ANGLE, Model, State4};

use crate::SwayError;
use crate::parallel::{Split, map};
use crate::sim::{
    ActuatorLimits, EarlyStop, LoopLaw, Metrics, Outcome, RampShape, Recording, RunSettings,
    SimProblem, SimResult, SimSpec, SimulateOwn, SolverSettings, SpeedProfile, settle,
};
use std::sync::atomic::{AtomicBool, Ordering};
use sway_model::optimise::{
    Bound, Bounded, Minimum, MixedProblem, OptimiserSettings, minimise, worst_case,
};

/// The open-loop sway cycle at constant speed, of a plant with M reduced states (4: the
/// paper's model).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SwayCycle<const M: usize = 4> {
    /// V0 \[m/s\]
    pub speed_mps: f64,
    /// period P \[s\] between upward zero crossings of θ
    pub period_s: f64,
    /// max |θ| over one period \[deg\]
    pub amplitude_deg: f64,
    /// the state at an upward zero crossing of θ (phase 0), in the plant's layout
    #[serde(skip)]
    pub anchor: SVector<f64, M>,
}

impl<const M: usize> SwayCycle<M> {
    /// The same cycle with the anchor's first four states \[σ1, σ2, σ3, θ\] (the paper's
    /// layout; a plant's own states dropped): what `summary.json` reports.
    pub fn paper_form(&self) -> SwayCycle {
        SwayCycle {
            speed_mps: self.speed_mps,
            period_s: self.period_s,
            amplitude_deg: self.amplitude_deg,
            anchor: State4::new(
                self.anchor[0],
                self.anchor[1],
                self.anchor[2],
                self.anchor[3],
            ),
        }
    }
}

/// Records upward zero crossings of θ and the largest |θ| at step ends.
struct Crossings<const M: usize> {
    times: Vec<f64>,
    states: Vec<SVector<f64, M>>,
    peak: f64,
}

impl<const M: usize> Observer<M> for Crossings<M> {
    fn on_step(&mut self, step: &dde::StepView<'_, M>) -> dde::Flow {
        if !self.times.is_empty() {
            self.peak = self.peak.max(step.x()[HITCH_ANGLE].abs());
        }
        dde::Flow::Continue
    }
    fn on_event(&mut self, hit: &EventHit<M>) {
        self.times.push(hit.t);
        self.states.push(hit.x);
    }
}

/// Integrates the open loop at constant `speed_mps` from `x0` for `duration_s`, recording
/// the upward zero crossings of θ.
fn open_loop<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    speed_mps: f64,
    x0: SVector<f64, M>,
    duration_s: f64,
    solver: &SolverSettings,
) -> Result<(SVector<f64, M>, Crossings<M>), SwayError> {
    let profile = SpeedProfile::Constant { speed_mps };
    let plant = SimProblem::<P, M, M>::new(model, &profile, None, x0)?;
    let context = || format!("the sway cycle at V = {speed_mps} m/s over {duration_s} s");
    let mut obs = Crossings {
        times: Vec::new(),
        states: Vec::new(),
        peak: 0.0,
    };
    let events = [Event::new(
        |_t, x: &SVector<f64, M>| x[HITCH_ANGLE],
        Direction::Rising,
        EventAction::Continue,
    )];
    let mut s = OdeSolver::new(&plant, 0.0, x0, solver.options(None))
        .map_err(|e| SwayError::numerical(context(), e))?;
    if duration_s > 0.0 {
        s.integrate(&plant, duration_s, &events, &mut obs)
            .map_err(|e| SwayError::numerical(context(), e))?;
    }
    Ok((*s.state(), obs))
}

/// Settles on the sway cycle (open loop at `speed_mps` for `settle_s` from θ(0) =
/// `theta0_rad`, as [`settle`]), then finds its period from three upward zero crossings of θ
/// (within `search_s` seconds).
///
/// # Errors
/// [`SwayError::Numerical`] if the solver fails or θ does not cross zero upwards three times
/// within `search_s` (no sway at this speed).
pub fn sway_cycle<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    speed_mps: f64,
    theta0_rad: f64,
    settle_s: f64,
    search_s: f64,
    solver: &SolverSettings,
) -> Result<SwayCycle<M>, SwayError> {
    find_sway_cycle(model, speed_mps, theta0_rad, settle_s, search_s, solver)?.map_err(|m| {
        SwayError::numerical(
            format!("the sway cycle at V = {speed_mps} m/s"),
            std::io::Error::other(m),
        )
    })
}

/// As [`sway_cycle`], with "no sway at this speed" (fewer than three upward zero crossings
/// of θ within `search_s`, or a sway that loses control while settling,
/// [`SwayError::NoSwayCycle`]) as `Ok(Err(reason))`, an outcome rather than an error.
///
/// # Errors
/// [`SwayError::Numerical`] if the solver fails.
pub fn find_sway_cycle<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    speed_mps: f64,
    theta0_rad: f64,
    settle_s: f64,
    search_s: f64,
    solver: &SolverSettings,
) -> Result<Result<SwayCycle<M>, String>, SwayError> {
    let x = match settle(model, speed_mps, theta0_rad, settle_s, solver) {
        Ok(x) => x,
        // the sway grows past the validity guard: no cycle at this speed either
        Err(e @ SwayError::NoSwayCycle { .. }) => return Ok(Err(e.to_string())),
        Err(e) => return Err(e),
    };
    let (_, c) = open_loop(model, speed_mps, x, search_s, solver)?;
    if c.times.len() < 3 {
        return Ok(Err(format!(
            "θ crossed zero upwards {} times in {search_s} s after settling for {settle_s} s at V = {speed_mps} m/s: \
             no sway at this speed (try a speed above V_crit or a longer settle_s)",
            c.times.len()
        )));
    }
    Ok(Ok(SwayCycle {
        speed_mps,
        period_s: c.times[2] - c.times[1],
        amplitude_deg: c.peak.to_degrees(),
        anchor: c.states[1],
    }))
}

/// The run starts: the state at φ·P − lead-in after the anchor crossing, for N equally
/// spaced phases φ_k = span·k/N.
///
/// The model is mirror-symmetric: (σ1, σ2, σ3, θ, δ) → −(σ1, σ2, σ3, θ, δ) maps solutions
/// to solutions (the brush tire is odd, V is unchanged). The sway cycle is its own mirror
/// image shifted by half a period, so the run from φ + ½ is the mirror image of the run
/// from φ and has the same settle time and peak. With span = ½ the N runs therefore
/// sample the whole period at spacing 1/(2N).
#[derive(Debug, Clone, PartialEq)]
pub struct PhaseStarts<const M: usize = 4> {
    /// φ ∈ \[0, span)
    pub phases: Vec<f64>,
    /// the state where each run starts (lead-in before the intervention), in the plant's
    /// layout
    pub states: Vec<SVector<f64, M>>,
    /// lead-in \[s\]: the intervention starts this long after each run's start
    pub lead_in_s: f64,
}

impl<const M: usize> PhaseStarts<M> {
    /// N phases equally spaced over `span` (1: the whole period, ½: half of it, the other
    /// half by mirror symmetry) with the given lead-in (≥ the feedback delay τ, so that
    /// the controller reads the cycle's past).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if the solver fails.
    pub fn new<P: SimulateOwn<M>>(
        model: &P,
        cycle: &SwayCycle<M>,
        n: usize,
        span: f64,
        lead_in_s: f64,
        solver: &SolverSettings,
    ) -> Result<Self, SwayError> {
        let phases: Vec<f64> = (0..n).map(|k| span * k as f64 / n as f64).collect();
        let p = cycle.period_s;
        let states = phases
            .iter()
            .map(|phi| {
                let s = (phi * p - lead_in_s).rem_euclid(p);
                open_loop(model, cycle.speed_mps, cycle.anchor, s, solver).map(|(x, _)| x)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            phases,
            states,
            lead_in_s,
        })
    }
}

/// The state of the cycle `t_s` seconds after its anchor (an upward zero crossing of θ).
///
/// # Errors
/// [`SwayError::Numerical`] if the solver fails.
pub fn cycle_state<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    cycle: &SwayCycle<M>,
    t_s: f64,
    solver: &SolverSettings,
) -> Result<SVector<f64, M>, SwayError> {
    open_loop(model, cycle.speed_mps, cycle.anchor, t_s, solver).map(|(x, _)| x)
}

/// One braking-and-steering intervention (times relative to its start).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intervention {
    /// ΔV \[m/s\] (≤ 0: braking; 0: no braking)
    pub speed_change_mps: f64,
    /// T \[s\]: duration of the speed ramp
    pub duration_s: f64,
    /// the ramp's shape
    pub shape: RampShape,
    /// D \[s\] of δ = −D·ψ̇(t − τ) (0: no steering)
    pub gain_s: f64,
    /// t_on \[s\]: the controller switches on
    pub on_s: f64,
    /// t_off \[s\]: it switches off (never when absent)
    pub off_s: Option<f64>,
}

/// What every evaluation shares: the speed, the hardware, the horizon and the limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Setting {
    /// V0 \[m/s\]
    pub speed_mps: f64,
    /// τ \[s\]: the feedback delay of the hardware
    pub delay_s: f64,
    /// steering actuator limits
    pub actuator: ActuatorLimits,
    /// H \[s\]: horizon after the intervention starts
    pub horizon_s: f64,
    /// the constraint on max |θ| after the intervention starts \[deg\]
    pub peak_limit_deg: f64,
    /// guard, tolerances and metric settings of the runs
    pub settings: RunSettings,
}

impl Setting {
    /// The run of `iv` starting `lead_in_s` before the intervention.
    pub fn spec(&self, iv: &Intervention, lead_in_s: f64) -> SimSpec {
        let profile = if iv.speed_change_mps == 0.0 {
            SpeedProfile::Constant {
                speed_mps: self.speed_mps,
            }
        } else {
            SpeedProfile::Ramp {
                initial_mps: self.speed_mps,
                change_mps: iv.speed_change_mps,
                start_s: lead_in_s,
                duration_s: iv.duration_s,
                shape: iv.shape,
            }
        };
        let controller = (iv.gain_s != 0.0).then(|| LoopLaw {
            steering_limits: self.actuator,
            ..LoopLaw::paper(iv.gain_s, self.delay_s)
                .switched(lead_in_s + iv.on_s, iv.off_s.map(|t| lead_in_s + t))
        });
        SimSpec {
            early_stop: EarlyStop::Never,
            steering: Default::default(),
            profile,
            controller,
            horizon_s: lead_in_s + self.horizon_s,
            action_s: lead_in_s,
            settings: self.settings,
        }
    }

    /// One run of `iv` from `x0` (the lead-in before the intervention included).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if the solver fails.
    pub fn run<P: SimulateOwn<M>, const M: usize>(
        &self,
        model: &P,
        iv: &Intervention,
        x0: SVector<f64, M>,
        lead_in_s: f64,
        recording: Recording,
    ) -> Result<SimResult<M>, SwayError> {
        model.simulate_own(&self.spec(iv, lead_in_s), x0, recording)
    }
}

/// The settle time \[s\] of a run (from the intervention start), if it settled: |θ| stays
/// below the threshold from then to the horizon **and** over the whole final window
/// (`final_amplitude_deg` below the threshold). The second condition keeps a sway cycle
/// that happens to end inside its brief |θ| < 1° window from counting as settled; it makes
/// H − (final window) the longest settle time that counts (35 s with the defaults).
pub fn settled(m: &Metrics, setting: &Setting) -> Option<f64> {
    let threshold = setting.settings.metrics.settle_threshold_deg.get();
    match (m.settle_time_s, m.final_amplitude_deg) {
        (Some(s), Some(a)) if a < threshold => Some(s),
        _ => None,
    }
}

/// The penalised cost of one phase's run (see the module docs): the settle time \[s\] when
/// feasible (≤ H), more than H otherwise.
pub fn phase_cost(m: &Metrics, lead_in_s: f64, setting: &Setting) -> f64 {
    let h = setting.horizon_s;
    let base = match (m.outcome, settled(m, setting)) {
        (Outcome::LossOfControl, _) => {
            let t = m.loss_of_control_time_s.unwrap_or(0.0) - lead_in_s;
            2.0 * h + (h - t.clamp(0.0, h))
        }
        (Outcome::Ok, Some(s)) => s,
        (Outcome::Ok, None) => h + m.final_amplitude_deg.unwrap_or(h).min(h),
    };
    match m.peak_theta_deg_after_action {
        Some(p) if p > setting.peak_limit_deg => base.max(h) + (p - setting.peak_limit_deg),
        _ => base,
    }
}

/// An intervention evaluated at every phase.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// the metrics of each phase's run (`settle_time_s` from the intervention start, other
    /// times from the run's start, a lead-in earlier)
    pub phases: Vec<Metrics>,
    /// each phase's penalised cost
    pub costs: Vec<f64>,
    /// the worst case over the phases: the objective
    pub cost: f64,
    /// the phase index of the worst case
    pub worst_phase: usize,
    /// worst-case settle time \[s\] (null if some phase never settles or loses control; see
    /// [`settled`])
    pub worst_settle_time_s: Option<f64>,
    /// worst-case peak |θ| after the intervention starts \[deg\]
    pub worst_peak_deg: f64,
    /// the phases (indices) that lose control
    pub lost_phases: Vec<usize>,
    /// whether every constraint holds at every phase
    pub feasible: bool,
}

/// Runs `iv` from every phase start in parallel (results in phase order) and takes the
/// worst case.
///
/// # Errors
/// [`SwayError::Numerical`] if a run's solver fails (the first failing phase).
pub fn evaluate<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    setting: &Setting,
    starts: &PhaseStarts<M>,
    iv: &Intervention,
) -> Result<Evaluation, SwayError> {
    let lead = starts.lead_in_s;
    let (runs, worst) = worst_case(
        &starts.states,
        |x0| {
            setting
                .run(model, iv, *x0, lead, Recording::None)
                .map(|r| r.metrics)
        },
        |m| phase_cost(m, lead, setting),
    )?;
    let costs: Vec<f64> = runs.iter().map(|m| phase_cost(m, lead, setting)).collect();
    let worst_phase = worst.unwrap_or(0);
    let cost = costs.get(worst_phase).copied().unwrap_or(f64::INFINITY);
    let lost_phases: Vec<usize> = (0..runs.len())
        .filter(|&k| runs[k].outcome == Outcome::LossOfControl)
        .collect();
    let settle: Option<Vec<f64>> = runs.iter().map(|m| settled(m, setting)).collect();
    Ok(Evaluation {
        worst_settle_time_s: settle.map(|s| s.into_iter().fold(0.0, f64::max)),
        worst_peak_deg: runs
            .iter()
            .filter_map(|m| m.peak_theta_deg_after_action)
            .fold(0.0, f64::max),
        feasible: cost <= setting.horizon_s,
        lost_phases,
        worst_phase,
        cost,
        costs,
        phases: runs,
    })
}

/// The bounds of the continuous decision variables, in the order of the decision vector
/// x = \[ΔV, T, D, t_on, on-duration\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecisionBounds {
    /// ΔV \[m/s\] (the lower end is also raised to min_final_speed − V0)
    pub speed_change_mps: Bound,
    /// T \[s\]
    pub duration_s: Bound,
    /// D \[s\]
    pub gain_s: Bound,
    /// t_on \[s\]
    pub on_s: Bound,
    /// t_off − t_on \[s\] (the controller stays on when t_off reaches the horizon)
    pub on_duration_s: Bound,
}

impl DecisionBounds {
    /// The bounds as a slice-able array in decision-vector order.
    pub fn to_array(&self) -> [Bound; 5] {
        [
            self.speed_change_mps,
            self.duration_s,
            self.gain_s,
            self.on_s,
            self.on_duration_s,
        ]
    }
}

/// The intervention of decision vector `x` = \[ΔV, T, D, t_on, on-duration\] with `shape`.
pub fn intervention(x: &[f64], shape: RampShape, horizon_s: f64) -> Intervention {
    let off = x[3] + x[4];
    Intervention {
        speed_change_mps: x[0],
        duration_s: x[1],
        shape,
        gain_s: x[2],
        on_s: x[3],
        off_s: (off < horizon_s).then_some(off),
    }
}

/// The decision vector of `iv` (the inverse of [`intervention`]; a controller that never
/// switches off has on-duration H − t_on).
pub fn decision_vector(iv: &Intervention, horizon_s: f64) -> Vec<f64> {
    vec![
        iv.speed_change_mps,
        iv.duration_s,
        iv.gain_s,
        iv.on_s,
        iv.off_s.unwrap_or(horizon_s) - iv.on_s,
    ]
}

/// The mitigation problem for [`sway_model::optimise::minimise`]: choices are the ramp shapes
/// ([`RampShape::ALL`]), the cost the worst case over the phases.
#[derive(Debug)]
pub struct MitigationProblem<'a, P = Model, const M: usize = 4> {
    /// the vehicle (any plant: the paper's [`Model`] or a vehicle with model variants)
    pub model: &'a P,
    /// speed, hardware, horizon, limits
    pub setting: Setting,
    /// the phase starts
    pub starts: &'a PhaseStarts<M>,
    /// the bounds in decision-vector order
    pub bounds: [Bound; 5],
}

impl<P: SimulateOwn<M>, const M: usize> MixedProblem for MitigationProblem<'_, P, M> {
    fn bounds(&self) -> &[Bound] {
        &self.bounds
    }
    fn choices(&self) -> usize {
        RampShape::ALL.len()
    }
    fn cost(&self, choice: usize, x: &[f64]) -> Result<f64, SwayError> {
        let iv = intervention(x, RampShape::ALL[choice], self.setting.horizon_s);
        Ok(evaluate(self.model, &self.setting, self.starts, &iv)?.cost)
    }

    fn cost_unless_above(
        &self,
        choice: usize,
        x: &[f64],
        cutoff: f64,
    ) -> Result<Bounded, SwayError> {
        let iv = intervention(x, RampShape::ALL[choice], self.setting.horizon_s);
        evaluate_unless_above(self.model, &self.setting, self.starts, &iv, cutoff)
    }
}

/// The worst-case cost of `iv` over the phases ([`evaluate`]'s `cost`, bit for bit), or
/// [`Bounded::Above`] as soon as one phase's cost is proven larger than `cutoff`: a phase's
/// penalised cost is at least its settle time, so its run stops once the settle time is
/// proven larger ([`EarlyStop::SettleTimeAbove`]), and the phases not started yet are
/// skipped. The answer depends on the phases' own runs only, not on their timing: `Above`
/// exactly when some phase's run alone proves its cost larger than `cutoff`.
///
/// # Errors
/// [`SwayError::Numerical`] if a run's solver fails (the first failing phase) and no phase
/// proves the cutoff exceeded.
pub fn evaluate_unless_above<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    setting: &Setting,
    starts: &PhaseStarts<M>,
    iv: &Intervention,
    cutoff: f64,
) -> Result<Bounded, SwayError> {
    let lead = starts.lead_in_s;
    let above = AtomicBool::new(false);
    let mut spec = setting.spec(iv, lead);
    spec.early_stop = EarlyStop::SettleTimeAbove(cutoff);
    let costs: Vec<Result<f64, SwayError>> = map(&starts.states, Split::Adaptive, &|_, x0| {
        if above.load(Ordering::Relaxed) {
            return Ok(f64::INFINITY);
        }
        let r = model.simulate_own(&spec, *x0, Recording::None)?;
        let cost = if r.stopped_early {
            f64::INFINITY
        } else {
            phase_cost(&r.metrics, lead, setting)
        };
        if cost > cutoff {
            above.store(true, Ordering::Relaxed);
        }
        Ok(cost)
    });
    if above.into_inner() {
        return Ok(Bounded::Above);
    }
    let costs = costs.into_iter().collect::<Result<Vec<f64>, SwayError>>()?;
    Ok(Bounded::Exact(
        costs.into_iter().reduce(f64::max).unwrap_or(f64::INFINITY),
    ))
}

/// The optimum of [`optimise()`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Optimum {
    /// the best intervention
    pub intervention: Intervention,
    /// the optimiser's record (choice = index into [`RampShape::ALL`])
    pub minimum: Minimum,
}

/// Minimises the worst-case settle time over the phases (penalised, see the module docs)
/// from the given interventions and seeded random starts, for every ramp shape.
///
/// # Errors
/// [`SwayError::Numerical`] if a run's solver or the optimiser fails.
pub fn optimise<P: SimulateOwn<M>, const M: usize>(
    problem: &MitigationProblem<'_, P, M>,
    starts: &[Intervention],
    settings: &OptimiserSettings,
) -> Result<Optimum, SwayError> {
    let h = problem.setting.horizon_s;
    let given: Vec<Vec<f64>> = starts.iter().map(|iv| decision_vector(iv, h)).collect();
    let minimum = minimise(problem, &given, settings)?;
    Ok(Optimum {
        intervention: intervention(&minimum.x, RampShape::ALL[minimum.choice], h),
        minimum,
    })
}
