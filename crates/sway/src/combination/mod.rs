//! Combinations of any number of units seen unit by unit: the sway modes of straight
//! running ([`modes`]: frequency, damping and the unit that leads each mode, the speeds
//! where each crosses) and the heavy-vehicle tests ([`manoeuvres`]: rearward amplification
//! and high-speed transient offtracking in a single lane change, the yaw damping of every
//! articulation after a steering pulse).
//!
//! ```
//! use sway::combination::modes::sway_modes;
//! use trailer_model::{AsChain, Model, VehicleParams};
//!
//! // Table I: one sway mode crosses at V_crit ≈ 34.75 m/s, led by the trailer
//! let chain = Model::new(VehicleParams::default()).unwrap().as_chain().unwrap();
//! let speeds: Vec<f64> = (1..=50).map(f64::from).collect();
//! let modes = sway_modes(&chain, &speeds);
//! let sway = modes.iter().find_map(|m| m.loses_stability()).unwrap();
//! assert!((sway.speed_mps - 34.748).abs() < 1e-3);
//! assert_eq!(sway.leading_unit, 1);
//! ```

pub mod manoeuvres;
pub mod modes;
