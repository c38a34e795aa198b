//! The chain model (towing unit + n towed units) against an independent Newton–Euler
//! formulation, against today's two-unit models, and against limits of the mechanics.

use nalgebra::{DMatrix, DVector, SMatrix, SVector, Vector2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tires::TireModel;
use trailer_model::{
    AxleSpec, ChainModel, ChainSpec, CriticalSpeedOptions, HitchSpec, Inputs, Model, Plant, Pose,
    TowedUnitSpec, UnitMotion, VehicleModel, VehicleParams, VehicleSpec,
};

// ---------------------------------------------------------------------------------------
// vehicles
// ---------------------------------------------------------------------------------------

fn axle(position_m: f64, cornering_stiffness: f64) -> AxleSpec {
    AxleSpec {
        position_m,
        cornering_stiffness,
        steered: false,
        tire: Default::default(),
        relaxation_length_m: 0.0,
    }
}

fn unit(mass: f64, yaw_inertia: f64, cog: f64, axle_m: f64, c: f64) -> TowedUnitSpec {
    TowedUnitSpec {
        mass,
        yaw_inertia,
        cog,
        axle: Some(axle_m),
        cornering_stiffness: Some(c),
        tire: None,
        relaxation_length_m: None,
        axles: None,
        rear_coupling: None,
        hitch: None,
    }
}

/// Table I as a chain, with `extra` towed units appended behind the trailer (the trailer's
/// rear coupling 4.0 m behind its hitch).
fn table_i_chain(extra: Vec<TowedUnitSpec>) -> ChainSpec {
    let mut s = ChainSpec::from(VehicleParams::default());
    if !extra.is_empty() {
        let mut first = s.trailer.take().unwrap();
        first.rear_coupling = Some(4.0);
        s.trailers.push(first);
        let k = extra.len();
        for (i, mut u) in extra.into_iter().enumerate() {
            if i + 1 < k {
                u.rear_coupling = Some(3.5);
            }
            s.trailers.push(u);
        }
    }
    s
}

/// A car with two caravans, with a tandem, relaxation, a damped hitch and a friction hitch.
fn three_units() -> ChainSpec {
    let mut second = unit(700.0, 800.0, 2.2, 2.4, 40e3);
    second.relaxation_length_m = Some(0.4);
    second.hitch = Some(HitchSpec {
        yaw_damping_nms: 300.0,
        friction_torque_nm: 250.0,
        friction_regularisation_rad_s: 0.05,
    });
    let mut first = unit(1100.0, 1600.0, 2.8, 0.0, 0.0);
    first.axle = None;
    first.cornering_stiffness = None;
    first.axles = Some(vec![axle(2.5, 30e3), axle(3.3, 30e3)]);
    first.hitch = Some(HitchSpec {
        yaw_damping_nms: 800.0,
        ..HitchSpec::default()
    });
    let mut s = table_i_chain(vec![second]);
    s.trailers[0] = TowedUnitSpec {
        rear_coupling: Some(4.6),
        ..first
    };
    s.tractor.front_relaxation_length_m = Some(0.3);
    s
}

/// Tractor (fifth wheel ahead of its rear tandem) – semitrailer – dolly – semitrailer.
fn four_units() -> ChainSpec {
    let toml = r#"
        [tractor]
        mass = 8000.0
        yaw_inertia = 3.0e4
        cog = 1.6
        [[tractor.axles]]
        position_m = 3.6
        cornering_stiffness = 3.2e5
        steered = true
        relaxation_length_m = 0.5
        [[tractor.axles]]
        position_m = -0.3
        cornering_stiffness = 4.5e5
        [[tractor.axles]]
        position_m = -1.6
        cornering_stiffness = 4.5e5
        tire = { law = "magic_formula", shape_factor = 1.5, peak_friction = 0.9 }

        [[trailers]]
        mass = 18000.0
        yaw_inertia = 2.2e5
        cog = 5.5
        rear_coupling = 11.5
        [[trailers.axles]]
        position_m = 8.0
        cornering_stiffness = 3.5e5
        [[trailers.axles]]
        position_m = 9.3
        cornering_stiffness = 3.5e5
        relaxation_length_m = 0.6
        [trailers.hitch]
        yaw_damping_nms = 2000.0

        [[trailers]]
        mass = 1200.0
        yaw_inertia = 900.0
        cog = 2.6
        axle = 3.0
        cornering_stiffness = 3.0e5
        rear_coupling = 3.1
        [trailers.hitch]
        friction_torque_nm = 1500.0

        [[trailers]]
        mass = 15000.0
        yaw_inertia = 1.6e5
        cog = 5.0
        axle = 7.8
        cornering_stiffness = 6.0e5
        tire = { law = "linear" }

        [friction]
        mu_static = 0.9
        mu_dynamic = 0.6
    "#;
    toml::from_str(toml).expect("the four-unit file parses")
}

// ---------------------------------------------------------------------------------------
// the Newton–Euler oracle
// ---------------------------------------------------------------------------------------

fn cross(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

fn heading(angle: f64) -> (Vector2<f64>, Vector2<f64>) {
    let (s, c) = angle.sin_cos();
    (Vector2::new(c, s), Vector2::new(-s, c))
}

/// An acceleration linear in the unknowns: known + Σ_j coef_j z_j.
#[derive(Clone)]
struct Lin {
    known: Vector2<f64>,
    coef: Vec<Vector2<f64>>,
}

/// What the oracle finds: the N derivatives, the longitudinal constraint force λ \[N\] along
/// the towing unit's axis, and the kinetic energy \[J\].
struct Oracle<const N: usize> {
    dx: SVector<f64, N>,
    lambda: f64,
    kinetic_energy: f64,
    /// a_C · E2_i of every unit's centre of gravity \[m/s²\]
    lateral_accelerations: Vec<f64>,
}

/// Newton–Euler for the chain, in the inertial frame with the towing unit at heading ψ:
/// per unit a free-body diagram (tyre forces, the coupling forces P_i of unit i on unit
/// i − 1 at H_i, +P_i on the unit in front, −P_i on unit i, the constraint force λ E1_0 on
/// the towing unit along its axis, the yaw moment, the coupling torques ±T_i). Unknowns
/// z = [v̇, ψ̈_0 … ψ̈_n, P_1 … P_n (2 each), λ]; 3 equations per unit. Geometry and masses are
/// read from the file, the tyre laws (with their static loads) from the model.
fn newton_euler<const N: usize>(
    model: &ChainModel<N>,
    x: &SVector<f64, N>,
    u: &Inputs,
    psi: f64,
    yaw_moment: f64,
    with_tyres: bool,
    stiffness: &[f64],
) -> Oracle<N> {
    let spec = model.spec();
    let towed = spec.towed_units();
    let nu = 1 + towed.len();
    let nz = 3 * nu;
    let iv = 0;
    let ipsi = |i: usize| 1 + i;
    let ip = |i: usize| 1 + nu + 2 * (i - 1); // P_i, i = 1…n
    let il = nz - 1;
    let (v, r) = (x[0], x[1]);
    let (speed, accel, delta) = (u.speed, u.acceleration, u.steering_angle);

    // headings and yaw rates
    let mut psis = vec![psi];
    let mut rates = vec![r];
    for i in 1..nu {
        psis.push(psis[i - 1] + x[2 * i + 1]);
        rates.push(rates[i - 1] + x[2 * i]);
    }
    let frames: Vec<_> = psis.iter().map(|&a| heading(a)).collect();
    let (e1, e2) = frames[0];

    // velocities and accelerations of the couplings H_1 … H_n (index 1…n)
    let zero = Lin {
        known: Vector2::zeros(),
        coef: vec![Vector2::zeros(); nz],
    };
    let mut vel_h = vec![Vector2::zeros(); nu];
    let mut acc_h = vec![zero.clone(); nu];
    vel_h[0] = e1 * speed + e2 * v; // H_1, stored at index 0 (the towing unit's hitch)
    acc_h[0].known = e1 * (accel - v * r) + e2 * (speed * r);
    acc_h[0].coef[iv] = e2;
    // a point `b` behind the reference point of towed unit i: a = a_H − b(ψ̈ E2 − ψ̇² E1)
    let behind = |a: &Lin, i: usize, b: f64| {
        let (big_e1, big_e2) = frames[i];
        let mut out = a.clone();
        out.known += big_e1 * (b * rates[i] * rates[i]);
        out.coef[ipsi(i)] -= big_e2 * b;
        out
    };
    for i in 1..nu - 1 {
        let rho = towed[i - 1].rear_coupling.unwrap();
        vel_h[i] = vel_h[i - 1] - frames[i].1 * (rho * rates[i]);
        acc_h[i] = behind(&acc_h[i - 1], i, rho);
    }
    // reference point of unit i: H_1 for units 0 and 1, H_i for unit i
    let ref_index = |i: usize| if i == 0 { 0 } else { i - 1 };

    // centres of gravity
    let mut acc_c = Vec::new();
    let mut kinetic_energy = 0.0;
    for i in 0..nu {
        let (m, j) = if i == 0 {
            (spec.tractor.mass, spec.tractor.yaw_inertia)
        } else {
            (towed[i - 1].mass, towed[i - 1].yaw_inertia)
        };
        let (a, vc) = if i == 0 {
            let d = spec.tractor.cog;
            let mut a = acc_h[0].clone();
            a.known -= e1 * (d * r * r);
            a.coef[ipsi(0)] += e2 * d;
            (a, vel_h[0] + e2 * (d * r))
        } else {
            let h = towed[i - 1].cog;
            (
                behind(&acc_h[ref_index(i)], i, h),
                vel_h[ref_index(i)] - frames[i].1 * (h * rates[i]),
            )
        };
        kinetic_energy += 0.5 * m * vc.norm_squared() + 0.5 * j * rates[i] * rates[i];
        acc_c.push((a, m, j));
    }

    // tyre forces: (unit, point of application relative to the unit's centre of gravity,
    // force vector)
    let mut out = SVector::<f64, N>::zeros();
    let mut tyres: Vec<(usize, Vector2<f64>, Vector2<f64>)> = Vec::new();
    for a in model.axles() {
        let i = a.unit;
        let (big_e1, big_e2) = frames[i];
        let (vel, arm) = if i == 0 {
            let d = spec.tractor.cog;
            (vel_h[0] + e2 * (a.position_m * r), e1 * (a.position_m - d))
        } else {
            let h = towed[i - 1].cog;
            (
                vel_h[ref_index(i)] - big_e2 * (a.position_m * rates[i]),
                big_e1 * (h - a.position_m),
            )
        };
        let steer = if a.steered { delta } else { 0.0 };
        if !with_tyres {
            continue;
        }
        let alpha = steer - (vel.dot(&big_e2) / vel.dot(&big_e1)).atan();
        let f = match a.state {
            None => a.tire.lateral_force(alpha),
            Some(j) => {
                out[j] = vel.dot(&big_e1) * (alpha - x[j]) / a.relaxation_length_m;
                a.tire.lateral_force(x[j])
            }
        };
        let normal = heading(psis[i] + steer).1;
        tyres.push((i, arm, normal * f));
    }
    // coupling torques T_i = c_h θ̇ + M_c clamp(θ̇/ω_c) + k θ (k: a test's spring)
    let torque = |i: usize| {
        let (h, _) = spec.coupling(i - 1);
        let w = x[2 * i];
        h.yaw_damping_nms * w
            + h.friction_torque_nm * (w / h.friction_regularisation_rad_s).clamp(-1.0, 1.0)
            + stiffness.get(i - 1).copied().unwrap_or(0.0) * x[2 * i + 1]
    };

    let mut a = DMatrix::<f64>::zeros(nz, nz);
    let mut b = DVector::<f64>::zeros(nz);
    for i in 0..nu {
        let (acc, m, j) = &acc_c[i];
        let row = 3 * i;
        // translation: m a_C − (coupling and constraint forces) = Σ F_tyre − m a_known
        for k in 0..2 {
            for (col, c) in acc.coef.iter().enumerate() {
                a[(row + k, col)] += m * c[k];
            }
            b[row + k] -= m * acc.known[k];
        }
        // rotation about C_i: J ψ̈ − (moments of the unknown forces) = known moments
        a[(row + 2, ipsi(i))] += j;
        // lever arms from C_i to its front coupling (towed) and to its rear coupling
        let (big_e1, _) = frames[i];
        let (front_arm, rear_arm) = if i == 0 {
            (None, Some(-e1 * spec.tractor.cog))
        } else {
            let t = &towed[i - 1];
            (
                Some(big_e1 * t.cog),
                t.rear_coupling.map(|rho| big_e1 * (t.cog - rho)),
            )
        };
        // −P_i at the front coupling of a towed unit
        if let Some(arm) = front_arm {
            let p = ip(i);
            a[(row, p)] += 1.0;
            a[(row + 1, p + 1)] += 1.0;
            // moment of −P: arm × (−P) = −(arm.x P_y − arm.y P_x)
            a[(row + 2, p)] += -arm.y;
            a[(row + 2, p + 1)] += arm.x;
            b[row + 2] -= torque(i);
        }
        // +P_{i+1} at the rear coupling
        if i + 1 < nu {
            let arm = rear_arm.unwrap();
            let p = ip(i + 1);
            a[(row, p)] -= 1.0;
            a[(row + 1, p + 1)] -= 1.0;
            a[(row + 2, p)] -= -arm.y;
            a[(row + 2, p + 1)] -= arm.x;
            b[row + 2] += torque(i + 1);
        }
        if i == 0 {
            a[(row, il)] -= e1.x;
            a[(row + 1, il)] -= e1.y;
            b[row + 2] += yaw_moment;
        }
        for (_, arm, f) in tyres.iter().filter(|t| t.0 == i) {
            b[row] += f.x;
            b[row + 1] += f.y;
            b[row + 2] += cross(*arm, *f);
        }
    }
    let z = a
        .lu()
        .solve(&b)
        .expect("the Newton–Euler system is regular");
    out[0] = z[iv];
    out[1] = z[ipsi(0)];
    for i in 1..nu {
        out[2 * i] = z[ipsi(i)] - z[ipsi(i - 1)];
        out[2 * i + 1] = x[2 * i];
    }
    let lateral_accelerations = acc_c
        .iter()
        .enumerate()
        .map(|(i, (acc, _, _))| {
            let a = acc
                .coef
                .iter()
                .zip(z.iter())
                .fold(acc.known, |s, (c, z)| s + c * *z);
            a.dot(&frames[i].1)
        })
        .collect();
    Oracle {
        dx: out,
        lambda: z[il],
        kinetic_energy,
        lateral_accelerations,
    }
}

// ---------------------------------------------------------------------------------------
// helpers
// ---------------------------------------------------------------------------------------

fn random_point<const N: usize>(
    rng: &mut ChaCha8Rng,
    units: usize,
) -> (SVector<f64, N>, Inputs, f64, f64) {
    let mut x = SVector::<f64, N>::zeros();
    x[0] = rng.random_range(-2.0..2.0);
    x[1] = rng.random_range(-0.5..0.5);
    for i in 1..units {
        x[2 * i] = rng.random_range(-1.0..1.0);
        x[2 * i + 1] = rng.random_range(-0.5..0.5);
    }
    for k in 2 * units..N {
        x[k] = rng.random_range(-0.1..0.1);
    }
    let u = Inputs {
        steering_angle: rng.random_range(-0.05..0.05),
        speed: rng.random_range(10.0..40.0),
        acceleration: rng.random_range(-2.0..2.0),
    };
    let psi = rng.random_range(-3.0..3.0);
    let yaw_moment = rng.random_range(-5e3..5e3);
    (x, u, psi, yaw_moment)
}

fn rel_err<const N: usize>(a: &SVector<f64, N>, b: &SVector<f64, N>) -> f64 {
    (a - b).amax() / b.amax().max(1e-300)
}

fn newton_euler_agreement<const N: usize>(spec: &ChainSpec, seed: u64, stiffness: &[f64]) -> f64 {
    let mut model = ChainModel::<N>::new(spec).expect("the chain builds");
    for (i, &k) in stiffness.iter().enumerate() {
        model = model.with_coupling_stiffness(i + 1, k);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut worst: f64 = 0.0;
    for _ in 0..200 {
        let (x, u, psi, m) = random_point::<N>(&mut rng, model.units());
        let ours = model.rhs_with_yaw_moment(&x, &u, m);
        let theirs = newton_euler(&model, &x, &u, psi, m, true, stiffness).dx;
        worst = worst.max(rel_err(&ours, &theirs));
    }
    worst
}

// ---------------------------------------------------------------------------------------
// checks
// ---------------------------------------------------------------------------------------

/// Each unit's motion ([`ChainModel::unit_motions`]: the kinematic recursion from the
/// generalised accelerations) against the Newton–Euler oracle's centre-of-gravity
/// accelerations, 200 random states per chain: agreement to 1e-10 of the largest value (the
/// two are independent formulations; their rounding differs at 1e-14).
fn unit_motion_agreement<const N: usize>(spec: &ChainSpec, seed: u64) -> f64 {
    let model = ChainModel::<N>::new(spec).expect("the chain builds");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut worst: f64 = 0.0;
    let mut motions = [UnitMotion::default(); 5];
    for _ in 0..200 {
        let (x, u, psi, _) = random_point::<N>(&mut rng, model.units());
        model.unit_motions(&x, &u, &mut motions);
        let oracle = newton_euler(&model, &x, &u, psi, 0.0, true, &[]);
        let scale = oracle
            .lateral_accelerations
            .iter()
            .fold(1e-300_f64, |m, a| m.max(a.abs()));
        let mut heading = 0.0;
        let mut rate = x[1];
        for (i, (m, a)) in motions
            .iter()
            .zip(&oracle.lateral_accelerations)
            .enumerate()
        {
            if i >= 1 {
                heading += x[2 * i + 1];
                rate += x[2 * i];
            }
            worst = worst.max((m.lateral_acceleration_mps2 - a).abs() / scale);
            assert_eq!(m.relative_heading_rad, heading);
            assert!((m.yaw_rate_rad_s - rate).abs() <= 1e-15 * rate.abs().max(1.0));
        }
    }
    worst
}

#[test]
fn unit_motions_equal_newton_euler() {
    let two = table_i_chain(vec![]);
    assert!(unit_motion_agreement::<4>(&two, 11) < 1e-10);
    assert!(unit_motion_agreement::<8>(&three_units(), 12) < 1e-10);
    assert!(unit_motion_agreement::<10>(&four_units(), 13) < 1e-10);
}

/// [`ChainModel::point_position`] of every axle against the geometry walked by hand: the
/// coupling H_{i+1} = H_i − ρ_i E1_i (ρ behind positive), an axle of a towed unit at
/// H_i − ℓ E1_i, of the towing unit at H_1 + a E1_0.
#[test]
fn point_positions_follow_the_couplings() {
    let spec = four_units();
    let model = ChainModel::<10>::new(&spec).expect("the chain builds");
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for _ in 0..50 {
        let (x, _, psi, _) = random_point::<10>(&mut rng, model.units());
        let pose = Pose {
            heading_rad: psi,
            x_m: rng.random_range(-50.0..50.0),
            y_m: rng.random_range(-50.0..50.0),
        };
        let hitch = Vector2::new(pose.x_m, pose.y_m);
        for (k, a) in model.axles().iter().enumerate() {
            let expected = if a.unit == 0 {
                hitch + heading_vector(psi) * a.position_m
            } else {
                let mut h = hitch;
                let mut angle = psi;
                for i in 1..=a.unit {
                    angle += x[2 * i + 1];
                    if i < a.unit {
                        h -= heading_vector(angle)
                            * spec.towed_units()[i - 1].rear_coupling.unwrap();
                    }
                }
                h - heading_vector(angle) * a.position_m
            };
            let got = model.point_position(&x, &pose, a.unit, model.axle_coordinate(k));
            assert!(
                (Vector2::new(got[0], got[1]) - expected).amax() < 1e-12,
                "axle {k}: {got:?} against {expected:?}"
            );
        }
    }
}

fn heading_vector(angle: f64) -> Vector2<f64> {
    heading(angle).0
}

#[test]
fn newton_euler_two_units() {
    // Table I, and Table I with relaxation on every axle and a damped friction hitch
    let e1 = newton_euler_agreement::<4>(&table_i_chain(vec![]), 1, &[]);
    let mut v = VehicleSpec::table_i_with_relaxation(0.3);
    v.hitch = HitchSpec {
        yaw_damping_nms: 500.0,
        friction_torque_nm: 300.0,
        friction_regularisation_rad_s: 0.05,
    };
    let e2 = newton_euler_agreement::<7>(&ChainSpec::from(&v), 2, &[]);
    println!("Newton–Euler, 2 units: max rel. error {e1:.2e} (Table I), {e2:.2e} (variants)");
    assert!(e1 < 1e-10 && e2 < 1e-10, "{e1:e} {e2:e}");
}

#[test]
fn newton_euler_three_units() {
    let spec = three_units();
    assert_eq!(spec.states().unwrap(), 8);
    let e = newton_euler_agreement::<8>(&spec, 3, &[]);
    // with torsional springs at the couplings
    let es = newton_euler_agreement::<8>(&spec, 33, &[2e4, 5e3]);
    println!("Newton–Euler, 3 units: max rel. error {e:.2e}, with coupling springs {es:.2e}");
    assert!(e < 1e-10 && es < 1e-10, "{e:e} {es:e}");
}

#[test]
fn newton_euler_four_units() {
    let spec = four_units();
    assert_eq!(spec.states().unwrap(), 10);
    let e = newton_euler_agreement::<10>(&spec, 4, &[]);
    println!("Newton–Euler, 4 units: max rel. error {e:.2e}");
    assert!(e < 1e-10, "{e:e}");
}

/// Today's state [σ1, σ2, σ3, θ] (eq. 4) from the chain's [v, r, θ̇, θ], and the derivative
/// map (the time derivative of eq. 4).
fn to_appellian<const N: usize>(
    p: &VehicleParams,
    x: &SVector<f64, N>,
    dx: &SVector<f64, N>,
) -> (SVector<f64, N>, SVector<f64, N>) {
    let (m1, j1, d) = (p.tractor.mass, p.tractor.yaw_inertia, p.tractor.cog);
    let (m2, j2, h) = (p.trailer.mass, p.trailer.yaw_inertia, p.trailer.cog);
    let (k1, k2) = (m1 * d / (j1 + m1 * d * d), m2 * h / (j2 + m2 * h * h));
    let (v, r, w, th) = (x[0], x[1], x[2], x[3]);
    let (vd, rd, wd) = (dx[0], dx[1], dx[2]);
    let mut s = *x;
    s[0] = v;
    s[1] = r + k1 * v;
    s[2] = r + w - k2 * v * th.cos();
    s[3] = th;
    let mut sd = *dx;
    sd[0] = vd;
    sd[1] = rd + k1 * vd;
    sd[2] = rd + wd - k2 * (vd * th.cos() - v * th.sin() * w);
    sd[3] = w;
    (s, sd)
}

#[test]
fn two_units_equal_todays_models() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    // the paper's model (Plant<4> of Model)
    let params = VehicleParams::default();
    let paper = Model::new(params).unwrap();
    let chain = ChainModel::<4>::new(&ChainSpec::from(&VehicleSpec::from(params))).unwrap();
    let mut worst_paper: f64 = 0.0;
    for _ in 0..500 {
        let (x, u, _, m) = random_point::<4>(&mut rng, 2);
        let (s, sd) = to_appellian(&params, &x, &chain.rhs_with_yaw_moment(&x, &u, m));
        let today = Plant::<4>::rhs_with_yaw_moment(&paper, &s, &u, m);
        worst_paper = worst_paper.max(rel_err(&sd, &today));
    }
    // the variants: relaxation on every axle, a damped friction hitch
    let mut v = VehicleSpec::table_i_with_relaxation(0.3);
    v.hitch = HitchSpec {
        yaw_damping_nms: 500.0,
        friction_torque_nm: 300.0,
        friction_regularisation_rad_s: 0.05,
    };
    let general = VehicleModel::<7>::new(&v).unwrap();
    let chain7 = ChainModel::<7>::new(&ChainSpec::from(&v)).unwrap();
    let mut worst_general: f64 = 0.0;
    for _ in 0..500 {
        let (x, u, _, m) = random_point::<7>(&mut rng, 2);
        let (s, sd) = to_appellian(&params, &x, &chain7.rhs_with_yaw_moment(&x, &u, m));
        let today = general.rhs_with_yaw_moment(&s, &u, m);
        worst_general = worst_general.max(rel_err(&sd, &today));
    }
    println!(
        "two units vs today: max rel. error {worst_paper:.2e} (Model), {worst_general:.2e} (VehicleModel<7>)"
    );
    assert!(worst_paper < 1e-12, "{worst_paper:e}");
    assert!(worst_general < 1e-12, "{worst_general:e}");

    // the same V_crit
    let opts = CriticalSpeedOptions::default();
    let today = Plant::<4>::critical_speed(&paper, &opts)
        .unwrap()
        .v_crit_mps;
    let ours = chain.critical_speed(&opts).unwrap().v_crit_mps;
    let today7 = general.critical_speed(&opts).unwrap().v_crit_mps;
    let ours7 = chain7.critical_speed(&opts).unwrap().v_crit_mps;
    println!(
        "V_crit: {ours:.10} vs {today:.10} m/s (rel. {:.1e}); relaxing {ours7:.10} vs {today7:.10} m/s (rel. {:.1e})",
        ((ours - today) / today).abs(),
        ((ours7 - today7) / today7).abs()
    );
    assert!(((ours - today) / today).abs() < 1e-8);
    assert!(((ours7 - today7) / today7).abs() < 1e-8);
}

#[test]
fn a_vanishing_last_unit_leaves_v_crit() {
    // a third unit with mass, inertia and cornering stiffness scaled by ε: its own mode is
    // that of a trailer towed on a straight path (stable at every speed, its eigenvalues
    // independent of ε), its effect on the first two units O(ε) (its coupling force, and
    // its ε-load on the second unit's axle). The tolerance 1e-8 is this O(ε) = O(1e-9)
    // perturbation of V_crit with a margin, well above the bisection's 1e-11 m/s bracket and
    // the eigenvalues' round-off (~1e-13 relative).
    let eps = 1e-9;
    let tiny = unit(800.0 * eps, 1000.0 * eps, 2.0, 2.5, 40e3 * eps);
    let three = ChainModel::<6>::new(&table_i_chain(vec![tiny])).unwrap();
    let two = ChainModel::<4>::new(&table_i_chain(vec![])).unwrap();
    let opts = CriticalSpeedOptions::default();
    let v3 = three.critical_speed(&opts).unwrap().v_crit_mps;
    let v2 = two.critical_speed(&opts).unwrap().v_crit_mps;
    let rel = ((v3 - v2) / v2).abs();
    println!("collapse: V_crit {v3:.12} (3 units) vs {v2:.12} (2 units), rel. {rel:.2e}");
    assert!(rel < 1e-8, "{rel:e}");
}

/// The linear single-track equations of one rigid body made of the towing unit and the
/// first towed unit at θ = 0 (state [v, r], v the lateral velocity of the coupling), with the
/// axles' cornering stiffnesses: M (v̇ + x_G ṙ + V r) = ΣF, I_G ṙ = Σ (x_j − x_G) F_j,
/// F_j = −C_j (v + x_j r)/V.
fn rigid_body_matrix(spec: &ChainSpec, speed: f64) -> SMatrix<f64, 2, 2> {
    let t = &spec.tractor;
    let r = &spec.towed_units()[0];
    let m = t.mass + r.mass;
    let xg = (t.mass * t.cog - r.mass * r.cog) / m;
    let ig = t.yaw_inertia
        + t.mass * (t.cog - xg).powi(2)
        + r.yaw_inertia
        + r.mass * (-r.cog - xg).powi(2);
    let axles: Vec<(f64, f64)> = spec
        .resolved_axles()
        .unwrap()
        .iter()
        .map(|a| {
            let x = if a.unit == 0 {
                a.spec.position_m
            } else {
                -a.spec.position_m
            };
            (x, a.spec.cornering_stiffness)
        })
        .collect();
    // ΣF = a_v v + a_r r, moment = b_v v + b_r r
    let (mut fv, mut fr, mut mv, mut mr) = (0.0, 0.0, 0.0, 0.0);
    for &(x, c) in &axles {
        fv -= c / speed;
        fr -= c * x / speed;
        mv -= c * (x - xg) / speed;
        mr -= c * x * (x - xg) / speed;
    }
    let rd_v = mv / ig;
    let rd_r = mr / ig;
    // v̇ = ΣF/M − V r − x_G ṙ
    SMatrix::<f64, 2, 2>::new(fv / m - xg * rd_v, fr / m - speed - xg * rd_r, rd_v, rd_r)
}

#[test]
fn a_locked_coupling_makes_one_body() {
    // a torsional spring k at the coupling: as k → ∞ two eigenvalues of A(V) tend to those
    // of the rigid body, the other two (±i√(k/I)) leave; the difference falls as 1/k
    let spec = table_i_chain(vec![]);
    let speed = 20.0;
    let rigid = rigid_body_matrix(&spec, speed).complex_eigenvalues();
    let mut errors = Vec::new();
    for k in [1e8, 1e9, 1e10] {
        let model = ChainModel::<4>::new(&spec)
            .unwrap()
            .with_coupling_stiffness(1, k);
        let spectrum = model.open_loop_spectrum(speed);
        let mut worst: f64 = 0.0;
        for l in rigid.iter() {
            let nearest = spectrum
                .iter()
                .map(|m| (m - l).norm())
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(nearest / l.norm());
        }
        errors.push(worst);
    }
    println!(
        "rigid lock: rigid-body eigenvalues {rigid:?}, rel. distance {errors:?} for k = 1e8, 1e9, 1e10 N m/rad"
    );
    assert!(errors[2] < 1e-4, "{errors:?}");
    assert!(errors[2] < errors[1] / 5.0 && errors[1] < errors[0] / 5.0);
}

/// One RK4 step of the chain's reduced system plus the quadrature of the constraint power
/// λ V (from the oracle) as an extra state.
fn rk4_step<const N: usize>(
    model: &ChainModel<N>,
    x: &SVector<f64, N>,
    work: f64,
    u: &Inputs,
    h: f64,
) -> (SVector<f64, N>, f64) {
    let f = |x: &SVector<f64, N>| {
        let lambda = newton_euler(model, x, u, 0.0, 0.0, false, &[]).lambda;
        (model.rhs(x, u), lambda * u.speed)
    };
    let (k1, p1) = f(x);
    let (k2, p2) = f(&(x + k1 * (h / 2.0)));
    let (k3, p3) = f(&(x + k2 * (h / 2.0)));
    let (k4, p4) = f(&(x + k3 * h));
    (
        x + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0),
        work + (p1 + 2.0 * p2 + 2.0 * p3 + p4) * h / 6.0,
    )
}

/// |T(t) − T(0) − W(t)| / T(0) over a free run of `duration` s with step h (W the work of the
/// constraint force).
/// and the largest |T(t) − T(0)| / T(0) (without the work).
fn energy_drift<const N: usize>(
    model: &ChainModel<N>,
    x0: &SVector<f64, N>,
    u: &Inputs,
    h: f64,
    duration: f64,
) -> (f64, f64) {
    let t0 = newton_euler(model, x0, u, 0.0, 0.0, false, &[]).kinetic_energy;
    let (mut x, mut w) = (*x0, 0.0);
    let (mut worst, mut change): (f64, f64) = (0.0, 0.0);
    for _ in 0..(duration / h).round() as usize {
        (x, w) = rk4_step(model, &x, w, u, h);
        let t = newton_euler(model, &x, u, 0.0, 0.0, false, &[]).kinetic_energy;
        worst = worst.max((t - t0 - w).abs() / t0);
        change = change.max((t - t0).abs() / t0);
    }
    (worst, change)
}

#[test]
fn kinetic_energy_of_the_free_chain() {
    // no tyres, no damping. At V = 0 the constraint v_H1·E1_0 = 0 is workless and T is
    // conserved; at V ≠ 0 the constraint force does work λ V (T alone is NOT conserved: a
    // free unit yawing at r with v̇ = −V r gains energy), and T − T(0) = ∫ λ V dt.
    let mut spec = three_units();
    spec.tractor.front_relaxation_length_m = None;
    for t in spec.trailers.iter_mut() {
        t.hitch = None;
        t.relaxation_length_m = None;
    }
    let model = ChainModel::<6>::new(&spec).unwrap().without_tyre_forces();
    let x0 = SVector::<f64, 6>::from_column_slice(&[0.4, 0.3, -0.8, 0.2, 0.6, -0.3]);
    // RK4: global error O(h⁴); with the motion's time scales τ ~ 0.5 s and h = 2 ms,
    // (h/τ)⁴ ≈ 3e-10 per unit time, so 1e-8 over 4 s is the integrator's bound with a margin
    // (measured: ~5e-14, and halving h divides the drift by 15–16 ≈ 2⁴)
    for speed in [0.0, 15.0] {
        let u = Inputs::constant_speed(speed);
        let (coarse, _) = energy_drift(&model, &x0, &u, 4e-3, 4.0);
        let (fine, change) = energy_drift(&model, &x0, &u, 2e-3, 4.0);
        println!(
            "energy, V = {speed} m/s: drift of T − T(0) − W {coarse:.2e} (h = 4 ms), {fine:.2e} (h = 2 ms), ratio {:.1}; T itself changes by up to {change:.2e} T(0)",
            coarse / fine
        );
        if speed > 0.0 {
            // the constraint's work is not negligible: T alone is not a conserved quantity
            assert!(change > 1e-3, "{change:e}");
        }
        assert!(fine < 1e-8, "{fine:e}");
        // the drift is the integrator's: halving h divides it by ~2⁴ (unless at round-off)
        assert!(fine < 1e-13 || coarse / fine > 10.0, "{coarse:e} {fine:e}");
    }
}

#[test]
fn jacobian_equals_finite_differences() {
    fn check<const N: usize>(spec: &ChainSpec, seed: u64) -> f64 {
        let model = ChainModel::<N>::new(spec).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut worst: f64 = 0.0;
        for _ in 0..20 {
            let (x, u, _, _) = random_point::<N>(&mut rng, model.units());
            let (a, b) = model.jacobian(&x, &u);
            let mut fd = SMatrix::<f64, N, N>::zeros();
            for k in 0..N {
                let h = 1e-6 * x[k].abs().max(1.0);
                let mut xp = x;
                let mut xm = x;
                xp[k] += h;
                xm[k] -= h;
                let col = (model.rhs(&xp, &u) - model.rhs(&xm, &u)) / (2.0 * h);
                fd.set_column(k, &col);
            }
            let h = 1e-7;
            let up = Inputs {
                steering_angle: u.steering_angle + h,
                ..u
            };
            let um = Inputs {
                steering_angle: u.steering_angle - h,
                ..u
            };
            let fd_b = (model.rhs(&x, &up) - model.rhs(&x, &um)) / (2.0 * h);
            worst = worst
                .max((a - fd).amax() / a.amax())
                .max((b - fd_b).amax() / b.amax());
        }
        worst
    }
    let e2 = check::<4>(&table_i_chain(vec![]), 7);
    let e3 = check::<8>(&three_units(), 8);
    let e4 = check::<10>(&four_units(), 9);
    println!("Jacobian vs central differences: {e2:.2e}, {e3:.2e}, {e4:.2e} (2, 3, 4 units)");
    assert!(e2.max(e3).max(e4) < 1e-6);
}

#[test]
fn the_file_form() {
    // the one-trailer form with [hitch] is today's file
    let today = r#"
        [tractor]
        mass = 2400.0
        yaw_inertia = 7647.0
        front_axle = 5.15
        cog = 3.25
        rear_axle = 1.35
        front_cornering_stiffness = 137e3
        rear_cornering_stiffness = 256e3
        [trailer]
        mass = 985.0
        yaw_inertia = 1416.0
        cog = 2.9
        axle = 2.8
        cornering_stiffness = 50e3
        [hitch]
        yaw_damping_nms = 100.0
        [friction]
        mu_static = 0.9
        mu_dynamic = 0.6
    "#;
    let chain: ChainSpec = toml::from_str(today).unwrap();
    let vehicle: VehicleSpec = toml::from_str(today).unwrap();
    assert_eq!(chain, ChainSpec::from(&vehicle));
    chain.validate().unwrap();
    assert_eq!(chain.coupling(0).1, "hitch");
    // loads: today's for one towed unit
    let (loads, _) = chain.static_loads().unwrap();
    assert_eq!(loads, vehicle.axle_loads().unwrap());
    // round trip of the chain form
    let four = four_units();
    four.validate().unwrap();
    let back: ChainSpec = toml::from_str(&toml::to_string(&four).unwrap()).unwrap();
    assert_eq!(back, four);
    // loads balance the weight
    let (loads, _) = four.static_loads().unwrap();
    let weight = (four.tractor.mass + four.trailers.iter().map(|t| t.mass).sum::<f64>()) * 9.81;
    assert!((loads.iter().sum::<f64>() - weight).abs() < 1e-9 * weight);

    // errors name the key
    let key_of = |s: &ChainSpec| match s.validate() {
        Err(trailer_model::ModelError::InvalidSpec { key, .. }) => key,
        other => panic!("{other:?}"),
    };
    let mut s = four_units();
    s.trailers[1].rear_coupling = None;
    assert_eq!(key_of(&s), "trailers[1].rear_coupling");
    let mut s = four_units();
    s.trailers[2].rear_coupling = Some(1.0);
    assert_eq!(key_of(&s), "trailers[2].rear_coupling");
    let mut s = four_units();
    s.trailers[2].cog = -1.0;
    assert_eq!(key_of(&s), "trailers[2].cog");
    let mut s = four_units();
    s.hitch = Some(HitchSpec::default());
    assert_eq!(key_of(&s), "hitch");
    let mut s = four_units();
    s.trailers[1].hitch = Some(HitchSpec {
        yaw_damping_nms: -1.0,
        ..HitchSpec::default()
    });
    assert_eq!(key_of(&s), "trailers[1].hitch.yaw_damping_nms");
    let mut s = four_units();
    s.trailers[0].axles.as_mut().unwrap()[1].position_m = 8.1;
    assert_eq!(key_of(&s), "trailers[0].axles[1].position_m");
    assert!(
        toml::from_str::<ChainSpec>(&today.replace("[hitch]", "[hitch]\nstiffness = 1.0")).is_err()
    );
    // the state count is checked
    assert!(matches!(
        ChainModel::<9>::new(&four_units()),
        Err(trailer_model::ModelError::StateCount { expected: 10, .. })
    ));
}

#[test]
fn two_units_plant_functions_equal_todays() {
    // switching functions and validity guard of the 2-unit chain are VehicleModel's
    let mut v = VehicleSpec::table_i_with_relaxation(0.3);
    v.hitch = HitchSpec {
        yaw_damping_nms: 500.0,
        friction_torque_nm: 300.0,
        friction_regularisation_rad_s: 0.05,
    };
    v.trailer.as_mut().unwrap().relaxation_length_m = None; // one instantaneous axle, two relaxing ones
    let params = v.equivalent_params().unwrap();
    let general = VehicleModel::<6>::new(&v).unwrap();
    let chain = ChainModel::<6>::new(&ChainSpec::from(&v)).unwrap();
    assert_eq!(chain.switching_kinds(), general.switching_kinds());
    assert_eq!(Plant::<6>::params(&chain), general.params());
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = chain.switching_kinds().len();
    let (mut g1, mut g2) = (vec![0.0; n], vec![0.0; n]);
    let mut worst: f64 = 0.0;
    for _ in 0..200 {
        let (x, u, _, _) = random_point::<6>(&mut rng, 2);
        let (s, _) = to_appellian(&params, &x, &x);
        chain.switching_functions(&x, &u, &mut g1);
        general.switching_functions(&s, &u, &mut g2);
        for (a, b) in g1.iter().zip(&g2) {
            worst = worst.max((a - b).abs() / b.abs().max(1e-3));
        }
        let (ga, gb) = (chain.guard_values(&x, &u), general.guard_values(&s, &u));
        for (a, b) in ga.iter().zip(&gb) {
            if a.is_finite() || b.is_finite() {
                worst = worst.max((a - b).abs() / b.abs().max(1e-3));
            }
        }
        assert_eq!(
            chain.trailer_longitudinal_speed(&x, u.speed),
            general.trailer_longitudinal_speed(&s, u.speed)
        );
    }
    println!("switching functions and guard vs VehicleModel<6>: max rel. error {worst:.2e}");
    assert!(worst < 1e-12, "{worst:e}");
}

// ---------------------------------------------------------------------------------------
// the chain as a vehicle file's model (VehicleSpec with `trailers`, VehicleModel<N>)
// ---------------------------------------------------------------------------------------

/// A chain's vehicle file as [`VehicleSpec`] (`[[trailers]]`).
fn as_vehicle_spec(c: &ChainSpec) -> VehicleSpec {
    VehicleSpec {
        tractor: c.tractor.clone(),
        trailer: None,
        trailers: c.towed_units().to_vec(),
        friction: c.friction,
        gravity: c.gravity,
        hitch: HitchSpec::default(),
    }
}

#[test]
fn a_one_unit_chain_file_is_todays_model_in_its_layout() {
    // Table I with σ = 0.3 m and a damped friction hitch, written as `[[trailers]]` with
    // one unit: VehicleModel's chain equations in the paper's layout (eq. 4 of the first
    // articulation) against today's two-unit equations, on random states
    let mut today_spec = VehicleSpec::table_i_with_relaxation(0.3);
    let hitch = HitchSpec {
        yaw_damping_nms: 500.0,
        friction_torque_nm: 300.0,
        friction_regularisation_rad_s: 0.05,
    };
    today_spec.hitch = hitch;
    let mut chain_spec = today_spec.clone();
    let mut unit = TowedUnitSpec::from(chain_spec.trailer.as_ref().unwrap());
    unit.hitch = Some(hitch);
    chain_spec.trailer = None;
    chain_spec.trailers = vec![unit];
    chain_spec.hitch = HitchSpec::default();
    assert!(chain_spec.is_chain());
    let today = VehicleModel::<7>::new(&today_spec).unwrap();
    let chain = VehicleModel::<7>::new(&chain_spec).unwrap();
    assert!(chain.chain().is_some() && today.chain().is_none());
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut worst: f64 = 0.0;
    for _ in 0..500 {
        // random states in the paper's layout
        let (mut x, u, _, m) = random_point::<7>(&mut rng, 2);
        x[2] = rng.random_range(-1.0..1.0);
        let a = chain.rhs_with_yaw_moment(&x, &u, m);
        let b = today.rhs_with_yaw_moment(&x, &u, m);
        worst = worst.max(rel_err(&a, &b));
        assert!((chain.yaw_rate(&x) - today.yaw_rate(&x)).abs() < 1e-14);
        assert!((chain.hitch_angle_rate(&x) - today.hitch_angle_rate(&x)).abs() < 1e-13);
    }
    println!("one-unit chain file vs today's VehicleModel<7>: max rel. error {worst:.2e}");
    assert!(worst < 1e-12, "{worst:e}");
    let opts = CriticalSpeedOptions::default();
    let (vc, vt) = (
        chain.critical_speed(&opts).unwrap().v_crit_mps,
        today.critical_speed(&opts).unwrap().v_crit_mps,
    );
    assert!(((vc - vt) / vt).abs() < 1e-9, "{vc} vs {vt}");
    // the same paper form (the towing unit with the first towed unit)
    assert_eq!(chain.params(), today.params());
}

#[test]
fn a_chain_file_is_the_chain_model_in_the_papers_layout() {
    let spec = three_units();
    let vspec = as_vehicle_spec(&spec);
    const N: usize = 8; // 3 units, σ on two axles
    let model = VehicleModel::<N>::new(&vspec).unwrap();
    let chain = ChainModel::<N>::new(&spec).unwrap();
    let p = *chain.params();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut worst: f64 = 0.0;
    for _ in 0..300 {
        let (y, u, _, m) = random_point::<N>(&mut rng, 3);
        let (x, dx) = to_appellian(&p, &y, &chain.rhs_with_yaw_moment(&y, &u, m));
        worst = worst.max(rel_err(&model.rhs_with_yaw_moment(&x, &u, m), &dx));
        // the guard and switching functions see the same vehicle
        assert_eq!(model.guard_values(&x, &u).map(|g| (g * 1e9).round()), {
            chain.guard_values(&y, &u).map(|g| (g * 1e9).round())
        });
    }
    println!("chain file (VehicleModel<8>) vs ChainModel<8>: max rel. error {worst:.2e}");
    assert!(worst < 1e-12, "{worst:e}");
    let opts = CriticalSpeedOptions::default();
    let (a, b) = (
        model.critical_speed(&opts).unwrap().v_crit_mps,
        chain.critical_speed(&opts).unwrap().v_crit_mps,
    );
    assert!(((a - b) / b).abs() < 1e-9, "{a} vs {b}");
    // AnyVehicleModel picks N = 2·3 + 2 and the same V_crit
    let any = trailer_model::AnyVehicleModel::new(&vspec).unwrap();
    assert_eq!(any.states(), N);
    let c = trailer_model::with_plant!(&any, m => m.critical_speed(&opts)).unwrap();
    assert_eq!(c.v_crit_mps.to_bits(), a.to_bits());
}

#[test]
fn too_many_states_for_any_vehicle_model() {
    // 5 towed units (6 units, 12 states) exceed MAX_STATES = 10: an error, not a panic
    let extra = (0..4)
        .map(|_| unit(500.0, 500.0, 1.8, 2.0, 30e3))
        .collect::<Vec<_>>();
    let vspec = as_vehicle_spec(&table_i_chain(extra));
    vspec.validate().unwrap();
    let e = trailer_model::AnyVehicleModel::new(&vspec).unwrap_err();
    assert!(e.to_string().contains("12 states"), "{e}");
}
