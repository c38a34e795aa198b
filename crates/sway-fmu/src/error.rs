//! The one error type of the crate.

/// What can go wrong in an FMU call or while packing one. Every C entry point turns it into
/// `fmi2Error` / `fmi3Error` with its message sent to the importer's logger.
#[derive(Debug, thiserror::Error)]
pub enum FmuError {
    /// 1: a parameter or start value was refused (the same message as the command line's for
    /// a vehicle file)
    #[error("E1 parameter `{key}`: {problem} (set a valid value before initialisation)")]
    Parameter {
        /// the variable's name (the vehicle file's key path for a vehicle parameter)
        key: String,
        /// what is wrong
        problem: String,
    },
    /// 2: no variable has this value reference, or it has another type
    #[error(
        "E2 value reference {vr}: {problem} (use the references of modelDescription.xml of the same archive)"
    )]
    ValueReference {
        /// the reference
        vr: u32,
        /// what is wrong
        problem: String,
    },
    /// 3: a call not allowed in the instance's current state
    #[error("E3 `{call}` is not allowed {phase} (see the FMI standard's state machine)")]
    Phase {
        /// the function
        call: &'static str,
        /// where the instance is
        phase: &'static str,
    },
    /// 4: an input that is not a finite number
    #[error("E4 input `{name}` = {value}: expected a finite number (the step was not taken)")]
    Input {
        /// the input's name
        name: &'static str,
        /// its value
        value: f64,
    },
    /// 5: a step the solver could not take
    #[error(
        "E5 step from t = {t} s to {t_end} s failed: {source} (reset the FMU or roll back to a saved state; tighter solver.rtol may help)"
    )]
    Step {
        /// start of the step \[s\]
        t: f64,
        /// end of the step \[s\]
        t_end: f64,
        /// the simulation's error
        source: sway::SwayError,
    },
    /// 6: a communication point that is not where the FMU stands
    #[error(
        "E6 doStep from t = {requested} s, but the FMU is at t = {at} s (steps must follow each other; roll back with a saved FMU state)"
    )]
    Time {
        /// the master's current communication point \[s\]
        requested: f64,
        /// the FMU's time \[s\]
        at: f64,
    },
    /// 7: a serialised FMU state that does not fit this instance
    #[error("E7 FMU state: {0} (serialise and restore states of the same FMU and parameters)")]
    State(String),
    /// 8: reading or writing an archive or its resources
    #[error("E8 {path}: {source}")]
    Io {
        /// the file
        path: std::path::PathBuf,
        /// the cause
        source: std::io::Error,
    },
    /// 9: a panic caught at the C boundary (a bug: please report it with the log)
    #[error("E9 internal error caught at the C boundary: {0} (please report it)")]
    Panic(String),
}

impl FmuError {
    /// A refused parameter.
    pub fn parameter(key: impl Into<String>, problem: impl Into<String>) -> Self {
        Self::Parameter {
            key: key.into(),
            problem: problem.into(),
        }
    }
}
