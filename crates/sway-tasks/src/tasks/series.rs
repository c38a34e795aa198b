//! The one skeleton of writing the time-series tasks (`fig3a` panels, `fig3b`, `fig4c`,
//! `simulate`), whose runs their studies compute ([`sway_studies::simulate`]): every run is
//! written as one CSV of typed rows, drawn, and summarised by its [`sway::sim::Metrics`] plus what
//! distinguishes it ([`RunEntry`]). The tasks of several runs from the sway cycle drawn over
//! each other (`fig3b`, `fig4c`) share all of their [`Prepared`] through [`SwayRuns`].

use crate::TaskError;
use serde::Serialize;
use std::path::Path;

use sway::SwayError;
use sway::ranging::SpeedReferences;
use sway::sim::speeds::{Resolution, ResolveSpeeds, ResolvedSpeed, UnresolvedSpeed};
use sway::sim::{Sample, SimResult};
pub use sway_studies::simulate::RunEntry;
use sway_studies::simulate::{Runs, SeriesRun, with_resolved_speeds};

use super::{Prepared, Report, TaskContext};
use crate::config_file::{Configured, TaskConfig};
use crate::io::{Keyed, OutputDir};
use crate::limits::{Plan, series_plan};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::report::{SeriesRow, loss_marker, max_abs_theta_deg, metrics_line, speed, theta_deg};

/// Writes the samples of every run to `<key>.csv` as rows `R` (e.g.
/// [`crate::report::SeriesRow`]).
///
/// # Errors
/// [`TaskError::Write`].
pub fn write_runs<R, E>(out: &OutputDir, runs: &[SeriesRun<E>]) -> Result<(), TaskError>
where
    R: Serialize + Default + for<'s> From<&'s Sample<7>>,
{
    for run in runs {
        let rows = run.result.trajectory.iter().map(R::from);
        out.write_table(&format!("{}.csv", run.key), rows)?;
    }
    Ok(())
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

/// How a run of a [`SwayRuns`] task is printed and drawn.
#[derive(Debug, Clone)]
pub struct RunStyle {
    /// the label of its printed metrics line
    pub line: String,
    /// its legend label
    pub label: String,
    /// the colour of its curves
    pub color: Rgb,
    /// the stroke of its speed curve
    pub speed_stroke: Stroke,
}

/// A task of several runs from the sway cycle drawn over each other (`fig3b`, `fig4c`).
/// Its study computes the runs (the speeds of the config resolved for the vehicle, see
/// [`sway::sim::speeds`]); the runs' CSV files, the figure (θ(t) and V(t) of all runs, see
/// [`Overlay`]) and `summary.json` (one [`RunEntry`] per run, keyed by its key, and the
/// resolved speeds) are written once, by the [`Prepared`] of [`Configured`] configs of this
/// trait. A vehicle the speeds do not resolve for (no V_crit: no sway to start from) gets a
/// summary with the reason ([`NothingToShow`]).
pub trait SwayRuns: TaskConfig + Serialize + ResolveSpeeds {
    /// the task's name (results directory and figure stem), its progress label and the
    /// plan's description of its runs
    const LABELS: (&'static str, &'static str, &'static str);
    /// whether the speed panel is drawn above the hitch-angle panel
    const SPEED_FIRST: bool;
    /// what the task has nothing to show of when its speeds do not resolve
    const NOTHING: &'static str;
    /// what distinguishes a run in `summary.json`
    type About: Serialize + Clone;
    /// The task's study on the vehicle of `ctx` (`file` names the config in messages).
    ///
    /// # Errors
    /// A config error of the resolved config, or numerical failures.
    fn compute(
        &self,
        ctx: &TaskContext<'_>,
        file: &Path,
    ) -> Result<Resolution<SwayRunsOf<Self>>, SwayError>;
    /// The empty overlay (the panel titles) and the horizon \[s\] of the resolved config.
    fn overlay(c: &Self::Resolved) -> (Overlay, f64);
    /// How the `i`-th run is printed and drawn.
    fn style(i: usize, run: &SeriesRun<Self::About>) -> RunStyle;
    /// (settling time, (horizon, output step), runs) for the plan, before resolution.
    fn plan_shape(&self) -> (f64, (f64, f64), usize);
}

/// The runs a [`SwayRuns`] task computes, and the config they ran with.
pub type SwayRunsOf<C> = Runs<<C as ResolveSpeeds>::Resolved, <C as SwayRuns>::About>;

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

impl NothingToShow {
    /// The summary of task `name` with nothing to show for this vehicle, and its printed
    /// line: `what` (e.g. "no sway to brake from") and the speed that does not resolve.
    pub fn of(
        name: &str,
        what: &str,
        unresolved: &UnresolvedSpeed,
        references: &SpeedReferences,
    ) -> (Self, Vec<String>) {
        let reason = format!("{what}: {}", unresolved.reason);
        let lines = vec![format!(
            "{name}: nothing to show for this vehicle — {reason}"
        )];
        let summary = Self {
            reason,
            unresolved_key: unresolved.key.clone(),
            v_crit_mps: references.v_crit_mps,
            v_fold_mps: references.v_fold_mps,
        };
        (summary, lines)
    }
}

/// `summary.json` of a task whose speeds may not resolve for the vehicle: its headline with
/// the resolved speeds, or why there is nothing to show.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum SeriesHeadline<H> {
    /// the speeds resolved
    Shown(WithSpeeds<H>),
    /// they did not
    Nothing(NothingToShow),
}

/// The headline of `summary.json` and the printed lines of a task.
pub type Headed<H> = (SeriesHeadline<H>, Vec<String>);

/// The outcome of a study whose speeds resolved and those speeds, or (`Err`) the summary
/// and printed line of task `name` with nothing to show: `what` (e.g. "no sway to brake
/// from") and the speed that does not resolve ([`NothingToShow::of`]).
pub fn resolved<T, H>(
    name: &str,
    what: &str,
    resolution: Resolution<T>,
) -> Result<(T, Vec<ResolvedSpeed>), Headed<H>> {
    match resolution.outcome {
        Ok(study) => Ok((study, resolution.speeds)),
        Err(u) => {
            let (summary, lines) = NothingToShow::of(name, what, &u, &resolution.references);
            Err((SeriesHeadline::Nothing(summary), lines))
        }
    }
}

/// Writes the summary of a task with nothing to show for this vehicle (no figure) and
/// reports the reason ([`NothingToShow::of`]).
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
    ctx.run_staged(
        name,
        &format!("{name}: nothing to show"),
        1,
        config,
        file,
        |_| Ok(NothingToShow::of(name, what, unresolved, references)),
    )
}

/// A config check on the resolved speeds: a config error says the speeds were resolved
/// for this vehicle, and to what ([`with_resolved_speeds`]).
pub fn resolved_check(r: Result<(), TaskError>, speeds: &[ResolvedSpeed]) -> Result<(), TaskError> {
    r.map_err(|e| match e {
        TaskError::Config { file, key, problem } => {
            with_resolved_speeds(SwayError::Config { file, key, problem }, speeds).into()
        }
        TaskError::Sway(e) => with_resolved_speeds(e, speeds).into(),
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
        let steps = self.config.plan_shape().2 as u64 + 1;
        ctx.run_staged(name, C::LABELS.1, steps, &self.config, &self.file, |out| {
            let resolution = self.config.compute(ctx, &self.file)?;
            let (study, speeds) = match resolved(name, C::NOTHING, resolution) {
                Ok(resolved) => resolved,
                Err(nothing) => return Ok(nothing),
            };
            write_runs::<SeriesRow, _>(out, &study.runs)?;
            let (mut figure, horizon_s) = C::overlay(&study.config);
            let mut summary = Keyed::default();
            let mut lines = Vec::new();
            for (i, run) in study.runs.iter().enumerate() {
                let style = C::style(i, run);
                lines.push(line(&style.line, &run.result));
                figure.add(&run.result, style.color, &style.label, style.speed_stroke);
                summary.0.push((run.key.clone(), run.entry()));
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
                resolved_speeds: speeds,
            };
            Ok((SeriesHeadline::Shown(summary), lines))
        })
    }
}
