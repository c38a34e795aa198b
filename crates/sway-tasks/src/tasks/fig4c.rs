//! `cargo xtask fig4c` (paper Fig. 4c): suppressing sway from the sway cycle at
//! V0 = 35 m/s with four strategies acting from t = 10 s: `"none"`, `"steering"`
//! (δ = −D·ψ̇(t − τ), τ = 0.2 s, D = 0.1 s), `"braking"` (−10 m/s over 5 s) and
//! `"combined"`; θ(t) of the four overlaid, metrics per strategy in `summary.json`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::config::Positive;
use sway::sim::{Controller, RunSettings, SimSpec, SpeedProfile};

use super::fig3b::SwayStart;
use super::series::{Overlay, RunEntry, line, run_and_write};
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::load_toml;
use crate::io::{Keyed, OutputDir};
use crate::limits::{Plan, series_plan};
use crate::plot::{Figure, Rgb, Stroke};
use crate::report::SeriesRow;

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
    /// D \[s\]
    pub gain_s: f64,
    /// τ \[s\]
    pub delay_s: f64,
    /// switched off at this time \[s\] (never when absent)
    #[serde(default)]
    pub off_s: Option<f64>,
}

/// The braking of the strategies "braking" and "combined".
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BrakingConfig {
    /// ΔV \[m/s\] (negative)
    pub speed_change_mps: f64,
    /// T \[s\]
    pub duration_s: f64,
}

/// `configs/fig4c.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig4cConfig {
    /// the sway-cycle start
    pub start: SwayStart,
    /// every action starts here \[s\]
    pub action_s: f64,
    /// horizon \[s\]
    pub horizon_s: Positive,
    /// sampling of the plotted series \[s\]
    pub output_step_s: Positive,
    /// steering
    pub steering: SteeringConfig,
    /// braking
    pub braking: BrakingConfig,
    /// validity guard, tolerances, metric settings
    #[serde(flatten)]
    pub settings: RunSettings,
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
        let v0 = self.start.speed_mps.get();
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
            horizon_s: self.horizon_s.get(),
            action_s: self.action_s,
            settings: self.settings,
        }
    }
}

/// What distinguishes a strategy in `summary.json` (beside its metrics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Strategy {
    /// whether it brakes
    pub braking: bool,
    /// whether it steers
    pub steering: bool,
}

/// `summary.json` of fig4c (before the common fields of [`crate::io::Summary`]): one entry
/// per strategy, keyed `"none"`, `"steering"`, `"braking"`, `"combined"`: the run's metrics
/// and `braking`, `steering`.
pub type Fig4cSummary = Keyed<RunEntry<Strategy>>;

struct Fig4cTask {
    file: PathBuf,
    config: Fig4cConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let c: Fig4cConfig = load_toml(file)?;
    c.start
        .validate_run(file, c.horizon_s.get(), c.output_step_s.get(), "action_s", c.action_s)?;
    // the combined strategy has both the braking and the steering of the others
    let spec = c.spec(true, true);
    spec.profile
        .validate()
        .map_err(|(k, p)| SwayError::config(file, format!("braking ({k})"), p))?;
    spec.controller
        .validate()
        .map_err(|(k, p)| SwayError::config(file, format!("steering.{k}"), p))?;
    c.settings.solver.validate_at(file, "solver")?;
    Ok(Box::new(Fig4cTask {
        file: file.to_path_buf(),
        config: c,
    }))
}

impl Prepared for Fig4cTask {
    fn plan(&self) -> Result<Plan, SwayError> {
        let c = &self.config;
        series_plan(
            &self.file,
            "",
            (c.horizon_s.get(), c.output_step_s.get()),
            STRATEGIES.len(),
            ("start.settle_s", c.start.settle_s.get()),
            "fig4c: mitigation strategies",
        )
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let c = &self.config;
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress
            .start("fig4c: strategies", STRATEGIES.len() as u64 + 1);
        let x0 = c.start.initial().state7(&ctx.model, &c.settings.solver)?;
        ctx.progress.advance(1);
        let mut summary = Fig4cSummary::default();
        let mut lines = Vec::new();
        let mut figure = Overlay::new(
            &format!(
                "Fig. 4c: sway suppression from V0 = {} m/s, action at t = {} s",
                c.start.speed_mps.get(),
                c.action_s
            ),
            "speed",
        );
        for (key, braking, steering, color) in STRATEGIES {
            let r = run_and_write::<SeriesRow>(
                ctx,
                &out,
                &c.spec(braking, steering),
                x0,
                c.output_step_s.get(),
                &format!("{key}.csv"),
            )?;
            lines.push(line(&format!("fig4c {key}"), &r));
            // the speed profiles coincide in pairs: steering-only runs dashed on top
            let stroke = if steering {
                Stroke::Dashed
            } else {
                Stroke::Solid
            };
            figure.add(&r, color, key, stroke);
            summary.0.push((
                key.to_string(),
                RunEntry {
                    metrics: r.metrics,
                    about: Strategy { braking, steering },
                },
            ));
            ctx.progress.advance(1);
        }
        let (p_th, p_v) = figure.panels(c.horizon_s.get());
        Figure::column(vec![p_th, p_v]).render(&out.path("fig4c"))?;
        ctx.conclude(out, summary, c, &self.file, lines)
    }
}
