//! The crate's error type.

use num_complex::Complex64;
use thiserror::Error;

/// Everything that can go wrong in this crate. Variants carry the offending numbers and say
/// what to try.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StabilityError {
    /// A matrix or vector has the wrong shape.
    #[error("{what} is {rows}x{cols}, expected {expected_rows}x{expected_cols}")]
    DimensionMismatch {
        /// which argument
        what: &'static str,
        /// actual rows
        rows: usize,
        /// actual columns
        cols: usize,
        /// expected rows
        expected_rows: usize,
        /// expected columns
        expected_cols: usize,
    },
    /// A delay is negative or not finite.
    #[error("delay τ = {tau} s is negative or not finite; delays must be finite and ≥ 0")]
    InvalidDelay {
        /// the delay \[s\]
        tau: f64,
    },
    /// A discretisation resolution is too coarse to represent the delays.
    #[error("resolution {resolution} is too small ({reason}); use at least {min}")]
    InvalidResolution {
        /// the resolution asked for
        resolution: usize,
        /// the smallest admissible one
        min: usize,
        /// why
        reason: &'static str,
    },
    /// A coefficient (matrix entry, gain, grid bound) is NaN or infinite.
    #[error("non-finite value in {what}; check the system matrices / parameters")]
    NonFinite {
        /// where it was found
        what: &'static str,
    },
    /// The dense eigensolver (faer) failed.
    #[error("eigensolver failed on a {size}x{size} matrix: {message}; try another resolution")]
    Eigensolver {
        /// matrix size
        size: usize,
        /// faer's error, formatted with `{:?}` (its `EvdError` does not implement `Error`)
        message: String,
    },
    /// Newton's method on the characteristic function did not converge.
    #[error(
        "Newton iteration on the characteristic function from λ0 = {start} did not converge in \
         {iterations} iterations (last step {last_step:e}); try a better starting point or a finer \
         discretisation for the seeds"
    )]
    NewtonDivergence {
        /// starting point
        start: Complex64,
        /// iterations done
        iterations: usize,
        /// size of the last Newton step
        last_step: f64,
    },
    /// The seeds from the discretisation could not be confirmed by Newton's method even at the
    /// finest allowed resolution.
    #[error(
        "rightmost roots not confirmed: the spectral discretisation at degree {degree} still moved \
         under Newton polishing by {mismatch:e}; ask for fewer roots, or raise `max_degree` \
         of `RootOptions` (the library's option; `RootOptions::for_count` sizes it)"
    )]
    Unconfirmed {
        /// last collocation degree tried
        degree: usize,
        /// largest seed-to-root distance (relative)
        mismatch: f64,
    },
    /// A chart grid is empty or has its bounds reversed.
    #[error(
        "invalid grid for {axis}: [{min}, {max}] with {count} points; need min < max and ≥ 2 points"
    )]
    InvalidGrid {
        /// which axis
        axis: &'static str,
        /// lower bound
        min: f64,
        /// upper bound
        max: f64,
        /// number of points
        count: usize,
    },
    /// The crossings of a rank-one loop are not bounded in frequency for gains up to the
    /// limit: the feedback's transfer function does not roll off faster than the plant's
    /// (deg q ≥ deg p, a loop of neutral type, or a gain limit above the high-frequency
    /// ratio), so crossing curves reach arbitrarily high frequencies.
    #[error(
        "no frequency bound for the crossings with |D| ≤ {d_lim} (plant degree {degree_p}, \
         feedback degree {degree_q}): the loop keeps gain at high frequency (neutral type); \
         lower the gain limit or use a feedback that rolls off"
    )]
    UnboundedCrossings {
        /// the gain limit of the search
        d_lim: f64,
        /// degree of the plant polynomial p
        degree_p: usize,
        /// degree of the feedback polynomial q
        degree_q: usize,
    },
    /// The user's system closure failed at parameter `v`.
    #[error("system at parameter V = {v}: {message}")]
    System {
        /// the parameter value
        v: f64,
        /// the error message of the closure
        message: String,
    },
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, StabilityError>;
