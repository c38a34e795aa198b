//! `cargo xtask sway_assist` (issue 48, items 4–5): the sway detectors (`sway-detect`)
//! and the sway assist ([`sway::assist`]) evaluated on the vehicle (`--vehicle FILE`, any
//! model variant) or the config's `vehicle_files` (a fleet) over a sway set and a
//! false-alarm set; the computation is
//! [`sway_studies::sway_assist`]. Writes `runs.csv` (one row per scenario and
//! intervention), `roc.csv`, `observer.csv` (one row per vehicle: the observer's
//! ordinary-driving run), `summary.json` (`detectors`, `assist`, `observer`) and the
//! figures `roc`, `latency`, `runs` (a sway run and a slalom run with every detector's
//! flag on a time axis) and `observer` (its V_crit estimate converging in ordinary driving,
//! on the first vehicle).

use std::path::{Path, PathBuf};

use serde::Serialize;
use sway::assist::{ONSET_AMPLITUDE_DEG, RunOutcome, SWAY_AMPLITUDE_DEG};
use trailer_model::AnyVehicleModel;
use sway_studies::sway_assist::{
    AssistMetrics, CONVERGED_WITHIN, DetectorMetrics, ObserverResult, ScenarioSet, SwayAssist,
    VehicleReferences, compute,
};
pub use sway_studies::sway_assist::SwayAssistConfig;

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{load_toml, load_vehicle_spec};
use crate::io::OutputDir;
use crate::limits::{BYTES_PER_ROW, MAX_SIMULATED_S, Plan, bound, human_seconds};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task.
pub const TASK: Task = Task {
    name: "sway_assist",
    about: "sway detectors and the sway assist on sensor signals: detection, false alarms, latency, ROC, loss of control with and without",
    config: "sway_assist.toml",
    prepare,
    models: super::Models::Any,
    runs: super::Runs::InAll,
};

/// The full evaluation (run by name only): more speeds, disturbances of rising size and
/// the whole false-alarm set of issue 48 (slalom 0.4–1.2 Hz up to 4 m/s²).
pub const FULL: Task = Task {
    name: "sway_assist_full",
    about: "the full sway-assist evaluation (configs/sway_assist_full.toml)",
    config: "sway_assist_full.toml",
    prepare: prepare_full,
    models: super::Models::Any,
    runs: super::Runs::OnDemand,
};

/// One detector's line of `summary.json` (the names first).
pub type DetectorEntry = DetectorMetrics;

/// The model-based observer's fields (issue 48, item 5), from each vehicle's
/// ordinary-driving run ([`sway_studies::sway_assist::ObserverResult`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObserverSummary {
    /// the largest relative error |V̂_crit − V_crit|/V_crit over the vehicles at the end of
    /// ordinary driving \[-\]
    pub v_crit_error_rel_max: Option<f64>,
    /// the largest relative error of V_fold with the estimated trailer \[-\]
    pub v_fold_error_rel_max: Option<f64>,
    /// the median over the vehicles of the time from the start of ordinary driving after
    /// which V̂_crit stays within 5 % of V_crit \[s\]
    pub converged_after_s_median: Option<f64>,
    /// its final V_crit estimate on the one vehicle \[m/s\]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_crit_estimate_mps: Option<f64>,
    /// its final V_fold estimate on the one vehicle \[m/s\]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_fold_estimate_mps: Option<f64>,
    /// why the fields are null
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

impl ObserverSummary {
    /// Every field null, with the reason.
    pub fn not_evaluated() -> Self {
        Self {
            v_crit_error_rel_max: None,
            v_fold_error_rel_max: None,
            converged_after_s_median: None,
            v_crit_estimate_mps: None,
            v_fold_estimate_mps: None,
            reason: Some(
                "the model-based observer is not among the config's detectors".into(),
            ),
        }
    }

    /// From the vehicles' ordinary-driving runs: the largest errors (over the vehicles that
    /// have them), the median
    /// convergence time (a vehicle that never converges counts as never), and on one
    /// vehicle its final estimates; a reason where a value is null.
    pub fn of(results: &[ObserverResult]) -> Self {
        if results.is_empty() {
            return Self::not_evaluated();
        }
        // over the vehicles that have the value (those without it give the reason)
        let max_of = |f: &dyn Fn(&ObserverResult) -> Option<f64>| {
            results.iter().filter_map(f).reduce(f64::max)
        };
        let mut times: Vec<f64> = results
            .iter()
            .map(|r| r.converged_after_s.unwrap_or(f64::INFINITY))
            .collect();
        times.sort_by(f64::total_cmp);
        let n = times.len();
        let median = if n % 2 == 1 {
            times[n / 2]
        } else {
            0.5 * (times[n / 2 - 1] + times[n / 2])
        };
        let one = (results.len() == 1).then(|| &results[0]);
        let mut s = Self {
            v_crit_error_rel_max: max_of(&|r| r.v_crit_error_rel),
            v_fold_error_rel_max: max_of(&|r| r.v_fold_error_rel),
            converged_after_s_median: median.is_finite().then_some(median),
            v_crit_estimate_mps: one.and_then(|r| r.v_crit_estimate_mps),
            v_fold_estimate_mps: one.and_then(|r| r.v_fold_estimate_mps),
            reason: None,
        };
        let missing = results
            .iter()
            .any(|r| r.v_crit_error_rel.is_none() || r.v_fold_error_rel.is_none())
            || s.converged_after_s_median.is_none()
            || one.is_some_and(|_| {
                s.v_crit_estimate_mps.is_none() || s.v_fold_estimate_mps.is_none()
            });
        if missing {
            let why: Vec<String> = results
                .iter()
                .filter_map(|r| r.reason.as_ref().map(|w| format!("{}: {w}", r.vehicle)))
                .collect();
            s.reason = Some(if s.converged_after_s_median.is_none() && why.is_empty() {
                format!(
                    "V̂_crit does not stay within {:.0} % of V_crit on most vehicles",
                    100.0 * CONVERGED_WITHIN
                )
            } else {
                why.join("; ")
            });
        }
        s
    }
}

/// `summary.json` of sway_assist (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SwayAssistSummary {
    /// per detector, then per detector behind the steering gate (`<name>_gated`)
    pub detectors: Vec<DetectorEntry>,
    /// the assist over every scenario, with and without it
    pub assist: AssistMetrics,
    /// the observer (null fields with the reason)
    pub observer: ObserverSummary,
    /// the ground truth's amplitude of sway \[deg of hitch angle\]
    pub sway_amplitude_deg: f64,
    /// the ground truth's onset amplitude \[deg of hitch angle\]
    pub onset_amplitude_deg: f64,
    /// the hours of false-alarm driving the rates are per \[h\]
    pub false_alarm_hours: f64,
    /// the vehicles' reference speeds
    pub vehicles: Vec<VehicleReferences>,
}

/// One row of `runs.csv`.
#[derive(Debug, Clone, PartialEq, Serialize)]
struct RunRow {
    vehicle: String,
    set: &'static str,
    speed: String,
    speed_mps: f64,
    disturbance: &'static str,
    disturbance_size: f64,
    intervention: &'static str,
    sways: Option<bool>,
    sustained_sway: Option<bool>,
    loss_of_control_s: Option<f64>,
    onset_s: Option<f64>,
    period_s: Option<f64>,
    peak_hitch_angle_deg: Option<f64>,
    speed_lost_mps: Option<f64>,
    settle_time_s: Option<f64>,
    engaged_s: Option<f64>,
    error: Option<String>,
    /// per detector: its first flag \[s\] and its flag count
    detectors: Vec<(Option<f64>, usize)>,
}

struct SwayAssistTask {
    name: &'static str,
    file: PathBuf,
    config: SwayAssistConfig,
    /// the config's vehicle files (name, model); empty: the task's vehicle
    fleet: Vec<(String, AnyVehicleModel)>,
    /// the fleet's files with a chain of towed units (`[[trailers]]`), by their key
    fleet_chains: Vec<String>,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    prepare_named(TASK.name, file)
}

fn prepare_full(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    prepare_named(FULL.name, file)
}

fn prepare_named(name: &'static str, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    Ok(Box::new(SwayAssistTask::load(name, file)?))
}

/// Reads and checks a sway-assist config file.
///
/// # Errors
/// Read errors and config errors naming the key.
pub(crate) fn load_config(file: &Path) -> Result<SwayAssistConfig, TaskError> {
    let config: SwayAssistConfig = load_toml(file)?;
    config
        .validate()
        .map_err(|(k, p)| TaskError::config(file, k, p))?;
    Ok(config)
}

/// The vehicles the evaluation of `config` (read from `file`) runs on (name, model): the
/// config's fleet, or the task's vehicle; [`TaskError::NotApplicable`] for a chain of towed units.
///
/// # Errors
/// Config and vehicle-file errors naming the key; not applicable to a chain.
pub(crate) fn vehicles(
    ctx: &TaskContext<'_>,
    config: &SwayAssistConfig,
    file: &Path,
) -> Result<Vec<(String, AnyVehicleModel)>, TaskError> {
    let task = SwayAssistTask::with_config(TASK.name, file, config.clone())?;
    task.two_units_only(ctx)?;
    Ok(task.vehicles(ctx))
}

fn rows(r: &SwayAssist, names: &[String]) -> Vec<RunRow> {
    let mut out = Vec::new();
    for s in &r.scenarios {
        for (label, run) in [("none", &s.without), ("assist", &s.with)] {
            let ok = run.as_ref().ok();
            out.push(RunRow {
                vehicle: s.vehicle.clone(),
                set: match s.set {
                    ScenarioSet::Sway => "sway",
                    ScenarioSet::FalseAlarm => "false_alarm",
                },
                speed: s.speed.to_string(),
                speed_mps: s.scenario.speed_mps,
                disturbance: s.scenario.disturbance.kind(),
                disturbance_size: s.scenario.disturbance.size(),
                intervention: label,
                sways: ok.map(|r| r.sways),
                sustained_sway: ok.map(|r| r.truth.sustained_sway),
                loss_of_control_s: ok.and_then(|r| r.loss_of_control_s),
                onset_s: ok.and_then(|r| r.truth.onset_s),
                period_s: ok.and_then(|r| r.truth.period_s),
                peak_hitch_angle_deg: ok.map(|r| r.truth.peak_hitch_angle_deg),
                speed_lost_mps: ok.map(|r| r.speed_lost_mps),
                settle_time_s: ok.and_then(|r| r.truth.settle_time_s),
                engaged_s: ok.and_then(|r| r.engaged_s),
                error: run.as_ref().err().cloned(),
                detectors: match ok {
                    Some(r) => r
                        .detectors
                        .iter()
                        .map(|d| (d.first_flag_s, d.flags))
                        .collect(),
                    None => vec![(None, 0); names.len()],
                },
            });
        }
    }
    out
}

fn write_tables(out: &OutputDir, r: &SwayAssist) -> Result<(), TaskError> {
    let names: Vec<String> = r.detectors.iter().map(|d| d.name.clone()).collect();
    let mut header: Vec<String> = [
        "vehicle",
        "set",
        "speed",
        "speed_mps",
        "disturbance",
        "disturbance_size",
        "intervention",
        "sways",
        "sustained_sway",
        "loss_of_control_s",
        "onset_s",
        "period_s",
        "peak_hitch_angle_deg",
        "speed_lost_mps",
        "settle_time_s",
        "engaged_s",
        "error",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for n in &names {
        header.push(format!("{n}_first_flag_s"));
        header.push(format!("{n}_flags"));
    }
    out.write_rows("runs.csv", &header, rows(r, &names))?;
    let roc_rows = r.detectors.iter().flat_map(|d| {
        d.roc.iter().map(move |p| {
            (
                d.name.clone(),
                p.threshold,
                p.false_positive_rate,
                p.true_positive_rate,
            )
        })
    });
    out.write_rows(
        "roc.csv",
        &[
            "detector",
            "threshold",
            "false_positive_rate",
            "true_positive_rate",
        ],
        roc_rows,
    )?;
    let obs_rows = r.observer.iter().map(|o| {
        let [m, j, h] = o.trailer_estimate.map_or([None; 3], |p| p.map(Some));
        (
            o.vehicle.clone(),
            o.speed_mps,
            o.manoeuvres,
            o.v_crit_mps,
            o.v_crit_estimate_mps,
            o.v_crit_sd_mps,
            o.v_crit_error_rel,
            o.v_fold_mps,
            o.v_fold_estimate_mps,
            o.v_fold_error_rel,
            o.converged_after_s,
            m,
            j,
            h,
            o.reason.clone(),
        )
    });
    out.write_rows(
        "observer.csv",
        &[
            "vehicle",
            "speed_mps",
            "manoeuvres",
            "v_crit_mps",
            "v_crit_estimate_mps",
            "v_crit_sd_mps",
            "v_crit_error_rel",
            "v_fold_mps",
            "v_fold_estimate_mps",
            "v_fold_error_rel",
            "converged_after_s",
            "trailer_mass_kg",
            "trailer_yaw_inertia_kgm2",
            "trailer_cog_m",
            "reason",
        ],
        obs_rows,
    )
}

/// The observer's V_crit estimate over the ordinary-driving run of the first vehicle, with
/// its ±1 sd band, the true V_crit and the 5 % band around it.
fn observer_panel(o: &ObserverResult, start_s: f64) -> Option<Panel> {
    let tr = o.track.as_ref()?;
    let v_crit = o.v_crit_mps?;
    let t_end = tr.t.last().copied()? - start_s;
    let t: Vec<f64> = tr.t.iter().map(|t| t - start_s).collect();
    let mut sd_rects = Vec::new();
    for i in 0..t.len().saturating_sub(1) {
        if let (Some(v), Some(sd)) = (tr.v_crit_mps[i], tr.v_crit_sd_mps[i]) {
            sd_rects.push([t[i], t[i + 1], v - sd, v + sd]);
        }
    }
    let est: Vec<(f64, f64)> = t
        .iter()
        .zip(&tr.v_crit_mps)
        .map(|(&t, v)| (t, v.unwrap_or(f64::NAN)))
        .collect();
    let lo = (1.0 - 4.0 * CONVERGED_WITHIN) * v_crit;
    let hi = (1.0 + 4.0 * CONVERGED_WITHIN) * v_crit;
    let mut p = Panel::new(
        &format!(
            "Observer in ordinary driving ({}: {} slaloms and lane changes at {:.1} m/s)",
            o.vehicle,
            o.manoeuvres,
            o.speed_mps.unwrap_or(f64::NAN)
        ),
        "time from the start of ordinary driving [s]",
        "critical speed V_crit [m/s]",
    )
    .x_range(0.0, t_end)
    .y_range(lo, hi)
    .legend(Legend::LowerRight)
    .with(Layer::Rects {
        rects: vec![[
            0.0,
            t_end,
            (1.0 - CONVERGED_WITHIN) * v_crit,
            (1.0 + CONVERGED_WITHIN) * v_crit,
        ]],
        color: Rgb::GREY,
        opacity: 0.25,
        label: Some(format!("V_crit ± {:.0} %", 100.0 * CONVERGED_WITHIN)),
    })
    .with(Layer::Rects {
        rects: sd_rects,
        color: Rgb::BLUE,
        opacity: 0.25,
        label: Some("estimate ± 1 sd".into()),
    })
    .with(Layer::line(
        vec![(0.0, v_crit), (t_end, v_crit)],
        Rgb::BLACK,
        Stroke::Dashed,
        Some("true V_crit"),
    ))
    .with(Layer::line(
        est.into_iter()
            .map(|(t, v)| (t, v.clamp(lo, hi)))
            .collect(),
        Rgb::BLUE,
        Stroke::Solid,
        Some("observer's V̂_crit"),
    ));
    if let Some(c) = o.converged_after_s {
        p.layers.push(Layer::vline(
            c,
            (lo, hi),
            Rgb::RED,
            Stroke::Dotted,
            Some("within 5 % from here on"),
        ));
    }
    Some(p)
}

fn draw(out: &OutputDir, r: &SwayAssist, start_s: f64) -> Result<(), TaskError> {
    // ROC curves
    let mut roc = Panel::new(
        "ROC of run-level verdicts over the detector's threshold",
        "false-positive rate (false-alarm runs flagged) [-]",
        "true-positive rate (sway runs flagged) [-]",
    )
    .x_range(-0.02, 1.02)
    .y_range(-0.02, 1.02)
    .legend(Legend::LowerRight);
    for (k, d) in r.detectors.iter().enumerate() {
        let pts = d
            .roc
            .iter()
            .map(|p| (p.false_positive_rate, p.true_positive_rate))
            .collect();
        let stroke = if d.name.ends_with("_gated") {
            Stroke::Dashed
        } else {
            Stroke::Solid
        };
        roc.layers
            .push(Layer::line(pts, Rgb::palette(k % (r.detectors.len() / 2).max(1)), stroke, Some(&d.name)));
    }
    roc.layers.push(Layer::line(
        vec![(0.0, 0.0), (1.0, 1.0)],
        Rgb::GREY,
        Stroke::Dotted,
        Some("chance"),
    ));
    Figure::grid(vec![roc], 1, 1, (820, 700)).render(&out.path("roc"))?;
    // latency distributions: the empirical CDF of each detector's latencies
    let mut lat = Panel::new(
        "Detection latency from the sway's onset (|θ| ≥ 1°)",
        "latency [s]",
        "fraction of the detected sway runs [-]",
    )
    .y_range(0.0, 1.02)
    .legend(Legend::LowerRight);
    for (k, d) in r.detectors.iter().enumerate() {
        let mut l = d.latencies_s.clone();
        if l.is_empty() {
            continue;
        }
        l.sort_by(f64::total_cmp);
        let n = l.len() as f64;
        let mut pts = Vec::with_capacity(2 * l.len());
        for (i, &x) in l.iter().enumerate() {
            pts.push((x, i as f64 / n));
            pts.push((x, (i + 1) as f64 / n));
        }
        let stroke = if d.name.ends_with("_gated") {
            Stroke::Dashed
        } else {
            Stroke::Solid
        };
        lat.layers.push(Layer::line(
            pts,
            Rgb::palette(k % (r.detectors.len() / 2).max(1)),
            stroke,
            Some(&d.name),
        ));
    }
    Figure::grid(vec![lat], 1, 1, (820, 600)).render(&out.path("latency"))?;
    // one sway run and one slalom run with every detector's flag
    let mut panels = Vec::new();
    let names: Vec<String> = r.detectors.iter().map(|d| d.name.clone()).collect();
    let mut flag_panels = Vec::new();
    for (title, run) in [
        ("A sway run", r.sway_trace.as_ref()),
        ("A slalom run", r.slalom_trace.as_ref()),
    ] {
        let Some(run) = run else { continue };
        let (sig, flags) = run_panels(title, run, &names);
        panels.push(sig);
        flag_panels.push(flags);
    }
    if !panels.is_empty() {
        let cols = panels.len();
        panels.extend(flag_panels);
        Figure::grid(panels, 2, cols, (1500, 900)).render(&out.path("runs"))?;
    }
    if let Some(p) = r
        .observer
        .first()
        .and_then(|o| observer_panel(o, start_s))
    {
        Figure::grid(vec![p], 1, 1, (1000, 600)).render(&out.path("observer"))?;
    }
    Ok(())
}

/// The signals of a run (θ, δ) and its flags, one row per detector.
fn run_panels(title: &str, run: &RunOutcome, names: &[String]) -> (Panel, Panel) {
    let Some(tr) = &run.trace else {
        return (
            Panel::new(title, "time [s]", "[deg]"),
            Panel::new(title, "time [s]", "detector"),
        );
    };
    let s = &run.scenario;
    let pair = |v: &[f64]| tr.t.iter().copied().zip(v.iter().copied()).collect();
    let signals = Panel::new(
        &format!(
            "{title}: {} at {:.1} m/s (no intervention)",
            s.disturbance.kind(),
            s.speed_mps
        ),
        "time [s]",
        "hitch angle θ, front-wheel angle δ [deg]",
    )
    .x_range(0.0, s.horizon_s)
    .with(Layer::line(
        pair(&tr.hitch_angle_deg),
        Rgb::BLUE,
        Stroke::Solid,
        Some("hitch angle θ [deg]"),
    ))
    .with(Layer::line(
        pair(&tr.steering_deg),
        Rgb::BLACK,
        Stroke::Dashed,
        Some("front-wheel angle δ [deg]"),
    ))
    .legend(Legend::UpperLeft);
    let mut flags = Panel::new(
        &format!("{title}: flags (a line where the detector flags sway)"),
        "time [s]",
        "detector (row k: the k-th of the legend)",
    )
    .x_range(0.0, s.horizon_s)
    .y_range(-0.5, names.len() as f64 + 0.5)
    .legend(Legend::LowerRight);
    for (k, n) in names.iter().enumerate() {
        let y = (names.len() - k) as f64;
        let pts = tr
            .t
            .iter()
            .zip(&tr.flags)
            .map(|(&t, f)| (t, if f[k] { y } else { f64::NAN }))
            .collect();
        flags
            .layers
            .push(Layer::line(pts, Rgb::palette(k), Stroke::Solid, Some(n)));
    }
    if let Some(t) = run.truth.onset_s.filter(|_| run.sways) {
        flags.layers.push(Layer::vline(
            t,
            (-0.5, names.len() as f64 + 0.5),
            Rgb::RED,
            Stroke::Dotted,
            Some("sway onset (|θ| = 1°)"),
        ));
    }
    (signals, flags)
}

/// Wall time per simulated second of a co-simulated run \[s/s\] (frames, sensors,
/// detectors and the solver restarted every 10 ms; measured: the default's 34 runs of 30 s
/// take ≈ 1 s on 2 cores).
const SECONDS_PER_COSIMULATED_SECOND: f64 = 1e-3;

impl SwayAssistTask {
    /// The task `name` with the config `file` and its fleet loaded.
    fn load(name: &'static str, file: &Path) -> Result<Self, TaskError> {
        Self::with_config(name, file, load_config(file)?)
    }

    /// The task `name` with `config`, read from `file`, and its fleet loaded.
    fn with_config(
        name: &'static str,
        file: &Path,
        config: SwayAssistConfig,
    ) -> Result<Self, TaskError> {
        let dir = file.parent().unwrap_or(Path::new("."));
        let fleet = config
            .vehicle_files
            .iter()
            .enumerate()
            .map(|(k, rel)| {
                let path = dir.join(rel);
                let loaded = load_vehicle_spec(&path).map_err(|e| {
                    TaskError::config(
                        file,
                        format!("vehicle_files[{k}]"),
                        format!("the vehicle file {} is not valid: {e}", path.display()),
                    )
                })?;
                let name = Path::new(rel)
                    .file_stem()
                    .map_or_else(|| rel.clone(), |s| s.to_string_lossy().into_owned());
                let chain = loaded
                    .spec
                    .is_chain()
                    .then(|| format!("vehicle_files[{k}]"));
                Ok(((name, loaded.plant), chain))
            })
            .collect::<Result<Vec<_>, TaskError>>()?;
        let (mut fleet, chains): (Vec<_>, Vec<_>) = fleet.into_iter().unzip();
        if let Some(sampled) = &config.sampled_vehicles {
            for (name, spec) in sampled.generate() {
                let plant = AnyVehicleModel::new(&spec).map_err(|e| {
                    TaskError::config(
                        file,
                        "sampled_vehicles",
                        format!("the sampled vehicle {name} does not build: {e}"),
                    )
                })?;
                fleet.push((name, plant));
            }
        }
        Ok(Self {
            name,
            file: file.to_path_buf(),
            config,
            fleet,
            fleet_chains: chains.into_iter().flatten().collect(),
        })
    }

    /// The vehicles (name, model): the fleet, or the task's vehicle named by its file.
    fn vehicles(&self, ctx: &TaskContext<'_>) -> Vec<(String, AnyVehicleModel)> {
        if self.fleet.is_empty() {
            let name = ctx
                .vehicle_file
                .file_stem()
                .map_or_else(|| "vehicle".to_string(), |s| s.to_string_lossy().into_owned());
            vec![(name, ctx.plant.clone())]
        } else {
            self.fleet.clone()
        }
    }

    /// A chain of towed units is not this task's: its observer estimates one trailer of
    /// the paper's two-unit model from the car's signals, and its V_crit and V_fold are
    /// that model's.
    fn two_units_only(&self, ctx: &TaskContext<'_>) -> Result<(), TaskError> {
        let key = if self.fleet.is_empty() {
            ctx.spec.is_chain().then(|| "trailers".to_string())
        } else {
            self.fleet_chains.first().cloned()
        };
        match key {
            None => Ok(()),
            Some(key) => Err(TaskError::NotApplicable {
                key,
                reason: "the model-based observer estimates the hitch angle and the one trailer of the paper's two-unit model (its mass, yaw inertia and centre of gravity) from the car's signals, and predicts that model's V_crit and V_fold; a chain of towed units (`[[trailers]]`) has more articulations than it models".to_string(),
            }),
        }
    }
}

impl Prepared for SwayAssistTask {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let scenarios = self.fleet.len().max(1)
            * (c.sway_speeds.len() * c.sway_disturbances.len()
                + c.false_alarm_speeds.len() * c.false_alarm_disturbances.len());
        let runs = 2.0 * scenarios as f64;
        // with the observer's ordinary-driving run per vehicle
        let driving = if c.detectors.model_observer.is_some() {
            self.fleet.len().max(1) as f64 * (c.disturbance_start_s + c.ordinary_driving_s)
        } else {
            0.0
        };
        let simulated = runs * c.horizon_s + driving;
        let plan = Plan::new(
            vec![format!(
                "{}: {scenarios} scenarios × (without, with the assist) × {} s",
                self.name, c.horizon_s
            )],
            runs * (BYTES_PER_ROW + 16.0 * c.horizon_s * c.sensors.frame_rate_hz),
            simulated * SECONDS_PER_COSIMULATED_SECOND,
        );
        bound(&self.file, "horizon_s", simulated, MAX_SIMULATED_S, || {
            format!(
                "{runs} runs × {} s = {simulated} s simulated, ≈ {}; fewer speeds or disturbances, or a shorter horizon",
                c.horizon_s,
                human_seconds(plan.time_s)
            )
        })?;
        Ok(plan)
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let vehicles = self.vehicles(ctx);
        let runs = (vehicles.len()
            * (cfg.sway_speeds.len() * cfg.sway_disturbances.len()
                + cfg.false_alarm_speeds.len() * cfg.false_alarm_disturbances.len()))
            as u64;
        ctx.run_staged(
            self.name,
            "sway_assist: runs",
            runs,
            cfg,
            &self.file,
            |out| {
                self.two_units_only(ctx)?;
                let r = compute(cfg, &vehicles, &ctx.limits)?;
                write_evaluation(out, cfg, &r)
            },
        )
    }
}

/// Writes an evaluation's tables and figures into `out` and gives its summary and printed
/// lines: the same for a run on one machine and the merge of its shards.
///
/// # Errors
/// Write errors.
pub fn write_evaluation(
    out: &OutputDir,
    cfg: &SwayAssistConfig,
    r: &SwayAssist,
) -> Result<(SwayAssistSummary, Vec<String>), TaskError> {
    write_tables(out, r)?;
    draw(out, r, cfg.disturbance_start_s)?;
    let summary = SwayAssistSummary {
        detectors: r.detectors.clone(),
        assist: r.assist.clone(),
        observer: ObserverSummary::of(&r.observer),
        sway_amplitude_deg: SWAY_AMPLITUDE_DEG,
        onset_amplitude_deg: ONSET_AMPLITUDE_DEG,
        false_alarm_hours: r.false_alarm_hours,
        vehicles: r.vehicles.clone(),
    };
    let pct = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{:.0}%", 100.0 * v));
    let secs = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.2} s"));
    let mut lines: Vec<String> = r
        .detectors
        .iter()
        .map(|d| {
            format!(
                "{}: detection {}, {} false alarms, latency median {} worst {}",
                d.name,
                pct(d.detection_rate),
                d.false_alarms,
                secs(d.latency_median_s),
                secs(d.latency_worst_s)
            )
        })
        .collect();
    let o = &summary.observer;
    let pct2 = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{:.1}%", 100.0 * v));
    lines.push(format!(
        "observer: V_crit error max {}, V_fold error max {}, converged after {} (median)",
        pct2(o.v_crit_error_rel_max),
        pct2(o.v_fold_error_rel_max),
        secs(o.converged_after_s_median)
    ));
    let a = &r.assist;
    lines.push(format!(
        "assist over {} scenarios: loss of control {} → {} ({} → {} after sway), sustained sway {} → {} (without → with)",
        a.runs,
        a.loss_of_control_without,
        a.loss_of_control_with,
        a.loss_of_control_after_sway_without,
        a.loss_of_control_after_sway_with,
        a.sustained_sway_without,
        a.sustained_sway_with
    ));
    Ok((summary, lines))
}

