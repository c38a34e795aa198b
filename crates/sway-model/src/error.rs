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
