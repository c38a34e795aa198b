//! Prescribed longitudinal speed profiles V(t) (the constraint of paper eq. 3) with their
//! derivative V̇(t) (which enters eq. 6) and the times where V̇ jumps.

use std::sync::LazyLock;

use serde::{Deserialize, Serialize};

use super::speeds::{Resolver, SpeedValue, UnresolvedSpeed, check_change};

/// The shape s(u) of a speed ramp, u = (t − t_b)/T ∈ \[0, 1\]: V = V0 + ΔV·s(u), s(0) = 0,
/// s(1) = 1, monotone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RampShape {
    /// s = u: constant deceleration ΔV/T (paper Fig. 3b); V̇ jumps at both ends
    #[default]
    Linear,
    /// s = 3u² − 2u³ (smoothstep): V̇ = 6ΔV·u(1 − u)/T rises from 0 and returns to 0, peak
    /// 1.5·ΔV/T at mid-ramp; V̇ is continuous (the jerk jumps at both ends)
    SCurve,
    /// s = (1 − e^(−u/k))/(1 − e^(−1/k)), k = [`RampShape::EXPONENTIAL_RATIO`]: a
    /// first-order (time constant t_c = k·T) approach truncated and rescaled to end exactly at
    /// V0 + ΔV at t_b + T; hardest braking at the start (V̇ = ΔV/(k·T·(1 − e^(−1/k))) ≈
    /// 3.16·ΔV/T), V̇ jumps at both ends
    Exponential,
}

impl RampShape {
    /// All shapes, in the order they are listed in results.
    pub const ALL: [RampShape; 3] = [RampShape::Linear, RampShape::SCurve, RampShape::Exponential];

    /// k = t_c/T of the exponential shape: the time constant is a third of the ramp.
    pub const EXPONENTIAL_RATIO: f64 = 1.0 / 3.0;

    /// Whether it is the default (then it is not written out).
    pub fn is_linear(&self) -> bool {
        *self == RampShape::Linear
    }

    /// The snake_case name used in configs and results.
    pub fn as_str(&self) -> &'static str {
        match self {
            RampShape::Linear => "linear",
            RampShape::SCurve => "s_curve",
            RampShape::Exponential => "exponential",
        }
    }

    /// s(u) for u ∈ \[0, 1\].
    #[inline]
    pub fn fraction(&self, u: f64) -> f64 {
        match self {
            RampShape::Linear => u,
            RampShape::SCurve => u * u * (3.0 - 2.0 * u),
            RampShape::Exponential => {
                let k = Self::EXPONENTIAL_RATIO;
                (-(-u / k).exp_m1()) / exponential_norm()
            }
        }
    }

    /// ds/du for u ∈ \[0, 1).
    #[inline]
    pub fn slope(&self, u: f64) -> f64 {
        match self {
            RampShape::Linear => 1.0,
            RampShape::SCurve => 6.0 * u * (1.0 - u),
            RampShape::Exponential => {
                let k = Self::EXPONENTIAL_RATIO;
                (-u / k).exp() / (k * exponential_norm())
            }
        }
    }
}

/// 1 − e^(−1/k) of the exponential shape (k = [`RampShape::EXPONENTIAL_RATIO`]): computed
/// once, not at every evaluation of V(t) and V̇(t) (the same number: the same libm call).
fn exponential_norm() -> f64 {
    static NORM: LazyLock<f64> = LazyLock::new(|| -(-1.0 / RampShape::EXPONENTIAL_RATIO).exp_m1());
    *NORM
}

/// A prescribed speed V(t) \[m/s\]. V̇ is right-continuous: at a corner it takes the value
/// that holds after it (the solver lands a step on every corner, see [`SpeedProfile::breakpoints`]).
///
/// `S` is the type of the speeds V0 and ΔV: `f64` (m/s) when running, [`SpeedSpec`] as
/// written in a config (a number or relative to the vehicle, see [`super::speeds`]); a
/// table's points are numbers.
///
/// [`SpeedSpec`]: sway_model::speeds::SpeedSpec
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub enum SpeedProfile<S = f64> {
    /// V(t) = V0.
    Constant {
        /// V0 \[m/s\]
        speed_mps: S,
    },
    /// Ramp: V0 until t_b, then a change of ΔV spread over T with the given shape (linear
    /// by default), then V0 + ΔV (paper Fig. 3b: linear, ΔV = −10 m/s over
    /// T ∈ {2, 3, 5, 10} s).
    Ramp {
        /// V0 \[m/s\]
        initial_mps: S,
        /// ΔV \[m/s\] (negative when braking; relative: `{ of_v_crit = f }`)
        change_mps: S,
        /// t_b \[s\], start of the ramp
        start_s: f64,
        /// T \[s\], duration of the ramp
        duration_s: f64,
        /// s(u): "linear" (default), "s_curve" or "exponential"
        #[serde(default, skip_serializing_if = "RampShape::is_linear")]
        shape: RampShape,
    },
    /// Piecewise-linear through (t \[s\], V \[m/s\]) points with increasing t; constant before
    /// the first and after the last point.
    Table {
        /// [\[t, V\], …]
        points: Vec<[f64; 2]>,
    },
}

impl<S: SpeedValue> SpeedProfile<S> {
    /// The profile with every speed a number (config keys under `key`).
    ///
    /// # Errors
    /// The first speed that does not resolve for this vehicle.
    pub fn resolve_speeds(
        &self,
        key: &str,
        r: &mut Resolver<'_>,
    ) -> Result<SpeedProfile, UnresolvedSpeed> {
        Ok(match self {
            SpeedProfile::Constant { speed_mps } => SpeedProfile::Constant {
                speed_mps: speed_mps.resolve_speed(&format!("{key}.speed_mps"), r)?,
            },
            SpeedProfile::Ramp {
                initial_mps,
                change_mps,
                start_s,
                duration_s,
                shape,
            } => SpeedProfile::Ramp {
                initial_mps: initial_mps.resolve_speed(&format!("{key}.initial_mps"), r)?,
                change_mps: change_mps.resolve_change(&format!("{key}.change_mps"), r)?,
                start_s: *start_s,
                duration_s: *duration_s,
                shape: *shape,
            },
            SpeedProfile::Table { points } => SpeedProfile::Table {
                points: points.clone(),
            },
        })
    }

    /// Checks what can be checked before the speeds are resolved: a ramp's change is not
    /// `in_bistable`; `Err((key, problem))` relative to the profile's table.
    pub fn validate_spec(&self) -> Result<(), (&'static str, String)> {
        if let SpeedProfile::Ramp { change_mps, .. } = self {
            check_change(change_mps, "change_mps").map_err(|(_, p)| ("change_mps", p))?;
        }
        Ok(())
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
                shape,
            } => {
                let u = ((t - start_s) / duration_s).clamp(0.0, 1.0);
                initial_mps + change_mps * shape.fraction(u)
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
                shape,
                ..
            } => {
                if t >= *start_s && t < start_s + duration_s {
                    let u = ((t - start_s) / duration_s).clamp(0.0, 1.0);
                    change_mps / duration_s * shape.slope(u)
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

    /// Times \[s\] where V̇ jumps (for the S-curve ramp: where V̈ jumps).
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
                ..
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
            shape: RampShape::Linear,
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
            shape: RampShape::Linear,
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
            shape: RampShape::Linear,
        };
        assert_eq!(p.validate().unwrap_err().0, "change_mps");
    }
}

#[cfg(test)]
mod shape_tests {
    use super::*;
    use approx::assert_relative_eq;

    fn ramp(shape: RampShape) -> SpeedProfile {
        SpeedProfile::Ramp {
            initial_mps: 35.0,
            change_mps: -10.0,
            start_s: 2.0,
            duration_s: 5.0,
            shape,
        }
    }

    #[test]
    fn shapes_end_where_the_linear_ramp_ends() {
        // reference: s(0) = 0, s(1) = 1 exactly up to round-off (1e-14)
        for shape in RampShape::ALL {
            let p = ramp(shape);
            assert_eq!(p.speed(2.0), 35.0);
            assert_relative_eq!(p.speed(7.0), 25.0, max_relative = 1e-14);
            assert_eq!(p.speed(9.0), p.speed(7.0));
            assert_eq!(p.breakpoints(), vec![2.0, 7.0]);
            assert_relative_eq!(p.min_speed(40.0), 25.0, max_relative = 1e-14);
        }
    }

    #[test]
    fn acceleration_is_the_derivative_of_the_speed() {
        // reference: central differences, h = 1e-5 s, truncation error O(h²·V⃛) < 1e-7 m/s²
        let h = 1e-5;
        for shape in RampShape::ALL {
            let p = ramp(shape);
            for i in 1..50 {
                let t = 2.0 + 0.1 * i as f64 + 0.003;
                let fd = (p.speed(t + h) - p.speed(t - h)) / (2.0 * h);
                assert!(
                    (p.acceleration(t) - fd).abs() < 1e-7,
                    "{shape:?} at t = {t}: {} vs {fd}",
                    p.acceleration(t)
                );
            }
        }
    }

    #[test]
    fn shape_is_optional_in_toml() {
        let p: SpeedProfile = toml::from_str(
            "kind = \"ramp\"\ninitial_mps = 35.0\nchange_mps = -10.0\nstart_s = 2.0\nduration_s = 5.0\n",
        )
        .unwrap();
        assert_eq!(p, ramp(RampShape::Linear));
        let p: SpeedProfile = toml::from_str(
            "kind = \"ramp\"\ninitial_mps = 35.0\nchange_mps = -10.0\nstart_s = 2.0\nduration_s = 5.0\nshape = \"s_curve\"\n",
        )
        .unwrap();
        assert_eq!(p, ramp(RampShape::SCurve));
        // the exponential's initial deceleration, by hand: ΔV/(kT(1 − e^(−3))) with k = 1/3
        let a0 = -10.0 / (5.0 / 3.0 * (1.0 - (-3f64).exp()));
        assert_relative_eq!(
            ramp(RampShape::Exponential).acceleration(2.0),
            a0,
            max_relative = 1e-14
        );
    }
}
