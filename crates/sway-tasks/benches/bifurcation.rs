//! Whole bifurcation diagrams: `fig3a` (open loop, Hopf to beyond the fold, ≥ 100 cycle
//! points with Floquet multipliers; target ≤ 1 s) and `fig4b` (all (τ, D) pairs of the
//! default config, parallel over pairs; target ≤ 10 s on 2 cores).
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::bifurcation::{DiagramOptions, LoopLaw, bifurcation_diagram};
use sway::progress::NoProgress;
use sway_tasks::tasks::fig4b::{Fig4bConfig, diagrams};
use trailer_model::{Model, VehicleParams};

fn bench(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I model");
    let mut g = c.benchmark_group("bifurcation");
    g.sample_size(10);
    g.bench_function("fig3a_diagram", |b| {
        b.iter(|| {
            let d = bifurcation_diagram(&model, LoopLaw::OPEN_LOOP, &DiagramOptions::default())
                .expect("diagram");
            assert!(d.cycle_summary.len() >= 100);
            black_box(d)
        })
    });
    let cfg: Fig4bConfig =
        toml::from_str(include_str!("../../../configs/fig4b.toml")).expect("configs/fig4b.toml");
    g.bench_function("fig4b_all_pairs", |b| {
        let limits = sway::ranging::SpeedLimits::default();
        b.iter(|| black_box(diagrams(&model, &cfg, &limits, &NoProgress).expect("diagrams")))
    });
    // the same diagram on the range derived from the vehicle (≤ 10 % dearer)
    g.bench_function("fig3a_diagram_derived_range", |b| {
        let limits = sway::ranging::SpeedLimits::default();
        b.iter(|| {
            black_box(
                sway::bifurcation::vehicle_diagram(
                    &model,
                    LoopLaw::OPEN_LOOP,
                    &sway::bifurcation::DiagramSettings::default(),
                    &limits,
                    sway::bifurcation::CycleExtent::WholeRange,
                )
                .expect("diagram"),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
