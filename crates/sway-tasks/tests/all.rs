//! The integration tests of this crate in one test binary (`autotests = false` in
//! Cargo.toml): each `tests/<name>.rs` is the module `<name>`, so a test is
//! `cargo test -p <crate> --test all <name>::<test>`. One binary links the dependency
//! graph once instead of once per file, and its tests share one pool of test threads
//! (the time of `cargo test --workspace`). `#[path]` makes each file a mod-rs
//! module, so that its own `mod common;` still finds `tests/common/mod.rs`.

// each file keeps its `mod common;` (a copy per module): the files stay as they were
#![allow(clippy::duplicate_mod)]

#[path = "capped_speeds.rs"]
mod capped_speeds;
#[path = "combinations.rs"]
mod combinations;
#[path = "configs.rs"]
mod configs;
#[path = "generated_inputs.rs"]
mod generated_inputs;
#[path = "generated_vehicles.rs"]
mod generated_vehicles;
#[path = "guide.rs"]
mod guide;
#[path = "import_cycles.rs"]
mod import_cycles;
#[path = "layering.rs"]
mod layering;
#[path = "linear.rs"]
mod linear;
#[path = "many_vehicles.rs"]
mod many_vehicles;
#[path = "many_vehicles_scenarios.rs"]
mod many_vehicles_scenarios;
#[path = "numerical_extremes.rs"]
mod numerical_extremes;
#[path = "shard.rs"]
mod shard;
#[path = "simulate_figure.rs"]
mod simulate_figure;
// the unit tests of the library's modules (tests/unit/mod.rs says why they are here)
mod unit;

/// `autotests = false` runs no `tests/*.rs` on its own: a new file must be a module above
/// (or its own `[[test]]` in Cargo.toml) or its tests would silently never run; likewise a
/// new file of `tests/unit/` must be a module of `tests/unit/mod.rs`.
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    assert_modules(&dir, "all.rs", &["regenerate.rs"]);
    assert_modules(&dir.join("unit"), "mod.rs", &[]);
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
