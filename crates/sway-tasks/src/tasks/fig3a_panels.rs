//! `cargo xtask fig3a`, time panels (paper Fig. 3a, bottom): at V = 33 m/s in the bistable
//! range, θ(0) = 2° decays and θ(0) = 8° grows into sway. `summary.json` has
//! `"time_panels": {"theta0_2deg": {"final_amplitude_deg": …}, "theta0_8deg": {…}}`
//! (max |θ| over the last 5 s).
//!
//! The task also runs the bifurcation diagram of the same figure (top;
//! [`super::fig3a_diagram`], `[diagram]` section of `configs/fig3a.toml`):
//! one figure `fig3a.svg/.png` with the diagram above the time panels, one `summary.json`
//! with the diagram's fields and `"time_panels"`.
//!
//! The panel speed may be given relative to the vehicle (the shipped config:
//! `{ in_bistable = f }`, = 33 m/s for Table I; see [`sway::sim::speeds`]); it resolves
//! against V_crit of the open loop and the diagram's own fold of cycles. A vehicle without a
//! bistable range (supercritical Hopf point, or stable at every speed up to the maximum) has
//! no panel speed: `"time_panels"` is null and `"time_panels_reason"` says why.
//!
//! Any vehicle file: the diagram is computed on the vehicle's plant (relaxation, tyre laws,
//! axle lists, hitch torque); a vehicle with model variants gets the diagram without time
//! panels (`"time_panels_reason"` names the variant). The computation is
//! [`sway_studies::fig3a::compute`]; this task checks the config, writes the branches, the
//! panels' series, the figure and the summary.

use std::path::{Path, PathBuf};

use serde::Serialize;
use sway::sim::speeds::ResolvedSpeed;
pub use sway_studies::fig3a::{
    Fig3a, Fig3aConfig, PanelRun, Panels, PanelsConfig, compute, panel_key,
};

use crate::TaskError;

use super::fig3a_diagram::{
    DiagramSummary, diagram_report, summary_fields, validate_diagram, write_branches,
};
use super::series::{RunEntry, line, write_runs};
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::load_toml;
use crate::io::Keyed;
use crate::limits::{Plan, series_plan};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::report::{SeriesRow, loss_marker, theta_deg};

/// The task: bifurcation diagram and time panels of paper Fig. 3a.
pub const TASK: Task = Task {
    name: "fig3a",
    about: "paper Fig. 3a: bifurcation diagram and time panels (2° decays, 8° grows into sway at 33 m/s)",
    config: "fig3a.toml",
    prepare,
    models: super::Models::Any,
    runs: super::Runs::InAll,
};

/// The `"time_panels"` entry of `summary.json`: one entry per panel, keyed
/// `"theta0_2deg"`, …: the run's metrics, `theta0_deg` and `speed_mps`.
pub type TimePanels = Keyed<RunEntry<PanelRun>>;

/// `summary.json` of fig3a (before the common fields of [`crate::io::Summary`]): the
/// diagram's fields, then `"time_panels"` (null when the panel speed does not resolve for
/// this vehicle, with `"time_panels_reason"`), and the resolved panel speed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fig3aSummary {
    /// the bifurcation diagram
    #[serde(flatten)]
    pub diagram: DiagramSummary,
    /// the time panels
    pub time_panels: Option<TimePanels>,
    /// why there are no time panels
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_panels_reason: Option<String>,
    /// the panel speed, when given relative to the vehicle, and its value
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub resolved_speeds: Vec<ResolvedSpeed>,
}

/// The panel of one run: θ(t) green when it settles, red when it sways, the final window
/// shaded.
fn time_panel(cfg: &PanelsConfig, theta0: f64, r: &sway::sim::SimResult<7>) -> Panel {
    let threshold = cfg.settings.metrics.settle_threshold_deg.get();
    let color = if r
        .metrics
        .final_amplitude_deg
        .is_some_and(|a| a < threshold)
    {
        Rgb::GREEN
    } else {
        Rgb::RED
    };
    let fa = r
        .metrics
        .final_amplitude_deg
        .map_or("n/a".into(), |a| format!("{a:.2}°"));
    let (v, horizon) = (cfg.speed_mps, cfg.horizon_s.get());
    let mut p = Panel::new(
        &format!(
            "V = {} m/s, θ(0) = {theta0}°: final amplitude {fa}",
            speed_text(v)
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
    .x_range(0.0, horizon)
    .legend(Legend::UpperRight);
    let window = horizon - cfg.settings.metrics.final_window_s.get();
    p.layers.insert(
        0,
        Layer::band(window, horizon, Rgb::GREY, Some("final window")),
    );
    if let Some(m) = loss_marker(r, Rgb::BLACK, Some("loss of control")) {
        p.layers.push(m);
    }
    p
}

/// The `"time_panels"` entry, the figure panels and the printed lines of the panels.
fn report_panels(p: &Panels) -> (TimePanels, Vec<Panel>, Vec<String>) {
    let cfg = &p.config;
    let speed = speed_text(cfg.speed_mps);
    let mut lines = Vec::new();
    let mut panels = Vec::new();
    for run in &p.runs {
        let th = run.about.theta0_deg;
        lines.push(line(&format!("fig3a V = {speed} m/s, θ(0) = {th}°"), &run.result));
        panels.push(time_panel(cfg, th, &run.result));
    }
    let entries = p.runs.iter().map(|r| (r.key.clone(), r.entry())).collect();
    (entries, panels, lines)
}

struct Fig3aTask {
    file: PathBuf,
    config: Fig3aConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    let config: Fig3aConfig = load_toml(file)?;
    config.panels.validate_spec(file, "panels")?;
    validate_diagram(&config.diagram, file, "diagram")?;
    Ok(Box::new(Fig3aTask {
        file: file.to_path_buf(),
        config,
    }))
}

impl Prepared for Fig3aTask {
    fn plan(&self) -> Result<Plan, TaskError> {
        let p = &self.config.panels;
        let o = &self.config.diagram.options;
        let mut plan = series_plan(
            &self.file,
            "panels.",
            (p.horizon_s.get(), p.output_step_s.get()),
            p.theta0_deg.len(),
            ("panels.horizon_s", 0.0),
            "fig3a: time panels",
        )?;
        let bytes = super::fig3a_diagram::cycle_branch_bytes(o);
        plan.work.push(format!(
            "fig3a: cycle branch of at most {} points on a mesh of {} intervals × degree {}",
            o.max_cycle_points, o.intervals, o.degree
        ));
        plan.memory_bytes += bytes;
        plan.time_s += 1.0; // the committed diagram takes 0.77 s
        Ok(plan)
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let stage = "fig3a: bifurcation diagram and time panels";
        ctx.run_staged(TASK.name, stage, 2, cfg, &self.file, |out| {
            let (plant, variant) = (&ctx.plant, ctx.variant_key.as_deref());
            let fig = compute(cfg, plant, variant, &ctx.limits, &self.file, ctx.progress)?;
            write_branches(fig.diagram.diagram.as_deref(), out)?;
            let (diagram_panel, mut lines) = diagram_report(&fig.diagram);
            let mut all = vec![diagram_panel];
            let (time_panels, reason) = match &fig.panels {
                Ok(p) => {
                    write_runs::<SeriesRow, _>(out, &p.runs)?;
                    let (time_panels, panels, panel_lines) = report_panels(p);
                    lines.extend(panel_lines);
                    all.extend(panels);
                    (Some(time_panels), None)
                }
                Err(reason) => {
                    lines.push(format!("fig3a: {reason}"));
                    (None, Some(reason.clone()))
                }
            };
            let n = all.len() as u32;
            Figure::grid(all, n as usize, 1, (900, 420 * n))
                .titled(
                    "Fig. 3a: open loop — bifurcation diagram (top) and bistability in time (below)",
                )
                .render(&out.path("fig3a"))?;
            let summary = Fig3aSummary {
                diagram: summary_fields(fig.diagram.summary),
                time_panels,
                time_panels_reason: reason,
                resolved_speeds: fig.resolved_speeds,
            };
            Ok((summary, lines))
        })
    }
}

/// A speed for titles and printed lines: to 1e-9 m/s, without trailing zeros (a speed
/// resolved relative to the vehicle's range, e.g. 32.99999999999999, reads 33).
fn speed_text(v: f64) -> String {
    let text = format!("{v:.9}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" { "0".into() } else { text.into() }
}
