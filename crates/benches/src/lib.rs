//! The criterion benchmarks of the workspace, one package for all of them. The bench files
//! live beside the crate each measures (`crates/<crate>/benches/<name>.rs`, named in this
//! package's `Cargo.toml`): `cargo bench --bench <name>` runs one, `cargo bench` all.
//!
//! Why a package of its own: a crate's dev-dependencies are built for every `cargo test` of
//! it, and criterion with its dependencies was ≈ 21 of the ≈ 490 compile unit-seconds of a
//! fresh `cargo test --workspace`. This package has no test target, so
//! `cargo test` builds nothing of it; `cargo clippy --all-targets` still checks the benches.
