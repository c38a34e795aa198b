//! Continuous extension of the Runge–Kutta steps and the stored solution.

use nalgebra::SVector;

use crate::Error;

/// The continuous extension of one accepted step on `[t_start, t_end]`, in Hairer's nested
/// form (*Solving ODEs I*, §II.6): with `θ = (t − t_start)/h`, `θ₁ = 1 − θ`,
/// `x(t) = r₀ + θ(r₁ + θ₁(r₂ + θ(r₃ + θ₁(r₄ + θ(r₅ + θ₁(r₆ + θ r₇))))))`.
/// Dormand–Prince 5(4) fills `r₀ … r₄` (order 4), DOP853 all eight (order 7).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment<const N: usize> {
    pub(crate) t_start: f64,
    pub(crate) t_end: f64,
    pub(crate) h: f64,
    degree: Degree,
    r: [SVector<f64, N>; 8],
}

/// How many coefficients of the nested form a segment uses.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Degree {
    /// `r₀ … r₄` (Dormand–Prince 5(4))
    Four,
    /// `r₀ … r₇` (DOP853)
    Seven,
}

impl<const N: usize> Segment<N> {
    /// The order-4 extension of a Dormand–Prince 5(4) step.
    pub(crate) fn order4(t_start: f64, t_end: f64, h: f64, r: [SVector<f64, N>; 5]) -> Self {
        let z = SVector::<f64, N>::zeros();
        let [r0, r1, r2, r3, r4] = r;
        Segment {
            t_start,
            t_end,
            h,
            degree: Degree::Four,
            r: [r0, r1, r2, r3, r4, z, z, z],
        }
    }

    /// The order-7 extension of a DOP853 step.
    pub(crate) fn order7(t_start: f64, t_end: f64, h: f64, r: [SVector<f64, N>; 8]) -> Self {
        Segment {
            t_start,
            t_end,
            h,
            degree: Degree::Seven,
            r,
        }
    }

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

    /// Order of the interpolant: 4 (Dormand–Prince 5(4)) or 7 (DOP853).
    pub fn order(&self) -> usize {
        match self.degree {
            Degree::Four => 4,
            Degree::Seven => 7,
        }
    }

    /// Evaluates the interpolant at `t` (meant for `t_start ≤ t ≤ t_end`; outside it
    /// extrapolates).
    #[inline]
    pub fn eval(&self, t: f64) -> SVector<f64, N> {
        let th = (t - self.t_start) / self.h;
        let th1 = 1.0 - th;
        let [r0, r1, r2, r3, r4, r5, r6, r7] = &self.r;
        let inner = match self.degree {
            Degree::Four => *r4,
            Degree::Seven => r4 + (r5 + (r6 + r7 * th) * th1) * th,
        };
        r0 + (r1 + (r2 + (r3 + inner * th1) * th) * th1) * th
    }

    /// Evaluates component `i` of the interpolant at `t` (cheaper than [`Segment::eval`]).
    #[inline]
    pub fn eval_component(&self, t: f64, i: usize) -> f64 {
        let th = (t - self.t_start) / self.h;
        let th1 = 1.0 - th;
        let r = &self.r;
        let inner = match self.degree {
            Degree::Four => r[4][i],
            Degree::Seven => r[4][i] + th * (r[5][i] + th1 * (r[6][i] + th * r[7][i])),
        };
        r[0][i] + th * (r[1][i] + th1 * (r[2][i] + th * (r[3][i] + th1 * inner)))
    }
}

/// The solution on the integrated range, evaluable at any t in it (requires
/// [`crate::DenseOutput::Keep`]).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
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

    /// The solution at `t` from the continuous extension (order 4 for Dormand–Prince 5(4),
    /// 7 for DOP853; at mesh points the step's own result).
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
