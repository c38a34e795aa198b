//! Config files: shipped ones load and validate; errors name the file and key path.

use sway::ranging::SpeedSpec;
use sway::ranging::resolve_speeds;
use sway::sim::ScenarioConfig;
use sway_studies::sweep::SweepConfig;

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

#[test]
fn a_predictor_reads_its_prediction_vehicle_beside_the_scenario() {
    // the `prediction_vehicle` of a predictor in a scenario (`controller`) and a sweep
    // (`base.controller`) is a vehicle file relative to the config's directory: loaded
    // into the controller as the file's paper-form parameters; a missing or invalid file
    // is an error naming the config, the key and the vehicle file
    use sway_tasks::config_file::{TaskConfig, load_toml};
    let dir = tempfile::tempdir().unwrap();
    let configs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let heavier = std::fs::read_to_string(configs.join("vehicle.toml"))
        .unwrap()
        .replace("mass = 985.0", "mass = 1083.5");
    assert!(heavier.contains("mass = 1083.5"));
    std::fs::create_dir(dir.path().join("vehicles")).unwrap();
    std::fs::write(dir.path().join("vehicles/heavier.toml"), heavier).unwrap();
    let scenario = |vehicle: &str| {
        format!(
            "name = \"p\"\nspeed = {{ kind = \"constant\", speed_mps = 30.0 }}\n\
             initial = {{ kind = \"state\", theta0_deg = 2.0 }}\n\
             controller = {{ kind = \"predictor\", delay_s = 0.6, gains = {{ yaw_rate = 0.05 }}, \
             prediction_vehicle = \"{vehicle}\" }}\n"
        )
    };
    let file = dir.path().join("scenario.toml");
    std::fs::write(&file, scenario("vehicles/heavier.toml")).unwrap();
    let mut c: ScenarioConfig<SpeedSpec> = load_toml(&file).unwrap();
    c.load_named_files(&file).unwrap();
    c.check(&file).unwrap();
    let sway::sim::ControllerTable::Predictor {
        prediction_vehicle: Some(p),
        ..
    } = &c.controller
    else {
        panic!("{:?}", c.controller)
    };
    let mut expected = trailer_model::VehicleParams::default();
    expected.trailer.mass = 1083.5;
    assert_eq!(p.params, Some(expected));
    // written back as the path it was given
    let json = serde_json::to_value(&c.controller).unwrap();
    assert_eq!(json["prediction_vehicle"], "vehicles/heavier.toml");

    std::fs::write(&file, scenario("vehicles/no_such.toml")).unwrap();
    let mut c: ScenarioConfig<SpeedSpec> = load_toml(&file).unwrap();
    let e = c.load_named_files(&file).unwrap_err().to_string();
    assert!(
        e.contains("scenario.toml")
            && e.contains("controller.prediction_vehicle")
            && e.contains("no_such.toml"),
        "{e}"
    );

    let sweep = dir.path().join("sweep.toml");
    let base = std::fs::read_to_string(configs.join("sweep_threshold.toml")).unwrap();
    let mut s: SweepConfig<SpeedSpec> = toml::from_str(&base).unwrap();
    s.base.controller = sway::sim::ControllerTable::Predictor {
        gains: sway::control::Gains::yaw_rate(0.05),
        delay_s: 0.6,
        actuator: sway::control::Actuator::Steering,
        on_s: 0.0,
        off_s: None,
        limit: Default::default(),
        model_error: Default::default(),
        prediction_vehicle: Some(sway::sim::PredictionVehicle::new("vehicles/bad.toml")),
    };
    std::fs::write(dir.path().join("vehicles/bad.toml"), "gravity = -1.0\n").unwrap();
    std::fs::write(&sweep, toml::to_string(&s).unwrap()).unwrap();
    let mut s: SweepConfig<SpeedSpec> = load_toml(&sweep).unwrap();
    let e = s.load_named_files(&sweep).unwrap_err().to_string();
    assert!(
        e.contains("sweep.toml")
            && e.contains("base.controller.prediction_vehicle")
            && e.contains("bad.toml"),
        "{e}"
    );
}
