use std::path::{Path, PathBuf};
use sway_tasks::config_file::parse_toml;
use sway_tasks::tasks::fig4a::*;

fn shipped() -> (PathBuf, String) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/fig4a.toml");
    let text = std::fs::read_to_string(&file).unwrap();
    (file, text)
}

#[test]
fn shipped_config_is_valid_and_as_the_issue_asks() {
    let (file, text) = shipped();
    let cfg: Fig4aConfig = parse_toml(&text, &file).unwrap();
    validate(&cfg, &file).unwrap();
    assert!(cfg.speed.cells >= 300 && cfg.gain.cells >= 200);
    assert_eq!(cfg.delays_s, vec![0.0, 0.1, 0.2, 0.4]);
    // the ranges and summary settings are derived from the vehicle
    assert_eq!((cfg.speed.min_mps, cfg.speed.max_mps), (None, None));
    assert_eq!((cfg.gain.min_s, cfg.gain.max_s), (None, None));
    assert_eq!(cfg.summary.gain_for_critical_speed_s, None);
    assert_eq!(cfg.summary.speed_for_gain_interval_mps, None);
}

#[test]
fn bad_values_name_their_key() {
    let (file, text) = shipped();
    let bad = text.replace("delays_s = [0.0, 0.1, 0.2, 0.4]", "delays_s = [0.0, -0.1]");
    let cfg: Fig4aConfig = parse_toml(&bad, &file).unwrap();
    let e = validate(&cfg, &file).unwrap_err().to_string();
    assert!(e.contains("delays_s[1]"), "{e}");
    let unknown = text.replace("[numerics]", "[numerics]\nfoo = 1");
    let e = parse_toml::<Fig4aConfig>(&unknown, &file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("foo"), "{e}");
}
