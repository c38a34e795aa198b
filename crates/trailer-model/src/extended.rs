//! The general single-track car–trailer model: any axles per unit (tandems),
//! a tyre law per axle, first-order tyre relaxation per axle and yaw damping at the hitch.
//!
//! **Equations.** The Appellian equations (5)–(7) are linear in the generalised forces, and
//! the constants of eq. (7) are linear in the axle positions: a tractor axle at a (forward
//! of the hitch) with lateral force F adds F·(J1 + m1 d (d − a))·I1·I2³ to the numerator of
//! σ̇1 and F·a/I1 to σ̇2 (p8, s2 of the paper's rear axle with c → a; steered axles with
//! F·cos δ, p10); a trailer axle at l adds F·cos θ·(J2 + m2 h (h − l))·I1²·I2² to σ̇1's
//! numerator and −F·l/I2 to σ̇3 (p9, p15). A pure yaw moment M on the tractor (a couple of
//! axle forces) adds −m1 d·I1·I2³·M to σ̇1's numerator and M/I1 to σ̇2; a moment M₂ on the
//! trailer adds cos θ·m2 h·I1²·I2²·M₂ and M₂/I2. The hitch torque T_h
//! ([`crate::HitchSpec`]) acts as M = +T_h, M₂ = −T_h. The Newton–Euler oracle of the tests
//! checks all of it.
//!
//! **Relaxation.** An axle with σ > 0 has a state α′ (after the four of eq. 5–6, in axle
//! order): σ·α̇′ + V_x·α′ = V_x·α, the force is F(α′) (Pacejka 2012, §7.2, the first-order
//! slip lag; linearised it is the force lag (σ/V)·Ḟ + F = F(α)). V_x is the longitudinal
//! speed of the unit at the axle: V on the tractor, V cos θ + σ1 sin θ on the trailer (the
//! denominators of the slip angles, eq. 2). Axles with σ = 0 react instantly and have no
//! state: with σ = 0 on every axle the model is the paper's.
//!
//! **Chains.** A vehicle file with `[[trailers]]` ([`crate::ChainSpec`]) builds the same
//! [`VehicleModel`] type with the chain's equations ([`ChainModel`], by Kane's method) behind
//! it, its state in the layout every [`Plant`] has: \[σ1, σ2, σ3, θ\] of the towing unit with
//! the first towed unit (eq. 4), then θ̇2, θ2, …, θ̇n, θn and the lagged slips. One type for
//! both kinds keeps the engines compiled once per N.
//!
//! **Fixed size.** N = 4 + (number of relaxing axles) is a const generic: every state vector
//! and Jacobian is a stack-allocated nalgebra type and the hot loop allocates nothing.
//! [`VehicleModel::<N>::new`] checks N against the vehicle; [`AnyVehicleModel`] picks N
//! from the vehicle at run time (4 ≤ N ≤ [`MAX_STATES`]) and [`with_plant!`](crate::with_plant)
//! hands the concrete `VehicleModel<N>` to generic code.

use nalgebra::SVector;
use num_dual::DualNum;
use tires::{TireLaw, TireModel};

use crate::chain_spec::MAX_CHAIN_AXLES;
use crate::model::is_plain_zero;
use crate::spec::{MAX_AXLES, Unit, VehicleSpec};
use crate::{
    AsChain, ChainModel, Inputs, Model, ModelError, Plant, State4, SwitchingKind, VehicleParams,
};

/// Most states of a reduced system [`AnyVehicleModel`] supports (4 + 6 relaxing axles).
pub const MAX_STATES: usize = 10;

/// One axle of a [`VehicleModel`], resolved: position, tyre, static load, relaxation and
/// the constants with which its force enters the equations.
#[derive(Debug, Clone, PartialEq)]
pub struct AxleModel {
    /// unit
    pub unit: Unit,
    /// distance from the hitch \[m\] (forward on the tractor, backward on the trailer)
    pub position_m: f64,
    /// turns with δ
    pub steered: bool,
    /// tyre law, built with the axle's static load
    pub tire: TireLaw,
    /// static vertical load \[N\]
    pub vertical_load: f64,
    /// relaxation length σ \[m\]
    pub relaxation_length_m: f64,
    /// index of α′ in the reduced state (σ > 0)
    pub state: Option<usize>,
    /// key path of the axle in the vehicle file
    pub key: String,
    /// coefficient of F (F cos δ, F cos θ) in the numerator of σ̇1
    k_sigma1: f64,
    /// coefficient of F in σ̇2 (tractor: a/I1) or σ̇3 (trailer: l/I2, subtracted)
    k_other: f64,
    /// 1/σ \[1/m\]
    inv_sigma: f64,
    /// tan α_cr (+∞ without a sliding limit)
    tan_critical: f64,
    /// tan α_sat of the validity guard (+∞ without saturation)
    tan_saturation: f64,
}

/// Which sum of eq. (6) an axle's force enters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum EvalKind {
    Unsteered,
    Trailer,
    Steered,
}

/// What the right-hand side needs of one axle.
#[derive(Debug, Clone, Copy)]
struct EvalAxle {
    kind: EvalKind,
    position_m: f64,
    tire: TireLaw,
    k_sigma1: f64,
    k_other: f64,
    inv_sigma: f64,
    state: Option<usize>,
}

/// The equations of a two-unit vehicle file (module docs): the Appellian equations with
/// axle lists, tyre laws, relaxation and hitch torque.
#[derive(Debug, Clone)]
struct PairModel<const N: usize> {
    /// the paper's model of the equivalent single-axle vehicle: the constants of eq. (7)
    core: Model,
    axles: Vec<AxleModel>,
    /// the axles in the evaluation order of the force sums (unsteered tractor, trailer,
    /// steered tractor: the order of eq. 6, so that one axle per unit reproduces the paper's
    /// model bit for bit), compact for the hot loop
    eval: Vec<EvalAxle>,
    /// c_h \[N m s/rad\], M_c \[N m\], ω_c \[rad/s\]; `None` for a free hitch
    hitch: Option<(f64, f64, f64)>,
    /// −m1 d I1 I2³ and m2 h I1² I2²: a tractor / trailer moment in σ̇1's numerator
    k_moment_tractor: f64,
    k_moment_trailer: f64,
    switching: Vec<SwitchingKind>,
}

impl<const N: usize> PairModel<N> {
    /// The model of a two-unit vehicle file with N = 4 + (axles with σ > 0) states.
    fn new(spec: &VehicleSpec) -> Result<Self, ModelError> {
        let laws = spec.check_physics()?;
        let resolved = spec.resolved_axles()?;
        let relaxed = spec.relaxed_axles()?;
        if N != 4 + relaxed {
            return Err(ModelError::StateCount {
                relaxed,
                expected: 4 + relaxed,
                requested: N,
                hint: " (AnyVehicleModel::new picks N from the vehicle)",
            });
        }
        let params = spec.equivalent_params()?;
        let core = Model::new(params)?;
        let loads = spec.axle_loads()?;
        let (t, r) = (&params.tractor, &params.trailer);
        let (m1, m2, j1, j2, d, h) = (t.mass, r.mass, t.yaw_inertia, r.yaw_inertia, t.cog, r.cog);
        let (i1, i2) = (core.i1, core.i2);
        let r3 = 1.0 / (i1 * i2.powi(3));
        let mut next_state = 4;
        let mut axles = Vec::with_capacity(resolved.len());
        for ((a, law), fz) in resolved.iter().zip(laws).zip(loads) {
            let pos = a.spec.position_m;
            // the expressions of p8/p10, s2_r/s2_f, p9 and q15 in Model::new, with the
            // axle's position, so that one axle per unit gives the same bits
            let (k_sigma1, k_other) = match a.unit {
                Unit::Tractor => ((j1 + m1 * d * (d - pos)) * i1 * i2.powi(3), pos / i1),
                Unit::Trailer => (
                    (j2 + m2 * h * (h - pos)) * i1 * i1 * i2 * i2,
                    i1 * i2 * i2 * pos * r3,
                ),
            };
            let sigma = a.spec.relaxation_length_m;
            let state = (sigma > 0.0).then(|| {
                next_state += 1;
                next_state - 1
            });
            let tan_critical = match law.critical_slip_angle() {
                Some(acr) if acr < std::f64::consts::FRAC_PI_2 => acr.tan(),
                _ => f64::INFINITY,
            };
            let sat = law.saturation_slip_angle();
            let tan_saturation = if sat < std::f64::consts::FRAC_PI_2 {
                sat.tan()
            } else {
                f64::INFINITY
            };
            axles.push(AxleModel {
                unit: a.unit,
                position_m: pos,
                steered: a.spec.steered,
                tire: law,
                vertical_load: fz,
                relaxation_length_m: sigma,
                state,
                key: a.key.clone(),
                k_sigma1,
                k_other,
                inv_sigma: if sigma > 0.0 { 1.0 / sigma } else { 0.0 },
                tan_critical,
                tan_saturation,
            });
        }
        debug_assert!(axles.len() <= MAX_AXLES);
        let kind = |a: &AxleModel| match (a.unit, a.steered) {
            (Unit::Trailer, _) => EvalKind::Trailer,
            (Unit::Tractor, false) => EvalKind::Unsteered,
            (Unit::Tractor, true) => EvalKind::Steered,
        };
        let mut eval = Vec::with_capacity(axles.len());
        for wanted in [EvalKind::Unsteered, EvalKind::Trailer, EvalKind::Steered] {
            for a in axles.iter().filter(|a| kind(a) == wanted) {
                eval.push(EvalAxle {
                    kind: wanted,
                    position_m: a.position_m,
                    tire: a.tire,
                    k_sigma1: a.k_sigma1,
                    k_other: a.k_other,
                    inv_sigma: a.inv_sigma,
                    state: a.state,
                });
            }
        }
        let hs = spec.hitch;
        let hitch = (!hs.is_free()).then_some((
            hs.yaw_damping_nms,
            hs.friction_torque_nm,
            hs.friction_regularisation_rad_s,
        ));
        let mut switching = Vec::new();
        for (i, a) in axles.iter().enumerate() {
            if a.tire.kinks().at_zero {
                switching.push(SwitchingKind::SlipSign { axle: i });
            }
        }
        for (i, a) in axles.iter().enumerate() {
            if a.tire.kinks().sliding_limit.is_some() {
                switching.push(SwitchingKind::SlidingOnset { axle: i });
            }
        }
        if hitch.is_some_and(|(_, mc, _)| mc > 0.0) {
            switching.push(SwitchingKind::HitchFriction);
        }
        Ok(Self {
            core,
            axles,
            eval,
            hitch,
            k_moment_tractor: -(m1 * d) * i1 * i2.powi(3),
            k_moment_trailer: m2 * h * i1 * i1 * i2 * i2,
            switching,
        })
    }

    /// The torque T_h \[N m\] of the hitch damping at hitch-angle rate θ̇ (on the tractor;
    /// −T_h on the trailer): c_h·θ̇ + M_c·sat(θ̇/ω_c). Zero for a free hitch.
    fn hitch_torque<D: DualNum<Primitive = f64> + Copy>(&self, theta_dot: D) -> D {
        match self.hitch {
            None => D::from(0.0),
            Some((ch, mc, wc)) => {
                let w = theta_dot.re();
                let coulomb = if w > wc {
                    D::from(mc)
                } else if w < -wc {
                    D::from(-mc)
                } else {
                    theta_dot * (mc / wc)
                };
                theta_dot * ch + coulomb
            }
        }
    }

    /// Slip angle α of every axle \[rad\] at (x, u), in axle order, into `out`.
    fn slip_angles<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        out: &mut [D],
    ) {
        let x4 = State4::new(x[0], x[1], x[2], x[3]);
        let kin = self.core.kinematics(&x4);
        for (i, a) in self.axles.iter().enumerate() {
            out[i] = match a.unit {
                Unit::Tractor => {
                    let r = (x[0] + kin.yaw_rate * a.position_m) / u.speed;
                    if a.steered {
                        u.steering_angle - r.atan()
                    } else {
                        (-r).atan()
                    }
                }
                Unit::Trailer => self.trailer_tangent(x[0], u.speed, &kin, a).atan(),
            };
        }
    }

    #[inline]
    fn trailer_tangent<D: DualNum<Primitive = f64> + Copy>(
        &self,
        s1: D,
        v: D,
        kin: &crate::model::Kinematics<D>,
        a: &AxleModel,
    ) -> D {
        let (sn, cs) = (kin.sin_theta, kin.cos_theta);
        -(-v * sn + s1 * cs - (kin.yaw_rate + kin.hitch_angle_rate) * a.position_m)
            / (v * cs + s1 * sn)
    }

    /// F of a steered axle from r = (σ1 + a ψ̇)/V, as [`Model`]'s front force: the tangent of
    /// α = δ − atan r without an atan/tan pair.
    #[inline]
    fn steered_force<D: DualNum<Primitive = f64> + Copy>(
        tire: &TireLaw,
        steering_angle: D,
        r: D,
    ) -> D {
        if is_plain_zero(steering_angle) {
            return tire.lateral_force_from_tan(-r);
        }
        let tan_delta = steering_angle.tan();
        let den = D::from(1.0) + r * tan_delta;
        if den.re() > 0.0 {
            tire.lateral_force_from_tan((tan_delta - r) / den)
        } else {
            tire.lateral_force(steering_angle - r.atan())
        }
    }

    #[inline]
    fn rhs_actuated<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: Option<D>,
    ) -> SVector<D, N> {
        let p = &self.core.p;
        let k = &self.core.k;
        let zero = D::from(0.0);
        let mut dx = SVector::<D, N>::from_element(zero);
        let x4 = State4::new(x[0], x[1], x[2], x[3]);
        let (s1, s2, s3) = (x[0], x[1], x[2]);
        let (v, v_dot) = (u.speed, u.acceleration);
        let kin = self.core.kinematics(&x4);
        let (sn, cs) = (kin.sin_theta, kin.cos_theta);
        let plain_delta = is_plain_zero(u.steering_angle);
        let cos_delta = if plain_delta {
            D::from(1.0)
        } else {
            u.steering_angle.cos()
        };
        // moments on the tractor and the trailer (yaw moment input, hitch damping)
        let hitch = self.hitch.map(|_| self.hitch_torque(kin.hitch_angle_rate));
        let m_tractor = match (yaw_moment, hitch) {
            (Some(m), Some(t)) => Some(m + t),
            (Some(m), None) => Some(m),
            (None, Some(t)) => Some(t),
            (None, None) => None,
        };
        let m_trailer = hitch.map(|t| -t);

        let sn2 = sn * sn;
        let sc = sn * cs;
        let denom = cs * cs * k.d_cos2 + sn2 * k.d_sin2 + k.d0;
        // eq. (6) with the axle terms added in the order of Model::rhs4 (unsteered, trailer,
        // steered: `eval` is sorted so), which keeps one axle per unit bitwise the paper's
        let mut num = (s1 * s2 - s1 * s3 * 2.0 - v_dot) * sc * p[1]
            - s1 * s1 * (cs * p[3] + p[2]) * sc
            - s3 * s3 * sn * p[4]
            + v * (s1 * p[5] - s2 * self.core.i1) * (sn2 * p[7] + p[6]);
        let mut sigma2_dot = v * (s1 * k.s2_v1 - s2 * k.s2_v2);
        let mut sigma3_dot = s1 * s1 * sc * k.q12
            + v * (s2 * k.q13 - s1 * k.q14) * cs
            + (s1 * s3 - v_dot) * sn * k.q13;
        for a in &self.eval {
            match a.kind {
                EvalKind::Trailer => {
                    let t = -(-v * sn + s1 * cs
                        - (kin.yaw_rate + kin.hitch_angle_rate) * a.position_m)
                        / (v * cs + s1 * sn);
                    let f = match a.state {
                        None => a.tire.lateral_force_from_tan(t),
                        Some(j) => {
                            let vx = v * cs + s1 * sn;
                            dx[j] = (t.atan() - x[j]) * vx * a.inv_sigma;
                            a.tire.lateral_force(x[j])
                        }
                    };
                    num += f * cs * a.k_sigma1;
                    sigma3_dot -= f * a.k_other;
                }
                EvalKind::Unsteered | EvalKind::Steered => {
                    let steered = a.kind == EvalKind::Steered;
                    let r = (s1 + kin.yaw_rate * a.position_m) / v;
                    let f = match a.state {
                        None if steered => Self::steered_force(&a.tire, u.steering_angle, r),
                        None => a.tire.lateral_force_from_tan(-r),
                        Some(j) => {
                            let alpha = if steered {
                                u.steering_angle - r.atan()
                            } else {
                                (-r).atan()
                            };
                            dx[j] = (alpha - x[j]) * v * a.inv_sigma;
                            a.tire.lateral_force(x[j])
                        }
                    };
                    // the lateral component in the tractor's frame: F cos δ when steered
                    let f = if steered && !plain_delta {
                        f * cos_delta
                    } else {
                        f
                    };
                    num += f * a.k_sigma1;
                    sigma2_dot += f * a.k_other;
                }
            }
        }
        if let Some(m) = m_tractor {
            num += m * self.k_moment_tractor;
            sigma2_dot += m / self.core.i1;
        }
        if let Some(m2) = m_trailer {
            num += m2 * cs * self.k_moment_trailer;
            sigma3_dot += m2 / self.core.i2;
        }
        dx[0] = num / denom;
        dx[1] = sigma2_dot;
        dx[2] = sigma3_dot;
        dx[3] = kin.hitch_angle_rate;
        dx
    }
}

impl<const N: usize> Plant<N> for PairModel<N> {
    #[inline]
    fn rhs<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
    ) -> SVector<D, N> {
        self.rhs_actuated(x, u, None)
    }

    fn rhs_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> SVector<D, N> {
        self.rhs_actuated(x, u, Some(yaw_moment))
    }

    #[inline]
    fn yaw_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        x[1] - x[0] * self.core.k.m1d_i1
    }

    fn hitch_angle_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        self.core
            .kinematics(&State4::new(x[0], x[1], x[2], x[3]))
            .hitch_angle_rate
    }

    fn params(&self) -> &VehicleParams {
        &self.core.params
    }

    fn guard_values(&self, x: &SVector<f64, N>, u: &Inputs) -> [f64; 5] {
        let x4 = State4::new(x[0], x[1], x[2], x[3]);
        let yaw_rate = self.core.k.m1d_i1;
        let yaw_rate = x[1] - x[0] * yaw_rate;
        let mut out = [f64::NEG_INFINITY; 5];
        let (sd, cd) = if u.steering_angle == 0.0 {
            (0.0, 1.0)
        } else {
            u.steering_angle.sin_cos()
        };
        for a in self.axles.iter().filter(|a| a.unit == Unit::Tractor) {
            let lateral = x[0] + yaw_rate * a.position_m;
            let r = lateral / u.speed;
            let tan_abs = match a.state {
                Some(j) if x[j].abs() < std::f64::consts::FRAC_PI_2 => x[j].abs().tan(),
                Some(_) => f64::INFINITY,
                None if a.steered => {
                    Model::front_slip_tangent(u.steering_angle, r).map_or(f64::INFINITY, f64::abs)
                }
                None => r.abs(),
            };
            let k = usize::from(!a.steered);
            if a.tan_saturation.is_finite() {
                out[k] = out[k].max(tan_abs - a.tan_saturation);
            }
            if a.steered {
                let speed = if u.steering_angle == 0.0 {
                    u.speed
                } else {
                    u.speed * cd + lateral * sd
                };
                out[2] = out[2].max(-speed);
            }
        }
        out[3] = -u.speed;
        out[4] = -self.core.trailer_wheel_speed(&x4, u.speed);
        out
    }

    fn switching_kinds(&self) -> &[SwitchingKind] {
        &self.switching
    }

    /// SlipSign: tan α of an instantaneous axle (tan α_F as in
    /// [`Model::slip_angle_tangents`] for steered axles), α′ of a relaxing one; SlidingOnset:
    /// tan²α − tan²α_cr, or α′² − α_cr²; HitchFriction: θ̇² − ω_c².
    fn switching_functions(&self, x: &SVector<f64, N>, u: &Inputs, g: &mut [f64]) {
        let x4 = State4::new(x[0], x[1], x[2], x[3]);
        let kin = self.core.kinematics(&x4);
        let slip = |a: &AxleModel| -> (f64, f64) {
            if let Some(j) = a.state {
                let acr = a.tire.critical_slip_angle().unwrap_or(f64::INFINITY);
                return (x[j], x[j] * x[j] - acr * acr);
            }
            let t = match a.unit {
                Unit::Tractor => {
                    let r = (x[0] + kin.yaw_rate * a.position_m) / u.speed;
                    if a.steered {
                        Model::front_slip_tangent(u.steering_angle, r)
                            .unwrap_or_else(|| u.steering_angle - r.atan())
                    } else {
                        -r
                    }
                }
                Unit::Trailer => self.trailer_tangent(x[0], u.speed, &kin, a),
            };
            (t, t * t - a.tan_critical * a.tan_critical)
        };
        for (g, kind) in g.iter_mut().zip(&self.switching) {
            *g = match *kind {
                SwitchingKind::SlipSign { axle } => slip(&self.axles[axle]).0,
                SwitchingKind::SlidingOnset { axle } => slip(&self.axles[axle]).1,
                SwitchingKind::HitchFriction => {
                    let wc = self.hitch.map_or(f64::INFINITY, |(_, _, wc)| wc);
                    let w = kin.hitch_angle_rate;
                    w * w - wc * wc
                }
            };
        }
    }
}

/// A chain's equations ([`ChainModel`]) in the layout of every [`Plant`]: the first four
/// states are the paper's \[σ1, σ2, σ3, θ\] of the first articulation (eq. 4 with the towing
/// unit and the first towed unit: σ2 = r + (m1 d/I1) v, σ3 = r + θ̇1 − (m2 h/I2) v cos θ1), the
/// rest the chain's own (θ̇2, θ2, …, θ̇n, θn, the lagged slips α′). The engines read the
/// reduced state only through [`Plant`] and [`crate::HITCH_ANGLE`], and the paper-layout
/// outputs (σ1, σ2, σ3, θ) keep their meaning.
#[derive(Debug, Clone)]
struct ChainEquations<const N: usize> {
    chain: ChainModel<N>,
    /// the towing unit with the first towed unit in the paper's form (not validated: a fifth
    /// wheel ahead of the rear axle has c < 0)
    paper: Model,
    /// m1 d / I1 and m2 h / I2 \[1/m\] of that pair (eq. 4)
    k1: f64,
    k2: f64,
}

impl<const N: usize> ChainEquations<N> {
    fn new(spec: &VehicleSpec) -> Result<Self, ModelError> {
        let chain = ChainModel::<N>::new(&spec.chain_spec())?;
        let paper = Model::build(*Plant::params(&chain)).map_err(|e| ModelError::InvalidSpec {
            key: "trailers[0]".into(),
            value: f64::NAN,
            expected: format!(
                "a first towed unit whose pair with the towing unit has positive static loads in the paper's form (its paper model: {e})"
            ),
        })?;
        let (k1, k2) = (paper.k.m1d_i1, paper.k.m2h_i2);
        Ok(Self {
            chain,
            paper,
            k1,
            k2,
        })
    }

    /// θ̇1 \[rad/s\] from the paper layout: σ3 − σ2 + σ1 (m1 d/I1 + (m2 h/I2) cos θ).
    #[inline]
    fn theta1_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        x[2] - x[1] + x[0] * (x[3].cos() * self.k2 + self.k1)
    }

    /// The chain's state \[v, r, θ̇1, θ1, …\] of a state in the paper layout.
    #[inline]
    fn chain_state<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> SVector<D, N> {
        self.chain.from_paper_layout(x)
    }
}

impl<const N: usize> Plant<N> for ChainEquations<N> {
    #[inline]
    fn rhs<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
    ) -> SVector<D, N> {
        self.chain.rhs_in_paper_layout(x, u, None)
    }

    fn rhs_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> SVector<D, N> {
        self.chain.rhs_in_paper_layout(x, u, Some(yaw_moment))
    }

    #[inline]
    fn yaw_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        x[1] - x[0] * self.k1
    }

    fn hitch_angle_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        self.theta1_rate(x)
    }

    fn params(&self) -> &VehicleParams {
        Plant::params(&self.chain)
    }

    fn switching_kinds(&self) -> &[SwitchingKind] {
        self.chain.switching_kinds()
    }

    fn switching_functions(&self, x: &SVector<f64, N>, u: &Inputs, g: &mut [f64]) {
        self.chain.switching_functions(&self.chain_state(x), u, g);
    }

    fn guard_values(&self, x: &SVector<f64, N>, u: &Inputs) -> [f64; 5] {
        self.chain.guard_values(&self.chain_state(x), u)
    }
}

/// The equations behind a [`VehicleModel`].
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)]
enum Equations<const N: usize> {
    /// a two-unit vehicle (`[trailer]`)
    Pair(PairModel<N>),
    /// a chain of towed units (`[[trailers]]`)
    Chain(ChainEquations<N>),
}

/// Runs `$body` on the equations inside a [`VehicleModel`] (both are a [`Plant<N>`]).
macro_rules! with_equations {
    ($model:expr, $e:ident => $body:expr) => {
        match &$model.equations {
            Equations::Pair($e) => $body,
            Equations::Chain($e) => $body,
        }
    };
}

/// The general model of a vehicle file with N reduced states: a two-unit vehicle (module
/// docs: axle lists, tyre laws, relaxation, hitch torque) or a chain of towed units
/// ([`ChainModel`], in the paper's layout of its first articulation: the first four states
/// are \[σ1, σ2, σ3, θ\] of the towing unit with the first towed unit, then θ̇2, θ2, …, θn
/// and the lagged slips α′). One type for both, so that every engine is compiled once per
/// N, not once per N and kind of vehicle.
#[derive(Debug, Clone)]
pub struct VehicleModel<const N: usize> {
    spec: VehicleSpec,
    equations: Equations<N>,
}

impl<const N: usize> VehicleModel<N> {
    /// Builds the model of a vehicle file with N = 4 + (axles with σ > 0) states (a chain:
    /// N = 2·units + (axles with σ > 0)).
    ///
    /// # Errors
    /// [`VehicleSpec::check_physics`]'s errors; [`ModelError::StateCount`] when N does not
    /// fit the vehicle; for a chain, [`ModelError::InvalidSpec`] naming `trailers[0]` when the
    /// towing unit with the first towed unit has no paper form with positive axle loads.
    pub fn new(spec: &VehicleSpec) -> Result<Self, ModelError> {
        let equations = if spec.is_chain() {
            Equations::Chain(ChainEquations::new(spec)?)
        } else {
            Equations::Pair(PairModel::new(spec)?)
        };
        Ok(Self {
            spec: spec.clone(),
            equations,
        })
    }

    /// The vehicle file it was built from.
    pub fn spec(&self) -> &VehicleSpec {
        &self.spec
    }

    /// The axles of a two-unit vehicle, tractor first, each unit in file order; empty for a
    /// chain (its axles: [`Self::chain`], [`ChainModel::axles`]).
    pub fn axles(&self) -> &[AxleModel] {
        match &self.equations {
            Equations::Pair(m) => &m.axles,
            Equations::Chain(_) => &[],
        }
    }

    /// The chain's model (in its own state layout, module docs of [`ChainModel`]); None for
    /// a two-unit vehicle.
    pub fn chain(&self) -> Option<&ChainModel<N>> {
        match &self.equations {
            Equations::Pair(_) => None,
            Equations::Chain(c) => Some(&c.chain),
        }
    }

    /// Number of towed units.
    pub fn towed_units(&self) -> usize {
        match &self.equations {
            Equations::Pair(_) => 1,
            Equations::Chain(c) => c.chain.units() - 1,
        }
    }

    /// The paper's model of the equivalent single-axle vehicle (same masses and inertias;
    /// each group of axles at its mean position with the summed stiffness, brush tyres). For
    /// a chain: the towing unit with the first towed unit (the units behind are not in it).
    pub fn equivalent_model(&self) -> &Model {
        match &self.equations {
            Equations::Pair(m) => &m.core,
            Equations::Chain(c) => &c.paper,
        }
    }

    /// I1 = J1 + m1 d² \[kg m²\].
    pub fn i1(&self) -> f64 {
        self.equivalent_model().i1
    }

    /// I2 = J2 + m2 h² \[kg m²\] (of the first towed unit).
    pub fn i2(&self) -> f64 {
        self.equivalent_model().i2
    }

    /// The torque T_h \[N m\] at the hitch (the first coupling) at hitch-angle rate θ̇
    /// \[rad/s\] (on the tractor; −T_h on the trailer): c_h·θ̇ + M_c·sat(θ̇/ω_c). Zero for a
    /// free hitch.
    pub fn hitch_torque<D: DualNum<Primitive = f64> + Copy>(&self, theta_dot: D) -> D {
        match &self.equations {
            Equations::Pair(m) => m.hitch_torque(theta_dot),
            Equations::Chain(c) => c.chain.coupling_torque(1, D::from(0.0), theta_dot),
        }
    }

    /// Slip angle α of every axle \[rad\] at (x, u) (body-frame form of eq. 2: the
    /// instantaneous slip, which relaxing axles lag behind), in axle order (a chain's:
    /// [`ChainModel::axles`]), into `out`.
    pub fn slip_angles<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        out: &mut [D],
    ) {
        match &self.equations {
            Equations::Pair(m) => m.slip_angles(x, u, out),
            Equations::Chain(c) => c.chain.slip_angles(&c.chain_state(x), u, out),
        }
    }

    /// Sets every lagged slip α′ of `x` to the instantaneous slip α at speed V \[m/s\] and
    /// δ = 0 (the steady state of the slip lag at that state).
    pub fn settle_lagged_slips(&self, x: &mut SVector<f64, N>, speed_mps: f64) {
        let mut alpha = [0.0; MAX_CHAIN_AXLES];
        let u = Inputs::constant_speed(speed_mps);
        let states: Vec<Option<usize>> = match &self.equations {
            Equations::Pair(m) => m.axles.iter().map(|a| a.state).collect(),
            Equations::Chain(c) => c.chain.axles().iter().map(|a| a.state).collect(),
        };
        self.slip_angles(x, &u, &mut alpha[..states.len()]);
        for (state, alpha) in states.into_iter().zip(alpha) {
            if let Some(j) = state {
                x[j] = alpha;
            }
        }
    }
}

impl<const N: usize> Plant<N> for VehicleModel<N> {
    #[inline]
    fn rhs<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
    ) -> SVector<D, N> {
        with_equations!(self, e => e.rhs(x, u))
    }

    #[inline]
    fn rhs_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> SVector<D, N> {
        with_equations!(self, e => e.rhs_with_yaw_moment(x, u, yaw_moment))
    }

    #[inline]
    fn yaw_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        with_equations!(self, e => e.yaw_rate(x))
    }

    fn hitch_angle_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        with_equations!(self, e => e.hitch_angle_rate(x))
    }

    fn params(&self) -> &VehicleParams {
        with_equations!(self, e => e.params())
    }

    fn switching_kinds(&self) -> &[SwitchingKind] {
        with_equations!(self, e => e.switching_kinds())
    }

    /// SlipSign: tan α of an instantaneous axle (tan α_F as in
    /// [`Model::slip_angle_tangents`] for steered axles), α′ of a relaxing one; SlidingOnset:
    /// tan²α − tan²α_cr, or α′² − α_cr²; HitchFriction: θ̇² − ω_c² (a chain: one per coupling
    /// with friction, front to back).
    fn switching_functions(&self, x: &SVector<f64, N>, u: &Inputs, g: &mut [f64]) {
        with_equations!(self, e => e.switching_functions(x, u, g))
    }

    /// The tractor's axles as in [`Plant::guard_values`]; a chain's last entry is the largest
    /// −v_x over every towed unit's axles (any towed unit stops).
    fn guard_values(&self, x: &SVector<f64, N>, u: &Inputs) -> [f64; 5] {
        with_equations!(self, e => e.guard_values(x, u))
    }
}

/// A [`VehicleModel`] with its state count chosen from the vehicle at run time (the
/// dispatch over the supported N = 4 … [`MAX_STATES`]). Use [`with_plant!`](crate::with_plant)
/// to run generic code on the concrete model.
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)]
pub enum AnyVehicleModel {
    /// the paper's model ([`Model`], 4 states): a vehicle without variants (the paper's
    /// form, brush tyres with the vehicle's friction, σ = 0, a free hitch). Same numbers as
    /// `N4`, bit for bit, ~15 % faster (its right-hand side is specialised to three axles).
    Paper(Model),
    /// 4 states (no relaxing axle)
    N4(VehicleModel<4>),
    /// 5 states
    N5(VehicleModel<5>),
    /// 6 states
    N6(VehicleModel<6>),
    /// 7 states (e.g. σ > 0 on the three axles of Table I)
    N7(VehicleModel<7>),
    /// 8 states
    N8(VehicleModel<8>),
    /// 9 states
    N9(VehicleModel<9>),
    /// 10 states
    N10(VehicleModel<10>),
}

impl AnyVehicleModel {
    /// The model of a vehicle file with N = 4 + (axles with σ > 0), a chain's with
    /// N = 2·units + (axles with σ > 0); [`Self::Paper`] when the file has none of the
    /// variants (a chain always has: `trailers`).
    ///
    /// # Errors
    /// As [`VehicleModel::new`]; [`ModelError::StateCount`] for more than 6 relaxing axles
    /// (a chain: more than [`MAX_STATES`] states).
    pub fn new(spec: &VehicleSpec) -> Result<Self, ModelError> {
        let relaxed = spec.relaxed_axles()?;
        if !spec.has_variants()? {
            spec.check_physics()?;
            return Ok(Self::Paper(Model::new(spec.equivalent_params()?)?));
        }
        let (states, hint) = if spec.is_chain() {
            (
                spec.chain_spec().states()?,
                ": a chain has 2 states per unit and one per relaxing axle, at most 10 (e.g. 5 units without relaxation, 4 with 2 relaxing axles)",
            )
        } else {
            (4 + relaxed, ": at most 6 axles may relax")
        };
        Ok(match states {
            4 => Self::N4(VehicleModel::new(spec)?),
            5 => Self::N5(VehicleModel::new(spec)?),
            6 => Self::N6(VehicleModel::new(spec)?),
            7 => Self::N7(VehicleModel::new(spec)?),
            8 => Self::N8(VehicleModel::new(spec)?),
            9 => Self::N9(VehicleModel::new(spec)?),
            10 => Self::N10(VehicleModel::new(spec)?),
            n => {
                return Err(ModelError::StateCount {
                    relaxed,
                    expected: n,
                    requested: MAX_STATES,
                    hint,
                });
            }
        })
    }

    /// Number of reduced states N.
    pub fn states(&self) -> usize {
        crate::with_plant!(self, m => m_states(m))
    }

    /// Number of towed units (1 for a two-unit vehicle); the rearmost articulation angle
    /// θ_n is state 2n + 1 of the plant's own layout ([`crate::HITCH_ANGLE`] for n = 1).
    pub fn towed_units(&self) -> usize {
        match self {
            AnyVehicleModel::Paper(_) => 1,
            AnyVehicleModel::N4(m) => m.towed_units(),
            AnyVehicleModel::N5(m) => m.towed_units(),
            AnyVehicleModel::N6(m) => m.towed_units(),
            AnyVehicleModel::N7(m) => m.towed_units(),
            AnyVehicleModel::N8(m) => m.towed_units(),
            AnyVehicleModel::N9(m) => m.towed_units(),
            AnyVehicleModel::N10(m) => m.towed_units(),
        }
    }
}

fn m_states<const N: usize>(_: &impl Plant<N>) -> usize {
    N
}

/// Runs `$body` with `$m` bound to the concrete plant inside an [`AnyVehicleModel`] (`&Model`
/// or `&VehicleModel<N>`, one arm per supported N; `$body` is compiled for each, so it may
/// only use what every plant has: the [`Plant`] trait).
///
/// ```
/// use trailer_model::{AnyVehicleModel, CriticalSpeedOptions, Plant, VehicleSpec, with_plant};
/// let any = AnyVehicleModel::new(&VehicleSpec::table_i_with_relaxation(0.3)).unwrap();
/// let vc = with_plant!(&any, m => m.critical_speed(&CriticalSpeedOptions::default())).unwrap();
/// assert!(vc.v_crit_mps < 34.0); // relaxation lowers V_crit
/// ```
#[macro_export]
macro_rules! with_plant {
    ($any:expr, $m:ident => $body:expr) => {
        match $any {
            $crate::AnyVehicleModel::Paper($m) => $body,
            $crate::AnyVehicleModel::N4($m) => $body,
            $crate::AnyVehicleModel::N5($m) => $body,
            $crate::AnyVehicleModel::N6($m) => $body,
            $crate::AnyVehicleModel::N7($m) => $body,
            $crate::AnyVehicleModel::N8($m) => $body,
            $crate::AnyVehicleModel::N9($m) => $body,
            $crate::AnyVehicleModel::N10($m) => $body,
        }
    };
}

/// A two-unit file's model builds its chain; a chain's is a copy.
impl<const N: usize> AsChain<N> for VehicleModel<N> {
    fn as_chain(&self) -> Result<ChainModel<N>, ModelError> {
        match self.chain() {
            Some(chain) => Ok(chain.clone()),
            None => ChainModel::new(&self.spec().chain_spec()),
        }
    }
}
