//! The unit tests of the task modules (their configs, checks and small helpers) and of
//! `limits` and `shard`. They live here rather than in `src/` so that `cargo test` does not
//! compile the library a second time for them: its test build recompiled everything they
//! reach. Helpers they need are `#[doc(hidden)] pub` in place. The
//! figures' layout tests (`plot`) and the staging-file tests (`io`) stay in `src/`: they
//! test private details and reach little.

mod chart_nonlinear_tests;
mod control_design_tests;
mod corners_tests;
mod fig4a_tests;
mod gain_design_tests;
mod limits_tests;
mod mitigation_tests;
mod roots_tests;
mod shard_tests;
mod sweep_tests;
