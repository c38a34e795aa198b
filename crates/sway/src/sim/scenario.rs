//! A user's scenario as written in TOML (`cargo xtask simulate FILE.toml`), validated
//! before any work.

use std::path::Path;

use serde::{Deserialize, Serialize};
use trailer_model::{State4, State7};

use super::paper_layout::{VehicleForm, settle_in_paper_layout};
use super::run::{RunSettings, SimSpec, SolverSettings};
use super::speeds::{ResolveSpeeds, Resolver, SpeedValue, UnresolvedSpeed};
use super::{ControllerTable, SpeedProfile};
use crate::SwayError;
use crate::config::{Positive, ensure, ensure_positive};

/// The initial state at t = 0 (`S`: the type of the settling speed, as in
/// [`SpeedProfile`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub enum InitialCondition<S = f64> {
    /// A given state; unspecified components are 0.
    State {
        /// σ1 \[m/s\]
        #[serde(default)]
        sigma1_mps: f64,
        /// σ2 \[1/s\]
        #[serde(default)]
        sigma2_per_s: f64,
        /// σ3 \[1/s\]
        #[serde(default)]
        sigma3_per_s: f64,
        /// hitch angle θ(0) \[deg\]
        #[serde(default)]
        theta0_deg: f64,
        /// yaw angle ψ(0) \[deg\]
        #[serde(default)]
        psi0_deg: f64,
    },
    /// "On the sway cycle": the state reached after `settle_s` seconds at constant
    /// `speed_mps` from θ(0) = `theta0_rad` (other states 0), open loop.
    SwayCycle {
        /// V0 \[m/s\] while settling
        speed_mps: S,
        /// settling time \[s\]
        settle_s: f64,
        /// the small initial perturbation θ(0) \[rad\]
        theta0_rad: f64,
    },
}

impl<S: SpeedValue> InitialCondition<S> {
    /// The initial condition with its speed a number (config keys under `key`).
    ///
    /// # Errors
    /// The speed does not resolve for this vehicle.
    pub fn resolve_speeds(
        &self,
        key: &str,
        r: &mut Resolver<'_>,
    ) -> Result<InitialCondition, UnresolvedSpeed> {
        Ok(match *self {
            InitialCondition::State {
                sigma1_mps,
                sigma2_per_s,
                sigma3_per_s,
                theta0_deg,
                psi0_deg,
            } => InitialCondition::State {
                sigma1_mps,
                sigma2_per_s,
                sigma3_per_s,
                theta0_deg,
                psi0_deg,
            },
            InitialCondition::SwayCycle {
                speed_mps,
                settle_s,
                theta0_rad,
            } => InitialCondition::SwayCycle {
                speed_mps: speed_mps.resolve_speed(&format!("{key}.speed_mps"), r)?,
                settle_s,
                theta0_rad,
            },
        })
    }

    /// The settling time \[s\] (0 for a state start).
    pub fn settle_s(&self) -> f64 {
        match self {
            InitialCondition::SwayCycle { settle_s, .. } => *settle_s,
            InitialCondition::State { .. } => 0.0,
        }
    }
}

impl InitialCondition {
    /// The reduced state \[σ1, σ2, σ3, θ\] and ψ(0) \[rad\] for `vehicle` (the sway cycle
    /// by [`settle_in_paper_layout`]).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if settling fails.
    pub fn resolve<'a>(
        &self,
        vehicle: impl Into<VehicleForm<'a>>,
        solver: &SolverSettings,
    ) -> Result<(State4, f64), SwayError> {
        match *self {
            InitialCondition::State {
                sigma1_mps,
                sigma2_per_s,
                sigma3_per_s,
                theta0_deg,
                psi0_deg,
            } => Ok((
                State4::new(
                    sigma1_mps,
                    sigma2_per_s,
                    sigma3_per_s,
                    theta0_deg.to_radians(),
                ),
                psi0_deg.to_radians(),
            )),
            InitialCondition::SwayCycle {
                speed_mps,
                settle_s,
                theta0_rad,
            } => Ok((
                settle_in_paper_layout(vehicle, speed_mps, theta0_rad, settle_s, solver)?,
                0.0,
            )),
        }
    }

    /// The 7-state initial vector (hitch at the origin) in the paper's layout.
    ///
    /// # Errors
    /// As [`InitialCondition::resolve`].
    pub fn state7<'a>(
        &self,
        vehicle: impl Into<VehicleForm<'a>>,
        solver: &SolverSettings,
    ) -> Result<State7, SwayError> {
        let (x4, psi0) = self.resolve(vehicle, solver)?;
        Ok(State7::from_column_slice(&[
            x4[0], x4[1], x4[2], x4[3], psi0, 0.0, 0.0,
        ]))
    }

    fn validate(&self, file: &Path, key: &str) -> Result<(), SwayError> {
        match *self {
            InitialCondition::State {
                sigma1_mps,
                sigma2_per_s,
                sigma3_per_s,
                theta0_deg,
                psi0_deg,
            } => {
                for (k, v) in [
                    ("sigma1_mps", sigma1_mps),
                    ("sigma2_per_s", sigma2_per_s),
                    ("sigma3_per_s", sigma3_per_s),
                    ("psi0_deg", psi0_deg),
                ] {
                    ensure(v.is_finite(), file, &format!("{key}.{k}"), || {
                        format!("expected a finite number, got {v}")
                    })?;
                }
                ensure(
                    theta0_deg.is_finite() && theta0_deg.abs() < 90.0,
                    file,
                    &format!("{key}.theta0_deg"),
                    || format!("expected |θ(0)| < 90 deg, got {theta0_deg}"),
                )
            }
            InitialCondition::SwayCycle {
                speed_mps,
                settle_s,
                theta0_rad,
            } => {
                ensure_positive(
                    speed_mps,
                    file,
                    &format!("{key}.speed_mps"),
                    "a speed > 0 m/s",
                )?;
                ensure(
                    settle_s.is_finite() && settle_s >= 0.0,
                    file,
                    &format!("{key}.settle_s"),
                    || format!("expected a time >= 0 s, got {settle_s}"),
                )?;
                ensure(
                    theta0_rad.is_finite() && theta0_rad.abs() < 1.5,
                    file,
                    &format!("{key}.theta0_rad"),
                    || format!("expected |θ(0)| < 1.5 rad, got {theta0_rad}"),
                )
            }
        }
    }
}

fn default_horizon() -> Positive {
    Positive::literal(40.0)
}
fn default_output_step() -> Positive {
    Positive::literal(0.01)
}

/// Declares a config struct with its own leading fields followed by the fields that define
/// a run, in this order (so scenario and sweep files read and echo them alike): `action_s`,
/// `speed`, `controller`, `initial` and the flattened run settings. The expansion names
/// `SpeedProfile`, `ControllerTable`, `InitialCondition`, `RunSettings`, `Serialize` and
/// `Deserialize`: the calling module imports them.
#[doc(hidden)]
#[macro_export]
macro_rules! with_run_fields {
    (
        $(#[$attr:meta])*
        pub struct $name:ident {
            $($(#[$field_attr:meta])* pub $field:ident: $ty:ty,)*
        }
    ) => {
        $(#[$attr])*
        #[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
        pub struct $name<S = f64> {
            $($(#[$field_attr])* pub $field: $ty,)*
            /// when the action starts \[s\]; default: the earliest of braking start and
            /// controller switch-on, else 0
            #[serde(default)]
            pub action_s: Option<f64>,
            /// V(t)
            pub speed: SpeedProfile<S>,
            /// δ(t)
            #[serde(default)]
            pub controller: ControllerTable,
            /// x(0)
            pub initial: InitialCondition<S>,
            /// validity guard (`guard = "stop"` or `"off"`), `[solver]`, `[metrics]`
            #[serde(flatten)]
            pub settings: RunSettings,
        }
    };
}

with_run_fields! {
    /// A scenario file (see `configs/scenario_example.toml`).
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct ScenarioConfig {
        /// results go to `results/<name>/`
        pub name: String,
        /// end time \[s\]
        #[serde(default = "default_horizon")]
        pub horizon_s: Positive,
        /// trajectory sampling interval \[s\]
        #[serde(default = "default_output_step")]
        pub output_step_s: Positive,
    }
}

/// Checks the `name` of a scenario or sweep file (it names the results directory): not
/// empty, letters, digits, '_' and '-' only; else "expected `expected`, got \"name\"".
///
/// # Errors
/// [`SwayError::Config`] under the key `name`.
pub fn ensure_name(file: &Path, name: &str, expected: &str) -> Result<(), SwayError> {
    let valid = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
    ensure(
        !name.is_empty() && name.chars().all(valid),
        file,
        "name",
        || format!("expected {expected}, got {name:?}"),
    )
}

/// Validates the parts shared by scenario and sweep files that do not validate themselves
/// on deserialisation; `prefix` is the key path of the scenario table ("" at the root).
///
/// # Errors
/// [`SwayError::Config`] naming the file and key.
pub fn validate_parts(
    file: &Path,
    prefix: &str,
    speed: &SpeedProfile,
    controller: &ControllerTable,
    initial: &InitialCondition,
    settings: &RunSettings,
) -> Result<(), SwayError> {
    let key = |k: &str| {
        if prefix.is_empty() {
            k.to_string()
        } else {
            format!("{prefix}.{k}")
        }
    };
    speed
        .validate()
        .map_err(|(k, p)| SwayError::config(file, key(&format!("speed.{k}")), p))?;
    controller
        .validate()
        .map_err(|(k, p)| SwayError::config(file, key(&format!("controller.{k}")), p))?;
    initial.validate(file, &key("initial"))?;
    settings.solver.validate_at(file, &key("solver"))
}

/// The speed-spec checks of the parts shared by scenario and sweep files (before the speeds
/// are resolved): a ramp's change is a number or `{ of_v_crit = f }`.
///
/// # Errors
/// [`SwayError::Config`] naming the file and key.
pub fn validate_spec_parts<S: SpeedValue>(
    file: &Path,
    prefix: &str,
    speed: &SpeedProfile<S>,
) -> Result<(), SwayError> {
    speed.validate_spec().map_err(|(k, p)| {
        let key = if prefix.is_empty() {
            format!("speed.{k}")
        } else {
            format!("{prefix}.speed.{k}")
        };
        SwayError::config(file, key, p)
    })
}

/// The default action time: the earliest of braking start and controller switch-on, else 0.
pub fn default_action_time<S: SpeedValue>(
    speed: &SpeedProfile<S>,
    controller: &ControllerTable,
) -> f64 {
    match (speed.action_time(), controller.action_time()) {
        (Some(a), Some(b)) => a.min(b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => 0.0,
    }
}

impl<S: SpeedValue> ResolveSpeeds for ScenarioConfig<S> {
    type Resolved = ScenarioConfig;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<ScenarioConfig, UnresolvedSpeed> {
        Ok(ScenarioConfig {
            name: self.name.clone(),
            horizon_s: self.horizon_s,
            output_step_s: self.output_step_s,
            action_s: self.action_s,
            speed: self.speed.resolve_speeds("speed", r)?,
            controller: self.controller.clone(),
            initial: self.initial.resolve_speeds("initial", r)?,
            settings: self.settings,
        })
    }
}

impl<S: SpeedValue> ScenarioConfig<S> {
    /// Checks every key that can be checked before the speeds are resolved; a scenario
    /// whose speeds are all numbers is checked completely ([`ScenarioConfig::validate`]).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate_spec(&self, file: &Path) -> Result<(), SwayError> {
        validate_spec_parts(file, "", &self.speed)?;
        match self.all_numbers() {
            Some(c) => c.validate(file),
            None => Ok(()),
        }
    }
}

impl ScenarioConfig {
    /// Checks every key.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path) -> Result<(), SwayError> {
        ensure_name(
            file,
            &self.name,
            "a non-empty name of letters, digits, '_' or '-' (it names the results directory)",
        )?;
        validate_parts(
            file,
            "",
            &self.speed,
            &self.controller,
            &self.initial,
            &self.settings,
        )?;
        let horizon = self.horizon_s.get();
        ensure(
            self.output_step_s.get() <= horizon,
            file,
            "output_step_s",
            || {
                format!(
                    "expected 0 < output_step_s <= horizon_s, got {}",
                    self.output_step_s.get()
                )
            },
        )?;
        if let Some(a) = self.action_s {
            ensure(
                a.is_finite() && a >= 0.0 && a <= horizon,
                file,
                "action_s",
                || format!("expected 0 <= action_s <= horizon_s = {}, got {a}", horizon),
            )?;
        }
        Ok(())
    }

    /// The run specification.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] for a predictor whose `prediction_vehicle` was not loaded
    /// (the caller that reads the file loads it).
    pub fn spec(&self) -> Result<SimSpec, SwayError> {
        let controller = self
            .controller
            .law()
            .map_err(|e| SwayError::numerical("the predictor's model", e))?;
        Ok(SimSpec {
            early_stop: crate::sim::EarlyStop::Never,
            steering: Default::default(),
            profile: self.speed.clone(),
            controller,
            horizon_s: self.horizon_s.get(),
            action_s: self
                .action_s
                .unwrap_or_else(|| default_action_time(&self.speed, &self.controller)),
            settings: self.settings,
        })
    }
}

/// Start on the sway cycle (fig3b, fig4c, mitigation): settle `settle_s` seconds at
/// constant V0 from θ(0) = `theta0_rad` (other states 0), open loop. `S`: the type of V0
/// (see [`crate::sim::speeds`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct SwayStart<S = f64> {
    /// V0 \[m/s\]
    pub speed_mps: S,
    /// settling time at V0 \[s\]
    pub settle_s: crate::config::NonNegative,
    /// initial perturbation of the settling run θ(0) \[rad\]
    pub theta0_rad: f64,
}

impl<S: SpeedValue> SwayStart<S> {
    /// The start with V0 a number (config keys under `key`).
    ///
    /// # Errors
    /// V0 does not resolve for this vehicle.
    pub fn resolve_speeds(
        &self,
        key: &str,
        r: &mut Resolver<'_>,
    ) -> Result<SwayStart, UnresolvedSpeed> {
        Ok(SwayStart {
            speed_mps: self
                .speed_mps
                .resolve_speed(&format!("{key}.speed_mps"), r)?,
            settle_s: self.settle_s,
            theta0_rad: self.theta0_rad,
        })
    }
}

impl SwayStart {
    /// As an initial condition.
    pub fn initial(&self) -> InitialCondition {
        InitialCondition::SwayCycle {
            speed_mps: self.speed_mps,
            settle_s: self.settle_s.get(),
            theta0_rad: self.theta0_rad,
        }
    }

    /// Checks the keys under `prefix` that do not validate themselves.
    ///
    /// # Errors
    /// [`SwayError::Config`].
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), SwayError> {
        ensure_positive(
            self.speed_mps,
            file,
            &format!("{prefix}.speed_mps"),
            "a speed > 0 m/s",
        )?;
        ensure(
            self.theta0_rad.is_finite() && self.theta0_rad.abs() < 1.5,
            file,
            &format!("{prefix}.theta0_rad"),
            || format!("expected |θ(0)| < 1.5 rad, got {}", self.theta0_rad),
        )
    }

    /// Checks a run that starts here (fig3b and fig4c): the start under `start`, an output
    /// step within the horizon, and the time `action_s` of the intervention (key
    /// `action_key`) in [0, horizon).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the key.
    pub fn validate_run(
        &self,
        file: &Path,
        horizon: f64,
        output_step: f64,
        action_key: &str,
        action_s: f64,
    ) -> Result<(), SwayError> {
        self.validate(file, "start")?;
        ensure(output_step <= horizon, file, "output_step_s", || {
            format!("expected 0 < output_step_s <= horizon_s, got {output_step}")
        })?;
        ensure(
            action_s.is_finite() && (0.0..horizon).contains(&action_s),
            file,
            action_key,
            || format!("expected 0 <= {action_key} < horizon_s, got {action_s}"),
        )
    }
}
