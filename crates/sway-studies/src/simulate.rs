//! The computation of `simulate` (one user scenario of the full model) and the time-series
//! runs it shares with `fig3b`, `fig4c` and the time panels of `fig3a`: the relative speeds
//! of the config resolved for the vehicle ([`sway::sim::speeds`]), the resolved config
//! checked, the initial state, then every run simulated on the vehicle's plant (any model
//! variant) in the paper's 7-state layout, sampled for the plotted series.
//!
//! A config whose speeds do not resolve for the vehicle (a relative speed and no V_crit: a
//! vehicle stable at every speed up to the maximum) is an outcome, not an error: the
//! [`Resolution`] of a computation says why, and which speed.

use std::path::Path;

use serde::Serialize;
use sway::SwayError;
use sway::progress::Progress;
use sway::ranging::{SpeedLimits, SpeedSpec, resolve_speeds};
use sway::sim::speeds::ResolveSpeeds;
use sway::sim::speeds::{Resolution, ResolvedSpeed, UnresolvedSpeed};
use sway::sim::{
    InitialCondition, Metrics, Recording, RunSettings, ScenarioConfig, SimResult, SimSpec,
    SolverSettings, SwayStart, simulate_in_paper_layout,
};
use trailer_model::{AnyVehicleModel, State7};

/// The summary entry of one run: its metrics (the field names of [`Metrics`]) followed by
/// the fields of `about` that say which run it is (e.g. `brake_duration_s`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunEntry<E> {
    /// the run's metrics
    #[serde(flatten)]
    pub metrics: Metrics,
    /// what distinguishes the run
    #[serde(flatten)]
    pub about: E,
}

/// One simulated run of a time-series task.
#[derive(Debug, Clone)]
pub struct SeriesRun<E> {
    /// its key in `summary.json` and the stem of its CSV file (`T2`, `braking`,
    /// `theta0_2deg`)
    pub key: String,
    /// what distinguishes it
    pub about: E,
    /// the simulation
    pub spec: SimSpec,
    /// its samples (every output step of the config) and metrics
    pub result: SimResult<7>,
}

impl<E: Clone> SeriesRun<E> {
    /// Its summary entry: the metrics and what distinguishes it.
    pub fn entry(&self) -> RunEntry<E> {
        RunEntry {
            metrics: self.result.metrics,
            about: self.about.clone(),
        }
    }
}

/// The runs of a time-series task and the config they ran with (its speeds resolved).
#[derive(Debug, Clone)]
pub struct Runs<C, E> {
    /// the config, every speed a number
    pub config: C,
    /// the runs in the config's order
    pub runs: Vec<SeriesRun<E>>,
}

/// A config error of a check on the resolved speeds, with what the relative speeds resolved
/// to for this vehicle appended; any other error (and every error when all speeds were
/// numbers) as it is.
pub fn with_resolved_speeds(e: SwayError, speeds: &[ResolvedSpeed]) -> SwayError {
    match e {
        SwayError::Config { file, key, problem } if !speeds.is_empty() => {
            let list: Vec<String> = speeds
                .iter()
                .map(|s| format!("{} = {} m/s", s.key, s.speed_mps))
                .collect();
            let note = format!(
                " (with the relative speeds resolved for this vehicle: {})",
                list.join(", ")
            );
            SwayError::config(file, key, format!("{problem}{note}"))
        }
        other => other,
    }
}

/// `run` on the resolved config of `resolution` once `check` accepts it (a config error
/// then names the resolved speeds, [`with_resolved_speeds`]); the references and the
/// resolved speeds are kept, and a config that did not resolve stays the outcome. A run
/// that finds no sway cycle to start from ([`SwayError::NoSwayCycle`]) is an outcome too:
/// the speed of `start_key` has nothing to start from, with the reason.
///
/// # Errors
/// The check's error, or the run's.
pub(crate) fn checked_run<T, U>(
    resolution: Resolution<T>,
    start_key: &str,
    check: impl FnOnce(&T) -> Result<(), SwayError>,
    run: impl FnOnce(T) -> Result<U, SwayError>,
) -> Result<Resolution<U>, SwayError> {
    let Resolution {
        outcome,
        references,
        speeds,
    } = resolution;
    let outcome = match outcome {
        Ok(c) => {
            check(&c).map_err(|e| with_resolved_speeds(e, &speeds))?;
            match run(c) {
                Ok(u) => Ok(u),
                // no stable sway cycle at the start's speed: nothing to start from, an
                // outcome like a speed that does not resolve (the key of that speed)
                Err(e @ SwayError::NoSwayCycle { speed_mps, .. }) => Err(UnresolvedSpeed {
                    key: start_key.to_string(),
                    spec: SpeedSpec::Absolute(speed_mps),
                    reason: e.to_string(),
                }),
                Err(e) => return Err(e),
            }
        }
        Err(u) => Err(u),
    };
    Ok(Resolution {
        outcome,
        references,
        speeds,
    })
}

/// The initial state in the paper's 7-state layout (one progress step).
///
/// # Errors
/// Numerical failures of settling onto the sway cycle, with context.
pub(crate) fn initial_state(
    vehicle: &AnyVehicleModel,
    initial: &InitialCondition,
    solver: &SolverSettings,
    progress: &dyn Progress,
) -> Result<State7, SwayError> {
    let x0 = initial.state7(vehicle, solver)?;
    progress.advance(1);
    Ok(x0)
}

/// Simulates one run from `x0`, recorded as `recording` says.
///
/// # Errors
/// Numerical failures with context.
pub(crate) fn run<E>(
    vehicle: &AnyVehicleModel,
    x0: State7,
    (key, about, spec): (String, E, SimSpec),
    recording: Recording,
) -> Result<SeriesRun<E>, SwayError> {
    let result = simulate_in_paper_layout::<7>(vehicle, &spec, x0, recording)?;
    Ok(SeriesRun {
        key,
        about,
        spec,
        result,
    })
}

/// Simulates `runs` (key, what distinguishes the run, its simulation) from one initial
/// state, recorded as `recording` says: one progress step for the initial state, one per
/// run.
///
/// # Errors
/// Numerical failures with context.
pub(crate) fn run_from<E>(
    vehicle: &AnyVehicleModel,
    initial: &InitialCondition,
    solver: &SolverSettings,
    recording: Recording,
    runs: Vec<(String, E, SimSpec)>,
    progress: &dyn Progress,
) -> Result<Vec<SeriesRun<E>>, SwayError> {
    let x0 = initial_state(vehicle, initial, solver, progress)?;
    runs.into_iter()
        .map(|r| {
            let r = run(vehicle, x0, r, recording)?;
            progress.advance(1);
            Ok(r)
        })
        .collect()
}

/// A config of runs from the sway cycle (`fig3b`, `fig4c`), its speeds resolved.
pub(crate) trait FromSwayCycle {
    /// what distinguishes a run
    type About;
    /// Checks every key.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the key.
    fn check(&self, file: &Path) -> Result<(), SwayError>;
    /// The start on the sway cycle, the run settings and the output step \[s\].
    fn start(&self) -> (&SwayStart, &RunSettings, f64);
    /// The runs (key, what distinguishes the run, its simulation) in drawing order.
    fn runs(&self) -> Vec<(String, Self::About, SimSpec)>;
}

/// The whole computation of a task of runs from the sway cycle: the speeds of `config`
/// resolved for `vehicle` within `limits`, the resolved config checked (`file` names it in
/// the messages), the start, the runs sampled every output step. Progress: one step for
/// the start, one per run.
///
/// # Errors
/// A config error of the resolved config (naming the resolved speeds), or numerical
/// failures with context.
pub(crate) fn sway_runs<C>(
    config: &C,
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    file: &Path,
    progress: &dyn Progress,
) -> Result<SwayRuns<C>, SwayError>
where
    C: ResolveSpeeds,
    C::Resolved: FromSwayCycle,
{
    let resolution = resolve_speeds(vehicle, limits, config)?;
    checked_run(
        resolution,
        "start.speed_mps",
        |c| c.check(file),
        |c| {
            let (start, settings, output_step_s) = c.start();
            let initial = start.initial();
            let recording = every(output_step_s);
            let runs = run_from(
                vehicle,
                &initial,
                &settings.solver,
                recording,
                c.runs(),
                progress,
            )?;
            Ok(Runs { config: c, runs })
        },
    )
}

/// What [`sway_runs`] returns for a config `C` as written.
pub(crate) type SwayRuns<C> = Resolution<
    Runs<<C as ResolveSpeeds>::Resolved, <<C as ResolveSpeeds>::Resolved as FromSwayCycle>::About>,
>;

/// The samples of the plotted series: every `output_step_s` seconds.
pub(crate) fn every(output_step_s: f64) -> Recording {
    Recording::Every {
        step_s: output_step_s,
    }
}

/// What a scenario's `summary.json` says about the run beside its metrics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScenarioRun {
    /// when the action started \[s\]
    pub action_s: f64,
    /// where the run ended \[s\] (the horizon, or the loss of control)
    pub t_end_s: f64,
    /// accepted solver steps
    pub accepted_steps: usize,
    /// rejected solver steps
    pub rejected_steps: usize,
}

/// The summary of a scenario: `name`, the run's metrics, `action_s`, `t_end_s`,
/// `accepted_steps`, `rejected_steps`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioSummary {
    /// the scenario's name (its results directory)
    pub name: String,
    /// metrics and run facts
    #[serde(flatten)]
    pub run: RunEntry<ScenarioRun>,
}

/// A scenario run: the scenario with its speeds resolved, and its one run (key
/// `trajectory`).
#[derive(Debug, Clone)]
pub struct Scenario {
    /// the scenario, every speed a number
    pub config: ScenarioConfig,
    /// the run
    pub run: SeriesRun<()>,
}

impl Scenario {
    /// Its summary.
    pub fn summary(&self) -> ScenarioSummary {
        let r = &self.run.result;
        ScenarioSummary {
            name: self.config.name.clone(),
            run: RunEntry {
                metrics: r.metrics,
                about: ScenarioRun {
                    action_s: self.run.spec.action_s,
                    t_end_s: r.t_end,
                    accepted_steps: r.stats.accepted,
                    rejected_steps: r.stats.rejected,
                },
            },
        }
    }
}

/// The whole computation of a scenario (`configs/scenario_example.toml`, as read and
/// checked before its speeds are resolved): its speeds resolved for `vehicle` within
/// `limits`, the resolved scenario checked (`file` names it in the messages), the initial
/// state, the run, its trajectory sampled every `output_step_s` (`trajectory`; without it
/// the metrics only). Two progress steps: the initial state, the run.
///
/// # Errors
/// A config error of the resolved scenario (naming the resolved speeds), or numerical
/// failures with context.
pub fn compute(
    config: &ScenarioConfig<SpeedSpec>,
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    file: &Path,
    trajectory: bool,
    progress: &dyn Progress,
) -> Result<Resolution<Scenario>, SwayError> {
    let resolution = resolve_speeds(vehicle, limits, config)?;
    checked_run(
        resolution,
        "initial.speed_mps",
        |c| c.validate(file),
        |c| {
            let recording = if trajectory {
                every(c.output_step_s.get())
            } else {
                Recording::None
            };
            let x0 = initial_state(vehicle, &c.initial, &c.settings.solver, progress)?;
            let run = run(vehicle, x0, ("trajectory".into(), (), c.spec()?), recording)?;
            progress.advance(1);
            Ok(Scenario { config: c, run })
        },
    )
}
