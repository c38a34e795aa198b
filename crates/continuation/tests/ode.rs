//! Equilibria, Hopf points, cycles, Floquet multipliers and folds of ODEs with known answers.
mod common;

use approx::assert_relative_eq;
use common::{colloc, cont, cycles_from_hopf, hopf_on_branch};
use continuation::*;
use continuation_textbook::{NormalForm, SaddleNode, VanDerPol};
use std::f64::consts::PI;

#[test]
fn stuart_landau_hopf_amplitude_period_multiplier() {
    // reference: closed form of r' = r(μ − r²), θ' = ω + b r²: Hopf at μ = 0 with frequency ω,
    // cycle radius √μ, period 2π/(ω + bμ), nontrivial Floquet multiplier exp(−2μT).
    let p = NormalForm::stuart_landau(1.3, 0.4);
    let hopf = hopf_on_branch(&p, vec![-0.37], 0, 30);
    // location tolerance 1e-10 in the options; required 1e-8
    assert!(hopf.parameter.abs() < 1e-8, "Hopf at {}", hopf.parameter);
    assert_relative_eq!(hopf.omega, 1.3, max_relative = 1e-12);
    assert!(hopf.transversality > 0.0);

    let c = cont(0.05, 0.2);
    let (po, br) = cycles_from_hopf(&c, &p, vec![0.0], 20, &hopf, 25);
    assert_eq!(criticality(&hopf, &br), Some(Criticality::Supercritical));
    let mut checked = 0;
    for pt in &br.points {
        let mu = pt.parameter;
        if mu < 0.05 {
            continue;
        }
        let t_exact = 2.0 * PI / (1.3 + 0.4 * mu);
        // collocation error (m = 4, L = 20) on a circle is ~1e-10; tolerance 1e-8
        assert_relative_eq!(po.max_abs(&pt.u, 0), mu.sqrt(), max_relative = 1e-8);
        assert_relative_eq!(po.period(&pt.u), t_exact, max_relative = 1e-8);
        let st = pt.stability.as_ref().unwrap();
        let trivial = st.trivial_multiplier().unwrap();
        assert!(
            (trivial - 1.0).norm() < 1e-8,
            "trivial multiplier {trivial}"
        );
        let other: Vec<_> = st.nontrivial().collect();
        assert_relative_eq!(
            other[0].re,
            (-2.0 * mu * t_exact).exp(),
            max_relative = 1e-7
        );
        assert!(other[0].im.abs() < 1e-10);
        assert!(st.is_stable());
        checked += 1;
    }
    assert!(checked > 5);
}

#[test]
fn subcritical_normal_form_fold_of_cycles() {
    // reference: r' = r(μ + 2r² − r⁴): cycles on μ = r⁴ − 2r², fold at μ = −1, r = 1;
    // multiplier exp(2π·4r²(1 − r²)) (unstable for r < 1, stable for r > 1); period 2π.
    let p = NormalForm::subcritical();
    let hopf = hopf_on_branch(&p, vec![-0.5], 0, 30);
    assert!(hopf.parameter.abs() < 1e-8);

    let c = Continuation::new(ContinuationOptions {
        initial_step: 0.05,
        max_step: 0.1,
        parameter_range: (-2.0, 1.0),
        ..Default::default()
    });
    let (po, br) = cycles_from_hopf(&c, &p, vec![0.0], 20, &hopf, 80);
    assert_eq!(criticality(&hopf, &br), Some(Criticality::Subcritical));
    let (i, fold) = br.first(SpecialKind::Fold).expect("fold of cycles");
    assert_eq!(fold.location, Location::Located);
    // location tolerance 1e-10; collocation error on a circle ~1e-10
    assert!(
        (fold.parameter + 1.0).abs() < 1e-8,
        "fold at {}",
        fold.parameter
    );
    assert_relative_eq!(po.max_abs(&br.points[i].u, 0), 1.0, max_relative = 1e-5);
    // before the fold unstable, after it stable
    assert_eq!(br.points[i - 1].is_stable(), Some(false));
    assert_eq!(br.points[i + 1].is_stable(), Some(true));
    for pt in br.points.iter().filter(|p| p.special.is_none()) {
        let r = po.max_abs(&pt.u, 0);
        assert_relative_eq!(pt.parameter, r.powi(4) - 2.0 * r * r, epsilon = 1e-8);
        let st = pt.stability.as_ref().unwrap();
        let mu2 = st.nontrivial().next().unwrap();
        let exact = (2.0 * PI * 4.0 * r * r * (1.0 - r * r)).exp();
        // collocation error: relative 1e-6, absolute 1e-12 for the tiny multipliers
        assert_relative_eq!(mu2.re, exact, max_relative = 1e-6, epsilon = 1e-12);
    }
}

#[test]
fn van_der_pol_period_liouville_and_mesh_doubling() {
    // reference: period of van der Pol at μ = 1, T = 6.663_286_859_323_13 (published, e.g.
    // Hairer–Nørsett–Wanner I, and many high-accuracy computations); nontrivial multiplier by
    // Liouville's formula exp(∫₀ᵀ tr J dt) = exp(∫ μ(1 − x²) dt) evaluated on the profile.
    // (the Hopf point of van der Pol at μ = 0 is degenerate — a vertical branch of harmonic
    // cycles — so we start from the guess x = 2 cos t at μ = 1 with the parameter fixed)
    let c = cont(0.1, 0.3);
    let mut results = Vec::new();
    for l in [40usize, 80] {
        let mut po = PeriodicOrbitSystem::new(&VanDerPol, vec![1.0], 0, colloc(l)).unwrap();
        let guess = po.unknowns_from(
            |s| vec![2.0 * (2.0 * PI * s).cos(), -2.0 * (2.0 * PI * s).sin()],
            2.0 * PI,
            1.0,
        );
        po.set_reference(&guess);
        let mut e = vec![0.0; guess.len()];
        e[po.parameter_index()] = 1.0;
        let br = c.start(&mut po, &guess, &e).unwrap();
        let pt = &br.points[0];
        assert_eq!(pt.parameter, 1.0);
        let t = po.period(&pt.u);
        assert_relative_eq!(t, 6.663_286_859_323_13, max_relative = 1e-7);
        // Liouville: integrate μ(1 − x²) over the period with Gauss quadrature on a fine grid
        let mut x = [0.0; 2];
        let mut dx = [0.0; 2];
        let (gx, gw) = gauss_legendre(6);
        let nseg = 400;
        let mut integral = 0.0;
        for sgm in 0..nseg {
            for (xi, w) in gx.iter().zip(&gw) {
                let s = (sgm as f64 + xi) / nseg as f64;
                po.eval(&pt.u, s, &mut x, &mut dx);
                integral += w / nseg as f64 * (1.0 - x[0] * x[0]);
            }
        }
        let liouville = (integral * t).exp();
        let st = pt.stability.as_ref().unwrap();
        assert!((st.trivial_multiplier().unwrap() - 1.0).norm() < 1e-7);
        let mu2 = st.nontrivial().next().unwrap();
        assert_relative_eq!(mu2.re, liouville, max_relative = 1e-6);
        results.push((t, po.max_abs(&pt.u, 0), mu2.re));
    }
    // mesh doubling changes results by < 1e-4 relative (here far less)
    let (a, b) = (results[0], results[1]);
    assert_relative_eq!(a.0, b.0, max_relative = 1e-4);
    assert_relative_eq!(a.1, b.1, max_relative = 1e-4);
    assert_relative_eq!(a.2, b.2, max_relative = 1e-4);
    // amplitude of van der Pol at μ = 1 is 2.00861986 (published value, to 1e-6)
    assert_relative_eq!(b.1, 2.00861986, max_relative = 1e-6);
}

#[test]
fn branch_saved_and_continued_later_gives_the_same_points() {
    // reference: continuing a deserialised branch must reproduce continuing the original
    let p = NormalForm::stuart_landau(1.0, 0.0);
    let c = cont(0.05, 0.1);
    let mut eq = EquilibriumSystem::new(&p, vec![-0.5], 0, ChebyshevRoots::default()).unwrap();
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[0.0, 0.0, -0.5], &dir).unwrap();
    c.extend(&mut eq, &mut br, 5).unwrap();
    let json = serde_json::to_string(&br).unwrap();
    let mut restored: Branch = serde_json::from_str(&json).unwrap();
    assert_eq!(restored, br);
    c.extend(&mut eq, &mut br, 10).unwrap();
    c.extend(&mut eq, &mut restored, 10).unwrap();
    assert_eq!(restored, br);
    assert!(br.first(SpecialKind::Hopf).is_some());
}

#[test]
fn saddle_node_of_equilibria_is_located() {
    // reference: x' = p − x² has equilibria x = ±√p, stable for x > 0, meeting in a fold at
    // p = 0; the fold is located on the parameter's turning point to 1e-8 (tolerance 1e-10)
    let c = cont(0.1, 0.2);
    let mut eq =
        EquilibriumSystem::new(&SaddleNode, vec![1.0], 0, ChebyshevRoots::default()).unwrap();
    // start at x = 1, p = 1 going down in p
    let mut dir = eq.parameter_direction();
    dir[1] = -1.0;
    let mut br = c.start(&mut eq, &[1.0, 1.0], &dir).unwrap();
    c.extend(&mut eq, &mut br, 30).unwrap();
    let (i, fold) = br.first(SpecialKind::Fold).expect("fold");
    assert_eq!(fold.location, Location::Located);
    assert!(fold.parameter.abs() < 1e-8, "fold at {}", fold.parameter);
    assert!(
        br.points[i].u[0].abs() < 1e-4,
        "x at the fold {}",
        br.points[i].u[0]
    );
    assert_eq!(br.points[i - 1].is_stable(), Some(true));
    assert_eq!(br.points[i + 1].is_stable(), Some(false));
    // every point lies on p = x²
    for p in &br.points {
        assert_relative_eq!(p.parameter, p.u[0] * p.u[0], epsilon = 1e-12);
    }
}
