//! Steering controllers: none, or the delayed yaw-rate feedback δ(t) = −D·ψ̇(t − τ) of
//! paper eq. (8), switched on at t_on and optionally off at t_off, with optional actuator
//! limits ([`ActuatorLimits`]): a steering-angle saturation |δ| ≤ δ_max and a rate limit
//! |δ̇| ≤ δ̇_max.
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

use crate::law::{Actuator, Gains};

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

/// The steering law.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Controller {
    /// δ ≡ 0 (open loop).
    #[default]
    None,
    /// δ(t) = −D·ψ̇(t − τ) for t_on ≤ t < t_off, 0 otherwise (paper eq. 8).
    YawRateFeedback {
        /// control gain D \[s\]
        gain_s: f64,
        /// feedback delay τ \[s\] (sensing, computation, actuation; 0.2–0.4 s in production cars)
        delay_s: f64,
        /// t_on \[s\]: switched on
        #[serde(default)]
        on_s: f64,
        /// t_off \[s\]: switched off (never when absent)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        off_s: Option<f64>,
        /// steering-angle saturation and rate limit (none when absent)
        #[serde(default, skip_serializing_if = "ActuatorLimits::is_default")]
        actuator: ActuatorLimits,
    },
    /// u(t) = −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ) for t_on ≤ t < t_off (the
    /// `yaw_rate_hitch` structure, [`crate::law::Structure::YawRateHitch`]): a yaw-rate and a
    /// hitch-angle sensor; u is the steering angle δ \[rad\] or the braking yaw moment
    /// M_z \[N m\] (saturated at ±M_max, [`CommandLimit`]).
    YawRateHitch {
        /// D, K_θ, D_θ (units of the actuator: [`crate::law`])
        gains: Gains,
        /// loop delay τ \[s\]
        delay_s: f64,
        /// what the command moves (default steering)
        #[serde(default = "default_loop_actuator")]
        actuator: Actuator,
        /// t_on \[s\]: switched on
        #[serde(default)]
        on_s: f64,
        /// t_off \[s\]: switched off (never when absent)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        off_s: Option<f64>,
        /// the braking limit (ignored for steering)
        #[serde(default, skip_serializing_if = "CommandLimit::is_default")]
        limit: CommandLimit,
    },
    /// u(t) = −D·ψ̇_p(t) for t_on ≤ t < t_off (the `predictor` structure,
    /// [`crate::law::predictor`]): ψ̇_p = Ĉ·x̂(t), x̂(t) = e^{Âτ}x(t − τ) + z(t), the state
    /// predicted τ ahead through the prediction model (Â, B̂, Ĉ) linearised at the speed of
    /// t = 0, with z(t) = ∫_{t−τ}^{t} e^{Â(t−s)}B̂u(s) ds realised as the four extra states
    /// ż = Âz + B̂u(t) − e^{Âτ}B̂u(t − τ), z(0) = 0 (u ≡ 0 before t_on). The realisation
    /// carries the eigenvalues of Â as modes that the exact integral does not have (an
    /// error in z obeys ė = Â e): exact where the prediction model is stable (below its
    /// open-loop critical speed); above it round-off grows at the rate of Â's unstable root.
    Predictor {
        /// D, on the predicted yaw rate (only `yaw_rate`; the hitch gains must be 0)
        gains: Gains,
        /// loop delay τ \[s\] (the prediction horizon)
        delay_s: f64,
        /// what the command moves (default steering)
        #[serde(default = "default_loop_actuator")]
        actuator: Actuator,
        /// t_on \[s\]: switched on
        #[serde(default)]
        on_s: f64,
        /// t_off \[s\]: switched off (never when absent)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        off_s: Option<f64>,
        /// the braking limit (ignored for steering)
        #[serde(default, skip_serializing_if = "CommandLimit::is_default")]
        limit: CommandLimit,
        /// how the prediction model differs from the vehicle (default: a perfect model);
        /// with `prediction_vehicle`, the factors apply to that vehicle
        #[serde(default, skip_serializing_if = "ModelError::is_default")]
        model_error: ModelError,
        /// the prediction model as a vehicle file of its own (default: the vehicle itself)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        prediction_vehicle: Option<PredictionVehicle>,
    },
}

/// The predictor's model given as a vehicle file (`prediction_vehicle`, a path relative to
/// the scenario or sweep file): the prediction runs on it instead of the vehicle, so a
/// simulation shows what a prediction model that differs from the vehicle does.
///
/// The predictor's realisation is four-state (module [`crate::law::predictor`]): it
/// predicts with the paper-form linearisation of the file's equivalent single-axle vehicle
/// ([`trailer_model::VehicleSpec::equivalent_params`]), as it does with the vehicle itself;
/// tyre relaxation in the file does not enter the prediction.
///
/// It (de)serialises as the path; the caller that reads files loads it
/// ([`Self::params`] is `None` until then, and a simulation refuses an unloaded one).
#[derive(Debug, Clone, PartialEq)]
pub struct PredictionVehicle {
    /// the file, as written in the scenario
    pub file: std::path::PathBuf,
    /// its equivalent paper-form parameters, once loaded
    pub params: Option<trailer_model::VehicleParams>,
}

impl PredictionVehicle {
    /// The vehicle file `file`, not yet loaded.
    pub fn new(file: impl Into<std::path::PathBuf>) -> Self {
        Self {
            file: file.into(),
            params: None,
        }
    }

    /// The file, loaded with `params`.
    pub fn loaded(
        file: impl Into<std::path::PathBuf>,
        params: trailer_model::VehicleParams,
    ) -> Self {
        Self {
            file: file.into(),
            params: Some(params),
        }
    }
}

impl Serialize for PredictionVehicle {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.file.serialize(s)
    }
}

impl<'de> Deserialize<'de> for PredictionVehicle {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        std::path::PathBuf::deserialize(d).map(Self::new)
    }
}

fn default_loop_actuator() -> Actuator {
    Actuator::Steering
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
        Self {
            track_width_m: default_track_width(),
            max_yaw_moment_nm: None,
        }
    }
}

impl CommandLimit {
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

    fn validate(&self) -> Result<(), (&'static str, String)> {
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
        Self {
            trailer_mass_factor: 1.0,
            trailer_yaw_inertia_factor: 1.0,
            trailer_cog_factor: 1.0,
        }
    }
}

impl ModelError {
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

    fn validate(&self) -> Result<(), (&'static str, String)> {
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

/// The loop law of a `yaw_rate_hitch` or `predictor` controller, as [`Controller::loop_law`]
/// gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopLaw {
    /// `yaw_rate_hitch` or `predictor`
    pub structure: crate::law::Structure,
    /// the gains
    pub gains: Gains,
    /// τ \[s\]
    pub delay_s: f64,
    /// steering or braking
    pub actuator: Actuator,
    /// t_on \[s\]
    pub on_s: f64,
    /// t_off \[s\]
    pub off_s: Option<f64>,
    /// the braking limit
    pub limit: CommandLimit,
    /// the predictor's model error (perfect for `yaw_rate_hitch`)
    pub model_error: ModelError,
    /// the predictor's model when it is not the vehicle: the loaded `prediction_vehicle`
    /// (`Err` with its file while it is not loaded)
    pub prediction: Result<Option<trailer_model::VehicleParams>, std::path::PathBuf>,
}

impl LoopLaw {
    /// The parameters of the predictor's model for a vehicle with `params`: the loaded
    /// `prediction_vehicle` (else the vehicle) with `model_error`'s factors applied.
    ///
    /// # Errors
    /// A message naming a `prediction_vehicle` that was not loaded.
    pub fn prediction_params(
        &self,
        params: &trailer_model::VehicleParams,
    ) -> Result<trailer_model::VehicleParams, String> {
        let base = match &self.prediction {
            Ok(p) => p.unwrap_or(*params),
            Err(file) => {
                return Err(format!(
                    "the prediction vehicle {} was not loaded (the caller that reads the \
                     scenario loads it: PredictionVehicle::loaded)",
                    file.display()
                ));
            }
        };
        Ok(self.model_error.apply(&base))
    }

    /// Whether the controller acts at time t (t_on ≤ t < t_off).
    #[inline]
    pub fn is_on(&self, t: f64) -> bool {
        t >= self.on_s && self.off_s.is_none_or(|off| t < off)
    }
}

impl Controller {
    /// The delay τ \[s\] of the loop, if there is a loop.
    pub fn delay(&self) -> Option<f64> {
        match self {
            Controller::None => None,
            Controller::YawRateFeedback { delay_s, .. }
            | Controller::YawRateHitch { delay_s, .. }
            | Controller::Predictor { delay_s, .. } => Some(*delay_s),
        }
    }

    /// The law of a `yaw_rate_hitch` or `predictor` controller (`None` for the others).
    pub fn loop_law(&self) -> Option<LoopLaw> {
        use crate::law::Structure;
        match self.clone() {
            Controller::None | Controller::YawRateFeedback { .. } => None,
            Controller::YawRateHitch {
                gains,
                delay_s,
                actuator,
                on_s,
                off_s,
                limit,
            } => Some(LoopLaw {
                structure: Structure::YawRateHitch,
                gains,
                delay_s,
                actuator,
                on_s,
                off_s,
                limit,
                model_error: ModelError::default(),
                prediction: Ok(None),
            }),
            Controller::Predictor {
                gains,
                delay_s,
                actuator,
                on_s,
                off_s,
                limit,
                model_error,
                prediction_vehicle,
            } => Some(LoopLaw {
                structure: Structure::Predictor,
                gains,
                delay_s,
                actuator,
                on_s,
                off_s,
                limit,
                model_error,
                prediction: match prediction_vehicle {
                    None => Ok(None),
                    Some(PredictionVehicle {
                        params: Some(p), ..
                    }) => Ok(Some(p)),
                    Some(PredictionVehicle { file, params: None }) => Err(file),
                },
            }),
        }
    }

    /// Number of states the simulation adds to the vehicle's: 1 for a rate-limited
    /// actuator (δ), 4 for the predictor (z), else 0.
    pub fn extra_states(&self) -> usize {
        match self {
            Controller::Predictor { .. } => 4,
            _ => usize::from(self.has_actuator_state()),
        }
    }

    /// The actuator limits (none for the open loop).
    pub fn actuator(&self) -> ActuatorLimits {
        match self {
            Controller::None | Controller::YawRateHitch { .. } | Controller::Predictor { .. } => {
                ActuatorLimits::NONE
            }
            Controller::YawRateFeedback { actuator, .. } => *actuator,
        }
    }

    /// Whether the steering angle is a state of the simulation (a rate limit is set).
    pub fn has_actuator_state(&self) -> bool {
        self.actuator().has_rate_limit()
    }

    /// Steering command δ_c(t) \[rad\] given the delayed yaw rate ψ̇(t − τ) \[rad/s\]:
    /// −D·ψ̇(t − τ) saturated at ±δ_max while the controller is on, 0 while it is off (eq. 8).
    /// It is the steering angle itself unless a rate limit is set (see the module docs).
    #[inline]
    pub fn steering_angle(&self, t: f64, delayed_yaw_rate: f64) -> f64 {
        self.actuator()
            .saturate(self.raw_steering_angle(t, delayed_yaw_rate))
    }

    /// The command before saturation \[rad\]: −D·ψ̇(t − τ) while the controller is on, 0
    /// while it is off (0 for `yaw_rate_hitch` and `predictor`, whose commands the
    /// simulation computes from the whole delayed state).
    #[inline]
    pub fn raw_steering_angle(&self, t: f64, delayed_yaw_rate: f64) -> f64 {
        match self {
            Controller::None | Controller::YawRateHitch { .. } | Controller::Predictor { .. } => {
                0.0
            }
            Controller::YawRateFeedback {
                gain_s,
                on_s,
                off_s,
                ..
            } => {
                if t >= *on_s && off_s.is_none_or(|off| t < off) {
                    -gain_s * delayed_yaw_rate
                } else {
                    0.0
                }
            }
        }
    }

    /// Times \[s\] where δ may jump (switching on and off).
    pub fn breakpoints(&self) -> Vec<f64> {
        match self {
            Controller::None => Vec::new(),
            Controller::YawRateFeedback { on_s, off_s, .. }
            | Controller::YawRateHitch { on_s, off_s, .. } => {
                let mut v = vec![*on_s];
                v.extend(off_s.iter());
                v
            }
            // u(t − τ) in ż jumps τ later
            Controller::Predictor {
                on_s,
                off_s,
                delay_s,
                ..
            } => {
                let mut v = vec![*on_s, on_s + delay_s];
                v.extend(off_s.iter().flat_map(|o| [*o, o + delay_s]));
                v
            }
        }
    }

    /// When the controller is switched on, if ever.
    pub fn action_time(&self) -> Option<f64> {
        match self {
            Controller::None => None,
            Controller::YawRateFeedback { on_s, .. }
            | Controller::YawRateHitch { on_s, .. }
            | Controller::Predictor { on_s, .. } => Some(*on_s),
        }
    }

    /// Checks; `Err((key, problem))` names the offending key.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if let Controller::YawRateFeedback {
            gain_s,
            delay_s,
            on_s,
            off_s,
            actuator,
        } = self
        {
            if !gain_s.is_finite() {
                return Err(("gain_s", format!("expected a finite gain, got {gain_s}")));
            }
            if !(delay_s.is_finite() && *delay_s >= 0.0) {
                return Err(("delay_s", format!("expected a delay >= 0 s, got {delay_s}")));
            }
            if !(on_s.is_finite() && *on_s >= 0.0) {
                return Err(("on_s", format!("expected a time >= 0 s, got {on_s}")));
            }
            if let Some(off) = off_s
                && !(off.is_finite() && off > on_s)
            {
                return Err((
                    "off_s",
                    format!("expected off_s > on_s = {on_s}, got {off}"),
                ));
            }
            actuator.validate()?;
        }
        if let Some(law) = self.loop_law() {
            let g = law.gains;
            for (key, v) in [
                ("gains.yaw_rate", g.yaw_rate),
                ("gains.hitch_angle", g.hitch_angle),
                ("gains.hitch_rate", g.hitch_rate),
            ] {
                if !v.is_finite() {
                    return Err((key, format!("expected a finite gain, got {v}")));
                }
            }
            if law.structure == crate::law::Structure::Predictor {
                for (key, v) in [
                    ("gains.hitch_angle", g.hitch_angle),
                    ("gains.hitch_rate", g.hitch_rate),
                ] {
                    if v != 0.0 {
                        return Err((
                            key,
                            format!("the predictor feeds back only gains.yaw_rate; got {v}"),
                        ));
                    }
                }
            }
            let (delay_s, on_s) = (law.delay_s, law.on_s);
            if !(delay_s.is_finite() && delay_s >= 0.0) {
                return Err(("delay_s", format!("expected a delay >= 0 s, got {delay_s}")));
            }
            if !(on_s.is_finite() && on_s >= 0.0) {
                return Err(("on_s", format!("expected a time >= 0 s, got {on_s}")));
            }
            if let Some(off) = law.off_s
                && !(off.is_finite() && off > on_s)
            {
                return Err((
                    "off_s",
                    format!("expected off_s > on_s = {on_s}, got {off}"),
                ));
            }
            law.limit.validate()?;
            law.model_error.validate()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn switching_window_is_right_continuous() {
        let c = Controller::YawRateFeedback {
            gain_s: 0.1,
            delay_s: 0.2,
            on_s: 10.0,
            off_s: Some(20.0),
            actuator: ActuatorLimits::NONE,
        };
        assert_eq!(c.steering_angle(9.999, 1.0), 0.0);
        assert_eq!(c.steering_angle(10.0, 1.0), -0.1);
        assert_eq!(c.steering_angle(19.999, -2.0), 0.2);
        assert_eq!(c.steering_angle(20.0, 1.0), 0.0);
        assert_eq!(c.breakpoints(), vec![10.0, 20.0]);
    }
}

#[cfg(test)]
mod limit_tests {
    use super::*;

    fn limited(actuator: ActuatorLimits) -> Controller {
        Controller::YawRateFeedback {
            gain_s: 0.1,
            delay_s: 0.2,
            on_s: 0.0,
            off_s: None,
            actuator,
        }
    }

    #[test]
    fn saturation_clamps_the_command_and_large_limits_change_nothing() {
        // reference: clamp by hand; 2° = 0.0349 rad, command −0.1·1 = −0.1 rad
        let c = limited(ActuatorLimits {
            max_angle_deg: Some(2.0),
            ..ActuatorLimits::NONE
        });
        assert_eq!(c.steering_angle(1.0, 1.0), -(2f64.to_radians()));
        assert_eq!(c.steering_angle(1.0, 0.1), -0.1 * 0.1);
        let big = limited(ActuatorLimits {
            max_angle_deg: Some(1e300),
            ..ActuatorLimits::NONE
        });
        let none = limited(ActuatorLimits::NONE);
        for r in [-3.0, -1e-9, 0.0, 0.7, 12.5] {
            assert_eq!(
                big.steering_angle(1.0, r).to_bits(),
                none.steering_angle(1.0, r).to_bits()
            );
        }
    }

    #[test]
    fn actuator_rate_is_clamped() {
        // reference: (δ_c − δ)/t_a = (0.1 − 0)/0.05 = 2 rad/s, limited to 10 deg/s
        let a = ActuatorLimits {
            max_rate_deg_s: Some(10.0),
            ..ActuatorLimits::NONE
        };
        assert_eq!(a.rate(0.1, 0.0), 10f64.to_radians());
        assert_eq!(a.rate(-0.1, 0.0), -(10f64.to_radians()));
        assert!((a.rate(0.001, 0.0) - 0.02).abs() < 1e-15);
    }

    #[test]
    fn limits_are_optional_in_toml_and_validated_by_key() {
        let c: Controller =
            toml::from_str("kind = \"yaw_rate_feedback\"\ngain_s = 0.1\ndelay_s = 0.2\n").unwrap();
        assert_eq!(c.actuator(), ActuatorLimits::NONE);
        let c: Controller = toml::from_str(
            "kind = \"yaw_rate_feedback\"\ngain_s = 0.1\ndelay_s = 0.2\nactuator = { max_rate_deg_s = -1.0 }\n",
        )
        .unwrap();
        assert_eq!(c.validate().unwrap_err().0, "actuator.max_rate_deg_s");
    }
}
