//! Cross-checks of the root finders against analytic results and against each other.

use approx::assert_relative_eq;
use nalgebra::{DMatrix, Matrix1};
use stability::{
    ChebyshevCollocation, Complex64, LinearDde, NewtonOptions, RankOneFeedback, RootOptions,
    SemiDiscretisation, rightmost_roots, sort_rightmost,
};

mod common;
use common::test_system as test_loop;

fn eig(m: &DMatrix<f64>) -> Vec<Complex64> {
    let f = faer::Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)]);
    let mut e = f.eigenvalues().unwrap();
    sort_rightmost(&mut e);
    e
}

#[test]
fn zero_delay_roots_are_eigenvalues_of_closed_loop_matrix() {
    // reference: eigenvalues of A − B·D·C (faer, dense); tolerance 1e-12 relative: both are
    // backward-stable computations of simple roots of a well-conditioned 4×4 problem
    for &(v, d) in &[(2.0, 0.3), (6.0, -0.4), (10.0, 1.2)] {
        let (a, b, c) = test_loop(v);
        let sys = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
        let roots = sys
            .rightmost_roots(d, 0.0, 4, &RootOptions::default())
            .unwrap();
        let closed = a - b * c * d;
        let reference = eig(&DMatrix::from_fn(4, 4, |i, j| closed[(i, j)]));
        for (r, e) in roots.iter().zip(&reference) {
            assert_relative_eq!(r.re, e.re, epsilon = 1e-12, max_relative = 1e-12);
            assert_relative_eq!(r.im, e.im, epsilon = 1e-12, max_relative = 1e-12);
        }
        // and the crossing count equals the eigenvalue count
        let unstable = reference.iter().filter(|e| e.re > 0.0).count();
        assert_eq!(sys.unstable_root_count(d, 0.0).unwrap(), unstable);
    }
}

#[test]
fn faddeev_leverrier_polynomials_match_determinants() {
    // reference: p(λ) + D·q(λ) = det(λI − A + B·D·C) (determinant lemma), evaluated directly
    let (a, b, c) = test_loop(3.0);
    let sys = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
    let d = 0.7;
    for &l in &[
        Complex64::new(0.3, 1.1),
        Complex64::new(-2.0, 0.5),
        Complex64::new(1.0, -3.0),
    ] {
        let m = DMatrix::from_fn(4, 4, |i, j| {
            let e = Complex64::new(-(a[(i, j)] - d * b[i] * c[j]), 0.0);
            if i == j { e + l } else { e }
        });
        let det = m.determinant();
        let (f, _) = sys.characteristic(l, d, 0.0);
        assert_relative_eq!(f.re, det.re, max_relative = 1e-12, epsilon = 1e-12);
        assert_relative_eq!(f.im, det.im, max_relative = 1e-12, epsilon = 1e-12);
    }
}

/// Hayes (1950): x' = a·x + b·x(t − τ) is asymptotically stable iff a·τ < 1 and
/// −s/(τ·sin s) < b < −a, where s ∈ (0, π) solves s·cot s = a·τ.
fn hayes_stable(a: f64, b: f64, tau: f64) -> Option<bool> {
    if a * tau >= 1.0 {
        return Some(false);
    }
    // bisection on s·cot(s) − a·τ (decreasing on (0, π))
    let (mut lo, mut hi) = (1e-12, std::f64::consts::PI - 1e-12);
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if m / m.tan() > a * tau {
            lo = m
        } else {
            hi = m
        }
    }
    let s = 0.5 * (lo + hi);
    let b_low = -s / (tau * s.sin());
    // stay 1e-6 away from the boundaries: exactly on them stability is not decided
    if (b - b_low).abs() < 1e-6 || (b + a).abs() < 1e-6 {
        return None;
    }
    Some(b > b_low && b < -a)
}

#[test]
fn scalar_dde_reproduces_hayes_region() {
    let tau = 1.0;
    let mut checked = 0;
    for i in 0..25 {
        for j in 0..25 {
            let a = -3.0 + 4.0 * i as f64 / 24.0 + 0.0123; // a ∈ (−3, 1.01)
            let b = -4.0 + 6.0 * j as f64 / 24.0 + 0.0071;
            let Some(reference) = hayes_stable(a, b, tau) else {
                continue;
            };
            // rank-one form: x' = a·x + u, u = −D·x(t − τ) with D = −b
            let sys = RankOneFeedback::from_state_space(
                &Matrix1::new(a),
                &Matrix1::new(1.0),
                &Matrix1::new(1.0),
            )
            .unwrap();
            assert_eq!(
                sys.unstable_root_count(-b, tau).unwrap() == 0,
                reference,
                "a={a} b={b}"
            );
            // general form, confirmed spectral roots
            let dde = LinearDde::new(DMatrix::from_element(1, 1, a))
                .unwrap()
                .with_delay(tau, DMatrix::from_element(1, 1, b))
                .unwrap();
            let r = rightmost_roots(&dde, 1, &RootOptions::default()).unwrap();
            assert_eq!(r[0].re < 0.0, reference, "a={a} b={b} root {}", r[0]);
            checked += 1;
        }
    }
    assert!(checked > 550);
}

#[test]
fn scalar_dde_dynamic_boundary_is_analytic_curve() {
    // reference: b = −s/(τ sin s) at a = s·cot(s)/τ (parametric Hayes boundary); tolerance 1e-11:
    // the crossing frequency is solved to round-off
    let tau = 0.5;
    for &s in &[0.3_f64, 1.0, 1.5, 2.2, 2.9] {
        let a = s / s.tan() / tau;
        let b = -s / (tau * s.sin());
        let sys = RankOneFeedback::from_state_space(
            &Matrix1::new(a),
            &Matrix1::new(1.0),
            &Matrix1::new(1.0),
        )
        .unwrap();
        let c = sys.crossings(tau, 2.0 * b.abs()).unwrap();
        let first = c
            .iter()
            .filter(|c| c.omega > 0.0)
            .min_by(|x, y| x.omega.total_cmp(&y.omega))
            .unwrap();
        assert_relative_eq!(first.omega, s / tau, max_relative = 1e-11);
        assert_relative_eq!(first.d, -b, max_relative = 1e-11);
    }
}

#[test]
fn semi_discretisation_converges_with_order_two() {
    // reference: the rightmost roots from Chebyshev collocation polished by Newton on det Δ(λ)
    // (accurate to ~1e-14); the first-order semi-discretisation error should fall by 4 per
    // halving of the step.
    let a0 = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -2.0, -0.3]);
    let a1 = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, -0.8, -0.4]);
    let dde = LinearDde::new(a0).unwrap().with_delay(1.3, a1).unwrap();
    let exact = rightmost_roots(&dde, 2, &RootOptions::default()).unwrap();
    let mut errors = Vec::new();
    for r in [10, 20, 40, 80, 160] {
        let sd = SemiDiscretisation { steps_per_delay: r }
            .roots(&dde)
            .unwrap();
        let e = sd
            .iter()
            .map(|z| (z - exact[0]).norm())
            .fold(f64::INFINITY, f64::min);
        errors.push(e);
    }
    let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("semi-discretisation errors {errors:?}, observed orders {orders:?}");
    for o in &orders[1..] {
        assert!((1.8..2.2).contains(o), "observed order {o}");
    }
    assert!(errors[4] < 1e-3);
}

#[test]
fn semi_discretisation_handles_delays_off_the_grid() {
    // reference: polished spectral roots; two delays whose ratio is irrational, so the delayed
    // points fall between grid points (the split-interval weights are exercised). Order 2 again.
    let a0 = DMatrix::from_row_slice(2, 2, &[-0.5, 1.0, -1.0, -0.2]);
    let a1 = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, -0.6, 0.1]);
    let a2 = DMatrix::from_row_slice(2, 2, &[0.2, 0.0, 0.0, -0.3]);
    let dde = LinearDde::new(a0)
        .unwrap()
        .with_delay(1.0, a1)
        .unwrap()
        .with_delay(std::f64::consts::FRAC_1_SQRT_2, a2)
        .unwrap();
    let exact = rightmost_roots(&dde, 2, &RootOptions::default()).unwrap();
    let err = |r: usize| {
        let sd = SemiDiscretisation { steps_per_delay: r }
            .roots(&dde)
            .unwrap();
        sd.iter()
            .map(|z| (z - exact[0]).norm())
            .fold(f64::INFINITY, f64::min)
    };
    let (e1, e2) = (err(40), err(160));
    let order = (e1 / e2).log2() / 2.0;
    eprintln!("off-grid delays: errors {e1:e} {e2:e}, order {order}");
    assert!((1.7..2.3).contains(&order), "observed order {order}");
}

#[test]
fn chebyshev_collocation_converges_spectrally() {
    // reference: Newton-polished root; the collocation error must drop below 1e-10 by N = 24
    let a0 = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -2.0, -0.3]);
    let a1 = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, -0.8, -0.4]);
    let dde = LinearDde::new(a0).unwrap().with_delay(1.3, a1).unwrap();
    let exact = rightmost_roots(&dde, 1, &RootOptions::default()).unwrap()[0];
    let err = |n: usize| {
        let ev = ChebyshevCollocation { degree: n }
            .eigenvalues(&dde)
            .unwrap();
        ev.iter()
            .map(|z| (z - exact).norm())
            .fold(f64::INFINITY, f64::min)
    };
    let (e8, e16, e24) = (err(8), err(16), err(24));
    eprintln!("collocation errors N=8 {e8:e}, 16 {e16:e}, 24 {e24:e}");
    assert!(e16 < 1e-2 * e8);
    assert!(e24 < 1e-10);
}

#[test]
fn rank_one_and_general_newton_agree() {
    // two independent characteristic functions (quasi-polynomial vs det Δ(λ)) polish to the
    // same roots; tolerance 1e-11 relative (both converge to round-off)
    let (a, b, c) = test_loop(5.0);
    let sys = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
    let (d, tau) = (0.8, 0.3);
    let r1 = sys
        .rightmost_roots(d, tau, 6, &RootOptions::default())
        .unwrap();
    let dde = sys.closed_loop(d, tau).unwrap();
    let r2 = rightmost_roots(&dde, 6, &RootOptions::default()).unwrap();
    for (x, y) in r1.iter().zip(&r2) {
        assert_relative_eq!(x.re, y.re, max_relative = 1e-11, epsilon = 1e-11);
        assert_relative_eq!(x.im, y.im, max_relative = 1e-11, epsilon = 1e-11);
        // residual of the exact characteristic function
        let res = dde.characteristic_function(*x).norm();
        let scale = dde.characteristic_matrix(*x).norm().powi(4);
        assert!(res < 1e-10 * scale, "residual {res}");
    }
    let _ = NewtonOptions::default();
}

#[test]
fn static_boundary_is_independent_of_delay_and_dynamic_points_are_on_axis() {
    for &v in &[1.0, 4.5, 9.0] {
        let (a, b, c) = test_loop(v);
        let sys = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
        let statics: Vec<f64> = [0.0, 0.1, 0.2, 0.4, 1.0]
            .iter()
            .map(|&t| {
                sys.crossings(t, 50.0)
                    .unwrap()
                    .iter()
                    .find(|c| c.omega == 0.0)
                    .unwrap()
                    .d
            })
            .collect();
        // reference: −p(0)/q(0); identical bits for every τ
        for s in &statics {
            assert_eq!(*s, statics[0]);
        }
        assert_relative_eq!(statics[0], -sys.p()[0] / sys.q()[0], max_relative = 1e-15);
        for &tau in &[0.0, 0.1, 0.4, 1.0] {
            let cr = sys.crossings(tau, 10.0).unwrap();
            assert!(cr.iter().any(|c| c.omega > 0.0) || tau == 0.0);
            for c in cr.iter().filter(|c| c.omega > 0.0) {
                // a root at (D, τ) near iω must exist and lie on the axis to 1e-8
                let l = sys
                    .polish_root(
                        Complex64::new(0.0, c.omega),
                        c.d,
                        tau,
                        &NewtonOptions::default(),
                    )
                    .unwrap();
                assert!(
                    l.re.abs() < 1e-8,
                    "v={v} τ={tau} D={} ω={}: root {l}",
                    c.d,
                    c.omega
                );
                assert!((l.im - c.omega).abs() < 1e-8 * c.omega.max(1.0));
            }
        }
    }
}

#[test]
fn crossing_count_matches_root_count_along_lines() {
    // reference: the number of roots with Re > 0 among the confirmed rightmost roots
    for &v in &[1.0, 6.0] {
        let (a, b, c) = test_loop(v);
        let sys = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
        for &tau in &[0.0, 0.3, 1.0] {
            let cr = sys.crossings(tau, 6.0).unwrap();
            for k in 0..41 {
                let d = -5.0 + 10.0 * k as f64 / 40.0 + 0.00317;
                let n = sys.unstable_count_from(d, &cr);
                let roots = sys
                    .rightmost_roots(d, tau, n + 3, &RootOptions::default())
                    .unwrap();
                let m = roots.iter().filter(|r| r.re > 0.0).count();
                assert_eq!(n, m, "v={v} τ={tau} D={d}: roots {roots:?}");
            }
        }
    }
}

#[test]
fn stable_intervals_end_on_crossings() {
    let (a, b, c) = test_loop(6.0);
    let sys = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
    let iv = sys.stable_gain_intervals(0.3, -5.0, 5.0).unwrap();
    assert!(!iv.is_empty());
    for (lo, hi) in iv {
        // just inside: stable; just outside (if not the range end): unstable
        assert_eq!(sys.unstable_root_count(lo + 1e-7, 0.3).unwrap(), 0);
        assert_eq!(sys.unstable_root_count(hi - 1e-7, 0.3).unwrap(), 0);
        if lo > -5.0 {
            assert!(sys.unstable_root_count(lo - 1e-7, 0.3).unwrap() > 0);
        }
        if hi < 5.0 {
            assert!(sys.unstable_root_count(hi + 1e-7, 0.3).unwrap() > 0);
        }
    }
}

#[test]
fn quasi_polynomial_from_coefficients_equals_the_state_space_loop() {
    // reference: the same loop built from (A, B, C) (Faddeev–LeVerrier); the canonical
    // realisation of its p and q must give the same crossings, counts and rightmost roots
    // (to 1e-9 relative: the companion matrix's eigenvalues carry its conditioning)
    for &(v, d, tau) in &[(2.0, 0.3, 0.2), (6.0, -0.4, 0.5), (10.0, 1.2, 0.1)] {
        let (a, b, c) = test_loop(v);
        let direct = RankOneFeedback::from_state_space(&a, &b, &c).unwrap();
        let canonical = RankOneFeedback::from_polynomials(direct.p(), direct.q()).unwrap();
        assert_eq!(direct.p(), canonical.p());
        assert_eq!(direct.q(), canonical.q());
        assert_eq!(
            direct.unstable_root_count(d, tau).unwrap(),
            canonical.unstable_root_count(d, tau).unwrap()
        );
        let (r1, r2) = (
            direct
                .rightmost_roots(d, tau, 4, &RootOptions::default())
                .unwrap(),
            canonical
                .rightmost_roots(d, tau, 4, &RootOptions::default())
                .unwrap(),
        );
        for (x, y) in r1.iter().zip(&r2) {
            assert!((x - y).norm() <= 1e-9 * x.norm().max(1.0), "{x} vs {y}");
        }
    }
    // a q of p's degree is a neutral equation: refused
    assert!(RankOneFeedback::from_polynomials(&[1.0, 1.0], &[0.0, 1.0]).is_err());
    assert!(RankOneFeedback::from_polynomials(&[1.0, 2.0], &[0.5]).is_err()); // not monic
}

#[test]
fn crossings_without_a_usable_frequency_bound_are_an_error_not_an_allocation() {
    // p(s) = s + 1e7: the crossing search's frequency bound is ~2e7 rad/s, which at τ = 1 s
    // (a sample every quarter period of e^{-iωτ}) would take ~2.5e7 samples; such a bound is
    // no bound (seen on a predictor with a mismatched model, where it asked for 1.7e15
    // bytes): a typed error naming the degrees
    let sys = RankOneFeedback::from_polynomials(&[1e7, 1.0], &[1.0]).expect("p, q");
    match sys.crossings(1.0, 1.0) {
        Err(stability::StabilityError::UnboundedCrossings {
            degree_p, degree_q, ..
        }) => assert_eq!((degree_p, degree_q), (1, 0)),
        other => panic!("expected UnboundedCrossings, got {other:?}"),
    }
    // the same loop with a delay that needs few samples still has its crossing:
    // |p(iω)| = |q| · D at D = 1 has none (|iω + 1e7| > 1), so the search is empty
    assert!(sys.crossings(1e-7, 1.0).expect("bounded").is_empty());
}

#[test]
fn delayed_terms_factored_by_rank_have_the_same_roots() {
    // reference: the same DDE with the full n×n delayed term (`with_delay`); the factored one
    // (`with_delay_by_rank`) has a rank-one term and a generator of 4 + N rows instead of
    // 4 + 4N. Its rightmost roots (polished on det Δ, the same function up to rounding of
    // B·C) agree to 1e-12 relative; a zero term is dropped, a full-rank one kept whole.
    let (a, b, c) = test_loop(5.0);
    let a0 = DMatrix::from_fn(4, 4, |i, j| a[(i, j)]);
    for (d, tau) in [(0.3, 0.2), (-0.8, 1.1)] {
        let a1 = DMatrix::from_fn(4, 4, |i, j| -d * b[i] * c[j]);
        let full = LinearDde::new(a0.clone())
            .unwrap()
            .with_delay(tau, a1.clone())
            .unwrap();
        let factored = LinearDde::new(a0.clone())
            .unwrap()
            .with_delay_by_rank(tau, a1)
            .unwrap();
        assert_eq!(factored.delayed_terms()[0].c.nrows(), 1);
        let want = rightmost_roots(&full, 6, &RootOptions::default()).unwrap();
        let got = rightmost_roots(&factored, 6, &RootOptions::default()).unwrap();
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).norm() <= 1e-12 * w.norm().max(1.0), "{g} vs {w}");
        }
    }
    let zero = LinearDde::new(a0.clone())
        .unwrap()
        .with_delay_by_rank(0.5, DMatrix::zeros(4, 4))
        .unwrap();
    assert!(zero.delayed_terms().is_empty());
    let whole = LinearDde::new(a0.clone())
        .unwrap()
        .with_delay_by_rank(0.5, DMatrix::identity(4, 4))
        .unwrap();
    assert_eq!(whole.delayed_terms()[0].c.nrows(), 4);
}
