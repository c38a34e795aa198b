//! The error type of the scenario library: configs (file, key, problem), the model and
//! numerical failures with their context.

use std::path::PathBuf;

/// Errors of config validation, the model and the pipelines.
#[derive(Debug, thiserror::Error)]
pub enum SwayError {
    /// A config is not valid TOML, has an unknown key, a wrong type or a bad value.
    #[error("{}: `{key}`: {problem}", file.display())]
    Config {
        /// the config file
        file: PathBuf,
        /// key path inside the file, e.g. `tractor.rear_axle` (`<root>` for the document)
        key: String,
        /// what is wrong and what was expected
        problem: String,
    },
    /// The vehicle model rejected its parameters or failed.
    #[error(transparent)]
    Model(#[from] trailer_model::ModelError),
    /// Settling on the sway cycle lost control: from its θ(0) the vehicle's sway grows past
    /// the model's validity instead of settling (it has no stable sway cycle at that
    /// speed, or the start is outside its basin).
    #[error(
        "no sway cycle to start from at V = {speed_mps} m/s: from θ(0) = {theta0_rad} rad the motion loses control ({}) after {time_s:.2} s of settling; the vehicle has no stable sway cycle reached from there (its bifurcation diagram, `cargo xtask fig3a --vehicle FILE`, shows where stable cycles exist): start from a state or at another speed",
        .condition.as_str()
    )]
    NoSwayCycle {
        /// the speed of the settling \[m/s\]
        speed_mps: f64,
        /// the initial hitch angle \[rad\]
        theta0_rad: f64,
        /// when control was lost \[s\]
        time_s: f64,
        /// the guard's condition that tripped
        condition: crate::vehicle::LossOfControl,
    },
    /// A numerical computation failed; `context` says which one and with what inputs.
    #[error("{context}: {cause}")]
    Numerical {
        /// what was being computed, with its parameters
        context: String,
        /// the solver's error (shown in the message, so not also chained as a source)
        cause: Box<dyn std::error::Error + Send + Sync>,
    },
}

impl SwayError {
    /// A config error for `key` in `file`.
    pub fn config(
        file: impl Into<PathBuf>,
        key: impl Into<String>,
        problem: impl Into<String>,
    ) -> Self {
        Self::Config {
            file: file.into(),
            key: key.into(),
            problem: problem.into(),
        }
    }

    /// Wraps a solver error with what was being computed.
    pub fn numerical(
        context: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        Self::Numerical {
            context: context.into(),
            cause: Box::new(source),
        }
    }
}
