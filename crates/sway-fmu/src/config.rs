//! The defaults the FMU starts from: the vehicle file and the settings of `configs/fmu.toml`
//! (the start values of its parameters and inputs). The archive carries them as
//! `resources/defaults.json`, so the shared library and `modelDescription.xml` agree.

use serde::{Deserialize, Serialize};
use sway_model::law::{Actuator, Gains, LoopLaw, Structure};
use trailer_model::VehicleSpec;

use crate::FmuError;

/// Which feedback law the FMU runs (the parameter `controller.structure`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControllerStructure {
    /// open loop: δ is the input alone
    #[default]
    None,
    /// the paper's δ(t) = −D·ψ̇(t − τ) (eq. 8)
    YawRate,
    /// −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ)
    YawRateHitch,
    /// −D·ψ̇ predicted τ ahead through the linear model
    Predictor,
}

impl ControllerStructure {
    /// Every structure, in the order of the docs.
    pub const ALL: [Self; 4] = [
        Self::None,
        Self::YawRate,
        Self::YawRateHitch,
        Self::Predictor,
    ];

    /// The name of the parameter's value.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::None => "none",
            Self::YawRate => "yaw_rate",
            Self::YawRateHitch => "yaw_rate_hitch",
            Self::Predictor => "predictor",
        }
    }
}

/// The controller's settings as the FMU's parameters (`controller.*`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerSettings {
    /// the law's structure
    pub structure: ControllerStructure,
    /// what it moves: "steering" (δ \[rad\]) or "differential_braking" (M_z \[N m\])
    pub actuator: Actuator,
    /// D on the yaw rate \[s\] (braking: N m s/rad)
    pub gain_s: f64,
    /// K_θ on the hitch angle \[rad/rad\] (braking: N m/rad; `yaw_rate_hitch` only)
    pub hitch_angle_gain: f64,
    /// D_θ on the hitch-angle rate \[s\] (braking: N m s/rad; `yaw_rate_hitch` only)
    pub hitch_rate_gain_s: f64,
    /// τ \[s\]
    pub delay_s: f64,
    /// t_on \[s\]: switched on
    pub on_s: f64,
}

impl Default for ControllerSettings {
    fn default() -> Self {
        Self {
            structure: ControllerStructure::None,
            actuator: Actuator::Steering,
            gain_s: 0.0,
            hitch_angle_gain: 0.0,
            hitch_rate_gain_s: 0.0,
            delay_s: 0.0,
            on_s: 0.0,
        }
    }
}

impl ControllerSettings {
    /// The law these settings describe (`None` in open loop), validated as a scenario
    /// file's controller is.
    ///
    /// # Errors
    /// [`FmuError::Parameter`] naming `controller.<key>`.
    pub fn law(&self) -> Result<Option<LoopLaw>, FmuError> {
        let structure = match self.structure {
            ControllerStructure::None => return Ok(None),
            ControllerStructure::YawRate => Structure::YawRate,
            ControllerStructure::YawRateHitch => Structure::YawRateHitch,
            ControllerStructure::Predictor => Structure::Predictor,
        };
        let gains = Gains {
            yaw_rate: self.gain_s,
            hitch_angle: self.hitch_angle_gain,
            hitch_rate: self.hitch_rate_gain_s,
        };
        let mut law = LoopLaw::new(structure, self.actuator, gains, self.delay_s);
        law.on_s = self.on_s;
        law.validate().map_err(|(key, problem)| {
            let key = match key {
                "gains.yaw_rate" => "gain_s",
                "gains.hitch_angle" => "hitch_angle_gain",
                "gains.hitch_rate" => "hitch_rate_gain_s",
                k => k,
            };
            FmuError::parameter(format!("controller.{key}"), problem)
        })?;
        Ok(Some(law))
    }
}

/// The start values of the initial state (`initial_*`): the paper's 7 states.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitialState {
    /// σ1(0): lateral velocity of the hitch \[m/s\]
    pub sigma1_mps: f64,
    /// σ2(0) \[rad/s\] (eq. 4)
    pub sigma2_rad_s: f64,
    /// σ3(0) \[rad/s\] (eq. 4)
    pub sigma3_rad_s: f64,
    /// θ(0) \[rad\]
    pub hitch_angle_rad: f64,
    /// ψ(0) \[rad\]
    pub car_yaw_angle_rad: f64,
    /// x_H(0) \[m\]
    pub hitch_x_m: f64,
    /// y_H(0) \[m\]
    pub hitch_y_m: f64,
}

/// The solver's tolerances (`solver.rtol`, `solver.atol`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Tolerances {
    /// relative tolerance
    pub rtol: f64,
    /// absolute tolerance
    pub atol: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        let s = sway::sim::SolverSettings::default();
        Self {
            rtol: s.rtol,
            atol: s.atol,
        }
    }
}

/// The settings of `configs/fmu.toml`: start values of the FMU's inputs and parameters
/// beside the vehicle's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FmuConfig {
    /// the start value of the input `speed_mps` \[m/s\]
    pub speed_mps: f64,
    /// the initial state
    pub initial: InitialState,
    /// the feedback law
    pub controller: ControllerSettings,
    /// the solver's tolerances
    pub solver: Tolerances,
}

impl Default for FmuConfig {
    fn default() -> Self {
        Self {
            speed_mps: 33.0,
            initial: InitialState::default(),
            controller: ControllerSettings::default(),
            solver: Tolerances::default(),
        }
    }
}

impl FmuConfig {
    /// Checks the settings (the controller's law, the tolerances, the speed).
    ///
    /// # Errors
    /// [`FmuError::Parameter`] naming the key.
    pub fn validate(&self) -> Result<(), FmuError> {
        if !(self.speed_mps.is_finite() && self.speed_mps > 0.0) {
            return Err(FmuError::parameter(
                "speed_mps",
                format!("{} is invalid: expected a speed > 0 m/s", self.speed_mps),
            ));
        }
        self.controller.law()?;
        let settings = sway::sim::SolverSettings {
            rtol: self.solver.rtol,
            atol: self.solver.atol,
            ..Default::default()
        };
        settings
            .validate()
            .map_err(|(key, problem)| FmuError::parameter(format!("solver.{key}"), problem))
    }
}

/// What the archive carries as `resources/defaults.json`: the vehicle and the settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Defaults {
    /// the vehicle file (its keys become the vehicle parameters)
    pub vehicle: VehicleSpec,
    /// the other start values
    pub config: FmuConfig,
}

impl Default for Defaults {
    /// Table I, open loop at 33 m/s.
    fn default() -> Self {
        Self {
            vehicle: VehicleSpec::from(trailer_model::VehicleParams::default()),
            config: FmuConfig::default(),
        }
    }
}
