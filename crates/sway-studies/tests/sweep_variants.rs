//! Sweeps over vehicles with model variants and over starts on the sway cycle: the points
//! equal what the analyses and the simulation compute on their own.

use std::path::Path;

use sway::SwayError;
use sway::bifurcation::{CycleExtent, DiagramOutcome, DiagramSettings, vehicle_diagram};
use sway::ranging::SpeedLimits;
use sway::sim::{LoopLaw, SolverSettings, settle_in_paper_layout};
use sway_model::vehicle::LoopModel;
use sway_studies::sweep::*;
use trailer_model::{AnyVehicleModel, Model, VehicleParams, VehicleSpec};

fn parse(text: &str) -> SweepConfig {
    let cfg: SweepConfig = toml::from_str(text).unwrap();
    cfg.validate(Path::new("test.toml")).unwrap();
    cfg
}

/// Table I with tyre relaxation (σ = 0.3 m on every axle): a 7-state vehicle.
fn relaxed() -> VehicleSpec {
    VehicleSpec::table_i_with_relaxation(0.3)
}

#[test]
fn a_vehicle_with_variants_gets_closed_loop_and_hopf_fold_speeds_in_sweeps() {
    // reference: two formulations of the loss of stability of the delayed loop
    // δ = −D·ψ̇(t − τ) on the relaxed vehicle: the unstable-root count of its
    // quasi-polynomial (linear kind) and the Hopf point of its bifurcation diagram
    // corrected on the Hopf defining system (hopf_fold_speeds kind): equal to 1e-6 m/s (the
    // count bisects to 1e-8 m/s, the Hopf point is Newton-converged). The sweep's points
    // equal the analyses called directly on the same plant.
    let spec = relaxed();
    assert!(spec.has_variants().unwrap());
    let plant = AnyVehicleModel::new(&spec).unwrap();
    let law = LoopLaw::paper(0.1, 0.2);
    let mut o = AnalysisOptions {
        v_max_mps: Some(60.0),
        ..AnalysisOptions::default()
    };
    o.diagram.intervals = 20;
    let limits = SpeedLimits::default();
    let linear = linear_critical_speed(&plant, Some(&law), &o, &limits).unwrap();
    let v_lin = linear
        .v_crit_mps
        .expect("the relaxed loop loses stability below 60 m/s");
    let hopf = trailer_model::with_plant!(&plant, m => diagram_hopf_fold_speeds(m, Some(&law), &o, &limits))
        .unwrap();
    let v_hopf = hopf.hopf_v_mps.expect("a Hopf point");
    assert!((v_lin - v_hopf).abs() < 1e-6, "{v_lin} vs {v_hopf}");
    let (w_lin, w_hopf) = (
        linear.hopf_omega_rad_s.unwrap(),
        hopf.hopf_omega_rad_s.unwrap(),
    );
    assert!((w_lin - w_hopf).abs() < 1e-6, "{w_lin} vs {w_hopf}");
    // relaxation lags the tyre forces: the relaxed loop differs from Table I's
    let table_i = Model::new(VehicleParams::default()).unwrap();
    let v_table_i = linear_critical_speed(&table_i, Some(&law), &o, &limits)
        .unwrap()
        .v_crit_mps
        .unwrap();
    assert!((v_lin - v_table_i).abs() > 1e-3, "{v_lin} vs {v_table_i}");

    // the same through a sweep of each kind on the vehicle file
    for (kind, expected) in [
        (
            "linear_critical_speed",
            PointOutput::LinearCriticalSpeed(linear),
        ),
        ("hopf_fold_speeds", PointOutput::HopfFoldSpeeds(hopf)),
    ] {
        let cfg = parse(&format!(
            r#"name = "t"
kind = "{kind}"
[[axes]]
parameter = "gain_s"
min = 0.1
max = 0.1
points = 1
[analysis]
v_max_mps = 60.0
[analysis.diagram]
intervals = 20
[base]
speed = {{ kind = "constant", speed_mps = 30.0 }}
controller = {{ kind = "yaw_rate_feedback", delay_s = 0.2, gain_s = 0.1 }}
initial = {{ kind = "state", theta0_deg = 2.0 }}
"#
        ));
        let sweep = Sweep::new(&VehicleParams::default(), &[], &cfg)
            .unwrap()
            .with_vehicle_spec(&spec)
            .unwrap();
        assert_eq!(sweep.run_point(0).output, Ok(expected), "{kind}");
    }
}

#[test]
fn settling_without_a_stable_sway_cycle_is_an_outcome_and_with_one_ends_on_it() {
    // reference: the bifurcation diagram (collocation with Floquet multipliers) says where
    // a stable cycle exists. Table I at 36 m/s has one: settling from θ(0) = 0.1 rad ends
    // on it (|θ| within its amplitude, +1e-3 relative for the phase the simulation ends
    // in). Generated vehicle 14 of the issue-52 study (seed 52: Magic Formula tyres, tandem
    // trailer axles) has none just above its subcritical Hopf point: settling loses control
    // (NoSwayCycle) instead of crawling through the jackknife.
    let solver = SolverSettings::default();
    let limits = SpeedLimits::default();
    let stable_amplitude = |plant: &AnyVehicleModel, v: f64| -> Option<f64> {
        trailer_model::with_plant!(plant, m => {
            let d = match vehicle_diagram(
                m,
                LoopLaw::OPEN_LOOP,
                &DiagramSettings::default(),
                &limits,
                CycleExtent::WholeRange,
            )
            .unwrap()
            {
                DiagramOutcome::Computed(d) => d,
                DiagramOutcome::NoHopf(n) => panic!("{}", n.reason),
            };
            d.cycles_at(m, v)
                .unwrap()
                .into_iter()
                .filter(|c| c.stable)
                .map(|c| c.amplitude_deg)
                .reduce(f64::max)
        })
    };

    let table_i = AnyVehicleModel::new(&VehicleSpec::from(VehicleParams::default())).unwrap();
    let amplitude = stable_amplitude(&table_i, 36.0).expect("Table I sways at 36 m/s");
    let x = settle_in_paper_layout(&table_i, 36.0, 0.1, 200.0, &solver).unwrap();
    let theta = x[3].abs().to_degrees();
    assert!(
        theta <= amplitude * (1.0 + 1e-3),
        "{theta} vs {amplitude} deg"
    );

    let generated = &sway_model::generator::generate(52, 15)[14];
    let plant = AnyVehicleModel::new(&generated.spec).unwrap();
    let v = 1.007
        * LoopModel::critical_speed_search(&plant, &Default::default())
            .unwrap()
            .expect("generated-14 loses stability")
            .v_crit_mps;
    assert_eq!(
        stable_amplitude(&plant, v),
        None,
        "no stable cycle at {v} m/s"
    );
    match settle_in_paper_layout(&plant, v, 0.1, 200.0, &solver) {
        Err(SwayError::NoSwayCycle {
            speed_mps, time_s, ..
        }) => {
            assert_eq!(speed_mps, v);
            assert!(time_s > 0.0 && time_s < 200.0, "{time_s}");
        }
        other => panic!("expected NoSwayCycle, got {other:?}"),
    }
    // mitigation's search for the cycle: no sway at this speed, an outcome
    let found = trailer_model::with_plant!(&plant, m => sway::mitigation::find_sway_cycle(m, v, 0.1, 200.0, 20.0, &solver).map(|r| r.err()))
        .unwrap();
    assert!(
        found.is_some_and(|reason| reason.starts_with("no sway cycle to start from")),
        "mitigation found a sway cycle"
    );
}

#[test]
fn points_that_start_on_the_sway_cycle_equal_their_own_simulation() {
    // reference: `simulate_point`, which settles on the sway cycle itself for every call;
    // the sweep settles once for all points of the unchanged vehicle. Equal to the bit.
    let cfg = parse(
        r#"name = "t"
[[axes]]
parameter = "brake_start_s"
min = 2.0
max = 4.0
points = 2
[[axes]]
parameter = "ramp_duration_s"
min = 2.0
max = 4.0
points = 2
[base]
horizon_s = 12.0
speed = { kind = "ramp", initial_mps = 36.0, change_mps = -8.0, start_s = 2.0, duration_s = 3.0 }
controller = { kind = "none" }
initial = { kind = "sway_cycle", speed_mps = 36.0, settle_s = 40.0, theta0_rad = 0.1 }
[base.solver]
rtol = 1e-7
atol = 1e-9
"#,
    );
    let sweep = Sweep::new(&VehicleParams::default(), &[], &cfg).unwrap();
    let model = Model::new(VehicleParams::default()).unwrap();
    for k in 0..4 {
        let r = sweep.run_point(k);
        let mut s = cfg.base.clone();
        set_scenario(&mut s, SweepParameter::BrakeStartS, r.values[0]).unwrap();
        set_scenario(&mut s, SweepParameter::RampDurationS, r.values[1]).unwrap();
        let (m, steps) = simulate_point(&model, &s, 12.0).unwrap();
        assert_eq!(r.output, Ok(PointOutput::Simulation(m)), "point {k}");
        assert_eq!(r.steps, steps);
    }
}

#[test]
fn a_start_without_a_sway_cycle_is_nothing_to_show_for_simulate_and_fig3b() {
    // reference: the settling outcome above (generated vehicle 14 has no stable sway cycle
    // at 1.007·V_crit). The scenario of `simulate` and the braking runs of `fig3b` that
    // start there are an outcome naming the start's speed key, not an error; Table I
    // (a stable cycle at 35 m/s) runs.
    let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let limits = SpeedLimits::default();
    let progress = sway::progress::NoProgress;
    let scenario_file = configs.join("scenario_example.toml");
    let scenario: sway::sim::ScenarioConfig<sway::ranging::SpeedSpec> =
        toml::from_str(&std::fs::read_to_string(&scenario_file).unwrap()).unwrap();
    let fig3b_file = configs.join("fig3b.toml");
    let fig3b: sway_studies::fig3b::Fig3bConfig<sway::ranging::SpeedSpec> =
        toml::from_str(&std::fs::read_to_string(&fig3b_file).unwrap()).unwrap();

    let generated = &sway_model::generator::generate(52, 15)[14];
    let plant = AnyVehicleModel::new(&generated.spec).unwrap();
    let r = sway_studies::simulate::compute(
        &scenario,
        &plant,
        &limits,
        &scenario_file,
        false,
        &progress,
    )
    .unwrap();
    let u = r.outcome.expect_err("no sway cycle to start from");
    assert_eq!(u.key, "initial.speed_mps");
    assert!(
        u.reason.starts_with("no sway cycle to start from"),
        "{}",
        u.reason
    );
    let r = sway_studies::fig3b::compute(&fig3b, &plant, &limits, &fig3b_file, &progress).unwrap();
    let u = r.outcome.expect_err("no sway cycle to brake from");
    assert_eq!(u.key, "start.speed_mps");

    let table_i = AnyVehicleModel::new(&VehicleSpec::from(VehicleParams::default())).unwrap();
    let r = sway_studies::simulate::compute(
        &scenario,
        &table_i,
        &limits,
        &scenario_file,
        false,
        &progress,
    )
    .unwrap();
    assert!(r.outcome.is_ok());
}
