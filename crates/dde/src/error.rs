//! Typed errors of the solver. Every variant carries the numbers that locate the failure and
//! its message says what to try.

use thiserror::Error;

/// Everything that can go wrong while setting up or running an integration.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Error {
    /// The step size fell below what the floating-point resolution of `t` allows.
    #[error(
        "step size underflow at t = {t}: h = {h:e} is below the resolution of t; the solution \
         may blow up or the problem may be stiff there — try a looser tolerance (rtol/atol), \
         declare a discontinuity of the right-hand side near t as a breakpoint, or check the \
         right-hand side for a singularity"
    )]
    StepSizeUnderflow {
        /// time at which the step failed
        t: f64,
        /// the rejected step size
        h: f64,
    },
    /// The right-hand side returned NaN or ±∞ and shrinking the step did not help.
    #[error(
        "non-finite state or derivative at t = {t}: the right-hand side returned NaN or infinity \
         even for tiny steps — check the right-hand side for a division by zero or a domain \
         error (e.g. sqrt/ln of a negative number) near t, or stop earlier with a terminal event"
    )]
    NonFiniteState {
        /// time of the last finite state
        t: f64,
    },
    /// The step budget `Options::max_steps` was used up before reaching the end time.
    #[error(
        "too many steps: max_steps = {max_steps} reached at t = {t} — raise Options::max_steps, \
         loosen rtol/atol, or check whether the problem is stiff (an explicit method then needs \
         tiny steps)"
    )]
    TooManySteps {
        /// time reached when the budget ran out
        t: f64,
        /// the budget
        max_steps: usize,
    },
    /// An option has a value the solver cannot work with.
    #[error("invalid option {field} = {value}: {expected}")]
    InvalidOptions {
        /// name of the offending `Options` field
        field: &'static str,
        /// its value
        value: f64,
        /// what is expected instead
        expected: &'static str,
    },
    /// The problem definition is unusable (e.g. a negative or non-finite delay).
    #[error("invalid problem: {what} = {value}: {expected}")]
    InvalidProblem {
        /// which part of the problem
        what: &'static str,
        /// the offending value
        value: f64,
        /// what is expected instead
        expected: &'static str,
    },
    /// The requested end time lies before the current time (only forward integration exists).
    #[error(
        "invalid interval: asked to integrate from t = {t} to t_end = {t_end}; only forward \
         integration is supported — pass t_end >= t"
    )]
    InvalidInterval {
        /// current solver time
        t: f64,
        /// requested end time
        t_end: f64,
    },
    /// The initial state is not finite.
    #[error("non-finite initial state at t0 = {t0}: every component of x0 must be finite")]
    NonFiniteInitialState {
        /// initial time
        t0: f64,
    },
    /// A dense-output evaluation was asked for outside the integrated range.
    #[error(
        "t = {t} lies outside the integrated range [{t_min}, {t_max}] of this solution — \
         integrate further or evaluate inside the range"
    )]
    OutOfRange {
        /// requested time
        t: f64,
        /// start of the stored range
        t_min: f64,
        /// end of the stored range
        t_max: f64,
    },
}
