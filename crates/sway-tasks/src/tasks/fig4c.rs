//! `cargo xtask fig4c` (paper Fig. 4c): suppressing sway from the sway cycle at
//! V0 = 35 m/s with four strategies acting from t = 10 s: `"none"`, `"steering"`
//! (δ = −D·ψ̇(t − τ), τ = 0.2 s, D = 0.1 s), `"braking"` (−10 m/s over 5 s) and
//! `"combined"`; θ(t) of the four overlaid, metrics per strategy in `summary.json`. The
//! shipped config gives V0 and the braking ΔV relative to V_crit (= 35 and −10 m/s for
//! Table I); a vehicle stable at every speed up to the maximum has no sway to suppress.

use std::path::Path;

use serde::{Deserialize, Serialize};
use sway::config::Positive;
use sway::ranging::SpeedSpec;
use sway::sim::speeds::{ResolveSpeeds, Resolver, SpeedValue, UnresolvedSpeed, check_change};
use sway::sim::{Controller, RunSettings, SimSpec, SpeedProfile, SwayStart};

use super::Task;
use super::series::{Overlay, OverlayRun, RunEntry, SwayRuns};
use crate::TaskError;
use crate::config_file::TaskConfig;
use crate::io::Keyed;
use crate::plot::{Rgb, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<Fig4cConfig<SpeedSpec>>(
    "fig4c",
    "paper Fig. 4c: sway suppression by braking, steering, and both",
    "fig4c.toml",
)
.any_model();

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
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct BrakingConfig<S = f64> {
    /// ΔV \[m/s\] (negative; relative: `{ of_v_crit = f }`)
    pub speed_change_mps: S,
    /// T \[s\]
    pub duration_s: f64,
}

/// `configs/fig4c.toml`. `S`: the type of the speeds (see [`sway::sim::speeds`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct Fig4cConfig<S = f64> {
    /// the sway-cycle start
    pub start: SwayStart<S>,
    /// every action starts here \[s\]
    pub action_s: f64,
    /// horizon \[s\]
    pub horizon_s: Positive,
    /// sampling of the plotted series \[s\]
    pub output_step_s: Positive,
    /// steering
    pub steering: SteeringConfig,
    /// braking
    pub braking: BrakingConfig<S>,
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

impl<S: SpeedValue> ResolveSpeeds for Fig4cConfig<S> {
    type Resolved = Fig4cConfig;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<Fig4cConfig, UnresolvedSpeed> {
        Ok(Fig4cConfig {
            start: self.start.resolve_speeds("start", r)?,
            action_s: self.action_s,
            horizon_s: self.horizon_s,
            output_step_s: self.output_step_s,
            steering: self.steering,
            braking: BrakingConfig {
                speed_change_mps: self
                    .braking
                    .speed_change_mps
                    .resolve_change("braking.speed_change_mps", r)?,
                duration_s: self.braking.duration_s,
            },
            settings: self.settings,
        })
    }
}

impl Fig4cConfig {
    /// The run of one strategy.
    pub fn spec(&self, braking: bool, steering: bool) -> SimSpec {
        let v0 = self.start.speed_mps;
        SimSpec {
            early_stop: sway::sim::EarlyStop::Never,
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

impl TaskConfig for Fig4cConfig<SpeedSpec> {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        check_change(&self.braking.speed_change_mps, "braking.speed_change_mps")
            .map_err(|(k, p)| TaskError::config(file, k, p))?;
        match self.all_numbers() {
            Some(c) => c.validate(file),
            None => Ok(()),
        }
    }
}

impl Fig4cConfig {
    /// Checks every key (speeds resolved).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the key.
    pub fn validate(&self, file: &Path) -> Result<(), TaskError> {
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

impl SwayRuns for Fig4cConfig<SpeedSpec> {
    fn runs(c: &Fig4cConfig) -> (Overlay, Vec<OverlayRun<Strategy>>) {
        let overlay = Overlay::new(
            &format!(
                "Fig. 4c: sway suppression from V0 = {} m/s, action at t = {} s",
                c.start.speed_mps, c.action_s
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
            spec: c.spec(braking, steering),
            about: Strategy { braking, steering },
        });
        (overlay, runs.into())
    }
    const LABELS: (&'static str, &'static str, &'static str) =
        (TASK.name, "fig4c: strategies", "fig4c: mitigation strategies");
    const SPEED_FIRST: bool = false;
    const NOTHING: &'static str = "no sway to suppress";
    type About = Strategy;
    fn setup(c: &Fig4cConfig) -> (&SwayStart, (f64, f64), &RunSettings) {
        (
            &c.start,
            (c.horizon_s.get(), c.output_step_s.get()),
            &c.settings,
        )
    }
    fn check_resolved(c: &Fig4cConfig, file: &Path) -> Result<(), TaskError> {
        c.validate(file)
    }
    fn plan_shape(&self) -> (f64, (f64, f64), usize) {
        (
            self.start.settle_s.get(),
            (self.horizon_s.get(), self.output_step_s.get()),
            STRATEGIES.len(),
        )
    }
}
