//! Cost of one evaluation of the reduced right-hand side (eq. 5–7), of its exact
//! Jacobian (forward-mode AD through the brush tires) and of the linearisation.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use trailer_model::{Inputs, Model, State4, State7, VehicleParams};

fn bench(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I");
    let x = State4::new(0.3, -0.05, 0.08, 0.12);
    let x7 = State7::from_column_slice(&[0.3, -0.05, 0.08, 0.12, 0.01, 5.0, -0.2]);
    let u = Inputs {
        steering_angle: 0.01,
        speed: 33.0,
        acceleration: -1.0,
    };
    c.bench_function("rhs4", |b| {
        b.iter(|| model.rhs4(black_box(&x), black_box(&u)))
    });
    c.bench_function("rhs7", |b| {
        b.iter(|| model.rhs7(black_box(&x7), black_box(&u)))
    });
    c.bench_function("jacobian4 (4x4 + d/dδ, exact)", |b| {
        b.iter(|| model.jacobian4(black_box(&x), black_box(&u)))
    });
    c.bench_function("linearize (7x7 A, B, C)", |b| {
        b.iter(|| model.linearize(black_box(33.0)))
    });
    c.bench_function("open-loop eigenvalues (4x4)", |b| {
        b.iter(|| model.open_loop_eigenvalues(black_box(33.0)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
