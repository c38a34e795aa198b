//! `cargo xtask fig4c` (paper Fig. 4c): suppressing sway from the sway cycle at
//! V0 = 35 m/s with four strategies acting from t = 10 s: `"none"`, `"steering"`
//! (δ = −D·ψ̇(t − τ), τ = 0.2 s, D = 0.1 s), `"braking"` (−10 m/s over 5 s) and
//! `"combined"`; θ(t) of the four overlaid, metrics per strategy in `summary.json`. The
//! shipped config gives V0 and the braking ΔV relative to V_crit (= 35 and −10 m/s for
//! Table I); a vehicle stable at every speed up to the maximum has no sway to suppress.
//! The runs are computed by [`sway_studies::fig4c`].

use std::path::Path;

use sway::SwayError;
use sway::ranging::SpeedSpec;
use sway::sim::speeds::{Resolution, ResolveSpeeds, check_change};
pub use sway_studies::fig4c::{
    BrakingConfig, Fig4c, Fig4cConfig, STRATEGIES, SteeringConfig, Strategy, compute,
};
use sway_studies::simulate::SeriesRun;

use super::series::{Overlay, RunEntry, RunStyle, SwayRuns};
use super::{Task, TaskContext};
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

/// The colours of the strategies of [`STRATEGIES`], in their order.
pub const COLORS: [Rgb; 4] = [Rgb::RED, Rgb::BLUE, Rgb::ORANGE, Rgb::GREEN];

/// `summary.json` of fig4c (before the common fields of [`crate::io::Summary`]): one entry
/// per strategy, keyed `"none"`, `"steering"`, `"braking"`, `"combined"`: the run's metrics
/// and `braking`, `steering`.
pub type Fig4cSummary = Keyed<RunEntry<Strategy>>;

impl TaskConfig for Fig4cConfig<SpeedSpec> {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        check_change(&self.braking.speed_change_mps, "braking.speed_change_mps")
            .map_err(|(k, p)| TaskError::config(file, k, p))?;
        match self.all_numbers() {
            Some(c) => Ok(c.validate(file)?),
            None => Ok(()),
        }
    }
}

impl SwayRuns for Fig4cConfig<SpeedSpec> {
    const LABELS: (&'static str, &'static str, &'static str) =
        (TASK.name, "fig4c: strategies", "fig4c: mitigation strategies");
    const SPEED_FIRST: bool = false;
    const NOTHING: &'static str = "no sway to suppress";
    type About = Strategy;
    fn compute(&self, ctx: &TaskContext<'_>, file: &Path) -> Result<Resolution<Fig4c>, SwayError> {
        compute(self, &ctx.plant, &ctx.limits, file, ctx.progress)
    }
    fn overlay(c: &Fig4cConfig) -> (Overlay, f64) {
        let overlay = Overlay::new(
            &format!(
                "Fig. 4c: sway suppression from V0 = {} m/s, action at t = {} s",
                c.start.speed_mps, c.action_s
            ),
            "speed",
        );
        (overlay, c.horizon_s.get())
    }
    fn style(i: usize, run: &SeriesRun<Strategy>) -> RunStyle {
        RunStyle {
            line: format!("fig4c {}", run.key),
            label: run.key.clone(),
            color: COLORS[i % COLORS.len()],
            // the speed profiles coincide in pairs: steering-only runs dashed on top
            speed_stroke: if run.about.steering {
                Stroke::Dashed
            } else {
                Stroke::Solid
            },
        }
    }
    fn plan_shape(&self) -> (f64, (f64, f64), usize) {
        (
            self.start.settle_s.get(),
            (self.horizon_s.get(), self.output_step_s.get()),
            STRATEGIES.len(),
        )
    }
}
