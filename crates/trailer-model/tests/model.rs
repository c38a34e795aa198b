//! The Appellian equations (5)–(7) against independent references.

mod common;

use approx::assert_relative_eq;
use nalgebra::{Matrix4, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use trailer_model::{
    AxleLoads, CriticalSpeedOptions, Inputs, Model, State4, VehicleParams, sorted_eigenvalues,
};

fn table_i() -> Model {
    Model::new(VehicleParams::default()).expect("Table I is valid")
}

/// A random state and input inside the physical range (tires may slide).
fn random_point(rng: &mut ChaCha8Rng) -> (State4, Inputs, f64) {
    let x = State4::new(
        rng.random_range(-3.0..3.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-0.6..0.6),
    );
    let u = Inputs {
        steering_angle: rng.random_range(-0.15..0.15),
        speed: rng.random_range(5.0..50.0),
        acceleration: rng.random_range(-8.0..3.0),
    };
    (x, u, rng.random_range(-3.2..3.2))
}

/// `count` reproducible random (state, inputs, heading ψ) triples from `seed`
fn random_points(seed: u64, count: usize) -> impl Iterator<Item = (State4, Inputs, f64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count).map(move |_| random_point(&mut rng))
}

#[test]
fn static_axle_loads_match_statics() {
    // Reference: the statics of Fig. 2 worked by hand (F_z,F ≈ 11894.6 N, F_z,R ≈ 11304.3 N,
    // F_z,T ≈ 10008.0 N, to 0.1 N) and the
    // global balance F_F + F_R + F_T = (m1 + m2) g (exact up to round-off).
    let p = VehicleParams::default();
    let loads = AxleLoads::from_params(&p);
    assert!((loads.front - 11894.6).abs() < 0.05, "{}", loads.front);
    assert!((loads.rear - 11304.3).abs() < 0.05, "{}", loads.rear);
    assert!((loads.trailer - 10008.0).abs() < 0.05, "{}", loads.trailer);
    assert!(loads.hitch < 0.0, "h > l: the trailer lifts the hitch");
    let total = (p.tractor.mass + p.trailer.mass) * p.gravity;
    assert_relative_eq!(
        loads.front + loads.rear + loads.trailer,
        total,
        max_relative = 1e-14
    );
    // moment balance of the tractor about the hitch
    let t = &p.tractor;
    let moment = loads.front * t.front_axle + loads.rear * t.rear_axle - t.mass * p.gravity * t.cog;
    assert!(moment.abs() < 1e-9 * total * t.front_axle);
}

#[test]
fn equations_of_motion_match_newton_euler() {
    // Reference: tests/common/mod.rs, Newton–Euler with the constraint forces solved for,
    // in the inertial frame at a random heading ψ. 2000 random states, speeds, V̇ and δ.
    // Tolerance 1e-10 relative to the size of each component's terms: both formulations
    // are exact, the difference is round-off of sums of terms up to ~1e25 (eq. 7).
    let model = table_i();
    let mut worst: f64 = 0.0;
    for (x, u, psi) in random_points(2024, 2000) {
        let a = model.rhs4(&x, &u);
        let b = common::newton_euler(&model, &x, &u, psi);
        // scale: accelerations of this state are O(1..100); use the largest of the
        // component and 1 (m/s², 1/s²) to avoid dividing by accidental near-zeros
        for i in 0..4 {
            let rel = (a[i] - b[i]).abs() / a[i].abs().max(b[i].abs()).max(1.0);
            worst = worst.max(rel);
        }
    }
    assert!(worst < 1e-10, "worst relative difference {worst:e}");
}

#[test]
fn trailer_force_matches_newton_euler() {
    // Reference: the Newton–Euler oracle with a lateral force on the trailer at C2
    // (tests/common/mod.rs, `newton_euler_with_loads`) against the Appellian right-hand side
    // plus `trailer_force_response`. 2000 random states with |F| ≤ 5 kN (a strong gust on a
    // caravan's side) and a yaw moment beside it; tolerance 1e-10 relative, as above.
    let model = table_i();
    let mut rng = ChaCha8Rng::seed_from_u64(78);
    let mut worst: f64 = 0.0;
    for (x, u, psi) in random_points(2026, 2000) {
        let m = rng.random_range(-8000.0..8000.0);
        let force = rng.random_range(-5000.0..5000.0);
        let a = model.rhs4_with_yaw_moment(&x, &u, m) + model.trailer_force_response(x[3], force);
        let b = common::newton_euler_with_loads(&model, &x, &u, psi, m, force);
        for i in 0..4 {
            let rel = (a[i] - b[i]).abs() / a[i].abs().max(b[i].abs()).max(1.0);
            worst = worst.max(rel);
        }
    }
    assert!(worst < 1e-10, "worst relative difference {worst:e}");
}

#[test]
fn yaw_moment_matches_newton_euler() {
    // Reference: the Newton–Euler oracle with the moment as a free torque on the tractor
    // (tests/common/mod.rs), against the Appellian form, where it enters as a couple of
    // axle forces. 2000 random states with |M_z| ≤ 8 kN m (what braking one side of a
    // 2 t car can give); tolerance 1e-10 relative, as for the equations without it.
    let model = table_i();
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let mut worst: f64 = 0.0;
    for (x, u, psi) in random_points(2025, 2000) {
        let m = rng.random_range(-8000.0..8000.0);
        let a = model.rhs4_with_yaw_moment(&x, &u, m);
        let b = common::newton_euler_with_yaw_moment(&model, &x, &u, psi, m);
        for i in 0..4 {
            let rel = (a[i] - b[i]).abs() / a[i].abs().max(b[i].abs()).max(1.0);
            worst = worst.max(rel);
        }
    }
    assert!(worst < 1e-10, "worst relative difference {worst:e}");
    // the linearisation's yaw-moment column: σ̇2 = … + M_z/I1 exactly (eq. 6), θ̇ unaffected
    let lin = model.linearize(30.0);
    assert_relative_eq!(lin.b_yaw_moment[1], 1.0 / model.i1(), max_relative = 1e-14);
    assert_eq!(lin.b_yaw_moment[3], 0.0);
    // and it equals the difference quotient of the exact right-hand side (linear in M_z)
    let x0 = State4::zeros();
    let u0 = Inputs::constant_speed(30.0);
    let dm = 1000.0;
    let fd = (model.rhs4_with_yaw_moment(&x0, &u0, dm) - model.rhs4(&x0, &u0)) / dm;
    for i in 0..4 {
        assert!(
            (fd[i] - lin.b4_yaw_moment[i]).abs() <= 1e-12 * fd.norm(),
            "{i}"
        );
    }
}

#[test]
fn printed_sigma3_prefactor_is_dimensionally_inconsistent() {
    // Reference: dimensional analysis. Rescale length by L, mass by M, time by T:
    // σ1, V → L/T; σ2, σ3 → 1/T; θ, δ unchanged; V̇ → L/T²; masses M; inertias M L²;
    // stiffnesses (N/rad) M L/T²; g → L/T². Then σ̇1 → L/T², σ̇2, σ̇3 → 1/T², θ̇ → 1/T.
    let (lsc, msc, tsc) = (1.7_f64, 2.3_f64, 0.6_f64);
    let p = VehicleParams::default();
    let mut q = p;
    q.tractor.mass *= msc;
    q.trailer.mass *= msc;
    q.tractor.yaw_inertia *= msc * lsc * lsc;
    q.trailer.yaw_inertia *= msc * lsc * lsc;
    for len in [
        &mut q.tractor.front_axle,
        &mut q.tractor.cog,
        &mut q.tractor.rear_axle,
        &mut q.trailer.cog,
        &mut q.trailer.axle,
    ] {
        *len *= lsc;
    }
    let force = msc * lsc / (tsc * tsc);
    q.tractor.front_cornering_stiffness *= force;
    q.tractor.rear_cornering_stiffness *= force;
    q.trailer.cornering_stiffness *= force;
    q.gravity *= lsc / (tsc * tsc);
    let (m, ms) = (Model::new(p).expect("valid"), Model::new(q).expect("valid"));
    for (x, u, _) in random_points(11, 200) {
        let xs = State4::new(x[0] * lsc / tsc, x[1] / tsc, x[2] / tsc, x[3]);
        let us = Inputs {
            steering_angle: u.steering_angle,
            speed: u.speed * lsc / tsc,
            acceleration: u.acceleration * lsc / (tsc * tsc),
        };
        let (r, rs) = (m.rhs4(&x, &u), ms.rhs4(&xs, &us));
        let expect = [
            lsc / (tsc * tsc),
            1.0 / (tsc * tsc),
            1.0 / (tsc * tsc),
            1.0 / tsc,
        ];
        for i in 0..4 {
            assert_relative_eq!(
                rs[i],
                r[i] * expect[i],
                max_relative = 1e-9,
                epsilon = 1e-12
            );
        }
        // the printed prefactor 1/(I1 I2²) equals ours times I2, which scales as M L²:
        // it would break the scaling law by the factor M L² = 6.6
        let misprint = r[2] * m.i2();
        let misprint_scaled = rs[2] * ms.i2();
        if r[2].abs() > 1e-6 {
            let ratio = misprint_scaled / (misprint * expect[2]);
            assert_relative_eq!(ratio, msc * lsc * lsc, max_relative = 1e-9);
        }
    }
}

#[test]
fn full_system_kinematics() {
    // Reference: eq. (5), ẋ_H = V cos ψ − σ1 sin ψ, ẏ_H = V sin ψ + σ1 cos ψ and
    // ψ̇ = σ2 − m1 d σ1 / I1; the reduced part equals rhs4.
    let model = table_i();
    for (x4, u, psi) in random_points(5, 100) {
        let x7 =
            SVector::<f64, 7>::from_column_slice(&[x4[0], x4[1], x4[2], x4[3], psi, 3.0, -2.0]);
        let r7 = model.rhs7(&x7, &u);
        let r4 = model.rhs4(&x4, &u);
        for i in 0..4 {
            assert_eq!(r7[i], r4[i]);
        }
        assert_relative_eq!(r7[4], model.yaw_rate(&x4), max_relative = 1e-15);
        assert_relative_eq!(
            r7[5],
            u.speed * psi.cos() - x4[0] * psi.sin(),
            max_relative = 1e-14
        );
        assert_relative_eq!(
            r7[6],
            u.speed * psi.sin() + x4[0] * psi.cos(),
            max_relative = 1e-14
        );
    }
}

#[test]
fn jacobian_matches_central_differences() {
    // Reference: central finite differences with step 1e-6 (relative truncation error
    // ~1e-12·f''' plus round-off ~1e-10/1e-6): agreement to 1e-6 relative to the
    // Jacobian's column norm. Random states generically avoid the tire kinks.
    let model = table_i();
    for (x, u, _) in random_points(99, 200) {
        let (j, jd) = model.jacobian4(&x, &u);
        let step = 1e-6;
        for k in 0..5 {
            let (mut xp, mut xm, mut up, mut um) = (x, x, u, u);
            if k < 4 {
                xp[k] += step;
                xm[k] -= step;
            } else {
                up.steering_angle += step;
                um.steering_angle -= step;
            }
            let fd = (model.rhs4(&xp, &up) - model.rhs4(&xm, &um)) / (2.0 * step);
            let ad = if k < 4 { j.column(k).into_owned() } else { jd };
            let scale = ad.norm().max(1.0);
            assert!(
                (fd - ad).norm() <= 1e-6 * scale,
                "column {k}: fd {fd:?} ad {ad:?} at {x:?} {u:?}"
            );
        }
    }
}

#[test]
fn linearization_has_the_zero_pattern_of_eq_11() {
    // Reference: eq. (11). '#' marks entries that must be nonzero, '0' exact zeros.
    let pattern = [
        "####000", "##00000", "####000", "###0000", "##00000", "0000000", "#000#00",
    ];
    let model = table_i();
    for v in [10.0, 33.0, 50.0] {
        let lin = model.linearize(v);
        for (i, row) in pattern.iter().enumerate() {
            for (k, ch) in row.chars().enumerate() {
                let a = lin.a[(i, k)];
                if ch == '0' {
                    assert_eq!(a, 0.0, "A[{i}][{k}] at V = {v}");
                } else {
                    assert_ne!(a, 0.0, "A[{i}][{k}] at V = {v}");
                }
            }
        }
        assert!(lin.b[0] != 0.0 && lin.b[1] != 0.0);
        assert!(lin.b.rows(2, 5).iter().all(|&b| b == 0.0));
        assert_relative_eq!(lin.a[(6, 4)], v, max_relative = 1e-15); // A75 = V
        assert_eq!(lin.c[1], 1.0);
        // C x = ψ̇ (eq. 10)
        let x = State4::new(0.3, -0.2, 0.1, 0.05);
        assert_relative_eq!((lin.c4 * x)[0], model.yaw_rate(&x), max_relative = 1e-14);
        // Ã and B̃ are the reduced Jacobian at straight running
        let (j, jd) = model.jacobian4(&State4::zeros(), &Inputs::constant_speed(v));
        assert_relative_eq!(lin.a4, j, max_relative = 1e-14);
        assert_relative_eq!(lin.b4, jd, max_relative = 1e-14);
    }
}

#[test]
fn critical_speed_agrees_with_the_independent_formulation() {
    // Reference: Ã from central differences of the Newton–Euler oracle (step 1e-7; the
    // brush tire's C¹ kink at α = 0 biases this by O(step), ~1e-7 relative) and its
    // V_crit by the same bisection: agreement within 1e-4 m/s.
    let model = table_i();
    let vc = model
        .critical_speed(&CriticalSpeedOptions::default())
        .expect("V_crit exists");
    let oracle_abscissa = |v: f64| {
        let u = Inputs::constant_speed(v);
        let h = 1e-7;
        let mut a = Matrix4::zeros();
        for k in 0..4 {
            let mut xp = State4::zeros();
            let mut xm = State4::zeros();
            xp[k] = h;
            xm[k] = -h;
            let col = (common::newton_euler(&model, &xp, &u, 0.4)
                - common::newton_euler(&model, &xm, &u, 0.4))
                / (2.0 * h);
            a.set_column(k, &col);
        }
        sorted_eigenvalues(&a)[0].re
    };
    let (mut lo, mut hi) = (vc.v_crit_mps - 0.5, vc.v_crit_mps + 0.5);
    assert!(oracle_abscissa(lo) < 0.0 && oracle_abscissa(hi) > 0.0);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if oracle_abscissa(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    assert!(
        (0.5 * (lo + hi) - vc.v_crit_mps).abs() < 1e-4,
        "{lo} vs {}",
        vc.v_crit_mps
    );
    // the bisection tolerance is 1e-11 m/s; the abscissa changes sign there
    assert!(model.spectral_abscissa(vc.v_crit_mps - 1e-9) < 0.0);
    assert!(model.spectral_abscissa(vc.v_crit_mps + 1e-9) > 0.0);
    // a complex pair crosses (Hopf), not a real root
    assert!(vc.hopf_frequency_hz > 0.1);
    assert!(vc.crossing_speed > 0.0);
}

#[test]
fn bad_parameters_are_rejected_with_their_key() {
    let mut p = VehicleParams::default();
    p.tractor.rear_axle = 6.0;
    let e = Model::new(p).expect_err("c ≥ f");
    assert!(e.to_string().contains("tractor.rear_axle"), "{e}");
    let mut p = VehicleParams::default();
    p.trailer.mass = -1.0;
    let e = Model::new(p).expect_err("negative mass");
    assert!(e.to_string().contains("trailer.mass"), "{e}");
    let mut p = VehicleParams::default();
    p.friction.mu_dynamic = 1.0;
    assert!(Model::new(p).is_err());
}

#[test]
fn front_force_from_the_tangent_of_a_difference_equals_the_angle_form() {
    // Reference: the brush force at the slip angle itself, F(α_F) with α_F = δ − atan r_F
    // (`slip_angles`), against `tire_forces`, which evaluates tan α_F as
    // (tan δ − r_F)/(1 + r_F tan δ). Exact identity; tolerance 1e-12 relative to the
    // sliding force: a few ulps of tan α_F times the polynomial's slope. 5000 random points
    // (tires adhering and sliding), plus δ = 0 and slip angles beyond ±π/2 (angle form).
    use tires::TireModel;
    let model = table_i();
    let front = model.tires()[0];
    let scale = front.sliding_force();
    let mut worst: f64 = 0.0;
    let mut compare = |x: &State4, u: &Inputs| {
        let a = model.slip_angles(x, u).front;
        // points within 1e-9 rad of the sliding limit may take either branch
        if (a.abs() - front.critical_slip_angle().unwrap_or(f64::INFINITY)).abs() < 1e-9 {
            return;
        }
        let want = front.lateral_force(a);
        let have = model.tire_forces(x, u).front;
        worst = worst.max((want - have).abs() / scale);
    };
    for (x, mut u, _) in random_points(7, 5000) {
        compare(&x, &u);
        u.steering_angle = 0.0;
        compare(&x, &u);
    }
    // σ1 + f ψ̇ against the speed so large that |α_F| > π/2 − δ
    let x = State4::new(-40.0, 0.0, 0.0, 0.0);
    let u = Inputs {
        steering_angle: 1.2,
        speed: 1.0,
        acceleration: 0.0,
    };
    compare(&x, &u);
    assert!(
        worst < 1e-12,
        "worst difference {worst:e} of the sliding force"
    );
}

#[test]
fn axle_slip_tangents_are_the_tangents_of_the_slip_angles() {
    // Reference: tan |α| of `slip_angles` (the angle form, with atan). Exact identity up to
    // round-off: tolerance 1e-12 relative (a few ulps of the ratio, amplified by the tangent
    // of a difference at most 1/(1 + r tan δ), bounded here by keeping |α_F| < 1.4 rad).
    // 5000 random points with their δ and again with δ = 0; |α_F| ≥ π/2 gives +∞.
    let model = table_i();
    let mut checked = 0;
    for (x, mut u, _) in random_points(11, 5000) {
        for delta in [u.steering_angle, 0.0] {
            u.steering_angle = delta;
            let a = model.slip_angles(&x, &u);
            let (front, rear) = model.axle_slip_tangents(&x, &u);
            let close = |want: f64, have: f64| (want - have).abs() <= 1e-12 * want.max(1.0);
            assert!(
                close(a.rear.abs().tan(), rear),
                "{} vs {rear}",
                a.rear.abs().tan()
            );
            if a.front.abs() < 1.4 {
                assert!(close(a.front.abs().tan(), front), "{a:?}: {front}");
                checked += 1;
            } else if a.front.abs() >= std::f64::consts::FRAC_PI_2 {
                assert_eq!(front, f64::INFINITY);
            }
        }
    }
    assert!(checked > 9000, "{checked}");
    let (tf, tr) = model.critical_slip_tangents();
    let acr = model.critical_slip_angles();
    assert!((tf - acr.front.tan()).abs() < 1e-15 && (tr - acr.rear.tan()).abs() < 1e-15);
}

#[test]
fn slip_angle_tangents_are_the_tangents_of_the_slip_angles() {
    // reference: tan of the slip angles of eq. (2) (atan form); 1e-12 relative over 1000
    // random points (δ ≠ 0) and again at δ = 0 (the trigonometry-free path)
    let model = table_i();
    for (x, u, _) in random_points(17, 1000) {
        for steering_angle in [u.steering_angle, 0.0] {
            let u = Inputs {
                steering_angle,
                ..u
            };
            let a = model.slip_angles(&x, &u);
            let t = model.slip_angle_tangents(&x, &u);
            for (angle, tan) in [(a.front, t.front), (a.rear, t.rear), (a.trailer, t.trailer)] {
                assert_relative_eq!(angle.tan(), tan, max_relative = 1e-12, epsilon = 1e-14);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Issue 21: the model variants (VehicleModel) against the Newton–Euler oracle and limits
// ---------------------------------------------------------------------------------------

mod variants {
    use super::*;
    use tires::{TireLawSpec, TireModel};
    use trailer_model::{
        AnyVehicleModel, AxleSpec, HitchSpec, ModelError, Plant, VehicleModel, VehicleSpec,
        with_plant,
    };

    fn vcrit<const N: usize>(m: &VehicleModel<N>) -> f64 {
        m.critical_speed(&CriticalSpeedOptions::default())
            .expect("V_crit exists")
            .v_crit_mps
    }

    fn magic(peak_friction: f64) -> TireLawSpec {
        TireLawSpec::MagicFormula {
            shape_factor: 1.536,
            curvature_factor: 0.3,
            peak_friction: Some(peak_friction),
            peak_force: None,
            stiffness_factor: None,
        }
    }

    fn axle(position_m: f64, c: f64, steered: bool, sigma: f64, tire: TireLawSpec) -> AxleSpec {
        AxleSpec {
            position_m,
            cornering_stiffness: c,
            steered,
            tire,
            relaxation_length_m: sigma,
        }
    }

    /// Table I with the trailer axle as a list
    fn with_trailer_axles(axles: Vec<AxleSpec>) -> VehicleSpec {
        let mut s = VehicleSpec::from(VehicleParams::default());
        s.trailer.as_mut().unwrap().axle = None;
        s.trailer.as_mut().unwrap().cornering_stiffness = None;
        s.trailer.as_mut().unwrap().axles = Some(axles);
        s
    }

    /// random state: the reduced state of `random_point` plus lagged slips |α′| < 0.25 rad
    fn random_states<const N: usize>(
        seed: u64,
        count: usize,
    ) -> impl Iterator<Item = (SVector<f64, N>, Inputs, f64, f64)> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..count).map(move |_| {
            let (x4, u, psi) = random_point(&mut rng);
            let mut x = SVector::<f64, N>::zeros();
            for i in 0..4 {
                x[i] = x4[i];
            }
            for i in 4..N {
                x[i] = rng.random_range(-0.25..0.25);
            }
            (x, u, psi, rng.random_range(-8000.0..8000.0))
        })
    }

    /// worst relative difference of the model and the oracle over 2000 random states
    /// (with and without a yaw moment), scaled as in `equations_of_motion_match_newton_euler`
    fn oracle_error<const N: usize>(model: &VehicleModel<N>, seed: u64) -> f64 {
        let mut worst: f64 = 0.0;
        for (x, u, psi, moment) in random_states::<N>(seed, 2000) {
            for m in [0.0, moment] {
                let a = if m == 0.0 {
                    model.rhs(&x, &u)
                } else {
                    model.rhs_with_yaw_moment(&x, &u, m)
                };
                let b = common::newton_euler_general(model, &x, &u, psi, m);
                for i in 0..N {
                    let rel = (a[i] - b[i]).abs() / a[i].abs().max(b[i].abs()).max(1.0);
                    worst = worst.max(rel);
                }
            }
        }
        worst
    }

    #[test]
    fn variants_match_newton_euler() {
        // Reference: tests/common (Newton–Euler with the constraint forces solved for, in
        // the inertial frame at a random heading; axles, tyre laws, slip lag and hitch torque
        // written from the mechanics). 2000 random states per variant, each with and without
        // a yaw moment |M_z| ≤ 8 kN m. Tolerance 1e-10 relative, as for the paper's model
        // (round-off of sums of terms up to ~1e25 in eq. 7).
        let tol = 1e-10;
        // 1. relaxation 0.3 m on the three axles of Table I (N = 7)
        let relaxed = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap();
        let e1 = oracle_error(&relaxed, 1);
        // 2. Magic Formula front, linear rear, brush trailer with its own friction (N = 4)
        let mut s = VehicleSpec::from(VehicleParams::default());
        s.tractor.front_tire = Some(magic(0.9));
        s.tractor.rear_tire = Some(TireLawSpec::Linear {});
        s.trailer.as_mut().unwrap().tire = Some(TireLawSpec::Brush {
            mu_static: Some(1.0),
            mu_dynamic: Some(0.7),
        });
        let laws = VehicleModel::<4>::new(&s).unwrap();
        let e2 = oracle_error(&laws, 2);
        // 3. tandem trailer axles ±0.4 m about l, half the stiffness each, the rear one
        //    relaxing (N = 5)
        let tandem = with_trailer_axles(vec![
            axle(2.4, 25e3, false, 0.0, TireLawSpec::default()),
            axle(3.2, 25e3, false, 0.4, TireLawSpec::default()),
        ]);
        let tandem = VehicleModel::<5>::new(&tandem).unwrap();
        let e3 = oracle_error(&tandem, 3);
        // 4. hitch damping: viscous and Coulomb (N = 4); random θ̇ fall on both sides of ω_c
        let mut s = VehicleSpec::from(VehicleParams::default());
        s.hitch = HitchSpec {
            yaw_damping_nms: 800.0,
            friction_torque_nm: 600.0,
            friction_regularisation_rad_s: 0.05,
        };
        let hitch = VehicleModel::<4>::new(&s).unwrap();
        let e4 = oracle_error(&hitch, 4);
        // 5. everything at once: a tractor axle list (steered front, two rear axles, one
        //    relaxing, Magic Formula), trailer tridem with two relaxing axles, hitch friction
        let mut s = with_trailer_axles(vec![
            axle(2.2, 20e3, false, 0.5, magic(1.0)),
            axle(2.9, 15e3, false, 0.0, TireLawSpec::Linear {}),
            axle(3.6, 15e3, false, 0.3, TireLawSpec::default()),
        ]);
        s.tractor.front_axle = None;
        s.tractor.rear_axle = None;
        s.tractor.front_cornering_stiffness = None;
        s.tractor.rear_cornering_stiffness = None;
        s.tractor.axles = Some(vec![
            axle(5.15, 137e3, true, 0.3, magic(0.9)),
            axle(1.7, 128e3, false, 0.0, TireLawSpec::default()),
            axle(1.0, 128e3, false, 0.45, TireLawSpec::default()),
        ]);
        s.hitch.friction_torque_nm = 300.0;
        let all = VehicleModel::<8>::new(&s).unwrap();
        let e5 = oracle_error(&all, 5);
        println!("oracle: relaxation {e1:e}, laws {e2:e}, tandem {e3:e}, hitch {e4:e}, all {e5:e}");
        for (name, e) in [
            ("relaxation", e1),
            ("tyre laws", e2),
            ("tandem", e3),
            ("hitch", e4),
            ("all", e5),
        ] {
            assert!(e < tol, "{name}: worst relative difference {e:e}");
        }
    }

    #[test]
    fn without_the_variants_the_model_is_the_papers_bit_for_bit() {
        // Reference: Model::rhs4 (today's model). VehicleModel<4> of Table I's file (and of
        // the file with σ = 0 given on every axle) must give identical bits: 2000 random
        // states with δ ≠ 0 and again with δ = 0, and their exact Jacobians.
        let paper = table_i();
        let mut spec = VehicleSpec::table_i_with_relaxation(0.0);
        assert_eq!(spec.relaxed_axles().unwrap(), 0);
        for variant in 0..2 {
            if variant == 1 {
                spec = VehicleSpec::from(VehicleParams::default());
            }
            let m = VehicleModel::<4>::new(&spec).unwrap();
            assert_eq!(Plant::params(&m), paper.params());
            for (x, mut u, _) in random_points(31, 2000) {
                for delta in [u.steering_angle, 0.0] {
                    u.steering_angle = delta;
                    let (a, b) = (paper.rhs4(&x, &u), m.rhs(&x, &u));
                    for i in 0..4 {
                        assert_eq!(a[i].to_bits(), b[i].to_bits(), "{i} at {x:?} {u:?}");
                    }
                    let (ja, da) = paper.jacobian4(&x, &u);
                    let (jb, db) = Plant::jacobian(&m, &x, &u);
                    assert_eq!(ja, jb);
                    assert_eq!(da, db);
                }
            }
            // the linearisation and V_crit (the spectrum by a general eigen-solver here: equal
            // to round-off, 1e-9 m/s after bisection to 1e-11 m/s)
            let (la, lb) = (paper.linearize(33.0), m.plant_linearization(33.0));
            assert_eq!(la.a4, lb.a);
            assert_eq!(la.b4, lb.b);
            assert_eq!(la.c4, lb.c);
            assert_relative_eq!(la.b4_yaw_moment, lb.b_yaw_moment, max_relative = 1e-13);
            let v = paper
                .critical_speed(&CriticalSpeedOptions::default())
                .unwrap()
                .v_crit_mps;
            assert!((vcrit(&m) - v).abs() < 1e-9, "{} vs {v}", vcrit(&m));
        }
        // the paper's model as a Plant: the trait methods are the inherent ones
        let lin = Plant::plant_linearization(&paper, 33.0);
        assert_eq!(lin.a, paper.linearize(33.0).a4);
        let vc = Plant::critical_speed(&paper, &CriticalSpeedOptions::default()).unwrap();
        assert_eq!(
            vc,
            paper
                .critical_speed(&CriticalSpeedOptions::default())
                .unwrap()
        );
        // the full state: [reduced, ψ, x_H, y_H] is rhs7
        for (x4, u, psi) in random_points(32, 100) {
            let x7 = State7Like::from_column_slice(&[x4[0], x4[1], x4[2], x4[3], psi, 3.0, -2.0]);
            assert_eq!(Plant::rhs_full(&paper, &x7, &u), paper.rhs7(&x7, &u));
        }
    }

    type State7Like = SVector<f64, 7>;

    #[test]
    fn relaxation_lowers_the_critical_speed_as_the_independent_analysis_says() {
        // References: (a) the independent linear analysis, V_crit ≈ 32.6 m/s at
        // σ = 0.3 m and ≈ 30.3 m/s at σ = 0.6 m on all three axles (quoted to 0.1 m/s:
        // tolerance 0.05 m/s); (b) the Newton–Euler oracle linearised by central differences
        // (step 1e-7 on all 7 states; the brush tyre's C¹ kink at α′ = 0 biases it by O(step)):
        // its V_crit by bisection agrees within 1e-4 m/s.
        for (sigma, quoted) in [(0.3, 32.6), (0.6, 30.3)] {
            let m = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(sigma)).unwrap();
            let vc = m.critical_speed(&CriticalSpeedOptions::default()).unwrap();
            println!(
                "σ = {sigma} m: V_crit = {:.4} m/s, {:.4} Hz",
                vc.v_crit_mps, vc.hopf_frequency_hz
            );
            assert!((vc.v_crit_mps - quoted).abs() < 0.05, "{}", vc.v_crit_mps);
            let oracle_abscissa = |v: f64| {
                let u = Inputs::constant_speed(v);
                let h = 1e-7;
                let mut a = nalgebra::SMatrix::<f64, 7, 7>::zeros();
                for k in 0..7 {
                    let (mut xp, mut xm) = (SVector::<f64, 7>::zeros(), SVector::<f64, 7>::zeros());
                    xp[k] = h;
                    xm[k] = -h;
                    let col = (common::newton_euler_general(&m, &xp, &u, 0.4, 0.0)
                        - common::newton_euler_general(&m, &xm, &u, 0.4, 0.0))
                        / (2.0 * h);
                    a.set_column(k, &col);
                }
                trailer_model::sorted_spectrum(&a)[0].re
            };
            let (mut lo, mut hi) = (vc.v_crit_mps - 0.5, vc.v_crit_mps + 0.5);
            assert!(oracle_abscissa(lo) < 0.0 && oracle_abscissa(hi) > 0.0);
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if oracle_abscissa(mid) < 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            assert!((0.5 * (lo + hi) - vc.v_crit_mps).abs() < 1e-4, "{lo}");
        }
    }

    #[test]
    fn small_relaxation_lengths_converge_to_the_instantaneous_model() {
        // Reference: the instantaneous model (σ = 0). (a) V_crit(σ) − V_crit(0) is O(σ) (the
        // lag σ/V enters the characteristic polynomial linearly): for σ = 1e-2, 1e-3, 1e-4 m
        // the difference falls tenfold each time (ratio within 10 ± 0.5) and is below
        // 1e-3 m/s at 1e-4 m. (b) On the slow manifold α′ = α the mechanical part of the
        // right-hand side is the instantaneous one (the force F(α′) from the angle equals
        // F(α) from its tangent): 1e-12 relative over 500 random states.
        let v0 =
            vcrit(&VehicleModel::<4>::new(&VehicleSpec::table_i_with_relaxation(0.0)).unwrap());
        let diffs: Vec<f64> = [1e-2, 1e-3, 1e-4]
            .iter()
            .map(|&s| {
                vcrit(&VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(s)).unwrap())
                    - v0
            })
            .collect();
        println!("V_crit(σ) − V_crit(0) at σ = 1e-2, 1e-3, 1e-4 m: {diffs:?}");
        assert!(diffs.iter().all(|d| *d < 0.0));
        for w in diffs.windows(2) {
            assert!((w[0] / w[1] - 10.0).abs() < 0.5, "{diffs:?}");
        }
        assert!(diffs[2].abs() < 1e-3);
        let m0 = table_i();
        let m = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap();
        let mut alpha = [0.0; 8];
        for (x4, u, _) in random_points(41, 500) {
            let mut x = SVector::<f64, 7>::zeros();
            x.fixed_rows_mut::<4>(0).copy_from(&x4);
            m.slip_angles(&x, &u, &mut alpha);
            for k in 0..3 {
                x[4 + k] = alpha[k];
            }
            let (a, b) = (m0.rhs4(&x4, &u), m.rhs(&x, &u));
            for i in 0..4 {
                assert!(
                    (a[i] - b[i]).abs() <= 1e-12 * a[i].abs().max(1.0),
                    "{i}: {} vs {}",
                    a[i],
                    b[i]
                );
            }
            for k in 4..7 {
                assert!(b[k].abs() < 1e-12, "α̇′ = {} on the slow manifold", b[k]);
            }
        }
    }

    /// classical RK4 with fixed step `dt` over `steps` steps
    fn rk4<const N: usize>(
        f: impl Fn(&SVector<f64, N>) -> SVector<f64, N>,
        mut x: SVector<f64, N>,
        dt: f64,
        steps: usize,
    ) -> SVector<f64, N> {
        for _ in 0..steps {
            let k1 = f(&x);
            let k2 = f(&(x + k1 * (0.5 * dt)));
            let k3 = f(&(x + k2 * (0.5 * dt)));
            let k4 = f(&(x + k3 * dt));
            x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
        }
        x
    }

    #[test]
    fn trajectories_converge_to_the_instantaneous_model_as_sigma_vanishes() {
        // Reference: the instantaneous model (σ = 0) integrated with the same fixed-step RK4
        // (dt = 2e-5 s, 0.5 s from θ0 = 0.05 rad at 33 m/s, the lagged slips starting on the
        // slow manifold α′ = α). The relaxing model is a regular perturbation off the initial
        // layer: the gap is O(σ), tenfold smaller per decade (ratio 10 ± 1), and below 1e-3
        // of the state's size at σ = 1e-3 m. (RK4's own error, ~dt⁴·|λ|⁴ with λ = −V/σ, is far
        // below: λ·dt ≥ −0.66.)
        let m0 = table_i();
        let u = Inputs::constant_speed(33.0);
        let x4 = State4::new(0.0, 0.0, 0.0, 0.05);
        let (dt, steps) = (2e-5, 25_000);
        let reference = rk4(|x| m0.rhs4(x, &u), x4, dt, steps);
        let mut gaps = Vec::new();
        for sigma in [1e-2, 1e-3] {
            let m = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(sigma)).unwrap();
            let mut x = SVector::<f64, 7>::zeros();
            x.fixed_rows_mut::<4>(0).copy_from(&x4);
            let mut alpha = [0.0; 8];
            m.slip_angles(&x, &u, &mut alpha);
            for k in 0..3 {
                x[4 + k] = alpha[k];
            }
            let end = rk4(|x| m.rhs(x, &u), x, dt, steps);
            let gap = (end.fixed_rows::<4>(0).into_owned() - reference).norm() / reference.norm();
            gaps.push(gap);
        }
        println!("trajectory gap to σ = 0 after 0.5 s, σ = 1e-2, 1e-3 m: {gaps:?}");
        assert!((gaps[0] / gaps[1] - 10.0).abs() < 1.0, "{gaps:?}");
        assert!(gaps[1] < 1e-3, "{gaps:?}");
    }

    #[test]
    fn a_magic_formula_tyre_of_the_same_stiffness_has_the_same_linear_critical_speed() {
        // Reference: the brush model of Table I. The linearisation sees only the slope at
        // α = 0, B·C·D = C_α (exact up to the round-off of B = C_α/(C·D)): V_crit equal within
        // 1e-9 m/s, A equal to 1e-12 relative. The forces differ away from α = 0.
        let brush = VehicleModel::<4>::new(&VehicleSpec::from(VehicleParams::default())).unwrap();
        let mut s = VehicleSpec::from(VehicleParams::default());
        s.tractor.front_tire = Some(magic(0.9));
        s.tractor.rear_tire = Some(magic(0.9));
        s.trailer.as_mut().unwrap().tire = Some(magic(0.9));
        let mf = VehicleModel::<4>::new(&s).unwrap();
        assert_relative_eq!(
            brush.plant_linearization(30.0).a,
            mf.plant_linearization(30.0).a,
            max_relative = 1e-12
        );
        let (vb, vm) = (vcrit(&brush), vcrit(&mf));
        assert!((vb - vm).abs() < 1e-9, "{vb} vs {vm}");
        let x = State4::new(0.5, 0.1, 0.0, 0.1);
        let u = Inputs::constant_speed(30.0);
        assert!((brush.rhs(&x, &u) - mf.rhs(&x, &u)).norm() > 1e-3);
        // smooth laws declare no switching functions; the brush tyre declares 2 per axle
        assert!(mf.switching_kinds().is_empty());
        assert_eq!(brush.switching_kinds().len(), 6);
    }

    #[test]
    fn a_tandem_collapsed_onto_one_position_is_the_single_axle() {
        // Reference: Table I. Two trailer axles at l with C_T/2 each carry F_z,T/2 each
        // (equal loads): the brush coefficients scale with C and F_z together, so each force
        // is half the single axle's. Right-hand sides equal to 1e-12 relative (the sum of two
        // halves vs one term) over 2000 random states; V_crit within 1e-9 m/s.
        let single = table_i();
        let collapsed = with_trailer_axles(vec![
            axle(2.8, 25e3, false, 0.0, TireLawSpec::default()),
            axle(2.8, 25e3, false, 0.0, TireLawSpec::default()),
        ]);
        // a file may not do this (overlapping axles), the model may
        assert!(collapsed.validate().is_err());
        let m = VehicleModel::<4>::new(&collapsed).unwrap();
        for (x, u, _) in random_points(51, 2000) {
            let (a, b) = (single.rhs4(&x, &u), m.rhs(&x, &u));
            for i in 0..4 {
                assert!((a[i] - b[i]).abs() <= 1e-12 * a[i].abs().max(1.0), "{i}");
            }
        }
        let v = single
            .critical_speed(&CriticalSpeedOptions::default())
            .unwrap()
            .v_crit_mps;
        assert!((vcrit(&m) - v).abs() < 1e-9);
        // the tandem of the example file: equal loads summing to F_z,T (statics: moments
        // about the hitch F (l1 + l2) = m2 g h)
        let tandem = with_trailer_axles(vec![
            axle(2.4, 25e3, false, 0.0, TireLawSpec::default()),
            axle(3.2, 25e3, false, 0.0, TireLawSpec::default()),
        ]);
        tandem.validate().unwrap();
        let m = VehicleModel::<4>::new(&tandem).unwrap();
        let loads: Vec<f64> = m.axles().iter().map(|a| a.vertical_load).collect();
        let fz_t = single.axle_loads().trailer;
        assert_relative_eq!(loads[2], loads[3], max_relative = 0.0);
        assert_relative_eq!(loads[2] + loads[3], fz_t, max_relative = 1e-15);
        let p = VehicleParams::default();
        assert_relative_eq!(
            loads[2] * 2.4 + loads[3] * 3.2,
            p.trailer.mass * p.gravity * p.trailer.cog,
            max_relative = 1e-14
        );
        println!(
            "tandem ±0.4 m: V_crit = {:.4} m/s (single axle {v:.4})",
            vcrit(&m)
        );
    }

    #[test]
    fn a_paper_key_of_an_axle_list_moves_or_scales_the_group() {
        // Reference: the axle lists written out by hand. Setting l of the tandem (2.4 m and
        // 3.2 m, mean 2.8 m) to 3.0 m shifts both axles by 0.2 m; setting C_T to 60e3 N/rad
        // scales both 25e3 N/rad to 30e3 N/rad; the equivalent vehicle then has exactly
        // the value set. The same on a tractor given as a list, its steered group only.
        let tandem = with_trailer_axles(vec![
            axle(2.4, 25e3, false, 0.0, TireLawSpec::default()),
            axle(3.2, 25e3, false, 0.0, TireLawSpec::default()),
        ]);
        let moved = tandem.with_parameter(10, 3.0).unwrap();
        let by_hand = with_trailer_axles(vec![
            axle(2.4 + 0.2, 25e3, false, 0.0, TireLawSpec::default()),
            axle(3.2 + 0.2, 25e3, false, 0.0, TireLawSpec::default()),
        ]);
        let positions = |s: &VehicleSpec| -> Vec<f64> {
            s.trailer
                .as_ref()
                .unwrap()
                .axles
                .as_ref()
                .unwrap()
                .iter()
                .map(|a| a.position_m)
                .collect()
        };
        for (a, b) in positions(&moved).iter().zip(positions(&by_hand)) {
            assert_relative_eq!(*a, b, max_relative = 1e-15);
        }
        assert_relative_eq!(
            moved.equivalent_params().unwrap().trailer.axle,
            3.0,
            max_relative = 1e-15
        );
        let stiffer = tandem.with_parameter(11, 60e3).unwrap();
        for a in stiffer.trailer.as_ref().unwrap().axles.as_ref().unwrap() {
            assert_relative_eq!(a.cornering_stiffness, 30e3, max_relative = 1e-15);
        }
        assert_relative_eq!(
            stiffer
                .equivalent_params()
                .unwrap()
                .trailer
                .cornering_stiffness,
            60e3,
            max_relative = 1e-15
        );
        // a tractor as a list: f moves the steered axle, the unsteered one stays
        let mut listed = VehicleSpec::from(VehicleParams::default());
        let p = VehicleParams::default();
        listed.tractor.front_axle = None;
        listed.tractor.rear_axle = None;
        listed.tractor.front_cornering_stiffness = None;
        listed.tractor.rear_cornering_stiffness = None;
        listed.tractor.axles = Some(vec![
            axle(
                p.tractor.front_axle,
                p.tractor.front_cornering_stiffness,
                true,
                0.0,
                TireLawSpec::default(),
            ),
            axle(
                p.tractor.rear_axle,
                p.tractor.rear_cornering_stiffness,
                false,
                0.0,
                TireLawSpec::default(),
            ),
        ]);
        let f = listed
            .with_parameter(2, p.tractor.front_axle + 0.1)
            .unwrap();
        let axles = f.tractor.axles.as_ref().unwrap();
        assert_relative_eq!(
            axles[0].position_m,
            p.tractor.front_axle + 0.1,
            max_relative = 1e-15
        );
        assert_eq!(axles[1].position_m, p.tractor.rear_axle);
    }

    #[test]
    fn hitch_friction_is_seen_by_the_linearisation_as_its_regularised_slope() {
        // Reference: the regularisation stated in HitchSpec: for |θ̇| < ω_c the Coulomb torque
        // is the viscous damping M_c/ω_c, so the linearisation (and V_crit) of (M_c, ω_c)
        // equals that of c_h = M_c/ω_c exactly (A to 1e-13 relative, V_crit to 1e-9 m/s);
        // beyond ω_c the torque is M_c (checked at θ̇ = ±2ω_c to 1e-15).
        let with = |c_h: f64, m_c: f64| {
            let mut s = VehicleSpec::from(VehicleParams::default());
            s.hitch = HitchSpec {
                yaw_damping_nms: c_h,
                friction_torque_nm: m_c,
                friction_regularisation_rad_s: 0.05,
            };
            VehicleModel::<4>::new(&s).unwrap()
        };
        let (coulomb, viscous) = (with(0.0, 100.0), with(2000.0, 0.0));
        assert_relative_eq!(
            coulomb.plant_linearization(35.0).a,
            viscous.plant_linearization(35.0).a,
            max_relative = 1e-13
        );
        let (vc, vv) = (vcrit(&coulomb), vcrit(&viscous));
        assert!((vc - vv).abs() < 1e-9);
        assert!(
            vc > vcrit(&with(0.0, 0.0)),
            "damping at the hitch raises V_crit"
        );
        assert_eq!(coulomb.hitch_torque(0.1), 100.0);
        assert_eq!(coulomb.hitch_torque(-0.1), -100.0);
        assert_relative_eq!(coulomb.hitch_torque(0.01), 20.0, max_relative = 1e-15);
        assert_eq!(
            coulomb.switching_kinds().last(),
            Some(&trailer_model::SwitchingKind::HitchFriction)
        );
        println!("hitch: M_c = 100 N m, ω_c = 0.05 rad/s: V_crit = {vc:.4} m/s");
    }

    #[test]
    fn exact_jacobian_of_the_relaxed_model_matches_differences() {
        // Reference: central differences, step 1e-6, as `jacobian_matches_central_differences`
        // (1e-6 relative to the column norm; random states avoid the kinks).
        let m = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.4)).unwrap();
        for (x, u, _, _) in random_states::<7>(61, 200) {
            let (j, jd) = Plant::jacobian(&m, &x, &u);
            let step = 1e-6;
            for k in 0..8 {
                let (mut xp, mut xm, mut up, mut um) = (x, x, u, u);
                if k < 7 {
                    xp[k] += step;
                    xm[k] -= step;
                } else {
                    up.steering_angle += step;
                    um.steering_angle -= step;
                }
                let fd = (m.rhs(&xp, &up) - m.rhs(&xm, &um)) / (2.0 * step);
                let ad = if k < 7 { j.column(k).into_owned() } else { jd };
                assert!((fd - ad).norm() <= 1e-6 * ad.norm().max(1.0), "column {k}");
            }
        }
    }

    #[test]
    fn switching_functions_change_sign_at_the_kinks() {
        // Reference: the brush law's kinks (tan α = 0, |α| = α_cr) at the slip angles of the
        // model (`slip_angles`) and the lagged slips. Exact identities.
        let m = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap();
        let kinds = m.switching_kinds().to_vec();
        assert_eq!(kinds.len(), 6);
        let mut g = vec![0.0; kinds.len()];
        for (x, u, _, _) in random_states::<7>(71, 200) {
            m.switching_functions(&x, &u, &mut g);
            for k in 0..3 {
                assert_eq!(g[k], x[4 + k]);
                let acr = m.axles()[k].tire.critical_slip_angle().unwrap();
                assert_eq!(g[3 + k], x[4 + k] * x[4 + k] - acr * acr);
            }
        }
        // instantaneous axles: tan α with its sign, as the paper's model gives it
        let paper = table_i();
        let m4 = VehicleModel::<4>::new(&VehicleSpec::from(VehicleParams::default())).unwrap();
        let (mut ga, mut gb) = ([0.0; 6], [0.0; 6]);
        for (x, u, _) in random_points(72, 500) {
            Plant::switching_functions(&paper, &x, &u, &mut ga);
            m4.switching_functions(&x, &u, &mut gb);
            for k in 0..6 {
                assert!((ga[k] - gb[k]).abs() <= 1e-12 * ga[k].abs().max(1.0), "{k}");
            }
        }
    }

    #[test]
    fn any_model_dispatches_on_the_number_of_relaxing_axles() {
        // Reference: N = 4 + (axles with σ > 0); a wrong N is an error that says so.
        for (sigmas, n) in [
            ([0.0, 0.0, 0.0], 4),
            ([0.3, 0.0, 0.0], 5),
            ([0.3, 0.3, 0.3], 7),
        ] {
            let mut s = VehicleSpec::from(VehicleParams::default());
            s.tractor.front_relaxation_length_m = Some(sigmas[0]);
            s.tractor.rear_relaxation_length_m = Some(sigmas[1]);
            s.trailer.as_mut().unwrap().relaxation_length_m = Some(sigmas[2]);
            let any = AnyVehicleModel::new(&s).unwrap();
            assert_eq!(any.states(), n);
            // no variant at all: the paper's model itself
            assert_eq!(matches!(any, AnyVehicleModel::Paper(_)), n == 4);
            let spectrum = with_plant!(&any, m => m.open_loop_spectrum(30.0));
            assert_eq!(spectrum.len(), n);
        }
        // a variant without extra states is the general model with N = 4
        let mut s = VehicleSpec::from(VehicleParams::default());
        s.hitch.yaw_damping_nms = 100.0;
        assert!(matches!(
            AnyVehicleModel::new(&s).unwrap(),
            AnyVehicleModel::N4(_)
        ));
        let e = VehicleModel::<5>::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::StateCount {
                    expected: 7,
                    requested: 5,
                    ..
                }
            ),
            "{e}"
        );
    }
}

mod vehicle_files {
    use std::path::PathBuf;

    use super::*;
    use tires::TireLawSpec;
    use trailer_model::{
        AnyVehicleModel, AxleSpec, HitchSpec, ModelError, Plant, VehicleSpec, with_plant,
    };

    fn configs() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../configs")
    }

    fn read<T: serde::de::DeserializeOwned>(path: &std::path::Path) -> T {
        let text = std::fs::read_to_string(path).expect("readable");
        toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    #[test]
    fn todays_vehicle_files_read_as_specs_with_the_same_parameters() {
        // Reference: the file read as VehicleParams (today's format): the spec's equivalent
        // parameters equal it exactly, and the spec is `From<VehicleParams>` of it.
        let mut files = vec![configs().join("vehicle.toml")];
        for entry in std::fs::read_dir(configs().join("fleet")).expect("fleet dir") {
            files.push(entry.expect("entry").path());
        }
        for f in files {
            let params: VehicleParams = read(&f);
            let spec: VehicleSpec = read(&f);
            assert_eq!(spec.equivalent_params().unwrap(), params, "{}", f.display());
            assert_eq!(spec, VehicleSpec::from(params), "{}", f.display());
        }
    }

    #[test]
    fn example_variant_files_are_table_i_with_only_their_change() {
        // Reference: Table I's spec with the one change made in code; each file parses,
        // validates, builds its model with the expected number of states and has a V_crit.
        let dir = configs().join("vehicles");
        let table_i = VehicleSpec::from(VehicleParams::default());
        let mf = TireLawSpec::MagicFormula {
            shape_factor: 1.247,
            curvature_factor: -1.24,
            peak_friction: Some(0.648),
            peak_force: None,
            stiffness_factor: None,
        };
        let mut magic = table_i.clone();
        magic.tractor.front_tire = Some(mf);
        magic.tractor.rear_tire = Some(mf);
        magic.trailer.as_mut().unwrap().tire = Some(mf);
        let mut tandem = table_i.clone();
        tandem.trailer.as_mut().unwrap().axle = None;
        tandem.trailer.as_mut().unwrap().cornering_stiffness = None;
        let half = |position_m| AxleSpec {
            position_m,
            cornering_stiffness: 25e3,
            steered: false,
            tire: TireLawSpec::default(),
            relaxation_length_m: 0.0,
        };
        tandem.trailer.as_mut().unwrap().axles = Some(vec![half(2.4), half(3.2)]);
        let mut hitch = table_i.clone();
        hitch.hitch = HitchSpec {
            yaw_damping_nms: 0.0,
            friction_torque_nm: 200.0,
            friction_regularisation_rad_s: 0.02,
        };
        let expected = [
            (
                "relaxation.toml",
                VehicleSpec::table_i_with_relaxation(0.3),
                7,
            ),
            ("magic_formula.toml", magic, 4),
            ("tandem.toml", tandem, 4),
            ("hitch_friction.toml", hitch, 4),
        ];
        let mut found = 0;
        for entry in std::fs::read_dir(&dir).expect("configs/vehicles") {
            let path = entry.expect("entry").path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            let spec: VehicleSpec = read(&path);
            spec.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
            let (_, want, n) = expected
                .iter()
                .find(|(f, _, _)| *f == name)
                .unwrap_or_else(|| panic!("{name} has no expectation in this test"));
            assert_eq!(&spec, want, "{name}");
            let any = AnyVehicleModel::new(&spec).unwrap();
            assert_eq!(any.states(), *n, "{name}");
            let vc =
                with_plant!(&any, m => m.critical_speed(&CriticalSpeedOptions::default())).unwrap();
            println!("{name}: N = {n}, V_crit = {:.4} m/s", vc.v_crit_mps);
            found += 1;
        }
        assert_eq!(found, expected.len());
        // the Magic Formula file keeps Table I's cornering stiffness, peak 0.648 F_z and the
        // sliding asymptote μ F_z (to the 3 digits of C)
        let spec: VehicleSpec = read(&dir.join("magic_formula.toml"));
        let m = trailer_model::VehicleModel::<4>::new(&spec).unwrap();
        use tires::TireModel;
        for (a, c) in m.axles().iter().zip([137e3, 256e3, 50e3]) {
            assert_relative_eq!(a.tire.cornering_stiffness(), c, max_relative = 1e-14);
            let far = a.tire.lateral_force(1e6) / a.vertical_load;
            assert!((far - 0.6).abs() < 2e-3, "{far}");
        }
        let _ = Plant::params(&m);
    }

    fn error_of(text: &str) -> String {
        match toml::from_str::<VehicleSpec>(text) {
            Err(e) => e.to_string(),
            Ok(spec) => match spec.validate() {
                Err(e) => e.to_string(),
                Ok(()) => match AnyVehicleModel::new(&spec) {
                    Err(e) => e.to_string(),
                    Ok(_) => String::from("accepted"),
                },
            },
        }
    }

    #[test]
    fn bad_variant_keys_are_named_errors() {
        // Reference: each broken file names the key (or the law) and the problem.
        let base = std::fs::read_to_string(configs().join("vehicle.toml")).unwrap();
        let with = |table: &str, line: &str| base.replacen(table, &format!("{table}\n{line}"), 1);
        let cases = [
            (with("[trailer]", "tire = { law = \"pacejka\" }"), "pacejka"),
            (
                with("[trailer]", "relaxation_length_m = -0.3"),
                "trailer.relaxation_length_m",
            ),
            (
                with("[tractor]", "front_relaxation_length_m = -1.0"),
                "tractor.front_relaxation_length_m",
            ),
            (with("[trailer]", "relaxation = 0.3"), "relaxation"),
            (
                with(
                    "[tractor]",
                    "front_tire = { law = \"magic_formula\", shape_factor = 2.4, peak_friction = 0.9 }",
                ),
                "tractor.front_tire",
            ),
            (
                with(
                    "[trailer]",
                    "tire = { law = \"magic_formula\", shape_factor = 1.3 }",
                ),
                "peak_friction",
            ),
            (
                format!(
                    "{base}\n[[trailer.axles]]\nposition_m = 2.4\ncornering_stiffness = 25e3\n"
                ),
                "trailer.axle",
            ),
            (
                format!("{base}\n[hitch]\nfriction_torque_nm = -5.0\n"),
                "hitch.friction_torque_nm",
            ),
            (
                format!(
                    "{base}\n[hitch]\nfriction_torque_nm = 5.0\nfriction_regularisation_rad_s = 0.0\n"
                ),
                "hitch.friction_regularisation_rad_s",
            ),
        ];
        for (text, needle) in &cases {
            let e = error_of(text);
            assert!(e.contains(needle), "expected `{needle}` in: {e}");
        }
        // list forms: an axle on the hitch, overlapping axles, a steered trailer axle
        let tandem = std::fs::read_to_string(configs().join("vehicles/tandem.toml")).unwrap();
        for (from, to, needle) in [
            (
                "position_m = 2.4",
                "position_m = 0.0",
                "trailer.axles[0].position_m",
            ),
            ("position_m = 3.2", "position_m = 2.5", "overlap"),
            (
                "position_m = 3.2",
                "position_m = 3.2\nsteered = true",
                "trailer.axles[1].steered",
            ),
            (
                "cornering_stiffness = 25e3         # [N/rad]\n\n",
                "cornering_stiffness = -25e3\n\n",
                "trailer.axles[0].cornering_stiffness",
            ),
        ] {
            let text = tandem.replacen(from, to, 1);
            assert_ne!(text, tandem);
            let e = error_of(&text);
            assert!(e.contains(needle), "expected `{needle}` in: {e}");
        }
        // a tractor axle list without a steered axle
        let mut spec = VehicleSpec::from(VehicleParams::default());
        spec.tractor.front_axle = None;
        spec.tractor.rear_axle = None;
        spec.tractor.front_cornering_stiffness = None;
        spec.tractor.rear_cornering_stiffness = None;
        let ax = |p: f64| AxleSpec {
            position_m: p,
            cornering_stiffness: 1e5,
            steered: false,
            tire: TireLawSpec::default(),
            relaxation_length_m: 0.0,
        };
        spec.tractor.axles = Some(vec![ax(5.0), ax(1.3)]);
        let e = spec.validate().unwrap_err();
        assert!(e.to_string().contains("steered"), "{e}");
        // seven relaxing axles: more states than supported
        spec.tractor.axles = Some(vec![
            AxleSpec {
                steered: true,
                relaxation_length_m: 0.3,
                ..ax(5.0)
            },
            AxleSpec {
                relaxation_length_m: 0.3,
                ..ax(1.3)
            },
            AxleSpec {
                relaxation_length_m: 0.3,
                ..ax(0.8)
            },
        ]);
        spec.trailer.as_mut().unwrap().axle = None;
        spec.trailer.as_mut().unwrap().cornering_stiffness = None;
        spec.trailer.as_mut().unwrap().axles = Some(
            [2.0, 2.6, 3.2, 3.8]
                .map(|p| AxleSpec {
                    relaxation_length_m: 0.3,
                    ..ax(p)
                })
                .to_vec(),
        );
        spec.validate().unwrap();
        let e = AnyVehicleModel::new(&spec).unwrap_err();
        assert!(matches!(e, ModelError::StateCount { .. }), "{e}");
    }
}

mod plant_services {
    use super::*;
    use tires::{TireLawSpec, TireModel};
    use trailer_model::{PARAMETERS, Plant, VehicleModel, VehicleSpec};

    #[test]
    fn guard_values_of_the_general_model_are_the_papers() {
        // Reference: the paper's model's guard (the conditions sway's simulations check):
        // VehicleModel<4> of Table I gives the same values (1e-12 relative: the same tangents,
        // the sliding limit through α_cr of the law) at 2000 random points, δ ≠ 0 and δ = 0.
        // A relaxing axle is judged by its lagged slip α′; a Magic Formula axle by its peak slip.
        let paper = table_i();
        let m = VehicleModel::<4>::new(&VehicleSpec::from(VehicleParams::default())).unwrap();
        for (x, mut u, _) in random_points(81, 2000) {
            for delta in [u.steering_angle, 0.0] {
                u.steering_angle = delta;
                let (a, b) = (Plant::guard_values(&paper, &x, &u), m.guard_values(&x, &u));
                for k in 0..5 {
                    assert!(
                        (a[k] - b[k]).abs() <= 1e-12 * a[k].abs().max(1.0),
                        "{k}: {a:?} {b:?}"
                    );
                }
            }
        }
        let relaxed = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap();
        let acr = paper.critical_slip_angles();
        let mut x = SVector::<f64, 7>::zeros();
        x[4] = acr.front * 1.01;
        let g = relaxed.guard_values(&x, &Inputs::constant_speed(30.0));
        assert!(g[0] > 0.0 && g[1] < 0.0, "{g:?}");
        assert_relative_eq!(
            g[0],
            (acr.front * 1.01).tan() - acr.front.tan(),
            max_relative = 1e-14
        );
        let mut s = VehicleSpec::from(VehicleParams::default());
        s.tractor.rear_tire = Some(TireLawSpec::Linear {});
        s.tractor.front_tire = Some(TireLawSpec::MagicFormula {
            shape_factor: 1.3,
            curvature_factor: 0.0,
            peak_friction: Some(0.9),
            peak_force: None,
            stiffness_factor: None,
        });
        let mf = VehicleModel::<4>::new(&s).unwrap();
        let g = mf.guard_values(&State4::zeros(), &Inputs::constant_speed(30.0));
        let peak = mf.axles()[0].tire.saturation_slip_angle();
        assert_relative_eq!(g[0], -peak.tan(), max_relative = 1e-14);
        assert_eq!(g[1], f64::NEG_INFINITY, "a linear tyre never saturates");
        // the peak slip is where the force is largest
        let tire = mf.axles()[0].tire;
        assert!(tire.lateral_force(peak) > tire.lateral_force(peak * 0.99));
        assert!(tire.lateral_force(peak) > tire.lateral_force(peak * 1.01));
    }

    #[test]
    fn a_paper_form_spec_serialises_as_the_parameters_do() {
        // Reference: toml of VehicleParams (what result summaries echo today): the same text,
        // so an echo of the spec keeps committed results byte-identical.
        let p = VehicleParams::default();
        let a = toml::to_string(&p).unwrap();
        let b = toml::to_string(&VehicleSpec::from(p)).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn spec_parameters_follow_the_paper_keys() {
        // Reference: VehicleParams::with (today's sweeps): the same change through the spec.
        let p = VehicleParams::default();
        let s = VehicleSpec::from(p);
        for (i, _) in PARAMETERS.iter().enumerate() {
            let v = p.get(i) * 1.1;
            let changed = s.with_parameter(i, v).unwrap();
            assert_eq!(changed.equivalent_params().unwrap(), p.with(i, v), "{i}");
        }
        let tandem: VehicleSpec = toml::from_str(
            &std::fs::read_to_string(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../configs/vehicles/tandem.toml"
            ))
            .unwrap(),
        )
        .unwrap();
        assert!(tandem.with_parameter(7, 1200.0).is_ok());
        // The axle key of an axle list moves the group (its mean position becomes the value);
        // the group's own test is `variants::a_paper_key_of_an_axle_list_moves_or_scales_the_group`.
        let moved = tandem.with_parameter(10, 3.0).unwrap();
        let axles = moved.trailer.as_ref().unwrap().axles.as_ref().unwrap();
        let mean = axles.iter().map(|a| a.position_m).sum::<f64>() / axles.len() as f64;
        assert!((mean - 3.0).abs() < 1e-12, "{mean}");
    }
}

#[test]
fn critical_speed_of_table_i_is_the_committed_one() {
    // Reference: results/linear/summary.json as committed (computed before the plant
    // abstraction existed): V_crit = 34.747923362676374 m/s, printed with 17 significant
    // digits (serde_json round-trips f64). The search is shared with every Plant now; Table
    // I's number must not move by one bit.
    let v = table_i()
        .critical_speed(&CriticalSpeedOptions::default())
        .expect("V_crit")
        .v_crit_mps;
    assert_eq!(v, 34.747923362676374);
}

/// `sorted_spectrum` returns (N NaN eigenvalues) on a matrix with a non-finite entry instead
/// of iterating forever (nalgebra's unbounded `complex_eigenvalues` never returned on such a
/// linearisation of a generated vehicle), and keeps its values elsewhere. Reference: the
/// eigenvalues of a companion matrix with roots −1, −2, −3 ± 4i (to 1e-9).
#[test]
fn sorted_spectrum_is_nan_on_a_non_finite_matrix_and_exact_elsewhere() {
    let mut a = nalgebra::SMatrix::<f64, 4, 4>::zeros();
    a[(0, 1)] = f64::NAN;
    let ev = trailer_model::sorted_spectrum(&a);
    assert_eq!(ev.len(), 4);
    assert!(ev.iter().all(|z| z.re.is_nan() && z.im.is_nan()));
    // companion matrix of (s + 1)(s + 2)(s² + 6s + 25) = s⁴ + 9s³ + 45s² + 87s + 50
    let c = [50.0, 87.0, 45.0, 9.0];
    let mut m = nalgebra::SMatrix::<f64, 4, 4>::zeros();
    for i in 0..3 {
        m[(i, i + 1)] = 1.0;
    }
    for (j, cj) in c.iter().enumerate() {
        m[(3, j)] = -cj;
    }
    let ev = trailer_model::sorted_spectrum(&m);
    let expected = [(-1.0, 0.0), (-2.0, 0.0), (-3.0, 4.0), (-3.0, -4.0)];
    for (z, (re, im)) in ev.iter().zip(expected) {
        assert!(
            (z.re - re).abs() < 1e-9 && (z.im - im).abs() < 1e-9,
            "{z} vs {re} {im}"
        );
    }
}
