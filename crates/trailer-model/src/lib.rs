//! The single-track car–trailer model of "Controlling the nonlinear dynamics of trailer
//! sway": vehicle parameters (Table I), static axle loads, slip angles (eq. 2), the
//! Appellian equations of motion (eq. 5–7) with brush tires (eq. 14–15), a prescribed,
//! time-varying speed V(t) and steering angle δ, and the linearisation about straight
//! running (eq. 9–11).
//!
//! Beyond the paper: the plant abstraction [`Plant`] (any model with N reduced
//! states, exact derivatives, linearisation, V_crit; [`Model`] is `Plant<4>`), and the
//! general model [`VehicleModel`] built from a vehicle file [`VehicleSpec`] — axle lists
//! (tandems), a tyre law per axle, first-order tyre relaxation, hitch damping — with
//! [`AnyVehicleModel`] / [`with_plant!`] choosing N at run time. A vehicle file may give a
//! chain of towed units (`[[trailers]]`, [`ChainSpec`]): the same [`VehicleModel`] type then
//! runs the chain's equations ([`ChainModel`], Kane's method) in the layout of every plant.
//!
//! ```
//! use trailer_model::{CriticalSpeedOptions, Plant, VehicleModel, VehicleSpec};
//!
//! // Table I with relaxation length σ = 0.3 m on every axle: 4 + 3 states
//! let model = VehicleModel::<7>::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap();
//! let vc = model.critical_speed(&CriticalSpeedOptions::default()).unwrap();
//! assert!((vc.v_crit_mps - 32.58).abs() < 0.01);
//! ```
//!
//! This crate knows nothing about files, plots or solvers: it evaluates right-hand sides
//! and their exact derivatives. The right-hand sides are generic over the scalar type
//! ([`num_dual::DualNum`]), so Jacobians are exact.
//!
//! ```
//! use trailer_model::{Inputs, Model, State4, VehicleParams, CriticalSpeedOptions};
//!
//! let model = Model::new(VehicleParams::default()).unwrap(); // Table I
//! // hitch angle θ = 0.1 rad at V = 33 m/s: the trailer is pushed back toward θ = 0
//! let x = State4::new(0.0, 0.0, 0.0, 0.1);
//! let dx = model.rhs4(&x, &Inputs::constant_speed(33.0));
//! assert!(dx[2] < 0.0);
//! // straight running loses stability near 34 m/s
//! let vc = model.critical_speed(&CriticalSpeedOptions::default()).unwrap();
//! assert!((vc.v_crit_mps - 34.0).abs() < 1.0);
//! ```

mod chain;
mod chain_spec;
mod extended;
mod linear;
mod model;
mod params;
mod plant;
mod spec;

pub use chain::{AsChain, ChainAxle, ChainModel, Pose, UnitMotion};
pub use chain_spec::{ChainAxleSpec, ChainSpec, MAX_CHAIN_AXLES, MAX_TOWED_UNITS, TowedUnitSpec};
pub use extended::{AnyVehicleModel, AxleModel, MAX_STATES, VehicleModel};
pub use linear::{CriticalSpeed, CriticalSpeedOptions, Linearization, sorted_eigenvalues};
pub use model::{HITCH_ANGLE, Inputs, Model, SlipAngles, State4, State7, YAW_ANGLE};
pub use params::{
    AxleLoads, FrictionParams, PARAMETERS, TractorParams, TrailerParams, VehicleParams,
};
pub use plant::sorted_spectrum;
pub use plant::{Plant, PlantLinearization, SwitchingKind};
pub use spec::{
    AxleSpec, DEFAULT_FRICTION_REGULARISATION_RAD_S, HitchSpec, MAX_AXLES, MIN_AXLE_SPACING_M,
    ResolvedAxle, TractorSpec, TrailerSpec, Unit, VehicleSpec,
};

/// Errors of the model crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// A vehicle parameter violates a physical constraint.
    #[error("invalid vehicle parameter `{key}` = {value}: expected {expected}")]
    InvalidParameter {
        /// key path of the parameter, e.g. `tractor.rear_axle`
        key: &'static str,
        /// the offending value
        value: f64,
        /// what was expected
        expected: &'static str,
    },
    /// A tire could not be built (e.g. a non-positive static axle load).
    #[error("{axle} tire: {source} (check the geometry: the static axle load follows from it)")]
    Tire {
        /// which axle
        axle: &'static str,
        /// the tire error
        #[source]
        source: tires::TireError,
    },
    /// A key of a vehicle file (the variants of [`VehicleSpec`]) violates a constraint.
    #[error("invalid vehicle key `{key}` = {value}: expected {expected}")]
    InvalidSpec {
        /// key path, e.g. `trailer.axles[1].position_m`
        key: String,
        /// the offending value (NaN where the key is missing or a choice is wrong)
        value: f64,
        /// what was expected
        expected: String,
    },
    /// The tyre law of an axle cannot be built.
    #[error("`{key}`: {source}")]
    TireSpec {
        /// key path of the tyre law, e.g. `tractor.front_tire`
        key: String,
        /// the tyre error
        #[source]
        source: tires::TireError,
    },
    /// A [`VehicleModel`] was asked for a state count its vehicle does not have.
    #[error(
        "the vehicle has {relaxed} relaxing axles, hence {expected} states, not {requested}{hint}"
    )]
    StateCount {
        /// axles with σ > 0
        relaxed: usize,
        /// 4 + relaxed
        expected: usize,
        /// the N asked for
        requested: usize,
        /// what to do
        hint: &'static str,
    },
    /// No sign change of the open-loop spectral abscissa in the scanned speed range.
    #[error("no critical speed in [{v_min}, {v_max}] m/s: {detail}; widen the speed range")]
    NoCriticalSpeed {
        /// lower end of the scan \[m/s\]
        v_min: f64,
        /// upper end of the scan \[m/s\]
        v_max: f64,
        /// what was seen
        detail: &'static str,
    },
}
