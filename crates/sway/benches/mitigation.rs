//! Issue 10 performance target (release, median): one objective evaluation of the
//! mitigation optimisation — the paper's combined strategy (ΔV = −10 m/s over 5 s, linear;
//! D = 0.1 s, τ = 0.2 s) from 16 phases of the sway cycle at 35 m/s (over half a period,
//! the task's default with the mirror symmetry), 40 s each after a
//! 0.2 s lead-in, rtol 1e-8 / atol 1e-10, in parallel (target ≤ 30 ms on 2 cores); and the
//! same at the optimiser's search tolerance rtol 1e-6 / atol 1e-8; and that evaluation
//! asked for its cost unless above 10 s (the combined strategy's worst phase settles after
//! ≈ 14 s: the answer is `Above`, found when the first phase's run passes 10 s unsettled),
//! as the optimiser asks for a trial point's cost.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::mitigation::{
    Intervention, PhaseStarts, Setting, evaluate, evaluate_unless_above, sway_cycle,
};
use sway::sim::{ActuatorLimits, RampShape, RunSettings, SolverSettings};
use sway_model::optimise::Bounded;
use trailer_model::{Model, VehicleParams};

fn objective(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).unwrap();
    let solver = SolverSettings::default();
    let cycle = sway_cycle(&model, 35.0, 0.1, 200.0, 20.0, &solver).unwrap();
    let starts = PhaseStarts::new(&model, &cycle, 16, 0.5, 0.2, &solver).unwrap();
    let combined = Intervention {
        speed_change_mps: -10.0,
        duration_s: 5.0,
        shape: RampShape::Linear,
        gain_s: 0.1,
        on_s: 0.0,
        off_s: None,
    };
    let mut setting = Setting {
        speed_mps: 35.0,
        delay_s: 0.2,
        actuator: ActuatorLimits::NONE,
        horizon_s: 40.0,
        peak_limit_deg: 45.0,
        settings: RunSettings::default(),
    };
    let e = evaluate(&model, &setting, &starts, &combined).unwrap();
    eprintln!(
        "period {} s; combined: worst settle {:?} s at phase {}",
        cycle.period_s, e.worst_settle_time_s, e.worst_phase
    );
    c.bench_function("objective_16_phases_40s_rtol1e-8", |b| {
        b.iter(|| {
            evaluate(&model, &setting, &starts, black_box(&combined))
                .unwrap()
                .cost
        })
    });
    setting.settings.solver = SolverSettings {
        rtol: 1e-6,
        atol: 1e-8,
        ..solver
    };
    c.bench_function("objective_16_phases_40s_rtol1e-6", |b| {
        b.iter(|| {
            evaluate(&model, &setting, &starts, black_box(&combined))
                .unwrap()
                .cost
        })
    });
    let cutoff = 10.0;
    assert_eq!(
        evaluate_unless_above(&model, &setting, &starts, &combined, cutoff).unwrap(),
        Bounded::Above
    );
    c.bench_function("objective_16_phases_40s_rtol1e-6_unless_above_10s", |b| {
        b.iter(|| {
            evaluate_unless_above(&model, &setting, &starts, black_box(&combined), cutoff).unwrap()
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = objective
}
criterion_main!(benches);
