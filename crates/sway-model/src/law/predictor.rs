//! The predictor: u(t) = −K·x̂(t), with x̂(t) the state predicted τ ahead from the state
//! measured at t − τ and the commands applied in \[t − τ, t\],
//!
//! x̂(t) = e^{Â τ}·x(t − τ) + ∫_{t−τ}^{t} e^{Â (t − s)}·B̂·u(s) ds,
//!
//! through a linear model (Â, B̂) of the vehicle at the current speed (finite spectrum
//! assignment; the Smith-predictor structure in state form, with a distributed delay).
//! For the yaw-rate structure K = D·C̃, so the command is −D·ψ̇_p(t) with ψ̇_p = C̃·x̂.
//!
//! **What it measures and assumes.** It needs the whole reduced state (σ1, σ2, σ3, θ) at
//! t − τ — the yaw rate, the hitch angle and its rate and the lateral hitch velocity, from
//! a yaw-rate sensor, a hitch-angle sensor and an observer — and the commands it sent in
//! the last τ seconds (it keeps them). It assumes the vehicle is its linear model about
//! straight running at the measured speed: the model is a separate vehicle file, so a
//! design can be judged with a model that is off (trailer mass, inertia, centre of gravity).
//!
//! **Characteristic function.** With x = X e^{λt} and u = U e^{λt} the plant gives
//! (λI − A) X = B U and the law gives
//! U = −K [e^{Âτ} e^{−λτ} X + (λI − Â)^{-1} (I − e^{Âτ} e^{−λτ}) B̂ U], so the roots are the
//! zeros of 1 + K e^{Âτ}(λI − A)^{-1}B e^{−λτ} + K(λI − Â)^{-1}(I − e^{Âτ}e^{−λτ})B̂.
//! Multiplied by p(λ) = det(λI − A) and p̂(λ) = det(λI − Â) this is the quasi-polynomial
//!
//! P₀(λ) + e^{−λτ} P₁(λ),  P₀ = p p̂ + p·K adj(λI − Â) B̂,
//! P₁ = p̂·(K e^{Âτ}) adj(λI − A) B − p·K adj(λI − Â) (e^{Âτ} B̂),
//!
//! monic of degree 2n with deg P₁ < 2n: retarded, so [`stability::RankOneFeedback`] counts
//! its unstable roots exactly. Clearing p̂ adds the eigenvalues of Â as roots (the
//! distributed term is entire: (λI − Â)^{-1}(I − e^{Âτ}e^{−λτ}) has no poles), which are not
//! roots of the loop: they are subtracted from counts and removed from root lists.
//!
//! **Closed form.** With a perfect model (Â, B̂) = (A, B) the two delayed terms cancel and
//! the loop's roots are the eigenvalues of A − B K, whatever τ: the spectrum of the delay-free
//! loop (tested against eig(A − B K)). `sway::control::LinearLoop` builds that delay-free loop
//! directly when the model is the plant ([`is_perfect_model`]): the cleared form would carry
//! P₁ as a round-off remainder (≈ 1e-16 of P₀'s coefficients) instead of 0, and
//! ε·e^{−λτ}P₁ has infinitely many roots near Re λ ≈ ln ε/τ that no spectral discretisation
//! resolves — asking it for more than the loop's n roots then fails. The integral must be computed as the finite integral it is (a quadrature
//! of the stored commands): realised as the ODE ż = Âz + B̂u − e^{Âτ}B̂u(t − τ) it would
//! carry the unstable eigenvalues of Â as hidden modes.

use nalgebra::{DMatrix, DVector, Matrix4, RowDVector, RowVector4, Vector4};
use stability::{Complex64, RankOneFeedback, StabilityError};

/// adj(λI − A) = Σ_{k=1}^{4} M_k λ^{4−k} and p(λ) = det(λI − A) (ascending coefficients),
/// by the Faddeev–LeVerrier recursion M_1 = I, M_k = A M_{k−1} + p_{5−k} I,
/// p_{4−k} = −tr(A M_k)/k.
fn adjugate(a: &Matrix4<f64>) -> ([Matrix4<f64>; 4], [f64; 5]) {
    let mut p = [0.0; 5];
    p[4] = 1.0;
    let mut m = [Matrix4::identity(); 4];
    for k in 1..=4 {
        if k > 1 {
            m[k - 1] = a * m[k - 2] + Matrix4::identity() * p[5 - k];
        }
        p[4 - k] = -(a * m[k - 1]).trace() / k as f64;
    }
    (m, p)
}

/// The polynomial r·adj(λI − A)·c (ascending coefficients, degree ≤ 3).
fn transfer(m: &[Matrix4<f64>; 4], r: &RowVector4<f64>, c: &Vector4<f64>) -> Vec<f64> {
    let mut out = vec![0.0; 4];
    for k in 1..=4 {
        out[4 - k] = (r * m[k - 1] * c)[(0, 0)];
    }
    out
}

fn mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

fn add(a: &[f64], b: &[f64], sign: f64) -> Vec<f64> {
    (0..a.len().max(b.len()))
        .map(|i| a.get(i).copied().unwrap_or(0.0) + sign * b.get(i).copied().unwrap_or(0.0))
        .collect()
}

/// The predictor loop on the plant (A, B) with the model (Â, B̂), gain row K and delay τ
/// as the cleared quasi-polynomial P₀ + e^{−λτ}P₁ (at gain 1), and its spurious roots (the
/// eigenvalues of Â).
///
/// # Errors
/// [`StabilityError`] if the coefficients are not finite or an eigensolver fails.
pub fn cleared_loop(
    a: &Matrix4<f64>,
    b: &Vector4<f64>,
    a_model: &Matrix4<f64>,
    b_model: &Vector4<f64>,
    k: &RowVector4<f64>,
    delay: f64,
) -> Result<(RankOneFeedback, Vec<Complex64>), StabilityError> {
    if !(delay.is_finite() && delay >= 0.0) {
        return Err(StabilityError::InvalidDelay { tau: delay });
    }
    let (m, p) = adjugate(a);
    let (m_hat, p_hat) = adjugate(a_model);
    let e = (a_model * delay).exp();
    let q_hat = transfer(&m_hat, k, b_model);
    let r = transfer(&m, &(k * e), b);
    let w = transfer(&m_hat, k, &(e * b_model));
    let p0 = add(&mul(&p, &p_hat), &mul(&p, &q_hat), 1.0);
    let p1 = add(&mul(&p_hat, &r), &mul(&p, &w), -1.0);
    let feedback = RankOneFeedback::from_polynomials(&p0, &p1)?;
    let spurious = stability::polynomial_roots(&p_hat)?;
    Ok((feedback, spurious))
}

/// adj(λI − A) = Σ_{k=1}^{n} M_k λ^{n−k} and p(λ) = det(λI − A) of an n×n matrix, by the
/// recursion of [`adjugate`]; `m` is filled in place (n matrices).
fn adjugate_dyn(a: &DMatrix<f64>, m: &mut Vec<DMatrix<f64>>) -> Vec<f64> {
    let n = a.nrows();
    let mut p = vec![0.0; n + 1];
    p[n] = 1.0;
    m.clear();
    for k in 1..=n {
        let mk = if k > 1 {
            let mut mk = a * &m[k - 2];
            for i in 0..n {
                mk[(i, i)] += p[n + 1 - k];
            }
            mk
        } else {
            DMatrix::identity(n, n)
        };
        p[n - k] = -(a * &mk).trace() / k as f64;
        m.push(mk);
    }
    p
}

/// r·adj(λI − A)·c (ascending coefficients, degree ≤ n − 1).
fn transfer_dyn(m: &[DMatrix<f64>], r: &RowDVector<f64>, c: &DVector<f64>) -> Vec<f64> {
    let n = m.len();
    let mut out = vec![0.0; n];
    for k in 1..=n {
        out[n - k] = (r * &m[k - 1]).dot(&c.transpose());
    }
    out
}

/// [`cleared_loop`] for a plant (A, B) of n states and a model (Â, B̂) of m states (the
/// model may have another state count than the vehicle: a relaxed vehicle predicted with
/// the paper's model, say); K acts on the model's state. P₀ has degree n + m. With
/// n = m = 4 it is [`cleared_loop`] itself (the same arithmetic, so the paper's numbers do
/// not move) and the time scale (the third value) is 1.
///
/// Otherwise the quasi-polynomial is returned in the scaled variable μ = λ/s with the delay
/// s·τ (the third value is s, the geometric mean of the magnitudes of the roots of P₀):
/// P₀(sμ)/s^{n+m} + e^{−μ·sτ} P₁(sμ)/s^{n+m}. A relaxed vehicle has roots near −V/σ
/// (−100 /s at 30 m/s, σ = 0.3 m) beside the sway mode (≈ 1 /s): unscaled, the coefficients
/// of the degree-14 polynomials span ~20 orders of magnitude and the companion realisation
/// behind the root seeds loses the rightmost roots.
///
/// # Errors
/// [`StabilityError`] if the dimensions do not fit, the coefficients are not finite or an
/// eigensolver fails.
pub fn cleared_loop_dyn(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    a_model: &DMatrix<f64>,
    b_model: &DVector<f64>,
    k: &RowDVector<f64>,
    delay: f64,
) -> Result<(RankOneFeedback, Vec<Complex64>, f64), StabilityError> {
    let (n, nm) = (a.nrows(), a_model.nrows());
    if n == 4 && nm == 4 && a.ncols() == 4 && a_model.ncols() == 4 && b.len() == 4 {
        return cleared_loop(
            &Matrix4::from_fn(|i, j| a[(i, j)]),
            &Vector4::from_fn(|i, _| b[i]),
            &Matrix4::from_fn(|i, j| a_model[(i, j)]),
            &Vector4::from_fn(|i, _| b_model[i]),
            &RowVector4::from_fn(|_, j| k[j]),
            delay,
        )
        .map(|(f, spurious)| (f, spurious, 1.0));
    }
    let mismatch = |what, rows, cols, er, ec| StabilityError::DimensionMismatch {
        what,
        rows,
        cols,
        expected_rows: er,
        expected_cols: ec,
    };
    if a.ncols() != n || b.len() != n {
        return Err(mismatch("A, B of the plant", b.len(), a.ncols(), n, n));
    }
    if a_model.ncols() != nm || b_model.len() != nm || k.len() != nm {
        return Err(mismatch(
            "Â, B̂, K of the model",
            b_model.len(),
            k.len(),
            nm,
            nm,
        ));
    }
    if !(delay.is_finite() && delay >= 0.0) {
        return Err(StabilityError::InvalidDelay { tau: delay });
    }
    // the model predicts from the measured state x(t − τ) restricted to the states it has:
    // x̂(t − τ) = S x(t − τ), S = [I 0] on the first min(n, m) states (σ1, σ2, σ3, θ, then
    // the lagged slips in axle order; a model state the vehicle lacks starts at 0), so the
    // delayed term's row on the plant's state is K e^{Âτ} S
    let (mut m, mut m_hat) = (Vec::new(), Vec::new());
    let p = adjugate_dyn(a, &mut m);
    let p_hat = adjugate_dyn(a_model, &mut m_hat);
    let e = (a_model * delay).exp();
    let q_hat = transfer_dyn(&m_hat, k, b_model);
    let ke = k * &e;
    let ke_plant = RowDVector::from_fn(n, |_, j| if j < nm { ke[j] } else { 0.0 });
    let r = transfer_dyn(&m, &ke_plant, b);
    let w = transfer_dyn(&m_hat, k, &(&e * b_model));
    let p0 = add(&mul(&p, &p_hat), &mul(&p, &q_hat), 1.0);
    let p1 = add(&mul(&p_hat, &r), &mul(&p, &w), -1.0);
    let spurious = stability::polynomial_roots(&p_hat)?;
    let s = time_scale(&p0);
    let degree = p0.len() - 1;
    let (p0, p1) = (scaled(&p0, s, degree), scaled(&p1, s, degree));
    let feedback = RankOneFeedback::from_polynomials(&p0, &p1)?;
    Ok((feedback, spurious, s))
}

/// The scale s \[1/s\] of the roots of the monic polynomial `p` of degree N: the geometric
/// mean of their magnitudes, |p(0)|^{1/N} (1 if p(0) = 0 or not finite).
fn time_scale(p: &[f64]) -> f64 {
    let n = p.len().saturating_sub(1);
    let s = p[0].abs().powf(1.0 / n.max(1) as f64);
    if s.is_finite() && s > 0.0 { s } else { 1.0 }
}

/// The coefficients of c(s·μ)/s^N, N the degree of the monic polynomial of the pair:
/// c_k·s^{k−N}.
fn scaled(c: &[f64], s: f64, degree: usize) -> Vec<f64> {
    c.iter()
        .enumerate()
        .map(|(k, x)| x * s.powi(k as i32 - degree as i32))
        .collect()
}

/// The prediction model is the plant itself: the same A, B, B_M and C bit for bit (the
/// vehicle's own linearisation, or a model file equal to the vehicle). Then P₁ of
/// [`cleared_loop`] vanishes identically — p̂ = p and adj(λI − A) commutes with e^{Aτ},
/// so P₁ = p·K (e^{Aτ} adj(λI − A) − adj(λI − A) e^{Aτ}) B = 0 — and P₀ = p·(p + K adj B):
/// the loop's roots are the eigenvalues of A − B K (finite spectrum assignment).
pub fn is_perfect_model(
    plant: &super::LoopLinearization,
    model: &super::LoopLinearization,
) -> bool {
    plant.a.shape() == model.a.shape()
        && plant.a == model.a
        && plant.b == model.b
        && plant.b_yaw_moment == model.b_yaw_moment
        && plant.c == model.c
}

/// `roots` (sorted rightmost first) without one root near each spurious one (within
/// 1e-6·max(1, |z|)), truncated to `count`.
pub fn without_spurious(
    mut roots: Vec<Complex64>,
    spurious: &[Complex64],
    count: usize,
) -> Vec<Complex64> {
    for z in spurious {
        let near = roots
            .iter()
            .enumerate()
            .map(|(i, r)| (i, (r - z).norm()))
            .filter(|&(_, d)| d <= 1e-6 * z.norm().max(1.0))
            .min_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((i, _)) = near {
            roots.remove(i);
        }
    }
    roots.truncate(count);
    roots
}
