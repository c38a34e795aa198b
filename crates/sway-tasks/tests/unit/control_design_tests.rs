use std::path::Path;
use std::path::PathBuf;
use sway::control::{Actuator, Structure};
use sway_tasks::config_file::TaskConfig;
use sway_tasks::config_file::parse_toml;
use sway_tasks::tasks::control_design::*;

fn shipped() -> (PathBuf, String) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/control_design.toml");
    let text = std::fs::read_to_string(&file).expect("shipped config");
    (file, text)
}

#[test]
fn shipped_config_is_valid_and_as_the_issue_asks() {
    // reference: the study's specification — τ ∈ [0, 2] s, every structure × actuator, the table delays
    // 0.4 / 0.6 / 0.8 s, a 10 % budget, study_uncertainty's h and l ranges
    let (file, text) = shipped();
    let cfg: ControlDesignConfig = parse_toml(&text, &file).unwrap();
    cfg.check(&file).unwrap();
    assert_eq!((cfg.delays_s.min, cfg.delays_s.max), (0.0, 2.0));
    assert_eq!(cfg.structures, Structure::ALL.to_vec());
    assert_eq!(cfg.actuators, Actuator::ALL.to_vec());
    assert_eq!(cfg.robustness.delays_s, vec![0.4, 0.6, 0.8]);
    assert_eq!(cfg.budget.rise_fraction, 0.1);
    assert_eq!(cfg.robustness.uncertainty, default_uncertainty());
}

#[test]
fn bad_values_name_the_file_and_their_key() {
    let (file, text) = shipped();
    for (from, to, key) in [
        (
            "track_width_m = 1.6",
            "track_width_m = -1.6",
            "track_width_m",
        ),
        (
            "band_fraction = 0.01",
            "band_fraction = 1.5",
            "search.band_fraction",
        ),
        (
            "hitch_angle = { lo = -1.0, hi = 1.0 }",
            "hitch_angle = { lo = 1.0, hi = -1.0 }",
            "search.bounds.hitch_angle",
        ),
        (
            "rise_fraction = 0.1",
            "rise_fraction = 0",
            "budget.rise_fraction",
        ),
        (
            "key = \"trailer.mass\"",
            "key = \"trailer.colour\"",
            "fields[2].key",
        ),
        ("samples = 50", "samples = 1", "robustness.speed.samples"),
    ] {
        assert!(text.contains(from), "{from}");
        let cfg: ControlDesignConfig = parse_toml(&text.replacen(from, to, 1), &file).unwrap();
        let e = cfg.check(&file).unwrap_err().to_string();
        assert!(
            e.contains(key) && e.contains("control_design.toml"),
            "{key}: {e}"
        );
    }
    let e = parse_toml::<ControlDesignConfig>(
        &text.replace("structures = [\"yaw_rate\"", "structures = [\"yaw_rat\""),
        &file,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("structures") && e.contains("control_design.toml"),
        "{e}"
    );
    // the prediction vehicle: resolved beside the config file, its problem named
    let bad = format!("prediction_vehicle = \"vehicles/no_such_vehicle.toml\"\n{text}");
    let cfg: ControlDesignConfig = parse_toml(&bad, &file).unwrap();
    let e = cfg.check(&file).unwrap_err().to_string();
    assert!(
        e.contains("prediction_vehicle")
            && e.contains("control_design.toml")
            && e.contains("no_such_vehicle"),
        "{e}"
    );
    let good = format!("prediction_vehicle = \"vehicles/relaxation.toml\"\n{text}");
    let cfg: ControlDesignConfig = parse_toml(&good, &file).unwrap();
    cfg.check(&file).unwrap();
    assert!(cfg.prediction(&file).unwrap().is_some());
}
