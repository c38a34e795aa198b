//! The bordered band solver of ODE collocation systems: cost linear in the mesh.
//!
//! The Newton matrix M of a periodic orbit of an ODE (and of the extended systems built on
//! it), in the systems' natural order, is a band matrix (each collocation row couples the
//! nodes of its own interval) up to
//! - a few trailing border rows and columns (phase and arclength rows; period and parameter
//!   columns), and
//! - the periodic wrap-around: the last interval's rows reach the first node x₀'s columns.
//!
//! The first node's (wrap) columns go to the border, and the last interval's rows see a
//! copy y = x₀ instead: a new band unknown at the end of the band block, with the equation
//! y − x₀ = 0 as a new border row. What is left is a band matrix A bordered by K = border +
//! wraps rows and columns:
//!
//! ```text
//! M' = [ A  C ]    A: band (kl below, ku above the diagonal), partial pivoting in the band
//!      [ R  D ]    C, R, D: the K border columns, rows and corner
//! ```
//!
//! With x₀ given (a border unknown), A is the collocation of a *forward* initial-value
//! problem over one period, ending in y: well conditioned however stiff the stable modes
//! are. (Keeping x₀ in the band and the end node in the border makes A the backward problem
//! x(T) ↦ x(0), whose condition number is that of the inverse monodromy matrix: 1e20 and
//! worse for the tyre-lag modes of a relaxation tyre.) The K × K Schur complement S carries
//! the periodicity, as in single shooting or AUTO's condensation.
//!
//! Solved by block elimination: A's band LU (O(N·kl·(kl + ku)) for N band unknowns, as
//! LAPACK's `dgbtrf`), A⁻¹C (K band solves), S = D − R A⁻¹ C (dense LU). det M = det M' up
//! to the sign of the column permutation (adding the copy's column to x₀'s leaves a unit
//! row and column), so the branch-point test keeps its determinant.
//!
//! Rows and columns whose couplings do not fit a narrow band (a delay equation: the delayed
//! coupling reaches τ/T of the period back) are not accepted ([`BandedLu::new`] returns
//! None) and the caller keeps the sparse LU.

use crate::linalg::{Determinant, Entry, permutation_sign};
use nalgebra::{DMatrix, DVector};

/// Smallest system worth the band solver (below, the sparse LU is as fast).
pub(crate) const BANDED_MIN_SIZE: usize = 200;

/// Most border rows/columns (with the wrap columns) the band solver takes.
const MAX_BORDER: usize = 64;

/// Where a column of M (in the column order) sits in M'.
#[derive(Debug, Clone, Copy)]
enum Slot {
    /// band unknown i
    Band(usize),
    /// border unknown k
    Border(usize),
}

/// The bordered band shape of a matrix: which columns go where.
#[derive(Debug)]
struct Layout {
    /// band block size N (the first N rows; N band unknowns)
    nb: usize,
    kl: usize,
    ku: usize,
    /// positions (in the column order) of the wrap columns x₀, sorted
    wraps: Vec<usize>,
    /// the slot of each position
    slot: Vec<Slot>,
}

impl Layout {
    /// the band or border slot of the entry at band-or-border row `row`, position `pos`:
    /// a wrap entry (the last interval reaching x₀) goes to x₀'s copy at the band's end
    fn slot(&self, row: usize, pos: usize) -> Slot {
        if row < self.nb
            && is_wrap(row, pos, self.nb)
            && let Ok(j) = self.wraps.binary_search(&pos)
        {
            return Slot::Band(self.nb - self.wraps.len() + j);
        }
        self.slot[pos]
    }

    /// the number of border unknowns (and border rows) K
    fn border(&self) -> usize {
        self.slot.len() - self.nb + self.wraps.len()
    }
}

/// A bordered band matrix, factorised. See the module docs.
#[derive(Debug)]
pub(crate) struct BandedLu {
    layout: Layout,
    /// row window width 2·kl + ku + 1 (row r holds band columns r − kl … r + kl + ku)
    w: usize,
    /// the band rows after elimination: U in the windows
    rows: Vec<f64>,
    /// the multipliers of L (kl per column)
    mult: Vec<f64>,
    /// the pivot row of each elimination step
    piv: Vec<usize>,
    /// columns in elimination order: `order[k]` is the original column of position k
    order: Vec<usize>,
    /// A⁻¹C, column-major N × K
    a_inv_c: Vec<f64>,
    /// R: the K border rows (M's border rows, then the copies' rows) over the band
    /// unknowns, row-major K × N
    border_rows: Vec<f64>,
    /// LU of the Schur complement S
    schur: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    det: Determinant,
}

impl BandedLu {
    /// The band solver of the n × n matrix `entries` (duplicates summed) with columns in
    /// `order` (forward array; natural when None), or None when the matrix is not a narrow
    /// bordered band up to wraps, or its band block is singular.
    pub(crate) fn new(n: usize, entries: &[Entry], order: Option<&[usize]>) -> Option<Self> {
        if n < BANDED_MIN_SIZE {
            return None;
        }
        let order: Vec<usize> = order.map_or_else(|| (0..n).collect(), <[usize]>::to_vec);
        let mut position = vec![usize::MAX; n];
        for (k, &c) in order.iter().enumerate() {
            *position.get_mut(c)? = k;
        }
        if position.contains(&usize::MAX) {
            return None;
        }
        let layout = band_layout(n, entries, &position)?;
        let (nb, kl, ku, k) = (layout.nb, layout.kl, layout.ku, layout.border());
        let w = 2 * kl + ku + 1;

        // assemble the band rows' windows, C (band rows × K), R (K × band) and D
        let mut rows = vec![0.0; nb * w];
        let mut c = vec![0.0; nb * k];
        let mut border_rows = vec![0.0; k * nb];
        let mut d = DMatrix::<f64>::zeros(k, k);
        for e in entries.iter().filter(|e| e.val != 0.0) {
            let r = e.row;
            match (r < nb, layout.slot(r, position[e.col])) {
                (true, Slot::Band(i)) => rows[r * w + (i + kl - r)] += e.val,
                (true, Slot::Border(j)) => c[j * nb + r] += e.val,
                (false, Slot::Band(i)) => border_rows[(r - nb) * nb + i] += e.val,
                (false, Slot::Border(j)) => d[(r - nb, j)] += e.val,
            }
        }
        // the copies' rows: y_j − x₀_j = 0 (+1 on the copy in R, −1 on x₀ in D)
        let first_wrap_slot = n - nb;
        for j in 0..layout.wraps.len() {
            let row = first_wrap_slot + j;
            border_rows[row * nb + (nb - layout.wraps.len() + j)] = 1.0;
            d[(row, first_wrap_slot + j)] = -1.0;
        }
        let column_sign = permutation_sign(&order) * permutation_sign(&extended_columns(&layout));
        let mut lu = Self {
            layout,
            w,
            rows,
            mult: vec![0.0; nb * kl.max(1)],
            piv: vec![0; nb],
            order,
            a_inv_c: c,
            border_rows,
            schur: DMatrix::<f64>::identity(1, 1).lu(),
            det: Determinant {
                sign: 1.0,
                log_abs: 0.0,
            },
        };
        let det_a = lu.factorise_band()?;
        let mut a_inv_c = std::mem::take(&mut lu.a_inv_c);
        for col in a_inv_c.chunks_mut(nb) {
            lu.solve_band(col);
        }
        lu.a_inv_c = a_inv_c;
        // S = D − R A⁻¹C
        for i in 0..k {
            let r = &lu.border_rows[i * nb..(i + 1) * nb];
            for j in 0..k {
                let x = &lu.a_inv_c[j * nb..(j + 1) * nb];
                d[(i, j)] -= dot(r, x);
            }
        }
        let det_s = d.determinant();
        lu.schur = d.lu();
        lu.det = Determinant {
            sign: if det_s == 0.0 {
                0.0
            } else {
                det_a.sign * det_s.signum() * column_sign
            },
            log_abs: det_a.log_abs + det_s.abs().ln(),
        };
        if !lu.det.log_abs.is_finite() {
            return None;
        }
        Some(lu)
    }

    /// band LU with partial pivoting in place; det A, or None if A is singular
    fn factorise_band(&mut self) -> Option<Determinant> {
        let (nb, kl, ku, w) = (self.layout.nb, self.layout.kl, self.layout.ku, self.w);
        let at = |r: usize, c: usize| r * w + (c + kl - r);
        let mut det = Determinant {
            sign: 1.0,
            log_abs: 0.0,
        };
        for k in 0..nb {
            let last_row = (k + kl).min(nb - 1);
            let last_col = (k + kl + ku).min(nb - 1);
            let p = (k..=last_row).max_by(|&a, &b| {
                self.rows[at(a, k)]
                    .abs()
                    .total_cmp(&self.rows[at(b, k)].abs())
            })?;
            let pivot = self.rows[at(p, k)];
            if pivot == 0.0 || !pivot.is_finite() {
                return None;
            }
            self.piv[k] = p;
            if p != k {
                det.sign = -det.sign;
                for c in k..=last_col {
                    self.rows.swap(at(k, c), at(p, c));
                }
            }
            det.sign *= pivot.signum();
            det.log_abs += pivot.abs().ln();
            // row k's window from column k on, and each row i below from column k on:
            // contiguous slices (row r holds column c at r·w + c + kl − r)
            let width = last_col - k; // columns k+1 ..= last_col
            let (upper, lower) = self.rows.split_at_mut((k + 1) * w);
            let pivot_row = &upper[at(k, k) + 1..=at(k, k) + width];
            for i in k + 1..=last_row {
                let start = i * w + (k + kl - i) - (k + 1) * w;
                let (first, rest) = lower[start..start + 1 + width].split_first_mut()?;
                let l = *first / pivot;
                self.mult[k * kl + (i - k - 1)] = l;
                if l != 0.0 {
                    for (a, b) in rest.iter_mut().zip(pivot_row) {
                        *a -= l * b;
                    }
                }
            }
        }
        Some(det)
    }

    /// x ← A⁻¹ x for the band block
    fn solve_band(&self, x: &mut [f64]) {
        let (nb, kl, ku, w) = (self.layout.nb, self.layout.kl, self.layout.ku, self.w);
        for k in 0..nb {
            x.swap(k, self.piv[k]);
            let xk = x[k];
            let last = (k + kl).min(nb - 1);
            if xk != 0.0 && last > k {
                let m = &self.mult[k * kl..k * kl + (last - k)];
                for (xi, l) in x[k + 1..=last].iter_mut().zip(m) {
                    *xi -= l * xk;
                }
            }
        }
        for k in (0..nb).rev() {
            let last = (k + kl + ku).min(nb - 1);
            let diag = k * w + kl;
            let row = &self.rows[diag + 1..=diag + (last - k)];
            x[k] = (x[k] - dot(row, &x[k + 1..=last])) / self.rows[diag];
        }
    }

    /// det of the matrix (in its original column order)
    pub(crate) fn determinant(&self) -> Determinant {
        self.det
    }

    /// solves M x = b in place (b in original row order, x in original column order)
    pub(crate) fn solve(&self, rhs: &mut [f64]) {
        let layout = &self.layout;
        let (nb, k) = (layout.nb, layout.border());
        let n = layout.slot.len();
        let mut z = rhs[..nb].to_vec();
        self.solve_band(&mut z);
        // S y = [b_border; 0] − R z
        let mut g = DVector::<f64>::zeros(k);
        for i in 0..k {
            let b = if i < n - nb { rhs[nb + i] } else { 0.0 };
            g[i] = b - dot(&self.border_rows[i * nb..(i + 1) * nb], &z);
        }
        let y = self
            .schur
            .solve(&g)
            .unwrap_or_else(|| DVector::from_element(k, f64::NAN));
        for j in 0..k {
            let col = &self.a_inv_c[j * nb..(j + 1) * nb];
            for (zi, ci) in z.iter_mut().zip(col) {
                *zi -= ci * y[j];
            }
        }
        // back to the original column order: position p holds column order[p] (the copies
        // y = x₀ are dropped)
        for (p, &col) in self.order.iter().enumerate() {
            rhs[col] = match layout.slot[p] {
                Slot::Band(i) => z[i],
                Slot::Border(j) => y[j],
            };
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A band-block entry far below the diagonal: the periodic wrap (the last interval's
/// rows reaching the first node), moved to the copy at the band's end.
fn is_wrap(row: usize, col: usize, nb: usize) -> bool {
    row > col + nb / 2
}

/// The columns of M' as columns of the extended matrix M_ext = [M with the wrap entries
/// on the copies' columns; the copies' rows], whose columns are the n positions and then
/// the copies (n + j) and whose determinant is det M. M' has M_ext's rows in the same
/// order, so det M' = sign(this permutation) · det M_ext.
fn extended_columns(layout: &Layout) -> Vec<usize> {
    let n = layout.slot.len();
    let (nb, nw, k) = (layout.nb, layout.wraps.len(), layout.border());
    let mut cols = vec![usize::MAX; nb + k];
    for (p, s) in layout.slot.iter().enumerate() {
        match *s {
            Slot::Band(i) => cols[i] = p,
            Slot::Border(j) => cols[nb + j] = p,
        }
    }
    for j in 0..nw {
        cols[nb - nw + j] = n + j;
    }
    cols
}

/// The bordered band layout of a matrix: the band block size N, the wrap columns (x₀) and
/// where every column goes, with the bandwidths kl and ku of the band block in that
/// layout. Tries the trailing borders 1 … [`MAX_BORDER`] and takes the first whose band
/// block is narrow (the band at most a quarter of the block) with at most [`MAX_BORDER`]
/// border and wrap columns.
fn band_layout(n: usize, entries: &[Entry], position: &[usize]) -> Option<Layout> {
    'border: for border in 1..=MAX_BORDER.min(n / 2) {
        let nb = n - border;
        let mut wraps: Vec<usize> = entries
            .iter()
            .map(|e| (e.row, position[e.col], e.val))
            .filter(|&(r, c, v)| r < nb && c < nb && v != 0.0 && is_wrap(r, c, nb))
            .map(|(_, c, _)| c)
            .collect();
        wraps.sort_unstable();
        wraps.dedup();
        if border + wraps.len() > MAX_BORDER || wraps.len() >= nb / 2 {
            continue;
        }
        let mut slot = Vec::with_capacity(n);
        let mut band = 0;
        for p in 0..n {
            if p >= nb {
                slot.push(Slot::Border(p - nb));
            } else if let Ok(j) = wraps.binary_search(&p) {
                slot.push(Slot::Border(border + j));
            } else {
                slot.push(Slot::Band(band));
                band += 1;
            }
        }
        let mut layout = Layout {
            nb,
            kl: 0,
            ku: 0,
            wraps,
            slot,
        };
        for e in entries.iter().filter(|e| e.row < nb && e.val != 0.0) {
            let r = e.row;
            let Slot::Band(i) = layout.slot(r, position[e.col]) else {
                continue;
            };
            if r > i {
                layout.kl = layout.kl.max(r - i);
            } else {
                layout.ku = layout.ku.max(i - r);
            }
            if 4 * (layout.kl + layout.ku + 1) > nb {
                continue 'border;
            }
        }
        return Some(layout);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trapezoidal collocation of a periodic linear ODE x' = J x on `intervals` steps of
    /// h = 1 / intervals (rows of interval i: (I − hJ/2) x_{i+1} − (I + hJ/2) x_i, with
    /// x_L = x_0: the wrap), plus 2 border columns and 2 dense border rows (seeded LCG).
    /// J has a damped rotation, a mildly unstable mode and a stiff stable mode of rate
    /// −`stiff`: over one period that mode decays by e^(−stiff), which makes the backward
    /// problem x(T) ↦ x(0) hopeless and the forward one harmless.
    fn periodic_collocation(intervals: usize, stiff: f64) -> (usize, Vec<Entry>) {
        const D: usize = 4;
        let j = [
            [-1.0, 3.0, 0.0, 0.0],
            [-3.0, -1.0, 0.0, 0.0],
            [0.0, 0.0, -stiff, 0.0],
            [0.5, 0.0, 1.0, 0.5],
        ];
        let h = 1.0 / intervals as f64;
        let nb = intervals * D;
        let n = nb + 2;
        let mut seed = 12345u64;
        let mut rand = || crate::linalg::lcg(&mut seed);
        let mut e = Vec::new();
        for i in 0..intervals {
            let next = (i + 1) % intervals;
            for a in 0..D {
                let r = i * D + a;
                for (b, jab) in j[a].iter().enumerate() {
                    let id = if a == b { 1.0 } else { 0.0 };
                    e.push(Entry::new(r, next * D + b, id - 0.5 * h * jab));
                    e.push(Entry::new(r, i * D + b, -id - 0.5 * h * jab));
                }
                e.push(Entry::new(r, nb, rand()));
                e.push(Entry::new(r, nb + 1, rand()));
            }
        }
        for r in nb..n {
            for c in 0..n {
                e.push(Entry::new(r, c, rand()));
            }
        }
        (n, e)
    }

    fn dense(n: usize, e: &[Entry]) -> DMatrix<f64> {
        let mut a = DMatrix::zeros(n, n);
        for t in e {
            a[(t.row, t.col)] += t.val;
        }
        a
    }

    /// the solution of A x = `b` by the band LU of A and by nalgebra's dense LU of `a` = A
    fn solve_both(lu: &BandedLu, a: &DMatrix<f64>, b: Vec<f64>) -> (DVector<f64>, DVector<f64>) {
        let mut x = b.clone();
        lu.solve(&mut x);
        let reference = a
            .clone()
            .lu()
            .solve(&DVector::from_vec(b))
            .expect("regular");
        (DVector::from_vec(x), reference)
    }

    /// solution and determinant against nalgebra's dense LU (independent), 1e-10
    /// relative: the band LU pivots within the band, so its rounding differs. The stiff
    /// mode (e^(−2000) over the period) is the case the backward elimination failed.
    #[test]
    fn bordered_cyclic_band_matches_dense_lu() {
        let (n, e) = periodic_collocation(300, 2000.0);
        let lu = BandedLu::new(n, &e, None).expect("banded");
        assert_eq!(lu.layout.wraps.len(), 4);
        let a = dense(n, &e);
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let (x, reference) = solve_both(&lu, &a, b);
        let err = (x - &reference).amax() / reference.amax();
        assert!(err < 1e-10, "solution error {err:e}");
        let det = a.determinant();
        let d = lu.determinant();
        assert_eq!(d.sign, det.signum());
        assert!(
            (d.log_abs - det.abs().ln()).abs() < 1e-9,
            "{} vs {}",
            d.log_abs,
            det.abs().ln()
        );
    }

    /// a column order: the solution comes back in the original columns, the determinant
    /// keeps its sign
    #[test]
    fn column_order_is_undone() {
        let (n, e) = periodic_collocation(240, 50.0);
        // swap the two border columns in the order
        let mut order: Vec<usize> = (0..n).collect();
        order.swap(n - 1, n - 2);
        let lu = BandedLu::new(n, &e, Some(&order)).expect("banded");
        let a = dense(n, &e);
        let b: Vec<f64> = (0..n).map(|i| 1.0 + (i % 7) as f64).collect();
        let (x, reference) = solve_both(&lu, &a, b);
        assert!((x - &reference).amax() < 1e-9 * reference.amax());
        assert_eq!(lu.determinant().sign, a.determinant().signum());
    }

    /// a coupling far from the diagonal (a delay) is no band: refused
    #[test]
    fn a_wide_coupling_is_refused() {
        let (n, mut e) = periodic_collocation(300, 1.0);
        assert!(BandedLu::new(n, &e, None).is_some());
        e.push(Entry::new(800, 400, 1.0));
        assert!(BandedLu::new(n, &e, None).is_none());
    }
}
