//! The committed results regenerate byte for byte: the `linear` task, run from the
//! repository root with the shipped configs, writes exactly the data files under
//! `results/linear/` (the CSV tables, and `summary.json` apart from `wall_time_s`).
//!
//! The figures (SVG, PNG) are left out here: their bytes belong to the plotting code, and
//! `cargo xtask all` followed by `git status --short results/` checks them.
//!
//! This file holds one test on purpose: it changes the working directory (summaries record
//! config paths relative to it), which is process-wide.

use std::path::{Path, PathBuf};

use sway::progress::NoProgress;
use sway_tasks::tasks::{self, TaskContext};

/// `summary.json` without its `wall_time_s` line (the one field that differs between runs).
fn without_wall_time(text: &str) -> String {
    text.lines()
        .filter(|l| !l.trim_start().starts_with("\"wall_time_s\""))
        .map(|l| l.trim_end_matches(','))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_linear_task_regenerates_its_committed_results_byte_for_byte() {
    let root: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("repository root");
    std::env::set_current_dir(&root).expect("cd to the repository root");
    let tmp = tempfile::tempdir().expect("tempdir");
    let ctx = TaskContext::new(
        &root.join("configs/vehicle.toml"),
        &root.join("configs"),
        tmp.path(),
        &NoProgress,
    )
    .expect("vehicle loads");
    let task = tasks::resolve("linear").expect("known")[0];
    (task.prepare)(&ctx, &root.join("configs").join(task.config))
        .expect("config valid")
        .run(&ctx)
        .expect("runs");
    let committed = root.join("results/linear");
    let mut compared = 0;
    for entry in std::fs::read_dir(&committed).expect("committed results") {
        let path = entry.expect("entry").path();
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or_default();
        if !matches!(ext, "csv" | "json") {
            continue;
        }
        let old = std::fs::read_to_string(&path).expect("read committed");
        let new = std::fs::read_to_string(tmp.path().join("linear").join(name))
            .unwrap_or_else(|e| panic!("{name} not regenerated: {e}"));
        if ext == "json" {
            assert_eq!(without_wall_time(&new), without_wall_time(&old), "{name}");
        } else {
            assert!(new == old, "{name} differs from the committed file");
        }
        compared += 1;
    }
    assert!(compared >= 4, "only {compared} data files compared");
}
