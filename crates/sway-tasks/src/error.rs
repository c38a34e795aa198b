//! The error type of the task layer: files, configs, figures, task names — and everything
//! the library ([`sway::SwayError`]) reports, passed through.

use std::path::PathBuf;

use sway::SwayError;

/// Errors of reading config files, writing results and drawing figures, plus the
/// library's errors.
#[derive(Debug, thiserror::Error)]
pub enum TaskError {
    /// A file could not be read.
    #[error("{}: cannot read: {source}", file.display())]
    Read {
        /// the file
        file: PathBuf,
        /// the I/O error
        #[source]
        source: std::io::Error,
    },
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
    /// A recording (`--recording`) cannot be read or analysed.
    #[error("{}: {place}: {problem}", file.display())]
    Recording {
        /// the recording
        file: PathBuf,
        /// where: `column `name``, `line N`, …
        place: String,
        /// what is wrong
        problem: String,
    },
    /// A result could not be written.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// the file or directory
        path: PathBuf,
        /// the I/O error
        #[source]
        source: std::io::Error,
    },
    /// A figure could not be drawn.
    #[error("{}: cannot draw figure: {message}", path.display())]
    Plot {
        /// the figure file
        path: PathBuf,
        /// what the plotting backend said
        message: String,
    },
    /// An unknown task name.
    #[error("unknown task `{name}`; known tasks: {known}")]
    UnknownTask {
        /// the name given
        name: String,
        /// the known names, comma separated
        known: String,
    },
    /// The task's notion does not exist for this vehicle (a trailer loading map of a chain
    /// of towed units, say). Not a failure: [`crate::tasks::TaskContext::run_staged`]
    /// turns it into a result whose `summary.json` says so (`not_applicable`: the key
    /// and the reason), and the task exits 0.
    #[error("not applicable to this vehicle: `{key}`: {reason}")]
    NotApplicable {
        /// the vehicle or config key that makes it so, e.g. `trailers`
        key: String,
        /// why, and what would apply
        reason: String,
    },
    /// The library's errors (model, numerics, config validation of library types).
    #[error(transparent)]
    Sway(#[from] SwayError),
    /// The FMU's errors (a start value it refuses, packing an archive).
    #[error(transparent)]
    Fmu(#[from] sway_fmu::FmuError),
    /// Building an artefact the task packs failed (`cargo xtask fmu`'s shared library).
    #[error("`{command}` failed: {problem}")]
    Build {
        /// the command that was run
        command: String,
        /// what went wrong
        problem: String,
    },
}

impl From<trailer_model::ModelError> for TaskError {
    fn from(e: trailer_model::ModelError) -> Self {
        Self::Sway(SwayError::Model(e))
    }
}

impl TaskError {
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
        Self::Sway(SwayError::numerical(context, source))
    }

    /// The file, key and problem of a config error, whichever layer found it.
    pub fn as_config(&self) -> Option<(&std::path::Path, &str, &str)> {
        match self {
            Self::Config { file, key, problem }
            | Self::Sway(SwayError::Config { file, key, problem }) => {
                Some((file.as_path(), key.as_str(), problem.as_str()))
            }
            _ => None,
        }
    }
}
