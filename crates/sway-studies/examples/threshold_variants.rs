//! The threshold kick of the model variants: the smallest θ(0) (other states 0) that
//! ends in sustained sway in open loop at constant speed, for Table I with tyre relaxation
//! σ ∈ {0, 0.3, 0.6} m on every axle and the example vehicles of `configs/vehicles/`
//! (Magic Formula tyres, a tandem trailer axle, hitch friction), at 0.95·V_crit of each
//! vehicle (33.01 m/s for Table I) and at 33 m/s where that is below its V_crit.
//!
//! `cargo run --release -p sway --example threshold_variants`
//!
//! The threshold search is `sway_studies::fleet::threshold_at` with `FleetOptions`' defaults
//! (θ(0) from 0.5° to 15° in 16 steps, bisected to 0.01°, 240 s horizon); the task
//! `cargo xtask variants` reports it with the other headline numbers of each variant.

use sway_studies::fleet::{FleetOptions, threshold_at};
use trailer_model::{AnyVehicleModel, CriticalSpeedOptions, Plant, VehicleSpec, with_plant};

fn threshold(vehicle: &AnyVehicleModel, v: f64) -> Option<f64> {
    threshold_at(vehicle, v, &FleetOptions::default()).expect("threshold")
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
