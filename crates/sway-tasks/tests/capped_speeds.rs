//! Labels true everywhere (issue 51, item 6): no capped value reported as a measured one.
//!
//! A speed searched for up to a cap (`--max-speed`, a search's `v_max_mps`) that finds
//! nothing below it is reported as the open-loop tasks report it (the README's convention):
//! null, with `stable_up_to_mps` = the cap and a `reason`; its CSV cell is empty. Checked by
//! `sway_tasks::io::speeds_at_cap`, which finds every number under a key ending `_mps`
//! equal to the cap without a `stable_up_to_mps` beside it:
//!
//! - on summaries built to hold each case (a unit check of the walk itself);
//! - on every committed `results/*/summary.json` (written by `cargo xtask all`);
//! - on `control_design` and `gain_design` run on Table I with designs stable up to a
//!   lowered cap (issue 51 found `control_design`'s `yaw_rate_hitch` + steering at
//!   τ = 0.2 s reported as `v_crit_mps: 100.0`, the cap of its search); the designs are
//!   confirmed stable up to the cap by the exact unstable-root count of their loops.

use std::path::{Path, PathBuf};

use serde_json::{Value, json};
use sway::control::{Actuator, Gains, LinearLoop, LoopLaw, Structure};
use sway::progress::NoProgress;
use sway::ranging::SpeedLimits;
use sway_tasks::io::speeds_at_cap;
use sway_tasks::tasks::{self, TaskContext};
use trailer_model::{Model, VehicleParams};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `task` on Table I with the config text `toml`; its `summary.json` and output
/// directory.
fn run(task: &str, toml: &str, dir: &Path) -> (Value, PathBuf) {
    let file = dir.join(format!("{task}.toml"));
    std::fs::write(&file, toml).expect("write config");
    let ctx = TaskContext::new(
        &root().join("configs/vehicle.toml"),
        &root().join("configs"),
        &dir.join("results"),
        &NoProgress,
    )
    .expect("Table I loads");
    let t = tasks::resolve(task).expect("known task")[0];
    let (prepared, _) = tasks::prepare_checked(&t, &ctx, &file).expect("config valid");
    let report = prepared.run(&ctx).expect("runs");
    let text = std::fs::read_to_string(report.output_dir.join("summary.json")).expect("summary");
    (
        serde_json::from_str(&text).expect("json"),
        report.output_dir,
    )
}

/// The rows of a CSV file as maps column → cell.
fn csv_rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let mut r = csv::Reader::from_path(path).expect("csv");
    let header: Vec<String> = r
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    r.records()
        .map(|rec| {
            let rec = rec.expect("row");
            header
                .iter()
                .cloned()
                .zip(rec.iter().map(String::from))
                .collect()
        })
        .collect()
}

#[test]
fn speeds_at_the_cap_are_found_unless_they_say_stable_up_to() {
    // reference: the convention itself, case by case (cap 100 m/s)
    let s = json!({
        "v_crit_mps": 100.0,
        "designs": [
            { "v_crit_mps": 100.0 },
            { "v_crit_mps": null, "stable_up_to_mps": 100.0, "reason": "…" },
            { "v_crit_mps": 60.0 },
            { "v_fold_away_from_corner": { "v_crit_mps": 100.0 } },
            { "v_crit_p05_mps": 100.0, "v_crit_p05_stable_up_to_mps": 100.0 }
        ],
        "band_mps": [99.0, 100.0],
        "searched_mps": [1.0, 100.0],
        "diagram_range_mps": [1.0, 100.0],
        "cycle_branch_end": { "reason": "speed cap", "limit_mps": 100.0 },
        "ranges": {
            "search": { "v_max_mps": 100.0 },
            "derivation": { "extent": { "highest_mps": 100.0, "stable_gains": 3 } }
        },
        "open_loop": { "v_crit_mps": null, "stable_up_to_mps": 100.0 },
        "excused": { "v_crit_mps": 100.0, "open_loop_stable_up_to_mps": 100.0 },
        "count": 100,
        "config": { "v_crit_mps": 100.0 },
        "vehicle": { "speed_mps": 100.0 }
    });
    assert_eq!(
        speeds_at_cap(&s, 100.0),
        [
            ".v_crit_mps",
            ".designs[0].v_crit_mps",
            ".designs[3].v_fold_away_from_corner.v_crit_mps",
            ".band_mps[1]",
        ]
    );
    // another cap: none of them is at it
    assert!(speeds_at_cap(&s, 60.5).is_empty());
    assert_eq!(speeds_at_cap(&s, 60.0), [".designs[2].v_crit_mps"]);
}

#[test]
fn no_committed_summary_reports_a_speed_cap_as_a_speed() {
    // every results/*/summary.json of `cargo xtask all` (and the on-demand tasks'
    // committed ones), against the maximum speed (--max-speed, 100 m/s) and every cap its
    // config names (`v_max_mps`, `max_speed_mps`)
    let default_cap = SpeedLimits::default().max_speed_mps;
    let mut checked = 0;
    let mut found = Vec::new();
    for entry in std::fs::read_dir(root().join("results")).expect("results/") {
        let file = entry.expect("entry").path().join("summary.json");
        let Ok(text) = std::fs::read_to_string(&file) else {
            continue;
        };
        let summary: Value = serde_json::from_str(&text).expect("summary.json parses");
        let mut caps = vec![default_cap];
        collect_caps(&summary, &mut caps);
        for cap in caps {
            for path in speeds_at_cap(&summary, cap) {
                found.push(format!("{}: {path} = {cap} m/s", file.display()));
            }
        }
        checked += 1;
    }
    assert!(checked >= 20, "{checked} summaries");
    assert!(
        found.is_empty(),
        "capped speeds reported as measured:\n{}",
        found.join("\n")
    );
}

/// The values of the keys naming a speed cap anywhere in `v`.
fn collect_caps(v: &Value, caps: &mut Vec<f64>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                if let ("v_max_mps" | "max_speed_mps", Some(c)) = (k.as_str(), x.as_f64())
                    && !caps.contains(&c)
                {
                    caps.push(c);
                }
                collect_caps(x, caps);
            }
        }
        Value::Array(a) => a.iter().for_each(|x| collect_caps(x, caps)),
        _ => {}
    }
}

/// The cap of the designs' search below the best `yaw_rate_hitch` + steering V_crit of
/// Table I at τ = 0 and 0.2 s (≥ 100 m/s, `results/control_design`) and above the open
/// loop's 34.75 m/s and its 10 % rise.
const CONTROL_CAP: f64 = 60.0;

#[test]
fn control_design_stable_up_to_its_cap_says_so() {
    // reference: issue 51 — yaw_rate_hitch + steering at τ = 0.2 s is stable up to the cap
    // of its search; here the cap is 60 m/s. Its loop has no unstable root from 1 to 60 m/s
    // (the exact unstable-root count, at 1 m/s steps), so the design must report
    // `v_crit_mps: null` with `stable_up_to_mps` = 60 and a reason, the delay budget must
    // say "at least" the grid's end, and no speed of the summary may be the cap.
    let tmp = tempfile::tempdir().expect("tempdir");
    let toml = format!(
        "structures = [\"yaw_rate_hitch\"]\nactuators = [\"steering\"]\n\
         delays_s = {{ min = 0.0, max = 0.2, points = 2 }}\n\
         [search]\ngain_samples = 6\nmax_iterations = 30\nsearch_tolerance_mps = 1e-4\n\
         [search.speed]\nv_max_mps = {CONTROL_CAP}\nsamples = 30\ntolerance_mps = 1e-6\n\
         [search.limits]\nyaw_rate_amplitude_rad_s = 0.2\nsteering_rad = 0.1\n\
         [search.optimiser]\nrandom_starts = 0\nmax_iters = 20\n\
         [budget]\ntau_tolerance_s = 0.1\n\
         [robustness]\ndelays_s = [0.2]\n\
         [robustness.speed]\nv_max_mps = {CONTROL_CAP}\nsamples = 15\ntolerance_mps = 1e-3\n\
         [robustness.uncertainty.vehicle]\nmethod = \"latin_hypercube\"\nsamples = 3\nseed = 1\n\
         [[robustness.uncertainty.vehicle.fields]]\nkey = \"trailer.cog\"\nabout = \"offset\"\n\
         distribution = \"uniform\"\nmin = -0.01\nmax = 0.01\n\
         [simulation_check]\ndelay_s = 0.2\nhorizon_s = 5.0\nkicks_deg = [2.0]\n"
    );
    let (s, out) = run("control_design", &toml, tmp.path());
    assert!(
        speeds_at_cap(&s, CONTROL_CAP).is_empty(),
        "{:?}",
        speeds_at_cap(&s, CONTROL_CAP)
    );
    let designs = s["designs"].as_array().expect("designs");
    let d = designs
        .iter()
        .find(|d| d["tau_s"].as_f64() == Some(0.2))
        .expect("the design at τ = 0.2 s");
    assert!(d["v_crit_mps"].is_null(), "{d}");
    assert_eq!(d["stable_up_to_mps"].as_f64(), Some(CONTROL_CAP), "{d}");
    let reason = d["reason"].as_str().expect("reason");
    assert!(
        reason.contains("stable at every speed up to 60 m/s"),
        "{reason}"
    );
    // the loop of the design has no unstable root up to the cap
    let g = &d["gains"];
    let gains = Gains {
        yaw_rate: g["yaw_rate"].as_f64().expect("D"),
        hitch_angle: g["hitch_angle"].as_f64().expect("K_θ"),
        hitch_rate: g["hitch_rate"].as_f64().expect("D_θ"),
    };
    let model = Model::new(VehicleParams::default()).expect("Table I");
    let law = LoopLaw::new(Structure::YawRateHitch, Actuator::Steering, gains, 0.2);
    for v in (1..=CONTROL_CAP as usize).map(|v| v as f64) {
        let n = LinearLoop::new(&model, &law, v, None)
            .expect("loop")
            .unstable_root_count()
            .expect("count");
        assert_eq!(n, 0, "an unstable root at {v} m/s: {d}");
    }
    // every design stable up to the cap: the budget reaches the grid's end, a lower bound
    let key = "yaw_rate_hitch_steering";
    if designs.iter().all(|d| d["v_crit_mps"].is_null()) {
        assert!(
            s["delay_budget_s"][key].is_null(),
            "{}",
            s["delay_budget_s"]
        );
        assert_eq!(s["delay_budget_at_least_s"][key].as_f64(), Some(0.2));
        assert!(s["delay_budget_reason"][key].is_string());
    }
    // the robust V_crit: a number below the cap, or null with the cap and the reason
    match d["v_crit_p05_mps"].as_f64() {
        Some(v) => assert!(v < CONTROL_CAP, "{d}"),
        None => {
            assert_eq!(
                d["v_crit_p05_stable_up_to_mps"].as_f64(),
                Some(CONTROL_CAP),
                "{d}"
            );
            assert!(d["v_crit_p05_reason"].is_string(), "{d}");
        }
    }
    // designs.csv: an empty V_crit cell and the cap beside it
    let rows = csv_rows(&out.join("designs.csv"));
    let row = rows
        .iter()
        .find(|r| r["tau_s"] == "0.2")
        .expect("τ = 0.2 s row");
    assert_eq!(
        (row["v_crit_mps"].as_str(), row["stable_up_to_mps"].as_str()),
        ("", "60.0")
    );
    assert!(!rows[0].contains_key("speed_capped"));
}

#[test]
fn gain_design_stable_up_to_its_cap_says_so() {
    // reference: V_crit,max of the paper's loop is 60.58 m/s at τ = 0 and 67.94 m/s at
    // τ = 0.1 s (results/gain_design, D* = 0.5 s): with the speed range capped at 50 m/s
    // both optima are stable up to the cap, so each reports `v_crit_mps: null` with
    // `stable_up_to_mps` = 50, the CSV cell is empty, and the delay budget reaches the grid's
    // end (at least 0.1 s) with its reason.
    let tmp = tempfile::tempdir().expect("tempdir");
    let cap = 50.0;
    let toml = format!(
        "delays_s = {{ min = 0.0, max = 0.1, points = 2 }}\nheadline_delays_s = [0.1]\n\
         [search]\nd_min_s = 0.0\nd_max_s = 0.5\nv_min_mps = 1.0\nv_max_mps = {cap}\n\
         gain_samples = 6\nspeed_samples = 25\ngain_tolerance_s = 1e-3\n[nonlinear]\nevery = 0\n"
    );
    let (s, out) = run("gain_design", &toml, tmp.path());
    assert!(
        speeds_at_cap(&s, cap).is_empty(),
        "{:?}",
        speeds_at_cap(&s, cap)
    );
    for o in s["optimal_gain"].as_array().expect("optima") {
        assert!(o["v_crit_mps"].is_null(), "{o}");
        assert_eq!(o["stable_up_to_mps"].as_f64(), Some(cap), "{o}");
        let reason = o["reason"].as_str().expect("reason");
        assert!(
            reason.contains("stable at every speed up to 50 m/s"),
            "{reason}"
        );
    }
    assert!(s["delay_budget_s"].is_null(), "{s}");
    assert_eq!(s["delay_budget_at_least_s"].as_f64(), Some(0.1));
    assert!(s["delay_budget_reason"].is_string());
    for row in csv_rows(&out.join("optimal_gain.csv")) {
        assert_eq!(
            (row["v_crit_mps"].as_str(), row["stable_up_to_mps"].as_str()),
            ("", "50.0")
        );
    }
}
