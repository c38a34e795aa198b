//! The one skeleton of the time-series tasks (`fig3a` panels, `fig3b`, `fig4c`,
//! `simulate`): every run is simulated on the vehicle's plant (`ctx.plant`, any model variant;
//! the paper's 7-state layout), written as one CSV of typed
//! rows, drawn, and summarised by its [`Metrics`] plus what distinguishes it. The tasks of
//! several runs from the sway cycle drawn over each other (`fig3b`, `fig4c`) share all of
//! their [`Prepared`] through [`SwayRuns`].

use crate::TaskError;
use serde::Serialize;
use std::path::Path;

use sway::SwayError;
use sway::ranging::SpeedReferences;
use sway::ranging::resolve_speeds;
use sway::sim::speeds::{ResolveSpeeds, ResolvedSpeed, UnresolvedSpeed};
use sway::sim::{
    Metrics, Recording, RunSettings, Sample, SimResult, SimSpec, SwayStart,
    simulate_in_paper_layout,
};
use trailer_model::State7;

use super::{Prepared, Report, TaskContext};
use crate::config_file::{Configured, TaskConfig};
use crate::io::{Keyed, OutputDir};
use crate::limits::{Plan, series_plan};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::report::{SeriesRow, loss_marker, max_abs_theta_deg, metrics_line, speed, theta_deg};

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

/// Simulates one run sampled every `output_step_s` seconds and writes its trajectory to
/// `file` as rows `R` (e.g. [`crate::report::SeriesRow`]).
///
/// # Errors
/// Numerical failures with context, or write errors.
pub fn run_and_write<R>(
    ctx: &TaskContext<'_>,
    out: &OutputDir,
    spec: &SimSpec,
    x0: State7,
    output_step_s: f64,
    file: &str,
) -> Result<SimResult<7>, TaskError>
where
    R: Serialize + Default + for<'s> From<&'s Sample<7>>,
{
    let r = simulate_in_paper_layout::<7>(
        &ctx.plant,
        spec,
        x0,
        Recording::Every {
            step_s: output_step_s,
        },
    )?;
    out.write_table(file, r.trajectory.iter().map(R::from))?;
    Ok(r)
}

/// The printed line of a run, `label: peak_theta_deg_after_action = …, …`.
pub fn line(label: &str, r: &SimResult<7>) -> String {
    metrics_line(label, &r.metrics)
}

/// θ(t) and V(t) of several runs overlaid in two panels (Fig. 3b, Fig. 4c), the θ axis
/// symmetric about 0 and fitted to the largest |θ| of all runs.
#[derive(Debug)]
pub struct Overlay {
    /// the hitch-angle panel
    pub theta: Panel,
    /// the speed panel
    pub speed: Panel,
    amplitude_deg: f64,
}

impl Overlay {
    /// Two empty panels with these titles, legends upper right.
    pub fn new(theta_title: &str, speed_title: &str) -> Self {
        Self {
            theta: Panel::new(theta_title, "t [s]", "θ [deg]").legend(Legend::UpperRight),
            speed: Panel::new(speed_title, "t [s]", "V [m/s]").legend(Legend::UpperRight),
            amplitude_deg: 1.0,
        }
    }

    /// Adds a run: θ(t) solid, a cross where control was lost, V(t) with `speed_stroke`.
    pub fn add(&mut self, r: &SimResult<7>, color: Rgb, label: &str, speed_stroke: Stroke) {
        self.amplitude_deg = max_abs_theta_deg(&r.trajectory, self.amplitude_deg);
        self.theta.layers.push(Layer::line(
            theta_deg(&r.trajectory),
            color,
            Stroke::Solid,
            Some(label),
        ));
        if let Some(m) = loss_marker(r, color, Some(&format!("{label}: loss of control"))) {
            self.theta.layers.push(m);
        }
        self.speed.layers.push(Layer::line(
            speed(&r.trajectory),
            color,
            speed_stroke,
            Some(label),
        ));
    }

    /// The finished panels (θ, V), both over `[0, horizon_s]`.
    pub fn panels(self, horizon_s: f64) -> (Panel, Panel) {
        let a = 1.1 * self.amplitude_deg;
        (
            self.theta.x_range(0.0, horizon_s).y_range(-a, a),
            self.speed.x_range(0.0, horizon_s),
        )
    }
}

/// One run of a [`SwayRuns`] task.
#[derive(Debug, Clone)]
pub struct OverlayRun<E> {
    /// its key in `summary.json` and the stem of its CSV file (`T2`, `braking`)
    pub key: String,
    /// the label of its printed metrics line
    pub line: String,
    /// its legend label
    pub label: String,
    /// the colour of its curves
    pub color: Rgb,
    /// the stroke of its speed curve
    pub speed_stroke: Stroke,
    /// the simulation
    pub spec: SimSpec,
    /// what distinguishes it in `summary.json`
    pub about: E,
}

/// A task of several runs from the sway cycle drawn over each other (`fig3b`, `fig4c`).
/// Its config (as written: speeds may be relative to the vehicle, see
/// [`sway::sim::speeds`]) says what differs; the speeds are resolved once per run, then the
/// plan, the settling run, the runs' CSV files, the figure (θ(t) and V(t) of all runs, see
/// [`Overlay`]) and `summary.json` (one [`RunEntry`] per run, keyed by
/// [`OverlayRun::key`], and the resolved speeds) are written once, by the [`Prepared`] of
/// [`Configured`] configs of this trait. A vehicle the speeds do not resolve for (no V_crit:
/// no sway to start from) gets a summary with the reason ([`nothing_to_show`]).
pub trait SwayRuns: TaskConfig + Serialize + ResolveSpeeds {
    /// the task's name (results directory and figure stem), its progress label and the
    /// plan's description of its runs
    const LABELS: (&'static str, &'static str, &'static str);
    /// whether the speed panel is drawn above the hitch-angle panel
    const SPEED_FIRST: bool;
    /// what the task has nothing to show of when its speeds do not resolve
    const NOTHING: &'static str;
    /// what distinguishes a run in `summary.json`
    type About: Serialize;
    /// The empty overlay (the panel titles) and the runs in drawing order.
    fn runs(c: &Self::Resolved) -> (Overlay, Vec<OverlayRun<Self::About>>);
    /// The start on the sway cycle, (horizon, output step) \[s\] and the run settings.
    fn setup(c: &Self::Resolved) -> (&SwayStart, (f64, f64), &RunSettings);
    /// Checks the resolved config (as [`TaskConfig::check`] checks one given in numbers).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the key.
    fn check_resolved(c: &Self::Resolved, file: &Path) -> Result<(), TaskError>;
    /// (settling time, (horizon, output step), runs) for the plan, before resolution.
    fn plan_shape(&self) -> (f64, (f64, f64), usize);
}

/// `summary.json` of a task whose speeds resolved: its headline, then the relative speeds
/// and their values for this vehicle (`"resolved_speeds"`, absent when every speed is a
/// number).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WithSpeeds<H> {
    /// the task's headline
    #[serde(flatten)]
    pub headline: H,
    /// the config's relative speeds and what they resolved to
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub resolved_speeds: Vec<ResolvedSpeed>,
}

/// `summary.json` of a task that has nothing to show for this vehicle.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NothingToShow {
    /// why: what the task has nothing of, and which speed of the config does not resolve
    pub reason: String,
    /// the config key of that speed
    pub unresolved_key: String,
    /// V_crit of the open loop \[m/s\] (null: stable at every speed up to the maximum)
    pub v_crit_mps: Option<f64>,
    /// the fold of cycles \[m/s\] (null: not needed, or no bistable range)
    pub v_fold_mps: Option<f64>,
}

/// Writes the summary of a task with nothing to show for this vehicle (no figure) and
/// reports the reason: `what` (e.g. "no sway to brake from") and the speed that does not
/// resolve.
///
/// # Errors
/// [`TaskError::Write`].
pub fn nothing_to_show<C: Serialize>(
    ctx: &TaskContext<'_>,
    name: &str,
    what: &str,
    unresolved: &UnresolvedSpeed,
    references: &SpeedReferences,
    config: &C,
    file: &Path,
) -> Result<Report, TaskError> {
    let reason = format!("{what}: {}", unresolved.reason);
    ctx.run_staged(
        name,
        &format!("{name}: nothing to show"),
        1,
        config,
        file,
        |_| {
            let lines = vec![format!(
                "{name}: nothing to show for this vehicle — {reason}"
            )];
            let summary = NothingToShow {
                reason,
                unresolved_key: unresolved.key.clone(),
                v_crit_mps: references.v_crit_mps,
                v_fold_mps: references.v_fold_mps,
            };
            Ok((summary, lines))
        },
    )
}

/// A config check on the resolved speeds: a config error says the speeds were resolved
/// for this vehicle, and to what.
pub fn resolved_check(r: Result<(), TaskError>, speeds: &[ResolvedSpeed]) -> Result<(), TaskError> {
    let note = || {
        let list: Vec<String> = speeds
            .iter()
            .map(|s| format!("{} = {} m/s", s.key, s.speed_mps))
            .collect();
        format!(
            " (with the relative speeds resolved for this vehicle: {})",
            list.join(", ")
        )
    };
    r.map_err(|e| match e {
        TaskError::Config { file, key, problem } if !speeds.is_empty() => {
            TaskError::config(file, key, format!("{problem}{}", note()))
        }
        TaskError::Sway(SwayError::Config { file, key, problem }) if !speeds.is_empty() => {
            TaskError::config(file, key, format!("{problem}{}", note()))
        }
        other => other,
    })
}

impl<C: SwayRuns> Prepared for Configured<C> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let (settle, sampling, runs) = self.config.plan_shape();
        series_plan(
            &self.file,
            "",
            sampling,
            runs,
            ("start.settle_s", settle),
            C::LABELS.2,
        )
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let name = C::LABELS.0;
        let resolution = resolve_speeds(&ctx.plant, &ctx.limits, &self.config)?;
        let c = match &resolution.outcome {
            Ok(c) => c,
            Err(u) => {
                return nothing_to_show(
                    ctx,
                    name,
                    C::NOTHING,
                    u,
                    &resolution.references,
                    &self.config,
                    &self.file,
                );
            }
        };
        resolved_check(C::check_resolved(c, &self.file), &resolution.speeds)?;
        let (start, (horizon_s, output_step_s), settings) = C::setup(c);
        let (mut figure, runs) = C::runs(c);
        let steps = runs.len() as u64 + 1;
        ctx.run_staged(name, C::LABELS.1, steps, &self.config, &self.file, |out| {
            let x0 = start.initial().state7(&ctx.plant, &settings.solver)?;
            ctx.progress.advance(1);
            let mut summary = Keyed::default();
            let mut lines = Vec::new();
            for run in runs {
                let r = run_and_write::<SeriesRow>(
                    ctx,
                    out,
                    &run.spec,
                    x0,
                    output_step_s,
                    &format!("{}.csv", run.key),
                )?;
                lines.push(line(&run.line, &r));
                figure.add(&r, run.color, &run.label, run.speed_stroke);
                summary.0.push((
                    run.key,
                    RunEntry {
                        metrics: r.metrics,
                        about: run.about,
                    },
                ));
                ctx.progress.advance(1);
            }
            let (p_th, p_v) = figure.panels(horizon_s);
            let panels = if C::SPEED_FIRST {
                vec![p_v, p_th]
            } else {
                vec![p_th, p_v]
            };
            Figure::column(panels).render(&out.path(name))?;
            let summary = WithSpeeds {
                headline: summary,
                resolved_speeds: resolution.speeds.clone(),
            };
            Ok((summary, lines))
        })
    }
}
