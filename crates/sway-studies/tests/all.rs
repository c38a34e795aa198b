//! The integration tests of this crate in one test binary (`autotests = false` in
//! Cargo.toml): each `tests/<name>.rs` is the module `<name>`, so a test is
//! `cargo test -p <crate> --test all <name>::<test>`. One binary links the dependency
//! graph once instead of once per file, and its tests share one pool of test threads
//! (the time of `cargo test --workspace`). `#[path]` makes each file a mod-rs
//! module, so that its own `mod common;` still finds `tests/common/mod.rs`.

// each file keeps its `mod common;` (a copy per module): the files stay as they were
#![allow(clippy::duplicate_mod)]

#[path = "charts_vehicle.rs"]
mod charts_vehicle;
#[path = "fig4b.rs"]
mod fig4b;
#[path = "lateral_stability.rs"]
mod lateral_stability;
#[path = "newcomer_vehicle.rs"]
mod newcomer_vehicle;
#[path = "roots.rs"]
mod roots;
#[path = "scenario_speeds.rs"]
mod scenario_speeds;
#[path = "sway_assist.rs"]
mod sway_assist;
#[path = "sweep.rs"]
mod sweep;
#[path = "sweep_points.rs"]
mod sweep_points;
#[path = "sweep_variants.rs"]
mod sweep_variants;

#[test]
fn every_test_file_is_a_module_of_this_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    assert_modules(&dir, "all.rs", &[]);
}

/// Every `*.rs` file of `dir` other than `root` and `own_binaries` is a `mod` of `dir/root`.
fn assert_modules(dir: &std::path::Path, root: &str, own_binaries: &[&str]) {
    let text = std::fs::read_to_string(dir.join(root)).expect("the module file");
    for entry in std::fs::read_dir(dir).expect("the test directory") {
        let name = entry
            .expect("an entry")
            .file_name()
            .into_string()
            .expect("UTF-8");
        if let Some(module) = name.strip_suffix(".rs")
            && name != root
            && !own_binaries.contains(&name.as_str())
        {
            assert!(
                text.contains(&format!("\nmod {module};\n")),
                "{}/{name} is not a module of {root}",
                dir.display()
            );
        }
    }
}
