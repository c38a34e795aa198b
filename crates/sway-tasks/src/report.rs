//! What the time-series tasks (`fig3a` panels, `fig3b`, `fig4c`, `simulate`) write and
//! draw of a run: typed CSV rows, plot series, the printed metric line.

use serde::Serialize;
use sway::sim::{Metrics, Outcome, Sample, SimResult};

use crate::plot::{Layer, Rgb};

/// One row of `trajectory.csv` (7-state runs): the state, V and δ.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct TrajectoryRow {
    /// time \[s\]
    pub t_s: f64,
    /// σ1 \[m/s\]
    pub sigma1_mps: f64,
    /// σ2 \[1/s\]
    pub sigma2_per_s: f64,
    /// σ3 \[1/s\]
    pub sigma3_per_s: f64,
    /// hitch angle θ \[rad\]
    pub theta_rad: f64,
    /// yaw angle ψ \[rad\]
    pub psi_rad: f64,
    /// hitch position x_H \[m\]
    pub x_h_m: f64,
    /// hitch position y_H \[m\]
    pub y_h_m: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// steering angle δ \[rad\]
    pub delta_rad: f64,
}

impl From<&Sample<7>> for TrajectoryRow {
    fn from(s: &Sample<7>) -> Self {
        Self {
            t_s: s.t,
            sigma1_mps: s.x[0],
            sigma2_per_s: s.x[1],
            sigma3_per_s: s.x[2],
            theta_rad: s.x[3],
            psi_rad: s.x[4],
            x_h_m: s.x[5],
            y_h_m: s.x[6],
            v_mps: s.speed,
            delta_rad: s.steering_angle,
        }
    }
}

/// One row of the per-run series CSVs of the figure tasks.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct SeriesRow {
    /// time \[s\]
    pub t_s: f64,
    /// hitch angle θ \[deg\]
    pub theta_deg: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// steering angle δ \[deg\]
    pub delta_deg: f64,
}

impl<const N: usize> From<&Sample<N>> for SeriesRow {
    fn from(s: &Sample<N>) -> Self {
        Self {
            t_s: s.t,
            theta_deg: s.x[3].to_degrees(),
            v_mps: s.speed,
            delta_deg: s.steering_angle.to_degrees(),
        }
    }
}

/// (t, θ \[deg\]) points.
pub fn theta_deg<const N: usize>(traj: &[Sample<N>]) -> Vec<(f64, f64)> {
    traj.iter().map(|s| (s.t, s.x[3].to_degrees())).collect()
}

/// (t, V) points.
pub fn speed<const N: usize>(traj: &[Sample<N>]) -> Vec<(f64, f64)> {
    traj.iter().map(|s| (s.t, s.speed)).collect()
}

/// max |θ| \[deg\] over a trajectory, at least `floor` (the symmetric y range of θ panels).
pub fn max_abs_theta_deg<const N: usize>(traj: &[Sample<N>], floor: f64) -> f64 {
    traj.iter()
        .map(|s| s.x[3].to_degrees().abs())
        .fold(floor, f64::max)
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

/// One printed line per run: `label: peak_theta_deg_after_action = …, final_amplitude_deg
/// = …, settle_time_s = …, outcome = ok` (the names of [`Metrics`]' fields), then when
/// control was lost `at t = … s (condition)`.
pub fn metrics_line(label: &str, m: &Metrics) -> String {
    let fields = match serde_json::to_value(m) {
        Ok(serde_json::Value::Object(map)) => map,
        _ => serde_json::Map::new(),
    };
    let shown: Vec<String> = fields
        .iter()
        .filter(|(k, _)| !k.starts_with("loss_of_control"))
        .map(|(k, v)| match v {
            serde_json::Value::Number(n) => format!("{k} = {:.3}", n.as_f64().unwrap_or(f64::NAN)),
            serde_json::Value::String(s) => format!("{k} = {s}"),
            other => format!("{k} = {other}"),
        })
        .collect();
    let mut s = format!("{label}: {}", shown.join(", "));
    if let (Some(t), Some(c)) = (m.loss_of_control_time_s, m.loss_of_control_condition) {
        s.push_str(&format!(" at t = {t:.3} s ({})", c.as_str()));
    }
    s
}

/// One row of `cycles.csv` (fig3a) and of fig4b's per-pair tables: a point of the cycle
/// branch.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct CycleRow {
    /// V \[m/s\]
    pub v_mps: f64,
    /// max |θ| over the cycle \[deg\]
    pub max_abs_theta_deg: f64,
    /// period \[s\]
    pub period_s: f64,
    /// 1 stable, 0 unstable (a number, as plotting tools read it)
    pub stable: f64,
    /// largest |μ| of the nontrivial Floquet multipliers
    pub max_nontrivial_multiplier: f64,
}

impl From<&sway::bifurcation::CycleSummary> for CycleRow {
    fn from(c: &sway::bifurcation::CycleSummary) -> Self {
        Self {
            v_mps: c.speed_mps,
            max_abs_theta_deg: c.amplitude_deg,
            period_s: c.period_s,
            stable: f64::from(u8::from(c.stable)),
            max_nontrivial_multiplier: c.max_multiplier,
        }
    }
}
