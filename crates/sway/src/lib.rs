//! Trailer-sway scenarios: the library that wires the vehicle model ([`trailer_model`])
//! into the numerical crates ([`dde`], [`stability`], [`continuation`]) — simulation
//! ([`sim`]), bifurcation diagrams ([`bifurcation`]), stability charts ([`charts`]),
//! linear analysis ([`linear`]), trailer loading ([`loading`]) and the design of the
//! feedback gain ([`gain_design`]), uncertainty sampling ([`sampling`]) — with typed configs as
//! plain serde data and their validation ([`config`]).
//!
//! It computes and returns values: it reads no files, writes no files and does not
//! depend on the plotting stack. The task layer above it (`sway-tasks`, used by
//! `cargo xtask`) reads config files, writes `results/<task>/` and draws the figures.
//!
//! ```
//! use sway::linear::eigen_table;
//! use trailer_model::{Model, VehicleParams};
//!
//! let model = Model::new(VehicleParams::default()).unwrap();
//! let table = eigen_table(&model, &[20.0, 30.0, 40.0]);
//! // straight running is stable at 20 m/s and unstable at 40 m/s
//! assert!(table.eigenvalues[0].iter().all(|l| l.re < 0.0));
//! assert!(table.eigenvalues[2].iter().any(|l| l.re > 0.0));
//! ```

pub mod bifurcation;
pub mod charts;
pub mod control;
pub mod gain_design;
pub mod linear;
pub mod loading;
pub mod mitigation;
pub mod ranging;
pub mod sim;

pub use sway_model::{SwayError, config, parallel, progress, sampling};

/// Internals of private modules that the tests in `tests/unit/` reach. Those tests are the
/// unit tests of the modules whose tests drive whole pipelines, kept as integration tests so
/// that `cargo test` does not compile the crate a second time for them (the library's test
/// build recompiled everything they reach: 32 of its 36 unit-s; issue 23 item 7). Helpers of
/// public modules that they call are `#[doc(hidden)] pub` in place. Not part of the API.
#[doc(hidden)]
pub mod __unit_tests {
    pub use crate::bifurcation::ranged::{FirstLoss, straight_running_to_first_loss};
}
