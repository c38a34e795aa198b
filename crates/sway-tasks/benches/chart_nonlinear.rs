//! The whole default `chart_nonlinear` computation (target ≤ 30 s on 2 cores):
//! Hopf curves, criticality samples, the fold-of-cycles curve, the shading grid and the
//! summary readings for all delays of `configs/chart_nonlinear.toml` (parallel over τ);
//! and, per piece, the τ = 0.2 s delay alone, and the derivation of the omitted ranges
//! from the vehicle (box, seeds, summary gains).
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::charts::auto_range::SpeedBounds;
use sway::progress::NoProgress;
use sway_tasks::tasks::chart_nonlinear::{ChartNonlinearConfig, compute, compute_delay};
use trailer_model::{Model, VehicleParams};

fn bench(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I model");
    let cfg: ChartNonlinearConfig =
        toml::from_str(include_str!("../../../configs/chart_nonlinear.toml"))
            .expect("configs/chart_nonlinear.toml");
    let bounds = SpeedBounds::default();
    let resolved = cfg.resolve(&model, &bounds).expect("ranges");
    let mut g = c.benchmark_group("chart_nonlinear");
    g.sample_size(10);
    g.bench_function("derive_ranges", |b| {
        b.iter(|| black_box(cfg.resolve(&model, &bounds).expect("ranges")))
    });
    g.bench_function("all_delays", |b| {
        b.iter(|| black_box(compute(&model, &cfg, &bounds, &NoProgress).expect("chart")))
    });
    g.bench_function("tau_0.2", |b| {
        b.iter(|| black_box(compute_delay(&model, &resolved, 0.2).expect("chart")))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
