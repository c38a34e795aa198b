//! The lateral stability test of Table I at the shipped settings: 10 test speeds × (1 + 12)
//! impulses of 40 s (130 simulations) and the open-loop bifurcation diagram with its
//! corrected V_crit and V_fold, on all cores.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::progress::NoProgress;
use sway::ranging::SpeedLimits;
use sway_studies::lateral_stability::{LateralStabilityConfig, compute};
use trailer_model::{AnyVehicleModel, VehicleParams, VehicleSpec};

fn lateral_stability(c: &mut Criterion) {
    let vehicle =
        AnyVehicleModel::new(&VehicleSpec::from(VehicleParams::default())).expect("Table I");
    let cfg = LateralStabilityConfig::default();
    let mut g = c.benchmark_group("lateral_stability");
    g.sample_size(10);
    g.bench_function("table_i_10_speeds_12_impulses", |b| {
        b.iter(|| {
            let r = compute(
                black_box(&cfg),
                &vehicle,
                &SpeedLimits::default(),
                &NoProgress,
            )
            .expect("test");
            r.test_critical_speed_mps
        })
    });
    g.finish();
}

criterion_group!(benches, lateral_stability);
criterion_main!(benches);
