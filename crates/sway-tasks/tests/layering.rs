//! The layering: the three library floors (`sway-model`, `sway`, `sway-studies`) do not
//! depend on the plotting stack (or on anything that reads or writes files for the tasks),
//! and each depends only on the floors below it. A user who calls the simulation from Rust
//! compiles none of the rest. Reference: `cargo tree` of each floor's normal dependencies.

use std::process::Command;

/// The normal dependencies of `package` (itself included), by `cargo tree`.
fn dependencies(package: &str) -> Vec<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "--package",
            package,
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
    let crates: Vec<String> = tree
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect();
    assert!(
        crates.iter().any(|c| c == package),
        "unexpected output: {tree}"
    );
    crates
}

/// The floors from the bottom up: each may depend on those below it, none above.
const FLOORS: [&str; 3] = ["sway-model", "sway", "sway-studies"];

#[test]
fn the_library_floors_do_not_depend_on_the_plotting_stack_or_on_higher_floors() {
    for (level, floor) in FLOORS.iter().enumerate() {
        let crates = dependencies(floor);
        let above = FLOORS[level + 1..].iter().copied();
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
        ]
        .into_iter()
        .chain(above)
        {
            assert!(
                !crates.iter().any(|c| c == forbidden),
                "{floor} depends on {forbidden}: {crates:?}"
            );
        }
    }
}
