//! Eigenvalues of dense real matrices: the routine of [`crate::small_eigen`] for the small
//! ones, faer's blocked QR for the rest.

use num_complex::Complex64;

use crate::error::{Result, StabilityError};
use crate::small_eigen;

/// Eigenvalues of a dense real matrix: [`small_eigen`](crate::small_eigen) up to
/// [`SMALL_EIGEN_MAX`](small_eigen::SMALL_EIGEN_MAX), faer's blocked QR above.
pub(crate) fn eigenvalues(m: &faer::Mat<f64>) -> Result<Vec<Complex64>> {
    let n = m.nrows();
    if n == 0 {
        return Ok(Vec::new());
    }
    if n <= small_eigen::SMALL_EIGEN_MAX {
        let mut a: Vec<f64> = (0..n * n).map(|k| m[(k / n, k % n)]).collect();
        let mut out = Vec::with_capacity(n);
        small_eigen::small_eigenvalues(&mut a, n, &mut out)?;
        return Ok(out);
    }
    m.eigenvalues().map_err(|e| StabilityError::Eigensolver {
        size: m.nrows(),
        message: format!("{e:?}"),
    })
}
