//! Thin wrappers around faer's sparse LU and dense eigenvalues.

use crate::error::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::lu::simplicial::{
    self, SimplicialLu, factorize_simplicial_numeric_lu, factorize_simplicial_numeric_lu_scratch,
};
use faer::sparse::linalg::lu::supernodal::{
    self, SupernodalLu, SymbolicSupernodalLu, factorize_supernodal_numeric_lu,
    factorize_supernodal_numeric_lu_scratch, factorize_supernodal_symbolic_lu,
    factorize_supernodal_symbolic_lu_scratch,
};
use faer::sparse::linalg::lu::{LuSymbolicParams, factorize_symbolic_lu};
use faer::sparse::linalg::qr::{
    col_etree, col_etree_scratch, column_counts_aat_scratch, column_counts_ata, postorder,
    postorder_scratch,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, Mat, MatMut, Par};
use num_complex::Complex64;

/// Triplet (row, column, value) of a sparse matrix under assembly.
pub type Entry = Triplet<usize, usize, f64>;

/// Which sparse LU to compute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Factorisation<'o> {
    /// Simplicial LU in the given column elimination order (forward array: the k-th
    /// eliminated column is `order[k]`; COLAMD when None). Keeps U's diagonal, so
    /// [`SparseLu::determinant`] is available (the branch-point test needs it).
    WithDeterminant(Option<&'o [usize]>),
    /// For systems of at least [`SUPERNODAL_MIN_SIZE`] unknowns a supernodal LU (dense
    /// kernels on blocks of columns) in COLAMD order; below, the simplicial LU in the given
    /// order (COLAMD when None). Supernodes win where the factors fill, as they do for DDE
    /// collocation (periodic wrap-around plus the delayed coupling): measured 2–3× faster on
    /// the cycle and fold-of-cycles systems of the delayed closed loop at τ = 0.4 s (COLAMD
    /// beat the systems' band orders there by ~10 %). No determinant.
    Fast(Option<&'o [usize]>),
}

/// Smallest system factorised with supernodes by [`Factorisation::Fast`].
pub(crate) const SUPERNODAL_MIN_SIZE: usize = 200;

/// Sparse LU factorisation P·A·Q = L·U of a square matrix (partial pivoting P; the column
/// ordering Q and the kind of factors as chosen by [`Factorisation`]).
#[derive(Debug)]
pub(crate) struct SparseLu {
    factors: Factors,
    row_perm: Vec<usize>,
    row_perm_inv: Vec<usize>,
    col_perm: Vec<usize>,
    col_perm_inv: Vec<usize>,
    n: usize,
}

#[derive(Debug)]
enum Factors {
    Simplicial(SimplicialLu<usize, f64>),
    Supernodal(SupernodalLu<usize, f64>),
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

/// COLAMD column ordering of `a` (forward array)
fn colamd_order(a: &SparseColMat<usize, f64>) -> Option<Vec<usize>> {
    let symbolic = factorize_symbolic_lu(
        a.symbolic(),
        LuSymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        },
    )
    .ok()?;
    Some(symbolic.col_perm().arrays().0.to_vec())
}

/// inverse of the permutation `fwd`; None unless `fwd` is a permutation of 0..n
fn inverse_permutation(fwd: &[usize], n: usize) -> Option<Vec<usize>> {
    if fwd.len() != n {
        return None;
    }
    let mut inv = vec![usize::MAX; n];
    for (k, &j) in fwd.iter().enumerate() {
        if j >= n || inv[j] != usize::MAX {
            return None;
        }
        inv[j] = k;
    }
    Some(inv)
}

impl SparseLu {
    /// factorise the `n × n` matrix given by triplets (duplicates are summed)
    pub(crate) fn new(
        n: usize,
        entries: &[Entry],
        factorisation: Factorisation<'_>,
        what: &str,
    ) -> Result<Self> {
        let singular = || Error::SingularSystem {
            size: n,
            what: what.to_string(),
        };
        let matrix = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, entries)
            .map_err(|_| singular())?;
        let (order, supernodes) = match factorisation {
            Factorisation::WithDeterminant(order) => (order, false),
            Factorisation::Fast(_) if n >= SUPERNODAL_MIN_SIZE => (None, true),
            Factorisation::Fast(order) => (order, false),
        };
        let col_perm = match order {
            Some(o) => o.to_vec(),
            None => colamd_order(&matrix).ok_or_else(singular)?,
        };
        let col_perm_inv = inverse_permutation(&col_perm, n).ok_or_else(|| {
            Error::InvalidInput(format!(
                "{what}: the column order is not a permutation of 0..{n}"
            ))
        })?;
        let mut lu = Self {
            factors: Factors::Simplicial(SimplicialLu::new()),
            row_perm: vec![0; n],
            row_perm_inv: vec![0; n],
            col_perm,
            col_perm_inv,
            n,
        };
        let done = if supernodes {
            lu.factorise_supernodal(&matrix)
        } else {
            lu.factorise_simplicial(&matrix)
        };
        done.ok_or_else(singular)?;
        Ok(lu)
    }

    fn factorise_simplicial(&mut self, a: &SparseColMat<usize, f64>) -> Option<()> {
        let n = self.n;
        let mut numeric = SimplicialLu::new();
        let req = factorize_simplicial_numeric_lu_scratch::<usize, f64>(n, n);
        let mut mem = MemBuffer::try_new(req).ok()?;
        factorize_simplicial_numeric_lu(
            &mut self.row_perm,
            &mut self.row_perm_inv,
            &mut numeric,
            a.as_ref(),
            PermRef::new_checked(&self.col_perm, &self.col_perm_inv, n),
            MemStack::new(&mut mem),
        )
        .ok()?;
        self.factors = Factors::Simplicial(numeric);
        Some(())
    }

    /// supernodal factors in the column order: the column elimination tree and column
    /// counts of AᵀA, the supernodal structure, then the numeric factorisation (sequential,
    /// so deterministic)
    fn factorise_supernodal(&mut self, a: &SparseColMat<usize, f64>) -> Option<()> {
        let n = self.n;
        let at = a.as_ref().transpose().to_col_major().ok()?;
        let col_perm = PermRef::new_checked(&self.col_perm, &self.col_perm_inv, n);
        let symbolic = self.supernodal_structure(a, &at, col_perm)?;
        let mut numeric = SupernodalLu::new();
        let req =
            factorize_supernodal_numeric_lu_scratch::<usize, f64>(&symbolic, Default::default());
        let mut mem = MemBuffer::try_new(req).ok()?;
        factorize_supernodal_numeric_lu(
            &mut self.row_perm,
            &mut self.row_perm_inv,
            &mut numeric,
            a.as_ref(),
            at.as_ref(),
            col_perm,
            &symbolic,
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .ok()?;
        self.factors = Factors::Supernodal(numeric);
        Some(())
    }

    fn supernodal_structure(
        &self,
        a: &SparseColMat<usize, f64>,
        at: &SparseColMat<usize, f64>,
        col_perm: PermRef<'_, usize>,
    ) -> Option<SymbolicSupernodalLu<usize>> {
        let n = self.n;
        let mut etree_buf = vec![0usize; n];
        let mut post = vec![0usize; n];
        let mut min_col = vec![0usize; n];
        let mut col_counts = vec![0usize; n];
        let mut mem = MemBuffer::try_new(col_etree_scratch::<usize>(n, n)).ok()?;
        let etree = col_etree(
            a.symbolic(),
            Some(col_perm),
            &mut etree_buf,
            MemStack::new(&mut mem),
        );
        let mut mem = MemBuffer::try_new(postorder_scratch::<usize>(n)).ok()?;
        postorder(&mut post, etree, MemStack::new(&mut mem));
        let mut mem = MemBuffer::try_new(column_counts_aat_scratch::<usize>(n, n)).ok()?;
        column_counts_ata(
            &mut col_counts,
            &mut min_col,
            at.symbolic(),
            Some(col_perm),
            etree,
            &post,
            MemStack::new(&mut mem),
        );
        let mut mem =
            MemBuffer::try_new(factorize_supernodal_symbolic_lu_scratch::<usize>(n, n)).ok()?;
        factorize_supernodal_symbolic_lu(
            a.symbolic(),
            Some(col_perm),
            &min_col,
            etree,
            &col_counts,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .ok()
    }

    fn solve_inplace(&self, b: MatMut<'_, f64>) {
        let (k, n) = (b.ncols(), self.n);
        let row_perm = PermRef::new_checked(&self.row_perm, &self.row_perm_inv, n);
        let col_perm = PermRef::new_checked(&self.col_perm, &self.col_perm_inv, n);
        let mut mem = MemBuffer::new(match &self.factors {
            Factors::Simplicial(_) => {
                simplicial::solve_in_place_scratch::<usize, f64>(n, k, Par::Seq)
            }
            Factors::Supernodal(_) => {
                supernodal::solve_in_place_scratch::<usize, f64>(n, k, Par::Seq)
            }
        });
        let stack = MemStack::new(&mut mem);
        match &self.factors {
            Factors::Simplicial(f) => {
                f.solve_in_place_with_conj(row_perm, col_perm, Conj::No, b, Par::Seq, stack)
            }
            Factors::Supernodal(f) => {
                f.solve_in_place_with_conj(row_perm, col_perm, Conj::No, b, Par::Seq, stack)
            }
        }
    }

    /// det A from the factors: sign(P)·sign(Q)·Π U_ii; None unless factorised with
    /// [`Factorisation::WithDeterminant`]
    pub(crate) fn determinant(&self) -> Option<Determinant> {
        let Factors::Simplicial(numeric) = &self.factors else {
            return None;
        };
        let u = numeric.u_factor_unsorted();
        let mut sign = permutation_sign(&self.row_perm) * permutation_sign(&self.col_perm);
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
        Some(Determinant { sign, log_abs })
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
        // COLAMD and a caller-supplied (reversed) column order
        let reversed: Vec<usize> = (0..n).rev().collect();
        for order in [None, Some(reversed.as_slice())] {
            let lu = SparseLu::new(n, entries, Factorisation::WithDeterminant(order), "test")
                .expect("LU");
            let d = lu.determinant().expect("simplicial factors");
            let got = d.sign * d.log_abs.exp();
            assert!(
                (got - expected).abs() <= 1e-12 * expected.abs(),
                "{got} vs {expected}"
            );
        }
    }

    /// the fast factors (COLAMD, simplicial or supernodal) solve like the simplicial ones:
    /// a periodic band with long-range coupling (the pattern of DDE collocation, n = 600,
    /// large enough for supernodes) against the residual of the dense product, 1e-10
    #[test]
    fn fast_factors_solve_like_simplicial_ones() {
        let n = 600;
        let mut entries = Vec::new();
        for i in 0..n {
            entries.push(Entry::new(i, i, 4.0 + (i % 7) as f64 * 0.1));
            for d in 1..6 {
                entries.push(Entry::new(i, (i + d) % n, 0.3 / d as f64));
                entries.push(Entry::new(i, (i + n - d) % n, -0.2 / d as f64));
            }
            entries.push(Entry::new(i, (i + n / 3) % n, 0.5));
        }
        let rhs: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let mut x_fast = rhs.clone();
        let fast = SparseLu::new(n, &entries, Factorisation::Fast(None), "test").expect("LU");
        fast.solve(&mut x_fast, "test").expect("solve");
        assert!(fast.determinant().is_none());
        let mut x_simpl = rhs.clone();
        SparseLu::new(n, &entries, Factorisation::WithDeterminant(None), "test")
            .expect("LU")
            .solve(&mut x_simpl, "test")
            .expect("solve");
        let mut ax = vec![0.0; n];
        for e in &entries {
            ax[e.row] += e.val * x_fast[e.col];
        }
        for i in 0..n {
            assert!(
                (ax[i] - rhs[i]).abs() < 1e-10,
                "row {i}: {} vs {}",
                ax[i],
                rhs[i]
            );
            assert!((x_fast[i] - x_simpl[i]).abs() < 1e-10 * (1.0 + x_simpl[i].abs()));
        }
    }

    /// a column order that is not a permutation is a typed error, not a panic
    #[test]
    fn invalid_column_order_is_an_error() {
        let entries = [Entry::new(0, 0, 1.0), Entry::new(1, 1, 2.0)];
        for order in [&[0, 0][..], &[0][..]] {
            let f = Factorisation::WithDeterminant(Some(order));
            assert!(SparseLu::new(2, &entries, f, "test").is_err());
        }
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
