//! The computation of `fig3b` (paper Fig. 3b): braking out of sway. From the sway cycle at
//! V0, V is lowered by ΔV over each ramp duration T of `configs/fig3b.toml`, one run per T.
//! V0 and ΔV may be given relative to the vehicle (the shipped config: 35 and −10 m/s for
//! Table I, see [`sway::sim::speeds`]).

use std::path::Path;

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::config::{Positive, ensure};
use sway::progress::Progress;
use sway::ranging::{SpeedLimits, SpeedSpec};
use sway::sim::speeds::{Resolution, ResolveSpeeds, Resolver, SpeedValue, UnresolvedSpeed};
use sway::sim::{RunSettings, SimSpec, SpeedProfile, SwayStart};
use trailer_model::AnyVehicleModel;

use crate::simulate::{FromSwayCycle, Runs, sway_runs};

/// `configs/fig3b.toml`. `S`: the type of the speeds, [`SpeedSpec`] as written (a number
/// or relative to the vehicle, see [`sway::sim::speeds`]), `f64` when run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct Fig3bConfig<S = f64> {
    /// the sway-cycle start
    pub start: SwayStart<S>,
    /// t_b \[s\]: braking starts
    pub brake_start_s: f64,
    /// ΔV \[m/s\] (negative: braking; relative: `{ of_v_crit = f }`)
    pub speed_change_mps: S,
    /// the ramp durations T \[s\], one run each
    pub brake_durations_s: Vec<Positive>,
    /// horizon \[s\]
    pub horizon_s: Positive,
    /// sampling of the plotted series \[s\]
    pub output_step_s: Positive,
    /// validity guard, tolerances, metric settings
    #[serde(flatten)]
    pub settings: RunSettings,
}

impl<S: SpeedValue> ResolveSpeeds for Fig3bConfig<S> {
    type Resolved = Fig3bConfig;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<Fig3bConfig, UnresolvedSpeed> {
        Ok(Fig3bConfig {
            start: self.start.resolve_speeds("start", r)?,
            brake_start_s: self.brake_start_s,
            speed_change_mps: self
                .speed_change_mps
                .resolve_change("speed_change_mps", r)?,
            brake_durations_s: self.brake_durations_s.clone(),
            horizon_s: self.horizon_s,
            output_step_s: self.output_step_s,
            settings: self.settings,
        })
    }
}

impl Fig3bConfig {
    /// The run that brakes over `duration_s`.
    pub fn spec(&self, duration_s: f64) -> SimSpec {
        SimSpec {
            early_stop: sway::sim::EarlyStop::Never,
            steering: Default::default(),
            profile: SpeedProfile::Ramp {
                initial_mps: self.start.speed_mps,
                change_mps: self.speed_change_mps,
                start_s: self.brake_start_s,
                duration_s,
                shape: Default::default(),
            },
            controller: None,
            horizon_s: self.horizon_s.get(),
            action_s: self.brake_start_s,
            settings: self.settings,
        }
    }

    /// Checks every key (speeds resolved).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the key.
    pub fn validate(&self, file: &Path) -> Result<(), SwayError> {
        let start_speed = self.start.speed_mps;
        self.start.validate_run(
            file,
            self.horizon_s.get(),
            self.output_step_s.get(),
            "brake_start_s",
            self.brake_start_s,
        )?;
        ensure(
            self.speed_change_mps.is_finite() && start_speed + self.speed_change_mps > 0.0,
            file,
            "speed_change_mps",
            || {
                format!(
                    "the final speed must stay > 0 m/s, got {}",
                    start_speed + self.speed_change_mps
                )
            },
        )?;
        ensure(
            !self.brake_durations_s.is_empty(),
            file,
            "brake_durations_s",
            || "expected a list of durations > 0 s, got none".into(),
        )?;
        self.settings.solver.validate_at(file, "solver")
    }
}

/// The summary key of a braking time: `T2`, `T3`, `T5`, `T10` (`T2.5` for 2.5 s).
pub fn duration_key(t: f64) -> String {
    format!("T{t}")
}

/// What distinguishes a run (beside its metrics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BrakeRun {
    /// T \[s\]
    pub brake_duration_s: f64,
}

impl FromSwayCycle for Fig3bConfig {
    type About = BrakeRun;
    fn check(&self, file: &Path) -> Result<(), SwayError> {
        self.validate(file)
    }
    fn start(&self) -> (&SwayStart, &RunSettings, f64) {
        (&self.start, &self.settings, self.output_step_s.get())
    }
    fn runs(&self) -> Vec<(String, BrakeRun, SimSpec)> {
        let durations = self.brake_durations_s.iter().map(|t| t.get());
        durations
            .map(|t| {
                (
                    duration_key(t),
                    BrakeRun {
                        brake_duration_s: t,
                    },
                    self.spec(t),
                )
            })
            .collect()
    }
}

/// The outcome of fig3b: the config with its speeds resolved, one run per braking time
/// (keyed [`duration_key`]).
pub type Fig3b = Runs<Fig3bConfig, BrakeRun>;

/// The whole computation of fig3b (`config` as read and checked before its speeds are
/// resolved): the speeds resolved for `vehicle` within `limits`, the resolved config
/// checked (`file` names it in the messages), the sway-cycle start, one run per braking
/// time. Progress: one step for the start, one per run.
///
/// # Errors
/// A config error of the resolved config (naming the resolved speeds), or numerical
/// failures with context.
pub fn compute(
    config: &Fig3bConfig<SpeedSpec>,
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    file: &Path,
    progress: &dyn Progress,
) -> Result<Resolution<Fig3b>, SwayError> {
    sway_runs(config, vehicle, limits, file, progress)
}
