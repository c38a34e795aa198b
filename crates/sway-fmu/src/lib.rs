//! The car–trailer model of trailer-sway as a **Co-Simulation FMU** (FMI 2.0 and FMI 3.0):
//! the vehicle of a vehicle file with its delayed sway controller, integrated inside the
//! FMU by the project's own DDE solver (kinks landed, the controller's delay history kept
//! across communication points), for Simulink, Dymola / OpenModelica, CarMaker or FMPy.
//!
//! - [`variables`]: the FMU's inputs, outputs and parameters, their names and units;
//! - [`instance`]: one instance and its state machine, independent of the FMI version;
//! - [`engine`]: the simulation (`sway`'s [`sway::sim::SimProblem`] with the master's held
//!   inputs) stepped one communication interval at a time, its state saved as bytes;
//! - [`description`] and [`archive`]: `modelDescription.xml` of either version and the
//!   `.fmu` archive (`cargo xtask fmu` writes `results/fmu/`);
//! - `ffi`: the C entry points `fmi2…` and `fmi3…` of the shared library; every one
//!   catches panics and returns `Error` with a logged message.
//!
//! The instance can be driven from Rust as the C functions drive it:
//!
//! ```
//! use sway_fmu::config::Defaults;
//! use sway_fmu::instance::Instance;
//! use sway_fmu::variables::{Kind, Value};
//!
//! let mut fmu = Instance::new(Defaults::default()).unwrap(); // Table I, open loop, 33 m/s
//! let theta0 = fmu.reference("initial_hitch_angle_rad").unwrap();
//! fmu.set(theta0, Value::Real(0.1)).unwrap();
//! fmu.enter_initialization().unwrap();
//! fmu.exit_initialization().unwrap();
//! for k in 0..100 {
//!     fmu.do_step(k as f64 * 0.01, 0.01).unwrap(); // 1 s in steps of 10 ms
//! }
//! let theta = fmu.reference("hitch_angle_rad").unwrap();
//! let Value::Real(th) = fmu.get(theta, Kind::Real).unwrap() else { panic!() };
//! assert!(th.abs() < 0.1); // the sway decays at 33 m/s from 0.1 rad
//! ```

#[forbid(unsafe_code)]
pub mod archive;
#[forbid(unsafe_code)]
pub mod config;
#[forbid(unsafe_code)]
pub mod description;
#[forbid(unsafe_code)]
pub mod engine;
#[forbid(unsafe_code)]
mod error;
pub mod ffi;
#[forbid(unsafe_code)]
pub mod instance;
#[forbid(unsafe_code)]
pub mod variables;

pub use error::FmuError;

/// The FMU's model identifier: the shared library is `binaries/<platform>/trailer_sway.so`.
pub const MODEL_IDENTIFIER: &str = "trailer_sway";
