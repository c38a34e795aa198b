//! `cargo xtask simulate FILE.toml`: one user scenario of the full 7-state model.
//! Writes `results/<name>/trajectory.csv` (t, σ1, σ2, σ3, θ, ψ, x_H, y_H, V, δ),
//! `summary.json` (the metrics with the run's `class` and `decay_rate_per_s`) and
//! `trajectory.svg/.png` (θ, the steering angle δ with the actuator's limits and where it
//! saturates, and V versus t, each action marked at its time; the path). Speeds may be given relative to
//! the vehicle (see [`sway::sim::speeds`]); when they do not resolve (a vehicle stable at
//! every speed up to the maximum has no V_crit) the summary says why and there is no run.

use std::path::Path;

use sway::ranging::SpeedSpec;
use sway::control::Actuator;
use sway::sim::{ScenarioConfig, SimResult, SimSpec};
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

/// The times \[s\] at which the scenario acts, each with what happens then (actions at one
/// time together): the speed starting to change (a ramp's start, a table's first changing
/// segment), the controller switched on and off, and `action_s` where the config sets it
/// apart from those (the metrics "after action" count from it; by default it is the
/// earliest of the others).
fn actions(cfg: &ScenarioConfig, spec: &SimSpec) -> Vec<(f64, Vec<&'static str>)> {
    let mut out: Vec<(f64, Vec<&'static str>)> = Vec::new();
    let mut add = |t: f64, what: &'static str| match out.iter_mut().find(|(at, _)| *at == t) {
        Some((_, list)) => list.push(what),
        None => out.push((t, vec![what])),
    };
    if let Some(t) = spec.profile.action_time() {
        add(t, "speed starts to change");
    }
    if let Some(law) = &spec.controller {
        add(law.on_s, "controller on");
        if let Some(off) = law.off_s {
            add(off, "controller off");
        }
    }
    if cfg.action_s.is_some() {
        add(spec.action_s, "action_s (metrics after it)");
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// The stretches of time \[s\] (start, end) where `flag(i)` holds for samples i and i + 1
/// of `t` (a stretch of one sample has zero width and is left out).
fn stretches(t: &[f64], flag: impl Fn(usize) -> bool) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for i in 0..t.len().saturating_sub(1) {
        if flag(i) && flag(i + 1) {
            match out.last_mut() {
                Some(last) if last.1 == t[i] => last.1 = t[i + 1],
                _ => out.push((t[i], t[i + 1])),
            }
        }
    }
    out
}

/// Relative tolerance of a recorded δ at its saturation δ_max, and of a recorded rate at
/// the rate limit δ̇_max (a rate-limited actuator approaches its saturated command
/// exponentially; the recorded rate is a difference over the output step).
const LIMIT_TOLERANCE: f64 = 1e-3;

/// The steering panel: δ(t) \[deg\] (the controller's command plus any steering input, as
/// applied), the steering limits ±δ_max of the law's actuator, and shaded where the
/// actuator saturates (|δ| at δ_max) or is rate-limited (|dδ/dt| at δ̇_max).
fn steering_panel(spec: &SimSpec, r: &SimResult<7>, horizon: f64) -> Panel {
    let t: Vec<f64> = r.trajectory.iter().map(|s| s.t).collect();
    let delta: Vec<f64> = r.trajectory.iter().map(|s| s.steering_angle.to_degrees()).collect();
    let title = match &spec.controller {
        None => "steering angle (open loop: no controller)".to_string(),
        Some(l) if l.actuator == Actuator::DifferentialBraking => format!(
            "steering angle (the {} controller brakes: its yaw moment M_z is not drawn)",
            l.structure.as_str()
        ),
        Some(l) => format!("steering angle commanded by the {} controller", l.structure.as_str()),
    };
    let mut p = Panel::new(&title, "t [s]", "δ [deg]")
        .with(Layer::line(
            t.iter().copied().zip(delta.iter().copied()).collect(),
            Rgb::BLUE,
            Stroke::Solid,
            Some("δ(t)"),
        ))
        .legend(Legend::UpperRight)
        .x_range(0.0, horizon);
    let limits = spec
        .controller
        .filter(|l| l.actuator == Actuator::Steering)
        .map(|l| l.steering_limits)
        .unwrap_or_default();
    let mut amp = delta.iter().fold(0.1_f64, |a, d| a.max(d.abs()));
    if let Some(max) = limits.max_angle_deg {
        amp = amp.max(max);
        p.layers.push(Layer::line(
            vec![(0.0, max), (horizon, max), (f64::NAN, f64::NAN), (0.0, -max), (horizon, -max)],
            Rgb::GREY,
            Stroke::Dotted,
            Some(&format!("±δ_max = ±{max}°")),
        ));
        let at_limit = |i: usize| delta[i].abs() >= (1.0 - LIMIT_TOLERANCE) * max;
        let spans = stretches(&t, at_limit);
        let label = format!("saturated: |δ| = δ_max (within {} %)", 100.0 * LIMIT_TOLERANCE);
        for (k, (a, b)) in spans.into_iter().enumerate() {
            p.layers.push(Layer::band(a, b, Rgb::RED, (k == 0).then_some(label.as_str())));
        }
    }
    if let Some(rate) = limits.max_rate_deg_s {
        let rate_at = |i: usize| {
            let j = (i + 1).min(t.len() - 1);
            let i = j.saturating_sub(1);
            (delta[j] - delta[i]).abs() / (t[j] - t[i]) >= (1.0 - LIMIT_TOLERANCE) * rate
        };
        let spans = stretches(&t, rate_at);
        let label = format!("rate-limited: |dδ/dt| = {rate}°/s");
        for (k, (a, b)) in spans.into_iter().enumerate() {
            p.layers.push(Layer::band(a, b, Rgb::ORANGE, (k == 0).then_some(label.as_str())));
        }
    }
    with_legend_room(p, 1.15 * amp)
}

/// `p` with the y range ±`top` raised above `top` by the room its legend needs (its
/// labelled layers, one row each, in a panel of [`Figure::column`]'s height), so that the
/// legend stays inside the axes above the curves and the action markers (which stop at
/// ±`top`) rather than beside the axes, where it would narrow them.
fn with_legend_room(p: Panel, top: f64) -> Panel {
    let rows = p
        .layers
        .iter()
        .filter(|l| match l {
            Layer::Line { label, .. } | Layer::Markers { label, .. } | Layer::Band { label, .. } => {
                label.is_some()
            }
            _ => false,
        })
        .count() as f64;
    // legend height (2 × 8 px padding, 19 px a row, 8 px inset, 4 px clearance) over the
    // 284 px of a column panel's axes, and a little more
    let f = ((28.0 + 19.0 * rows) / 284.0 + 0.03).min(0.6);
    p.y_range(-top, top * (1.0 + f) / (1.0 - f))
}

/// θ(t) with the actions (speed change, controller on and off) and the loss of control;
/// δ(t) with the actuator's limits and where it saturates; V(t); the hitch's path.
fn figure(cfg: &ScenarioConfig, spec: &SimSpec, r: &SimResult<7>) -> Figure {
    let theta: Vec<(f64, f64)> = r
        .trajectory
        .iter()
        .map(|s| (s.t, s.x[3].to_degrees()))
        .collect();
    let speed: Vec<(f64, f64)> = r.trajectory.iter().map(|s| (s.t, s.speed)).collect();
    let path: Vec<(f64, f64)> = r.trajectory.iter().map(|s| (s.x[5], s.x[6])).collect();
    let horizon = cfg.horizon_s.get();
    let amp = max_abs_theta_deg(&r.trajectory, 1.0);
    // an action at t = 0 is where the axis is: said in the title, not drawn on it
    let (at_start, later): (Vec<_>, Vec<_>) =
        actions(cfg, spec).into_iter().partition(|(t, _)| *t <= 0.0);
    let title = match at_start.first() {
        None => format!("{}: hitch angle", cfg.name),
        Some((_, what)) => format!("{}: hitch angle ({} from t = 0)", cfg.name, what.join(", ")),
    };
    let mut p1 = Panel::new(&title, "t [s]", "θ [deg]")
        .with(Layer::line(theta, Rgb::BLUE, Stroke::Solid, Some("θ(t)")))
        .legend(Legend::UpperRight)
        .x_range(0.0, horizon);
    let mut p2 = steering_panel(spec, r, horizon);
    let delta_range = p2.y_range.map_or((-1.0, 1.0), |(lo, _)| (lo, -lo));
    for (k, (t, what)) in later.iter().enumerate() {
        let stroke = if k % 2 == 0 { Stroke::Dotted } else { Stroke::Dashed };
        let color = Rgb::palette(k + 2);
        let label = format!("{} at t = {t} s", what.join(", "));
        p1.layers
            .push(Layer::vline(*t, (-1.1 * amp, 1.1 * amp), color, stroke, Some(&label)));
        p2.layers.push(Layer::vline(*t, delta_range, color, stroke, None));
    }
    if let Some(m) = loss_marker(r, Rgb::RED, Some("loss of control (validity guard)")) {
        p1.layers.push(m);
    }
    let p1 = with_legend_room(p1, 1.1 * amp);
    let p3 = Panel::new("prescribed speed", "t [s]", "V [m/s]")
        .with(Layer::line(speed, Rgb::ORANGE, Stroke::Solid, Some("V(t)")))
        .x_range(0.0, horizon);
    let p4 = Panel::new("path of the hitch point", "x_H [m]", "y_H [m]")
        .with(Layer::line(
            path,
            Rgb::GREEN,
            Stroke::Solid,
            Some("(x_H, y_H)"),
        ))
        .legend(Legend::UpperLeft);
    Figure::column(vec![p1, p2, p3, p4])
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
            figure(cfg, &run.spec, &run.result).render(&out.path("trajectory"))?;
            let lines = vec![line(&cfg.name, &run.result), class_line(&cfg.name, &run.result)];
            let summary = WithSpeeds {
                headline: scenario.summary(),
                resolved_speeds: speeds,
            };
            Ok((SeriesHeadline::Shown(summary), lines))
        })
    }
}
