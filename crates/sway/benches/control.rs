//! One spectral-abscissa evaluation (the loop built at one speed, its rightmost
//! root) per controller structure at one (V, gains, τ), with steering; target ≤ 100 µs.
//! The predictor twice: with a perfect model (its loop is the delay-free one, a polynomial)
//! and with a model 10 % off in trailer mass (the cleared quasi-polynomial of degree 8).

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::control::{Actuator, Gains, LinearLoop, LoopLaw, Structure};
use trailer_model::{Model, VehicleParams};

fn spectral_abscissa(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I");
    let (speed, tau) = (40.0, 0.6);
    let cases = [
        (Structure::YawRate, Gains::yaw_rate(0.05)),
        (
            Structure::YawRateHitch,
            Gains {
                yaw_rate: 0.1,
                hitch_angle: 0.05,
                hitch_rate: 0.03,
            },
        ),
        (Structure::Predictor, Gains::yaw_rate(0.05)),
    ];
    let mut off = VehicleParams::default();
    off.trailer.mass *= 1.1;
    let off = Model::new(off).expect("Table I with 10 % more trailer mass");
    let mut group = c.benchmark_group("spectral_abscissa");
    let predictor = LoopLaw::new(
        Structure::Predictor,
        Actuator::Steering,
        Gains::yaw_rate(0.05),
        tau,
    );
    group.bench_function("predictor_model_off_10pct", |b| {
        b.iter(|| {
            let l =
                LinearLoop::new(&model, black_box(&predictor), speed, Some(&off)).expect("loop");
            l.rightmost_roots(1).expect("roots")[0].re
        })
    });
    for (structure, gains) in cases {
        let controller = LoopLaw::new(structure, Actuator::Steering, gains, tau);
        group.bench_function(structure.as_str(), |b| {
            b.iter(|| {
                let l = LinearLoop::new(&model, black_box(&controller), speed, None).expect("loop");
                l.rightmost_roots(1).expect("roots")[0].re
            })
        });
    }
    group.finish();
}

criterion_group!(benches, spectral_abscissa);
criterion_main!(benches);
