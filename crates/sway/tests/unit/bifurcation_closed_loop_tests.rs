//! The closed loop's exact derivatives against central finite differences of the next lower
//! derivative (the `continuation` crate's explicit fallbacks), at pseudo-random states away
//! from the tire curve's kinks (where the differences would straddle a jump of f'').

use continuation::Problem;
use continuation::{fd_dfdp, fd_jacobian, fd_jacobian_dp, fd_second_derivative};
use std::sync::OnceLock;
use sway::bifurcation::*;
use sway::control::{Actuator, Gains, Structure};
use trailer_model::Model;
use trailer_model::{VehicleModel, VehicleParams, VehicleSpec};

fn model() -> &'static Model {
    static M: OnceLock<Model> = OnceLock::new();
    M.get_or_init(|| Model::new(VehicleParams::default()).expect("Table I model"))
}

/// deterministic pseudo-random numbers in [−1, 1) (64-bit LCG, top 53 bits)
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        2.0 * ((self.0 >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    }
    fn vec(&mut self, n: usize, scale: &[f64]) -> Vec<f64> {
        (0..n).map(|i| scale[i % 4] * self.next()).collect()
    }
}

/// typical sway magnitudes of [σ1 (m/s), σ2 (1/s), σ3 (1/s), θ (rad)]
const SCALE: [f64; 4] = [0.8, 0.3, 0.3, 0.2];

/// the yaw moment per radian of equivalent steering (the braking gains' scale)
fn braking_scale() -> f64 {
    Actuator::DifferentialBraking.scale(model())
}

/// the controller laws: hitch gains on steering, braking alone and with the
/// hitch gains (K_θ, D_θ in steering units, scaled for braking); D and τ set per loop
fn laws() -> [(LoopLaw, f64); 3] {
    let s = braking_scale();
    let hitch = |actuator, hitch_angle, hitch_rate| {
        let gains = Gains {
            yaw_rate: 0.0,
            hitch_angle,
            hitch_rate,
        };
        LoopLaw::new(Structure::YawRateHitch, actuator, gains, 0.0)
    };
    [
        (hitch(Actuator::Steering, 0.3, -0.1), 1.0),
        (
            LoopLaw {
                actuator: Actuator::DifferentialBraking,
                ..LoopLaw::OPEN_LOOP
            },
            s,
        ),
        (hitch(Actuator::DifferentialBraking, 0.3 * s, 0.1 * s), s),
    ]
}

/// `law` with the gain D and the delay τ of one loop
fn with_feedback(law: LoopLaw, gain: f64, tau: f64) -> LoopLaw {
    LoopLaw {
        gains: Gains {
            yaw_rate: gain,
            ..law.gains
        },
        delay_s: tau,
        ..law
    }
}

/// the settings: ODE (τ = 0) and DDE (τ = 0.2 s) loops, gains of both signs and zero; then
/// the controller laws with τ = 0 and 0.2 s
fn loops() -> Vec<(ClosedLoop<'static>, Vec<f64>)> {
    let mut out = Vec::new();
    for (law, scale) in laws() {
        for (tau, gain, speed) in [(0.0, 0.1, 35.0), (0.2, 0.15, 45.0)] {
            let cl = ClosedLoop::new(model(), with_feedback(law, gain * scale, tau));
            let p = cl.parameters(speed);
            out.push((cl, p));
        }
    }
    for (tau, gain, speed) in [
        (0.0, 0.15, 35.0),
        (0.2, 0.1, 45.0),
        (0.2, -0.1, 30.0),
        (0.2, 0.0, 40.0),
        (0.4, 0.3, 60.0),
    ] {
        let fb = LoopLaw::paper(gain, tau);
        let cl = ClosedLoop::new(model(), fb);
        let p = cl.parameters(speed);
        out.push((cl, p));
    }
    out
}

/// pseudo-random stacked arguments whose slip angles are ≥ 1e-3 rad away from 0 and from
/// sliding (the brush tire's f'' jumps there; the differences step by ~1e-5)
fn smooth_states(cl: &ClosedLoop<'_>, p: &[f64], rng: &mut Lcg, count: usize) -> Vec<Vec<f64>> {
    let na = cl.n_args();
    let mut g = [0.0; 6];
    let mut out = Vec::new();
    while out.len() < count {
        let args = rng.vec(na, &SCALE);
        cl.switching(&args, p, &mut g);
        if g.iter().all(|v| v.abs() > 1e-3) {
            out.push(args);
        }
    }
    out
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// ‖exact − fd‖∞ ≤ tol·max(1, ‖exact‖∞)
fn assert_close(exact: &[f64], fd: &[f64], tol: f64, what: &str) {
    let err = exact
        .iter()
        .zip(fd)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        err <= tol * max_abs(exact).max(1.0),
        "{what}: exact {exact:?} vs differences {fd:?} (error {err:e})"
    );
}

#[test]
fn jacobian_and_parameter_derivatives_agree_with_central_differences() {
    // reference: continuation::fd_jacobian / fd_dfdp (central differences of rhs, step
    // 1e-6, truncation ~1e-12·f''' and rounding ~1e-10·|f|); tolerance 1e-6 relative
    let mut rng = Lcg(7);
    for (cl, p) in loops() {
        let na = cl.n_args();
        for args in smooth_states(&cl, &p, &mut rng, 20) {
            let (mut j, mut jfd) = (vec![0.0; 4 * na], vec![0.0; 4 * na]);
            cl.jacobian(&args, &p, &mut j);
            fd_jacobian(&cl, &args, &p, &mut jfd);
            assert_close(&j, &jfd, 1e-6, "jacobian");
            for ip in [SPEED, GAIN, DELAY] {
                let (mut d, mut dfd) = ([0.0; 4], [0.0; 4]);
                cl.dfdp(&args, &p, ip, &mut d);
                fd_dfdp(&cl, &args, &p, ip, &mut dfd);
                assert_close(&d, &dfd, 1e-6, &format!("dfdp {ip}"));
            }
        }
    }
}

#[test]
fn second_derivative_agrees_with_differences_of_the_jacobian() {
    // reference: continuation::fd_second_derivative (central differences of the exact
    // Jacobian along a, relative step 1e-5: truncation ~1e-10·f'''); tolerance 1e-6 relative
    let mut rng = Lcg(11);
    for (cl, p) in loops() {
        let na = cl.n_args();
        for args in smooth_states(&cl, &p, &mut rng, 20) {
            let a = rng.vec(na, &SCALE);
            let b = rng.vec(na, &SCALE);
            let (mut s, mut sfd, mut sba) = ([0.0; 4], [0.0; 4], [0.0; 4]);
            cl.second_derivative(&args, &p, &a, &b, &mut s).unwrap();
            fd_second_derivative(&cl, &args, &p, &a, &b, &mut sfd).unwrap();
            assert_close(&s, &sfd, 1e-6, "second derivative");
            // symmetry of the second derivative (exact up to rounding)
            cl.second_derivative(&args, &p, &b, &a, &mut sba).unwrap();
            assert_close(&s, &sba, 1e-12, "symmetry");
        }
    }
}

#[test]
fn jacobian_dp_agrees_with_differences_of_the_jacobian() {
    // reference: continuation::fd_jacobian_dp (central differences of the exact Jacobian in
    // p_ip, step 1e-6·(1 + |p|)); tolerance 1e-6 relative. The delay has none: f depends on
    // τ only through x(t − τ).
    let mut rng = Lcg(13);
    for (cl, p) in loops() {
        let na = cl.n_args();
        for args in smooth_states(&cl, &p, &mut rng, 20) {
            let a = rng.vec(na, &SCALE);
            for ip in [SPEED, GAIN, DELAY] {
                let (mut d, mut dfd) = ([0.0; 4], [0.0; 4]);
                cl.jacobian_dp(&args, &p, ip, &a, &mut d).unwrap();
                fd_jacobian_dp(&cl, &args, &p, ip, &a, &mut dfd).unwrap();
                assert_close(&d, &dfd, 1e-6, &format!("jacobian_dp {ip}"));
            }
        }
    }
}

#[test]
fn structure_does_not_switch_with_the_gain() {
    // a loop with τ > 0 is a DDE with delay p[τ] for every D (also D = 0, where the delayed
    // argument has no effect); the delay's only parameter dependence is ∂τ/∂τ = 1
    let cl = ClosedLoop::new(model(), LoopLaw::paper(0.0, 0.3));
    assert_eq!(cl.n_delays(), 1);
    let p = [40.0, 0.0, 0.3];
    assert_eq!(cl.delay(0, &p), 0.3);
    assert_eq!(
        [SPEED, GAIN, DELAY].map(|ip| cl.delay_dp(0, &p, ip)),
        [0.0, 0.0, 1.0]
    );
    let mut rng = Lcg(3);
    let mut args = rng.vec(8, &SCALE);
    let (mut f0, mut f1) = ([0.0; 4], [0.0; 4]);
    cl.rhs(&args, &p, &mut f0);
    args[4..].iter_mut().for_each(|v| *v *= 2.0);
    cl.rhs(&args, &p, &mut f1);
    assert_eq!(f0, f1);
    // the gain is read from p, not from the construction
    cl.rhs(&args, &[40.0, 0.2, 0.3], &mut f1);
    assert_ne!(f0, f1);
    assert_eq!(
        ClosedLoop::new(model(), LoopLaw::OPEN_LOOP).n_delays(),
        0,
        "τ = 0 is an ODE"
    );
}

/// The loop of a 7-state plant (σ = 0.3 m on the three axles of Table I) with each law:
/// derivatives against central differences as above (same references and tolerances).
#[test]
fn relaxation_plant_loop_derivatives_agree_with_central_differences() {
    let plant = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap();
    let scale7 = [0.8, 0.3, 0.3, 0.2, 0.05, 0.05, 0.05];
    let mut rng = Lcg(17);
    for (law, scale) in laws().into_iter().chain([(LoopLaw::OPEN_LOOP, 1.0)]) {
        for (tau, gain, speed) in [(0.0, 0.1, 35.0), (0.2, 0.15, 45.0)] {
            let cl = ClosedLoop::new(&plant, with_feedback(law, gain * scale, tau));
            let p = cl.parameters(speed);
            let na = cl.n_args();
            let mut g = vec![0.0; cl.n_switching()];
            let mut done = 0;
            while done < 10 {
                let args: Vec<f64> = (0..na).map(|i| scale7[i % 7] * rng.next()).collect();
                cl.switching(&args, &p, &mut g);
                if g.iter().any(|v| v.abs() < 1e-3) {
                    continue;
                }
                done += 1;
                let (mut j, mut jfd) = (vec![0.0; 7 * na], vec![0.0; 7 * na]);
                cl.jacobian(&args, &p, &mut j);
                fd_jacobian(&cl, &args, &p, &mut jfd);
                assert_close(&j, &jfd, 1e-6, "jacobian (7 states)");
                let a: Vec<f64> = (0..na).map(|i| scale7[i % 7] * rng.next()).collect();
                let b: Vec<f64> = (0..na).map(|i| scale7[i % 7] * rng.next()).collect();
                let (mut s2, mut sfd) = ([0.0; 7], [0.0; 7]);
                cl.second_derivative(&args, &p, &a, &b, &mut s2).unwrap();
                fd_second_derivative(&cl, &args, &p, &a, &b, &mut sfd).unwrap();
                assert_close(&s2, &sfd, 1e-6, "second derivative (7 states)");
                for ip in [SPEED, GAIN] {
                    let (mut d, mut dfd) = ([0.0; 7], [0.0; 7]);
                    cl.dfdp(&args, &p, ip, &mut d);
                    fd_dfdp(&cl, &args, &p, ip, &mut dfd);
                    assert_close(&d, &dfd, 1e-6, "dfdp (7 states)");
                    cl.jacobian_dp(&args, &p, ip, &a, &mut d).unwrap();
                    fd_jacobian_dp(&cl, &args, &p, ip, &a, &mut dfd).unwrap();
                    assert_close(&d, &dfd, 1e-6, "jacobian_dp (7 states)");
                }
            }
        }
    }
}
