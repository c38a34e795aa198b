//! Issue 22: one spectral-abscissa evaluation (the loop built at one speed, its rightmost
//! root) per controller structure at one (V, gains, τ), with steering; target ≤ 100 µs.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::control::{Actuator, Controller, Gains, LinearLoop, Structure};
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
    let mut group = c.benchmark_group("spectral_abscissa");
    for (structure, gains) in cases {
        let controller = Controller {
            structure,
            actuator: Actuator::Steering,
            gains,
        };
        group.bench_function(structure.as_str(), |b| {
            b.iter(|| {
                let l = LinearLoop::new(&model, black_box(&controller), speed, tau, None)
                    .expect("loop");
                l.rightmost_roots(1).expect("roots")[0].re
            })
        });
    }
    group.finish();
}

criterion_group!(benches, spectral_abscissa);
criterion_main!(benches);
