//! `cargo xtask fig4c` (paper Fig. 4c): suppressing sway from the sway cycle at
//! V0 = 35 m/s with four strategies acting from t = 10 s: `"none"`, `"steering"`
//! (δ = −D·ψ̇(t − τ), τ = 0.2 s, D = 0.1 s), `"braking"` (−10 m/s over 5 s) and
//! `"combined"`; θ(t) of the four overlaid, metrics per strategy in `summary.json`.

use std::path::Path;

use serde::{Deserialize, Serialize};
use crate::TaskError;
use sway::config::Positive;
use sway::sim::{Controller, RunSettings, SimSpec, SpeedProfile};

use super::Task;
use super::fig3b::SwayStart;
use super::series::{Overlay, OverlayRun, RunEntry, SwayRuns};
use crate::config_file::TaskConfig;
use crate::io::Keyed;
use crate::plot::{Rgb, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<Fig4cConfig>(
    "fig4c",
    "paper Fig. 4c: sway suppression by braking, steering, and both",
    "fig4c.toml",
);

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
                    shape: Default::default(),
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
                    actuator: Default::default(),
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

impl TaskConfig for Fig4cConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        let (horizon, step) = (self.horizon_s.get(), self.output_step_s.get());
        self.start
            .validate_run(file, horizon, step, "action_s", self.action_s)?;
        // the combined strategy has both the braking and the steering of the others
        let spec = self.spec(true, true);
        spec.profile
            .validate()
            .map_err(|(k, p)| TaskError::config(file, format!("braking ({k})"), p))?;
        spec.controller
            .validate()
            .map_err(|(k, p)| TaskError::config(file, format!("steering.{k}"), p))?;
        Ok(self.settings.solver.validate_at(file, "solver")?)
    }
}

impl SwayRuns for Fig4cConfig {
    fn runs(&self) -> (Overlay, Vec<OverlayRun<Strategy>>) {
        let overlay = Overlay::new(
            &format!(
                "Fig. 4c: sway suppression from V0 = {} m/s, action at t = {} s",
                self.start.speed_mps.get(),
                self.action_s
            ),
            "speed",
        );
        let runs = STRATEGIES.map(|(key, braking, steering, color)| OverlayRun {
            key: key.to_string(),
            line: format!("fig4c {key}"),
            label: key.to_string(),
            color,
            // the speed profiles coincide in pairs: steering-only runs dashed on top
            speed_stroke: if steering {
                Stroke::Dashed
            } else {
                Stroke::Solid
            },
            spec: self.spec(braking, steering),
            about: Strategy { braking, steering },
        });
        (overlay, runs.into())
    }
    const LABELS: (&'static str, &'static str, &'static str) =
        (TASK.name, "fig4c: strategies", "fig4c: mitigation strategies");
    const SPEED_FIRST: bool = false;
    type About = Strategy;
    fn setup(&self) -> (&SwayStart, (f64, f64), &RunSettings) {
        (
            &self.start,
            (self.horizon_s.get(), self.output_step_s.get()),
            &self.settings,
        )
    }
}
