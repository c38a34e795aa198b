//! Adaptive explicit Runge–Kutta integration of ODEs and of delay differential equations
//! with constant delays — general purpose, it knows nothing about any application.
//!
//! * Methods ([`Method`]): Dormand–Prince 5(4) with FSAL, embedded error estimate and a
//!   free continuous extension of order 4 (Hairer–Nørsett–Wanner, *Solving ODEs I*,
//!   §II.4–II.6, the DOPRI5 code), the default; and Dormand–Prince 8(5,3) (the DOP853 code,
//!   ibid. §II.10): twelve stages, far fewer steps at tight tolerances, an extension of
//!   order 7 that costs three more stages and is built only for the steps that need it.
//!   Mixed `rtol`/`atol` error norm, PI step-size control.
//! * DDEs: several constant delays, a history function for `t ≤ t0`, the method of steps
//!   reading the past off the continuous extension (steps are capped at the smallest
//!   positive delay, so no delayed argument is ever extrapolated), breakpoint tracking
//!   (`t0 + Σkⱼτⱼ` up to the method's order, user breakpoints where an input jumps and their
//!   propagation); steps land on breakpoints exactly.
//! * Events: zero crossings of `g(t, x)` — or `g(t, x, x(t − τ₁), …)` for DDEs
//!   ([`Event::with_delays`]) — located on the continuous extension (Illinois regula falsi
//!   with bisection safeguard, to [`Options::event_tol`] = 1e-12 in t) with a direction
//!   filter and a continue/stop action. Only sign changes between step ends are seen: two
//!   crossings inside one step cancel.
//! * Kinks: a problem may declare switching functions ([`OdeProblem::switching`]) whose sign
//!   changes mark where `f` loses smoothness (`|s|`, saturations); steps land on their roots
//!   instead of stepping across ([`KinkLanding`]), and DDEs carry a landed kink along the
//!   delays ([`Options::kink_propagation`]). A high-order pair stepping across a kink loses
//!   its order there and its controller rejects step after step.
//! * Fixed-size states (`nalgebra::SVector<f64, N>`), no heap allocation per step: the ODE
//!   path stores nothing unless asked ([`DenseOutput::Keep`]); the DDE path keeps only the
//!   steps the longest delay reaches back to.
//! * Problem ([`OdeProblem`], [`DdeProblem`]), method options ([`Options`]) and integration
//!   state ([`OdeSolver`], [`DdeSolver`], cloneable) are apart; an [`Observer`] sees every
//!   accepted step, for quantities computed on the fly.
//!
//! # Example
//!
//! The delayed negative feedback `x'(t) = −x(t − 1)` with `x ≡ 1` for `t ≤ 0` has the exact
//! solution `x(t) = 1 − t` on `[0, 1]` and `1 − t + (t − 1)²/2` on `[1, 2]`:
//!
//! ```
//! use dde::{DdeProblem, Options, solve_dde};
//! use nalgebra::SVector;
//!
//! struct Feedback;
//! impl DdeProblem<1> for Feedback {
//!     fn delays(&self) -> &[f64] { &[1.0] }
//!     fn history(&self, _t: f64) -> SVector<f64, 1> { SVector::from([1.0]) }
//!     fn rhs(&self, _t: f64, _x: &SVector<f64, 1>, xd: &[SVector<f64, 1>], dx: &mut SVector<f64, 1>) {
//!         dx[0] = -xd[0][0];
//!     }
//! }
//!
//! let sol = solve_dde(&Feedback, 0.0, 2.0, Options::with_tolerances(1e-10, 1e-12))?;
//! let t = 1.5;
//! let exact = 1.0 - t + (t - 1.0f64).powi(2) / 2.0;
//! assert!((sol.eval(t)?[0] - exact).abs() < 1e-9);
//!
//! // events: the first time x falls through 0.2, located on the continuous extension
//! use dde::{DdeSolver, Direction, Event, EventAction, NoObserver, Status};
//! let mut solver = DdeSolver::new(&Feedback, 0.0, Options::with_tolerances(1e-10, 1e-12))?;
//! let ev = [Event::new(|_t, x: &SVector<f64, 1>| x[0] - 0.2, Direction::Falling, EventAction::Stop)];
//! let status = solver.integrate(&Feedback, 2.0, &ev, &mut NoObserver)?;
//! let Status::Event(hit) = status else { panic!("expected the event") };
//! assert!((hit.t - 0.8).abs() < 1e-10); // x = 1 − t on [0, 1]
//! # Ok::<(), dde::Error>(())
//! ```

mod dense;
mod error;
mod events;
mod options;
mod problem;
mod scheme;
mod solver;
mod step;

pub use dense::{Segment, Solution};
pub use error::Error;
pub use events::{Direction, Event, EventAction, EventHit};
pub use options::{DenseOutput, KinkLanding, Method, Options, StepController};
pub use problem::{DdeProblem, OdeProblem};
pub use solver::{
    DdeSolver, Flow, NoObserver, Observer, OdeSolver, Stats, Status, StepView, solve_dde, solve_ode,
};
