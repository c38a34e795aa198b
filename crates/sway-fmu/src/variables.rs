//! The FMU's variables: their names (which importers and scripts refer to), types,
//! causalities, start values and meanings, in the order of their value references.

use serde_json::Value as Json;

use crate::config::{ControllerStructure, Defaults};

/// The type of a variable (FMI 2.0 Real/Integer/Boolean/String, FMI 3.0
/// Float64/Int32/Boolean/String).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// a 64-bit float
    Real,
    /// a 32-bit integer
    Integer,
    /// a boolean
    Boolean,
    /// a string
    String,
}

impl Kind {
    /// Its FMI 2.0 type name (`Real`, `Integer`, `Boolean`, `String`).
    pub fn fmi2_name(&self) -> &'static str {
        match self {
            Kind::Real => "Real",
            Kind::Integer => "Integer",
            Kind::Boolean => "Boolean",
            Kind::String => "String",
        }
    }
}

/// What a variable is to the importer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// set before initialisation (variability "fixed")
    Parameter,
    /// set by the master at each communication point, held until the next
    Input,
    /// computed by the FMU
    Output,
    /// the independent variable, time \[s\]
    Independent,
}

/// A value of a variable.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// Real
    Real(f64),
    /// Integer
    Integer(i32),
    /// Boolean
    Boolean(bool),
    /// String
    String(String),
}

impl Value {
    /// Its kind.
    pub fn kind(&self) -> Kind {
        match self {
            Value::Real(_) => Kind::Real,
            Value::Integer(_) => Kind::Integer,
            Value::Boolean(_) => Kind::Boolean,
            Value::String(_) => Kind::String,
        }
    }
}

/// The inputs, in the order of their value references (0–3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input {
    /// δ \[rad\] added to the controller's
    SteeringAngle,
    /// V \[m/s\], held (V̇ = 0) between communication points
    Speed,
    /// M_z \[N m\] of differential braking on the car
    YawMoment,
    /// lateral force \[N\] on the trailer at its centre of gravity
    TrailerLateralForce,
}

impl Input {
    /// Every input in reference order.
    pub const ALL: [Self; 4] = [
        Self::SteeringAngle,
        Self::Speed,
        Self::YawMoment,
        Self::TrailerLateralForce,
    ];

    /// The variable's name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::SteeringAngle => "steering_angle_rad",
            Self::Speed => "speed_mps",
            Self::YawMoment => "yaw_moment_nm",
            Self::TrailerLateralForce => "trailer_lateral_force_n",
        }
    }

    fn description(&self) -> &'static str {
        match self {
            Self::SteeringAngle => {
                "front-wheel steering angle delta [rad], added to the controller's command"
            }
            Self::Speed => {
                "forward speed V of the car [m/s], held between communication points (dV/dt = 0 within a step)"
            }
            Self::YawMoment => {
                "yaw moment M_z on the car [N m] (differential braking), positive in the sense of the yaw angle"
            }
            Self::TrailerLateralForce => {
                "lateral force on the trailer at its centre of gravity [N] (crosswind), positive to the trailer's left"
            }
        }
    }
}

/// The outputs, in the order of their value references (after the inputs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// σ1 \[m/s\]
    Sigma1,
    /// σ2 \[rad/s\]
    Sigma2,
    /// σ3 \[rad/s\]
    Sigma3,
    /// θ \[rad\]
    HitchAngle,
    /// ψ \[rad\]
    CarYawAngle,
    /// x_H \[m\]
    HitchX,
    /// y_H \[m\]
    HitchY,
    /// θ̇ \[rad/s\]
    HitchAngleRate,
    /// ψ̇ \[rad/s\]
    CarYawRate,
    /// ψ̇ + θ̇ \[rad/s\]
    TrailerYawRate,
    /// lateral acceleration of the car's centre of gravity \[m/s²\]
    CarLateralAcceleration,
    /// δ applied \[rad\]
    SteeringAngleApplied,
    /// α_F \[rad\]
    FrontSlipAngle,
    /// α_R \[rad\]
    RearSlipAngle,
    /// α_T \[rad\]
    TrailerSlipAngle,
    /// F_F \[N\]
    FrontTyreForce,
    /// F_R \[N\]
    RearTyreForce,
    /// F_T \[N\]
    TrailerTyreForce,
    /// the validity guard tripped
    LossOfControl,
    /// which condition (0 none)
    LossOfControlReason,
}

impl Output {
    /// Every output in reference order.
    pub const ALL: [Self; 20] = [
        Self::Sigma1,
        Self::Sigma2,
        Self::Sigma3,
        Self::HitchAngle,
        Self::CarYawAngle,
        Self::HitchX,
        Self::HitchY,
        Self::HitchAngleRate,
        Self::CarYawRate,
        Self::TrailerYawRate,
        Self::CarLateralAcceleration,
        Self::SteeringAngleApplied,
        Self::FrontSlipAngle,
        Self::RearSlipAngle,
        Self::TrailerSlipAngle,
        Self::FrontTyreForce,
        Self::RearTyreForce,
        Self::TrailerTyreForce,
        Self::LossOfControl,
        Self::LossOfControlReason,
    ];

    /// The variable's name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Sigma1 => "sigma1_mps",
            Self::Sigma2 => "sigma2_rad_s",
            Self::Sigma3 => "sigma3_rad_s",
            Self::HitchAngle => "hitch_angle_rad",
            Self::CarYawAngle => "car_yaw_angle_rad",
            Self::HitchX => "hitch_x_m",
            Self::HitchY => "hitch_y_m",
            Self::HitchAngleRate => "hitch_angle_rate_rad_s",
            Self::CarYawRate => "car_yaw_rate_rad_s",
            Self::TrailerYawRate => "trailer_yaw_rate_rad_s",
            Self::CarLateralAcceleration => "car_lateral_acceleration_mps2",
            Self::SteeringAngleApplied => "steering_angle_applied_rad",
            Self::FrontSlipAngle => "front_slip_angle_rad",
            Self::RearSlipAngle => "rear_slip_angle_rad",
            Self::TrailerSlipAngle => "trailer_slip_angle_rad",
            Self::FrontTyreForce => "front_tyre_force_n",
            Self::RearTyreForce => "rear_tyre_force_n",
            Self::TrailerTyreForce => "trailer_tyre_force_n",
            Self::LossOfControl => "loss_of_control",
            Self::LossOfControlReason => "loss_of_control_reason",
        }
    }

    /// What it means, with its unit.
    pub fn description(&self) -> &'static str {
        match self {
            Self::Sigma1 => "state sigma1: lateral velocity of the hitch in the car's frame [m/s]",
            Self::Sigma2 => "state sigma2 = yaw rate + m1 d/I1 sigma1 (paper eq. 4) [rad/s]",
            Self::Sigma3 => {
                "state sigma3 = trailer yaw rate - m2 h/I2 sigma1 cos(theta) (eq. 4) [rad/s]"
            }
            Self::HitchAngle => "state theta: articulation (hitch) angle [rad]",
            Self::CarYawAngle => "state psi: the car's yaw angle [rad]",
            Self::HitchX => "state x_H: the hitch's position, x [m]",
            Self::HitchY => "state y_H: the hitch's position, y [m]",
            Self::HitchAngleRate => "articulation angle rate [rad/s]",
            Self::CarYawRate => "the car's yaw rate [rad/s]",
            Self::TrailerYawRate => "the trailer's yaw rate [rad/s]",
            Self::CarLateralAcceleration => {
                "lateral acceleration of the car's centre of gravity in its frame [m/s2]"
            }
            Self::SteeringAngleApplied => {
                "front-wheel steering angle applied: controller's command plus the input [rad]"
            }
            Self::FrontSlipAngle => "slip angle of the front axle [rad]",
            Self::RearSlipAngle => "slip angle of the car's rear axle [rad]",
            Self::TrailerSlipAngle => "slip angle of the trailer axle [rad]",
            Self::FrontTyreForce => "lateral tyre force of the front axle [N]",
            Self::RearTyreForce => "lateral tyre force of the car's rear axle [N]",
            Self::TrailerTyreForce => "lateral tyre force of the trailer axle [N]",
            Self::LossOfControl => {
                "true once the validity guard tripped: the integration stopped there (doStep returns Discard, terminated)"
            }
            Self::LossOfControlReason => {
                "0 none, 1 front axle sliding, 2 rear axle sliding, 3 front wheel stopped, 4 rear wheel stopped, 5 trailer wheel stopped (jackknife)"
            }
        }
    }

    /// Its kind.
    pub fn kind(&self) -> Kind {
        match self {
            Self::LossOfControl => Kind::Boolean,
            Self::LossOfControlReason => Kind::Integer,
            _ => Kind::Real,
        }
    }
}

/// A step of a key path into the vehicle file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PathStep {
    /// a table's key
    Key(String),
    /// an array's element
    Index(usize),
}

/// What a variable sets or reads.
#[derive(Debug, Clone, PartialEq)]
pub enum Slot {
    /// an input
    Input(Input),
    /// an output
    Output(Output),
    /// one of the 7 initial states (index in the paper's layout)
    Initial(usize),
    /// a controller setting
    Controller(ControllerKey),
    /// solver.rtol (false) or solver.atol (true)
    Tolerance {
        /// atol
        absolute: bool,
    },
    /// a leaf of the vehicle file
    Vehicle(Vec<PathStep>),
    /// time
    Time,
}

/// The controller's parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerKey {
    /// controller.structure
    Structure,
    /// controller.actuator
    Actuator,
    /// controller.gain_s
    Gain,
    /// controller.hitch_angle_gain
    HitchAngleGain,
    /// controller.hitch_rate_gain_s
    HitchRateGain,
    /// controller.delay_s
    Delay,
    /// controller.on_s
    On,
}

/// One variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// its name
    pub name: String,
    /// its type
    pub kind: Kind,
    /// its causality
    pub causality: Causality,
    /// its meaning and unit
    pub description: String,
    /// its start value (parameters and inputs)
    pub start: Option<Value>,
    /// what it sets or reads
    pub slot: Slot,
}

/// The names of the initial-state parameters, in the paper's layout.
pub const INITIAL_NAMES: [&str; 7] = [
    "initial_sigma1_mps",
    "initial_sigma2_rad_s",
    "initial_sigma3_rad_s",
    "initial_hitch_angle_rad",
    "initial_car_yaw_angle_rad",
    "initial_hitch_x_m",
    "initial_hitch_y_m",
];

/// Every variable of an FMU with these defaults; a variable's value reference is its index.
///
/// # Errors
/// [`crate::FmuError::Parameter`] if the vehicle does not serialise (it always does).
pub fn variables(defaults: &Defaults) -> Result<Vec<Variable>, crate::FmuError> {
    let mut v = Vec::new();
    let c = &defaults.config;
    for input in Input::ALL {
        let start = match input {
            Input::Speed => c.speed_mps,
            _ => 0.0,
        };
        v.push(Variable {
            name: input.name().into(),
            kind: Kind::Real,
            causality: Causality::Input,
            description: input.description().into(),
            start: Some(Value::Real(start)),
            slot: Slot::Input(input),
        });
    }
    for output in Output::ALL {
        v.push(Variable {
            name: output.name().into(),
            kind: output.kind(),
            causality: Causality::Output,
            description: output.description().into(),
            start: None,
            slot: Slot::Output(output),
        });
    }
    let i = &c.initial;
    let starts = [
        i.sigma1_mps,
        i.sigma2_rad_s,
        i.sigma3_rad_s,
        i.hitch_angle_rad,
        i.car_yaw_angle_rad,
        i.hitch_x_m,
        i.hitch_y_m,
    ];
    for (k, (name, start)) in INITIAL_NAMES.iter().zip(starts).enumerate() {
        let of = Output::ALL[k];
        v.push(Variable {
            name: (*name).into(),
            kind: Kind::Real,
            causality: Causality::Parameter,
            description: format!("initial value of {}", of.description()),
            start: Some(Value::Real(start)),
            slot: Slot::Initial(k),
        });
    }
    let ctl = &c.controller;
    let structures: Vec<&str> = ControllerStructure::ALL
        .iter()
        .map(|s| s.as_str())
        .collect();
    let controller = [
        (
            "structure",
            Value::String(ctl.structure.as_str().into()),
            format!("the feedback law: {}", structures.join(", ")),
            ControllerKey::Structure,
        ),
        (
            "actuator",
            Value::String(ctl.actuator.as_str().into()),
            "what the law moves: steering (delta [rad]) or differential_braking (M_z [N m])".into(),
            ControllerKey::Actuator,
        ),
        (
            "gain_s",
            Value::Real(ctl.gain_s),
            "gain D on the delayed yaw rate [s] (braking: N m s/rad)".into(),
            ControllerKey::Gain,
        ),
        (
            "hitch_angle_gain",
            Value::Real(ctl.hitch_angle_gain),
            "gain K_theta on the delayed hitch angle [rad/rad] (braking: N m/rad; yaw_rate_hitch)"
                .into(),
            ControllerKey::HitchAngleGain,
        ),
        (
            "hitch_rate_gain_s",
            Value::Real(ctl.hitch_rate_gain_s),
            "gain D_theta on the delayed hitch-angle rate [s] (braking: N m s/rad; yaw_rate_hitch)"
                .into(),
            ControllerKey::HitchRateGain,
        ),
        (
            "delay_s",
            Value::Real(ctl.delay_s),
            "loop delay tau [s]".into(),
            ControllerKey::Delay,
        ),
        (
            "on_s",
            Value::Real(ctl.on_s),
            "time the law is switched on [s]".into(),
            ControllerKey::On,
        ),
    ];
    for (key, start, description, slot) in controller {
        v.push(Variable {
            name: format!("controller.{key}"),
            kind: start.kind(),
            causality: Causality::Parameter,
            description,
            start: Some(start),
            slot: Slot::Controller(slot),
        });
    }
    for (absolute, key, start) in [
        (false, "rtol", c.solver.rtol),
        (true, "atol", c.solver.atol),
    ] {
        v.push(Variable {
            name: format!("solver.{key}"),
            kind: Kind::Real,
            causality: Causality::Parameter,
            description: format!("the DDE solver's {key} (error control of the internal steps)"),
            start: Some(Value::Real(start)),
            slot: Slot::Tolerance { absolute },
        });
    }
    let tree = vehicle_tree(defaults)?;
    let mut leaves = Vec::new();
    flatten(&tree, &mut Vec::new(), &mut leaves);
    for (path, value) in leaves {
        v.push(Variable {
            name: key_path(&path),
            kind: value.kind(),
            causality: Causality::Parameter,
            description: "vehicle parameter: the vehicle file's key of this name (SI units, docs/src/vehicle-files.md)".into(),
            start: Some(value),
            slot: Slot::Vehicle(path),
        });
    }
    v.push(Variable {
        name: "time".into(),
        kind: Kind::Real,
        causality: Causality::Independent,
        description: "simulation time [s]".into(),
        start: None,
        slot: Slot::Time,
    });
    Ok(v)
}

/// The vehicle file as a JSON tree.
///
/// # Errors
/// [`crate::FmuError::Parameter`] if it does not serialise.
pub fn vehicle_tree(defaults: &Defaults) -> Result<Json, crate::FmuError> {
    serde_json::to_value(&defaults.vehicle)
        .map_err(|e| crate::FmuError::parameter("<vehicle>", e.to_string()))
}

/// `tractor.axles[0].position_m` of a path.
pub fn key_path(path: &[PathStep]) -> String {
    let mut s = String::new();
    for step in path {
        match step {
            PathStep::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            PathStep::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

fn flatten(node: &Json, path: &mut Vec<PathStep>, out: &mut Vec<(Vec<PathStep>, Value)>) {
    match node {
        Json::Object(map) => {
            for (k, child) in map {
                path.push(PathStep::Key(k.clone()));
                flatten(child, path, out);
                path.pop();
            }
        }
        Json::Array(items) => {
            for (i, child) in items.iter().enumerate() {
                path.push(PathStep::Index(i));
                flatten(child, path, out);
                path.pop();
            }
        }
        Json::Number(n) => out.push((path.clone(), Value::Real(n.as_f64().unwrap_or(f64::NAN)))),
        Json::String(s) => out.push((path.clone(), Value::String(s.clone()))),
        Json::Bool(b) => out.push((path.clone(), Value::Boolean(*b))),
        Json::Null => {}
    }
}

/// Writes `value` at `path` of `tree`.
pub fn set_leaf(tree: &mut Json, path: &[PathStep], value: &Value) {
    let mut node = tree;
    for step in path {
        node = match (step, node) {
            (PathStep::Key(k), Json::Object(map)) => match map.get_mut(k) {
                Some(n) => n,
                None => return,
            },
            (PathStep::Index(i), Json::Array(items)) => match items.get_mut(*i) {
                Some(n) => n,
                None => return,
            },
            _ => return,
        };
    }
    *node = match value {
        Value::Real(x) => serde_json::Number::from_f64(*x).map_or(Json::Null, Json::Number),
        Value::Integer(x) => Json::from(*x),
        Value::Boolean(b) => Json::Bool(*b),
        Value::String(s) => Json::String(s.clone()),
    };
}
