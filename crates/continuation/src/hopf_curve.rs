//! Curves of Hopf points of equilibria in two free parameters (p1, p2), for ODEs and
//! constant-delay DDEs x' = f(x, x(t−τ1), …; p), delays allowed to depend on p1 and p2.
//!
//! Defining system (the standard one of DDE-Biftool, Engelborghs et al., ACM TOMS 28,
//! 2002), unknowns u = [x (n), Re v (n), Im v (n), ω, p1, p2]:
//!
//! - f(x, x, …, x; p) = 0 (the equilibrium),
//! - Δ(x, p, iω) v = 0 with the characteristic matrix
//!   Δ(λ) = λI − A0 − Σ_j A_j e^{−λτ_j(p)} (the critical pair ±iω, eigenvector v),
//! - c^H v = 1 (two real equations; c = the previous point's v / ‖v‖², updated in
//!   `accept`, so the phase and the length of v are fixed).
//!
//! Its Jacobian is exact: [`Problem::second_derivative`] gives ∂(A v)/∂x,
//! [`Problem::jacobian_dp`] ∂(A v)/∂p, [`Problem::delay_dp`] the dependence of e^{−iωτ_j}
//! on the parameters and [`Problem::dfdp`] that of f.
//!
//! Stability along the curve is the remaining spectrum: the rightmost eigenvalues or
//! characteristic roots other than the critical pair ±iω. Codimension-two points are
//! detected and located with the engine's special-point mechanism:
//! - [`SpecialKind::DoubleHopf`]: a second pair crosses the imaginary axis (test function:
//!   Re of the remaining complex root nearest to the axis);
//! - [`SpecialKind::ZeroHopf`]: a real root crosses 0 (test: the real root nearest to 0);
//! - [`SpecialKind::BogdanovTakens`]: ω passes through 0 (test: ω). The curve turns back in
//!   the parameter plane there (it continues as the same curve with −ω), so the engine
//!   records it as a [`SpecialKind::Fold`] of p1; [`HopfCurveSystem::codim2_points`]
//!   reports such a turning point with a sign change of ω as a Bogdanov–Takens point.
//!
//! # Example: x' = −γx + b·x(t−τ), Hopf curve in (τ, b)
//!
//! ```
//! use continuation::*;
//!
//! /// x' = −γ x + b x(t − τ), p = [γ, b, τ]
//! struct Scalar;
//! impl Problem for Scalar {
//!     fn dim(&self) -> usize { 1 }
//!     fn n_delays(&self) -> usize { 1 }
//!     fn delay(&self, _j: usize, p: &[f64]) -> f64 { p[2] }
//!     fn delay_dp(&self, _j: usize, _p: &[f64], ip: usize) -> f64 { if ip == 2 { 1.0 } else { 0.0 } }
//!     fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) { f[0] = -p[0] * x[0] + p[1] * x[1]; }
//!     fn jacobian(&self, _x: &[f64], p: &[f64], j: &mut [f64]) { j[0] = -p[0]; j[1] = p[1]; }
//!     fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
//!         out[0] = match ip { 0 => -x[0], 1 => x[1], _ => 0.0 };
//!     }
//!     fn second_derivative(&self, _x: &[f64], _p: &[f64], _a: &[f64], _b: &[f64], out: &mut [f64]) -> Result<()> {
//!         out[0] = 0.0; // linear
//!         Ok(())
//!     }
//!     fn jacobian_dp(&self, _x: &[f64], _p: &[f64], ip: usize, a: &[f64], out: &mut [f64]) -> Result<()> {
//!         out[0] = match ip { 0 => -a[0], 1 => a[1], _ => 0.0 };
//!         Ok(())
//!     }
//! }
//!
//! # fn main() -> Result<()> {
//! let cont = Continuation::new(ContinuationOptions { initial_step: 0.1, max_step: 0.2, ..Default::default() });
//! // equilibrium x = 0 continued in the delay τ (index 2) at γ = 1, b = −2: Hopf point
//! let mut eq = EquilibriumSystem::new(&Scalar, vec![1.0, -2.0, 0.5], 2, ChebyshevRoots::default())?;
//! let dir = eq.parameter_direction();
//! let mut branch = cont.start(&mut eq, &[0.0, 0.5], &dir)?;
//! cont.extend(&mut eq, &mut branch, 20)?;
//! let (i, sp) = branch.first(SpecialKind::Hopf).expect("Hopf point");
//! let hopf = eq.hopf_point(&branch.points[i].u, sp.transversality.unwrap())?;
//!
//! // the Hopf curve in (p1, p2) = (τ, b), towards larger b
//! let mut hc = HopfCurveSystem::new(&Scalar, vec![1.0, -2.0, 0.5], [2, 1], ChebyshevRoots::default())?;
//! let (guess, dir) = hc.start_at_hopf(&hopf, 2)?;
//! let mut curve = cont.start(&mut hc, &guess, &dir)?;
//! cont.extend(&mut hc, &mut curve, 5)?;
//! for pt in &curve.points {
//!     let (tau, b) = (pt.parameter, pt.secondary_parameter.unwrap());
//!     let omega = (b * b - 1.0).sqrt(); // closed form ω = √(b² − γ²)
//!     assert!((hc.omega(&pt.u) - omega).abs() < 1e-9);
//!     assert!((tau - (1.0 / b).acos() / omega).abs() < 1e-9);
//! }
//! # Ok(())
//! # }
//! ```

use crate::codim2::{
    Codim2Point, Linearisation, TestPair, check_free, nearest_axis, remove_nearest, unstable_counts,
};
use crate::engine::{Branch, ContinuationSystem};
use crate::equilibrium::HopfPoint;
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::problem::Problem;
use crate::roots::CharacteristicRoots;
use crate::stability::{Location, SpecialKind, Stability};
use num_complex::Complex64;

/// Continuation system of Hopf points in two free parameters (see the module docs).
///
/// Unknowns u = [x (n), Re v (n), Im v (n), ω, p1, p2]; the curve's `parameter` is p1,
/// its `secondary_parameter` p2.
#[derive(Debug)]
pub struct HopfCurveSystem<'a, P: Problem, R: CharacteristicRoots> {
    problem: &'a P,
    params: Vec<f64>,
    free: [usize; 2],
    roots: R,
    lin: Linearisation,
    /// normalisation vector c (c^H v = 1)
    c: Vec<Complex64>,
    /// cos(ω τ_d), sin(ω τ_d) for d = 0..=k
    cs: Vec<(f64, f64)>,
    /// stacked Re and Im of V_d = e^{−iωτ_d} v
    wr: Vec<f64>,
    wi: Vec<f64>,
    /// scratch: per-block scales and n-vectors
    scale: Vec<f64>,
    buf: Vec<f64>,
    buf2: Vec<f64>,
    /// ω at the last accepted point and at the last stability evaluation
    tests: TestPair<f64>,
}

impl<'a, P: Problem, R: CharacteristicRoots> HopfCurveSystem<'a, P, R> {
    /// `params`: all parameters (the free ones, indices `free = [p1, p2]`, are overwritten
    /// from the unknowns); `roots`: how to compute the remaining spectrum.
    pub fn new(problem: &'a P, params: Vec<f64>, free: [usize; 2], roots: R) -> Result<Self> {
        check_free(free, params.len())?;
        let lin = Linearisation::new(problem);
        let (n, k) = (lin.n, lin.k);
        Ok(Self {
            problem,
            params,
            free,
            roots,
            c: vec![Complex64::new(0.0, 0.0); n],
            cs: vec![(1.0, 0.0); k + 1],
            wr: vec![0.0; n * (k + 1)],
            wi: vec![0.0; n * (k + 1)],
            scale: vec![0.0; k + 1],
            buf: vec![0.0; n],
            buf2: vec![0.0; n],
            lin,
            tests: TestPair::default(),
        })
    }

    fn n(&self) -> usize {
        self.lin.n
    }

    /// Start data from a Hopf point located on an equilibrium branch whose free parameter
    /// was `hopf_parameter` (one of the two free parameters; the other one keeps its value
    /// from `params`). Returns the initial unknowns and the start direction for
    /// [`crate::Continuation::start`]: the unit vector of the other parameter (negate it to
    /// go the other way along the curve). Also sets the normalisation vector c = v.
    pub fn start_at_hopf(
        &mut self,
        hopf: &HopfPoint,
        hopf_parameter: usize,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.n();
        if !self.free.contains(&hopf_parameter) {
            return Err(Error::InvalidInput(format!(
                "the Hopf point's parameter {hopf_parameter} is not one of the free parameters {:?}",
                self.free
            )));
        }
        if hopf.state.len() != n || hopf.eigenvector.len() != n {
            return Err(Error::InvalidInput(format!(
                "Hopf point of dimension {} for a system of dimension {n}",
                hopf.state.len()
            )));
        }
        self.params[hopf_parameter] = hopf.parameter;
        let mut u = hopf.state.clone();
        u.extend(hopf.eigenvector.iter().map(|z| z.re));
        u.extend(hopf.eigenvector.iter().map(|z| z.im));
        u.extend([
            hopf.omega,
            self.params[self.free[0]],
            self.params[self.free[1]],
        ]);
        self.set_reference(&u);
        let mut dir = vec![0.0; u.len()];
        let other = if hopf_parameter == self.free[0] { 2 } else { 1 };
        dir[3 * n + other] = 1.0;
        Ok((u, dir))
    }

    /// the equilibrium x of a point
    pub fn state<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[..self.n()]
    }

    /// the critical eigenvector v of a point (Δ(iω) v = 0, c^H v = 1)
    pub fn eigenvector(&self, u: &[f64]) -> Vec<Complex64> {
        let n = self.n();
        (0..n)
            .map(|i| Complex64::new(u[n + i], u[2 * n + i]))
            .collect()
    }

    /// the angular frequency ω of the critical pair ±iω \[rad / time unit\]
    /// (negative beyond a Bogdanov–Takens point, where the curve retraces itself)
    pub fn omega(&self, u: &[f64]) -> f64 {
        u[3 * self.n()]
    }

    /// the two free parameters (p1, p2) of a point
    pub fn parameters(&self, u: &[f64]) -> (f64, f64) {
        let n = self.n();
        (u[3 * n + 1], u[3 * n + 2])
    }

    /// all parameters at a point (the free ones taken from u)
    pub fn parameters_at(&self, u: &[f64]) -> Vec<f64> {
        let mut p = self.params.clone();
        let (p1, p2) = self.parameters(u);
        p[self.free[0]] = p1;
        p[self.free[1]] = p2;
        p
    }

    /// set the normalisation vector from the v of `u`: c = v / ‖v‖²
    pub fn set_reference(&mut self, u: &[f64]) {
        let v = self.eigenvector(u);
        let norm2: f64 = v.iter().map(|z| z.norm_sqr()).sum();
        if norm2 > 0.0 {
            self.c = v.into_iter().map(|z| z / norm2).collect();
        }
    }

    /// the remaining spectrum at u: the rightmost roots without the critical pair ±iω
    pub fn remaining_spectrum(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        self.set(u);
        let a = self.lin.matrices();
        let mut roots = self.roots.rightmost_roots(&a, &self.lin.delays())?;
        let w = self.omega(u);
        let tol = 1e-6 * (1.0 + w.abs());
        remove_nearest(
            &mut roots,
            &[Complex64::new(0.0, w), Complex64::new(0.0, -w)],
            tol,
        );
        Ok(roots)
    }

    /// The codimension-two points located on `curve`, with their critical frequencies.
    /// A turning point of p1 where ω changes sign (recorded by the engine as a fold) is
    /// reported as a Bogdanov–Takens point; other turning points are not codimension two.
    pub fn codim2_points(&self, curve: &Branch) -> Vec<Codim2Point> {
        let mut out = Vec::new();
        for (i, sp) in curve.special_points() {
            if sp.location != Location::Located {
                continue;
            }
            let pt = &curve.points[i];
            let w = self.omega(&pt.u).abs();
            let kind = match sp.kind {
                SpecialKind::Fold if self.omega_changes_sign(curve, i) => {
                    SpecialKind::BogdanovTakens
                }
                k @ (SpecialKind::DoubleHopf
                | SpecialKind::ZeroHopf
                | SpecialKind::BogdanovTakens) => k,
                _ => continue,
            };
            let omegas = match kind {
                SpecialKind::DoubleHopf => {
                    let w2 = sp.critical.map(|z| z.im.abs()).unwrap_or(f64::NAN);
                    vec![w, w2]
                }
                SpecialKind::ZeroHopf => vec![w],
                _ => vec![],
            };
            let (p1, p2) = self.parameters(&pt.u);
            out.push(Codim2Point {
                kind,
                index: i,
                p1,
                p2,
                omegas,
            });
        }
        out
    }

    fn omega_changes_sign(&self, curve: &Branch, i: usize) -> bool {
        let before = i.checked_sub(1).map(|j| self.omega(&curve.points[j].u));
        let after = curve.points.get(i + 1).map(|p| self.omega(&p.u));
        matches!((before, after), (Some(a), Some(b)) if a * b <= 0.0)
    }

    /// evaluate everything that depends on u: parameters, linearisation, delays,
    /// e^{−iωτ_d} and the stacked V_d = e^{−iωτ_d} v
    fn set(&mut self, u: &[f64]) {
        let n = self.n();
        self.params[self.free[0]] = u[3 * n + 1];
        self.params[self.free[1]] = u[3 * n + 2];
        self.lin.set(self.problem, &u[..n], &self.params);
        let w = u[3 * n];
        for d in 0..=self.lin.k {
            let th = w * self.lin.tau[d];
            let (c, s) = (th.cos(), th.sin());
            self.cs[d] = (c, s);
            for m in 0..n {
                let (vr, vi) = (u[n + m], u[2 * n + m]);
                self.wr[d * n + m] = c * vr + s * vi;
                self.wi[d * n + m] = c * vi - s * vr;
            }
        }
    }

    /// columns of the two free parameters
    fn parameter_columns(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let n = self.n();
        let w = u[3 * n];
        for (slot, &ip) in self.free.iter().enumerate() {
            let col = 3 * n + 1 + slot;
            self.problem
                .dfdp(&self.lin.args, &self.params, ip, &mut self.buf);
            for i in 0..n {
                entries.push(Entry::new(i, col, self.buf[i]));
            }
            // explicit dependence of the A_d
            self.problem
                .jacobian_dp(&self.lin.args, &self.params, ip, &self.wr, &mut self.buf)?;
            self.problem
                .jacobian_dp(&self.lin.args, &self.params, ip, &self.wi, &mut self.buf2)?;
            for i in 0..n {
                entries.push(Entry::new(n + i, col, -self.buf[i]));
                entries.push(Entry::new(2 * n + i, col, -self.buf2[i]));
            }
            // dependence of the delays: dV_d/dp = −iω τ_d' V_d
            self.scale[0] = 0.0;
            for j in 0..self.lin.k {
                self.scale[j + 1] = w * self.problem.delay_dp(j, &self.params, ip);
            }
            if self.scale.iter().any(|&s| s != 0.0) {
                self.lin.apply(&self.scale, &self.wi, &mut self.buf);
                self.lin.apply(&self.scale, &self.wr, &mut self.buf2);
                for i in 0..n {
                    entries.push(Entry::new(n + i, col, -self.buf[i]));
                    entries.push(Entry::new(2 * n + i, col, self.buf2[i]));
                }
            }
        }
        Ok(())
    }

    /// columns of x: Σ A_d in the equilibrium rows, −∂(A V)/∂x from second derivatives
    fn state_columns(&mut self, entries: &mut Vec<Entry>) -> Result<()> {
        let n = self.n();
        let k = self.lin.k;
        for m in 0..n {
            for i in 0..n {
                let v: f64 = (0..=k).map(|d| self.lin.a(d, i, m)).sum();
                entries.push(Entry::new(i, m, v));
            }
            self.lin.set_unit_direction(m);
            let lin = &self.lin;
            self.problem.second_derivative(
                &lin.args,
                &self.params,
                &lin.dir,
                &self.wr,
                &mut self.buf,
            )?;
            self.problem.second_derivative(
                &lin.args,
                &self.params,
                &lin.dir,
                &self.wi,
                &mut self.buf2,
            )?;
            for i in 0..n {
                entries.push(Entry::new(n + i, m, -self.buf[i]));
                entries.push(Entry::new(2 * n + i, m, -self.buf2[i]));
            }
        }
        Ok(())
    }

    /// columns of Re v, Im v and ω in the rows of Δ(iω) v = 0, and the normalisation rows
    fn eigen_columns(&mut self, u: &[f64], entries: &mut Vec<Entry>) {
        let n = self.n();
        let k = self.lin.k;
        let w = u[3 * n];
        for i in 0..n {
            for m in 0..n {
                let (mut ac, mut as_) = (0.0, 0.0);
                for d in 0..=k {
                    let a = self.lin.a(d, i, m);
                    ac += self.cs[d].0 * a;
                    as_ += self.cs[d].1 * a;
                }
                let delta = if i == m { w } else { 0.0 };
                entries.push(Entry::new(n + i, n + m, -ac));
                entries.push(Entry::new(2 * n + i, n + m, delta + as_));
                entries.push(Entry::new(n + i, 2 * n + m, -delta - as_));
                entries.push(Entry::new(2 * n + i, 2 * n + m, -ac));
            }
        }
        // ∂/∂ω: dV_d/dω = −iτ_d V_d
        self.scale.copy_from_slice(&self.lin.tau);
        self.lin.apply(&self.scale, &self.wi, &mut self.buf);
        self.lin.apply(&self.scale, &self.wr, &mut self.buf2);
        for i in 0..n {
            entries.push(Entry::new(n + i, 3 * n, -u[2 * n + i] - self.buf[i]));
            entries.push(Entry::new(2 * n + i, 3 * n, u[n + i] + self.buf2[i]));
        }
        for (m, c) in self.c.iter().enumerate() {
            entries.push(Entry::new(3 * n, n + m, c.re));
            entries.push(Entry::new(3 * n, 2 * n + m, c.im));
            entries.push(Entry::new(3 * n + 1, 2 * n + m, c.re));
            entries.push(Entry::new(3 * n + 1, n + m, -c.im));
        }
    }
}

impl<P: Problem, R: CharacteristicRoots> ContinuationSystem for HopfCurveSystem<'_, P, R> {
    fn n_unknowns(&self) -> usize {
        3 * self.n() + 3
    }
    fn parameter_index(&self) -> usize {
        3 * self.n() + 1
    }
    fn secondary_parameter_index(&self) -> Option<usize> {
        Some(3 * self.n() + 2)
    }
    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        let n = self.n();
        self.set(u);
        self.problem.rhs(&self.lin.args, &self.params, &mut r[..n]);
        let w = u[3 * n];
        self.lin.apply(&self.lin.ones, &self.wr, &mut self.buf);
        self.lin.apply(&self.lin.ones, &self.wi, &mut self.buf2);
        for i in 0..n {
            r[n + i] = -w * u[2 * n + i] - self.buf[i];
            r[2 * n + i] = w * u[n + i] - self.buf2[i];
        }
        let (mut re, mut im) = (-1.0, 0.0);
        for (m, c) in self.c.iter().enumerate() {
            let (vr, vi) = (u[n + m], u[2 * n + m]);
            re += c.re * vr + c.im * vi;
            im += c.re * vi - c.im * vr;
        }
        r[3 * n] = re;
        r[3 * n + 1] = im;
        Ok(())
    }
    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        self.set(u);
        self.state_columns(entries)?;
        self.eigen_columns(u, entries);
        self.parameter_columns(u, entries)
    }
    fn weights(&self) -> Vec<f64> {
        vec![1.0; self.n_unknowns()]
    }
    fn accept(&mut self, u: &[f64]) {
        self.set_reference(u);
        self.tests.accepted = Some(self.omega(u));
    }
    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        self.tests.current = Some(self.omega(u));
        Ok(Some(Stability::from_eigenvalues(
            self.remaining_spectrum(u)?,
        )))
    }
    fn classify(&self, a: &Stability, b: &Stability) -> Option<SpecialKind> {
        let (ca, ra) = unstable_counts(a);
        let (cb, rb) = unstable_counts(b);
        if self.tests.sign_change(|w| *w) {
            Some(SpecialKind::BogdanovTakens)
        } else if ca != cb {
            Some(SpecialKind::DoubleHopf)
        } else if ra != rb {
            Some(SpecialKind::ZeroHopf)
        } else {
            None
        }
    }
    fn test_function(&mut self, kind: SpecialKind, u: &[f64]) -> Result<Option<f64>> {
        Ok(match kind {
            SpecialKind::BogdanovTakens => Some(self.omega(u)),
            SpecialKind::DoubleHopf | SpecialKind::ZeroHopf => {
                let s = Stability::from_eigenvalues(self.remaining_spectrum(u)?);
                nearest_axis(&s, kind == SpecialKind::DoubleHopf)
            }
            _ => None,
        })
    }
}
