//! `cargo xtask control_design` (beyond the paper): which controller structure
//! and which actuator keep straight running stable for which loop delay τ
//! ([`sway::control`]): for `yaw_rate`, `yaw_rate_hitch` and `predictor` with front-wheel
//! steering and with differential braking, the gains maximising the linear critical speed
//! on a grid of delays, the delay budget of each, and at chosen delays the critical speed
//! the optimum guarantees under vehicle uncertainty (5 % quantile); for every optimum of
//! `yaw_rate` and `yaw_rate_hitch` (either actuator) its fold-of-cycles speed and, at a
//! double-Hopf optimum, the gains a little away from it with the largest fold speed.
//!
//! `summary.json`: `"designs"`, an array of `{"structure", "actuator", "tau_s", "gains",
//! "v_crit_mps", "v_fold_mps", "v_crit_p05_mps", "at_double_hopf",
//! "v_fold_away_from_corner", …}` (`v_crit_mps` checked for windows of instability between
//! the scan's samples, [`sway::control::verified_critical_speed`], with the scan's value as
//! `v_crit_scan_mps` where they differ; the fold of every design, null with `v_fold_reason` for
//! the predictor and where there is none; the robust speed at the checked delays, null with
//! a `…_reason` elsewhere; `v_fold_away_from_corner` = `{"gains", "v_fold_mps",
//! "v_crit_mps", "tried"}` at a double-Hopf optimum, else null), and
//! `"delay_budget_s"`: `{"<structure>_<actuator>": seconds}`. `designs.csv` holds the
//! same rows; `control_design.svg/.png` the figure.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use sway::bifurcation::chart::ChartOptions;
use sway::config::{Grid, ensure, ensure_positive};
use sway::control::{
    Actuator, CommandLimits, Design, DesignSearch, GainName, Gains, SpeedSearch, Structure,
    VehicleUncertainty,
};
use sway_studies::control_design::{
    AwayFromCorner, CheckedDesign, Combination, ControlStudy, Curve, ROBUSTNESS_CAP, SEARCH_CAP,
    SimulationCheck, SimulationOutcome, StudySettings, StudyVehicle, control_study,
    open_loop_critical_speed, simulation_check,
};
use sway::ranging::CappedSpeed;
use sway::sampling::{About, Distribution, Field, Method, Sampling};
use sway::sim::PredictionVehicle;

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig, check_delays};
use crate::io::OutputDir;
use crate::limits::{Plan, human_seconds};
use crate::figures::{capped_speed_layers, stable_up_to_key};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<ControlDesignConfig>(
    "control_design",
    "sway control for longer delays: best gains of each controller structure × actuator per τ, delay budgets, robust V_crit",
    "control_design.toml",
)
.any_model();

fn default_delays() -> Grid {
    Grid {
        min: 0.0,
        max: 2.0,
        points: 11,
    }
}

fn default_checked() -> Vec<f64> {
    vec![0.4, 0.6, 0.8]
}

fn uniform(key: &str, about: About, min: f64, max: f64) -> Field {
    Field {
        key: key.into(),
        about,
        distribution: Distribution::Uniform,
        min,
        max,
        mean: None,
        sd: None,
    }
}

/// `study_uncertainty`'s vehicle uncertainty (h and l to ±0.05 m about the vehicle's
/// values) and the predictor's model off by ±10 % in trailer mass, yaw inertia and centre
/// of gravity.
#[doc(hidden)] // pub for tests/unit
pub fn default_uncertainty() -> VehicleUncertainty {
    VehicleUncertainty {
        vehicle: Sampling {
            method: Method::LatinHypercube,
            samples: 100,
            seed: 2026,
            fields: vec![
                uniform("trailer.cog", About::Offset, -0.05, 0.05),
                uniform("trailer.axle", About::Offset, -0.05, 0.05),
            ],
        },
        prediction_model: Some(Sampling {
            method: Method::LatinHypercube,
            samples: 100,
            seed: 2027,
            fields: vec![
                uniform("trailer.mass", About::Factor, 0.9, 1.1),
                uniform("trailer.yaw_inertia", About::Factor, 0.9, 1.1),
                uniform("trailer.cog", About::Factor, 0.9, 1.1),
            ],
        }),
    }
}

/// The delay budget's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BudgetConfig {
    /// the required rise of the critical speed over the open loop (0.1: 10 %)
    pub rise_fraction: f64,
    /// bisection tolerance in τ \[s\]
    pub tau_tolerance_s: f64,
}

impl Default for BudgetConfig {
    fn default() -> Self {
        Self {
            rise_fraction: 0.1,
            tau_tolerance_s: 1e-3,
        }
    }
}

fn default_robustness_speed() -> SpeedSearch {
    SpeedSearch {
        samples: 50,
        tolerance_mps: 1e-4,
        ..SpeedSearch::default()
    }
}

/// The robustness checks' settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobustnessConfig {
    /// the delays whose optima are checked \[s\] (snapped to the nearest grid delay)
    #[serde(default = "default_checked")]
    pub delays_s: Vec<f64>,
    /// the critical-speed search of each uncertainty sample
    #[serde(default = "default_robustness_speed")]
    pub speed: SpeedSearch,
    /// the sampled uncertainty
    #[serde(default = "default_uncertainty")]
    pub uncertainty: VehicleUncertainty,
}

impl Default for RobustnessConfig {
    fn default() -> Self {
        Self {
            delays_s: default_checked(),
            speed: default_robustness_speed(),
            uncertainty: default_uncertainty(),
        }
    }
}

fn default_structures() -> Vec<Structure> {
    Structure::ALL.to_vec()
}

fn default_actuators() -> Vec<Actuator> {
    Actuator::ALL.to_vec()
}

/// The fold-of-cycles computation of the paper's structure: `chart_nonlinear`'s options with
/// a coarser cycle mesh (L = 20, as `gain_design`'s fold part) and longer fold steps.
fn default_away_samples() -> usize {
    2
}

fn default_fold_chart() -> ChartOptions {
    ChartOptions {
        seed_gains_s: vec![0.1],
        fold_max_step: 4.0,
        cycles: sway::bifurcation::DiagramOptions {
            intervals: 20,
            max_step: 0.5,
            ..sway::bifurcation::DiagramOptions::default()
        },
        ..ChartOptions::default()
    }
}

/// `configs/control_design.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlDesignConfig {
    /// the delays τ \[s\]
    #[serde(default = "default_delays")]
    pub delays_s: Grid,
    /// the controller structures
    #[serde(default = "default_structures")]
    pub structures: Vec<Structure>,
    /// the actuators
    #[serde(default = "default_actuators")]
    pub actuators: Vec<Actuator>,
    /// the track width w \[m\] of the tow vehicle (the braking limit M_max = μ0·(F_zF +
    /// F_zR)·w/4 reported beside the designs)
    #[serde(default = "default_track_width")]
    pub track_width_m: f64,
    /// the search of the best gains at one delay
    #[serde(default)]
    pub search: DesignSearch,
    /// the delay budget
    #[serde(default)]
    pub budget: BudgetConfig,
    /// the robustness checks
    #[serde(default)]
    pub robustness: RobustnessConfig,
    /// the fold-of-cycles computation of every design (the output-feedback structures)
    #[serde(default = "default_fold_chart")]
    pub fold: ChartOptions,
    /// gains of D tried on each side of a double-Hopf optimum, evenly over its near-optimal
    /// band, for the fold speed away from the corner (`v_fold_away_from_corner`; 0: skipped)
    #[serde(default = "default_away_samples")]
    pub away_from_corner_samples: usize,
    /// the simulation check of one design per structure
    #[serde(default)]
    pub simulation_check: SimulationCheck,
    /// the predictor's model of the vehicle: a vehicle file (relative to this file's
    /// directory) the prediction runs on, so that a design is judged with a model that
    /// differs from the vehicle (absent: the vehicle itself, a perfect prediction model)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prediction_vehicle: Option<std::path::PathBuf>,
}

impl ControlDesignConfig {
    /// The prediction vehicle, loaded and checked.
    ///
    /// # Errors
    /// [`TaskError::Config`] naming this file, `prediction_vehicle` and the problem (the
    /// vehicle file's own error in it).
    #[doc(hidden)] // pub for tests/unit
    pub fn prediction(&self, file: &Path) -> Result<Option<crate::config_file::LoadedVehicle>, TaskError> {
        self.prediction_vehicle
            .as_ref()
            .map(|p| crate::config_file::load_named_vehicle(file, "prediction_vehicle", p))
            .transpose()
    }
}

fn default_track_width() -> f64 {
    1.6
}

impl TaskConfig for ControlDesignConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        ensure(self.delays_s.min >= 0.0, file, "delays_s.min", || {
            format!("expected a delay ≥ 0 s, got {}", self.delays_s.min)
        })?;
        ensure(!self.structures.is_empty(), file, "structures", || {
            "expected at least one structure".into()
        })?;
        ensure(!self.actuators.is_empty(), file, "actuators", || {
            "expected at least one actuator".into()
        })?;
        ensure_positive(self.track_width_m, file, "track_width_m", "a width > 0 m")?;
        let sc = &self.simulation_check;
        ensure(
            self.delays_s.values().iter().any(|t| (t - sc.delay_s).abs() < 1e-9),
            file,
            "simulation_check.delay_s",
            || format!("expected one of the delays of delays_s, got {}", sc.delay_s),
        )?;
        ensure(
            sc.speed_fraction > 0.0 && sc.speed_fraction.is_finite(),
            file,
            "simulation_check.speed_fraction",
            || format!("expected a fraction > 0, got {}", sc.speed_fraction),
        )?;
        ensure(
            !sc.kicks_deg.is_empty() && sc.kicks_deg.iter().all(|k| k.is_finite() && *k > 0.0),
            file,
            "simulation_check.kicks_deg",
            || format!("expected kicks > 0 deg, got {:?}", sc.kicks_deg),
        )?;
        ensure_positive(
            sc.horizon_s,
            file,
            "simulation_check.horizon_s",
            "a time > 0 s",
        )?;
        check_speed_search(&self.search.speed, file, "search.speed")?;
        check_speed_search(&self.robustness.speed, file, "robustness.speed")?;
        self.prediction(file)?;
        let s = &self.search;
        ensure(s.gain_samples >= 3, file, "search.gain_samples", || {
            format!("expected at least 3 gains, got {}", s.gain_samples)
        })?;
        ensure_positive(s.gain_tolerance, file, "search.gain_tolerance", "a tolerance > 0")?;
        ensure_positive(
            s.search_tolerance_mps,
            file,
            "search.search_tolerance_mps",
            "a tolerance > 0 m/s",
        )?;
        ensure(
            s.band_fraction > 0.0 && s.band_fraction < 1.0,
            file,
            "search.band_fraction",
            || format!("expected a fraction in (0, 1), got {}", s.band_fraction),
        )?;
        for (name, b) in [
            ("yaw_rate", s.bounds.yaw_rate),
            ("hitch_angle", s.bounds.hitch_angle),
            ("hitch_rate", s.bounds.hitch_rate),
        ] {
            ensure(b.is_valid(), file, &format!("search.bounds.{name}"), || {
                format!("expected finite lo ≤ hi, got [{}, {}]", b.lo, b.hi)
            })?;
        }
        if let Some(l) = &s.limits {
            ensure_positive(
                l.yaw_rate_amplitude_rad_s,
                file,
                "search.limits.yaw_rate_amplitude_rad_s",
                "a yaw rate > 0 rad/s",
            )?;
            ensure_positive(l.steering_rad, file, "search.limits.steering_rad", "an angle > 0 rad")?;
        }
        s.optimiser
            .validate()
            .map_err(|(key, problem)| TaskError::config(file, format!("search.optimiser.{key}"), problem))?;
        ensure_positive(self.budget.rise_fraction, file, "budget.rise_fraction", "a fraction > 0")?;
        ensure_positive(
            self.budget.tau_tolerance_s,
            file,
            "budget.tau_tolerance_s",
            "a tolerance > 0 s",
        )?;
        check_delays(file, "robustness.delays_s", &self.robustness.delays_s)?;
        let u = &self.robustness.uncertainty;
        u.vehicle.validate().map_err(|(key, problem)| {
            TaskError::config(file, format!("robustness.uncertainty.vehicle.{key}"), problem)
        })?;
        if let Some(p) = &u.prediction_model {
            p.validate().map_err(|(key, problem)| {
                TaskError::config(
                    file,
                    format!("robustness.uncertainty.prediction_model.{key}"),
                    problem,
                )
            })?;
        }
        for (i, f) in u
            .vehicle
            .fields
            .iter()
            .chain(u.prediction_model.iter().flat_map(|p| &p.fields))
            .enumerate()
        {
            ensure(
                trailer_model::PARAMETERS.iter().any(|(k, _, _)| *k == f.key),
                file,
                &format!("robustness.uncertainty fields[{i}].key"),
                || format!("`{}` is not a vehicle field", f.key),
            )?;
        }
        Ok(())
    }
}

fn check_speed_search(s: &SpeedSearch, file: &Path, key: &str) -> Result<(), TaskError> {
    ensure(
        s.v_min_mps > 0.0 && s.v_max_mps > s.v_min_mps && s.v_max_mps.is_finite(),
        file,
        &format!("{key}.v_min_mps"),
        || format!("expected 0 < v_min < v_max, got [{}, {}]", s.v_min_mps, s.v_max_mps),
    )?;
    ensure(s.samples >= 2, file, &format!("{key}.samples"), || {
        format!("expected at least 2 speeds, got {}", s.samples)
    })?;
    ensure_positive(s.tolerance_mps, file, &format!("{key}.tolerance_mps"), "a tolerance > 0 m/s")?;
    Ok(())
}

impl ControlDesignConfig {
    fn settings(&self) -> StudySettings {
        StudySettings {
            delays_s: self.delays_s.values(),
            structures: self.structures.clone(),
            actuators: self.actuators.clone(),
            search: DesignSearch {
                limits: self.search.limits.map(|l| CommandLimits {
                    track_width_m: self.track_width_m,
                    ..l
                }),
                ..self.search.clone()
            },
            budget_rise_fraction: self.budget.rise_fraction,
            budget_tau_tolerance_s: self.budget.tau_tolerance_s,
            checked_delays_s: self.robustness.delays_s.clone(),
            uncertainty: self.robustness.uncertainty.clone(),
            robustness_speed: self.robustness.speed,
            fold: self.fold.clone(),
            away_from_corner_samples: self.away_from_corner_samples,
        }
    }
}

/// One entry of `summary.json`'s `"designs"` (and a row of `designs.csv`).
#[derive(Debug, Clone, PartialEq, Serialize)]
struct DesignEntry {
    structure: &'static str,
    actuator: &'static str,
    tau_s: f64,
    gains: Gains,
    /// V_crit,max, found or stable up to the cap (written as the fields below)
    #[serde(skip)]
    v_crit: CappedSpeed,
    /// the robust (5 %) V_crit at a checked delay where a sample succeeded (written as the
    /// fields below)
    #[serde(skip)]
    robust: Option<CappedSpeed>,
    /// the maximal linear critical speed \[m/s\] (null: stable up to the search's cap,
    /// `stable_up_to_mps` and `reason`)
    v_crit_mps: Option<f64>,
    /// the scan's V_crit where a narrower window of instability lies below it
    #[serde(skip_serializing_if = "Option::is_none")]
    v_crit_scan_mps: Option<f64>,
    /// the scan found none up to the cap \[m/s\], a window of instability lies below it
    #[serde(skip_serializing_if = "Option::is_none")]
    v_crit_scan_stable_up_to_mps: Option<f64>,
    /// straight running with the optimal gains is stable up to this speed \[m/s\]
    /// (`search.speed.v_max_mps`; absent: `v_crit_mps` was found below it)
    #[serde(skip_serializing_if = "Option::is_none")]
    stable_up_to_mps: Option<f64>,
    /// why `v_crit_mps` is null
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<String>,
    v_fold_mps: Option<f64>,
    /// the Hopf point the fold's cycle branch starts from
    v_fold_hopf_mps: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    v_fold_reason: Option<String>,
    /// the 5 % quantile of V_crit over the uncertainty samples \[m/s\] (null: not a checked
    /// delay, every sample failed, or stable up to the cap, `v_crit_p05_stable_up_to_mps`)
    v_crit_p05_mps: Option<f64>,
    /// at least 95 % of the samples are stable up to this speed \[m/s\]
    /// (`robustness.speed.v_max_mps`)
    #[serde(skip_serializing_if = "Option::is_none")]
    v_crit_p05_stable_up_to_mps: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    v_crit_p05_reason: Option<String>,
    at_double_hopf: bool,
    /// at a double-Hopf optimum: the gains a little away from it (along D, in its band)
    /// with the largest fold speed
    v_fold_away_from_corner: Option<AwayFromCorner>,
    second_pair_re_per_s: Option<f64>,
    second_pair_omega_rad_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    second_pair_reason: Option<String>,
}

/// A row of `designs.csv` (an empty cell: null in `summary.json`, with its reason there).
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
struct DesignRow {
    structure: String,
    actuator: String,
    tau_s: f64,
    gain_yaw_rate: f64,
    gain_hitch_angle: f64,
    gain_hitch_rate: f64,
    v_crit_mps: Option<f64>,
    stable_up_to_mps: Option<f64>,
    v_fold_mps: Option<f64>,
    v_crit_p05_mps: Option<f64>,
    v_crit_p05_stable_up_to_mps: Option<f64>,
    at_double_hopf: bool,
    v_fold_away_from_corner_mps: Option<f64>,
}

/// The robust (5 %) critical speed of a checked design: the quantile, or stable up to the
/// samples' cap where it reaches it (at least 95 % of the samples are stable up to there);
/// None where every sample failed.
fn robust_v_crit(k: &CheckedDesign, cfg: &ControlDesignConfig) -> Option<CappedSpeed> {
    k.robustness
        .v_crit_p05_mps
        .map(|v| CappedSpeed::from_bounded(v, cfg.robustness.speed.v_max_mps))
}

fn entry(c: &Combination, d: &Design, cfg: &ControlDesignConfig) -> DesignEntry {
    let checked: Option<&CheckedDesign> = c.checked.iter().find(|k| k.tau_s == d.tau_s);
    let fold = c
        .designs
        .iter()
        .zip(&c.folds)
        .find(|(e, _)| e.tau_s == d.tau_s)
        .map(|(_, f)| f);
    let not_checked = || Some("not a checked delay (robustness.delays_s)".to_string());
    let v_crit = d.v_crit();
    let scan = d
        .v_crit_scan_mps
        .map(|v| CappedSpeed::from_bounded(v, cfg.search.speed.v_max_mps));
    let robust = checked.and_then(|k| robust_v_crit(k, cfg));
    DesignEntry {
        structure: d.structure.as_str(),
        actuator: d.actuator.as_str(),
        tau_s: d.tau_s,
        gains: d.gains,
        v_crit,
        robust,
        v_crit_mps: v_crit.found(),
        v_crit_scan_mps: scan.and_then(CappedSpeed::found),
        v_crit_scan_stable_up_to_mps: scan.and_then(CappedSpeed::stable_up_to),
        stable_up_to_mps: v_crit.stable_up_to(),
        reason: v_crit.reason("straight running with the optimal gains", SEARCH_CAP),
        v_fold_mps: fold.and_then(|f| f.v_fold_mps),
        v_fold_hopf_mps: fold.and_then(|f| f.hopf_v_mps),
        v_fold_reason: fold.and_then(|f| f.v_fold_reason.clone()),
        v_crit_p05_mps: robust.and_then(CappedSpeed::found),
        v_crit_p05_stable_up_to_mps: robust.and_then(CappedSpeed::stable_up_to),
        v_crit_p05_reason: match (checked, robust) {
            (Some(_), None) => Some("every uncertainty sample failed".into()),
            (Some(_), Some(r)) => r.reason(
                "straight running of at least 95 % of the uncertainty samples",
                ROBUSTNESS_CAP,
            ),
            (None, _) => not_checked(),
        },
        at_double_hopf: d.at_double_hopf,
        v_fold_away_from_corner: fold.and_then(|f| f.away_from_corner.clone()),
        second_pair_re_per_s: d.second_pair.map(|p| p[0]),
        second_pair_omega_rad_s: d.second_pair.map(|p| p[1]),
        second_pair_reason: d.second_pair_note.clone(),
    }
}

fn key(c: &Combination) -> String {
    format!("{}_{}", c.structure.as_str(), c.actuator.as_str())
}

/// `summary.json` of a vehicle whose open loop is stable up to the search's top speed.
#[derive(Debug, Clone, PartialEq, Serialize)]
struct StableOpenLoop {
    designs: Vec<DesignEntry>,
    open_loop_v_crit_mps: Option<f64>,
    open_loop_stable_up_to_mps: f64,
    reason: String,
}

impl StableOpenLoop {
    fn line(cfg: &ControlDesignConfig) -> String {
        format!(
            "straight running is stable up to {} m/s without control: nothing to design for (raise search.speed.v_max_mps)",
            cfg.settings().search.speed.v_max_mps
        )
    }

    fn summary(cfg: &ControlDesignConfig) -> Summary {
        Summary::Stable(Self {
            designs: Vec::new(),
            open_loop_v_crit_mps: None,
            open_loop_stable_up_to_mps: cfg.settings().search.speed.v_max_mps,
            reason: Self::line(cfg),
        })
    }
}

/// `summary.json`: the designs, or the reason there are none.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
enum Summary {
    Designs(Box<Designs>),
    Stable(StableOpenLoop),
}

#[derive(Debug, Clone, PartialEq, Serialize)]
struct Designs {
    designs: Vec<DesignEntry>,
    /// per `<structure>_<actuator>`: the largest delay at which the best gains still raise
    /// V_crit by `budget_rise_fraction` \[s\] (null: not even at the first delay, or at every
    /// delay of the grid: `delay_budget_at_least_s`; `delay_budget_reason` says which)
    delay_budget_s: BTreeMap<String, Option<f64>>,
    /// the budgets that reach the end of the delay grid: at least this \[s\]
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    delay_budget_at_least_s: BTreeMap<String, f64>,
    /// why a budget is null
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    delay_budget_reason: BTreeMap<String, String>,
    delay_budget_later_windows_s: BTreeMap<String, Vec<f64>>,
    budget_rise_fraction: f64,
    open_loop_v_crit_mps: f64,
    yaw_moment_limit_nm: Option<f64>,
    /// the upper end of the yaw-rate gain's search per actuator (actuator units), from
    /// `search.limits` (u_max/ψ̇_ref) or `search.bounds`
    yaw_rate_gain_max: BTreeMap<String, f64>,
    track_width_m: f64,
    checked_delays_s: Vec<f64>,
    /// None for a vehicle with model variants (`simulation_check_reason`)
    simulation_check: Option<SimulationOutcome>,
    #[serde(skip_serializing_if = "Option::is_none")]
    simulation_check_reason: Option<String>,
}

fn simulation_figure(o: &SimulationOutcome, curves: &[Curve]) -> Figure {
    let mut panel = Panel::new(
        &format!(
            "Kick θ(0) = {}° at V = {:.2} m/s (0.95 × open-loop V_crit), designs at τ = {} s",
            o.kick_deg, o.speed_mps, o.delay_s
        ),
        "time t [s]",
        "hitch angle θ [deg]",
    )
    .legend(Legend::UpperRight);
    for (i, (label, pts)) in curves.iter().enumerate() {
        let (colour, stroke) = if i == 0 {
            (Rgb(0, 0, 0), Stroke::Dotted)
        } else {
            (Rgb::palette(i - 1), Stroke::Solid)
        };
        panel = panel.with(Layer::line(pts.clone(), colour, stroke, Some(label)));
    }
    Figure::single(panel).titled("Simulation check of the designs: does the sway-triggering kick die out?")
}

fn color(s: Structure) -> Rgb {
    match s {
        Structure::YawRate => Rgb::palette(0),
        Structure::YawRateHitch => Rgb::palette(1),
        Structure::Predictor => Rgb::palette(2),
    }
}

fn stroke(a: Actuator) -> Stroke {
    match a {
        Actuator::Steering => Stroke::Solid,
        Actuator::DifferentialBraking => Stroke::Dashed,
    }
}

fn figure(r: &ControlStudy, cfg: &ControlDesignConfig) -> Figure {
    let (t0, t1) = (cfg.delays_s.min, cfg.delays_s.max);
    let v_open = r.open_loop_v_crit_mps;
    let mut best = Panel::new(
        "Best linear critical speed per delay (solid: steering, dashed: differential braking)",
        "loop delay τ [s]",
        "V_crit,max [m/s]",
    )
    .legend(Legend::UpperRight);
    let mut robust = Panel::new(
        "What the optimum guarantees at the checked delays",
        "loop delay τ [s]",
        "speed [m/s]",
    )
    .legend(Legend::UpperRight);
    let mut capped: Vec<CappedSpeed> = Vec::new();
    let mut capped_robust: Vec<CappedSpeed> = Vec::new();
    for c in &r.combinations {
        let label = format!("{} + {}", c.structure.as_str(), c.actuator.as_str());
        let pts: Vec<(f64, CappedSpeed)> = c.designs.iter().map(|d| (d.tau_s, d.v_crit())).collect();
        capped.extend(pts.iter().map(|p| p.1));
        best.layers.extend(capped_speed_layers(
            &pts,
            color(c.structure),
            stroke(c.actuator),
            Some(&label),
        ));
        let p05: Vec<(f64, CappedSpeed)> = c
            .checked
            .iter()
            .filter_map(|k| robust_v_crit(k, cfg).map(|v| (k.tau_s, v)))
            .collect();
        if !p05.is_empty() {
            capped_robust.extend(p05.iter().map(|p| p.1));
            robust.layers.extend(capped_speed_layers(
                &p05,
                color(c.structure),
                stroke(c.actuator),
                Some(&format!("{label}: 5 % V_crit")),
            ));
        }
        let fold: Vec<(f64, f64)> = c
            .checked
            .iter()
            .filter_map(|k| k.v_fold_mps.map(|v| (k.tau_s, v)))
            .collect();
        if !fold.is_empty() {
            robust = robust.with(Layer::markers(
                fold,
                color(c.structure),
                Some(&format!("{label}: V_fold")),
            ));
        }
    }
    let reference = |p: Panel| {
        p.with(Layer::line(
            vec![(t0, v_open), (t1, v_open)],
            Rgb(0, 0, 0),
            Stroke::Dotted,
            Some("open loop V_crit"),
        ))
        .with(Layer::line(
            vec![(t0, 1.1 * v_open), (t1, 1.1 * v_open)],
            Rgb(120, 120, 120),
            Stroke::Dotted,
            Some("1.1 × open loop"),
        ))
        .x_range(t0, t1)
    };
    best.layers.extend(stable_up_to_key(capped));
    robust.layers.extend(stable_up_to_key(capped_robust));
    Figure::column(vec![reference(best), reference(robust)])
        .titled("Sway control for longer delays: controller structures × actuators")
}

/// Critical speeds per second on one core (release): ≈ 2.5 ms each.
const SECONDS_PER_CRITICAL_SPEED: f64 = 2.5e-3;

impl Prepared for Configured<ControlDesignConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let pairs = (c.structures.len() * c.actuators.len()) as f64;
        let per_design = c.search.gain_samples as f64
            + 60.0
            + (c.search.optimiser.random_starts as f64 + 2.0) * 120.0;
        let designs = pairs * c.delays_s.points as f64 * per_design;
        let robust = pairs
            * c.robustness.delays_s.len() as f64
            * c.robustness.uncertainty.vehicle.samples as f64
            * 0.5;
        let time = (designs + robust) * SECONDS_PER_CRITICAL_SPEED / 2.0;
        Ok(Plan::new(
            vec![
                format!(
                    "control_design: {} structures × {} actuators × {} delays",
                    c.structures.len(),
                    c.actuators.len(),
                    c.delays_s.points
                ),
                format!("estimated time on 2 cores: at most {}", human_seconds(time)),
            ],
            pairs * c.delays_s.points as f64 * 4000.0,
            time,
        ))
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let steps = (cfg.structures.len() * cfg.actuators.len()) as u64;
        ctx.run_staged(
            TASK.name,
            "control_design: structure × actuator",
            steps,
            cfg,
            &self.file,
            |out: &OutputDir| {
                let prediction = cfg.prediction(&self.file)?;
                let vehicle = StudyVehicle {
                    spec: &ctx.spec,
                    plant: &ctx.plant,
                    // a vehicle with model variants: the linear side on its plant, the folds
                    // of cycles and the simulation check only for the paper's model
                    paper: ctx.variant_key.is_none().then_some((&ctx.model, &ctx.vehicle)),
                    prediction: prediction.as_ref().map(|p| &p.spec),
                };
                // an open loop stable up to the search's top speed is an outcome: nothing to
                // design for (summary with its reason, no designs)
                if open_loop_critical_speed(vehicle, &cfg.settings())?.is_none() {
                    return Ok((StableOpenLoop::summary(cfg), vec![StableOpenLoop::line(cfg)]));
                }
                let r = control_study(vehicle, &cfg.settings(), ctx.progress)?;
                let entries: Vec<DesignEntry> = r
                    .combinations
                    .iter()
                    .flat_map(|c| c.designs.iter().map(move |d| entry(c, d, cfg)))
                    .collect();
                out.write_table(
                    "designs.csv",
                    entries.iter().map(|e| DesignRow {
                        structure: e.structure.into(),
                        actuator: e.actuator.into(),
                        tau_s: e.tau_s,
                        gain_yaw_rate: e.gains.yaw_rate,
                        gain_hitch_angle: e.gains.hitch_angle,
                        gain_hitch_rate: e.gains.hitch_rate,
                        v_crit_mps: e.v_crit_mps,
                        stable_up_to_mps: e.stable_up_to_mps,
                        v_fold_mps: e.v_fold_mps,
                        v_crit_p05_mps: e.v_crit_p05_mps,
                        v_crit_p05_stable_up_to_mps: e.v_crit_p05_stable_up_to_mps,
                        at_double_hopf: e.at_double_hopf,
                        v_fold_away_from_corner_mps: e
                            .v_fold_away_from_corner
                            .as_ref()
                            .map(|a| a.v_fold_mps),
                    }),
                )?;
                figure(&r, cfg).render(&out.path("control_design"))?;
                let simulation = if ctx.variant_key.is_none() {
                    let sim_prediction = cfg
                        .prediction_vehicle
                        .as_ref()
                        .zip(prediction.as_ref())
                        .map(|(file, p)| PredictionVehicle::loaded(file, p.params));
                    let (simulation, curves) = simulation_check(
                        &ctx.model,
                        &r,
                        &cfg.simulation_check,
                        sim_prediction.as_ref(),
                    )?;
                    // `simulation_tau_0_6` for τ = 0.6 s: a dot would read as the file's extension
                    let stem = format!("simulation_tau_{}", cfg.simulation_check.delay_s)
                        .replace('.', "_");
                    simulation_figure(&simulation, &curves).render(&out.path(&stem))?;
                    Some(simulation)
                } else {
                    None
                };
                let lines = headlines(&r, &entries, cfg);
                let budgets: Vec<(String, Budget)> = r
                    .combinations
                    .iter()
                    .map(|c| (key(c), Budget::of(c, &r, cfg)))
                    .collect();
                let summary = Summary::Designs(Box::new(Designs {
                    delay_budget_s: budgets
                        .iter()
                        .map(|(k, b)| (k.clone(), b.seconds()))
                        .collect(),
                    delay_budget_at_least_s: budgets
                        .iter()
                        .filter_map(|(k, b)| b.at_least().map(|t| (k.clone(), t)))
                        .collect(),
                    delay_budget_reason: budgets
                        .iter()
                        .filter_map(|(k, b)| b.reason.clone().map(|why| (k.clone(), why)))
                        .collect(),
                    delay_budget_later_windows_s: r
                        .combinations
                        .iter()
                        .map(|c| (key(c), c.budget.later_windows_s.clone()))
                        .collect(),
                    designs: entries,
                    budget_rise_fraction: cfg.budget.rise_fraction,
                    open_loop_v_crit_mps: r.open_loop_v_crit_mps,
                    yaw_moment_limit_nm: Actuator::DifferentialBraking
                        .limit(&ctx.model, cfg.track_width_m),
                    yaw_rate_gain_max: cfg
                        .actuators
                        .iter()
                        .map(|&a| {
                            let search = cfg.settings().search;
                            let b = search.gain_bound(GainName::YawRate, a, &ctx.model);
                            (a.as_str().to_string(), b.hi)
                        })
                        .collect(),
                    track_width_m: cfg.track_width_m,
                    checked_delays_s: cfg.robustness.delays_s.clone(),
                    simulation_check_reason: simulation.is_none().then(|| {
                        "the simulation check runs on the paper's model only: this vehicle has \
                         model variants"
                            .to_string()
                    }),
                    simulation_check: simulation,
                }));
                Ok((summary, lines))
            },
        )
    }
}

/// A delay budget as the summary reports it: the budget, or null with the grid's end it
/// reaches (the true budget is larger) or none, and the reason.
#[derive(Debug, Clone, PartialEq)]
struct Budget {
    /// the budget \[s\]
    tau_s: Option<f64>,
    /// the budget reaches the end of the delay grid, this delay \[s\]
    at_grid_end: bool,
    /// why `tau_s` is null
    reason: Option<String>,
}

impl Budget {
    fn of(c: &Combination, r: &ControlStudy, cfg: &ControlDesignConfig) -> Self {
        let b = &c.budget;
        let rise = format!(
            "by {} % over the open loop's {:.4} m/s",
            b.gain_fraction * 100.0,
            r.open_loop_v_crit_mps
        );
        let reason = match (b.tau_s, b.at_grid_end) {
            (Some(_), false) => None,
            (Some(t), true) => Some(format!(
                "the best gains raise V_crit {rise} at every delay of the grid up to its end, \
                 τ = {t} s (delays_s.max): the delay budget is at least that"
            )),
            // a capped design is a lower bound: above the cap no rise can be told
            (None, _) if (1.0 + b.gain_fraction) * r.open_loop_v_crit_mps > cfg.search.speed.v_max_mps => {
                Some(format!(
                    "the rise {rise} asks for a V_crit above the speed cap, {} m/s (search.speed.v_max_mps): no delay budget can be told",
                    cfg.search.speed.v_max_mps
                ))
            }
            (None, _) => Some(format!(
                "not even at the first delay of the grid, τ = {} s, do the best gains raise V_crit {rise}",
                cfg.delays_s.min
            )),
        };
        Self {
            tau_s: b.tau_s,
            at_grid_end: b.at_grid_end,
            reason,
        }
    }

    /// The budget \[s\]: null at the grid's end (a lower bound, [`Budget::at_least`]).
    fn seconds(&self) -> Option<f64> {
        self.tau_s.filter(|_| !self.at_grid_end)
    }

    /// The grid's end where the budget reaches it \[s\].
    fn at_least(&self) -> Option<f64> {
        self.tau_s.filter(|_| self.at_grid_end)
    }
}

fn headlines(r: &ControlStudy, entries: &[DesignEntry], cfg: &ControlDesignConfig) -> Vec<String> {
    let mut lines = vec![format!(
        "open-loop V_crit = {:.3} m/s; delay budget = largest τ with V_crit,max ≥ 1.1 × it",
        r.open_loop_v_crit_mps
    )];
    for c in &r.combinations {
        let b = Budget::of(c, r, cfg);
        let budget = match (b.seconds(), b.at_least()) {
            (Some(t), _) => format!("{t:.3} s"),
            (None, Some(t)) => format!("≥ {t:.3} s (the end of the delay grid)"),
            (None, None) => "none (not even at the first delay)".into(),
        };
        let later = if c.budget.later_windows_s.is_empty() {
            String::new()
        } else {
            format!(
                "; reached again at τ = {:?} s (back in phase with the sway)",
                c.budget.later_windows_s
            )
        };
        lines.push(format!("{}: delay budget {budget}{later}", key(c)));
    }
    for e in entries {
        let Some(robust) = e.robust else {
            continue;
        };
        lines.push(format!(
            "τ = {:.2} s, {} + {}: {}, {}{}{}",
            e.tau_s,
            e.structure,
            e.actuator,
            e.v_crit.label("V_crit", 2),
            robust.label("robust (5 %) V_crit", 2),
            e.v_fold_mps
                .map(|v| format!(", V_fold {v:.2} m/s"))
                .unwrap_or_default(),
            if e.at_double_hopf { " (double-Hopf corner)" } else { "" }
        ));
    }
    lines
}
