//! The integration tests of this crate in one test binary (`autotests = false` in
//! Cargo.toml): each `tests/<name>.rs` is the module `<name>`, so a test is
//! `cargo test -p sway-detect --test all <name>::<test>`. `#[path]` makes each file a
//! mod-rs module, so that its own `mod common;` still finds `tests/common/mod.rs`.
//! `tests/no_alloc.rs` is its own binary (a counting global allocator, no harness).

// each file keeps its `mod common;` (a copy per module): the files stay as they were
#![allow(clippy::duplicate_mod)]

#[path = "bad_input.rs"]
mod bad_input;
#[path = "counter.rs"]
mod counter;
#[path = "damping.rs"]
mod damping;
#[path = "filter.rs"]
mod filter;
#[path = "independence.rs"]
mod independence;
#[path = "observer.rs"]
mod observer;
#[path = "sensors.rs"]
mod sensors;

/// `autotests = false` runs no `tests/*.rs` on its own: a new file must be a module above
/// (or its own `[[test]]` in Cargo.toml) or its tests would silently never run.
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let all = std::fs::read_to_string(dir.join("all.rs")).expect("tests/all.rs");
    let own_binaries: [&str; 1] = ["no_alloc.rs"];
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
