//! Problems and helpers shared by the integration tests and the benchmarks
//! (`#[path]`-included by `benches/integrators.rs`).
#![allow(dead_code)]

use dde::{DdeProblem, OdeProblem};
use nalgebra::SVector;

/// Van der Pol oscillator x'' − μ(1 − x²)x' + x = 0 as a first-order system.
pub struct VanDerPol {
    pub mu: f64,
}

impl OdeProblem<2> for VanDerPol {
    fn rhs(&self, _t: f64, x: &SVector<f64, 2>, dx: &mut SVector<f64, 2>) {
        dx[0] = x[1];
        dx[1] = self.mu * (1.0 - x[0] * x[0]) * x[1] - x[0];
    }
}

/// x'(t) = r x(t) (1 − x(t − 1)), x ≡ 0.5 on [−1, 0]; r = 1.4 gives a stable limit cycle.
pub struct DelayedLogistic {
    pub r: f64,
}

impl DdeProblem<1> for DelayedLogistic {
    fn delays(&self) -> &[f64] {
        &[1.0]
    }
    fn history(&self, _t: f64) -> SVector<f64, 1> {
        SVector::from([0.5])
    }
    fn rhs(&self, _t: f64, x: &SVector<f64, 1>, xd: &[SVector<f64, 1>], dx: &mut SVector<f64, 1>) {
        dx[0] = self.r * x[0] * (1.0 - xd[0][0]);
    }
}

/// Least-squares slope of log(err) against log(h): the observed order of convergence.
pub fn slope(hs: &[f64], errs: &[f64]) -> f64 {
    let n = hs.len() as f64;
    let xs: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let ys: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}
