//! Characteristic roots of the linearisation at an equilibrium: the pluggable
//! [`CharacteristicRoots`] trait and [`ChebyshevRoots`], the adapter to the `stability` crate
//! (Chebyshev collocation of the infinitesimal generator and Newton polishing live there, once).

use crate::error::{Error, Result};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use stability::{LinearDde, NewtonOptions, StabilityError, collocation_roots};

/// Rightmost roots of the characteristic equation of the linear DDE
/// y'(t) = A0 y(t) + Σ_j A_j y(t − τ_j), i.e. det(λI − A0 − Σ_j A_j e^{−λτ_j}) = 0.
///
/// Plug in any method (e.g. a semi-discretisation from another crate); [`ChebyshevRoots`]
/// is the built-in one. For an ODE (`a.len() == 1`) it must return the eigenvalues of A0.
pub trait CharacteristicRoots {
    /// the rightmost roots (any order); `a[0]` = A0, `a[j]` the matrix of delay τ_j
    fn rightmost_roots(&self, a: &[DMatrix<f64>], delays: &[f64]) -> Result<Vec<Complex64>>;
}

/// Newton refinement of approximate characteristic roots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refinement {
    /// Newton on det Δ(λ) (λ ← λ − 1/tr(Δ(λ)⁻¹Δ'(λ))) to machine precision
    Newton,
    /// keep the discretised values
    None,
}

/// Characteristic roots by Chebyshev collocation of the infinitesimal generator
/// (Breda, Maset & Vermiglio, SIAM J. Sci. Comput. 27, 2005), followed by Newton refinement on
/// the characteristic matrix: [`stability::collocation_roots`] with N + 1 Chebyshev points on
/// each delay interval [−τ_j, 0]. For an ODE all eigenvalues of A0 + Σ_j A_j are returned.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ChebyshevRoots {
    /// polynomial degree N of the collocation
    pub degree: usize,
    /// how many rightmost roots to return
    pub count: usize,
    /// refinement of the discretised roots
    pub refinement: Refinement,
}

impl Default for ChebyshevRoots {
    fn default() -> Self {
        Self {
            degree: 30,
            count: 8,
            refinement: Refinement::Newton,
        }
    }
}

/// the failure of the `stability` crate in this crate's terms
fn roots_error(size: usize, e: StabilityError) -> Error {
    Error::Eigen {
        size,
        message: format!("characteristic roots: {e}"),
    }
}

/// the linear DDE with A0 = `a[0]` and the terms `a[j]` at delay `delays[j − 1]`
/// (zero delays are merged into A0; each term factored by its numerical rank, so that the
/// collocated generator is as small as the feedback allows)
fn linear_dde(a: &[DMatrix<f64>], delays: &[f64]) -> Result<LinearDde> {
    let n = a.first().map_or(0, |m| m.nrows());
    let Some((a0, delayed)) = a.split_first() else {
        return Err(Error::InvalidInput(
            "characteristic roots: no matrices given".into(),
        ));
    };
    if delayed.len() != delays.len() {
        return Err(Error::InvalidInput(format!(
            "characteristic roots: {} delayed matrices but {} delays",
            delayed.len(),
            delays.len()
        )));
    }
    let mut dde = LinearDde::new(a0.clone()).map_err(|e| roots_error(n, e))?;
    for (aj, &tau) in delayed.iter().zip(delays) {
        dde = dde
            .with_delay_by_rank(tau, aj.clone())
            .map_err(|e| roots_error(n, e))?;
    }
    Ok(dde)
}

/// Newton on det Δ(λ) from `lambda` ([`LinearDde::polish_root`] with the default options):
/// λ ← λ − 1/tr(Δ⁻¹Δ'). Returns None if it does not converge.
pub fn refine_root(a: &[DMatrix<f64>], delays: &[f64], lambda: Complex64) -> Option<Complex64> {
    linear_dde(a, delays)
        .ok()?
        .polish_root(lambda, &NewtonOptions::default())
        .ok()
}

impl CharacteristicRoots for ChebyshevRoots {
    fn rightmost_roots(&self, a: &[DMatrix<f64>], delays: &[f64]) -> Result<Vec<Complex64>> {
        let dde = linear_dde(a, delays)?;
        let newton = NewtonOptions::default();
        let polish = match self.refinement {
            Refinement::Newton => Some(&newton),
            Refinement::None => None,
        };
        collocation_roots(&dde, self.degree, self.count, polish)
            .map_err(|e| roots_error(dde.dim(), e))
    }
}
