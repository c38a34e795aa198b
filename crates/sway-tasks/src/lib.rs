//! The task layer of trailer-sway: everything `cargo xtask` does around the scenario
//! library [`sway`] — the task registry ([`tasks`]), reading config files with errors that
//! name the file and key path ([`config_file`]), staged result directories and the CSV and
//! JSON writers ([`io`]), sharding a study over machines and merging it exactly ([`shard`]), the time-series helpers shared by the simulation tasks
//! ([`report`]) and figures rendered to SVG and PNG ([`plot`]).
//!
//! The library [`sway`] computes and never writes a file or links the plotting stack;
//! this crate writes `results/<task>/`.

pub mod config_file;
mod error;
pub mod figures;
pub mod io;
pub mod limits;
pub mod plot;
pub mod recording;
pub mod report;
pub mod shard;
pub mod tasks;

pub use error::TaskError;
