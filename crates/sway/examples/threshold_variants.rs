//! The threshold kick of issue 21's model variants: the smallest θ(0) (other states 0) that
//! ends in sustained sway in open loop at constant speed, for Table I with tyre relaxation
//! σ ∈ {0, 0.3, 0.6} m on every axle and the example vehicles of `configs/vehicles/`
//! (Magic Formula tyres, a tandem trailer axle, hitch friction), at 0.95·V_crit of each
//! vehicle (33.01 m/s for Table I) and at 33 m/s where that is below its V_crit.
//!
//! `cargo run --release -p sway --example threshold_variants`

use sway::config::Positive;
use sway::sim::sweep::{
    Axis, AxisParameter, BaseScenario, SweepParameter, ThresholdSearch, theta0_threshold_any,
};
use sway::sim::{
    Controller, InitialCondition, MetricSettings, RunSettings, SolverSettings, SpeedProfile,
};
use trailer_model::{AnyVehicleModel, CriticalSpeedOptions, Plant, VehicleSpec, with_plant};

fn threshold(vehicle: &AnyVehicleModel, v: f64) -> Option<f64> {
    let base = BaseScenario {
        horizon_s: Positive::literal(240.0),
        action_s: Some(0.0),
        speed: SpeedProfile::Constant { speed_mps: v },
        controller: Controller::None,
        initial: InitialCondition::State {
            sigma1_mps: 0.0,
            sigma2_per_s: 0.0,
            sigma3_per_s: 0.0,
            theta0_deg: 0.0,
            psi0_deg: 0.0,
        },
        settings: RunSettings {
            solver: SolverSettings {
                rtol: 1e-6,
                atol: 1e-8,
                ..SolverSettings::default()
            },
            metrics: MetricSettings::default(),
            ..RunSettings::default()
        },
    };
    let column = Axis::range(
        AxisParameter::Scenario(SweepParameter::Theta0Deg),
        0.5,
        15.0,
        16,
    )
    .values();
    let search = ThresholdSearch {
        horizon_s: Positive::literal(240.0),
        tolerance_deg: Positive::literal(0.01),
        max_doublings: 3,
        compare_cycles: false,
        cycles: Default::default(),
    };
    theta0_threshold_any(vehicle, &base, &column, &search, v)
        .expect("threshold")
        .theta0_threshold_deg
}

fn main() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/vehicles");
    let file = |name: &str| -> VehicleSpec {
        toml::from_str(&std::fs::read_to_string(dir.join(name)).expect("read")).expect("parse")
    };
    let vehicles = [
        ("Table I (σ = 0)", VehicleSpec::table_i_with_relaxation(0.0)),
        ("σ = 0.3 m", VehicleSpec::table_i_with_relaxation(0.3)),
        ("σ = 0.6 m", VehicleSpec::table_i_with_relaxation(0.6)),
        ("Magic Formula", file("magic_formula.toml")),
        ("tandem ±0.4 m", file("tandem.toml")),
        ("hitch friction", file("hitch_friction.toml")),
    ];
    println!(
        "| vehicle | V_crit [m/s] | V = 0.95·V_crit [m/s] | θ(0) threshold there [deg] | θ(0) threshold at 33 m/s [deg] |"
    );
    println!("|---|---|---|---|---|");
    for (name, spec) in vehicles {
        let any = AnyVehicleModel::new(&spec).expect("vehicle");
        let vc = with_plant!(&any, m => m.critical_speed(&CriticalSpeedOptions::default()))
            .expect("V_crit")
            .v_crit_mps;
        let v = 0.95 * vc;
        let fmt = |t: Option<f64>| t.map_or("none ≤ 15°".to_string(), |t| format!("{t:.2}"));
        let at33 = if 33.0 < vc {
            fmt(threshold(&any, 33.0))
        } else {
            "(above V_crit)".to_string()
        };
        println!(
            "| {name} | {vc:.3} | {v:.2} | {} | {at33} |",
            fmt(threshold(&any, v))
        );
    }
}
