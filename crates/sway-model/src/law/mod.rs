//! Loop laws: what a controller measures, what it moves and with which gains, and the
//! linearisation of a vehicle that the linear loops are built on.
//!
//! The paper closes the loop with δ(t) = −D·ψ̇(t − τ) (eq. 8). Three **structures**
//! ([`Structure`]) drive either of two **actuators** ([`Actuator`]):
//!
//! - `yaw_rate`: u(t) = −D·ψ̇(t − τ) (the paper's);
//! - `yaw_rate_hitch`: u(t) = −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ), a hitch-angle sensor
//!   (rear camera) beside the yaw-rate sensor;
//! - `predictor`: u(t) = −D·ψ̇_p(t), the yaw rate predicted τ ahead ([`predictor`]).
//!
//! The actuator is the tractor's front-wheel steering u = δ \[rad\] (the paper's) or
//! differential braking of the tow vehicle, u = M_z \[N m\], a yaw moment on the tractor
//! ([`trailer_model::Model::rhs4_with_yaw_moment`]). The measured output row K
//! ([`output_row`], [`loop_output_row`]) is the gains times the sensed quantities, so the
//! loop of the two output-feedback structures is x' = Ã x − B̃_u K x(t − τ).
//!
//! Gains carry the actuator's units: for steering D and D_θ in s, K_θ in rad/rad; for
//! braking D and D_θ in N m s/rad, K_θ in N m/rad.
//!
//! [`simulation`] holds the controller of a simulation: a law switched on and off in time,
//! with the actuator's limits, as scenario files write it.

pub mod predictor;
pub mod simulation;

use nalgebra::{DMatrix, DVector, RowDVector, RowVector4, Vector4};
use serde::{Deserialize, Serialize};
use trailer_model::{HITCH_ANGLE, Linearization, Model, PlantLinearization};

/// The linearisation of a plant of any state count n about straight running at one speed
/// V: x' = A x + B δ + B_M M_z, ψ̇ = C x (eq. 9–11 for the paper's model, n = 4), as
/// dynamic-size matrices.
///
/// The linear loops are built on the dynamic size rather than generic over the plant's
/// const N: [`stability::RankOneFeedback`] works on dynamic matrices anyway, the
/// predictor's model may have another state count than the vehicle (a relaxed vehicle
/// predicted with the paper's model), and the design, chart and gain-design code is then
/// compiled once, not once per N of [`trailer_model::AnyVehicleModel`]. The paper's model gives the same
/// entries as [`Model::linearize`], so its numbers do not move.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopLinearization {
    /// speed V \[m/s\]
    pub speed: f64,
    /// A = ∂f/∂x (n×n) \[1/s\]
    pub a: DMatrix<f64>,
    /// B = ∂f/∂δ (steering)
    pub b: DVector<f64>,
    /// B_M = ∂f/∂M_z (yaw moment on the tractor)
    pub b_yaw_moment: DVector<f64>,
    /// C: ψ̇ = C x
    pub c: RowDVector<f64>,
}

impl LoopLinearization {
    /// The dynamic-size copy of a plant's linearisation.
    pub fn from_plant<const N: usize>(l: &PlantLinearization<N>) -> Self {
        Self {
            speed: l.speed,
            a: DMatrix::from_column_slice(N, N, l.a.as_slice()),
            b: DVector::from_column_slice(l.b.as_slice()),
            b_yaw_moment: DVector::from_column_slice(l.b_yaw_moment.as_slice()),
            c: RowDVector::from_row_slice(l.c.as_slice()),
        }
    }

    /// Number of states n.
    pub fn states(&self) -> usize {
        self.a.nrows()
    }
}

/// The controller structure: what is measured and how it is turned into the command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Structure {
    /// u(t) = −D·ψ̇(t − τ): the paper's yaw-rate feedback (eq. 8)
    YawRate,
    /// u(t) = −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ): yaw rate plus a hitch-angle sensor
    YawRateHitch,
    /// u(t) = −D·ψ̇_p(t): the yaw rate predicted τ ahead from the state measured at t − τ
    /// and the commands of \[t − τ, t\] through a linear model ([`predictor`])
    Predictor,
}

impl Structure {
    /// Every structure, in the order of the tables.
    pub const ALL: [Self; 3] = [Self::YawRate, Self::YawRateHitch, Self::Predictor];

    /// The name used in configs and summaries.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::YawRate => "yaw_rate",
            Self::YawRateHitch => "yaw_rate_hitch",
            Self::Predictor => "predictor",
        }
    }

    /// The gains this structure uses (the others stay 0).
    pub fn gain_names(&self) -> &'static [GainName] {
        match self {
            Self::YawRate | Self::Predictor => &[GainName::YawRate],
            Self::YawRateHitch => &[GainName::YawRate, GainName::HitchAngle, GainName::HitchRate],
        }
    }
}

/// What the controller moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Actuator {
    /// front-wheel steering angle δ \[rad\] (the paper's)
    Steering,
    /// differential braking of the tow vehicle: a yaw moment M_z \[N m\] on the tractor
    /// (as ESC-based trailer-sway mitigation applies it)
    DifferentialBraking,
}

impl Actuator {
    /// Both actuators, in the order of the tables.
    pub const ALL: [Self; 2] = [Self::Steering, Self::DifferentialBraking];

    /// The name used in configs and summaries.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Steering => "steering",
            Self::DifferentialBraking => "differential_braking",
        }
    }

    /// The input column B̃_u of the linearisation \[1/s per unit of the command\].
    pub fn input_column(&self, lin: &Linearization) -> Vector4<f64> {
        match self {
            Self::Steering => lin.b4,
            Self::DifferentialBraking => lin.b4_yaw_moment,
        }
    }

    /// [`Actuator::input_column`] of a plant of any state count.
    pub fn loop_input_column<'a>(&self, lin: &'a LoopLinearization) -> &'a DVector<f64> {
        match self {
            Self::Steering => &lin.b,
            Self::DifferentialBraking => &lin.b_yaw_moment,
        }
    }

    /// The command per radian of equivalent steering: 1 for steering; for braking the yaw
    /// moment C_F·(f − c) \[N m/rad\] that a steering angle of 1 rad would put on the tractor
    /// through the front axle's linear force, about the rear axle. Sizes the default gain
    /// ranges of braking from those of steering, per vehicle.
    pub fn scale(&self, model: &Model) -> f64 {
        match self {
            Self::Steering => 1.0,
            Self::DifferentialBraking => {
                let t = &model.params().tractor;
                t.front_cornering_stiffness * (t.front_axle - t.rear_axle)
            }
        }
    }

    /// The largest command the actuator can give: for steering none (`None`); for braking
    /// the yaw moment of braking the wheels of one side of the tractor to the friction
    /// limit, μ0·(F_zF + F_zR)/2 at half the track width w:
    /// M_max = μ0·(F_zF + F_zR)·w/4 \[N m\] (the lateral forces the tyres need at the same
    /// time are not subtracted: an upper bound).
    pub fn limit(&self, model: &Model, track_width_m: f64) -> Option<f64> {
        match self {
            Self::Steering => None,
            Self::DifferentialBraking => {
                let l = model.axle_loads();
                Some(model.params().friction.mu_static * (l.front + l.rear) * track_width_m / 4.0)
            }
        }
    }
}

/// One gain of a structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GainName {
    /// D: on the yaw rate ψ̇
    YawRate,
    /// K_θ: on the hitch angle θ
    HitchAngle,
    /// D_θ: on the hitch-angle rate θ̇
    HitchRate,
}

impl GainName {
    /// The name used in summaries.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::YawRate => "yaw_rate",
            Self::HitchAngle => "hitch_angle",
            Self::HitchRate => "hitch_rate",
        }
    }
}

/// The gains of a controller; units depend on the actuator (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Gains {
    /// D, on the yaw rate ψ̇ (steering: s; braking: N m s/rad)
    pub yaw_rate: f64,
    /// K_θ, on the hitch angle θ (steering: rad/rad; braking: N m/rad)
    pub hitch_angle: f64,
    /// D_θ, on the hitch-angle rate θ̇ (steering: s; braking: N m s/rad)
    pub hitch_rate: f64,
}

impl Gains {
    /// The paper's D alone.
    pub fn yaw_rate(d: f64) -> Self {
        Self {
            yaw_rate: d,
            ..Self::default()
        }
    }

    /// The value of one gain.
    pub fn get(&self, name: GainName) -> f64 {
        match name {
            GainName::YawRate => self.yaw_rate,
            GainName::HitchAngle => self.hitch_angle,
            GainName::HitchRate => self.hitch_rate,
        }
    }

    /// A copy with one gain set.
    pub fn with(mut self, name: GainName, value: f64) -> Self {
        match name {
            GainName::YawRate => self.yaw_rate = value,
            GainName::HitchAngle => self.hitch_angle = value,
            GainName::HitchRate => self.hitch_rate = value,
        }
        self
    }
}

/// A controller: structure, actuator and gains. The predictor's model of the vehicle is
/// given where its loop is built (`sway::control::LinearLoop::new`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Controller {
    /// what is measured and how
    pub structure: Structure,
    /// what is moved
    pub actuator: Actuator,
    /// the gains (only those of the structure are read)
    pub gains: Gains,
}

impl Controller {
    /// The paper's controller δ = −D·ψ̇(t − τ).
    pub fn paper(d: f64) -> Self {
        Self {
            structure: Structure::YawRate,
            actuator: Actuator::Steering,
            gains: Gains::yaw_rate(d),
        }
    }
}

/// The measured output row K of the output-feedback structures: u = −K x(t − τ) on the
/// reduced state (σ1, σ2, σ3, θ), with ψ̇ = C̃ x (eq. 10) and θ̇ = Ã_θ x (the θ row of Ã:
/// the hitch-angle rate is kinematic, eq. 5, and no input enters it).
pub fn output_row(lin: &Linearization, structure: Structure, gains: &Gains) -> RowVector4<f64> {
    let mut k = lin.c4 * gains.yaw_rate;
    if structure == Structure::YawRateHitch {
        k[HITCH_ANGLE] += gains.hitch_angle;
        k += lin.a4.row(HITCH_ANGLE) * gains.hitch_rate;
    }
    k
}

/// [`output_row`] of a plant of any state count (θ is state 3 of every plant,
/// [`HITCH_ANGLE`]).
pub fn loop_output_row(
    lin: &LoopLinearization,
    structure: Structure,
    gains: &Gains,
) -> RowDVector<f64> {
    let mut k = &lin.c * gains.yaw_rate;
    if structure == Structure::YawRateHitch {
        k[HITCH_ANGLE] += gains.hitch_angle;
        k += lin.a.row(HITCH_ANGLE) * gains.hitch_rate;
    }
    k
}
