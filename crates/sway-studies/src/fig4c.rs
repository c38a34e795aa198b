//! The computation of `fig4c` (paper Fig. 4c): suppressing sway from the sway cycle at V0
//! with the four strategies of [`STRATEGIES`] acting from `action_s`: none, the delayed
//! yaw-rate feedback δ = −D·ψ̇(t − τ), braking by ΔV over T, and both. V0 and ΔV may be
//! given relative to the vehicle (the shipped config: 35 and −10 m/s for Table I, see
//! [`sway::sim::speeds`]).

use std::path::Path;

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::config::Positive;
use sway::progress::Progress;
use sway::ranging::{SpeedLimits, SpeedSpec};
use sway::sim::speeds::{Resolution, ResolveSpeeds, Resolver, SpeedValue, UnresolvedSpeed};
use sway::sim::{LoopLaw, RunSettings, SimSpec, SpeedProfile, SwayStart};
use trailer_model::AnyVehicleModel;

use crate::simulate::{FromSwayCycle, Runs, sway_runs};

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

/// The four strategies in plotting order: (key, braking?, steering?).
pub const STRATEGIES: [(&str, bool, bool); 4] = [
    ("none", false, false),
    ("steering", false, true),
    ("braking", true, false),
    ("combined", true, true),
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
            steering: Default::default(),
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
            controller: steering.then(|| {
                LoopLaw::paper(self.steering.gain_s, self.steering.delay_s)
                    .switched(self.action_s, self.steering.off_s)
            }),
            horizon_s: self.horizon_s.get(),
            action_s: self.action_s,
            settings: self.settings,
        }
    }

    /// Checks every key (speeds resolved).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the key.
    pub fn validate(&self, file: &Path) -> Result<(), SwayError> {
        let (horizon, step) = (self.horizon_s.get(), self.output_step_s.get());
        self.start
            .validate_run(file, horizon, step, "action_s", self.action_s)?;
        // the combined strategy has both the braking and the steering of the others
        let spec = self.spec(true, true);
        spec.profile
            .validate()
            .map_err(|(k, p)| SwayError::config(file, format!("braking ({k})"), p))?;
        spec.controller
            .as_ref()
            .map_or(Ok(()), LoopLaw::validate)
            .map_err(|(k, p)| {
                // the steering table writes D as `gain_s`
                let k = if k == "gains.yaw_rate" { "gain_s" } else { k };
                SwayError::config(file, format!("steering.{k}"), p)
            })?;
        self.settings.solver.validate_at(file, "solver")
    }
}

/// What distinguishes a strategy (beside its metrics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Strategy {
    /// whether it brakes
    pub braking: bool,
    /// whether it steers
    pub steering: bool,
}

impl FromSwayCycle for Fig4cConfig {
    type About = Strategy;
    fn check(&self, file: &Path) -> Result<(), SwayError> {
        self.validate(file)
    }
    fn start(&self) -> (&SwayStart, &RunSettings, f64) {
        (&self.start, &self.settings, self.output_step_s.get())
    }
    fn runs(&self) -> Vec<(String, Strategy, SimSpec)> {
        let runs = STRATEGIES.map(|(key, braking, steering)| {
            let about = Strategy { braking, steering };
            (key.to_string(), about, self.spec(braking, steering))
        });
        runs.into()
    }
}

/// The outcome of fig4c: the config with its speeds resolved, one run per strategy in the
/// order of [`STRATEGIES`] (keyed by its name).
pub type Fig4c = Runs<Fig4cConfig, Strategy>;

/// The whole computation of fig4c (`config` as read and checked before its speeds are
/// resolved): the speeds resolved for `vehicle` within `limits`, the resolved config
/// checked (`file` names it in the messages), the sway-cycle start, one run per strategy.
/// Progress: one step for the start, one per run.
///
/// # Errors
/// A config error of the resolved config (naming the resolved speeds), or numerical
/// failures with context.
pub fn compute(
    config: &Fig4cConfig<SpeedSpec>,
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    file: &Path,
    progress: &dyn Progress,
) -> Result<Resolution<Fig4c>, SwayError> {
    sway_runs(config, vehicle, limits, file, progress)
}
