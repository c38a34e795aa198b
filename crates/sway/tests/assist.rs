//! The sway assist's co-simulation: the stepping keeps the physics, the ground truth and
//! the detectors on runs below and above V_crit, the assist's braking against the
//! mitigation's, determinism, a run that loses control.

use sway::assist::{AssistSetup, Disturbance, Intervention, Scenario, run};
use sway::sim::{EarlyStop, Recording, RunSettings, SimSpec, SpeedProfile, simulate};
use trailer_model::{Model, State4, VehicleParams};

fn model() -> Model {
    Model::new(VehicleParams::default()).unwrap()
}

fn scenario(speed_mps: f64, disturbance: Disturbance, horizon_s: f64) -> Scenario {
    Scenario {
        speed_mps,
        disturbance,
        disturbance_start_s: 1.0,
        horizon_s,
        seed: 0,
    }
}

fn impulse(amplitude_deg: f64) -> Disturbance {
    Disturbance::SteeringImpulse {
        amplitude_deg,
        duration_s: 0.4,
    }
}

/// The reference: no detector acts and no intervention, against `simulate` of the same
/// scenario (the steering impulse as the problem's input, the speed constant). Tolerance
/// 1e-6 rad on θ after 10 s: the solver's (rtol 1e-8) global error is ≈ 1e-7; the stepping
/// lands on the 1000 frame ends, which changes the step sequence, not the physics.
#[test]
fn stepping_frame_by_frame_keeps_the_physics() {
    let m = model();
    let s = scenario(30.0, impulse(2.0), 10.0);
    let setup = AssistSetup::default();
    let r = run(&m, &s, Intervention::None, &setup, true).unwrap();
    let steering = s.disturbance.steering(&m, 30.0, 1.0).unwrap();
    let spec = SimSpec {
        early_stop: EarlyStop::Never,
        steering,
        profile: SpeedProfile::Constant { speed_mps: 30.0 },
        controller: None,
        horizon_s: 10.0,
        action_s: 0.0,
        settings: RunSettings::default(),
    };
    let reference = simulate::<_, 4, 4>(
        &m,
        &spec,
        State4::zeros(),
        Recording::Every { step_s: 0.01 },
    )
    .unwrap();
    let trace = r.trace.unwrap();
    assert_eq!(trace.t.len(), 1000);
    let mut worst = 0.0f64;
    for (k, sample) in reference.trajectory.iter().take(1000).enumerate() {
        assert!((sample.t - trace.t[k]).abs() < 1e-9);
        worst = worst.max((sample.x[3].to_degrees() - trace.hitch_angle_deg[k]).abs());
    }
    assert!(worst < 1e-6f64.to_degrees(), "worst |Δθ| = {worst} deg");
    assert!(r.truth.peak_hitch_angle_deg > 1.0);
}

/// Below V_crit (Table I: 34.75 m/s) a small impulse decays: no sway, no detector flags.
#[test]
fn a_damped_impulse_below_v_crit_is_not_sway_and_not_flagged() {
    let r = run(
        &model(),
        &scenario(25.0, impulse(0.5), 20.0),
        Intervention::Assist,
        &AssistSetup::default(),
        false,
    )
    .unwrap();
    assert!(!r.sways && !r.truth.sustained_sway);
    assert!(
        r.detectors
            .iter()
            .all(|d| d.first_flag_s.is_none() && d.flags == 0)
    );
    assert_eq!(r.engaged_s, None);
    assert_eq!(r.speed_lost_mps, 0.0);
}

/// Above V_crit an impulse grows into sway; the assist ends it. Its braking alone
/// (no differential braking, fig4c's 2 m/s² with the torque cut) ends it as the
/// mitigation's braking does: a linear speed ramp of the same speed loss and deceleration
/// from the engagement (`sway::sim::simulate` with `SpeedProfile::Ramp`) settles too.
#[test]
fn above_v_crit_the_assist_ends_the_sway_as_the_mitigations_braking_does() {
    let m = model();
    let s = scenario(38.0, impulse(1.0), 30.0);
    let setup = AssistSetup::default();
    let without = run(&m, &s, Intervention::None, &setup, false).unwrap();
    assert!(without.sways, "{without:?}");
    let onset = without.truth.onset_s.unwrap();
    assert!(
        without
            .detectors
            .iter()
            .all(|d| d.first_flag_s.unwrap() > onset)
    );
    let with = run(&m, &s, Intervention::Assist, &setup, false).unwrap();
    assert!(!with.sways, "{with:?}");
    assert!(with.loss_of_control_s.is_none());
    assert!(with.truth.settle_time_s.is_some());
    assert!(with.speed_lost_mps >= setup.assist.release_speed_drop_mps);
    let mut braking = setup.clone();
    braking.assist.yaw_moment_gain_s = 0.0;
    braking.assist.target_deceleration_mps2 = 2.0;
    let b = run(&m, &s, Intervention::Assist, &braking, false).unwrap();
    let engaged = b.engaged_s.unwrap();
    let deceleration =
        braking.assist.target_deceleration_mps2 + braking.assist.torque_cut_deceleration_mps2;
    let ramp = SimSpec {
        early_stop: EarlyStop::Never,
        steering: s.disturbance.steering(&m, 38.0, 1.0).unwrap(),
        profile: SpeedProfile::Ramp {
            initial_mps: 38.0,
            change_mps: -b.speed_lost_mps,
            start_s: engaged,
            duration_s: b.speed_lost_mps / deceleration,
            shape: Default::default(),
        },
        controller: None,
        horizon_s: 30.0,
        action_s: engaged,
        settings: RunSettings::default(),
    };
    let reference = simulate::<_, 4, 4>(&m, &ramp, State4::zeros(), Recording::None).unwrap();
    eprintln!("braking only: {b:?}\nreference: {:?}", reference.metrics);
    assert!(!b.sways && b.truth.settle_time_s.is_some(), "{b:?}");
    assert_eq!(reference.metrics.class, sway::sim::SwayClass::Settled);
}

/// The same seed gives the same numbers; another seed other noise.
#[test]
fn runs_are_deterministic_in_their_seed() {
    let m = model();
    let setup = AssistSetup::default();
    let mut s = scenario(33.0, impulse(3.0), 12.0);
    let a = run(&m, &s, Intervention::Assist, &setup, false).unwrap();
    let b = run(&m, &s, Intervention::Assist, &setup, false).unwrap();
    assert_eq!(a, b);
    s.seed = 1;
    let c = run(&m, &s, Intervention::Assist, &setup, false).unwrap();
    assert_ne!(a.detectors, c.detectors);
}

/// A run that loses control ends there, as an outcome.
#[test]
fn a_run_that_loses_control_is_an_outcome() {
    let r = run(
        &model(),
        &scenario(40.0, impulse(10.0), 20.0),
        Intervention::None,
        &AssistSetup::default(),
        true,
    )
    .unwrap();
    assert!(r.sways);
    let t = r.loss_of_control_s.unwrap();
    assert!(t < 20.0 && r.loss_of_control_condition.is_some());
    assert_eq!(r.t_end_s, t);
    assert_eq!(r.truth.settle_time_s, None);
}
