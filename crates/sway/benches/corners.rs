//! Issue 12 performance (release, medians): locating all double-Hopf points of one delay,
//! τ = 0.2 s, on the nonlinear chart's box V ∈ [5, 70] m/s, D ∈ [−0.1, 0.3] s (the
//! D-subdivision scan of 131 speeds and the refinement of every intersection of two Hopf
//! curves, with the root check), and τ = 0.4 s (none inside the box).

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::bifurcation::corners::double_hopf_points;
use trailer_model::{Model, VehicleParams};

fn locate(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I model");
    let mut g = c.benchmark_group("corners");
    g.sample_size(10);
    for tau in [0.2, 0.4] {
        g.bench_function(format!("double_hopf_points_tau_{tau}"), |b| {
            b.iter(|| {
                let p = double_hopf_points(&model, tau, (5.0, 70.0), (-0.1, 0.3), 131).unwrap();
                black_box(p)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, locate);
criterion_main!(benches);
