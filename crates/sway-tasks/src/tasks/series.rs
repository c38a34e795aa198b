//! The one skeleton of the time-series tasks (`fig3a` panels, `fig3b`, `fig4c`,
//! `simulate`): every run is simulated on the 7-state model, written as one CSV of typed
//! rows, drawn, and summarised by its [`Metrics`] plus what distinguishes it.

use serde::Serialize;
use sway::SwayError;
use sway::sim::{Metrics, Recording, Sample, SimResult, SimSpec, simulate};
use trailer_model::State7;

use super::TaskContext;
use crate::io::OutputDir;
use crate::plot::{Layer, Legend, Panel, Rgb, Stroke};
use crate::report::{loss_marker, max_abs_theta_deg, metrics_line, speed, theta_deg};

/// The summary entry of one run: its metrics (the field names of [`Metrics`]) followed by
/// the fields of `about` that say which run it is (e.g. `brake_duration_s`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunEntry<E> {
    /// the run's metrics
    #[serde(flatten)]
    pub metrics: Metrics,
    /// what distinguishes the run
    #[serde(flatten)]
    pub about: E,
}

/// Simulates one run sampled every `output_step_s` seconds and writes its trajectory to
/// `file` as rows `R` (e.g. [`crate::report::SeriesRow`]).
///
/// # Errors
/// Numerical failures with context, or write errors.
pub fn run_and_write<R>(
    ctx: &TaskContext<'_>,
    out: &OutputDir,
    spec: &SimSpec,
    x0: State7,
    output_step_s: f64,
    file: &str,
) -> Result<SimResult<7>, SwayError>
where
    R: Serialize + Default + for<'s> From<&'s Sample<7>>,
{
    let r = simulate::<7>(
        &ctx.model,
        spec,
        x0,
        Recording::Every {
            step_s: output_step_s,
        },
    )?;
    out.write_table(file, r.trajectory.iter().map(R::from))?;
    Ok(r)
}

/// The printed line of a run, `label: peak_theta_deg_after_action = …, …`.
pub fn line(label: &str, r: &SimResult<7>) -> String {
    metrics_line(label, &r.metrics)
}

/// θ(t) and V(t) of several runs overlaid in two panels (Fig. 3b, Fig. 4c), the θ axis
/// symmetric about 0 and fitted to the largest |θ| of all runs.
#[derive(Debug)]
pub struct Overlay {
    /// the hitch-angle panel
    pub theta: Panel,
    /// the speed panel
    pub speed: Panel,
    amplitude_deg: f64,
}

impl Overlay {
    /// Two empty panels with these titles, legends upper right.
    pub fn new(theta_title: &str, speed_title: &str) -> Self {
        Self {
            theta: Panel::new(theta_title, "t [s]", "θ [deg]").legend(Legend::UpperRight),
            speed: Panel::new(speed_title, "t [s]", "V [m/s]").legend(Legend::UpperRight),
            amplitude_deg: 1.0,
        }
    }

    /// Adds a run: θ(t) solid, a cross where control was lost, V(t) with `speed_stroke`.
    pub fn add(&mut self, r: &SimResult<7>, color: Rgb, label: &str, speed_stroke: Stroke) {
        self.amplitude_deg = max_abs_theta_deg(&r.trajectory, self.amplitude_deg);
        self.theta.layers.push(Layer::line(
            theta_deg(&r.trajectory),
            color,
            Stroke::Solid,
            Some(label),
        ));
        if let Some(m) = loss_marker(r, color, Some(&format!("{label}: loss of control"))) {
            self.theta.layers.push(m);
        }
        self.speed.layers.push(Layer::line(
            speed(&r.trajectory),
            color,
            speed_stroke,
            Some(label),
        ));
    }

    /// The finished panels (θ, V), both over `[0, horizon_s]`.
    pub fn panels(self, horizon_s: f64) -> (Panel, Panel) {
        let a = 1.1 * self.amplitude_deg;
        (
            self.theta.x_range(0.0, horizon_s).y_range(-a, a),
            self.speed.x_range(0.0, horizon_s),
        )
    }
}
