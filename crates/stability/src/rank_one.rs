//! Rank-one delayed feedback and D-subdivision.
//!
//! For `x' = A·x + B·u`, `u(t) = −D·C·x(t − τ)` (single input, single output; A n×n, B n×1,
//! C 1×n) the characteristic function factorises (matrix determinant lemma) into the
//! quasi-polynomial
//!
//! `F(λ) = p(λ) + D·e^{−λτ}·q(λ)`,  `p(λ) = det(λI − A)` (monic, degree n),
//! `q(λ) = C·adj(λI − A)·B` (degree ≤ n − 1),
//!
//! which is eq. (13) of the paper written out. Both polynomials come from one Faddeev–LeVerrier
//! recursion. Because `deg q < deg p` the equation is retarded: roots can only enter the right
//! half plane across the imaginary axis, which gives the D-subdivision:
//!
//! * static boundary (λ = 0): `D = −p(0)/q(0)`, independent of τ;
//! * dynamic boundaries (λ = ±iω, ω > 0): `D(ω) = −p(iω)·e^{iωτ}/q(iω)` wherever this is real.
//!
//! Along a line of constant (A, B, C, τ) the number of unstable roots is the open-loop count
//! (D = 0: roots of p) plus the signed crossings met between 0 and D; the sign of each crossing
//! is `sign Re(dλ/dD)`, so which side is stable is decided by counting, not assumed.
//!
//! **Finding the dynamic crossings.** With the roots z_j of p and w_k of q,
//! `arg(p(iω)e^{iωτ}/q(iω)) = Σ_j atan((ω−Im z_j)/(−Re z_j)) − Σ_k atan((ω−Im w_k)/(−Re w_k)) + ωτ
//! (mod π)`; every term is continuous in ω, so this phase φ(ω) is evaluated without unwrapping,
//! and the crossings are the solutions of φ(ω) = mπ. φ is sampled on a grid refined around
//! every Im z_j, Im w_k (where the phase turns fast for lightly damped roots) and at every
//! extremum of φ (the real roots of the polynomial φ'(ω)·Π_k Q_k(ω), see
//! `RankOneFeedback::phase_extrema`), so φ is monotone between samples and no pair of close
//! crossings (where a boundary curve turns back in D) can be missed; each level crossing is
//! solved by safeguarded Newton with the analytic φ'. Only ω up to the bound beyond
//! which `|p(iω)|/|q(iω)| > D_lim` is searched.

use nalgebra::{DMatrix, Dim, Matrix, Storage, U1};
use num_complex::Complex64;

use crate::dde::{LinearDde, NewtonOptions, NewtonStep, newton, sort_rightmost};
use crate::error::{Result, StabilityError, eigenvalues};
use crate::roots::{RootOptions, confirmed_rightmost};

/// A point where a characteristic root crosses the imaginary axis as the gain D varies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// gain D at the crossing
    pub d: f64,
    /// crossing frequency ω ≥ 0 \[rad/s\] (0: static boundary, a real root through 0)
    pub omega: f64,
    /// `Re(dλ/dD)` at the crossing: > 0 means increasing D moves the root(s) to the right
    pub direction: f64,
    /// number of roots crossing: 1 at ω = 0, 2 (a conjugate pair) at ω > 0
    pub multiplicity: u32,
}

impl Crossing {
    /// Signed change of the unstable-root count when D increases through this crossing.
    pub fn signed_change(&self) -> i64 {
        if self.direction > 0.0 {
            self.multiplicity as i64
        } else if self.direction < 0.0 {
            -(self.multiplicity as i64)
        } else {
            0
        }
    }
}

/// Bound on |atan_approx(x) − atan(x)| over all x \[rad\] (the approximation's maximum
/// error is 1.5e-3 rad; checked on a dense grid by this module's tests).
const ATAN_APPROX_ERROR: f64 = 2e-3;

/// atan x to within [`ATAN_APPROX_ERROR`], without `atan`: on |x| ≤ 1 the cubic
/// π/4·x − x(|x| − 1)(0.2447 + 0.0663|x|) (Rajan, Wang, Inkol & Joyal 2006, max error
/// 1.5e-3 rad), beyond it atan x = ±π/2 − atan(1/x).
#[inline]
fn atan_approx(x: f64) -> f64 {
    let core = |t: f64| {
        let m = t.abs();
        std::f64::consts::FRAC_PI_4 * t - t * (m - 1.0) * (0.2447 + 0.0663 * m)
    };
    if x.abs() <= 1.0 {
        core(x)
    } else {
        std::f64::consts::FRAC_PI_2.copysign(x) - core(1.0 / x)
    }
}

/// Evaluates a real polynomial (ascending coefficients) and its derivative at a complex point.
#[inline]
fn horner2(c: &[f64], z: Complex64) -> (Complex64, Complex64) {
    let mut v = Complex64::ZERO;
    let mut dv = Complex64::ZERO;
    for &a in c.iter().rev() {
        dv = dv * z + v;
        v = v * z + a;
    }
    (v, dv)
}

/// The closed loop `x' = A·x − B·D·C·x(t − τ)` in quasi-polynomial form `p(λ) + D·e^{−λτ}·q(λ)`.
#[derive(Debug, Clone, PartialEq)]
pub struct RankOneFeedback {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    /// ascending coefficients of p (monic, degree n)
    p: Vec<f64>,
    /// ascending coefficients of q (trimmed: last one nonzero; empty if q ≡ 0)
    q: Vec<f64>,
    p_roots: Vec<Complex64>,
    q_roots: Vec<Complex64>,
}

impl RankOneFeedback {
    /// From state-space matrices A (n×n), B (n×1), C (1×n); works with fixed-size
    /// (`SMatrix`) and dynamic nalgebra matrices.
    pub fn from_state_space<N, SA, SB, SC>(
        a: &Matrix<f64, N, N, SA>,
        b: &Matrix<f64, N, U1, SB>,
        c: &Matrix<f64, U1, N, SC>,
    ) -> Result<Self>
    where
        N: Dim,
        SA: Storage<f64, N, N>,
        SB: Storage<f64, N, U1>,
        SC: Storage<f64, U1, N>,
    {
        let n = a.nrows();
        if a.ncols() != n {
            return Err(StabilityError::DimensionMismatch {
                what: "A",
                rows: n,
                cols: a.ncols(),
                expected_rows: n,
                expected_cols: n,
            });
        }
        let a = DMatrix::from_fn(n, n, |i, j| a[(i, j)]);
        let b = DMatrix::from_fn(n, 1, |i, _| b[i]);
        let c = DMatrix::from_fn(1, n, |_, j| c[j]);
        if !(a
            .iter()
            .chain(b.iter())
            .chain(c.iter())
            .all(|x| x.is_finite()))
        {
            return Err(StabilityError::NonFinite { what: "A, B or C" });
        }
        // Faddeev–LeVerrier: adj(λI − A) = Σ_{k=1}^{n} M_k λ^{n−k}, M_1 = I,
        // M_k = A·M_{k−1} + c_{n−k+1}·I, c_{n−k} = −tr(A·M_k)/k.
        let mut p = vec![0.0; n + 1];
        let mut q = vec![0.0; n.max(1)];
        p[n] = 1.0;
        let mut m = DMatrix::<f64>::identity(n, n);
        for k in 1..=n {
            if k > 1 {
                m = &a * &m;
                for i in 0..n {
                    m[(i, i)] += p[n - k + 1];
                }
            }
            let am = &a * &m;
            p[n - k] = -am.trace() / k as f64;
            q[n - k] = (&c * &m * &b)[(0, 0)];
        }
        let p_roots = {
            let fm = faer::Mat::from_fn(n, n, |i, j| a[(i, j)]);
            eigenvalues(&fm)?
        };
        // trim q's leading coefficients that are negligible on the scale of A's spectrum
        let rho = p_roots.iter().map(|z| z.norm()).fold(1.0, f64::max);
        let scaled_max = q
            .iter()
            .enumerate()
            .map(|(k, x)| x.abs() * rho.powi(k as i32))
            .fold(0.0, f64::max);
        while let Some(&last) = q.last() {
            if last == 0.0 || last.abs() * rho.powi(q.len() as i32 - 1) <= 1e-13 * scaled_max {
                q.pop();
            } else {
                break;
            }
        }
        let q_roots = polynomial_roots(&q)?;
        Ok(Self {
            a,
            b,
            c,
            p,
            q,
            p_roots,
            q_roots,
        })
    }

    /// From the coefficients of the quasi-polynomial `p(λ) + D·e^{−λτ}·q(λ)` themselves
    /// (ascending; p monic of degree n ≥ 1, q of degree < n), for loops that are not given as
    /// (A, B, C) — a predictor's characteristic function cleared of its denominators, say.
    /// The state-space form (for [`RankOneFeedback::closed_loop`] and the root seeds) is the
    /// controllable canonical realisation: A the companion matrix of p, B = e_n,
    /// C = (q_0, …, q_{n−1}), for which C·adj(λI − A)·B = q(λ) exactly.
    ///
    /// # Errors
    /// [`StabilityError::NonFinite`] for non-finite coefficients, a p that is not monic or
    /// has no degree, or a q of degree ≥ n (a neutral equation).
    pub fn from_polynomials(p: &[f64], q: &[f64]) -> Result<Self> {
        if !p.iter().chain(q).all(|x| x.is_finite()) {
            return Err(StabilityError::NonFinite {
                what: "quasi-polynomial coefficients",
            });
        }
        let n = p.len().saturating_sub(1);
        if n == 0 || p[n] != 1.0 {
            return Err(StabilityError::NonFinite {
                what: "p: expected a monic polynomial of degree ≥ 1",
            });
        }
        let mut q = q.to_vec();
        while q.last() == Some(&0.0) {
            q.pop();
        }
        if q.len() > n {
            return Err(StabilityError::NonFinite {
                what: "q: expected degree below p's (a retarded equation)",
            });
        }
        let a = DMatrix::from_fn(n, n, |i, j| {
            if i + 1 == j {
                1.0
            } else if i + 1 == n {
                -p[j]
            } else {
                0.0
            }
        });
        let b = DMatrix::from_fn(n, 1, |i, _| if i + 1 == n { 1.0 } else { 0.0 });
        let c = DMatrix::from_fn(1, n, |_, j| q.get(j).copied().unwrap_or(0.0));
        let p_roots = polynomial_roots(p)?;
        let q_roots = polynomial_roots(&q)?;
        Ok(Self {
            a,
            b,
            c,
            p: p.to_vec(),
            q,
            p_roots,
            q_roots,
        })
    }

    /// Dynamic dimension n.
    pub fn dim(&self) -> usize {
        self.a.nrows()
    }

    /// Ascending coefficients of `p(λ) = det(λI − A)`.
    pub fn p(&self) -> &[f64] {
        &self.p
    }

    /// Ascending coefficients of `q(λ) = C·adj(λI − A)·B` (trimmed; empty if q ≡ 0).
    pub fn q(&self) -> &[f64] {
        &self.q
    }

    /// Open-loop eigenvalues (roots of p).
    pub fn open_loop_eigenvalues(&self) -> &[Complex64] {
        &self.p_roots
    }

    /// Number of open-loop eigenvalues with Re > 0 (the unstable count at D = 0 for every τ).
    pub fn open_loop_unstable_count(&self) -> usize {
        self.p_roots.iter().filter(|z| z.re > 0.0).count()
    }

    /// The closed loop as a general [`LinearDde`]: `x' = A·x + (−D·B)·C·x(t − τ)`.
    pub fn closed_loop(&self, d: f64, tau: f64) -> Result<LinearDde> {
        if !d.is_finite() {
            return Err(StabilityError::NonFinite { what: "gain D" });
        }
        LinearDde::new(self.a.clone())?.with_low_rank_delay(tau, &self.b * (-d), self.c.clone())
    }

    /// `F(λ) = p(λ) + D·e^{−λτ}·q(λ)` and `F'(λ)`.
    #[inline]
    pub fn characteristic(&self, lambda: Complex64, d: f64, tau: f64) -> (Complex64, Complex64) {
        let (p, dp) = horner2(&self.p, lambda);
        let (q, dq) = horner2(&self.q, lambda);
        let e = (-lambda * tau).exp() * d;
        (p + e * q, dp + e * (dq - q * tau))
    }

    /// Newton's method on the quasi-polynomial from `lambda0`.
    pub fn polish_root(
        &self,
        lambda0: Complex64,
        d: f64,
        tau: f64,
        options: &NewtonOptions,
    ) -> Result<Complex64> {
        newton(lambda0, options, |lambda| {
            let (f, df) = self.characteristic(lambda, d, tau);
            if f == Complex64::ZERO {
                NewtonStep::Root
            } else {
                NewtonStep::Step(f / df)
            }
        })
    }

    /// The `count` rightmost roots at gain `d` and delay `tau` (conjugates listed separately),
    /// sorted by decreasing real part, polished to ~1e-14 relative on the quasi-polynomial.
    /// Seeds: Chebyshev collocation of the reduced generator (size n + N), see
    /// [`crate::rightmost_roots`]. For τ = 0 these are the eigenvalues of A − B·D·C.
    pub fn rightmost_roots(
        &self,
        d: f64,
        tau: f64,
        count: usize,
        options: &RootOptions,
    ) -> Result<Vec<Complex64>> {
        self.rightmost_roots_with_degree(d, tau, count, options)
            .map(|(r, _)| r)
    }

    /// As [`RankOneFeedback::rightmost_roots`], also returning the Chebyshev degree used.
    pub fn rightmost_roots_with_degree(
        &self,
        d: f64,
        tau: f64,
        count: usize,
        options: &RootOptions,
    ) -> Result<(Vec<Complex64>, usize)> {
        let dde = self.closed_loop(d, tau)?;
        let newton = options.newton;
        confirmed_rightmost(&dde, count, options, |s| {
            self.polish_root(s, d, tau, &newton)
        })
    }

    /// Phase φ(ω) of `p(iω)e^{iωτ}/q(iω)` (mod π, continuous in ω) and φ'(ω).
    fn phase(&self, omega: f64, tau: f64) -> (f64, f64) {
        let mut phi = omega * tau;
        let mut dphi = tau;
        let mut term = |z: &Complex64, sign: f64| {
            let a = -z.re;
            let u = omega - z.im;
            if a == 0.0 {
                phi += sign
                    * if u >= 0.0 {
                        std::f64::consts::FRAC_PI_2
                    } else {
                        -std::f64::consts::FRAC_PI_2
                    };
            } else {
                phi += sign * (u / a).atan();
                dphi += sign * a / (a * a + u * u);
            }
        };
        for z in &self.p_roots {
            term(z, 1.0);
        }
        for w in &self.q_roots {
            term(w, -1.0);
        }
        (phi, dphi)
    }

    /// ⌊φ(ω)/π⌋ and ⌈φ(ω)/π⌉ of [`RankOneFeedback::phase`]'s φ, as floats: all the crossing
    /// search needs of φ at a sample. Each term's `atan` is replaced by [`atan_approx`]
    /// (error ≤ [`ATAN_APPROX_ERROR`]); where no multiple of π lies within the summed error
    /// bound (plus a rounding margin of 1e-9·(1 + |φ|)) of the approximate φ, the exact φ
    /// lies strictly between the same two multiples and so does its rounded value: both
    /// are then known without evaluating it. Only near a level (≈ 1 % of the samples) is φ
    /// evaluated exactly, so the result is the exact φ's, bit for bit.
    fn phase_levels(&self, omega: f64, tau: f64) -> (f64, f64) {
        use std::f64::consts::{FRAC_PI_2, PI};
        let mut approx = omega * tau;
        let mut terms = 0usize;
        let mut term = |z: &Complex64, sign: f64| {
            let a = -z.re;
            let u = omega - z.im;
            if a == 0.0 {
                approx += sign * if u >= 0.0 { FRAC_PI_2 } else { -FRAC_PI_2 };
            } else {
                approx += sign * atan_approx(u / a);
                terms += 1;
            }
        };
        for z in &self.p_roots {
            term(z, 1.0);
        }
        for w in &self.q_roots {
            term(w, -1.0);
        }
        let bound = terms as f64 * ATAN_APPROX_ERROR + 1e-9 * (1.0 + approx.abs());
        let lo = ((approx - bound) / PI).floor();
        if lo == ((approx + bound) / PI).floor() {
            return (lo, lo + 1.0);
        }
        let (phi, _) = self.phase(omega, tau);
        ((phi / PI).floor(), (phi / PI).ceil())
    }

    /// The frequencies ω > 0 where φ'(ω) = 0. With a_k = −Re z_k, b_k = Im z_k over the roots
    /// of p (s_k = +1) and q (s_k = −1), φ'(ω) = τ + Σ s_k a_k / Q_k(ω), Q_k = (ω − b_k)² + a_k²;
    /// multiplied by Π Q_k this is the polynomial τ Π Q_k + Σ_k s_k a_k Π_{j≠k} Q_j, whose
    /// real roots (companion-matrix eigenvalues) are returned. Nearly real ones are kept too
    /// (|Im| ≤ 1e-2·(1 + |Re|): φ' nearly touches 0 there); an extra sample costs nothing.
    fn phase_extrema(&self, tau: f64) -> Result<Vec<f64>> {
        let terms: Vec<(f64, f64, f64)> = self
            .p_roots
            .iter()
            .map(|z| (1.0, -z.re, z.im))
            .chain(self.q_roots.iter().map(|w| (-1.0, -w.re, w.im)))
            .filter(|&(_, a, _)| a != 0.0)
            .collect();
        let quadratic = |a: f64, b: f64| vec![b * b + a * a, -2.0 * b, 1.0];
        let product = |skip: Option<usize>| {
            terms
                .iter()
                .enumerate()
                .filter(|&(k, _)| Some(k) != skip)
                .fold(vec![1.0], |acc, (_, &(_, a, b))| {
                    poly_mul(&acc, &quadratic(a, b))
                })
        };
        let mut numerator: Vec<f64> = product(None).iter().map(|c| tau * c).collect();
        for (k, &(sign, a, _)) in terms.iter().enumerate() {
            for (i, c) in product(Some(k)).iter().enumerate() {
                numerator[i] += sign * a * c;
            }
        }
        while numerator.len() > 1 && numerator.last() == Some(&0.0) {
            numerator.pop();
        }
        let scale = numerator.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        if numerator.len() < 2 || scale == 0.0 {
            return Ok(Vec::new());
        }
        let roots = polynomial_roots(&numerator)?;
        Ok(roots
            .iter()
            .filter(|r| r.re > 0.0 && r.im.abs() <= 1e-2 * (1.0 + r.re.abs()))
            .map(|r| r.re)
            .collect())
    }

    /// `D(ω) = −Re(p(iω)e^{iωτ}/q(iω))` (the real part; exact on a boundary).
    fn gain_at(&self, omega: f64, tau: f64) -> f64 {
        let l = Complex64::new(0.0, omega);
        let (p, _) = horner2(&self.p, l);
        let (q, _) = horner2(&self.q, l);
        -(p * Complex64::from_polar(1.0, omega * tau) / q).re
    }

    /// Static crossing (λ = 0): `D = −p(0)/q(0)`, the same for every τ (only its direction
    /// depends on τ). `None` if q(0) = 0.
    pub fn static_crossing(&self, tau: f64) -> Option<Crossing> {
        let q0 = self.q.first().copied().unwrap_or(0.0);
        if q0 == 0.0 {
            return None;
        }
        let d = -self.p[0] / q0;
        let (_, df) = self.characteristic(Complex64::ZERO, d, tau);
        let dl = -q0 / df.re;
        Some(Crossing {
            d,
            omega: 0.0,
            direction: if dl.is_finite() { dl } else { 0.0 },
            multiplicity: 1,
        })
    }

    /// Upper bound of the frequencies at which a crossing with |D| ≤ `d_lim` can occur.
    ///
    /// # Errors
    /// [`StabilityError::UnboundedCrossings`] when no ω up to 2^60 times the roots' radius
    /// bounds them (|p| does not outgrow d_lim·|q|: the loop keeps gain at high frequency).
    fn omega_bound(&self, d_lim: f64) -> Result<f64> {
        let rz = self.p_roots.iter().map(|z| z.norm()).fold(0.0, f64::max);
        let rw = self.q_roots.iter().map(|z| z.norm()).fold(0.0, f64::max);
        let lead = self.q.last().map_or(0.0, |x| x.abs());
        let mut w = 2.0 * rz.max(rw).max(1.0);
        for _ in 0..60 {
            let lower_p: f64 = self.p_roots.iter().map(|z| w - z.norm()).product();
            let upper_q: f64 = lead * self.q_roots.iter().map(|z| w + z.norm()).product::<f64>();
            if lower_p > d_lim * upper_q {
                return Ok(w);
            }
            w *= 2.0;
        }
        Err(StabilityError::UnboundedCrossings {
            d_lim,
            degree_p: self.p_roots.len(),
            degree_q: self.q_roots.len(),
        })
    }

    /// All crossings with |D| ≤ `d_lim` (static one included), sorted by D.
    pub fn crossings(&self, tau: f64, d_lim: f64) -> Result<Vec<Crossing>> {
        if !(tau.is_finite() && tau >= 0.0) {
            return Err(StabilityError::InvalidDelay { tau });
        }
        if !(d_lim.is_finite() && d_lim > 0.0) {
            return Err(StabilityError::NonFinite { what: "gain limit" });
        }
        let mut out = Vec::new();
        if self.q.is_empty() {
            return Ok(out);
        }
        if let Some(s) = self.static_crossing(tau).filter(|s| s.d.abs() <= d_lim) {
            out.push(s);
        }
        let w_max = self.omega_bound(d_lim)?;
        // sample grid: uniform plus refinement around every root's imaginary part
        let base = if tau > 0.0 {
            (std::f64::consts::PI / (4.0 * tau)).min(w_max / 256.0)
        } else {
            w_max / 256.0
        };
        // a quarter period of e^{-iωτ} per sample: beyond a million samples the bound is
        // no bound (a loop that keeps its gain far beyond the roots' frequencies)
        let nb = (w_max / base).ceil();
        if nb > 1e6 {
            return Err(StabilityError::UnboundedCrossings {
                d_lim,
                degree_p: self.p_roots.len(),
                degree_q: self.q_roots.len(),
            });
        }
        let nb = nb as usize;
        let mut samples: Vec<f64> = (0..=nb).map(|i| (i as f64 * base).min(w_max)).collect();
        const OFFS: [f64; 13] = [
            -8.0, -4.0, -2.0, -1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0,
        ];
        for z in self.p_roots.iter().chain(&self.q_roots) {
            let (b, a) = (z.im.abs(), z.re.abs());
            for o in OFFS {
                let w = b + o * a;
                if w > 0.0 && w < w_max {
                    samples.push(w);
                }
            }
        }
        // every extremum of φ is a sample too: between samples φ is then monotone, so no
        // pair of level crossings (two close crossings where a boundary curve turns back in
        // D) can hide inside one interval
        samples.extend(
            self.phase_extrema(tau)?
                .into_iter()
                .filter(|&w| w > 0.0 && w < w_max),
        );
        samples.sort_by(f64::total_cmp);
        samples.dedup();
        let pi = std::f64::consts::PI;
        let (phi0, _) = self.phase(0.0, tau);
        let mut prev_w = 0.0;
        // at ω = 0 the phase is a multiple of π (p(0)/q(0) real) unless p or q vanishes there;
        // snap it so that the static crossing is not counted as a dynamic one
        let snapped = (phi0 / pi).round() * pi;
        let prev_phi = if (phi0 - snapped).abs() < 1e-9 {
            snapped
        } else {
            phi0
        };
        let mut prev = ((prev_phi / pi).floor(), (prev_phi / pi).ceil());
        for &w in samples.iter().skip(1) {
            // the levels mπ between the samples: prev < mπ ≤ φ where φ increased, φ ≤ mπ <
            // prev where it decreased (⌊·/π⌋ and ⌈·/π⌉ of φ, which say which)
            let (floor, ceil) = self.phase_levels(w, tau);
            let (lo_m, hi_m) = if floor > prev.0 || (floor == prev.0 && ceil > prev.1) {
                (prev.0 as i64 + 1, floor as i64)
            } else {
                (ceil as i64, prev.1 as i64 - 1)
            };
            for m in lo_m..=hi_m {
                let omega = self.solve_level(prev_w, w, m as f64 * pi, tau);
                let d = self.gain_at(omega, tau);
                if d.is_finite() && d.abs() <= d_lim {
                    let l = Complex64::new(0.0, omega);
                    let q = horner2(&self.q, l).0;
                    let (_, df) = self.characteristic(l, d, tau);
                    let dl = -(-l * tau).exp() * q / df;
                    out.push(Crossing {
                        d,
                        omega,
                        direction: if dl.re.is_finite() { dl.re } else { 0.0 },
                        multiplicity: 2,
                    });
                }
            }
            prev_w = w;
            prev = (floor, ceil);
        }
        out.sort_by(|a, b| a.d.total_cmp(&b.d).then(a.omega.total_cmp(&b.omega)));
        Ok(out)
    }

    /// Solves φ(ω) = level on [lo, hi] (φ − level changes sign there) by safeguarded Newton.
    fn solve_level(&self, lo: f64, hi: f64, level: f64, tau: f64) -> f64 {
        let f_lo = self.phase(lo, tau).0 - level;
        let (mut a, mut b) = (lo, hi);
        let increasing = f_lo < 0.0;
        let mut x = 0.5 * (a + b);
        for _ in 0..200 {
            let (phi, dphi) = self.phase(x, tau);
            let f = phi - level;
            if f == 0.0 {
                return x;
            }
            if (f < 0.0) == increasing {
                a = x;
            } else {
                b = x;
            }
            let newton = x - f / dphi;
            let next = if newton > a && newton < b && dphi.is_finite() {
                newton
            } else {
                0.5 * (a + b)
            };
            if (next - x).abs() <= 1e-15 * x.abs().max(1e-300)
                || b - a <= 4.0 * f64::EPSILON * b.abs()
            {
                return next;
            }
            x = next;
        }
        x
    }

    /// Number of characteristic roots with Re λ > 0 at gain `d`, from the open-loop count and the
    /// signed `crossings` between 0 and `d` (which must cover |D| ≤ |d|, e.g. from
    /// [`RankOneFeedback::crossings`]). Exact except exactly on a boundary.
    pub fn unstable_count_from(&self, d: f64, crossings: &[Crossing]) -> usize {
        let mut n = self.open_loop_unstable_count() as i64;
        for c in crossings {
            if d > 0.0 && c.d > 0.0 && c.d < d {
                n += c.signed_change();
            } else if d < 0.0 && c.d < 0.0 && c.d > d {
                n -= c.signed_change();
            }
        }
        n.max(0) as usize
    }

    /// Number of characteristic roots with Re λ > 0 at (d, τ) by crossing counting.
    pub fn unstable_root_count(&self, d: f64, tau: f64) -> Result<usize> {
        let c = self.crossings(tau, d.abs().max(f64::MIN_POSITIVE))?;
        Ok(self.unstable_count_from(d, &c))
    }

    /// The intervals of D in [d_min, d_max] where the closed loop is asymptotically stable,
    /// with end points at the exact crossings (or the interval ends).
    pub fn stable_gain_intervals(
        &self,
        tau: f64,
        d_min: f64,
        d_max: f64,
    ) -> Result<Vec<(f64, f64)>> {
        let lim = d_min.abs().max(d_max.abs());
        let cr = self.crossings(tau, lim)?;
        let mut cuts: Vec<f64> = vec![d_min];
        cuts.extend(cr.iter().map(|c| c.d).filter(|&d| d > d_min && d < d_max));
        cuts.push(d_max);
        let mut out: Vec<(f64, f64)> = Vec::new();
        for w in cuts.windows(2) {
            if w[1] <= w[0] {
                continue;
            }
            let mid = 0.5 * (w[0] + w[1]);
            if self.unstable_count_from(mid, &cr) == 0 {
                match out.last_mut() {
                    Some(last) if last.1 == w[0] => last.1 = w[1],
                    _ => out.push((w[0], w[1])),
                }
            }
        }
        Ok(out)
    }
}

/// Product of two real polynomials (ascending coefficients).
fn poly_mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// Roots of a real polynomial (ascending coefficients, last one nonzero) via the eigenvalues of
/// its companion matrix.
pub fn polynomial_roots(c: &[f64]) -> Result<Vec<Complex64>> {
    if c.len() <= 1 {
        return Ok(Vec::new());
    }
    let n = c.len() - 1;
    let lead = c[n];
    // companion matrix, row-major: first row −c_{n−1−j}/c_n, ones on the subdiagonal (upper
    // Hessenberg already: the QR iteration starts at once)
    let mut m = vec![0.0; n * n];
    for j in 0..n {
        m[j] = -c[n - 1 - j] / lead;
    }
    for i in 1..n {
        m[i * n + i - 1] = 1.0;
    }
    let mut r = Vec::with_capacity(n);
    if n <= crate::small_eigen::SMALL_EIGEN_MAX {
        crate::small_eigen::small_eigenvalues(&mut m, n, &mut r)?;
    } else {
        r = eigenvalues(&faer::Mat::from_fn(n, n, |i, j| m[i * n + j]))?;
    }
    sort_rightmost(&mut r);
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan_approx_is_within_its_stated_error() {
        // dense grid over |x| ≤ 1e3 (and the limits): the bound the crossing search relies
        // on (ATAN_APPROX_ERROR) against std's atan, the reference
        let mut worst = 0.0f64;
        for i in -200_000..=200_000 {
            let x = i as f64 * 5e-3;
            worst = worst.max((atan_approx(x) - x.atan()).abs());
            let y = 1.0 / (i as f64 * 1e-5 + 1e-12);
            worst = worst.max((atan_approx(y) - y.atan()).abs());
        }
        for x in [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            -f64::MIN_POSITIVE,
        ] {
            worst = worst.max((atan_approx(x) - x.atan()).abs());
        }
        assert!(worst <= 1.6e-3, "worst {worst} (ATAN_APPROX_ERROR = 2e-3)");
    }

    #[test]
    fn phase_levels_are_those_of_the_exact_phase() {
        // a lightly damped loop (the phase turns fast): on a fine ω grid the levels from the
        // approximate phase equal ⌊φ/π⌋, ⌈φ/π⌉ of the exact φ, bit for bit
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 1.0, 0.0, 0.0, -40.0, -0.05, 3.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 0.0, -9.0,
                -0.3,
            ],
        );
        let b = nalgebra::DVector::from_column_slice(&[0.0, 1.0, 0.0, 0.5]);
        let c = nalgebra::RowDVector::from_row_slice(&[1.0, 0.2, -0.7, 0.1]);
        let f = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
        let pi = std::f64::consts::PI;
        for tau in [0.0, 0.2, 1.7] {
            for i in 0..20_000 {
                let w = i as f64 * 1e-3;
                let (phi, _) = f.phase(w, tau);
                assert_eq!(
                    f.phase_levels(w, tau),
                    ((phi / pi).floor(), (phi / pi).ceil()),
                    "ω = {w}, τ = {tau}"
                );
            }
        }
    }
}
