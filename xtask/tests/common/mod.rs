//! Shared by the sharding tests: a small sweep, running the xtask binary, and comparing
//! result directories.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A sweep of 5 speeds × 3 initial hitch angles, 10 s each (about 0.1 s in all).
pub const SWEEP: &str = r#"
name = "cluster_check"

[[axes]]
parameter = "speed_mps"
min = 30.0
max = 36.0
points = 5

[[axes]]
parameter = "theta0_deg"
min = 2.0
max = 12.0
points = 3

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

/// The xtask binary of this build.
pub fn xtask() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_xtask"))
}

/// The repository's vehicle file.
pub fn vehicle() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/vehicle.toml")
}

/// Runs xtask with `args`; panics with its output unless it succeeds.
pub fn run_ok(args: &[&str]) -> Output {
    let out = run(args);
    assert!(
        out.status.success(),
        "xtask {args:?} failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs xtask with `args`.
pub fn run(args: &[&str]) -> Output {
    Command::new(xtask())
        .args(args)
        .output()
        .expect("xtask runs")
}

/// The files of a results directory, name and bytes; `summary.json` without its
/// `wall_time_s` line (the one field that differs between two runs).
pub fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).expect("read");
            if n != "summary.json" {
                return (n, bytes);
            }
            let text = String::from_utf8(bytes).expect("utf-8");
            let kept: Vec<&str> = text
                .lines()
                .filter(|l| !l.trim_start().starts_with("\"wall_time_s\""))
                .collect();
            (n, kept.join("\n").into_bytes())
        })
        .collect()
}

/// Asserts that two result directories hold the same files with the same bytes.
pub fn assert_same_outputs(want: &Path, have: &Path) {
    let (a, b) = (outputs(want), outputs(have));
    let names = |v: &[(String, Vec<u8>)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b), "the same files");
    assert!(a.len() >= 4, "csv, summary and figures: {:?}", names(&a));
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "{name} differs between {} and {}",
            want.display(),
            have.display()
        );
    }
}

/// `path` as a &str (the temporary directories are UTF-8).
pub fn s(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}
