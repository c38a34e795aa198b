//! The one vehicle abstraction of the engines: [`Vehicle`], what simulation, continuation
//! and the linear loops need of a model of the car–trailer combination beyond its equations
//! of motion ([`trailer_model::Plant`]), with defaults for everything but the paper form of
//! the vehicle; and [`LoopModel`], its object-safe view for the linear loops (no const N),
//! which [`linear_view!`](crate::linear_view) implements for a vehicle type in one line.
//!
//! A new model of the combination is a type implementing [`Plant<N>`] (its right-hand side,
//! switching functions and guard) and `Vehicle<N>` (its paper form, and any override), and
//! one `linear_view!(Type, N)`. The paper's [`Model`] overrides the methods whose numbers
//! its pipelines have always produced in their own form (slip-angle tangents for the
//! integrator, slip angles for the closed loop, its guard, one dual pass for the steering
//! Jacobian); every [`VehicleModel`] takes the defaults.

use nalgebra::{SMatrix, SVector};
use num_dual::{Dual64, DualNum, DualSVec64, jacobian};
use serde::{Deserialize, Serialize};
pub use stability::Complex64;
use trailer_model::{
    AnyVehicleModel, CriticalSpeed, CriticalSpeedOptions, Inputs, Model, ModelError, Plant, State4,
    SwitchingKind, VehicleModel, VehicleParams, VehicleSpec, with_plant,
};

use crate::law::{Actuator, LoopLinearization};

/// |tan α| below which a slip counts as zero for the switching functions (a kink of that size
/// changes the brush force by φ₂·tan²α ≈ 1e-18 of its scale).
pub const SLIP_TANGENT_FLOOR: f64 = 1e-9;

/// Which validity condition tripped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LossOfControl {
    /// |α_F| > α_cr,F: the front axle slides fully
    FrontAxleSliding,
    /// |α_R| > α_cr,R: the rear axle slides fully
    RearAxleSliding,
    /// the front wheel's longitudinal velocity reached 0
    FrontWheelStopped,
    /// the rear wheel's longitudinal velocity (= V) reached 0
    RearWheelStopped,
    /// the trailer wheel's longitudinal velocity V cos θ + σ1 sin θ reached 0 (jackknife)
    TrailerWheelStopped,
}

impl LossOfControl {
    /// The snake_case name used in CSV and JSON.
    pub fn as_str(&self) -> &'static str {
        match self {
            LossOfControl::FrontAxleSliding => "front_axle_sliding",
            LossOfControl::RearAxleSliding => "rear_axle_sliding",
            LossOfControl::FrontWheelStopped => "front_wheel_stopped",
            LossOfControl::RearWheelStopped => "rear_wheel_stopped",
            LossOfControl::TrailerWheelStopped => "trailer_wheel_stopped",
        }
    }

    /// The conditions in the order of [`Plant::guard_values`].
    pub const ALL: [LossOfControl; 5] = [
        LossOfControl::FrontAxleSliding,
        LossOfControl::RearAxleSliding,
        LossOfControl::FrontWheelStopped,
        LossOfControl::RearWheelStopped,
        LossOfControl::TrailerWheelStopped,
    ];
}

/// What the engines need of a model of the combination beyond [`Plant`]: its paper form,
/// its initial state from the paper's four states, its switching functions as the
/// integrator and the closed loop want them, the first tripped condition of the validity
/// guard and the exact Jacobian of the steered right-hand side. Everything but
/// [`Vehicle::paper_model`] has a default from [`Plant`].
pub trait Vehicle<const N: usize>: Plant<N> + Sync {
    /// The paper's model of the vehicle (for axle lists: of the equivalent single-axle
    /// vehicle, [`trailer_model::VehicleSpec::equivalent_params`]): the predictor's model
    /// and the actuators' scale and limits.
    fn paper_model(&self) -> &Model;

    /// The reduced state with \[σ1, σ2, σ3, θ\] = `x4` and the model's own states at their
    /// steady-state values at speed `speed_mps` and δ = 0 (default: 0).
    fn initial_state(&self, x4: &State4, speed_mps: f64) -> SVector<f64, N> {
        let _ = speed_mps;
        SVector::<f64, N>::from_fn(|i, _| if i < 4 { x4[i] } else { 0.0 })
    }

    /// Number of the switching functions of the simulation ([`Vehicle::sim_switching`]).
    fn switching_count(&self) -> usize {
        self.switching_kinds().len()
    }

    /// The switching functions at (x, u) into `g` (length [`Vehicle::switching_count`]) as
    /// the integrator wants them: [`Plant::switching_functions`] with a slip below
    /// [`SLIP_TANGENT_FLOOR`] counted as zero (near straight running the slips hover at
    /// round-off level, where sign flips are noise and landing on them would never end) and
    /// a function that cannot change sign (no sliding limit) as −1.
    fn sim_switching(&self, x: &SVector<f64, N>, u: &Inputs, g: &mut [f64]) {
        self.switching_functions(x, u, g);
        for (g, kind) in g.iter_mut().zip(self.switching_kinds()) {
            if !g.is_finite() {
                *g = -1.0;
            } else if matches!(kind, SwitchingKind::SlipSign { .. })
                && g.abs() <= SLIP_TANGENT_FLOOR
            {
                *g = 0.0;
            }
        }
    }

    /// Number of the closed loop's switching functions ([`Vehicle::loop_switching`]).
    fn loop_switching_count(&self) -> usize {
        self.switching_kinds().len()
    }

    /// The switching functions at (x, u) as the continuation's Floquet computation resolves
    /// them (kinks of the right-hand side).
    fn loop_switching(&self, x: &SVector<f64, N>, u: &Inputs, g: &mut [f64]) {
        self.switching_functions(x, u, g);
    }

    /// The first tripped condition of the validity guard (in [`LossOfControl::ALL`]'s order:
    /// a saturating axle when its value is > 0, a stopped wheel when ≥ 0), None while the
    /// model is valid.
    fn loop_loss_of_control(&self, x: &SVector<f64, N>, u: &Inputs) -> Option<LossOfControl> {
        let v = self.guard_values(x, u);
        (0..5)
            .find(|&k| if k < 2 { v[k] > 0.0 } else { v[k] >= 0.0 })
            .map(|k| LossOfControl::ALL[k])
    }

    /// ∂F/∂x and ∂F/∂δ at (x, δ, V), exact (an N-component and a one-component dual pass).
    fn steering_jacobian(
        &self,
        x: &SVector<f64, N>,
        steering: f64,
        speed: f64,
    ) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
        input_jacobian(self, x, steering, speed, Actuator::Steering)
    }
}

/// ∂F/∂x and ∂F/∂u at (x, u, V) for the command u of `actuator`, exact.
pub fn input_jacobian<P: Plant<N> + ?Sized, const N: usize>(
    plant: &P,
    x: &SVector<f64, N>,
    command: f64,
    speed: f64,
    actuator: Actuator,
) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
    let (_, jx) = jacobian(
        |z: SVector<DualSVec64<N>, N>| {
            actuated_rhs(
                plant,
                &z,
                DualSVec64::<N>::from(command),
                DualSVec64::<N>::from(speed),
                actuator,
            )
        },
        x,
    );
    let r = actuated_rhs(
        plant,
        &x.map(Dual64::from),
        Dual64::new(command, 1.0),
        Dual64::from(speed),
        actuator,
    );
    (jx, r.map(|v| v.eps))
}

/// F(x, u; V) at constant speed with the command u on `actuator`, for any number type.
#[inline]
pub fn actuated_rhs<P: Plant<N> + ?Sized, T: DualNum<Primitive = f64> + Copy, const N: usize>(
    plant: &P,
    x: &SVector<T, N>,
    command: T,
    speed: T,
    actuator: Actuator,
) -> SVector<T, N> {
    match actuator {
        Actuator::Steering => plant.rhs(
            x,
            &Inputs {
                steering_angle: command,
                speed,
                acceleration: T::from(0.0),
            },
        ),
        Actuator::DifferentialBraking => plant.rhs_with_yaw_moment(
            x,
            &Inputs {
                steering_angle: T::from(0.0),
                speed,
                acceleration: T::from(0.0),
            },
            command,
        ),
    }
}

/// The paper's model: the integrator's switching functions on the slip-angle tangents, the
/// closed loop's on the slip angles, its own guard and one 5-component dual Jacobian — the
/// forms its pipelines have always computed, so that their numbers do not move.
impl Vehicle<4> for Model {
    fn paper_model(&self) -> &Model {
        self
    }

    fn initial_state(&self, x4: &State4, _speed_mps: f64) -> State4 {
        *x4
    }

    fn switching_count(&self) -> usize {
        6
    }

    /// tan α of the front, rear and trailer axles (0 below the floor), then
    /// tan²α − tan²α_cr of each (−1 without a sliding limit).
    #[inline]
    fn sim_switching(&self, x: &State4, u: &Inputs, g: &mut [f64]) {
        let tan = self.slip_angle_tangents(x, u);
        let signed = |t: f64| {
            if t.abs() <= SLIP_TANGENT_FLOOR {
                0.0
            } else {
                t
            }
        };
        let cr = self.critical_slip_angle_tangents();
        let tans = [tan.front, tan.rear, tan.trailer];
        let crs = [cr.front, cr.rear, cr.trailer];
        for k in 0..3 {
            g[k] = signed(tans[k]);
            g[3 + k] = if crs[k].is_finite() {
                tans[k] * tans[k] - crs[k] * crs[k]
            } else {
                -1.0
            };
        }
    }

    fn loop_switching_count(&self) -> usize {
        6
    }

    /// slip angles α_F, α_R, α_T (the brush tire is only C¹ at α = 0) and |α| − α_cr
    /// (sliding starts, the force curve's second derivative jumps)
    fn loop_switching(&self, x: &State4, u: &Inputs, g: &mut [f64]) {
        let a = self.slip_angles(x, u);
        let cr = self.critical_slip_angles();
        g[0] = a.front;
        g[1] = a.rear;
        g[2] = a.trailer;
        g[3] = a.front.abs() - cr.front;
        g[4] = a.rear.abs() - cr.rear;
        g[5] = a.trailer.abs() - cr.trailer;
    }

    /// A tractor axle sliding fully (|α| > α_cr, eq. 15) or a wheel's longitudinal velocity
    /// at or below 0.
    fn loop_loss_of_control(&self, x: &State4, u: &Inputs) -> Option<LossOfControl> {
        let (tan_front, tan_rear) = self.axle_slip_tangents(x, u);
        let (cr_front, cr_rear) = self.critical_slip_tangents();
        let front_wheel_speed = {
            let lateral_front = x[0] + Model::yaw_rate(self, x) * self.params().tractor.front_axle;
            let (sd, cd) = u.steering_angle.sin_cos();
            u.speed * cd + lateral_front * sd
        };
        if tan_front > cr_front {
            Some(LossOfControl::FrontAxleSliding)
        } else if tan_rear > cr_rear {
            Some(LossOfControl::RearAxleSliding)
        } else if front_wheel_speed <= 0.0 {
            Some(LossOfControl::FrontWheelStopped)
        } else if u.speed <= 0.0 {
            Some(LossOfControl::RearWheelStopped)
        } else if self.trailer_wheel_speed(x, u.speed) <= 0.0 {
            Some(LossOfControl::TrailerWheelStopped)
        } else {
            None
        }
    }

    /// ∂F/∂(x, δ) by one 5-component dual vector
    fn steering_jacobian(
        &self,
        x: &State4,
        steering: f64,
        speed: f64,
    ) -> (SMatrix<f64, 4, 4>, SVector<f64, 4>) {
        let z = SVector::<f64, 5>::new(x[0], x[1], x[2], x[3], steering);
        let (_, j) = jacobian(
            |z: SVector<DualSVec64<5>, 5>| {
                let x = State4::new(z[0], z[1], z[2], z[3]);
                let u = Inputs {
                    steering_angle: z[4],
                    speed: DualSVec64::<5>::from(speed),
                    acceleration: DualSVec64::<5>::from(0.0),
                };
                self.rhs4(&x, &u)
            },
            &z,
        );
        (
            SMatrix::<f64, 4, 4>::from_fn(|i, k| j[(i, k)]),
            SVector::<f64, 4>::from_fn(|i, _| j[(i, 4)]),
        )
    }
}

/// Every model of a vehicle file (two units or a chain): its equivalent paper model (a
/// chain's: the towing unit with the first towed unit), and a lagged slip α′ that starts at
/// the instantaneous slip α; the rest from the defaults. A chain's initial state has the
/// first articulation's \[σ1, σ2, σ3, θ\] = `x4` and the couplings behind it straight and at
/// rest (θ̇i = θi = 0, i ≥ 2).
impl<const N: usize> Vehicle<N> for VehicleModel<N> {
    fn paper_model(&self) -> &Model {
        self.equivalent_model()
    }

    fn initial_state(&self, x4: &State4, speed_mps: f64) -> SVector<f64, N> {
        let mut x = SVector::<f64, N>::from_fn(|i, _| if i < 4 { x4[i] } else { 0.0 });
        self.settle_lagged_slips(&mut x, speed_mps);
        x
    }
}

/// What the linear loops need of a vehicle, without its state count: its linearisation at a
/// speed, its open-loop spectrum and critical speed, and its paper form (which sizes the
/// actuators, [`Actuator::scale`]). The object-safe view of a [`Vehicle`] (the linear loops,
/// charts, gain and control design are compiled once, not once per N): implemented for a
/// vehicle type by [`linear_view!`](crate::linear_view), and for [`AnyVehicleModel`] by
/// dispatch.
pub trait LoopModel: Sync {
    /// The linearisation about straight running at speed V \[m/s\].
    fn loop_linearization(&self, speed: f64) -> LoopLinearization;

    /// Eigenvalues of A(V), sorted by decreasing real part (ties: decreasing imaginary part).
    fn open_loop_spectrum(&self, speed: f64) -> Vec<Complex64>;

    /// The open-loop critical speed search ([`Plant::critical_speed_search`]).
    ///
    /// # Errors
    /// As [`Plant::critical_speed_search`].
    fn critical_speed_search(
        &self,
        opts: &CriticalSpeedOptions,
    ) -> Result<Option<CriticalSpeed>, ModelError>;

    /// The paper's form of the vehicle (for axle lists the equivalent single-axle vehicle).
    fn paper_model(&self) -> &Model;

    /// Number of reduced states n.
    fn states(&self) -> usize;
}

/// [`LoopModel::loop_linearization`] of a vehicle.
pub fn loop_linearization<V: Vehicle<N> + ?Sized, const N: usize>(
    vehicle: &V,
    speed: f64,
) -> LoopLinearization {
    LoopLinearization::from_plant(&Plant::plant_linearization(vehicle, speed))
}

/// [`LoopModel::open_loop_spectrum`] of a vehicle.
pub fn open_loop_spectrum<V: Vehicle<N> + ?Sized, const N: usize>(
    vehicle: &V,
    speed: f64,
) -> Vec<Complex64> {
    Plant::open_loop_spectrum(vehicle, speed)
        .into_iter()
        .map(|z| Complex64::new(z.re, z.im))
        .collect()
}

/// Implements [`LoopModel`] for a vehicle type through its [`Vehicle`] impl: the one line
/// that registers a model of N reduced states with the linear loops,
/// `linear_view!(MyModel, 4);` (generic types: `linear_view!(VehicleModel<N>, N; const N:
/// usize)`).
#[macro_export]
macro_rules! linear_view {
    ($ty:ty, $n:expr $(; $($generics:tt)*)?) => {
        impl$(<$($generics)*>)? $crate::vehicle::LoopModel for $ty {
            fn loop_linearization(&self, speed: f64) -> $crate::law::LoopLinearization {
                $crate::vehicle::loop_linearization::<Self, { $n }>(self, speed)
            }

            fn open_loop_spectrum(&self, speed: f64) -> Vec<$crate::vehicle::Complex64> {
                $crate::vehicle::open_loop_spectrum::<Self, { $n }>(self, speed)
            }

            fn critical_speed_search(
                &self,
                opts: &$crate::__trailer_model::CriticalSpeedOptions,
            ) -> Result<Option<$crate::__trailer_model::CriticalSpeed>, $crate::__trailer_model::ModelError> {
                $crate::__trailer_model::Plant::<{ $n }>::critical_speed_search(self, opts)
            }

            fn paper_model(&self) -> &$crate::__trailer_model::Model {
                $crate::vehicle::Vehicle::<{ $n }>::paper_model(self)
            }

            fn states(&self) -> usize {
                $n
            }
        }
    };
}

linear_view!(Model, 4);
linear_view!(VehicleModel<N>, N; const N: usize);

impl LoopModel for AnyVehicleModel {
    fn loop_linearization(&self, speed: f64) -> LoopLinearization {
        with_plant!(self, m => LoopModel::loop_linearization(m, speed))
    }

    fn open_loop_spectrum(&self, speed: f64) -> Vec<Complex64> {
        with_plant!(self, m => LoopModel::open_loop_spectrum(m, speed))
    }

    fn critical_speed_search(
        &self,
        opts: &CriticalSpeedOptions,
    ) -> Result<Option<CriticalSpeed>, ModelError> {
        with_plant!(self, m => LoopModel::critical_speed_search(m, opts))
    }

    fn paper_model(&self) -> &Model {
        with_plant!(self, m => LoopModel::paper_model(m))
    }

    fn states(&self) -> usize {
        AnyVehicleModel::states(self)
    }
}

/// A description of a vehicle whose paper keys ([`trailer_model::PARAMETERS`]) can be set
/// one by one, and which builds its model: the paper's [`VehicleParams`] (a [`Model`]) and a
/// vehicle file of any form, [`VehicleSpec`] (an [`AnyVehicleModel`]).
pub trait VehicleDescription: Clone + Sync {
    /// The model the description builds.
    type Model: LoopModel;

    /// The values of the paper's keys (of a vehicle file: those of its equivalent
    /// single-axle vehicle, [`VehicleSpec::equivalent_params`]; of a chain: its towing unit
    /// with the first towed unit).
    ///
    /// # Errors
    /// An invalid vehicle file.
    fn paper_values(&self) -> Result<VehicleParams, ModelError>;

    /// The description with paper key `index` set to `value`.
    ///
    /// # Errors
    /// A key the vehicle file does not have ([`VehicleSpec::with_parameter`]).
    fn with_paper_value(&self, index: usize, value: f64) -> Result<Self, ModelError>;

    /// The model of the vehicle.
    ///
    /// # Errors
    /// An invalid vehicle.
    fn model(&self) -> Result<Self::Model, ModelError>;
}

impl VehicleDescription for VehicleParams {
    type Model = Model;

    fn paper_values(&self) -> Result<VehicleParams, ModelError> {
        Ok(*self)
    }

    fn with_paper_value(&self, index: usize, value: f64) -> Result<Self, ModelError> {
        Ok(self.with(index, value))
    }

    fn model(&self) -> Result<Model, ModelError> {
        Model::new(*self)
    }
}

impl VehicleDescription for VehicleSpec {
    type Model = AnyVehicleModel;

    /// A chain of towed units: the towing unit with the first towed unit
    /// ([`trailer_model::ChainSpec::first_pair_params`]), whose trailer keys
    /// [`VehicleDescription::with_paper_value`] refuses (the chain has no `[trailer]`).
    fn paper_values(&self) -> Result<VehicleParams, ModelError> {
        if self.is_chain() {
            return self.chain_spec().first_pair_params();
        }
        self.equivalent_params()
    }

    fn with_paper_value(&self, index: usize, value: f64) -> Result<Self, ModelError> {
        self.with_parameter(index, value)
    }

    fn model(&self) -> Result<AnyVehicleModel, ModelError> {
        AnyVehicleModel::new(self)
    }
}
