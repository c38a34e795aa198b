//! `cargo xtask sweep FILE.toml`: a study in parallel (rayon): a grid over scenario
//! quantities (V, θ(0), D, τ, braking), vehicle fields by key path and vehicle files (a
//! fleet), optionally times uncertainty samples, each point a simulation (classified), the
//! linear critical speed or the Hopf and fold speeds ([`sway_studies::sweep`]). One CSV row per
//! grid point (a failed point says why in its row), `summary.json`, a heat map over the first
//! two axes, and with `[sampling]` the distributions (quantiles, histogram figure); a
//! threshold map also bisects the θ(0) threshold per speed and compares it with the
//! unstable cycle of the bifurcation diagram. Same numbers whatever the thread count.
//!
//! Everything written comes from the ordered list of point results through
//! [`write_sweep_outputs`] (only `wall_time_s` differs between two runs), so a study computed
//! in shards and merged writes the same files as one run.
//!
//! Speeds (the base scenario's and a `speed_mps` axis's `min`/`max`) may be given relative
//! to the vehicle ([`sway::sim::speeds`]); they are resolved once per run against the
//! `--vehicle` (a study with a fleet axis gives numbers). A vehicle they do not resolve for
//! (no V_crit, or no bistable range for an `in_bistable` speed) gets a summary with the
//! reason and no points.

use std::path::{Path, PathBuf};

use serde::Serialize;
use sway::ranging::SpeedSpec;
use sway::sim::speeds::Resolution;
use sway_studies::sweep::{
    AxisParameter, PointKind, PointOutput, PointResult, Sweep, SweepConfig, run_sweep,
};
use sway::ranging::resolve_speeds;
use sway::sim::{Metrics, Outcome, SwayClass};

use super::fig3a_diagram::validate_settings;
use super::series::{WithSpeeds, nothing_to_show, resolved_check};
use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig, load_vehicle};
use crate::io::{Keyed, OutputDir, row_cells};
use crate::limits::{
    BYTES_PER_ROW, MAX_AXIS_POINTS, MAX_SIMULATED_S, MAX_SIMULATIONS, Plan,
    SWEEP_SECONDS_PER_SIM_SECOND, bound, human_seconds,
};

mod study;

pub use study::{
    DistributionEntry, Distributions, HeatmapSummary, SeparatrixSummary, ThresholdPoint,
    quantity_names,
};

/// The task (its default config is the bistability threshold map).
pub const TASK: Task = Task::configured::<SweepConfig<SpeedSpec>>(
    "sweep",
    "parallel study (TOML): simulations, V_crit or Hopf/fold speeds over scenario, vehicle and fleet axes and uncertainty samples; default: which perturbations trigger sway",
    "sweep_threshold.toml",
)
.any_model();

/// The same sweep runner on `configs/sweep_brake_timing.toml`: when braking from sway
/// loses control (beyond the paper), so that `cargo xtask all` regenerates it too.
pub const BRAKE_TIMING: Task = Task::configured::<SweepConfig<SpeedSpec>>(
    "brake_timing",
    "sweep of braking start t_b × duration T from sway: where braking loses control (beyond the paper)",
    "sweep_brake_timing.toml",
)
.any_model();

/// The uncertainty study `configs/study_uncertainty.toml`: the distribution of V_crit when
/// h and l are known to ±0.05 m.
pub const UNCERTAINTY: Task = Task::configured::<SweepConfig<SpeedSpec>>(
    "study_uncertainty",
    "distribution of V_crit when h and l are known to ±0.05 m (Latin hypercube)",
    "study_uncertainty.toml",
)
.any_model();

/// The fleet study `configs/study_fleet.toml`: V_crit over trailer mass for the vehicle
/// files of `configs/fleet/`.
pub const FLEET: Task = Task::configured::<SweepConfig<SpeedSpec>>(
    "study_fleet",
    "V_crit over trailer mass for a fleet of vehicle files (configs/fleet/)",
    "study_fleet.toml",
)
.any_model();

/// The checks of a sweep config beyond [`SweepConfig::validate`] (its speeds resolved):
/// the continuation settings, checked as fig3a checks its own.
///
/// # Errors
/// [`TaskError::Config`] naming the key.
pub fn check_resolved(cfg: &SweepConfig, file: &Path) -> Result<(), TaskError> {
    cfg.validate(file)?;
    cfg.check_options(file)
}

impl TaskConfig for SweepConfig<SpeedSpec> {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        self.validate_spec(file)?;
        self.check_options(file)
    }

    fn load_named_files(&mut self, file: &Path) -> Result<(), TaskError> {
        crate::config_file::load_prediction_vehicle(
            &mut self.base.controller,
            file,
            "base.controller",
        )
    }
}

/// The continuation settings of a sweep (any speed type).
trait CheckOptions {
    fn check_options(&self, file: &Path) -> Result<(), TaskError>;
}

impl<S: sway::sim::speeds::SpeedValue> CheckOptions for SweepConfig<S> {
    fn check_options(&self, file: &Path) -> Result<(), TaskError> {
        // the continuation settings, checked as fig3a checks its own
        if self.kind == PointKind::HopfFoldSpeeds {
            validate_settings(&self.analysis.diagram, file, "analysis.diagram")?;
        }
        if let Some(t) = self.threshold.as_ref().filter(|t| t.compare_cycles) {
            validate_settings(&t.cycles, file, "threshold.cycles")?;
        }
        Ok(())
    }
}

/// The fleet's vehicle files, resolved against the sweep file's directory.
pub fn fleet_paths<S: sway::sim::speeds::SpeedValue>(
    cfg: &SweepConfig<S>,
    file: &Path,
) -> Vec<PathBuf> {
    let dir = file.parent().unwrap_or(Path::new("."));
    cfg.fleet_files().iter().map(|f| dir.join(f)).collect()
}

/// The speeds of `cfg` resolved for the context's vehicle (once per run; nothing is
/// computed when every speed is a number).
///
/// # Errors
/// When a reference (V_crit, the fold) cannot be computed.
pub fn resolve(
    ctx: &TaskContext<'_>,
    cfg: &SweepConfig<SpeedSpec>,
) -> Result<Resolution<SweepConfig>, TaskError> {
    Ok(resolve_speeds(&ctx.plant, &ctx.limits, cfg)?)
}

/// Builds the [`Sweep`] of `cfg` (read from `file`, its speeds resolved): loads the fleet's
/// vehicle files (errors name the file and key), checks the resolved config and every
/// vehicle the axes and samples can build.
///
/// # Errors
/// [`TaskError::Read`] / [`TaskError::Config`].
pub fn prepare_sweep(
    ctx: &TaskContext<'_>,
    cfg: &SweepConfig,
    file: &Path,
) -> Result<Sweep, TaskError> {
    let fleet = fleet_paths(cfg, file)
        .iter()
        .map(|p| load_vehicle(p).map(|(v, _)| v))
        .collect::<Result<Vec<_>, _>>()?;
    let vehicles = if fleet.is_empty() {
        vec![ctx.vehicle]
    } else {
        fleet.clone()
    };
    cfg.validate_vehicles(file, &vehicles)?;
    Ok(Sweep::new(&ctx.vehicle, &fleet, cfg)?
        .with_limits(ctx.limits)
        .with_vehicle_spec(&ctx.spec)?)
}

/// The kind's result columns (the field names of its output).
fn kind_columns(kind: PointKind) -> Vec<String> {
    fn names(v: &impl Serialize) -> Vec<String> {
        row_cells(v).map(|(n, _)| n).unwrap_or_default()
    }
    match kind {
        PointKind::Simulation => names(&empty_metrics()),
        PointKind::LinearCriticalSpeed => names(&sway_studies::sweep::LinearCriticalSpeed {
            v_crit_mps: None,
            hopf_omega_rad_s: None,
            hopf_frequency_hz: None,
        }),
        PointKind::HopfFoldSpeeds => names(&sway_studies::sweep::HopfFoldSpeeds {
            hopf_v_mps: None,
            hopf_omega_rad_s: None,
            criticality: None,
            fold_v_mps: None,
            fold_amplitude_deg: None,
            reason: None,
        }),
    }
}

fn empty_metrics() -> Metrics {
    Metrics {
        peak_theta_deg_after_action: None,
        final_amplitude_deg: None,
        settle_time_s: None,
        outcome: Outcome::Ok,
        loss_of_control_time_s: None,
        loss_of_control_condition: None,
        class: SwayClass::Failed,
        decay_rate_per_s: None,
    }
}

/// The header of `sweep.csv`: one column per axis (named by its parameter), the sampled
/// fields' key paths, the kind's result fields (a simulation: the field names of
/// [`Metrics`]), `accepted_steps`, `error`.
pub fn header(cfg: &SweepConfig) -> Vec<String> {
    let mut h: Vec<String> = cfg
        .axes
        .iter()
        .map(|a| a.parameter.as_str().to_string())
        .collect();
    h.extend(cfg.sampling.iter().flat_map(|s| s.fields.iter().map(|f| f.key.clone())));
    h.extend(kind_columns(cfg.kind));
    h.extend(["accepted_steps".to_string(), "error".to_string()]);
    h
}

/// The cells of one grid point's row, in the order of [`header`]: a fleet axis writes the
/// vehicle file; a failed point writes `outcome = "error"`, `class = "failed"` (simulations)
/// and its message.
fn cells(cfg: &SweepConfig, r: &PointResult) -> Vec<String> {
    let mut row: Vec<String> = r
        .values
        .iter()
        .enumerate()
        .map(|(i, &v)| match cfg.axes.get(i) {
            Some(a) if a.parameter == AxisParameter::VehicleFile => a
                .files
                .get(v as usize)
                .map(|f| f.display().to_string())
                .unwrap_or_default(),
            _ => crate::io::fmt_num(v),
        })
        .collect();
    let out = match &r.output {
        Ok(PointOutput::Simulation(m)) => row_cells(m),
        Ok(PointOutput::LinearCriticalSpeed(l)) => row_cells(l),
        Ok(PointOutput::HopfFoldSpeeds(h)) => row_cells(h),
        Ok(_) | Err(_) => Ok((Vec::new(), Vec::new())),
    };
    match (&r.output, out) {
        (Ok(_), Ok((_, c))) if !c.is_empty() => {
            row.extend(c);
            row.extend([r.steps.to_string(), String::new()]);
        }
        (output, _) => {
            row.extend(kind_columns(cfg.kind).iter().map(|name| match name.as_str() {
                "outcome" => "error".to_string(),
                "class" => SwayClass::Failed.as_str().to_string(),
                _ => String::new(),
            }));
            let msg = match output {
                Err(e) => e.replace(['\n', '\r'], " "),
                Ok(_) => "unexpected point output".into(),
            };
            row.extend(["0".to_string(), msg]);
        }
    }
    row
}

/// One CSV row (its cells as a sequence).
struct Row(Vec<String>);

impl Serialize for Row {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

/// `summary.json` of a sweep (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepSummary {
    /// grid points (× samples)
    pub points: usize,
    /// what each point evaluated
    pub kind: PointKind,
    /// points that ran to the horizon (simulations) or were computed (other kinds)
    pub points_ok: usize,
    /// points that lost control
    pub points_loss_of_control: usize,
    /// points whose run failed
    pub points_failed: usize,
    /// points whose final amplitude (max |θ| over the final window) is at least the settle
    /// threshold (whatever their class)
    pub points_with_sway: usize,
    /// that threshold \[deg\]
    pub sway_threshold_deg: f64,
    /// points per class (simulations)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_by_class: Option<Keyed<usize>>,
    /// with a speed axis: the lowest speed with a point in sustained sway \[m/s\]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lowest_sustained_sway_speed_mps: Option<f64>,
    /// with 2 or more axes: the heat map's axes and the threshold line
    #[serde(flatten)]
    pub heatmap: Option<HeatmapSummary>,
    /// a threshold map: the bisected threshold against the bifurcation diagram
    #[serde(skip_serializing_if = "Option::is_none")]
    pub separatrix: Option<SeparatrixSummary>,
    /// the results' statistics (linear and bifurcation kinds; with `[sampling]` per grid
    /// point): per quantity, quantiles, mean, sd
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distributions: Option<Distributions>,
}

fn is_sim_ok(r: &PointResult, o: Outcome) -> bool {
    r.metrics().is_some_and(|m| m.outcome == o)
}

/// The counts of the summary.
fn counts(cfg: &SweepConfig, grid: &[PointResult]) -> SweepSummary {
    let thr = cfg.base.settings.metrics.settle_threshold_deg.get();
    let sim = cfg.kind == PointKind::Simulation;
    let n_ok = if sim {
        grid.iter().filter(|r| is_sim_ok(r, Outcome::Ok)).count()
    } else {
        grid.iter().filter(|r| r.output.is_ok()).count()
    };
    let by_class = sim.then(|| {
        Keyed(
            SwayClass::ALL
                .iter()
                .map(|c| {
                    let n = grid
                        .iter()
                        .filter(|r| r.metrics().map_or(SwayClass::Failed, |m| m.class) == *c)
                        .count();
                    (c.as_str().to_string(), n)
                })
                .collect(),
        )
    });
    let speed_axis = cfg
        .axes
        .iter()
        .position(|a| a.parameter.as_str() == "speed_mps");
    let lowest = speed_axis.and_then(|i| {
        grid.iter()
            .filter(|r| r.metrics().is_some_and(|m| m.class == SwayClass::SustainedSway))
            .map(|r| r.values[i])
            .min_by(f64::total_cmp)
    });
    SweepSummary {
        points: grid.len(),
        kind: cfg.kind,
        points_ok: n_ok,
        points_loss_of_control: grid
            .iter()
            .filter(|r| is_sim_ok(r, Outcome::LossOfControl))
            .count(),
        points_failed: grid.iter().filter(|r| r.output.is_err()).count(),
        points_with_sway: grid
            .iter()
            .filter(|r| {
                r.metrics()
                    .is_some_and(|m| m.final_amplitude_deg.is_some_and(|a| a >= thr))
            })
            .count(),
        sway_threshold_deg: thr,
        points_by_class: by_class,
        lowest_sustained_sway_speed_mps: lowest,
        heatmap: None,
        separatrix: None,
        distributions: None,
    }
}

/// Writes `sweep.csv`, `summary.json` and the figures of a sweep from the ordered full list
/// of its point results (`results.len()` = the sweep's number of points: grid points, then
/// threshold points, then the reference) into `out`, and commits it. Everything written is
/// derived from `results`, `cfg` and the context's vehicle, except `wall_time_s`; this is
/// the one writer of a sweep, used by a run and by a merge of shards.
///
/// # Errors
/// [`TaskError::Write`] / [`TaskError::Plot`]; [`TaskError::Config`] if `results` does not
/// have the sweep's number of points.
pub fn write_sweep_outputs(
    ctx: &TaskContext<'_>,
    spec: &SweepConfig<SpeedSpec>,
    resolution: &Resolution<SweepConfig>,
    file: &Path,
    results: &[PointResult],
    out: OutputDir,
) -> Result<Report, TaskError> {
    let cfg = match &resolution.outcome {
        Ok(c) => c,
        Err(u) => {
            drop(out);
            return nothing_to_show(
                ctx,
                &spec.name,
                "no study for this vehicle",
                u,
                &resolution.references,
                spec,
                file,
            );
        }
    };
    let grid_len = cfg.grid_len();
    if results.len() < grid_len {
        return Err(TaskError::config(
            file,
            "axes",
            format!(
                "{} point results for a sweep of {grid_len} grid points",
                results.len()
            ),
        ));
    }
    let (grid, extra) = results.split_at(grid_len);
    let rows = grid.iter().map(|r| Row(cells(cfg, r)));
    out.write_rows("sweep.csv", &header(cfg), rows)?;

    let mut summary = counts(cfg, grid);
    let mut lines = vec![summary_line(cfg, &summary)];
    if let Some((heatmap, line)) = study::heatmap(&out, cfg, grid, extra)? {
        summary.heatmap = Some(heatmap);
        lines.extend(line);
    }
    if let Some((sep, sep_lines)) = study::separatrix(cfg, grid, extra) {
        summary.separatrix = Some(sep);
        lines.extend(sep_lines);
    }
    if let Some((dist, dist_lines)) = study::distributions(&out, cfg, grid)? {
        summary.distributions = Some(dist);
        lines.extend(dist_lines);
    }
    if cfg.axes.len() == 1 && cfg.sampling.is_none() && cfg.kind != PointKind::Simulation {
        study::line_figure(&out, cfg, grid)?;
    }
    let summary = WithSpeeds {
        headline: summary,
        resolved_speeds: resolution.speeds.clone(),
    };
    ctx.conclude(out, summary, spec, file, lines)
}

fn summary_line(cfg: &SweepConfig, s: &SweepSummary) -> String {
    match &s.points_by_class {
        Some(by) => {
            let classes: Vec<String> = by.0.iter().map(|(c, n)| format!("{n} {c}")).collect();
            format!(
                "{}: {} points: {}",
                cfg.name,
                s.points,
                classes.join(", ")
            )
        }
        None => format!(
            "{}: {} points of {}: {} ok, {} failed",
            cfg.name,
            s.points,
            cfg.kind.as_str(),
            s.points_ok,
            s.points_failed
        ),
    }
}

/// Seconds per point of the non-simulation kinds (release, one core): V_crit by scan and
/// bisection ≈ 1e-4 s (benches/study.rs), a bifurcation diagram with its corrections ≈ 2 s.
fn seconds_per_point(kind: PointKind) -> f64 {
    match kind {
        PointKind::Simulation => 0.0,
        PointKind::LinearCriticalSpeed => 2e-4,
        PointKind::HopfFoldSpeeds => 2.0,
    }
}

impl Prepared for Configured<SweepConfig<SpeedSpec>> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let file = self.file.as_path();
        for (i, a) in c.axes.iter().enumerate() {
            bound(
                file,
                &format!("axes[{i}].points"),
                a.len() as f64,
                MAX_AXIS_POINTS as f64,
                || format!("{} points on this axis alone", a.len()),
            )?;
        }
        let samples = c.sampling.as_ref().map_or(1.0, |s| s.samples as f64);
        let points = c.axes.iter().map(|a| a.len() as f64).product::<f64>() * samples;
        let settle = c.base.initial.settle_s();
        bound(file, "base.initial.settle_s", settle, MAX_SIMULATED_S, || {
            format!("{} per simulation", human_seconds(settle * SWEEP_SECONDS_PER_SIM_SECOND))
        })?;
        let horizon = c.base.horizon_s.get();
        bound(file, "base.horizon_s", horizon, MAX_SIMULATED_S, || {
            format!("{} per simulation", human_seconds(horizon * SWEEP_SECONDS_PER_SIM_SECOND))
        })?;
        if let Some(t) = &c.threshold {
            let h = t.horizon_s.get() * 2f64.powi(t.max_doublings as i32 + 1);
            bound(file, "threshold.horizon_s", h, MAX_SIMULATED_S, || {
                format!(
                    "× 2^(max_doublings + 1), the longest check: {} per simulation",
                    human_seconds(h * SWEEP_SECONDS_PER_SIM_SECOND)
                )
            })?;
        }
        let per_point = if c.kind == PointKind::Simulation {
            (horizon + settle) * SWEEP_SECONDS_PER_SIM_SECOND
        } else {
            seconds_per_point(c.kind)
        };
        // a threshold point: its column and ≈ 12 bisection steps at its horizon, 2 checks at twice it
        let threshold_s = c.threshold.as_ref().map_or(0.0, |t| {
            let n_y = c.axes.get(1).map_or(0, |a| a.len()) as f64;
            let n_x = c.axes.first().map_or(0, |a| a.len()) as f64;
            n_x * (n_y + 16.0) * t.horizon_s.get() * SWEEP_SECONDS_PER_SIM_SECOND + 5.0
        });
        let plan = Plan::new(
            vec![format!(
                "{}: {} axes, {points} points of {}{}",
                c.name,
                c.axes.len(),
                c.kind.as_str(),
                if c.threshold.is_some() { " + θ(0) threshold bisection per speed" } else { "" }
            )],
            points * BYTES_PER_ROW,
            (points * per_point + threshold_s) / 2.0, // rayon on 2 cores
        );
        plan.within(file, "axes", points, MAX_SIMULATIONS, || {
            format!("product of the axis points × samples = {points} points")
        })
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let spec = &self.config;
        if let Some(e) = inapplicable_field(ctx, spec) {
            let stage = format!("{}: not applicable", spec.name);
            return ctx.run_staged::<(), _>(&spec.name, &stage, 0, spec, &self.file, |_| Err(e));
        }
        let run = prepare_run(ctx, spec, &self.file)?;
        // staged before the points run: an interrupted sweep leaves its staging directory
        // to be removed (by the signal handler or the next run), never a half-written result
        let out = OutputDir::create(&ctx.results_dir, &spec.name)?;
        let results = match &run.sweep {
            Some(sweep) => run_sweep(sweep, ctx.progress),
            None => Vec::new(),
        };
        write_sweep_outputs(ctx, spec, &run.resolution, &self.file, &results, out)
    }
}

/// The first vehicle field the sweep varies that the vehicle does not have (a trailer key
/// of a chain of towed units), as [`TaskError::NotApplicable`] naming the config key.
fn inapplicable_field(ctx: &TaskContext<'_>, spec: &SweepConfig<SpeedSpec>) -> Option<TaskError> {
    if !ctx.spec.is_chain() {
        return None;
    }
    spec.vehicle_fields().into_iter().find_map(|(key, field)| {
        let value = field.get(&ctx.vehicle);
        ctx.spec
            .with_parameter(field.index(), value)
            .err()
            .map(|e| TaskError::NotApplicable {
                key,
                reason: format!("the sweep varies `{}`: {e}", field.key()),
            })
    })
}

/// A sweep ready to run: its speeds resolved for the vehicle and, when they resolved, the
/// [`Sweep`] of its points.
#[derive(Debug)]
pub struct SweepRun {
    /// the config with numbers, or why it has none for this vehicle
    pub resolution: Resolution<SweepConfig>,
    /// the points (None when the speeds do not resolve: no points)
    pub sweep: Option<Sweep>,
}

impl SweepRun {
    /// The number of points (0 when the speeds do not resolve).
    pub fn len(&self) -> usize {
        self.sweep.as_ref().map_or(0, Sweep::len)
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point `k` (see [`Sweep::run_point`]).
    pub fn run_point(&self, k: usize) -> PointResult {
        match &self.sweep {
            Some(s) => s.run_point(k),
            None => PointResult {
                values: Vec::new(),
                output: Err("the sweep's speeds do not resolve for this vehicle".into()),
                steps: 0,
            },
        }
    }
}

/// Resolves the speeds of `spec` for the context's vehicle and, when they resolve, checks
/// the resolved config and builds its [`Sweep`] ([`prepare_sweep`]).
///
/// # Errors
/// Config errors naming the key (with the resolved speeds), read errors of a fleet.
pub fn prepare_run(
    ctx: &TaskContext<'_>,
    spec: &SweepConfig<SpeedSpec>,
    file: &Path,
) -> Result<SweepRun, TaskError> {
    let resolution = resolve(ctx, spec)?;
    let sweep = match &resolution.outcome {
        Ok(cfg) => {
            resolved_check(check_resolved(cfg, file), &resolution.speeds)?;
            Some(prepare_sweep(ctx, cfg, file)?)
        }
        Err(_) => None,
    };
    Ok(SweepRun { resolution, sweep })
}
