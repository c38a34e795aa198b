//! Helpers shared by the sweep tests.
#![allow(dead_code)]

use trailer_model::{Model, State7, VehicleParams};

/// the model with the paper's Table I parameters
pub fn model() -> Model {
    Model::new(VehicleParams::default()).unwrap()
}

/// the straight-running state with hitch angle θ(0) = `theta_deg` (deg)
pub fn x7(theta_deg: f64) -> State7 {
    State7::from_column_slice(&[0.0, 0.0, 0.0, theta_deg.to_radians(), 0.0, 0.0, 0.0])
}
