//! Dormand–Prince 5(4) (Dormand & Prince 1980; Hairer–Nørsett–Wanner, *Solving ODEs I*,
//! Table II.5.2, the DOPRI5 code): seven stages with FSAL, so six new right-hand sides per
//! step, an embedded 4th-order error estimate and Shampine's order-4 continuous extension in
//! Hairer's form (ibid. §II.6), free of extra evaluations.

use nalgebra::SVector;

use super::{Scheme, hermite_part};
use crate::dense::Segment;
use crate::step::{Plan, Rhs, Tolerances};

type SV<const N: usize> = SVector<f64, N>;

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;

const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
// 5th-order weights (= the last row of A: FSAL)
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;

// error estimate weights b - b̂
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

// dense output (Shampine's order-4 interpolant in Hairer's form)
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// The stages `k[0] = k1 … k[6] = k7` of one Dormand–Prince 5(4) step and its result.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Dopri5<const N: usize> {
    k: [SV<N>; 7],
    x_new: SV<N>,
}

impl<const N: usize> Scheme<N> for Dopri5<N> {
    const ORDER: usize = 5;
    const EVALS: usize = 6;
    const EXPONENT: f64 = 1.0 / 5.0;
    const BETA_WEIGHT: f64 = 0.75;

    fn attempt<R: Rhs<N>>(rhs: &R, p: &Plan<N>) -> Self {
        let (t, x, k1, h) = (p.t, p.x, p.k1, p.h);
        // the second stage multiplies h·a21 first, not (a21 k1)·h as `Plan::stage` does
        let mut k2 = SV::<N>::zeros();
        rhs.eval(t + C2 * h, &(x + k1 * (h * A21)), &mut k2);
        let k3 = p.stage(rhs, C3, k1 * A31 + k2 * A32);
        let k4 = p.stage(rhs, C4, k1 * A41 + k2 * A42 + k3 * A43);
        let k5 = p.stage(rhs, C5, k1 * A51 + k2 * A52 + k3 * A53 + k4 * A54);
        let k6 = p.stage_at(
            rhs,
            p.t_end_stage(),
            k1 * A61 + k2 * A62 + k3 * A63 + k4 * A64 + k5 * A65,
        );
        let x_new = x + (k1 * A71 + k3 * A73 + k4 * A74 + k5 * A75 + k6 * A76) * h;
        let mut k7 = SV::<N>::zeros();
        rhs.eval(p.t_last, &x_new, &mut k7);
        Dopri5 {
            k: [k1, k2, k3, k4, k5, k6, k7],
            x_new,
        }
    }

    fn x_new(&self) -> &SV<N> {
        &self.x_new
    }

    fn f_new(&self) -> &SV<N> {
        &self.k[6]
    }

    /// The RMS norm of the embedded estimate (5th minus 4th order solution).
    fn error(&self, p: &Plan<N>, tol: Tolerances) -> f64 {
        let [k1, _, k3, k4, k5, k6, k7] = self.k;
        let e = (k1 * E1 + k3 * E3 + k4 * E4 + k5 * E5 + k6 * E6 + k7 * E7) * p.h;
        (tol.scaled_square_sum(&e, &p.x, &self.x_new) / N as f64).sqrt()
    }

    /// The continuous extension of order 4 (no extra evaluations).
    fn dense<R: Rhs<N>>(&self, _rhs: &R, p: &Plan<N>) -> (Segment<N>, usize) {
        let [k1, _, k3, k4, k5, k6, k7] = self.k;
        let h = p.h;
        let [r0, r1, r2, r3] = hermite_part(&p.x, &self.x_new, &k1, &k7, h);
        let r4 = (k1 * D1 + k3 * D3 + k4 * D4 + k5 * D5 + k6 * D6 + k7 * D7) * h;
        let r = [r0, r1, r2, r3, r4];
        (Segment::order4(p.t, p.t_new, h, r), 0)
    }
}
