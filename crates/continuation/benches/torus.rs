//! Torus curves: cost of one Newton step of the torus defining system versus the number of
//! mesh intervals L, and of a whole torus curve of 40 points, on the 4-dimensional delayed
//! test bed of `textbook::TorusTestBed` (τ = 2.5, τ/T ≈ 0.4), started at its double-Hopf
//! point on the torus curve of cycle 1.
use continuation::*;
use continuation_textbook::TorusTestBed;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::hint::black_box;

const TAU: f64 = 2.5;
/// mesh of the whole-curve benchmark (the torus curve is exact to ~1e-8 on it)
const CURVE_INTERVALS: usize = 10;

fn continuation() -> Continuation {
    Continuation::new(ContinuationOptions {
        initial_step: 0.02,
        max_step: 0.05,
        ..Default::default()
    })
}

/// the torus curve of cycle 1 started at the (closed-form) double-Hopf point with
/// amplitude 0.1 on L intervals: system, corrected first point and its tangent
fn torus_start(
    bed: &TorusTestBed,
    l: usize,
    multipliers: bool,
) -> (TorusCurveSystem<'_, TorusTestBed>, Vec<f64>, Vec<f64>) {
    let (omega, d) = bed.second_hopf(TAU);
    let hh = DoubleHopfPoint::new(bed, vec![0.0, d, TAU], vec![0.0; 4], [1.0, omega])
        .expect("double-Hopf point");
    let col = CollocationOptions {
        intervals: l,
        ..Default::default()
    };
    let options = TorusCurveOptions {
        multipliers,
        ..Default::default()
    };
    let (mut sys, guess, dir) =
        TorusCurveSystem::from_double_hopf(bed, &hh, [0, 1], 0, 0.1, col, options)
            .expect("torus system");
    let first = continuation()
        .start(&mut sys, &guess, &dir)
        .expect("torus curve start");
    let u = first.points[0].u.clone();
    let t = first.points[0].tangent.clone();
    sys.accept(&u);
    (sys, u, t)
}

fn bench(c: &mut Criterion) {
    let bed = TorusTestBed::delayed();
    let mut group = c.benchmark_group("torus_4d_dde");
    group.sample_size(10);
    for &l in &[10usize, 20, 40, 80] {
        let (mut sys, u, t) = torus_start(&bed, l, false);
        group.bench_with_input(BenchmarkId::new("newton_step", l), &l, |b, _| {
            b.iter(|| newton_step(&mut sys, black_box(&u), &t).expect("step"))
        });
    }
    for multipliers in [false, true] {
        let (mut sys, u, t) = torus_start(&bed, CURVE_INTERVALS, multipliers);
        let cont = continuation();
        let name = if multipliers {
            "curve_40_points_with_multipliers"
        } else {
            "curve_40_points"
        };
        group.bench_function(BenchmarkId::new(name, CURVE_INTERVALS), |b| {
            b.iter(|| {
                let mut curve = cont.start(&mut sys, &u, &t).expect("start");
                let stop = sys.extend_curve(&cont, &mut curve, 40).expect("curve");
                assert!(curve.points.len() > 40, "{stop:?}");
                curve
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
