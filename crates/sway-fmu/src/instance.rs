//! One FMU instance, the same for FMI 2.0 and 3.0: its variables' values, the state
//! machine (instantiated → initialisation → stepping → terminated), the engine, and FMU
//! states. The C entry points (`ffi`) translate their arguments and call these methods.

use sway::sim::{HeldInputs, SolverSettings};
use trailer_model::{AnyVehicleModel, ModelError, VehicleSpec};

use crate::FmuError;
use crate::config::{ControllerSettings, ControllerStructure, Defaults};
use crate::engine::{self, Engine, EngineSpec, StepEnd};
use crate::variables::{
    Causality, ControllerKey, Input, Kind, Output, Slot, Value, Variable, set_leaf, variables,
    vehicle_tree,
};

/// Where an instance is in the FMI state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// parameters may be set
    Instantiated,
    /// parameters may still be set; outputs computed from them
    Initialization,
    /// doStep
    Stepping,
    /// after terminate (or a loss of control)
    Terminated,
}

impl Phase {
    fn describe(&self) -> &'static str {
        match self {
            Phase::Instantiated => "before initialisation",
            Phase::Initialization => "in initialisation mode",
            Phase::Stepping => "while stepping",
            Phase::Terminated => "after termination",
        }
    }
}

/// A saved FMU state (fmi2GetFMUstate): the engine's state as bytes and the instance's.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Snapshot {
    engine: Vec<u8>,
    inputs: [f64; 4],
    terminated: bool,
}

/// One instance.
#[derive(Debug)]
pub struct Instance {
    defaults: Defaults,
    vars: Vec<Variable>,
    values: Vec<Value>,
    phase: Phase,
    engine: Option<Box<dyn Engine>>,
    outputs: Option<[f64; Output::ALL.len()]>,
    start_s: f64,
}

impl Instance {
    /// A new instance with the start values of `defaults`.
    ///
    /// # Errors
    /// [`FmuError::Parameter`] if the defaults are not valid.
    pub fn new(defaults: Defaults) -> Result<Self, FmuError> {
        let vars = variables(&defaults)?;
        let values = vars.iter().map(start_value).collect();
        Ok(Self {
            defaults,
            vars,
            values,
            phase: Phase::Instantiated,
            engine: None,
            outputs: None,
            start_s: 0.0,
        })
    }

    /// The variables, by value reference.
    pub fn variables(&self) -> &[Variable] {
        &self.vars
    }

    /// The phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The value reference of the variable `name`.
    pub fn reference(&self, name: &str) -> Option<u32> {
        self.vars
            .iter()
            .position(|v| v.name == name)
            .map(|i| i as u32)
    }

    fn not_now(&self, call: &'static str) -> FmuError {
        FmuError::Phase {
            call,
            phase: self.phase.describe(),
        }
    }

    /// Back to the start values (fmi2Reset).
    pub fn reset(&mut self) {
        self.values = self.vars.iter().map(start_value).collect();
        self.phase = Phase::Instantiated;
        self.engine = None;
        self.outputs = None;
        self.start_s = 0.0;
    }

    /// The start time (fmi2SetupExperiment, fmi3EnterInitializationMode).
    ///
    /// # Errors
    /// [`FmuError::Parameter`] for a non-finite time.
    pub fn set_start_time(&mut self, start_s: f64) -> Result<(), FmuError> {
        if !start_s.is_finite() {
            return Err(FmuError::parameter(
                "startTime",
                format!("{start_s} is not finite"),
            ));
        }
        self.start_s = start_s;
        Ok(())
    }

    /// fmi2EnterInitializationMode.
    ///
    /// # Errors
    /// [`FmuError::Phase`] unless just instantiated.
    pub fn enter_initialization(&mut self) -> Result<(), FmuError> {
        if self.phase != Phase::Instantiated {
            return Err(self.not_now("EnterInitializationMode"));
        }
        self.phase = Phase::Initialization;
        Ok(())
    }

    /// fmi2ExitInitializationMode: the parameters are checked and the engine built.
    ///
    /// # Errors
    /// [`FmuError::Parameter`] naming the first bad parameter, [`FmuError::Phase`].
    pub fn exit_initialization(&mut self) -> Result<(), FmuError> {
        if self.phase != Phase::Initialization {
            return Err(self.not_now("ExitInitializationMode"));
        }
        self.ensure_engine()?;
        self.phase = Phase::Stepping;
        Ok(())
    }

    /// fmi2Terminate.
    pub fn terminate(&mut self) {
        self.phase = Phase::Terminated;
    }

    fn ensure_engine(&mut self) -> Result<(), FmuError> {
        if self.engine.is_none() {
            let spec = self.engine_spec()?;
            let mut engine = engine::build(&spec)?;
            self.outputs = Some(engine.outputs(self.held()));
            self.engine = Some(engine);
        }
        Ok(())
    }

    fn real(&self, slot: &Slot) -> f64 {
        self.vars
            .iter()
            .zip(&self.values)
            .find(|(v, _)| &v.slot == slot)
            .and_then(|(_, value)| match value {
                Value::Real(x) => Some(*x),
                _ => None,
            })
            .unwrap_or(f64::NAN)
    }

    fn string(&self, slot: &Slot) -> String {
        self.vars
            .iter()
            .zip(&self.values)
            .find(|(v, _)| &v.slot == slot)
            .and_then(|(_, value)| match value {
                Value::String(s) => Some(s.clone()),
                _ => None,
            })
            .unwrap_or_default()
    }

    /// The inputs as the engine holds them.
    pub fn held(&self) -> HeldInputs {
        HeldInputs {
            speed_mps: Some(self.real(&Slot::Input(Input::Speed))),
            steering_angle_rad: self.real(&Slot::Input(Input::SteeringAngle)),
            yaw_moment_nm: self.real(&Slot::Input(Input::YawMoment)),
            trailer_lateral_force_n: self.real(&Slot::Input(Input::TrailerLateralForce)),
            ..HeldInputs::default()
        }
    }

    /// The vehicle of the current parameter values, validated as the command line
    /// validates a vehicle file.
    fn vehicle(&self) -> Result<AnyVehicleModel, FmuError> {
        let mut tree = vehicle_tree(&self.defaults)?;
        for (v, value) in self.vars.iter().zip(&self.values) {
            if let Slot::Vehicle(path) = &v.slot {
                if let Value::Real(x) = value
                    && !x.is_finite()
                {
                    return Err(FmuError::parameter(
                        &v.name,
                        format!("{x} is invalid: expected a finite number"),
                    ));
                }
                set_leaf(&mut tree, path, value);
            }
        }
        let spec: VehicleSpec = serde_path_to_error::deserialize(tree)
            .map_err(|e| FmuError::parameter(e.path().to_string(), e.inner().to_string()))?;
        let checked = || -> Result<AnyVehicleModel, ModelError> {
            spec.validate()?;
            AnyVehicleModel::new(&spec)
        };
        let invalid =
            |key: &str, value: &dyn std::fmt::Display, expected: &dyn std::fmt::Display| {
                FmuError::parameter(key, format!("{value} is invalid: expected {expected}"))
            };
        checked().map_err(|e| match e {
            ModelError::InvalidParameter {
                key,
                value,
                expected,
            } => invalid(key, &value, &expected),
            ModelError::InvalidSpec {
                key,
                value,
                expected,
            } => invalid(&key, &value, &expected),
            ModelError::TireSpec { key, source } => FmuError::parameter(key, source.to_string()),
            other => FmuError::parameter("<vehicle>", other.to_string()),
        })
    }

    fn controller(&self) -> Result<ControllerSettings, FmuError> {
        let key = |k| Slot::Controller(k);
        let structure_name = self.string(&key(ControllerKey::Structure));
        let structure = ControllerStructure::ALL
            .into_iter()
            .find(|s| s.as_str() == structure_name)
            .ok_or_else(|| {
                let names: Vec<&str> = ControllerStructure::ALL
                    .iter()
                    .map(|s| s.as_str())
                    .collect();
                FmuError::parameter(
                    "controller.structure",
                    format!(
                        "`{structure_name}` is invalid: expected one of {}",
                        names.join(", ")
                    ),
                )
            })?;
        let actuator_name = self.string(&key(ControllerKey::Actuator));
        let actuator = sway_model::law::Actuator::ALL
            .into_iter()
            .find(|a| a.as_str() == actuator_name)
            .ok_or_else(|| {
                FmuError::parameter(
                    "controller.actuator",
                    format!(
                        "`{actuator_name}` is invalid: expected steering or differential_braking"
                    ),
                )
            })?;
        Ok(ControllerSettings {
            structure,
            actuator,
            gain_s: self.real(&key(ControllerKey::Gain)),
            hitch_angle_gain: self.real(&key(ControllerKey::HitchAngleGain)),
            hitch_rate_gain_s: self.real(&key(ControllerKey::HitchRateGain)),
            delay_s: self.real(&key(ControllerKey::Delay)),
            on_s: self.real(&key(ControllerKey::On)),
        })
    }

    fn engine_spec(&self) -> Result<EngineSpec, FmuError> {
        let plant = self.vehicle()?;
        let law = self.controller()?.law()?;
        let mut initial = [0.0; 7];
        for (k, x) in initial.iter_mut().enumerate() {
            *x = self.real(&Slot::Initial(k));
            if !x.is_finite() {
                return Err(FmuError::parameter(
                    crate::variables::INITIAL_NAMES[k],
                    format!("{x} is invalid: expected a finite number"),
                ));
            }
        }
        let solver = SolverSettings {
            rtol: self.real(&Slot::Tolerance { absolute: false }),
            atol: self.real(&Slot::Tolerance { absolute: true }),
            ..Default::default()
        };
        solver
            .validate()
            .map_err(|(key, problem)| FmuError::parameter(format!("solver.{key}"), problem))?;
        let held = self.held();
        self.check_inputs(&held)?;
        Ok(EngineSpec {
            plant,
            law,
            initial,
            speed_mps: held.speed_mps.unwrap_or(f64::NAN),
            start_s: self.start_s,
            solver,
        })
    }

    fn check_inputs(&self, held: &HeldInputs) -> Result<(), FmuError> {
        for (input, value) in Input::ALL.into_iter().zip([
            held.steering_angle_rad,
            held.speed_mps.unwrap_or(f64::NAN),
            held.yaw_moment_nm,
            held.trailer_lateral_force_n,
        ]) {
            if !value.is_finite() {
                return Err(FmuError::Input {
                    name: input.name(),
                    value,
                });
            }
        }
        let v = held.speed_mps.unwrap_or(f64::NAN);
        if v <= 0.0 {
            return Err(FmuError::Input {
                name: Input::Speed.name(),
                value: v,
            });
        }
        Ok(())
    }

    fn variable(&self, vr: u32, kind: Kind) -> Result<&Variable, FmuError> {
        let v = self
            .vars
            .get(vr as usize)
            .ok_or_else(|| FmuError::ValueReference {
                vr,
                problem: format!("no such variable (the FMU has {})", self.vars.len()),
            })?;
        if v.kind != kind {
            return Err(FmuError::ValueReference {
                vr,
                problem: format!("`{}` is a {:?}, not a {kind:?}", v.name, v.kind),
            });
        }
        Ok(v)
    }

    /// The value of variable `vr` of kind `kind`.
    ///
    /// # Errors
    /// [`FmuError::ValueReference`]; [`FmuError::Parameter`] for an output asked for in
    /// initialisation mode with invalid parameters.
    pub fn get(&mut self, vr: u32, kind: Kind) -> Result<Value, FmuError> {
        let var = self.variable(vr, kind)?;
        if var.slot == Slot::Time {
            return Ok(Value::Real(self.time()));
        }
        if let Slot::Output(output) = var.slot {
            if self.phase == Phase::Instantiated {
                return Err(self.not_now("Get of an output"));
            }
            self.ensure_engine()?;
            let k = Output::ALL.iter().position(|o| *o == output).unwrap_or(0);
            let x = self.outputs.map_or(f64::NAN, |o| o[k]);
            return Ok(match kind {
                Kind::Boolean => Value::Boolean(x != 0.0),
                Kind::Integer => Value::Integer(x as i32),
                _ => Value::Real(x),
            });
        }
        Ok(self.values[vr as usize].clone())
    }

    /// Sets variable `vr` (a parameter before stepping, an input any time before
    /// termination).
    ///
    /// # Errors
    /// [`FmuError::ValueReference`], [`FmuError::Phase`] (an output, or a parameter while
    /// stepping), [`FmuError::Input`] for a non-finite input.
    pub fn set(&mut self, vr: u32, value: Value) -> Result<(), FmuError> {
        let var = self.variable(vr, value.kind())?;
        match var.causality {
            Causality::Output | Causality::Independent => {
                return Err(FmuError::ValueReference {
                    vr,
                    problem: format!("`{}` is an output: it cannot be set", var.name),
                });
            }
            Causality::Parameter
                if !matches!(self.phase, Phase::Instantiated | Phase::Initialization) =>
            {
                return Err(self.not_now("Set of a parameter"));
            }
            Causality::Input => {
                if let Value::Real(x) = value
                    && !x.is_finite()
                {
                    let name = match var.slot {
                        Slot::Input(i) => i.name(),
                        _ => "input",
                    };
                    return Err(FmuError::Input { name, value: x });
                }
            }
            Causality::Parameter => {
                // a parameter changes the engine of initialisation mode
                self.engine = None;
                self.outputs = None;
            }
        }
        self.values[vr as usize] = value;
        let held = self.held();
        if self.phase == Phase::Stepping
            && let Some(engine) = &mut self.engine
        {
            self.outputs = Some(engine.outputs(held));
        }
        Ok(())
    }

    /// The engine's time \[s\] (the start time before stepping).
    pub fn time(&self) -> f64 {
        self.engine.as_ref().map_or(self.start_s, |e| e.time())
    }

    /// One communication step from `t` over `h`: Ok(None) when it was reached, Ok(Some)
    /// with the time and reason of a loss of control (the instance is then terminated).
    ///
    /// # Errors
    /// [`FmuError::Phase`], [`FmuError::Time`], [`FmuError::Input`], [`FmuError::Step`].
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<Option<(f64, &'static str)>, FmuError> {
        if self.phase != Phase::Stepping {
            return Err(self.not_now("DoStep"));
        }
        let held = self.held();
        self.check_inputs(&held)?;
        let engine = self.engine.as_mut().ok_or_else(|| FmuError::Phase {
            call: "DoStep",
            phase: "without an engine",
        })?;
        let at = engine.time();
        if !(t.is_finite() && h.is_finite() && h >= 0.0)
            || (t - at).abs() > 1e-9 * at.abs().max(1.0)
        {
            return Err(FmuError::Time { requested: t, at });
        }
        let end = engine.step(held, t + h)?;
        self.outputs = Some(engine.outputs(held));
        match end {
            StepEnd::Reached => Ok(None),
            StepEnd::LostControl(t, why) => {
                self.phase = Phase::Terminated;
                Ok(Some((t, why.as_str())))
            }
        }
    }

    /// The current state (fmi2GetFMUstate).
    ///
    /// # Errors
    /// [`FmuError::Phase`] before initialisation, [`FmuError::State`].
    pub fn snapshot(&self) -> Result<Snapshot, FmuError> {
        let engine = self
            .engine
            .as_ref()
            .ok_or_else(|| self.not_now("GetFMUstate"))?;
        let held = self.held();
        Ok(Snapshot {
            engine: engine.save()?,
            inputs: [
                held.steering_angle_rad,
                held.speed_mps.unwrap_or(f64::NAN),
                held.yaw_moment_nm,
                held.trailer_lateral_force_n,
            ],
            terminated: self.phase == Phase::Terminated,
        })
    }

    /// Restores a state (fmi2SetFMUstate).
    ///
    /// # Errors
    /// [`FmuError::Phase`] before initialisation, [`FmuError::State`].
    pub fn restore(&mut self, snapshot: &Snapshot) -> Result<(), FmuError> {
        if self.engine.is_none() {
            self.ensure_engine()?;
        }
        let engine = self.engine.as_mut().ok_or_else(|| FmuError::Phase {
            call: "SetFMUstate",
            phase: "without an engine",
        })?;
        engine.restore(&snapshot.engine)?;
        for (input, x) in Input::ALL.into_iter().zip(snapshot.inputs) {
            if let Some(i) = self.vars.iter().position(|v| v.slot == Slot::Input(input)) {
                self.values[i] = Value::Real(x);
            }
        }
        self.phase = if snapshot.terminated {
            Phase::Terminated
        } else {
            Phase::Stepping
        };
        let held = self.held();
        if let Some(engine) = &mut self.engine {
            self.outputs = Some(engine.outputs(held));
        }
        Ok(())
    }
}

impl Snapshot {
    /// The state as bytes (fmi2SerializeFMUstate).
    ///
    /// # Errors
    /// [`FmuError::State`].
    pub fn to_bytes(&self) -> Result<Vec<u8>, FmuError> {
        let mut bytes = Vec::new();
        ciborium::into_writer(self, &mut bytes)
            .map_err(|e| FmuError::State(format!("serialising: {e}")))?;
        Ok(bytes)
    }

    /// A state from bytes of [`Snapshot::to_bytes`].
    ///
    /// # Errors
    /// [`FmuError::State`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, FmuError> {
        ciborium::from_reader(bytes).map_err(|e| FmuError::State(format!("not an FMU state ({e})")))
    }
}

fn start_value(v: &Variable) -> Value {
    v.start.clone().unwrap_or(match v.kind {
        Kind::Real => Value::Real(0.0),
        Kind::Integer => Value::Integer(0),
        Kind::Boolean => Value::Boolean(false),
        Kind::String => Value::String(String::new()),
    })
}
