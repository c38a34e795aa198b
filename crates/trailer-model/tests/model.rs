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
    // Reference: DESIGN.md's independently checked values (printed to 0.1 N) and the
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
