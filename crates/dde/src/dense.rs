//! Continuous extension of the Dormand–Prince steps and the stored solution.

use nalgebra::SVector;

use crate::Error;

/// The continuous extension of one accepted step on `[t_start, t_end]`: Hairer's order-4
/// dense output of DOPRI5 (*Solving ODEs I*, §II.6),
/// `x(t + θh) = r₀ + θ(r₁ + (1−θ)(r₂ + θ(r₃ + (1−θ) r₄)))`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment<const N: usize> {
    pub(crate) t_start: f64,
    pub(crate) t_end: f64,
    pub(crate) h: f64,
    pub(crate) r: [SVector<f64, N>; 5],
}

impl<const N: usize> Segment<N> {
    /// Start of the step.
    pub fn t_start(&self) -> f64 {
        self.t_start
    }

    /// End of the step (earlier than `t_start + h` when a terminal event cut it short).
    pub fn t_end(&self) -> f64 {
        self.t_end
    }

    /// State at the start of the step.
    pub fn x_start(&self) -> SVector<f64, N> {
        self.r[0]
    }

    /// Evaluates the interpolant at `t` (meant for `t_start ≤ t ≤ t_end`; outside it
    /// extrapolates).
    #[inline]
    pub fn eval(&self, t: f64) -> SVector<f64, N> {
        let th = (t - self.t_start) / self.h;
        let th1 = 1.0 - th;
        let [r0, r1, r2, r3, r4] = &self.r;
        r0 + (r1 + (r2 + (r3 + r4 * th1) * th) * th1) * th
    }

    /// Evaluates component `i` of the interpolant at `t` (cheaper than [`Segment::eval`]).
    #[inline]
    pub fn eval_component(&self, t: f64, i: usize) -> f64 {
        let th = (t - self.t_start) / self.h;
        let th1 = 1.0 - th;
        let r = &self.r;
        r[0][i] + th * (r[1][i] + th1 * (r[2][i] + th * (r[3][i] + th1 * r[4][i])))
    }
}

/// The solution on the integrated range, evaluable at any t in it (requires
/// [`crate::DenseOutput::Keep`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Solution<const N: usize> {
    pub(crate) segments: Vec<Segment<N>>,
}

impl<const N: usize> Solution<N> {
    /// Start of the integrated range (`None` before the first step).
    pub fn t_start(&self) -> Option<f64> {
        self.segments.first().map(|s| s.t_start)
    }

    /// End of the integrated range (`None` before the first step).
    pub fn t_end(&self) -> Option<f64> {
        self.segments.last().map(|s| s.t_end)
    }

    /// The accepted steps.
    pub fn segments(&self) -> &[Segment<N>] {
        &self.segments
    }

    /// Number of accepted steps.
    pub fn len(&self) -> usize {
        self.segments.len()
    }

    /// True before the first step.
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }

    /// Mesh points `t_0 < t_1 < …` (the start of the range and the end of every step).
    pub fn mesh(&self) -> impl Iterator<Item = f64> + '_ {
        self.segments
            .first()
            .map(|s| s.t_start)
            .into_iter()
            .chain(self.segments.iter().map(|s| s.t_end))
    }

    /// The solution at `t` from the continuous extension (order 4, exact at mesh points up to
    /// the global error of the method).
    pub fn eval(&self, t: f64) -> Result<SVector<f64, N>, Error> {
        let (Some(t_min), Some(t_max)) = (self.t_start(), self.t_end()) else {
            return Err(Error::OutOfRange {
                t,
                t_min: f64::NAN,
                t_max: f64::NAN,
            });
        };
        if !(t >= t_min && t <= t_max) {
            return Err(Error::OutOfRange { t, t_min, t_max });
        }
        let i = self.segments.partition_point(|s| s.t_end < t);
        let i = i.min(self.segments.len() - 1);
        Ok(self.segments[i].eval(t))
    }

    pub(crate) fn push(&mut self, seg: Segment<N>) {
        self.segments.push(seg);
    }

    pub(crate) fn truncate_last(&mut self, t_end: f64) {
        if let Some(s) = self.segments.last_mut() {
            s.t_end = t_end;
        }
    }
}
