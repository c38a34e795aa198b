//! Thin wrappers around faer's sparse LU and dense eigenvalues.

use crate::error::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::lu::{
    LuRef, LuSymbolicParams, NumericLu, SymbolicLu, factorize_symbolic_lu,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, Mat, MatMut, Par};
use num_complex::Complex64;

/// Triplet (row, column, value) of a sparse matrix under assembly.
pub type Entry = Triplet<usize, usize, f64>;

/// Sparse LU factorisation of a square matrix (COLAMD column ordering, partial pivoting,
/// simplicial: the collocation matrices are too sparse for supernodes to pay off).
#[derive(Debug)]
pub(crate) struct SparseLu {
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    n: usize,
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
        let mut numeric = NumericLu::new();
        let req = symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|_| singular())?;
        symbolic
            .factorize_numeric_lu(
                &mut numeric,
                a.as_ref(),
                Par::Seq,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|_| singular())?;
        Ok(Self {
            symbolic,
            numeric,
            n,
        })
    }

    fn solve_inplace(&self, b: MatMut<'_, f64>) {
        let k = b.ncols();
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric);
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(k, Par::Seq));
        lu.solve_in_place_with_conj(Conj::No, b, Par::Seq, MemStack::new(&mut mem));
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
