//! Torus (Neimark–Sacker) points and curves of cycles (ODE and DDE) and the start at a
//! double-Hopf point, against the closed forms of `textbook::TorusTestBed` and finite
//! differences.
mod common;
use common::{cont, curve_system, dense_jacobian, fd_jacobian_of, hopf_on_branch, single_codim2};
use continuation::*;
use continuation_textbook::TorusTestBed;
use std::f64::consts::PI;

const TAU: f64 = 2.5;

fn colloc(intervals: usize, degree: usize) -> CollocationOptions {
    CollocationOptions {
        intervals,
        degree,
        ..Default::default()
    }
}

/// θ reduced to [0, 2π)
fn reduced(theta: f64) -> f64 {
    theta.rem_euclid(2.0 * PI)
}

/// the delay of `bed` (unused by the ODE)
fn tau(bed: &TorusTestBed) -> f64 {
    if bed.delayed { TAU } else { 0.0 }
}

#[test]
fn torus_jacobian_equals_central_differences() {
    // reference: central differences of the residual (h = 1e-6 (1 + |u_i|)), error O(h²)
    // ≈ 1e-10 times third derivatives plus rounding ≈ 1e-16/h; required 1e-6 relative to
    // the largest entry. A generic point (not a solution; z2 ≠ 0, so every second
    // derivative term is non-zero), with the free parameter pairs (μ, τ) (the delay as p2:
    // delay_dp terms of the cycle's and the mode's rows), (τ, ν) (delay as p1) and the ODE.
    let cases = [
        (TorusTestBed::delayed(), (0, 2)),
        (TorusTestBed::delayed(), (2, 1)),
        (TorusTestBed::ode(), (0, 1)),
    ];
    for (bed, free) in cases {
        let options = TorusCurveOptions::default();
        let mut sys =
            TorusCurveSystem::new(&bed, vec![0.2, 0.3, TAU], free, colloc(4, 3), options).unwrap();
        let np = 4 * 12;
        let tp = 2.0 * PI;
        let mut u = Vec::new();
        for g in 0..12 {
            let s = g as f64 / 12.0;
            u.extend([
                0.4 * (tp * s).cos(),
                0.45 * (tp * s).sin(),
                0.2 * (tp * s + 1.0).cos(),
                0.1 * (2.0 * tp * s).sin(),
            ]);
        }
        u.extend([6.1, [0.2, 0.3, TAU][free.0], [0.2, 0.3, TAU][free.1]]);
        for i in 0..2 * np {
            u.push(0.3 + 0.2 * ((i as f64) * 0.618).sin());
        }
        u.push(2.3);
        let mut reference = u.clone();
        reference[np + 3] += 0.1;
        sys.accept(&reference);
        let exact = dense_jacobian(&mut sys, &u);
        let fd = fd_jacobian_of(&mut sys, &u);
        let scale = exact.amax();
        let err = (&exact - &fd).amax();
        assert!(
            err < 1e-6 * scale,
            "{free:?}: |J − J_fd| = {err:e}, max |J| = {scale}"
        );
    }
}

/// the double-Hopf point of `bed` from its Hopf curve μ = 0 continued in (ν, μ) from
/// ν = D − 0.3
fn double_hopf(bed: &TorusTestBed) -> (DoubleHopfPoint, Codim2Point) {
    let (_, d) = bed.second_hopf(tau(bed));
    let p = vec![-0.3, d - 0.3, tau(bed)];
    let hopf = hopf_on_branch(bed, p.clone(), 0, 20);
    let mut hc = curve_system(HopfCurveSystem::new, bed, p, [1, 0]);
    let (guess, dir) = hc.start_at_hopf(&hopf, 0).unwrap();
    let c = cont(0.05, 0.1);
    let mut curve = c.start(&mut hc, &guess, &dir).unwrap();
    c.extend(&mut hc, &mut curve, 30).unwrap();
    let c2 = single_codim2(hc.codim2_points(&curve), SpecialKind::DoubleHopf);
    let hh = DoubleHopfPoint::from_hopf_curve(bed, &hc, &curve, &c2).unwrap();
    (hh, c2)
}

#[test]
fn double_hopf_of_delay_coupled_oscillators() {
    // reference: closed form (TorusTestBed): Hopf curves μ = 0 (ω1 = 1) and ν = D (Ω),
    // Ω = ω2 − κ sin Ωτ, D = κ(1 − cos Ωτ); the double-Hopf point (μ, ν) = (0, D) is
    // located by regula falsi on the second pair's real part; required 1e-8 (the location
    // tolerance of the engine is 1e-10 in the parameter).
    for bed in [TorusTestBed::delayed(), TorusTestBed::ode()] {
        let (omega, d) = bed.second_hopf(tau(&bed));
        let (hh, c2) = double_hopf(&bed);
        assert!((c2.p1 - d).abs() < 1e-8, "ν = {} vs D = {d}", c2.p1);
        assert!(c2.p2.abs() < 1e-8, "μ = {}", c2.p2);
        assert!((hh.omegas[0] - 1.0).abs() < 1e-8, "{:?}", hh.omegas);
        assert!(
            (hh.omegas[1] - omega).abs() < 1e-8,
            "{:?} vs Ω = {omega}",
            hh.omegas
        );
        // eigenvectors: pair 1 lives in z1, pair 2 in z2
        let [v1, v2] = &hh.eigenvectors;
        assert!(v1[2].norm() + v1[3].norm() < 1e-8 && v2[0].norm() + v2[1].norm() < 1e-8);
    }
}

/// the cycle-1 branch of `bed` at ν = `nu`, from the closed-form cycle at μ = 0.1 upwards
/// in μ, on `l` intervals of degree 4, to the first torus point
fn cycle_one_to_torus<'a>(
    bed: &'a TorusTestBed,
    nu: f64,
    l: usize,
) -> (PeriodicOrbitSystem<'a, TorusTestBed>, Branch, usize) {
    let mu = 0.1;
    let mut po = PeriodicOrbitSystem::new(bed, vec![mu, nu, tau(bed)], 0, colloc(l, 4)).unwrap();
    let (r, tp) = (f64::sqrt(mu), 2.0 * PI);
    let period = tp / (bed.omega1 + bed.b * mu);
    let u0 = po.unknowns_from(
        |s| vec![r * (tp * s).cos(), r * (tp * s).sin(), 0.0, 0.0],
        period,
        mu,
    );
    po.set_reference(&u0);
    let mut dir = vec![0.0; u0.len()];
    dir[po.parameter_index()] = 1.0;
    let c = cont(0.05, 0.05);
    let mut br = c.start(&mut po, &u0, &dir).unwrap();
    for _ in 0..20 {
        c.extend(&mut po, &mut br, 1).unwrap();
        if br.first(SpecialKind::Torus).is_some() {
            break;
        }
    }
    let (i, sp) = br.first(SpecialKind::Torus).expect("a torus point");
    assert_eq!(sp.location, Location::Located);
    (po, br, i)
}

#[test]
fn torus_point_on_a_cycle_branch_and_torus_curve() {
    // reference: closed form (TorusTestBed::torus_curve_one): cycle 1 at ν has its
    // Neimark–Sacker point at μ* = (D − ν)/c with θ = ΩT mod 2π, T = 2π/(ω1 + bμ*); the
    // torus curve is ν = −cμ + D with θ(μ). Mesh L = 12, m = 4 (cycle error ≈ 1e-9, the
    // mode of form (T1) is e^{2πis}·const there); required 1e-6 on μ*, ν, θ and T (the
    // issue's requirement), 1e-9 on |e^{iθ}| − 1 of the computed Floquet multipliers'
    // critical pair and 1e-6 on their angle (DDE: the monodromy discretisation).
    for bed in [TorusTestBed::delayed(), TorusTestBed::ode()] {
        let (_, d) = bed.second_hopf(tau(&bed));
        let mu_star = 0.25;
        let nu = d - bed.c * mu_star;
        let (po, br, i) = cycle_one_to_torus(&bed, nu, 12);
        let c = cont(0.05, 0.05);
        let options = TorusCurveOptions::default();
        let (mut torus, mut curve) =
            TorusCurveSystem::start_at_torus(&c, &po, &br.points[i], 1, options).unwrap();
        let tp = torus.torus_point(&curve.points[0].u);
        let (nu_x, period_x, theta_x) = bed.torus_curve_one(mu_star, tau(&bed));
        assert!((nu_x - nu).abs() < 1e-12);
        assert!(
            (tp.parameters[0] - mu_star).abs() < 1e-6,
            "μ* = {}",
            tp.parameters[0]
        );
        assert!(
            (tp.period - period_x).abs() < 1e-6,
            "T = {} vs {period_x}",
            tp.period
        );
        let phi_x = theta_x.min(2.0 * PI - theta_x);
        assert!(
            (tp.multiplier_angle - phi_x).abs() < 1e-6,
            "φ = {} vs {phi_x}",
            tp.multiplier_angle
        );
        assert!((tp.rotation_number - phi_x / (2.0 * PI)).abs() < 1e-7);
        // the critical pair of the cycle's multipliers sits at e^{±iφ}
        let mu = torus.multipliers(&curve.points[0].u).unwrap();
        let z = mu
            .iter()
            .filter(|z| z.im > 1e-3)
            .min_by(|a, b| (a.norm() - 1.0).abs().total_cmp(&(b.norm() - 1.0).abs()))
            .unwrap();
        assert!((z.norm() - 1.0).abs() < 1e-6, "|μ| = {}", z.norm());
        assert!(
            (z.arg() - phi_x).abs() < 1e-6,
            "arg μ = {} vs {phi_x}",
            z.arg()
        );
        // the curve in both directions
        torus.extend_curve(&c, &mut curve, 4).unwrap();
        let mut back = c
            .start(
                &mut torus,
                &curve.points[0].u,
                &vec_neg(&curve.points[0].tangent),
            )
            .unwrap();
        torus.extend_curve(&c, &mut back, 3).unwrap();
        let mus: Vec<f64> = curve
            .points
            .iter()
            .chain(&back.points)
            .map(|p| p.parameter)
            .collect();
        assert!(
            mus.iter().any(|&m| m > 0.3) && mus.iter().any(|&m| m < 0.2),
            "{mus:?}"
        );
        for pt in curve.points.iter().chain(&back.points) {
            // the stored stability is without the critical pair: cycle 1 is otherwise
            // stable (radial multiplier e^{−2μT}), and no multiplier is left at e^{±iθ}
            let st = pt.stability.as_ref().unwrap();
            assert!(st.is_stable(), "{st:?}");
            let pair = num_complex::Complex64::from_polar(1.0, torus.theta(&pt.u));
            assert!(
                st.values
                    .iter()
                    .all(|z| (z - pair).norm() > 1e-3 && (z - pair.conj()).norm() > 1e-3)
            );
            let cp = torus.curve_point(&pt.u);
            let [mu, nu] = cp.parameters;
            let (nu_x, period_x, theta_x) = bed.torus_curve_one(mu, tau(&bed));
            assert!((nu - nu_x).abs() < 1e-6, "μ = {mu}: ν = {nu} vs {nu_x}");
            assert!((cp.period - period_x).abs() < 1e-6);
            assert!(
                (reduced(cp.theta) - theta_x).abs() < 1e-6,
                "θ = {} vs {theta_x}",
                cp.theta
            );
            assert!((cp.amplitude - mu.sqrt()).abs() < 1e-6);
        }
    }
}

fn vec_neg(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| -x).collect()
}

#[test]
fn torus_curves_start_at_the_double_hopf_point_and_end_there() {
    // reference: closed forms of TorusTestBed: torus curve T1 (of cycle 1) ν = −cμ + D,
    // θ = ΩT mod 2π; T2 (of cycle 2) μ = −e(ν − D), θ = 2πω1/Ω (unreduced in (T1), the
    // mode constant). Started from the double-Hopf point located on the Hopf curve
    // (itself 1e-8 accurate) with amplitude 0.1, mesh L = 12, m = 4: required 1e-6 on the
    // curves. Continued back towards the point, the curve stops at amplitude 0.02 and
    // extrapolates (linearly in amplitude², exact for these curves up to discretisation) to
    // the double-Hopf point: required 1e-6 on (μ, ν) and on both frequencies.
    for bed in [TorusTestBed::delayed(), TorusTestBed::ode()] {
        let (omega, d) = bed.second_hopf(tau(&bed));
        let (hh, _) = double_hopf(&bed);
        let c = cont(0.02, 0.05);
        let options = TorusCurveOptions {
            min_amplitude: 0.02,
            multipliers: false,
            ..Default::default()
        };
        for family in [0, 1] {
            let (mut torus, guess, dir) = TorusCurveSystem::from_double_hopf(
                &bed,
                &hh,
                [0, 1],
                family,
                0.1,
                colloc(12, 4),
                options.clone(),
            )
            .unwrap();
            let mut out = c.start(&mut torus, &guess, &dir).unwrap();
            torus.extend_curve(&c, &mut out, 3).unwrap();
            let on_curve = |cp: &TorusCurvePoint| {
                let [mu, nu] = cp.parameters;
                if family == 0 {
                    let (nu_x, _, theta_x) = bed.torus_curve_one(mu, tau(&bed));
                    assert!((nu - nu_x).abs() < 1e-6, "T1: μ = {mu}, ν = {nu} vs {nu_x}");
                    assert!((reduced(cp.theta) - theta_x).abs() < 1e-6);
                } else {
                    let mu_x = -bed.e * (nu - d);
                    assert!((mu - mu_x).abs() < 1e-6, "T2: ν = {nu}, μ = {mu} vs {mu_x}");
                    let theta_x = 2.0 * PI * bed.omega1 / omega;
                    assert!(
                        (cp.theta - theta_x).abs() < 1e-6,
                        "θ = {} vs {theta_x}",
                        cp.theta
                    );
                }
            };
            for pt in &out.points {
                on_curve(&torus.curve_point(&pt.u));
            }
            let grown = torus.amplitude(&out.points.last().unwrap().u);
            assert!(
                grown > 0.12,
                "family {family}: amplitude {grown} after 3 steps"
            );
            let mut back = c.start(&mut torus, &guess, &vec_neg(&dir)).unwrap();
            let stop = torus.extend_curve(&c, &mut back, 30).unwrap();
            let TorusCurveStop::DoubleHopfEnd(end) = stop else {
                panic!("family {family}: {stop:?}")
            };
            assert!((end.parameters[0]).abs() < 1e-6, "{end:?}");
            assert!((end.parameters[1] - d).abs() < 1e-6, "{end:?}");
            let (wi, wj) = if family == 0 {
                (1.0, omega)
            } else {
                (omega, 1.0)
            };
            assert!((end.omegas[0] - wi).abs() < 1e-6, "{end:?}");
            assert!((end.omegas[1] - wj).abs() < 1e-6, "{end:?}");
        }
    }
}

#[test]
fn torus_curve_passes_one_to_four_and_stops_at_one_to_one() {
    // reference: closed form of the ODE test bed's torus curve T1 (ν = −cμ, D = 0):
    // θ = 2π·1.3/(1 + 0.2μ) − 2π (the branch's θ0 ∈ (0, π)); the 1:4 resonance θ = π/2 at
    // μ = 0.2, the 1:1 resonance θ = 0 at μ = 1.5. Linear interpolation between points of
    // step ≤ 0.05 is exact to ≈ θ''Δμ²/8 ≈ 1e-4: required 1e-3 on μ.
    let bed = TorusTestBed::ode();
    let (po, br, i) = cycle_one_to_torus(&bed, -0.075, 10);
    let c = cont(0.05, 0.05);
    let options = TorusCurveOptions {
        multipliers: false,
        ..Default::default()
    };
    let (mut torus, mut curve) =
        TorusCurveSystem::start_at_torus(&c, &po, &br.points[i], 1, options).unwrap();
    if curve.points[0].tangent[po.parameter_index()] < 0.0 {
        let back = vec_neg(&curve.points[0].tangent);
        curve = c.start(&mut torus, &curve.points[0].u, &back).unwrap();
    }
    let stop = torus.extend_curve(&c, &mut curve, 200).unwrap();
    let TorusCurveStop::StrongResonance { index, order, .. } = stop else {
        panic!("{stop:?}")
    };
    assert_eq!(order, 1);
    assert_eq!(index, curve.points.len() - 1);
    let res = torus.resonances(&curve);
    let four: Vec<_> = res.iter().filter(|r| r.order == 4).collect();
    assert_eq!(four.len(), 1, "{res:?}");
    assert!((four[0].parameters[0] - 0.2).abs() < 1e-3, "{res:?}");
    assert!((four[0].parameters[1] + 0.1).abs() < 1e-3, "{res:?}");
    let one: Vec<_> = res.iter().filter(|r| r.order == 1).collect();
    assert_eq!(one.len(), 1, "{res:?}");
    assert!((one[0].parameters[0] - 1.5).abs() < 1e-3, "{res:?}");
    assert!(res.iter().all(|r| r.order != 2 && r.order != 3), "{res:?}");
}

#[test]
fn torus_curve_in_the_delay() {
    // reference: closed form of TorusTestBed's T1 with the delay τ as second parameter:
    // at fixed ν the Neimark–Sacker point of cycle 1 is μ = (D(τ) − ν)/c with θ = Ω(τ)T
    // mod 2π (Ω, D from the scalar fixed-point equation to 1e-15). Exercises the ∂τ/∂p
    // terms of the cycle's and the mode's rows along a curve. Mesh L = 12, m = 4 as in the
    // torus-point test: required 1e-6 on μ and θ.
    let bed = TorusTestBed::delayed();
    let (_, d) = bed.second_hopf(TAU);
    let nu = d - bed.c * 0.25;
    let (po, br, i) = cycle_one_to_torus(&bed, nu, 12);
    let c = cont(0.05, 0.05);
    let options = TorusCurveOptions {
        multipliers: false,
        ..Default::default()
    };
    let (mut torus, mut curve) =
        TorusCurveSystem::start_at_torus(&c, &po, &br.points[i], 2, options).unwrap();
    torus.extend_curve(&c, &mut curve, 5).unwrap();
    let taus: Vec<f64> = curve
        .points
        .iter()
        .map(|p| p.secondary_parameter.unwrap())
        .collect();
    assert!(taus.iter().any(|t| (t - TAU).abs() > 0.05), "{taus:?}");
    for pt in &curve.points {
        let cp = torus.curve_point(&pt.u);
        let [mu, tau] = cp.parameters;
        let (omega, d) = bed.second_hopf(tau);
        let mu_x = (d - nu) / bed.c;
        assert!((mu - mu_x).abs() < 1e-6, "τ = {tau}: μ = {mu} vs {mu_x}");
        let theta_x = (omega * cp.period).rem_euclid(2.0 * PI);
        assert!(
            (reduced(cp.theta) - theta_x).abs() < 1e-6,
            "θ = {} vs {theta_x}",
            cp.theta
        );
    }
}

#[test]
fn both_cycle_families_from_the_double_hopf_point() {
    // reference: closed forms of TorusTestBed at the double-Hopf point (μ, ν) = (0, D):
    // family 0 (free μ) are the cycles |z1|² = μ of period 2π/(ω1 + bμ), family 1 (free ν)
    // the cycles |z2|² = ν − D of period 2π/Ω. Mesh L = 12, m = 4: required 1e-6 on the
    // radius (max |x_k| over the period) and the period.
    let bed = TorusTestBed::delayed();
    let (omega, d) = bed.second_hopf(TAU);
    let (hh, _) = double_hopf(&bed);
    let c = cont(0.05, 0.05);
    for family in [0, 1] {
        let mut po =
            PeriodicOrbitSystem::new(&bed, hh.parameters.clone(), family, colloc(12, 4)).unwrap();
        let (guess, dir) = po.hopf_guess(&hh.hopf_point(family, family), 0.1);
        let mut br = c.start(&mut po, &guess, &dir).unwrap();
        c.extend(&mut po, &mut br, 4).unwrap();
        for pt in &br.points {
            let (r2, period, k) = if family == 0 {
                let mu = pt.parameter;
                (mu, 2.0 * PI / (bed.omega1 + bed.b * mu), 0)
            } else {
                (pt.parameter - d, 2.0 * PI / omega, 2)
            };
            assert!(r2 > 0.0, "family {family}: {r2}");
            assert!(
                (po.max_abs(&pt.u, k) - r2.sqrt()).abs() < 1e-6,
                "family {family}"
            );
            assert!((po.period(&pt.u) - period).abs() < 1e-6, "family {family}");
        }
    }
}
