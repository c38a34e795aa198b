//! The model floor of trailer-sway: what the analysis engines ([`sway`]) and the studies
//! (`sway-studies`) share and what knows nothing about simulation, continuation or charts.
//!
//! - [`vehicle`]: the one vehicle abstraction of the engines ([`vehicle::Vehicle`]) and its
//!   object-safe view for the linear loops ([`vehicle::LoopModel`], [`linear_view!`]);
//! - [`law`]: the loop laws — controller structures, actuators and gains, the predictor's
//!   realisation, and the one feedback law every engine takes ([`law::LoopLaw`]);
//! - [`speeds`]: the limits of every automatic range ([`speeds::SpeedLimits`]), the open-loop
//!   critical-speed search, speeds given relative to the vehicle ([`speeds::SpeedSpec`]) and
//!   their resolution in a config ([`speeds::resolve`]);
//! - [`config`]: typed config values that validate themselves ([`config::Positive`],
//!   [`config::Grid`]);
//! - [`optimise`]: a bounded multi-start Nelder–Mead with a discrete choice;
//! - [`sampling`]: Monte-Carlo and Latin-hypercube samples and their statistics;
//! - [`generator`]: seeded plausible car–trailer combinations with random model-variant
//!   mixes (the vehicles of `study_generated` and of the many-vehicle tests);
//! - [`parallel`], [`progress`]: the parallel maps and the progress observer every engine
//!   takes;
//! - [`SwayError`]: the error of the floors above.
//!
//! [`sway`]: https://docs.rs/sway
//!
//! ```
//! use sway_model::law::{Actuator, Gains, Structure};
//! use sway_model::speeds::{SpeedLimits, open_loop_critical_speed};
//! use trailer_model::{Model, VehicleParams};
//!
//! let model = Model::new(VehicleParams::default()).unwrap();
//! let stability = open_loop_critical_speed(&model, &SpeedLimits::default()).unwrap();
//! // Table I loses straight running at 34.75 m/s
//! assert!((stability.v_crit().unwrap() - 34.75).abs() < 0.01);
//! // the paper's controller: steering on the yaw rate alone
//! let gains = Gains::yaw_rate(0.1);
//! assert_eq!(Structure::YawRate.gain_names().len(), 1);
//! assert_eq!((Actuator::Steering.as_str(), gains.hitch_angle), ("steering", 0.0));
//! ```

pub mod config;
mod error;
pub mod generator;
pub mod law;
pub mod optimise;
pub mod parallel;
pub mod progress;
pub mod sampling;
pub mod speeds;
pub mod vehicle;

pub use error::SwayError;

/// The model crate, for [`linear_view!`]'s expansion in other crates.
#[doc(hidden)]
pub use trailer_model as __trailer_model;
