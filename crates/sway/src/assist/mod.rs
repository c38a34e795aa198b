//! The sway assist (issue 48, items 3–4): the vehicle co-simulated with the towing car's
//! sensors, the sway detectors and the intervention, one sensor frame (10 ms) at a time.
//!
//! Per frame, at t_k: the true signals from the state (the car's yaw rate ψ̇, its lateral
//! acceleration at its centre of gravity from the right-hand side
//! ([`CoSimulation::lateral_acceleration`]), the steering-wheel angle δ·i_s, the speed, the
//! hitch angle) → [`Sensors::sample`] → every detector's [`Detector::update`] → the
//! steering gate and the intervention ([`intervention::Controller`]) → the inputs held until
//! t_k+1 ([`HeldInputs`]: the speed with its V̇, the yaw moment, the gust's force on the
//! trailer) → the model integrated to t_k+1 by [`CoSimulation::step`]. The disturbance's
//! steering is the problem's own [`crate::sim::SteeringInput`] (continuous, its corners
//! landed on), so a run without intervention is the same problem as [`crate::sim::simulate`]
//! integrates: the stepping does not change the physics.
//!
//! The detectors see only the frames, never the state; a detector joins
//! [`DetectorsConfig`] by one field and one line of [`DetectorsConfig::build`]. The
//! model-based observer ([`ModelObserver`]) is told the vehicle's paper form
//! ([`observer_options`]: the car, the trailer's axle and tyre; never the trailer's mass,
//! inertia or centre of gravity, which it estimates) and its estimates are recorded
//! ([`ObserverTrack`]). The ground truth ([`truth`]) is defined once. A run that loses control ends there (the validity
//! guard, [`LossOfControl`]) and is an outcome, not an error.

pub mod disturbance;
pub mod intervention;
pub mod truth;

use nalgebra::SVector;
use serde::{Deserialize, Serialize};
use sway_detect::ConfigError;
use sway_detect::detector::observer::model::{CarParams, Friction};
use sway_detect::detector::{
    CounterOptions, DampingEstimator, DampingOptions, Detector, ModelObserver, ObserverEstimate,
    ObserverOptions, OscillationCounter,
};
use sway_detect::sensor::{Sensors, SensorsConfig, Truth};
use sway_model::vehicle::{LossOfControl, Vehicle};
use trailer_model::{AnyVehicleModel, HITCH_ANGLE, Model, State4};

use crate::SwayError;
use crate::sim::cosim::{CoSimulation, StepEnd};
use crate::sim::{HeldInputs, SimProblem, SolverSettings, SpeedProfile};
pub use disturbance::{Disturbance, DrivingSequence};
pub use intervention::{AssistOptions, AssistState, Controller, FrictionLimits, SteeringGate};
pub use truth::{ONSET_AMPLITUDE_DEG, RunTruth, SWAY_AMPLITUDE_DEG, SwayCriterion};

/// The detectors of an evaluation: each one present runs on every frame (all by
/// default, with their defaults).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DetectorsConfig {
    /// the oscillation counter (the production approach)
    pub oscillation_counter: Option<CounterOptions>,
    /// the online damping estimator
    pub damping_estimator: Option<DampingOptions>,
    /// the model-based observer: its priors, noise and thresholds; the car, the trailer's
    /// axle and cornering stiffness, the steering ratio and the frame rate are replaced by
    /// the run's ([`observer_options`])
    pub model_observer: Option<ObserverOptions>,
}

impl Default for DetectorsConfig {
    fn default() -> Self {
        Self {
            oscillation_counter: Some(CounterOptions::default()),
            damping_estimator: Some(DampingOptions::default()),
            model_observer: Some(ObserverOptions::default()),
        }
    }
}

/// A detector that runs in a thread of the evaluation.
pub type BoxedDetector = Box<dyn Detector + Send>;

/// The detectors of a run: the boxed ones, then the observer (kept by type: its estimates
/// are recorded).
pub struct DetectorSet {
    /// the counter and the damping estimator, as configured
    pub boxed: Vec<BoxedDetector>,
    /// the model-based observer
    pub observer: Option<ModelObserver>,
}

impl std::fmt::Debug for DetectorSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(self.boxed.iter().map(|d| d.name()))
            .entries(self.observer.as_ref().map(|o| o.name()))
            .finish()
    }
}

impl DetectorSet {
    /// Every detector, in the order of the config's fields (the order of every result).
    pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut dyn Detector> {
        self.boxed
            .iter_mut()
            .map(|d| d.as_mut() as &mut dyn Detector)
            .chain(self.observer.as_mut().map(|o| o as &mut dyn Detector))
    }

    /// How many.
    pub fn len(&self) -> usize {
        self.boxed.len() + usize::from(self.observer.is_some())
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl DetectorsConfig {
    /// The detectors as configured, in the order of the config's fields (the order of
    /// every result); the observer with its options as given (a check of the config: a
    /// run uses [`DetectorsConfig::build_for`]).
    ///
    /// # Errors
    /// A detector's [`ConfigError`].
    pub fn build(&self) -> Result<DetectorSet, ConfigError> {
        let mut v: Vec<BoxedDetector> = Vec::new();
        if let Some(o) = self.oscillation_counter {
            v.push(Box::new(OscillationCounter::new(o)?));
        }
        if let Some(o) = self.damping_estimator {
            v.push(Box::new(DampingEstimator::new(o)?));
        }
        let observer = self.model_observer.map(ModelObserver::new).transpose()?;
        Ok(DetectorSet { boxed: v, observer })
    }

    /// The detectors of a run on `model` (the vehicle's paper form) with the steering
    /// ratio and frame rate of the run ([`observer_options`]).
    ///
    /// # Errors
    /// A detector's [`ConfigError`].
    pub fn build_for(
        &self,
        model: &Model,
        steering_ratio: f64,
        frame_rate_hz: f64,
    ) -> Result<DetectorSet, ConfigError> {
        Self {
            model_observer: self
                .model_observer
                .map(|o| observer_options(&o, model, steering_ratio, frame_rate_hz)),
            ..*self
        }
        .build()
    }
}

/// The observer's options for a run on `model`: `base` (its priors, noise, thresholds) with
/// the towing car's parameters (known to its ESC), the trailer's hitch → axle distance and
/// axle cornering stiffness as the nominal values (the observer is told the trailer's axle
/// and tyre and estimates its mass, yaw inertia and centre of gravity), the road's friction
/// (the ESC's friction estimate, here exact), the run's steering ratio and frame rate. A vehicle file with model variants gives its equivalent paper
/// form ([`Vehicle::paper_model`]). The trailer's mass, inertia and centre of gravity are
/// never taken from the vehicle: the priors stay `base`'s.
pub fn observer_options(
    base: &ObserverOptions,
    model: &Model,
    steering_ratio: f64,
    frame_rate_hz: f64,
) -> ObserverOptions {
    let p = model.params();
    let c = &p.tractor;
    ObserverOptions {
        sample_rate_hz: frame_rate_hz,
        car: CarParams {
            mass: c.mass,
            yaw_inertia: c.yaw_inertia,
            front_axle: c.front_axle,
            cog: c.cog,
            rear_axle: c.rear_axle,
            front_cornering_stiffness: c.front_cornering_stiffness,
            rear_cornering_stiffness: c.rear_cornering_stiffness,
        },
        steering_ratio,
        trailer_axle_m: p.trailer.axle,
        trailer_cornering_stiffness: p.trailer.cornering_stiffness,
        friction: Friction {
            mu_static: p.friction.mu_static,
            mu_dynamic: p.friction.mu_dynamic,
        },
        ..*base
    }
}

/// The observer's estimates in a run, every critical-speed search
/// ([`ObserverOptions::v_crit_interval_samples`] frames).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ObserverTrack {
    /// t \[s\]
    pub t: Vec<f64>,
    /// V̂_crit \[m/s\] (None: none yet, or the estimated trailer does not sway)
    pub v_crit_mps: Vec<Option<f64>>,
    /// its standard deviation \[m/s\]
    pub v_crit_sd_mps: Vec<Option<f64>>,
    /// the estimate after the last frame (not serialised: what a study keeps of it, it
    /// copies out)
    #[serde(skip)]
    pub last: Option<ObserverEstimate>,
}

/// Whether the assist acts in a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Intervention {
    /// the detectors watch, nothing acts (the run's truth and the detectors' flags)
    None,
    /// the assist brakes on a gated flag
    Assist,
}

/// Everything of an evaluation but the vehicle and the scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct AssistSetup {
    /// the sensors (their seed is offset by each scenario's [`Scenario::seed`])
    pub sensors: SensorsConfig,
    /// the detectors
    pub detectors: DetectorsConfig,
    /// the intervention
    pub assist: AssistOptions,
    /// the ground truth's settings
    pub criterion: SwayCriterion,
    /// the steering ratio i_s \[-\]: steering-wheel angle per front-wheel angle
    pub steering_ratio: f64,
    /// the solver's error control
    pub solver: SolverSettings,
}

impl Default for AssistSetup {
    fn default() -> Self {
        Self {
            sensors: SensorsConfig::default(),
            detectors: DetectorsConfig::default(),
            assist: AssistOptions::default(),
            criterion: SwayCriterion::default(),
            steering_ratio: 16.0,
            solver: SolverSettings::default(),
        }
    }
}

/// One run's scenario: straight running at a speed, a disturbance, a horizon.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// the initial speed V0 \[m/s\]
    pub speed_mps: f64,
    /// the disturbance
    pub disturbance: Disturbance,
    /// when the disturbance starts \[s\]
    pub disturbance_start_s: f64,
    /// the run's end \[s\]
    pub horizon_s: f64,
    /// added to the sensors' seed: each run its own noise
    pub seed: u64,
}

/// One detector's verdicts in a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectorRecord {
    /// the detector's name; `<name>_gated` behind the steering gate
    pub name: String,
    /// the first frame it flagged at \[s\]
    pub first_flag_s: Option<f64>,
    /// how often its flag rose in the run (the false alarms of a run without sway)
    pub flags: usize,
    /// its largest score in the run (the ROC curves' input; None: the gate was shut
    /// throughout)
    pub max_score: Option<f64>,
}

/// The frames of a run for a figure.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// t \[s\]
    pub t: Vec<f64>,
    /// θ \[deg\]
    pub hitch_angle_deg: Vec<f64>,
    /// the measured car yaw rate \[deg/s\]
    pub yaw_rate_deg_s: Vec<f64>,
    /// the front-wheel angle δ \[deg\]
    pub steering_deg: Vec<f64>,
    /// V \[m/s\]
    pub speed_mps: Vec<f64>,
    /// the flags per detector (the order of [`RunOutcome::detectors`]), per frame
    pub flags: Vec<Vec<bool>>,
    /// whether the assist was engaged, per frame
    pub engaged: Vec<bool>,
}

/// What one run gives.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunOutcome {
    /// the scenario
    pub scenario: Scenario,
    /// whether the assist acted
    pub intervention: Intervention,
    /// per detector, then per detector behind the steering gate
    pub detectors: Vec<DetectorRecord>,
    /// the ground truth
    pub truth: RunTruth,
    /// when the validity guard tripped \[s\]
    pub loss_of_control_s: Option<f64>,
    /// which condition tripped
    pub loss_of_control_condition: Option<LossOfControl>,
    /// loss of control or sustained sway ([`truth`])
    pub sways: bool,
    /// V0 − V at the end \[m/s\]
    pub speed_lost_mps: f64,
    /// when the assist engaged first \[s\]
    pub engaged_s: Option<f64>,
    /// where the run ended \[s\]
    pub t_end_s: f64,
    /// the frames (when asked for)
    #[serde(skip)]
    pub trace: Option<Trace>,
    /// the observer's estimates (when it runs)
    #[serde(skip)]
    pub observer: Option<ObserverTrack>,
}

fn config_error(what: &str, e: ConfigError) -> SwayError {
    SwayError::numerical(format!("the sway assist's {what}"), e)
}

/// Runs `scenario` on `vehicle` (M reduced states) with `setup`; `record`: keep the frames.
///
/// # Errors
/// [`SwayError::Numerical`] when the solver fails or the sensors, detectors or gate do not
/// build (a loss of control is an outcome).
pub fn run<P: Vehicle<M>, const M: usize>(
    vehicle: &P,
    scenario: &Scenario,
    intervention: Intervention,
    setup: &AssistSetup,
    record: bool,
) -> Result<RunOutcome, SwayError> {
    run_steered(vehicle, scenario, None, intervention, setup, record)
}

/// [`run`] with ordinary driving's steering beside the scenario's disturbance (held per
/// frame, [`DrivingSequence`]): the run the observer learns the trailer in.
///
/// # Errors
/// As [`run`].
pub fn run_driving<P: Vehicle<M>, const M: usize>(
    vehicle: &P,
    scenario: &Scenario,
    driving: &DrivingSequence,
    setup: &AssistSetup,
    record: bool,
) -> Result<RunOutcome, SwayError> {
    run_steered(
        vehicle,
        scenario,
        Some(driving),
        Intervention::None,
        setup,
        record,
    )
}

fn run_steered<P: Vehicle<M>, const M: usize>(
    vehicle: &P,
    scenario: &Scenario,
    driving: Option<&DrivingSequence>,
    intervention: Intervention,
    setup: &AssistSetup,
    record: bool,
) -> Result<RunOutcome, SwayError> {
    let v0 = scenario.speed_mps;
    let t0 = scenario.disturbance_start_s;
    let model = vehicle.paper_model();
    let steering = scenario.disturbance.steering(model, v0, t0)?;
    let profile = SpeedProfile::Constant { speed_mps: v0 };
    let x0: SVector<f64, M> = vehicle.initial_state(&State4::zeros(), v0);
    let mut problem =
        SimProblem::<P, M, M>::new(vehicle, &profile, None, x0)?.with_steering(steering);
    let mut cosim = CoSimulation::start(&problem, 0.0, x0, &setup.solver)?;
    let mut sensor_cfg = setup.sensors.clone();
    sensor_cfg.seed = sensor_cfg.seed.wrapping_add(scenario.seed);
    let mut sensors = Sensors::new(&sensor_cfg).map_err(|e| config_error("sensors", e))?;
    let frame_s = sensors.frame_period_s();
    let mut detectors = setup
        .detectors
        .build_for(model, setup.steering_ratio, 1.0 / frame_s)
        .map_err(|e| config_error("detectors", e))?;
    let names: Vec<String> = detectors.iter_mut().map(|d| d.name().to_string()).collect();
    let mut gate = SteeringGate::new(setup.assist.gate, 1.0 / frame_s)
        .map_err(|e| config_error("steering gate", e))?;
    let mut controller = Controller::new(setup.assist, FrictionLimits::of(model), frame_s)
        .map_err(|e| config_error("controller", e))?;
    let nd = detectors.len();
    let mut records: Vec<DetectorRecord> = names
        .iter()
        .cloned()
        .chain(names.iter().map(|n| format!("{n}_gated")))
        .map(|name| DetectorRecord {
            name,
            first_flag_s: None,
            flags: 0,
            max_score: None,
        })
        .collect();
    // the flags of the last frame and of this one (raw, then gated), reused every frame
    let mut flagged_before = vec![false; 2 * nd];
    let mut flagged_now = vec![false; 2 * nd];
    let mut trace = record.then(Trace::default);
    let frames = (scenario.horizon_s / frame_s).round() as usize;
    let (mut ts, mut thetas) = (
        Vec::with_capacity(frames + 1),
        Vec::with_capacity(frames + 1),
    );
    let mut speed = v0;
    let mut held = HeldInputs {
        speed_mps: Some(v0),
        ..HeldInputs::default()
    };
    problem.set_held_inputs(held);
    let mut lost = None;
    let mut engaged_s = None;
    let mut track = detectors
        .observer
        .as_ref()
        .map(|_| ObserverTrack::default());
    let track_every = detectors
        .observer
        .as_ref()
        .map_or(1, |o| o.options().v_crit_interval_samples.max(1));
    let mut used = 0usize;
    for k in 0..=frames {
        let t = k as f64 * frame_s;
        if let Some(d) = driving {
            // ordinary driving's steering, held over this frame (sampled at its start)
            held.steering_angle_rad = d.angle(t);
            problem.set_held_inputs(held);
        }
        let x = *cosim.state();
        let u = problem.inputs(t, &x, &[]);
        let truth = Truth {
            yaw_rate: vehicle.yaw_rate(&x),
            lateral_acceleration: cosim.lateral_acceleration(&problem),
            steering_wheel_angle: u.steering_angle * setup.steering_ratio,
            speed: u.speed,
            hitch_angle: x[HITCH_ANGLE],
        };
        ts.push(t);
        thetas.push(x[HITCH_ANGLE]);
        if k == frames {
            break;
        }
        flagged_now.fill(false);
        let mut commands = intervention::Commands::default();
        let mut measured_yaw_rate = f64::NAN;
        if let Some(m) = sensors.sample(t, &truth) {
            measured_yaw_rate = m.yaw_rate;
            let shut = gate.update(m.steering_wheel_angle);
            let mut any_gated = false;
            for (i, d) in detectors.iter_mut().enumerate() {
                let out = d.update(&m);
                let raw = out.flag.is_sway();
                flagged_now[i] = raw;
                flagged_now[nd + i] = raw && !shut;
                any_gated |= flagged_now[nd + i];
                if t >= t0 && out.score.is_finite() {
                    let best = |r: &mut DetectorRecord| {
                        r.max_score = Some(r.max_score.map_or(out.score, |s| s.max(out.score)));
                    };
                    best(&mut records[i]);
                    if !shut {
                        best(&mut records[nd + i]);
                    }
                }
            }
            used += 1;
            if let (Some(o), Some(tr)) = (detectors.observer.as_ref(), track.as_mut())
                && used.is_multiple_of(track_every)
            {
                let e = o.estimate();
                tr.t.push(t);
                tr.v_crit_mps.push(e.v_crit_estimate_mps);
                tr.v_crit_sd_mps.push(e.v_crit_sd_mps);
            }
            if intervention == Intervention::Assist {
                commands = controller.update(m.yaw_rate, m.speed, any_gated);
                if controller.state() == AssistState::Engaged && engaged_s.is_none() {
                    engaged_s = Some(t);
                }
            }
        }
        for (i, r) in records.iter_mut().enumerate() {
            if flagged_now[i] && !flagged_before[i] {
                r.flags += 1;
                r.first_flag_s.get_or_insert(t);
            }
        }
        std::mem::swap(&mut flagged_before, &mut flagged_now);
        if let Some(tr) = trace.as_mut() {
            tr.t.push(t);
            tr.hitch_angle_deg.push(x[HITCH_ANGLE].to_degrees());
            tr.yaw_rate_deg_s.push(measured_yaw_rate.to_degrees());
            tr.steering_deg.push(u.steering_angle.to_degrees());
            tr.speed_mps.push(u.speed);
            tr.flags.push(flagged_before.clone());
            tr.engaged.push(controller.state() == AssistState::Engaged);
        }
        held = HeldInputs {
            speed_mps: Some(speed),
            acceleration_mps2: -commands.deceleration_mps2,
            speed_from_s: t,
            yaw_moment_nm: commands.yaw_moment_nm,
            trailer_lateral_force_n: scenario.disturbance.trailer_force(t, t0),
            steering_angle_rad: driving.map_or(0.0, |d| d.angle(t)),
        };
        let end = cosim.step(&mut problem, held, t + frame_s)?;
        speed -= commands.deceleration_mps2 * frame_s;
        if let StepEnd::LostControl(t_lost, why) = end {
            lost = Some((t_lost, why));
            ts.push(t_lost);
            thetas.push(cosim.state()[HITCH_ANGLE]);
            break;
        }
    }
    let settle_from = scenario.disturbance.end_s(model, v0, t0);
    let truth = setup
        .criterion
        .judge(&ts, &thetas, t0, settle_from, lost.is_some());
    let t_end_s = ts.last().copied().unwrap_or(0.0);
    if let (Some(o), Some(tr)) = (detectors.observer.as_ref(), track.as_mut()) {
        tr.last = Some(o.estimate());
    }
    let end_speed = match held.speed_mps {
        Some(v) => v + held.acceleration_mps2 * (t_end_s - held.speed_from_s),
        None => v0,
    };
    Ok(RunOutcome {
        scenario: *scenario,
        intervention,
        detectors: records,
        truth,
        loss_of_control_s: lost.map(|l| l.0),
        loss_of_control_condition: lost.map(|l| l.1),
        sways: lost.is_some() || truth.sustained_sway,
        speed_lost_mps: v0 - end_speed,
        engaged_s,
        t_end_s,
        trace,
        observer: track,
    })
}

/// [`run`] for any vehicle of a vehicle file.
///
/// # Errors
/// As [`run`].
pub fn run_any(
    vehicle: &AnyVehicleModel,
    scenario: &Scenario,
    intervention: Intervention,
    setup: &AssistSetup,
    record: bool,
) -> Result<RunOutcome, SwayError> {
    trailer_model::with_plant!(vehicle, m => run(m, scenario, intervention, setup, record))
}
