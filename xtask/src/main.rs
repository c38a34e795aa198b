//! `cargo xtask <task>`: the runner. It parses arguments, shows progress and prints the
//! headline numbers; every pipeline lives in the `sway` library.
//!
//! ```text
//! cargo xtask list                       # the tasks and groups
//! cargo xtask linear [--vehicle FILE] [--config FILE]
//! cargo xtask fig3 | fig4 | all          # groups of tasks
//! cargo xtask roots --speed V --gain D --delay TAU [--count N]   # rightmost characteristic roots
//! cargo xtask <task|group> --check       # validate configs, print the plan, run nothing
//! cargo xtask sweep FILE --shard K/N [--shard-dir DIR]   # the K-th of N slices (K from 1)
//! cargo xtask study_generated --shard K/N   # likewise: vehicles K-th slice through every task
//! cargo xtask sway_assist_full --shard K/N   # likewise: the K-th slice of the evaluation's runs
//! cargo xtask merge DIR [--results DIR]  # the shards of DIR → results/<name>/
//! cargo xtask slurm FILE --shards N [--partition P] [--time T]   # sbatch scripts
//! ```
//!
//! A sweep runs sharded as N independent processes ([`sway_tasks::shard`]): each writes
//! `shard-K-of-N.json` into the shard directory (default `results/<name>.shards/`), and
//! `merge` writes the same `results/<name>/` as one unsharded run. `slurm` writes a job
//! array of the shards and a dependent merge job ([`slurm`]).
//!
//! `--check` loads and validates the vehicle and task configs through the same path as a
//! real run ([`tasks::prepare_checked`]), prints what would run with estimates of memory
//! and time ([`sway_tasks::limits`]) and exits: 0 for valid input, 1 otherwise.
//!
//! SIGINT and SIGTERM stop a running task: the results directory is left as it was
//! (this process's staging directories removed, [`sway_tasks::io::interrupt`]) and the
//! process exits with status 130 after one line on stderr.
//!
//! The process exits from the handler instead of setting a flag that the loops poll, which
//! is safe here: `ctrlc` runs the handler on its own thread (not in signal context), and
//! every change to `results/` (each CSV, JSON and figure file, and the two renames of a
//! commit) is made under one lock that the handler takes first. So a write in progress
//! completes, later writes are refused, the staging directories are removed and the
//! process exits still holding the lock; a task's `results/<task>/` is either the previous
//! one or, if the commit completed before the signal, the new one, never a mixture.
//! `xtask/tests/interrupt.rs` sends SIGTERM (and SIGKILL) to a running task.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, mpsc};
use std::time::Instant;

mod slurm;

use anyhow::{Context, Result, bail};
use clap::Parser;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use sway::progress::Progress;
use sway_tasks::config_file;
use sway_tasks::shard::{self, ShardSpec};
use sway_tasks::tasks::{self, Task, TaskContext};

/// The repository root (this crate lives in `<root>/xtask`).
fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Options every task takes.
#[derive(Debug, Parser)]
#[command(no_binary_name = true)]
struct TaskArgs {
    /// the task's config as a positional argument (`cargo xtask simulate FILE.toml`)
    file: Option<PathBuf>,
    /// vehicle parameters (the form of configs/vehicle.toml)
    #[arg(long)]
    vehicle: Option<PathBuf>,
    /// the task's config (default: configs/TASK.toml; single tasks only)
    #[arg(long)]
    config: Option<PathBuf>,
    /// where results/TASK/ goes
    #[arg(long)]
    results: Option<PathBuf>,
    /// validate the configs and print what would run (with estimates), then exit
    #[arg(long)]
    check: bool,
    /// compute only the K-th of N slices of the points (K from 1) and write a shard file
    #[arg(long, value_name = "K/N")]
    shard: Option<ShardSpec>,
    /// where shard files go (default: RESULTS/NAME.shards/)
    #[arg(long, value_name = "DIR")]
    shard_dir: Option<PathBuf>,
    /// the highest speed of every range derived from the vehicle [m/s]: straight running
    /// stable up to here is reported as "stable up to" it
    #[arg(long, value_name = "MPS", default_value_t = sway::ranging::SpeedLimits::default().max_speed_mps)]
    max_speed: f64,
    /// lateral_stability: analyse this recorded pulse-steer run (CSV; repeat for several)
    #[arg(long, value_name = "FILE")]
    recording: Vec<PathBuf>,
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
struct Bar(ProgressBar);

impl Progress for Bar {
    fn start(&self, stage: &str, total: u64) {
        self.0.reset();
        self.0.set_length(total);
        self.0.set_position(0);
        self.0.set_message(stage.to_string());
    }
    fn advance(&self, n: u64) {
        self.0.inc(n);
    }
    fn finish(&self) {
        self.0.set_position(self.0.length().unwrap_or(0));
    }
}

fn usage() -> String {
    let mut s = String::from(
        "usage: cargo xtask <task|group> [--vehicle FILE] [--config FILE] [--results DIR] [--check]\n\ntasks:\n",
    );
    for t in tasks::registry() {
        s.push_str(&format!("  {:<10} {}\n", t.name, t.about));
    }
    s.push_str(&format!(
        "  {:<10} {}\n",
        "roots", "rightmost characteristic roots of eq. (13) at one point: --speed V --gain D --delay TAU [--count N] [--structure S] [--actuator A] [--hitch-angle-gain K] [--hitch-rate-gain D] [--prediction-vehicle FILE]"
    ));
    s.push_str(&format!(
        "  {:<10} {}\n  {:<10} {}\n",
        "merge",
        "merge the shard files of DIR into results/<name>/: cargo xtask merge DIR [--results DIR]",
        "slurm",
        "SLURM job array of a sharded study: cargo xtask slurm FILE --shards N [--task sweep|brake_timing|study_generated|sway_assist|sway_assist_full] [--partition P] [--time T]"
    ));
    s.push_str(
        "sharding: cargo xtask sweep|brake_timing|study_generated|sway_assist|sway_assist_full [--config FILE] --shard K/N [--shard-dir DIR]\n",
    );
    s.push_str("groups:\n");
    for (g, members) in tasks::groups() {
        if !members.is_empty() {
            s.push_str(&format!("  {:<10} {}\n", g, members.join(", ")));
        }
    }
    s
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(name) = args.first() else {
        eprint!("{}", usage());
        bail!("no task given");
    };
    if matches!(name.as_str(), "list" | "help" | "--help" | "-h") {
        print!("{}", usage());
        return Ok(());
    }
    match name.as_str() {
        "roots" => return roots(&args[1..]),
        "merge" => return merge(&args[1..]),
        "slurm" => return slurm::run(&args[1..], &repo_root()),
        _ => {}
    }
    let mut opts = TaskArgs::try_parse_from(&args[1..]).map_err(|e| anyhow::anyhow!("{e}"))?;
    if let Some(file) = opts.file.take() {
        if opts.config.is_some() {
            bail!("give the config either as FILE or with --config, not both");
        }
        opts.config = Some(file);
    }
    let root = repo_root();
    let task_list = tasks::resolve(name)?;
    if opts.config.is_some() && task_list.len() > 1 {
        bail!("--config applies to a single task, not to the group `{name}`");
    }
    let configs_dir = root.join("configs");
    let vehicle = opts
        .vehicle
        .clone()
        .unwrap_or_else(|| configs_dir.join("vehicle.toml"));
    let results = opts.results.clone().unwrap_or_else(|| root.join("results"));

    let lanes = Lanes::new(task_list.len());
    let progress = lanes.first();
    if !(opts.max_speed.is_finite() && opts.max_speed > 1.0) {
        bail!(
            "--max-speed {}: expected a finite speed above 1 m/s (the lowest speed of the critical-speed scan)",
            opts.max_speed
        );
    }
    let limits = sway::ranging::SpeedLimits {
        max_speed_mps: opts.max_speed,
        ..Default::default()
    };
    let ctx = TaskContext::new(&vehicle, &configs_dir, &results, &progress)?.with_limits(limits);

    if !opts.recording.is_empty() {
        return run_recordings(&task_list, &opts, &configs_dir, &results, &ctx, &lanes);
    }
    // Load and validate every config (and its resource plan) before any work: a bad
    // config stops the run here.
    let mut prepared = Vec::new();
    for task in &task_list {
        let config = match &opts.config {
            Some(c) => c.clone(),
            None => configs_dir.join(task.config),
        };
        let (p, plan) = tasks::prepare_checked(task, &ctx, &config)?;
        if opts.check {
            println!("[{}] valid (config {})", task.name, config.display());
            for line in plan.lines() {
                println!("  {line}");
            }
        }
        prepared.push((task, p));
    }
    if let Some(spec) = opts.shard {
        let (task, config) = single_task(&task_list, &opts, &configs_dir)?;
        return run_shard(
            task,
            &config,
            spec,
            opts.shard_dir.as_deref(),
            &opts,
            &ctx,
            &progress,
        );
    }
    sway_tasks::io::ensure_writable(&results)?;
    if opts.check {
        println!("results would go to {}", results.display());
        return Ok(());
    }
    stop_cleanly_on_signals(&results, &lanes.bars, None)?;
    run_prepared(prepared, &ctx, &lanes)
}

/// `cargo xtask lateral_stability --recording FILE …`: the recorded runs analysed with the
/// task's config into `results/lateral_stability_recordings/`.
fn run_recordings(
    task_list: &[Task],
    opts: &TaskArgs,
    configs_dir: &Path,
    results: &Path,
    ctx: &TaskContext<'_>,
    lanes: &Lanes,
) -> Result<()> {
    let (task, config) = single_task(task_list, opts, configs_dir)?;
    if task.name != tasks::lateral_stability::TASK.name {
        bail!(
            "--recording applies to lateral_stability, not to `{}`",
            task.name
        );
    }
    let prepared = tasks::lateral_stability::recordings(&config, &opts.recording)?;
    if opts.check {
        println!("[{}] valid (config {})", task.name, config.display());
        for file in &opts.recording {
            match sway_tasks::recording::read_recording(file) {
                Ok(r) => println!("  {}: {} samples", file.display(), r.time_s.len()),
                Err(e) => println!("  {e}"),
            }
        }
        println!("results would go to {}", results.display());
        return Ok(());
    }
    sway_tasks::io::ensure_writable(results)?;
    stop_cleanly_on_signals(results, &lanes.bars, None)?;
    run_prepared(vec![(task, Box::new(prepared))], ctx, lanes)
}

/// The one task and its config file of a sharded run.
fn single_task<'t>(
    task_list: &'t [Task],
    opts: &TaskArgs,
    configs_dir: &Path,
) -> Result<(&'t Task, PathBuf)> {
    let [task] = task_list else {
        bail!("--shard applies to a single task, not to a group");
    };
    let config = opts
        .config
        .clone()
        .unwrap_or_else(|| configs_dir.join(task.config));
    Ok((task, config))
}

/// `cargo xtask sweep FILE --shard K/N`: computes one slice of the points and writes
/// `shard-K-of-N.json` into the shard directory; a failure is recorded beside it
/// (`shard-K-of-N.failed.json`) so that the merge names it.
fn run_shard(
    task: &Task,
    config: &Path,
    spec: ShardSpec,
    shard_dir: Option<&Path>,
    opts: &TaskArgs,
    ctx: &TaskContext<'_>,
    progress: &Bar,
) -> Result<()> {
    let name = shard::study_name(task.name, config)?;
    let dir = shard_dir
        .map(Path::to_path_buf)
        .unwrap_or_else(|| ctx.results_dir.join(format!("{name}.shards")));
    if opts.check {
        println!("shard {spec} would go to {}", dir.display());
        return Ok(());
    }
    sway_tasks::io::ensure_writable(&dir)?;
    let bars = std::slice::from_ref(&progress.0);
    stop_cleanly_on_signals(&ctx.results_dir, bars, Some((dir.clone(), spec)))?;
    let t0 = Instant::now();
    let r = shard::run_task_shard(task.name, ctx, config, spec, &dir);
    progress.0.finish_and_clear();
    let r = r.with_context(|| format!("shard {spec} of `{}` failed", task.name))?;
    println!(
        "[{}] shard {spec}: points {}..{} of {} in {:.2} s ({} failed) → {}",
        task.name,
        r.range.start,
        r.range.end,
        r.points_total,
        t0.elapsed().as_secs_f64(),
        r.points_failed,
        r.file.display()
    );
    Ok(())
}

/// `cargo xtask merge DIR`.
#[derive(Debug, Parser)]
#[command(no_binary_name = true)]
struct MergeArgs {
    /// the directory of shard files (shard-K-of-N.json)
    dir: PathBuf,
    /// where results/NAME/ goes
    #[arg(long)]
    results: Option<PathBuf>,
}

/// `cargo xtask merge DIR`: checks the shards of DIR (one study, complete, none
/// duplicated) and writes the same `results/<name>/` as an unsharded run.
fn merge(args: &[String]) -> Result<()> {
    let a = MergeArgs::try_parse_from(args).map_err(|e| anyhow::anyhow!("{e}"))?;
    let results = a.results.unwrap_or_else(|| repo_root().join("results"));
    sway_tasks::io::ensure_writable(&results)?;
    let progress = sway::progress::NoProgress;
    stop_cleanly_on_signals(&results, &[], None)?;
    let t0 = Instant::now();
    let report = shard::merge_dir(&a.dir, &results, &progress)?;
    println!(
        "[{}] merged {} in {:.2} s → {}",
        report.task,
        a.dir.display(),
        t0.elapsed().as_secs_f64(),
        report.output_dir.display()
    );
    for line in &report.lines {
        println!("{line}");
    }
    Ok(())
}

/// On SIGINT or SIGTERM: stop writing, remove this run's staging directories (results/
/// stays as it was) and exit with status 130 after one line on stderr. A shard run first
/// records the interruption beside its shard file (SLURM sends SIGTERM at the time limit
/// and on scancel), so that the merge names the shard as failed.
fn stop_cleanly_on_signals(
    results: &Path,
    bars: &[ProgressBar],
    shard: Option<(PathBuf, ShardSpec)>,
) -> Result<()> {
    let results = results.to_path_buf();
    let bars = bars.to_vec();
    ctrlc::set_handler(move || {
        if let Some((dir, spec)) = &shard {
            let why = "interrupted by SIGINT/SIGTERM (under SLURM: the time limit or scancel)";
            let _ = shard::record_failure(dir, *spec, None, why);
        }
        let (_guard, removed) = sway_tasks::io::interrupt(&results);
        for bar in &bars {
            bar.finish_and_clear();
        }
        eprintln!(
            "interrupted: stopped, {} left as it was ({} staging director{} removed)",
            results.display(),
            removed.len(),
            if removed.len() == 1 { "y" } else { "ies" }
        );
        std::process::exit(130);
    })
    .context("cannot install the SIGINT/SIGTERM handler")
}

/// `cargo xtask roots`: the rightmost characteristic roots of the closed loop (eq. 13).
#[derive(Debug, Parser)]
#[command(no_binary_name = true)]
struct RootsArgs {
    /// speed V (m/s)
    #[arg(long)]
    speed: f64,
    /// feedback gain D (s)
    #[arg(long, allow_negative_numbers = true)]
    gain: f64,
    /// delay τ (s)
    #[arg(long)]
    delay: f64,
    /// how many roots
    #[arg(long, default_value_t = sway_tasks::tasks::roots::DEFAULT_COUNT)]
    count: usize,
    /// vehicle file (the form of configs/vehicle.toml, or a model variant of configs/vehicles/)
    #[arg(long)]
    vehicle: Option<PathBuf>,
    /// controller structure: yaw_rate (default), yaw_rate_hitch or predictor
    #[arg(long, default_value = "yaw_rate")]
    structure: String,
    /// actuator: steering (default) or differential_braking
    #[arg(long, default_value = "steering")]
    actuator: String,
    /// K_θ of yaw_rate_hitch (steering: rad/rad; braking: N m/rad)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    hitch_angle_gain: f64,
    /// D_θ of yaw_rate_hitch (steering: s; braking: N m s/rad)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    hitch_rate_gain: f64,
    /// the predictor's model of the vehicle, a separate vehicle file (default: the vehicle)
    #[arg(long)]
    prediction_vehicle: Option<PathBuf>,
    /// validate the arguments and the vehicle, then exit
    #[arg(long)]
    check: bool,
}

fn roots(args: &[String]) -> Result<()> {
    let a = RootsArgs::try_parse_from(args).map_err(|e| anyhow::anyhow!("{e}"))?;
    let vehicle = a
        .vehicle
        .unwrap_or_else(|| repo_root().join("configs").join("vehicle.toml"));
    let loaded = config_file::load_vehicle_spec(&vehicle)?;
    use sway::control::{Actuator, Structure};
    let structure = Structure::ALL
        .into_iter()
        .find(|s| s.as_str() == a.structure)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "--structure: expected yaw_rate, yaw_rate_hitch or predictor, got `{}`",
                a.structure
            )
        })?;
    let actuator = Actuator::ALL
        .into_iter()
        .find(|s| s.as_str() == a.actuator)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "--actuator: expected steering or differential_braking, got `{}`",
                a.actuator
            )
        })?;
    let gains = sway::control::Gains {
        yaw_rate: a.gain,
        hitch_angle: a.hitch_angle_gain,
        hitch_rate: a.hitch_rate_gain,
    };
    let law = sway::control::LoopLaw::new(structure, actuator, gains, a.delay);
    if a.check {
        sway_tasks::tasks::roots::validate_args(a.speed, a.gain, a.delay, a.count)?;
        println!(
            "[roots] valid: the {} rightmost roots at V = {} m/s, D = {} s, τ = {} s",
            a.count, a.speed, a.gain, a.delay
        );
        println!("  estimate: memory ≈ 1 MB, time ≈ 0.01 s");
        return Ok(());
    }
    let prediction = match &a.prediction_vehicle {
        Some(file) => Some(config_file::load_vehicle_spec(file)?.plant),
        None => None,
    };
    let point = sway_tasks::tasks::roots::RootsConfig {
        speed_mps: a.speed,
        count: a.count,
        law,
    };
    let roots = sway_tasks::tasks::roots::run(
        &loaded.plant,
        &point,
        prediction
            .as_ref()
            .map(|m| m as &dyn sway::control::LoopModel),
    )?;
    print!("{}", sway_tasks::tasks::roots::format_roots(&roots));
    Ok(())
}

/// A task ready to run: what [`tasks::prepare_checked`] made of its config.
type PreparedTask<'t> = (&'t Task, Box<dyn tasks::Prepared>);

/// Runs the prepared tasks on [`Lanes`]: each lane takes the next task of the list until
/// none is left, all of them feeding the one rayon pool, so that one task's sequential
/// stretches (a continuation, writing, rendering) overlap another's work. Every task
/// computes exactly what it computes alone (no state is shared between tasks, results
/// do not depend on scheduling); the printed lines come in the list's order.
fn run_prepared(
    prepared: Vec<PreparedTask<'_>>,
    ctx: &TaskContext<'_>,
    lanes: &Lanes,
) -> Result<()> {
    // the tasks with their places in the list, taken one at a time by the lanes
    let queue = Mutex::new(prepared.into_iter().enumerate());
    let (done_tx, done_rx) = mpsc::channel::<Finished>();
    let mut failed = Vec::new();
    std::thread::scope(|scope| {
        for bar in &lanes.bars {
            let (queue, done_tx) = (&queue, done_tx.clone());
            scope.spawn(move || {
                let progress = Bar(bar.clone());
                let ctx = ctx.with_progress(&progress);
                loop {
                    let Some((order, (task, p))) = queue.lock().ok().and_then(|mut q| q.next())
                    else {
                        break;
                    };
                    let t0 = Instant::now();
                    let outcome = p
                        .run(&ctx)
                        .with_context(|| format!("task `{}` failed", task.name));
                    bar.reset();
                    let finished = Finished {
                        order,
                        name: task.name,
                        elapsed_s: t0.elapsed().as_secs_f64(),
                        outcome,
                    };
                    if done_tx.send(finished).is_err() {
                        break;
                    }
                }
            });
        }
        drop(done_tx);
        // a task's lines as soon as it and every task before it in the list have finished
        let mut waiting = BTreeMap::new();
        let mut printed = 0;
        for f in done_rx {
            waiting.insert(f.order, f);
            while let Some(f) = waiting.remove(&printed) {
                lanes.multi.suspend(|| f.print());
                if f.outcome.is_err() {
                    failed.push(f.name);
                }
                printed += 1;
            }
        }
    });
    lanes.clear();
    if failed.is_empty() {
        Ok(())
    } else {
        bail!("{} task(s) failed: {}", failed.len(), failed.join(", "))
    }
}

/// A task run by a lane: its place in the list, and what it printed or why it failed.
struct Finished {
    order: usize,
    name: &'static str,
    elapsed_s: f64,
    outcome: Result<tasks::Report>,
}

impl Finished {
    fn print(&self) {
        match &self.outcome {
            Ok(report) => {
                println!(
                    "[{}] done in {:.2} s → {}",
                    report.task,
                    self.elapsed_s,
                    report.output_dir.display()
                );
                for line in &report.lines {
                    println!("{line}");
                }
            }
            Err(e) => eprintln!("error: {e:#}"),
        }
    }
}

/// The progress bars of the lanes that run a list of tasks side by side: two where the
/// list has several tasks and rayon has several threads, else one (a single task, or
/// `RAYON_NUM_THREADS=1`, runs alone as before).
struct Lanes {
    multi: MultiProgress,
    bars: Vec<ProgressBar>,
}

impl Lanes {
    /// Side by side at most this many tasks: two already fill the sequential stretches
    /// of one with the other's work (`cargo xtask all` on 2 cores: 63 → 61 s).
    const MAX: usize = 2;

    fn new(tasks: usize) -> Self {
        let style = ProgressStyle::with_template("{msg:40} [{bar:30}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
        let multi = MultiProgress::new();
        let n = tasks.min(sway::parallel::threads()).clamp(1, Self::MAX);
        let bars = (0..n)
            .map(|_| multi.add(ProgressBar::new(0).with_style(style.clone())))
            .collect();
        Self { multi, bars }
    }

    /// The first lane's bar (a single task's, a shard's).
    fn first(&self) -> Bar {
        Bar(self.bars[0].clone())
    }

    fn clear(&self) {
        for bar in &self.bars {
            bar.finish_and_clear();
        }
    }
}
