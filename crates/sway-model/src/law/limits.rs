//! The limits of a loop's actuator and the predictor's model error, parts of a
//! [`LoopLaw`](super::LoopLaw).
//!
//! Steering ([`ActuatorLimits`], the yaw-rate loop on the steering): a steering-angle
//! saturation |δ| ≤ δ_max and a rate limit |δ̇| ≤ δ̇_max. Differential braking
//! ([`CommandLimit`]): |M_z| ≤ M_max. The predictor's model ([`ModelError`]): factors on
//! the trailer's mass, inertia and centre of gravity.
//!
//! The saturation is memoryless: the command becomes
//! δ_c(t) = clamp(−D·ψ̇(t − τ), −δ_max, δ_max) while the controller is on (0 while it is
//! off). A rate limit is not a function of the delayed signal (the angle reached depends on
//! the whole past of the command), so with a rate limit the steering angle is a state of a
//! first-order actuator:
//!
//! δ̇(t) = clamp((δ_c(t) − δ(t)) / t_a, −δ̇_max, δ̇_max),  δ(0) = 0,
//!
//! with the actuator time constant t_a (`time_constant_s`, default 0.05 s): a linear servo
//! of bandwidth 1/t_a whose speed saturates at δ̇_max. For t_a → 0 it tends to the ideal rate
//! limiter (δ follows δ_c wherever it moves slower than δ̇_max); t_a = 0.05 s lags the
//! sway mode (≈ 2.3 rad/s) by atan(2.3 · 0.05) ≈ 7°. The extra state exists only when the
//! rate limit is on ([`ActuatorLimits::has_rate_limit`]); δ stays within ±δ_max because it
//! relaxes towards a command that does. Without limits (the default) everything is
//! unchanged.

use serde::{Deserialize, Serialize};

use crate::law::Actuator;

fn default_time_constant() -> f64 {
    0.05
}

/// Limits of the steering actuator (the `actuator` table of a yaw-rate controller); every
/// key is optional and the default is no limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorLimits {
    /// δ_max \[deg\]: saturation |δ| ≤ δ_max (none when absent)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_angle_deg: Option<f64>,
    /// δ̇_max \[deg/s\]: rate limit |δ̇| ≤ δ̇_max (none when absent); adds the actuator state
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_rate_deg_s: Option<f64>,
    /// t_a \[s\]: time constant of the first-order actuator used with a rate limit
    #[serde(default = "default_time_constant")]
    pub time_constant_s: f64,
}

impl Default for ActuatorLimits {
    fn default() -> Self {
        Self::NONE
    }
}

impl ActuatorLimits {
    /// No limits (the paper's ideal actuator).
    pub const NONE: Self = Self {
        max_angle_deg: None,
        max_rate_deg_s: None,
        time_constant_s: 0.05,
    };

    /// Whether these are the defaults (then they are not written out).
    pub fn is_default(&self) -> bool {
        *self == Self::NONE
    }

    /// Whether a rate limit is set (then δ is an extra state of the simulation).
    pub fn has_rate_limit(&self) -> bool {
        self.max_rate_deg_s.is_some()
    }

    /// Checks; `Err((key, problem))` names the key inside the `actuator` table.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if let Some(m) = self.max_angle_deg
            && !(m.is_finite() && m > 0.0)
        {
            return Err((
                "actuator.max_angle_deg",
                format!("expected a finite angle > 0 deg, got {m}"),
            ));
        }
        if let Some(r) = self.max_rate_deg_s
            && !(r.is_finite() && r > 0.0)
        {
            return Err((
                "actuator.max_rate_deg_s",
                format!("expected a finite rate > 0 deg/s, got {r}"),
            ));
        }
        let ta = self.time_constant_s;
        if !(ta.is_finite() && ta > 0.0) {
            return Err((
                "actuator.time_constant_s",
                format!("expected a time constant > 0 s, got {ta}"),
            ));
        }
        Ok(())
    }

    /// The saturated command clamp(δ, −δ_max, δ_max) \[rad\] (δ itself without a limit).
    #[inline]
    pub fn saturate(&self, delta: f64) -> f64 {
        match self.max_angle_deg {
            Some(m) => {
                let m = m.to_radians();
                delta.clamp(-m, m)
            }
            None => delta,
        }
    }

    /// Switching function of the saturation (its sign changes where the clamp engages or
    /// lets go): δ_raw² − δ_max² for the unsaturated command δ_raw \[rad\]; −1 (never)
    /// without a limit.
    #[inline]
    pub fn saturation_switch(&self, raw_command: f64) -> f64 {
        match self.max_angle_deg {
            Some(m) => raw_command * raw_command - m.to_radians().powi(2),
            None => -1.0,
        }
    }

    /// Switching function of the rate limit: r² − δ̇_max² with r = (δ_c − δ)/t_a; −1 (never)
    /// without a limit.
    #[inline]
    pub fn rate_switch(&self, command: f64, delta: f64) -> f64 {
        match self.max_rate_deg_s {
            Some(m) => {
                let r = (command - delta) / self.time_constant_s;
                r * r - m.to_radians().powi(2)
            }
            None => -1.0,
        }
    }

    /// The actuator's δ̇ = clamp((δ_c − δ)/t_a, −δ̇_max, δ̇_max) \[rad/s\] (δ_c − δ over t_a
    /// without a rate limit).
    #[inline]
    pub fn rate(&self, command: f64, delta: f64) -> f64 {
        let r = (command - delta) / self.time_constant_s;
        match self.max_rate_deg_s {
            Some(m) => {
                let m = m.to_radians();
                r.clamp(-m, m)
            }
            None => r,
        }
    }
}

fn default_track_width() -> f64 {
    1.6
}

/// The limit of the differential-braking command (the `limit` table of `yaw_rate_hitch`
/// and `predictor`): |M_z| ≤ M_max with M_max = `max_yaw_moment_nm` when given, else
/// [`Actuator::limit`] of the vehicle, μ0·(F_zF + F_zR)·w/4 with the track width w.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandLimit {
    /// track width w \[m\] of the tractor for [`Actuator::limit`] (default 1.6 m)
    #[serde(default = "default_track_width")]
    pub track_width_m: f64,
    /// M_max \[N m\] stated directly (replaces the friction limit when present)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_yaw_moment_nm: Option<f64>,
}

impl Default for CommandLimit {
    fn default() -> Self {
        Self::FRICTION
    }
}

impl CommandLimit {
    /// The friction limit of a tractor 1.6 m wide (the default).
    pub const FRICTION: Self = Self {
        track_width_m: 1.6,
        max_yaw_moment_nm: None,
    };

    /// Whether these are the defaults (then they are not written out).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// M_max \[N m\] of `actuator` on `model` (`None` for steering: no limit).
    pub fn max_command(&self, actuator: Actuator, model: &trailer_model::Model) -> Option<f64> {
        match actuator {
            Actuator::Steering => None,
            Actuator::DifferentialBraking => self
                .max_yaw_moment_nm
                .or_else(|| actuator.limit(model, self.track_width_m)),
        }
    }

    /// Checks; `Err((key, problem))` names the key inside the table.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let w = self.track_width_m;
        if !(w.is_finite() && w > 0.0) {
            return Err((
                "limit.track_width_m",
                format!("expected a width > 0 m, got {w}"),
            ));
        }
        if let Some(m) = self.max_yaw_moment_nm
            && !(m.is_finite() && m > 0.0)
        {
            return Err((
                "limit.max_yaw_moment_nm",
                format!("expected a finite yaw moment > 0 N m, got {m}"),
            ));
        }
        Ok(())
    }
}

/// How the predictor's model differs from the vehicle: factors on the trailer's mass m2,
/// yaw inertia J2 and hitch-to-centre-of-gravity distance h (the `model_error` table;
/// each defaults to 1, a perfect model).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelError {
    /// factor on m2 \[-\]
    pub trailer_mass_factor: f64,
    /// factor on J2 \[-\]
    pub trailer_yaw_inertia_factor: f64,
    /// factor on h \[-\]
    pub trailer_cog_factor: f64,
}

impl Default for ModelError {
    fn default() -> Self {
        Self::PERFECT
    }
}

impl ModelError {
    /// A perfect model (every factor 1, the default).
    pub const PERFECT: Self = Self {
        trailer_mass_factor: 1.0,
        trailer_yaw_inertia_factor: 1.0,
        trailer_cog_factor: 1.0,
    };

    /// Whether this is the perfect model.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The prediction model's parameters: `params` with the factors applied.
    pub fn apply(&self, params: &trailer_model::VehicleParams) -> trailer_model::VehicleParams {
        let mut p = *params;
        p.trailer.mass *= self.trailer_mass_factor;
        p.trailer.yaw_inertia *= self.trailer_yaw_inertia_factor;
        p.trailer.cog *= self.trailer_cog_factor;
        p
    }

    /// Checks; `Err((key, problem))` names the key inside the table.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (key, f) in [
            ("model_error.trailer_mass_factor", self.trailer_mass_factor),
            (
                "model_error.trailer_yaw_inertia_factor",
                self.trailer_yaw_inertia_factor,
            ),
            ("model_error.trailer_cog_factor", self.trailer_cog_factor),
        ] {
            if !(f.is_finite() && f > 0.0) {
                return Err((key, format!("expected a finite factor > 0, got {f}")));
            }
        }
        Ok(())
    }
}
