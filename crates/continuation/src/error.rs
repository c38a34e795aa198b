//! Error type of the continuation crate.

use thiserror::Error;

/// Everything that can go wrong in continuation, location of special points and Floquet
/// analysis. Variants carry the numbers needed to understand the failure and say what to try.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    /// Newton's method did not converge.
    #[error(
        "Newton corrector did not converge at parameter {parameter} after {iterations} iterations \
         (residual {residual:e}, last update {update:e}); try a smaller step, a better initial guess \
         or a looser tolerance"
    )]
    NewtonDivergence {
        /// parameter value where the corrector was running
        parameter: f64,
        /// iterations done
        iterations: usize,
        /// max-norm of the residual at the last iterate
        residual: f64,
        /// max-norm of the last Newton update
        update: f64,
    },
    /// The continuation step became smaller than the allowed minimum.
    #[error(
        "continuation step {step:e} fell below the minimum {min_step:e} at parameter {parameter}; \
         the branch may end here, or try a finer mesh / smaller min_step"
    )]
    StepSizeUnderflow {
        /// parameter value of the last accepted point
        parameter: f64,
        /// attempted step
        step: f64,
        /// smallest step allowed by the options
        min_step: f64,
    },
    /// A (sparse or dense) linear system could not be solved.
    #[error(
        "singular linear system of size {size} ({what}); the point may be a branch point or the mesh too coarse"
    )]
    SingularSystem {
        /// dimension of the system
        size: usize,
        /// which system
        what: String,
    },
    /// The eigenvalue solver failed.
    #[error("eigensolver failed on a {size}x{size} matrix: {message}")]
    Eigen {
        /// matrix dimension
        size: usize,
        /// solver message
        message: String,
    },
    /// The problem returned a non-finite value.
    #[error(
        "right-hand side or Jacobian is not finite at parameter {parameter}; the state left the model's domain, try a smaller step or amplitude"
    )]
    NonFinite {
        /// parameter value
        parameter: f64,
    },
    /// Wrong sizes or options.
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The problem does not provide a derivative a defining system needs.
    #[error(
        "the problem does not provide `{what}`, which this defining system needs; implement it \
         exactly (e.g. with nested dual numbers) or opt in to finite differences with the \
         crate's `fd_*` helpers"
    )]
    MissingDerivative {
        /// the missing `Problem` method
        what: &'static str,
    },
    /// A normal form was asked of a problem that is not smooth enough there.
    #[error(
        "{what} needs third derivatives, but the problem is only C¹ at its kinks \
         (`Problem::smoothness`); no normal-form coefficient is defined there: decide \
         criticality from the computed cycles (`continuation::criticality`)"
    )]
    NotSmooth {
        /// the quantity that was asked for
        what: &'static str,
    },
    /// A branch has no points to continue from.
    #[error("the branch is empty: start it with `Continuation::start` before extending it")]
    EmptyBranch,
    /// Location of a special point failed.
    #[error(
        "could not locate the {kind} between parameters {p0} and {p1} within {iterations} iterations; \
         try a smaller continuation step"
    )]
    LocationFailed {
        /// kind of special point
        kind: String,
        /// parameter at the bracket's start
        p0: f64,
        /// parameter at the bracket's end
        p1: f64,
        /// iterations used
        iterations: usize,
    },
}

/// Result type of this crate.
pub type Result<T> = std::result::Result<T, Error>;
