//! Config files: shipped ones load and validate; errors name the file and key path.

use sway::sim::ScenarioConfig;
use sway::sim::sweep::SweepConfig;

#[test]
fn scenario_config_errors_name_the_key() {
    let file = std::path::Path::new("scenario.toml");
    let text = r#"
name = "x"
speed = { kind = "ramp", initial_mps = 35.0, change_mps = -40.0, start_s = 2.0, duration_s = 5.0 }
initial = { kind = "state", theta0_deg = 2.0 }
"#;
    let c: ScenarioConfig = sway_tasks::config_file::parse_toml(text, file).unwrap();
    let e = c.validate(file).unwrap_err().to_string();
    assert!(
        e.contains("speed.change_mps") && e.contains("scenario.toml"),
        "{e}"
    );
    let unknown = text.replace("name = \"x\"", "name = \"x\"\nhorizon = 3.0");
    let e = sway_tasks::config_file::parse_toml::<ScenarioConfig>(&unknown, file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("horizon"), "{e}");
    let bad_ctl = format!(
        "{text}\ncontroller = {{ kind = \"yaw_rate_feedback\", gain_s = 0.1, delay_s = -0.2 }}\n"
    );
    let c: ScenarioConfig = sway_tasks::config_file::parse_toml(&bad_ctl, file).unwrap();
    let e = c.validate(file).unwrap_err().to_string();
    assert!(
        e.contains("controller.delay_s") || e.contains("speed.change_mps"),
        "{e}"
    );
}

#[test]
fn shipped_configs_load_and_validate() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let f = root.join("scenario_example.toml");
    let c: ScenarioConfig = sway_tasks::config_file::load_toml(&f).unwrap();
    c.validate(&f).unwrap();
    let f = root.join("sweep_threshold.toml");
    let c: SweepConfig = sway_tasks::config_file::load_toml(&f).unwrap();
    c.validate(&f).unwrap();
    assert!(c.grid_len() >= 64 * 16);
    for name in [
        "study_uncertainty.toml",
        "study_fleet.toml",
        "sweep_brake_timing.toml",
    ] {
        let f = root.join(name);
        let c: SweepConfig = sway_tasks::config_file::load_toml(&f).unwrap();
        c.validate(&f).unwrap();
    }
}

#[test]
fn errors_inside_the_flattened_run_settings_name_their_key() {
    // `guard`, `[solver]` and `[metrics]` are one flattened struct (RunSettings); a bad
    // value in them is still reported at its key path, at the root and in a section
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let file = std::path::Path::new("scenario.toml");
    let good = std::fs::read_to_string(root.join("scenario_example.toml")).expect("read");
    for (bad, key) in [
        (
            good.replace("final_window_s = 5.0", "final_window_s = -5.0"),
            "metrics.final_window_s",
        ),
        (good.replace("rtol = 1e-8", "rtol = \"x\""), "solver.rtol"),
        (
            good.replace("guard = \"stop\"", "guard = \"maybe\""),
            "guard",
        ),
    ] {
        let e = sway_tasks::config_file::parse_toml::<ScenarioConfig>(&bad, file)
            .expect_err(key)
            .to_string();
        assert!(e.contains(&format!("`{key}`")), "{key}: {e}");
    }
    let sweep = std::fs::read_to_string(root.join("sweep_threshold.toml")).expect("read");
    let bad = sweep.replace("settle_threshold_deg = 1.0", "settle_threshold_deg = 0.0");
    let e = sway_tasks::config_file::parse_toml::<SweepConfig>(&bad, file)
        .expect_err("zero threshold")
        .to_string();
    assert!(e.contains("`base.metrics.settle_threshold_deg`"), "{e}");
}
