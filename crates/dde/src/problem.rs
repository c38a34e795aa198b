//! Problem definitions: what to integrate, kept apart from how ([`crate::Options`]) and from
//! the integration state ([`crate::OdeSolver`], [`crate::DdeSolver`]).

use nalgebra::SVector;

/// An ordinary differential equation `x'(t) = f(t, x(t))` with `N` states.
pub trait OdeProblem<const N: usize> {
    /// Writes `f(t, x)` into `dx`. Must not allocate if the integration is to be
    /// allocation-free.
    fn rhs(&self, t: f64, x: &SVector<f64, N>, dx: &mut SVector<f64, N>);

    /// Times at which `f` jumps (an input switched on, a ramp's start and end). The solver
    /// lands a step exactly on each one. `f` must be right-continuous there: at `t = b` it
    /// evaluates the value that holds after the jump (write `if t < b { … } else { … }`).
    fn breakpoints(&self) -> &[f64] {
        &[]
    }

    /// Number of switching functions ([`OdeProblem::switching`]); 0 by default.
    fn switching_count(&self) -> usize {
        0
    }

    /// Writes the switching functions `g₀(t, x) … g_{m−1}(t, x)` into `g` (length
    /// [`OdeProblem::switching_count`]). Declare them where `f` is continuous but not smooth:
    /// `f` may lose smoothness where a `gⱼ` changes sign (a kink such as `s·|s|` in a tyre
    /// law, a saturation, a change of formula) and must be smooth wherever none does. The
    /// solver locates each sign change on the continuous extension and lands a step on it
    /// instead of stepping across: a step across a kink loses the method's order, and the
    /// step-size controller then rejects step after step (for an 8th-order pair, many).
    /// Jumps of `f` itself at known times are [`OdeProblem::breakpoints`].
    fn switching(&self, _t: f64, _x: &SVector<f64, N>, _g: &mut [f64]) {}
}

/// A delay differential equation with constant delays τ₁ … τₘ ≥ 0:
/// `x'(t) = f(t, x(t), x(t − τ₁), …, x(t − τₘ))` for `t ≥ t0`, `x(t) = history(t)` for `t ≤ t0`.
pub trait DdeProblem<const N: usize> {
    /// The constant delays τⱼ ≥ 0. A zero delay gives the current state.
    fn delays(&self) -> &[f64];

    /// The initial function `x(t)` for `t ≤ t0`; `history(t0)` is the initial state.
    fn history(&self, t: f64) -> SVector<f64, N>;

    /// Writes `f(t, x, x_delayed)` into `dx`, with `x_delayed[j] = x(t − τⱼ)` in the order
    /// of [`DdeProblem::delays`].
    fn rhs(
        &self,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
        dx: &mut SVector<f64, N>,
    );

    /// Times at which `f` jumps (see [`OdeProblem::breakpoints`]); they are propagated along
    /// the delays like the initial discontinuity.
    fn breakpoints(&self) -> &[f64] {
        &[]
    }

    /// Number of switching functions ([`DdeProblem::switching`]); 0 by default.
    fn switching_count(&self) -> usize {
        0
    }

    /// Writes the switching functions `gⱼ(t, x, x(t − τ₁), …)` into `g`, as
    /// [`OdeProblem::switching`] (`x_delayed` as in [`DdeProblem::rhs`]). A landed switch is
    /// carried along the delays like a breakpoint (see [`crate::Options::kink_propagation`]):
    /// `f` reads the kink back through its delayed arguments.
    fn switching(
        &self,
        _t: f64,
        _x: &SVector<f64, N>,
        _x_delayed: &[SVector<f64, N>],
        _g: &mut [f64],
    ) {
    }
}
