//! The FMU's `doStep` against the native solver over the same interval (release, medians;
//! target: doStep ≤ native + 2 µs per call). S1 (open loop, V = 33 m/s, θ(0) = 0.1 rad,
//! rtol 1e-8 / atol 1e-10) for 1 s in 100 communication steps of 10 ms:
//!
//! - `native_one_run_1s`: `sway::sim::simulate` to 1 s in one call (the solver's steps
//!   free, no communication point);
//! - `engine_100_steps_1s`: the FMU's engine (`sway_fmu::engine`, the same `dde` solver on
//!   `sway`'s `SimProblem`) integrating to each of the 100 points in turn: the native
//!   solver over the same intervals, landing on every communication point;
//! - `fmi2DoStep_100_steps_1s`: the same through the C API (`fmi2DoStep` of the rlib's
//!   exported functions: pointer checks, `catch_unwind`, the instance's state machine and
//!   input checks, and the 20 outputs computed after each step);
//! - `fmi2DoStep_zero_length` and `fmi2GetReal_4_outputs`: one call of each, the cost of a
//!   call with nothing to integrate.
//!
//! The overhead per call is (`fmi2DoStep_100_steps_1s` − `engine_100_steps_1s`) / 100.
//! Results: docs/src/performance.md (`cargo bench --bench fmu`).

// the FMU's `extern "C"` entry points are called as an importer calls them
#![allow(unsafe_code)]

use std::hint::black_box;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use sway::sim::{EarlyStop, HeldInputs, Recording, SimSpec, SpeedProfile, simulate};
use sway_fmu::config::Defaults;
use sway_fmu::engine::{Engine, EngineSpec, build};
use sway_fmu::ffi::Component;
use sway_fmu::ffi::fmi2::{
    fmi2DoStep, fmi2EnterInitializationMode, fmi2ExitInitializationMode, fmi2FreeInstance,
    fmi2GetReal, fmi2Instantiate, fmi2SetReal, fmi2SetupExperiment,
};
use sway_fmu::instance::Instance;
use trailer_model::{AnyVehicleModel, Model, State7, VehicleParams};

const STEPS: usize = 100;
const H: f64 = 0.01;

/// An initialised FMI 2.0 instance at θ(0) = 0.1 rad, through the C API.
fn instance() -> *mut Component {
    let names = Instance::new(Defaults::default()).expect("defaults");
    let theta0 = names.reference("initial_hitch_angle_rad").expect("vr");
    // SAFETY: C strings and a null callback struct (no logger), as an importer may pass
    unsafe {
        let c = fmi2Instantiate(
            c"bench".as_ptr(),
            1,
            c"".as_ptr(),
            c"".as_ptr(),
            std::ptr::null(),
            0,
            0,
        );
        assert!(!c.is_null());
        assert_eq!(fmi2SetReal(c, &theta0, 1, &0.1) as i32, 0);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) as i32, 0);
        assert_eq!(fmi2EnterInitializationMode(c) as i32, 0);
        assert_eq!(fmi2ExitInitializationMode(c) as i32, 0);
        c
    }
}

fn engine() -> Box<dyn Engine> {
    build(&EngineSpec {
        plant: AnyVehicleModel::Paper(Model::new(VehicleParams::default()).expect("Table I")),
        law: None,
        initial: [0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0],
        speed_mps: 33.0,
        start_s: 0.0,
        solver: Default::default(),
    })
    .expect("engine")
}

fn held() -> HeldInputs {
    HeldInputs {
        speed_mps: Some(33.0),
        ..Default::default()
    }
}

fn do_step(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I");
    let spec = SimSpec {
        early_stop: EarlyStop::Never,
        steering: Default::default(),
        profile: SpeedProfile::Constant { speed_mps: 33.0 },
        controller: None,
        horizon_s: STEPS as f64 * H,
        action_s: 0.0,
        settings: Default::default(),
    };
    let x0 = State7::from_column_slice(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0]);
    // the three agree on θ(1 s) (a check that they integrate the same problem)
    let native = simulate(&model, &spec, x0, Recording::None).expect("native");
    let mut e = engine();
    for k in 0..STEPS {
        e.step(held(), (k + 1) as f64 * H).expect("step");
    }
    let theta_engine = e.outputs(held())[3];
    eprintln!(
        "θ(1 s): native {:.9}, engine {theta_engine:.9}; native stats {:?}",
        native.x_end[3], native.stats
    );

    let mut g = c.benchmark_group("fmu");
    g.bench_function("native_one_run_1s", |b| {
        b.iter(|| simulate(&model, black_box(&spec), x0, Recording::None).expect("native"))
    });
    g.bench_function("engine_100_steps_1s", |b| {
        b.iter_batched(
            engine,
            |mut e| {
                for k in 0..STEPS {
                    black_box(e.step(held(), (k + 1) as f64 * H).expect("step"));
                }
                e
            },
            BatchSize::SmallInput,
        )
    });
    g.bench_function("fmi2DoStep_100_steps_1s", |b| {
        b.iter_batched(
            instance,
            |c| {
                for k in 0..STEPS {
                    // SAFETY: a live instance of `instance()`
                    let s = unsafe { fmi2DoStep(c, k as f64 * H, H, 1) };
                    assert_eq!(s as i32, 0);
                }
                c
            },
            BatchSize::SmallInput,
        )
    });
    let c0 = instance();
    // SAFETY: a live instance, freed at the end
    unsafe {
        assert_eq!(fmi2DoStep(c0, 0.0, H, 1) as i32, 0);
    }
    g.bench_function("fmi2DoStep_zero_length", |b| {
        // SAFETY: as above
        b.iter(|| unsafe { fmi2DoStep(c0, black_box(H), 0.0, 1) })
    });
    let vr = [3u32 + 4, 4 + 8, 4 + 9, 4 + 10]; // θ, ψ̇, ψ̇ + θ̇, a_y (inputs are 0–3)
    let mut out = [0.0; 4];
    g.bench_function("fmi2GetReal_4_outputs", |b| {
        // SAFETY: as above
        b.iter(|| unsafe { fmi2GetReal(c0, vr.as_ptr(), 4, out.as_mut_ptr()) })
    });
    g.finish();
    // SAFETY: freed once
    unsafe { fmi2FreeInstance(c0) };
}

criterion_group!(benches, do_step);
criterion_main!(benches);
