//! Folds of cycles in two parameters (ODE and DDE) and delays as free parameters of cycles,
//! against closed forms (radial normal forms, rotating waves) and finite differences.
mod common;
use approx::assert_relative_eq;
use common::{colloc, cont, dense_jacobian, fd_jacobian_of};
use continuation::*;
use continuation_textbook::{DelayedBautin, Radial};
use std::f64::consts::PI;

/// rotating wave (ρ, ω) of `DelayedBautin` near the guess, by Newton on the 2 × 2 system
/// (independent of collocation)
fn rotating_wave(mu1: f64, mu2: f64, tau: f64, guess: (f64, f64)) -> (f64, f64) {
    let (mut r, mut w) = guess;
    for _ in 0..100 {
        let (c, s) = ((w * tau).cos(), (w * tau).sin());
        let f1 = mu1 + mu2 * r * c - r * r;
        let f2 = w - 1.0 + mu2 * r * s;
        let (a, b) = (mu2 * c - 2.0 * r, -mu2 * r * tau * s);
        let (cc, d) = (mu2 * s, 1.0 + mu2 * r * tau * c);
        let det = a * d - b * cc;
        let (dr, dw) = ((d * f1 - b * f2) / det, (a * f2 - cc * f1) / det);
        r -= dr;
        w -= dw;
        if dr.abs() + dw.abs() < 1e-15 {
            break;
        }
    }
    (r, w)
}

/// fold in μ1 of the rotating waves of `DelayedBautin` at (μ2, τ): (μ1*, ρ*, ω*), by
/// bisection on dμ1/dρ along the family (ω(ρ) from the imaginary part by Newton)
fn rotating_wave_fold(mu2: f64, tau: f64) -> (f64, f64, f64) {
    let omega = |r: f64| {
        let mut w: f64 = 1.0;
        for _ in 0..100 {
            let f = w - 1.0 + mu2 * r * (w * tau).sin();
            let df = 1.0 + mu2 * r * tau * (w * tau).cos();
            w -= f / df;
        }
        w
    };
    let slope = |r: f64| {
        let w = omega(r);
        let (c, s) = ((w * tau).cos(), (w * tau).sin());
        let dw = -mu2 * s / (1.0 + mu2 * r * tau * c);
        2.0 * r - mu2 * c + mu2 * r * tau * s * dw
    };
    let (mut a, mut b) = (0.1 * mu2, 1.5 * mu2);
    assert!(slope(a) < 0.0 && slope(b) > 0.0, "no fold bracket");
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if slope(m) < 0.0 { a = m } else { b = m }
    }
    let r = 0.5 * (a + b);
    let w = omega(r);
    (r * r - mu2 * r * (w * tau).cos(), r, w)
}

fn circle(r: f64) -> impl Fn(f64) -> Vec<f64> {
    move |s| vec![r * (2.0 * PI * s).cos(), r * (2.0 * PI * s).sin()]
}

/// continue the cycle `u0` of `po` in its free parameter (direction `sign`) to the first
/// located fold; returns that point
fn first_fold<P: Problem>(
    po: &mut PeriodicOrbitSystem<'_, P>,
    u0: &[f64],
    sign: f64,
) -> BranchPoint {
    po.set_reference(u0);
    let mut dir = vec![0.0; u0.len()];
    dir[po.parameter_index()] = sign;
    let c = cont(0.05, 0.1);
    let mut br = c.start(po, u0, &dir).unwrap();
    // point by point up to the first fold (beyond it the branch runs into the Hopf point)
    for _ in 0..60 {
        c.extend(po, &mut br, 1).unwrap();
        if br.first(SpecialKind::Fold).is_some() {
            break;
        }
    }
    let (i, sp) = br.first(SpecialKind::Fold).expect("a fold of cycles");
    assert_eq!(sp.location, Location::Located);
    br.points[i].clone()
}

/// the first fold of the cycles of the radial form `p` from the circle of radius `r` at
/// `params` (continued in p\[0\] in the direction `sign`), on `intervals` mesh intervals
fn fold_from_circle(
    p: &Radial,
    params: Vec<f64>,
    intervals: usize,
    r: f64,
    sign: f64,
) -> (PeriodicOrbitSystem<'_, Radial>, BranchPoint) {
    let mu1 = params[0];
    let mut po = PeriodicOrbitSystem::new(p, params, 0, colloc(intervals)).unwrap();
    let u0 = po.unknowns_from(circle(r), 2.0 * PI, mu1);
    let fold = first_fold(&mut po, &u0, sign);
    (po, fold)
}

/// fold-of-cycles options without Floquet multipliers along the curve
fn without_multipliers() -> FoldCyclesOptions {
    FoldCyclesOptions {
        multipliers: false,
        ..Default::default()
    }
}

#[test]
fn bautin_fold_of_cycles_curve_is_analytic_and_ends_at_the_bautin_point() {
    // reference: the folds of cycles of the Bautin normal form lie exactly on μ1 = −μ2²/4 with
    // radius √(μ2/2) and period 2π; the two leading Floquet multipliers (trivial and fold)
    // are 1. Collocation of a circle with m = 4, L = 12 is accurate to ~1e-11 (the profile
    // is a trigonometric polynomial; superconvergence at the mesh points), so the tolerance is
    // 1e-8 on μ1, radius and period; multipliers (a double eigenvalue: errors ~√ε) 1e-6.
    let p = Radial::BAUTIN;
    let (po, fold) = fold_from_circle(&p, vec![0.0, 1.0], 12, 1.0, -1.0);
    assert!(
        (fold.parameter + 0.25).abs() < 1e-8,
        "fold at {}",
        fold.parameter
    );
    let opts = FoldCyclesOptions {
        min_amplitude: 0.02,
        multipliers: true,
    };
    let (mut sys, guess, dir) = FoldOfCyclesSystem::from_fold(&po, &fold, 1, opts).unwrap();
    let back: Vec<f64> = dir.iter().map(|d| -d).collect();
    let c = cont(0.05, 0.1);
    let mut curve = c.start(&mut sys, &guess, &back).unwrap();
    let stop = sys.extend_curve(&c, &mut curve, 300).unwrap();
    let FoldCyclesStop::HopfEnd(end) = stop else {
        panic!("the curve did not end at the Bautin point: {stop:?}")
    };
    assert!(curve.points.len() > 10);
    for pt in &curve.points {
        let (mu1, mu2) = (pt.parameter, pt.secondary_parameter.unwrap());
        assert!(
            (mu1 + mu2 * mu2 / 4.0).abs() < 1e-8,
            "μ1 = {mu1}, μ2 = {mu2}"
        );
        let cyc = sys.periodic_system(&pt.u).unwrap();
        let r = cyc.max_abs(sys.orbit(&pt.u), 0);
        assert!(
            (r - (mu2 / 2.0).sqrt()).abs() < 1e-8,
            "radius {r} at μ2 = {mu2}"
        );
        assert!((sys.period(&pt.u) - 2.0 * PI).abs() < 1e-8);
        let st = pt.stability.as_ref().unwrap();
        assert!((st.values[0] - 1.0).norm() < 1e-6 && (st.values[1] - 1.0).norm() < 1e-6);
    }
    // the end: amplitude below 0.02 → μ2 ≈ 2·0.02² = 8e-4; the extrapolation to zero
    // amplitude is exact to first order in ρ: the estimate is within ρ² ~ 1e-7 of (0, 0)
    let last = curve.points.last().unwrap();
    assert_eq!(end.index, curve.points.len() - 1);
    assert_eq!(
        last.special.as_ref().unwrap().kind,
        SpecialKind::CriticalityChange
    );
    assert!(end.amplitude < 0.02);
    assert!(
        end.parameters[0].abs() < 1e-6 && end.parameters[1].abs() < 1e-5,
        "{end:?}"
    );
    assert!((end.omega - 1.0).abs() < 1e-8, "ω = {}", end.omega);
}

#[test]
fn delayed_bautin_fold_curve_in_mu1_and_the_delay_matches_rotating_waves() {
    // reference: folds of the rotating waves of the delayed Bautin form at (μ2 = 1, τ) from
    // the 2 × 2 rotating-wave equations (bisection on dμ1/dρ, to 1e-15); the fold-of-cycles
    // curve is continued in (μ1, τ), so a delay is the second free parameter. DDE collocation
    // (L = 24, m = 4) reads delayed values off the interpolant, error O(h^(m+1)): measured
    // ~6e-8 in μ1 at L = 12 and ~2e-8 relative in the radius at L = 24; tolerances 1e-8 on μ1,
    // 1e-7 relative on radius and period.
    let p = DelayedBautin::SINGLE;
    let (mu2, tau) = (1.0, 0.5);
    // the rotating wave of radius 1 (ρ = 1): ω = 1 − μ2 sin ωτ, μ1 = 1 − μ2 cos ωτ
    let mut w0: f64 = 1.0;
    for _ in 0..100 {
        w0 -= (w0 - 1.0 + mu2 * (w0 * tau).sin()) / (1.0 + mu2 * tau * (w0 * tau).cos());
    }
    let mu1 = 1.0 - mu2 * (w0 * tau).cos();
    let mut po = PeriodicOrbitSystem::new(&p, vec![mu1, mu2, tau], 0, colloc(24)).unwrap();
    let u0 = po.unknowns_from(circle(1.0), 2.0 * PI / w0, mu1);
    let fold = first_fold(&mut po, &u0, -1.0);
    let (mu1_star, _, _) = rotating_wave_fold(mu2, tau);
    assert!(
        (fold.parameter - mu1_star).abs() < 1e-8,
        "fold at {} vs {mu1_star}",
        fold.parameter
    );

    for newton in [NewtonUpdate::Full, NewtonUpdate::Chord { full: 2 }] {
        let opts = without_multipliers();
        let (mut sys, guess, dir) = FoldOfCyclesSystem::from_fold(&po, &fold, 2, opts).unwrap();
        // the chord corrector (NewtonUpdate::Chord) converges to the same points: the same
        // analytic tolerances hold for both
        let c = Continuation::new(ContinuationOptions {
            initial_step: 0.05,
            max_step: 0.1,
            newton,
            ..Default::default()
        });
        let mut curve = c.start(&mut sys, &guess, &dir).unwrap();
        sys.extend_curve(&c, &mut curve, 15).unwrap();
        let taus: Vec<f64> = curve
            .points
            .iter()
            .map(|p| p.secondary_parameter.unwrap())
            .collect();
        assert!(
            taus.last().unwrap() - taus[0] > 0.25,
            "τ moved from {} to {}",
            taus[0],
            taus.last().unwrap()
        );
        for pt in &curve.points {
            let tau = pt.secondary_parameter.unwrap();
            let (mu1_star, r_star, w_star) = rotating_wave_fold(mu2, tau);
            assert!(
                (pt.parameter - mu1_star).abs() < 1e-8,
                "μ1 {} vs {mu1_star} at τ = {tau}",
                pt.parameter
            );
            let cyc = sys.periodic_system(&pt.u).unwrap();
            assert_relative_eq!(
                cyc.max_abs(sys.orbit(&pt.u), 0),
                r_star.sqrt(),
                max_relative = 1e-7
            );
            assert_relative_eq!(sys.period(&pt.u), 2.0 * PI / w_star, max_relative = 1e-7);
        }
        // the Floquet multipliers of the fold's cycle: trivial and fold multiplier both 1
        let last = curve.points.last().unwrap().u.clone();
        let mu = sys.multipliers(&last).unwrap();
        assert!(
            (mu[0] - 1.0).norm() < 1e-5 && (mu[1] - 1.0).norm() < 1e-5,
            "{mu:?}"
        );
    }
}

#[test]
fn cycles_continued_in_the_delay_match_rotating_waves() {
    // reference: rotating waves of the delayed Bautin form at (μ1, μ2) = (0.3, −1) for each τ
    // from the 2 × 2 equations (Newton to 1e-15); the cycle branch is continued with the
    // delay τ as free parameter (Jacobian column −T f_τ + Σ J_d x'(s − τ/T) ∂τ/∂p).
    // Tolerance 1e-7 relative (DDE collocation, m = 4, delayed values read off the
    // interpolant, error O(h^(m+1)): measured 1.1e-7 at L = 12, so L = 24 is used).
    let p = DelayedBautin::SINGLE;
    let (mu1, mu2, tau0) = (0.3, -1.0, 0.2);
    let (rho, w) = rotating_wave(mu1, mu2, tau0, (0.3, 1.0));
    let mut po = PeriodicOrbitSystem::new(&p, vec![mu1, mu2, tau0], 2, colloc(24)).unwrap();
    let u0 = po.unknowns_from(circle(rho.sqrt()), 2.0 * PI / w, tau0);
    po.set_reference(&u0);
    let mut dir = vec![0.0; u0.len()];
    dir[po.parameter_index()] = 1.0;
    let c = cont(0.1, 0.5);
    let mut br = c.start(&mut po, &u0, &dir).unwrap();
    c.extend(&mut po, &mut br, 20).unwrap();
    let last_tau = br.points.last().unwrap().parameter;
    // the period falls from 6.0 to 4.2 on the way: a strongly varying family
    assert!(last_tau > 0.9, "τ reached only {last_tau}");
    let mut guess = (rho, w);
    for pt in &br.points {
        let tau = pt.parameter;
        guess = rotating_wave(mu1, mu2, tau, guess);
        let (rho, w) = guess;
        assert_relative_eq!(po.max_abs(&pt.u, 0), rho.sqrt(), max_relative = 1e-7);
        assert_relative_eq!(po.period(&pt.u), 2.0 * PI / w, max_relative = 1e-7);
        // a Newton corrector with the exact Jacobian converges in few iterations
        assert!(
            pt.newton_iterations <= 4,
            "{} iterations at τ = {tau}",
            pt.newton_iterations
        );
    }
}

/// max over entries of |J − J_fd| / (1 + |J|) with central differences (h = 1e-6)
fn jacobian_error<S: ContinuationSystem>(sys: &mut S, u: &[f64]) -> f64 {
    let jac = dense_jacobian(sys, u);
    let fd = fd_jacobian_of(sys, u);
    jac.iter().zip(fd.iter()).fold(0.0, |err: f64, (j, f)| {
        err.max((f - j).abs() / (1.0 + j.abs()))
    })
}

/// deterministic pseudo-random numbers in [−1, 1] (xorshift)
fn random(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 * 2.0 - 1.0
        })
        .collect()
}

/// a random point near a circle of radius 0.7: profile, period, parameters and null vector
fn random_point<P: Problem>(
    sys: &FoldOfCyclesSystem<'_, P>,
    po: &PeriodicOrbitSystem<'_, P>,
    p1: f64,
    p2: f64,
    seed: u64,
) -> Vec<f64> {
    let orbit = perturbed_circle(po, p1, seed);
    let np = po.period_index();
    let mut v = random(np + 1, seed + 1);
    v[np] = 0.3;
    sys.unknowns(&orbit, p2, &v).unwrap()
}

/// 5 intervals of degree 3: a small collocation system for the Jacobian checks
fn small_mesh() -> CollocationOptions {
    CollocationOptions {
        intervals: 5,
        degree: 3,
        ..Default::default()
    }
}

/// the unknowns of the circle of radius 0.7 and period 5.5 at the parameter `p1`, its
/// profile perturbed by 0.1 × random numbers from `seed`
fn perturbed_circle<P: Problem>(po: &PeriodicOrbitSystem<'_, P>, p1: f64, seed: u64) -> Vec<f64> {
    let mut u = po.unknowns_from(circle(0.7), 5.5, p1);
    let np = po.period_index();
    for (x, e) in u[..np].iter_mut().zip(random(np, seed)) {
        *x += 0.1 * e;
    }
    u
}

#[test]
fn fold_cycles_jacobian_matches_central_differences() {
    // reference: central differences of the residual (h = 1e-6: error ~1e-10 relative) at
    // random points, ODE (non-symmetric radial form) and DDE with the delay as second and as
    // first free parameter; tolerance 1e-6 relative to 1 + |entry|
    let col = small_mesh();
    let opts = FoldCyclesOptions::default();
    let ode = Radial {
        c2: -1.0,
        c3: 0.2,
        eps: 0.3,
    };
    let po = PeriodicOrbitSystem::new(&ode, vec![-0.2, 1.0], 0, col.clone()).unwrap();
    let mut sys =
        FoldOfCyclesSystem::new(&ode, vec![-0.2, 1.0], (0, 1), col.clone(), opts.clone()).unwrap();
    let u = random_point(&sys, &po, -0.2, 1.0, 7);
    sys.accept(&u);
    let e = jacobian_error(&mut sys, &u);
    assert!(e < 1e-6, "ODE: Jacobian error {e:e}");

    let dde = DelayedBautin::SINGLE;
    for (ip1, ip2, seed) in [(0, 2, 11), (2, 1, 13), (1, 0, 17)] {
        let params = vec![-0.2, 1.0, 1.3];
        let po = PeriodicOrbitSystem::new(&dde, params.clone(), ip1, col.clone()).unwrap();
        let mut sys =
            FoldOfCyclesSystem::new(&dde, params.clone(), (ip1, ip2), col.clone(), opts.clone())
                .unwrap();
        let u = random_point(&sys, &po, params[ip1], params[ip2], seed);
        sys.accept(&u);
        let e = jacobian_error(&mut sys, &u);
        assert!(
            e < 1e-6,
            "DDE (p1 = {ip1}, p2 = {ip2}): Jacobian error {e:e}"
        );
    }
}

#[test]
fn periodic_orbit_jacobian_with_the_delay_as_free_parameter_matches_central_differences() {
    // reference: central differences of the collocation residual (h = 1e-6) at a random
    // profile; the parameter column contains the moving delayed value; tolerance 1e-6
    let mut po = PeriodicOrbitSystem::new(
        &DelayedBautin::SINGLE,
        vec![-0.2, 1.0, 1.3],
        2,
        small_mesh(),
    )
    .unwrap();
    let u = perturbed_circle(&po, 1.3, 5);
    po.set_reference(&u);
    let e = jacobian_error(&mut po, &u);
    assert!(e < 1e-6, "Jacobian error {e:e}");
}

#[test]
fn cusp_of_cycles_is_detected_where_two_folds_meet() {
    // reference: r' = r(μ1 + μ2ρ + 3ρ² − ρ³), ρ = r²: folds of cycles on μ1 = 3ρ² − 2ρ³,
    // μ2 = 3ρ² − 6ρ; both turn at ρ = 1: a cusp of cycles at (μ1, μ2) = (1, −3). Located on
    // dμ1/ds = 0 (location tolerance 1e-10), μ1 − 1 and μ2 + 3 are O((ρ − 1)²): tolerance 1e-6.
    let p = Radial {
        c2: 3.0,
        c3: -1.0,
        eps: 0.0,
    };
    let mu2 = -2.25;
    let mu1 = 0.390625; // the cycle ρ = 0.25 at μ2 = −2.25
    let (po, fold) = fold_from_circle(&p, vec![mu1, mu2], 12, 0.5, 1.0);
    assert!(
        (fold.parameter - 0.5).abs() < 1e-8,
        "fold at μ1 = {}",
        fold.parameter
    );
    let opts = without_multipliers();
    let (mut sys, guess, dir) = FoldOfCyclesSystem::from_fold(&po, &fold, 1, opts).unwrap();
    let back: Vec<f64> = dir.iter().map(|d| -d).collect();
    let c = cont(0.05, 0.1);
    let mut curve = c.start(&mut sys, &guess, &back).unwrap();
    sys.extend_curve(&c, &mut curve, 30).unwrap();
    let (i, cusp) = curve
        .first(SpecialKind::CuspOfCycles)
        .expect("cusp of cycles");
    assert_eq!(cusp.location, Location::Located);
    let pt = &curve.points[i];
    assert!(
        (pt.parameter - 1.0).abs() < 1e-6,
        "cusp at μ1 = {}",
        pt.parameter
    );
    assert!(
        (pt.secondary_parameter.unwrap() + 3.0).abs() < 1e-6,
        "cusp at μ2 = {:?}",
        pt.secondary_parameter
    );
    assert!(curve.first(SpecialKind::Fold).is_none());
    for pt in &curve.points {
        let cyc = sys.periodic_system(&pt.u).unwrap();
        let rho = cyc.max_abs(sys.orbit(&pt.u), 0).powi(2);
        assert!((pt.parameter - (3.0 * rho * rho - 2.0 * rho.powi(3))).abs() < 1e-8);
        assert!((pt.secondary_parameter.unwrap() - (3.0 * rho * rho - 6.0 * rho)).abs() < 1e-8);
    }
}

/// fold curve of the non-symmetric radial form (ε = 0.3) on L intervals, from μ2 = 1 up
fn distorted_fold_curve(l: usize) -> (Vec<f64>, Vec<BranchPoint>) {
    let p = Radial {
        c2: -1.0,
        c3: 0.0,
        eps: 0.3,
    };
    let (po, fold) = fold_from_circle(&p, vec![0.0, 1.0], l, 1.0, -1.0);
    let opts = without_multipliers();
    let (mut sys, guess, dir) = FoldOfCyclesSystem::from_fold(&po, &fold, 1, opts).unwrap();
    let c = cont(0.05, 0.1);
    let mut curve = c.start(&mut sys, &guess, &dir).unwrap();
    sys.extend_curve(&c, &mut curve, 12).unwrap();
    // the curve at fixed μ1 values: μ2 there
    let targets = [-0.35, -0.4, -0.45];
    let mut out = Vec::new();
    for t in targets {
        let pts = points_at_parameter(&c, &mut sys, &curve, t).unwrap();
        assert_eq!(pts.len(), 1, "μ1 = {t}");
        out.push(pts[0].secondary_parameter.unwrap());
    }
    (out, curve.points)
}

#[test]
fn mesh_doubling_moves_the_fold_curve_little() {
    // reference: the fold curve on L = 32 (converged); a distorted (ε = 0.3) cycle so that the
    // collocation error is visible. Measured μ2 at μ1 = −0.35, −0.4, −0.45: L = 8 → 16 moves
    // it by 4.6e-8, 4.5e-8, 4.1e-8 and L = 16 → 32 by 1.1e-10, 7.3e-11, 2.2e-11 (ratio ~400:
    // order ≈ 2m = 8, superconvergence at the mesh points). Asserted: < 1e-7 and < 1e-9.
    let (a, _) = distorted_fold_curve(8);
    let (b, _) = distorted_fold_curve(16);
    let (c, _) = distorted_fold_curve(32);
    for i in 0..a.len() {
        let d_ab = (a[i] - b[i]).abs();
        let d_bc = (b[i] - c[i]).abs();
        assert!(d_ab < 1e-7, "L = 8 → 16 moves μ2 by {d_ab:e}");
        assert!(d_bc < 1e-9, "L = 16 → 32 moves μ2 by {d_bc:e}");
    }
}

#[test]
fn fold_curve_saved_and_continued_later_gives_the_same_points() {
    // reference: continuing a deserialised curve (new system, same inputs) must reproduce
    // continuing the original
    let p = Radial::BAUTIN;
    let (po, fold) = fold_from_circle(&p, vec![0.0, 1.0], 8, 1.0, -1.0);
    let opts = without_multipliers();
    let (mut sys, guess, dir) = FoldOfCyclesSystem::from_fold(&po, &fold, 1, opts.clone()).unwrap();
    let c = cont(0.05, 0.1);
    let mut curve = c.start(&mut sys, &guess, &dir).unwrap();
    sys.extend_curve(&c, &mut curve, 4).unwrap();
    let json = serde_json::to_string(&curve).unwrap();
    let mut restored: Branch = serde_json::from_str(&json).unwrap();
    // serde_json's float parsing may differ from the original in the last bit: compare the
    // continued curves to 1e-12
    let close = |a: &Branch, b: &Branch| {
        a.points.len() == b.points.len()
            && a.points.iter().zip(&b.points).all(|(p, q)| {
                p.special == q.special && p.u.iter().zip(&q.u).all(|(x, y)| (x - y).abs() < 1e-12)
            })
    };
    assert!(close(&restored, &curve));
    sys.extend_curve(&c, &mut curve, 5).unwrap();
    let mut fresh = FoldOfCyclesSystem::new(&p, vec![0.0, 1.0], (0, 1), colloc(8), opts).unwrap();
    fresh.extend_curve(&c, &mut restored, 5).unwrap();
    assert!(close(&restored, &curve));
    assert_eq!(restored.points.len(), 10);
    assert!(curve.points.iter().all(|p| p.secondary_parameter.is_some()));
}
