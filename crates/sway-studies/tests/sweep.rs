//! Sweeps of simulations: determinism across thread counts and agreement with single runs,
//! a failing point reported rather than fatal, the brake-timing sweep against fig3b/fig4c.
mod common;

use approx::assert_abs_diff_eq;
use common::{model, x7};
use sway::config::Positive;
use sway::progress::NoProgress;
use sway::sim::{
    InitialCondition, MetricSettings, Outcome, Recording, RunSettings, SimSpec, SolverSettings,
    SpeedProfile, ValidityGuard, simulate,
};
use sway_studies::sweep::{
    Axis, AxisParameter, BaseScenario, Sweep, SweepConfig, SweepParameter, run_sweep,
};

fn small_sweep() -> SweepConfig {
    SweepConfig {
        name: "test".into(),
        kind: Default::default(),
        axes: vec![
            Axis::range(
                AxisParameter::Scenario(SweepParameter::SpeedMps),
                30.0,
                35.0,
                3,
            ),
            Axis::range(
                AxisParameter::Scenario(SweepParameter::Theta0Deg),
                2.0,
                10.0,
                2,
            ),
        ],
        base: BaseScenario {
            horizon_s: Positive::new(8.0).unwrap(),
            action_s: Some(0.0),
            speed: SpeedProfile::Constant { speed_mps: 33.0 },
            controller: sway::sim::ControllerTable::None,
            initial: InitialCondition::State {
                sigma1_mps: 0.0,
                sigma2_per_s: 0.0,
                sigma3_per_s: 0.0,
                theta0_deg: 2.0,
                psi0_deg: 0.0,
            },
            settings: RunSettings {
                guard: ValidityGuard::Stop,
                solver: SolverSettings {
                    rtol: 1e-6,
                    atol: 1e-8,
                    ..SolverSettings::default()
                },
                metrics: MetricSettings::default(),
            },
        },
        sampling: None,
        threshold: None,
        analysis: Default::default(),
    }
}

/// The sweep of `cfg` on the Table I vehicle.
fn sweep_of(cfg: &SweepConfig) -> Sweep {
    Sweep::new(&trailer_model::VehicleParams::default(), &[], cfg).unwrap()
}

#[test]
fn sweep_is_deterministic_across_thread_counts_and_matches_single_runs() {
    let m = model();
    let cfg = small_sweep();
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    let sweep = sweep_of(&cfg);
    let one = pool(1).install(|| run_sweep(&sweep, &NoProgress));
    let two = pool(2).install(|| run_sweep(&sweep, &NoProgress));
    assert_eq!(one, two);
    assert_eq!(one.len(), 6);
    // grid order: first axis fastest
    assert_eq!(one[1].values, vec![32.5, 2.0]);
    assert_eq!(one[3].values, vec![30.0, 10.0]);
    // the sweep's 4-state run equals a 7-state simulate to tolerance level
    let s = SimSpec {
        early_stop: sway::sim::EarlyStop::Never,
        steering: Default::default(),
        profile: SpeedProfile::Constant { speed_mps: 35.0 },
        controller: None,
        horizon_s: 8.0,
        action_s: 0.0,
        settings: RunSettings {
            guard: ValidityGuard::Stop,
            solver: cfg.base.settings.solver,
            metrics: MetricSettings::default(),
        },
    };
    let r7 = simulate(&m, &s, x7(10.0), Recording::None).unwrap();
    let swept = one[5].metrics().unwrap();
    assert_abs_diff_eq!(
        swept.final_amplitude_deg.unwrap(),
        r7.metrics.final_amplitude_deg.unwrap(),
        epsilon = 1e-3
    );
}

#[test]
fn a_failing_point_is_reported_not_fatal() {
    let mut cfg = small_sweep();
    cfg.base.settings.solver.max_steps = 20;
    let sweep = sweep_of(&cfg);
    let r = sweep.run_point(0);
    let msg = r.output.unwrap_err();
    assert!(msg.contains("max_steps"), "{msg}");
    let all = run_sweep(&sweep, &NoProgress);
    assert_eq!(all.len(), 6);
}

#[test]
fn brake_timing_sweep_reproduces_fig3b_and_fig4c_points() {
    // Reference: the committed fig3b / fig4c results (7-state simulations through
    // `simulate`, summary.json): braking 10 m/s over T = 5 s from the sway cycle at 35 m/s
    // is ok when it starts at t_b = 2 s (peak 70.8325°) and ends in loss of control when it
    // starts at t_b = 10 s (at 14.695 s). The sweep runs the 4-state model: agreement to
    // tolerance level (1e-4° in angle, 1e-3 s in time; measured 1e-7°. Before the kinks of
    // the tyre law were landed on, the peak was 70.8315°, off by 1e-3°).
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let f = root.join("sweep_brake_timing.toml");
    // the shipped file gives its speeds relative to V_crit (resolved by the task layer);
    // here they are Table I's 35 m/s and −10 m/s, written as numbers
    let text = std::fs::read_to_string(&f)
        .expect("read")
        .replace("{ of_v_crit = 1.0072544374722083 }", "35.0")
        .replace("{ of_v_crit = -0.2877869821349167 }", "-10.0");
    let mut cfg: SweepConfig = toml::from_str(&text).expect("parses");
    cfg.validate(&f).unwrap();
    cfg.axes[0] = Axis::range(cfg.axes[0].parameter, 2.0, 10.0, 2);
    cfg.axes[1] = Axis::range(cfg.axes[1].parameter, 5.0, 6.0, 2);
    let sweep = sweep_of(&cfg);
    let at = |tb: f64, t: f64| {
        let k = (0..sweep.len())
            .find(|&k| sweep.grid_point(k).0 == vec![tb, t])
            .expect("grid point");
        *sweep.run_point(k).metrics().expect("runs")
    };
    let early = at(2.0, 5.0);
    assert_eq!(early.outcome, Outcome::Ok);
    assert_abs_diff_eq!(
        early.peak_theta_deg_after_action.unwrap(),
        70.8325,
        epsilon = 1e-4
    );
    let late = at(10.0, 5.0);
    assert_eq!(late.outcome, Outcome::LossOfControl);
    assert_abs_diff_eq!(late.loss_of_control_time_s.unwrap(), 14.695, epsilon = 1e-3);
}
