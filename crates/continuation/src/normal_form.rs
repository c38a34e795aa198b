//! Normal forms of Hopf and double-Hopf points of equilibria of ODEs and constant-delay
//! DDEs x' = f(x(t), x(t−τ1), …, x(t−τk); p), from exact second and third derivatives
//! ([`Problem::second_derivative`], [`Problem::third_derivative`]).
//!
//! The formulas are those of Kuznetsov (Elements of Applied Bifurcation Theory, 3rd ed.,
//! eq. (3.20) and §8.7 for ODEs) carried over to DDEs with the characteristic matrix
//! Δ(λ) = λI − A0 − Σ_j A_j e^{−λτ_j} (as DDE-Biftool's `nmfm_hopf` / `nmfm_hoho` and
//! Janssens' thesis do). An eigenfunction φ(θ) = q e^{λθ} (θ ∈ [−τ_max, 0]) enters the
//! multilinear forms of f through its stacked values [q, q e^{−λτ1}, …, q e^{−λτk}], a
//! constant function h through [h, h, …, h].
//!
//! Normalisation (that of DDE-Biftool): Δ(iω) q = 0 with ‖q‖₂ = 1 (largest component real
//! and positive), pᴴ Δ(iω) = 0 with pᴴ Δ'(iω) q = 1, Δ'(λ) = I + Σ_j τ_j A_j e^{−λτ_j}.
//! The state near the equilibrium is x* + w q + w̄ q̄ + …, and on the centre manifold
//!
//! w' = iω w + c1 w|w|² + O(|w|⁵)   (Hopf),
//!
//! c1 = ½ pᴴ [C(φ, φ, φ̄) + B(φ̄, h20) + 2 B(φ, h11)],
//! h20 = Δ(2iω)⁻¹ B(φ, φ) e^{2iωθ},  h11 = Δ(0)⁻¹ B(φ, φ̄),
//!
//! with B, C the second and third derivatives of f. The first Lyapunov coefficient is
//! l1 = Re c1 / ω: l1 < 0 supercritical (stable cycles on the side where the equilibrium
//! is unstable), l1 > 0 subcritical. Its value depends on the normalisation of q (‖q‖ = 1
//! here, as in MatCont and DDE-Biftool), its sign does not.
//!
//! A problem that is only C¹ where the normal form would be computed
//! ([`Problem::smoothness`] = [`Smoothness::C1AtKinks`]) gets [`Error::NotSmooth`]: there is
//! no third derivative to evaluate, and criticality is decided from the cycles
//! ([`crate::criticality`]).

use crate::codim2::Linearisation;
use crate::error::{Error, Result};
use crate::problem::{Problem, Smoothness};
use crate::stability::Criticality;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::Serialize;

type C64 = Complex64;

/// The cubic normal form of a Hopf point (see the module docs): w' = iω w + c1 w|w|².
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HopfNormalForm {
    /// angular frequency ω > 0 of the critical pair \[rad / time unit\]
    pub omega: f64,
    /// cubic coefficient c1 (Re c1 sets the amplitude, Im c1 the frequency shift)
    pub c1: Complex64,
    /// first Lyapunov coefficient l1 = Re c1 / ω (‖q‖ = 1 normalisation)
    pub l1: f64,
    /// right eigenvector q: Δ(iω) q = 0, ‖q‖ = 1, largest component real positive
    pub q: Vec<Complex64>,
    /// left eigenvector p: pᴴ Δ(iω) = 0, pᴴ Δ'(iω) q = 1
    pub p: Vec<Complex64>,
}

impl HopfNormalForm {
    /// The normal form at the Hopf point of the equilibrium `x` for the parameters
    /// `params` with critical frequency `omega` (its sign is ignored).
    pub fn compute<P: Problem>(problem: &P, x: &[f64], params: &[f64], omega: f64) -> Result<Self> {
        let forms = Forms::new(problem, x, params, "the first Lyapunov coefficient")?;
        let omega = omega.abs();
        if omega.is_nan() || omega <= 0.0 || !omega.is_finite() {
            return Err(Error::InvalidInput(format!(
                "Hopf normal form needs a frequency ω > 0 (got {omega}); at ω = 0 the point is a \
                 Bogdanov-Takens point"
            )));
        }
        let lambda = C64::new(0.0, omega);
        let (q, p) = forms.null_vectors(lambda)?;
        let c1 = forms.hopf_c1(&q, &p, lambda)?;
        Ok(Self {
            omega,
            c1,
            l1: c1.re / omega,
            q,
            p,
        })
    }

    /// Criticality from the sign of l1 (None if l1 is 0 or not finite).
    pub fn criticality(&self) -> Option<Criticality> {
        if self.l1 < 0.0 {
            Some(Criticality::Supercritical)
        } else if self.l1 > 0.0 {
            Some(Criticality::Subcritical)
        } else {
            None
        }
    }
}

/// Which of Kuznetsov's two families the unfolding of a double-Hopf point belongs to
/// (ELABT §8.6.2): the sign of p11·p22.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum DoubleHopfCase {
    /// p11 p22 > 0
    Simple,
    /// p11 p22 < 0
    Difficult,
}

/// The cubic normal form of a double-Hopf point (ELABT §8.6, in DDE-Biftool's notation):
///
/// w1' = iω1 w1 + g2100 w1|w1|² + g1011 w1|w2|²,
/// w2' = iω2 w2 + g1110 w2|w1|² + g0021 w2|w2|²,
///
/// with p11 = Re g2100, p12 = Re g1011, p21 = Re g1110, p22 = Re g0021, θ = p12/p22,
/// δ = p21/p11. Pair 1 is the one passed first (on a Hopf curve: the continued pair).
/// θ and δ do not depend on the normalisation of the eigenvectors; swapping the pairs
/// swaps them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DoubleHopfNormalForm {
    /// the two critical frequencies ω1, ω2 \[rad / time unit\]
    pub omegas: [f64; 2],
    /// coefficient of w1|w1|² in the w1 equation
    pub g2100: Complex64,
    /// coefficient of w1|w2|² in the w1 equation
    pub g1011: Complex64,
    /// coefficient of w2|w1|² in the w2 equation
    pub g1110: Complex64,
    /// coefficient of w2|w2|² in the w2 equation
    pub g0021: Complex64,
    /// θ = p12 / p22
    pub theta: f64,
    /// δ = p21 / p11
    pub delta: f64,
    /// simple (p11 p22 > 0) or difficult (p11 p22 < 0) case
    pub case: DoubleHopfCase,
    /// Kuznetsov's subtype (ELABT §8.6.2): simple case "I" … "V", difficult case "VI" …
    /// "XI", from the signs of θ, δ and θδ − 1 (None when one of them is 0). In the simple
    /// case (θ < 0 < δ) is subtype III with the pairs swapped.
    pub subtype: Option<&'static str>,
}

impl DoubleHopfNormalForm {
    /// The normal form at the double-Hopf point of the equilibrium `x` for the parameters
    /// `params` with the critical frequencies `omegas` (signs ignored; must differ).
    pub fn compute<P: Problem>(
        problem: &P,
        x: &[f64],
        params: &[f64],
        omegas: [f64; 2],
    ) -> Result<Self> {
        let forms = Forms::new(problem, x, params, "the double-Hopf normal form")?;
        let [w1, w2] = [omegas[0].abs(), omegas[1].abs()];
        if !(w1 > 0.0 && w2 > 0.0) || (w1 - w2).abs() <= 1e-9 * (w1 + w2) {
            return Err(Error::InvalidInput(format!(
                "double-Hopf normal form needs two different frequencies > 0 (got {w1}, {w2}); \
                 equal frequencies are a 1:1 resonance"
            )));
        }
        let (l1, l2) = (C64::new(0.0, w1), C64::new(0.0, w2));
        let (q1, p1) = forms.null_vectors(l1)?;
        let (q2, p2) = forms.null_vectors(l2)?;
        let zero = C64::new(0.0, 0.0);
        let (f1, f2) = (forms.stack(&q1, l1), forms.stack(&q2, l2));
        let (f1b, f2b) = (conj(&f1), conj(&f2));
        // quadratic centre manifold: h_{jklm} = Δ(λ)⁻¹ B(·, ·) e^{λθ}
        let h = |a: &[C64], b: &[C64], lambda: C64| -> Result<Vec<C64>> {
            let rhs = forms.b(a, b)?;
            let v = forms.solve(lambda, rhs)?;
            Ok(forms.stack(&v, lambda))
        };
        let h1100 = h(&f1, &f1b, zero)?;
        let h2000 = h(&f1, &f1, 2.0 * l1)?;
        let h1010 = h(&f1, &f2, l1 + l2)?;
        let h1001 = h(&f1, &f2b, l1 - l2)?;
        let h1001b = conj(&h1001);
        let h0020 = h(&f2, &f2, 2.0 * l2)?;
        let h0011 = h(&f2, &f2b, zero)?;
        let pr = |p: &[C64], terms: &[Vec<C64>]| -> C64 {
            let mut s = vec![zero; p.len()];
            for t in terms {
                s.iter_mut().zip(t).for_each(|(a, b)| *a += *b);
            }
            pair(p, &s)
        };
        let g2100 = 0.5
            * pr(
                &p1,
                &[
                    scaled(&forms.b(&h1100, &f1)?, 2.0),
                    forms.b(&h2000, &f1b)?,
                    forms.c(&f1, &f1, &f1b)?,
                ],
            );
        let g1011 = pr(
            &p1,
            &[
                forms.b(&h0011, &f1)?,
                forms.b(&h1001, &f2)?,
                forms.b(&h1010, &f2b)?,
                forms.c(&f1, &f2, &f2b)?,
            ],
        );
        let g1110 = pr(
            &p2,
            &[
                forms.b(&h1001b, &f1)?,
                forms.b(&h1010, &f1b)?,
                forms.b(&h1100, &f2)?,
                forms.c(&f1, &f1b, &f2)?,
            ],
        );
        let g0021 = 0.5
            * pr(
                &p2,
                &[
                    scaled(&forms.b(&h0011, &f2)?, 2.0),
                    forms.b(&h0020, &f2b)?,
                    forms.c(&f2, &f2, &f2b)?,
                ],
            );
        let (p11, p12, p21, p22) = (g2100.re, g1011.re, g1110.re, g0021.re);
        let (theta, delta) = (p12 / p22, p21 / p11);
        let case = if p11 * p22 > 0.0 {
            DoubleHopfCase::Simple
        } else {
            DoubleHopfCase::Difficult
        };
        Ok(Self {
            omegas: [w1, w2],
            g2100,
            g1011,
            g1110,
            g0021,
            theta,
            delta,
            case,
            subtype: subtype(case, theta, delta),
        })
    }
}

/// Kuznetsov's subtypes of the double-Hopf unfolding from the signs of θ, δ, θδ − 1.
fn subtype(case: DoubleHopfCase, theta: f64, delta: f64) -> Option<&'static str> {
    let (t, d, e) = (theta, delta, theta * delta - 1.0);
    if !(t != 0.0 && d != 0.0 && e != 0.0 && t.is_finite() && d.is_finite()) {
        return None;
    }
    let (t, d, e) = (t > 0.0, d > 0.0, e > 0.0);
    Some(match (case, t, d, e) {
        (DoubleHopfCase::Simple, true, true, true) => "I",
        (DoubleHopfCase::Simple, true, true, false) => "II",
        (DoubleHopfCase::Simple, true, false, _) | (DoubleHopfCase::Simple, false, true, _) => {
            "III"
        }
        (DoubleHopfCase::Simple, false, false, true) => "IV",
        (DoubleHopfCase::Simple, false, false, false) => "V",
        (DoubleHopfCase::Difficult, true, true, true) => "VI",
        (DoubleHopfCase::Difficult, true, true, false) => "VII",
        (DoubleHopfCase::Difficult, true, false, _) => "VIII",
        (DoubleHopfCase::Difficult, false, true, _) => "IX",
        (DoubleHopfCase::Difficult, false, false, true) => "X",
        (DoubleHopfCase::Difficult, false, false, false) => "XI",
    })
}

/// The multilinear forms of f at an equilibrium and the characteristic matrix.
pub(crate) struct Forms<'a, P: Problem> {
    problem: &'a P,
    params: Vec<f64>,
    lin: Linearisation,
}

impl<'a, P: Problem> Forms<'a, P> {
    /// Linearise at the equilibrium x; `what` names the quantity for the error message of
    /// a non-smooth problem.
    pub fn new(problem: &'a P, x: &[f64], params: &[f64], what: &'static str) -> Result<Self> {
        if problem.smoothness() != Smoothness::Smooth {
            return Err(Error::NotSmooth { what });
        }
        let mut lin = Linearisation::new(problem);
        if x.len() != lin.n {
            return Err(Error::InvalidInput(format!(
                "equilibrium of length {} for a system of dimension {}",
                x.len(),
                lin.n
            )));
        }
        lin.set(problem, x, params);
        if lin.jac.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                parameter: f64::NAN,
            });
        }
        Ok(Self {
            problem,
            params: params.to_vec(),
            lin,
        })
    }

    /// Δ(λ) = λI − Σ_d A_d e^{−λτ_d} (τ_0 = 0)
    fn delta(&self, lambda: C64) -> DMatrix<C64> {
        let n = self.lin.n;
        let e: Vec<C64> = self.lin.tau.iter().map(|&t| (-lambda * t).exp()).collect();
        DMatrix::from_fn(n, n, |i, m| {
            let id = if i == m { lambda } else { C64::new(0.0, 0.0) };
            id - (0..=self.lin.k)
                .map(|d| e[d] * self.lin.a(d, i, m))
                .sum::<C64>()
        })
    }

    /// Δ'(λ) = I + Σ_d τ_d A_d e^{−λτ_d}
    fn delta_prime(&self, lambda: C64) -> DMatrix<C64> {
        let n = self.lin.n;
        DMatrix::from_fn(n, n, |i, m| {
            let id = if i == m { 1.0 } else { 0.0 };
            C64::new(id, 0.0)
                + (0..=self.lin.k)
                    .map(|d| {
                        let t = self.lin.tau[d];
                        (-lambda * t).exp() * t * self.lin.a(d, i, m)
                    })
                    .sum::<C64>()
        })
    }

    /// the stacked values [v, v e^{−λτ1}, …] of the function θ ↦ v e^{λθ}
    fn stack(&self, v: &[C64], lambda: C64) -> Vec<C64> {
        self.lin
            .tau
            .iter()
            .flat_map(|&t| {
                let e = (-lambda * t).exp();
                v.iter().map(move |z| z * e)
            })
            .collect()
    }

    /// Δ(λ)⁻¹ rhs
    fn solve(&self, lambda: C64, rhs: Vec<C64>) -> Result<Vec<C64>> {
        let n = self.lin.n;
        let d = self.delta(lambda);
        let scale = d.iter().fold(0.0f64, |m, z| m.max(z.norm())).max(1.0);
        let lu = d.lu();
        let sol = lu
            .solve(&DVector::from_vec(rhs))
            .filter(|s| s.iter().all(|z| z.is_finite()))
            .ok_or_else(|| Error::SingularSystem {
                size: n,
                what: format!(
                    "characteristic matrix Δ({lambda}) in the normal form: a root at λ = {lambda} \
                     (scale {scale:e}) makes the point of higher codimension (zero-Hopf, \
                     resonant double-Hopf)"
                ),
            })?;
        Ok(sol.iter().copied().collect())
    }

    /// (q, p): Δ(λ) q = 0 (‖q‖ = 1, largest component real positive), pᴴ Δ(λ) = 0 with
    /// pᴴ Δ'(λ) q = 1, from the SVD of Δ(λ)
    fn null_vectors(&self, lambda: C64) -> Result<(Vec<C64>, Vec<C64>)> {
        let n = self.lin.n;
        let svd = self.delta(lambda).svd(true, true);
        let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
            return Err(Error::Eigen {
                size: n,
                message: "SVD of the characteristic matrix".into(),
            });
        };
        let k = (0..n)
            .min_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]))
            .unwrap_or(0);
        let mut q: Vec<C64> = (0..n).map(|j| vt[(k, j)].conj()).collect();
        let big = (0..n)
            .max_by(|&a, &b| q[a].norm().total_cmp(&q[b].norm()))
            .unwrap_or(0);
        let phase = q[big] / q[big].norm();
        q.iter_mut().for_each(|z| *z /= phase);
        let p: Vec<C64> = (0..n).map(|i| u[(i, k)]).collect();
        let dq = self.delta_prime(lambda) * DVector::from_column_slice(&q);
        let s = pair(&p, dq.as_slice());
        if s.norm().is_nan() || s.norm() <= 1e-12 {
            return Err(Error::SingularSystem {
                size: n,
                what: format!(
                    "normalisation pᴴΔ'(λ)q = {s} of the eigenvectors at λ = {lambda}: the root \
                     is not simple (non-semisimple or double)"
                ),
            });
        }
        let p = p.iter().map(|z| z / s.conj()).collect();
        Ok((q, p))
    }

    /// c1 = ½ pᴴ [C(φ, φ, φ̄) + B(φ̄, h20) + 2 B(φ, h11)] at λ = iω
    fn hopf_c1(&self, q: &[C64], p: &[C64], lambda: C64) -> Result<C64> {
        let phi = self.stack(q, lambda);
        let phib = conj(&phi);
        let h20 = self.solve(2.0 * lambda, self.b(&phi, &phi)?)?;
        let h20 = self.stack(&h20, 2.0 * lambda);
        let h11 = self.solve(C64::new(0.0, 0.0), self.b(&phi, &phib)?)?;
        let h11 = self.stack(&h11, C64::new(0.0, 0.0));
        let mut s = self.c(&phi, &phi, &phib)?;
        let b1 = self.b(&phib, &h20)?;
        let b2 = self.b(&phi, &h11)?;
        for i in 0..s.len() {
            s[i] += b1[i] + 2.0 * b2[i];
        }
        Ok(0.5 * pair(p, &s))
    }

    /// B(a, b) for complex stacked directions (four real evaluations)
    fn b(&self, a: &[C64], b: &[C64]) -> Result<Vec<C64>> {
        let n = self.lin.n;
        let (ar, ai, br, bi) = (re(a), im(a), re(b), im(b));
        let mut out = vec![C64::new(0.0, 0.0); n];
        let mut buf = vec![0.0; n];
        let parts: [(&[f64], &[f64], C64); 4] = [
            (&ar, &br, C64::new(1.0, 0.0)),
            (&ai, &bi, C64::new(-1.0, 0.0)),
            (&ar, &bi, C64::new(0.0, 1.0)),
            (&ai, &br, C64::new(0.0, 1.0)),
        ];
        for (x, y, f) in parts {
            self.problem
                .second_derivative(&self.lin.args, &self.params, x, y, &mut buf)?;
            out.iter_mut().zip(&buf).for_each(|(o, v)| *o += f * *v);
        }
        finite(out)
    }

    /// C(a, b, c) for complex stacked directions (eight real evaluations)
    fn c(&self, a: &[C64], b: &[C64], c: &[C64]) -> Result<Vec<C64>> {
        let n = self.lin.n;
        let split = |v: &[C64]| [re(v), im(v)];
        let (sa, sb, sc) = (split(a), split(b), split(c));
        let mut out = vec![C64::new(0.0, 0.0); n];
        let mut buf = vec![0.0; n];
        let i_pow = [
            C64::new(1.0, 0.0),
            C64::new(0.0, 1.0),
            C64::new(-1.0, 0.0),
            C64::new(0.0, -1.0),
        ];
        for ia in 0..2 {
            for ib in 0..2 {
                for ic in 0..2 {
                    self.problem.third_derivative(
                        &self.lin.args,
                        &self.params,
                        &sa[ia],
                        &sb[ib],
                        &sc[ic],
                        &mut buf,
                    )?;
                    let f = i_pow[ia + ib + ic];
                    out.iter_mut().zip(&buf).for_each(|(o, v)| *o += f * *v);
                }
            }
        }
        finite(out)
    }
}

fn finite(v: Vec<C64>) -> Result<Vec<C64>> {
    if v.iter().all(|z| z.is_finite()) {
        Ok(v)
    } else {
        Err(Error::NonFinite {
            parameter: f64::NAN,
        })
    }
}

/// pᴴ v = Σ conj(p_i) v_i
fn pair(p: &[C64], v: &[C64]) -> C64 {
    p.iter().zip(v).map(|(a, b)| a.conj() * b).sum()
}

fn conj(v: &[C64]) -> Vec<C64> {
    v.iter().map(|z| z.conj()).collect()
}

fn scaled(v: &[C64], s: f64) -> Vec<C64> {
    v.iter().map(|z| z * s).collect()
}

fn re(v: &[C64]) -> Vec<f64> {
    v.iter().map(|z| z.re).collect()
}

fn im(v: &[C64]) -> Vec<f64> {
    v.iter().map(|z| z.im).collect()
}
