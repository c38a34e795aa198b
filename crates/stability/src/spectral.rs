//! Chebyshev (spectral) collocation of the infinitesimal generator (Breda, Maset, Vermiglio,
//! SIAM J. Sci. Comput. 27 (2005) 482–495): the independent second method, and the source of
//! seeds for Newton polishing.
//!
//! The state of the DDE is the history segment. For the factored terms `B_k·C_k·x(t − τ_k)` only
//! the outputs `z_k = C_k·x` need a history, so each term gets its own delay line
//! `u_k(θ) = z_k(t + θ)`, θ ∈ [−τ_k, 0], that obeys the transport equation `∂_t u = ∂_θ u`
//! with `u_k(0) = C_k·x(t)`. Collocating every line at the N+1 Chebyshev points
//! `θ_j = τ_k (cos(jπ/N) − 1)/2` (θ_0 = 0, θ_N = −τ_k) gives a matrix of size
//! `n + N·Σ_k m_k` whose eigenvalues converge to the characteristic roots with spectral
//! accuracy (geometric in N for a fixed root) — for a full-rank term this is exactly the
//! classical n·(N+1) collocation of Breda et al.

use faer::Mat;
use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::dde::{LinearDde, sort_rightmost};
use crate::eigen::eigenvalues;
use crate::error::{Result, StabilityError};

/// Chebyshev differentiation matrix on the N+1 points `x_j = cos(jπ/N)` of [−1, 1]
/// (Trefethen, *Spectral Methods in MATLAB*, program `cheb`), row-major `(N+1)²`.
pub fn chebyshev_differentiation(n: usize) -> (Vec<f64>, Vec<f64>) {
    let m = n + 1;
    let x: Vec<f64> = (0..m)
        .map(|j| (std::f64::consts::PI * j as f64 / n as f64).cos())
        .collect();
    let c = |j: usize| if j == 0 || j == n { 2.0 } else { 1.0 };
    let mut d = vec![0.0; m * m];
    for i in 0..m {
        let mut sum = 0.0;
        for j in 0..m {
            if i != j {
                let sign = if (i + j) % 2 == 0 { 1.0 } else { -1.0 };
                let v = c(i) / c(j) * sign / (x[i] - x[j]);
                d[i * m + j] = v;
                sum += v;
            }
        }
        d[i * m + i] = -sum; // negative-sum trick: exact derivative of constants
    }
    (x, d)
}

/// Spectral collocation of the generator with polynomial degree `degree` per delay line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChebyshevCollocation {
    /// polynomial degree N of each delay line (N+1 collocation points)
    pub degree: usize,
}

impl Default for ChebyshevCollocation {
    fn default() -> Self {
        Self { degree: 20 }
    }
}

impl ChebyshevCollocation {
    /// The collocated generator (size `n + N·Σ_k m_k`).
    pub fn generator_matrix(&self, dde: &LinearDde) -> Result<DMatrix<f64>> {
        let n = dde.dim();
        let big_n = self.degree;
        if big_n < 2 && !dde.delayed_terms().is_empty() {
            return Err(StabilityError::InvalidResolution {
                resolution: big_n,
                min: 2,
                reason: "Chebyshev degree",
            });
        }
        let size = n + big_n
            * dde
                .delayed_terms()
                .iter()
                .map(|t| t.c.nrows())
                .sum::<usize>();
        let mut g = DMatrix::<f64>::zeros(size, size);
        g.view_mut((0, 0), (n, n)).copy_from(dde.a0());
        if dde.delayed_terms().is_empty() {
            return Ok(g);
        }
        let (_, dx) = chebyshev_differentiation(big_n);
        let m1 = big_n + 1;
        let mut offset = n;
        for t in dde.delayed_terms() {
            let m = t.c.nrows();
            let scale = 2.0 / t.tau;
            // line block j (1..=N) starts at offset + (j−1)·m
            let blk = |j: usize| offset + (j - 1) * m;
            // x' gets B·u(−τ) = B·u_N
            g.view_mut((0, blk(big_n)), (n, m)).copy_from(&t.b);
            for i in 1..=big_n {
                let d0 = dx[i * m1] * scale;
                let mut rows = g.view_mut((blk(i), 0), (m, n));
                rows += &t.c * d0;
                for j in 1..=big_n {
                    let dij = dx[i * m1 + j] * scale;
                    for r in 0..m {
                        g[(blk(i) + r, blk(j) + r)] += dij;
                    }
                }
            }
            offset += big_n * m;
        }
        Ok(g)
    }

    /// All eigenvalues of the collocated generator, sorted by decreasing real part. Only those
    /// with |λ|·τ_max well below the degree N are accurate; see [`crate::rightmost_roots`].
    pub fn eigenvalues(&self, dde: &LinearDde) -> Result<Vec<Complex64>> {
        let g = self.generator_matrix(dde)?;
        let m = Mat::from_fn(g.nrows(), g.ncols(), |i, j| g[(i, j)]);
        let mut ev = eigenvalues(&m)?;
        sort_rightmost(&mut ev);
        Ok(ev)
    }

    /// As [`ChebyshevCollocation::eigenvalues`], but for small matrices (≤ 48) with nalgebra's
    /// Schur iteration, which has less overhead than faer at these sizes (falls back to faer if
    /// it does not converge). Used for Newton seeds, whose accuracy only needs to be ~1e-4.
    pub fn seed_eigenvalues(&self, dde: &LinearDde) -> Result<Vec<Complex64>> {
        let g = self.generator_matrix(dde)?;
        let size = g.nrows();
        if size <= 48
            && let Some(schur) =
                nalgebra::Schur::try_new(g.clone(), f64::EPSILON, 100 * size.max(1))
        {
            let mut ev: Vec<Complex64> = schur.complex_eigenvalues().iter().copied().collect();
            if ev.iter().all(|z| z.re.is_finite() && z.im.is_finite()) {
                sort_rightmost(&mut ev);
                return Ok(ev);
            }
        }
        let m = Mat::from_fn(size, size, |i, j| g[(i, j)]);
        let mut ev = eigenvalues(&m)?;
        sort_rightmost(&mut ev);
        Ok(ev)
    }
}
