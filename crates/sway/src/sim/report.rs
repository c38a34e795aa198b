//! Helpers shared by the simulation tasks: trajectory tables, plot series, metric JSON.

use serde_json::{Value, json};

use super::run::{Metrics, Outcome, Sample, SimResult};
use crate::plot::{Layer, Rgb};

/// Header of `trajectory.csv` (7-state runs).
pub const TRAJECTORY_HEADER: [&str; 10] = [
    "t_s",
    "sigma1_mps",
    "sigma2_per_s",
    "sigma3_per_s",
    "theta_rad",
    "psi_rad",
    "x_h_m",
    "y_h_m",
    "v_mps",
    "delta_rad",
];

/// Rows of `trajectory.csv`: t, σ1, σ2, σ3, θ, ψ, x_H, y_H, V, δ.
pub fn trajectory_rows(traj: &[Sample<7>]) -> Vec<[f64; 10]> {
    traj.iter()
        .map(|s| {
            [
                s.t,
                s.x[0],
                s.x[1],
                s.x[2],
                s.x[3],
                s.x[4],
                s.x[5],
                s.x[6],
                s.speed,
                s.steering_angle,
            ]
        })
        .collect()
}

/// Header of the per-series CSVs of the figure tasks.
pub const SERIES_HEADER: [&str; 4] = ["t_s", "theta_deg", "v_mps", "delta_deg"];

/// Rows t, θ [deg], V, δ [deg].
pub fn series_rows<const N: usize>(traj: &[Sample<N>]) -> Vec<[f64; 4]> {
    traj.iter()
        .map(|s| {
            [
                s.t,
                s.x[3].to_degrees(),
                s.speed,
                s.steering_angle.to_degrees(),
            ]
        })
        .collect()
}

/// (t, θ [deg]) points.
pub fn theta_deg<const N: usize>(traj: &[Sample<N>]) -> Vec<(f64, f64)> {
    traj.iter().map(|s| (s.t, s.x[3].to_degrees())).collect()
}

/// (t, V) points.
pub fn speed<const N: usize>(traj: &[Sample<N>]) -> Vec<(f64, f64)> {
    traj.iter().map(|s| (s.t, s.speed)).collect()
}

/// A cross at the point where the validity guard stopped the run, if it did.
pub fn loss_marker<const N: usize>(
    r: &SimResult<N>,
    color: Rgb,
    label: Option<&str>,
) -> Option<Layer> {
    (r.metrics.outcome == Outcome::LossOfControl).then(|| Layer::Markers {
        points: vec![(r.t_end, r.x_end[3].to_degrees())],
        color,
        shape: crate::plot::Shape::Cross,
        size: 9,
        label: label.map(str::to_string),
    })
}

/// The metrics as JSON with the field names of the issue (nulls for absent values).
pub fn metrics_json(m: &Metrics) -> Value {
    json!({
        "peak_theta_deg_after_action": m.peak_theta_deg_after_action,
        "final_amplitude_deg": m.final_amplitude_deg,
        "settle_time_s": m.settle_time_s,
        "outcome": m.outcome.as_str(),
        "loss_of_control_time_s": m.loss_of_control_time_s,
        "loss_of_control_condition": m.loss_of_control_condition.map(|c| c.as_str()),
    })
}

/// One printed line per run: `label: peak …°, final …°, settle … s, ok`.
pub fn metrics_line(label: &str, m: &Metrics) -> String {
    let f = |x: Option<f64>, unit: &str| x.map_or("null".to_string(), |v| format!("{v:.3}{unit}"));
    let mut s = format!(
        "{label}: peak_theta_deg_after_action = {}, final_amplitude_deg = {}, settle_time_s = {}, outcome = {}",
        f(m.peak_theta_deg_after_action, ""),
        f(m.final_amplitude_deg, ""),
        f(m.settle_time_s, ""),
        m.outcome.as_str()
    );
    if let (Some(t), Some(c)) = (m.loss_of_control_time_s, m.loss_of_control_condition) {
        s.push_str(&format!(" at t = {t:.3} s ({})", c.as_str()));
    }
    s
}
