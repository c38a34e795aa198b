//! Trailer-sway scenarios and figure pipelines: the application layer that wires the
//! vehicle model ([`trailer_model`]) into the numerical crates ([`dde`], [`stability`],
//! [`continuation`]), reads TOML configs, and writes CSV, JSON and figures.
//!
//! Every task of `cargo xtask` is a library function here ([`tasks`]), so tests reach
//! every pipeline. Configs are typed and validated before any work
//! ([`config`]); results are written atomically ([`io`]).
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
pub mod config;
mod error;
pub mod io;
pub mod linear;
pub mod loading;
pub mod plot;
pub mod progress;
pub mod sim;
pub mod tasks;

pub use error::SwayError;
