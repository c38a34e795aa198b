//! `cargo xtask fig3b` (paper Fig. 3b): braking out of sway. Start on the sway cycle at
//! V0 = 35 m/s, lower V by 10 m/s over T ∈ {2, 3, 5, 10} s from t = 2 s, 40 s horizon;
//! panels V(t) and θ(t); metrics per T in `summary.json` under `"T2"`, `"T3"`, `"T5"`, `"T10"`.
//! The shipped config gives V0 and ΔV relative to V_crit (= 35 and −10 m/s for Table I); a
//! vehicle stable at every speed up to the maximum has no sway to brake from
//! (`summary.json`: `reason`).

use std::path::Path;

use serde::{Deserialize, Serialize};
use sway::config::{Positive, ensure};
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
pub const TASK: Task = Task::configured::<Fig3bConfig<SpeedSpec>>(
    "fig3b",
    "paper Fig. 3b: braking out of sway with T = 2, 3, 5, 10 s",
    "fig3b.toml",
)
.any_model();

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
            speed_change_mps: self.speed_change_mps.resolve_change("speed_change_mps", r)?,
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
            profile: SpeedProfile::Ramp {
                initial_mps: self.start.speed_mps,
                change_mps: self.speed_change_mps,
                start_s: self.brake_start_s,
                duration_s,
                shape: Default::default(),
            },
            controller: Controller::None,
            horizon_s: self.horizon_s.get(),
            action_s: self.brake_start_s,
            settings: self.settings,
        }
    }
}

/// The summary key of a braking time: `T2`, `T3`, `T5`, `T10` (`T2.5` for 2.5 s).
pub fn duration_key(t: f64) -> String {
    format!("T{t}")
}

/// What distinguishes a run in `summary.json` (beside its metrics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BrakeRun {
    /// T \[s\]
    pub brake_duration_s: f64,
}

/// `summary.json` of fig3b (before the common fields of [`crate::io::Summary`]): one
/// entry per braking time, keyed `"T2"`, `"T3"`, …: the run's metrics and
/// `brake_duration_s`.
pub type Fig3bSummary = Keyed<RunEntry<BrakeRun>>;

impl Fig3bConfig {
    /// Checks every key (speeds resolved).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the key.
    pub fn validate(&self, file: &Path) -> Result<(), TaskError> {
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
        Ok(self.settings.solver.validate_at(file, "solver")?)
    }
}

impl TaskConfig for Fig3bConfig<SpeedSpec> {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        check_change(&self.speed_change_mps, "speed_change_mps")
            .map_err(|(k, p)| TaskError::config(file, k, p))?;
        match self.all_numbers() {
            Some(c) => c.validate(file),
            None => Ok(()),
        }
    }
}

impl SwayRuns for Fig3bConfig<SpeedSpec> {
    fn runs(c: &Fig3bConfig) -> (Overlay, Vec<OverlayRun<BrakeRun>>) {
        let durations = c.brake_durations_s.iter().map(|t| t.get());
        let runs = durations
            .enumerate()
            .map(|(i, tt)| OverlayRun {
                key: duration_key(tt),
                line: format!("fig3b T = {tt} s"),
                label: format!("T = {tt} s"),
                color: Rgb::palette(i),
                speed_stroke: Stroke::Solid,
                spec: c.spec(tt),
                about: BrakeRun {
                    brake_duration_s: tt,
                },
            })
            .collect();
        (Overlay::new("hitch angle", "Fig. 3b: speed profiles"), runs)
    }
    const LABELS: (&'static str, &'static str, &'static str) =
        (TASK.name, "fig3b: braking", "fig3b: braking runs");
    const SPEED_FIRST: bool = true;
    const NOTHING: &'static str = "no sway to brake from";
    type About = BrakeRun;
    fn setup(c: &Fig3bConfig) -> (&SwayStart, (f64, f64), &RunSettings) {
        let sampling = (c.horizon_s.get(), c.output_step_s.get());
        (&c.start, sampling, &c.settings)
    }
    fn check_resolved(c: &Fig3bConfig, file: &Path) -> Result<(), TaskError> {
        c.validate(file)
    }
    fn plan_shape(&self) -> (f64, (f64, f64), usize) {
        (
            self.start.settle_s.get(),
            (self.horizon_s.get(), self.output_step_s.get()),
            self.brake_durations_s.len(),
        )
    }
}
