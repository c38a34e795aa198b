//! Config files: shipped ones load and validate; errors name the file and key path.

use sway::ranging::SpeedSpec;
use sway::sim::sweep::SweepConfig;
use sway::sim::{ScenarioConfig, resolve_speeds};

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
    // the shipped scenario and sweep files give speeds relative to the vehicle: checked as
    // written, then resolved for Table I (35 m/s etc.) and checked completely
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let model = trailer_model::Model::new(trailer_model::VehicleParams::default()).unwrap();
    let limits = sway::ranging::SpeedLimits::default();
    let f = root.join("scenario_example.toml");
    let c: ScenarioConfig<SpeedSpec> = sway_tasks::config_file::load_toml(&f).unwrap();
    c.validate_spec(&f).unwrap();
    let r = resolve_speeds(&model, &limits, &c)
        .unwrap()
        .outcome
        .unwrap();
    r.validate(&f).unwrap();
    assert!((r.speed.initial_speed() - 35.0).abs() < 1e-12);
    for name in [
        "sweep_threshold.toml",
        "study_uncertainty.toml",
        "study_fleet.toml",
        "sweep_brake_timing.toml",
    ] {
        let f = root.join(name);
        let c: SweepConfig<SpeedSpec> = sway_tasks::config_file::load_toml(&f).unwrap();
        c.validate_spec(&f).unwrap();
        let r = resolve_speeds(&model, &limits, &c)
            .unwrap()
            .outcome
            .unwrap();
        r.validate(&f).unwrap();
        if name == "sweep_threshold.toml" {
            assert!(r.grid_len() >= 64 * 16);
            let speeds = r.axes[0].values();
            assert!((speeds[0] - 28.0).abs() < 1e-9 && (speeds[63] - 36.0).abs() < 1e-9);
        }
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
        let e = sway_tasks::config_file::parse_toml::<ScenarioConfig<SpeedSpec>>(&bad, file)
            .expect_err(key)
            .to_string();
        assert!(e.contains(&format!("`{key}`")), "{key}: {e}");
    }
    let sweep = std::fs::read_to_string(root.join("sweep_threshold.toml")).expect("read");
    let bad = sweep.replace("settle_threshold_deg = 1.0", "settle_threshold_deg = 0.0");
    let e = sway_tasks::config_file::parse_toml::<SweepConfig<SpeedSpec>>(&bad, file)
        .expect_err("zero threshold")
        .to_string();
    assert!(e.contains("`base.metrics.settle_threshold_deg`"), "{e}");
}
