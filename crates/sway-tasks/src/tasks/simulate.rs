//! `cargo xtask simulate FILE.toml`: one user scenario of the full 7-state model.
//! Writes `results/<name>/trajectory.csv` (t, σ1, σ2, σ3, θ, ψ, x_H, y_H, V, δ),
//! `summary.json` (the metrics with the run's `class` and `decay_rate_per_s`) and
//! `trajectory.svg/.png` (θ and V versus t, and the path). Speeds may be given relative to
//! the vehicle (see [`sway::sim::speeds`]); when they do not resolve (a vehicle stable at
//! every speed up to the maximum has no V_crit) the summary says why and there is no run.

use std::path::Path;

use sway::ranging::SpeedSpec;
use sway::sim::{ScenarioConfig, SimResult};
pub use sway_studies::simulate::{Scenario, ScenarioRun, ScenarioSummary, compute};

use super::series::{SeriesHeadline, WithSpeeds, line, resolved, write_runs};
use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig};
use crate::limits::{Plan, series_plan};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::report::{TrajectoryRow, loss_marker, max_abs_theta_deg};

/// The task (its default config is an example scenario).
pub const TASK: Task = Task::configured::<ScenarioConfig<SpeedSpec>>(
    "simulate",
    "simulate a user scenario (TOML): trajectory, metrics, figure",
    "scenario_example.toml",
)
.any_model();

impl TaskConfig for ScenarioConfig<SpeedSpec> {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        Ok(self.validate_spec(file)?)
    }

    fn load_named_files(&mut self, file: &Path) -> Result<(), TaskError> {
        crate::config_file::load_prediction_vehicle(&mut self.controller, file, "controller")
    }
}

/// θ(t) with the action time and the loss of control, V(t), and the hitch's path.
fn figure(cfg: &ScenarioConfig, action_s: f64, r: &SimResult<7>) -> Figure {
    let theta: Vec<(f64, f64)> = r
        .trajectory
        .iter()
        .map(|s| (s.t, s.x[3].to_degrees()))
        .collect();
    let speed: Vec<(f64, f64)> = r.trajectory.iter().map(|s| (s.t, s.speed)).collect();
    let path: Vec<(f64, f64)> = r.trajectory.iter().map(|s| (s.x[5], s.x[6])).collect();
    let horizon = cfg.horizon_s.get();
    let mut p1 = Panel::new(&format!("{}: hitch angle", cfg.name), "t [s]", "θ [deg]")
        .with(Layer::line(theta, Rgb::BLUE, Stroke::Solid, Some("θ(t)")))
        .legend(Legend::UpperRight)
        .x_range(0.0, horizon);
    p1.layers.push(Layer::vline(
        action_s,
        (-90.0, 90.0),
        Rgb::GREY,
        Stroke::Dotted,
        Some(&format!("action at t = {action_s} s")),
    ));
    if let Some(m) = loss_marker(r, Rgb::RED, Some("loss of control (validity guard)")) {
        p1.layers.push(m);
    }
    let amp = max_abs_theta_deg(&r.trajectory, 1.0);
    p1 = p1.y_range(-1.1 * amp, 1.1 * amp);
    let p2 = Panel::new("prescribed speed", "t [s]", "V [m/s]")
        .with(Layer::line(speed, Rgb::ORANGE, Stroke::Solid, Some("V(t)")))
        .x_range(0.0, horizon);
    let p3 = Panel::new("path of the hitch point", "x_H [m]", "y_H [m]")
        .with(Layer::line(
            path,
            Rgb::GREEN,
            Stroke::Solid,
            Some("(x_H, y_H)"),
        ))
        .legend(Legend::UpperLeft);
    Figure::column(vec![p1, p2, p3])
}

/// The run's class (sustained sway, decaying with its decay rate, offset, settled, loss of
/// control: [`sway::sim::classify`]).
fn class_line(name: &str, r: &SimResult<7>) -> String {
    let m = &r.metrics;
    let rate = m
        .decay_rate_per_s
        .map_or(String::new(), |d| format!(", amplitude decay rate {d:.4} 1/s"));
    format!("{name}: class {}{rate}", m.class.as_str())
}

impl Prepared for Configured<ScenarioConfig<SpeedSpec>> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        series_plan(
            &self.file,
            "",
            (c.horizon_s.get(), c.output_step_s.get()),
            1,
            ("initial.settle_s", c.initial.settle_s()),
            &format!("simulate {}", c.name),
        )
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let name = self.config.name.as_str();
        let stage = format!("simulate {name}");
        ctx.run_staged(name, &stage, 2, &self.config, &self.file, |out| {
            let (plant, limits) = (&ctx.plant, &ctx.limits);
            let resolution = compute(&self.config, plant, limits, &self.file, true, ctx.progress)?;
            let what = "no scenario for this vehicle";
            let (scenario, speeds) = match resolved(name, what, resolution) {
                Ok(resolved) => resolved,
                Err(nothing) => return Ok(nothing),
            };
            let (cfg, run) = (&scenario.config, &scenario.run);
            write_runs::<TrajectoryRow, _>(out, std::slice::from_ref(run))?;
            figure(cfg, run.spec.action_s, &run.result).render(&out.path("trajectory"))?;
            let lines = vec![line(&cfg.name, &run.result), class_line(&cfg.name, &run.result)];
            let summary = WithSpeeds {
                headline: scenario.summary(),
                resolved_speeds: speeds,
            };
            Ok((SeriesHeadline::Shown(summary), lines))
        })
    }
}
