//! What the stepping loop (`solver`) and the Runge–Kutta pairs (`scheme`) share: the step
//! about to be attempted ([`Plan`]), the right-hand side as the loop sees it ([`Rhs`], with
//! the stored past behind it, [`PastEval`]) and the mixed error weights of the error norms
//! ([`Tolerances`]).

use nalgebra::SVector;

use crate::dense::Segment;

type SV<const N: usize> = SVector<f64, N>;

/// Evaluation of the stored past (DDE) for observers.
pub(crate) trait PastEval<const N: usize> {
    fn eval_past(&self, t: f64) -> Option<SV<N>>;
}

/// The right-hand side as the stepping loop sees it.
pub(crate) trait Rhs<const N: usize>: PastEval<N> {
    fn eval(&self, t: f64, x: &SV<N>, dx: &mut SV<N>);
    /// whether every step's continuous extension must be stored (a DDE's past)
    fn keeps_past(&self) -> bool;
    fn push(&mut self, seg: &Segment<N>);
    fn truncate(&mut self, t_end: f64);
    /// largest step that keeps every delayed argument in the computed past
    fn h_cap(&self) -> f64;
    /// number of delays
    fn n_delays(&self) -> usize;
    /// `out[j] = x(t − τⱼ)` from the stored past (the current step included)
    fn delayed_states(&self, t: f64, x: &SV<N>, out: &mut [SV<N>]);
    /// the switching functions at `(t, x)` (DDE: with the delayed states from the past)
    fn switching(&self, t: f64, x: &SV<N>, g: &mut [f64]);
}

/// The step about to be attempted from `(t, x)` with `k1 = f(t, x)`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Plan<const N: usize> {
    pub(crate) t: f64,
    pub(crate) x: SV<N>,
    pub(crate) k1: SV<N>,
    /// the step size
    pub(crate) h: f64,
    /// the size the controller proposed (before landing)
    pub(crate) h_prop: f64,
    /// whether the step lands on a breakpoint or on `t_end`
    pub(crate) land: bool,
    /// whether it lands on a breakpoint
    pub(crate) at_bp: bool,
    /// end of the step
    pub(crate) t_new: f64,
    /// where `f` at the new point is evaluated: the left limit at a breakpoint
    pub(crate) t_last: f64,
}

impl<const N: usize> Plan<N> {
    /// Where a stage with node `c = 1` is evaluated: `t + h`, or the left limit at a
    /// breakpoint.
    #[inline]
    pub(crate) fn t_end_stage(&self) -> f64 {
        if self.at_bp {
            self.t_last
        } else {
            self.t + self.h
        }
    }

    /// The stage `f(t_c, x + h·sum)` at the time `t_c` of its node, with `sum = Σⱼ aᵢⱼ kⱼ`
    /// (the row of the Runge–Kutta matrix applied to the earlier stages).
    #[inline]
    pub(crate) fn stage_at<R: Rhs<N>>(&self, rhs: &R, t_c: f64, sum: SV<N>) -> SV<N> {
        let mut k = SV::<N>::zeros();
        rhs.eval(t_c, &(self.x + sum * self.h), &mut k);
        k
    }

    /// The stage of the node `c`, at `t + c·h` (see [`Plan::stage_at`]).
    #[inline]
    pub(crate) fn stage<R: Rhs<N>>(&self, rhs: &R, c: f64, sum: SV<N>) -> SV<N> {
        self.stage_at(rhs, self.t + c * self.h, sum)
    }
}

/// The mixed error weights `atol + rtol · max(|xᵢ|, |x_newᵢ|)` of the error norms.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tolerances {
    pub rtol: f64,
    pub atol: f64,
}

impl Tolerances {
    /// `Σᵢ (eᵢ / skᵢ)²` with `skᵢ = atol + rtol · max(|xᵢ|, |x_newᵢ|)`.
    #[inline]
    pub fn scaled_square_sum<const N: usize>(self, e: &SV<N>, x: &SV<N>, x_new: &SV<N>) -> f64 {
        let mut s = 0.0;
        for i in 0..N {
            let sk = self.atol + self.rtol * x[i].abs().max(x_new[i].abs());
            let q = e[i] / sk;
            s += q * q;
        }
        s
    }
}
