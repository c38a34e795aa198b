//! The whole default Fig. 4(a) computation (configs/fig4a.toml: 4 delays, 300 × 200 cells each,
//! boundaries and headline numbers; no file output), the derivation of its omitted axes from
//! the vehicle alone, and the rightmost roots at one point.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use sway_tasks::tasks::fig4a::{Fig4aConfig, compute};
use trailer_model::{Model, VehicleParams};

fn config() -> Fig4aConfig {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/fig4a.toml");
    sway_tasks::config_file::load_toml(&file).expect("configs/fig4a.toml")
}

fn fig4a(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).unwrap();
    let cfg = config();
    let bounds = sway::charts::auto_range::SpeedBounds::default();
    let mut g = c.benchmark_group("fig4a");
    g.sample_size(10);
    g.bench_function("derive_ranges", |b| {
        b.iter(|| sway_studies::fig4a::resolve(black_box(&model), &cfg, &bounds).unwrap())
    });
    g.bench_function("default_config", |b| {
        b.iter(|| compute(black_box(&model), &cfg, &bounds).unwrap())
    });
    g.finish();
    let mut g = c.benchmark_group("roots_point");
    for tau in [0.0, 0.1, 0.2, 0.4] {
        g.bench_function(format!("v35_d0.1_tau{tau}_6_roots"), |b| {
            b.iter(|| sway::charts::rightmost_roots(&model, 35.0, black_box(0.1), tau, 6).unwrap())
        });
        g.bench_function(format!("v35_d0.1_tau{tau}_2_roots"), |b| {
            b.iter(|| sway::charts::rightmost_roots(&model, 35.0, black_box(0.1), tau, 2).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, fig4a);
criterion_main!(benches);
