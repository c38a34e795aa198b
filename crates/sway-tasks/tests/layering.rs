//! The layering: the scenario library `sway` does not depend on the plotting stack (or on
//! anything that reads or writes files for the tasks). A user who calls the simulation
//! from Rust compiles none of it. Reference: `cargo tree` of `sway`'s normal dependencies.

use std::process::Command;

#[test]
fn the_scenario_library_does_not_depend_on_the_plotting_stack() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "--package",
            "sway",
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
    assert!(crates.contains(&"sway"), "unexpected output: {tree}");
    for forbidden in [
        "plotters",
        "dejavu",
        "tiny-skia",
        "ab_glyph",
        "image",
        "csv",
        "toml",
        "serde_json",
        "sway-tasks",
    ] {
        assert!(
            !crates.contains(&forbidden),
            "sway depends on {forbidden}:\n{tree}"
        );
    }
}
