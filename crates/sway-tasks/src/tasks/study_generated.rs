//! `cargo xtask study_generated`: generated car–trailer combinations with random model
//! variant mixes ([`sway_model::generator`]: relaxation, Magic Formula tyres, tandem trailer
//! axles, hitch damping and friction) through every task that takes the vehicle, exactly as
//! `cargo xtask <task> --vehicle FILE` runs them (issue 52: every valid vehicle file gets a
//! physical outcome from every task; a curve that cannot go on is a result with its `end`).
//!
//! Not part of `cargo xtask all` (it runs the other tasks many times over). The tasks run
//! with the configs of `configs_dir` (default: the shipped configs, the tasks' default
//! settings), each vehicle's results in a scratch directory that is removed afterwards.
//!
//! Outputs: `summary.json` (vehicles, runs, failures with their messages, the curves that
//! ended early by reason, per-task tallies and the variant counts), `runs.csv` (one row per
//! vehicle × task) and `table.md` (the README's table).

use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;
use sway::progress::NoProgress;
use sway_model::generator::{GeneratedVehicle, generate};

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig};
use crate::plot::{Figure, Layer, Panel, Rgb};

/// The task.
pub const TASK: Task = Task::configured::<StudyGeneratedConfig>(
    "study_generated",
    "generated car–trailer combinations with random variant mixes through every task: runs, failures, curves ended early by reason (not part of `all`)",
    "study_generated.toml",
)
.any_model()
.on_demand();

/// The tasks that take the vehicle of `--vehicle` (`fleet`, `study_fleet` and `variants`
/// run vehicle files of their own, this study itself is not run on its vehicles).
pub const VEHICLE_TASKS: [&str; 17] = [
    "linear",
    "loading",
    "fig3a",
    "fig3b",
    "fig4a",
    "fig4b",
    "fig4c",
    "chart_nonlinear",
    "corners",
    "gain_design",
    "control_design",
    "simulate",
    "mitigation",
    "sweep",
    "brake_timing",
    "study_uncertainty",
    "lateral_stability",
];

/// `configs/study_generated.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyGeneratedConfig {
    /// seed of the generator (ChaCha8)
    pub seed: u64,
    /// number of generated vehicles
    pub count: usize,
    /// the tasks run on every vehicle (default: [`VEHICLE_TASKS`])
    #[serde(default = "default_tasks")]
    pub tasks: Vec<String>,
    /// directory of the tasks' configs, relative to this file (default: the configs
    /// directory of the run, the tasks' default settings)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub configs_dir: Option<PathBuf>,
}

fn default_tasks() -> Vec<String> {
    VEHICLE_TASKS.iter().map(|s| s.to_string()).collect()
}

impl TaskConfig for StudyGeneratedConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        if !(1..=10_000).contains(&self.count) {
            return Err(TaskError::config(
                file,
                "count",
                format!("expected 1 to 10000 vehicles, got {}", self.count),
            ));
        }
        if self.tasks.is_empty() {
            return Err(TaskError::config(file, "tasks", "expected at least one task"));
        }
        let reg = super::registry();
        for (i, t) in self.tasks.iter().enumerate() {
            if t == TASK.name || !reg.iter().any(|r| r.name == t) {
                return Err(TaskError::config(
                    file,
                    format!("tasks[{i}]"),
                    format!("expected a task of the registry other than {}, got {t:?}", TASK.name),
                ));
            }
        }
        Ok(())
    }
}

/// A curve that ended before its range, as a task's `summary.json` reports it under
/// `curves_ended_early`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EndedCurve {
    /// which curve (the task's words)
    pub curve: String,
    /// the `reason` of its `end`
    pub reason: String,
}

/// One run of one task on one vehicle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Run {
    /// the vehicle's name (`generated-<index>`)
    pub vehicle: String,
    /// its variants, `+`-joined (`paper` for none)
    pub variants: String,
    /// the task
    pub task: String,
    /// None: exited 0 with a summary; else the error (or panic) message
    pub error: Option<String>,
    /// the curves its summary reports as ended early
    pub ended_early: Vec<EndedCurve>,
    /// the speeds its summary reports at the speed cap without `stable_up_to_mps`
    /// ([`crate::io::speeds_at_cap`]; a capped value reported as a measured one): JSON paths
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub speeds_at_cap: Vec<String>,
    /// wall time of the run \[s\] (not in `runs.csv`: it varies from run to run)
    pub seconds: f64,
}

/// One row of `runs.csv`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct RunRow {
    /// vehicle name
    pub vehicle: String,
    /// its variants
    pub variants: String,
    /// task
    pub task: String,
    /// `ok` or `failed`
    pub outcome: String,
    /// curves ended early, `reason×count` joined by `; `
    pub ended_early: String,
    /// the error of a failed run
    pub error: String,
}

/// The tally of one task.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct TaskTally {
    /// task
    pub task: String,
    /// runs
    pub runs: usize,
    /// runs that failed
    pub failures: usize,
    /// curves ended early in its runs
    pub curves_ended_early: usize,
    /// wall time of its runs together \[s\] (one vehicle at a time on the whole machine)
    pub seconds: f64,
}

/// `summary.json` of the study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyGeneratedSummary {
    /// generated vehicles
    pub vehicles: usize,
    /// how many vehicles have each variant (`paper`: none)
    pub variant_counts: BTreeMap<String, usize>,
    /// task runs (vehicles × tasks)
    pub runs: usize,
    /// runs that did not exit 0 with a summary (target 0)
    pub failures: usize,
    /// curves that ended early (in runs that succeeded), by the reason of their end
    pub curves_ended_early_by_reason: BTreeMap<String, usize>,
    /// per task
    pub per_task: Vec<TaskTally>,
    /// the failed runs with their messages
    pub failed_runs: Vec<Run>,
}

/// Every `curves_ended_early` array of a task's summary, with the reasons of their ends.
pub fn ended_early(summary: &Value) -> Vec<EndedCurve> {
    fn walk(v: &Value, out: &mut Vec<EndedCurve>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    match (k.as_str(), x) {
                        ("curves_ended_early", Value::Array(a)) => {
                            out.extend(a.iter().map(|e| EndedCurve {
                                curve: e["curve"].as_str().unwrap_or("").to_string(),
                                reason: e["end"]["reason"]
                                    .as_str()
                                    .or_else(|| e["reason"].as_str())
                                    .unwrap_or("unknown")
                                    .to_string(),
                            }));
                        }
                        _ => walk(x, out),
                    }
                }
            }
            Value::Array(a) => a.iter().for_each(|x| walk(x, out)),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(summary, &mut out);
    out
}

/// Runs `task` on the vehicle file `vehicle` with the configs of `configs`, results into
/// `results`: None on success with the curves its summary reports as ended early, else the
/// error (a panic is a failure too).
fn run_one(
    task: &str,
    vehicle: &Path,
    configs: &Path,
    results: &Path,
    limits: sway::ranging::SpeedLimits,
) -> Result<(Vec<EndedCurve>, Vec<String>), String> {
    let progress = NoProgress;
    let body = || -> Result<(Vec<EndedCurve>, Vec<String>), String> {
        let ctx = TaskContext::new(vehicle, configs, results, &progress)
            .map_err(|e| e.to_string())?
            .with_limits(limits);
        let t = super::resolve(task).map_err(|e| e.to_string())?;
        let t = t.first().ok_or_else(|| format!("no task {task}"))?;
        let file = configs.join(t.config);
        let (prepared, _plan) = super::prepare_checked(t, &ctx, &file).map_err(|e| e.to_string())?;
        let report = prepared.run(&ctx).map_err(|e| e.to_string())?;
        let summary = report.output_dir.join("summary.json");
        let text = std::fs::read_to_string(&summary).map_err(|e| e.to_string())?;
        let value: Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
        Ok((
            ended_early(&value),
            crate::io::speeds_at_cap(&value, limits.max_speed_mps),
        ))
    };
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(r) => r,
        Err(p) => {
            // a cancellation stops the study, it is not this run's failure
            let p = cancel::resume_if_cancelled(p);
            Err(format!(
                "panic: {}",
                p.downcast_ref::<String>()
                    .map(String::as_str)
                    .or_else(|| p.downcast_ref::<&str>().copied())
                    .unwrap_or("(no message)")
            ))
        }
    }
}

/// Runs `tasks` on one vehicle, its file and results in `scratch/<name>/` (removed after
/// its runs). A vehicle file that cannot be written fails every run of the vehicle with the
/// write error (the study goes on).
pub fn run_vehicle(
    vehicle: &GeneratedVehicle,
    tasks: &[String],
    configs: &Path,
    scratch: &Path,
    limits: sway::ranging::SpeedLimits,
) -> Vec<Run> {
    let dir = scratch.join(&vehicle.name);
    let variants = vehicle.variants.names().join("+");
    let written = write_vehicle(vehicle, &dir);
    let runs = tasks
        .iter()
        .map(|t| {
            let start = std::time::Instant::now();
            let r = match &written {
                Ok(file) => run_one(t, file, configs, &dir.join("results"), limits),
                Err(e) => Err(e.to_string()),
            };
            Run {
                seconds: start.elapsed().as_secs_f64(),
                vehicle: vehicle.name.clone(),
                variants: variants.clone(),
                task: t.clone(),
                ended_early: r.as_ref().map_or(Vec::new(), |r| r.0.clone()),
                speeds_at_cap: r.as_ref().map_or(Vec::new(), |r| r.1.clone()),
                error: r.err(),
            }
        })
        .collect();
    // the scratch results are not kept (a failed removal leaves files, no error)
    let _ = std::fs::remove_dir_all(&dir);
    runs
}

/// Writes the vehicle's file `dir/<name>.toml`.
fn write_vehicle(v: &GeneratedVehicle, dir: &Path) -> Result<PathBuf, TaskError> {
    let write = |path: PathBuf, source| TaskError::Write { path, source };
    std::fs::create_dir_all(dir).map_err(|e| write(dir.to_path_buf(), e))?;
    let file = dir.join(format!("{}.toml", v.name));
    let text = toml::to_string(&v.spec)
        .map_err(|e| write(file.clone(), std::io::Error::other(e.to_string())))?;
    std::fs::write(&file, text).map_err(|e| write(file.clone(), e))?;
    Ok(file)
}

/// Runs `tasks` on every vehicle, one vehicle after another (each task parallelises
/// inside itself; vehicles side by side, a worker waiting inside one vehicle's parallel
/// loop would steal a whole other vehicle), results in vehicle order ([`run_vehicle`]),
/// calling `advance` after each vehicle.
pub fn run_all(
    vehicles: &[GeneratedVehicle],
    tasks: &[String],
    configs: &Path,
    scratch: &Path,
    limits: sway::ranging::SpeedLimits,
    advance: &(dyn Fn() + Sync),
) -> Vec<Run> {
    vehicles
        .iter()
        .flat_map(|v| {
            let runs = run_vehicle(v, tasks, configs, scratch, limits);
            advance();
            runs
        })
        .collect()
}

/// The summary of `runs` on `vehicles`.
pub fn summarise(vehicles: &[GeneratedVehicle], tasks: &[String], runs: &[Run]) -> StudyGeneratedSummary {
    let mut variant_counts = BTreeMap::new();
    for v in vehicles {
        for n in v.variants.names() {
            *variant_counts.entry(n.to_string()).or_insert(0) += 1;
        }
    }
    let mut by_reason = BTreeMap::new();
    for e in runs.iter().flat_map(|r| &r.ended_early) {
        *by_reason.entry(e.reason.clone()).or_insert(0) += 1;
    }
    let per_task = tasks
        .iter()
        .map(|t| {
            let mine: Vec<&Run> = runs.iter().filter(|r| &r.task == t).collect();
            TaskTally {
                task: t.clone(),
                runs: mine.len(),
                failures: mine.iter().filter(|r| r.error.is_some()).count(),
                curves_ended_early: mine.iter().map(|r| r.ended_early.len()).sum(),
                seconds: mine.iter().map(|r| r.seconds).sum(),
            }
        })
        .collect();
    let failed_runs: Vec<Run> = runs.iter().filter(|r| r.error.is_some()).cloned().collect();
    StudyGeneratedSummary {
        vehicles: vehicles.len(),
        variant_counts,
        runs: runs.len(),
        failures: failed_runs.len(),
        curves_ended_early_by_reason: by_reason,
        per_task,
        failed_runs,
    }
}

/// The markdown table of the README: per task the runs, failures and curves ended early,
/// then the reasons.
pub fn markdown(s: &StudyGeneratedSummary) -> String {
    let mut m = String::from(
        "| task | runs | failures | curves ended early | time [s] |\n|---|---|---|---|---|\n",
    );
    for t in &s.per_task {
        m.push_str(&format!(
            "| `{}` | {} | {} | {} | {:.0} |\n",
            t.task, t.runs, t.failures, t.curves_ended_early, t.seconds
        ));
    }
    let ended: usize = s.curves_ended_early_by_reason.values().sum();
    let seconds: f64 = s.per_task.iter().map(|t| t.seconds).sum();
    m.push_str(&format!(
        "| **all** | **{}** | **{}** | **{ended}** | **{seconds:.0}** |\n",
        s.runs, s.failures
    ));
    if !s.curves_ended_early_by_reason.is_empty() {
        let reasons: Vec<String> = s
            .curves_ended_early_by_reason
            .iter()
            .map(|(r, n)| format!("{r}: {n}"))
            .collect();
        m.push_str(&format!("\nCurves ended early by reason: {}.\n", reasons.join(", ")));
    }
    m
}

/// The study's figure: per task, its runs as a horizontal bar split into runs without an
/// early curve end (green), runs with curves that ended early (orange) and failed runs
/// (red); beside it the curves that ended early by reason.
pub fn figure(s: &StudyGeneratedSummary, runs: &[Run]) -> Figure {
    let bar = |y: f64, x0: f64, x1: f64| [x0, x1, y - 0.38, y + 0.38];
    let (mut clean, mut early, mut failed) = (Vec::new(), Vec::new(), Vec::new());
    for (k, t) in s.per_task.iter().enumerate() {
        let y = -(k as f64);
        let mine = runs.iter().filter(|r| r.task == t.task);
        let n_failed = mine.clone().filter(|r| r.error.is_some()).count() as f64;
        let n_early = mine
            .filter(|r| r.error.is_none() && !r.ended_early.is_empty())
            .count() as f64;
        let n_clean = t.runs as f64 - n_failed - n_early;
        clean.push(bar(y, 0.0, n_clean));
        early.push(bar(y, n_clean, n_clean + n_early));
        failed.push(bar(y, n_clean + n_early, t.runs as f64));
    }
    let rects = |rects, color, label: &str| Layer::Rects {
        rects,
        color,
        opacity: 0.8,
        label: Some(label.to_string()),
    };
    let by_task = Panel::new(
        &format!("{} generated vehicles: runs per task", s.vehicles),
        "runs",
        "task",
    )
    .with(rects(clean, Rgb::GREEN, "no curve ended early"))
    .with(rects(early, Rgb::ORANGE, "curves ended early (a result)"))
    .with(rects(failed, Rgb::RED, "failed"))
    .x_range(0.0, 1.45 * s.vehicles.max(1) as f64)
    .y_categories(s.per_task.iter().map(|t| t.task.clone()).collect());
    let reasons: Vec<(&String, &usize)> = s.curves_ended_early_by_reason.iter().collect();
    let most = reasons.iter().map(|(_, n)| **n).max().unwrap_or(1) as f64;
    let by_reason = Panel::new("curves that ended early, by reason", "curves", "reason")
        .with(rects(
            reasons
                .iter()
                .enumerate()
                .map(|(k, (_, n))| bar(-(k as f64), 0.0, **n as f64))
                .collect(),
            Rgb::ORANGE,
            "curves",
        ))
        .x_range(0.0, 1.45 * most)
        .y_categories(reasons.iter().map(|(r, _)| (*r).clone()).collect());
    Figure::grid(vec![by_task, by_reason], 1, 2, (1500, 40 * s.per_task.len().max(8) as u32 + 200))
}

fn csv_row(r: &Run) -> RunRow {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for e in &r.ended_early {
        *counts.entry(e.reason.as_str()).or_insert(0) += 1;
    }
    RunRow {
        vehicle: r.vehicle.clone(),
        variants: r.variants.clone(),
        task: r.task.clone(),
        outcome: if r.error.is_some() { "failed" } else { "ok" }.into(),
        ended_early: counts
            .iter()
            .map(|(k, n)| format!("{k}×{n}"))
            .collect::<Vec<_>>()
            .join("; "),
        error: r.error.clone().unwrap_or_default(),
    }
}

/// The configs directory of the study: `configs_dir` relative to the config file, else
/// the run's.
fn configs_of(cfg: &StudyGeneratedConfig, file: &Path, ctx: &TaskContext<'_>) -> PathBuf {
    match &cfg.configs_dir {
        Some(d) => file.parent().unwrap_or(Path::new(".")).join(d),
        None => ctx.configs_dir.clone(),
    }
}

/// The scratch directory of this process's vehicles.
fn scratch_of(ctx: &TaskContext<'_>) -> PathBuf {
    ctx.results_dir
        .join(format!(".{}-scratch-{}", TASK.name, std::process::id()))
}

/// Writes `runs.csv`, the figure and `table.md` into `out` and returns the summary and the
/// console lines: the same for a run on one machine and a merge of shards.
fn write_study(
    out: &crate::io::OutputDir,
    vehicles: &[GeneratedVehicle],
    tasks: &[String],
    runs: &[Run],
) -> Result<(StudyGeneratedSummary, Vec<String>), TaskError> {
    let summary = summarise(vehicles, tasks, runs);
    out.write_table("runs.csv", runs.iter().map(csv_row))?;
    figure(&summary, runs).render(&out.path("study_generated"))?;
    let md = markdown(&summary);
    std::fs::write(out.path("table.md"), &md).map_err(|source| TaskError::Write {
        path: out.path("table.md"),
        source,
    })?;
    let ended: usize = summary.curves_ended_early_by_reason.values().sum();
    let mut lines = vec![format!(
        "{} vehicles × {} tasks: {} runs, {} failed, {ended} curves ended early {:?}",
        summary.vehicles,
        tasks.len(),
        summary.runs,
        summary.failures,
        summary.curves_ended_early_by_reason
    )];
    lines.extend(summary.failed_runs.iter().map(|r| {
        format!(
            "failed: {} ({}) {}: {}",
            r.vehicle,
            r.variants,
            r.task,
            r.error.as_deref().unwrap_or("")
        )
    }));
    Ok((summary, lines))
}

const STAGE: &str = "study_generated: generated vehicles through every task";

impl Prepared for Configured<StudyGeneratedConfig> {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let configs = configs_of(cfg, &self.file, ctx);
        let vehicles = generate(cfg.seed, cfg.count);
        let scratch = scratch_of(ctx);
        ctx.run_staged(TASK.name, STAGE, vehicles.len() as u64, cfg, &self.file, |out| {
            let advance = || ctx.progress.advance(1);
            let runs = run_all(&vehicles, &cfg.tasks, &configs, &scratch, ctx.limits, &advance);
            let _ = std::fs::remove_dir_all(&scratch);
            write_study(out, &vehicles, &cfg.tasks, &runs)
        })
    }
}

/// What the points of the sharded study need (the shards' `GeneratedVehicles`): point k
/// is generated vehicle k through every task.
#[derive(Debug)]
pub struct GeneratedPoints {
    vehicles: Vec<GeneratedVehicle>,
    tasks: Vec<String>,
    configs: PathBuf,
    scratch: PathBuf,
    limits: sway::ranging::SpeedLimits,
}

impl GeneratedPoints {
    /// The points of `config` (read from `file`) in the run `ctx`.
    pub fn new(ctx: &TaskContext<'_>, config: &StudyGeneratedConfig, file: &Path) -> Self {
        Self {
            vehicles: generate(config.seed, config.count),
            tasks: config.tasks.clone(),
            configs: configs_of(config, file, ctx),
            scratch: scratch_of(ctx),
            limits: ctx.limits,
        }
    }

    /// The number of vehicles.
    pub fn len(&self) -> usize {
        self.vehicles.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.vehicles.is_empty()
    }

    /// Vehicle `k` through every task ([`run_vehicle`]).
    pub fn run(&self, k: usize) -> Vec<Run> {
        run_vehicle(
            &self.vehicles[k],
            &self.tasks,
            &self.configs,
            &self.scratch,
            self.limits,
        )
    }
}

impl Drop for GeneratedPoints {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.scratch);
    }
}

/// Writes the study's outputs from the runs of every vehicle, in vehicle order, and
/// commits them: what a merge of shards writes.
///
/// # Errors
/// Write errors.
pub fn write_outputs(
    ctx: &TaskContext<'_>,
    out: crate::io::OutputDir,
    config_file: &Path,
    config: &StudyGeneratedConfig,
    per_vehicle: &[Vec<Run>],
) -> Result<Report, TaskError> {
    let vehicles = generate(config.seed, config.count);
    let runs: Vec<Run> = per_vehicle.iter().flatten().cloned().collect();
    let (summary, lines) = write_study(&out, &vehicles, &config.tasks, &runs)?;
    ctx.conclude(out, summary, config, config_file, lines)
}
