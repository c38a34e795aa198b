//! `cargo xtask fig3a`, time panels (paper Fig. 3a, bottom): at V = 33 m/s in the bistable
//! range, θ(0) = 2° decays and θ(0) = 8° grows into sway. `summary.json` has
//! `"time_panels": {"theta0_2deg": {"final_amplitude_deg": …}, "theta0_8deg": {…}}`
//! (max |θ| over the last 5 s).
//!
//! The task also runs the bifurcation diagram of the same figure (top;
//! [`super::fig3a_diagram::run_diagram`], `[diagram]` section of `configs/fig3a.toml`):
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
//! axle lists, hitch torque); the time panels simulate through [`run_and_write`], which
//! simulates the paper's model, so a vehicle with model variants gets the diagram without
//! time panels (`"time_panels_reason"` names the variant).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sway::config::{Positive, ensure};
use sway::parallel::Split;
use sway::ranging::{SpeedReferences, SpeedSpec};
use sway::sim::speeds::{
    ResolveSpeeds, ResolvedSpeed, Resolver, SpeedValue, UnresolvedSpeed, resolve_against,
};
use sway::sim::{Controller, RunSettings, SimSpec, SpeedProfile};

use crate::TaskError;

use super::fig3a_diagram::{DiagramConfig, DiagramSummary, run_diagram};
use super::series::{RunEntry, line, resolved_check, run_and_write};
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::load_toml;
use crate::io::{Keyed, OutputDir};
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
};

fn default_speed<S: From<f64>>() -> S {
    S::from(33.0)
}
fn default_thetas() -> Vec<f64> {
    vec![2.0, 8.0]
}
fn default_horizon() -> Positive {
    Positive::literal(60.0)
}
fn default_output_step() -> Positive {
    Positive::literal(0.02)
}

/// The `[panels]` section of `configs/fig3a.toml`. `S`: the type of the speed,
/// [`SpeedSpec`] as written (a number or relative to the vehicle), `f64` when run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(
    serialize = "S: Serialize",
    deserialize = "S: Deserialize<'de> + From<f64>"
))]
pub struct PanelsConfig<S = f64> {
    /// constant speed V \[m/s\] (default 33 m/s)
    #[serde(default = "default_speed")]
    pub speed_mps: S,
    /// initial hitch angles θ(0) \[deg\], one panel each (other states 0)
    #[serde(default = "default_thetas")]
    pub theta0_deg: Vec<f64>,
    /// horizon \[s\]
    #[serde(default = "default_horizon")]
    pub horizon_s: Positive,
    /// sampling of the plotted series \[s\]
    #[serde(default = "default_output_step")]
    pub output_step_s: Positive,
    /// validity guard, tolerances, metric settings (final window 5 s)
    #[serde(flatten)]
    pub settings: RunSettings,
}

impl<S: SpeedValue> ResolveSpeeds for PanelsConfig<S> {
    type Resolved = PanelsConfig;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<PanelsConfig, UnresolvedSpeed> {
        Ok(PanelsConfig {
            speed_mps: self.speed_mps.resolve_speed("panels.speed_mps", r)?,
            theta0_deg: self.theta0_deg.clone(),
            horizon_s: self.horizon_s,
            output_step_s: self.output_step_s,
            settings: self.settings,
        })
    }
}

impl PanelsConfig<SpeedSpec> {
    /// Checks the keys that can be checked before the speed is resolved; with a number,
    /// every key ([`PanelsConfig::validate`]).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the file and key.
    pub fn validate_spec(&self, file: &Path, prefix: &str) -> Result<(), TaskError> {
        match self.all_numbers() {
            Some(c) => c.validate(file, prefix),
            None => Ok(()),
        }
    }
}

impl PanelsConfig {
    /// Checks the keys that do not validate themselves (`prefix` is the section's key
    /// path).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), TaskError> {
        ensure(
            self.speed_mps.is_finite() && self.speed_mps > 0.0,
            file,
            &format!("{prefix}.speed_mps"),
            || format!("expected a speed > 0 m/s, got {}", self.speed_mps),
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
        ensure(
            self.output_step_s <= self.horizon_s,
            file,
            &format!("{prefix}.output_step_s"),
            || {
                format!(
                    "expected 0 < output_step_s <= horizon_s, got {}",
                    self.output_step_s.get()
                )
            },
        )?;
        Ok(self
            .settings
            .solver
            .validate_at(file, &format!("{prefix}.solver"))?)
    }

    /// The run at constant speed (every panel; they differ in θ(0)).
    pub fn spec(&self) -> SimSpec {
        SimSpec {
            early_stop: sway::sim::EarlyStop::Never,
            profile: SpeedProfile::Constant {
                speed_mps: self.speed_mps,
            },
            controller: Controller::None,
            horizon_s: self.horizon_s.get(),
            action_s: 0.0,
            settings: self.settings,
        }
    }
}

/// `configs/fig3a.toml`: `[panels]` for the time panels, `[diagram]` for the bifurcation
/// diagram (defaults when absent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig3aConfig {
    /// time panels
    pub panels: PanelsConfig<SpeedSpec>,
    /// the bifurcation diagram
    #[serde(default)]
    pub diagram: DiagramConfig,
}

/// The key of a panel in `"time_panels"`: `theta0_2deg`, `theta0_8deg`, `theta0_2.5deg`.
pub fn panel_key(theta0_deg: f64) -> String {
    format!("theta0_{theta0_deg}deg")
}

/// What distinguishes a panel's run in `summary.json` (beside its metrics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PanelRun {
    /// θ(0) \[deg\]
    pub theta0_deg: f64,
    /// V \[m/s\]
    pub speed_mps: f64,
}

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

/// Simulates the panels, writes `theta0_<θ>deg.csv` per panel, and returns the
/// `"time_panels"` summary entry, the figure panels and printed lines.
///
/// # Errors
/// Numerical failures with context, or write errors.
pub fn run_panels(
    ctx: &TaskContext<'_>,
    cfg: &PanelsConfig,
    out: &OutputDir,
) -> Result<(TimePanels, Vec<Panel>, Vec<String>), TaskError> {
    let spec = cfg.spec();
    let speed = cfg.speed_mps;
    let mut entries = TimePanels::default();
    let mut panels = Vec::new();
    let mut lines = Vec::new();
    // the panels' simulations side by side (each writes its own file)
    let runs = sway::parallel::try_map(&cfg.theta0_deg, Split::OnePerTask, &|_, &th| {
        let x0 = trailer_model::State7::from_column_slice(&[
            0.0,
            0.0,
            0.0,
            th.to_radians(),
            0.0,
            0.0,
            0.0,
        ]);
        let file = format!("{}.csv", panel_key(th));
        run_and_write::<SeriesRow>(ctx, out, &spec, x0, cfg.output_step_s.get(), &file)
    })?;
    for (&th, r) in cfg.theta0_deg.iter().zip(runs) {
        let key = panel_key(th);
        lines.push(line(
            &format!("fig3a V = {} m/s, θ(0) = {th}°", speed_text(speed)),
            &r,
        ));
        panels.push(time_panel(cfg, th, &r));
        entries.0.push((
            key,
            RunEntry {
                metrics: r.metrics,
                about: PanelRun {
                    theta0_deg: th,
                    speed_mps: speed,
                },
            },
        ));
    }
    Ok((entries, panels, lines))
}

struct Fig3aTask {
    file: PathBuf,
    config: Fig3aConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    let config: Fig3aConfig = load_toml(file)?;
    config.panels.validate_spec(file, "panels")?;
    config.diagram.validate(file, "diagram")?;
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
            let (diagram, diagram_panel, mut lines) = run_diagram(ctx, &cfg.diagram, out)?;
            ctx.progress.advance(1);
            // the panel speed against the diagram's own V_crit and fold (corrected on their
            // defining systems), as the diagram's report speeds: one factor means the same
            // speed in both sections, and nothing more is computed
            let refs = SpeedReferences {
                v_crit_mps: diagram.hopf_v_mps,
                v_fold_mps: diagram.fold_v_mps,
                reason: diagram
                    .hopf_reason
                    .clone()
                    .or_else(|| diagram.fold_reason.clone()),
            };
            let resolution = resolve_against(&refs, &cfg.panels);
            let mut all = vec![diagram_panel];
            let (time_panels, reason) = match &resolution.outcome {
                Ok(_) if ctx.variant_key.is_some() => {
                    let reason = format!(
                        "no time panels: the vehicle has a model variant ({}) and the time panels simulate the paper's model",
                        ctx.variant_key.as_deref().unwrap_or_default()
                    );
                    lines.push(format!("fig3a: {reason}"));
                    (None, Some(reason))
                }
                Ok(panels) => {
                    resolved_check(panels.validate(&self.file, "panels"), &resolution.speeds)?;
                    let (time_panels, panels, panel_lines) = run_panels(ctx, panels, out)?;
                    lines.extend(panel_lines);
                    all.extend(panels);
                    (Some(time_panels), None)
                }
                Err(u) => {
                    let reason = format!("no time panels (no speed in the bistable range): {}", u.reason);
                    lines.push(format!("fig3a: {reason}"));
                    (None, Some(reason))
                }
            };
            ctx.progress.advance(1);
            let n = all.len() as u32;
            Figure::grid(all, n as usize, 1, (900, 420 * n))
                .titled(
                    "Fig. 3a: open loop — bifurcation diagram (top) and bistability in time (below)",
                )
                .render(&out.path("fig3a"))?;
            let summary = Fig3aSummary {
                diagram,
                time_panels,
                time_panels_reason: reason,
                resolved_speeds: resolution.speeds.clone(),
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
