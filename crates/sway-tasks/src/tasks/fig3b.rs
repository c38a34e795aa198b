//! `cargo xtask fig3b` (paper Fig. 3b): braking out of sway. Start on the sway cycle at
//! V0 = 35 m/s, lower V by 10 m/s over T ∈ {2, 3, 5, 10} s from t = 2 s, 40 s horizon;
//! panels V(t) and θ(t); metrics per T in `summary.json` under `"T2"`, `"T3"`, `"T5"`, `"T10"`.
//! The shipped config gives V0 and ΔV relative to V_crit (= 35 and −10 m/s for Table I); a
//! vehicle stable at every speed up to the maximum has no sway to brake from
//! (`summary.json`: `reason`). The runs are computed by [`sway_studies::fig3b`].

use std::path::Path;

use sway::SwayError;
use sway::ranging::SpeedSpec;
use sway::sim::speeds::{Resolution, ResolveSpeeds, check_change};
pub use sway_studies::fig3b::{BrakeRun, Fig3b, Fig3bConfig, compute, duration_key};
use sway_studies::simulate::SeriesRun;

use super::series::{Overlay, RunEntry, RunStyle, SwayRuns};
use super::{Task, TaskContext};
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

/// `summary.json` of fig3b (before the common fields of [`crate::io::Summary`]): one
/// entry per braking time, keyed `"T2"`, `"T3"`, …: the run's metrics and
/// `brake_duration_s`.
pub type Fig3bSummary = Keyed<RunEntry<BrakeRun>>;

impl TaskConfig for Fig3bConfig<SpeedSpec> {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        check_change(&self.speed_change_mps, "speed_change_mps")
            .map_err(|(k, p)| TaskError::config(file, k, p))?;
        match self.all_numbers() {
            Some(c) => Ok(c.validate(file)?),
            None => Ok(()),
        }
    }
}

impl SwayRuns for Fig3bConfig<SpeedSpec> {
    const LABELS: (&'static str, &'static str, &'static str) =
        (TASK.name, "fig3b: braking", "fig3b: braking runs");
    const SPEED_FIRST: bool = true;
    const NOTHING: &'static str = "no sway to brake from";
    type About = BrakeRun;
    fn compute(&self, ctx: &TaskContext<'_>, file: &Path) -> Result<Resolution<Fig3b>, SwayError> {
        compute(self, &ctx.plant, &ctx.limits, file, ctx.progress)
    }
    fn overlay(c: &Fig3bConfig) -> (Overlay, f64) {
        let overlay = Overlay::new("hitch angle", "Fig. 3b: speed profiles");
        (overlay, c.horizon_s.get())
    }
    fn style(i: usize, run: &SeriesRun<BrakeRun>) -> RunStyle {
        let tt = run.about.brake_duration_s;
        RunStyle {
            line: format!("fig3b T = {tt} s"),
            label: format!("T = {tt} s"),
            color: Rgb::palette(i),
            speed_stroke: Stroke::Solid,
        }
    }
    fn plan_shape(&self) -> (f64, (f64, f64), usize) {
        (
            self.start.settle_s.get(),
            (self.horizon_s.get(), self.output_step_s.get()),
            self.brake_durations_s.len(),
        )
    }
}
