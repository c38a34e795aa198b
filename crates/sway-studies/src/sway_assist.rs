//! The computation of `sway_assist` (issue 48, item 4): the sway detectors and the assist
//! ([`sway::assist`]) evaluated against the nonlinear model.
//!
//! - **Sway set**: every vehicle × speeds relative to it (below V_fold, inside the bistable
//!   range, above V_crit: [`SpeedSpec`], resolved against the vehicle's own open-loop V_crit
//!   and fold of cycles, [`sway::ranging::open_loop_references`]) × disturbances of rising
//!   size (steering impulses, crosswind gusts, a single lane change).
//! - **False-alarm set**: speeds where straight running is stable × driving manoeuvres in
//!   the sway band (slalom, single and double lane changes, a ramp into a steady corner).
//! - Each scenario runs twice: the detectors watching ([`Intervention::None`]: the ground
//!   truth [`sway::assist::truth`] and the detectors' flags) and with the assist.
//! - **Per detector** (and behind the steering gate): detection rate over the scenarios
//!   that sway without the assist, false alarms (flags in the false-alarm runs that do not
//!   sway; count and per hour of that driving), latency from the sway's onset (median and
//!   worst, in s and in sway periods), and the ROC curve of run-level verdicts over the
//!   detector's threshold (a run is flagged at threshold h when its largest score reaches
//!   h: exact, since every detector flags exactly when its score reaches its threshold).
//! - **Assist**: loss of control and sustained sway over all scenarios with and without it,
//!   peak articulation, speed lost, time to settle.
//! - **Observer** (the model-based observer runs in every run beside the other detectors
//!   and has their metrics): per vehicle one run of ordinary driving
//!   ([`DrivingSequence`]: the false-alarm set's slaloms and lane changes one after another
//!   at `ordinary_driving_speed`, for `ordinary_driving_s`, but those that alone sway the
//!   trailer or lose control at that speed: they are sway scenarios, not ordinary driving),
//!   its final V̂_crit against the
//!   vehicle's V_crit, the V_fold of the vehicle with the estimated trailer mass, yaw
//!   inertia and centre of gravity (the paper form, the same fold-of-cycles search as the
//!   vehicle's own V_fold, [`open_loop_references`]) against the true V_fold, and the time
//!   from the start of the driving after which V̂_crit stays within
//!   [`CONVERGED_WITHIN`] of V_crit. The observer is told the vehicle's paper form (a file
//!   with model variants: its equivalent paper parameters): the car, the trailer's axle
//!   and tyre ([`sway::assist::observer_options`]).
//!
//! The evaluation is a list of independent points ([`AssistPlan`]: each scenario's two
//! runs, each vehicle's ordinary driving), computed in parallel
//! ([`sway::parallel::map_indices`]) or as shards, results in point order whatever the
//! number of threads; a run whose solver fails is recorded with its error and the
//! evaluation goes on.

use serde::{Deserialize, Serialize};
use sway::assist::{
    AssistOptions, AssistSetup, DetectorsConfig, Disturbance, DrivingSequence, Intervention,
    ObserverTrack, RunOutcome, Scenario, SwayCriterion, run_any, run_driving,
};
use sway::parallel::{Split, map_indices};
use sway::ranging::{
    Reference, RelativeSpeed, SpeedLimits, SpeedReferences, SpeedSpec, open_loop_references,
};
use sway::sim::SolverSettings;
use sway::{SwayError, sim::VehicleForm};
use sway_detect::sensor::SensorsConfig;
use sway_model::vehicle::Vehicle;
use trailer_model::{AnyVehicleModel, Model};

/// `configs/sway_assist.toml` (every key has a default: the small evaluation of
/// `cargo xtask all`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SwayAssistConfig {
    /// vehicle files to evaluate (a fleet), relative to the config's directory; empty (and
    /// no `sampled_vehicles`): the task's vehicle (`--vehicle`). Read by the task layer; the
    /// study takes the models
    pub vehicle_files: Vec<String>,
    /// sampled vehicles evaluated after the files: plausible car–trailer combinations with
    /// random model variants ([`sway_model::generator::generate`], the vehicles of
    /// `study_generated`), the same on every machine for a seed
    pub sampled_vehicles: Option<SampledVehicles>,
    /// the sway set's speeds, relative to each vehicle
    pub sway_speeds: Vec<SpeedSpec>,
    /// the sway set's disturbances
    pub sway_disturbances: Vec<Disturbance>,
    /// the false-alarm set's speeds (where straight running is stable)
    pub false_alarm_speeds: Vec<SpeedSpec>,
    /// the false-alarm set's manoeuvres
    pub false_alarm_disturbances: Vec<Disturbance>,
    /// the speed of the observer's ordinary-driving run, relative to each vehicle
    pub ordinary_driving_speed: SpeedSpec,
    /// how long ordinary driving lasts \[s\]: the false-alarm set's slaloms and lane changes
    /// one after another, from `disturbance_start_s`
    pub ordinary_driving_s: f64,
    /// the straight driving between two of its manoeuvres \[s\]
    pub ordinary_driving_gap_s: f64,
    /// when every disturbance starts \[s\]
    pub disturbance_start_s: f64,
    /// each run's length \[s\]
    pub horizon_s: f64,
    /// the steering ratio i_s \[-\]
    pub steering_ratio: f64,
    /// the sensors (the seed of run k is seed + k)
    pub sensors: SensorsConfig,
    /// the detectors
    pub detectors: DetectorsConfig,
    /// the intervention
    pub assist: AssistOptions,
    /// the solver
    pub solver: SolverSettings,
}

/// The sampled vehicles of an evaluation: `generated-0` … `generated-<count − 1>` of the
/// generator's `seed`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampledVehicles {
    /// the generator's seed
    pub seed: u64,
    /// how many (1 … [`MAX_SAMPLED_VEHICLES`])
    pub count: usize,
}

/// The most sampled vehicles of one evaluation.
pub const MAX_SAMPLED_VEHICLES: usize = 10_000;

impl SampledVehicles {
    /// The vehicles (name, vehicle file).
    pub fn generate(&self) -> Vec<(String, trailer_model::VehicleSpec)> {
        sway_model::generator::generate(self.seed, self.count)
            .into_iter()
            .map(|g| (g.name, g.spec))
            .collect()
    }
}

impl Default for SwayAssistConfig {
    fn default() -> Self {
        let in_bistable = |f| SpeedSpec::Relative(RelativeSpeed::InBistable(f));
        let of_v_crit = |f| SpeedSpec::Relative(RelativeSpeed::OfVCrit(f));
        let impulse = |a| Disturbance::SteeringImpulse {
            amplitude_deg: a,
            duration_s: 0.4,
        };
        Self {
            vehicle_files: Vec::new(),
            sampled_vehicles: None,
            sway_speeds: vec![in_bistable(-0.5), in_bistable(0.5), of_v_crit(1.05)],
            sway_disturbances: vec![
                impulse(1.0),
                impulse(3.0),
                Disturbance::CrosswindGust {
                    force_n: 3000.0,
                    duration_s: 0.5,
                },
                Disturbance::SingleLaneChange {
                    lateral_acceleration_mps2: 3.0,
                    frequency_hz: 0.5,
                },
            ],
            false_alarm_speeds: vec![of_v_crit(0.7)],
            false_alarm_disturbances: vec![
                Disturbance::Slalom {
                    frequency_hz: 0.4,
                    lateral_acceleration_mps2: 2.0,
                    periods: 4.0,
                },
                Disturbance::Slalom {
                    frequency_hz: 1.2,
                    lateral_acceleration_mps2: 4.0,
                    periods: 6.0,
                },
                Disturbance::SingleLaneChange {
                    lateral_acceleration_mps2: 3.0,
                    frequency_hz: 0.5,
                },
                Disturbance::DoubleLaneChange {
                    lateral_acceleration_mps2: 2.0,
                    frequency_hz: 0.5,
                    hold_s: 1.0,
                },
                Disturbance::CorneringRamp {
                    lateral_acceleration_mps2: 3.0,
                    duration_s: 3.0,
                },
            ],
            ordinary_driving_speed: of_v_crit(0.7),
            ordinary_driving_s: 90.0,
            ordinary_driving_gap_s: 2.0,
            disturbance_start_s: 1.0,
            horizon_s: 30.0,
            steering_ratio: 16.0,
            sensors: SensorsConfig::default(),
            detectors: DetectorsConfig::default(),
            assist: AssistOptions::default(),
            solver: SolverSettings::default(),
        }
    }
}

impl SwayAssistConfig {
    /// Checks what does not need the vehicle; `Err((key, problem))`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let positive = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((
                    key.to_string(),
                    format!("expected a finite value > 0, got {v}"),
                ))
            }
        };
        positive("horizon_s", self.horizon_s)?;
        positive("steering_ratio", self.steering_ratio)?;
        if let Some(s) = &self.sampled_vehicles
            && !(1..=MAX_SAMPLED_VEHICLES).contains(&s.count)
        {
            return Err((
                "sampled_vehicles.count".into(),
                format!(
                    "expected 1 … {MAX_SAMPLED_VEHICLES} vehicles, got {}",
                    s.count
                ),
            ));
        }
        positive("ordinary_driving_s", self.ordinary_driving_s)?;
        if !(self.ordinary_driving_gap_s.is_finite() && self.ordinary_driving_gap_s >= 0.0) {
            return Err((
                "ordinary_driving_gap_s".into(),
                format!(
                    "expected a time >= 0 s, got {}",
                    self.ordinary_driving_gap_s
                ),
            ));
        }
        if !(self.disturbance_start_s.is_finite()
            && self.disturbance_start_s >= 0.0
            && self.disturbance_start_s < self.horizon_s)
        {
            return Err((
                "disturbance_start_s".into(),
                format!(
                    "expected a time in [0, horizon_s), got {}",
                    self.disturbance_start_s
                ),
            ));
        }
        for (key, list) in [
            ("sway_disturbances", &self.sway_disturbances),
            ("false_alarm_disturbances", &self.false_alarm_disturbances),
        ] {
            for (k, d) in list.iter().enumerate() {
                d.validate()
                    .map_err(|(sub, p)| (format!("{key}[{k}].{sub}"), p))?;
            }
        }
        self.assist
            .validate()
            .map_err(|(k, p)| (format!("assist.{k}"), p))?;
        self.solver
            .validate()
            .map_err(|(k, p)| (format!("solver.{k}"), p))?;
        if let Err(e) = self.sensors.validate() {
            return Err(("sensors".into(), e.to_string()));
        }
        if let Err(e) = self.detectors.build() {
            return Err(("detectors".into(), e.to_string()));
        }
        Ok(())
    }

    /// The run's setup.
    pub fn setup(&self) -> AssistSetup {
        AssistSetup {
            sensors: self.sensors.clone(),
            detectors: self.detectors,
            assist: self.assist,
            criterion: SwayCriterion::default(),
            steering_ratio: self.steering_ratio,
            solver: self.solver,
        }
    }
}

/// Which set a scenario belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScenarioSet {
    /// disturbances that may start sway
    Sway,
    /// driving that must not be taken for sway
    FalseAlarm,
}

/// One scenario's two runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioResult {
    /// the vehicle's name
    pub vehicle: String,
    /// its set
    pub set: ScenarioSet,
    /// the speed as the config gives it
    pub speed: SpeedSpec,
    /// the scenario
    pub scenario: Scenario,
    /// the detectors watching (Err: the run failed, with the reason)
    pub without: Result<RunOutcome, String>,
    /// with the assist
    pub with: Result<RunOutcome, String>,
}

/// One point of a ROC curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RocPoint {
    /// the threshold \[the detector's score unit\]
    pub threshold: f64,
    /// the fraction of the false-alarm runs without sway flagged \[-\]
    pub false_positive_rate: f64,
    /// the fraction of the sway runs flagged \[-\]
    pub true_positive_rate: f64,
}

/// One detector's metrics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DetectorMetrics {
    /// the detector (`<name>_gated`: behind the steering gate)
    pub name: String,
    /// flagged sway runs / sway runs (None: no run swayed)
    pub detection_rate: Option<f64>,
    /// flags in the false-alarm runs that do not sway
    pub false_alarms: usize,
    /// per hour of that driving \[1/h\]
    pub false_alarms_per_hour: Option<f64>,
    /// the median latency from the sway's onset \[s\]
    pub latency_median_s: Option<f64>,
    /// the worst latency \[s\]
    pub latency_worst_s: Option<f64>,
    /// the median latency in sway periods \[-\]
    pub latency_median_periods: Option<f64>,
    /// the worst latency in sway periods \[-\]
    pub latency_worst_periods: Option<f64>,
    /// the latencies of the detected sway runs \[s\], in run order
    #[serde(skip)]
    pub latencies_s: Vec<f64>,
    /// the ROC curve, thresholds falling
    #[serde(skip)]
    pub roc: Vec<RocPoint>,
}

/// The assist's metrics over all scenarios.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AssistMetrics {
    /// runs that lost control without the assist
    pub loss_of_control_without: usize,
    /// with it
    pub loss_of_control_with: usize,
    /// scenarios whose run without the assist swung before it lost control
    /// ([`sway::assist::RunTruth::swung`]): the losses of control a sway assist is for (the
    /// others are divergences with no sway to detect)
    pub loss_of_control_after_sway_without: usize,
    /// of those scenarios, the runs that still lost control with the assist
    pub loss_of_control_after_sway_with: usize,
    /// runs that ended in sustained sway without the assist
    pub sustained_sway_without: usize,
    /// with it
    pub sustained_sway_with: usize,
    /// scenarios run (each with and without the assist)
    pub runs: usize,
    /// runs that failed numerically (either run of a scenario)
    pub failed: usize,
    /// scenarios without sway in which the assist engaged
    pub engaged_without_sway: usize,
    /// the largest articulation angle without the assist \[deg\]
    pub peak_hitch_angle_deg_without: Option<f64>,
    /// with it \[deg\]
    pub peak_hitch_angle_deg_with: Option<f64>,
    /// the largest speed the assist took off \[m/s\]
    pub speed_lost_mps_max: Option<f64>,
    /// the median time to settle (|θ| < 1° to the end) of the sway scenarios with the
    /// assist, from the disturbance's end \[s\]
    pub settle_time_s_median: Option<f64>,
}

/// A vehicle's reference speeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VehicleReferences {
    /// its name
    pub vehicle: String,
    /// V_crit and V_fold
    pub references: SpeedReferences,
    /// the config's speeds it lacks, with the reason
    pub unresolved: Vec<(String, String)>,
}

/// The relative error of V̂_crit within which the observer has converged \[-\] (issue 48's
/// goal: 5 %).
pub const CONVERGED_WITHIN: f64 = 0.05;

/// The observer on one vehicle: its ordinary-driving run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObserverResult {
    /// the vehicle's name
    pub vehicle: String,
    /// the run's speed \[m/s\]
    pub speed_mps: Option<f64>,
    /// the manoeuvres driven
    pub manoeuvres: usize,
    /// the false-alarm manoeuvres left out of ordinary driving because, each alone at its
    /// speed, they sway the trailer or end in a loss of control (kind and sizes, e.g.
    /// `slalom 0.4 Hz 4 m/s²`)
    pub left_out: Vec<String>,
    /// the vehicle's V_crit \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// its V_fold \[m/s\]
    pub v_fold_mps: Option<f64>,
    /// the final V̂_crit \[m/s\]
    pub v_crit_estimate_mps: Option<f64>,
    /// its standard deviation \[m/s\]
    pub v_crit_sd_mps: Option<f64>,
    /// V_fold of the vehicle's paper form with the estimated trailer \[m/s\]
    pub v_fold_estimate_mps: Option<f64>,
    /// |V̂_crit − V_crit| / V_crit \[-\]
    pub v_crit_error_rel: Option<f64>,
    /// |V̂_fold − V_fold| / V_fold \[-\]
    pub v_fold_error_rel: Option<f64>,
    /// the time from the start of ordinary driving after which V̂_crit stays within
    /// [`CONVERGED_WITHIN`] of V_crit \[s\]
    pub converged_after_s: Option<f64>,
    /// the estimated trailer mass \[kg\], yaw inertia \[kg m²\], centre of gravity \[m\]
    pub trailer_estimate: Option<[f64; 3]>,
    /// why a value is missing
    pub reason: Option<String>,
    /// the estimates over time
    pub track: Option<ObserverTrack>,
}

/// What the evaluation gives.
#[derive(Debug, Clone, PartialEq)]
pub struct SwayAssist {
    /// per vehicle
    pub vehicles: Vec<VehicleReferences>,
    /// every scenario, vehicles outer, the sway set before the false-alarm set, speeds,
    /// disturbances inner
    pub scenarios: Vec<ScenarioResult>,
    /// per detector
    pub detectors: Vec<DetectorMetrics>,
    /// the assist
    pub assist: AssistMetrics,
    /// the hours of false-alarm driving without sway \[h\]
    pub false_alarm_hours: f64,
    /// one sway run with its frames (the first scenario of the sway set that sways
    /// without the assist)
    pub sway_trace: Option<RunOutcome>,
    /// one slalom run with its frames
    pub slalom_trace: Option<RunOutcome>,
    /// the observer per vehicle (empty: no observer in the config)
    pub observer: Vec<ObserverResult>,
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// One scenario of the evaluation before it runs.
#[derive(Debug, Clone)]
struct Item {
    /// index into the plan's vehicles
    vehicle: usize,
    set: ScenarioSet,
    speed: SpeedSpec,
    scenario: Scenario,
}

/// One point of the evaluation: a scenario's two runs, or one vehicle's ordinary-driving
/// run of the observer. Round-trips exactly through JSON (the shards of a sharded
/// evaluation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AssistPoint {
    /// a scenario of the sway or the false-alarm set
    Scenario(Box<ScenarioResult>),
    /// a vehicle's ordinary driving
    Observer(Box<ObserverResult>),
}

/// The evaluation of a config on its vehicles, planned: every vehicle's reference speeds
/// and the list of independent points ([`AssistPlan::run_point`]): the scenarios (vehicles
/// outer, the sway set before the false-alarm set, speeds, disturbances inner), then one
/// ordinary-driving run per vehicle when the config has the observer. Point k is a pure
/// function of the plan and k, so the points can run on any number of threads or as
/// shards on several machines, and [`AssistPlan::assemble`] gives the same evaluation.
#[derive(Debug, Clone)]
pub struct AssistPlan {
    config: SwayAssistConfig,
    setup: AssistSetup,
    limits: SpeedLimits,
    vehicles: Vec<(String, AnyVehicleModel)>,
    references: Vec<VehicleReferences>,
    items: Vec<Item>,
}

impl AssistPlan {
    /// Resolves every vehicle's speeds (its V_crit and V_fold) and lists the points.
    ///
    /// # Errors
    /// A numerical failure of a vehicle's reference speeds.
    pub fn new(
        cfg: &SwayAssistConfig,
        vehicles: Vec<(String, AnyVehicleModel)>,
        limits: &SpeedLimits,
    ) -> Result<Self, SwayError> {
        let need = cfg
            .sway_speeds
            .iter()
            .chain(&cfg.false_alarm_speeds)
            .map(SpeedSpec::needs)
            .chain(cfg.detectors.model_observer.map(|_| Reference::Fold))
            .max()
            .unwrap_or(Reference::None);
        let mut references = Vec::new();
        let mut items = Vec::new();
        for (index, (name, vehicle)) in vehicles.iter().enumerate() {
            let refs = match VehicleForm::from(vehicle) {
                VehicleForm::Paper(m) => open_loop_references(m, limits, need)?,
                VehicleForm::Variants(v) => {
                    trailer_model::with_plant!(v, m => open_loop_references(m, limits, need))?
                }
            };
            let mut unresolved = Vec::new();
            for (set, speeds, disturbances) in [
                (ScenarioSet::Sway, &cfg.sway_speeds, &cfg.sway_disturbances),
                (
                    ScenarioSet::FalseAlarm,
                    &cfg.false_alarm_speeds,
                    &cfg.false_alarm_disturbances,
                ),
            ] {
                for spec in speeds {
                    let v = match spec.resolve(&refs) {
                        Ok(v) => v,
                        Err(e) => {
                            unresolved.push((spec.to_string(), e.reason));
                            continue;
                        }
                    };
                    for d in disturbances {
                        let seed = items.len() as u64;
                        items.push(Item {
                            vehicle: index,
                            set,
                            speed: *spec,
                            scenario: Scenario {
                                speed_mps: v,
                                disturbance: *d,
                                disturbance_start_s: cfg.disturbance_start_s,
                                horizon_s: cfg.horizon_s,
                                seed,
                            },
                        });
                    }
                }
            }
            references.push(VehicleReferences {
                vehicle: name.clone(),
                references: refs,
                unresolved,
            });
        }
        Ok(Self {
            config: cfg.clone(),
            setup: cfg.setup(),
            limits: *limits,
            vehicles,
            references,
            items,
        })
    }

    /// The number of points: scenarios, then the observer's runs.
    pub fn len(&self) -> usize {
        self.items.len() + self.observer_runs()
    }

    /// Whether there is no point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The number of scenarios (each run without and with the assist).
    pub fn scenarios(&self) -> usize {
        self.items.len()
    }

    fn observer_runs(&self) -> usize {
        if self.config.detectors.model_observer.is_some() {
            self.vehicles.len()
        } else {
            0
        }
    }

    /// Point `k` (`k` < [`Self::len`]): scenario k's runs without and with the assist (a
    /// failed run is recorded with its error), or the ordinary-driving run of vehicle
    /// k − [`Self::scenarios`].
    ///
    /// # Panics
    /// If `k` ≥ [`Self::len`].
    pub fn run_point(&self, k: usize) -> AssistPoint {
        if let Some(it) = self.items.get(k) {
            let (name, vehicle) = &self.vehicles[it.vehicle];
            let go = |i| {
                run_any(vehicle, &it.scenario, i, &self.setup, false).map_err(|e| e.to_string())
            };
            return AssistPoint::Scenario(Box::new(ScenarioResult {
                vehicle: name.clone(),
                set: it.set,
                speed: it.speed,
                scenario: it.scenario,
                without: go(Intervention::None),
                with: go(Intervention::Assist),
            }));
        }
        let j = k - self.items.len();
        assert!(j < self.observer_runs(), "point {k} of {}", self.len());
        let (name, vehicle) = &self.vehicles[j];
        AssistPoint::Observer(Box::new(observe(
            &self.config,
            &self.setup,
            name,
            vehicle,
            &self.references[j].references,
            &self.limits,
            j as u64,
        )))
    }

    /// The evaluation from the points' results in point order: the metrics, and the two
    /// runs of the figures with their frames (run again).
    pub fn assemble(&self, points: Vec<AssistPoint>) -> SwayAssist {
        let mut scenarios = Vec::new();
        let mut observer = Vec::new();
        for p in points {
            match p {
                AssistPoint::Scenario(s) => scenarios.push(*s),
                AssistPoint::Observer(o) => observer.push(*o),
            }
        }
        let detectors = detector_metrics(&scenarios);
        let assist = assist_metrics(&scenarios);
        let false_alarm_hours = false_alarm_runs(&scenarios)
            .map(|r| r.t_end_s - r.scenario.disturbance_start_s.min(r.t_end_s))
            .sum::<f64>()
            / 3600.0;
        // scenario k is item k's (the points in order)
        let trace_of = |pick: &dyn Fn(&ScenarioResult) -> bool| {
            let (_, it) = scenarios.iter().zip(&self.items).find(|(s, _)| pick(s))?;
            let vehicle = &self.vehicles[it.vehicle].1;
            run_any(vehicle, &it.scenario, Intervention::None, &self.setup, true).ok()
        };
        let sway_trace =
            trace_of(&|s| s.set == ScenarioSet::Sway && s.without.as_ref().is_ok_and(|r| r.sways));
        let slalom_trace =
            trace_of(&|s| matches!(s.scenario.disturbance, Disturbance::Slalom { .. }));
        SwayAssist {
            vehicles: self.references.clone(),
            scenarios,
            detectors,
            assist,
            false_alarm_hours,
            sway_trace,
            slalom_trace,
            observer,
        }
    }
}

/// Runs the evaluation of `cfg` on `vehicles` (name, model): [`AssistPlan`]'s points in
/// parallel, assembled.
///
/// # Errors
/// A numerical failure of a vehicle's reference speeds (a failed run is recorded, not an
/// error).
pub fn compute(
    cfg: &SwayAssistConfig,
    vehicles: &[(String, AnyVehicleModel)],
    limits: &SpeedLimits,
) -> Result<SwayAssist, SwayError> {
    let plan = AssistPlan::new(cfg, vehicles.to_vec(), limits)?;
    let points = map_indices(plan.len(), Split::OnePerTask, &|k| plan.run_point(k));
    Ok(plan.assemble(points))
}

/// The observer's ordinary-driving run on one vehicle (the `k`-th: its sensors' seed is
/// offset past every scenario's by 2^32 + k) and its numbers.
fn observe(
    cfg: &SwayAssistConfig,
    setup: &AssistSetup,
    name: &str,
    vehicle: &AnyVehicleModel,
    refs: &SpeedReferences,
    limits: &SpeedLimits,
    k: u64,
) -> ObserverResult {
    let mut out = ObserverResult {
        vehicle: name.to_string(),
        speed_mps: None,
        manoeuvres: 0,
        left_out: Vec::new(),
        v_crit_mps: refs.v_crit_mps,
        v_fold_mps: refs.v_fold_mps,
        v_crit_estimate_mps: None,
        v_crit_sd_mps: None,
        v_fold_estimate_mps: None,
        v_crit_error_rel: None,
        v_fold_error_rel: None,
        converged_after_s: None,
        trailer_estimate: None,
        reason: None,
        track: None,
    };
    let speed = match cfg.ordinary_driving_speed.resolve(refs) {
        Ok(v) => v,
        Err(e) => {
            out.reason = Some(format!("no ordinary-driving speed: {}", e.reason));
            return out;
        }
    };
    out.speed_mps = Some(speed);
    // a file with model variants: its equivalent paper form
    let paper: &Model = trailer_model::with_plant!(vehicle, m => Vehicle::paper_model(m));
    let t0 = cfg.disturbance_start_s;
    let until = t0 + cfg.ordinary_driving_s;
    let scenario = Scenario {
        speed_mps: speed,
        disturbance: Disturbance::None,
        disturbance_start_s: t0,
        horizon_s: until,
        seed: (1u64 << 32) + k,
    };
    let (ordinary, left_out) = ordinary_manoeuvres(cfg, setup, vehicle, speed, scenario.seed);
    out.left_out = left_out;
    let run = DrivingSequence::new(
        &ordinary,
        paper,
        speed,
        t0,
        cfg.ordinary_driving_gap_s,
        until,
    )
    .and_then(|d| {
        out.manoeuvres = d.manoeuvres();
        trailer_model::with_plant!(vehicle, m => run_driving(m, &scenario, &d, setup, false))
    });
    let run = match run {
        Ok(r) => r,
        Err(e) => {
            out.reason = Some(format!("the ordinary-driving run failed: {e}"));
            return out;
        }
    };
    let mut reasons = Vec::new();
    if !out.left_out.is_empty() {
        reasons.push(format!(
            "left out of ordinary driving (each alone sways the trailer or loses control at {speed:.2} m/s): {}",
            out.left_out.join(", ")
        ));
    }
    // (the ground truth's sustained sway means nothing here: the driving itself keeps the
    // trailer swinging; a loss of control ends the run early)
    if let Some(t) = run.loss_of_control_s {
        let how = run.loss_of_control_condition.map_or("", |c| c.as_str());
        reasons.push(format!(
            "the vehicle lost control in ordinary driving at {t:.1} s ({how})"
        ));
    }
    let Some(track) = run.observer else {
        out.reason = Some("the observer did not run".into());
        return out;
    };
    let Some(last) = track.last else {
        out.reason = Some("the observer used no frame".into());
        return out;
    };
    out.v_crit_estimate_mps = last.v_crit_estimate_mps;
    out.v_crit_sd_mps = last.v_crit_sd_mps;
    out.trailer_estimate = Some([
        last.trailer_mass.value,
        last.trailer_yaw_inertia.value,
        last.trailer_cog.value,
    ]);
    if let Some(r) = last.v_crit_reason {
        reasons.push(format!("the observer gives no V_crit: {r}"));
    }
    let rel = |est: Option<f64>, truth: Option<f64>| Some((est? - truth?).abs() / truth?);
    out.v_crit_error_rel = rel(out.v_crit_estimate_mps, refs.v_crit_mps);
    if let Some(v_crit) = refs.v_crit_mps {
        // the last sample outside the band; converged from the next one on
        let outside =
            |v: &Option<f64>| !v.is_some_and(|v| (v - v_crit).abs() <= CONVERGED_WITHIN * v_crit);
        match track.v_crit_mps.iter().rposition(outside) {
            None => out.converged_after_s = track.t.first().map(|t| (t - t0).max(0.0)),
            Some(i) if i + 1 < track.t.len() => {
                out.converged_after_s = Some((track.t[i + 1] - t0).max(0.0));
            }
            Some(_) => reasons.push(format!(
                "V̂_crit is not within {:.0} % of V_crit at the end of ordinary driving",
                100.0 * CONVERGED_WITHIN
            )),
        }
    }
    // V_fold of the paper form with the estimated trailer
    let mut p = *paper.params();
    p.trailer.mass = last.trailer_mass.value;
    p.trailer.yaw_inertia = last.trailer_yaw_inertia.value;
    p.trailer.cog = last.trailer_cog.value;
    match Model::new(p) {
        Ok(m) => match open_loop_references(&m, limits, Reference::Fold) {
            Ok(r) => {
                out.v_fold_estimate_mps = r.v_fold_mps;
                if let Some(why) = r.reason.filter(|_| r.v_fold_mps.is_none()) {
                    reasons.push(format!("no V_fold of the estimated trailer: {why}"));
                }
            }
            Err(e) => reasons.push(format!("no V_fold of the estimated trailer: {e}")),
        },
        Err(e) => reasons.push(format!("the estimated trailer is not a valid vehicle: {e}")),
    }
    if refs.v_fold_mps.is_none() {
        reasons.push("the vehicle has no V_fold".into());
    }
    out.v_fold_error_rel = rel(out.v_fold_estimate_mps, refs.v_fold_mps);
    out.track = Some(track);
    if !reasons.is_empty() {
        out.reason = Some(reasons.join("; "));
    }
    out
}

/// Ordinary driving's manoeuvres on one vehicle at `speed` \[m/s\]: the false-alarm set's
/// driving ([`Disturbance::is_driving`]) that, each driven alone at that speed (a watching
/// run, sensors seeded with `seed`), neither sways ([`RunOutcome::sways`]) nor ends in a
/// loss of control. A manoeuvre
/// that sways the trailer is a sway scenario, not ordinary driving: driven back to back, it
/// would end the observer's run in a loss of control. Also the left-out manoeuvres'
/// descriptions (a failed run leaves its manoeuvre out, with the error).
fn ordinary_manoeuvres(
    cfg: &SwayAssistConfig,
    setup: &AssistSetup,
    vehicle: &AnyVehicleModel,
    speed: f64,
    seed: u64,
) -> (Vec<Disturbance>, Vec<String>) {
    let mut kept = Vec::new();
    let mut left_out = Vec::new();
    for d in cfg
        .false_alarm_disturbances
        .iter()
        .filter(|d| d.is_driving())
    {
        let alone = Scenario {
            speed_mps: speed,
            disturbance: *d,
            disturbance_start_s: cfg.disturbance_start_s,
            horizon_s: cfg.horizon_s,
            seed,
        };
        let label = d.to_string();
        match run_any(vehicle, &alone, Intervention::None, setup, false) {
            Ok(r) if !r.sways && r.loss_of_control_s.is_none() => kept.push(*d),
            Ok(_) => left_out.push(label),
            Err(e) => left_out.push(format!("{label} (its run failed: {e})")),
        }
    }
    (kept, left_out)
}

/// The watching runs of the false-alarm set that do not sway.
fn false_alarm_runs(scenarios: &[ScenarioResult]) -> impl Iterator<Item = &RunOutcome> {
    scenarios
        .iter()
        .filter(|s| s.set == ScenarioSet::FalseAlarm)
        .filter_map(|s| s.without.as_ref().ok())
        .filter(|r| !r.sways)
}

fn detector_metrics(scenarios: &[ScenarioResult]) -> Vec<DetectorMetrics> {
    let sway_runs: Vec<&RunOutcome> = scenarios
        .iter()
        .filter_map(|s| s.without.as_ref().ok())
        .filter(|r| r.sways)
        .collect();
    let quiet: Vec<&RunOutcome> = false_alarm_runs(scenarios).collect();
    let hours = quiet
        .iter()
        .map(|r| r.t_end_s - r.scenario.disturbance_start_s.min(r.t_end_s))
        .sum::<f64>()
        / 3600.0;
    let names: Vec<String> = scenarios
        .iter()
        .find_map(|s| s.without.as_ref().ok())
        .map(|r| r.detectors.iter().map(|d| d.name.clone()).collect())
        .unwrap_or_default();
    names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let mut latencies = Vec::new();
            let mut periods = Vec::new();
            let mut detected = 0;
            for r in &sway_runs {
                let d = &r.detectors[k];
                if let Some(f) = d.first_flag_s {
                    detected += 1;
                    let onset = r.truth.onset_s.unwrap_or(r.scenario.disturbance_start_s);
                    let l = f - onset;
                    latencies.push(l);
                    if let Some(p) = r.truth.period_s {
                        periods.push(l / p);
                    }
                }
            }
            let false_alarms = quiet.iter().map(|r| r.detectors[k].flags).sum();
            let worst = |v: &[f64]| v.iter().copied().reduce(f64::max);
            let latencies_s = latencies.clone();
            DetectorMetrics {
                name: name.clone(),
                detection_rate: (!sway_runs.is_empty())
                    .then(|| detected as f64 / sway_runs.len() as f64),
                false_alarms,
                false_alarms_per_hour: (hours > 0.0).then(|| false_alarms as f64 / hours),
                latency_worst_s: worst(&latencies),
                latency_median_s: median(&mut latencies),
                latency_worst_periods: worst(&periods),
                latency_median_periods: median(&mut periods),
                latencies_s,
                roc: roc(
                    &sway_runs
                        .iter()
                        .map(|r| r.detectors[k].max_score)
                        .collect::<Vec<_>>(),
                    &quiet
                        .iter()
                        .map(|r| r.detectors[k].max_score)
                        .collect::<Vec<_>>(),
                ),
            }
        })
        .collect()
}

/// The ROC curve from the runs' largest scores (None: never scored, never flagged): one
/// point per distinct score, thresholds falling, from (0, 0) to (1, 1).
pub fn roc(positives: &[Option<f64>], negatives: &[Option<f64>]) -> Vec<RocPoint> {
    let mut thresholds: Vec<f64> = positives
        .iter()
        .chain(negatives)
        .flatten()
        .copied()
        .collect();
    thresholds.sort_by(|a, b| b.total_cmp(a));
    thresholds.dedup();
    let rate = |runs: &[Option<f64>], h: f64| {
        if runs.is_empty() {
            0.0
        } else {
            runs.iter().filter(|s| s.is_some_and(|s| s >= h)).count() as f64 / runs.len() as f64
        }
    };
    let mut curve = vec![RocPoint {
        threshold: f64::INFINITY,
        false_positive_rate: 0.0,
        true_positive_rate: 0.0,
    }];
    curve.extend(thresholds.into_iter().map(|h| RocPoint {
        threshold: h,
        false_positive_rate: rate(negatives, h),
        true_positive_rate: rate(positives, h),
    }));
    curve.push(RocPoint {
        threshold: f64::NEG_INFINITY,
        false_positive_rate: 1.0,
        true_positive_rate: 1.0,
    });
    curve
}

/// Whether the scenario's run without the assist swung before it lost control (None: the
/// run failed).
fn lost_after_sway(s: &ScenarioResult) -> Option<bool> {
    let r = s.without.as_ref().ok()?;
    Some(r.loss_of_control_s.is_some() && r.truth.swung)
}

fn assist_metrics(scenarios: &[ScenarioResult]) -> AssistMetrics {
    let count = |f: &dyn Fn(&ScenarioResult) -> Option<bool>| {
        scenarios.iter().filter(|s| f(s) == Some(true)).count()
    };
    let max = |f: &dyn Fn(&RunOutcome) -> f64, with: bool| {
        scenarios
            .iter()
            .filter_map(|s| if with { &s.with } else { &s.without }.as_ref().ok())
            .map(f)
            .reduce(f64::max)
    };
    let mut settle: Vec<f64> = scenarios
        .iter()
        .filter(|s| s.without.as_ref().is_ok_and(|r| r.sways))
        .filter_map(|s| s.with.as_ref().ok()?.truth.settle_time_s)
        .collect();
    AssistMetrics {
        loss_of_control_without: count(&|s| {
            s.without
                .as_ref()
                .ok()
                .map(|r| r.loss_of_control_s.is_some())
        }),
        loss_of_control_with: count(&|s| {
            s.with.as_ref().ok().map(|r| r.loss_of_control_s.is_some())
        }),
        loss_of_control_after_sway_without: count(&lost_after_sway),
        loss_of_control_after_sway_with: count(&|s| {
            Some(lost_after_sway(s)? && s.with.as_ref().ok()?.loss_of_control_s.is_some())
        }),
        sustained_sway_without: count(&|s| s.without.as_ref().ok().map(|r| r.truth.sustained_sway)),
        sustained_sway_with: count(&|s| s.with.as_ref().ok().map(|r| r.truth.sustained_sway)),
        runs: scenarios.len(),
        failed: scenarios
            .iter()
            .filter(|s| s.without.is_err() || s.with.is_err())
            .count(),
        engaged_without_sway: count(&|s| {
            let sways = s.without.as_ref().ok()?.sways;
            Some(!sways && s.with.as_ref().ok()?.engaged_s.is_some())
        }),
        peak_hitch_angle_deg_without: max(&|r| r.truth.peak_hitch_angle_deg, false),
        peak_hitch_angle_deg_with: max(&|r| r.truth.peak_hitch_angle_deg, true),
        speed_lost_mps_max: max(&|r| r.speed_lost_mps, true),
        settle_time_s_median: median(&mut settle),
    }
}
