//! Test oracle: the same mechanics written from scratch as Newton–Euler equations with
//! the hitch force and the longitudinal constraint force solved for: an independent
//! formulation is the guard against the next typo in the equations of motion.
#![allow(dead_code)]

use nalgebra::{SMatrix, SVector, Vector2};
use tires::TireModel;
use trailer_model::{Inputs, Model, State4};

/// Right-hand side [σ̇1, σ̇2, σ̇3, θ̇] from Newton–Euler in the inertial frame at heading ψ.
///
/// Unknowns z = [σ̇1, ψ̈, ψ̈2, P_x, P_y, λ]: hitch force P of the trailer on the tractor,
/// longitudinal constraint force λ along the tractor axis (it enforces V(t), eq. 3, and
/// produces no moment about C1 since it acts along the axis through C1).
pub fn newton_euler(model: &Model, x: &State4, u: &Inputs, psi: f64) -> State4 {
    newton_euler_with_yaw_moment(model, x, u, psi, 0.0)
}

/// [`newton_euler`] with an external yaw moment `yaw_moment` \[N m\] on the tractor (a free
/// moment: it enters the tractor's rotation about C1 and nothing else).
pub fn newton_euler_with_yaw_moment(
    model: &Model,
    x: &State4,
    u: &Inputs,
    psi: f64,
    yaw_moment: f64,
) -> State4 {
    newton_euler_with_loads(model, x, u, psi, yaw_moment, 0.0)
}

/// [`newton_euler_with_yaw_moment`] with a lateral force `trailer_force` \[N\] on the
/// trailer at its centre of gravity C2, along E2 (the trailer's left, as its tyre force):
/// it enters the trailer's translation and, acting at C2, no moment about it.
pub fn newton_euler_with_loads(
    model: &Model,
    x: &State4,
    u: &Inputs,
    psi: f64,
    yaw_moment: f64,
    trailer_force: f64,
) -> State4 {
    let p = model.params();
    let (m1, j1, f, d, c) = (
        p.tractor.mass,
        p.tractor.yaw_inertia,
        p.tractor.front_axle,
        p.tractor.cog,
        p.tractor.rear_axle,
    );
    let (m2, j2, h, l) = (
        p.trailer.mass,
        p.trailer.yaw_inertia,
        p.trailer.cog,
        p.trailer.axle,
    );
    let i1 = j1 + m1 * d * d;
    let i2 = j2 + m2 * h * h;
    let (s1, s2, s3, th) = (x[0], x[1], x[2], x[3]);
    let (v, v_dot, delta) = (u.speed, u.acceleration, u.steering_angle);

    // generalized velocities from the pseudovelocities (inverse of eq. 4)
    let psi_dot = s2 - m1 * d / i1 * s1;
    let psi2 = psi + th;
    let psi2_dot = s3 + m2 * h / i2 * s1 * th.cos();
    let theta_dot = psi2_dot - psi_dot;

    let e1 = Vector2::new(psi.cos(), psi.sin());
    let e2 = Vector2::new(-psi.sin(), psi.cos());
    let big_e1 = Vector2::new(psi2.cos(), psi2.sin());
    let big_e2 = Vector2::new(-psi2.sin(), psi2.cos());
    let n_f = Vector2::new(-(psi + delta).sin(), (psi + delta).cos());
    let cross = |a: &Vector2<f64>, b: &Vector2<f64>| a.x * b.y - a.y * b.x;

    // wheel-centre velocities in the inertial frame, slip angles from their directions
    let v_h = e1 * v + e2 * s1;
    let v_f = v_h + e2 * (f * psi_dot);
    let v_r = v_h + e2 * (c * psi_dot);
    let v_t = v_h - big_e2 * (l * psi2_dot);
    let alpha_f = delta - (v_f.dot(&e2) / v_f.dot(&e1)).atan();
    let alpha_r = -(v_r.dot(&e2) / v_r.dot(&e1)).atan();
    let alpha_t = -(v_t.dot(&big_e2) / v_t.dot(&big_e1)).atan();
    let [tf, tr, tt] = model.tires();
    let (f_f, f_r, f_t) = (
        tf.lateral_force(alpha_f),
        tr.lateral_force(alpha_r),
        tt.lateral_force(alpha_t),
    );

    // known part of the accelerations
    let a_h0 = e1 * (v_dot - s1 * psi_dot) + e2 * (v * psi_dot);
    let a_c1_0 = a_h0 - e1 * (d * psi_dot * psi_dot);
    let a_c2_0 = a_h0 + big_e1 * (h * psi2_dot * psi2_dot);

    let mut m = SMatrix::<f64, 6, 6>::zeros();
    let mut rhs = SVector::<f64, 6>::zeros();
    // tractor translation: m1 (a_c1_0 + σ̇1 e2 + d ψ̈ e2) = λ e1 + F_F n_F + F_R e2 + P
    for k in 0..2 {
        m[(k, 0)] = m1 * e2[k];
        m[(k, 1)] = m1 * d * e2[k];
        m[(k, 3 + k)] = -1.0;
        m[(k, 5)] = -e1[k];
        rhs[k] = f_f * n_f[k] + f_r * e2[k] - m1 * a_c1_0[k];
    }
    // tractor rotation about C1: J1 ψ̈ = (f−d) F_F cos δ + (c−d) F_R + (−d e1) × P
    m[(2, 1)] = j1;
    m[(2, 3)] = -d * e1.y; // −(−d e1) × P, x-part: (−d e1)×P = −d(e1x Py − e1y Px)
    m[(2, 4)] = d * e1.x;
    rhs[2] = (f - d) * f_f * cross(&e1, &n_f) + (c - d) * f_r + yaw_moment;
    // trailer translation: m2 (a_c2_0 + σ̇1 e2 − h ψ̈2 E2) = F_T E2 − P
    for k in 0..2 {
        m[(3 + k, 0)] = m2 * e2[k];
        m[(3 + k, 2)] = -m2 * h * big_e2[k];
        m[(3 + k, 3 + k)] = 1.0;
        rhs[3 + k] = (f_t + trailer_force) * big_e2[k] - m2 * a_c2_0[k];
    }
    // trailer rotation about C2: J2 ψ̈2 = (h − l) F_T + (h E1) × (−P)
    m[(5, 2)] = j2;
    m[(5, 3)] = -h * big_e1.y;
    m[(5, 4)] = h * big_e1.x;
    rhs[5] = (h - l) * f_t;

    let z = m.lu().solve(&rhs).expect("Newton–Euler system is regular");
    let (s1_dot, psi_ddot, psi2_ddot) = (z[0], z[1], z[2]);
    State4::new(
        s1_dot,
        m1 * d / i1 * s1_dot + psi_ddot,
        -m2 * h / i2 * (s1_dot * th.cos() - s1 * th.sin() * theta_dot) + psi2_ddot,
        theta_dot,
    )
}

/// The Newton–Euler oracle for the model variants ([`trailer_model::VehicleModel`]):
/// any axles per unit with their own tyre laws, steered tractor axles, the first-order slip
/// lag of relaxing axles (α̇′ = V_x (α − α′)/σ with V_x the wheel centre's velocity along
/// its unit's axis and α from the wheel centre's inertial velocity), a yaw moment on the
/// tractor and the hitch torque T_h = c_h θ̇ + M_c·clamp(θ̇/ω_c, −1, 1) (on the tractor,
/// −T_h on the trailer). Returns the N derivatives [σ̇1, σ̇2, σ̇3, θ̇, α̇′…].
pub fn newton_euler_general<const N: usize>(
    model: &trailer_model::VehicleModel<N>,
    x: &SVector<f64, N>,
    u: &Inputs,
    psi: f64,
    yaw_moment: f64,
) -> SVector<f64, N> {
    use trailer_model::{Plant, Unit};
    let p = model.params();
    let (m1, j1, d) = (p.tractor.mass, p.tractor.yaw_inertia, p.tractor.cog);
    let (m2, j2, h) = (p.trailer.mass, p.trailer.yaw_inertia, p.trailer.cog);
    let i1 = j1 + m1 * d * d;
    let i2 = j2 + m2 * h * h;
    let (s1, s2, s3, th) = (x[0], x[1], x[2], x[3]);
    let (v, v_dot, delta) = (u.speed, u.acceleration, u.steering_angle);

    let psi_dot = s2 - m1 * d / i1 * s1;
    let psi2 = psi + th;
    let psi2_dot = s3 + m2 * h / i2 * s1 * th.cos();
    let theta_dot = psi2_dot - psi_dot;

    let e1 = Vector2::new(psi.cos(), psi.sin());
    let e2 = Vector2::new(-psi.sin(), psi.cos());
    let big_e1 = Vector2::new(psi2.cos(), psi2.sin());
    let big_e2 = Vector2::new(-psi2.sin(), psi2.cos());
    let cross = |a: &Vector2<f64>, b: &Vector2<f64>| a.x * b.y - a.y * b.x;
    let v_h = e1 * v + e2 * s1;

    let mut out = SVector::<f64, N>::zeros();
    // sums of the tyre forces on each body and their moments about the centres of gravity
    let mut f_tractor = Vector2::zeros();
    let mut m_tractor = 0.0;
    let mut f_trailer = Vector2::zeros();
    let mut m_trailer = 0.0;
    for a in model.axles() {
        let (vel, long, lat, normal, arm) = match a.unit {
            Unit::Tractor => {
                let vel = v_h + e2 * (a.position_m * psi_dot);
                let ang = if a.steered { psi + delta } else { psi };
                let n = Vector2::new(-ang.sin(), ang.cos());
                (vel, e1, e2, n, (a.position_m - d) * 1.0)
            }
            Unit::Trailer => {
                let vel = v_h - big_e2 * (a.position_m * psi2_dot);
                (vel, big_e1, big_e2, big_e2, h - a.position_m)
            }
        };
        let steer = if a.steered { delta } else { 0.0 };
        let alpha = steer - (vel.dot(&lat) / vel.dot(&long)).atan();
        let force = match a.state {
            None => a.tire.lateral_force(alpha),
            Some(j) => {
                out[j] = vel.dot(&long) * (alpha - x[j]) / a.relaxation_length_m;
                a.tire.lateral_force(x[j])
            }
        };
        match a.unit {
            Unit::Tractor => {
                f_tractor += normal * force;
                // arm along e1 from C1: (a − d) e1 × F n
                m_tractor += arm * force * cross(&e1, &normal);
            }
            Unit::Trailer => {
                f_trailer += normal * force;
                // arm along E1 from C2: (h − l) E1 × F E2 = (h − l) F
                m_trailer += arm * force;
            }
        }
    }
    let hs = model.spec().hitch;
    let t_h = hs.yaw_damping_nms * theta_dot
        + hs.friction_torque_nm * (theta_dot / hs.friction_regularisation_rad_s).clamp(-1.0, 1.0);

    let a_h0 = e1 * (v_dot - s1 * psi_dot) + e2 * (v * psi_dot);
    let a_c1_0 = a_h0 - e1 * (d * psi_dot * psi_dot);
    let a_c2_0 = a_h0 + big_e1 * (h * psi2_dot * psi2_dot);

    let mut m = SMatrix::<f64, 6, 6>::zeros();
    let mut rhs = SVector::<f64, 6>::zeros();
    for k in 0..2 {
        m[(k, 0)] = m1 * e2[k];
        m[(k, 1)] = m1 * d * e2[k];
        m[(k, 3 + k)] = -1.0;
        m[(k, 5)] = -e1[k];
        rhs[k] = f_tractor[k] - m1 * a_c1_0[k];
    }
    m[(2, 1)] = j1;
    m[(2, 3)] = -d * e1.y;
    m[(2, 4)] = d * e1.x;
    rhs[2] = m_tractor + yaw_moment + t_h;
    for k in 0..2 {
        m[(3 + k, 0)] = m2 * e2[k];
        m[(3 + k, 2)] = -m2 * h * big_e2[k];
        m[(3 + k, 3 + k)] = 1.0;
        rhs[3 + k] = f_trailer[k] - m2 * a_c2_0[k];
    }
    m[(5, 2)] = j2;
    m[(5, 3)] = -h * big_e1.y;
    m[(5, 4)] = h * big_e1.x;
    rhs[5] = m_trailer - t_h;

    let z = m.lu().solve(&rhs).expect("Newton–Euler system is regular");
    let (s1_dot, psi_ddot, psi2_ddot) = (z[0], z[1], z[2]);
    out[0] = s1_dot;
    out[1] = m1 * d / i1 * s1_dot + psi_ddot;
    out[2] = -m2 * h / i2 * (s1_dot * th.cos() - s1 * th.sin() * theta_dot) + psi2_ddot;
    out[3] = theta_dot;
    out
}
