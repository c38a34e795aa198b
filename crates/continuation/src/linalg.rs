//! Thin wrappers around faer's sparse LU and dense eigenvalues, and the structured solver
//! of collocation systems ([`LinearSolver::Krylov`]): the mesh-local part of the Jacobian
//! factorised by sparse LU, the delayed couplings by GMRES with that factorisation as its
//! preconditioner.

use crate::banded::BandedLu;
use crate::block_forward::PeriodicForwardLu;
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
use serde::{Deserialize, Serialize};
use std::cell::OnceCell;

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

/// det A = sign · exp(log_abs) (sign 0 for an exactly singular matrix).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Determinant {
    /// −1, 0 or +1
    pub(crate) sign: f64,
    /// log |det A| (−∞ when singular)
    pub(crate) log_abs: f64,
}

/// sign (±1) of a permutation given as its forward index array
pub(crate) fn permutation_sign(fwd: &[usize]) -> f64 {
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
    /// residual [`KRYLOV_TOLERANCE`] checked with the true residual; the iteration count
    /// does not grow with L, so a solve costs O(L). For ODEs E = 0 and the LU of P is the
    /// exact (direct) solve. If GMRES does not converge the whole system is factorised as
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

/// relative residual ‖b − J x‖ / ‖b‖ to which [`LinearSolver::Krylov`] solves
pub const KRYLOV_TOLERANCE: f64 = 1e-12;
/// largest Krylov space per GMRES cycle
const KRYLOV_MAX_ITERATIONS: usize = 150;
/// GMRES cycles (restarts from the true residual) before the direct fallback
const KRYLOV_MAX_CYCLES: usize = 3;

/// Where the unknowns and equations of a collocation system sit on its mesh, for
/// [`LinearSolver::Krylov`]: profile-sized column blocks (node g, component k at
/// `offset + g·n + k`, g < L·m; the node L·m is node 0) and collocation row blocks (point
/// c of interval i, component r at `offset + (i·m + c)·n + r`). All other rows and columns
/// are borders.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshStructure {
    pub(crate) n: usize,
    pub(crate) m: usize,
    pub(crate) intervals: usize,
    pub(crate) column_blocks: Vec<usize>,
    pub(crate) row_blocks: Vec<usize>,
    /// smaller systems are factorised directly (by [`LinearSolver::Krylov`]'s split)
    pub(crate) min_size: usize,
    /// the block-forward solver first ([`LinearSolver::Auto`], [`LinearSolver::BlockForward`])
    pub(crate) block_forward: bool,
    /// ℓ_j(ξ_c) at the collocation points, row c: `basis[c * (m + 1) + j]`
    pub(crate) basis: Vec<f64>,
}

impl MeshStructure {
    /// (block offset, node, component) of column `col`, None for a border column
    fn column(&self, col: usize) -> Option<(usize, usize, usize)> {
        let size = self.n * self.intervals * self.m;
        self.column_blocks
            .iter()
            .find(|&&o| (o..o + size).contains(&col))
            .map(|&o| (o, (col - o) / self.n, (col - o) % self.n))
    }

    /// (interval, collocation point) of row `row`, None for a border row
    fn row(&self, row: usize) -> Option<(usize, usize)> {
        let size = self.n * self.intervals * self.m;
        self.row_blocks
            .iter()
            .find(|&&o| (o..o + size).contains(&row))
            .map(|&o| {
                let p = (row - o) / self.n;
                (p / self.m, p % self.m)
            })
    }

    /// Split the triplets of J into P (local, delayed couplings moved to the collocation
    /// point) and E = J − P (see [`LinearSolver::Krylov`]).
    fn split(&self, entries: &[Entry]) -> (Vec<Entry>, Vec<Entry>) {
        let (m, nodes) = (self.m, self.intervals * self.m);
        let mut p = Vec::with_capacity(entries.len());
        let mut e = Vec::new();
        for en in entries {
            let (Some((i, c)), Some((off, g, k))) = (self.row(en.row), self.column(en.col)) else {
                p.push(*en);
                continue;
            };
            if (g + nodes - (i * m) % nodes) % nodes <= m {
                p.push(*en);
                continue;
            }
            e.push(*en);
            for j in 0..=m {
                let w = en.val * self.basis[c * (m + 1) + j];
                let col = off + ((i * m + j) % nodes) * self.n + k;
                p.push(Entry::new(en.row, col, w));
                e.push(Entry::new(en.row, col, -w));
            }
        }
        (p, e)
    }
}

/// The counting sort of items by their rows (`rows` of them, the items' order kept within
/// a row): the row pointers (row r holds slots `ptr[r]..ptr[r + 1]`) and each item's slot.
pub(crate) fn sorted_by_rows(
    rows: usize,
    row_of: impl Iterator<Item = usize> + Clone,
) -> (Vec<usize>, Vec<usize>) {
    let mut ptr = vec![0; rows + 1];
    for r in row_of.clone() {
        ptr[r + 1] += 1;
    }
    for r in 0..rows {
        ptr[r + 1] += ptr[r];
    }
    let mut next = ptr.clone();
    let slots = row_of
        .map(|r| {
            next[r] += 1;
            next[r] - 1
        })
        .collect();
    (ptr, slots)
}

/// compressed sparse rows (duplicates summed)
#[derive(Debug)]
pub(crate) struct Csr {
    ptr: Vec<usize>,
    idx: Vec<usize>,
    val: Vec<f64>,
}

impl Csr {
    /// `n` rows of the triplets `entries` (duplicates summed)
    pub(crate) fn new(n: usize, entries: &[Entry]) -> Self {
        let mut sorted: Vec<(usize, usize, f64)> =
            entries.iter().map(|e| (e.row, e.col, e.val)).collect();
        sorted.sort_by_key(|a| (a.0, a.1));
        let mut ptr = vec![0; n + 1];
        let mut idx = Vec::with_capacity(sorted.len());
        let mut val: Vec<f64> = Vec::with_capacity(sorted.len());
        let mut last = (usize::MAX, usize::MAX);
        for (r, c, v) in sorted {
            if (r, c) == last {
                if let Some(x) = val.last_mut() {
                    *x += v;
                }
                continue;
            }
            last = (r, c);
            idx.push(c);
            val.push(v);
            ptr[r + 1] = idx.len();
        }
        for r in 0..n {
            ptr[r + 1] = ptr[r + 1].max(ptr[r]);
        }
        Self { ptr, idx, val }
    }

    /// the matrix of the row pointers, column indices and values of its stored entries
    pub(crate) fn from_parts(ptr: Vec<usize>, idx: Vec<usize>, val: Vec<f64>) -> Self {
        debug_assert!(idx.len() == val.len() && ptr.last() == Some(&idx.len()));
        Self { ptr, idx, val }
    }

    /// `n` rows of the triplets `entries` by a counting sort: O(nnz), duplicates kept
    /// (products sum them)
    pub(crate) fn by_rows(n: usize, entries: &[(usize, usize, f64)]) -> Self {
        let (ptr, slots) = sorted_by_rows(n, entries.iter().map(|e| e.0));
        let mut idx = vec![0; entries.len()];
        let mut val = vec![0.0; entries.len()];
        for (&(_, c, v), &at) in entries.iter().zip(&slots) {
            idx[at] = c;
            val[at] = v;
        }
        Self { ptr, idx, val }
    }

    /// the (column, value) pairs of row r
    pub(crate) fn row(&self, r: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let q = self.ptr[r]..self.ptr[r + 1];
        self.idx[q.clone()]
            .iter()
            .copied()
            .zip(self.val[q].iter().copied())
    }

    /// y += A x
    pub(crate) fn mul_add(&self, x: &[f64], y: &mut [f64]) {
        for (r, yr) in y.iter_mut().enumerate() {
            let mut s = 0.0;
            for q in self.ptr[r]..self.ptr[r + 1] {
                s += self.val[q] * x[self.idx[q]];
            }
            *yr += s;
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
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

/// A linear operator for [`gmres`]: x = A⁻¹ b with a right preconditioner M.
pub(crate) trait KrylovOperator {
    /// the size of A
    fn dim(&self) -> usize;
    /// w = A M⁻¹ v
    fn apply_preconditioned(&self, v: &[f64], w: &mut [f64]);
    /// z ← M⁻¹ z
    fn precondition(&self, z: &mut [f64]);
    /// r = b − A x
    fn residual(&self, b: &[f64], x: &[f64], r: &mut [f64]);
}

/// w ← w minus its projection on the orthonormal `basis`, by modified Gram–Schmidt twice
/// (keeps the basis orthogonal to rounding); the projection coefficients, with room for
/// one more (the new vector's norm)
fn orthogonalise(basis: &[Vec<f64>], w: &mut [f64]) -> Vec<f64> {
    let mut col = vec![0.0; basis.len() + 1];
    for _ in 0..2 {
        for (i, v) in basis.iter().enumerate() {
            let hij = dot(w, v);
            col[i] += hij;
            w.iter_mut().zip(v).for_each(|(a, b)| *a -= hij * b);
        }
    }
    col
}

/// x = A⁻¹ b by restarted, right-preconditioned GMRES (modified Gram–Schmidt twice,
/// Givens rotations) to the relative residual [`KRYLOV_TOLERANCE`], checked with the true
/// residual; false if it was not reached in [`KRYLOV_MAX_CYCLES`] cycles
pub(crate) fn gmres<O: KrylovOperator>(op: &O, b: &[f64], x: &mut [f64]) -> bool {
    x.iter_mut().for_each(|v| *v = 0.0);
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        return true;
    }
    let tol = KRYLOV_TOLERANCE * bnorm;
    let mut r = b.to_vec();
    for cycle in 0..KRYLOV_MAX_CYCLES {
        if cycle > 0 {
            op.residual(b, x, &mut r);
        }
        let rnorm = dot(&r, &r).sqrt();
        if !rnorm.is_finite() {
            return false;
        }
        if rnorm <= tol {
            return true;
        }
        gmres_cycle(op, &r, rnorm, tol, x);
    }
    op.residual(b, x, &mut r);
    dot(&r, &r).sqrt() <= tol
}

/// one GMRES cycle on A M⁻¹ d' = r (‖r‖ = rnorm) from d' = 0; x += M⁻¹ d'
fn gmres_cycle<O: KrylovOperator>(op: &O, r: &[f64], rnorm: f64, tol: f64, x: &mut [f64]) {
    let n = op.dim();
    let kmax = KRYLOV_MAX_ITERATIONS.min(n);
    let mut basis: Vec<Vec<f64>> = vec![r.iter().map(|v| v / rnorm).collect()];
    let mut h: Vec<Vec<f64>> = Vec::with_capacity(kmax);
    let (mut cs, mut sn): (Vec<f64>, Vec<f64>) =
        (Vec::with_capacity(kmax), Vec::with_capacity(kmax));
    let mut g = vec![0.0; kmax + 1];
    g[0] = rnorm;
    let mut k = 0;
    while k < kmax {
        let mut w = vec![0.0; n];
        op.apply_preconditioned(&basis[k], &mut w);
        let mut col = orthogonalise(&basis, &mut w);
        let hnext = dot(&w, &w).sqrt();
        col[k + 1] = hnext;
        for i in 0..k {
            let t = cs[i] * col[i] + sn[i] * col[i + 1];
            col[i + 1] = -sn[i] * col[i] + cs[i] * col[i + 1];
            col[i] = t;
        }
        let rho = (col[k] * col[k] + col[k + 1] * col[k + 1]).sqrt();
        let (c, s) = if rho == 0.0 {
            (1.0, 0.0)
        } else {
            (col[k] / rho, col[k + 1] / rho)
        };
        cs.push(c);
        sn.push(s);
        col[k] = rho;
        col[k + 1] = 0.0;
        g[k + 1] = -s * g[k];
        g[k] *= c;
        h.push(col);
        k += 1;
        if g[k].abs() <= tol || hnext == 0.0 || !hnext.is_finite() {
            break;
        }
        basis.push(w.iter().map(|v| v / hnext).collect());
    }
    // y from the triangular system, d = M⁻¹ (V y)
    let mut y = vec![0.0; k];
    for i in (0..k).rev() {
        let mut s = g[i];
        for j in i + 1..k {
            s -= h[j][i] * y[j];
        }
        y[i] = if h[i][i] != 0.0 { s / h[i][i] } else { 0.0 };
    }
    let mut z = vec![0.0; n];
    for (yi, v) in y.iter().zip(&basis) {
        z.iter_mut().zip(v).for_each(|(a, b)| *a += yi * b);
    }
    op.precondition(&mut z);
    x.iter_mut().zip(&z).for_each(|(a, b)| *a += b);
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
    /// collocation ([`crate::block_forward::ForwardMonodromy`]; None for the other
    /// solvers)
    pub(crate) fn forward_monodromy(&self) -> Option<crate::block_forward::ForwardMonodromy<'_>> {
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

/// Arnoldi's dominant eigenvalues are accepted when they move by less than this times
/// max(1, |θ₁|) as the Krylov space grows by [`ARNOLDI_GROWTH`]
const ARNOLDI_TOLERANCE: f64 = 1e-12;
/// basis vectors added between two convergence checks
const ARNOLDI_GROWTH: usize = 8;

/// Decreasing modulus: the order of Floquet multipliers (a `fn` item, so that the sorts of
/// the problem-generic callers are compiled once).
pub(crate) fn by_decreasing_modulus(a: &Complex64, b: &Complex64) -> std::cmp::Ordering {
    b.norm().total_cmp(&a.norm())
}

/// The `wanted` eigenvalues of largest modulus of the linear operator `apply` (w = A v)
/// on ℝ^dim, by Arnoldi's method (modified Gram–Schmidt twice, a fixed start vector: the
/// same numbers on every run): the Krylov space grows until the `wanted` largest Ritz values
/// move by less than 1e-12 · max(1, |θ₁|) between two sizes, or the space is invariant, or
/// it fills ℝ^dim (the Ritz values are then the eigenvalues). For operators whose spectrum
/// falls off fast — the monodromy operator of a delay equation's cycle — a few dozen
/// products suffice whatever the discretisation's size.
pub(crate) fn dominant_eigenvalues(
    dim: usize,
    wanted: usize,
    apply: impl FnMut(&[f64], &mut [f64]),
) -> Result<Vec<Complex64>> {
    let ritz_values = |h: &[Vec<f64>]| -> Result<Vec<Complex64>> {
        let size = h.len();
        let hm = Mat::<f64>::from_fn(size, size, |r, c| h[c].get(r).copied().unwrap_or(0.0));
        let mut ritz = eigenvalues(&hm)?;
        ritz.sort_by(by_decreasing_modulus);
        ritz.truncate(wanted);
        Ok(ritz)
    };
    // the Ritz values at sizes 2·wanted + 10, then every ARNOLDI_GROWTH more, until they
    // settle (`done`: the settled values, or the eigenvalue solver's error)
    let mut previous: Vec<Complex64> = Vec::new();
    let mut check_at = (2 * wanted + 10).min(dim);
    let mut done: Option<Result<Vec<Complex64>>> = None;
    let space = arnoldi(dim, dim, apply, |h| {
        if h.len() != check_at {
            return false;
        }
        let ritz = match ritz_values(h) {
            Ok(ritz) => ritz,
            Err(e) => {
                done = Some(Err(e));
                return true;
            }
        };
        let tol = ARNOLDI_TOLERANCE * ritz.first().map_or(1.0, |z| z.norm().max(1.0));
        let settled = previous.len() == ritz.len()
            && ritz
                .iter()
                .all(|z| previous.iter().any(|p| (z - p).norm() <= tol));
        if settled {
            done = Some(Ok(ritz));
            return true;
        }
        previous = ritz;
        check_at = (check_at + ARNOLDI_GROWTH).min(dim);
        false
    })
    .ok_or_else(|| Error::Eigen {
        size: dim,
        message: "the operator gave non-finite values".into(),
    })?;
    // settled, or else the space is invariant or fills ℝ^dim: its Ritz values
    done.unwrap_or_else(|| ritz_values(&space.h))
}

/// The start vector of the Arnoldi processes: fixed (the same numbers on every run), of
/// unit length, with no symmetry a structured operator could be blind to.
fn arnoldi_start(dim: usize) -> Vec<f64> {
    let mut v0: Vec<f64> = (0..dim)
        .map(|i| 1.0 + 0.5 * (0.7 * i as f64).sin())
        .collect();
    let norm = dot(&v0, &v0).sqrt();
    v0.iter_mut().for_each(|x| *x /= norm);
    v0
}

/// [`determinant_settled`]: two successive estimates of det(I − E) (the Krylov space grown
/// by [`ARNOLDI_GROWTH`]) agree in sign and to this in log |det|
pub(crate) const KRYLOV_DETERMINANT_TOLERANCE: f64 = 1e-11;

/// A Krylov space of a linear operator E on ℝ^dim from the Arnoldi process:
/// E V_j = V_j H_j + h_{j+1,j} v_{j+1} e_jᵀ with V_j orthonormal and H_j upper Hessenberg.
pub(crate) struct KrylovSpace {
    /// the orthonormal basis V_j (j vectors of length dim)
    pub(crate) basis: Vec<Vec<f64>>,
    /// H_j's columns: h[c][r] = H(r, c) for r ≤ c, and h[c][c + 1] = h_{c+2,c+1} (the last
    /// column's is the residual's norm h_{j+1,j})
    pub(crate) h: Vec<Vec<f64>>,
    /// whether V_j is invariant under E (h_{j+1,j} below 1e-14 of the product's norm, or
    /// j = dim): then E V_j = V_j H_j
    pub(crate) invariant: bool,
}

/// The Arnoldi process on E (`apply`: w = E v, w zeroed before) from a fixed start vector
/// (modified Gram–Schmidt twice: the same numbers on every run), until the space is
/// invariant, or has `max_size` vectors, or `enough(h)` (asked after every product with
/// the Hessenberg columns so far) says so. The one Krylov loop of [`dominant_eigenvalues`]
/// and of the block-forward solver's determinant. None if E gives non-finite values.
pub(crate) fn arnoldi(
    dim: usize,
    max_size: usize,
    mut apply: impl FnMut(&[f64], &mut [f64]),
    mut enough: impl FnMut(&[Vec<f64>]) -> bool,
) -> Option<KrylovSpace> {
    let max_size = max_size.clamp(1, dim.max(1));
    let mut basis = vec![arnoldi_start(dim)];
    let mut h: Vec<Vec<f64>> = Vec::new();
    let mut w = vec![0.0; dim];
    loop {
        let j = h.len();
        w.iter_mut().for_each(|x| *x = 0.0);
        apply(&basis[j], &mut w);
        if !w.iter().all(|x| x.is_finite()) {
            return None;
        }
        let scale = dot(&w, &w).sqrt();
        let mut col = orthogonalise(&basis, &mut w);
        let next = dot(&w, &w).sqrt();
        col[j + 1] = next;
        h.push(col);
        let size = j + 1;
        let invariant = next <= 1e-14 * scale.max(f64::MIN_POSITIVE) || size == dim;
        let checked = enough(&h);
        if invariant || checked || size == max_size {
            return Some(KrylovSpace {
                basis,
                h,
                invariant,
            });
        }
        basis.push(w.iter().map(|x| x / next).collect());
    }
}

/// Whether the Arnoldi estimate of det(I − E) has settled, for an operator E whose
/// eigenvalues fall off fast (the discretisation of a compact operator, as the period map
/// of a delay equation's history): det(I − H_j) = Π (1 − θ_i) over the Ritz values tends
/// to det(I − E) = Π (1 − λ_i) as the Krylov space takes in every eigenvalue that is not
/// negligible against 1 (the Galerkin approximation of a Fredholm determinant; the
/// eigenvalues left out change log |det| by about their sum, and cannot change its sign
/// once every eigenvalue of modulus ≥ 1 is in). Settled when two successive estimates
/// (`h`, the Hessenberg columns so far, and `previous`, which keeps the last one) agree in
/// sign and to [`KRYLOV_DETERMINANT_TOLERANCE`] in log |det|, estimated every
/// [`ARNOLDI_GROWTH`] products. Used as [`arnoldi`]'s `enough`: the cost is then j products
/// and O(j²·dim) orthogonalisation, against dim products for the matrix of E.
pub(crate) fn determinant_settled(previous: &mut Option<Determinant>, h: &[Vec<f64>]) -> bool {
    if !h.len().is_multiple_of(ARNOLDI_GROWTH) {
        return false;
    }
    let Some(estimate) = identity_minus_hessenberg_determinant(h) else {
        return false;
    };
    let settled = previous.is_some_and(|p| {
        p.sign == estimate.sign
            && (p.log_abs - estimate.log_abs).abs() <= KRYLOV_DETERMINANT_TOLERANCE
    });
    *previous = Some(estimate);
    settled
}

/// det(I − H) of the j × j upper Hessenberg matrix of the columns `h` (h[c][r] = H(r, c),
/// r ≤ c + 1; the subdiagonal entry of the last column left out): Gaussian elimination
/// with partial pivoting, which in a Hessenberg matrix chooses between two rows. None if
/// it is singular to working precision.
pub(crate) fn identity_minus_hessenberg_determinant(h: &[Vec<f64>]) -> Option<Determinant> {
    let j = h.len();
    // row-major I − H
    let mut a = vec![0.0; j * j];
    for (c, col) in h.iter().enumerate() {
        for (r, &v) in col.iter().enumerate().take(j) {
            a[r * j + c] = -v;
        }
        a[c * j + c] += 1.0;
    }
    let mut det = Determinant {
        sign: 1.0,
        log_abs: 0.0,
    };
    for k in 0..j {
        if k + 1 < j && a[(k + 1) * j + k].abs() > a[k * j + k].abs() {
            for c in k..j {
                a.swap(k * j + c, (k + 1) * j + c);
            }
            det.sign = -det.sign;
        }
        let pivot = a[k * j + k];
        if pivot == 0.0 || !pivot.is_finite() {
            return None;
        }
        det.sign *= pivot.signum();
        det.log_abs += pivot.abs().ln();
        if k + 1 < j {
            let l = a[(k + 1) * j + k] / pivot;
            for c in k + 1..j {
                a[(k + 1) * j + c] -= l * a[k * j + c];
            }
        }
    }
    Some(det)
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

/// The unit tests' seeded random numbers: a linear congruential generator (Knuth's MMIX
/// constants), uniform in [−0.5, 0.5)
#[cfg(test)]
pub(crate) fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
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

    /// det(I − E) from the Arnoldi process ([`arnoldi`] with [`determinant_settled`]) for
    /// a non-normal E = P Λ P⁻¹ on ℝ^200 (P = I + a seeded random perturbation) whose
    /// spectrum falls off like a compact operator's — one real eigenvalue 1.7 > 1 (det
    /// negative), a complex pair 0.5 ± 0.8i, 0.6^i for the rest — against the closed form
    /// Π (1 − λ_i): the sign exactly and log |det| to 1e-9 (the eigenvalues left out are
    /// below 0.6^40 ≈ 1e-9), from a Krylov space of at most 64 vectors.
    #[test]
    fn arnoldi_determinant_of_a_compact_operator() {
        let n = 200;
        let mut seed = 11u64;
        let mut rand = || crate::linalg::lcg(&mut seed);
        let p = DMatrix::<f64>::from_fn(n, n, |i, j| {
            f64::from(u8::from(i == j)) + 0.2 * rand() / (n as f64).sqrt()
        });
        let mut lambda = DMatrix::<f64>::zeros(n, n);
        lambda[(0, 0)] = 1.7;
        lambda[(1, 1)] = 0.5;
        lambda[(1, 2)] = 0.8;
        lambda[(2, 1)] = -0.8;
        lambda[(2, 2)] = 0.5;
        for i in 3..n {
            lambda[(i, i)] = 0.6f64.powi(i as i32 - 2) * if i % 2 == 0 { 1.0 } else { -1.0 };
        }
        let e = &p * lambda * p.clone().try_inverse().expect("P regular");
        let mut expected_log = (1.0f64 - 1.7).abs().ln() + ((0.5f64).powi(2) + 0.64).ln();
        for i in 3..n {
            expected_log +=
                (1.0 - 0.6f64.powi(i as i32 - 2) * if i % 2 == 0 { 1.0 } else { -1.0 }).ln();
        }
        let mut previous = None;
        let space = arnoldi(
            n,
            n,
            |v, w| {
                let y = &e * nalgebra::DVector::from_column_slice(v);
                w.copy_from_slice(y.as_slice());
            },
            |h| determinant_settled(&mut previous, h),
        )
        .expect("finite");
        assert!(space.basis.len() <= 64, "{} vectors", space.basis.len());
        let det = identity_minus_hessenberg_determinant(&space.h).expect("regular");
        assert_eq!(det.sign, -1.0);
        assert!(
            (det.log_abs - expected_log).abs() < 1e-9,
            "log |det| {} against {expected_log}",
            det.log_abs
        );
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

    /// Arnoldi's dominant eigenvalues against the dense eigenvalues of the same matrix
    /// (faer's Schur form, independent of the Krylov space): A = Q diag-blocks Q⁻¹ of size
    /// 300 with a rotation block, a real unit eigenvalue and the rest falling off like 0.7^k
    /// (a monodromy operator's shape); the 12 largest to 1e-10 (Arnoldi accepts at 1e-12
    /// of |θ₁| between two sizes)
    #[test]
    fn arnoldi_finds_the_dominant_eigenvalues() {
        let n = 300;
        let mut seed = 99u64;
        let mut rand = || crate::linalg::lcg(&mut seed);
        let mut d = nalgebra::DMatrix::<f64>::zeros(n, n);
        d[(0, 0)] = 1.0;
        d[(1, 1)] = 0.9;
        d[(1, 2)] = -0.3;
        d[(2, 1)] = 0.3;
        d[(2, 2)] = 0.9;
        for k in 3..n {
            d[(k, k)] = 0.7f64.powi(k as i32 - 2) * if k % 2 == 0 { 1.0 } else { -1.0 };
        }
        // Q = I + 0.3·random (well conditioned), A = Q D Q⁻¹
        let q = nalgebra::DMatrix::<f64>::from_fn(n, n, |i, j| {
            f64::from(u8::from(i == j)) + 0.3 * rand() / (n as f64).sqrt()
        });
        let qinv = q.clone().try_inverse().expect("Q regular");
        let a_na = &q * &d * &qinv;
        let a = Mat::<f64>::from_fn(n, n, |i, j| a_na[(i, j)]);
        let mut dense = eigenvalues(&a).unwrap();
        dense.sort_by(|x, y| y.norm().total_cmp(&x.norm()));
        let arnoldi = dominant_eigenvalues(n, 12, |v, w| {
            for (i, wi) in w.iter_mut().enumerate() {
                *wi = (0..n).map(|j| a[(i, j)] * v[j]).sum();
            }
        })
        .unwrap();
        assert_eq!(arnoldi.len(), 12);
        for (k, z) in arnoldi.iter().enumerate() {
            let err = dense[..14]
                .iter()
                .map(|e| (e - z).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(err < 1e-10, "Ritz value {k} = {z}: error {err:e}");
        }
        assert!((arnoldi[0] - 1.0).norm() < 1e-12 || arnoldi[0].norm() > 0.94);
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
