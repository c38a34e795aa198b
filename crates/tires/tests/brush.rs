//! Properties of the brush tire, eq. (14)–(15), checked against analytic facts.

use approx::assert_relative_eq;
use num_dual::{Dual64, first_derivative};
use proptest::prelude::*;
use tires::{BrushTire, LinearTire, TireError, TireModel};

/// Table I front tire with the statically computed load (DESIGN.md): C_F, F_z,F, μ0, μ.
fn front() -> BrushTire {
    BrushTire::new(137e3, 11894.6, 0.9, 0.6).expect("valid tire")
}

#[test]
fn continuous_at_critical_slip_angle() {
    // Reference: eq. (15) makes the polynomial equal F_z·μ at tan α_cr = 3 F_z μ0 / C
    // exactly; the residual is round-off of a sum of terms of size ~3 F_z μ0 (1e-12 rel).
    let t = front();
    let a_cr = t.critical_slip_angle().expect("brush tire has α_cr");
    assert_relative_eq!(
        a_cr.tan(),
        3.0 * 11894.6 * 0.9 / 137e3,
        max_relative = 1e-14
    );
    for sign in [1.0, -1.0] {
        let inside = t.lateral_force(sign * a_cr);
        let outside = t.lateral_force(sign * a_cr * (1.0 + 1e-12));
        assert_relative_eq!(inside, sign * t.sliding_force(), max_relative = 1e-11);
        assert_relative_eq!(outside, sign * t.sliding_force(), max_relative = 1e-14);
    }
}

#[test]
fn slope_at_zero_is_cornering_stiffness() {
    // Reference: dF/dα(0) = φ1 = C (eq. 15); exact through dual numbers.
    let t = front();
    for a0 in [0.0, 1e-300, -1e-300] {
        let (_, slope) = first_derivative(|a: Dual64| t.lateral_force(a), a0);
        assert_relative_eq!(slope, 137e3, max_relative = 1e-14);
    }
}

#[test]
fn saturates_at_sliding_force() {
    // Reference: eq. (14) second case, F = F_z μ sgn α for |α| > α_cr.
    let t = front();
    for a in [0.3, 0.7, 1.2] {
        assert_eq!(t.lateral_force(a), 11894.6 * 0.6);
        assert_eq!(t.lateral_force(-a), -11894.6 * 0.6);
    }
}

#[test]
fn linear_tire_is_linear() {
    let t = LinearTire {
        cornering_stiffness: 5e4,
    };
    assert_relative_eq!(t.lateral_force(0.01), 500.0, max_relative = 1e-15);
    assert!(t.critical_slip_angle().is_none());
}

#[test]
fn bad_parameters_are_rejected() {
    assert!(matches!(
        BrushTire::new(-1.0, 1e4, 0.9, 0.6),
        Err(TireError::NotPositive {
            name: "cornering_stiffness",
            ..
        })
    ));
    assert!(matches!(
        BrushTire::new(1e5, 1e4, 0.6, 0.9),
        Err(TireError::FrictionOrder { .. })
    ));
    assert!(BrushTire::new(1e5, f64::NAN, 0.9, 0.6).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

    #[test]
    fn odd_in_alpha(a in -1.5f64..1.5, c in 1e4f64..5e5, fz in 1e3f64..3e4, mu in 0.1f64..1.0) {
        // Reference: symmetry F(−α) = −F(α) of eq. (14); exact in floating point.
        let t = BrushTire::new(c, fz, 1.0, mu).expect("valid");
        prop_assert_eq!(t.lateral_force(-a), -t.lateral_force(a));
    }

    #[test]
    fn derivative_matches_central_differences(u in 0.02f64..0.98, c in 1e4f64..5e5, fz in 1e3f64..3e4, sign in prop::bool::ANY) {
        // Reference: central finite differences, error O(h²·F''') + O(eps·F/h); with
        // h = 1e-6·α_cr the relative agreement is better than 1e-6. Points stay away
        // from the kinks at 0 (C¹ only) and ±α_cr (C⁰ only).
        let t = BrushTire::new(c, fz, 0.9, 0.6).expect("valid");
        let a_cr = t.critical_slip_angle().expect("has α_cr");
        let a = if sign { u * a_cr } else { -u * a_cr };
        let h = 1e-6 * a_cr;
        let fd = (t.lateral_force(a + h) - t.lateral_force(a - h)) / (2.0 * h);
        let (_, ad) = first_derivative(|x: Dual64| t.lateral_force(x), a);
        prop_assert!((fd - ad).abs() <= 1e-6 * ad.abs().max(c * 1e-3), "fd {fd} ad {ad}");
    }

    #[test]
    fn tan_form_equals_angle_form(a in -1.5f64..1.5, c in 1e4f64..5e5, fz in 1e3f64..3e4) {
        // Reference: eq. (14) evaluated at α and at tan α describe the same function;
        // identical up to the round-off of tan(atan(t)) (1e-15 relative).
        let t = BrushTire::new(c, fz, 0.9, 0.6).expect("valid");
        let f1 = t.lateral_force(a);
        let f2 = t.lateral_force_from_tan(a.tan());
        prop_assert!((f1 - f2).abs() <= 1e-12 * f1.abs().max(1.0), "{f1} {f2}");
    }

    #[test]
    fn force_bounded_by_peak(a in -1.5f64..1.5) {
        // The brush force never exceeds the static-friction peak F_z μ0 (physical bound).
        let t = front();
        prop_assert!(t.lateral_force(a).abs() <= 11894.6 * 0.9 * (1.0 + 1e-12));
    }
}
