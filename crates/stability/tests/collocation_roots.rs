//! `collocation_roots`: rightmost characteristic roots at one fixed Chebyshev degree.
use nalgebra::DMatrix;
use num_complex::Complex64;
use stability::{LinearDde, NewtonOptions, collocation_roots};

#[test]
fn roots_of_x_prime_equals_minus_x_delayed_are_lambert_w_values() {
    // reference: λ + e^{−λ} = 0 has the roots λ = W_k(−1); the rightmost pair is
    // W_0(−1) = −0.318131505204764 ± 1.337235701430689i (tabulated, 15 digits). Polished
    // roots: 1e-13; every returned root satisfies the characteristic equation to 1e-12.
    let dde = LinearDde::new(DMatrix::zeros(1, 1))
        .and_then(|d| d.with_delay(1.0, DMatrix::from_element(1, 1, -1.0)))
        .expect("dde");
    let roots = collocation_roots(&dde, 30, 6, Some(&NewtonOptions::default())).expect("roots");
    assert_eq!(roots.len(), 6);
    let w0 = Complex64::new(-0.318_131_505_204_764, 1.337_235_701_430_689);
    assert!((roots[0] - w0).norm() < 1e-13, "{}", roots[0]);
    assert!((roots[1] - w0.conj()).norm() < 1e-13, "{}", roots[1]);
    for l in &roots {
        assert!((l + (-l).exp()).norm() < 1e-12, "{l}");
    }
    assert!(roots.windows(2).all(|w| w[0].re >= w[1].re));
    // unpolished: the collocation's own accuracy (spectral; degree 30 resolves W_0 to 1e-10)
    let raw = collocation_roots(&dde, 30, 2, None).expect("raw roots");
    assert!((raw[0] - w0).norm() < 1e-10, "{}", raw[0]);
}

#[test]
fn without_delays_all_eigenvalues_are_returned() {
    // reference: the eigenvalues of diag(−1, −2, −3) (exact), whatever `count` says
    let dde = LinearDde::new(DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![
        -1.0, -2.0, -3.0,
    ])))
    .expect("ode");
    let roots = collocation_roots(&dde, 30, 1, Some(&NewtonOptions::default())).expect("roots");
    assert_eq!(roots.len(), 3);
    for (r, e) in roots.iter().zip([-1.0, -2.0, -3.0]) {
        assert!((r - e).norm() < 1e-14, "{r}");
    }
}
