//! The lateral stability test against what can be derived: the linearisation's damping
//! ratio and the unstable sway cycles of continuation.

use sway::progress::NoProgress;
use sway::ranging::SpeedLimits;
use sway_model::vehicle::LoopModel;
use sway_studies::lateral_stability::{LateralStabilityConfig, compute};
use trailer_model::{AnyVehicleModel, VehicleParams, VehicleSpec};

fn table_i() -> AnyVehicleModel {
    AnyVehicleModel::new(&VehicleSpec::from(VehicleParams::default())).unwrap()
}

/// −Re λ / |λ| of the rightmost oscillatory root pair of A(V).
fn linear_damping(vehicle: &AnyVehicleModel, speed: f64) -> (f64, f64) {
    let pair = vehicle
        .open_loop_spectrum(speed)
        .into_iter()
        .find(|z| z.im.abs() > 1e-9)
        .unwrap();
    (
        -pair.re / pair.norm(),
        pair.im.abs() / std::f64::consts::TAU,
    )
}

#[test]
fn a_small_impulse_shows_the_linearisations_damping_ratio() {
    // reference: the damping ratio −Re λ/|λ| and frequency of the rightmost oscillatory
    // pair of the linearisation at each speed (an independent formulation: eigenvalues, no
    // simulation); the run's decrement over 3 periods after skipping 2 peaks (the second
    // pair has decayed by then) agrees to 1e-3 in D and 1 % in frequency
    let vehicle = table_i();
    let cfg = LateralStabilityConfig {
        speeds: vec![],
        ..LateralStabilityConfig::default()
    };
    for speed in [17.0, 24.0, 30.0, 36.0] {
        let cfg = LateralStabilityConfig {
            speeds: vec![sway::ranging::SpeedSpec::Absolute(speed)],
            amplitudes_deg: vec![],
            ..cfg.clone()
        };
        let r = compute(&cfg, &vehicle, &SpeedLimits::default(), &NoProgress).unwrap();
        let row = &r.speeds[0];
        let (d, f) = linear_damping(&vehicle, speed);
        let ours = row.damping_ratio.unwrap();
        println!(
            "V = {speed}: D = {ours} vs {d}, f = {:?} vs {f}",
            row.frequency_hz
        );
        assert!((ours - d).abs() < 1e-3, "V = {speed}: {ours} vs {d}");
        let fo = row.frequency_hz.unwrap();
        assert!((fo - f).abs() < 0.01 * f, "V = {speed}: {fo} vs {f}");
    }
}

#[test]
fn the_test_sees_zero_damping_at_the_unstable_cycle_and_overestimates_the_safe_speed() {
    // reference: the unstable sway cycle's max |θ| from continuation at the same speeds
    // (an independent method: collocation of the periodic orbit); the amplitude where the
    // impulses' local damping crosses zero agrees within 2 %; the extrapolated test speed
    // lies above V_fold (the test cannot see the bistable range)
    let vehicle = table_i();
    let r = compute(
        &LateralStabilityConfig::default(),
        &vehicle,
        &SpeedLimits::default(),
        &NoProgress,
    )
    .unwrap();
    let mut compared = 0;
    for row in &r.speeds {
        println!(
            "V = {:.3}: D = {:?}, zero-damping A = {:?}, unstable cycle = {:?}, trigger = {:?}",
            row.speed_mps,
            row.damping_ratio,
            row.zero_damping_amplitude_deg,
            row.unstable_cycle_amplitude_deg,
            row.triggering_impulse_deg
        );
        if let (Some(a), Some(c)) = (
            row.zero_damping_amplitude_deg,
            row.unstable_cycle_amplitude_deg,
        ) {
            assert!(
                (a - c).abs() < 0.02 * c,
                "V = {}: {a} vs {c}",
                row.speed_mps
            );
            compared += 1;
        }
    }
    println!(
        "test V_crit {:?}, V_crit {:?}, V_fold {:?}, overestimate {:?}",
        r.test_critical_speed_mps, r.v_crit_mps, r.v_fold_mps, r.overestimate_mps
    );
    assert!(compared >= 3, "{compared} speeds compared");
    assert!(r.overestimate_mps.unwrap() > 0.0);
}

#[test]
fn a_noisy_recording_of_a_simulated_run_gives_the_clean_damping() {
    // reference: the damping and frequency of the same run read from the clean simulation
    // (sampled at 5 ms); the recording is that run sampled at 50 Hz with seeded white
    // noise of 0.05° (σ) on θ: D within 0.01 and the frequency within 1 % (the issue's
    // tolerances; the 3 Hz zero-phase low-pass and the prominence threshold keep the noise
    // from making peaks)
    use sway::sim::{PulseShape, Recording, SimSpec, SpeedProfile, SteeringInput, simulate};
    use sway_studies::lateral_stability::{RecordingAnalysis, analyse_recording};
    let model = trailer_model::Model::new(VehicleParams::default()).unwrap();
    let spec = SimSpec {
        early_stop: sway::sim::EarlyStop::Never,
        steering: SteeringInput::Pulse {
            shape: PulseShape::HalfSine,
            start_s: 1.0,
            duration_s: 0.4,
            amplitude_rad: 1f64.to_radians(),
        },
        profile: SpeedProfile::Constant { speed_mps: 27.0 },
        controller: None,
        horizon_s: 30.0,
        action_s: 1.0,
        settings: Default::default(),
    };
    let run = |step_s: f64| {
        simulate(
            &model,
            &spec,
            trailer_model::State4::zeros(),
            Recording::Every { step_s },
        )
        .unwrap()
        .trajectory
    };
    let columns = |s: &[sway::sim::Sample<4>]| -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        (
            s.iter().map(|p| p.t).collect(),
            s.iter().map(|p| p.steering_angle).collect(),
            s.iter().map(|p| p.x[3]).collect(),
        )
    };
    let (t, delta, theta) = columns(&run(0.005));
    let clean = analyse_recording(&t, &delta, &theta, &RecordingAnalysis::default()).unwrap();
    let (t50, delta50, theta50) = columns(&run(0.02));
    // seeded Gaussian noise (Box–Muller on a 64-bit LCG), σ = 0.05°
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut uniform = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let sigma = 0.05f64.to_radians();
    let noisy: Vec<f64> = theta50
        .iter()
        .map(|v| {
            let (u1, u2) = (uniform(), uniform());
            v + sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        })
        .collect();
    let rec = analyse_recording(&t50, &delta50, &noisy, &RecordingAnalysis::default()).unwrap();
    println!("clean {:?}\nrecorded {:?}", clean.decay, rec.decay);
    assert!((rec.decay.damping_ratio - clean.decay.damping_ratio).abs() < 0.01);
    let f = clean.decay.frequency_hz;
    assert!((rec.decay.frequency_hz - f).abs() < 0.01 * f);
    // bad recordings are refused with the reason
    let e = analyse_recording(
        &t50[..5],
        &delta50[..5],
        &noisy[..5],
        &RecordingAnalysis::default(),
    );
    assert!(e.unwrap_err().contains("at least 10 samples"));
    let zero = vec![0.0; t50.len()];
    let e = analyse_recording(&t50, &zero, &noisy, &RecordingAnalysis::default());
    assert!(e.unwrap_err().contains("no steering impulse"));
}
