//! `cargo xtask simulate FILE.toml`: one user scenario of the full 7-state model.
//! Writes `results/<name>/trajectory.csv` (t, σ1, σ2, σ3, θ, ψ, x_H, y_H, V, δ),
//! `summary.json` and `trajectory.svg/.png` (θ and V versus t, and the path).

use std::path::{Path, PathBuf};

use serde_json::{Map, json};

use super::{Prepared, Report, Task, TaskContext};
use crate::SwayError;
use crate::config::load_toml;
use crate::io::OutputDir;
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::sim::report::{
    TRAJECTORY_HEADER, loss_marker, metrics_json, metrics_line, trajectory_rows,
};
use crate::sim::{Recording, ScenarioConfig, simulate};

/// The task (its default config is an example scenario).
pub const TASK: Task = Task {
    name: "simulate",
    about: "simulate a user scenario (TOML): trajectory, metrics, figure",
    config: "scenario_example.toml",
    prepare,
};

struct SimulateTask {
    file: PathBuf,
    config: ScenarioConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let config: ScenarioConfig = load_toml(file)?;
    config.validate(file)?;
    Ok(Box::new(SimulateTask {
        file: file.to_path_buf(),
        config,
    }))
}

impl Prepared for SimulateTask {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let cfg = &self.config;
        let out = OutputDir::create(&ctx.results_dir, &cfg.name)?;
        ctx.progress.start(&format!("simulate {}", cfg.name), 2);
        let x0 = cfg.initial.state7(&ctx.model, &cfg.solver)?;
        ctx.progress.advance(1);
        let spec = cfg.spec();
        let r = simulate::<7>(
            &ctx.model,
            &spec,
            x0,
            Recording::Every {
                step_s: cfg.output_step_s,
            },
        )?;
        ctx.progress.advance(1);
        out.write_csv(
            "trajectory.csv",
            &TRAJECTORY_HEADER,
            trajectory_rows(&r.trajectory),
        )?;

        let theta: Vec<(f64, f64)> = r
            .trajectory
            .iter()
            .map(|s| (s.t, s.x[3].to_degrees()))
            .collect();
        let speed: Vec<(f64, f64)> = r.trajectory.iter().map(|s| (s.t, s.speed)).collect();
        let path: Vec<(f64, f64)> = r.trajectory.iter().map(|s| (s.x[5], s.x[6])).collect();
        let mut p1 = Panel::new(&format!("{}: hitch angle", cfg.name), "t [s]", "θ [deg]")
            .with(Layer::line(theta, Rgb::BLUE, Stroke::Solid, Some("θ(t)")))
            .legend(Legend::UpperRight)
            .x_range(0.0, cfg.horizon_s);
        p1.layers.push(Layer::vline(
            spec.action_s,
            (-90.0, 90.0),
            Rgb::GREY,
            Stroke::Dotted,
            Some(&format!("action at t = {} s", spec.action_s)),
        ));
        if let Some(m) = loss_marker(&r, Rgb::RED, Some("loss of control (validity guard)")) {
            p1.layers.push(m);
        }
        let amp = r
            .trajectory
            .iter()
            .map(|s| s.x[3].to_degrees().abs())
            .fold(1.0, f64::max);
        p1 = p1.y_range(-1.1 * amp, 1.1 * amp);
        let p2 = Panel::new("prescribed speed", "t [s]", "V [m/s]")
            .with(Layer::line(speed, Rgb::ORANGE, Stroke::Solid, Some("V(t)")))
            .x_range(0.0, cfg.horizon_s);
        let p3 = Panel::new("path of the hitch point", "x_H [m]", "y_H [m]")
            .with(Layer::line(
                path,
                Rgb::GREEN,
                Stroke::Solid,
                Some("(x_H, y_H)"),
            ))
            .legend(Legend::UpperLeft);
        Figure::column(vec![p1, p2, p3]).render(&out.path("trajectory"))?;

        let mut summary = Map::new();
        summary.insert("name".into(), json!(cfg.name));
        if let serde_json::Value::Object(m) = metrics_json(&r.metrics) {
            summary.extend(m);
        }
        summary.insert("action_s".into(), json!(spec.action_s));
        summary.insert("t_end_s".into(), json!(r.t_end));
        summary.insert("accepted_steps".into(), json!(r.stats.accepted));
        summary.insert("rejected_steps".into(), json!(r.stats.rejected));
        out.write_summary(summary, cfg, &ctx.run_info(&self.file))?;
        ctx.progress.finish();
        let dir = out.commit()?;
        Ok(Report {
            task: cfg.name.clone(),
            output_dir: dir,
            lines: vec![metrics_line(&cfg.name, &r.metrics)],
        })
    }
}
