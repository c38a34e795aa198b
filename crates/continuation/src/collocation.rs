//! Piecewise-polynomial bases: Gauss–Legendre collocation points and Lagrange
//! interpolation on equispaced nodes of one mesh interval (local coordinate ξ ∈ [0, 1]).

/// largest supported polynomial degree
pub const MAX_DEGREE: usize = 8;

/// Gauss–Legendre nodes and weights on [0, 1] (Newton on the Legendre polynomial).
pub fn gauss_legendre(m: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; m];
    let mut weights = vec![0.0; m];
    for i in 0..m {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (m as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=m {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if m == 0 { 1.0 } else { p1 };
            let pm1 = if m == 1 { 1.0 } else { p0 };
            dp = m as f64 * (x * p - pm1) / (x * x - 1.0);
            let dx = p / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        nodes[m - 1 - i] = 0.5 * (x + 1.0);
        weights[m - 1 - i] = 1.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

/// Lagrange basis of degree m on the equispaced nodes ξ_j = j/m: values ℓ_j(ξ) and
/// derivatives ℓ'_j(ξ) written to the first m + 1 entries of `l` and `dl`.
pub fn lagrange(m: usize, xi: f64, l: &mut [f64; MAX_DEGREE + 1], dl: &mut [f64; MAX_DEGREE + 1]) {
    let node = |j: usize| j as f64 / m as f64;
    for j in 0..=m {
        let mut v = 1.0;
        let mut d = 0.0;
        for k in 0..=m {
            if k == j {
                continue;
            }
            let den = node(j) - node(k);
            // product rule: d(v·(ξ−ξk)/den) = d·(ξ−ξk)/den + v/den
            d = d * (xi - node(k)) / den + v / den;
            v *= (xi - node(k)) / den;
        }
        l[j] = v;
        dl[j] = d;
    }
}

/// Lagrange basis of degree m on the equispaced nodes ξ_j = j/m with second derivatives:
/// values ℓ_j(ξ), ℓ'_j(ξ) and ℓ''_j(ξ) written to the first m + 1 entries of `l`, `dl`, `ddl`
/// (the second derivatives are needed by the Jacobians of defining systems that contain
/// delayed values of derivatives, e.g. folds of cycles of delay equations).
pub fn lagrange_d2(
    m: usize,
    xi: f64,
    l: &mut [f64; MAX_DEGREE + 1],
    dl: &mut [f64; MAX_DEGREE + 1],
    ddl: &mut [f64; MAX_DEGREE + 1],
) {
    let node = |j: usize| j as f64 / m as f64;
    for j in 0..=m {
        let (mut v, mut d, mut dd) = (1.0, 0.0, 0.0);
        for k in 0..=m {
            if k == j {
                continue;
            }
            let den = node(j) - node(k);
            let q = (xi - node(k)) / den;
            // product rule for v·q with q' = 1/den, q'' = 0
            dd = dd * q + 2.0 * d / den;
            d = d * q + v / den;
            v *= q;
        }
        l[j] = v;
        dl[j] = d;
        ddl[j] = dd;
    }
}

/// Precomputed values at the collocation points of one interval.
#[derive(Debug, Clone)]
pub(crate) struct Basis {
    /// Gauss–Legendre points on [0, 1]
    pub xi: Vec<f64>,
    /// Gauss–Legendre weights on [0, 1]
    pub w: Vec<f64>,
    /// ℓ_j(ξ_c), row c: `val[c * (m + 1) + j]`
    pub val: Vec<f64>,
    /// ℓ'_j(ξ_c)
    pub der: Vec<f64>,
}

impl Basis {
    pub(crate) fn new(m: usize) -> Self {
        let (xi, w) = gauss_legendre(m);
        let mut val = vec![0.0; m * (m + 1)];
        let mut der = vec![0.0; m * (m + 1)];
        let mut l = [0.0; MAX_DEGREE + 1];
        let mut dl = [0.0; MAX_DEGREE + 1];
        for c in 0..m {
            lagrange(m, xi[c], &mut l, &mut dl);
            val[c * (m + 1)..(c + 1) * (m + 1)].copy_from_slice(&l[..=m]);
            der[c * (m + 1)..(c + 1) * (m + 1)].copy_from_slice(&dl[..=m]);
        }
        Self { xi, w, val, der }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn gauss_legendre_integrates_degree_2m_minus_1_exactly() {
        // reference: ∫_0^1 ξ^k dξ = 1/(k+1); m-point Gauss is exact up to degree 2m−1
        for m in 1..=MAX_DEGREE {
            let (x, w) = gauss_legendre(m);
            for k in 0..2 * m {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                assert_relative_eq!(q, 1.0 / (k as f64 + 1.0), max_relative = 1e-13);
            }
        }
    }

    #[test]
    fn lagrange_reproduces_polynomials_and_derivatives() {
        // reference: interpolation of a degree-m polynomial is exact
        let m = 5;
        let p = |x: f64| 1.0 + 2.0 * x - 3.0 * x.powi(3) + 0.5 * x.powi(5);
        let dp = |x: f64| 2.0 - 9.0 * x * x + 2.5 * x.powi(4);
        let mut l = [0.0; MAX_DEGREE + 1];
        let mut dl = [0.0; MAX_DEGREE + 1];
        for &xi in &[0.0, 0.13, 0.5, 0.77, 1.0] {
            lagrange(m, xi, &mut l, &mut dl);
            let v: f64 = (0..=m).map(|j| l[j] * p(j as f64 / m as f64)).sum();
            let d: f64 = (0..=m).map(|j| dl[j] * p(j as f64 / m as f64)).sum();
            assert_relative_eq!(v, p(xi), epsilon = 1e-13);
            assert_relative_eq!(d, dp(xi), epsilon = 1e-11);
        }
    }

    #[test]
    fn lagrange_d2_reproduces_second_derivatives_and_agrees_with_lagrange() {
        // reference: interpolation of a degree-m polynomial is exact, so are its derivatives;
        // values and first derivatives must equal `lagrange` (tolerance: rounding, 1e-10)
        let m = 5;
        let p = |x: f64| 1.0 + 2.0 * x - 3.0 * x.powi(3) + 0.5 * x.powi(5);
        let ddp = |x: f64| -18.0 * x + 10.0 * x.powi(3);
        let (mut l, mut dl, mut ddl) = (
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
        );
        let (mut l1, mut dl1) = ([0.0; MAX_DEGREE + 1], [0.0; MAX_DEGREE + 1]);
        for &xi in &[0.0, 0.13, 0.5, 0.77, 1.0] {
            lagrange_d2(m, xi, &mut l, &mut dl, &mut ddl);
            lagrange(m, xi, &mut l1, &mut dl1);
            let dd: f64 = (0..=m).map(|j| ddl[j] * p(j as f64 / m as f64)).sum();
            assert_relative_eq!(dd, ddp(xi), epsilon = 1e-9);
            for j in 0..=m {
                assert_relative_eq!(l[j], l1[j], epsilon = 1e-12);
                assert_relative_eq!(dl[j], dl1[j], epsilon = 1e-10);
            }
        }
    }
}
