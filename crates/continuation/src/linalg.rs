//! Thin wrappers around faer's sparse LU and dense eigenvalues.

use crate::error::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::lu::simplicial::{
    SimplicialLu, factorize_simplicial_numeric_lu, factorize_simplicial_numeric_lu_scratch,
};
use faer::sparse::linalg::lu::{LuSymbolicParams, SymbolicLu, factorize_symbolic_lu};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, Mat, MatMut, Par};
use num_complex::Complex64;

/// Triplet (row, column, value) of a sparse matrix under assembly.
pub type Entry = Triplet<usize, usize, f64>;

/// Sparse LU factorisation P·A·Q = L·U of a square matrix (COLAMD column ordering Q, partial
/// pivoting P, simplicial: the collocation matrices are too sparse for supernodes to pay off).
/// The factors are kept so that the determinant is available (branch-point test function).
#[derive(Debug)]
pub(crate) struct SparseLu {
    symbolic: SymbolicLu<usize>,
    numeric: SimplicialLu<usize, f64>,
    row_perm: Vec<usize>,
    row_perm_inv: Vec<usize>,
    n: usize,
}

/// det A = sign · exp(log_abs) (sign 0 for an exactly singular matrix).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Determinant {
    /// −1, 0 or +1
    pub(crate) sign: f64,
    /// log |det A| (−∞ when singular)
    pub(crate) log_abs: f64,
}

/// sign (±1) of a permutation given as its forward index array
fn permutation_sign(fwd: &[usize]) -> f64 {
    let mut seen = vec![false; fwd.len()];
    let mut sign = 1.0;
    for start in 0..fwd.len() {
        let mut len = 0;
        let mut i = start;
        while !seen[i] {
            seen[i] = true;
            i = fwd[i];
            len += 1;
        }
        if len > 0 && len % 2 == 0 {
            sign = -sign;
        }
    }
    sign
}

impl SparseLu {
    /// factorise the `n × n` matrix given by triplets (duplicates are summed)
    pub(crate) fn new(n: usize, entries: &[Entry], what: &str) -> Result<Self> {
        let singular = || Error::SingularSystem {
            size: n,
            what: what.to_string(),
        };
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, entries)
            .map_err(|_| singular())?;
        let symbolic = factorize_symbolic_lu(
            a.symbolic(),
            LuSymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
                ..Default::default()
            },
        )
        .map_err(|_| singular())?;
        let mut numeric = SimplicialLu::new();
        let mut row_perm = vec![0usize; n];
        let mut row_perm_inv = vec![0usize; n];
        let req = factorize_simplicial_numeric_lu_scratch::<usize, f64>(n, n);
        let mut mem = MemBuffer::try_new(req).map_err(|_| singular())?;
        factorize_simplicial_numeric_lu(
            &mut row_perm,
            &mut row_perm_inv,
            &mut numeric,
            a.as_ref(),
            symbolic.col_perm(),
            MemStack::new(&mut mem),
        )
        .map_err(|_| singular())?;
        Ok(Self {
            symbolic,
            numeric,
            row_perm,
            row_perm_inv,
            n,
        })
    }

    fn row_perm(&self) -> PermRef<'_, usize> {
        PermRef::new_checked(&self.row_perm, &self.row_perm_inv, self.n)
    }

    fn solve_inplace(&self, b: MatMut<'_, f64>) {
        let k = b.ncols();
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(k, Par::Seq));
        self.numeric.solve_in_place_with_conj(
            self.row_perm(),
            self.symbolic.col_perm(),
            Conj::No,
            b,
            Par::Seq,
            MemStack::new(&mut mem),
        );
    }

    /// det A from the factors: sign(P)·sign(Q)·Π U_ii
    pub(crate) fn determinant(&self) -> Determinant {
        let u = self.numeric.u_factor_unsorted();
        let mut sign = permutation_sign(&self.row_perm)
            * permutation_sign(self.symbolic.col_perm().arrays().0);
        let mut log_abs = 0.0;
        for j in 0..self.n {
            let diag = u
                .row_idx_of_col(j)
                .zip(u.val_of_col(j))
                .find(|(i, _)| *i == j)
                .map_or(0.0, |(_, v)| *v);
            sign *= diag.signum() * f64::from(diag != 0.0);
            log_abs += diag.abs().ln();
        }
        Determinant { sign, log_abs }
    }

    /// solve in place for one right-hand side; fails on non-finite results (singular matrix)
    pub(crate) fn solve(&self, rhs: &mut [f64], what: &str) -> Result<()> {
        let mut b = Mat::<f64>::from_fn(self.n, 1, |i, _| rhs[i]);
        self.solve_inplace(b.as_mut());
        for i in 0..self.n {
            rhs[i] = b[(i, 0)];
        }
        if rhs.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(Error::SingularSystem {
                size: self.n,
                what: what.to_string(),
            })
        }
    }

    /// solve in place for several right-hand sides (columns of `b`)
    pub(crate) fn solve_mat(&self, b: &mut Mat<f64>, what: &str) -> Result<()> {
        self.solve_inplace(b.as_mut());
        for j in 0..b.ncols() {
            if !b.col_as_slice(j).iter().all(|v| v.is_finite()) {
                return Err(Error::SingularSystem {
                    size: self.n,
                    what: what.to_string(),
                });
            }
        }
        Ok(())
    }
}

/// Eigenvalues of a dense real matrix.
pub(crate) fn eigenvalues(a: &Mat<f64>) -> Result<Vec<Complex64>> {
    if !(0..a.ncols()).all(|j| a.col_as_slice(j).iter().all(|v| v.is_finite())) {
        return Err(Error::Eigen {
            size: a.nrows(),
            message: "matrix has non-finite entries".into(),
        });
    }
    let ev = a.eigenvalues().map_err(|e| Error::Eigen {
        size: a.nrows(),
        message: format!("{e:?}"),
    })?;
    Ok(ev.into_iter().map(|z| Complex64::new(z.re, z.im)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// determinant from the sparse LU versus nalgebra's dense LU (independent), 1e-12 relative
    fn check(n: usize, entries: &[Entry]) {
        let mut dense = DMatrix::<f64>::zeros(n, n);
        for e in entries {
            dense[(e.row, e.col)] += e.val;
        }
        let expected = dense.determinant();
        let d = SparseLu::new(n, entries, "test").expect("LU").determinant();
        let got = d.sign * d.log_abs.exp();
        assert!(
            (got - expected).abs() <= 1e-12 * expected.abs(),
            "{got} vs {expected}"
        );
    }

    #[test]
    fn determinant_sign_and_modulus_match_dense_lu() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for n in [1, 2, 5, 9] {
            for _ in 0..20 {
                let mut entries = Vec::new();
                for i in 0..n {
                    // a permuted (anti-)diagonal keeps it regular; random fill on top
                    entries.push(Entry::new(i, n - 1 - i, 2.0 + rnd()));
                    for j in 0..n {
                        if rnd() > 0.3 {
                            entries.push(Entry::new(i, j, rnd()));
                        }
                    }
                }
                check(n, &entries);
            }
        }
    }
}
