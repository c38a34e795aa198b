//! Curves of folds (saddle-nodes) of equilibria in two free parameters (p1, p2), for ODEs
//! and constant-delay DDEs x' = f(x, x(t−τ1), …; p).
//!
//! Defining system, unknowns u = [x (n), v (n), p1, p2]:
//!
//! - f(x, x, …, x; p) = 0 (the equilibrium),
//! - J v = 0 with J = A0 + Σ_j A_j = −Δ(0) (a zero root, null vector v),
//! - c·v = 1 (c = the previous point's v / ‖v‖², updated in `accept`).
//!
//! Exact Jacobian from [`Problem::second_derivative`] (∂(J v)/∂x),
//! [`Problem::jacobian_dp`] (∂(J v)/∂p) and [`Problem::dfdp`]. The delays do not enter:
//! a zero root does not see them.
//!
//! Stability along the curve is the remaining spectrum (all rightmost roots but the zero
//! root). Codimension-two points, with w the left null vector of J (unit length, oriented
//! continuously along the curve):
//! - [`SpecialKind::Cusp`]: the quadratic coefficient w·f_xx(v, v) changes sign;
//! - [`SpecialKind::BogdanovTakens`]: a second zero root, test function w·Δ'(0) v with
//!   Δ'(0) = I + Σ_j τ_j A_j (w ⟂ Δ'(0) v when the zero root is double);
//! - [`SpecialKind::ZeroHopf`]: a complex pair of the remaining spectrum crosses the
//!   imaginary axis (test: its real part).
//!
//! A cusp is also a turning point of the curve in the parameter plane. When p1 turns there
//! the engine records a [`SpecialKind::Fold`]; [`FoldCurveSystem::codim2_points`] reports
//! such a turning point as a cusp when the quadratic coefficient changes sign across it.
//!
//! # Example: x' = p1 + p2 x − x³, fold curve 27 p1² = 4 p2³ and its cusp at (0, 0)
//!
//! ```
//! use continuation::*;
//!
//! struct Cubic;
//! impl Problem for Cubic {
//!     fn dim(&self) -> usize { 1 }
//!     fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) { f[0] = p[0] + p[1] * x[0] - x[0].powi(3); }
//!     fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) { j[0] = p[1] - 3.0 * x[0] * x[0]; }
//!     fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
//!         out[0] = if ip == 0 { 1.0 } else { x[0] };
//!     }
//!     fn second_derivative(&self, x: &[f64], _p: &[f64], a: &[f64], b: &[f64], out: &mut [f64]) -> Result<()> {
//!         out[0] = -6.0 * x[0] * a[0] * b[0];
//!         Ok(())
//!     }
//!     fn jacobian_dp(&self, _x: &[f64], _p: &[f64], ip: usize, a: &[f64], out: &mut [f64]) -> Result<()> {
//!         out[0] = if ip == 1 { a[0] } else { 0.0 };
//!         Ok(())
//!     }
//! }
//!
//! # fn main() -> Result<()> {
//! let cont = Continuation::new(ContinuationOptions { initial_step: 0.05, max_step: 0.1, ..Default::default() });
//! // fold at x = −1, p2 = 3, p1 = 2: start the curve there, towards smaller p1
//! let mut fc = FoldCurveSystem::new(&Cubic, vec![2.0, 3.0], [0, 1], ChebyshevRoots::default())?;
//! let (guess, dir) = fc.start_at_fold(&[-1.0], 0, 2.0)?;
//! let dir: Vec<f64> = dir.iter().map(|d| -d).collect(); // p2 decreasing
//! let mut curve = cont.start(&mut fc, &guess, &dir)?;
//! cont.extend(&mut fc, &mut curve, 80)?;
//! let cusp = fc.codim2_points(&curve)?.into_iter().find(|c| c.kind == SpecialKind::Cusp).unwrap();
//! assert!(cusp.p1.abs() < 1e-8 && cusp.p2.abs() < 1e-8);
//! # Ok(())
//! # }
//! ```

use crate::codim2::{
    Codim2Point, Linearisation, TestPair, check_free, nearest_axis, remove_nearest, unstable_counts,
};
use crate::engine::{Branch, ContinuationSystem};
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::problem::Problem;
use crate::roots::CharacteristicRoots;
use crate::stability::{Location, SpecialKind, Stability};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// test functions of a fold point
#[derive(Debug, Clone, Copy)]
struct FoldTests {
    /// w·f_xx(v, v)
    cusp: f64,
    /// w·Δ'(0) v
    bt: f64,
}

/// Continuation system of folds of equilibria in two free parameters (see the module docs).
///
/// Unknowns u = [x (n), v (n), p1, p2]; the curve's `parameter` is p1, its
/// `secondary_parameter` p2.
#[derive(Debug)]
pub struct FoldCurveSystem<'a, P: Problem, R: CharacteristicRoots> {
    problem: &'a P,
    params: Vec<f64>,
    free: [usize; 2],
    roots: R,
    lin: Linearisation,
    /// normalisation vector (c·v = 1)
    c: Vec<f64>,
    /// orientation of the left null vector w (w·r > 0); None before the first point
    reference: Option<Vec<f64>>,
    /// stacked [v, v, …]
    vs: Vec<f64>,
    buf: Vec<f64>,
    tests: TestPair<FoldTests>,
}

impl<'a, P: Problem, R: CharacteristicRoots> FoldCurveSystem<'a, P, R> {
    /// `params`: all parameters (the free ones, indices `free = [p1, p2]`, are overwritten
    /// from the unknowns); `roots`: how to compute the remaining spectrum.
    pub fn new(problem: &'a P, params: Vec<f64>, free: [usize; 2], roots: R) -> Result<Self> {
        check_free(free, params.len())?;
        let lin = Linearisation::new(problem);
        let n = lin.n;
        Ok(Self {
            problem,
            params,
            free,
            roots,
            c: vec![0.0; n],
            reference: None,
            vs: vec![0.0; lin.nc()],
            buf: vec![0.0; n],
            lin,
            tests: TestPair::default(),
        })
    }

    fn n(&self) -> usize {
        self.lin.n
    }

    /// Start data from a fold located on an equilibrium branch: the equilibrium `x` at the
    /// value `value` of its free parameter `fold_parameter` (one of the two free
    /// parameters; the other keeps its value from `params`). The null vector v comes from
    /// an SVD of J. Returns the initial unknowns and the start direction (the unit vector
    /// of the other parameter; negate it to go the other way).
    pub fn start_at_fold(
        &mut self,
        x: &[f64],
        fold_parameter: usize,
        value: f64,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.n();
        if !self.free.contains(&fold_parameter) || x.len() != n {
            return Err(Error::InvalidInput(format!(
                "start_at_fold: parameter {fold_parameter} must be one of {:?} and x of length {n}",
                self.free
            )));
        }
        self.params[fold_parameter] = value;
        self.lin.set(self.problem, x, &self.params);
        let (_, v) = null_vectors(&self.matrix_j())?;
        let mut u = x.to_vec();
        u.extend(v.iter());
        u.extend([self.params[self.free[0]], self.params[self.free[1]]]);
        self.set_reference(&u);
        let mut dir = vec![0.0; u.len()];
        let other = if fold_parameter == self.free[0] { 1 } else { 0 };
        dir[2 * n + other] = 1.0;
        Ok((u, dir))
    }

    /// the equilibrium x of a point
    pub fn state<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[..self.n()]
    }

    /// the null vector v of J at a point (c·v = 1)
    pub fn null_vector<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[self.n()..2 * self.n()]
    }

    /// the two free parameters (p1, p2) of a point
    pub fn parameters(&self, u: &[f64]) -> (f64, f64) {
        let n = self.n();
        (u[2 * n], u[2 * n + 1])
    }

    /// set the normalisation vector from the v of `u`: c = v / ‖v‖²
    pub fn set_reference(&mut self, u: &[f64]) {
        let v = self.null_vector(u);
        let norm2: f64 = v.iter().map(|z| z * z).sum();
        if norm2 > 0.0 {
            self.c = v.iter().map(|z| z / norm2).collect();
        }
    }

    /// the remaining spectrum at u: the rightmost roots without the zero root
    pub fn remaining_spectrum(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        self.set(u);
        let a = self.lin.matrices();
        let mut roots = self.roots.rightmost_roots(&a, &self.lin.delays())?;
        remove_nearest(&mut roots, &[Complex64::new(0.0, 0.0)], 1e-6);
        Ok(roots)
    }

    /// The quadratic (cusp) coefficient w·f_xx(v, v) at u, with w the unit left null
    /// vector of J oriented along the curve (zero at a cusp).
    pub fn cusp_coefficient(&mut self, u: &[f64]) -> Result<f64> {
        let reference = self.reference.clone();
        Ok(self.tests_at(u, reference.as_deref())?.0.cusp)
    }

    /// The codimension-two points located on `curve`. A turning point of p1 (recorded by
    /// the engine as a fold) across which the cusp coefficient changes sign is reported
    /// as a cusp; for zero-Hopf points the frequency is read off the remaining spectrum.
    pub fn codim2_points(&mut self, curve: &Branch) -> Result<Vec<Codim2Point>> {
        let mut out = Vec::new();
        let located: Vec<(usize, SpecialKind)> = curve
            .special_points()
            .filter(|(_, sp)| sp.location == Location::Located)
            .map(|(i, sp)| (i, sp.kind))
            .collect();
        for (i, kind) in located {
            let u = &curve.points[i].u;
            let kind = match kind {
                SpecialKind::Fold if self.cusp_changes_sign(curve, i)? => SpecialKind::Cusp,
                k @ (SpecialKind::Cusp | SpecialKind::ZeroHopf | SpecialKind::BogdanovTakens) => k,
                _ => continue,
            };
            let omegas = if kind == SpecialKind::ZeroHopf {
                let s = Stability::from_eigenvalues(self.remaining_spectrum(u)?);
                s.values
                    .iter()
                    .filter(|z| z.im > 1e-8)
                    .min_by(|a, b| a.re.abs().total_cmp(&b.re.abs()))
                    .map(|z| vec![z.im])
                    .unwrap_or_default()
            } else {
                vec![]
            };
            let (p1, p2) = self.parameters(u);
            out.push(Codim2Point {
                kind,
                index: i,
                p1,
                p2,
                omegas,
            });
        }
        Ok(out)
    }

    fn cusp_changes_sign(&mut self, curve: &Branch, i: usize) -> Result<bool> {
        let (Some(before), Some(after)) = (
            i.checked_sub(1).map(|j| &curve.points[j]),
            curve.points.get(i + 1),
        ) else {
            return Ok(false);
        };
        let (_, w) = self.tests_at(&curve.points[i].u, None)?;
        let a = self.tests_at(&before.u, Some(&w))?.0.cusp;
        let b = self.tests_at(&after.u, Some(&w))?.0.cusp;
        Ok(a * b <= 0.0)
    }

    fn set(&mut self, u: &[f64]) {
        let n = self.n();
        self.params[self.free[0]] = u[2 * n];
        self.params[self.free[1]] = u[2 * n + 1];
        self.lin.set(self.problem, &u[..n], &self.params);
        for c in self.vs.chunks_mut(n) {
            c.copy_from_slice(&u[n..2 * n]);
        }
    }

    /// J = Σ_d A_d at the current linearisation
    fn matrix_j(&self) -> DMatrix<f64> {
        DMatrix::from_fn(self.n(), self.n(), |i, m| {
            (0..=self.lin.k).map(|d| self.lin.a(d, i, m)).sum()
        })
    }

    /// test functions at u and the unit left null vector w (oriented along `reference`,
    /// or by its largest component without one)
    fn tests_at(&mut self, u: &[f64], reference: Option<&[f64]>) -> Result<(FoldTests, Vec<f64>)> {
        let n = self.n();
        self.set(u);
        let j = self.matrix_j();
        let v = DVector::from_column_slice(&u[n..2 * n]);
        let w = match reference {
            Some(r) => bordered_left_null(&j, &v, r)?,
            None => null_vectors(&j)?.0,
        };
        let lin = &self.lin;
        self.problem.second_derivative(
            &lin.args,
            &self.params,
            &self.vs,
            &self.vs,
            &mut self.buf,
        )?;
        let cusp = w.iter().zip(&self.buf).map(|(a, b)| a * b).sum();
        // Δ'(0) v = v + Σ τ_d A_d v
        lin.apply(&lin.tau, &self.vs, &mut self.buf);
        let bt = (0..n).map(|i| w[i] * (v[i] + self.buf[i])).sum();
        Ok((FoldTests { cusp, bt }, w))
    }
}

/// unit left and right null vectors of a square matrix from its SVD, each with its
/// largest component positive
fn null_vectors(j: &DMatrix<f64>) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = j.nrows();
    let svd = j.clone().svd(true, true);
    let (Some(uu), Some(vt)) = (svd.u, svd.v_t) else {
        return Err(Error::Eigen {
            size: n,
            message: "SVD of the equilibrium Jacobian".into(),
        });
    };
    let kmin = (0..n)
        .min_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]))
        .unwrap_or(0);
    let orient = |mut x: Vec<f64>| {
        let big = x
            .iter()
            .fold(0.0f64, |m, &v| if v.abs() > m.abs() { v } else { m });
        if big < 0.0 {
            x.iter_mut().for_each(|v| *v = -*v);
        }
        x
    };
    let w = orient((0..n).map(|i| uu[(i, kmin)]).collect());
    let v = orient((0..n).map(|i| vt[(kmin, i)]).collect());
    Ok((w, v))
}

/// unit left null vector w of J from the bordered system [Jᵀ v; rᵀ 0] (w, s) = (0, 1)
/// (nonsingular at a simple fold: v ∉ range Jᵀ = v^⟂, and r·w ≠ 0)
fn bordered_left_null(j: &DMatrix<f64>, v: &DVector<f64>, r: &[f64]) -> Result<Vec<f64>> {
    let n = j.nrows();
    let m = DMatrix::from_fn(n + 1, n + 1, |row, col| match (row < n, col < n) {
        (true, true) => j[(col, row)],
        (true, false) => v[row],
        (false, true) => r[col],
        (false, false) => 0.0,
    });
    let mut rhs = DVector::zeros(n + 1);
    rhs[n] = 1.0;
    let sol = m.lu().solve(&rhs).ok_or(Error::SingularSystem {
        size: n + 1,
        what: "bordered system of the left null vector at a fold".into(),
    })?;
    let norm = sol.rows(0, n).norm();
    Ok((0..n).map(|i| sol[i] / norm).collect())
}

impl<P: Problem, R: CharacteristicRoots> ContinuationSystem for FoldCurveSystem<'_, P, R> {
    fn n_unknowns(&self) -> usize {
        2 * self.n() + 2
    }
    fn parameter_index(&self) -> usize {
        2 * self.n()
    }
    fn secondary_parameter_index(&self) -> Option<usize> {
        Some(2 * self.n() + 1)
    }
    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        let n = self.n();
        self.set(u);
        self.problem.rhs(&self.lin.args, &self.params, &mut r[..n]);
        let lin = &self.lin;
        lin.apply(&lin.ones, &self.vs, &mut r[n..2 * n]);
        r[2 * n] = self
            .c
            .iter()
            .zip(&u[n..2 * n])
            .map(|(c, v)| c * v)
            .sum::<f64>()
            - 1.0;
        Ok(())
    }
    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let n = self.n();
        self.set(u);
        for m in 0..n {
            for i in 0..n {
                let a: f64 = (0..=self.lin.k).map(|d| self.lin.a(d, i, m)).sum();
                entries.push(Entry::new(i, m, a));
                entries.push(Entry::new(n + i, n + m, a));
            }
            self.lin.set_unit_direction(m);
            let lin = &self.lin;
            self.problem.second_derivative(
                &lin.args,
                &self.params,
                &lin.dir,
                &self.vs,
                &mut self.buf,
            )?;
            for i in 0..n {
                entries.push(Entry::new(n + i, m, self.buf[i]));
            }
            entries.push(Entry::new(2 * n, n + m, self.c[m]));
        }
        for (slot, &ip) in self.free.iter().enumerate() {
            let col = 2 * n + slot;
            self.problem
                .dfdp(&self.lin.args, &self.params, ip, &mut self.buf);
            for i in 0..n {
                entries.push(Entry::new(i, col, self.buf[i]));
            }
            self.problem
                .jacobian_dp(&self.lin.args, &self.params, ip, &self.vs, &mut self.buf)?;
            for i in 0..n {
                entries.push(Entry::new(n + i, col, self.buf[i]));
            }
        }
        Ok(())
    }
    fn weights(&self) -> Vec<f64> {
        vec![1.0; self.n_unknowns()]
    }
    fn accept(&mut self, u: &[f64]) {
        let reference = self.reference.take();
        if let Ok((t, w)) = self.tests_at(u, reference.as_deref()) {
            self.tests.accepted = Some(t);
            self.reference = Some(w);
        } else {
            self.tests.accepted = None;
            self.reference = reference;
        }
        self.set_reference(u);
    }
    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        let reference = self.reference.clone();
        self.tests.current = Some(self.tests_at(u, reference.as_deref())?.0);
        Ok(Some(Stability::from_eigenvalues(
            self.remaining_spectrum(u)?,
        )))
    }
    fn classify(&self, a: &Stability, b: &Stability) -> Option<SpecialKind> {
        let (ca, ra) = unstable_counts(a);
        let (cb, rb) = unstable_counts(b);
        if self.tests.sign_change(|t| t.cusp) {
            Some(SpecialKind::Cusp)
        } else if self.tests.sign_change(|t| t.bt) || ra != rb {
            Some(SpecialKind::BogdanovTakens)
        } else if ca != cb {
            Some(SpecialKind::ZeroHopf)
        } else {
            None
        }
    }
    fn test_function(&mut self, kind: SpecialKind, u: &[f64]) -> Result<Option<f64>> {
        let reference = self.reference.clone();
        Ok(match kind {
            SpecialKind::Cusp => Some(self.tests_at(u, reference.as_deref())?.0.cusp),
            SpecialKind::BogdanovTakens => Some(self.tests_at(u, reference.as_deref())?.0.bt),
            SpecialKind::ZeroHopf => {
                let s = Stability::from_eigenvalues(self.remaining_spectrum(u)?);
                nearest_axis(&s, true)
            }
            _ => None,
        })
    }
}
