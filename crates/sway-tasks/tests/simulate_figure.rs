//! The `simulate` figure (issue 51, item 6): besides θ(t), V(t) and the path it shows the
//! steering angle δ(t) with the actuator's limits and where the actuator saturates, and it
//! marks each action at its own time — a speed table that changes from t = 0 does not hide
//! the controller switching on later behind a marker at t = 0.

use std::path::Path;

use sway::progress::NoProgress;
use sway_tasks::tasks::{self, TaskContext};

/// Runs `simulate` on Table I with the scenario `toml` (named `name`); the SVG text of its
/// figure and its trajectory's δ column \[rad\].
fn run(name: &str, toml: &str) -> (String, Vec<f64>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = tmp.path().join(format!("{name}.toml"));
    std::fs::write(&file, toml).expect("write scenario");
    let ctx = TaskContext::new(
        &root.join("configs/vehicle.toml"),
        &root.join("configs"),
        &tmp.path().join("results"),
        &NoProgress,
    )
    .expect("Table I loads");
    let t = tasks::resolve("simulate").expect("known")[0];
    let (prepared, _) = tasks::prepare_checked(&t, &ctx, &file).expect("scenario valid");
    let report = prepared.run(&ctx).expect("runs");
    let svg = std::fs::read_to_string(report.output_dir.join("trajectory.svg")).expect("svg");
    assert!(report.output_dir.join("trajectory.png").is_file());
    let mut r = csv::Reader::from_path(report.output_dir.join("trajectory.csv")).expect("csv");
    let col = r
        .headers()
        .expect("header")
        .iter()
        .position(|h| h == "delta_rad")
        .expect("delta_rad column");
    let delta = r
        .records()
        .map(|rec| rec.expect("row")[col].parse::<f64>().expect("δ"))
        .collect();
    (svg, delta)
}

#[test]
fn the_steering_panel_shows_delta_its_limits_and_the_saturation() {
    // a yaw-rate controller on from t = 5 s with a steering saturation of 0.2° and a speed
    // table that brakes from t = 0: the δ panel, its ±δ_max lines and a saturated stretch
    // (reference: the trajectory's δ reaches δ_max = 0.2° to 0.1 %, the tolerance the figure
    // marks saturation with), the controller's switch-on at 5 s marked, the braking from
    // t = 0 said in the title instead of a marker on the axis
    let (svg, delta) = run(
        "saturating",
        "name = \"saturating\"\nhorizon_s = 15.0\noutput_step_s = 0.02\n\
         speed = { kind = \"table\", points = [[0.0, 35.0], [10.0, 30.0]] }\n\
         controller = { kind = \"yaw_rate_feedback\", gain_s = 0.1, delay_s = 0.2, on_s = 5.0, \
         actuator = { max_angle_deg = 0.2 } }\n\
         initial = { kind = \"state\", theta0_deg = 8.0 }\n",
    );
    let max = 0.2_f64.to_radians();
    assert!(delta.iter().all(|d| d.abs() <= max * (1.0 + 1e-12)));
    assert!(
        delta.iter().any(|d| d.abs() >= max * (1.0 - 1e-3)),
        "δ never reaches δ_max"
    );
    for text in [
        "δ [deg]",
        "δ(t)",
        "±δ_max = ±0.2°",
        "saturated: |δ| = δ_max",
        "controller on at t = 5 s",
        "speed starts to change from t = 0",
    ] {
        assert!(svg.contains(text), "no «{text}» in the figure");
    }
    assert!(!svg.contains("speed starts to change at t = 0 s"));
}

#[test]
fn a_rate_limited_actuator_is_marked_and_an_open_loop_says_so() {
    // reference: a rate limit of 1°/s under a command of ≈ 0.6° at ω ≈ 2.3 rad/s (≈ 1.4°/s)
    // is reached: the stretch is shaded and named; the controller switches off at 12 s
    let (svg, _) = run(
        "rate_limited",
        "name = \"rate_limited\"\nhorizon_s = 15.0\noutput_step_s = 0.02\n\
         speed = { kind = \"constant\", speed_mps = 35.0 }\n\
         controller = { kind = \"yaw_rate_feedback\", gain_s = 0.1, delay_s = 0.2, on_s = 2.0, \
         off_s = 12.0, actuator = { max_rate_deg_s = 1.0 } }\n\
         initial = { kind = \"state\", theta0_deg = 8.0 }\n",
    );
    for text in [
        "rate-limited: |dδ/dt| = 1°/s",
        "controller on at t = 2 s",
        "controller off at t = 12 s",
    ] {
        assert!(svg.contains(text), "no «{text}» in the figure");
    }
    let (svg, delta) = run(
        "open_loop",
        "name = \"open_loop\"\nhorizon_s = 5.0\noutput_step_s = 0.02\n\
         speed = { kind = \"constant\", speed_mps = 30.0 }\n\
         initial = { kind = \"state\", theta0_deg = 2.0 }\n",
    );
    assert!(delta.iter().all(|&d| d == 0.0));
    assert!(
        svg.contains("open loop: no controller"),
        "open loop not said"
    );
}
