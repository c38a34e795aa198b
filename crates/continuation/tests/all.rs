//! The integration tests of this crate in one test binary (`autotests = false` in
//! Cargo.toml): each `tests/<name>.rs` is the module `<name>`, so a test is
//! `cargo test -p <crate> --test all <name>::<test>`. One binary links the dependency
//! graph once instead of once per file, and its tests share one pool of test threads
//! (the time of `cargo test --workspace`). `#[path]` makes each file a mod-rs
//! module, so that its own `mod common;` still finds `tests/common/mod.rs`.

// each file keeps its `mod common;` (a copy per module): the files stay as they were
#![allow(clippy::duplicate_mod)]

#[path = "branch_points.rs"]
mod branch_points;
#[path = "curves.rs"]
mod curves;
#[path = "dde.rs"]
mod dde;
#[path = "fold_cycles.rs"]
mod fold_cycles;
#[path = "kinks.rs"]
mod kinks;
#[path = "linear_solver.rs"]
mod linear_solver;
#[path = "normal_forms.rs"]
mod normal_forms;
#[path = "ode.rs"]
mod ode;
#[path = "period_doubling.rs"]
mod period_doubling;
#[path = "stagnation.rs"]
mod stagnation;
#[path = "torus.rs"]
mod torus;

/// `autotests = false` runs no `tests/*.rs` on its own: a new file must be a module above
/// (or its own `[[test]]` in Cargo.toml) or its tests would silently never run.
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let all = std::fs::read_to_string(dir.join("all.rs")).expect("tests/all.rs");
    let own_binaries: [&str; 0] = [];
    for entry in std::fs::read_dir(&dir).expect("tests/") {
        let name = entry
            .expect("an entry")
            .file_name()
            .into_string()
            .expect("UTF-8");
        if let Some(module) = name.strip_suffix(".rs")
            && name != "all.rs"
            && !own_binaries.contains(&name.as_str())
        {
            assert!(
                all.contains(&format!("\nmod {module};\n")),
                "tests/{name} is not a module of tests/all.rs"
            );
        }
    }
}
