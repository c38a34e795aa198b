//! Helpers shared by the simulation tests and benchmarks (`#[path]`-included by
//! `benches/simulation.rs`).
#![allow(dead_code)]

use sway::sim::{
    LoopLaw, MetricSettings, RunSettings, SimSpec, SolverSettings, SpeedProfile, ValidityGuard,
};
use trailer_model::{Model, State7, VehicleParams};

/// the model with the paper's Table I parameters
pub fn model() -> Model {
    Model::new(VehicleParams::default()).unwrap()
}

/// a run with the action at t = 0, the validity guard on, default metrics and the solver
/// tolerances `rtol` and atol = rtol/100
pub fn spec(
    profile: SpeedProfile,
    controller: Option<LoopLaw>,
    horizon_s: f64,
    rtol: f64,
) -> SimSpec {
    SimSpec {
        early_stop: sway::sim::EarlyStop::Never,
        steering: Default::default(),
        profile,
        controller,
        horizon_s,
        action_s: 0.0,
        settings: RunSettings {
            guard: ValidityGuard::Stop,
            solver: SolverSettings {
                rtol,
                atol: rtol * 1e-2,
                ..SolverSettings::default()
            },
            metrics: MetricSettings::default(),
        },
    }
}

/// the straight-running state with hitch angle θ(0) = `theta_deg` (deg)
pub fn x7(theta_deg: f64) -> State7 {
    State7::from_column_slice(&[0.0, 0.0, 0.0, theta_deg.to_radians(), 0.0, 0.0, 0.0])
}

/// braking from 35 to 25 m/s, linearly over `duration_s` from `start_s` (both s)
pub fn braking_35_to_25(start_s: f64, duration_s: f64) -> SpeedProfile {
    SpeedProfile::Ramp {
        initial_mps: 35.0,
        change_mps: -10.0,
        start_s,
        duration_s,
        shape: Default::default(),
    }
}
