//! The bordered band solver of ODE collocation systems: cost linear in the mesh.
//!
//! The Newton matrix of a periodic orbit of an ODE (and of the extended systems built on it),
//! in the systems' natural order, is a band matrix A (each collocation row couples the nodes
//! of its own interval) up to
//! - a few trailing border rows and columns (phase and arclength rows; period and parameter
//!   columns), and
//! - the periodic wrap-around: the last interval's rows reach the first node's columns.
//!
//! Each wrap column w gets a copy y_w = x_w as an extra border unknown (and the equation
//! y_w − x_w = 0 as an extra border row), so that what is left is a band matrix bordered by
//! K = border + wraps rows and columns:
//!
//! ```text
//! M' = [ A  C ]    A: band (kl below, ku above the diagonal), partial pivoting in the band
//!      [ R  D ]    C, R, D: the K border columns, rows and corner
//! ```
//!
//! solved by block elimination: A's band LU (O(N·kl·(kl + ku)) for N band unknowns, as
//! LAPACK's `dgbtrf`), A⁻¹C (K band solves), the K × K Schur complement S = D − R A⁻¹ C
//! (dense LU). det M = det M' = det A · det S (the copies change neither the determinant nor
//! its sign: adding each copy's column to its original column leaves a unit row and column
//! in last place), so the branch-point test keeps its determinant.
//!
//! Rows and columns whose couplings do not fit a narrow band (a delay equation: the delayed
//! coupling reaches τ/T of the period back) are not accepted ([`BandedLu::new`] returns
//! None) and the caller keeps the sparse LU.

use crate::linalg::{Determinant, Entry, permutation_sign};
use nalgebra::{DMatrix, DVector};

/// Smallest system worth the band solver (below, the sparse LU is as fast).
pub(crate) const BANDED_MIN_SIZE: usize = 200;

/// Most border rows/columns (with the wrap copies) the band solver takes.
const MAX_BORDER: usize = 64;

/// A bordered band matrix, factorised. See the module docs.
#[derive(Debug)]
pub(crate) struct BandedLu {
    /// full size n
    n: usize,
    /// band block size N (the first N rows and, in the column order, columns)
    nb: usize,
    kl: usize,
    ku: usize,
    /// row window width 2·kl + ku + 1 (row r holds columns r − kl … r + kl + ku)
    w: usize,
    /// the band rows after elimination: U in the windows
    rows: Vec<f64>,
    /// the multipliers of L (kl per column)
    mult: Vec<f64>,
    /// the pivot row of each elimination step
    piv: Vec<usize>,
    /// columns in elimination order: `order[k]` is the original column of position k
    order: Vec<usize>,
    /// positions (in the column order) of the wrap columns, each with its copy
    wraps: Vec<usize>,
    /// A⁻¹C, column-major N × K
    a_inv_c: Vec<f64>,
    /// the border rows (n − N of them) over the band unknowns, row-major (n − N) × N
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
        let (nb, kl, ku, wraps) = band_shape(n, entries, &position)?;
        let k = (n - nb) + wraps.len();
        let w = 2 * kl + ku + 1;
        let wrap_slot = |pos: usize| wraps.binary_search(&pos).ok();

        // assemble: band rows' windows, border columns C (band rows × K), border rows R
        // over band unknowns, the corner D
        let mut rows = vec![0.0; nb * w];
        let mut c = vec![0.0; nb * k];
        let mut border_rows = vec![0.0; (n - nb) * nb];
        let mut d = DMatrix::<f64>::zeros(k, k);
        for e in entries.iter().filter(|e| e.val != 0.0) {
            let (r, col) = (e.row, position[e.col]);
            match (r < nb, col < nb) {
                (true, true) if is_wrap(r, col, nb) => {
                    let j = (n - nb) + wrap_slot(col)?;
                    c[j * nb + r] += e.val;
                }
                (true, true) => rows[r * w + (col + kl - r)] += e.val,
                (true, false) => c[(col - nb) * nb + r] += e.val,
                (false, true) => border_rows[(r - nb) * nb + col] += e.val,
                (false, false) => d[(r - nb, col - nb)] += e.val,
            }
        }
        // the copies: y_j − x_{wrap j} = 0 (−1 on the band unknown enters R; +1 in D)
        for j in 0..wraps.len() {
            d[(n - nb + j, n - nb + j)] = 1.0;
        }
        let mut lu = Self {
            n,
            nb,
            kl,
            ku,
            w,
            rows,
            mult: vec![0.0; nb * kl.max(1)],
            piv: vec![0; nb],
            order,
            wraps,
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
            for j in 0..k {
                let x = &lu.a_inv_c[j * nb..(j + 1) * nb];
                d[(i, j)] -= lu.border_row_dot(i, x);
            }
        }
        let det_s = d.determinant();
        lu.schur = d.lu();
        let sign = det_a.sign * det_s.signum() * permutation_sign(&lu.order);
        lu.det = Determinant {
            sign: if det_s == 0.0 { 0.0 } else { sign },
            log_abs: det_a.log_abs + det_s.abs().ln(),
        };
        if !lu.det.log_abs.is_finite() {
            return None;
        }
        Some(lu)
    }

    /// R_i · x for border row i of M' (the matrix's border rows, then the copies' rows
    /// −x_{wrap})
    fn border_row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let nb = self.nb;
        if i < self.n - nb {
            self.border_rows[i * nb..(i + 1) * nb]
                .iter()
                .zip(x)
                .map(|(a, b)| a * b)
                .sum()
        } else {
            -x[self.wraps[i - (self.n - nb)]]
        }
    }

    /// band LU with partial pivoting in place; det A, or None if A is singular
    fn factorise_band(&mut self) -> Option<Determinant> {
        let (nb, kl, ku, w) = (self.nb, self.kl, self.ku, self.w);
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
        let (nb, kl, ku, w) = (self.nb, self.kl, self.ku, self.w);
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
            let s: f64 = row.iter().zip(&x[k + 1..=last]).map(|(a, b)| a * b).sum();
            x[k] = (x[k] - s) / self.rows[diag];
        }
    }

    /// det of the matrix (in its original column order)
    pub(crate) fn determinant(&self) -> Determinant {
        self.det
    }

    /// solves M x = b in place (b in original row order, x in original column order)
    pub(crate) fn solve(&self, rhs: &mut [f64]) {
        let (n, nb) = (self.n, self.nb);
        let k = (n - nb) + self.wraps.len();
        let mut z = rhs[..nb].to_vec();
        self.solve_band(&mut z);
        // S y = [b_border; 0] − R z
        let mut g = DVector::<f64>::zeros(k);
        for i in 0..k {
            let b = if i < n - nb { rhs[nb + i] } else { 0.0 };
            g[i] = b - self.border_row_dot(i, &z);
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
        // back to the original column order: position p holds column order[p]
        for (p, &col) in self.order.iter().enumerate() {
            rhs[col] = if p < nb { z[p] } else { y[p - nb] };
        }
    }
}

/// A band-block entry far below the diagonal: the periodic wrap (the last interval's
/// rows reaching the first node), moved to the border.
fn is_wrap(row: usize, col: usize, nb: usize) -> bool {
    row > col + nb / 2
}

/// The shape of a bordered band matrix: the band block size N, its bandwidths kl and ku
/// without the wrap entries, and the wrap columns' positions (sorted). Tries the trailing
/// borders 1 … [`MAX_BORDER`] and takes the first whose band block is narrow (the band at
/// most a quarter of the block) with at most [`MAX_BORDER`] border and wrap columns.
fn band_shape(
    n: usize,
    entries: &[Entry],
    position: &[usize],
) -> Option<(usize, usize, usize, Vec<usize>)> {
    'border: for border in 1..=MAX_BORDER.min(n / 2) {
        let nb = n - border;
        let (mut kl, mut ku) = (0usize, 0usize);
        let mut wraps = Vec::new();
        for e in entries {
            let (r, c) = (e.row, position[e.col]);
            if r >= nb || c >= nb || e.val == 0.0 {
                continue;
            }
            if is_wrap(r, c, nb) {
                wraps.push(c);
                continue;
            }
            if r > c {
                kl = kl.max(r - c);
            } else {
                ku = ku.max(c - r);
            }
            if 4 * (kl + ku + 1) > nb {
                continue 'border;
            }
        }
        wraps.sort_unstable();
        wraps.dedup();
        if border + wraps.len() > MAX_BORDER {
            continue;
        }
        return Some((nb, kl, ku, wraps));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// a periodic band system like an ODE's collocation: n_b band unknowns with couplings
    /// −kl … +ku, a wrap block in the last rows on the first columns, 2 dense border rows
    /// and columns; random values (seeded LCG), diagonal dominant enough to be regular
    fn cyclic_system(nb: usize, kl: usize, ku: usize, wrap: usize) -> (usize, Vec<Entry>) {
        let n = nb + 2;
        let mut seed = 12345u64;
        let mut rand = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let mut e = Vec::new();
        for r in 0..nb {
            for c in r.saturating_sub(kl)..=(r + ku).min(nb - 1) {
                let v = rand() + if r == c { 0.3 } else { 0.0 };
                e.push(Entry::new(r, c, v));
            }
            if r + wrap >= nb {
                for c in 0..wrap {
                    e.push(Entry::new(r, c, rand()));
                }
            }
            e.push(Entry::new(r, nb, rand()));
            e.push(Entry::new(r, nb + 1, rand()));
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

    /// solution and determinant against nalgebra's dense LU (independent), 1e-10
    /// relative: the band LU pivots within the band, so its rounding differs
    #[test]
    fn bordered_cyclic_band_matches_dense_lu() {
        let (n, e) = cyclic_system(300, 7, 9, 4);
        let lu = BandedLu::new(n, &e, None).expect("banded");
        assert_eq!((lu.kl, lu.ku, lu.wraps.len()), (7, 9, 4));
        let a = dense(n, &e);
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut x = b.clone();
        lu.solve(&mut x);
        let reference = a
            .clone()
            .lu()
            .solve(&DVector::from_vec(b))
            .expect("regular");
        let err = (DVector::from_vec(x) - &reference).amax() / reference.amax();
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
        let (n, e) = cyclic_system(240, 5, 6, 3);
        // swap the two border columns in the order
        let mut order: Vec<usize> = (0..n).collect();
        order.swap(n - 1, n - 2);
        let lu = BandedLu::new(n, &e, Some(&order)).expect("banded");
        let a = dense(n, &e);
        let b: Vec<f64> = (0..n).map(|i| 1.0 + (i % 7) as f64).collect();
        let mut x = b.clone();
        lu.solve(&mut x);
        let reference = a
            .clone()
            .lu()
            .solve(&DVector::from_vec(b))
            .expect("regular");
        assert!((DVector::from_vec(x) - &reference).amax() < 1e-9 * reference.amax());
        assert_eq!(lu.determinant().sign, a.determinant().signum());
    }

    /// a coupling far from the diagonal (a delay) is no band: refused
    #[test]
    fn a_wide_coupling_is_refused() {
        let (n, mut e) = cyclic_system(300, 3, 3, 2);
        e.push(Entry::new(200, 100, 1.0));
        assert!(BandedLu::new(n, &e, None).is_none());
    }
}
