use std::path::Path;
use std::path::PathBuf;
use sway_tasks::config_file::parse_toml;
use sway_tasks::tasks::chart_nonlinear::*;

fn shipped() -> (PathBuf, String) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/chart_nonlinear.toml");
    let text = std::fs::read_to_string(&file).expect("shipped config");
    (file, text)
}

#[test]
fn shipped_config_is_valid_and_as_the_issue_asks() {
    let (file, text) = shipped();
    let cfg: ChartNonlinearConfig = parse_toml(&text, &file).unwrap();
    validate(&cfg, &file).unwrap();
    assert_eq!(cfg.delays_s, vec![0.0, 0.1, 0.2, 0.4]);
    // the box, the seeds and the summary gains are derived from the vehicle
    assert_eq!(
        cfg.chart.box_keys(),
        sway::charts::auto_range::BoxKeys::default()
    );
    assert_eq!(cfg.chart.seed_gains_s, None);
    assert_eq!(
        (cfg.summary_gains_s.as_ref(), cfg.bistable_gain_s),
        (None, None)
    );
}

#[test]
fn lines_are_cut_at_the_gain_range() {
    // reference: the crossings of the segments with D = 0 and D = 1, by hand
    let line = [(0.0, -1.0), (2.0, 1.0), (4.0, 3.0), (6.0, 0.5), (8.0, 0.25)];
    let cut = clip_to_gains(&line, (0.0, 1.0));
    let nan = |p: &(f64, f64)| p.0.is_nan();
    assert!(nan(&cut[0]));
    assert_eq!(cut[1], (1.0, 0.0));
    assert_eq!(cut[2], (2.0, 1.0));
    assert_eq!(cut[3], (2.0, 1.0));
    assert!(nan(&cut[4]) && nan(&cut[5]));
    // (4, 3) → (6, 0.5) meets D = 1 at t = 0.8: V = 5.6 (round-off only)
    assert!(
        (cut[6].0 - 5.6).abs() < 1e-12 && cut[6].1 == 1.0,
        "{:?}",
        cut[6]
    );
    assert_eq!(&cut[7..], &[(6.0, 0.5), (8.0, 0.25)]);
}

#[test]
fn bad_values_name_their_key() {
    let (file, text) = shipped();
    let bad = text.replace("[chart]\n", "[chart]\nd_min_s = -0.1\nd_max_s = -0.3\n");
    let cfg: ChartNonlinearConfig = parse_toml(&bad, &file).unwrap();
    let e = validate(&cfg, &file).unwrap_err().to_string();
    assert!(e.contains("chart.d_min_s"), "{e}");
    let unknown = text.replace("[regions]", "[regions]\nfoo = 1");
    let e = parse_toml::<ChartNonlinearConfig>(&unknown, &file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("foo"), "{e}");
}
