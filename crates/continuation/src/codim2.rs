//! Shared pieces of the two-parameter curves ([`crate::HopfCurveSystem`],
//! [`crate::FoldCurveSystem`]): codimension-two points, the linearisation at an
//! equilibrium and the bookkeeping of test functions between accepted points.

use crate::error::{Error, Result};
use crate::problem::Problem;
use crate::stability::{SpecialKind, Stability};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// A codimension-two point located on a curve of codimension-one points.
///
/// `omegas` lists the critical angular frequencies \[rad / time unit\]: both frequencies
/// (ω1 of the continued pair first) at a double-Hopf point, the one frequency at a
/// zero-Hopf point, none at Bogdanov–Takens and cusp points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Codim2Point {
    /// what it is: [`SpecialKind::DoubleHopf`], [`SpecialKind::ZeroHopf`],
    /// [`SpecialKind::BogdanovTakens`] or [`SpecialKind::Cusp`]
    pub kind: SpecialKind,
    /// index of the point in the branch
    pub index: usize,
    /// value of the first free parameter p1
    pub p1: f64,
    /// value of the second free parameter p2
    pub p2: f64,
    /// critical angular frequencies \[rad / time unit\]
    pub omegas: Vec<f64>,
}

/// Check the indices of the two free parameters.
pub(crate) fn check_free(free: [usize; 2], n_params: usize) -> Result<()> {
    if free[0] >= n_params || free[1] >= n_params || free[0] == free[1] {
        return Err(Error::InvalidInput(format!(
            "free parameters {free:?} must be two different indices below {n_params}"
        )));
    }
    Ok(())
}

/// Evaluation buffers for the linearisation at an equilibrium x* of
/// x' = f(x, x(t−τ1), …; p): stacked arguments, Jacobian, delays and their parameter
/// derivatives. Allocated once per curve system.
#[derive(Debug, Clone)]
pub(crate) struct Linearisation {
    /// state dimension n
    pub n: usize,
    /// number of delays k
    pub k: usize,
    /// stacked arguments [x*, x*, …] (n·(k+1))
    pub args: Vec<f64>,
    /// Jacobian n × n·(k+1), row-major
    pub jac: Vec<f64>,
    /// τ_0 = 0, τ_1 … τ_k
    pub tau: Vec<f64>,
    /// scratch for directions of length n·(k+1)
    pub dir: Vec<f64>,
    /// k + 1 ones (block scales of Σ_d A_d w_d)
    pub ones: Vec<f64>,
}

impl Linearisation {
    pub fn new<P: Problem>(problem: &P) -> Self {
        let n = problem.dim();
        let k = problem.n_delays();
        Self {
            n,
            k,
            args: vec![0.0; n * (k + 1)],
            jac: vec![0.0; n * n * (k + 1)],
            tau: vec![0.0; k + 1],
            dir: vec![0.0; n * (k + 1)],
            ones: vec![1.0; k + 1],
        }
    }

    /// number of stacked columns n·(k+1)
    pub fn nc(&self) -> usize {
        self.n * (self.k + 1)
    }

    /// evaluate at the equilibrium x and parameters p: arguments, Jacobian, delays
    pub fn set<P: Problem>(&mut self, problem: &P, x: &[f64], p: &[f64]) {
        let n = self.n;
        for c in self.args.chunks_mut(n) {
            c.copy_from_slice(&x[..n]);
        }
        problem.jacobian(&self.args, p, &mut self.jac);
        self.tau[0] = 0.0;
        for j in 0..self.k {
            self.tau[j + 1] = problem.delay(j, p);
        }
    }

    /// entry (i, m) of the matrix A_d of argument block d (d = 0: undelayed)
    pub fn a(&self, d: usize, i: usize, m: usize) -> f64 {
        self.jac[i * self.nc() + d * self.n + m]
    }

    /// out_i = Σ_d scale_d (A_d w_d)_i for a stacked vector w
    pub fn apply(&self, scale: &[f64], w: &[f64], out: &mut [f64]) {
        let (n, nc) = (self.n, self.nc());
        for (i, o) in out.iter_mut().enumerate().take(n) {
            let row = &self.jac[i * nc..(i + 1) * nc];
            *o = (0..=self.k)
                .map(|d| {
                    let s: f64 = (0..n).map(|m| row[d * n + m] * w[d * n + m]).sum();
                    scale[d] * s
                })
                .sum();
        }
    }

    /// the matrices A_0, A_1, …, A_k
    pub fn matrices(&self) -> Vec<DMatrix<f64>> {
        (0..=self.k)
            .map(|d| DMatrix::from_fn(self.n, self.n, |i, m| self.a(d, i, m)))
            .collect()
    }

    /// the delays τ_1 … τ_k
    pub fn delays(&self) -> Vec<f64> {
        self.tau[1..].to_vec()
    }

    /// `dir` = the unit vector e_m in every argument block (a perturbation of x*)
    pub fn set_unit_direction(&mut self, m: usize) {
        self.dir.iter_mut().for_each(|v| *v = 0.0);
        for d in 0..=self.k {
            self.dir[d * self.n + m] = 1.0;
        }
    }
}

/// Remove from `roots` the value nearest to each target (if within `tol` of it).
pub(crate) fn remove_nearest(roots: &mut Vec<Complex64>, targets: &[Complex64], tol: f64) {
    for t in targets {
        let nearest = roots
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - t).norm().total_cmp(&(b.1 - t).norm()))
            .map(|(i, z)| (i, (z - t).norm()));
        if let Some((i, d)) = nearest
            && d <= tol
        {
            roots.remove(i);
        }
    }
}

/// number of values in the open right half plane, complex (|Im| > 1e-8) or real
pub(crate) fn unstable_counts(s: &Stability) -> (usize, usize) {
    let complex = s
        .values
        .iter()
        .filter(|z| z.re > 0.0 && z.im.abs() > 1e-8)
        .count();
    let real = s
        .values
        .iter()
        .filter(|z| z.re > 0.0 && z.im.abs() <= 1e-8)
        .count();
    (complex, real)
}

/// Re of the complex (Im > 1e-8) or real value nearest to the imaginary axis
pub(crate) fn nearest_axis(s: &Stability, complex: bool) -> Option<f64> {
    s.values
        .iter()
        .filter(|z| {
            if complex {
                z.im > 1e-8
            } else {
                z.im.abs() <= 1e-8
            }
        })
        .min_by(|a, b| a.re.abs().total_cmp(&b.re.abs()))
        .map(|z| z.re)
}

/// Values of the non-spectral test functions at the last accepted point and at the point
/// whose stability was computed last. The engine computes the stability of a new point
/// and then classifies the step between the previous (accepted) and the new point, so the
/// two slots hold exactly the pair being classified.
#[derive(Debug, Clone)]
pub(crate) struct TestPair<T> {
    /// at the last accepted point (set in `accept`)
    pub accepted: Option<T>,
    /// at the point of the last stability evaluation
    pub current: Option<T>,
}

impl<T> Default for TestPair<T> {
    fn default() -> Self {
        Self {
            accepted: None,
            current: None,
        }
    }
}

impl<T: Copy> TestPair<T> {
    /// whether the test `f` changes sign between the accepted and the current point
    pub fn sign_change(&self, f: impl Fn(&T) -> f64) -> bool {
        match (&self.accepted, &self.current) {
            (Some(a), Some(b)) => f(a) * f(b) < 0.0,
            _ => false,
        }
    }
}
