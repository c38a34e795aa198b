//! The explicit Runge–Kutta pairs the stepping loop runs ([`crate::Method`]): the attempt of
//! one step, its error estimate and its continuous extension, and each method's constants
//! ([`Method::order`], the controller's exponents). The loop itself (step-size control,
//! breakpoints, events, observers) lives in `solver` and is shared; the step and the
//! right-hand side both of them see are in `step`.

mod dop853;
mod dopri5;

use dop853::Dop853;
use dopri5::Dopri5;

use nalgebra::SVector;

use crate::dense::Segment;
use crate::options::Method;
use crate::step::{Plan, Rhs, Tolerances};

type SV<const N: usize> = SVector<f64, N>;

/// One embedded Runge–Kutta pair: the stages of an attempted step and what is read off them.
pub(crate) trait Scheme<const N: usize>: Sized {
    /// Order of the propagated solution: the first step size is chosen for it and, by
    /// default, DDE breakpoints are tracked up to it.
    const ORDER: usize;
    /// Right-hand side evaluations of one attempt (the first stage is the previous step's
    /// last, FSAL).
    const EVALS: usize;
    /// The controller's exponent `α = EXPONENT − BETA_WEIGHT · β` of the current error
    /// (Hairer–Nørsett–Wanner, *Solving ODEs I*, §IV.2; the DOPRI5 and DOP853 codes).
    const EXPONENT: f64;
    /// See [`Scheme::EXPONENT`].
    const BETA_WEIGHT: f64;

    /// Evaluates the stages of the step `p` (all of them, `f` at the new point included).
    fn attempt<R: Rhs<N>>(rhs: &R, p: &Plan<N>) -> Self;

    /// The solution at the end of the step.
    fn x_new(&self) -> &SV<N>;

    /// `f` at the end of the step (the next step's first stage; at a breakpoint its left
    /// limit).
    fn f_new(&self) -> &SV<N>;

    /// The scaled error of the step: ≤ 1 accepts it.
    fn error(&self, p: &Plan<N>, tol: Tolerances) -> f64;

    /// The continuous extension on `[p.t, p.t_new]` and the number of extra right-hand side
    /// evaluations it took.
    fn dense<R: Rhs<N>>(&self, rhs: &R, p: &Plan<N>) -> (Segment<N>, usize);
}

/// The stages of one attempted step of the pair the options chose, as a value: the stepping
/// loop is compiled once per problem and dispatches here (one `match` per call, the
/// stage arithmetic inside each arm is the pair's own, unchanged).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Pair<const N: usize> {
    /// Dormand–Prince 5(4)
    Dopri5(Dopri5<N>),
    /// Dormand–Prince 8(5,3)
    Dop853(Dop853<N>),
}

impl<const N: usize> Pair<N> {
    /// [`Scheme::attempt`] of the pair `method`.
    #[inline]
    pub(crate) fn attempt<R: Rhs<N>>(method: Method, rhs: &R, p: &Plan<N>) -> Self {
        match method {
            Method::Dopri5 => Pair::Dopri5(Dopri5::attempt(rhs, p)),
            Method::Dop853 => Pair::Dop853(Dop853::attempt(rhs, p)),
        }
    }

    /// [`Scheme::x_new`].
    #[inline]
    pub(crate) fn x_new(&self) -> &SV<N> {
        match self {
            Pair::Dopri5(s) => s.x_new(),
            Pair::Dop853(s) => s.x_new(),
        }
    }

    /// [`Scheme::f_new`].
    #[inline]
    pub(crate) fn f_new(&self) -> &SV<N> {
        match self {
            Pair::Dopri5(s) => s.f_new(),
            Pair::Dop853(s) => s.f_new(),
        }
    }

    /// [`Scheme::error`].
    #[inline]
    pub(crate) fn error(&self, p: &Plan<N>, tol: Tolerances) -> f64 {
        match self {
            Pair::Dopri5(s) => s.error(p, tol),
            Pair::Dop853(s) => s.error(p, tol),
        }
    }

    /// [`Scheme::dense`].
    #[inline]
    pub(crate) fn dense<R: Rhs<N>>(&self, rhs: &R, p: &Plan<N>) -> (Segment<N>, usize) {
        match self {
            Pair::Dopri5(s) => s.dense(rhs, p),
            Pair::Dop853(s) => s.dense(rhs, p),
        }
    }
}

impl Method {
    /// Order of the method's propagated solution (5 or 8).
    pub fn order(self) -> usize {
        match self {
            Method::Dopri5 => <Dopri5<1> as Scheme<1>>::ORDER,
            Method::Dop853 => <Dop853<1> as Scheme<1>>::ORDER,
        }
    }
}

/// The pair's constants ([`Scheme`]'s) for the method chosen at run time (its order:
/// [`Method::order`]).
impl Method {
    /// [`Scheme::EVALS`]
    pub(crate) fn evals(self) -> usize {
        match self {
            Method::Dopri5 => <Dopri5<1> as Scheme<1>>::EVALS,
            Method::Dop853 => <Dop853<1> as Scheme<1>>::EVALS,
        }
    }

    /// [`Scheme::EXPONENT`]
    pub(crate) fn exponent(self) -> f64 {
        match self {
            Method::Dopri5 => <Dopri5<1> as Scheme<1>>::EXPONENT,
            Method::Dop853 => <Dop853<1> as Scheme<1>>::EXPONENT,
        }
    }

    /// [`Scheme::BETA_WEIGHT`]
    pub(crate) fn beta_weight(self) -> f64 {
        match self {
            Method::Dopri5 => <Dopri5<1> as Scheme<1>>::BETA_WEIGHT,
            Method::Dop853 => <Dop853<1> as Scheme<1>>::BETA_WEIGHT,
        }
    }
}

/// The first four coefficients of Hairer's nested continuous extension, shared by both
/// pairs: `r₀ = x`, `r₁ = x_new − x`, `r₂ = h f − r₁`, `r₃ = r₁ − h f_new − r₂` — the cubic
/// Hermite interpolant of the step's ends (*Solving ODEs I*, §II.6).
#[inline]
pub(crate) fn hermite_part<const N: usize>(
    x: &SV<N>,
    x_new: &SV<N>,
    f: &SV<N>,
    f_new: &SV<N>,
    h: f64,
) -> [SV<N>; 4] {
    let ydiff = x_new - x;
    let bspl = f * h - ydiff;
    [*x, ydiff, bspl, ydiff - f_new * h - bspl]
}
