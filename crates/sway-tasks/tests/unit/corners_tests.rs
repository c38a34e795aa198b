use std::path::Path;
use std::path::PathBuf;
use sway_tasks::config_file::parse_toml;
use sway_tasks::tasks::corners::*;

fn shipped() -> (PathBuf, String) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/corners.toml");
    let text = std::fs::read_to_string(&file).expect("shipped config");
    (file, text)
}

#[test]
fn shipped_config_is_valid_and_as_the_issue_asks() {
    let (file, text) = shipped();
    let cfg: CornersConfig = parse_toml(&text, &file).unwrap();
    validate(&cfg, &file).unwrap();
    assert_eq!(cfg.delays_s, vec![0.2, 0.4]);
    // the box and the seeds are derived from the vehicle
    assert_eq!(
        cfg.chart.box_keys(),
        sway::charts::auto_range::BoxKeys::default()
    );
    assert_eq!(cfg.chart.seed_gains_s, None);
}

#[test]
fn bad_values_name_their_key() {
    let (file, text) = shipped();
    let bad = text.replace("window_s = 200.0", "window_s = -1.0");
    let cfg: CornersConfig = parse_toml(&bad, &file).unwrap();
    let e = validate(&cfg, &file).unwrap_err().to_string();
    assert!(e.contains("corners.simulation.window_s"), "{e}");
    let unknown = text.replace("[corners]", "[corners]\nfoo = 1");
    let e = parse_toml::<CornersConfig>(&unknown, &file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("foo"), "{e}");
}
