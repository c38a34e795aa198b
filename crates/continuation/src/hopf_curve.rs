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
//!   reports such a turning point with a sign change of ω as a Bogdanov–Takens point;
//! - [`SpecialKind::CriticalityChange`]: the first Lyapunov coefficient l1
//!   ([`crate::HopfNormalForm`]) changes sign, a generalised-Hopf (Bautin) point (test: l1).
//!   Watched only for problems with [`Problem::third_derivative`] that are
//!   [`crate::Smoothness::Smooth`]; a sign change through a pole of l1 (where Δ(0) or the
//!   eigenvector normalisation is singular) is not reported by
//!   [`HopfCurveSystem::codim2_points`].
//!
//! [`HopfCurveSystem::normal_form`] gives l1 at any point of the curve,
//! [`HopfCurveSystem::double_hopf_normal_form`] the coefficients of a double-Hopf point.
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
    Codim2Point, CurveBase, TestPair, crossings, first_kind, located_codim2, nearest_axis,
};
use crate::engine::{Branch, ContinuationSystem};
use crate::equilibrium::HopfPoint;
use crate::error::{Error, Result};
use crate::linalg::Entry;
use crate::normal_form::{DoubleHopfNormalForm, HopfNormalForm};
use crate::problem::Problem;
use crate::roots::CharacteristicRoots;
use crate::stability::{SpecialKind, Stability};
use num_complex::Complex64;

/// Continuation system of Hopf points in two free parameters (see the module docs).
///
/// Unknowns u = [x (n), Re v (n), Im v (n), ω, p1, p2]; the curve's `parameter` is p1,
/// its `secondary_parameter` p2.
#[derive(Debug)]
pub struct HopfCurveSystem<'a, P: Problem, R: CharacteristicRoots> {
    base: CurveBase<'a, P, R>,
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
    /// ω and l1 at the last accepted point and at the last stability evaluation
    tests: TestPair<HopfTests>,
    /// whether l1 is watched (None: not yet tried; false: the problem has no third
    /// derivative or is not smooth)
    watch_l1: Option<bool>,
}

/// test functions of a Hopf point besides the spectrum
#[derive(Debug, Clone, Copy)]
struct HopfTests {
    omega: f64,
    /// first Lyapunov coefficient (None: not watched or not computable here)
    l1: Option<f64>,
}

impl<'a, P: Problem, R: CharacteristicRoots> HopfCurveSystem<'a, P, R> {
    /// `params`: all parameters (the free ones, indices `free = [p1, p2]`, are overwritten
    /// from the unknowns); `roots`: how to compute the remaining spectrum.
    pub fn new(problem: &'a P, params: Vec<f64>, free: [usize; 2], roots: R) -> Result<Self> {
        let base = CurveBase::new(problem, params, free, roots)?;
        let (n, k) = (base.lin.n, base.lin.k);
        Ok(Self {
            c: vec![Complex64::new(0.0, 0.0); n],
            cs: vec![(1.0, 0.0); k + 1],
            wr: vec![0.0; n * (k + 1)],
            wi: vec![0.0; n * (k + 1)],
            scale: vec![0.0; k + 1],
            buf: vec![0.0; n],
            buf2: vec![0.0; n],
            base,
            tests: TestPair::default(),
            watch_l1: None,
        })
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
        let n = self.base.n();
        if !self.base.free.contains(&hopf_parameter) {
            return Err(Error::InvalidInput(format!(
                "the Hopf point's parameter {hopf_parameter} is not one of the free parameters {:?}",
                self.base.free
            )));
        }
        if hopf.state.len() != n || hopf.eigenvector.len() != n {
            return Err(Error::InvalidInput(format!(
                "Hopf point of dimension {} for a system of dimension {n}",
                hopf.state.len()
            )));
        }
        self.base.params[hopf_parameter] = hopf.parameter;
        let mut u = hopf.state.clone();
        u.extend(hopf.eigenvector.iter().map(|z| z.re));
        u.extend(hopf.eigenvector.iter().map(|z| z.im));
        u.push(hopf.omega);
        u.extend(self.base.free_values());
        self.set_reference(&u);
        let dir = self
            .base
            .start_direction(u.len(), 3 * n + 1, hopf_parameter);
        Ok((u, dir))
    }

    /// the equilibrium x of a point
    pub fn state<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[..self.base.n()]
    }

    /// the critical eigenvector v of a point (Δ(iω) v = 0, c^H v = 1)
    pub fn eigenvector(&self, u: &[f64]) -> Vec<Complex64> {
        let n = self.base.n();
        (0..n)
            .map(|i| Complex64::new(u[n + i], u[2 * n + i]))
            .collect()
    }

    /// the angular frequency ω of the critical pair ±iω \[rad / time unit\]
    /// (negative beyond a Bogdanov–Takens point, where the curve retraces itself)
    pub fn omega(&self, u: &[f64]) -> f64 {
        u[3 * self.base.n()]
    }

    /// the two free parameters (p1, p2) of a point
    pub fn parameters(&self, u: &[f64]) -> (f64, f64) {
        let n = self.base.n();
        (u[3 * n + 1], u[3 * n + 2])
    }

    /// all parameters at a point (the free ones taken from u)
    pub fn parameters_at(&self, u: &[f64]) -> Vec<f64> {
        let mut p = self.base.params.clone();
        let (p1, p2) = self.parameters(u);
        p[self.base.free[0]] = p1;
        p[self.base.free[1]] = p2;
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
        let w = self.omega(u);
        let tol = 1e-6 * (1.0 + w.abs());
        self.base
            .remaining_spectrum(&[Complex64::new(0.0, w), Complex64::new(0.0, -w)], tol)
    }

    /// The codimension-two points located on `curve`, with their critical frequencies.
    /// A turning point of p1 where ω changes sign (recorded by the engine as a fold) is
    /// reported as a Bogdanov–Takens point; other turning points are not codimension two.
    pub fn codim2_points(&self, curve: &Branch) -> Vec<Codim2Point> {
        let points = located_codim2::<std::convert::Infallible>(
            curve,
            |u| self.parameters(u),
            |i, sp| {
                let w = self.omega(&curve.points[i].u).abs();
                let kind = match sp.kind {
                    SpecialKind::Fold if self.omega_changes_sign(curve, i) => {
                        SpecialKind::BogdanovTakens
                    }
                    k @ (SpecialKind::DoubleHopf
                    | SpecialKind::ZeroHopf
                    | SpecialKind::BogdanovTakens) => k,
                    SpecialKind::CriticalityChange if self.l1_vanishes(curve, i) => {
                        SpecialKind::CriticalityChange
                    }
                    _ => return Ok(None),
                };
                let omegas = match kind {
                    SpecialKind::DoubleHopf => {
                        let w2 = sp.critical.map(|z| z.im.abs()).unwrap_or(f64::NAN);
                        vec![w, w2]
                    }
                    SpecialKind::ZeroHopf | SpecialKind::CriticalityChange => vec![w],
                    _ => vec![],
                };
                Ok(Some((kind, omegas)))
            },
        );
        let Ok(points) = points;
        points
    }

    /// The normal form (first Lyapunov coefficient l1) of the Hopf point u of the curve.
    pub fn normal_form(&self, u: &[f64]) -> Result<HopfNormalForm> {
        HopfNormalForm::compute(
            self.base.problem,
            self.state(u),
            &self.parameters_at(u),
            self.omega(u),
        )
    }

    /// The double-Hopf normal form at the point u of the curve with the second critical
    /// frequency `omega2` (e.g. `Codim2Point::omegas[1]`); pair 1 is the curve's pair.
    pub fn double_hopf_normal_form(&self, u: &[f64], omega2: f64) -> Result<DoubleHopfNormalForm> {
        DoubleHopfNormalForm::compute(
            self.base.problem,
            self.state(u),
            &self.parameters_at(u),
            [self.omega(u), omega2],
        )
    }

    /// l1 at u if it is watched (see the module docs)
    fn watched_l1(&mut self, u: &[f64]) -> Option<f64> {
        if self.watch_l1 == Some(false) {
            return None;
        }
        match self.normal_form(u) {
            Ok(nf) => {
                self.watch_l1 = Some(true);
                Some(nf.l1)
            }
            Err(Error::MissingDerivative { .. } | Error::NotSmooth { .. }) => {
                self.watch_l1 = Some(false);
                None
            }
            Err(_) => None,
        }
    }

    /// whether |l1| at point i is below its neighbours' (a zero, not a pole, of l1)
    fn l1_vanishes(&self, curve: &Branch, i: usize) -> bool {
        let l1 = |j: usize| {
            curve
                .points
                .get(j)
                .and_then(|p| self.normal_form(&p.u).ok())
                .map(|nf| nf.l1.abs())
        };
        match (i.checked_sub(1).and_then(l1), l1(i), l1(i + 1)) {
            (Some(a), Some(m), Some(b)) => m <= a && m <= b,
            (_, Some(m), _) => m.is_finite(),
            _ => false,
        }
    }

    fn omega_changes_sign(&self, curve: &Branch, i: usize) -> bool {
        let before = i.checked_sub(1).map(|j| self.omega(&curve.points[j].u));
        let after = curve.points.get(i + 1).map(|p| self.omega(&p.u));
        matches!((before, after), (Some(a), Some(b)) if a * b <= 0.0)
    }

    /// evaluate everything that depends on u: parameters, linearisation, delays,
    /// e^{−iωτ_d} and the stacked V_d = e^{−iωτ_d} v
    fn set(&mut self, u: &[f64]) {
        let n = self.base.n();
        self.base.set(&u[..n], u[3 * n + 1], u[3 * n + 2]);
        let w = u[3 * n];
        for d in 0..=self.base.lin.k {
            let th = w * self.base.lin.tau[d];
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
        let n = self.base.n();
        let w = u[3 * n];
        let base = &self.base;
        let (wr, wi, buf2, scale) = (&self.wr, &self.wi, &mut self.buf2, &mut self.scale);
        base.parameter_columns(
            3 * n + 1,
            &mut self.buf,
            entries,
            |col, ip, buf, entries| {
                let (problem, lin, params) = (base.problem, &base.lin, &base.params);
                // explicit dependence of the A_d
                problem.jacobian_dp(&lin.args, params, ip, wr, buf)?;
                problem.jacobian_dp(&lin.args, params, ip, wi, buf2)?;
                for i in 0..n {
                    entries.push(Entry::new(n + i, col, -buf[i]));
                    entries.push(Entry::new(2 * n + i, col, -buf2[i]));
                }
                // dependence of the delays: dV_d/dp = −iω τ_d' V_d
                scale[0] = 0.0;
                for j in 0..lin.k {
                    scale[j + 1] = w * problem.delay_dp(j, params, ip);
                }
                if scale.iter().any(|&s| s != 0.0) {
                    lin.apply(scale, wi, buf);
                    lin.apply(scale, wr, buf2);
                    for i in 0..n {
                        entries.push(Entry::new(n + i, col, -buf[i]));
                        entries.push(Entry::new(2 * n + i, col, buf2[i]));
                    }
                }
                Ok(())
            },
        )
    }

    /// columns of x: Σ A_d in the equilibrium rows, −∂(A V)/∂x from second derivatives
    fn state_columns(&mut self, entries: &mut Vec<Entry>) -> Result<()> {
        let n = self.base.n();
        for m in 0..n {
            for i in 0..n {
                entries.push(Entry::new(i, m, self.base.j(i, m)));
            }
            self.base.second_derivative_x(m, &self.wr, &mut self.buf)?;
            self.base.second_derivative_x(m, &self.wi, &mut self.buf2)?;
            for i in 0..n {
                entries.push(Entry::new(n + i, m, -self.buf[i]));
                entries.push(Entry::new(2 * n + i, m, -self.buf2[i]));
            }
        }
        Ok(())
    }

    /// columns of Re v, Im v and ω in the rows of Δ(iω) v = 0, and the normalisation rows
    fn eigen_columns(&mut self, u: &[f64], entries: &mut Vec<Entry>) {
        let n = self.base.n();
        let lin = &self.base.lin;
        let w = u[3 * n];
        for i in 0..n {
            for m in 0..n {
                let (mut ac, mut as_) = (0.0, 0.0);
                for d in 0..=lin.k {
                    let a = lin.a(d, i, m);
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
        self.scale.copy_from_slice(&lin.tau);
        lin.apply(&self.scale, &self.wi, &mut self.buf);
        lin.apply(&self.scale, &self.wr, &mut self.buf2);
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
        3 * self.base.n() + 3
    }
    fn parameter_index(&self) -> usize {
        3 * self.base.n() + 1
    }
    fn secondary_parameter_index(&self) -> Option<usize> {
        Some(3 * self.base.n() + 2)
    }
    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        self.set(u);
        self.base.equilibrium_residual(r);
        self.eigen_residual(u, r);
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
        let (omega, l1) = (self.omega(u), self.watched_l1(u));
        self.tests.accepted = Some(HopfTests { omega, l1 });
    }
    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        let (omega, l1) = (self.omega(u), self.watched_l1(u));
        self.tests.current = Some(HopfTests { omega, l1 });
        Ok(Some(Stability::from_eigenvalues(
            self.remaining_spectrum(u)?,
        )))
    }
    fn classify(&self, a: &Stability, b: &Stability) -> Option<SpecialKind> {
        let (complex, real) = crossings(a, b);
        first_kind([
            (
                self.tests.sign_change(|t| t.omega),
                SpecialKind::BogdanovTakens,
            ),
            (complex, SpecialKind::DoubleHopf),
            (real, SpecialKind::ZeroHopf),
            (
                self.tests.sign_change(|t| t.l1.unwrap_or(f64::NAN)),
                SpecialKind::CriticalityChange,
            ),
        ])
    }
    fn test_function(&mut self, kind: SpecialKind, u: &[f64]) -> Result<Option<f64>> {
        Ok(match kind {
            SpecialKind::BogdanovTakens => Some(self.omega(u)),
            SpecialKind::CriticalityChange => self.watched_l1(u),
            SpecialKind::DoubleHopf | SpecialKind::ZeroHopf => {
                let s = Stability::from_eigenvalues(self.remaining_spectrum(u)?);
                nearest_axis(&s, kind == SpecialKind::DoubleHopf)
            }
            _ => None,
        })
    }
}

impl<P: Problem, R: CharacteristicRoots> HopfCurveSystem<'_, P, R> {
    /// the rows of Δ(iω) v = 0 and of the normalisation c^H v = 1 (after `set(u)`)
    fn eigen_residual(&mut self, u: &[f64], r: &mut [f64]) {
        let n = self.base.n();
        let lin = &self.base.lin;
        let w = u[3 * n];
        lin.apply(&lin.ones, &self.wr, &mut self.buf);
        lin.apply(&lin.ones, &self.wi, &mut self.buf2);
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
    }
}
