//! Running one scenario: events (hitch-angle extrema, the 1° settle threshold, the
//! validity guard), metrics computed on the fly, an optional sampled trajectory.

use dde::{
    DdeSolver, Direction, Event, EventAction, EventHit, Flow, Method, NoObserver, Observer,
    OdeSolver, Options, Stats, Status, StepView,
};
use nalgebra::SVector;
use serde::{Deserialize, Serialize};
use trailer_model::{HITCH_ANGLE, State4};

use super::SpeedProfile;
use super::classify::{MetricSettings, SwayClass, Window, Windows, classify};
use super::plant::SimProblem;
use crate::SwayError;
use sway_model::law::LoopLaw;
use sway_model::vehicle::{LossOfControl, Vehicle};

/// The Runge–Kutta pair of the simulations (`method = "auto"`, `"dop853"` or `"dopri5"` in
/// a `[solver]` table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IntegrationMethod {
    /// DOP853 for the open loop (an ODE) and Dormand–Prince 5(4) for the delayed closed
    /// loop. Measured at rtol 1e-8 (60 s at 33 m/s open loop, 40 s at 35 m/s closed loop with
    /// τ = 0.2 s): in open loop DOP853 needs 20 % fewer right-hand sides and is 20× more
    /// accurate; in closed loop every tyre kink echoes along the delay and the 8th-order
    /// pair must land on six echoes per kink instead of three, which costs more steps than
    /// its order saves.
    #[default]
    Auto,
    /// Dormand–Prince 8(5,3) ([`dde::Method::Dop853`])
    Dop853,
    /// Dormand–Prince 5(4) ([`dde::Method::Dopri5`])
    Dopri5,
}

impl IntegrationMethod {
    /// The integrator's method for an ODE (`delayed == false`) or a DDE.
    pub fn dde_method(self, delayed: bool) -> Method {
        match self {
            IntegrationMethod::Auto if delayed => Method::Dopri5,
            IntegrationMethod::Auto | IntegrationMethod::Dop853 => Method::Dop853,
            IntegrationMethod::Dopri5 => Method::Dopri5,
        }
    }
}

/// How steps land on the kinks of the right-hand side (`kink_landing = "auto"`, `"once"`
/// or `"exact"` in a `[solver]` table; the kinks are
/// [`crate::sim::SimProblem::switching_functions`], the rules [`dde::KinkLanding`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KinkLandingMode {
    /// `once` unless the actuator clamps the steering angle or its rate, then `exact`. The
    /// tyre law's kinks (tan α·|tan α| at α = 0, the onset of sliding where the force
    /// levels off with zero slope) keep the right-hand side C¹: the remainder a single
    /// landing straddles costs O(δ²), and measured against DOP853 at rtol 1e-13 (60 s open
    /// loop at 33 m/s, 40 s closed loop with τ = 0.2 s) `once` has the global error of
    /// `exact` (1.6e-7 and 1.0e-9 at rtol 1e-8) with 23 % fewer right-hand sides in open loop.
    /// A clamp is a C⁰ kink, whose straddled remainder costs O(δ).
    #[default]
    Auto,
    /// Once per kink ([`dde::KinkLanding::Once`]).
    Once,
    /// On the root to the event tolerance ([`dde::KinkLanding::Exact`]).
    Exact,
}

impl KinkLandingMode {
    /// The integrator's landing rule for a run with (`clamps == true`) or without actuator
    /// limits.
    pub fn dde_landing(self, clamps: bool) -> dde::KinkLanding {
        match self {
            KinkLandingMode::Auto if clamps => dde::KinkLanding::Exact,
            KinkLandingMode::Auto | KinkLandingMode::Once => dde::KinkLanding::Once,
            KinkLandingMode::Exact => dde::KinkLanding::Exact,
        }
    }
}

/// Error control of the simulations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSettings {
    /// relative tolerance
    pub rtol: f64,
    /// absolute tolerance
    pub atol: f64,
    /// step budget per run
    pub max_steps: usize,
    /// the Runge–Kutta pair
    pub method: IntegrationMethod,
    /// how steps land on the kinks of the right-hand side
    pub kink_landing: KinkLandingMode,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            atol: 1e-10,
            max_steps: 2_000_000,
            method: IntegrationMethod::default(),
            kink_landing: KinkLandingMode::default(),
        }
    }
}

impl SolverSettings {
    /// The [`dde::Options`] for these settings, for a run of `controller` (an ODE without
    /// a delay, a DDE with one).
    pub fn options(&self, controller: Option<&LoopLaw>) -> Options {
        let delayed = controller.is_some();
        let clamps = controller.is_some_and(|l| {
            l.steering_limits.max_angle_deg.is_some() || l.steering_limits.has_rate_limit()
        });
        Options {
            max_steps: self.max_steps,
            kink_landing: self.kink_landing.dde_landing(clamps),
            ..Options::with_tolerances(self.rtol, self.atol)
                .with_method(self.method.dde_method(delayed))
        }
    }

    /// Checks the tolerances; the error names `<prefix>.<key>` in `file`.
    ///
    /// # Errors
    /// [`SwayError::Config`].
    pub fn validate_at(&self, file: &std::path::Path, prefix: &str) -> Result<(), SwayError> {
        self.validate()
            .map_err(|(k, p)| SwayError::config(file, format!("{prefix}.{k}"), p))
    }

    /// Checks the tolerances (names the key on failure).
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        self.options(None).validate().map_err(|e| match e {
            dde::Error::InvalidOptions { field: "atol", .. } => ("atol", e.to_string()),
            dde::Error::InvalidOptions {
                field: "max_steps", ..
            } => ("max_steps", e.to_string()),
            _ => ("rtol", e.to_string()),
        })
    }
}

/// The validity guard: the model stops being physical when a tractor axle slides fully
/// (|α| > α_cr of eq. 15) or a wheel's longitudinal velocity reaches 0 (jackknifing
/// trailer, stopped vehicle). With `Stop` the run ends there with
/// `outcome = "loss_of_control"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ValidityGuard {
    /// stop at the first violation (default)
    #[default]
    Stop,
    /// integrate on regardless (the results past a violation are not physical)
    Off,
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// the horizon was reached with the model valid throughout
    Ok,
    /// the validity guard stopped the run
    LossOfControl,
}

impl Outcome {
    /// "ok" or "loss_of_control".
    pub fn as_str(&self) -> &'static str {
        match self {
            Outcome::Ok => "ok",
            Outcome::LossOfControl => "loss_of_control",
        }
    }
}

/// The headline numbers of one run (field names as in the summaries and sweep CSVs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// max |θ| \[deg\] for t ≥ the action time (null if the run ended before it)
    pub peak_theta_deg_after_action: Option<f64>,
    /// max |θ| \[deg\] over the final window (null when control was lost)
    pub final_amplitude_deg: Option<f64>,
    /// time \[s\] from the action until |θ| stays below the threshold to the end of the
    /// horizon (null if it never does, or when control was lost)
    pub settle_time_s: Option<f64>,
    /// "ok" or "loss_of_control"
    pub outcome: Outcome,
    /// when the guard tripped \[s\] (null when ok)
    pub loss_of_control_time_s: Option<f64>,
    /// which condition tripped (null when ok)
    pub loss_of_control_condition: Option<LossOfControl>,
    /// the class of the run ([`crate::sim::classify`]): "sustained_sway", "decaying",
    /// "offset", "settled" or "loss_of_control"
    pub class: SwayClass,
    /// ln(A_previous / A_final) / Δt \[1/s\] of the oscillation amplitudes of the last two
    /// windows (> 0: shrinking, < 0: growing); null unless the class is sustained sway or
    /// decaying
    pub decay_rate_per_s: Option<f64>,
}

/// The settings every simulation shares: the validity guard, the solver's error control
/// and the metric settings. Task configs flatten it, so its keys sit beside theirs
/// (`guard = "stop"`, `[solver]`, `[metrics]`); each key has a default.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct RunSettings {
    /// validity guard: "stop" (default) or "off"
    pub guard: ValidityGuard,
    /// tolerances
    pub solver: SolverSettings,
    /// metric settings
    pub metrics: MetricSettings,
}

/// What to record of the trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Recording {
    /// nothing (metrics only)
    None,
    /// the state, V and δ every `step_s` seconds (from the continuous extension)
    Every {
        /// sampling interval \[s\]
        step_s: f64,
    },
}

/// One sample of a recorded trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample<const N: usize> {
    /// time \[s\]
    pub t: f64,
    /// state (4 or 7 components)
    pub x: SVector<f64, N>,
    /// speed V \[m/s\]
    pub speed: f64,
    /// steering angle δ \[rad\]
    pub steering_angle: f64,
}

/// Everything that defines a run apart from the vehicle and the initial state.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSpec {
    /// V(t)
    pub profile: SpeedProfile,
    /// the feedback law (`None`: open loop, δ ≡ 0)
    pub controller: Option<LoopLaw>,
    /// a steering input added to the law's command (a test's impulse; none by default)
    pub steering: super::SteeringInput,
    /// end time \[s\] (runs start at t = 0)
    pub horizon_s: f64,
    /// the action (braking / steering) starts here \[s\]; metrics "after action" count from it
    pub action_s: f64,
    /// guard, tolerances and metric settings
    pub settings: RunSettings,
    /// whether the run may end before the horizon
    pub early_stop: EarlyStop,
}

/// When a run may end before its horizon (besides a loss of control).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum EarlyStop {
    /// never: the run goes to the horizon
    #[default]
    Never,
    /// as soon as the settle time (from the action start) is proven larger than this \[s\]:
    /// |θ| is above the settle threshold at a step's end that late, or fell below it for
    /// the last time so far that late. A run that settles does so at a falling crossing
    /// after every such moment, so its settle time is larger; one that does not settle
    /// has none. The metrics of a stopped run cover its time so far only
    /// ([`SimResult::stopped_early`]).
    SettleTimeAbove(f64),
}

/// The result of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct SimResult<const N: usize> {
    /// headline numbers
    pub metrics: Metrics,
    /// sampled trajectory (empty with [`Recording::None`])
    pub trajectory: Vec<Sample<N>>,
    /// where the run ended \[s\]
    pub t_end: f64,
    /// the state there
    pub x_end: SVector<f64, N>,
    /// solver work
    pub stats: Stats,
    /// the run was ended at `t_end` by [`SimSpec::early_stop`]: its settle time is proven
    /// larger than the bound, and its metrics cover \[0, `t_end`\] only
    pub stopped_early: bool,
}

/// Turning points reserved per classification window (the sway mode has ≈ 4 per 5 s, the
/// fast mode ≈ 15; more only reallocate once).
const TURNING_POINTS_RESERVED: usize = 64;

struct MetricObserver<'p, 'm, P, const M: usize, const N: usize> {
    plant: &'p SimProblem<'m, P, M, N>,
    action_s: f64,
    final_from: f64,
    /// start of the window before the final one
    previous_from: f64,
    windows: Windows,
    peak: Option<f64>,
    final_amp: f64,
    last_fall: Option<f64>,
    rec_step: Option<f64>,
    next_k: usize,
    trajectory: Vec<Sample<N>>,
    /// x(t_end − τ) of the last step (closed loop), for the guard diagnosis
    delayed_at_end: Option<SVector<f64, N>>,
    /// |θ| of the settle threshold \[rad\] and the early stop
    theta_settle: f64,
    early_stop: EarlyStop,
    stopped_early: bool,
}

impl<P: Vehicle<M>, const M: usize, const N: usize> MetricObserver<'_, '_, P, M, N> {
    #[inline]
    fn update(&mut self, t: f64, abs_theta: f64) {
        if t >= self.action_s {
            self.peak = Some(self.peak.map_or(abs_theta, |p| p.max(abs_theta)));
        }
        if t >= self.final_from {
            self.final_amp = self.final_amp.max(abs_theta);
        }
    }

    /// Whether the settle time is now proven larger than the early stop's bound (see
    /// [`EarlyStop::SettleTimeAbove`]), at a step's end `t` with |θ(t)| = `abs_theta`.
    fn stop_early(&mut self, t: f64, abs_theta: f64) -> Flow {
        let EarlyStop::SettleTimeAbove(bound) = self.early_stop else {
            return Flow::Continue;
        };
        let unsettled_since = if abs_theta > self.theta_settle {
            Some(t)
        } else {
            self.last_fall
        };
        match unsettled_since {
            Some(s) if s - self.action_s > bound => {
                self.stopped_early = true;
                Flow::Stop
            }
            _ => Flow::Continue,
        }
    }

    /// The classification window holding time `t` (None before both).
    #[inline]
    fn window(&mut self, t: f64) -> Option<&mut Window> {
        if t >= self.final_from {
            Some(&mut self.windows.last)
        } else if t >= self.previous_from {
            Some(&mut self.windows.previous)
        } else {
            None
        }
    }

    fn sample(&self, t: f64, x: SVector<f64, N>, delayed: Option<SVector<f64, N>>) -> Sample<N> {
        let xd: &[SVector<f64, N>] = match &delayed {
            Some(v) => std::slice::from_ref(v),
            None => &[],
        };
        let u = self.plant.inputs(t, &x, xd);
        Sample {
            t,
            x,
            speed: u.speed,
            steering_angle: u.steering_angle,
        }
    }
}

impl<P: Vehicle<M>, const M: usize, const N: usize> Observer<N>
    for MetricObserver<'_, '_, P, M, N>
{
    fn on_step(&mut self, step: &StepView<'_, N>) -> Flow {
        let (t0, t1) = (step.t_start(), step.t_end());
        if let Some(tau) = self.plant.controller().map(|l| l.delay_s) {
            self.delayed_at_end = step.eval_past(t1 - tau);
        }
        for tm in [self.action_s, self.previous_from, self.final_from] {
            if tm > t0 && tm < t1 {
                let th = step.eval(tm)[HITCH_ANGLE];
                self.update(tm, th.abs());
                if tm == self.previous_from {
                    self.windows.previous.start(th);
                } else if tm == self.final_from {
                    self.windows.previous.value(th);
                    self.windows.last.start(th);
                }
            }
        }
        let th1 = step.x()[HITCH_ANGLE];
        self.update(t1, th1.abs());
        if let Some(w) = self.window(t1) {
            w.value(th1);
        }
        if let Some(dt) = self.rec_step {
            loop {
                let t = self.next_k as f64 * dt;
                if t > t1 * (1.0 + 1e-14) {
                    break;
                }
                let t = t.min(t1);
                let x = step.eval(t);
                let delayed = self
                    .plant
                    .controller()
                    .map(|l| step.eval_past(t - l.delay_s).unwrap_or(x));
                let s = self.sample(t, x, delayed);
                self.trajectory.push(s);
                self.next_k += 1;
            }
        }
        self.stop_early(t1, th1.abs())
    }

    fn on_event(&mut self, hit: &EventHit<N>) {
        match hit.index {
            0 => {
                let th = hit.x[HITCH_ANGLE];
                self.update(hit.t, th.abs());
                if let Some(w) = self.window(hit.t) {
                    w.turning_point(hit.t, th);
                }
            }
            1 if hit.direction == Direction::Falling && hit.t >= self.action_s => {
                self.last_fall = Some(hit.t);
            }
            _ => {}
        }
    }
}

/// Runs one scenario of `vehicle` from the state `x0` at t = 0, in the vehicle's own
/// layout: its M reduced states (the paper's [`trailer_model::Model`]: \[σ1, σ2, σ3, θ\]),
/// or M + 3 with the kinematic states \[ψ, x_H, y_H\] last to get the path. Open loop uses
/// the ODE solver; with a controller the DDE solver (history: x ≡ x0 for t ≤ 0). With a
/// rate-limited actuator the steering angle is an extra state, starting at δ(0) = 0 (see
/// [`crate::sim::ActuatorLimits`]), with a predictor its integral z, starting at z(0) = 0
/// ([`sway_model::law::Structure::Predictor`]); these are added here and dropped from the result, which has
/// `N` states all the same, and the recorded `steering_angle` is the applied steering angle
/// (0 under differential braking). [`super::simulate_in_paper_layout`] runs the paper's
/// model or a vehicle file's model from the paper's layout.
///
/// # Errors
/// [`SwayError::Numerical`] if the solver fails (step-size underflow, non-finite state,
/// step budget), with the scenario's time in the message, or when `N` is neither M nor
/// M + 3.
pub fn simulate<V: Vehicle<M>, const M: usize, const N: usize>(
    vehicle: &V,
    spec: &SimSpec,
    x0: SVector<f64, N>,
    recording: Recording,
) -> Result<SimResult<N>, SwayError>
where
    Layout<N>: ControllerStates<N>,
{
    <Layout<N> as ControllerStates<N>>::run(vehicle, spec, x0, recording)
}

/// A vehicle that [`simulate`] runs in its own reduced layout (M states, no kinematic
/// ones), with the state counts of every controller known: every plant of
/// [`trailer_model::AnyVehicleModel`]. Generic code that simulates takes `P: SimulateOwn<M>`
/// instead of carrying the bound `Layout<M>: ControllerStates<M>` through every signature.
pub trait SimulateOwn<const M: usize>: Vehicle<M> {
    /// [`simulate`] from the reduced state `x0` (M states).
    ///
    /// # Errors
    /// As [`simulate`].
    fn simulate_own(
        &self,
        spec: &SimSpec,
        x0: SVector<f64, M>,
        recording: Recording,
    ) -> Result<SimResult<M>, SwayError>;
}

impl<P: Vehicle<M>, const M: usize> SimulateOwn<M> for P
where
    Layout<M>: ControllerStates<M>,
{
    fn simulate_own(
        &self,
        spec: &SimSpec,
        x0: SVector<f64, M>,
        recording: Recording,
    ) -> Result<SimResult<M>, SwayError> {
        simulate::<P, M, M>(self, spec, x0, recording)
    }
}

/// The state counts of a simulation problem: `Layout<N>` (N plant states, with the kinematic
/// ones if any) knows the counts with the controller's states added (1 for a rate-limited
/// actuator, 4 for a predictor), as literals for the fixed-size solver.
#[derive(Debug, Clone, Copy)]
pub struct Layout<const N: usize>;

/// Runs an N-state plant problem with the controller's states appended (see [`Layout`]).
pub trait ControllerStates<const N: usize> {
    /// [`simulate`] with the controller's states.
    ///
    /// # Errors
    /// As [`simulate`].
    fn run<P: Vehicle<M>, const M: usize>(
        plant: &P,
        spec: &SimSpec,
        x0: SVector<f64, N>,
        recording: Recording,
    ) -> Result<SimResult<N>, SwayError>;
}

macro_rules! layouts {
    ($($n:literal => $actuator:literal, $predictor:literal;)*) => {$(
        impl ControllerStates<$n> for Layout<$n> {
            fn run<P: Vehicle<M>, const M: usize>(
                plant: &P,
                spec: &SimSpec,
                x0: SVector<f64, $n>,
                recording: Recording,
            ) -> Result<SimResult<$n>, SwayError> {
                match spec.controller.map_or(0, |l| l.extra_states()) {
                    0 => run_problem::<P, M, $n>(plant, spec, x0, recording),
                    1 => with_controller_states::<P, M, $n, $actuator>(plant, spec, x0, recording),
                    4 => with_controller_states::<P, M, $n, $predictor>(plant, spec, x0, recording),
                    extra => Err(SwayError::numerical(
                        format!("simulation with {extra} controller states"),
                        std::io::Error::other("expected 0, 1 or 4"),
                    )),
                }
            }
        }
    )*};
}

// N = M or M + 3 for M = 4 … 10 (trailer_model::MAX_STATES)
layouts! {
    4 => 5, 8;
    5 => 6, 9;
    6 => 7, 10;
    7 => 8, 11;
    8 => 9, 12;
    9 => 10, 13;
    10 => 11, 14;
    11 => 12, 15;
    12 => 13, 16;
    13 => 14, 17;
}

/// Runs the `S`-state problem (the controller's states last: δ(0) = 0 or z(0) = 0) and drops
/// them from the states.
fn with_controller_states<P: Vehicle<M>, const M: usize, const N: usize, const S: usize>(
    plant: &P,
    spec: &SimSpec,
    x0: SVector<f64, N>,
    recording: Recording,
) -> Result<SimResult<N>, SwayError> {
    let x0s = SVector::<f64, S>::from_fn(|i, _| if i < N { x0[i] } else { 0.0 });
    let r = run_problem::<P, M, S>(plant, spec, x0s, recording)?;
    Ok(r.map_states(|x| SVector::<f64, N>::from_fn(|i, _| x[i])))
}

impl<const N: usize> SimResult<N> {
    /// The result with every state vector mapped by `f` (the trajectory's samples and the end
    /// state).
    pub fn map_states<const K: usize>(
        self,
        f: impl Fn(&SVector<f64, N>) -> SVector<f64, K>,
    ) -> SimResult<K> {
        SimResult {
            metrics: self.metrics,
            trajectory: self
                .trajectory
                .iter()
                .map(|s| Sample {
                    t: s.t,
                    x: f(&s.x),
                    speed: s.speed,
                    steering_angle: s.steering_angle,
                })
                .collect(),
            t_end: self.t_end,
            x_end: f(&self.x_end),
            stats: self.stats,
            stopped_early: self.stopped_early,
        }
    }
}

/// Events of a run: 0 the extrema of θ (θ̇ = 0, eq. 5), 1 |θ| crossing the settle threshold
/// `theta_settle` \[rad\]; the validity guard is added by [`guard_event`].
fn metric_events<'e, P: Vehicle<M>, const M: usize, const N: usize>(
    problem: &'e SimProblem<'_, P, M, N>,
    theta_settle: f64,
) -> Vec<Event<'e, N>> {
    vec![
        Event::new(
            move |_t, x| problem.hitch_angle_rate(x),
            Direction::Either,
            EventAction::Continue,
        ),
        Event::new(
            move |_t, x| x[HITCH_ANGLE] * x[HITCH_ANGLE] - theta_settle * theta_settle,
            Direction::Either,
            EventAction::Continue,
        ),
    ]
}

/// The validity guard as one terminal event: the five conditions of
/// [`trailer_model::Plant::guard_values`], each "tripped when > 0"; one event on their maximum
/// (continuous, and zero exactly when the first of them reaches zero) costs one slip
/// evaluation per call instead of five events.
pub fn guard_event<'e, P: Vehicle<M>, const M: usize, const N: usize>(
    problem: &'e SimProblem<'_, P, M, N>,
) -> Event<'e, N> {
    Event::with_delays(
        move |t, x, xd| {
            problem
                .guard_values(t, x, xd)
                .into_iter()
                .fold(f64::NEG_INFINITY, f64::max)
        },
        Direction::Rising,
        EventAction::Stop,
    )
}

/// Which condition of the guard tripped: the largest of
/// [`SimProblem::guard_values`].
pub fn tripped(v: [f64; 5]) -> LossOfControl {
    let k = (0..5).fold(0, |b, k| if v[k] > v[b] { k } else { b });
    LossOfControl::ALL[k]
}

/// Integrates the problem to the horizon (ODE in open loop, DDE with a delay): status, end
/// time, end state and the solver's counters.
fn integrate<P: Vehicle<M>, const M: usize, const N: usize>(
    problem: &SimProblem<'_, P, M, N>,
    spec: &SimSpec,
    x0: SVector<f64, N>,
    events: &[Event<'_, N>],
    obs: &mut MetricObserver<'_, '_, P, M, N>,
) -> Result<(Status<N>, f64, SVector<f64, N>, Stats), SwayError> {
    let opts = spec.settings.solver.options(spec.controller.as_ref());
    let context = || {
        format!(
            "simulation (profile {:?}, controller {:?}, horizon {} s)",
            spec.profile, spec.controller, spec.horizon_s
        )
    };
    if spec.controller.is_none() {
        let mut s = OdeSolver::new(problem, 0.0, x0, opts)
            .map_err(|e| SwayError::numerical(context(), e))?;
        let st = s
            .integrate(problem, spec.horizon_s, events, obs)
            .map_err(|e| SwayError::numerical(context(), e))?;
        Ok((st, s.t(), *s.state(), s.stats()))
    } else {
        let mut s =
            DdeSolver::new(problem, 0.0, opts).map_err(|e| SwayError::numerical(context(), e))?;
        let st = s
            .integrate(problem, spec.horizon_s, events, obs)
            .map_err(|e| SwayError::numerical(context(), e))?;
        Ok((st, s.t(), *s.state(), s.stats()))
    }
}

/// The metrics at the end of a run that reached the horizon, or lost control at `lost`.
fn final_metrics<P: Vehicle<M>, const M: usize, const N: usize>(
    obs: &mut MetricObserver<'_, '_, P, M, N>,
    spec: &SimSpec,
    x_end: &SVector<f64, N>,
    lost: Option<(f64, LossOfControl)>,
) -> Metrics {
    match lost {
        Some((t, cond)) => Metrics {
            peak_theta_deg_after_action: obs.peak.map(f64::to_degrees),
            final_amplitude_deg: None,
            settle_time_s: None,
            outcome: Outcome::LossOfControl,
            loss_of_control_time_s: Some(t),
            loss_of_control_condition: Some(cond),
            class: SwayClass::LossOfControl,
            decay_rate_per_s: None,
        },
        None => {
            let settled = x_end[HITCH_ANGLE].abs() < obs.theta_settle;
            obs.windows.last.last = Some(x_end[HITCH_ANGLE]);
            let verdict = classify(&obs.windows, &spec.settings.metrics);
            Metrics {
                peak_theta_deg_after_action: obs.peak.map(f64::to_degrees),
                final_amplitude_deg: Some(obs.final_amp.to_degrees()),
                settle_time_s: settled.then(|| {
                    obs.last_fall
                        .map_or(0.0, |tf| (tf - spec.action_s).max(0.0))
                }),
                outcome: Outcome::Ok,
                loss_of_control_time_s: None,
                loss_of_control_condition: None,
                class: verdict.class,
                decay_rate_per_s: verdict.decay_rate_per_s,
            }
        }
    }
}

/// One run of an N-state problem (controller states included): build the problem, its
/// events and the metric observer, integrate, and read the metrics.
fn run_problem<P: Vehicle<M>, const M: usize, const N: usize>(
    plant: &P,
    spec: &SimSpec,
    x0: SVector<f64, N>,
    recording: Recording,
) -> Result<SimResult<N>, SwayError> {
    let problem = SimProblem::<P, M, N>::new(plant, &spec.profile, spec.controller, x0)?
        .with_steering(spec.steering);
    let th_s = spec
        .settings
        .metrics
        .settle_threshold_deg
        .get()
        .to_radians();
    let mut events = metric_events(&problem, th_s);
    let x0_delayed: Vec<SVector<f64, N>> = spec.controller.map(|_| x0).into_iter().collect();
    if spec.settings.guard == ValidityGuard::Stop {
        let v0 = problem.guard_values(0.0, &x0, &x0_delayed);
        if v0.iter().any(|&g| g >= 0.0) {
            return Ok(lost_at_start(spec, x0, tripped(v0)));
        }
        events.push(guard_event(&problem));
    }
    let mut obs = MetricObserver::start(&problem, spec, recording, th_s, x0, &x0_delayed);
    let (status, t_end, x_end, stats) = integrate(&problem, spec, x0, &events, &mut obs)?;
    let lost = match status {
        Status::Event(hit) if hit.index == 2 => {
            // which condition: the largest guard value at the event (the others are < 0)
            let xd: Vec<SVector<f64, N>> = match spec.controller.map(|l| l.delay_s) {
                Some(_) => vec![obs.delayed_at_end.unwrap_or(hit.x)],
                None => Vec::new(),
            };
            Some((hit.t, tripped(problem.guard_values(hit.t, &hit.x, &xd))))
        }
        _ => None,
    };
    let metrics = final_metrics(&mut obs, spec, &x_end, lost);
    Ok(SimResult {
        metrics,
        trajectory: obs.trajectory,
        t_end,
        x_end,
        stats,
        stopped_early: obs.stopped_early,
    })
}

impl<'p, 'm, P: Vehicle<M>, const M: usize, const N: usize> MetricObserver<'p, 'm, P, M, N> {
    /// The observer of a run from `x0` at t = 0 (its first values seen, the first sample
    /// recorded), with the settle threshold `theta_settle` \[rad\].
    fn start(
        problem: &'p SimProblem<'m, P, M, N>,
        spec: &SimSpec,
        recording: Recording,
        theta_settle: f64,
        x0: SVector<f64, N>,
        x0_delayed: &[SVector<f64, N>],
    ) -> Self {
        let window_s = spec.settings.metrics.final_window_s.get();
        let mut obs = MetricObserver {
            plant: problem,
            action_s: spec.action_s,
            final_from: (spec.horizon_s - window_s).max(0.0),
            previous_from: (spec.horizon_s - 2.0 * window_s).max(0.0),
            windows: Windows {
                previous: Window::with_capacity(TURNING_POINTS_RESERVED),
                last: Window::with_capacity(TURNING_POINTS_RESERVED),
            },
            peak: None,
            final_amp: 0.0,
            last_fall: None,
            rec_step: match recording {
                Recording::None => None,
                Recording::Every { step_s } => Some(step_s),
            },
            next_k: 1,
            trajectory: Vec::new(),
            delayed_at_end: None,
            theta_settle,
            early_stop: spec.early_stop,
            stopped_early: false,
        };
        obs.update(0.0, x0[HITCH_ANGLE].abs());
        if let Some(w) = obs.window(0.0) {
            w.start(x0[HITCH_ANGLE]);
        }
        if obs.rec_step.is_some() {
            let s = obs.sample(0.0, x0, x0_delayed.first().copied());
            obs.trajectory.push(s);
        }
        obs
    }
}

fn lost_at_start<const N: usize>(
    spec: &SimSpec,
    x0: SVector<f64, N>,
    cond: LossOfControl,
) -> SimResult<N> {
    SimResult {
        metrics: Metrics {
            peak_theta_deg_after_action: (spec.action_s <= 0.0)
                .then(|| x0[HITCH_ANGLE].abs().to_degrees()),
            final_amplitude_deg: None,
            settle_time_s: None,
            outcome: Outcome::LossOfControl,
            loss_of_control_time_s: Some(0.0),
            loss_of_control_condition: Some(cond),
            class: SwayClass::LossOfControl,
            decay_rate_per_s: None,
        },
        trajectory: Vec::new(),
        t_end: 0.0,
        x_end: x0,
        stats: Stats::default(),
        stopped_early: false,
    }
}

/// The state "on the sway cycle" in the vehicle's own layout: integrate the open loop at
/// constant speed `speed_mps` from θ(0) = `theta0_rad` (the other paper states 0, the
/// vehicle's own states in steady state of the tyres, [`Vehicle::initial_state`]) for
/// `settle_s` seconds and return the reduced state where it ends. At a speed above V_crit
/// this is on the stable limit cycle (trailer sway). [`super::settle_in_paper_layout`]
/// gives it in the paper's four states.
///
/// # Errors
/// [`SwayError::NoSwayCycle`] if the sway grows past the model's validity guard
/// ([`guard_event`]) instead of settling; [`SwayError::Numerical`] if the solver fails.
pub fn settle<V: Vehicle<M>, const M: usize>(
    vehicle: &V,
    speed_mps: f64,
    theta0_rad: f64,
    settle_s: f64,
    solver: &SolverSettings,
) -> Result<SVector<f64, M>, SwayError> {
    let profile = SpeedProfile::Constant { speed_mps };
    let x0 = vehicle.initial_state(&State4::new(0.0, 0.0, 0.0, theta0_rad), speed_mps);
    let problem = SimProblem::<V, M, M>::new(vehicle, &profile, None, x0)?;
    let context = || format!("settling on the sway cycle at V = {speed_mps} m/s for {settle_s} s");
    let mut s = OdeSolver::new(&problem, 0.0, x0, solver.options(None))
        .map_err(|e| SwayError::numerical(context(), e))?;
    // a sway that grows past the model's validity has no cycle to settle on: stop there
    // (beyond it the explicit solver crawls through a jackknife for the rest of settle_s)
    let status = s
        .integrate(
            &problem,
            settle_s,
            &[guard_event(&problem)],
            &mut NoObserver,
        )
        .map_err(|e| SwayError::numerical(context(), e))?;
    if let Status::Event(_) = status {
        let condition = tripped(problem.guard_values(s.t(), s.state(), &[]));
        return Err(SwayError::NoSwayCycle {
            speed_mps,
            theta0_rad,
            time_s: s.t(),
            condition,
        });
    }
    Ok(*s.state())
}
