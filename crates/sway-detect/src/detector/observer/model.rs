//! The observer's own car–trailer model: the paper's single-track model with the brush
//! tyre law (eq. 14–15) on every axle, written in the conventional lateral states of the car
//! instead of the paper's Appellian generalized velocities, with the kinematics of small
//! angles (below). Its linearisation about straight running at constant speed — the brush
//! tyre's slope at zero slip is its cornering stiffness, so this is the linearisation of
//! eq. 9–11 — gives the critical speed.
//!
//! # Geometry and conventions (the paper's, Fig. 1 and Table I)
//! Every length is measured from the hitch H: forward on the car to its front axle (f), its
//! centre of gravity C1 (d) and its rear axle (c); backward on the trailer to its centre of
//! gravity C2 (h) and its axle (l). The car's lateral axis points left; the hitch angle θ is
//! the trailer's heading minus the car's (the trailer's yaw rate is ψ̇ + θ̇), as in the
//! paper's slip angle of the trailer axle (eq. 2).
//!
//! # State, input and outputs
//! x = [v, r, θ, θ̇]: the lateral velocity v \[m/s\] of the car's centre of gravity in the
//! car's frame, the car's yaw rate r = ψ̇ \[rad/s\], the hitch angle θ \[rad\] and its rate θ̇
//! \[rad/s\]; the input is the road-wheel steering angle δ \[rad\]; the speed V \[m/s\] of the
//! car is a parameter (prescribed, the paper's constraint eq. 3). The paper's linear state
//! maps onto it one to one (σ1 is the hitch's lateral velocity v − d r, σ2 − (m1 d/I1) σ1 = r
//! by eq. 5), so the two linearisations are the same linear model:
//! [`LinearModel::critical_speed`] gives the toolkit's linear V_crit of Table I (a test
//! checks it to 10⁻⁶).
//!
//! # Equations (Newton–Euler)
//! Slip angles (eq. 2 for small steering and hitch angles), as tangents:
//! tan α_F = δ − (v + (f − d) r)/V, tan α_R = −(v + (c − d) r)/V,
//! tan α_T = θ − (v − (d + l) r − l θ̇)/V (tan α_R is exact; the other two drop terms of
//! order δ², θ²). Tyre forces F_i = F(tan α_i; C_i, F_z,i), the brush tyre of eq. 14–15 in
//! t = tan α with t_cr = tan α_cr = 3 μ0 F_z / C:
//! ```text
//! F = C t (1 + (μ/μ0 − 2) |t|/t_cr + (1 − 2μ/(3μ0)) (t/t_cr)²)   for |t| ≤ t_cr,
//! F = μ F_z sgn t                                                  beyond,
//! ```
//! with the friction coefficients μ0 (static) and μ (sliding) of [`Friction`]; its slope at
//! t = 0 is C, it falls to 0 at t_cr where the force reaches μ F_z (C¹ at 0, continuous at
//! t_cr: a C⁰ kink). At half the sliding friction the force is 17 % below the linear tyre's.
//! The static axle loads follow from the geometry and the masses (the trailer's mass and
//! centre of gravity are estimated, so the trailer's load and the car's share move with
//! them): the trailer axle carries F_z,T = m2 g h/l, the hitch H = m2 g − F_z,T (negative for
//! a centre of gravity behind the axle: the trailer lifts the hitch), the car's axles
//! F_z,F = (m1 g (d − c) − H c)/(f − c) and F_z,R = m1 g + H − F_z,F (moments about the
//! rear and front axle); g = [`GRAVITY`]. A load below [`MIN_AXLE_LOAD_N`] (parameters that
//! would tip the car) is held there.
//!
//! Lateral accelerations: the car's a1 = v̇ + V r at C1, the trailer's
//! a2 = v̇ − (d + h) ṙ − h θ̈ + V r at C2. With Y the hitch's lateral force on the trailer and
//! F_w a lateral force on the trailer at C2 (a gust; zero in the model, the observer's
//! process noise):
//! - car, lateral: m1 a1 = F_F + F_R − Y;
//! - car, yaw about C1: J1 ṙ = (f − d) F_F + (c − d) F_R + d Y;
//! - trailer, lateral: m2 a2 = F_T + Y + F_w;
//! - trailer, yaw about C2: J2 (ṙ + θ̈) = h Y − (l − h) F_T.
//!
//! Eliminating Y leaves M [v̇, ṙ, θ̈]ᵀ = e(x, δ) + B_w F_w with
//! ```text
//!     | m1 + m2   −m2 (d + h)          −m2 h        |
//! M = | −d m2     J1 + d m2 (d + h)    d m2 h       |
//!     | −h m2     J2 + m2 h (d + h)    J2 + m2 h²   |
//! ```
//! and the right-hand sides e = [F_F + F_R + F_T − (m1 + m2) V r,
//! (f − d) F_F + (c − d) F_R − d F_T + d m2 V r, −l F_T + h m2 V r] (B_w = [1, −d, −h]ᵀ).
//! With θ̇ = θ̇ this is ẋ = f(x, δ) (+ G F_w); with linear tyres F_i = C_i tan α_i it is the
//! linear model ẋ = A x + B δ ([`LinearModel`]). The measured lateral acceleration is that
//! of C1, where the observer assumes the sensor sits: a_y = v̇ + V r.
//!
//! # What the kinematics leave out
//! Of the paper's nonlinearities the model keeps the tyres', the ones ordinary driving
//! reaches first: a lane change at 3 m/s² uses half the sliding friction, while the hitch
//! angle stays at a few degrees, where cos θ differs from 1 by 10⁻³. The terms of order θ²
//! (the trailer's inertia seen along the car's axis, cos θ in the hitch force) and the
//! front tyre's force along the car (F_F sin δ) are left out.
//!
//! Everything is written once over a scalar type, so the same code gives values (`f64`) and
//! exact derivatives with respect to the states, the trailer's parameters, the steering and
//! the speed (forward-mode dual numbers).

use serde::{Deserialize, Serialize};

use super::dual::{Dual, Scalar};
use crate::error::{ConfigError, positive};

/// The towing car's parameters, known to the observer (the ESC knows its car). Lengths from
/// the hitch forward, the paper's Table I convention. [`Default`] is Table I's car.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CarParams {
    /// m1 \[kg\] (with occupants)
    pub mass: f64,
    /// J1 \[kg m²\]: yaw moment of inertia about C1
    pub yaw_inertia: f64,
    /// f \[m\]: hitch → front axle
    pub front_axle: f64,
    /// d \[m\]: hitch → centre of gravity C1
    pub cog: f64,
    /// c \[m\]: hitch → rear axle
    pub rear_axle: f64,
    /// C_F \[N/rad\]: front axle cornering stiffness
    pub front_cornering_stiffness: f64,
    /// C_R \[N/rad\]: rear axle cornering stiffness
    pub rear_cornering_stiffness: f64,
}

impl Default for CarParams {
    fn default() -> Self {
        CarParams {
            mass: 2400.0,
            yaw_inertia: 7647.0,
            front_axle: 5.15,
            cog: 3.25,
            rear_axle: 1.35,
            front_cornering_stiffness: 137e3,
            rear_cornering_stiffness: 256e3,
        }
    }
}

impl CarParams {
    /// Checks positive values and 0 < c < f, 0 < d < f (keys `car.*`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("car.mass", self.mass)?;
        positive("car.yaw_inertia", self.yaw_inertia)?;
        let f = positive("car.front_axle", self.front_axle)?;
        let d = positive("car.cog", self.cog)?;
        let c = positive("car.rear_axle", self.rear_axle)?;
        positive(
            "car.front_cornering_stiffness",
            self.front_cornering_stiffness,
        )?;
        positive(
            "car.rear_cornering_stiffness",
            self.rear_cornering_stiffness,
        )?;
        for (key, value) in [("car.cog", d), ("car.rear_axle", c)] {
            if value >= f {
                return Err(ConfigError::Bounds {
                    key,
                    value,
                    low: 0.0,
                    high: f,
                });
            }
        }
        Ok(())
    }
}

/// The trailer's parameters. Lengths from the hitch backward. [`Default`] is Table I's
/// trailer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrailerParams {
    /// m2 \[kg\] (with load)
    pub mass: f64,
    /// J2 \[kg m²\]: yaw moment of inertia about C2
    pub yaw_inertia: f64,
    /// h \[m\]: hitch → centre of gravity C2
    pub cog: f64,
    /// l \[m\]: hitch → trailer axle
    pub axle: f64,
    /// C_T \[N/rad\]: trailer axle cornering stiffness
    pub cornering_stiffness: f64,
}

impl Default for TrailerParams {
    fn default() -> Self {
        TrailerParams {
            mass: 985.0,
            yaw_inertia: 1416.0,
            cog: 2.9,
            axle: 2.8,
            cornering_stiffness: 50e3,
        }
    }
}

/// g \[m/s²\]: the static axle loads' gravity (the toolkit's value).
pub const GRAVITY: f64 = 9.81;

/// The least static axle load \[N\] the model uses: estimated parameters far from physical
/// ones could put an axle's load at or below zero (a car that tips); the brush tyre needs a
/// positive load, and an axle at this load has no grip to speak of.
pub const MIN_AXLE_LOAD_N: f64 = 100.0;

/// The tyre–road friction of the brush tyre (paper eq. 15): the observer's assumption, the
/// ESC's friction estimate where it has one. [`Default`] is the paper's dry road.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Friction {
    /// μ0 \[-\]: the static coefficient (adhesion), which sets where the tyre starts
    /// to slide: tan α_cr = 3 μ0 F_z / C. Default 0.9, the paper's
    pub mu_static: f64,
    /// μ \[-\]: the sliding coefficient, the force's limit μ F_z. Default 0.6, the paper's
    pub mu_dynamic: f64,
}

impl Default for Friction {
    fn default() -> Self {
        Friction {
            mu_static: 0.9,
            mu_dynamic: 0.6,
        }
    }
}

impl Friction {
    /// Checks 0 < μ ≤ μ0 (keys `friction.*`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let mu0 = positive("friction.mu_static", self.mu_static)?;
        let mu = positive("friction.mu_dynamic", self.mu_dynamic)?;
        if mu > mu0 {
            return Err(ConfigError::Bounds {
                key: "friction.mu_dynamic",
                value: mu,
                low: 0.0,
                high: mu0,
            });
        }
        Ok(())
    }
}

/// The trailer's parameters in the arithmetic `S` (the estimated three may carry
/// derivatives; the axle and its stiffness are the observer's nominal values).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Trailer<S> {
    pub(crate) mass: S,
    pub(crate) yaw_inertia: S,
    pub(crate) cog: S,
    pub(crate) axle: f64,
    pub(crate) cornering_stiffness: f64,
}

impl Trailer<f64> {
    fn from_params(t: &TrailerParams) -> Self {
        Trailer {
            mass: t.mass,
            yaw_inertia: t.yaw_inertia,
            cog: t.cog,
            axle: t.axle,
            cornering_stiffness: t.cornering_stiffness,
        }
    }
}

/// A 4×4 matrix (rows of columns) in the arithmetic `S`.
pub(crate) type Mat4<S> = [[S; 4]; 4];

/// ẋ = A x + B δ at one speed: the state matrix A \[1/s and alike\] and the steering
/// column B (per rad of road-wheel angle) of the linear model.
#[derive(Debug, Clone, Copy)]
pub(crate) struct System<S> {
    pub(crate) a: Mat4<S>,
    pub(crate) b: [S; 4],
}

/// The inverse of a 3×3 matrix by cofactors (M of the model is positive definite in the
/// sense of kinetic energy, so its determinant is positive for physical parameters).
fn inverse3<S: Scalar>(m: &[[S; 3]; 3]) -> [[S; 3]; 3] {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    // the inverse is the transposed cofactor matrix over the determinant
    std::array::from_fn(|i| std::array::from_fn(|j| cof[j][i] / det))
}

/// M of the module's equations: the left-hand side of [v̇, ṙ, θ̈] once the hitch force is
/// eliminated.
fn mass_matrix<S: Scalar>(car: &CarParams, t: &Trailer<S>) -> [[S; 3]; 3] {
    let k = |x: f64| S::from(x);
    let (m1, j1, d) = (k(car.mass), k(car.yaw_inertia), car.cog);
    let (m2, j2, h) = (t.mass, t.yaw_inertia, t.cog);
    let dh = k(d) + h;
    [
        [m1 + m2, -(m2 * dh), -(m2 * h)],
        [-(k(d) * m2), j1 + k(d) * m2 * dh, k(d) * m2 * h],
        [-(h * m2), j2 + m2 * h * dh, j2 + m2 * h * h],
    ]
}

/// The linear model's matrices at speed `v` \[m/s\] (the module's equations).
pub(crate) fn system<S: Scalar>(car: &CarParams, t: &Trailer<S>, v: S) -> System<S> {
    let k = |x: f64| S::from(x);
    let m1 = k(car.mass);
    let (f, d, c) = (car.front_axle, car.cog, car.rear_axle);
    let (m2, h, l) = (t.mass, t.cog, t.axle);
    let inv = inverse3(&mass_matrix(car, t));
    // the axle forces as rows over [v, r, θ, θ̇, δ]
    let (cf, cr, ct) = (
        car.front_cornering_stiffness,
        car.rear_cornering_stiffness,
        t.cornering_stiffness,
    );
    let zero = k(0.0);
    let front = [-(k(cf) / v), -(k(cf * (f - d)) / v), zero, zero, k(cf)];
    let rear = [-(k(cr) / v), -(k(cr * (c - d)) / v), zero, zero, zero];
    let trailer = [
        -(k(ct) / v),
        k(ct * (d + l)) / v,
        k(ct),
        k(ct * l) / v,
        zero,
    ];
    // right-hand sides of the three equations, rows over [v, r, θ, θ̇, δ]
    let rhs: [[S; 5]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let forces = match i {
                0 => front[j] + rear[j] + trailer[j],
                1 => k(f - d) * front[j] + k(c - d) * rear[j] - k(d) * trailer[j],
                _ => -(k(l) * trailer[j]),
            };
            let inertial = match (i, j) {
                (0, 1) => -((m1 + m2) * v),
                (1, 1) => k(d) * m2 * v,
                (2, 1) => h * m2 * v,
                _ => zero,
            };
            forces + inertial
        })
    });
    // [v̇, ṙ, θ̈] = M⁻¹ (rhs): rows 0, 1, 3 of the state equation; row 2 is θ̇ = θ̇
    let solve = |col: &dyn Fn(usize) -> S| -> [S; 3] {
        std::array::from_fn(|i| inv[i][0] * col(0) + inv[i][1] * col(1) + inv[i][2] * col(2))
    };
    let mut a = [[zero; 4]; 4];
    let mut b = [zero; 4];
    for j in 0..4 {
        let acc = solve(&|i| rhs[i][j]);
        a[0][j] = acc[0];
        a[1][j] = acc[1];
        a[3][j] = acc[2];
    }
    a[2][3] = k(1.0);
    let acc = solve(&|i| rhs[i][4]);
    (b[0], b[1], b[3]) = (acc[0], acc[1], acc[2]);
    System { a, b }
}

/// The static axle loads [F_z,F, F_z,R, F_z,T] \[N\] (module docs), each at least
/// [`MIN_AXLE_LOAD_N`].
pub(crate) fn axle_loads<S: Scalar>(car: &CarParams, t: &Trailer<S>) -> [S; 3] {
    let k = |x: f64| S::from(x);
    let (f, d, c) = (car.front_axle, car.cog, car.rear_axle);
    let car_weight = car.mass * GRAVITY;
    let trailer_weight = t.mass * k(GRAVITY);
    let trailer = trailer_weight * t.cog / k(t.axle);
    let hitch = trailer_weight - trailer;
    let front = (k(car_weight * (d - c)) - hitch * k(c)) / k(f - c);
    let rear = k(car_weight) + hitch - front;
    [front, rear, trailer].map(|fz| {
        if fz.value() < MIN_AXLE_LOAD_N {
            k(MIN_AXLE_LOAD_N)
        } else {
            fz
        }
    })
}

/// The brush tyre (paper eq. 14–15) as a function of the slip angle's tangent `t`: the
/// lateral force \[N\] of an axle with cornering stiffness `stiffness` \[N/rad\] and
/// `critical` = tan α_cr = 3 μ0 F_z / C, whose load `load` \[N\] bounds it at μ F_z.
fn brush<S: Scalar>(t: S, stiffness: f64, critical: S, load: S, friction: &Friction) -> S {
    let ratio = friction.mu_dynamic / friction.mu_static;
    let u = t / critical;
    let a = u.abs();
    if a.value() <= 1.0 {
        // C t (1 + (μ/μ0 − 2)|u| + (1 − 2μ/(3μ0)) u²), Horner in |u|
        t * S::from(stiffness)
            * (S::from(1.0) + a * (S::from(ratio - 2.0) + a * S::from(1.0 - 2.0 * ratio / 3.0)))
    } else if t.value() > 0.0 {
        load * S::from(friction.mu_dynamic)
    } else {
        -(load * S::from(friction.mu_dynamic))
    }
}

/// The brush tyre's force \[N\] at slip tangent `tan_alpha` of an axle with cornering
/// stiffness `stiffness` \[N/rad\] and vertical load `load` \[N\] (paper eq. 14–15).
pub fn brush_lateral_force(tan_alpha: f64, stiffness: f64, load: f64, friction: &Friction) -> f64 {
    let critical = 3.0 * friction.mu_static * load / stiffness;
    brush(tan_alpha, stiffness, critical, load, friction)
}

/// The nonlinear model of one car–trailer at one speed, ready to evaluate: what does not
/// depend on the state (M⁻¹, the axle loads and the tyres' critical slips) computed once.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Plant<S> {
    car: CarParams,
    friction: Friction,
    trailer_axle: f64,
    trailer_stiffness: f64,
    /// h
    trailer_cog: S,
    /// m1 + m2, d m2 and h m2 (the right-hand sides' inertial terms per V r)
    inertial: [S; 3],
    m_inv: [[S; 3]; 3],
    loads: [S; 3],
    critical: [S; 3],
    speed: f64,
}

impl<S: Scalar> Plant<S> {
    /// The model of `car` towing `t` on `friction` at `speed` \[m/s\].
    pub(crate) fn new(car: &CarParams, t: &Trailer<S>, friction: &Friction, speed: f64) -> Self {
        let k = |x: f64| S::from(x);
        let loads = axle_loads(car, t);
        let stiffness = [
            car.front_cornering_stiffness,
            car.rear_cornering_stiffness,
            t.cornering_stiffness,
        ];
        Plant {
            car: *car,
            friction: *friction,
            trailer_axle: t.axle,
            trailer_stiffness: t.cornering_stiffness,
            trailer_cog: t.cog,
            inertial: [k(car.mass) + t.mass, k(car.cog) * t.mass, t.cog * t.mass],
            m_inv: inverse3(&mass_matrix(car, t)),
            loads,
            critical: std::array::from_fn(|i| {
                loads[i] * k(3.0 * friction.mu_static / stiffness[i])
            }),
            speed,
        }
    }

    /// The tangents of the slip angles [tan α_F, tan α_R, tan α_T] at `x` and `delta`.
    fn slips(&self, x: &[S; 4], delta: S) -> [S; 3] {
        let k = |x: f64| S::from(x);
        let (f, d, c, l) = (
            self.car.front_axle,
            self.car.cog,
            self.car.rear_axle,
            self.trailer_axle,
        );
        let inv_v = k(1.0 / self.speed);
        let [v, r, theta, rate] = *x;
        [
            delta - (v + r * k(f - d)) * inv_v,
            -((v + r * k(c - d)) * inv_v),
            theta - (v - r * k(d + l) - rate * k(l)) * inv_v,
        ]
    }

    /// The axle forces [F_F, F_R, F_T] \[N\] at `x` and `delta`.
    pub(crate) fn forces(&self, x: &[S; 4], delta: S) -> [S; 3] {
        let t = self.slips(x, delta);
        let stiffness = [
            self.car.front_cornering_stiffness,
            self.car.rear_cornering_stiffness,
            self.trailer_stiffness,
        ];
        std::array::from_fn(|i| {
            brush(
                t[i],
                stiffness[i],
                self.critical[i],
                self.loads[i],
                &self.friction,
            )
        })
    }

    /// [v̇, ṙ, θ̈] at `x` and `delta`.
    fn accelerations(&self, x: &[S; 4], delta: S) -> [S; 3] {
        let k = |x: f64| S::from(x);
        let (f, d, c, l) = (
            self.car.front_axle,
            self.car.cog,
            self.car.rear_axle,
            self.trailer_axle,
        );
        let [ff, fr, ft] = self.forces(x, delta);
        let vr = x[1] * k(self.speed);
        let e = [
            ff + fr + ft - self.inertial[0] * vr,
            ff * k(f - d) + fr * k(c - d) - ft * k(d) + self.inertial[1] * vr,
            self.inertial[2] * vr - ft * k(l),
        ];
        std::array::from_fn(|i| {
            self.m_inv[i][0] * e[0] + self.m_inv[i][1] * e[1] + self.m_inv[i][2] * e[2]
        })
    }

    /// ẋ = f(x, δ).
    pub(crate) fn derivative(&self, x: &[S; 4], delta: S) -> [S; 4] {
        let [dv, dr, ddtheta] = self.accelerations(x, delta);
        [dv, dr, x[3], ddtheta]
    }

    /// a_y = v̇ + V r at C1 \[m/s²\].
    pub(crate) fn lateral_acceleration(&self, x: &[S; 4], delta: S) -> S {
        self.accelerations(x, delta)[0] + x[1] * S::from(self.speed)
    }

    /// G: ẋ per N of a lateral force on the trailer at C2.
    pub(crate) fn trailer_force_column(&self) -> [S; 4] {
        let k = |x: f64| S::from(x);
        let column = [k(1.0), k(-self.car.cog), -self.trailer_cog];
        let acc: [S; 3] = std::array::from_fn(|i| {
            self.m_inv[i][0] * column[0]
                + self.m_inv[i][1] * column[1]
                + self.m_inv[i][2] * column[2]
        });
        [acc[0], acc[1], k(0.0), acc[2]]
    }

    /// One step of `h` \[s\] from `x` by [`rk4`] on `substeps` equal substeps, the
    /// steering going linearly from `u0` to `u1`.
    pub(crate) fn step(&self, x: &[S; 4], u0: S, u1: S, h: f64, substeps: usize) -> [S; 4] {
        rk4(
            |x: &[S; 4], u: S| self.derivative(x, u),
            x,
            u0,
            u1,
            h,
            substeps,
        )
    }
}

/// One step of `h` \[s\] of ẋ = f(x, u) from `x` by the classical Runge–Kutta method on
/// `substeps` equal substeps, the input going linearly from `u0` to `u1` (first-order
/// hold, evaluated at the stages). For a linear system this is the exact discretisation's
/// series truncated after the 4th power of h_s A.
pub(crate) fn rk4<S: Scalar>(
    f: impl Fn(&[S; 4], S) -> [S; 4],
    x: &[S; 4],
    u0: S,
    u1: S,
    h: f64,
    substeps: usize,
) -> [S; 4] {
    let n = substeps as f64;
    let hs = h / n;
    let du = u1 - u0;
    let at = |s: f64| u0 + du * S::from(s / n);
    let add = |x: &[S; 4], k: &[S; 4], c: f64| -> [S; 4] {
        std::array::from_fn(|i| x[i] + k[i] * S::from(c))
    };
    let mut x = *x;
    for j in 0..substeps {
        let s = j as f64;
        let k1 = f(&x, at(s));
        let mid = at(s + 0.5);
        let k2 = f(&add(&x, &k1, 0.5 * hs), mid);
        let k3 = f(&add(&x, &k2, 0.5 * hs), mid);
        let k4 = f(&add(&x, &k3, hs), at(s + 1.0));
        x = std::array::from_fn(|i| {
            x[i] + (k1[i] + (k2[i] + k3[i]) * S::from(2.0) + k4[i]) * S::from(hs / 6.0)
        });
    }
    x
}

/// The product of two 4×4 matrices.
pub(crate) fn mat_mul<S: Scalar>(x: &Mat4<S>, y: &Mat4<S>) -> Mat4<S> {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            x[i][0] * y[0][j] + x[i][1] * y[1][j] + x[i][2] * y[2][j] + x[i][3] * y[3][j]
        })
    })
}

/// The product of a 4×4 matrix and a vector.
pub(crate) fn mat_vec<S: Scalar>(x: &Mat4<S>, v: &[S; 4]) -> [S; 4] {
    std::array::from_fn(|i| x[i][0] * v[0] + x[i][1] * v[1] + x[i][2] * v[2] + x[i][3] * v[3])
}

/// The coefficients [a0, a1, a2, a3] of the characteristic polynomial
/// det(sI − A) = s⁴ + a3 s³ + a2 s² + a1 s + a0 (Faddeev–LeVerrier: N_1 = I,
/// a_{4−k} = −tr(A N_k)/k, N_{k+1} = A N_k + a_{4−k} I).
pub(crate) fn characteristic_polynomial<S: Scalar>(a: &Mat4<S>) -> [S; 4] {
    let zero = S::from(0.0);
    let mut n: Mat4<S> =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { S::from(1.0) } else { zero }));
    let mut coefficients = [zero; 4];
    for k in 1..=4 {
        let an = mat_mul(a, &n);
        let trace = an[0][0] + an[1][1] + an[2][2] + an[3][3];
        let coefficient = -(trace / S::from(k as f64));
        coefficients[4 - k] = coefficient;
        n = an;
        for (i, row) in n.iter_mut().enumerate() {
            row[i] = row[i] + coefficient;
        }
    }
    coefficients
}

/// How straight running loses stability at a critical speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Crossing {
    /// a complex pair crosses the imaginary axis (sway sets in, a Hopf bifurcation): the
    /// Hurwitz determinant Δ3 = a3 a2 a1 − a1² − a3² a0 changes sign
    Hopf,
    /// a real eigenvalue crosses zero (the trailer jack-knifes slowly): a0 changes sign
    Divergence,
}

/// Which Hurwitz condition of s⁴ + a3 s³ + a2 s² + a1 s + a0 fails first (`None`: all hold,
/// straight running is asymptotically stable). For a quartic, a0, a1, a2, a3 > 0 and
/// Δ3 = a3 a2 a1 − a1² − a3² a0 > 0 are necessary and sufficient.
fn hurwitz_failure(c: &[f64; 4]) -> Option<Crossing> {
    let [a0, a1, a2, a3] = *c;
    // false for NaN too
    let positive = |x: f64| x > 0.0;
    if !positive(a0) {
        Some(Crossing::Divergence)
    } else if !(positive(a1) && positive(a2) && positive(a3) && positive(hurwitz_determinant(c))) {
        Some(Crossing::Hopf)
    } else {
        None
    }
}

/// Δ3 = a3 a2 a1 − a1² − a3² a0 of [a0, a1, a2, a3].
fn hurwitz_determinant<S: Scalar>(c: &[S; 4]) -> S {
    let [a0, a1, a2, a3] = *c;
    a3 * a2 * a1 - a1 * a1 - a3 * a3 * a0
}

/// Where and how the linear model's straight running loses stability.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CriticalSpeed {
    /// V_crit \[m/s\]: the lowest speed of the range at which a Hurwitz condition fails
    pub v_crit_mps: f64,
    /// which condition fails
    pub crossing: Crossing,
    /// the sway frequency at a Hopf crossing, √(a1/a3)/2π \[Hz\]; 0 at a divergence
    pub frequency_hz: f64,
}

/// Why the linear model has no critical speed in the searched range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, thiserror::Error)]
#[serde(rename_all = "snake_case", tag = "reason")]
pub enum NoCriticalSpeed {
    /// straight running is stable up to the search's highest speed
    #[error("straight running is stable up to {v_max_mps} m/s")]
    StableUpTo {
        /// the search's highest speed \[m/s\]
        v_max_mps: f64,
    },
    /// straight running is already unstable at the search's lowest speed
    #[error("straight running is already unstable at {v_min_mps} m/s")]
    UnstableAt {
        /// the search's lowest speed \[m/s\]
        v_min_mps: f64,
    },
    /// the characteristic polynomial is not finite (parameters beyond physical ones)
    #[error("the characteristic polynomial is not finite")]
    NotFinite,
    /// no estimate yet (before the observer's first critical-speed search)
    #[error("not computed yet")]
    NotComputed,
}

/// The range and resolution of the critical-speed search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CriticalSpeedSearch {
    /// the lowest speed searched \[m/s\] (default 1 m/s: below, no trailer sways)
    pub v_min_mps: f64,
    /// the highest speed searched \[m/s\] (default 100 m/s, as the toolkit's search)
    pub v_max_mps: f64,
    /// the scan's step before the bisection \[m/s\] (default 0.5 m/s: a stable window
    /// narrower than this beyond an unstable one would be missed; the linear model of a car
    /// and trailer loses stability once)
    pub scan_step_mps: f64,
    /// the bisection stops at a bracket this wide \[m/s\] (default 10⁻³ m/s, far below the
    /// estimate's uncertainty)
    pub tolerance_mps: f64,
}

impl Default for CriticalSpeedSearch {
    fn default() -> Self {
        CriticalSpeedSearch {
            v_min_mps: 1.0,
            v_max_mps: 100.0,
            scan_step_mps: 0.5,
            tolerance_mps: 1e-3,
        }
    }
}

impl CriticalSpeedSearch {
    /// Checks 0 < v_min < v_max and positive steps (keys `v_crit_search.*`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let low = positive("v_crit_search.v_min_mps", self.v_min_mps)?;
        let high = positive("v_crit_search.v_max_mps", self.v_max_mps)?;
        if high <= low {
            return Err(ConfigError::Bounds {
                key: "v_crit_search.v_max_mps",
                value: high,
                low,
                high: f64::INFINITY,
            });
        }
        positive("v_crit_search.scan_step_mps", self.scan_step_mps)?;
        positive("v_crit_search.tolerance_mps", self.tolerance_mps)?;
        Ok(())
    }
}

/// The Hurwitz failure at speed `v`, `Err` when the polynomial is not finite.
fn failure_at(
    car: &CarParams,
    t: &Trailer<f64>,
    v: f64,
) -> Result<Option<Crossing>, NoCriticalSpeed> {
    let c = characteristic_polynomial(&system(car, t, v).a);
    if c.iter().all(|x| x.is_finite()) {
        Ok(hurwitz_failure(&c))
    } else {
        Err(NoCriticalSpeed::NotFinite)
    }
}

/// The critical speed of the linear model: a scan from `v_min` in steps, then bisection on
/// the bracket where the Hurwitz conditions start to fail; `hint` \[m/s\] (the previous
/// estimate) is tried first as the centre of a bracket of one scan step.
pub(crate) fn critical_speed(
    car: &CarParams,
    t: &Trailer<f64>,
    search: &CriticalSpeedSearch,
    hint: Option<f64>,
) -> Result<CriticalSpeed, NoCriticalSpeed> {
    let at = |v: f64| failure_at(car, t, v);
    if at(search.v_min_mps)?.is_some() {
        return Err(NoCriticalSpeed::UnstableAt {
            v_min_mps: search.v_min_mps,
        });
    }
    let step = search.scan_step_mps;
    let bracket = match hint {
        Some(v)
            if v - step > search.v_min_mps
                && v + step < search.v_max_mps
                && at(v - step)?.is_none()
                && at(v + step)?.is_some() =>
        {
            Some((v - step, v + step))
        }
        _ => None,
    };
    let (mut lo, mut hi) = match bracket {
        Some(b) => b,
        None => {
            let mut lo = search.v_min_mps;
            loop {
                let hi = (lo + step).min(search.v_max_mps);
                if at(hi)?.is_some() {
                    break (lo, hi);
                }
                if hi >= search.v_max_mps || hi <= lo {
                    return Err(NoCriticalSpeed::StableUpTo {
                        v_max_mps: search.v_max_mps,
                    });
                }
                lo = hi;
            }
        }
    };
    while hi - lo > search.tolerance_mps {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break; // adjacent floating-point numbers
        }
        if at(mid)?.is_some() {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let v_crit_mps = 0.5 * (lo + hi);
    let crossing = at(hi)?.unwrap_or(Crossing::Hopf);
    let frequency_hz = match crossing {
        Crossing::Hopf => {
            let c = characteristic_polynomial(&system(car, t, v_crit_mps).a);
            (c[1] / c[3]).max(0.0).sqrt() / std::f64::consts::TAU
        }
        Crossing::Divergence => 0.0,
    };
    Ok(CriticalSpeed {
        v_crit_mps,
        crossing,
        frequency_hz,
    })
}

/// ∂V_crit/∂(m2, J2, h) \[m/s per kg, per kg m², per m\] by the implicit function theorem
/// on the failing Hurwitz condition g(V, p) = 0: −(∂g/∂p)/(∂g/∂V), both exact (dual
/// numbers in the three parameters and the speed).
pub(crate) fn critical_speed_gradient(
    car: &CarParams,
    t: &Trailer<f64>,
    critical: &CriticalSpeed,
) -> [f64; 3] {
    let trailer = Trailer {
        mass: Dual::<4>::variable(t.mass, 0),
        yaw_inertia: Dual::variable(t.yaw_inertia, 1),
        cog: Dual::variable(t.cog, 2),
        axle: t.axle,
        cornering_stiffness: t.cornering_stiffness,
    };
    let c =
        characteristic_polynomial(&system(car, &trailer, Dual::variable(critical.v_crit_mps, 3)).a);
    let g = match critical.crossing {
        Crossing::Hopf => hurwitz_determinant(&c),
        Crossing::Divergence => c[0],
    };
    std::array::from_fn(|i| -g.eps[i] / g.eps[3])
}

/// The car–trailer linear model with every parameter known: what the observer runs with its
/// estimates, public so that its critical speed and its responses can be checked against
/// the toolkit's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearModel {
    car: CarParams,
    trailer: TrailerParams,
}

impl LinearModel {
    /// The model of `car` towing `trailer`, checked (positive values, 0 < c, d < f).
    pub fn new(car: CarParams, trailer: TrailerParams) -> Result<Self, ConfigError> {
        car.validate()?;
        positive("trailer.mass", trailer.mass)?;
        positive("trailer.yaw_inertia", trailer.yaw_inertia)?;
        positive("trailer.cog", trailer.cog)?;
        positive("trailer.axle", trailer.axle)?;
        positive("trailer.cornering_stiffness", trailer.cornering_stiffness)?;
        Ok(LinearModel { car, trailer })
    }

    /// A \[rows over [v̇, ṙ, θ̇, θ̈]\] and B of ẋ = A x + B δ at speed `speed` \[m/s\].
    pub fn state_matrices(&self, speed: f64) -> ([[f64; 4]; 4], [f64; 4]) {
        let s = system(&self.car, &Trailer::from_params(&self.trailer), speed);
        (s.a, s.b)
    }

    /// ẋ at state `x` = [v, r, θ, θ̇], road-wheel angle `steering_angle` \[rad\] and
    /// `speed` \[m/s\].
    pub fn derivative(&self, x: &[f64; 4], steering_angle: f64, speed: f64) -> [f64; 4] {
        let (a, b) = self.state_matrices(speed);
        let ax = mat_vec(&a, x);
        std::array::from_fn(|i| ax[i] + b[i] * steering_angle)
    }

    /// The lateral acceleration of the car's centre of gravity, a_y = v̇ + V r \[m/s²\].
    pub fn lateral_acceleration(&self, x: &[f64; 4], steering_angle: f64, speed: f64) -> f64 {
        self.derivative(x, steering_angle, speed)[0] + speed * x[1]
    }

    /// The critical speed: the lowest speed of `search` at which straight running is no
    /// longer asymptotically stable (bisection on the Hurwitz conditions of the
    /// characteristic polynomial, to `search.tolerance_mps`).
    pub fn critical_speed(
        &self,
        search: &CriticalSpeedSearch,
    ) -> Result<CriticalSpeed, NoCriticalSpeed> {
        critical_speed(
            &self.car,
            &Trailer::from_params(&self.trailer),
            search,
            None,
        )
    }
}

/// The car–trailer model with brush tyres and every parameter known: what the observer
/// predicts with its estimates, public so that its responses can be checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrushModel {
    car: CarParams,
    trailer: TrailerParams,
    friction: Friction,
}

impl BrushModel {
    /// The model of `car` towing `trailer` on `friction`, checked (as [`LinearModel::new`],
    /// and 0 < μ ≤ μ0).
    pub fn new(
        car: CarParams,
        trailer: TrailerParams,
        friction: Friction,
    ) -> Result<Self, ConfigError> {
        LinearModel::new(car, trailer)?;
        friction.validate()?;
        Ok(BrushModel {
            car,
            trailer,
            friction,
        })
    }

    /// Its linearisation about straight running (linear tyres of the cornering stiffnesses).
    pub fn linear(&self) -> LinearModel {
        LinearModel {
            car: self.car,
            trailer: self.trailer,
        }
    }

    fn plant(&self, speed: f64) -> Plant<f64> {
        Plant::new(
            &self.car,
            &Trailer::from_params(&self.trailer),
            &self.friction,
            speed,
        )
    }

    /// The static axle loads [F_z,F, F_z,R, F_z,T] \[N\].
    pub fn axle_loads(&self) -> [f64; 3] {
        axle_loads(&self.car, &Trailer::from_params(&self.trailer))
    }

    /// The axle forces [F_F, F_R, F_T] \[N\] at state `x` = [v, r, θ, θ̇], road-wheel angle
    /// `steering_angle` \[rad\] and `speed` \[m/s\].
    pub fn axle_forces(&self, x: &[f64; 4], steering_angle: f64, speed: f64) -> [f64; 3] {
        self.plant(speed).forces(x, steering_angle)
    }

    /// ẋ at state `x` = [v, r, θ, θ̇], road-wheel angle `steering_angle` \[rad\] and
    /// `speed` \[m/s\].
    pub fn derivative(&self, x: &[f64; 4], steering_angle: f64, speed: f64) -> [f64; 4] {
        self.plant(speed).derivative(x, steering_angle)
    }

    /// The lateral acceleration of the car's centre of gravity, a_y = v̇ + V r \[m/s²\].
    pub fn lateral_acceleration(&self, x: &[f64; 4], steering_angle: f64, speed: f64) -> f64 {
        self.plant(speed).lateral_acceleration(x, steering_angle)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table_i() -> (CarParams, Trailer<f64>) {
        (
            CarParams::default(),
            Trailer::from_params(&TrailerParams::default()),
        )
    }

    /// The paper's brush tyre (eq. 14–15) as printed, in α: φ1 tan α + φ2 tan²α sgn α +
    /// φ3 tan³α up to α_cr = atan(3 F_z μ0 / C), F_z μ sgn α beyond.
    fn paper_brush(alpha: f64, c: f64, fz: f64, mu0: f64, mu: f64) -> f64 {
        let alpha_cr = (3.0 * fz * mu0 / c).atan();
        if alpha.abs() > alpha_cr {
            return fz * mu * alpha.signum();
        }
        let phi2 = c * c / (3.0 * fz * mu0) * (mu / mu0 - 2.0);
        let phi3 = c.powi(3) / (9.0 * fz * fz * mu0 * mu0) * (1.0 - 2.0 * mu / (3.0 * mu0));
        let t = alpha.tan();
        c * t + phi2 * t * t * t.signum() + phi3 * t.powi(3)
    }

    #[test]
    fn the_brush_tyre_is_the_papers_and_its_derivative_is_exact() {
        // reference: eq. 14–15 as printed (above), to 1e-12 relative; the slope from the
        // duals against the analytic dF/dt = C + 2 φ2 |t| + 3 φ3 t² (1e-12 relative) and a
        // central difference (step 1e-7 of α_cr: truncation ~1e-13, round-off ~1e-8
        // relative); the slope C at t = 0 and 0 at t_cr, the force μ F_z there
        let friction = Friction::default();
        let (c, fz) = (137e3, 11894.6);
        let (mu0, mu) = (friction.mu_static, friction.mu_dynamic);
        let t_cr = 3.0 * mu0 * fz / c;
        let phi2 = c * c / (3.0 * fz * mu0) * (mu / mu0 - 2.0);
        let phi3 = c.powi(3) / (9.0 * fz * fz * mu0 * mu0) * (1.0 - 2.0 * mu / (3.0 * mu0));
        for k in -60..=60 {
            let t = t_cr * k as f64 / 50.0; // beyond t_cr at both ends
            let alpha = t.atan();
            let force = brush_lateral_force(t, c, fz, &friction);
            let reference = paper_brush(alpha, c, fz, mu0, mu);
            assert!(
                (force - reference).abs() <= 1e-12 * fz,
                "t = {t}: {force} vs {reference}"
            );
            let d = brush(
                Dual::<1>::variable(t, 0),
                c,
                Dual::from(t_cr),
                Dual::from(fz),
                &friction,
            );
            let slope = if t.abs() <= t_cr {
                c + 2.0 * phi2 * t.abs() + 3.0 * phi3 * t * t
            } else {
                0.0
            };
            assert!(
                (d.eps[0] - slope).abs() <= 1e-12 * c,
                "t = {t}: {} vs {slope}",
                d.eps[0]
            );
            if (t.abs() - t_cr).abs() > 1e-6 * t_cr {
                let e = 1e-7 * t_cr;
                let fd = (brush_lateral_force(t + e, c, fz, &friction)
                    - brush_lateral_force(t - e, c, fz, &friction))
                    / (2.0 * e);
                assert!(
                    (d.eps[0] - fd).abs() <= 1e-6 * c,
                    "t = {t}: {} vs {fd}",
                    d.eps[0]
                );
            }
        }
        let at = |t: f64| {
            brush(
                Dual::<1>::variable(t, 0),
                c,
                Dual::from(t_cr),
                Dual::from(fz),
                &friction,
            )
        };
        assert!((at(0.0).eps[0] - c).abs() <= 1e-9 * c);
        assert!(at(t_cr).eps[0].abs() <= 1e-9 * c);
        assert!((at(t_cr).re - mu * fz).abs() <= 1e-9 * fz);
        // the load's derivative: dF/dF_z through t_cr, against a central difference
        let by_load = brush(
            Dual::<1>::from(0.5 * t_cr),
            c,
            Dual::variable(fz, 0) * Dual::from(3.0 * mu0 / c),
            Dual::variable(fz, 0),
            &friction,
        );
        let e = 1e-6 * fz;
        let fd = (brush_lateral_force(0.5 * t_cr, c, fz + e, &friction)
            - brush_lateral_force(0.5 * t_cr, c, fz - e, &friction))
            / (2.0 * e);
        assert!(
            (by_load.eps[0] - fd).abs() <= 1e-7 * fd.abs(),
            "{} vs {fd}",
            by_load.eps[0]
        );
    }

    #[test]
    fn the_axle_loads_of_table_i_are_the_statics() {
        // reference: the design notes' statics of Table I (F_z,F ≈ 11894.6 N,
        // F_z,R ≈ 11304.3 N, F_z,T ≈ 10008.0 N, to their 0.1 N) and their sum (m1 + m2) g
        let (car, t) = table_i();
        let [front, rear, trailer] = axle_loads(&car, &t);
        assert!((front - 11894.6).abs() < 0.1, "{front}");
        assert!((rear - 11304.3).abs() < 0.1, "{rear}");
        assert!((trailer - 10008.0).abs() < 0.1, "{trailer}");
        let sum = (car.mass + t.mass) * GRAVITY;
        assert!((front + rear + trailer - sum).abs() < 1e-9 * sum);
    }

    #[test]
    fn the_linearisation_of_the_brush_model_is_the_linear_model() {
        // reference: the linear model's A and B (its own code: the axle forces as rows over
        // the states) against the Jacobian of the brush model at straight running from the
        // duals; equal to round-off (1e-12 of each column's size), at three speeds
        let (car, t) = table_i();
        for speed in [8.0, 25.0, 40.0] {
            let s = system(&car, &t, speed);
            let trailer = Trailer {
                mass: Dual::<5>::from(t.mass),
                yaw_inertia: Dual::from(t.yaw_inertia),
                cog: Dual::from(t.cog),
                axle: t.axle,
                cornering_stiffness: t.cornering_stiffness,
            };
            let plant = Plant::new(&car, &trailer, &Friction::default(), speed);
            let x: [Dual<5>; 4] = std::array::from_fn(|i| Dual::variable(0.0, i));
            let dx = plant.derivative(&x, Dual::variable(0.0, 4));
            for j in 0..5 {
                let column: [f64; 4] =
                    std::array::from_fn(|i| if j < 4 { s.a[i][j] } else { s.b[i] });
                let size = column.iter().fold(0.0_f64, |a, c| a.max(c.abs()));
                for i in 0..4 {
                    assert!(
                        (dx[i].eps[j] - column[i]).abs() <= 1e-12 * size,
                        "V {speed}: ∂ẋ{i}/∂x{j}: {} vs {}",
                        dx[i].eps[j],
                        column[i]
                    );
                }
            }
        }
    }

    #[test]
    fn the_jacobian_of_a_step_is_the_derivative() {
        // reference: central differences of the plain RK4 step of the brush model (steps
        // 1e-6 of each variable's scale; truncation ~1e-12, round-off ~1e-9 relative),
        // tolerance 1e-6 of the column's size; a state where all three tyres are well into
        // their nonlinear range (|t|/t_cr ≈ 0.2–0.6)
        let (car, t) = table_i();
        let friction = Friction::default();
        let speed = 25.0;
        let x = [-0.8, 0.2, 0.1, 0.05];
        let (u0, u1) = (0.05, 0.055);
        let step = |x: &[f64; 4], t: &Trailer<f64>, offset: f64| {
            Plant::new(&car, t, &friction, speed).step(x, u0 + offset, u1 + offset, 0.01, 2)
        };
        let plain = Plant::new(&car, &t, &friction, speed);
        let loads = axle_loads(&car, &t);
        let slips = plain.slips(&x, u0);
        for i in 0..3 {
            let ratio = slips[i].abs() / plain.critical[i];
            assert!((0.1..0.9).contains(&ratio), "axle {i}: {ratio}");
            assert!(loads[i] > 0.0);
        }
        let trailer = Trailer {
            mass: Dual::<8>::variable(t.mass, 4),
            yaw_inertia: Dual::variable(t.yaw_inertia, 5),
            cog: Dual::variable(t.cog, 6),
            axle: t.axle,
            cornering_stiffness: t.cornering_stiffness,
        };
        let xd: [Dual<8>; 4] = std::array::from_fn(|i| Dual::variable(x[i], i));
        let offset = Dual::variable(0.0, 7);
        let next = Plant::new(&car, &trailer, &friction, speed).step(
            &xd,
            Dual::from(u0) + offset,
            Dual::from(u1) + offset,
            0.01,
            2,
        );
        let base = step(&x, &t, 0.0);
        for i in 0..4 {
            assert!((next[i].re - base[i]).abs() <= 1e-14 * base[i].abs().max(1e-3));
        }
        let scales = [0.1, 0.1, 0.01, 0.1, t.mass, t.yaw_inertia, t.cog, 0.01];
        for j in 0..8 {
            let e = 1e-6 * scales[j];
            let moved = |sign: f64| {
                let (mut xm, mut tm, mut off) = (x, t, 0.0);
                match j {
                    0..4 => xm[j] += sign * e,
                    4 => tm.mass += sign * e,
                    5 => tm.yaw_inertia += sign * e,
                    6 => tm.cog += sign * e,
                    _ => off = sign * e,
                }
                step(&xm, &tm, off)
            };
            let (p, m) = (moved(1.0), moved(-1.0));
            let column: [f64; 4] = std::array::from_fn(|i| (p[i] - m[i]) / (2.0 * e));
            let size = column.iter().fold(0.0_f64, |a, c| a.max(c.abs()));
            for i in 0..4 {
                assert!(
                    (next[i].eps[j] - column[i]).abs() <= 1e-6 * size,
                    "∂x{i}/∂z{j}: {} vs {}",
                    next[i].eps[j],
                    column[i]
                );
            }
        }
    }

    #[test]
    fn the_v_crit_gradient_is_the_derivative() {
        // reference: V_crit of Table I with each parameter moved by ±0.1 %, bisected to
        // 1e-10 m/s (central difference, truncation ~1e-6 relative); tolerance 1e-4 relative
        let (car, t) = table_i();
        let search = CriticalSpeedSearch {
            tolerance_mps: 1e-10,
            ..CriticalSpeedSearch::default()
        };
        let c = critical_speed(&car, &t, &search, None).unwrap();
        assert_eq!(c.crossing, Crossing::Hopf);
        let g = critical_speed_gradient(&car, &t, &c);
        for j in 0..3 {
            let moved = |factor: f64| {
                let mut m = t;
                match j {
                    0 => m.mass *= factor,
                    1 => m.yaw_inertia *= factor,
                    _ => m.cog *= factor,
                }
                critical_speed(&car, &m, &search, None).unwrap().v_crit_mps
            };
            let value = [t.mass, t.yaw_inertia, t.cog][j];
            let fd = (moved(1.001) - moved(0.999)) / (0.002 * value);
            assert!(
                (g[j] - fd).abs() <= 1e-4 * fd.abs(),
                "{j}: {} vs {fd}",
                g[j]
            );
        }
    }
}
