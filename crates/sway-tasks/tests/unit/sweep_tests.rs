use std::path::Path;

use std::path::PathBuf;
use sway::progress::NoProgress;
use sway::ranging::SpeedSpec;
use sway::sim::speeds::ResolveSpeeds;
use sway_studies::sweep::SweepConfig;
use sway_tasks::config_file::Configured;
use sway_tasks::config_file::TaskConfig;
use sway_tasks::config_file::load_toml;
use sway_tasks::tasks::Prepared;
use sway_tasks::tasks::TaskContext;
use sway_tasks::tasks::sweep::*;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn context(results: &Path) -> TaskContext<'static> {
    TaskContext::new(
        &root().join("configs/vehicle.toml"),
        &root().join("configs"),
        results,
        &NoProgress,
    )
    .unwrap()
}

/// Runs the sweep of `file` with `edit` applied, into `results`; returns the summary.
fn run(
    file: &Path,
    results: &Path,
    edit: impl FnOnce(&mut SweepConfig<SpeedSpec>),
) -> serde_json::Value {
    let ctx = context(results);
    let mut cfg: SweepConfig<SpeedSpec> = load_toml(file).unwrap();
    edit(&mut cfg);
    cfg.check(file).unwrap();
    Box::new(Configured {
        file: file.to_path_buf(),
        config: cfg.clone(),
    })
    .run(&ctx)
    .unwrap();
    let text = std::fs::read_to_string(results.join(&cfg.name).join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn uncertainty_study_writes_distributions_and_histogram() {
    let tmp = tempfile::tempdir().unwrap();
    let file = root().join("configs/study_uncertainty.toml");
    let s = run(&file, tmp.path(), |c| {
        if let Some(s) = c.sampling.as_mut() {
            s.samples = 200;
        }
    });
    let d = &s["distributions"]["v_crit_mps"][0];
    assert_eq!(d["count"], 200);
    let (q05, q50, q95) = (
        d["quantiles"]["q05"].as_f64().unwrap(),
        d["quantiles"]["q50"].as_f64().unwrap(),
        d["quantiles"]["q95"].as_f64().unwrap(),
    );
    // reference: Table I's V_crit 34.748 m/s (fig3a) lies inside the 5–95 % range (h = 2.9,
    // l = 2.8 is the middle of the sampled square)
    assert!(q05 < 34.748 && 34.748 < q95, "{q05} {q50} {q95}");
    let dir = tmp.path().join("study_uncertainty");
    assert!(dir.join("histogram.svg").is_file() && dir.join("histogram.png").is_file());
    let csv = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
    assert!(
        csv.starts_with("trailer.cog,trailer.axle,v_crit_mps,"),
        "{csv:.80}"
    );
    assert_eq!(csv.lines().count(), 201);
}

#[test]
fn fleet_study_loads_its_files_and_names_them_in_the_rows() {
    let tmp = tempfile::tempdir().unwrap();
    let file = root().join("configs/study_fleet.toml");
    let s = run(&file, tmp.path(), |c| {
        c.axes[0] = sway_studies::sweep::Axis {
            parameter: c.axes[0].parameter,
            min: Some(985.0.into()),
            max: Some(985.0.into()),
            points: Some(1),
            files: Vec::new(),
        };
    });
    assert_eq!(s["points"], 3);
    let csv = std::fs::read_to_string(tmp.path().join("study_fleet/sweep.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert!(
        rows[2].starts_with("985.0,fleet/loaded_trailer.toml,"),
        "{}",
        rows[2]
    );
    // the Table I member at Table I's mass has fig3a's V_crit (34.748 m/s, to 1e-3)
    let v: f64 = rows[1].split(',').nth(2).unwrap().parse().unwrap();
    assert!((v - 34.748).abs() < 1e-3, "{v}");

    // a missing fleet file is an error naming it
    let ctx = context(tmp.path());
    let mut cfg: SweepConfig<SpeedSpec> = load_toml(&file).unwrap();
    cfg.axes[1].files[1] = "fleet/missing.toml".into();
    let e = prepare_sweep(&ctx, &cfg.all_numbers().unwrap(), &file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.toml"), "{e}");
}
