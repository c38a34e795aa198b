//! Cost of one evaluation of the reduced right-hand side (eq. 5–7), of its exact
//! Jacobian (forward-mode AD through the brush tires) and of the linearisation; and of the
//! general model: Table I through `VehicleModel<4>` (the paper's model without
//! variants), and the 10-state full system with relaxation on the three axles
//! (`VehicleModel<7>`, σ = 0.3 m) against the paper's 7-state `rhs7`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::SVector;
use trailer_model::{
    Inputs, Model, Plant, State4, State7, VehicleModel, VehicleParams, VehicleSpec,
};

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

    // the general model
    let paper =
        VehicleModel::<4>::new(&VehicleSpec::from(VehicleParams::default())).expect("Table I");
    let relaxed =
        VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.3)).expect("σ = 0.3 m");
    let x10 = SVector::<f64, 10>::from_column_slice(&[
        0.3, -0.05, 0.08, 0.12, 0.02, -0.01, 0.03, 0.01, 5.0, -0.2,
    ]);
    let x7r = x10.fixed_rows::<7>(0).into_owned();
    c.bench_function("VehicleModel<4> rhs (Table I, general code)", |b| {
        b.iter(|| paper.rhs(black_box(&x), black_box(&u)))
    });
    c.bench_function("VehicleModel<4> rhs_full (7 states, general code)", |b| {
        b.iter(|| paper.rhs_full(black_box(&x7), black_box(&u)))
    });
    c.bench_function("VehicleModel<7> rhs (relaxation, 7 reduced states)", |b| {
        b.iter(|| relaxed.rhs(black_box(&x7r), black_box(&u)))
    });
    c.bench_function("VehicleModel<7> rhs_full (relaxation, 10 states)", |b| {
        b.iter(|| relaxed.rhs_full(black_box(&x10), black_box(&u)))
    });
    c.bench_function("VehicleModel<7> jacobian (7x7 + d/dδ, exact)", |b| {
        b.iter(|| Plant::jacobian(&relaxed, black_box(&x7r), black_box(&u)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
