//! Linear-algebra primitives of the collocation solvers: sparse triplets and rows (`Csr`),
//! determinants as sign and log-modulus, restarted GMRES on a preconditioned operator, the
//! Arnoldi process (dominant eigenvalues, Fredholm-type determinants det(I − E)), dense
//! eigenvalues, and the mesh layout of a collocation system ([`MeshStructure`]). The
//! factorisations built on them, and the choice between them, are in `linear_solver`.

use crate::error::{Error, Result};
use faer::Mat;
use faer::sparse::Triplet;
use num_complex::Complex64;

/// Triplet (row, column, value) of a sparse matrix under assembly.
pub type Entry = Triplet<usize, usize, f64>;

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

/// relative residual ‖b − J x‖ / ‖b‖ to which GMRES solves (the tolerance of
/// [`LinearSolver::Krylov`](crate::LinearSolver::Krylov))
pub const KRYLOV_TOLERANCE: f64 = 1e-12;
/// largest Krylov space per GMRES cycle
const KRYLOV_MAX_ITERATIONS: usize = 150;
/// GMRES cycles (restarts from the true residual) before the direct fallback
const KRYLOV_MAX_CYCLES: usize = 3;

/// Where the unknowns and equations of a collocation system sit on its mesh, for the
/// structured solvers ([`LinearSolver::Krylov`], [`LinearSolver::BlockForward`]):
/// profile-sized column blocks (node g, component k at `offset + g·n + k`, g < L·m; the
/// node L·m is node 0) and collocation row blocks (point c of interval i, component r at
/// `offset + (i·m + c)·n + r`). All other rows and columns are borders.
///
/// [`LinearSolver::Krylov`]: crate::LinearSolver::Krylov
/// [`LinearSolver::BlockForward`]: crate::LinearSolver::BlockForward
#[derive(Debug, Clone, PartialEq)]
pub struct MeshStructure {
    pub(crate) n: usize,
    pub(crate) m: usize,
    pub(crate) intervals: usize,
    pub(crate) column_blocks: Vec<usize>,
    pub(crate) row_blocks: Vec<usize>,
    /// smaller systems are factorised directly (by the Krylov solver's split)
    pub(crate) min_size: usize,
    /// the block-forward solver first (`LinearSolver::Auto`, `LinearSolver::BlockForward`)
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
    /// point) and E = J − P (the preconditioner of the Krylov solver and its coupling).
    pub(crate) fn split(&self, entries: &[Entry]) -> (Vec<Entry>, Vec<Entry>) {
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
}
