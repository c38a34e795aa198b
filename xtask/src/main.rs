//! `cargo xtask <task>`: the runner. It parses arguments, shows progress and prints the
//! headline numbers; every pipeline lives in the `sway` library.
//!
//! ```text
//! cargo xtask list                       # the tasks and groups
//! cargo xtask linear [--vehicle FILE] [--config FILE]
//! cargo xtask fig3 | fig4 | all          # groups of tasks
//! cargo xtask roots --speed V --gain D --delay TAU [--count N]   # rightmost characteristic roots
//! cargo xtask <task|group> --check       # validate configs, print the plan, run nothing
//! ```
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

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use sway::progress::Progress;
use sway_tasks::config_file;
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
        "roots", "rightmost characteristic roots of eq. (13) at one point: --speed V --gain D --delay TAU [--count N]"
    ));
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
    if name == "roots" {
        return roots(&args[1..]);
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

    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("{msg:40} [{bar:30}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let progress = Bar(bar);
    let ctx = TaskContext::new(&vehicle, &configs_dir, &results, &progress)?;

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
    sway_tasks::io::ensure_writable(&results)?;
    if opts.check {
        println!("results would go to {}", results.display());
        return Ok(());
    }
    stop_cleanly_on_signals(&results, &progress.0)?;
    run_prepared(prepared, &ctx, &progress)
}

/// On SIGINT or SIGTERM: stop writing, remove this run's staging directories (results/
/// stays as it was) and exit with status 130 after one line on stderr.
fn stop_cleanly_on_signals(results: &Path, bar: &ProgressBar) -> Result<()> {
    let results = results.to_path_buf();
    let bar = bar.clone();
    ctrlc::set_handler(move || {
        let (_guard, removed) = sway_tasks::io::interrupt(&results);
        bar.finish_and_clear();
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
    /// vehicle parameters (the form of configs/vehicle.toml)
    #[arg(long)]
    vehicle: Option<PathBuf>,
    /// validate the arguments and the vehicle, then exit
    #[arg(long)]
    check: bool,
}

fn roots(args: &[String]) -> Result<()> {
    let a = RootsArgs::try_parse_from(args).map_err(|e| anyhow::anyhow!("{e}"))?;
    let vehicle = a
        .vehicle
        .unwrap_or_else(|| repo_root().join("configs").join("vehicle.toml"));
    let (_, model) = config_file::load_vehicle(&vehicle)?;
    if a.check {
        sway_tasks::tasks::roots::validate_args(a.speed, a.gain, a.delay, a.count)?;
        println!(
            "[roots] valid: the {} rightmost roots at V = {} m/s, D = {} s, τ = {} s",
            a.count, a.speed, a.gain, a.delay
        );
        println!("  estimate: memory ≈ 1 MB, time ≈ 0.01 s");
        return Ok(());
    }
    let roots = sway_tasks::tasks::roots::roots(&model, a.speed, a.gain, a.delay, a.count)?;
    print!("{}", sway_tasks::tasks::roots::format_roots(&roots));
    Ok(())
}

fn run_prepared(
    prepared: Vec<(&Task, Box<dyn tasks::Prepared>)>,
    ctx: &TaskContext<'_>,
    progress: &Bar,
) -> Result<()> {
    let mut failed = Vec::new();
    for (task, p) in prepared {
        let t0 = Instant::now();
        match p
            .run(ctx)
            .with_context(|| format!("task `{}` failed", task.name))
        {
            Ok(report) => {
                progress.0.finish_and_clear();
                println!(
                    "[{}] done in {:.2} s → {}",
                    report.task,
                    t0.elapsed().as_secs_f64(),
                    report.output_dir.display()
                );
                for line in &report.lines {
                    println!("{line}");
                }
            }
            Err(e) => {
                progress.0.finish_and_clear();
                eprintln!("error: {e:#}");
                failed.push(task.name);
            }
        }
    }
    if failed.is_empty() {
        Ok(())
    } else {
        bail!("{} task(s) failed: {}", failed.len(), failed.join(", "))
    }
}
