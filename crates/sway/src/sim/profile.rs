//! Prescribed longitudinal speed profiles V(t) (the constraint of paper eq. 3) with their
//! derivative V̇(t) (which enters eq. 6) and the times where V̇ jumps.

use serde::{Deserialize, Serialize};

/// A prescribed speed V(t) \[m/s\]. V̇ is right-continuous: at a corner it takes the value
/// that holds after it (the solver lands a step on every corner, see [`SpeedProfile::breakpoints`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SpeedProfile {
    /// V(t) = V0.
    Constant {
        /// V0 \[m/s\]
        speed_mps: f64,
    },
    /// Linear ramp: V0 until t_b, then a change of ΔV spread linearly over T, then
    /// V0 + ΔV (paper Fig. 3b: ΔV = −10 m/s over T ∈ {2, 3, 5, 10} s).
    Ramp {
        /// V0 \[m/s\]
        initial_mps: f64,
        /// ΔV \[m/s\] (negative when braking)
        change_mps: f64,
        /// t_b \[s\], start of the ramp
        start_s: f64,
        /// T \[s\], duration of the ramp
        duration_s: f64,
    },
    /// Piecewise-linear through (t \[s\], V \[m/s\]) points with increasing t; constant before
    /// the first and after the last point.
    Table {
        /// [\[t, V\], …]
        points: Vec<[f64; 2]>,
    },
}

impl SpeedProfile {
    /// V(t) \[m/s\].
    pub fn speed(&self, t: f64) -> f64 {
        match self {
            SpeedProfile::Constant { speed_mps } => *speed_mps,
            SpeedProfile::Ramp {
                initial_mps,
                change_mps,
                start_s,
                duration_s,
            } => {
                let s = ((t - start_s) / duration_s).clamp(0.0, 1.0);
                initial_mps + change_mps * s
            }
            SpeedProfile::Table { points } => {
                let n = points.len();
                if n == 0 {
                    return f64::NAN;
                }
                if t <= points[0][0] {
                    return points[0][1];
                }
                if t >= points[n - 1][0] {
                    return points[n - 1][1];
                }
                let i = points.partition_point(|p| p[0] <= t) - 1;
                let (a, b) = (points[i], points[i + 1]);
                a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0])
            }
        }
    }

    /// V̇(t) \[m/s²\], right-continuous at the corners.
    pub fn acceleration(&self, t: f64) -> f64 {
        match self {
            SpeedProfile::Constant { .. } => 0.0,
            SpeedProfile::Ramp {
                change_mps,
                start_s,
                duration_s,
                ..
            } => {
                if t >= *start_s && t < start_s + duration_s {
                    change_mps / duration_s
                } else {
                    0.0
                }
            }
            SpeedProfile::Table { points } => {
                let n = points.len();
                if n < 2 || t < points[0][0] || t >= points[n - 1][0] {
                    return 0.0;
                }
                let i = points.partition_point(|p| p[0] <= t) - 1;
                let (a, b) = (points[i], points[i + 1]);
                (b[1] - a[1]) / (b[0] - a[0])
            }
        }
    }

    /// Times \[s\] where V̇ jumps.
    pub fn breakpoints(&self) -> Vec<f64> {
        match self {
            SpeedProfile::Constant { .. } => Vec::new(),
            SpeedProfile::Ramp {
                start_s,
                duration_s,
                ..
            } => vec![*start_s, start_s + duration_s],
            SpeedProfile::Table { points } => points.iter().map(|p| p[0]).collect(),
        }
    }

    /// The speed at t = 0 \[m/s\].
    pub fn initial_speed(&self) -> f64 {
        self.speed(0.0)
    }

    /// The lowest speed over \[0, horizon\] \[m/s\] (at a corner or an end).
    pub fn min_speed(&self, horizon: f64) -> f64 {
        let mut ts = self.breakpoints();
        ts.extend([0.0, horizon]);
        ts.iter()
            .filter(|&&t| (0.0..=horizon).contains(&t))
            .map(|&t| self.speed(t))
            .fold(f64::INFINITY, f64::min)
    }

    /// When the speed starts to change (ramp start / first changing table segment), if ever.
    pub fn action_time(&self) -> Option<f64> {
        match self {
            SpeedProfile::Constant { .. } => None,
            SpeedProfile::Ramp { start_s, .. } => Some(*start_s),
            SpeedProfile::Table { points } => points
                .windows(2)
                .find(|w| w[1][1] != w[0][1])
                .map(|w| w[0][0]),
        }
    }

    /// Physical checks; `Err((key, problem))` names the offending key (relative to the
    /// profile's table).
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        match self {
            SpeedProfile::Constant { speed_mps } => {
                if !(speed_mps.is_finite() && *speed_mps > 0.0) {
                    return Err((
                        "speed_mps",
                        format!("expected a speed > 0 m/s, got {speed_mps}"),
                    ));
                }
            }
            SpeedProfile::Ramp {
                initial_mps,
                change_mps,
                start_s,
                duration_s,
            } => {
                if !(initial_mps.is_finite() && *initial_mps > 0.0) {
                    return Err((
                        "initial_mps",
                        format!("expected a speed > 0 m/s, got {initial_mps}"),
                    ));
                }
                if !change_mps.is_finite() || initial_mps + change_mps <= 0.0 {
                    return Err((
                        "change_mps",
                        format!(
                            "the final speed initial_mps + change_mps must stay > 0 m/s, got {}",
                            initial_mps + change_mps
                        ),
                    ));
                }
                if !(start_s.is_finite() && *start_s >= 0.0) {
                    return Err(("start_s", format!("expected a time >= 0 s, got {start_s}")));
                }
                if !(duration_s.is_finite() && *duration_s > 0.0) {
                    return Err((
                        "duration_s",
                        format!("expected a duration > 0 s, got {duration_s}"),
                    ));
                }
            }
            SpeedProfile::Table { points } => {
                if points.is_empty() {
                    return Err(("points", "expected at least one [t, V] point".into()));
                }
                for (i, p) in points.iter().enumerate() {
                    if !(p[0].is_finite() && p[1].is_finite() && p[1] > 0.0) {
                        return Err((
                            "points",
                            format!("point {i}: expected finite t and V > 0 m/s, got {p:?}"),
                        ));
                    }
                    if i > 0 && p[0] <= points[i - 1][0] {
                        return Err((
                            "points",
                            format!("point {i}: times must increase, got {p:?}"),
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn ramp_speed_and_acceleration() {
        // 35 m/s, braking by 10 m/s over 5 s from t = 2 s: V(4.5) = 30, V̇ = −2 m/s² inside
        let p = SpeedProfile::Ramp {
            initial_mps: 35.0,
            change_mps: -10.0,
            start_s: 2.0,
            duration_s: 5.0,
        };
        assert_relative_eq!(p.speed(4.5), 30.0, max_relative = 1e-15);
        assert_eq!(p.speed(1.0), 35.0);
        assert_eq!(p.speed(9.0), 25.0);
        assert_eq!(p.acceleration(1.999), 0.0);
        assert_eq!(p.acceleration(2.0), -2.0); // right-continuous
        assert_eq!(p.acceleration(7.0), 0.0);
        assert_eq!(p.breakpoints(), vec![2.0, 7.0]);
        assert_eq!(p.min_speed(40.0), 25.0);
    }

    #[test]
    fn table_matches_the_equivalent_ramp() {
        let ramp = SpeedProfile::Ramp {
            initial_mps: 35.0,
            change_mps: -10.0,
            start_s: 2.0,
            duration_s: 5.0,
        };
        let table = SpeedProfile::Table {
            points: vec![[0.0, 35.0], [2.0, 35.0], [7.0, 25.0]],
        };
        for i in 0..=100 {
            let t = 0.1 * i as f64;
            assert_relative_eq!(table.speed(t), ramp.speed(t), max_relative = 1e-14);
            assert_relative_eq!(
                table.acceleration(t),
                ramp.acceleration(t),
                max_relative = 1e-14
            );
        }
        assert_eq!(table.action_time(), Some(2.0));
    }

    #[test]
    fn validation_names_the_key() {
        let p = SpeedProfile::Ramp {
            initial_mps: 35.0,
            change_mps: -40.0,
            start_s: 2.0,
            duration_s: 5.0,
        };
        assert_eq!(p.validate().unwrap_err().0, "change_mps");
    }
}
