//! The detectors could run on a controller and know nothing of the simulation: this crate's
//! normal dependencies hold no other crate of the workspace and nothing that reads files or
//! draws. Reference: `cargo tree` of its normal dependencies (as `sway-tasks`'s layering
//! test does for the library floors).

use std::process::Command;

#[test]
fn sway_detect_depends_on_no_workspace_crate_and_no_file_format() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "--package",
            "sway-detect",
            "--edges",
            "normal",
            "--prefix",
            "none",
            "--format",
            "{p}",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8_lossy(&out.stdout);
    let crates: Vec<&str> = tree
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(crates.contains(&"sway-detect"), "unexpected output: {tree}");
    for forbidden in [
        "cancel",
        "tires",
        "trailer-model",
        "dde",
        "continuation",
        "stability",
        "sway-model",
        "sway",
        "sway-studies",
        "sway-tasks",
        "toml",
        "serde_json",
        "csv",
        "plotters",
    ] {
        assert!(
            !crates.contains(&forbidden),
            "sway-detect depends on {forbidden}: {crates:?}"
        );
    }
}
