//! The Appellian equations of motion, paper eq. (2)–(7).

use nalgebra::{SVector, Vector4};
use num_dual::DualNum;
use tires::{BrushTire, TireModel};

use crate::{AxleLoads, ModelError, VehicleParams};

/// Reduced state [σ1, σ2, σ3, θ]: lateral hitch velocity σ1 \[m/s\], pseudovelocities
/// σ2, σ3 \[1/s\] of eq. (4) and hitch angle θ \[rad\]. Stability, continuation and charts
/// work on this 4-state system: its dynamics do not depend on ψ, x_H, y_H.
pub type State4<D = f64> = SVector<D, 4>;

/// Full state [σ1, σ2, σ3, θ, ψ, x_H, y_H] in the order of eq. (10): the reduced state,
/// the tractor's yaw angle ψ \[rad\] and the hitch position x_H, y_H \[m\].
pub type State7<D = f64> = SVector<D, 7>;

/// Index of the hitch angle θ in [`State4`] and [`State7`].
pub const HITCH_ANGLE: usize = 3;
/// Index of the yaw angle ψ in [`State7`].
pub const YAW_ANGLE: usize = 4;

/// The model's inputs at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs<D = f64> {
    /// steering angle δ \[rad\]
    pub steering_angle: D,
    /// prescribed longitudinal speed V \[m/s\] of the tractor (constraint eq. 3)
    pub speed: D,
    /// its time derivative V̇ \[m/s²\] (enters eq. 6)
    pub acceleration: D,
}

impl Inputs<f64> {
    /// Straight running at constant speed V \[m/s\] without steering.
    pub fn constant_speed(speed: f64) -> Self {
        Self {
            steering_angle: 0.0,
            speed,
            acceleration: 0.0,
        }
    }

    /// The same inputs as (constant) dual numbers.
    pub fn lift<D: DualNum<Primitive = f64> + Copy>(&self) -> Inputs<D> {
        Inputs {
            steering_angle: D::from(self.steering_angle),
            speed: D::from(self.speed),
            acceleration: D::from(self.acceleration),
        }
    }
}

/// Slip angles (α_F, α_R, α_T) \[rad\] of the front, rear and trailer axles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipAngles<D = f64> {
    /// front axle α_F \[rad\]
    pub front: D,
    /// rear axle α_R \[rad\]
    pub rear: D,
    /// trailer axle α_T \[rad\]
    pub trailer: D,
}

/// The car–trailer single-track model with brush tires.
///
/// Built once from validated [`VehicleParams`]; holds the constants I1, I2, p1…p15 of
/// eq. (7) and the three tires, so evaluating the right-hand side allocates nothing.
#[derive(Debug, Clone)]
pub struct Model {
    pub(crate) params: VehicleParams,
    loads: AxleLoads,
    front_tire: BrushTire,
    rear_tire: BrushTire,
    trailer_tire: BrushTire,
    // geometry used by the slip angles
    pub(crate) f: f64,
    pub(crate) c: f64,
    pub(crate) l: f64,
    pub(crate) i1: f64,
    pub(crate) i2: f64,
    pub(crate) p: [f64; 16], // p[1..=15] of eq. (7); p[0] unused
    pub(crate) k: Derived,
    /// [`Model::critical_slip_tangents`], cached for the validity guard
    pub(crate) critical_tangents: (f64, f64),
    /// tan α_cr of the trailer axle (∞ without a sliding limit), cached for the switching
    /// functions of the simulation ([`Model::critical_slip_angle_tangents`])
    critical_tangent_trailer: f64,
}

/// Products of the constants of eq. (6)–(7) that do not depend on the state, computed
/// once so that the right-hand side does no redundant arithmetic.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Derived {
    /// D(θ) = d0 + d_cos2·cos²θ + d_sin2·sin²θ (eq. 7)
    pub(crate) d0: f64,
    pub(crate) d_cos2: f64,
    pub(crate) d_sin2: f64,
    /// σ̇2 = s2_v1·V σ1 − s2_v2·V σ2 + s2_r·F_R + s2_f·F_F cos δ
    pub(crate) s2_v1: f64,
    pub(crate) s2_v2: f64,
    pub(crate) s2_r: f64,
    pub(crate) s2_f: f64,
    /// p12, p13, p14, p15 divided by I1·I2³ (σ̇3 of eq. 6 with the corrected prefactor)
    pub(crate) q12: f64,
    pub(crate) q13: f64,
    pub(crate) q14: f64,
    pub(crate) q15: f64,
    /// m1 d / I1 and m2 h / I2 (eq. 4–5)
    pub(crate) m1d_i1: f64,
    pub(crate) m2h_i2: f64,
}

/// State-dependent quantities shared by the slip angles and the right-hand side.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Kinematics<D> {
    pub(crate) sin_theta: D,
    pub(crate) cos_theta: D,
    pub(crate) yaw_rate: D,
    pub(crate) hitch_angle_rate: D,
}

/// Whether `x` is a plain number (no derivative parts) equal to ±0: then tan x = ±0 and
/// cos x = 1 exactly, and the hot loop skips the calls. (A dual number's `is_zero` looks at
/// its real part only, so duals always take the calls.)
#[inline]
pub(crate) fn is_plain_zero<D: DualNum<Primitive = f64> + Copy>(x: D) -> bool {
    D::NDERIV == 0 && x.re() == 0.0
}

impl Model {
    /// Builds the model: validates the parameters, computes the static axle loads and
    /// the brush tires (eq. 15) and the constants of eq. (7).
    ///
    /// # Errors
    /// [`ModelError::InvalidParameter`] for unphysical parameters, or a tire error if a
    /// static axle load is not positive (trailer centre of gravity far behind its axle).
    pub fn new(params: VehicleParams) -> Result<Self, ModelError> {
        params.validate()?;
        Self::build(params)
    }

    /// [`Model::new`] without [`VehicleParams::validate`]: the paper form of a chain's
    /// towing unit with its first towed unit ([`crate::ChainSpec::first_pair_params`]), whose
    /// fifth wheel may sit ahead of the rear axle (c < 0), checked by the chain instead.
    ///
    /// # Errors
    /// A tire error if a static axle load of the pair is not positive.
    pub(crate) fn build(params: VehicleParams) -> Result<Self, ModelError> {
        let loads = AxleLoads::from_params(&params);
        let fr = &params.friction;
        let tire = |axle: &'static str, c: f64, fz: f64| {
            BrushTire::new(c, fz, fr.mu_static, fr.mu_dynamic)
                .map_err(|source| ModelError::Tire { axle, source })
        };
        let t = &params.tractor;
        let r = &params.trailer;
        let front_tire = tire("front", t.front_cornering_stiffness, loads.front)?;
        let rear_tire = tire("rear", t.rear_cornering_stiffness, loads.rear)?;
        let trailer_tire = tire("trailer", r.cornering_stiffness, loads.trailer)?;
        let (m1, m2, j1, j2) = (t.mass, r.mass, t.yaw_inertia, r.yaw_inertia);
        let (f, c, d, h, l) = (t.front_axle, t.rear_axle, t.cog, r.cog, r.axle);
        let i1 = j1 + m1 * d * d;
        let i2 = j2 + m2 * h * h;
        let mut p = [0.0; 16];
        p[1] = m2 * m2 * i1 * i1 * i2 * i2 * h * h;
        p[2] = m1 * m2 * m2 * i1 * i2 * i2 * d * h * h;
        p[3] = m2.powi(3) * i1 * i1 * i2 * h.powi(3);
        p[4] = m2 * i1 * i1 * i2.powi(3) * h;
        p[5] = m1 * d;
        p[6] = (m1 * j1 * i2 + m2 * i1 * j2) * i2 * i2;
        p[7] = m2 * m2 * i1 * i2 * i2 * h * h;
        p[8] = (j1 + m1 * d * (d - c)) * i1 * i2.powi(3);
        p[9] = (j2 + m2 * h * (h - l)) * i1 * i1 * i2 * i2;
        p[10] = (j1 + m1 * d * (d - f)) * i1 * i2.powi(3);
        p[11] = m1 * i1 * d;
        p[12] = m2 * m2 * i1 * i2 * h * h;
        p[13] = m2 * i1 * i2 * i2 * h;
        p[14] = m1 * m2 * i2 * i2 * h * d;
        p[15] = i1 * i2 * i2 * l;
        let r3 = 1.0 / (i1 * i2.powi(3));
        let k = Derived {
            d0: i2
                * (m2 * i1 * i1 * j2 * j2
                    + m1 * j1 * j1 * i2 * i2
                    + m1 * m1 * j1 * i2 * i2 * d * d),
            d_cos2: i2 * m2 * m2 * j2 * i1 * i1 * h * h,
            d_sin2: i2 * m2 * i1 * i1 * (2.0 * m2 * j2 * h * h + m2 * m2 * h.powi(4)),
            s2_v1: p[5] * p[5] / (i1 * i1),
            s2_v2: p[11] / (i1 * i1),
            s2_r: c / i1,
            s2_f: f / i1,
            q12: p[12] * r3,
            q13: p[13] * r3,
            q14: p[14] * r3,
            q15: p[15] * r3,
            m1d_i1: m1 * d / i1,
            m2h_i2: m2 * h / i2,
        };
        let mut model = Self {
            params,
            loads,
            front_tire,
            rear_tire,
            trailer_tire,
            f,
            c,
            l,
            i1,
            i2,
            p,
            k,
            critical_tangents: (f64::INFINITY, f64::INFINITY),
            critical_tangent_trailer: f64::INFINITY,
        };
        model.critical_tangents = model.critical_slip_tangents();
        let trailer = model.critical_slip_angles().trailer;
        if trailer < std::f64::consts::FRAC_PI_2 {
            model.critical_tangent_trailer = trailer.tan();
        }
        Ok(model)
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &VehicleParams {
        &self.params
    }

    /// Static vertical axle loads.
    pub fn axle_loads(&self) -> &AxleLoads {
        &self.loads
    }

    /// The brush tires of the front, rear and trailer axles.
    pub fn tires(&self) -> [&BrushTire; 3] {
        [&self.front_tire, &self.rear_tire, &self.trailer_tire]
    }

    /// Critical slip angles α_cr (eq. 15) of the front, rear and trailer tires \[rad\].
    pub fn critical_slip_angles(&self) -> SlipAngles<f64> {
        let a = |t: &BrushTire| t.critical_slip_angle().unwrap_or(f64::INFINITY);
        SlipAngles {
            front: a(&self.front_tire),
            rear: a(&self.rear_tire),
            trailer: a(&self.trailer_tire),
        }
    }

    /// I1 = J1 + m1 d² \[kg m²\] (tractor inertia about the hitch).
    pub fn i1(&self) -> f64 {
        self.i1
    }

    /// I2 = J2 + m2 h² \[kg m²\] (trailer inertia about the hitch).
    pub fn i2(&self) -> f64 {
        self.i2
    }

    /// Yaw rate of the tractor ψ̇ = σ2 − (m1 d / I1) σ1 \[rad/s\] (eq. 5); the measured
    /// output y of eq. (10).
    pub fn yaw_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &State4<D>) -> D {
        x[1] - x[0] * self.k.m1d_i1
    }

    /// Hitch-angle rate θ̇ \[rad/s\] (eq. 5).
    pub fn hitch_angle_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &State4<D>) -> D {
        self.kinematics(x).hitch_angle_rate
    }

    pub(crate) fn kinematics<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
    ) -> Kinematics<D> {
        let (s1, s2, s3) = (x[0], x[1], x[2]);
        let (sin_theta, cos_theta) = x[3].sin_cos();
        Kinematics {
            sin_theta,
            cos_theta,
            yaw_rate: s2 - s1 * self.k.m1d_i1,
            hitch_angle_rate: s1 * (cos_theta * self.k.m2h_i2 + self.k.m1d_i1) - s2 + s3,
        }
    }

    /// Longitudinal velocity \[m/s\] of the trailer wheel, V cos θ + σ1 sin θ: the
    /// denominator of α_T. The model is meaningful only while it is positive.
    pub fn trailer_wheel_speed<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        speed: D,
    ) -> D {
        let (s, c) = x[3].sin_cos();
        speed * c + x[0] * s
    }

    /// |tan α_F| and |tan α_R| of the tractor's axles (eq. 2), without inverse
    /// trigonometry: comparing them with tan α_cr is comparing |α| with α_cr, since tan is
    /// increasing on [0, π/2). Where |α_F| ≥ π/2 (1 + r_F tan δ ≤ 0, far beyond sliding) the
    /// front value is +∞. At δ = 0 no trigonometric function is called (the open loop's
    /// validity check, once per solver step).
    pub fn axle_slip_tangents(&self, x: &State4, u: &Inputs) -> (f64, f64) {
        let t = self.slip_tangents(x, u, &self.kinematics_without_angle(x));
        let front = match Self::front_slip_tangent(u.steering_angle, t.front) {
            Some(tan) => tan.abs(),
            None => f64::INFINITY,
        };
        (front, t.rear.abs())
    }

    /// tan α of the three axles with their signs (eq. 2; α_F from the tangent of a
    /// difference, α_R and α_T as in [`Self::slip_angles`]). The brush law (eq. 14) is
    /// smooth in tan α except at 0 (through tan α·|tan α|) and at the sliding limit
    /// |tan α| = tan α_cr: these are the kinks of the model's right-hand side. Where
    /// |α_F| ≥ π/2 (far beyond sliding) the front value is α_F itself, which has the sign
    /// of α_F and exceeds any tan α_cr < π/2.
    pub fn slip_angle_tangents(&self, x: &State4, u: &Inputs) -> SlipAngles<f64> {
        let t = self.slip_tangents(x, u, &self.kinematics(x));
        SlipAngles {
            front: Self::front_slip_tangent(u.steering_angle, t.front)
                .unwrap_or_else(|| u.steering_angle - t.front.atan()),
            rear: t.rear,
            trailer: t.trailer,
        }
    }

    /// tan α_F = (tan δ − r_F)/(1 + r_F tan δ) for α_F = δ − atan r_F; `None` where
    /// 1 + r_F tan δ ≤ 0 (|α_F| ≥ π/2). At δ = 0 no trigonometric function is called.
    #[inline]
    pub(crate) fn front_slip_tangent(steering_angle: f64, r: f64) -> Option<f64> {
        if steering_angle == 0.0 {
            return Some(-r);
        }
        let tan_delta = steering_angle.tan();
        let den = 1.0 + r * tan_delta;
        (den > 0.0).then(|| (tan_delta - r) / den)
    }

    /// tan α_cr of the front and rear tires (+∞ for a tire without a sliding limit or with
    /// α_cr ≥ π/2), for comparison with [`Self::axle_slip_tangents`].
    pub fn critical_slip_tangents(&self) -> (f64, f64) {
        let a = self.critical_slip_angles();
        let tan = |a: f64| {
            if a < std::f64::consts::FRAC_PI_2 {
                a.tan()
            } else {
                f64::INFINITY
            }
        };
        (tan(a.front), tan(a.rear))
    }

    /// tan α_cr of the front, rear and trailer axles (∞ for a tyre that never fully slides),
    /// computed once at construction: [`Model::critical_slip_tangents`] with the trailer's.
    /// The simulation's switching functions read them at every step.
    pub fn critical_slip_angle_tangents(&self) -> SlipAngles<f64> {
        SlipAngles {
            front: self.critical_tangents.0,
            rear: self.critical_tangents.1,
            trailer: self.critical_tangent_trailer,
        }
    }

    /// The yaw rate and the slip ratios of the tractor's axles do not depend on θ: the
    /// kinematics with the θ-dependent parts left NaN (they are not read).
    fn kinematics_without_angle(&self, x: &State4) -> Kinematics<f64> {
        Kinematics {
            sin_theta: f64::NAN,
            cos_theta: f64::NAN,
            yaw_rate: self.yaw_rate(x),
            hitch_angle_rate: f64::NAN,
        }
    }

    /// Slip angles in the body-frame form (equivalent to eq. 2, valid for any heading ψ):
    /// α_F = δ − atan((σ1 + f ψ̇)/V), α_R = −atan((σ1 + c ψ̇)/V),
    /// α_T = −atan((−V sin θ + σ1 cos θ − l (ψ̇ + θ̇)) / (V cos θ + σ1 sin θ)).
    pub fn slip_angles<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        u: &Inputs<D>,
    ) -> SlipAngles<D> {
        let t = self.slip_tangents(x, u, &self.kinematics(x));
        SlipAngles {
            front: u.steering_angle - t.front.atan(),
            rear: t.rear.atan(),
            trailer: t.trailer.atan(),
        }
    }

    /// The ratios of eq. (2) in body-frame form: r_F = (σ1 + f ψ̇)/V with α_F = δ − atan r_F,
    /// and tan α_R, tan α_T. The brush model is a polynomial in tan α, so the forces need
    /// no atan/tan pair ([`Self::front_force`] for the front axle).
    fn slip_tangents<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        u: &Inputs<D>,
        k: &Kinematics<D>,
    ) -> SlipAngles<D> {
        let v = u.speed;
        let s1 = x[0];
        let (sn, cs) = (k.sin_theta, k.cos_theta);
        SlipAngles {
            front: (s1 + k.yaw_rate * self.f) / v,
            rear: -(s1 + k.yaw_rate * self.c) / v,
            trailer: -(-v * sn + s1 * cs - (k.yaw_rate + k.hitch_angle_rate) * self.l)
                / (v * cs + s1 * sn),
        }
    }

    /// Lateral tire forces (F_F, F_R, F_T) \[N\] of eq. (14) at the current slip angles.
    pub fn tire_forces<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        u: &Inputs<D>,
    ) -> SlipAngles<D> {
        self.tire_forces_at(
            self.slip_tangents(x, u, &self.kinematics(x)),
            u.steering_angle,
        )
    }

    /// the forces at the slip ratios `t` of [`Self::slip_tangents`] and the steering angle δ
    fn tire_forces_at<D: DualNum<Primitive = f64> + Copy>(
        &self,
        t: SlipAngles<D>,
        steering_angle: D,
    ) -> SlipAngles<D> {
        SlipAngles {
            front: self.front_force(steering_angle, t.front),
            rear: self.rear_tire.lateral_force_from_tan(t.rear),
            trailer: self.trailer_tire.lateral_force_from_tan(t.trailer),
        }
    }

    /// F_F at α_F = δ − atan r_F, from tan α_F = (tan δ − r_F)/(1 + r_F tan δ) (the tangent
    /// of a difference): one tan instead of an atan/tan pair. Where 1 + r_F tan δ ≤ 0
    /// (|α_F| ≥ π/2, far beyond sliding) the angle form is used.
    #[inline]
    fn front_force<D: DualNum<Primitive = f64> + Copy>(&self, steering_angle: D, r: D) -> D {
        if is_plain_zero(steering_angle) {
            // δ = 0 (open loop): tan α_F = −r_F, exactly what the formula gives
            return self.front_tire.lateral_force_from_tan(-r);
        }
        let tan_delta = steering_angle.tan();
        let den = D::from(1.0) + r * tan_delta;
        if den.re() > 0.0 {
            self.front_tire
                .lateral_force_from_tan((tan_delta - r) / den)
        } else {
            self.front_tire.lateral_force(steering_angle - r.atan())
        }
    }

    /// Right-hand side of the reduced system: (σ̇1, σ̇2, σ̇3) of eq. (6) with the constants
    /// of eq. (7) and θ̇ of eq. (5).
    ///
    /// The σ̇3 prefactor is 1/(I1·I2³): the printed 1/(I1·I2²) is dimensionally
    /// inconsistent (the Newton–Euler oracle of the tests, `independent_formulation` and
    /// `dimensional_consistency`).
    pub fn rhs4<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        u: &Inputs<D>,
    ) -> State4<D> {
        self.rhs4_actuated(x, u, None)
    }

    /// [`rhs4`](Self::rhs4) with an external yaw moment M_z \[N m\] on the tractor
    /// (positive in the sense of ψ), as differential braking of the tow vehicle applies it
    /// (ESC-based trailer-sway mitigation). A pure moment is a couple of lateral forces
    /// ±M_z/(f − c) at the front and rear axles: it enters eq. (6) exactly where the axle
    /// forces do, so σ̇2 gains M_z/I1 and σ̇1 gains (p10 − p8)·M_z/((f − c)·D(θ)).
    /// The longitudinal braking force it costs is taken up by the prescribed speed V(t)
    /// (constraint eq. 3).
    pub fn rhs4_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> State4<D> {
        self.rhs4_actuated(x, u, Some(yaw_moment))
    }

    /// What a lateral force F \[N\] on the trailer at its centre of gravity C2 adds to the
    /// reduced right-hand side \[σ̇1, σ̇2, σ̇3, θ̇\] at hitch angle θ: a crosswind or any
    /// other external side load, perpendicular to the trailer's axis and positive to its
    /// left (as the tyre forces, F_T of eq. 6). It enters eq. (6) as a trailer axle force at
    /// h instead of l: σ̇1 gains F cos θ·J2·I1²·I2²/D(θ) (p9 with l = h) and σ̇3 loses F·h/I2
    /// (p15/(I1·I2³) with l = h); σ̇2 and θ̇ are unaffected. The right-hand side is affine in
    /// F, so this is exact for any state (checked against the Newton–Euler oracle).
    pub fn trailer_force_response(&self, hitch_angle_rad: f64, force_n: f64) -> State4 {
        let (sn, cs) = hitch_angle_rad.sin_cos();
        let k = &self.k;
        let denom = cs * cs * k.d_cos2 + sn * sn * k.d_sin2 + k.d0;
        let j2 = self.params.trailer.yaw_inertia;
        let h = self.params.trailer.cog;
        Vector4::new(
            force_n * cs * j2 * self.i1 * self.i1 * self.i2 * self.i2 / denom,
            0.0,
            -force_n * h / self.i2,
            0.0,
        )
    }

    fn rhs4_actuated<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        u: &Inputs<D>,
        yaw_moment: Option<D>,
    ) -> State4<D> {
        let p = &self.p;
        let k = &self.k;
        let (s1, s2, s3) = (x[0], x[1], x[2]);
        let (v, v_dot) = (u.speed, u.acceleration);
        let kin = self.kinematics(x);
        let (sn, cs) = (kin.sin_theta, kin.cos_theta);
        let forces = self.tire_forces_at(self.slip_tangents(x, u, &kin), u.steering_angle);
        let (f_f, f_r, f_t) = (forces.front, forces.rear, forces.trailer);
        // δ = 0 (open loop): cos δ = 1 exactly, without the call
        let f_f_cos_delta = if is_plain_zero(u.steering_angle) {
            f_f
        } else {
            f_f * u.steering_angle.cos()
        };
        // the yaw moment as the couple ±M_z/(f − c) at the front and rear axles
        let (f_f_cos_delta, f_r) = match yaw_moment {
            Some(m) => {
                let couple = m / (self.f - self.c);
                (f_f_cos_delta + couple, f_r - couple)
            }
            None => (f_f_cos_delta, f_r),
        };

        let sn2 = sn * sn;
        let sc = sn * cs;
        // D(θ) of eq. (7)
        let denom = cs * cs * k.d_cos2 + sn2 * k.d_sin2 + k.d0;
        let sigma1_dot = ((s1 * s2 - s1 * s3 * 2.0 - v_dot) * sc * p[1]
            - s1 * s1 * (cs * p[3] + p[2]) * sc
            - s3 * s3 * sn * p[4]
            + v * (s1 * p[5] - s2 * self.i1) * (sn2 * p[7] + p[6])
            + f_r * p[8]
            + f_t * cs * p[9]
            + f_f_cos_delta * p[10])
            / denom;
        let sigma2_dot = v * (s1 * k.s2_v1 - s2 * k.s2_v2) + f_r * k.s2_r + f_f_cos_delta * k.s2_f;
        let sigma3_dot = s1 * s1 * sc * k.q12
            + v * (s2 * k.q13 - s1 * k.q14) * cs
            + (s1 * s3 - v_dot) * sn * k.q13
            - f_t * k.q15;
        let theta_dot = kin.hitch_angle_rate;
        Vector4::new(sigma1_dot, sigma2_dot, sigma3_dot, theta_dot)
    }

    /// Right-hand side of the full 7-state system (eq. 5–6): the reduced dynamics plus
    /// ψ̇, ẋ_H = V cos ψ − σ1 sin ψ and ẏ_H = V sin ψ + σ1 cos ψ.
    pub fn rhs7<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State7<D>,
        u: &Inputs<D>,
    ) -> State7<D> {
        self.rhs7_actuated(x, u, None)
    }

    /// [`rhs7`](Self::rhs7) with a yaw moment M_z \[N m\] on the tractor
    /// ([`rhs4_with_yaw_moment`](Self::rhs4_with_yaw_moment)).
    pub fn rhs7_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State7<D>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> State7<D> {
        self.rhs7_actuated(x, u, Some(yaw_moment))
    }

    fn rhs7_actuated<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State7<D>,
        u: &Inputs<D>,
        yaw_moment: Option<D>,
    ) -> State7<D> {
        let x4: State4<D> = x.fixed_rows::<4>(0).into_owned();
        let r = self.rhs4_actuated(&x4, u, yaw_moment);
        let (sp, cp) = x[YAW_ANGLE].sin_cos();
        let s1 = x[0];
        State7::from_column_slice(&[
            r[0],
            r[1],
            r[2],
            r[3],
            self.yaw_rate(&x4),
            u.speed * cp - s1 * sp,
            u.speed * sp + s1 * cp,
        ])
    }
}
