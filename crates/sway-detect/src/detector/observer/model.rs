//! The observer's own car–trailer model: the paper's single-track model linearised about
//! straight running at constant speed with linear tyres (the linearisation of eq. 9–11),
//! written in the conventional lateral states of the car instead of the paper's Appellian
//! generalized velocities.
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
//! by eq. 5), so the two are the same linear model: [`LinearModel::critical_speed`] gives
//! the toolkit's linear V_crit of Table I (a test checks it to 10⁻⁶).
//!
//! # Equations (Newton–Euler, linear in the lateral states)
//! Slip angles (eq. 2 linearised, small angles):
//! α_F = δ − (v + (f − d) r)/V, α_R = −(v + (c − d) r)/V,
//! α_T = θ − (v − (d + l) r − l θ̇)/V; linear tyres F_i = C_i α_i (the brush tyre's slope at
//! zero slip, eq. 14–15). Lateral accelerations: the car's a1 = v̇ + V r at C1, the
//! trailer's a2 = v̇ − (d + h) ṙ − h θ̈ + V r at C2. With Y the hitch's lateral force on the
//! trailer and F_w a lateral force on the trailer at C2 (a gust; zero in the model, the
//! observer's process noise):
//! - car, lateral: m1 a1 = F_F + F_R − Y;
//! - car, yaw about C1: J1 ṙ = (f − d) F_F + (c − d) F_R + d Y;
//! - trailer, lateral: m2 a2 = F_T + Y + F_w;
//! - trailer, yaw about C2: J2 (ṙ + θ̈) = h Y − (l − h) F_T.
//!
//! Eliminating Y leaves M [v̇, ṙ, θ̈]ᵀ = K x + B_δ δ + B_w F_w with
//! ```text
//!     | m1 + m2   −m2 (d + h)          −m2 h        |
//! M = | −d m2     J1 + d m2 (d + h)    d m2 h       |
//!     | −h m2     J2 + m2 h (d + h)    J2 + m2 h²   |
//! ```
//! and the right-hand sides F_F + F_R + F_T − (m1 + m2) V r,
//! (f − d) F_F + (c − d) F_R − d F_T + d m2 V r and −l F_T + h m2 V r (B_w = [1, −d, −h]ᵀ).
//! With θ̇ = θ̇ this is ẋ = A x + B δ (+ G F_w). The measured lateral acceleration is that of C1, where the
//! observer assumes the sensor sits: a_y = v̇ + V r.
//!
//! Everything is written once over a scalar type, so the same code gives values (`f64`) and
//! exact derivatives with respect to the trailer's parameters and the speed (forward-mode
//! dual numbers).

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

/// ẋ = A x + B δ + G F_w at one speed: the state matrix A \[1/s and alike\], the steering
/// column B (per rad of road-wheel angle) and the column G of a lateral force on the
/// trailer at C2 (per N).
#[derive(Debug, Clone, Copy)]
pub(crate) struct System<S> {
    pub(crate) a: Mat4<S>,
    pub(crate) b: [S; 4],
    pub(crate) g: [S; 4],
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

/// The linear model's matrices at speed `v` \[m/s\] (the module's equations).
pub(crate) fn system<S: Scalar>(car: &CarParams, t: &Trailer<S>, v: S) -> System<S> {
    let k = |x: f64| S::from(x);
    let (m1, j1) = (k(car.mass), k(car.yaw_inertia));
    let (f, d, c) = (car.front_axle, car.cog, car.rear_axle);
    let (m2, j2, h, l) = (t.mass, t.yaw_inertia, t.cog, t.axle);
    let dh = k(d) + h;
    let m = [
        [m1 + m2, -(m2 * dh), -(m2 * h)],
        [-(k(d) * m2), j1 + k(d) * m2 * dh, k(d) * m2 * h],
        [-(h * m2), j2 + m2 * h * dh, j2 + m2 * h * h],
    ];
    let inv = inverse3(&m);
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
    let force_column = [k(1.0), k(-d), -h];
    // [v̇, ṙ, θ̈] = M⁻¹ (rhs): rows 0, 1, 3 of the state equation; row 2 is θ̇ = θ̇
    let solve = |col: &dyn Fn(usize) -> S| -> [S; 3] {
        std::array::from_fn(|i| inv[i][0] * col(0) + inv[i][1] * col(1) + inv[i][2] * col(2))
    };
    let mut a = [[zero; 4]; 4];
    let mut b = [zero; 4];
    let mut g = [zero; 4];
    for j in 0..4 {
        let acc = solve(&|i| rhs[i][j]);
        a[0][j] = acc[0];
        a[1][j] = acc[1];
        a[3][j] = acc[2];
    }
    a[2][3] = k(1.0);
    let acc = solve(&|i| rhs[i][4]);
    (b[0], b[1], b[3]) = (acc[0], acc[1], acc[2]);
    let acc = solve(&|i| force_column[i]);
    (g[0], g[1], g[3]) = (acc[0], acc[1], acc[2]);
    System { a, b, g }
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

/// The exact discretisation of ẋ = A x + B u over a step `h` with the input linear in time
/// (first-order hold from u_k to u_{k+1}), its series truncated after the 4th power of hA
/// (what the classical Runge–Kutta method gives for a linear system), on `substeps` equal
/// substeps: per substep x ← Φ x + Γ u_j + Λ (u_{j+1} − u_j) with Φ = Σ_{i≤4} T^i/i!,
/// Γ = Σ_{i≤3} T^i/(i+1)! · h_s B, Λ = Σ_{i≤2} T^i/(i+2)! · h_s B, T = h_s A.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Discrete<S> {
    pub(crate) phi: Mat4<S>,
    pub(crate) gamma: [S; 4],
    pub(crate) lambda: [S; 4],
    pub(crate) substeps: usize,
}

impl<S: Scalar> Discrete<S> {
    /// The discretisation of `a`, `b` over `h` \[s\] in `substeps` substeps.
    pub(crate) fn new(a: &Mat4<S>, b: &[S; 4], h: f64, substeps: usize) -> Self {
        let hs = h / substeps as f64;
        let t: Mat4<S> = a.map(|row| row.map(|x| x * S::from(hs)));
        let identity = |i: usize, j: usize, c: f64| S::from(if i == j { c } else { 0.0 });
        // Horner, from the innermost term: every series shares the powers of T
        let scaled = |m: &Mat4<S>, c: f64| -> Mat4<S> { m.map(|row| row.map(|x| x * S::from(c))) };
        let plus = |m: Mat4<S>, c: f64| -> Mat4<S> {
            std::array::from_fn(|i| std::array::from_fn(|j| m[i][j] + identity(i, j, c)))
        };
        // Λ-series L = I/2 + T/6 + T²/24 = I/2 + T (I/6 + T/24)
        let inner = plus(scaled(&t, 1.0 / 24.0), 1.0 / 6.0);
        let l_series = plus(mat_mul(&t, &inner), 0.5);
        // Γ-series G = I + T/2 + T²/6 + T³/24 = I + T L
        let g_series = plus(mat_mul(&t, &l_series), 1.0);
        // Φ = I + T G
        let phi = plus(mat_mul(&t, &g_series), 1.0);
        let hb = b.map(|x| x * S::from(hs));
        Discrete {
            phi,
            gamma: mat_vec(&g_series, &hb),
            lambda: mat_vec(&l_series, &hb),
            substeps,
        }
    }

    /// x after the step from `x` with the input going linearly from `u0` to `u1`.
    pub(crate) fn step(&self, x: &[S; 4], u0: S, u1: S) -> [S; 4] {
        let n = self.substeps as f64;
        let mut x = *x;
        for j in 0..self.substeps {
            let ua = u0 + (u1 - u0) * S::from(j as f64 / n);
            let du = (u1 - u0) * S::from(1.0 / n);
            let px = mat_vec(&self.phi, &x);
            x = std::array::from_fn(|i| px[i] + self.gamma[i] * ua + self.lambda[i] * du);
        }
        x
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

    #[test]
    fn the_parameter_jacobian_of_a_step_is_the_derivative() {
        // reference: central differences of the plain step (steps 1e-6 relative; their
        // truncation error ~1e-10 relative), tolerance 1e-6 relative to the column's size
        let (car, t) = table_i();
        let x = [0.1, 0.02, -0.03, 0.05];
        let step = |t: &Trailer<f64>| {
            let s = system(&car, t, 25.0);
            Discrete::new(&s.a, &s.b, 0.01, 2).step(&x, 0.01, 0.012)
        };
        let dual = Trailer {
            mass: Dual::<3>::variable(t.mass, 0),
            yaw_inertia: Dual::variable(t.yaw_inertia, 1),
            cog: Dual::variable(t.cog, 2),
            axle: t.axle,
            cornering_stiffness: t.cornering_stiffness,
        };
        let s = system(&car, &dual, Dual::from(25.0));
        let xd = x.map(Dual::from);
        let next =
            Discrete::new(&s.a, &s.b, 0.01, 2).step(&xd, Dual::from(0.01), Dual::from(0.012));
        for j in 0..3 {
            let mut plus = t;
            let mut minus = t;
            let value = [t.mass, t.yaw_inertia, t.cog][j];
            let h = 1e-6 * value;
            match j {
                0 => (plus.mass, minus.mass) = (value + h, value - h),
                1 => (plus.yaw_inertia, minus.yaw_inertia) = (value + h, value - h),
                _ => (plus.cog, minus.cog) = (value + h, value - h),
            }
            let (p, m) = (step(&plus), step(&minus));
            let column: [f64; 4] = std::array::from_fn(|i| (p[i] - m[i]) / (2.0 * h));
            let size = column.iter().fold(0.0_f64, |a, c| a.max(c.abs()));
            for i in 0..4 {
                assert!(
                    (next[i].eps[j] - column[i]).abs() <= 1e-6 * size,
                    "∂x{i}/∂p{j}: {} vs {}",
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
