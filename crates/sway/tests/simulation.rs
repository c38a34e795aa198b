//! Simulation layer: the closed-loop DDE path against the ODE path, tolerance refinement,
//! the sway amplitude, the validity guard, metrics against dense sampling, bitwise digests.
mod common;

use approx::assert_abs_diff_eq;
use common::{braking_35_to_25, model, spec, x7};
use dde::{DdeProblem, OdeProblem};
use nalgebra::SVector;
use sway::sim::{
    LoopLaw, LossOfControl, Outcome, Recording, SimProblem, SimResult, SimSpec, SolverSettings,
    SpeedProfile, ValidityGuard, settle, simulate,
};
use trailer_model::{Inputs, State4, State7};

#[test]
fn plant_rhs_matches_the_model_rhs7() {
    // reference: trailer_model's own 7-state right-hand side (eq. 5–6), written separately
    let m = model();
    let profile = braking_35_to_25(1.0, 5.0);
    let ctl = Some(LoopLaw::paper(0.1, 0.2).switched(0.5, None));
    let x = State7::from_column_slice(&[0.3, -0.05, 0.2, 0.15, 0.4, 10.0, -2.0]);
    let xd = State7::from_column_slice(&[0.1, 0.08, -0.1, 0.05, 0.3, 9.0, -1.5]);
    let plant = SimProblem::<_, 4, 7>::new(&m, &profile, ctl, x).unwrap();
    let t = 2.0;
    let mut dx = SVector::<f64, 7>::zeros();
    DdeProblem::rhs(&plant, t, &x, &[xd], &mut dx);
    let delta = -0.1 * m.yaw_rate(&State4::new(xd[0], xd[1], xd[2], xd[3]));
    let u = Inputs {
        steering_angle: delta,
        speed: 35.0 - 2.0,
        acceleration: -2.0,
    };
    let reference = m.rhs7(&x, &u);
    for i in 0..7 {
        assert_abs_diff_eq!(
            dx[i],
            reference[i],
            epsilon = 1e-12 * (1.0 + reference[i].abs())
        );
    }
    // open loop (ODE path): δ = 0
    let mut dx0 = SVector::<f64, 7>::zeros();
    OdeProblem::rhs(&plant, t, &x, &mut dx0);
    let r0 = m.rhs7(
        &x,
        &Inputs {
            steering_angle: 0.0,
            ..u
        },
    );
    for i in 0..7 {
        assert_abs_diff_eq!(dx0[i], r0[i], epsilon = 1e-12 * (1.0 + r0[i].abs()));
    }
}

#[test]
fn open_loop_equals_delay_solver_with_zero_gain() {
    // δ ≡ 0 at constant V: the ODE path and the DDE path (D = 0, τ = 0.2 s, on from t = 0)
    // solve the same equations with different step sequences (steps capped at τ, breakpoints
    // at kτ); each carries a global error of ~1e-7 at rtol 1e-10 after 2300 steps of growing
    // sway (measured largest difference 1.9e-7, in σ3), so they must agree to 1e-6
    let m = model();
    let p = SpeedProfile::Constant { speed_mps: 33.0 };
    let ode = spec(p.clone(), None, 20.0, 1e-10);
    let ctl = Some(LoopLaw::paper(0.0, 0.2));
    let dde_spec = spec(p, ctl, 20.0, 1e-10);
    let rec = Recording::Every { step_s: 0.05 };
    let a = simulate(&m, &ode, x7(8.0), rec).unwrap();
    let b = simulate(&m, &dde_spec, x7(8.0), rec).unwrap();
    assert_eq!(a.trajectory.len(), b.trajectory.len());
    for (sa, sb) in a.trajectory.iter().zip(&b.trajectory) {
        assert_eq!(sa.t, sb.t);
        for i in 0..7 {
            assert_abs_diff_eq!(sa.x[i], sb.x[i], epsilon = 1e-6 * (1.0 + sa.x[i].abs()));
        }
        assert_eq!(sb.steering_angle, 0.0);
    }
}

/// The errors of θ(`horizon_s`) \[rad\] at rtol = 1e-5, 1e-7, 1e-9 against rtol = 1e-12,
/// at the constant speed `speed_mps` \[m/s\] from θ(0) = `theta0_deg` \[deg\].
fn refinement_errors(
    speed_mps: f64,
    controller: Option<LoopLaw>,
    horizon_s: f64,
    theta0_deg: f64,
) -> Vec<f64> {
    let m = model();
    let run = |rtol: f64| {
        let s = spec(
            SpeedProfile::Constant { speed_mps },
            controller,
            horizon_s,
            rtol,
        );
        simulate(&m, &s, x7(theta0_deg), Recording::None)
            .unwrap()
            .x_end[3]
    };
    let reference = run(1e-12);
    [1e-5, 1e-7, 1e-9]
        .iter()
        .map(|&r| (run(r) - reference).abs())
        .collect()
}

#[test]
fn tolerance_refinement_converges() {
    // θ(20 s) at V = 33 m/s from θ(0) = 8° (growing sway, which amplifies errors) for
    // rtol = 1e-5, 1e-7, 1e-9 against rtol = 1e-12: the error stays below 100·rtol, falls
    // from the loosest to the tightest tolerance and is below 1e-6 rad at 1e-9 (measured
    // with DOP853 landing on the tyre kinks: 8.9e-9, 2.5e-8, 6.8e-10 rad — at this level the
    // error no longer falls strictly with every decade; with Dormand–Prince 5(4) stepping
    // across the kinks it was 1.1e-4, 2.3e-5, 1.8e-7 rad)
    let errs = refinement_errors(33.0, None, 20.0, 8.0);
    for (e, rtol) in errs.iter().zip([1e-5, 1e-7, 1e-9]) {
        assert!(*e < 100.0 * rtol, "{errs:?}");
    }
    assert!(errs[0] > errs[2], "{errs:?}");
    assert!(errs[2] < 1e-6, "{errs:?}");
}

#[test]
fn closed_loop_tolerance_refinement_converges() {
    // the DDE path: V = 35 m/s, D = 0.1 s, τ = 0.2 s switched on at t = 1 s
    let ctl = Some(LoopLaw::paper(0.1, 0.2).switched(1.0, None));
    let errs = refinement_errors(35.0, ctl, 10.0, 10.0);
    eprintln!("closed-loop errors {errs:?}");
    assert!(errs[0] > errs[2], "{errs:?}");
    assert!(errs[2] < 1e-7, "{errs:?}");
}

#[test]
fn sway_amplitude_at_35_agrees_with_tight_tolerance_run() {
    // on the sway cycle at V = 35 m/s: max |θ| over 5 s (≥ one period) at the default
    // tolerances vs rtol = 1e-12 from the same start: within 0.01° (the issue's bound)
    let m = model();
    let tight = SolverSettings {
        rtol: 1e-12,
        atol: 1e-14,
        ..SolverSettings::default()
    };
    let x4 = settle(&m, 35.0, 0.1, 100.0, &tight).unwrap();
    let x0 = State7::from_column_slice(&[x4[0], x4[1], x4[2], x4[3], 0.0, 0.0, 0.0]);
    let amp = |solver: SolverSettings| {
        let mut s = spec(SpeedProfile::Constant { speed_mps: 35.0 }, None, 10.0, 1e-8);
        s.settings.solver = solver;
        simulate(&m, &s, x0, Recording::None)
            .unwrap()
            .metrics
            .final_amplitude_deg
            .unwrap()
    };
    let a_default = amp(SolverSettings::default());
    let a_tight = amp(tight);
    assert!(
        a_tight > 10.0,
        "expected sway at 35 m/s, amplitude {a_tight}°"
    );
    assert_abs_diff_eq!(a_default, a_tight, epsilon = 0.01);
}

/// An open-loop run at the constant speed `speed_mps` \[m/s\] from θ(0) = `theta0_deg`
/// \[deg\], rtol 1e-9, horizon `horizon_s` and action at `action_s` \[s\], sampled every
/// 1 ms.
fn sampled_run(
    speed_mps: f64,
    horizon_s: f64,
    action_s: f64,
    theta0_deg: f64,
) -> (SimSpec, SimResult<7>) {
    let mut s = spec(SpeedProfile::Constant { speed_mps }, None, horizon_s, 1e-9);
    s.action_s = action_s;
    let r = simulate(
        &model(),
        &s,
        x7(theta0_deg),
        Recording::Every { step_s: 0.001 },
    )
    .unwrap();
    (s, r)
}

#[test]
fn metrics_agree_with_dense_sampling() {
    // peak and final amplitude come from θ̇ = 0 events on the continuous extension: they
    // bound the maximum of a 1 ms sampling from above and exceed it by less than the
    // sampling error (θ'' Δt²/8 ≈ 1e-4°)
    let (_, r) = sampled_run(33.0, 30.0, 3.0, 8.0);
    let max_from = |t0: f64| {
        r.trajectory
            .iter()
            .filter(|p| p.t >= t0)
            .map(|p| p.x[3].abs().to_degrees())
            .fold(0.0, f64::max)
    };
    let peak = r.metrics.peak_theta_deg_after_action.unwrap();
    let fin = r.metrics.final_amplitude_deg.unwrap();
    assert!(
        peak >= max_from(3.0) - 1e-9 && peak - max_from(3.0) < 1e-3,
        "{peak} {}",
        max_from(3.0)
    );
    assert!(
        fin >= max_from(25.0) - 1e-9 && fin - max_from(25.0) < 1e-3,
        "{fin} {}",
        max_from(25.0)
    );
    assert!(r.metrics.settle_time_s.is_none()); // it sways at the end
}

#[test]
fn settle_time_is_the_last_fall_below_the_threshold() {
    // V = 25 m/s (stable), θ(0) = 5°: decays; after action + settle_time |θ| < 1° to the
    // end, just before it |θ| was ≥ 1° (checked on a 1 ms sampling)
    let (s, r) = sampled_run(25.0, 20.0, 1.0, 5.0);
    let ts = s.action_s + r.metrics.settle_time_s.unwrap();
    assert!(ts > 1.0 && ts < 20.0);
    let th = 1f64.to_radians();
    assert!(
        r.trajectory
            .iter()
            .filter(|p| p.t > ts + 1e-6)
            .all(|p| p.x[3].abs() < th)
    );
    let before = r.trajectory.iter().filter(|p| p.t <= ts && p.t > ts - 0.01);
    assert!(before.map(|p| p.x[3].abs()).fold(0.0, f64::max) > 0.999 * th);
}

#[test]
fn guard_stops_hard_braking_exactly_at_axle_saturation() {
    // from sway at 35 m/s, braking by 10 m/s in 2 s: a tractor axle slides fully. At the
    // reported time the guard function |α| − α_cr is 0 (independently recomputed from the
    // model's slip angles at the returned state)
    let m = model();
    let x4 = settle(&m, 35.0, 0.1, 200.0, &SolverSettings::default()).unwrap();
    let x0 = State7::from_column_slice(&[x4[0], x4[1], x4[2], x4[3], 0.0, 0.0, 0.0]);
    let profile = braking_35_to_25(2.0, 2.0);
    let mut s = spec(profile.clone(), None, 40.0, 1e-8);
    s.action_s = 2.0;
    let r = simulate(&m, &s, x0, Recording::None).unwrap();
    assert_eq!(r.metrics.outcome, Outcome::LossOfControl);
    assert!(r.metrics.final_amplitude_deg.is_none() && r.metrics.settle_time_s.is_none());
    let t = r.metrics.loss_of_control_time_s.unwrap();
    assert_eq!(r.t_end, t);
    let u = Inputs {
        steering_angle: 0.0,
        speed: profile.speed(t),
        acceleration: profile.acceleration(t),
    };
    let a = m.slip_angles(
        &State4::new(r.x_end[0], r.x_end[1], r.x_end[2], r.x_end[3]),
        &u,
    );
    let acr = m.critical_slip_angles();
    let g = match r.metrics.loss_of_control_condition.unwrap() {
        LossOfControl::FrontAxleSliding => a.front.abs() - acr.front,
        LossOfControl::RearAxleSliding => a.rear.abs() - acr.rear,
        other => panic!("unexpected condition {other:?}"),
    };
    assert!(g.abs() < 1e-8, "guard function at the event: {g}");
    // without the guard the same run goes on past that point
    s.settings.guard = ValidityGuard::Off;
    let r_off = simulate(&m, &s, x0, Recording::None);
    if let Ok(r_off) = r_off {
        assert!(r_off.t_end > t);
    }
}

/// A digest of every number of a run (FNV-1a over the bits of the recorded samples, the end
/// state, the metrics' numbers and the solver's counters).
fn digest<const N: usize>(r: &SimResult<N>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |v: u64| {
        for b in v.to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for s in &r.trajectory {
        eat(s.t.to_bits());
        s.x.iter().for_each(|v| eat(v.to_bits()));
        eat(s.speed.to_bits());
        eat(s.steering_angle.to_bits());
    }
    r.x_end.iter().for_each(|v| eat(v.to_bits()));
    eat(r.t_end.to_bits());
    let m = &r.metrics;
    for v in [
        m.peak_theta_deg_after_action,
        m.final_amplitude_deg,
        m.settle_time_s,
        m.loss_of_control_time_s,
        m.decay_rate_per_s,
    ] {
        eat(v.map_or(u64::MAX, f64::to_bits));
    }
    for v in [
        r.stats.accepted,
        r.stats.rejected,
        r.stats.rhs_evals,
        r.stats.switches,
    ] {
        eat(v as u64);
    }
    h
}

#[test]
fn paper_vehicle_simulations_are_bitwise_those_of_main() {
    // reference: digests recorded on main (4728b97) before the simulation became generic
    // over the plant; every number of these runs must be identical (no tolerance). The
    // predictor's run was recorded again when an attempt cut short at a kink it crossed
    // stopped bringing back a size that failed the error test (its states moved by ~1e-11)
    let m = model();
    let rec = Recording::Every { step_s: 0.05 };
    let feedback = |actuator| {
        Some(LoopLaw {
            steering_limits: actuator,
            ..LoopLaw::paper(0.1, 0.2).switched(1.0, None)
        })
    };
    let limited = sway::sim::ActuatorLimits {
        max_angle_deg: Some(1.0),
        max_rate_deg_s: Some(5.0),
        time_constant_s: 0.05,
    };
    let gains = sway::control::Gains::yaw_rate(0.1);
    let predictor = Some(LoopLaw::new(
        sway::control::Structure::Predictor,
        sway::control::Actuator::Steering,
        gains,
        0.3,
    ));
    let braking = Some(
        LoopLaw::new(
            sway::control::Structure::YawRateHitch,
            sway::control::Actuator::DifferentialBraking,
            sway::control::Gains::yaw_rate(2e4),
            0.2,
        )
        .switched(0.5, None),
    );
    let v35 = SpeedProfile::Constant { speed_mps: 35.0 };
    let runs: Vec<(&str, u64)> = vec![
        (
            "S1 open loop 7 states",
            digest(
                &simulate(
                    &m,
                    &spec(SpeedProfile::Constant { speed_mps: 33.0 }, None, 30.0, 1e-8),
                    x7(5.7),
                    rec,
                )
                .unwrap(),
            ),
        ),
        (
            "S3 closed loop 7 states",
            digest(
                &simulate(
                    &m,
                    &spec(v35.clone(), feedback(Default::default()), 20.0, 1e-8),
                    x7(5.7),
                    rec,
                )
                .unwrap(),
            ),
        ),
        (
            "rate-limited actuator 4 states",
            digest(
                &simulate(
                    &m,
                    &spec(v35.clone(), feedback(limited), 20.0, 1e-8),
                    State4::new(0.0, 0.0, 0.0, 0.1),
                    rec,
                )
                .unwrap(),
            ),
        ),
        (
            "predictor 7 states",
            digest(&simulate(&m, &spec(v35.clone(), predictor, 20.0, 1e-8), x7(5.7), rec).unwrap()),
        ),
        (
            "braking yaw_rate_hitch 4 states",
            digest(
                &simulate(
                    &m,
                    &spec(v35.clone(), braking, 20.0, 1e-8),
                    State4::new(0.0, 0.0, 0.0, 0.1),
                    rec,
                )
                .unwrap(),
            ),
        ),
        (
            "hard braking to loss of control",
            digest(
                &simulate(
                    &m,
                    &spec(braking_35_to_25(0.0, 0.3), None, 10.0, 1e-8),
                    x7(8.0),
                    rec,
                )
                .unwrap(),
            ),
        ),
        ("settle", {
            let x = settle(&m, 35.0, 0.1, 50.0, &SolverSettings::default()).unwrap();
            x.iter().fold(0u64, |h, v| h.rotate_left(7) ^ v.to_bits())
        }),
    ];
    let main: [(&str, u64); 7] = [
        ("S1 open loop 7 states", 0x01e3_31b1_a3e6_dffe),
        ("S3 closed loop 7 states", 0x6287_b217_ce6f_0b08),
        ("rate-limited actuator 4 states", 0x6d8a_07ca_9823_0656),
        ("predictor 7 states", 0xa8c4_42b4_efd0_14ad),
        ("braking yaw_rate_hitch 4 states", 0xe1e5_0819_8008_8b71),
        ("hard braking to loss of control", 0x7cc7_f5fb_7550_48c5),
        ("settle", 0x29f1_e714_78b5_ded1),
    ];
    let differing: Vec<String> = runs
        .iter()
        .zip(main)
        .filter(|((name, d), (main_name, main_d))| {
            assert_eq!(name, main_name);
            d != main_d
        })
        .map(|((name, d), (_, main_d))| format!("{name}: digest {d:#018x}, main {main_d:#018x}"))
        .collect();
    assert!(differing.is_empty(), "{}", differing.join("\n"));
}

/// Classical RK4 of an M-state plant at constant speed, open loop, with step `dt` \[s\].
fn rk4<P: trailer_model::Plant<M>, const M: usize>(
    plant: &P,
    speed_mps: f64,
    x0: SVector<f64, M>,
    t_end: f64,
    dt: f64,
) -> SVector<f64, M> {
    let u = Inputs::constant_speed(speed_mps);
    let f = |x: &SVector<f64, M>| plant.rhs(x, &u);
    let steps = (t_end / dt).round() as usize;
    let mut x = x0;
    for _ in 0..steps {
        let k1 = f(&x);
        let k2 = f(&(x + k1 * (dt / 2.0)));
        let k3 = f(&(x + k2 * (dt / 2.0)));
        let k4 = f(&(x + k3 * dt));
        x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
    }
    x
}

#[test]
fn relaxed_vehicle_simulation_matches_an_independent_rk4() {
    // reference: fixed-step RK4 of VehicleModel<7>'s right-hand side (σ = 0.3 m on the three
    // axles of Table I, 33 m/s: above its V_crit ≈ 32.6 m/s), started from the same lifted
    // state (α′ = α). RK4 at dt = 1 ms has a global error ~ T·|λ|⁵dt⁴/120 ≈ 1e-11 on the
    // sway mode (|λ| ≈ 4 rad/s) and the lag modes (|λ| ≈ V/σ = 110 1/s) start unexcited;
    // the simulation runs at rtol 1e-10: 1e-8 rad on the states is ample and far below
    // what a wrong layout or lag would give (θ grows to ≈ 0.05 rad)
    let spec_r = trailer_model::VehicleSpec::table_i_with_relaxation(0.3);
    let any = trailer_model::AnyVehicleModel::new(&spec_r).unwrap();
    let vm = trailer_model::VehicleModel::<7>::new(&spec_r).unwrap();
    let s = spec(
        SpeedProfile::Constant { speed_mps: 33.0 },
        None,
        10.0,
        1e-10,
    );
    let x0 = State4::new(0.0, 0.0, 0.0, 2f64.to_radians());
    let r = sway::sim::simulate_in_paper_layout::<4>(&any, &s, x0, Recording::None).unwrap();
    assert_eq!(r.metrics.outcome, Outcome::Ok);
    let x0m = sway::sim::lift_state::<_, 7, 4, 7>(&vm, &x0, 33.0);
    // the lagged slips start at the instantaneous ones: α′_T = α_T = atan(tan θ…) ≠ 0
    assert!(x0m[6].abs() > 1e-3, "{x0m}");
    let reference = rk4(&vm, 33.0, x0m, 10.0, 1e-3);
    for i in 0..4 {
        assert!(
            (r.x_end[i] - reference[i]).abs() < 1e-8,
            "state {i}: {} vs RK4 {}",
            r.x_end[i],
            reference[i]
        );
    }
    // and it sways differently from the paper's model (the check is not vacuous)
    let paper = simulate(&model(), &s, x0, Recording::None).unwrap();
    assert!((paper.x_end[3] - r.x_end[3]).abs() > 1e-3);
}

#[test]
fn relaxation_length_to_zero_converges_to_the_paper_trajectory() {
    // reference: the paper's model (σ = 0); the first-order slip lag moves the trajectory
    // by O(σ), so halving σ halves the distance in the reduced states (ratio 2 within 10 %),
    // and at σ = 1 cm it is below 2 % of their size (measured 1.2 %)
    let s = spec(SpeedProfile::Constant { speed_mps: 33.0 }, None, 5.0, 1e-10);
    let x0 = x7(2.0);
    let paper = simulate(&model(), &s, x0, Recording::None).unwrap();
    let distance = |sigma: f64| {
        let any = trailer_model::AnyVehicleModel::new(
            &trailer_model::VehicleSpec::table_i_with_relaxation(sigma),
        )
        .unwrap();
        let r = sway::sim::simulate_in_paper_layout::<7>(&any, &s, x0, Recording::None).unwrap();
        (0..4)
            .map(|i| (r.x_end[i] - paper.x_end[i]).abs())
            .fold(0.0, f64::max)
    };
    let size = (0..4).map(|i| paper.x_end[i].abs()).fold(0.0, f64::max);
    let (d1, d2) = (distance(0.01), distance(0.02));
    let ratio = d2 / d1;
    assert!((ratio - 2.0).abs() < 0.2, "d(2 cm) / d(1 cm) = {ratio}");
    assert!(d1 < 0.02 * size, "d(1 cm) = {d1}, size {size}");
}

#[test]
fn relaxed_s1_at_bench_settings_matches_a_converged_run() {
    // the relaxed performance case (the `S1_relaxation_0.3m…` bench: Table I with σ = 0.3 m on
    // the three axles, 33 m/s, θ(0) = 0.1 rad, 60 s, rtol 1e-8 / atol 1e-10, the default
    // solver) against the same run converged: DOP853 at rtol 1e-12 with exact kink landing
    // (at rtol 1e-10 it is already 6e-13 from the run at 1e-13). Measured 1.2e-6 (relative,
    // largest over the seven states); the bound 5e-6 keeps any cheaper treatment of the stiff
    // lag modes (λ ≈ −V/σ ≈ −110 1/s) honest. The run grows from 0.1 rad onto a 27° cycle
    // (33 m/s is above the relaxed V_crit ≈ 32.6 m/s), which amplifies every early error; the
    // paper's model at the same settings is 1.6e-7 from its converged run.
    let any = trailer_model::AnyVehicleModel::new(
        &trailer_model::VehicleSpec::table_i_with_relaxation(0.3),
    )
    .unwrap();
    let s1 = spec(SpeedProfile::Constant { speed_mps: 33.0 }, None, 60.0, 1e-8);
    let mut converged = spec(
        SpeedProfile::Constant { speed_mps: 33.0 },
        None,
        60.0,
        1e-12,
    );
    converged.settings.solver.method = sway::sim::IntegrationMethod::Dop853;
    converged.settings.solver.kink_landing = sway::sim::KinkLandingMode::Exact;
    let x0 = State7::from_column_slice(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0]);
    let r = sway::sim::simulate_in_paper_layout::<7>(&any, &s1, x0, Recording::None).unwrap();
    let c =
        sway::sim::simulate_in_paper_layout::<7>(&any, &converged, x0, Recording::None).unwrap();
    let err = (0..7)
        .map(|i| (r.x_end[i] - c.x_end[i]).abs() / c.x_end[i].abs().max(1.0))
        .fold(0.0, f64::max);
    assert!(err < 5e-6, "relative error {err:e} after 60 s");
    // on the 27° cycle (the paper's model sways at 8°)
    assert!(
        r.metrics.final_amplitude_deg.unwrap() > 25.0,
        "{:?}",
        r.metrics
    );
}

/// A vehicle of the generated study (`study_generated`, vehicle 35): tyre relaxation
/// σ = 0.42 m on every axle, a tandem trailer axle and Coulomb friction at the hitch.
const RELAXED_TANDEM_WITH_HITCH_FRICTION: &str = r#"
gravity = 9.81
[tractor]
mass = 2466.19
yaw_inertia = 7677.46
front_axle = 4.7787
cog = 3.2019
rear_axle = 1.3396
front_cornering_stiffness = 163561.3
rear_cornering_stiffness = 186855.8
front_relaxation_length_m = 0.4233
rear_relaxation_length_m = 0.4233
[trailer]
mass = 1558.63
yaw_inertia = 1467.07
cog = 2.6810
[[trailer.axles]]
position_m = 2.2468
cornering_stiffness = 106994.5
relaxation_length_m = 0.4233
[[trailer.axles]]
position_m = 3.0350
cornering_stiffness = 106994.5
relaxation_length_m = 0.4233
[friction]
mu_static = 0.9
mu_dynamic = 0.6
[hitch]
friction_torque_nm = 166.45
"#;

/// Classical RK4 of an M-state plant at constant speed under the steering `delta(t)`,
/// open loop, with step `dt` \[s\].
fn rk4_steered<P: trailer_model::Plant<M>, const M: usize>(
    plant: &P,
    speed_mps: f64,
    delta: impl Fn(f64) -> f64,
    t_end: f64,
    dt: f64,
) -> SVector<f64, M> {
    let f = |t: f64, x: &SVector<f64, M>| {
        let u = Inputs {
            steering_angle: delta(t),
            ..Inputs::constant_speed(speed_mps)
        };
        plant.rhs(x, &u)
    };
    let steps = (t_end / dt).round() as usize;
    let mut x = SVector::zeros();
    for i in 0..steps {
        let t = i as f64 * dt;
        let k1 = f(t, &x);
        let k2 = f(t + dt / 2.0, &(x + k1 * (dt / 2.0)));
        let k3 = f(t + dt / 2.0, &(x + k2 * (dt / 2.0)));
        let k4 = f(t + dt, &(x + k3 * dt));
        x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
    }
    x
}

#[test]
fn a_pulse_after_straight_running_on_a_relaxed_vehicle_runs_in_few_steps_and_matches_rk4() {
    // At rest the error estimate is 0 and the step grows to the pulse's start; there the
    // grown size diverges on the fast lag modes (V/σ = 173 1/s at 73.1 m/s), and a landing
    // on a root read from such an attempt must not bring that size back (it crept on by
    // landings of picoseconds until the 2·10⁶-step budget was spent: 35 s per run).
    // Reference: fixed-step RK4 of the same plant at dt = 0.1 ms, whose steps land on the
    // pulse's ends; the hitch friction's kinks (|θ̇| = ω_c) cost it O(dt²) each: agreement
    // to 1e-7 in the paper's states (which reach ~1; measured 4e-9) is ample.
    let vehicle: trailer_model::VehicleSpec =
        toml::from_str(RELAXED_TANDEM_WITH_HITCH_FRICTION).expect("the vehicle parses");
    let any = trailer_model::AnyVehicleModel::new(&vehicle).unwrap();
    let (speed, amplitude, start, duration) = (73.1, 0.5f64.to_radians(), 0.5, 0.4);
    let s = SimSpec {
        steering: sway::sim::SteeringInput::Pulse {
            shape: sway::sim::PulseShape::HalfSine,
            start_s: start,
            duration_s: duration,
            amplitude_rad: amplitude,
        },
        ..spec(
            SpeedProfile::Constant { speed_mps: speed },
            None,
            5.0,
            1e-10,
        )
    };
    let r = sway::sim::simulate_in_paper_layout::<4>(&any, &s, State4::zeros(), Recording::None)
        .unwrap();
    assert_eq!(r.metrics.outcome, Outcome::Ok);
    // measured: 535 steps over 5 s at rtol 1e-10
    assert!(r.stats.accepted < 5_000, "{:?}", r.stats);
    let delta = |t: f64| {
        if (start..start + duration).contains(&t) {
            amplitude * (std::f64::consts::PI * (t - start) / duration).sin()
        } else {
            0.0
        }
    };
    let reference = trailer_model::with_plant!(&any, m => {
        let x = rk4_steered(m, speed, delta, 5.0, 1e-4);
        [x[0], x[1], x[2], x[3]]
    });
    eprintln!("{:?} vs RK4 {reference:?}, {:?}", r.x_end, r.stats);
    for i in 0..4 {
        assert!(
            (r.x_end[i] - reference[i]).abs() < 1e-7,
            "state {i}: {} vs RK4 {}",
            r.x_end[i],
            reference[i]
        );
    }
    assert!(reference[3].abs() > 1e-4, "the pulse moves the trailer");
}
