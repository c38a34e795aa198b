//! The factorised Newton matrices of the continuation systems and the choice between the
//! solvers ([`LinearSolver`]): faer's sparse LU (simplicial with the determinant, or
//! supernodal), the structured Krylov solver of collocation systems (the mesh-local part
//! factorised, the delayed couplings by GMRES), the bordered band solver of ODE collocation
//! ([`BandedLu`]) and the block-forward solver of delay collocation ([`PeriodicForwardLu`]),
//! all behind one [`SparseLu`].

use crate::banded::BandedLu;
use crate::block_forward::{ForwardMonodromy, PeriodicForwardLu};
use crate::error::{Error, Result};
use crate::linalg::{
    Csr, Determinant, Entry, KrylovOperator, MeshStructure, gmres, permutation_sign,
};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::SparseColMat;
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
use faer::{Conj, Mat, MatMut, Par};
use serde::{Deserialize, Serialize};
use std::cell::OnceCell;

/// How the bordered Newton systems of a collocation system (periodic orbits and the
/// extended systems of folds, tori and period doublings of cycles) are solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinearSolver {
    /// one sparse LU of the whole system (faer, supernodal where large; an ODE's cycle,
    /// whose collocation is banded up to the wrap and the borders, by the band solver).
    /// Exact; for delay equations the delayed coupling (reaching τ/T of the period back)
    /// and the periodic wrap-around fill the factors: the cost grows like L^2.5 to L^3 for
    /// a fixed τ/T.
    SparseLu,
    /// The structured solver: the Jacobian split as J = P + E, where P holds the
    /// mesh-local couplings (each collocation row with the nodes of its own interval, the
    /// periodic wrap, the border rows and columns) and every delayed coupling moved to the
    /// collocation point itself (the delayed value x(s − τ/T) read as x(s): the equations
    /// with the delays set to zero), and E = J − P. P is banded up to the wrap-around and
    /// the borders: its sparse LU in the systems' node order costs O(L). J x = b is then
    /// solved by GMRES on J P⁻¹ = I + E P⁻¹ (right preconditioning), whose spectrum
    /// clusters at 1 (E P⁻¹ is the discretisation of a compact operator), to the relative
    /// residual [`KRYLOV_TOLERANCE`](crate::KRYLOV_TOLERANCE) checked with the true
    /// residual; the iteration count does not grow with L, so a solve costs O(L). For ODEs
    /// E = 0 and the LU of P is the exact (direct) solve. If GMRES does not converge the whole system is factorised as
    /// with [`LinearSolver::SparseLu`]. Where the engine needs the determinant (the
    /// branch-point test of one-parameter branches) and E ≠ 0, the direct LU is used.
    Krylov,
    /// Block elimination of a delay equation's collocation (`block_forward.rs`): the
    /// collocation integrated forward interval by interval (dense LU of each interval's
    /// block, no fill), the periodic wrap and the delayed history of the first τ/T of the
    /// period reached ahead carried by K ≈ (τ/T·L + 1)·m·n border unknowns, whose Schur
    /// complement is factorised densely. Exact, with the determinant; cost
    /// O(K·(nnz + L·(m·n)²) + K³). An ODE's cycle fits too (x₀ is the only column reached
    /// ahead: K = n plus the borders). Systems it does not fit (fewer than 120 unknowns,
    /// an extended system without mesh blocks) get the sparse LU (ODEs: the band solver).
    BlockForward,
    /// [`LinearSolver::BlockForward`] where the system fits it, else
    /// [`LinearSolver::Krylov`] for systems of at least [`KRYLOV_MIN_SIZE`] unknowns and
    /// [`LinearSolver::SparseLu`] below (see `benches/fold_cycles.rs`
    /// and `crates/sway/benches/closed_loop_mesh.rs` for the measured costs)
    #[default]
    Auto,
}

/// smallest system solved by GMRES under [`LinearSolver::Auto`]
pub const KRYLOV_MIN_SIZE: usize = 2000;

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
    /// collocation (periodic wrap-around plus the delayed coupling), and there COLAMD beats
    /// the systems' band orders. No determinant.
    Fast(Option<&'o [usize]>),
    /// The bordered band solver ([`BandedLu`]) where the matrix is a narrow band up to a
    /// border and a periodic wrap in the given column order (an ODE's collocation: cost
    /// linear in the mesh, with the determinant); else as [`Self::WithDeterminant`].
    Banded(Option<&'o [usize]>),
}

/// Smallest system factorised with supernodes by [`Factorisation::Fast`].
pub(crate) const SUPERNODAL_MIN_SIZE: usize = 200;

/// Sparse LU factorisation P·A·Q = L·U of a square matrix (partial pivoting P; the column
/// ordering Q and the kind of factors as chosen by [`Factorisation`]).
#[derive(Debug)]
struct DirectLu {
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

impl DirectLu {
    /// factorise the `n × n` matrix given by triplets (duplicates are summed)
    fn new(
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
            Factorisation::WithDeterminant(order) | Factorisation::Banded(order) => (order, false),
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
    fn determinant(&self) -> Option<Determinant> {
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

    /// solve in place for one right-hand side (no check of the result)
    fn solve_raw(&self, rhs: &mut [f64]) {
        let mut b = Mat::<f64>::from_fn(self.n, 1, |i, _| rhs[i]);
        self.solve_inplace(b.as_mut());
        for i in 0..self.n {
            rhs[i] = b[(i, 0)];
        }
    }
}

/// the preconditioned Krylov solver of [`LinearSolver::Krylov`]
#[derive(Debug)]
struct KrylovLu {
    n: usize,
    /// LU of P
    precond: Box<SparseLu>,
    /// E = J − P
    coupling: Csr,
    /// J itself, for the true residual
    matrix: Csr,
    /// the triplets of J, for the direct fallback
    entries: Vec<Entry>,
    fallback: OnceCell<Option<DirectLu>>,
}

impl KrylovOperator for KrylovLu {
    fn dim(&self) -> usize {
        self.n
    }

    /// w = J P⁻¹ v = v + E P⁻¹ v
    fn apply_preconditioned(&self, v: &[f64], w: &mut [f64]) {
        let mut z = v.to_vec();
        self.precond.solve_unchecked(&mut z);
        w.copy_from_slice(v);
        self.coupling.mul_add(&z, w);
    }

    fn precondition(&self, z: &mut [f64]) {
        self.precond.solve_unchecked(z);
    }

    fn residual(&self, b: &[f64], x: &[f64], r: &mut [f64]) {
        r.copy_from_slice(b);
        let minus_x: Vec<f64> = x.iter().map(|v| -v).collect();
        self.matrix.mul_add(&minus_x, r);
    }
}

impl KrylovLu {
    fn solve_raw(&self, rhs: &mut [f64]) {
        let b = rhs.to_vec();
        if gmres(self, &b, rhs) {
            return;
        }
        let direct = self.fallback.get_or_init(|| {
            DirectLu::new(self.n, &self.entries, Factorisation::Fast(None), "fallback").ok()
        });
        match direct {
            Some(lu) => {
                rhs.copy_from_slice(&b);
                lu.solve_raw(rhs);
            }
            None => rhs.iter_mut().for_each(|v| *v = f64::NAN),
        }
    }
}

/// A factorised square sparse matrix: the direct sparse LU or the structured solver of
/// [`LinearSolver::Krylov`].
#[derive(Debug)]
pub(crate) struct SparseLu {
    kind: Kind,
    n: usize,
}

#[derive(Debug)]
enum Kind {
    Direct(Box<DirectLu>),
    Krylov(Box<KrylovLu>),
    /// a bordered band matrix ([`BandedLu`]: ODE collocation, cost linear in the mesh)
    Banded(Box<BandedLu>),
    /// block elimination of a delay equation's collocation ([`PeriodicForwardLu`])
    Forward(Box<PeriodicForwardLu>),
}

impl SparseLu {
    /// factorise the `n × n` matrix given by triplets (duplicates are summed): the band
    /// solver for [`Factorisation::Banded`] where the matrix has that shape, else the sparse
    /// LU.
    pub(crate) fn new(
        n: usize,
        entries: &[Entry],
        factorisation: Factorisation<'_>,
        what: &str,
    ) -> Result<Self> {
        if let Factorisation::Banded(order) = factorisation
            && let Some(lu) = BandedLu::new(n, entries, order)
        {
            return Ok(Self {
                kind: Kind::Banded(Box::new(lu)),
                n,
            });
        }
        Ok(Self {
            kind: Kind::Direct(Box::new(DirectLu::new(n, entries, factorisation, what)?)),
            n,
        })
    }

    /// factorise with the structured solver where `structure` is given (see
    /// [`LinearSolver::Krylov`]): without delayed couplings the LU of P is exact (and has
    /// the determinant); with, a determinant request gets the direct LU
    pub(crate) fn structured(
        n: usize,
        entries: &[Entry],
        factorisation: Factorisation<'_>,
        structure: Option<&MeshStructure>,
        what: &str,
    ) -> Result<Self> {
        if let Some(st) = structure.filter(|s| s.block_forward)
            && let Some(lu) = PeriodicForwardLu::new(
                n,
                entries,
                st,
                matches!(factorisation, Factorisation::WithDeterminant(_)),
            )
        {
            return Ok(Self {
                kind: Kind::Forward(Box::new(lu)),
                n,
            });
        }
        let Some(structure) = structure.filter(|s| n >= s.min_size) else {
            return Self::new(n, entries, factorisation, what);
        };
        let order = match factorisation {
            Factorisation::WithDeterminant(o)
            | Factorisation::Fast(o)
            | Factorisation::Banded(o) => o,
        };
        let (p, e) = structure.split(entries);
        if e.is_empty() {
            let exact = match factorisation {
                Factorisation::Banded(_) => factorisation,
                _ => Factorisation::WithDeterminant(order),
            };
            return Self::new(n, &p, exact, what);
        }
        if let Factorisation::WithDeterminant(_) | Factorisation::Banded(_) = factorisation {
            return Self::new(n, entries, factorisation, what);
        }
        let precond = match Self::new(n, &p, Factorisation::WithDeterminant(order), what) {
            Ok(lu) => lu,
            // P singular: the whole system directly
            Err(_) => return Self::new(n, entries, Factorisation::Fast(None), what),
        };
        Ok(Self {
            kind: Kind::Krylov(Box::new(KrylovLu {
                n,
                precond: Box::new(precond),
                coupling: Csr::new(n, &e),
                matrix: Csr::new(n, entries),
                entries: entries.to_vec(),
                fallback: OnceCell::new(),
            })),
            n,
        })
    }

    /// solve in place for one right-hand side without checking the result
    fn solve_unchecked(&self, rhs: &mut [f64]) {
        match &self.kind {
            Kind::Direct(lu) => lu.solve_raw(rhs),
            Kind::Krylov(k) => k.solve_raw(rhs),
            Kind::Banded(lu) => lu.solve(rhs),
            Kind::Forward(lu) => lu.solve(rhs),
        }
    }

    /// det A (None unless direct factors made with [`Factorisation::WithDeterminant`])
    pub(crate) fn determinant(&self) -> Option<Determinant> {
        match &self.kind {
            Kind::Direct(lu) => lu.determinant(),
            Kind::Krylov(_) => None,
            Kind::Banded(lu) => Some(lu.determinant()),
            Kind::Forward(lu) => lu.determinant(),
        }
    }

    /// the monodromy operator read off a block-forward factorisation of a periodic
    /// collocation ([`ForwardMonodromy`]; None for the other
    /// solvers)
    pub(crate) fn forward_monodromy(&self) -> Option<ForwardMonodromy<'_>> {
        match &self.kind {
            Kind::Forward(lu) => Some(lu.monodromy()),
            _ => None,
        }
    }

    /// solve in place for one right-hand side; fails on non-finite results (singular matrix)
    pub(crate) fn solve(&self, rhs: &mut [f64], what: &str) -> Result<()> {
        self.solve_unchecked(rhs);
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
        match &self.kind {
            Kind::Direct(lu) => lu.solve_inplace(b.as_mut()),
            Kind::Banded(lu) => {
                for j in 0..b.ncols() {
                    lu.solve(b.col_as_slice_mut(j));
                }
            }
            Kind::Forward(lu) => {
                for j in 0..b.ncols() {
                    lu.solve(b.col_as_slice_mut(j));
                }
            }
            Kind::Krylov(k) => {
                let mut col = vec![0.0; self.n];
                for j in 0..b.ncols() {
                    col.copy_from_slice(b.col_as_slice(j));
                    k.solve_raw(&mut col);
                    b.col_as_slice_mut(j).copy_from_slice(&col);
                }
            }
        }
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
