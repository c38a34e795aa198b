//! Delay equations: Hopf points and periodic orbits with known answers, DDE Floquet multipliers.
mod common;

use approx::assert_relative_eq;
use common::{colloc, cycles_from_hopf};
use continuation::*;
use continuation_textbook::{DelayedStuartLandau, LinearDelay};
use nalgebra::DMatrix;
use num_complex::Complex64;
use std::f64::consts::PI;

#[test]
fn linear_delay_equation_hopf_at_a_tau_pi_half() {
    // reference: x' = −a x(t − τ) has roots ±iω with ω = a exactly when aτ = π/2
    let tau = 1.0;
    let c = Continuation::new(ContinuationOptions {
        initial_step: 0.1,
        max_step: 0.2,
        ..Default::default()
    });
    let mut eq =
        EquilibriumSystem::new(&LinearDelay, vec![1.0, tau], 0, ChebyshevRoots::default()).unwrap();
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[0.0, 1.0], &dir).unwrap();
    c.extend(&mut eq, &mut br, 10).unwrap();
    assert_eq!(br.points[0].is_stable(), Some(true));
    let (i, sp) = br.first(SpecialKind::Hopf).expect("Hopf point");
    // location tolerance 1e-10 on the parameter; required 1e-8
    assert!(
        (sp.parameter - PI / 2.0).abs() < 1e-8,
        "Hopf at {}",
        sp.parameter
    );
    let hopf = eq
        .hopf_point(&br.points[i].u, sp.transversality.unwrap())
        .unwrap();
    assert_relative_eq!(hopf.omega, PI / 2.0, max_relative = 1e-10);
    assert_eq!(br.points.last().unwrap().is_stable(), Some(false));
}

/// characteristic roots of the co-rotating linearisation of the delayed Stuart–Landau cycle
/// the distance from z to the nearest of `values` (∞ without values)
fn distance(z: Complex64, values: impl Iterator<Item = Complex64>) -> f64 {
    values.map(|v| (v - z).norm()).fold(f64::INFINITY, f64::min)
}

fn rotating_frame_roots(mu: f64, kappa: f64, tau: f64) -> Vec<Complex64> {
    let (c, s) = (tau.cos(), tau.sin());
    let a0 = DMatrix::from_row_slice(
        2,
        2,
        &[-2.0 * mu - kappa * c, -kappa * s, kappa * s, -kappa * c],
    );
    let a1 = DMatrix::from_row_slice(2, 2, &[kappa * c, kappa * s, -kappa * s, kappa * c]);
    let roots = ChebyshevRoots {
        degree: 60,
        count: 12,
        refinement: Refinement::Newton,
    };
    roots.rightmost_roots(&[a0, a1], &[tau]).unwrap()
}

fn delayed_stuart_landau(tau: f64) {
    // reference: the cycle z = √μ e^{it} (period 2π) exists for every τ; Hopf at μ = 0, ω = 1;
    // Floquet multipliers = exp(2πλ) for the roots λ of the co-rotating linearisation,
    // computed independently (Chebyshev collocation of the generator + Newton, degree 60).
    let kappa = 0.1;
    let c = Continuation::new(ContinuationOptions {
        initial_step: 0.05,
        max_step: 0.1,
        parameter_range: (-1.0, 0.5),
        ..Default::default()
    });
    let p = DelayedStuartLandau;
    let mut eq =
        EquilibriumSystem::new(&p, vec![-0.3, kappa, tau], 0, ChebyshevRoots::default()).unwrap();
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[0.0, 0.0, -0.3], &dir).unwrap();
    c.extend(&mut eq, &mut br, 12).unwrap();
    let (i, sp) = br.first(SpecialKind::Hopf).expect("Hopf point");
    assert!(sp.parameter.abs() < 1e-8, "Hopf at {}", sp.parameter);
    let hopf = eq
        .hopf_point(&br.points[i].u, sp.transversality.unwrap())
        .unwrap();
    assert_relative_eq!(hopf.omega, 1.0, max_relative = 1e-10);

    let (po, cyc) = cycles_from_hopf(&c, &p, vec![0.0, kappa, tau], 30, &hopf, 30);
    assert_eq!(criticality(&hopf, &cyc), Some(Criticality::Supercritical));
    let mut checked = 0;
    for pt in cyc.points.iter().filter(|p| p.parameter > 0.05) {
        let mu = pt.parameter;
        // collocation on a circle: error ~1e-10; tolerance 1e-8
        assert_relative_eq!(po.max_abs(&pt.u, 0), mu.sqrt(), max_relative = 1e-8);
        assert_relative_eq!(po.period(&pt.u), 2.0 * PI, max_relative = 1e-8);
        let st = pt.stability.as_ref().unwrap();
        assert!((st.trivial_multiplier().unwrap() - 1.0).norm() < 1e-7);
        let roots = rotating_frame_roots(mu, kappa, tau);
        let expected: Vec<Complex64> = roots.iter().map(|l| (l * 2.0 * PI).exp()).collect();
        // every computed multiplier with |μ| > 1e-3 is exp(2πλ) of some root, to 1e-6
        for m in st.values.iter().filter(|m| m.norm() > 1e-3) {
            let err = distance(*m, expected.iter().copied());
            assert!(
                err < 1e-6,
                "multiplier {m} not among exp(2πλ): error {err:e}"
            );
        }
        // and the leading nontrivial one is present
        let lead = expected
            .iter()
            .filter(|e| (*e - 1.0).norm() > 1e-6)
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
            .unwrap();
        let err = distance(*lead, st.nontrivial());
        assert!(
            err < 1e-6,
            "leading multiplier {lead} missing (error {err:e})"
        );
        checked += 1;
    }
    assert!(checked >= 3);
}

#[test]
fn delayed_stuart_landau_delay_shorter_than_period() {
    delayed_stuart_landau(0.5);
}

#[test]
fn delayed_stuart_landau_delay_longer_than_period() {
    delayed_stuart_landau(2.0 * PI + 1.0);
}

#[test]
fn torus_bifurcation_of_the_delayed_stuart_landau_cycle() {
    // reference: the cycle z = √μ e^{it} loses stability when a complex pair of roots of the
    // co-rotating linearisation crosses the imaginary axis (then the multipliers exp(2πλ)
    // leave the unit circle as a complex pair: a torus / Neimark–Sacker point). The crossing
    // κ* is found independently by bisection on Re λ(κ) of the characteristic roots
    // (Chebyshev + Newton); the continuation in κ must detect a torus point and locate it
    // to 1e-6 in κ (collocation error of the multipliers, L = 30, m = 4).
    let (mu, tau) = (0.1, 2.0);
    let crit = |kappa: f64| {
        rotating_frame_roots(mu, kappa, tau)
            .into_iter()
            .filter(|z| z.im.abs() > 1e-6)
            .map(|z| z.re)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (mut a, mut b) = (0.6, 0.7);
    assert!(crit(a) < 0.0 && crit(b) > 0.0);
    while b - a > 1e-12 {
        let m = 0.5 * (a + b);
        if crit(m) < 0.0 { a = m } else { b = m }
    }
    let kappa_star = 0.5 * (a + b);

    let p = DelayedStuartLandau;
    let mut po = PeriodicOrbitSystem::new(&p, vec![mu, 0.55, tau], 1, colloc(30)).unwrap();
    let guess = po.unknowns_from(
        |s| {
            vec![
                mu.sqrt() * (2.0 * PI * s).cos(),
                mu.sqrt() * (2.0 * PI * s).sin(),
            ]
        },
        2.0 * PI,
        0.55,
    );
    po.set_reference(&guess);
    let mut e = vec![0.0; guess.len()];
    e[po.parameter_index()] = 1.0;
    let c = Continuation::new(ContinuationOptions {
        initial_step: 0.02,
        max_step: 0.05,
        parameter_range: (0.0, 0.8),
        ..Default::default()
    });
    let mut br = c.start(&mut po, &guess, &e).unwrap();
    c.extend(&mut po, &mut br, 40).unwrap();
    let (i, sp) = br.first(SpecialKind::Torus).expect("torus point");
    assert_eq!(sp.location, Location::Located);
    assert!(
        (sp.parameter - kappa_star).abs() < 1e-6,
        "torus at κ = {} vs κ* = {kappa_star}",
        sp.parameter
    );
    assert_eq!(br.points[i - 1].is_stable(), Some(true));
    assert_eq!(br.points[i + 1].is_stable(), Some(false));
    // the critical multipliers are a complex pair on the unit circle
    let z = sp.critical.unwrap();
    assert!(
        (z.norm() - 1.0).abs() < 1e-8 && z.im.abs() > 0.1,
        "critical multiplier {z}"
    );
}
