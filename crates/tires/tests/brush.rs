//! Properties of the brush tire, eq. (14)–(15), checked against analytic facts.

use approx::assert_relative_eq;
use num_dual::{Dual64, first_derivative};
use proptest::prelude::*;
use tires::{BrushTire, LinearTire, TireError, TireModel};

/// Table I front tire with the load from the statics of Fig. 2: C_F, F_z,F, μ0, μ.
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

// ---- Magic Formula and the per-axle tyre law ----

use tires::{MagicFormulaTire, TireLaw, TireLawSpec};

/// Table I front axle load, C_F = 137 kN/rad, μ_p = 0.9, C = 1.536, E = 0.3
fn magic() -> MagicFormulaTire {
    MagicFormulaTire::from_peak_friction(137e3, 11894.6, 0.9, 1.536, 0.3).expect("valid")
}

#[test]
fn magic_formula_slope_peak_and_asymptote() {
    // References (Pacejka 2012, §4.3.2): dF/dα(0) = B·C·D (exact through dual numbers, up to
    // the round-off of B = C_α/(C·D): 1e-15 relative); the peak value is D, reached where
    // B·α − E(B·α − atan B·α) = tan(π/(2C)) (closed form of the argument, the slip angle by
    // Newton to 1e-15); the large-slip asymptote is D·sin(C·π/2) (the argument of sin tends
    // to C·π/2; at α = 1e6 rad the gap is O(1/(B α)) ≈ 1e-7 relative).
    let t = magic();
    let (f0, slope) = first_derivative(|a: Dual64| t.lateral_force(a), 0.0);
    assert_eq!(f0, 0.0);
    assert_relative_eq!(slope, 137e3, max_relative = 1e-14);
    assert_relative_eq!(t.cornering_stiffness(), 137e3, max_relative = 1e-14);
    let a_peak = t.peak_slip_angle();
    assert_relative_eq!(t.lateral_force(a_peak), 0.9 * 11894.6, max_relative = 1e-14);
    let (_, d_peak) = first_derivative(|a: Dual64| t.lateral_force(a), a_peak);
    assert!(d_peak.abs() < 1e-9 * 137e3, "slope at the peak {d_peak}");
    // nothing on a fine grid exceeds D
    for k in 0..20_000 {
        let a = -1.5 + 3.0 * k as f64 / 20_000.0;
        assert!(t.lateral_force(a).abs() <= 0.9 * 11894.6 * (1.0 + 1e-15));
    }
    let asymptote = 0.9 * 11894.6 * (1.536 * std::f64::consts::FRAC_PI_2).sin();
    assert_relative_eq!(t.lateral_force(1e6), asymptote, max_relative = 1e-6);
    // C ≤ 1: no peak
    let flat = MagicFormulaTire::new(10.0, 0.9, 1000.0, 0.0).expect("valid");
    assert_eq!(flat.peak_slip_angle(), f64::INFINITY);
}

#[test]
fn tyre_laws_from_the_vehicle_file_form() {
    // Reference: the law built by hand with the same numbers (exact equality), and the
    // errors naming the parameter.
    let fz = 10008.0;
    let parse = |s: &str| -> TireLawSpec { toml::from_str(s).expect(s) };
    let brush = parse("law = \"brush\"")
        .build(50e3, fz, 0.9, 0.6)
        .expect("brush");
    assert_eq!(
        brush,
        TireLaw::Brush(BrushTire::new(50e3, fz, 0.9, 0.6).unwrap())
    );
    assert_eq!(TireLawSpec::default().build(50e3, fz, 0.9, 0.6), Ok(brush));
    let own = parse("law = \"brush\"\nmu_static = 1.0\nmu_dynamic = 0.8")
        .build(50e3, fz, 0.9, 0.6)
        .expect("brush");
    assert_eq!(
        own,
        TireLaw::Brush(BrushTire::new(50e3, fz, 1.0, 0.8).unwrap())
    );
    let lin = parse("law = \"linear\"")
        .build(50e3, fz, 0.9, 0.6)
        .expect("linear");
    assert_eq!(lin.lateral_force(0.01), 500.0);
    let mf = parse("law = \"magic_formula\"\nshape_factor = 1.536\ncurvature_factor = 0.3\npeak_friction = 0.9")
        .build(137e3, 11894.6, 0.9, 0.6)
        .expect("mf");
    assert_eq!(mf, TireLaw::MagicFormula(magic()));
    assert_eq!(mf.kinks().sliding_limit, None);
    assert!(!mf.kinks().at_zero && brush.kinks().at_zero);
    // B given and consistent: accepted; inconsistent: named error
    let b = magic().stiffness_factor;
    let with_b = format!(
        "law = \"magic_formula\"\nshape_factor = 1.536\ncurvature_factor = 0.3\npeak_force = {}\nstiffness_factor = {b}",
        0.9 * 11894.6
    );
    assert!(parse(&with_b).build(137e3, 11894.6, 0.9, 0.6).is_ok());
    assert!(matches!(
        parse(&with_b).build(100e3, 11894.6, 0.9, 0.6),
        Err(TireError::StiffnessMismatch { .. })
    ));
    // D twice or not at all
    let e = parse(
        "law = \"magic_formula\"\nshape_factor = 1.3\npeak_force = 9000.0\npeak_friction = 0.9",
    )
    .build(137e3, fz, 0.9, 0.6)
    .unwrap_err();
    assert_eq!(e, TireError::PeakChoice { given: 2 });
    let e = parse("law = \"magic_formula\"\nshape_factor = 1.3").build(137e3, fz, 0.9, 0.6);
    assert_eq!(e, Err(TireError::PeakChoice { given: 0 }));
    // out of range C and E, negative μ_p
    let e = parse("law = \"magic_formula\"\nshape_factor = 2.5\npeak_friction = 0.9")
        .build(137e3, fz, 0.9, 0.6)
        .unwrap_err();
    assert!(e.to_string().contains("shape_factor"), "{e}");
    let e = parse(
        "law = \"magic_formula\"\nshape_factor = 1.3\ncurvature_factor = 1.5\npeak_friction = 0.9",
    )
    .build(137e3, fz, 0.9, 0.6)
    .unwrap_err();
    assert!(e.to_string().contains("curvature_factor"), "{e}");
    let e = parse("law = \"magic_formula\"\nshape_factor = 1.3\npeak_friction = -0.9")
        .build(137e3, fz, 0.9, 0.6)
        .unwrap_err();
    assert!(e.to_string().contains("peak_friction"), "{e}");
    // unknown law and unknown key: serde errors that name them
    let e = toml::from_str::<TireLawSpec>("law = \"pacejka\"").unwrap_err();
    assert!(e.to_string().contains("pacejka"), "{e}");
    let e = toml::from_str::<TireLawSpec>("law = \"linear\"\nshape_factor = 1.0").unwrap_err();
    assert!(e.to_string().contains("shape_factor"), "{e}");
    let e = toml::from_str::<TireLawSpec>("law = \"brush\"\nmu = 1.0").unwrap_err();
    assert!(e.to_string().contains("mu"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(21), ..ProptestConfig::default() })]

    #[test]
    fn magic_formula_is_odd_and_its_derivative_matches_differences(
        a in -1.0f64..1.0, c in 0.5f64..1.9, e in -2.0f64..1.0, mu in 0.3f64..1.2
    ) {
        // Reference: oddness of the formula (exact in floating point: atan and sin are odd)
        // and central differences with h = 1e-6 (smooth law: error O(h²F''') + O(ε F/h),
        // below 1e-6 of the cornering stiffness).
        let t = MagicFormulaTire::from_peak_friction(1e5, 1e4, mu, c, e).expect("valid");
        prop_assert_eq!(t.lateral_force(-a), -t.lateral_force(a));
        let h = 1e-6;
        let fd = (t.lateral_force(a + h) - t.lateral_force(a - h)) / (2.0 * h);
        let (_, ad) = first_derivative(|x: Dual64| t.lateral_force(x), a);
        prop_assert!((fd - ad).abs() <= 1e-6 * 1e5, "fd {fd} ad {ad}");
        // the law dispatches to the same numbers
        let law = TireLaw::MagicFormula(t);
        prop_assert_eq!(law.lateral_force(a), t.lateral_force(a));
        prop_assert_eq!(law.lateral_force_from_tan(a.tan()), t.lateral_force_from_tan(a.tan()));
    }
}
