//! Time-domain simulation of the car–trailer model: speed profiles V(t) (paper Fig. 3b),
//! a feedback law ([`LoopLaw`]; the paper's δ(t) = −D·ψ̇(t − τ), eq. 8), initial conditions (a state,
//! or on the sway cycle), the validity guard, metrics computed on the fly, and parallel
//! sweeps. The integration is done by the general-purpose [`dde`] crate: the open loop is an
//! ODE, the closed loop a DDE with one constant delay.
//!
//! Any vehicle simulates ([`sway_model::vehicle::Vehicle`]: the paper's
//! [`trailer_model::Model`] and every [`trailer_model::VehicleModel`] of a vehicle file with
//! model variants): [`SimProblem`] is the ODE/DDE problem of a plant with M reduced states,
//! [`simulate`] runs any vehicle in its own layout, and [`simulate_in_paper_layout`] the
//! paper's model or the model of a vehicle file ([`trailer_model::AnyVehicleModel`], as a
//! [`VehicleForm`]) in the paper's layout of 4 or 7 states.
//!
//! ```
//! use sway::sim::{Outcome, Recording, SimSpec, SpeedProfile, simulate};
//! use trailer_model::{Model, State4, VehicleParams};
//!
//! let model = Model::new(VehicleParams::default()).unwrap();
//! // V = 33 m/s (bistable range), small hitch-angle perturbation of 2°: it dies out
//! let spec = SimSpec {
//!     early_stop: sway::sim::EarlyStop::Never,
//!     steering: Default::default(),
//!     profile: SpeedProfile::Constant { speed_mps: 33.0 },
//!     controller: None,
//!     horizon_s: 30.0,
//!     action_s: 0.0,
//!     settings: Default::default(),
//! };
//! let x0 = State4::new(0.0, 0.0, 0.0, 2f64.to_radians());
//! let r = simulate(&model, &spec, x0, Recording::None).unwrap();
//! assert_eq!(r.metrics.outcome, Outcome::Ok);
//! assert!(r.metrics.final_amplitude_deg.unwrap() < 1.0);
//! ```

pub mod classify;
pub mod cosim;
pub mod decay;
mod paper_layout;
mod plant;
mod profile;
mod run;
mod scenario;
mod steering;
pub use sway_model::speeds::resolve as speeds;

pub use classify::{MetricSettings, SwayClass};
pub use paper_layout::{
    VehicleForm, lift_state, paper_layout, settle_in_paper_layout, simulate_in_paper_layout,
};
#[allow(deprecated)]
pub use plant::Plant;
pub use plant::{HeldInputs, SWITCHING_FUNCTIONS, SimProblem, reduced, reduced_state};
pub use profile::{RampShape, SpeedProfile};
pub use run::{
    ControllerStates, EarlyStop, IntegrationMethod, KinkLandingMode, Layout, Metrics, Outcome,
    Recording, RunSettings, Sample, SimResult, SimSpec, SimulateOwn, SolverSettings, ValidityGuard,
    guard_event, settle, simulate, tripped,
};
pub use scenario::{
    InitialCondition, ScenarioConfig, SwayStart, default_action_time, ensure_name, validate_parts,
    validate_spec_parts,
};
pub use steering::{PulseShape, SteeringInput};
pub use sway_model::law::table::{ControllerTable, PredictionVehicle, UnloadedPrediction};
pub use sway_model::law::{ActuatorLimits, CommandLimit, LoopLaw, ModelError};
pub use sway_model::speeds::resolve::{Resolution, ResolveSpeeds, ResolvedSpeed, UnresolvedSpeed};
pub use sway_model::vehicle::{LossOfControl, SLIP_TANGENT_FLOOR};
