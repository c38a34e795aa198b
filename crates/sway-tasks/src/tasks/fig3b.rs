//! `cargo xtask fig3b` (paper Fig. 3b): braking out of sway. Start on the sway cycle at
//! V0 = 35 m/s, lower V by 10 m/s over T ∈ {2, 3, 5, 10} s from t = 2 s, 40 s horizon;
//! panels V(t) and θ(t); metrics per T in `summary.json` under `"T2"`, `"T3"`, `"T5"`, `"T10"`.

use std::path::Path;

use serde::{Deserialize, Serialize};
use crate::TaskError;
use sway::config::{NonNegative, Positive, ensure};
use sway::sim::{Controller, InitialCondition, RunSettings, SimSpec, SpeedProfile};

use super::Task;
use super::series::{Overlay, OverlayRun, RunEntry, SwayRuns};
use crate::config_file::TaskConfig;
use crate::io::Keyed;
use crate::plot::{Rgb, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<Fig3bConfig>(
    "fig3b",
    "paper Fig. 3b: braking out of sway with T = 2, 3, 5, 10 s",
    "fig3b.toml",
);

/// Start on the sway cycle (shared by fig3b and fig4c).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SwayStart {
    /// V0 \[m/s\]
    pub speed_mps: Positive,
    /// settling time at V0 \[s\]
    pub settle_s: NonNegative,
    /// initial perturbation of the settling run θ(0) \[rad\]
    pub theta0_rad: f64,
}

impl SwayStart {
    /// As an initial condition.
    pub fn initial(&self) -> InitialCondition {
        InitialCondition::SwayCycle {
            speed_mps: self.speed_mps.get(),
            settle_s: self.settle_s.get(),
            theta0_rad: self.theta0_rad,
        }
    }

    /// Checks the keys under `prefix` that do not validate themselves.
    ///
    /// # Errors
    /// [`TaskError::Config`].
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), TaskError> {
        Ok(ensure(
            self.theta0_rad.is_finite() && self.theta0_rad.abs() < 1.5,
            file,
            &format!("{prefix}.theta0_rad"),
            || format!("expected |θ(0)| < 1.5 rad, got {}", self.theta0_rad),
        )?)
    }

    /// Checks a run that starts here (fig3b and fig4c): the start under `start`, an output
    /// step within the horizon, and the time `action_s` of the intervention (key
    /// `action_key`) in [0, horizon).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the key.
    pub fn validate_run(
        &self,
        file: &Path,
        horizon: f64,
        output_step: f64,
        action_key: &str,
        action_s: f64,
    ) -> Result<(), TaskError> {
        self.validate(file, "start")?;
        ensure(output_step <= horizon, file, "output_step_s", || {
            format!("expected 0 < output_step_s <= horizon_s, got {output_step}")
        })?;
        Ok(ensure(
            action_s.is_finite() && (0.0..horizon).contains(&action_s),
            file,
            action_key,
            || format!("expected 0 <= {action_key} < horizon_s, got {action_s}"),
        )?)
    }
}

/// `configs/fig3b.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig3bConfig {
    /// the sway-cycle start
    pub start: SwayStart,
    /// t_b \[s\]: braking starts
    pub brake_start_s: f64,
    /// ΔV \[m/s\] (negative: braking)
    pub speed_change_mps: f64,
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

impl Fig3bConfig {
    /// The run that brakes over `duration_s`.
    pub fn spec(&self, duration_s: f64) -> SimSpec {
        SimSpec {
            profile: SpeedProfile::Ramp {
                initial_mps: self.start.speed_mps.get(),
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

impl TaskConfig for Fig3bConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        let start_speed = self.start.speed_mps.get();
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

impl SwayRuns for Fig3bConfig {
    fn runs(&self) -> (Overlay, Vec<OverlayRun<BrakeRun>>) {
        let durations = self.brake_durations_s.iter().map(|t| t.get());
        let runs = durations
            .enumerate()
            .map(|(i, tt)| OverlayRun {
                key: duration_key(tt),
                line: format!("fig3b T = {tt} s"),
                label: format!("T = {tt} s"),
                color: Rgb::palette(i),
                speed_stroke: Stroke::Solid,
                spec: self.spec(tt),
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
    type About = BrakeRun;
    fn setup(&self) -> (&SwayStart, (f64, f64), &RunSettings) {
        let sampling = (self.horizon_s.get(), self.output_step_s.get());
        (&self.start, sampling, &self.settings)
    }
}
