//! The controller tables of the config files and their conversion into the one
//! [`LoopLaw`].
//!
//! A scenario or sweep file writes its controller as `[controller]` with a `kind`:
//! `none`, `yaw_rate_feedback` (the paper's δ(t) = −D·ψ̇(t − τ), eq. 8, with optional
//! steering limits, [`ActuatorLimits`]), `yaw_rate_hitch` or `predictor` (with either
//! actuator and the braking limit, [`CommandLimit`]). [`ControllerTable`] reads and echoes
//! that form; every engine takes the [`LoopLaw`] it converts into.

use serde::{Deserialize, Serialize};

use crate::law::{Actuator, ActuatorLimits, CommandLimit, Gains, LoopLaw, ModelError, Structure};

/// A controller table of a scenario or sweep file (`[controller]`, `kind = …`): the file
/// form of a [`LoopLaw`], into which it converts ([`ControllerTable::law`]). Each kind
/// names its keys as the files always have (`gain_s` and the steering limits `actuator` of
/// the yaw-rate feedback; `gains`, `actuator` and the braking `limit` of the others), and
/// a predictor's `prediction_vehicle` is a path that the caller reading the file loads.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ControllerTable {
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
        #[serde(default = "default_actuator")]
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
        #[serde(default = "default_actuator")]
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

fn default_actuator() -> Actuator {
    Actuator::Steering
}

/// A predictor's `prediction_vehicle` that the caller reading the file has not loaded
/// ([`PredictionVehicle::loaded`]).
#[derive(Debug, Clone, PartialEq)]
pub struct UnloadedPrediction(pub std::path::PathBuf);

impl std::fmt::Display for UnloadedPrediction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the prediction vehicle {} was not loaded (the caller that reads the scenario \
             loads it: PredictionVehicle::loaded)",
            self.0.display()
        )
    }
}

impl std::error::Error for UnloadedPrediction {}

impl ControllerTable {
    /// The law this table describes (`None` for `kind = "none"`).
    ///
    /// # Errors
    /// [`UnloadedPrediction`] for a predictor whose `prediction_vehicle` was not loaded.
    pub fn law(&self) -> Result<Option<LoopLaw>, UnloadedPrediction> {
        match (self.law_shape(), self) {
            (
                Some(mut law),
                ControllerTable::Predictor {
                    prediction_vehicle: Some(p),
                    ..
                },
            ) => {
                law.prediction_vehicle =
                    Some(p.params.ok_or_else(|| UnloadedPrediction(p.file.clone()))?);
                Ok(Some(law))
            }
            (law, _) => Ok(law),
        }
    }

    /// The law without the predictor's vehicle file (which only a loaded file gives).
    fn law_shape(&self) -> Option<LoopLaw> {
        match *self {
            ControllerTable::None => None,
            ControllerTable::YawRateFeedback {
                gain_s,
                delay_s,
                on_s,
                off_s,
                actuator,
            } => Some(LoopLaw {
                steering_limits: actuator,
                ..LoopLaw::paper(gain_s, delay_s).switched(on_s, off_s)
            }),
            ControllerTable::YawRateHitch {
                gains,
                delay_s,
                actuator,
                on_s,
                off_s,
                limit,
            } => Some(LoopLaw {
                braking_limit: limit,
                ..LoopLaw::new(Structure::YawRateHitch, actuator, gains, delay_s)
                    .switched(on_s, off_s)
            }),
            ControllerTable::Predictor {
                gains,
                delay_s,
                actuator,
                on_s,
                off_s,
                limit,
                model_error,
                ..
            } => Some(LoopLaw {
                braking_limit: limit,
                model_error,
                ..LoopLaw::new(Structure::Predictor, actuator, gains, delay_s).switched(on_s, off_s)
            }),
        }
    }

    /// The delay τ \[s\] of the loop, if there is a loop.
    pub fn delay(&self) -> Option<f64> {
        self.law_shape().map(|l| l.delay_s)
    }

    /// When the controller is switched on, if ever.
    pub fn action_time(&self) -> Option<f64> {
        self.law_shape().map(|l| l.on_s)
    }

    /// Checks ([`LoopLaw::validate`]); `Err((key, problem))` names the offending key of
    /// this table.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let Some(law) = self.law_shape() else {
            return Ok(());
        };
        law.validate().map_err(|(key, problem)| match self {
            // the yaw-rate feedback writes D as `gain_s`
            ControllerTable::YawRateFeedback { .. } if key == "gains.yaw_rate" => {
                ("gain_s", problem)
            }
            _ => (key, problem),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn law(c: &ControllerTable) -> LoopLaw {
        c.law().unwrap().unwrap()
    }

    #[test]
    fn switching_window_is_right_continuous() {
        let c = ControllerTable::YawRateFeedback {
            gain_s: 0.1,
            delay_s: 0.2,
            on_s: 10.0,
            off_s: Some(20.0),
            actuator: ActuatorLimits::NONE,
        };
        assert_eq!(law(&c).steering_angle(9.999, 1.0), 0.0);
        assert_eq!(law(&c).steering_angle(10.0, 1.0), -0.1);
        assert_eq!(law(&c).steering_angle(19.999, -2.0), 0.2);
        assert_eq!(law(&c).steering_angle(20.0, 1.0), 0.0);
        assert_eq!(law(&c).breakpoints(), vec![10.0, 20.0]);
    }
}

#[cfg(test)]
mod limit_tests {
    use super::*;

    fn law(c: &ControllerTable) -> LoopLaw {
        c.law().unwrap().unwrap()
    }

    fn limited(actuator: ActuatorLimits) -> ControllerTable {
        ControllerTable::YawRateFeedback {
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
        assert_eq!(law(&c).steering_angle(1.0, 1.0), -(2f64.to_radians()));
        assert_eq!(law(&c).steering_angle(1.0, 0.1), -0.1 * 0.1);
        let big = limited(ActuatorLimits {
            max_angle_deg: Some(1e300),
            ..ActuatorLimits::NONE
        });
        let none = limited(ActuatorLimits::NONE);
        for r in [-3.0, -1e-9, 0.0, 0.7, 12.5] {
            assert_eq!(
                law(&big).steering_angle(1.0, r).to_bits(),
                law(&none).steering_angle(1.0, r).to_bits()
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
        let c: ControllerTable =
            toml::from_str("kind = \"yaw_rate_feedback\"\ngain_s = 0.1\ndelay_s = 0.2\n").unwrap();
        assert_eq!(law(&c).steering_limits, ActuatorLimits::NONE);
        let c: ControllerTable = toml::from_str(
            "kind = \"yaw_rate_feedback\"\ngain_s = 0.1\ndelay_s = 0.2\nactuator = { max_rate_deg_s = -1.0 }\n",
        )
        .unwrap();
        assert_eq!(c.validate().unwrap_err().0, "actuator.max_rate_deg_s");
    }
}
