use std::path::Path;
use std::path::PathBuf;
use sway_tasks::config_file::parse_toml;
use sway_tasks::tasks::gain_design::*;

fn shipped() -> (PathBuf, String) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/gain_design.toml");
    let text = std::fs::read_to_string(&file).expect("shipped config");
    (file, text)
}

#[test]
fn shipped_config_is_valid_and_as_the_issue_asks() {
    // reference: the defaults (τ = 0 … 0.5 s in 51 values, D in 0 … 0.5 s, 1 %, 10 %)
    let (file, text) = shipped();
    let cfg: GainDesignConfig = parse_toml(&text, &file).unwrap();
    validate(&cfg, &file).unwrap();
    assert_eq!(
        (cfg.delays_s.min, cfg.delays_s.max, cfg.delays_s.points),
        (0.0, 0.5, 51)
    );
    // the gain range is derived from the vehicle (Table I: [0, 0.5] s)
    assert_eq!((cfg.search.d_min_s, cfg.search.d_max_s), (None, None));
    assert_eq!(cfg.search.band_fraction, 0.01);
    assert_eq!(cfg.budget.rise_fraction, 0.1);
    // the nonlinear delays include the headline delays 0.1, 0.2, 0.4 s
    let d = cfg.delays();
    for t in [0.1, 0.2, 0.4] {
        let i = d.iter().position(|x| (x - t).abs() < 1e-12).unwrap();
        assert!(cfg.is_nonlinear(i), "τ = {t} s");
    }
}

#[test]
fn bad_values_name_the_file_and_their_key() {
    let (file, text) = shipped();
    for (from, to, key) in [
        (
            "[search]\n",
            "[search]\nd_min_s = 0.0\nd_max_s = -0.5\n",
            "search.d_min_s",
        ),
        (
            "band_fraction = 0.01",
            "band_fraction = 1.5",
            "search.band_fraction",
        ),
        (
            "rise_fraction = 0.1",
            "rise_fraction = -0.1",
            "budget.rise_fraction",
        ),
        (
            "[nonlinear.chart]\n",
            "[nonlinear.chart]\nseed_gains_s = [-0.9]\n",
            "nonlinear.chart.seed_gains_s",
        ),
        (
            "intervals = 20",
            "intervals = 0",
            "nonlinear.chart.cycles.intervals",
        ),
    ] {
        assert!(text.contains(from), "{from}");
        let cfg: GainDesignConfig = parse_toml(&text.replace(from, to), &file).unwrap();
        let e = validate(&cfg, &file).unwrap_err().to_string();
        assert!(
            e.contains(key) && e.contains("gain_design.toml"),
            "{key}: {e}"
        );
    }
    let e = parse_toml::<GainDesignConfig>(&text.replace("[budget]", "[budget]\nfoo = 1"), &file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("foo") && e.contains("gain_design.toml"), "{e}");
    let bad_grid = text.replace("points = 51", "points = 1");
    let e = parse_toml::<GainDesignConfig>(&bad_grid, &file)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("delays_s") && e.contains("gain_design.toml"),
        "{e}"
    );
}
