//! Running any vehicle in the paper's layout of 4 or 7 states: [`VehicleForm`], the vehicle
//! as the scenario-level functions take it (the paper's [`Model`], or the model of a vehicle
//! file with model variants), and the simulation and the settling on the sway cycle from and
//! to the paper's states, the plant's own states lifted and dropped.

use nalgebra::SVector;
use trailer_model::{AnyVehicleModel, Model, State4};

use super::plant::reduced_state;
use super::run::{
    ControllerStates, Layout, Recording, SimResult, SimSpec, SolverSettings, settle, simulate,
};
use crate::SwayError;
use sway_model::vehicle::Vehicle;

/// A vehicle as the scenario-level functions take it: `&Model` and `&AnyVehicleModel`
/// convert into it (`impl Into<VehicleForm>`), a vehicle file of the paper's form into
/// [`VehicleForm::Paper`], so the paper's model always runs in its own form.
#[derive(Debug, Clone, Copy)]
pub enum VehicleForm<'a> {
    /// the paper's model
    Paper(&'a Model),
    /// the model of a vehicle file with model variants (tyre relaxation, axle lists, tyre
    /// laws, hitch torque)
    Variants(&'a AnyVehicleModel),
}

impl<'a> From<&'a Model> for VehicleForm<'a> {
    fn from(model: &'a Model) -> Self {
        VehicleForm::Paper(model)
    }
}

impl<'a> From<&'a AnyVehicleModel> for VehicleForm<'a> {
    fn from(vehicle: &'a AnyVehicleModel) -> Self {
        match vehicle {
            AnyVehicleModel::Paper(model) => VehicleForm::Paper(model),
            v => VehicleForm::Variants(v),
        }
    }
}

/// [`simulate`] from and to the paper's layout (`N` = 4: \[σ1, σ2, σ3, θ\]; 7: with
/// \[ψ, x_H, y_H\]): the paper's [`Model`] runs as [`simulate`]; a model with its own
/// states runs in its layout, those states starting in steady state of the tyres
/// ([`Vehicle::initial_state`] at V(0)) and dropped from the result.
///
/// # Errors
/// As [`simulate`]; [`SwayError::Numerical`] when `N` is neither 4 nor 7.
pub fn simulate_in_paper_layout<'a, const N: usize>(
    vehicle: impl Into<VehicleForm<'a>>,
    spec: &SimSpec,
    x0: SVector<f64, N>,
    recording: Recording,
) -> Result<SimResult<N>, SwayError>
where
    Layout<N>: ControllerStates<N>,
{
    macro_rules! lifted {
        ($m:expr, $states:literal) => {
            if N == 7 {
                lifted::<_, $states, N, { $states + 3 }>($m, spec, x0, recording)
            } else {
                lifted::<_, $states, N, $states>($m, spec, x0, recording)
            }
        };
    }
    match vehicle.into() {
        VehicleForm::Paper(m) | VehicleForm::Variants(AnyVehicleModel::Paper(m)) => {
            simulate(m, spec, x0, recording)
        }
        VehicleForm::Variants(AnyVehicleModel::N4(m)) => lifted!(m, 4),
        VehicleForm::Variants(AnyVehicleModel::N5(m)) => lifted!(m, 5),
        VehicleForm::Variants(AnyVehicleModel::N6(m)) => lifted!(m, 6),
        VehicleForm::Variants(AnyVehicleModel::N7(m)) => lifted!(m, 7),
        VehicleForm::Variants(AnyVehicleModel::N8(m)) => lifted!(m, 8),
        VehicleForm::Variants(AnyVehicleModel::N9(m)) => lifted!(m, 9),
        VehicleForm::Variants(AnyVehicleModel::N10(m)) => lifted!(m, 10),
    }
}

/// [`settle`] in the paper's four states: the state on the sway cycle with the plant's own
/// states (the lagged slips) dropped. A run started from it restarts them in steady state of
/// the tyres, off the cycle by the tyres' lag, which dies out within a few σ/V.
///
/// # Errors
/// [`SwayError::Numerical`] if the solver fails.
pub fn settle_in_paper_layout<'a>(
    vehicle: impl Into<VehicleForm<'a>>,
    speed_mps: f64,
    theta0_rad: f64,
    settle_s: f64,
    solver: &SolverSettings,
) -> Result<State4, SwayError> {
    match vehicle.into() {
        VehicleForm::Paper(m) => settle(m, speed_mps, theta0_rad, settle_s, solver),
        VehicleForm::Variants(v) => trailer_model::with_plant!(v, m => {
            settle(m, speed_mps, theta0_rad, settle_s, solver).map(|x| reduced_state(&x))
        }),
    }
}

/// The paper-layout state `x` (4 or 7 states) in the layout of an M-state plant (M or M + 3
/// states): the plant's own states from [`Vehicle::initial_state`] at `speed_mps`.
pub fn lift_state<P: Vehicle<M>, const M: usize, const N: usize, const S: usize>(
    plant: &P,
    x: &SVector<f64, N>,
    speed_mps: f64,
) -> SVector<f64, S> {
    let xr = plant.initial_state(&State4::new(x[0], x[1], x[2], x[3]), speed_mps);
    SVector::<f64, S>::from_fn(|i, _| match i {
        i if i < M => xr[i],
        i if N == 7 => x[4 + i - M],
        _ => 0.0,
    })
}

/// The paper-layout state (4 or 7 states) of an M- or (M + 3)-state vector.
pub fn paper_layout<const M: usize, const S: usize, const N: usize>(
    x: &SVector<f64, S>,
) -> SVector<f64, N> {
    SVector::<f64, N>::from_fn(|i, _| if i < 4 { x[i] } else { x[M + i - 4] })
}

fn lifted<P: Vehicle<M>, const M: usize, const N: usize, const S: usize>(
    plant: &P,
    spec: &SimSpec,
    x0: SVector<f64, N>,
    recording: Recording,
) -> Result<SimResult<N>, SwayError>
where
    Layout<S>: ControllerStates<S>,
{
    if !(N == 4 || N == 7) || S != if N == 7 { M + 3 } else { M } {
        return Err(SwayError::numerical(
            format!("simulation of a {M}-state plant from {N} states"),
            std::io::Error::other("expected 4 or 7 states"),
        ));
    }
    let x0s = lift_state::<P, M, N, S>(plant, &x0, spec.profile.speed(0.0));
    let r = simulate::<P, M, S>(plant, spec, x0s, recording)?;
    Ok(r.map_states(paper_layout::<M, S, N>))
}
