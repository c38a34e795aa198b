//! `cargo xtask fig3b` (paper Fig. 3b): braking out of sway. Start on the sway cycle at
//! V0 = 35 m/s, lower V by 10 m/s over T ∈ {2, 3, 5, 10} s from t = 2 s, 40 s horizon;
//! panels V(t) and θ(t); metrics per T in `summary.json` under `"T2"`, `"T3"`, `"T5"`, `"T10"`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};

use super::{Prepared, Report, Task, TaskContext};
use crate::SwayError;
use crate::config::{ensure, ensure_positive, ensure_time_span, load_toml};
use crate::io::OutputDir;
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::sim::report::{
    SERIES_HEADER, loss_marker, metrics_json, metrics_line, series_rows, speed, theta_deg,
};
use crate::sim::{
    Controller, InitialCondition, MetricSettings, Recording, SimSpec, SolverSettings, SpeedProfile,
    ValidityGuard, simulate,
};

/// The task.
pub const TASK: Task = Task {
    name: "fig3b",
    about: "paper Fig. 3b: braking out of sway with T = 2, 3, 5, 10 s",
    config: "fig3b.toml",
    prepare,
};

/// Start on the sway cycle (shared by fig3b and fig4c).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SwayStart {
    /// V0 [m/s]
    pub speed_mps: f64,
    /// settling time at V0 [s]
    pub settle_s: f64,
    /// initial perturbation of the settling run θ(0) [rad]
    pub theta0_rad: f64,
}

impl SwayStart {
    /// As an initial condition.
    pub fn initial(&self) -> InitialCondition {
        InitialCondition::SwayCycle {
            speed_mps: self.speed_mps,
            settle_s: self.settle_s,
            theta0_rad: self.theta0_rad,
        }
    }

    /// Checks the keys under `prefix`.
    ///
    /// # Errors
    /// [`SwayError::Config`].
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), SwayError> {
        ensure_positive(
            self.speed_mps,
            file,
            &format!("{prefix}.speed_mps"),
            "a speed > 0 m/s",
        )?;
        ensure(
            self.settle_s.is_finite() && self.settle_s >= 0.0,
            file,
            &format!("{prefix}.settle_s"),
            || format!("expected a time >= 0 s, got {}", self.settle_s),
        )?;
        ensure(
            self.theta0_rad.is_finite() && self.theta0_rad.abs() < 1.5,
            file,
            &format!("{prefix}.theta0_rad"),
            || format!("expected |θ(0)| < 1.5 rad, got {}", self.theta0_rad),
        )
    }
}

/// `configs/fig3b.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig3bConfig {
    /// the sway-cycle start
    pub start: SwayStart,
    /// t_b [s]: braking starts
    pub brake_start_s: f64,
    /// ΔV [m/s] (negative: braking)
    pub speed_change_mps: f64,
    /// the ramp durations T [s], one run each
    pub brake_durations_s: Vec<f64>,
    /// horizon [s]
    pub horizon_s: f64,
    /// sampling of the plotted series [s]
    pub output_step_s: f64,
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

/// The summary key of a braking time: `T2`, `T3`, `T5`, `T10` (`T2.5` for 2.5 s).
pub fn duration_key(t: f64) -> String {
    format!("T{t}")
}

struct Fig3bTask {
    file: PathBuf,
    config: Fig3bConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let c: Fig3bConfig = load_toml(file)?;
    c.start.validate(file, "start")?;
    ensure_time_span(c.horizon_s, c.output_step_s, file, "")?;
    ensure(
        c.brake_start_s.is_finite() && (0.0..c.horizon_s).contains(&c.brake_start_s),
        file,
        "brake_start_s",
        || {
            format!(
                "expected 0 <= brake_start_s < horizon_s, got {}",
                c.brake_start_s
            )
        },
    )?;
    ensure(
        c.speed_change_mps.is_finite() && c.start.speed_mps + c.speed_change_mps > 0.0,
        file,
        "speed_change_mps",
        || {
            format!(
                "the final speed must stay > 0 m/s, got {}",
                c.start.speed_mps + c.speed_change_mps
            )
        },
    )?;
    ensure(
        !c.brake_durations_s.is_empty()
            && c.brake_durations_s
                .iter()
                .all(|t| t.is_finite() && *t > 0.0),
        file,
        "brake_durations_s",
        || {
            format!(
                "expected a list of durations > 0 s, got {:?}",
                c.brake_durations_s
            )
        },
    )?;
    c.solver
        .validate()
        .map_err(|(k, p)| SwayError::config(file, format!("solver.{k}"), p))?;
    Ok(Box::new(Fig3bTask {
        file: file.to_path_buf(),
        config: c,
    }))
}

impl Prepared for Fig3bTask {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let c = &self.config;
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress
            .start("fig3b: braking", c.brake_durations_s.len() as u64 + 1);
        let x0 = c.start.initial().state7(&ctx.model, &c.solver)?;
        ctx.progress.advance(1);
        let mut summary = Map::new();
        let mut lines = Vec::new();
        let mut p_v =
            Panel::new("Fig. 3b: speed profiles", "t [s]", "V [m/s]").legend(Legend::UpperRight);
        let mut p_th = Panel::new("hitch angle", "t [s]", "θ [deg]").legend(Legend::UpperRight);
        let mut amp: f64 = 1.0;
        for (i, &tt) in c.brake_durations_s.iter().enumerate() {
            let spec = SimSpec {
                profile: SpeedProfile::Ramp {
                    initial_mps: c.start.speed_mps,
                    change_mps: c.speed_change_mps,
                    start_s: c.brake_start_s,
                    duration_s: tt,
                },
                controller: Controller::None,
                horizon_s: c.horizon_s,
                action_s: c.brake_start_s,
                guard: c.guard,
                solver: c.solver,
                metrics: c.metrics,
            };
            let r = simulate::<7>(
                &ctx.model,
                &spec,
                x0,
                Recording::Every {
                    step_s: c.output_step_s,
                },
            )?;
            let key = duration_key(tt);
            out.write_csv(
                &format!("{key}.csv"),
                &SERIES_HEADER,
                series_rows(&r.trajectory),
            )?;
            let mut e = metrics_json(&r.metrics);
            if let Value::Object(m) = &mut e {
                m.insert("brake_duration_s".into(), json!(tt));
            }
            summary.insert(key.clone(), e);
            lines.push(metrics_line(&format!("fig3b T = {tt} s"), &r.metrics));
            let color = Rgb::palette(i);
            let label = format!("T = {tt} s");
            p_v.layers.push(Layer::line(
                speed(&r.trajectory),
                color,
                Stroke::Solid,
                Some(&label),
            ));
            amp = r
                .trajectory
                .iter()
                .map(|s| s.x[3].to_degrees().abs())
                .fold(amp, f64::max);
            p_th.layers.push(Layer::line(
                theta_deg(&r.trajectory),
                color,
                Stroke::Solid,
                Some(&label),
            ));
            if let Some(m) = loss_marker(&r, color, Some(&format!("T = {tt} s: loss of control"))) {
                p_th.layers.push(m);
            }
            ctx.progress.advance(1);
        }
        p_v = p_v.x_range(0.0, c.horizon_s);
        p_th = p_th
            .x_range(0.0, c.horizon_s)
            .y_range(-1.1 * amp, 1.1 * amp);
        Figure::column(vec![p_v, p_th]).render(&out.path("fig3b"))?;
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
