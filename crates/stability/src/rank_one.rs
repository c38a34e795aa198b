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
//! extremum of φ, so φ is monotone between samples and no pair of close crossings (where a
//! boundary curve turns back in D) can be missed. The extrema are certified, not sampled for:
//! φ'(ω) = τ + Σ_k s_k a_k/((ω − b_k)² + a_k²) is a sum of Lorentzians whose exact range on an
//! interval is cheap, so an interval is either proven monotone (φ' of one sign), or φ' is
//! proven monotone there (φ'' of one sign: one extremum at most, solved by safeguarded Newton),
//! or it is bisected (see `RankOneFeedback::phase_extrema`). Each level crossing is solved by
//! safeguarded Newton with the analytic φ'. Only ω up to the bound beyond which
//! `|p(iω)|/|q(iω)| > D_lim` is searched, and a level is only solved where D can lie in the
//! range asked for: its sign follows from the level's parity, its magnitude |p|/|q| is bounded
//! below on the sample interval.

use nalgebra::{DMatrix, Dim, Matrix, Storage, U1};
use num_complex::Complex64;

use crate::dde::{LinearDde, NewtonOptions, NewtonStep, newton, sort_rightmost};
use crate::eigen::eigenvalues;
use crate::error::{Result, StabilityError};
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

/// ⌊x⌋ for |x| < 2⁶² by truncation (`f64::floor` is a library call on baseline x86-64,
/// and the crossing search takes two per sample); NaN and larger |x| go to `f64::floor`.
#[inline]
fn floor_small(x: f64) -> f64 {
    const LIMIT: f64 = 4.611_686_018_427_388e18; // 2^62
    if x.is_nan() || x.abs() >= LIMIT {
        return x.floor();
    }
    let t = x as i64 as f64; // toward zero
    if t > x { t - 1.0 } else { t }
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
    /// the Lorentzian terms of φ' (roots off the imaginary axis)
    phase_terms: Vec<PhaseTerm>,
    /// parity of the constant K in arg(p(iω)e^{iωτ}/q(iω)) = φ(ω) + Kπ: at a level φ = mπ the
    /// gain D = −|p/q|·(−1)^{m+K} is positive exactly when m + K is odd
    phase_offset_odd: bool,
}

/// One root's share of the phase: a root −a + ib of p (`sign` +1) or of q (`sign` −1, a
/// zero of the loop) adds sign·atan((ω − b)/a) to φ(ω) and the Lorentzian
/// sign·a/((ω − b)² + a²) to φ'(ω).
#[derive(Debug, Clone, Copy, PartialEq)]
struct PhaseTerm {
    sign: f64,
    a: f64,
    b: f64,
}

impl PhaseTerm {
    /// The term of φ' and its derivative (the term of φ'') at ω.
    #[inline]
    fn slope(&self, omega: f64) -> (f64, f64) {
        let u = omega - self.b;
        let q = u * u + self.a * self.a;
        let c = self.sign * self.a;
        (c / q, -2.0 * c * u / (q * q))
    }

    /// The exact range of the term of φ' over [l, r]: the Lorentzian is monotone on either
    /// side of its peak at ω = b.
    #[inline]
    fn slope_range(&self, l: f64, r: f64) -> (f64, f64) {
        let (fl, fr) = (self.slope(l).0, self.slope(r).0);
        let (mut lo, mut hi) = (fl.min(fr), fl.max(fr));
        if l < self.b && self.b < r {
            let peak = self.sign / self.a;
            lo = lo.min(peak);
            hi = hi.max(peak);
        }
        (lo, hi)
    }

    /// The exact range of the term of φ'' over [l, r]: −2c·u/(u² + a²)² (u = ω − b) is
    /// monotone between its extrema at u = ±|a|/√3.
    #[inline]
    fn curvature_range(&self, l: f64, r: f64) -> (f64, f64) {
        let (gl, gr) = (self.slope(l).1, self.slope(r).1);
        let (mut lo, mut hi) = (gl.min(gr), gl.max(gr));
        let u = self.a.abs() / 3f64.sqrt();
        for w in [self.b - u, self.b + u] {
            if l < w && w < r {
                let g = self.slope(w).1;
                lo = lo.min(g);
                hi = hi.max(g);
            }
        }
        (lo, hi)
    }
}

/// Intervals of the crossing search's uniform grid at least (more where τ asks for them).
const UNIFORM_SAMPLES: f64 = 32.0;

/// Bisections of one interval of the partition before a point where φ' and φ'' both vanish
/// (a degenerate extremum) is taken as a sample as it stands: 2^-60 of the interval.
const EXTREMA_MAX_DEPTH: u32 = 60;

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
        Ok(Self::with_roots(a, b, c, p, q, p_roots, q_roots))
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
        Ok(Self::with_roots(a, b, c, p.to_vec(), q, p_roots, q_roots))
    }

    /// The loop with its polynomials' roots, and the phase terms derived from them.
    fn with_roots(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        p: Vec<f64>,
        q: Vec<f64>,
        p_roots: Vec<Complex64>,
        q_roots: Vec<Complex64>,
    ) -> Self {
        let phase_terms = p_roots
            .iter()
            .map(|z| (1.0, z))
            .chain(q_roots.iter().map(|w| (-1.0, w)))
            .filter(|(_, z)| z.re != 0.0)
            .map(|(sign, z)| PhaseTerm {
                sign,
                a: -z.re,
                b: z.im,
            })
            .collect();
        // arg(iω − z) = atan((ω − b)/a) + π·[a < 0] for a root z = −a + ib off the axis (the
        // ±π/2 of a root on it is φ's own convention), and arg q(iω) has π more when q's
        // leading coefficient is negative
        let right_half = p_roots
            .iter()
            .chain(&q_roots)
            .filter(|z| z.re > 0.0)
            .count();
        let negative_lead = q.last().is_some_and(|&x| x < 0.0);
        let phase_offset_odd = (right_half + usize::from(negative_lead)) % 2 == 1;
        Self {
            a,
            b,
            c,
            p,
            q,
            p_roots,
            q_roots,
            phase_terms,
            phase_offset_odd,
        }
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
        let lo = floor_small((approx - bound) / PI);
        if lo == floor_small((approx + bound) / PI) {
            return (lo, lo + 1.0);
        }
        let (phi, _) = self.phase(omega, tau);
        ((phi / PI).floor(), (phi / PI).ceil())
    }

    /// φ'(ω) and φ''(ω).
    fn phase_slope(&self, omega: f64, tau: f64) -> (f64, f64) {
        self.phase_terms.iter().fold((tau, 0.0), |(d1, d2), t| {
            let (s1, s2) = t.slope(omega);
            (d1 + s1, d2 + s2)
        })
    }

    /// Every ω inside the `partition`'s intervals where φ has an extremum (φ' changes sign),
    /// certified: on each interval the exact ranges of the Lorentzian terms bound φ' (and
    /// φ''); an interval where φ' has one sign holds no extremum, one where φ'' has one sign
    /// holds one at most (found by safeguarded Newton on φ' when φ' changes sign between its
    /// ends), any other is bisected — up to [`EXTREMA_MAX_DEPTH`] times, after which its
    /// midpoint is returned (φ' and φ'' vanish together there: a sample too many is harmless).
    /// Between the partition points and the returned extrema φ is then monotone.
    fn phase_extrema(&self, tau: f64, partition: &[f64]) -> Vec<f64> {
        let range = |l: f64, r: f64, part: fn(&PhaseTerm, f64, f64) -> (f64, f64), base: f64| {
            let (mut lo, mut hi, mut size) = (base, base, base.abs());
            for t in &self.phase_terms {
                let (a, b) = part(t, l, r);
                lo += a;
                hi += b;
                size += a.abs().max(b.abs());
            }
            // a sign is certified only beyond the rounding of the sums
            let margin = 64.0 * f64::EPSILON * size;
            (lo - margin, hi + margin)
        };
        let mut extrema = Vec::new();
        let mut stack: Vec<(f64, f64, u32)> = partition
            .windows(2)
            .filter(|w| w[1] > w[0])
            .map(|w| (w[0], w[1], 0))
            .collect();
        while let Some((l, r, depth)) = stack.pop() {
            let (lo, hi) = range(l, r, PhaseTerm::slope_range, tau);
            if lo > 0.0 || hi < 0.0 {
                continue; // φ monotone on [l, r]
            }
            let (lo2, hi2) = range(l, r, PhaseTerm::curvature_range, 0.0);
            if lo2 > 0.0 || hi2 < 0.0 {
                // φ' monotone: an extremum inside only where φ' changes sign
                let (fl, fr) = (self.phase_slope(l, tau).0, self.phase_slope(r, tau).0);
                if fl * fr < 0.0 {
                    extrema.push(self.solve_slope_zero(l, r, fl < 0.0, tau));
                }
                continue;
            }
            let m = 0.5 * (l + r);
            if depth == EXTREMA_MAX_DEPTH || m <= l || m >= r {
                extrema.push(m);
            } else {
                stack.push((l, m, depth + 1));
                stack.push((m, r, depth + 1));
            }
        }
        extrema
    }

    /// The zero of φ' on [lo, hi] where φ' is monotone and changes sign (`increasing`: φ' < 0
    /// at lo), by Newton with φ'' safeguarded by bisection.
    fn solve_slope_zero(&self, lo: f64, hi: f64, increasing: bool, tau: f64) -> f64 {
        bracketed_newton(lo, hi, increasing, (4.0 * f64::EPSILON, 0.0), |x| {
            self.phase_slope(x, tau)
        })
    }

    /// A lower bound of |D(ω)| = |p(iω)|/|q(iω)| for ω in [l, r]: each factor |iω − z| is
    /// smallest where ω is nearest Im z.
    fn gain_magnitude_lower_bound(&self, l: f64, r: f64) -> f64 {
        let nearest = |z: &Complex64| {
            let u = if z.im < l {
                l - z.im
            } else if z.im > r {
                z.im - r
            } else {
                0.0
            };
            (z.re * z.re + u * u).sqrt()
        };
        let farthest = |z: &Complex64| {
            let u = (l - z.im).abs().max((r - z.im).abs());
            (z.re * z.re + u * u).sqrt()
        };
        let num: f64 = self.p_roots.iter().map(nearest).product();
        let den: f64 = self.q_roots.iter().map(farthest).product::<f64>()
            * self.q.last().map_or(0.0, |x| x.abs());
        num / den
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
    ///
    /// # Errors
    /// [`StabilityError::InvalidDelay`] for a negative or non-finite τ,
    /// [`StabilityError::NonFinite`] for a gain limit that is not positive and finite,
    /// [`StabilityError::UnboundedCrossings`] if the loop keeps its gain at high frequency.
    pub fn crossings(&self, tau: f64, d_lim: f64) -> Result<Vec<Crossing>> {
        if !(d_lim.is_finite() && d_lim > 0.0) {
            return Err(StabilityError::NonFinite { what: "gain limit" });
        }
        self.crossings_between(tau, -d_lim, d_lim)
    }

    /// The crossings with `d_lo` ≤ D ≤ `d_hi` (d_lo ≤ 0 ≤ d_hi, not both 0), sorted by D:
    /// [`RankOneFeedback::crossings`] restricted to one sign of the gain where only that is
    /// needed (the levels of the other sign are not solved for).
    fn crossings_between(&self, tau: f64, d_lo: f64, d_hi: f64) -> Result<Vec<Crossing>> {
        if !(tau.is_finite() && tau >= 0.0) {
            return Err(StabilityError::InvalidDelay { tau });
        }
        let d_lim = d_lo.abs().max(d_hi.abs());
        let within = |d: f64| d.is_finite() && d_lo <= d && d <= d_hi;
        let mut out = Vec::new();
        if self.q.is_empty() {
            return Ok(out);
        }
        if let Some(s) = self.static_crossing(tau).filter(|s| within(s.d)) {
            out.push(s);
        }
        let w_max = self.omega_bound(d_lim)?;
        let samples = self.phase_samples(tau, w_max, d_lim)?;
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
        // which levels can give a gain in [d_lo, d_hi]: D > 0 exactly when m + K is odd
        let wanted_parity = |m: i64| {
            let positive = (m.rem_euclid(2) == 1) != self.phase_offset_odd;
            if positive { d_hi > 0.0 } else { d_lo < 0.0 }
        };
        for &w in samples.iter().skip(1) {
            // the levels mπ between the samples: prev < mπ ≤ φ where φ increased, φ ≤ mπ <
            // prev where it decreased (⌊·/π⌋ and ⌈·/π⌉ of φ, which say which)
            let (floor, ceil) = self.phase_levels(w, tau);
            let (lo_m, hi_m) = if floor > prev.0 || (floor == prev.0 && ceil > prev.1) {
                (prev.0 as i64 + 1, floor as i64)
            } else {
                (ceil as i64, prev.1 as i64 - 1)
            };
            let reachable =
                lo_m <= hi_m && self.gain_magnitude_lower_bound(prev_w, w) <= d_lim * (1.0 + 1e-9);
            for m in (lo_m..=hi_m).filter(|&m| reachable && wanted_parity(m)) {
                let omega = self.solve_level(prev_w, w, m as f64 * pi, tau);
                let d = self.gain_at(omega, tau);
                if within(d) {
                    out.push(self.dynamic_crossing(omega, d, tau));
                }
            }
            prev_w = w;
            prev = (floor, ceil);
        }
        out.sort_by(|a, b| a.d.total_cmp(&b.d).then(a.omega.total_cmp(&b.omega)));
        Ok(out)
    }

    /// The sample frequencies of the crossing search on [0, `w_max`], sorted: points around
    /// every root's imaginary part at its damping's scale, every extremum of φ between those
    /// (φ is monotone between samples from these alone), and a uniform grid of
    /// [`UNIFORM_SAMPLES`] intervals or half a period of e^{−iωτ}, whichever is finer, which
    /// keeps each level's bracket short and the gain bound that skips it tight.
    fn phase_samples(&self, tau: f64, w_max: f64, d_lim: f64) -> Result<Vec<f64>> {
        let base = if tau > 0.0 {
            (std::f64::consts::PI / (2.0 * tau)).min(w_max / UNIFORM_SAMPLES)
        } else {
            w_max / UNIFORM_SAMPLES
        };
        // beyond a million samples the bound is no bound (a loop that keeps its gain far
        // beyond the roots' frequencies)
        let nb = (w_max / base).ceil();
        if nb > 1e6 {
            return Err(StabilityError::UnboundedCrossings {
                d_lim,
                degree_p: self.p_roots.len(),
                degree_q: self.q_roots.len(),
            });
        }
        const OFFS: [f64; 13] = [
            -8.0, -4.0, -2.0, -1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0,
        ];
        // the partition on which the extrema are certified: the roots' neighbourhoods, where
        // the Lorentzians of φ' vary, and the ends
        let mut samples = vec![0.0, w_max];
        for z in self.p_roots.iter().chain(&self.q_roots) {
            let (b, a) = (z.im.abs(), z.re.abs());
            samples.extend(
                OFFS.iter()
                    .map(|o| b + o * a)
                    .filter(|&w| w > 0.0 && w < w_max),
            );
        }
        samples.sort_by(f64::total_cmp);
        samples.dedup();
        let extrema = self.phase_extrema(tau, &samples);
        samples.extend(extrema);
        samples.sort_by(f64::total_cmp);
        // merged with the (sorted) uniform grid
        let uniform = (1..nb as usize)
            .map(|i| i as f64 * base)
            .take_while(|&w| w < w_max);
        let mut merged = Vec::with_capacity(samples.len() + nb as usize);
        let mut rest = samples.into_iter().peekable();
        for w in uniform {
            while let Some(x) = rest.next_if(|&x| x <= w) {
                merged.push(x);
            }
            merged.push(w);
        }
        merged.extend(rest);
        merged.dedup();
        Ok(merged)
    }

    /// The crossing at a level point ω > 0 with gain d: its direction Re(dλ/dD).
    fn dynamic_crossing(&self, omega: f64, d: f64, tau: f64) -> Crossing {
        let l = Complex64::new(0.0, omega);
        let q = horner2(&self.q, l).0;
        let (_, df) = self.characteristic(l, d, tau);
        let dl = -(-l * tau).exp() * q / df;
        Crossing {
            d,
            omega,
            direction: if dl.re.is_finite() { dl.re } else { 0.0 },
            multiplicity: 2,
        }
    }

    /// Solves φ(ω) = level on [lo, hi] (φ − level changes sign there) by safeguarded Newton.
    fn solve_level(&self, lo: f64, hi: f64, level: f64, tau: f64) -> f64 {
        let increasing = self.phase(lo, tau).0 - level < 0.0;
        bracketed_newton(lo, hi, increasing, (1e-15, 1e-300), |x| {
            let (phi, dphi) = self.phase(x, tau);
            (phi - level, dphi)
        })
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
        if !d.is_finite() {
            return Err(StabilityError::NonFinite { what: "gain D" });
        }
        // only the crossings between 0 and d count
        let reach = d.abs().max(f64::MIN_POSITIVE);
        let c = if d >= 0.0 {
            self.crossings_between(tau, 0.0, reach)?
        } else {
            self.crossings_between(tau, -reach, 0.0)?
        };
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

/// The zero of f on [lo, hi] where f changes sign (`increasing`: f < 0 at lo), by Newton
/// safeguarded by bisection; `eval(x)` = (f(x), f'(x)). It stops when a step is at most
/// `rel`·max(|x|, `floor`) or the bracket [a, b] at most 4ε·|b| wide.
fn bracketed_newton(
    lo: f64,
    hi: f64,
    increasing: bool,
    (rel, floor): (f64, f64),
    mut eval: impl FnMut(f64) -> (f64, f64),
) -> f64 {
    let (mut a, mut b) = (lo, hi);
    let mut x = 0.5 * (a + b);
    for _ in 0..200 {
        let (f, df) = eval(x);
        if f == 0.0 {
            return x;
        }
        if (f < 0.0) == increasing {
            a = x;
        } else {
            b = x;
        }
        // x is now a or b, so a step that is not finite, or none (f' not finite), is not
        // strictly inside the bracket: bisection then
        let newton = x - f / df;
        let next = if newton > a && newton < b {
            newton
        } else {
            0.5 * (a + b)
        };
        if (next - x).abs() <= rel * x.abs().max(floor) || b - a <= 4.0 * f64::EPSILON * b.abs() {
            return next;
        }
        x = next;
    }
    x
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
    fn floor_small_is_floor() {
        // reference: f64::floor, on integers, their neighbours, halves, negatives, the limits
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
            1e300,
        ];
        for k in [
            1.0f64,
            2.0,
            3.0,
            1e6,
            4.5e15,
            9.007_199_254_740_992e15,
            4.6e18,
            5e18,
        ] {
            for x in [k, -k] {
                xs.extend([x, x.next_up(), x.next_down(), x + 0.5, x - 0.5]);
            }
        }
        for x in xs {
            let (got, want) = (floor_small(x), x.floor());
            assert!(
                got == want || (got.is_nan() && want.is_nan()),
                "{x}: {got} vs {want}"
            );
        }
    }

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

    /// The independent reference for the extrema: φ'(ω)·Π_k Q_k(ω) is the polynomial
    /// τ Π Q_k + Σ_k s_k a_k Π_{j≠k} Q_j (Q_k = (ω − b_k)² + a_k²); its real roots in (0, w_max)
    /// where it changes sign, from the companion matrix.
    fn slope_polynomial_extrema(f: &RankOneFeedback, tau: f64, w_max: f64) -> Vec<f64> {
        let terms = &f.phase_terms;
        let quadratic = |t: &PhaseTerm| vec![t.b * t.b + t.a * t.a, -2.0 * t.b, 1.0];
        let product = |skip: Option<usize>| {
            terms
                .iter()
                .enumerate()
                .filter(|&(k, _)| Some(k) != skip)
                .fold(vec![1.0], |acc, (_, t)| poly_mul(&acc, &quadratic(t)))
        };
        let mut numerator: Vec<f64> = product(None).iter().map(|c| tau * c).collect();
        for (k, t) in terms.iter().enumerate() {
            for (i, c) in product(Some(k)).iter().enumerate() {
                numerator[i] += t.sign * t.a * c;
            }
        }
        while numerator.last() == Some(&0.0) {
            numerator.pop();
        }
        let value = |w: f64| numerator.iter().rev().fold(0.0, |acc, c| acc * w + c);
        let mut roots: Vec<f64> = polynomial_roots(&numerator)
            .unwrap()
            .iter()
            .filter(|r| r.im.abs() <= 1e-9 * (1.0 + r.re.abs()) && r.re > 0.0 && r.re < w_max)
            .map(|r| r.re)
            .filter(|&w| {
                let h = 1e-6 * w.max(1.0);
                value(w - h) * value(w + h) < 0.0
            })
            .collect();
        roots.sort_by(f64::total_cmp);
        roots
    }

    /// Seeded random loops: n states, entries in [−3, 3), a lightly damped diagonal.
    fn random_loops(count: usize, n: usize, seed: u64) -> Vec<RankOneFeedback> {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            6.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 3.0
        };
        (0..count)
            .map(|_| {
                let a = DMatrix::from_fn(
                    n,
                    n,
                    |i, j| {
                        if i == j { -0.1 + 0.05 * next() } else { next() }
                    },
                );
                let b = nalgebra::DVector::from_fn(n, |_, _| next());
                let c = nalgebra::RowDVector::from_fn(n, |_, _| next());
                RankOneFeedback::from_state_space(&a, &b, &c).unwrap()
            })
            .collect()
    }

    #[test]
    fn certified_extrema_are_the_real_roots_of_the_slope_polynomial() {
        // reference: the sign-changing real roots of the polynomial φ'·ΠQ_k (companion
        // matrix); every one is found, nothing else is, to 1e-7 relative (the polynomial's
        // roots are that sensitive; the certified ones are Newton-polished on φ' itself)
        let mut checked = 0;
        for (k, f) in random_loops(40, 4, 21)
            .iter()
            .chain(&random_loops(20, 6, 22))
            .enumerate()
        {
            for tau in [0.0, 0.3, 1.7] {
                let w_max = f.omega_bound(10.0).unwrap();
                let mut partition = vec![0.0, w_max];
                partition.extend(
                    f.phase_terms
                        .iter()
                        .map(|t| t.b.abs())
                        .filter(|&w| w < w_max),
                );
                partition.sort_by(f64::total_cmp);
                let mut got = f.phase_extrema(tau, &partition);
                got.sort_by(f64::total_cmp);
                let want = slope_polynomial_extrema(f, tau, w_max);
                assert_eq!(
                    got.len(),
                    want.len(),
                    "loop {k}, τ = {tau}: {got:?} vs {want:?}"
                );
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        (g - w).abs() <= 1e-7 * w.max(1.0),
                        "loop {k}, τ = {tau}: {g} vs {w}"
                    );
                }
                checked += want.len();
            }
        }
        assert!(
            checked > 20,
            "only {checked} extrema met: the test checks too little"
        );
    }

    #[test]
    fn one_signed_crossings_are_the_crossings_of_that_sign() {
        // the parity rule (D > 0 exactly at the levels with m + K odd) and the magnitude
        // bound skip only levels whose crossing lies outside the range: the one-signed search
        // returns the same crossings, bit for bit, as the full one filtered by sign
        let mut met = 0;
        for (k, f) in random_loops(30, 4, 23).iter().enumerate() {
            for tau in [0.0, 0.4, 2.0] {
                let all = f.crossings(tau, 5.0).unwrap();
                met += all.len();
                let positive = f.crossings_between(tau, 0.0, 5.0).unwrap();
                let negative = f.crossings_between(tau, -5.0, 0.0).unwrap();
                let filtered = |keep: fn(f64) -> bool| -> Vec<Crossing> {
                    all.iter().filter(|c| keep(c.d)).copied().collect()
                };
                assert_eq!(positive, filtered(|d| d >= 0.0), "loop {k}, τ = {tau}");
                assert_eq!(negative, filtered(|d| d <= 0.0), "loop {k}, τ = {tau}");
            }
        }
        assert!(
            met > 50,
            "only {met} crossings met: the test checks too little"
        );
    }
}
