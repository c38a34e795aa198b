//! `cargo xtask fig3b` (paper Fig. 3b): braking out of sway. Start on the sway cycle at
//! V0 = 35 m/s, lower V by 10 m/s over T ∈ {2, 3, 5, 10} s from t = 2 s, 40 s horizon;
//! panels V(t) and θ(t); metrics per T in `summary.json` under `"T2"`, `"T3"`, `"T5"`, `"T10"`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::config::{NonNegative, Positive, ensure};
use sway::sim::{Controller, InitialCondition, RunSettings, SimSpec, SpeedProfile};

use super::series::{Overlay, RunEntry, line, run_and_write};
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::load_toml;
use crate::io::{Keyed, OutputDir};
use crate::limits::{Plan, series_plan};
use crate::plot::{Figure, Rgb, Stroke};
use crate::report::SeriesRow;

/// The task.
pub const TASK: Task = Task {
    name: "fig3b",
    about: "paper Fig. 3b: braking out of sway with T = 2, 3, 5, 10 s",
    config: "fig3b.toml",
    prepare,
};

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
    /// [`SwayError::Config`].
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), SwayError> {
        ensure(
            self.theta0_rad.is_finite() && self.theta0_rad.abs() < 1.5,
            file,
            &format!("{prefix}.theta0_rad"),
            || format!("expected |θ(0)| < 1.5 rad, got {}", self.theta0_rad),
        )
    }

    /// Checks a run that starts here (fig3b and fig4c): the start under `start`, an output
    /// step within the horizon, and the time `action_s` of the intervention (key
    /// `action_key`) in [0, horizon).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the key.
    pub fn validate_run(
        &self,
        file: &Path,
        horizon: f64,
        output_step: f64,
        action_key: &str,
        action_s: f64,
    ) -> Result<(), SwayError> {
        self.validate(file, "start")?;
        ensure(output_step <= horizon, file, "output_step_s", || {
            format!("expected 0 < output_step_s <= horizon_s, got {output_step}")
        })?;
        ensure(
            action_s.is_finite() && (0.0..horizon).contains(&action_s),
            file,
            action_key,
            || format!("expected 0 <= {action_key} < horizon_s, got {action_s}"),
        )
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

struct Fig3bTask {
    file: PathBuf,
    config: Fig3bConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let c: Fig3bConfig = load_toml(file)?;
    let horizon = c.horizon_s.get();
    c.start.validate_run(
        file,
        horizon,
        c.output_step_s.get(),
        "brake_start_s",
        c.brake_start_s,
    )?;
    ensure(
        c.speed_change_mps.is_finite() && c.start.speed_mps.get() + c.speed_change_mps > 0.0,
        file,
        "speed_change_mps",
        || {
            format!(
                "the final speed must stay > 0 m/s, got {}",
                c.start.speed_mps.get() + c.speed_change_mps
            )
        },
    )?;
    ensure(!c.brake_durations_s.is_empty(), file, "brake_durations_s", || {
        "expected a list of durations > 0 s, got none".into()
    })?;
    c.settings.solver.validate_at(file, "solver")?;
    Ok(Box::new(Fig3bTask {
        file: file.to_path_buf(),
        config: c,
    }))
}

impl Prepared for Fig3bTask {
    fn plan(&self) -> Result<Plan, SwayError> {
        let c = &self.config;
        series_plan(
            &self.file,
            "",
            (c.horizon_s.get(), c.output_step_s.get()),
            c.brake_durations_s.len(),
            ("start.settle_s", c.start.settle_s.get()),
            "fig3b: braking runs",
        )
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let c = &self.config;
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress
            .start("fig3b: braking", c.brake_durations_s.len() as u64 + 1);
        let x0 = c.start.initial().state7(&ctx.model, &c.settings.solver)?;
        ctx.progress.advance(1);
        let mut summary = Fig3bSummary::default();
        let mut lines = Vec::new();
        let mut figure = Overlay::new("hitch angle", "Fig. 3b: speed profiles");
        for (i, tt) in c.brake_durations_s.iter().map(|t| t.get()).enumerate() {
            let key = duration_key(tt);
            let r = run_and_write::<SeriesRow>(
                ctx,
                &out,
                &c.spec(tt),
                x0,
                c.output_step_s.get(),
                &format!("{key}.csv"),
            )?;
            lines.push(line(&format!("fig3b T = {tt} s"), &r));
            figure.add(&r, Rgb::palette(i), &format!("T = {tt} s"), Stroke::Solid);
            summary.0.push((
                key,
                RunEntry {
                    metrics: r.metrics,
                    about: BrakeRun {
                        brake_duration_s: tt,
                    },
                },
            ));
            ctx.progress.advance(1);
        }
        let (p_th, p_v) = figure.panels(c.horizon_s.get());
        Figure::column(vec![p_v, p_th]).render(&out.path("fig3b"))?;
        ctx.conclude(out, summary, c, &self.file, lines)
    }
}
