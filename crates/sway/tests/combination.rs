//! The unit-by-unit view of a combination (`sway::combination`) on Table I, against what
//! the two-unit engines and the linear theory give independently.

use sway::combination::manoeuvres::{
    LaneChangeSettings, YawDampingSettings, lane_change, yaw_damping,
};
use sway::combination::modes::sway_modes;
use sway::sim::SolverSettings;
use trailer_model::{AnyVehicleModel, AsChain, CriticalSpeedOptions, Model, VehicleParams};

fn table_i() -> Model {
    Model::new(VehicleParams::default()).expect("Table I")
}

/// The one mode that loses stability does so at the V_crit of the paper's own search (the
/// spectral abscissa's sign change, bisected to 1e-11 m/s) to the bisection's 1e-9 m/s
/// (here: 1e-8 m/s), with the Hopf frequency to 1e-8 Hz, and is led by the trailer.
#[test]
fn the_sway_mode_of_table_i_crosses_at_v_crit() {
    let model = table_i();
    let vc = model
        .critical_speed(&CriticalSpeedOptions::default())
        .expect("a V_crit");
    let speeds: Vec<f64> = (2..=120).map(|k| 0.5 * f64::from(k)).collect();
    let modes = sway_modes(&model.as_chain().expect("a chain"), &speeds);
    let crossing: Vec<_> = modes.iter().filter_map(|m| m.loses_stability()).collect();
    assert_eq!(crossing.len(), 1, "{modes:#?}");
    let c = crossing[0];
    assert!(
        (c.speed_mps - vc.v_crit_mps).abs() < 1e-8,
        "{} vs {}",
        c.speed_mps,
        vc.v_crit_mps
    );
    assert!((c.frequency_hz - vc.hopf_frequency_hz).abs() < 1e-8);
    assert!(c.damping_ratio.abs() < 1e-8);
    assert_eq!(c.leading_unit, 1);
    assert!((c.heading_amplitudes[1] - 1.0).abs() < 1e-15 && c.heading_amplitudes[0] < 1.0);
}

/// The lane change: the secant finds the amplitude of the towing unit's target peak to
/// 0.1 %; after the manoeuvre the rearmost axle runs on the steered axle's path (to 1 mm
/// per metre of lane offset, the paths compared at equal x); in the linear range
/// the rearward amplification does not depend on the size (0.05 g and 0.15 g agree to 1 %,
/// the brush tyres' cubic term at these slips moves it by less).
#[test]
fn the_lane_change_reaches_its_target_and_ends_in_the_new_lane() {
    let plant = AnyVehicleModel::Paper(table_i());
    let solver = SolverSettings::default();
    let settings = LaneChangeSettings {
        after_s: 30.0,
        ..LaneChangeSettings::default()
    };
    let l = lane_change(&plant, 20.0, &settings, &solver).expect("a lane change");
    let target = settings.towing_unit_peak_lateral_acceleration_mps2;
    assert!((l.towing_unit_peak_lateral_acceleration_mps2 / target - 1.0).abs() < 1e-3);
    let end = l.samples.last().expect("samples");
    assert!(l.lane_offset_m.abs() > 0.5, "{}", l.lane_offset_m);
    let [x, y] = end.rearmost_axle_m;
    let k = l.samples.partition_point(|s| s.steer_axle_m[0] < x);
    let (a, b) = (l.samples[k - 1].steer_axle_m, l.samples[k].steer_axle_m);
    let y_steer = a[1] + (b[1] - a[1]) * (x - a[0]) / (b[0] - a[0]);
    assert!(
        (y - y_steer).abs() < 1e-3 * l.lane_offset_m.abs(),
        "{y} vs {y_steer} at x = {x}"
    );
    assert!(l.rearward_amplification > 0.5 && l.rearward_amplification < 5.0);
    let small = lane_change(
        &plant,
        20.0,
        &LaneChangeSettings {
            towing_unit_peak_lateral_acceleration_mps2: 0.05 * 9.81,
            ..settings
        },
        &solver,
    )
    .expect("a lane change");
    assert!(
        (small.rearward_amplification / l.rearward_amplification - 1.0).abs() < 1e-2,
        "{} vs {}",
        small.rearward_amplification,
        l.rearward_amplification
    );
}

/// The pulse-steer damping of the articulation (read from its peaks, as a test engineer
/// reads it) is the damping ratio of the least damped mode of the linearisation: after the
/// first peak the other modes have died out; the decrement over three periods of a 0.5°
/// pulse agrees to 3 % (the brush tyres' nonlinearity and what is left of the faster modes).
#[test]
fn the_pulse_damping_is_the_least_damped_modes() {
    let model = table_i();
    let v = 25.0;
    let modes = sway_modes(&model.as_chain().expect("a chain"), &[v]);
    let least = modes
        .iter()
        .map(|m| m.points[0].damping_ratio)
        .fold(f64::INFINITY, f64::min);
    let d = yaw_damping(
        &AnyVehicleModel::Paper(model),
        v,
        &YawDampingSettings::default(),
        &SolverSettings::default(),
    )
    .expect("a pulse run");
    assert_eq!(d.len(), 1);
    let read = d[0].damping_ratio.expect("a decrement");
    assert!((read / least - 1.0).abs() < 3e-2, "{read} vs {least}");
}
