//! Issue 11 performance targets (release, medians):
//! - sweep overhead per point (all but the integration itself) ≤ 5 % of S1: S1 (60 s open
//!   loop at 33 m/s, θ(0) = 0.1 rad, rtol 1e-8, 4 states as a sweep runs it) through
//!   `simulate` and as a sweep point (`Sweep::run_point`, with a vehicle-field axis so that
//!   the point also builds its model); the difference is the overhead;
//! - a 100 000-point linear-critical-speed sweep over two vehicle fields (h × l,
//!   400 × 250) ≤ 10 s on 2 cores (and one such point alone).

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::progress::NoProgress;
use sway::sim::{Recording, SimSpec, simulate};
use sway_studies::sweep::{Sweep, SweepConfig, run_sweep};
use trailer_model::{Model, State4, VehicleParams};

const S1: &str = r#"
name = "s1"
[[axes]]
parameter = "trailer.mass"   # a vehicle axis: the point builds and validates its model
min = 985.0
max = 985.0
points = 1
[base]
horizon_s = 60.0
speed = { kind = "constant", speed_mps = 33.0 }
controller = { kind = "none" }
initial = { kind = "state", theta0_deg = 5.729577951308232 }
[base.solver]
rtol = 1e-8
atol = 1e-10
"#;

fn overhead(c: &mut Criterion) {
    let cfg: SweepConfig = toml::from_str(S1).unwrap();
    cfg.validate(std::path::Path::new("s1")).unwrap();
    let sweep = Sweep::new(&VehicleParams::default(), &[], &cfg).unwrap();
    let model = Model::new(VehicleParams::default()).unwrap();
    let spec = SimSpec {
        early_stop: sway::sim::EarlyStop::Never,
        steering: Default::default(),
        profile: cfg.base.speed.clone(),
        controller: cfg.base.controller.law().unwrap(),
        horizon_s: 60.0,
        action_s: 0.0,
        settings: cfg.base.settings,
    };
    let x0 = State4::new(0.0, 0.0, 0.0, 5.729577951308232_f64.to_radians());
    let direct = simulate(&model, &spec, x0, Recording::None).unwrap();
    let point = sweep.run_point(0);
    assert_eq!(point.metrics(), Some(&direct.metrics));
    let mut g = c.benchmark_group("sweep_overhead");
    g.bench_function("S1_simulate_4_states", |b| {
        b.iter(|| {
            simulate(&model, black_box(&spec), x0, Recording::None)
                .unwrap()
                .metrics
        })
    });
    g.bench_function("S1_as_sweep_point", |b| {
        b.iter(|| sweep.run_point(black_box(0)).steps)
    });
    g.finish();
}

const LINEAR: &str = r#"
name = "linear_100k"
kind = "linear_critical_speed"
[[axes]]
parameter = "trailer.cog"    # h [m]
min = 2.7
max = 3.1
points = 400
[[axes]]
parameter = "trailer.axle"   # l [m]
min = 2.6
max = 3.0
points = 250
[base]
speed = { kind = "constant", speed_mps = 30.0 }
controller = { kind = "none" }
initial = { kind = "state", theta0_deg = 0.0 }
"#;

fn linear_sweep(c: &mut Criterion) {
    let cfg: SweepConfig = toml::from_str(LINEAR).unwrap();
    cfg.validate(std::path::Path::new("linear_100k")).unwrap();
    let sweep = Sweep::new(&VehicleParams::default(), &[], &cfg).unwrap();
    assert_eq!(sweep.len(), 100_000);
    let mut g = c.benchmark_group("linear_critical_speed_sweep");
    g.bench_function("one_point", |b| {
        b.iter(|| sweep.run_point(black_box(54_321)))
    });
    g.sample_size(10);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    g.bench_function("100k_points_2_threads", |b| {
        b.iter(|| {
            pool.install(|| run_sweep(black_box(&sweep), &NoProgress))
                .len()
        })
    });
    g.finish();
}

criterion_group!(benches, overhead, linear_sweep);
criterion_main!(benches);
