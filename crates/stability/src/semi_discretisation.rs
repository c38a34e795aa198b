//! First-order semi-discretisation (Insperger & Stépán, *Semi-Discretization for Time-Delay
//! Systems*, Springer 2011, ch. 3; Int. J. Numer. Meth. Engng 61 (2004) 117–141): the method
//! the paper uses for Fig. 4(a).
//!
//! Time is divided into steps of length `h = τ_max / r` (r = [`SemiDiscretisation::steps_per_delay`]).
//! On each step `[t_i, t_i + h)` the undelayed part `A0·x(t)` is kept exact while every delayed
//! output `z_k(t − τ_k) = C_k·x(t − τ_k)` is replaced by the linear interpolation of its values
//! at the two grid points around `t − τ_k` (split at the point where `t − τ_k` passes a grid
//! point when τ_k is not a multiple of h). Solving the resulting ODE over one step exactly gives
//! the discrete map `y_{i+1} = G·y_i` on `y_i = (x_i, z_{i−1}, …, z_{i−J})`; the convolution
//! integrals `∫ e^{A0(L−s)} ds`, `∫ e^{A0(L−s)} s ds` are evaluated exactly by one matrix
//! exponential of a 3n×3n block matrix (Van Loan, IEEE TAC 23 (1978) 395–404).
//!
//! **Roots from multipliers.** The eigenvalues μ of G (the multipliers of the discrete map) give
//! characteristic roots `λ = ln μ / h` with the principal branch of the logarithm:
//! `Im λ ∈ (−π/h, π/h]`. Roots with |Im λ| beyond π/h are aliased, so r must be large enough that
//! the roots of interest satisfy |Im λ|·h ≪ π. Zero multipliers (λ = −∞) are dropped. The
//! method converges with order 2 in h for simple roots (measured in the tests).

use faer::Mat;
use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::dde::{LinearDde, sort_rightmost};
use crate::eigen::eigenvalues;
use crate::error::{Result, StabilityError};

/// Semi-discretisation with `steps_per_delay` steps over the largest delay.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SemiDiscretisation {
    /// resolution r: step h = τ_max / r; every positive delay must be ≥ h
    pub steps_per_delay: usize,
}

impl Default for SemiDiscretisation {
    fn default() -> Self {
        Self {
            steps_per_delay: 40,
        }
    }
}

/// `(e^{AL}, ∫_0^L e^{A(L−s)} ds, ∫_0^L e^{A(L−s)} s ds)` by Van Loan's block exponential.
fn exp_integrals(a: &DMatrix<f64>, l: f64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let mut m = DMatrix::<f64>::zeros(3 * n, 3 * n);
    m.view_mut((0, 0), (n, n)).copy_from(&(a * l));
    for i in 0..n {
        m[(i, n + i)] = l;
        m[(n + i, 2 * n + i)] = l;
    }
    let e = m.exp();
    // exp(M·L) = [[E(L), G0(L), G1(L)], [0, I, L·I], [0, 0, I]]
    let e0 = e.view((0, 0), (n, n)).into_owned();
    let g0 = e.view((0, n), (n, n)).into_owned();
    let g1 = e.view((0, 2 * n), (n, n)).into_owned();
    (e0, g0, g1)
}

impl SemiDiscretisation {
    /// Step length h \[s\].
    pub fn step(&self, dde: &LinearDde) -> f64 {
        dde.max_delay() / self.steps_per_delay as f64
    }

    /// The matrix G of the discrete map `y_{i+1} = G·y_i` (size `n + Σ_k m_k·J_k`).
    pub fn discrete_map(&self, dde: &LinearDde) -> Result<DMatrix<f64>> {
        let n = dde.dim();
        let r = self.steps_per_delay;
        if dde.delayed_terms().is_empty() {
            return Err(StabilityError::InvalidResolution {
                resolution: r,
                min: 1,
                reason: "no delayed term: the step is undefined (use the eigenvalues of A0)",
            });
        }
        if r < 1 {
            return Err(StabilityError::InvalidResolution {
                resolution: r,
                min: 1,
                reason: "steps per delay",
            });
        }
        let h = self.step(dde);
        // per term: (m_k, φ_k, J_k)
        let mut layout = Vec::new();
        for t in dde.delayed_terms() {
            let ratio = t.tau / h;
            let mut mk = ratio.floor() as usize;
            let mut phi = ratio - mk as f64;
            if phi > 1.0 - 1e-10 {
                mk += 1;
                phi = 0.0;
            } else if phi < 1e-10 {
                phi = 0.0;
            }
            if mk < 1 {
                let min = (dde.max_delay() / t.tau).ceil() as usize;
                return Err(StabilityError::InvalidResolution {
                    resolution: r,
                    min,
                    reason: "a delay is shorter than the step",
                });
            }
            let jk = if phi > 0.0 { mk + 1 } else { mk };
            layout.push((t.c.nrows(), phi, mk, jk));
        }
        let size = n + layout.iter().map(|(m, _, _, j)| m * j).sum::<usize>();
        let mut g = DMatrix::<f64>::zeros(size, size);
        let (eh, _, _) = exp_integrals(dde.a0(), h);
        g.view_mut((0, 0), (n, n)).copy_from(&eh);
        let mut offset = n;
        for (t, &(m, phi, mk, jk)) in dde.delayed_terms().iter().zip(&layout) {
            // history block j (1..=J) of this term starts at column offset + (j−1)·m
            let col = |j: usize| offset + (j - 1) * m;
            let add = |g: &mut DMatrix<f64>, j: usize, w: DMatrix<f64>| {
                if j == 0 {
                    // z_i = C·x_i
                    let wc = &w * &t.c;
                    let mut v = g.view_mut((0, 0), (n, n));
                    v += wc;
                } else {
                    let mut v = g.view_mut((0, col(j)), (n, m));
                    v += w;
                }
            };
            let l1 = (1.0 - phi) * h;
            let (e1, g0, g1) = exp_integrals(dde.a0(), l1);
            add(&mut g, mk, (&g0 - &g1 / h) * &t.b);
            add(&mut g, mk - 1, (&g1 / h) * &t.b);
            if phi > 0.0 {
                let (_, g0b, g1b) = exp_integrals(dde.a0(), phi * h);
                add(&mut g, mk, &e1 * (&g0b * (1.0 - phi) + &g1b / h) * &t.b);
                add(&mut g, mk + 1, &e1 * (&g0b * phi - &g1b / h) * &t.b);
            }
            // shift register: z_i = C·x_i enters block 1, block j−1 moves to block j
            g.view_mut((col(1), 0), (m, n)).copy_from(&t.c);
            for j in 2..=jk {
                for rr in 0..m {
                    g[(col(j) + rr, col(j - 1) + rr)] = 1.0;
                }
            }
            offset += m * jk;
        }
        Ok(g)
    }

    /// Multipliers μ of the discrete map (eigenvalues of G), unsorted.
    pub fn multipliers(&self, dde: &LinearDde) -> Result<Vec<Complex64>> {
        let g = self.discrete_map(dde)?;
        let m = Mat::from_fn(g.nrows(), g.ncols(), |i, j| g[(i, j)]);
        eigenvalues(&m)
    }

    /// Approximate characteristic roots `λ = ln μ / h` (principal branch), sorted by decreasing
    /// real part; zero multipliers are dropped. For an ODE (no delayed term) the exact eigenvalues
    /// of A0 are returned.
    pub fn roots(&self, dde: &LinearDde) -> Result<Vec<Complex64>> {
        if dde.delayed_terms().is_empty() {
            let a = dde.a0();
            let m = Mat::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)]);
            let mut ev = eigenvalues(&m)?;
            sort_rightmost(&mut ev);
            return Ok(ev);
        }
        let h = self.step(dde);
        let mu = self.multipliers(dde)?;
        let mut roots: Vec<Complex64> = mu
            .into_iter()
            .filter(|m| m.norm() > 1e-300)
            .map(|m| {
                let mut l = m.ln() / h;
                if m.im == 0.0 && m.re > 0.0 {
                    l.im = 0.0;
                }
                l
            })
            .collect();
        sort_rightmost(&mut roots);
        Ok(roots)
    }
}
