//! A user's scenario as written in TOML (`cargo xtask simulate FILE.toml`), validated
//! before any work.

use std::path::Path;

use serde::{Deserialize, Serialize};
use trailer_model::{Model, State4, State7};

use super::run::{RunSettings, SimSpec, SolverSettings, settle};
use super::{Controller, SpeedProfile};
use crate::SwayError;
use crate::config::{Positive, ensure};

/// The initial state at t = 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum InitialCondition {
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
        speed_mps: f64,
        /// settling time \[s\]
        settle_s: f64,
        /// the small initial perturbation θ(0) \[rad\]
        theta0_rad: f64,
    },
}

impl InitialCondition {
    /// The reduced state \[σ1, σ2, σ3, θ\] and ψ(0) \[rad\].
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if settling fails.
    pub fn resolve(
        &self,
        model: &Model,
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
            } => Ok((settle(model, speed_mps, theta0_rad, settle_s, solver)?, 0.0)),
        }
    }

    /// The 7-state initial vector (hitch at the origin).
    ///
    /// # Errors
    /// As [`InitialCondition::resolve`].
    pub fn state7(&self, model: &Model, solver: &SolverSettings) -> Result<State7, SwayError> {
        let (x4, psi0) = self.resolve(model, solver)?;
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
                ensure(
                    speed_mps.is_finite() && speed_mps > 0.0,
                    file,
                    &format!("{key}.speed_mps"),
                    || format!("expected a speed > 0 m/s, got {speed_mps}"),
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
/// `speed`, `controller`, `initial` and the flattened run settings.
macro_rules! with_run_fields {
    (
        $(#[$attr:meta])*
        pub struct $name:ident {
            $($(#[$field_attr:meta])* pub $field:ident: $ty:ty,)*
        }
    ) => {
        $(#[$attr])*
        pub struct $name {
            $($(#[$field_attr])* pub $field: $ty,)*
            /// when the action starts \[s\]; default: the earliest of braking start and
            /// controller switch-on, else 0
            #[serde(default)]
            pub action_s: Option<f64>,
            /// V(t)
            pub speed: SpeedProfile,
            /// δ(t)
            #[serde(default)]
            pub controller: Controller,
            /// x(0)
            pub initial: InitialCondition,
            /// validity guard (`guard = "stop"` or `"off"`), `[solver]`, `[metrics]`
            #[serde(flatten)]
            pub settings: RunSettings,
        }
    };
}
pub(crate) use with_run_fields;

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
    controller: &Controller,
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

/// The default action time: the earliest of braking start and controller switch-on, else 0.
pub fn default_action_time(speed: &SpeedProfile, controller: &Controller) -> f64 {
    match (speed.action_time(), controller.action_time()) {
        (Some(a), Some(b)) => a.min(b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => 0.0,
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
    pub fn spec(&self) -> SimSpec {
        SimSpec {
            profile: self.speed.clone(),
            controller: self.controller,
            horizon_s: self.horizon_s.get(),
            action_s: self
                .action_s
                .unwrap_or_else(|| default_action_time(&self.speed, &self.controller)),
            settings: self.settings,
        }
    }
}
