//! The task registry: every figure of the paper (and more) as a named task.
//!
//! A task runs in two steps so that a bad config stops the run before any work and
//! before anything is written: [`Task::prepare`] loads and validates the task's config
//! (and may precompute nothing expensive), then [`Prepared::run`] computes and writes
//! `results/<task>/` through a staged [`OutputDir`].

use std::path::{Path, PathBuf};

use serde::Serialize;
use trailer_model::{AnyVehicleModel, Model, VehicleParams, VehicleSpec};

use crate::TaskError;
use crate::config_file;
use crate::config_file::{Configured, TaskConfig, load_toml};
use crate::io::OutputDir;
use crate::limits::Plan;
use sway::progress::Progress;
use sway::ranging::SpeedLimits;

/// The registry in one place: each line declares a task module and the tasks it
/// defines, in the order `cargo xtask all` runs them. Adding a task is one file (the
/// module, with its `pub const TASK: Task`) plus one line here.
macro_rules! registry {
    ($($module:ident => [$($task:ident),+]),+ $(,)?) => {
        $(pub mod $module;)+

        /// Every task, in the order `all` runs them.
        pub fn registry() -> Vec<Task> {
            vec![$($($module::$task),+),+]
        }
    };
}

registry! {
    linear => [TASK],
    loading => [TASK],
    fig3a_panels => [TASK],
    fig3b => [TASK],
    fig4a => [TASK],
    fig4b => [TASK],
    fig4c => [TASK],
    chart_nonlinear => [TASK],
    corners => [TASK],
    gain_design => [TASK],
    control_design => [TASK],
    simulate => [TASK],
    mitigation => [TASK],
    sweep => [TASK, BRAKE_TIMING, UNCERTAINTY, FLEET],
    fleet => [TASK],
    combination => [TASK],
    variants => [TASK],
    lateral_stability => [TASK],
    sway_assist => [TASK, FULL],
    fmu => [TASK],
    study_generated => [TASK],
}

pub mod fig3a_diagram;
pub mod roots;
pub mod series;

/// What every task gets: the vehicle, where configs and results live, and a progress
/// observer.
pub struct TaskContext<'a> {
    /// the vehicle file the model was loaded from
    pub vehicle_file: PathBuf,
    /// its paper-form parameters (the file's keys for a vehicle of the paper's form; for a
    /// vehicle with model variants the equivalent single-axle vehicle, which only tasks of
    /// [`Models::Paper`] see, and they refuse such a vehicle: [`prepare_checked`])
    pub vehicle: VehicleParams,
    /// the paper's model built from them
    pub model: Model,
    /// the vehicle file as written (axle lists, tyre laws, relaxation, hitch torque)
    pub spec: VehicleSpec,
    /// the plant of the vehicle, for tasks of [`Models::Any`]
    /// ([`AnyVehicleModel::Paper`] for a vehicle of the paper's form)
    pub plant: AnyVehicleModel,
    /// the first key of the file that makes it differ from the paper's model, None for a
    /// vehicle of the paper's form
    pub variant_key: Option<String>,
    /// directory of the default task configs (`configs/`)
    pub configs_dir: PathBuf,
    /// root of the results (`results/`)
    pub results_dir: PathBuf,
    /// progress observer
    pub progress: &'a dyn Progress,
    /// the vehicle-independent limits of every range derived from the vehicle
    /// (`--max-speed`; default 100 m/s)
    pub limits: SpeedLimits,
}

impl std::fmt::Debug for TaskContext<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TaskContext")
            .field("vehicle_file", &self.vehicle_file)
            .field("configs_dir", &self.configs_dir)
            .field("results_dir", &self.results_dir)
            .field("limits", &self.limits)
            .finish_non_exhaustive()
    }
}

impl<'a> TaskContext<'a> {
    /// Loads and validates the vehicle file ([`config_file::load_vehicle_spec`]).
    ///
    /// # Errors
    /// [`TaskError::Read`] / [`TaskError::Config`] naming the file and key.
    pub fn new(
        vehicle_file: &Path,
        configs_dir: &Path,
        results_dir: &Path,
        progress: &'a dyn Progress,
    ) -> Result<Self, TaskError> {
        let loaded = config_file::load_vehicle_spec(vehicle_file)?;
        Ok(Self {
            vehicle_file: vehicle_file.to_path_buf(),
            vehicle: loaded.params,
            model: loaded.paper_model,
            spec: loaded.spec,
            plant: loaded.plant,
            variant_key: loaded.variant_key,
            configs_dir: configs_dir.to_path_buf(),
            results_dir: results_dir.to_path_buf(),
            progress,
            limits: SpeedLimits::default(),
        })
    }

    /// The same context with other [`SpeedLimits`] (`--max-speed`).
    #[must_use]
    pub fn with_limits(self, limits: SpeedLimits) -> Self {
        Self { limits, ..self }
    }

    /// A copy of the context that reports to another progress observer (a runner that
    /// runs tasks side by side gives each its own).
    #[must_use]
    pub fn with_progress<'b>(&self, progress: &'b dyn Progress) -> TaskContext<'b> {
        TaskContext {
            vehicle_file: self.vehicle_file.clone(),
            vehicle: self.vehicle,
            model: self.model.clone(),
            spec: self.spec.clone(),
            plant: self.plant.clone(),
            variant_key: self.variant_key.clone(),
            configs_dir: self.configs_dir.clone(),
            results_dir: self.results_dir.clone(),
            progress,
            limits: self.limits,
        }
    }

    /// The skeleton of every task run: creates the staged `results/<name>/`
    /// ([`OutputDir::create`]), starts the progress stage `stage` of `steps` steps, runs
    /// `body` (which computes, writes its files into the staged directory, advances the
    /// progress and returns the summary's headline and the report lines), then
    /// [`conclude`](Self::conclude)s. If `body` fails nothing is committed: the previous
    /// results stay. A body that finds the task [`TaskError::NotApplicable`] to the vehicle
    /// leaves a result saying so instead ([`NotApplicable`]: nothing else of the body's is
    /// kept).
    ///
    /// # Errors
    /// The body's error, or [`TaskError::Write`].
    pub fn run_staged<H: Serialize, C: Serialize>(
        &self,
        name: &str,
        stage: &str,
        steps: u64,
        config: &C,
        config_file: &Path,
        body: impl FnOnce(&OutputDir) -> Result<(H, Vec<String>), TaskError>,
    ) -> Result<Report, TaskError> {
        let out = OutputDir::create(&self.results_dir, name)?;
        self.progress.start(stage, steps);
        match body(&out) {
            Ok((headline, lines)) => self.conclude(out, headline, config, config_file, lines),
            Err(TaskError::NotApplicable { key, reason }) => {
                // a fresh staging directory: no file of the body's stays
                drop(out);
                let out = OutputDir::create(&self.results_dir, name)?;
                let line = format!("{name}: not applicable to this vehicle: `{key}`: {reason}");
                let headline = NotApplicableSummary {
                    not_applicable: NotApplicable { key, reason },
                };
                self.conclude(out, headline, config, config_file, vec![line])
            }
            Err(e) => Err(e),
        }
    }

    /// The last step of every task: writes `summary.json` (`headline`, then the inputs of
    /// the run), closes the progress stage, replaces `results/<task>/` by the staged
    /// directory and reports `lines`.
    ///
    /// # Errors
    /// [`TaskError::Write`].
    pub fn conclude<H: Serialize, C: Serialize>(
        &self,
        out: OutputDir,
        headline: H,
        config: &C,
        config_file: &Path,
        lines: Vec<String>,
    ) -> Result<Report, TaskError> {
        out.write_summary(headline, config, &self.run_info(config_file))?;
        self.progress.finish();
        let task = out.name().to_string();
        let output_dir = out.commit()?;
        Ok(Report {
            task,
            output_dir,
            lines,
        })
    }

    /// The record of inputs that every summary.json carries.
    pub fn run_info<'b>(&'b self, config_file: &'b Path) -> crate::io::RunInfo<'b> {
        crate::io::RunInfo {
            config_file,
            vehicle_file: &self.vehicle_file,
            vehicle: if self.spec.is_chain() {
                crate::io::VehicleRecord::Chain(&self.spec)
            } else {
                crate::io::VehicleRecord::Pair(&self.vehicle)
            },
        }
    }
}

/// Why a task has nothing to compute for the vehicle (`summary.json`'s `not_applicable`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct NotApplicable {
    /// the vehicle or config key that makes it so, e.g. `trailers`
    pub key: String,
    /// why, and what would apply
    pub reason: String,
}

/// The headline of a task that does not apply to the vehicle.
#[derive(Debug, Clone, Serialize)]
struct NotApplicableSummary {
    not_applicable: NotApplicable,
}

/// What a finished task reports.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// task name
    pub task: String,
    /// where the results are
    pub output_dir: PathBuf,
    /// headline lines to print, e.g. `V_crit = 34.05 m/s`
    pub lines: Vec<String>,
}

/// A task whose config has been loaded and validated.
pub trait Prepared: Send {
    /// Computes and writes the results.
    ///
    /// # Errors
    /// Numerical failures with context, or write errors.
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError>;

    /// What [`run`](Self::run) would compute, with estimates of memory and time; refuses
    /// work beyond the limits of [`crate::limits`] naming the key. The default describes a
    /// task without a cost model of its own (its counts are bounded by its validation).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the key whose value exceeds a limit.
    fn plan(&self) -> Result<Plan, TaskError> {
        Ok(Plan::described(
            "(no cost model: counts bounded by validation)",
        ))
    }
}

/// Loads and validates `task`'s config `file` and checks its [`Plan`] against the
/// resource limits: the one validation path of both `--check` and a real run.
///
/// # Errors
/// [`TaskError::Read`] / [`TaskError::Config`] naming the file and the key.
pub fn prepare_checked(
    task: &Task,
    ctx: &TaskContext<'_>,
    file: &Path,
) -> Result<(Box<dyn Prepared>, Plan), TaskError> {
    check_models(task, ctx)?;
    let prepared = (task.prepare)(ctx, file)?;
    let plan = prepared.plan()?;
    Ok((prepared, plan))
}

/// A task of [`Models::Paper`] refuses a vehicle with model variants, naming the file, the
/// variant key and the tasks that take it (never the equivalent paper vehicle in silence).
///
/// # Errors
/// [`TaskError::Config`] naming the vehicle file and its first variant key.
fn check_models(task: &Task, ctx: &TaskContext<'_>) -> Result<(), TaskError> {
    let Some(key) = &ctx.variant_key else {
        return Ok(());
    };
    if task.models == Models::Any {
        return Ok(());
    }
    let takers: Vec<&str> = registry()
        .iter()
        .filter(|t| t.models == Models::Any)
        .map(|t| t.name)
        .collect();
    Err(TaskError::config(
        &ctx.vehicle_file,
        key.as_str(),
        format!(
            "task `{}` takes only the paper's model (one brush-tyre axle per unit, no \
             relaxation, a free hitch), and this key makes the vehicle a model variant; \
             tasks that take model variants: {}",
            task.name,
            if takers.is_empty() {
                "none yet".to_string()
            } else {
                takers.join(", ")
            }
        ),
    ))
}

/// Which vehicle models a task takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Models {
    /// only the paper's model (a vehicle file of the paper's form); a vehicle with model
    /// variants is refused before any work
    #[default]
    Paper,
    /// any plant ([`TaskContext::plant`]): relaxation, tyre laws, axle lists, hitch torque
    Any,
}

/// Loads and validates a task's config.
pub type PrepareFn = fn(&TaskContext<'_>, &Path) -> Result<Box<dyn Prepared>, TaskError>;

/// A named task.
#[derive(Debug, Clone, Copy)]
pub struct Task {
    /// the name used on the command line (`cargo xtask <name>`)
    pub name: &'static str,
    /// one line saying what it reproduces
    pub about: &'static str,
    /// its config file, relative to the configs directory
    pub config: &'static str,
    /// config loading and validation
    pub prepare: PrepareFn,
    /// which vehicle models it takes
    pub models: Models,
    /// whether `cargo xtask all` runs it
    pub runs: Runs,
}

/// Whether a task is part of `cargo xtask all`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Runs {
    /// in `all`: its results are committed and regenerated by `cargo xtask all`
    #[default]
    InAll,
    /// only when named (`cargo xtask fmu`): it builds artefacts rather than results of the
    /// paper's kind, or takes longer than `all`'s budget allows
    OnDemand,
}

impl Task {
    /// The same task, taking any plant ([`Models::Any`]).
    #[must_use]
    pub const fn any_model(self) -> Self {
        Self {
            models: Models::Any,
            ..self
        }
    }

    /// The same task, run only when named ([`Runs::OnDemand`]).
    #[must_use]
    pub const fn on_demand(self) -> Self {
        Self {
            runs: Runs::OnDemand,
            ..self
        }
    }
}

/// Named groups of tasks: `fig3`, `fig4` (the panels of one figure, plus the nonlinear
/// chart that extends Fig. 4) and `all` (every task but those of [`Runs::OnDemand`]).
pub fn groups() -> Vec<(&'static str, Vec<&'static str>)> {
    let all: Vec<&'static str> = registry()
        .iter()
        .filter(|t| t.runs == Runs::InAll)
        .map(|t| t.name)
        .collect();
    let with_prefix = |p: &str| -> Vec<&'static str> {
        all.iter().copied().filter(|n| n.starts_with(p)).collect()
    };
    vec![
        ("fig3", with_prefix("fig3")),
        ("fig4", {
            let mut g = with_prefix("fig4");
            g.push(chart_nonlinear::TASK.name);
            g
        }),
        ("all", all.clone()),
    ]
}

/// Resolves a task or group name to tasks.
///
/// # Errors
/// [`TaskError::UnknownTask`] listing the known names.
pub fn resolve(name: &str) -> Result<Vec<Task>, TaskError> {
    let reg = registry();
    if let Some(t) = reg.iter().find(|t| t.name == name) {
        return Ok(vec![*t]);
    }
    if let Some((_, members)) = groups()
        .into_iter()
        .find(|(g, m)| *g == name && !m.is_empty())
    {
        return Ok(members
            .iter()
            .filter_map(|m| reg.iter().find(|t| t.name == *m).copied())
            .collect());
    }
    let mut known: Vec<&str> = reg.iter().map(|t| t.name).collect();
    known.extend(
        groups()
            .iter()
            .filter(|(_, m)| !m.is_empty())
            .map(|(g, _)| *g),
    );
    Err(TaskError::UnknownTask {
        name: name.to_string(),
        known: known.join(", "),
    })
}

/// The [`Task::prepare`] of a task whose prepared value is [`Configured`]:
/// reads `file`, checks it (`TaskConfig::check`) and boxes it.
///
/// # Errors
/// Read and config errors.
pub fn prepare_config<C: TaskConfig>(
    _ctx: &TaskContext<'_>,
    file: &Path,
) -> Result<Box<dyn Prepared>, TaskError>
where
    Configured<C>: Prepared,
{
    Ok(Box::new(Configured {
        file: file.to_path_buf(),
        config: load_checked::<C>(file)?,
    }))
}

/// A task config read from `file`, its named files loaded and checked.
///
/// # Errors
/// [`TaskError::Read`] / [`TaskError::Config`] naming the file and the key.
pub fn load_checked<C: TaskConfig>(file: &Path) -> Result<C, TaskError> {
    let mut config: C = load_toml(file)?;
    config.load_named_files(file)?;
    config.check(file)?;
    Ok(config)
}

impl Task {
    /// The task `name` (`about` it, default config file `config` in `configs/`) whose
    /// prepared value is a [`Configured`] `C` ([`prepare_config`]).
    pub const fn configured<C: TaskConfig>(
        name: &'static str,
        about: &'static str,
        config: &'static str,
    ) -> Self
    where
        Configured<C>: Prepared,
    {
        Self {
            name,
            about,
            config,
            prepare: prepare_config::<C>,
            models: Models::Paper,
            runs: Runs::InAll,
        }
    }
}
