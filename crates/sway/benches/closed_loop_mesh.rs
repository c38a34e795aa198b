//! Issue 23 performance (release, medians): the closed-loop bifurcation diagram at
//! τ = 0.2 s, D = 0.1 s (fig4b's settings, `DiagramOptions::closed_loop`) on L = 40 and
//! L = 120 mesh intervals (target: L = 120 at most 3× L = 40), with the cycle branch's
//! branch-point test on (the default: the bordered determinant needs the direct sparse LU)
//! and off (the Newton systems by the default structured solver).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::bifurcation::{BranchPointTest, DiagramOptions, Feedback, bifurcation_diagram};
use trailer_model::{Model, VehicleParams};

fn diagrams(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I model");
    let feedback = Feedback {
        gain_d_s: 0.1,
        delay_s: 0.2,
    };
    let mut g = c.benchmark_group("closed_loop_mesh");
    g.sample_size(10);
    for (test, name) in [
        (BranchPointTest::Watch, "diagram"),
        (BranchPointTest::Ignore, "diagram_no_branch_points"),
    ] {
        for l in [40usize, 120] {
            let options = DiagramOptions {
                intervals: l,
                cycle_branch_points: test,
                ..DiagramOptions::closed_loop()
            };
            g.bench_with_input(BenchmarkId::new(name, l), &l, |b, _| {
                b.iter(|| black_box(bifurcation_diagram(&model, feedback, &options).unwrap()))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, diagrams);
criterion_main!(benches);
