//! The unit tests of the modules whose tests drive whole pipelines (bifurcation diagrams,
//! charts, control design, gain design, sweeps), one file per module
//! (`<module path>_tests.rs`). They live here rather than in `src/` so that
//! `cargo test` does not compile the library a second time for them: its test build
//! recompiled everything they reach. Helpers they need are
//! `#[doc(hidden)] pub` in place, or re-exported by `sway::__unit_tests` from private modules.

mod bifurcation_chart_tests;
mod bifurcation_closed_loop_tests;
mod bifurcation_corners_tests;
mod bifurcation_tests;
mod charts_tests;
mod control_tests;
mod gain_design_tests;
