//! Actuator limits of the yaw-rate feedback (issue 10, part 2): the steering-angle
//! saturation and the rate-limited first-order actuator, on the sway cycle at 35 m/s.

mod common;

use sway::sim::{
    ActuatorLimits, Controller, KinkLandingMode, Recording, SimResult, SolverSettings,
    SpeedProfile, settle, simulate,
};
use trailer_model::State4;

const STEP: f64 = 0.01;

fn on_the_cycle() -> State4 {
    let model = common::model();
    settle(&model, 35.0, 0.1, 200.0, &SolverSettings::default()).unwrap()
}

fn run(actuator: ActuatorLimits, horizon_s: f64) -> SimResult<4> {
    let model = common::model();
    let controller = Controller::YawRateFeedback {
        gain_s: 0.1,
        delay_s: 0.2,
        on_s: 1.0,
        off_s: None,
        actuator,
    };
    let mut spec = common::spec(
        SpeedProfile::Constant { speed_mps: 35.0 },
        controller,
        horizon_s,
        1e-8,
    );
    // one landing rule for all runs (`auto` picks `exact` as soon as a limit is set), so
    // that the runs differ in the limits alone
    spec.settings.solver.kink_landing = KinkLandingMode::Exact;
    simulate::<4>(
        &model,
        &spec,
        on_the_cycle(),
        Recording::Every { step_s: STEP },
    )
    .unwrap()
}

fn max_abs_steering(r: &SimResult<4>) -> f64 {
    r.trajectory
        .iter()
        .map(|s| s.steering_angle.abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_very_large_saturation_changes_nothing_bit_for_bit() {
    // reference: the unlimited controller; clamp(x, −m, m) = x for |x| < m, so every
    // number must be identical (no tolerance)
    let free = run(ActuatorLimits::NONE, 40.0);
    let huge = run(
        ActuatorLimits {
            max_angle_deg: Some(1e6),
            ..ActuatorLimits::NONE
        },
        40.0,
    );
    assert_eq!(free.metrics, huge.metrics);
    assert_eq!(free.stats, huge.stats);
    assert_eq!(free.trajectory, huge.trajectory);
    for i in 0..4 {
        assert_eq!(free.x_end[i].to_bits(), huge.x_end[i].to_bits());
    }
}

#[test]
fn a_small_saturation_bounds_the_steering_angle() {
    // reference: δ_max itself (exact: δ is clamped before it is used or recorded); the
    // unlimited controller steers more than 4 times as far, so the limit is active
    let limit = 0.05f64.to_radians();
    let free = run(ActuatorLimits::NONE, 20.0);
    eprintln!(
        "unlimited max |δ| = {} deg",
        max_abs_steering(&free).to_degrees()
    );
    assert!(max_abs_steering(&free) > 4.0 * limit);
    let r = run(
        ActuatorLimits {
            max_angle_deg: Some(0.05),
            ..ActuatorLimits::NONE
        },
        20.0,
    );
    let m = max_abs_steering(&r);
    assert!(m <= limit, "max |δ| = {m} rad > δ_max = {limit} rad");
    assert!(m >= 0.999 * limit, "the saturation was never active: {m}");
}

#[test]
fn a_rate_limit_bounds_the_steering_rate() {
    // reference: δ̇_max = 1 deg/s; |Δδ/Δt| between samples 0.01 s apart is bounded by
    // max |δ̇| (mean value theorem) plus the error of the solver's dense output. The
    // actuator's right-hand side has corners where the clamp switches, inside steps, where
    // the order-4 interpolant is less accurate than the step's error estimate: measured
    // overshoot 1.4e-5·δ̇_max at rtol = 1e-8, tolerance 1e-4·δ̇_max. With also
    // δ_max = 0.1°: |δ| ≤ δ_max, same relative tolerance.
    let rate = 1f64.to_radians();
    for max_angle_deg in [None, Some(0.1)] {
        let r = run(
            ActuatorLimits {
                max_angle_deg,
                max_rate_deg_s: Some(1.0),
                time_constant_s: 0.05,
            },
            20.0,
        );
        let fastest = r
            .trajectory
            .windows(2)
            .map(|w| ((w[1].steering_angle - w[0].steering_angle) / (w[1].t - w[0].t)).abs())
            .fold(0.0, f64::max);
        assert!(fastest <= rate * (1.0 + 1e-4), "{fastest} > {rate}");
        assert!(
            fastest >= 0.99 * rate,
            "the rate limit was never active: {fastest}"
        );
        assert_eq!(r.trajectory[0].steering_angle, 0.0);
        if let Some(m) = max_angle_deg {
            let over = max_abs_steering(&r) / m.to_radians() - 1.0;
            eprintln!("relative overshoot of δ_max: {over:e}");
            assert!(over <= 1e-4, "{over}");
        }
    }
}

#[test]
fn a_fast_unlimited_actuator_converges_to_the_ideal_controller() {
    // reference: the ideal controller δ = −D·ψ̇(t − τ). A first-order actuator with a rate
    // limit far above the command's rate (1e4 deg/s) lags it by ≈ t_a, an O(t_a) change:
    // max |Δθ| over 10 s must fall by ≥ 5× from t_a = 1 ms to 0.1 ms (first order: 10×)
    // and be below 0.01° at 0.1 ms
    let free = run(ActuatorLimits::NONE, 10.0);
    let deviation = |ta: f64| {
        let fast = run(
            ActuatorLimits {
                max_angle_deg: None,
                max_rate_deg_s: Some(1e4),
                time_constant_s: ta,
            },
            10.0,
        );
        free.trajectory
            .iter()
            .zip(&fast.trajectory)
            .map(|(a, b)| (a.x[3] - b.x[3]).abs().to_degrees())
            .fold(0.0, f64::max)
    };
    let (coarse, fine) = (deviation(1e-3), deviation(1e-4));
    eprintln!("max |Δθ|: {coarse} deg (t_a = 1 ms), {fine} deg (0.1 ms)");
    assert!(fine * 5.0 < coarse, "{coarse} → {fine}");
    assert!(fine < 0.01, "{fine} deg");
}
