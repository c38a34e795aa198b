//! The integration tests of this crate in one test binary (`autotests = false` in
//! Cargo.toml): each `tests/<name>.rs` is the module `<name>`, so a test is
//! `cargo test -p <crate> --test all <name>::<test>`. One binary links the dependency
//! graph once instead of once per file, and its tests share one pool of test threads
//! (the time of `cargo test --workspace`). `#[path]` makes each file a mod-rs
//! module, so that its own `mod common;` still finds `tests/common/mod.rs`.

// each file keeps its `mod common;` (a copy per module): the files stay as they were
#![allow(clippy::duplicate_mod)]

#[path = "actuator.rs"]
mod actuator;
#[path = "assist.rs"]
mod assist;
#[path = "combination.rs"]
mod combination;
#[path = "linear.rs"]
mod linear;
#[path = "loading.rs"]
mod loading;
#[path = "mitigation.rs"]
mod mitigation;
#[path = "optimise.rs"]
mod optimise;
#[path = "simulation.rs"]
mod simulation;
#[path = "trivial_multiplier.rs"]
mod trivial_multiplier;
// the unit tests of the pipeline modules (tests/unit/mod.rs says why they are here)
mod unit;

/// `autotests = false` runs no `tests/*.rs` on its own: a new file must be a module above
/// (or its own `[[test]]` in Cargo.toml) or its tests would silently never run; likewise a
/// new file of `tests/unit/` must be a module of `tests/unit/mod.rs`.
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    assert_modules(&dir, "all.rs", &[]);
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
