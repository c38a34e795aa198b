//! The analysis floor of trailer-sway: the engines that take a vehicle
//! ([`sway_model::vehicle::Vehicle`]) and a loop law and return values — simulation
//! ([`sim`]), bifurcation diagrams and the nonlinear chart ([`bifurcation`]), linear
//! stability charts of the delayed loop ([`charts`]), linear analysis ([`linear`]), trailer
//! loading ([`loading`]), the reference speeds that need a diagram ([`ranging`]), the design
//! of the feedback gain ([`gain_design`]) and of other controllers ([`control`]), and the
//! mitigation ([`mitigation`]). They wire the model ([`trailer_model`]) into the numerical
//! crates ([`dde`], [`stability`], [`continuation`]).
//!
//! It reads no files, writes no files and does not depend on the plotting stack. The model
//! floor below it is `sway-model` (re-exported here: [`config`], [`parallel`],
//! [`progress`], [`sampling`], [`SwayError`]); the studies above it, one per task, are
//! `sway-studies`.
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

pub mod assist;
pub mod bifurcation;
pub mod charts;
pub mod combination;
pub mod control;
pub mod gain_design;
pub mod linear;
pub mod loading;
pub mod mitigation;
pub mod ranging;
pub mod sim;

pub use sway_model::{SwayError, config, parallel, progress, sampling};

/// Internals of private modules that the tests in `tests/unit/` reach (the unit tests of
/// the modules whose tests drive whole pipelines, kept as integration tests so that
/// `cargo test` does not compile the crate a second time for them). Not part of the API.
#[doc(hidden)]
pub mod __unit_tests {
    pub use crate::bifurcation::ranged::{FirstLoss, straight_running_to_first_loss};
}
