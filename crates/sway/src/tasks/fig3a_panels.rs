//! `cargo xtask fig3a`, time panels (paper Fig. 3a, bottom): at V = 33 m/s in the bistable
//! range, θ(0) = 2° decays and θ(0) = 8° grows into sway. `summary.json` has
//! `"time_panels": {"theta0_2deg": {"final_amplitude_deg": …}, "theta0_8deg": {…}}`
//! (max |θ| over the last 5 s).
//!
//! The task also runs the bifurcation diagram of the same figure (top;
//! [`super::fig3a_diagram::run_diagram`], `[diagram]` section of `configs/fig3a.toml`):
//! one figure `fig3a.svg/.png` with the diagram above the time panels, one `summary.json`
//! with the diagram's fields and `"time_panels"`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};

use super::fig3a_diagram::{DiagramConfig, run_diagram};
use super::{Prepared, Report, Task, TaskContext};
use crate::SwayError;
use crate::config::{ensure, ensure_positive, ensure_time_span, load_toml};
use crate::io::OutputDir;
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::sim::report::{
    SERIES_HEADER, loss_marker, metrics_json, metrics_line, series_rows, theta_deg,
};
use crate::sim::{
    Controller, MetricSettings, Recording, SimSpec, SolverSettings, SpeedProfile, ValidityGuard,
    simulate,
};

/// The task: bifurcation diagram and time panels of paper Fig. 3a.
pub const TASK: Task = Task {
    name: "fig3a",
    about: "paper Fig. 3a: bifurcation diagram and time panels (2° decays, 8° grows into sway at 33 m/s)",
    config: "fig3a.toml",
    prepare,
};

fn default_speed() -> f64 {
    33.0
}
fn default_thetas() -> Vec<f64> {
    vec![2.0, 8.0]
}
fn default_horizon() -> f64 {
    60.0
}
fn default_output_step() -> f64 {
    0.02
}

/// The `[panels]` section of `configs/fig3a.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PanelsConfig {
    /// constant speed V [m/s]
    #[serde(default = "default_speed")]
    pub speed_mps: f64,
    /// initial hitch angles θ(0) [deg], one panel each (other states 0)
    #[serde(default = "default_thetas")]
    pub theta0_deg: Vec<f64>,
    /// horizon [s]
    #[serde(default = "default_horizon")]
    pub horizon_s: f64,
    /// sampling of the plotted series [s]
    #[serde(default = "default_output_step")]
    pub output_step_s: f64,
    /// validity guard
    #[serde(default)]
    pub guard: ValidityGuard,
    /// tolerances
    #[serde(default)]
    pub solver: SolverSettings,
    /// metric settings (final window 5 s)
    #[serde(default)]
    pub metrics: MetricSettings,
}

impl PanelsConfig {
    /// Checks the keys (`prefix` is the section's key path).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), SwayError> {
        ensure_positive(
            self.speed_mps,
            file,
            &format!("{prefix}.speed_mps"),
            "a speed > 0 m/s",
        )?;
        ensure(
            !self.theta0_deg.is_empty()
                && self
                    .theta0_deg
                    .iter()
                    .all(|t| t.is_finite() && t.abs() < 90.0),
            file,
            &format!("{prefix}.theta0_deg"),
            || {
                format!(
                    "expected a list of angles with |θ| < 90 deg, got {:?}",
                    self.theta0_deg
                )
            },
        )?;
        ensure_time_span(
            self.horizon_s,
            self.output_step_s,
            file,
            &format!("{prefix}."),
        )?;
        self.solver
            .validate()
            .map_err(|(k, p)| SwayError::config(file, format!("{prefix}.solver.{k}"), p))
    }
}

/// `configs/fig3a.toml`: `[panels]` for the time panels, `[diagram]` for the bifurcation
/// diagram (defaults when absent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig3aConfig {
    /// time panels
    pub panels: PanelsConfig,
    /// the bifurcation diagram
    #[serde(default)]
    pub diagram: DiagramConfig,
}

/// The key of a panel in `"time_panels"`: `theta0_2deg`, `theta0_8deg`, `theta0_2.5deg`.
pub fn panel_key(theta0_deg: f64) -> String {
    format!("theta0_{theta0_deg}deg")
}

/// Simulates the panels, writes `theta0_<θ>deg.csv` per panel, and returns the
/// `"time_panels"` summary entry, the figure panels and printed lines.
///
/// # Errors
/// Numerical failures with context, or write errors.
pub fn run_panels(
    ctx: &TaskContext<'_>,
    cfg: &PanelsConfig,
    out: &OutputDir,
) -> Result<(Value, Vec<Panel>, Vec<String>), SwayError> {
    let spec = SimSpec {
        profile: SpeedProfile::Constant {
            speed_mps: cfg.speed_mps,
        },
        controller: Controller::None,
        horizon_s: cfg.horizon_s,
        action_s: 0.0,
        guard: cfg.guard,
        solver: cfg.solver,
        metrics: cfg.metrics,
    };
    let mut entries = Map::new();
    let mut panels = Vec::new();
    let mut lines = Vec::new();
    for (i, &th) in cfg.theta0_deg.iter().enumerate() {
        let x0 = trailer_model::State7::from_column_slice(&[
            0.0,
            0.0,
            0.0,
            th.to_radians(),
            0.0,
            0.0,
            0.0,
        ]);
        let r = simulate::<7>(
            &ctx.model,
            &spec,
            x0,
            Recording::Every {
                step_s: cfg.output_step_s,
            },
        )?;
        let key = panel_key(th);
        out.write_csv(
            &format!("{key}.csv"),
            &SERIES_HEADER,
            series_rows(&r.trajectory),
        )?;
        let mut e = metrics_json(&r.metrics);
        if let Value::Object(m) = &mut e {
            m.insert("theta0_deg".into(), json!(th));
            m.insert("speed_mps".into(), json!(cfg.speed_mps));
        }
        entries.insert(key.clone(), e);
        lines.push(metrics_line(
            &format!("fig3a V = {} m/s, θ(0) = {th}°", cfg.speed_mps),
            &r.metrics,
        ));
        let color = if r
            .metrics
            .final_amplitude_deg
            .is_some_and(|a| a < cfg.metrics.settle_threshold_deg)
        {
            Rgb::GREEN
        } else {
            Rgb::RED
        };
        let fa = r
            .metrics
            .final_amplitude_deg
            .map_or("n/a".into(), |a| format!("{a:.2}°"));
        let mut p = Panel::new(
            &format!(
                "V = {} m/s, θ(0) = {th}°: final amplitude {fa}",
                cfg.speed_mps
            ),
            "t [s]",
            "θ [deg]",
        )
        .with(Layer::line(
            theta_deg(&r.trajectory),
            color,
            Stroke::Solid,
            Some("θ(t)"),
        ))
        .x_range(0.0, cfg.horizon_s)
        .legend(Legend::UpperRight);
        let window = cfg.horizon_s - cfg.metrics.final_window_s;
        p.layers.insert(
            0,
            Layer::band(window, cfg.horizon_s, Rgb::GREY, Some("final window")),
        );
        if let Some(m) = loss_marker(&r, Rgb::BLACK, Some("loss of control")) {
            p.layers.push(m);
        }
        let _ = i;
        panels.push(p);
    }
    Ok((Value::Object(entries), panels, lines))
}

struct Fig3aTask {
    file: PathBuf,
    config: Fig3aConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let config: Fig3aConfig = load_toml(file)?;
    config.panels.validate(file, "panels")?;
    config.diagram.validate(file, "diagram")?;
    Ok(Box::new(Fig3aTask {
        file: file.to_path_buf(),
        config,
    }))
}

impl Prepared for Fig3aTask {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress
            .start("fig3a: bifurcation diagram and time panels", 2);
        let (mut summary, diagram_panel, mut lines) = run_diagram(ctx, &self.config.diagram, &out)?;
        ctx.progress.advance(1);
        let (entry, panels, panel_lines) = run_panels(ctx, &self.config.panels, &out)?;
        ctx.progress.advance(1);
        lines.extend(panel_lines);
        let mut all = vec![diagram_panel];
        all.extend(panels);
        let n = all.len() as u32;
        Figure::grid(all, n as usize, 1, (900, 420 * n))
            .titled(
                "Fig. 3a: open loop — bifurcation diagram (top) and bistability in time (below)",
            )
            .render(&out.path("fig3a"))?;
        summary.insert("time_panels".into(), entry);
        out.write_summary(summary, &self.config, &ctx.run_info(&self.file))?;
        ctx.progress.finish();
        let dir = out.commit()?;
        Ok(Report {
            task: TASK.name.into(),
            output_dir: dir,
            lines,
        })
    }
}
