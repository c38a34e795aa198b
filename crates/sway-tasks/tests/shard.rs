//! Sharding and merging: a sweep computed as N shards and merged writes the
//! same bytes as the unsharded run, for several N; re-running a shard rewrites the same
//! bytes; the merge names a missing, failed, duplicated or foreign shard.
//!
//! The reference is always the unsharded run of the same sweep through the task's own
//! `run` (tolerance: none, byte equality; `summary.json` without its `wall_time_s` line,
//! the one field that differs between two runs). The sweep is small (8 points of 10 s) so
//! that the whole file runs in about a second.

use std::path::{Path, PathBuf};

use sway::progress::NoProgress;
use sway_tasks::shard::{self, ShardError, ShardSpec};
use sway_tasks::tasks::{self, TaskContext};

const SWEEP: &str = r#"
name = "tiny"

[[axes]]
parameter = "speed_mps"
min = 30.0
max = 36.0
points = 4

[[axes]]
parameter = "theta0_deg"
min = 2.0
max = 12.0
points = 2

[base]
horizon_s = 10.0
action_s = 0.0
speed = { kind = "constant", speed_mps = 33.0 }
controller = { kind = "none" }
initial = { kind = "state", theta0_deg = 2.0 }

[base.solver]
rtol = 1e-6
atol = 1e-8
"#;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A temporary directory with the sweep file `sweep.toml` (and `other.toml`, another
/// study with the same name).
fn setup() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("sweep.toml");
    std::fs::write(&cfg, SWEEP).expect("write");
    let other = tmp.path().join("other.toml");
    std::fs::write(&other, SWEEP.replace("max = 12.0", "max = 11.0")).expect("write");
    (tmp, cfg, other)
}

fn ctx(results: &Path) -> TaskContext<'static> {
    TaskContext::new(
        &repo().join("configs/vehicle.toml"),
        &repo().join("configs"),
        results,
        &NoProgress,
    )
    .expect("vehicle loads")
}

fn unsharded(cfg: &Path, results: &Path) {
    let ctx = ctx(results);
    let task = tasks::resolve("sweep").expect("task").remove(0);
    let (p, _) = tasks::prepare_checked(&task, &ctx, cfg).expect("valid");
    p.run(&ctx).expect("runs");
}

fn sharded(cfg: &Path, n: usize, shards: &Path) {
    let ctx = ctx(shards);
    for k in 1..=n {
        let spec = ShardSpec::new(k, n).expect("valid");
        shard::run_task_shard("sweep", &ctx, cfg, spec, shards).expect("shard runs");
    }
}

/// The files of a results directory: name and bytes (summary.json without wall_time_s).
fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("results")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).expect("read");
            if n == "summary.json" {
                let text = String::from_utf8(bytes).expect("utf-8");
                let kept: Vec<&str> = text
                    .lines()
                    .filter(|l| !l.trim_start().starts_with("\"wall_time_s\""))
                    .collect();
                (n, kept.join("\n").into_bytes())
            } else {
                (n, bytes)
            }
        })
        .collect()
}

#[test]
fn merged_shards_equal_the_unsharded_run_byte_for_byte() {
    let (tmp, cfg, _) = setup();
    let single = tmp.path().join("single");
    unsharded(&cfg, &single);
    let reference = outputs(&single.join("tiny"));
    let names: Vec<&str> = reference.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        ["heatmap.png", "heatmap.svg", "summary.json", "sweep.csv"]
    );
    // 1 shard, uneven slices, one point per shard, and more shards than points
    for n in [1, 3, 8, 11] {
        let shards = tmp.path().join(format!("shards-{n}"));
        sharded(&cfg, n, &shards);
        let merged = tmp.path().join(format!("merged-{n}"));
        shard::merge_dir(&shards, &merged, &NoProgress).expect("merges");
        let got = outputs(&merged.join("tiny"));
        for ((name, want), (_, have)) in reference.iter().zip(&got) {
            assert!(want == have, "N = {n}: {name} differs");
        }
        assert_eq!(got.len(), reference.len());
    }
}

#[test]
fn rerunning_a_shard_rewrites_the_same_bytes_and_clears_its_failure() {
    let (tmp, cfg, _) = setup();
    let dir = tmp.path().join("shards");
    let ctx = ctx(&dir);
    let spec = ShardSpec::new(2, 3).expect("valid");
    let r = shard::run_task_shard("sweep", &ctx, &cfg, spec, &dir).expect("runs");
    let first = std::fs::read(&r.file).expect("read");
    shard::record_failure(&dir, spec, None, "killed").expect("records");
    shard::run_task_shard("sweep", &ctx, &cfg, spec, &dir).expect("runs again");
    assert_eq!(std::fs::read(&r.file).expect("read"), first);
    assert!(!dir.join(spec.failure_name()).exists());
    // nothing else is left behind (no temporary file)
    assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 1);
    assert_eq!((r.range, r.points_total), (2..5, 8));
}

#[test]
fn merge_names_missing_failed_duplicated_and_foreign_shards() {
    let (tmp, cfg, other) = setup();
    let dir = tmp.path().join("shards");
    sharded(&cfg, 4, &dir);
    let out = tmp.path().join("merged");
    let merge = || shard::merge_dir(&dir, &out, &NoProgress).expect_err("refused");
    let file = |k: usize| dir.join(ShardSpec::new(k, 4).expect("valid").file_name());

    // missing: shard 3 removed
    let kept = std::fs::read(file(3)).expect("read");
    std::fs::remove_file(file(3)).expect("rm");
    let e = merge();
    assert!(
        matches!(&e, ShardError::Incomplete { missing, failed, shards: 4, .. } if missing == &[3] && failed.is_empty()),
        "{e}"
    );
    assert!(e.to_string().contains("missing 3/4"), "{e}");

    // failed: shard 3 recorded a failure
    shard::record_failure(
        &dir,
        ShardSpec::new(3, 4).expect("valid"),
        None,
        "out of time",
    )
    .expect("records");
    let e = merge();
    assert!(e.to_string().contains("failed 3/4 (out of time)"), "{e}");
    std::fs::write(file(3), &kept).expect("restore");

    // duplicated: a copy of shard 2 under another name
    let copy = dir.join("shard-2-of-4 (copy).json");
    std::fs::copy(file(2), &copy).expect("copy");
    let e = merge();
    assert!(
        matches!(&e, ShardError::Duplicated { shard: 2, shards: 4, files } if files.contains(&copy)),
        "{e}"
    );
    std::fs::remove_file(&copy).expect("rm");

    // foreign: shard 1 of another config replaces ours
    let ctx = ctx(&dir);
    std::fs::remove_file(file(1)).expect("rm");
    shard::run_task_shard(
        "sweep",
        &ctx,
        &other,
        ShardSpec::new(1, 4).expect("valid"),
        &dir,
    )
    .expect("runs");
    let e = merge();
    let first = file(1);
    assert!(
        matches!(&e, ShardError::Foreign { shard: 1, shards: 4, file, .. } if file == &first),
        "{e}"
    );
    assert!(e.to_string().contains("foreign shard 1/4"), "{e}");
    assert!(!out.join("tiny").exists(), "nothing was written");
}

#[test]
fn an_edited_shard_is_inconsistent() {
    // reference: the provenance's config hash, recomputed from the shard's own config
    let (tmp, cfg, _) = setup();
    let dir = tmp.path().join("shards");
    sharded(&cfg, 1, &dir);
    let f = dir.join("shard-1-of-1.json");
    let text = std::fs::read_to_string(&f).expect("read");
    std::fs::write(&f, text.replacen("\"max\":36.0", "\"max\":37.0", 1)).expect("write");
    let e = shard::merge_dir(&dir, &tmp.path().join("m"), &NoProgress).expect_err("refused");
    assert!(matches!(e, ShardError::Inconsistent { .. }), "{e}");
}

#[test]
fn f64_round_trips_exactly_through_shard_json() {
    // reference: the bit pattern; serde_json with float_roundtrip parses the shortest
    // representation it writes back to the same double (checked on 100 000 random
    // finite doubles, including subnormals and extremes)
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut xs: Vec<f64> = (0..100_000)
        .map(|_| f64::from_bits(rng.random::<u64>()))
        .filter(|x| x.is_finite())
        .collect();
    xs.extend([f64::MIN_POSITIVE, 5e-324, f64::MAX, -0.0, 0.1, 1.0 / 3.0]);
    let text = serde_json::to_string(&xs).expect("writes");
    let back: Vec<f64> = serde_json::from_str(&text).expect("reads");
    assert!(
        xs.iter()
            .zip(&back)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
}

/// A sampled study: V_crit over a vehicle-field axis × Latin-hypercube samples of h and l.
const SAMPLED: &str = r#"
name = "sampled"
kind = "linear_critical_speed"

[[axes]]
parameter = "trailer.mass"
min = 800.0
max = 1200.0
points = 3

[sampling]
method = "latin_hypercube"
samples = 7
seed = 11

[[sampling.fields]]
key = "trailer.cog"
distribution = "uniform"
min = 2.85
max = 2.95

[[sampling.fields]]
key = "trailer.axle"
distribution = "normal"
mean = 2.8
sd = 0.03
min = 2.75
max = 2.85

[base]
speed = { kind = "constant", speed_mps = 30.0 }
controller = { kind = "none" }
initial = { kind = "state", theta0_deg = 0.0 }
"#;

#[test]
fn a_sampled_study_over_a_vehicle_axis_merges_byte_for_byte() {
    // reference: the unsharded run of the same file; the samples are drawn per point from
    // the seed (not from a shared stream), so any slicing gives the same points and the
    // merged files (CSV, histogram, summary with its distributions) are the same bytes
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("sampled.toml");
    std::fs::write(&cfg, SAMPLED).expect("write");
    let single = tmp.path().join("single");
    unsharded(&cfg, &single);
    let reference = outputs(&single.join("sampled"));
    assert!(reference.iter().any(|(n, _)| n == "sweep.csv"));
    for n in [2, 5, 21, 40] {
        let shards = tmp.path().join(format!("shards-{n}"));
        sharded(&cfg, n, &shards);
        let merged = tmp.path().join(format!("merged-{n}"));
        shard::merge_dir(&shards, &merged, &NoProgress).expect("merges");
        let got = outputs(&merged.join("sampled"));
        assert_eq!(got.len(), reference.len());
        for ((name, want), (_, have)) in reference.iter().zip(&got) {
            assert!(want == have, "N = {n}: {name} differs");
        }
    }
}

/// The generated vehicles' study as shards: merged, its `runs.csv` (the runs' outcomes and
/// curve ends, no times) is byte for byte the unsharded run's, and the summary counts the
/// same runs. Reference: the unsharded run through the task's own `run`; two vehicles
/// through `linear`, a fraction of a second each.
#[test]
fn the_generated_vehicles_study_shards_and_merges_to_the_unsharded_runs() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("study_generated.toml");
    let configs = repo().join("configs");
    std::fs::write(
        &cfg,
        format!(
            "seed = 52\ncount = 3\ntasks = [\"linear\"]\nconfigs_dir = {:?}\n",
            configs.display().to_string()
        ),
    )
    .expect("write");
    let single = tmp.path().join("single");
    let c = ctx(&single);
    let task = tasks::resolve("study_generated").expect("task").remove(0);
    let (p, _) = tasks::prepare_checked(&task, &c, &cfg).expect("valid");
    p.run(&c).expect("runs");
    let shards = tmp.path().join("shards");
    let c = ctx(&shards);
    for k in 1..=2 {
        let spec = ShardSpec::new(k, 2).expect("valid");
        let r =
            shard::run_task_shard("study_generated", &c, &cfg, spec, &shards).expect("shard runs");
        assert_eq!(r.points_total, 3);
        assert_eq!(r.points_failed, 0, "{r:?}");
    }
    assert_eq!(
        shard::study_name("study_generated", &cfg).expect("name"),
        "study_generated"
    );
    let merged = tmp.path().join("merged");
    shard::merge_dir(&shards, &merged, &NoProgress).expect("merges");
    let read = |d: &Path, f: &str| std::fs::read(d.join("study_generated").join(f)).expect(f);
    assert!(
        read(&single, "runs.csv") == read(&merged, "runs.csv"),
        "runs.csv differs"
    );
    let runs = |d: &Path| -> serde_json::Value {
        let s: serde_json::Value = serde_json::from_slice(&read(d, "summary.json")).expect("json");
        serde_json::json!([s["vehicles"], s["runs"], s["failures"], s["variant_counts"]])
    };
    assert_eq!(runs(&single), runs(&merged));
    assert_eq!(
        runs(&merged),
        serde_json::json!([3, 3, 0, runs(&merged)[3]])
    );
}

#[test]
fn the_sway_assist_evaluation_shards_and_merges_to_the_unsharded_run_byte_for_byte() {
    // a small evaluation on Table I (configs/vehicle.toml): 2 sway and 2 false-alarm
    // scenarios and the observer's ordinary driving = 5 points; every output file
    // (tables, figures; summary.json but its wall time) of the merge of 3 shards equals the
    // unsharded run's
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("sway_assist.toml");
    std::fs::write(
        &cfg,
        r#"horizon_s = 12.0
ordinary_driving_s = 20.0
sway_speeds = [{ of_v_crit = 1.05 }]
false_alarm_speeds = [{ of_v_crit = 0.7 }]
[[sway_disturbances]]
kind = "steering_impulse"
amplitude_deg = 3.0
duration_s = 0.4
[[sway_disturbances]]
kind = "crosswind_gust"
force_n = 3000.0
duration_s = 0.5
[[false_alarm_disturbances]]
kind = "slalom"
frequency_hz = 0.6
lateral_acceleration_mps2 = 2.0
periods = 4.0
[[false_alarm_disturbances]]
kind = "single_lane_change"
lateral_acceleration_mps2 = 3.0
frequency_hz = 0.5
"#,
    )
    .expect("write");
    let single = tmp.path().join("single");
    let c = ctx(&single);
    let task = tasks::resolve("sway_assist").expect("task").remove(0);
    let (p, _) = tasks::prepare_checked(&task, &c, &cfg).expect("valid");
    p.run(&c).expect("runs");
    let shards = tmp.path().join("shards");
    let c = ctx(&shards);
    let mut failed = 0;
    for k in 1..=3 {
        let spec = ShardSpec::new(k, 3).expect("valid");
        let r = shard::run_task_shard("sway_assist", &c, &cfg, spec, &shards).expect("shard runs");
        assert_eq!(r.points_total, 5);
        failed += r.points_failed;
    }
    assert_eq!(failed, 0);
    assert_eq!(
        shard::study_name("sway_assist", &cfg).expect("name"),
        "sway_assist"
    );
    let merged = tmp.path().join("merged");
    shard::merge_dir(&shards, &merged, &NoProgress).expect("merges");
    let (a, b) = (
        outputs(&single.join("sway_assist")),
        outputs(&merged.join("sway_assist")),
    );
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "{name} differs between the unsharded run and the merge"
        );
    }
    assert!(a.iter().any(|f| f.0 == "observer.csv"));
}

#[test]
fn the_sway_assist_evaluation_runs_on_sampled_vehicles() {
    // the observer's ordinary driving (20 s, two manoeuvres) on two sampled vehicles
    // (`sway_model::generator`, seed 52: the first two vehicles of `study_generated`); each
    // gets its row in observer.csv under its generated name, the same in a run of the
    // shards; a count of 0 is an error naming the key
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("sway_assist.toml");
    let text = |count: usize| {
        format!(
            r#"sway_speeds = []
false_alarm_speeds = []
ordinary_driving_s = 20.0
sampled_vehicles = {{ seed = 52, count = {count} }}
[[false_alarm_disturbances]]
kind = "slalom"
frequency_hz = 0.6
lateral_acceleration_mps2 = 1.5
periods = 3.0
[[false_alarm_disturbances]]
kind = "single_lane_change"
lateral_acceleration_mps2 = 2.0
frequency_hz = 0.5
"#
        )
    };
    std::fs::write(&cfg, text(2)).expect("write");
    let results = tmp.path().join("results");
    let c = ctx(&results);
    let task = tasks::resolve("sway_assist").expect("task").remove(0);
    let (p, _) = tasks::prepare_checked(&task, &c, &cfg).expect("valid");
    p.run(&c).expect("runs");
    let observer = std::fs::read_to_string(results.join("sway_assist/observer.csv")).expect("csv");
    let names: Vec<&str> = observer
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().expect("a vehicle"))
        .collect();
    assert_eq!(names, ["generated-0", "generated-1"], "{observer}");
    let shards = tmp.path().join("shards");
    let c = ctx(&shards);
    let r = shard::run_task_shard(
        "sway_assist",
        &c,
        &cfg,
        ShardSpec::new(1, 1).expect("1/1"),
        &shards,
    )
    .expect("shard runs");
    assert_eq!(r.points_total, 2);
    std::fs::write(&cfg, text(0)).expect("write");
    let err = tasks::prepare_checked(&task, &ctx(&results), &cfg)
        .err()
        .expect("a count of 0 is refused")
        .to_string();
    assert!(err.contains("sampled_vehicles.count"), "{err}");
}
