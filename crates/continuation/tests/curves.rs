//! Two-parameter curves of Hopf points and folds of equilibria, codimension-two points:
//! every check against a closed form (or, for the Jacobians, central differences).
mod common;

use common::{
    cont, continued, curve_system, dense_jacobian, equilibrium_branch, fd_jacobian_of,
    hopf_on_branch, only_codim2, single_codim2,
};
use continuation::*;
use continuation_textbook::*;
use num_complex::Complex64;

#[test]
fn delay_as_free_parameter_of_equilibria_and_hopf_points() {
    // reference: closed form τ* = arccos(γ/b)/ω, ω = √(b² − γ²) at γ = 1, b = −2;
    // location tolerance 1e-10 in τ, required 1e-8; ω from Newton-refined roots, 1e-10
    let hopf = hopf_on_branch(&ScalarDelay, vec![1.0, -2.0, 0.3], 2, 40);
    let (omega, tau) = ScalarDelay::hopf(1.0, -2.0);
    assert!(
        (hopf.parameter - tau).abs() < 1e-8,
        "τ = {}",
        hopf.parameter
    );
    assert!((hopf.omega - omega).abs() < 1e-10 * omega);
    assert!(hopf.transversality > 0.0, "unstable beyond the Hopf delay");
}

#[test]
fn analytic_hopf_curve_with_the_delay_as_parameter() {
    // reference: closed form ω = √(b² − γ²), τ = arccos(γ/b)/ω (γ = 1). Tolerance 1e-9
    // relative: Newton stops at updates below 1e-10 and converges quadratically, so the
    // points are exact to ~1e-14; 1e-9 leaves room for the conditioning of the defining
    // system (its Jacobian has entries up to |b|τ ~ 5).
    let hopf = hopf_on_branch(&ScalarDelay, vec![1.0, -2.0, 0.3], 2, 40);
    let c = cont(0.05, 0.2);
    for sign in [1.0, -1.0] {
        let mut hc = curve_system(
            HopfCurveSystem::new,
            &ScalarDelay,
            vec![1.0, -2.0, 0.3],
            [2, 1],
        );
        let (guess, dir) = hc.start_at_hopf(&hopf, 2).unwrap();
        let dir: Vec<f64> = dir.iter().map(|d| sign * d).collect();
        let curve = continued(&c, &mut hc, &guess, &dir, 30);
        let mut checked = 0;
        for pt in &curve.points {
            let (tau, b) = (pt.parameter, pt.secondary_parameter.unwrap());
            assert!(b < -1.0, "b = {b}");
            let (omega, tau_exact) = ScalarDelay::hopf(1.0, b);
            assert!(
                (hc.omega(&pt.u) - omega).abs() < 1e-9 * omega,
                "ω at b = {b}"
            );
            assert!((tau - tau_exact).abs() < 1e-9 * tau_exact, "τ at b = {b}");
            assert!(hc.state(&pt.u)[0].abs() < 1e-12);
            // the eigenvector solves Δ(iω) v = 0 and the remaining roots are stable
            let v = hc.eigenvector(&pt.u)[0];
            let delta = Complex64::new(1.0, omega) - b * Complex64::new(0.0, -omega * tau).exp();
            assert!((delta * v).norm() < 1e-9);
            assert_eq!(pt.is_stable(), Some(true));
            checked += 1;
        }
        assert!(checked > 30);
        // the curve moves along b in the requested direction
        let b_end = curve.points.last().unwrap().secondary_parameter.unwrap();
        assert!(sign * (b_end + 2.0) > 0.1, "b_end = {b_end}");
    }
}

#[test]
fn ode_hopf_curve_ends_at_a_bogdanov_takens_point() {
    // reference: closed form of the normal form, Hopf curve β1 = −β2², x = β2, ω = √(−2β2),
    // BT point at (0, 0). Curve points to 1e-9 (Newton-converged, see the DDE test).
    // The BT point is a turning point of p1 = β2 located to 1e-10 in p1 by the engine;
    // required |β2|, |β1| < 1e-8.
    // Hopf point on the equilibrium x = −1 (β1 = −1) continued in β2 from −2: β2 = −1
    let c = cont(0.05, 0.1);
    let (mut eq, br) =
        equilibrium_branch(&BogdanovTakens, vec![-1.0, -2.0], 1, &[-1.0, 0.0, -2.0], 40);
    let (i, sp) = br.first(SpecialKind::Hopf).expect("Hopf point");
    let hopf = eq
        .hopf_point(&br.points[i].u, sp.transversality.unwrap())
        .unwrap();
    assert!((hopf.parameter + 1.0).abs() < 1e-8);
    assert!((hopf.omega - 2f64.sqrt()).abs() < 1e-10);

    let mut hc = curve_system(
        HopfCurveSystem::new,
        &BogdanovTakens,
        vec![-1.0, -1.0],
        [1, 0],
    );
    let (guess, dir) = hc.start_at_hopf(&hopf, 1).unwrap();
    let curve = continued(&c, &mut hc, &guess, &dir, 80);
    for pt in &curve.points {
        let (beta2, beta1) = hc.parameters(&pt.u);
        let w = hc.omega(&pt.u);
        assert!(
            (beta1 + beta2 * beta2).abs() < 1e-9,
            "β1 = {beta1}, β2 = {beta2}"
        );
        assert!((w * w + 2.0 * beta2).abs() < 1e-9, "ω = {w}, β2 = {beta2}");
        assert!((hc.state(&pt.u)[0] - beta2).abs() < 1e-9);
    }
    let bt = single_codim2(hc.codim2_points(&curve), SpecialKind::BogdanovTakens);
    assert!(bt.p1.abs() < 1e-8 && bt.p2.abs() < 1e-8, "{bt:?}");
    assert!(bt.omegas.is_empty());
}

#[test]
fn fold_curve_of_the_bt_normal_form_and_its_bt_point() {
    // reference: closed form, fold curve β1 = 0 with x = y = 0; the second zero eigenvalue
    // (remaining eigenvalue β2) at β2 = 0. Points to 1e-12 (exact zeros, Newton-converged),
    // BT located to 1e-10 in p1 = β2, required 1e-8.
    let c = cont(0.05, 0.1);
    // fold of the equilibrium x = −√(−β1) at β1 = 0, β2 = 0.5
    let (_, br) = equilibrium_branch(&BogdanovTakens, vec![-1.0, 0.5], 0, &[-1.0, 0.0, -1.0], 60);
    let (i, sp) = br.first(SpecialKind::Fold).expect("fold");
    assert!(sp.parameter.abs() < 1e-8);
    let x_fold = br.points[i].u[..2].to_vec();

    let mut fc = curve_system(
        FoldCurveSystem::new,
        &BogdanovTakens,
        vec![0.0, 0.5],
        [1, 0],
    );
    let (guess, dir) = fc.start_at_fold(&x_fold, 0, sp.parameter).unwrap();
    let dir: Vec<f64> = dir.iter().map(|d| -d).collect(); // β2 decreasing
    let curve = continued(&c, &mut fc, &guess, &dir, 30);
    for pt in &curve.points {
        let (beta2, beta1) = fc.parameters(&pt.u);
        assert!(beta1.abs() < 1e-12 && fc.state(&pt.u).iter().all(|x| x.abs() < 1e-12));
        // remaining eigenvalue β2
        if beta2.abs() > 1e-6 {
            assert_eq!(pt.is_stable(), Some(beta2 < 0.0));
        }
    }
    let c2 = fc.codim2_points(&curve).unwrap();
    only_codim2(c2, SpecialKind::BogdanovTakens, (1e-8, 1e-12));
}

#[test]
fn fold_curve_with_a_cusp() {
    // reference: closed form 27 p1² = 4 p2³ (p1 = −2x³, p2 = 3x²), cusp at (0, 0).
    // Points to 1e-9 relative (Newton-converged); the cusp is located by regula falsi on
    // the quadratic coefficient until p1 changes by < 1e-10; required |p1|, |p2| < 1e-8.
    let (_, br) = equilibrium_branch(&Cubic, vec![-2.0, 3.0], 0, &[-2.0, -2.0], 80);
    let (i, sp) = br.first(SpecialKind::Fold).expect("fold");
    assert!((sp.parameter - 2.0).abs() < 1e-8);

    let mut fc = curve_system(FoldCurveSystem::new, &Cubic, vec![2.0, 3.0], [0, 1]);
    let (guess, dir) = fc
        .start_at_fold(&br.points[i].u[..1], 0, sp.parameter)
        .unwrap();
    let dir: Vec<f64> = dir.iter().map(|d| -d).collect(); // p2 decreasing, towards the cusp
    let c = cont(0.1, 0.3);
    let curve = continued(&c, &mut fc, &guess, &dir, 80);
    for pt in &curve.points {
        let (p1, p2) = fc.parameters(&pt.u);
        let x = fc.state(&pt.u)[0];
        assert!((p1 + 2.0 * x.powi(3)).abs() < 1e-9 * (1.0 + p1.abs()));
        assert!((p2 - 3.0 * x * x).abs() < 1e-9 * (1.0 + p2.abs()));
        assert!((27.0 * p1 * p1 - 4.0 * p2.powi(3)).abs() < 1e-9 * (1.0 + p2.powi(3)));
    }
    // the curve passed through the cusp to the other side (x > 0)
    assert!(fc.state(&curve.points.last().unwrap().u)[0] > 0.2);
    let cusp = only_codim2(
        fc.codim2_points(&curve).unwrap(),
        SpecialKind::Cusp,
        (1e-8, 1e-8),
    );
    assert_eq!(
        curve.points[cusp.index].special.as_ref().unwrap().location,
        Location::Located
    );
}

/// Hopf curve of mode 1 of `problem` from b1 = −3, in (τ, b1) with b1 increasing
fn mode_one_curve(
    problem: &TwoModes,
    points: usize,
) -> (HopfCurveSystem<'_, TwoModes, ChebyshevRoots>, Branch) {
    let hopf = hopf_on_branch(problem, vec![-3.0, 0.3], 1, 40);
    let mut hc = curve_system(HopfCurveSystem::new, problem, vec![-3.0, 0.3], [1, 0]);
    let (guess, dir) = hc.start_at_hopf(&hopf, 1).unwrap();
    let mut c = cont(0.05, 0.1);
    // stop before mode 2's next crossing at τ = (2.5 + 2π)/2.5 ≈ 3.5
    c.options.parameter_range = (0.0, 3.0);
    let curve = continued(&c, &mut hc, &guess, &dir, points);
    (hc, curve)
}

fn double_hopf_problem() -> (TwoModes, f64) {
    // both modes critical at τ* = 1: mode 1 with ω1 = 2 at b1* = −2/sin 2, mode 2 with
    // ω2 = 2.5 for every b1
    let (gamma1, b1_star) = TwoModes::mode(1.0, 2.0);
    let (gamma2, b2) = TwoModes::mode(1.0, 2.5);
    let p = TwoModes {
        gamma1,
        gamma2,
        b2,
        real: None,
    };
    (p, b1_star)
}

#[test]
fn double_hopf_point_of_two_delayed_modes() {
    // reference: by construction (closed form γ = −ω cot ωτ, b = −ω/sin ωτ) both modes have
    // their first Hopf point at τ* = 1, mode 1 with ω1 = 2 at b1* = −2/sin 2, mode 2 with
    // ω2 = 2.5. The double-Hopf point is located by regula falsi on Re of the second pair
    // until τ changes by < 1e-10; required 1e-8 on (τ, b1) and on both frequencies.
    let (p, b1_star) = double_hopf_problem();
    let (hc, curve) = mode_one_curve(&p, 40);
    let d = &single_codim2(hc.codim2_points(&curve), SpecialKind::DoubleHopf);
    assert!((d.p1 - 1.0).abs() < 1e-8, "τ = {}", d.p1);
    assert!((d.p2 - b1_star).abs() < 1e-8, "b1 = {} vs {b1_star}", d.p2);
    assert_eq!(d.omegas.len(), 2);
    assert!((d.omegas[0] - 2.0).abs() < 1e-8, "ω1 = {}", d.omegas[0]);
    assert!((d.omegas[1] - 2.5).abs() < 1e-8, "ω2 = {}", d.omegas[1]);
    let sp = curve.points[d.index].special.as_ref().unwrap();
    assert_eq!(sp.location, Location::Located);
    assert!((sp.critical.unwrap().im - 2.5).abs() < 1e-8);
    // remaining spectrum stable before, unstable after (b1 increasing)
    assert_eq!(curve.points[d.index - 1].is_stable(), Some(true));
    assert_eq!(curve.points[d.index + 1].is_stable(), Some(false));
    // every point on mode 1's closed-form curve τ = arccos(γ1/b1)/√(b1² − γ1²)
    for pt in &curve.points {
        let (tau, b1) = (pt.parameter, pt.secondary_parameter.unwrap());
        let (omega, tau_exact) = ScalarDelay::hopf(p.gamma1, b1);
        assert!((tau - tau_exact).abs() < 1e-9 * tau_exact);
        assert!((hc.omega(&pt.u) - omega).abs() < 1e-9 * omega);
    }
}

#[test]
fn zero_hopf_point_of_a_delayed_mode_and_a_real_mode() {
    // reference: the real root b1 + β of x2' = (b1 + β) x2 passes 0 at b1 = −β = −2.5 on
    // mode 1's Hopf curve, τ = arccos(γ1/b1)/√(b1² − γ1²) there (closed form); located to
    // 1e-10 in τ, required 1e-8.
    let (gamma1, _) = TwoModes::mode(1.0, 2.0);
    let p = TwoModes {
        gamma1,
        gamma2: 0.0,
        b2: 0.0,
        real: Some(2.5),
    };
    let (hc, curve) = mode_one_curve(&p, 30);
    let zh = single_codim2(hc.codim2_points(&curve), SpecialKind::ZeroHopf);
    let (omega, tau) = ScalarDelay::hopf(gamma1, -2.5);
    assert!((zh.p2 + 2.5).abs() < 1e-8, "b1 = {}", zh.p2);
    assert!((zh.p1 - tau).abs() < 1e-8);
    assert!((zh.omegas[0] - omega).abs() < 1e-8);
}

#[test]
fn hopf_curve_resumed_from_json_equals_an_uninterrupted_run() {
    // reference: the uninterrupted run (40 points, through the double-Hopf point); the
    // resumed run saves the branch after 20 points to JSON, loads it into a fresh system
    // and extends it by 20. JSON keeps f64 exactly (shortest round-trip representation), and
    // the system's only state (the normalisation vector) is rebuilt from the last point, so
    // the points agree to rounding (1e-13).
    let (p, _) = double_hopf_problem();
    let (_, full) = mode_one_curve(&p, 40);
    let (_, half) = mode_one_curve(&p, 20);
    let json = serde_json::to_string(&half).unwrap();
    let mut loaded: Branch = serde_json::from_str(&json).unwrap();
    let mut hc = curve_system(HopfCurveSystem::new, &p, vec![-3.0, 0.3], [1, 0]);
    let mut c = cont(0.05, 0.1);
    c.options.parameter_range = (0.0, 3.0);
    c.extend(&mut hc, &mut loaded, 20).unwrap();
    assert_eq!(loaded.points.len(), full.points.len());
    for (a, b) in loaded.points.iter().zip(&full.points) {
        for (x, y) in a.u.iter().zip(&b.u) {
            assert!((x - y).abs() < 1e-13 * (1.0 + y.abs()), "{x} vs {y}");
        }
        assert_eq!(
            a.special.as_ref().map(|s| s.kind),
            b.special.as_ref().map(|s| s.kind)
        );
    }
    assert!(loaded.first(SpecialKind::DoubleHopf).is_some());
}

/// deterministic pseudo-random numbers in (−1, 1)
fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// `n` of them
fn random(n: usize, seed: &mut u64) -> Vec<f64> {
    (0..n).map(|_| lcg(seed)).collect()
}

/// random unknowns, the two free parameters (the last two) in [1, 1.5) to keep the delays
/// positive
fn random_unknowns(n: usize, seed: &mut u64) -> Vec<f64> {
    let mut u = random(n, seed);
    for p in &mut u[n - 2..] {
        *p = 1.0 + 0.5 * p.abs();
    }
    u
}

/// the exact Jacobian of `sys` at `u` against central differences
fn assert_exact_jacobian<S: ContinuationSystem>(sys: &mut S, u: &[f64], what: &str) {
    let exact = dense_jacobian(sys, u);
    let fd = fd_jacobian_of(sys, u);
    for (e, f) in exact.iter().zip(fd.iter()) {
        assert!(
            (e - f).abs() < 1e-6 * (1.0 + e.abs()),
            "{what}: exact {e} vs central differences {f}"
        );
    }
}

#[test]
fn exact_jacobians_of_the_curve_systems_match_central_differences() {
    // reference: central differences of the residual (h = 1e-6, error O(h²) ≈ 1e-12 plus
    // rounding ≈ 1e-10); tolerance 1e-6 relative. Random points (not on the curves), both
    // delays depending on the free parameters (τ and c), and a pair without delays (a, b).
    let params = vec![0.7, 1.3, 0.4, 0.9];
    let mut seed = 42u64;
    for free in [[3, 2], [2, 3], [0, 1]] {
        for _ in 0..5 {
            let mut hc = curve_system(HopfCurveSystem::new, &TanhNet, params.clone(), free);
            let mut u = random_unknowns(hc.n_unknowns(), &mut seed);
            let nu = u.len();
            u[nu - 3] += 1.0; // ω
            hc.set_reference(&random(nu, &mut seed));
            assert_exact_jacobian(&mut hc, &u, "Hopf curve");

            let mut fc = curve_system(FoldCurveSystem::new, &TanhNet, params.clone(), free);
            let u = random_unknowns(fc.n_unknowns(), &mut seed);
            fc.set_reference(&random(u.len(), &mut seed));
            assert_exact_jacobian(&mut fc, &u, "fold curve");
        }
    }
}

#[test]
fn missing_second_derivatives_are_reported() {
    // reference: the trait default reports MissingDerivative instead of guessing
    // (`SaddleNode` supplies first derivatives only)
    let mut fc = curve_system(FoldCurveSystem::new, &SaddleNode, vec![0.0, 0.0], [0, 1]);
    let mut entries = Vec::new();
    let err = fc
        .jacobian(&[0.0, 1.0, 0.0, 0.0], &mut entries)
        .unwrap_err();
    assert!(matches!(err, Error::MissingDerivative { .. }), "{err}");
}
