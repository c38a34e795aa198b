//! `cargo xtask fig4c` (paper Fig. 4c): suppressing sway from the sway cycle at
//! V0 = 35 m/s with four strategies acting from t = 10 s: `"none"`, `"steering"`
//! (δ = −D·ψ̇(t − τ), τ = 0.2 s, D = 0.1 s), `"braking"` (−10 m/s over 5 s) and
//! `"combined"`; θ(t) of the four overlaid, metrics per strategy in `summary.json`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};

use super::fig3b::SwayStart;
use super::{Prepared, Report, Task, TaskContext};
use crate::SwayError;
use crate::config::{ensure, ensure_time_span, load_toml};
use crate::io::OutputDir;
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::sim::report::{
    SERIES_HEADER, loss_marker, metrics_json, metrics_line, series_rows, speed, theta_deg,
};
use crate::sim::{
    Controller, MetricSettings, Recording, SimSpec, SolverSettings, SpeedProfile, ValidityGuard,
    simulate,
};

/// The task.
pub const TASK: Task = Task {
    name: "fig4c",
    about: "paper Fig. 4c: sway suppression by braking, steering, and both",
    config: "fig4c.toml",
    prepare,
};

/// The steering controller of the strategies "steering" and "combined".
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteeringConfig {
    /// D [s]
    pub gain_s: f64,
    /// τ [s]
    pub delay_s: f64,
    /// switched off at this time [s] (never when absent)
    #[serde(default)]
    pub off_s: Option<f64>,
}

/// The braking of the strategies "braking" and "combined".
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrakingConfig {
    /// ΔV [m/s] (negative)
    pub speed_change_mps: f64,
    /// T [s]
    pub duration_s: f64,
}

/// `configs/fig4c.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig4cConfig {
    /// the sway-cycle start
    pub start: SwayStart,
    /// every action starts here [s]
    pub action_s: f64,
    /// horizon [s]
    pub horizon_s: f64,
    /// sampling of the plotted series [s]
    pub output_step_s: f64,
    /// steering
    pub steering: SteeringConfig,
    /// braking
    pub braking: BrakingConfig,
    /// validity guard
    #[serde(default)]
    pub guard: ValidityGuard,
    /// tolerances
    #[serde(default)]
    pub solver: SolverSettings,
    /// metric settings
    #[serde(default)]
    pub metrics: MetricSettings,
}

/// The four strategies in plotting order: (key, braking?, steering?, colour).
pub const STRATEGIES: [(&str, bool, bool, Rgb); 4] = [
    ("none", false, false, Rgb::RED),
    ("steering", false, true, Rgb::BLUE),
    ("braking", true, false, Rgb::ORANGE),
    ("combined", true, true, Rgb::GREEN),
];

impl Fig4cConfig {
    /// The run of one strategy.
    pub fn spec(&self, braking: bool, steering: bool) -> SimSpec {
        let v0 = self.start.speed_mps;
        SimSpec {
            profile: if braking {
                SpeedProfile::Ramp {
                    initial_mps: v0,
                    change_mps: self.braking.speed_change_mps,
                    start_s: self.action_s,
                    duration_s: self.braking.duration_s,
                }
            } else {
                SpeedProfile::Constant { speed_mps: v0 }
            },
            controller: if steering {
                Controller::YawRateFeedback {
                    gain_s: self.steering.gain_s,
                    delay_s: self.steering.delay_s,
                    on_s: self.action_s,
                    off_s: self.steering.off_s,
                }
            } else {
                Controller::None
            },
            horizon_s: self.horizon_s,
            action_s: self.action_s,
            guard: self.guard,
            solver: self.solver,
            metrics: self.metrics,
        }
    }
}

struct Fig4cTask {
    file: PathBuf,
    config: Fig4cConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let c: Fig4cConfig = load_toml(file)?;
    c.start.validate(file, "start")?;
    ensure_time_span(c.horizon_s, c.output_step_s, file, "")?;
    ensure(
        c.action_s.is_finite() && (0.0..c.horizon_s).contains(&c.action_s),
        file,
        "action_s",
        || format!("expected 0 <= action_s < horizon_s, got {}", c.action_s),
    )?;
    {
        // the combined strategy has both the braking and the steering of the others
        let spec = c.spec(true, true);
        spec.profile
            .validate()
            .map_err(|(k, p)| SwayError::config(file, format!("braking ({k})"), p))?;
        spec.controller
            .validate()
            .map_err(|(k, p)| SwayError::config(file, format!("steering.{k}"), p))?;
    }
    c.solver
        .validate()
        .map_err(|(k, p)| SwayError::config(file, format!("solver.{k}"), p))?;
    Ok(Box::new(Fig4cTask {
        file: file.to_path_buf(),
        config: c,
    }))
}

impl Prepared for Fig4cTask {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let c = &self.config;
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress
            .start("fig4c: strategies", STRATEGIES.len() as u64 + 1);
        let x0 = c.start.initial().state7(&ctx.model, &c.solver)?;
        ctx.progress.advance(1);
        let mut summary = Map::new();
        let mut lines = Vec::new();
        let mut p_th = Panel::new(
            &format!(
                "Fig. 4c: sway suppression from V0 = {} m/s, action at t = {} s",
                c.start.speed_mps, c.action_s
            ),
            "t [s]",
            "θ [deg]",
        )
        .legend(Legend::UpperRight);
        let mut p_v = Panel::new("speed", "t [s]", "V [m/s]").legend(Legend::UpperRight);
        let mut amp: f64 = 1.0;
        for (key, braking, steering, color) in STRATEGIES {
            let spec = c.spec(braking, steering);
            let r = simulate::<7>(
                &ctx.model,
                &spec,
                x0,
                Recording::Every {
                    step_s: c.output_step_s,
                },
            )?;
            out.write_csv(
                &format!("{key}.csv"),
                &SERIES_HEADER,
                series_rows(&r.trajectory),
            )?;
            let mut e = metrics_json(&r.metrics);
            if let Value::Object(m) = &mut e {
                m.insert("braking".into(), json!(braking));
                m.insert("steering".into(), json!(steering));
            }
            summary.insert(key.into(), e);
            lines.push(metrics_line(&format!("fig4c {key}"), &r.metrics));
            amp = r
                .trajectory
                .iter()
                .map(|s| s.x[3].to_degrees().abs())
                .fold(amp, f64::max);
            p_th.layers.push(Layer::line(
                theta_deg(&r.trajectory),
                color,
                Stroke::Solid,
                Some(key),
            ));
            if let Some(m) = loss_marker(&r, color, Some(&format!("{key}: loss of control"))) {
                p_th.layers.push(m);
            }
            // the speed profiles coincide in pairs: steering-only runs dashed on top
            let stroke = if steering {
                Stroke::Dashed
            } else {
                Stroke::Solid
            };
            p_v.layers
                .push(Layer::line(speed(&r.trajectory), color, stroke, Some(key)));
            ctx.progress.advance(1);
        }
        p_th = p_th
            .x_range(0.0, c.horizon_s)
            .y_range(-1.1 * amp, 1.1 * amp);
        p_v = p_v.x_range(0.0, c.horizon_s);
        Figure::column(vec![p_th, p_v]).render(&out.path("fig4c"))?;
        out.write_summary(summary, c, &ctx.run_info(&self.file))?;
        ctx.progress.finish();
        let dir = out.commit()?;
        Ok(Report {
            task: TASK.name.into(),
            output_dir: dir,
            lines,
        })
    }
}
