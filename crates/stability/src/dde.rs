//! The problem: a linear constant-coefficient DDE and its characteristic function.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::error::{Result, StabilityError};

/// One delayed term `B·C·x(t − τ)` of a [`LinearDde`], stored factored so that low-rank
/// feedback (a scalar output fed back through one input) gives small discretisations.
#[derive(Debug, Clone, PartialEq)]
pub struct DelayedTerm {
    /// delay τ \[s\], > 0
    pub tau: f64,
    /// n×m input factor
    pub b: DMatrix<f64>,
    /// m×n output factor
    pub c: DMatrix<f64>,
}

impl DelayedTerm {
    /// The n×n coefficient `A_k = B·C`.
    pub fn matrix(&self) -> DMatrix<f64> {
        &self.b * &self.c
    }
}

/// The linear constant-coefficient delay differential equation
/// `x'(t) = A0·x(t) + Σ_k A_k·x(t − τ_k)` with `A_k = B_k·C_k` (dynamic dimension n).
///
/// Terms with τ_k = 0 are merged into `A0` on construction. The characteristic function is
/// `det Δ(λ)`, `Δ(λ) = λI − A0 − Σ_k A_k e^{−λτ_k}` (eq. (13) of the paper for one term).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearDde {
    a0: DMatrix<f64>,
    delayed: Vec<DelayedTerm>,
}

/// Singular values of a delayed coefficient below this fraction of the largest are dropped by
/// [`LinearDde::with_delay_by_rank`]: rounding level of a product of factors (a rank-one
/// B·D·C computed in floating point has the others near 1e-16·σ_max).
pub const DELAY_RANK_TOLERANCE: f64 = 1e-13;

fn check_finite(m: &DMatrix<f64>, what: &'static str) -> Result<()> {
    if m.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(StabilityError::NonFinite { what })
    }
}

impl LinearDde {
    /// An ODE `x' = A0·x` (add delayed terms with [`LinearDde::with_delay`]).
    pub fn new(a0: DMatrix<f64>) -> Result<Self> {
        if a0.nrows() != a0.ncols() {
            return Err(StabilityError::DimensionMismatch {
                what: "A0",
                rows: a0.nrows(),
                cols: a0.ncols(),
                expected_rows: a0.nrows(),
                expected_cols: a0.nrows(),
            });
        }
        check_finite(&a0, "A0")?;
        Ok(Self {
            a0,
            delayed: Vec::new(),
        })
    }

    /// Adds the full-rank term `A_k·x(t − τ)`.
    pub fn with_delay(self, tau: f64, a_k: DMatrix<f64>) -> Result<Self> {
        let n = self.dim();
        self.with_low_rank_delay(tau, a_k, DMatrix::identity(n, n))
    }

    /// Adds `A_k·x(t − τ)` factored by its numerical rank r: `A_k = B·C` with B = U_r·Σ_r and
    /// C = V_rᵀ from the singular value decomposition, keeping the singular values above
    /// [`DELAY_RANK_TOLERANCE`]·σ_max (a zero A_k adds no term). The characteristic function
    /// is that of [`LinearDde::with_delay`] up to rounding, but the collocated generator of
    /// [`crate::ChebyshevCollocation`] has n + N·r rows instead of n + N·n: for delayed
    /// feedback through one input (r = 1) and n = 4 at N = 24, 28 instead of 100.
    pub fn with_delay_by_rank(self, tau: f64, a_k: DMatrix<f64>) -> Result<Self> {
        let n = self.dim();
        if a_k.nrows() != n || a_k.ncols() != n {
            return Err(StabilityError::DimensionMismatch {
                what: "A_k (delayed coefficient)",
                rows: a_k.nrows(),
                cols: a_k.ncols(),
                expected_rows: n,
                expected_cols: n,
            });
        }
        check_finite(&a_k, "A_k")?;
        let svd = a_k.clone().svd(true, true);
        let sigma_max = svd.singular_values.max();
        let rank = svd
            .singular_values
            .iter()
            .filter(|&&s| s > DELAY_RANK_TOLERANCE * sigma_max)
            .count();
        match (rank, svd.u, svd.v_t) {
            (0, _, _) => {
                if !(tau.is_finite() && tau >= 0.0) {
                    return Err(StabilityError::InvalidDelay { tau });
                }
                Ok(self)
            }
            (r, Some(u), Some(v_t)) if r < n => {
                // singular values come sorted, largest first
                let mut b = u.columns(0, r).into_owned();
                for (j, mut col) in b.column_iter_mut().enumerate() {
                    col *= svd.singular_values[j];
                }
                self.with_low_rank_delay(tau, b, v_t.rows(0, r).into_owned())
            }
            _ => self.with_delay(tau, a_k),
        }
    }

    /// Adds the term `B·C·x(t − τ)` with B n×m and C m×n (m = 1 for single-input feedback).
    pub fn with_low_rank_delay(
        mut self,
        tau: f64,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
    ) -> Result<Self> {
        let n = self.dim();
        if !(tau.is_finite() && tau >= 0.0) {
            return Err(StabilityError::InvalidDelay { tau });
        }
        if b.nrows() != n {
            return Err(StabilityError::DimensionMismatch {
                what: "B (delayed input factor)",
                rows: b.nrows(),
                cols: b.ncols(),
                expected_rows: n,
                expected_cols: b.ncols(),
            });
        }
        if c.nrows() != b.ncols() || c.ncols() != n {
            return Err(StabilityError::DimensionMismatch {
                what: "C (delayed output factor)",
                rows: c.nrows(),
                cols: c.ncols(),
                expected_rows: b.ncols(),
                expected_cols: n,
            });
        }
        check_finite(&b, "B")?;
        check_finite(&c, "C")?;
        if tau == 0.0 {
            self.a0 += &b * &c;
        } else {
            self.delayed.push(DelayedTerm { tau, b, c });
        }
        Ok(self)
    }

    /// Dynamic dimension n.
    pub fn dim(&self) -> usize {
        self.a0.nrows()
    }

    /// The undelayed coefficient A0 (including merged zero-delay terms).
    pub fn a0(&self) -> &DMatrix<f64> {
        &self.a0
    }

    /// The delayed terms (all with τ > 0).
    pub fn delayed_terms(&self) -> &[DelayedTerm] {
        &self.delayed
    }

    /// Largest delay \[s\] (0 for an ODE).
    pub fn max_delay(&self) -> f64 {
        self.delayed.iter().map(|t| t.tau).fold(0.0, f64::max)
    }

    /// The characteristic matrix `Δ(λ) = λI − A0 − Σ_k A_k e^{−λτ_k}`.
    pub fn characteristic_matrix(&self, lambda: Complex64) -> DMatrix<Complex64> {
        let n = self.dim();
        let mut m = DMatrix::from_fn(n, n, |i, j| {
            Complex64::new(-self.a0[(i, j)], 0.0) + if i == j { lambda } else { Complex64::ZERO }
        });
        for t in &self.delayed {
            let e = (-lambda * t.tau).exp();
            let ak = t.matrix();
            m.zip_apply(&ak, |x, a| *x -= e * a);
        }
        m
    }

    /// `Δ'(λ) = I + Σ_k τ_k A_k e^{−λτ_k}`.
    fn characteristic_matrix_derivative(&self, lambda: Complex64) -> DMatrix<Complex64> {
        let n = self.dim();
        let mut m = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                Complex64::ONE
            } else {
                Complex64::ZERO
            }
        });
        for t in &self.delayed {
            let e = (-lambda * t.tau).exp() * t.tau;
            let ak = t.matrix();
            m.zip_apply(&ak, |x, a| *x += e * a);
        }
        m
    }

    /// The characteristic function `det Δ(λ)`.
    pub fn characteristic_function(&self, lambda: Complex64) -> Complex64 {
        self.characteristic_matrix(lambda).determinant()
    }

    /// Newton's method on `det Δ(λ) = 0` from `lambda0`, with the step
    /// `1 / trace(Δ(λ)⁻¹ Δ'(λ))` (Jacobi's formula). Converges quadratically to simple roots.
    pub fn polish_root(&self, lambda0: Complex64, options: &NewtonOptions) -> Result<Complex64> {
        if !(lambda0.re.is_finite() && lambda0.im.is_finite()) {
            return Err(StabilityError::NonFinite {
                what: "Newton start",
            });
        }
        newton(lambda0, options, |lambda| {
            let lu = self.characteristic_matrix(lambda).lu();
            let dprime = self.characteristic_matrix_derivative(lambda);
            let Some(x) = lu.solve(&dprime) else {
                // Δ(λ) exactly singular: λ is a root
                return NewtonStep::Root;
            };
            let tr = x.trace();
            if tr == Complex64::ZERO {
                return NewtonStep::Stuck;
            }
            NewtonStep::Step(tr.inv())
        })
    }
}

/// What one evaluation of a Newton iteration on a characteristic equation found.
pub(crate) enum NewtonStep {
    /// λ is exactly a root
    Root,
    /// the Newton step to subtract from λ
    Step(Complex64),
    /// no step can be taken (zero derivative)
    Stuck,
}

/// Newton's iteration λ ← λ − step(λ) from `lambda0`, stopped when the step is below
/// `tolerance·max(1, |λ|)` or has [`stagnated`]; `NewtonDivergence` after
/// `max_iterations`, at a non-finite step or when it is [`NewtonStep::Stuck`].
pub(crate) fn newton(
    lambda0: Complex64,
    options: &NewtonOptions,
    mut step_at: impl FnMut(Complex64) -> NewtonStep,
) -> Result<Complex64> {
    let mut lambda = lambda0;
    let mut last = f64::INFINITY;
    for _ in 0..options.max_iterations {
        let step = match step_at(lambda) {
            NewtonStep::Root => return Ok(lambda),
            NewtonStep::Stuck => break,
            NewtonStep::Step(step) => step,
        };
        let prev = last;
        last = step.norm();
        if !last.is_finite() {
            break;
        }
        lambda -= step;
        let scale = lambda.norm().max(1.0);
        if last <= options.tolerance * scale || stagnated(last, prev, scale) {
            return Ok(lambda);
        }
    }
    Err(StabilityError::NewtonDivergence {
        start: lambda0,
        iterations: options.max_iterations,
        last_step: last,
    })
}

/// Newton has reached the round-off floor of a (near-)multiple root: the step is already
/// below `1e-7·scale` (the attainable accuracy of a double root is ~√ε relative) and no longer
/// shrinks (quadratic convergence gave out, linear convergence would shrink it by ½).
pub(crate) fn stagnated(step: f64, previous: f64, scale: f64) -> bool {
    step < 1e-7 * scale && step > 0.9 * previous
}

/// Options of the Newton polishing of characteristic roots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// stop when the step is below `tolerance·max(1, |λ|)`
    pub tolerance: f64,
    /// give up after this many iterations
    pub max_iterations: usize,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-14,
            max_iterations: 50,
        }
    }
}

/// Sorts roots by decreasing real part (ties: increasing imaginary part... no: decreasing
/// imaginary part so that `a + bi` precedes `a − bi`).
pub fn sort_rightmost(roots: &mut [Complex64]) {
    roots.sort_by(|a, b| b.re.total_cmp(&a.re).then(b.im.total_cmp(&a.im)));
}
