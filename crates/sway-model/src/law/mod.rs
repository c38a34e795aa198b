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
//! [`LoopLaw`] is the one feedback law every engine takes (structure, gains, delay,
//! actuator, on/off times, limits); [`table`] holds the controller tables of the config
//! files that convert into it.

mod limits;
pub mod predictor;
pub mod table;

pub use limits::{ActuatorLimits, CommandLimit, ModelError};

use nalgebra::{DMatrix, DVector, RowDVector, RowVector4, SVector, Vector4};
use num_dual::DualNum;
use serde::{Deserialize, Serialize};
use trailer_model::{HITCH_ANGLE, Linearization, Model, Plant, PlantLinearization};

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

/// A feedback law, the one type every engine takes: what it measures and moves
/// ([`Structure`], [`Actuator`]), its [`Gains`], the loop delay τ, when it acts
/// (t_on ≤ t < t_off), the actuator's limits and, for the predictor, the model it predicts
/// with.
///
/// - A simulation runs all of it (`sway::sim`).
/// - The linear engines (roots, charts, gain and control design) read structure, actuator,
///   gains and τ: a linear loop is always on and unsaturated.
/// - Continuation (`sway::bifurcation`) reads the actuator and the gains, with D and τ as
///   the parameters p = [V, D, τ] it may free; the braking limit is not modelled there and
///   the predictor is not a continuation problem.
///
/// The config files write it as a controller table ([`table::ControllerTable`]), which
/// converts into it.
///
/// ```
/// use sway_model::law::{Actuator, Gains, LoopLaw, Structure};
///
/// // the paper's δ(t) = −D·ψ̇(t − τ), D = 0.1 s, τ = 0.2 s, switched on at 5 s
/// let law = LoopLaw::paper(0.1, 0.2).switched(5.0, None);
/// assert_eq!(law.steering_angle(4.0, 1.0), 0.0);
/// assert_eq!(law.steering_angle(5.0, 1.0), -0.1);
/// // a hitch-angle sensor and differential braking
/// let braking = LoopLaw::new(
///     Structure::YawRateHitch,
///     Actuator::DifferentialBraking,
///     Gains { yaw_rate: 2000.0, hitch_angle: 5000.0, hitch_rate: 0.0 },
///     0.3,
/// );
/// assert!(braking.validate().is_ok());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopLaw {
    /// what is measured and how
    pub structure: Structure,
    /// what is moved
    pub actuator: Actuator,
    /// the gains (only those of the structure are read)
    pub gains: Gains,
    /// loop delay τ \[s\] (sensing, computation, actuation; 0.2–0.4 s in production cars);
    /// the predictor's prediction horizon
    pub delay_s: f64,
    /// t_on \[s\]: switched on (0: from the start)
    pub on_s: f64,
    /// t_off \[s\]: switched off (never when `None`)
    pub off_s: Option<f64>,
    /// saturation and rate limit of the steering (the `yaw_rate` structure on the
    /// steering; none by default)
    pub steering_limits: ActuatorLimits,
    /// the limit of the braking yaw moment (differential braking only)
    pub braking_limit: CommandLimit,
    /// how the predictor's model differs from its vehicle (perfect by default)
    pub model_error: ModelError,
    /// the predictor's vehicle when it is not the controlled one (paper-form parameters of
    /// its equivalent single-axle vehicle)
    pub prediction_vehicle: Option<trailer_model::VehicleParams>,
}

impl Default for LoopLaw {
    fn default() -> Self {
        Self::OPEN_LOOP
    }
}

impl LoopLaw {
    /// No steering control: the paper's law with D = 0 and τ = 0 (δ ≡ 0).
    pub const OPEN_LOOP: Self = Self::paper(0.0, 0.0);

    /// The paper's law δ(t) = −D·ψ̇(t − τ) (eq. 8): gain D \[s\], delay τ \[s\], always on, no
    /// limits.
    pub const fn paper(gain_s: f64, delay_s: f64) -> Self {
        Self::new(
            Structure::YawRate,
            Actuator::Steering,
            Gains {
                yaw_rate: gain_s,
                hitch_angle: 0.0,
                hitch_rate: 0.0,
            },
            delay_s,
        )
    }

    /// `structure` moving `actuator` with `gains` and delay τ \[s\], always on, no limits
    /// beyond the braking's friction limit, a perfect prediction model.
    pub const fn new(structure: Structure, actuator: Actuator, gains: Gains, delay_s: f64) -> Self {
        Self {
            structure,
            actuator,
            gains,
            delay_s,
            on_s: 0.0,
            off_s: None,
            steering_limits: ActuatorLimits::NONE,
            braking_limit: CommandLimit::FRICTION,
            model_error: ModelError::PERFECT,
            prediction_vehicle: None,
        }
    }

    /// This law with the delay τ \[s\].
    #[must_use]
    pub fn with_delay(self, delay_s: f64) -> Self {
        Self { delay_s, ..self }
    }

    /// This law with `gains`.
    #[must_use]
    pub fn with_gains(self, gains: Gains) -> Self {
        Self { gains, ..self }
    }

    /// This law switched on at t_on \[s\] and off at t_off \[s\] (never when `None`).
    #[must_use]
    pub fn switched(self, on_s: f64, off_s: Option<f64>) -> Self {
        Self {
            on_s,
            off_s,
            ..self
        }
    }

    /// The paper's loop: the yaw rate alone on the steering (the structure whose command is
    /// a function of the delayed yaw rate only, with the steering's limits).
    #[inline]
    pub fn is_paper_structure(&self) -> bool {
        self.structure == Structure::YawRate && self.actuator == Actuator::Steering
    }

    /// The closed loop is a delay equation: τ > 0 (for every gain, also 0, so that the
    /// structure does not change when D is continued through 0).
    pub fn is_delayed(&self) -> bool {
        self.delay_s > 0.0
    }

    /// The hitch gains (K_θ, D_θ) the command feeds back: those of `yaw_rate_hitch`, (0, 0)
    /// for the other structures.
    pub fn hitch_gains(&self) -> (f64, f64) {
        match self.structure {
            Structure::YawRateHitch => (self.gains.hitch_angle, self.gains.hitch_rate),
            Structure::YawRate | Structure::Predictor => (0.0, 0.0),
        }
    }

    /// Whether the law acts at time t (t_on ≤ t < t_off).
    #[inline]
    pub fn is_on(&self, t: f64) -> bool {
        t >= self.on_s && self.off_s.is_none_or(|off| t < off)
    }

    /// Number of states a simulation adds to the vehicle's: 1 for a rate-limited steering
    /// (δ), 4 for the predictor (z), else 0.
    pub fn extra_states(&self) -> usize {
        match self.structure {
            Structure::Predictor => 4,
            _ => usize::from(self.has_actuator_state()),
        }
    }

    /// Whether the steering angle is a state of a simulation (a rate limit is set).
    pub fn has_actuator_state(&self) -> bool {
        self.steering_limits.has_rate_limit()
    }

    /// The paper loop's steering command δ_c(t) \[rad\] given the delayed yaw rate
    /// ψ̇(t − τ) \[rad/s\]: −D·ψ̇(t − τ) saturated at ±δ_max while the law is on, 0 while it
    /// is off (eq. 8). It is the steering angle itself unless a rate limit is set
    /// ([`ActuatorLimits`]).
    #[inline]
    pub fn steering_angle(&self, t: f64, delayed_yaw_rate: f64) -> f64 {
        self.steering_limits
            .saturate(self.raw_steering_angle(t, delayed_yaw_rate))
    }

    /// The paper loop's command before saturation \[rad\]: −D·ψ̇(t − τ) while the law is on,
    /// 0 while it is off (0 for the other structures and for braking, whose commands a
    /// simulation computes from the whole delayed state).
    #[inline]
    pub fn raw_steering_angle(&self, t: f64, delayed_yaw_rate: f64) -> f64 {
        if self.is_paper_structure() && self.is_on(t) {
            -self.gains.yaw_rate * delayed_yaw_rate
        } else {
            0.0
        }
    }

    /// The measured output y of an output-feedback structure at the (delayed) state `x` of
    /// `plant`, in a simulation: u(t) = −y(t − τ) with y = D·ψ̇ + K_θ·θ + D_θ·θ̇ (`yaw_rate`:
    /// D·ψ̇, its hitch gains 0; θ̇ the plant's nonlinear hitch-angle rate). The predictor's
    /// command is not a function of one delayed state (its realisation is in the
    /// simulation): 0.
    #[inline]
    pub fn measured_output<P: Plant<M>, const M: usize>(
        &self,
        plant: &P,
        x: &SVector<f64, M>,
    ) -> f64 {
        let g = &self.gains;
        match self.structure {
            Structure::YawRate | Structure::YawRateHitch => {
                g.yaw_rate * plant.yaw_rate(x)
                    + g.hitch_angle * x[HITCH_ANGLE]
                    + g.hitch_rate * plant.hitch_angle_rate(x)
            }
            Structure::Predictor => 0.0,
        }
    }

    /// The part of the measured output beyond the yaw rate, K_θ·θ + D_θ·θ̇ of
    /// [`LoopLaw::hitch_gains`], for any number type (the continuation's exact derivatives);
    /// 0 where the structure feeds back the yaw rate alone.
    #[inline]
    pub fn output_beyond_yaw_rate<T, P, const M: usize>(&self, plant: &P, x: &SVector<T, M>) -> T
    where
        T: DualNum<Primitive = f64> + Copy,
        P: Plant<M>,
    {
        let (hitch_angle, hitch_rate) = self.hitch_gains();
        x[HITCH_ANGLE] * hitch_angle + plant.hitch_angle_rate(x) * hitch_rate
    }

    /// Times \[s\] where the command may jump: switching on and off, and for the predictor
    /// the same times τ later (u(t − τ) enters its ż).
    pub fn breakpoints(&self) -> Vec<f64> {
        let (on, off) = (self.on_s, self.off_s);
        match self.structure {
            Structure::Predictor => {
                let tau = self.delay_s;
                let mut v = vec![on, on + tau];
                v.extend(off.iter().flat_map(|o| [*o, o + tau]));
                v
            }
            Structure::YawRate | Structure::YawRateHitch => {
                let mut v = vec![on];
                v.extend(off.iter());
                v
            }
        }
    }

    /// The largest braking command M_max \[N m\] on `model` (`None` for steering).
    pub fn max_command(&self, model: &Model) -> Option<f64> {
        self.braking_limit.max_command(self.actuator, model)
    }

    /// The parameters of the predictor's model for a vehicle with `params`: the
    /// `prediction_vehicle` (else the vehicle) with `model_error`'s factors applied.
    pub fn prediction_params(
        &self,
        params: &trailer_model::VehicleParams,
    ) -> trailer_model::VehicleParams {
        self.model_error
            .apply(&self.prediction_vehicle.unwrap_or(*params))
    }

    /// Checks; `Err((key, problem))` names the offending key as the controller tables
    /// write it ([`table::ControllerTable`]).
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let g = self.gains;
        for (key, v) in [
            ("gains.yaw_rate", g.yaw_rate),
            ("gains.hitch_angle", g.hitch_angle),
            ("gains.hitch_rate", g.hitch_rate),
        ] {
            if !v.is_finite() {
                return Err((key, format!("expected a finite gain, got {v}")));
            }
        }
        if self.structure != Structure::YawRateHitch {
            for (key, v) in [
                ("gains.hitch_angle", g.hitch_angle),
                ("gains.hitch_rate", g.hitch_rate),
            ] {
                if v != 0.0 {
                    return Err((
                        key,
                        format!(
                            "the {} structure feeds back only gains.yaw_rate; got {v}",
                            self.structure.as_str()
                        ),
                    ));
                }
            }
        }
        let (delay_s, on_s) = (self.delay_s, self.on_s);
        if !(delay_s.is_finite() && delay_s >= 0.0) {
            return Err(("delay_s", format!("expected a delay >= 0 s, got {delay_s}")));
        }
        if !(on_s.is_finite() && on_s >= 0.0) {
            return Err(("on_s", format!("expected a time >= 0 s, got {on_s}")));
        }
        if let Some(off) = self.off_s
            && !(off.is_finite() && off > on_s)
        {
            return Err((
                "off_s",
                format!("expected off_s > on_s = {on_s}, got {off}"),
            ));
        }
        self.steering_limits.validate()?;
        if !self.steering_limits.is_default() && !self.is_paper_structure() {
            return Err((
                "actuator",
                "steering limits act on the yaw-rate loop on the steering only".into(),
            ));
        }
        self.braking_limit.validate()?;
        self.model_error.validate()
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
