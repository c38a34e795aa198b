//! Events: zero crossings of a user function `g(t, x)`, located on the continuous extension.

use std::fmt;

use nalgebra::SVector;

/// Which sign changes of `g` count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// `g` goes from negative to non-negative
    Rising,
    /// `g` goes from positive to non-positive
    Falling,
    /// either
    Either,
}

/// What happens when an event fires.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EventAction {
    /// report it to the observer and go on
    Continue,
    /// report it and stop the integration at the event time
    Stop,
}

/// The boxed event function `g(t, x, x_delayed)`.
type EventFn<'a, const N: usize> =
    Box<dyn Fn(f64, &SVector<f64, N>, &[SVector<f64, N>]) -> f64 + 'a>;

/// An event function with its direction filter and action.
pub struct Event<'a, const N: usize> {
    g: EventFn<'a, N>,
    /// which crossings count
    pub direction: Direction,
    /// what to do when it fires
    pub action: EventAction,
}

impl<const N: usize> fmt::Debug for Event<'_, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Event")
            .field("direction", &self.direction)
            .field("action", &self.action)
            .finish_non_exhaustive()
    }
}

impl<'a, const N: usize> Event<'a, N> {
    /// An event on the zeros of `g(t, x)`.
    pub fn new(
        g: impl Fn(f64, &SVector<f64, N>) -> f64 + 'a,
        direction: Direction,
        action: EventAction,
    ) -> Self {
        Event {
            g: Box::new(move |t, x, _| g(t, x)),
            direction,
            action,
        }
    }

    /// DDE: an event on the zeros of `g(t, x, x_delayed)` with `x_delayed[j] = x(t − τⱼ)`
    /// (as in [`crate::DdeProblem::rhs`]; empty for an ODE). For conditions that depend on
    /// a delayed input, e.g. a steering angle fed back with a delay.
    pub fn with_delays(
        g: impl Fn(f64, &SVector<f64, N>, &[SVector<f64, N>]) -> f64 + 'a,
        direction: Direction,
        action: EventAction,
    ) -> Self {
        Event {
            g: Box::new(g),
            direction,
            action,
        }
    }

    /// Evaluates the event function.
    #[inline]
    pub fn g(&self, t: f64, x: &SVector<f64, N>, x_delayed: &[SVector<f64, N>]) -> f64 {
        (self.g)(t, x, x_delayed)
    }

    /// Whether the sign change `g0 → g1` over a step is a crossing this event looks for.
    pub(crate) fn triggers(&self, g0: f64, g1: f64) -> Option<Direction> {
        let rising = g0 < 0.0 && g1 >= 0.0;
        let falling = g0 > 0.0 && g1 <= 0.0;
        match self.direction {
            Direction::Rising if rising => Some(Direction::Rising),
            Direction::Falling if falling => Some(Direction::Falling),
            Direction::Either if rising => Some(Direction::Rising),
            Direction::Either if falling => Some(Direction::Falling),
            _ => None,
        }
    }
}

/// A located event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventHit<const N: usize> {
    /// index of the event in the slice passed to `integrate`
    pub index: usize,
    /// time of the zero crossing
    pub t: f64,
    /// state at that time (from the continuous extension)
    pub x: SVector<f64, N>,
    /// the direction of this crossing (`Rising` or `Falling`)
    pub direction: Direction,
}

/// Locates a sign change of `phi` in `[a, b]` (`phi(a) = fa` on the old side, `phi(b) = fb`
/// on the new side or zero) with the Illinois variant of regula falsi, safeguarded by
/// bisection. Returns a time on the new side of the crossing at most `tol` after the root.
pub(crate) fn locate_root(
    mut phi: impl FnMut(f64) -> f64,
    mut a: f64,
    mut fa: f64,
    mut b: f64,
    mut fb: f64,
    tol: f64,
) -> f64 {
    // side: +1 if the last update moved b, -1 if it moved a (Illinois halves the stale end)
    let mut side = 0i8;
    for iter in 0..200 {
        let tol_eff = tol.max(4.0 * f64::EPSILON * b.abs());
        if fb == 0.0 || (b - a) <= tol_eff {
            return b;
        }
        // every 4th iteration bisect, which bounds the worst case to a geometric rate
        let mut t = if iter % 4 == 3 {
            0.5 * (a + b)
        } else {
            (a * fb - b * fa) / (fb - fa)
        };
        // keep the trial point strictly inside and not closer than tol/2 to an end
        let margin = 0.5 * tol_eff;
        if !(t > a + margin && t < b - margin) {
            t = if (t - a).abs() < (b - t).abs() {
                (a + margin).min(0.5 * (a + b))
            } else {
                (b - margin).max(0.5 * (a + b))
            };
        }
        let ft = phi(t);
        if ft == 0.0 || (ft > 0.0) == (fb > 0.0) && fb != 0.0 {
            // t is on the new side
            b = t;
            fb = ft;
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        } else {
            a = t;
            fa = ft;
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        }
    }
    b
}
