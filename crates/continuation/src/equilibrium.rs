//! Equilibria x* with f(x*, x*, …, x*; p) = 0: Newton correction along a branch, stability
//! from eigenvalues (ODE) or the rightmost characteristic roots (DDE), Hopf points.

use crate::engine::ContinuationSystem;
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::problem::Problem;
use crate::roots::CharacteristicRoots;
use crate::stability::{SpecialKind, Stability};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// characteristic matrix Δ(λ) = λI − A0 − Σ A_j e^{−λτ_j} and its derivative
fn char_matrix(
    a: &[DMatrix<f64>],
    delays: &[f64],
    lambda: Complex64,
) -> (DMatrix<Complex64>, DMatrix<Complex64>) {
    let n = a[0].nrows();
    let mut d = DMatrix::<Complex64>::from_fn(n, n, |i, j| {
        let id = if i == j {
            lambda
        } else {
            Complex64::new(0.0, 0.0)
        };
        id - a[0][(i, j)]
    });
    let mut dd = DMatrix::<Complex64>::identity(n, n);
    for (aj, &tau) in a[1..].iter().zip(delays) {
        let e = (-lambda * tau).exp();
        for i in 0..n {
            for j in 0..n {
                d[(i, j)] -= e * aj[(i, j)];
                dd[(i, j)] += e * tau * aj[(i, j)];
            }
        }
    }
    (d, dd)
}

/// A Hopf point of an equilibrium branch, ready for branch switching.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HopfPoint {
    /// value of the free parameter
    pub parameter: f64,
    /// the equilibrium x*
    pub state: Vec<f64>,
    /// angular frequency ω of the critical pair ±iω [rad / time unit]
    pub omega: f64,
    /// critical eigenvector v (Δ(iω) v = 0, ‖v‖ = 1, largest component real)
    pub eigenvector: Vec<Complex64>,
    /// d Re λ / dp at the crossing (sign says on which side the equilibrium is stable)
    pub transversality: f64,
}

/// The equilibrium problem f(x, x, …, x; p) = 0 as a continuation system.
/// Unknowns u = [x (n), p_free].
///
/// The free parameter may be a delay (or enter the delays): the delays are re-evaluated
/// from u at every point, for the spectrum, the Hopf test function and [`Self::hopf_point`].
/// At an equilibrium f does not see the delays, so [`Problem::dfdp`] only needs the
/// explicit dependence of f on the parameter.
#[derive(Debug)]
pub struct EquilibriumSystem<'a, P: Problem, R: CharacteristicRoots> {
    problem: &'a P,
    params: Vec<f64>,
    ip: usize,
    roots: R,
    args: Vec<f64>,
    jac: Vec<f64>,
    fbuf: Vec<f64>,
}

impl<'a, P: Problem, R: CharacteristicRoots> EquilibriumSystem<'a, P, R> {
    /// `params`: all parameters (the free one, index `ip`, is overwritten by u's last entry);
    /// `roots`: how to compute the spectrum.
    pub fn new(problem: &'a P, params: Vec<f64>, ip: usize, roots: R) -> Result<Self> {
        if ip >= params.len() {
            return Err(Error::InvalidInput(format!(
                "free parameter index {ip} out of range ({} parameters)",
                params.len()
            )));
        }
        let n = problem.dim();
        let k = problem.n_delays();
        Ok(Self {
            problem,
            params,
            ip,
            roots,
            args: vec![0.0; n * (k + 1)],
            jac: vec![0.0; n * n * (k + 1)],
            fbuf: vec![0.0; n],
        })
    }

    /// initial unknowns from a state and a parameter value
    pub fn unknowns(&self, x: &[f64], parameter: f64) -> Vec<f64> {
        let mut u = x.to_vec();
        u.push(parameter);
        u
    }

    /// unit vector of the free parameter (start direction)
    pub fn parameter_direction(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.problem.dim() + 1];
        d[self.problem.dim()] = 1.0;
        d
    }

    fn set(&mut self, u: &[f64]) {
        let n = self.problem.dim();
        self.params[self.ip] = u[n];
        for c in self.args.chunks_mut(n) {
            c.copy_from_slice(&u[..n]);
        }
    }

    /// set u and evaluate the Jacobian there; returns (n, k)
    fn linearise(&mut self, u: &[f64]) -> (usize, usize) {
        self.set(u);
        self.problem
            .jacobian(&self.args, &self.params, &mut self.jac);
        (self.problem.dim(), self.problem.n_delays())
    }

    /// entry (i, j) of the matrix A_d of argument block d at the last `linearise`
    fn a(&self, d: usize, i: usize, j: usize) -> f64 {
        let n = self.problem.dim();
        self.jac[i * self.args.len() + d * n + j]
    }

    /// the matrices A0, A1, …, Ak of the linearisation at u
    pub fn linearisation(&mut self, u: &[f64]) -> Vec<DMatrix<f64>> {
        let (n, k) = self.linearise(u);
        (0..=k)
            .map(|d| DMatrix::from_fn(n, n, |i, j| self.a(d, i, j)))
            .collect()
    }

    /// all parameters at u (the free one taken from u), e.g. to start a two-parameter
    /// curve ([`crate::HopfCurveSystem`], [`crate::FoldCurveSystem`]) from a point of this
    /// branch
    pub fn parameters_at(&self, u: &[f64]) -> Vec<f64> {
        let mut p = self.params.clone();
        p[self.ip] = u[self.problem.dim()];
        p
    }

    /// delays at the parameters of u
    pub fn delays(&mut self, u: &[f64]) -> Vec<f64> {
        self.set(u);
        (0..self.problem.n_delays())
            .map(|j| self.problem.delay(j, &self.params))
            .collect()
    }

    /// the rightmost eigenvalues / characteristic roots at u
    pub fn spectrum(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        let a = self.linearisation(u);
        let delays = self.delays(u);
        self.roots.rightmost_roots(&a, &delays)
    }

    /// The normal form (first Lyapunov coefficient) at a Hopf point of this branch
    /// (needs [`Problem::third_derivative`]; [`crate::Error::NotSmooth`] for problems only
    /// C¹ there).
    pub fn hopf_normal_form(&self, hopf: &HopfPoint) -> Result<crate::HopfNormalForm> {
        let mut p = self.params.clone();
        p[self.ip] = hopf.parameter;
        crate::HopfNormalForm::compute(self.problem, &hopf.state, &p, hopf.omega)
    }

    /// Hopf point data at a located Hopf point `u` (critical pair from the spectrum,
    /// eigenvector as the null vector of Δ(iω))
    pub fn hopf_point(&mut self, u: &[f64], transversality: f64) -> Result<HopfPoint> {
        let n = self.problem.dim();
        let spec = self.spectrum(u)?;
        let crit = spec
            .iter()
            .filter(|z| z.im > 1e-8)
            .min_by(|a, b| a.re.abs().total_cmp(&b.re.abs()))
            .copied()
            .ok_or(Error::InvalidInput(
                "no complex pair at the Hopf point".into(),
            ))?;
        let omega = crit.im;
        let a = self.linearisation(u);
        let delays = self.delays(u);
        let (d, _) = char_matrix(&a, &delays, Complex64::new(0.0, omega));
        let svd = d.svd(false, true);
        let vt = svd.v_t.ok_or(Error::Eigen {
            size: n,
            message: "SVD of the characteristic matrix".into(),
        })?;
        let kmin = (0..n)
            .min_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]))
            .unwrap_or(0);
        let mut v: Vec<Complex64> = (0..n).map(|j| vt[(kmin, j)].conj()).collect();
        let big = (0..n)
            .max_by(|&i, &j| v[i].norm().total_cmp(&v[j].norm()))
            .unwrap_or(0);
        let phase = v[big] / v[big].norm();
        let norm = v.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt();
        v.iter_mut().for_each(|z| *z /= phase * norm);
        Ok(HopfPoint {
            parameter: u[n],
            state: u[..n].to_vec(),
            omega,
            eigenvector: v,
            transversality,
        })
    }
}

fn complex_unstable(s: &Stability) -> usize {
    s.values
        .iter()
        .filter(|z| z.re > 0.0 && z.im.abs() > 1e-8)
        .count()
}

impl<P: Problem, R: CharacteristicRoots> ContinuationSystem for EquilibriumSystem<'_, P, R> {
    fn n_unknowns(&self) -> usize {
        self.problem.dim() + 1
    }
    fn parameter_index(&self) -> usize {
        self.problem.dim()
    }
    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        self.set(u);
        self.problem.rhs(&self.args, &self.params, r);
        Ok(())
    }
    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let (n, k) = self.linearise(u);
        for i in 0..n {
            for j in 0..n {
                let v: f64 = (0..=k).map(|d| self.a(d, i, j)).sum();
                entries.push(Entry::new(i, j, v));
            }
        }
        self.problem
            .dfdp(&self.args, &self.params, self.ip, &mut self.fbuf);
        for i in 0..n {
            entries.push(Entry::new(i, n, self.fbuf[i]));
        }
        Ok(())
    }
    fn weights(&self) -> Vec<f64> {
        vec![1.0; self.problem.dim() + 1]
    }
    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        Ok(Some(Stability::from_eigenvalues(self.spectrum(u)?)))
    }
    fn classify(&self, a: &Stability, b: &Stability) -> Option<SpecialKind> {
        if a.unstable == b.unstable {
            None
        } else if complex_unstable(a) != complex_unstable(b) {
            Some(SpecialKind::Hopf)
        } else {
            Some(SpecialKind::RealCrossing)
        }
    }
    fn test_function(&mut self, kind: SpecialKind, u: &[f64]) -> Result<Option<f64>> {
        let spec = self.spectrum(u)?;
        let pick = |complex: bool| {
            spec.iter()
                .filter(|z| (z.im > 1e-8) == complex && z.im > -1e-8)
                .min_by(|a, b| a.re.abs().total_cmp(&b.re.abs()))
                .map(|z| z.re)
        };
        Ok(match kind {
            SpecialKind::Hopf => pick(true),
            SpecialKind::RealCrossing => pick(false),
            _ => None,
        })
    }
}
