//! Chains of units against the two-unit vehicle (release, medians; `cargo bench -p
//! sway-benches --bench combination`):
//! - `linear`'s V_crit search (scan of the spectral abscissa from 1 m/s in 0.5 m/s steps and
//!   bisection to 1e-11 m/s, [`trailer_model::Plant::critical_speed_search`]) on Table I (the
//!   paper's model, 4 states), on Table I written as a one-trailer chain (`[[trailers]]`,
//!   the chain's equations, 4 states) and on the car with two caravans (6 states); target:
//!   3 units ≤ 2× 2 units;
//! - an S1-type run (open loop, θ(0) = 0.1 rad, 60 s, rtol 1e-8 / atol 1e-10, at 0.95 V_crit
//!   of each vehicle: inside its bistable range, the run settles on the sway cycle) on the
//!   same three; target: 3 units ≤ 2× S1;
//! - the sway modes of `linear` and `combination` (eigenvalues and eigenvectors along 199
//!   speeds, and the bisection of each crossing) for 2 and 3 units, and one lane change of
//!   `combination` (one run at the found amplitude, 11 s, every sample's unit motions).

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use sway::combination::manoeuvres::{LaneChangeSettings, lane_change};
use sway::sim::{
    EarlyStop, Recording, RunSettings, SimSpec, SolverSettings, SpeedProfile,
    simulate_in_paper_layout,
};
use sway_studies::modes::modes_of;
use sway_tasks::config_file::load_vehicle_spec;
use trailer_model::{
    AnyVehicleModel, ChainSpec, CriticalSpeedOptions, Model, Plant, State7, VehicleParams,
    VehicleSpec, with_plant,
};

fn vehicles() -> [(&'static str, AnyVehicleModel); 3] {
    let table_i = AnyVehicleModel::Paper(Model::new(VehicleParams::default()).expect("Table I"));
    // Table I in the chain's file form: one `[[trailers]]` entry
    let mut chain = VehicleSpec::from(VehicleParams::default());
    let chain_spec = ChainSpec::from(&chain);
    chain.trailers = chain_spec.towed_units().to_vec();
    chain.trailer = None;
    let one_trailer_chain = AnyVehicleModel::new(&chain).expect("Table I as a chain");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let caravans = load_vehicle_spec(&root.join("configs/combinations/car_two_caravans.toml"))
        .expect("the car with two caravans")
        .plant;
    [
        ("2_units_paper_model", table_i),
        ("2_units_chain", one_trailer_chain),
        ("3_units_car_two_caravans", caravans),
    ]
}

fn s1_type(v_crit: f64) -> SimSpec {
    SimSpec {
        profile: SpeedProfile::Constant {
            speed_mps: 0.95 * v_crit,
        },
        controller: None,
        steering: Default::default(),
        horizon_s: 60.0,
        action_s: 0.0,
        settings: RunSettings {
            solver: SolverSettings {
                rtol: 1e-8,
                atol: 1e-10,
                ..SolverSettings::default()
            },
            ..RunSettings::default()
        },
        early_stop: EarlyStop::Never,
    }
}

fn bench(c: &mut Criterion) {
    let search = CriticalSpeedOptions::default();
    let x0 = State7::from_column_slice(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0]);
    let speeds: Vec<f64> = (2..=200).map(|k| 0.5 * f64::from(k)).collect();
    let mut g = c.benchmark_group("combination");
    for (name, plant) in vehicles() {
        let vc = with_plant!(&plant, m => m.critical_speed_search(&search))
            .expect("a search")
            .expect("a V_crit");
        let spec = s1_type(vc.v_crit_mps);
        let r = simulate_in_paper_layout::<7>(&plant, &spec, x0, Recording::None).expect("S1");
        eprintln!(
            "{name}: V_crit {:.6} m/s; S1-type {:?}, {:?}",
            vc.v_crit_mps, r.stats, r.metrics
        );
        g.bench_function(format!("v_crit_search/{name}"), |b| {
            b.iter(|| with_plant!(&plant, m => m.critical_speed_search(black_box(&search))))
        });
        g.bench_function(format!("s1_type/{name}"), |b| {
            b.iter(|| {
                simulate_in_paper_layout::<7>(&plant, black_box(&spec), x0, Recording::None)
                    .expect("S1")
                    .metrics
            })
        });
        g.bench_function(format!("sway_modes_199_speeds/{name}"), |b| {
            b.iter(|| modes_of(&plant, black_box(&speeds), 22.0).expect("modes"))
        });
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let truck = load_vehicle_spec(&root.join("configs/combinations/truck_dolly_semitrailer.toml"))
        .expect("the A-double")
        .plant;
    let settings = LaneChangeSettings::default();
    let solver = SolverSettings::default();
    g.bench_function("lane_change_80kmh/truck_dolly_semitrailer", |b| {
        b.iter(|| {
            lane_change(&truck, black_box(80.0 / 3.6), &settings, &solver).expect("a lane change")
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
