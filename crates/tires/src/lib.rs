//! Lateral tire force models for single-track vehicle models.
//!
//! A tire model maps the slip angle α \[rad\] (the angle between the wheel plane and the
//! velocity of the wheel centre, positive when the force it produces is positive) to a
//! lateral force F^lat \[N\]. Two models are provided:
//!
//! * [`BrushTire`]: the brush model of the paper's appendix, eq. (14)–(15): a cubic
//!   polynomial in tan α up to the critical slip angle α_cr, full sliding (F_z·μ) beyond.
//!   It is C¹ at α = 0 (the tan²α·sgn α term) and only C⁰ at ±α_cr.
//! * [`LinearTire`]: F = C·α, the small-slip limit of every model.
//! * [`MagicFormulaTire`]: Pacejka's Magic Formula, simplified form,
//!   F = D·sin(C·atan(B·α − E·(B·α − atan(B·α)))) with D = μ_p·F_z; smooth.
//!
//! [`TireLaw`] chooses one per axle (an enum, so the hot loop dispatches without
//! allocation); [`TireLawSpec`] is its form in a vehicle file (serde, `law = "…"`), validated
//! when built ([`TireLawSpec::build`]). [`TireLaw::kinks`] declares where a law is not smooth
//! (the brush tyre's α = 0 and |α| = α_cr), for switching functions.
//!
//! Both are generic over the scalar type through [`num_dual::DualNum`], so exact
//! derivatives (Jacobians for Newton's method, linearisations) flow through them.
//!
//! ```
//! use tires::{BrushTire, TireModel};
//! use num_dual::{first_derivative, Dual64};
//!
//! // front tire of Table I: C = 137 kN/rad, vertical load 11.9 kN, μ0 = 0.9, μ = 0.6
//! let tire = BrushTire::new(137e3, 11894.6, 0.9, 0.6).unwrap();
//! // the slope at α = 0 is the cornering stiffness, exactly
//! let (f0, slope) = first_derivative(|a: Dual64| tire.lateral_force(a), 0.0);
//! assert_eq!(f0, 0.0);
//! assert!((slope - 137e3).abs() < 1e-6);
//! // far beyond α_cr the tire slides with the dynamic friction force F_z·μ
//! assert!((tire.lateral_force(0.5_f64) - 11894.6 * 0.6).abs() < 1e-9);
//! ```

use num_dual::DualNum;
use serde::{Deserialize, Serialize};

/// Errors raised when a tire is built from unphysical parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TireError {
    /// A parameter that must be strictly positive and finite is not.
    #[error("tire parameter `{name}` must be positive and finite, got {value}")]
    NotPositive {
        /// parameter name
        name: &'static str,
        /// offending value
        value: f64,
    },
    /// The dynamic friction coefficient exceeds the static one.
    #[error("dynamic friction μ = {mu} must not exceed static friction μ0 = {mu0} (0 < μ ≤ μ0)")]
    FrictionOrder {
        /// dynamic friction coefficient μ
        mu: f64,
        /// static friction coefficient μ0
        mu0: f64,
    },
    /// A parameter outside the range where the law is meaningful.
    #[error("tire parameter `{name}` = {value}: expected {expected}")]
    OutOfRange {
        /// parameter name
        name: &'static str,
        /// offending value
        value: f64,
        /// what was expected
        expected: &'static str,
    },
    /// The Magic Formula's peak needs exactly one of `peak_force` and `peak_friction`.
    #[error(
        "magic formula: give exactly one of `peak_force` (D) and `peak_friction` (D = μ_p·F_z), got {given}"
    )]
    PeakChoice {
        /// how many of the two were given
        given: usize,
    },
    /// A given stiffness factor B disagrees with the axle's cornering stiffness.
    #[error(
        "magic formula: `stiffness_factor` gives B·C·D = {bcd} N/rad, but the axle's cornering stiffness is {cornering_stiffness} N/rad (omit B to derive it)"
    )]
    StiffnessMismatch {
        /// B·C·D \[N/rad\]
        bcd: f64,
        /// the axle's cornering stiffness \[N/rad\]
        cornering_stiffness: f64,
    },
}

/// A lateral tire force model F^lat(α).
///
/// Implementations must be odd in α and generic over the scalar so that automatic
/// differentiation passes through them.
pub trait TireModel {
    /// Lateral force F^lat \[N\] at slip angle α \[rad\].
    fn lateral_force<D: DualNum<Primitive = f64> + Copy>(&self, alpha: D) -> D;

    /// Lateral force \[N\] given tan α instead of α (|α| < π/2). Slip angles are atan of
    /// velocity ratios, and the brush model is a polynomial in tan α, so this form skips
    /// an atan/tan pair in the hot loop.
    fn lateral_force_from_tan<D: DualNum<Primitive = f64> + Copy>(&self, tan_alpha: D) -> D {
        self.lateral_force(tan_alpha.atan())
    }

    /// Slip angle \[rad\] beyond which the contact patch slides completely, if the model
    /// has one (α_cr of eq. 15 for the brush tire).
    fn critical_slip_angle(&self) -> Option<f64>;

    /// Cornering stiffness C = dF/dα at α = 0 \[N/rad\].
    fn cornering_stiffness(&self) -> f64;
}

/// Brush tire model, paper eq. (14)–(15).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BrushTire {
    /// cornering stiffness C \[N/rad\]
    pub cornering_stiffness: f64,
    /// vertical load F_z \[N\]
    pub vertical_load: f64,
    /// static friction coefficient μ0 \[-\]
    pub mu_static: f64,
    /// dynamic (sliding) friction coefficient μ \[-\]
    pub mu_dynamic: f64,
    // derived coefficients of eq. (15), cached
    phi1: f64,
    phi2: f64,
    phi3: f64,
    alpha_cr: f64,
    tan_alpha_cr: f64,
}

impl BrushTire {
    /// Builds a brush tire from C \[N/rad\], F_z \[N\], μ0 and μ (eq. 15).
    ///
    /// # Errors
    /// [`TireError`] if a parameter is not positive or μ > μ0.
    pub fn new(
        cornering_stiffness: f64,
        vertical_load: f64,
        mu_static: f64,
        mu_dynamic: f64,
    ) -> Result<Self, TireError> {
        for (name, value) in [
            ("cornering_stiffness", cornering_stiffness),
            ("vertical_load", vertical_load),
            ("mu_static", mu_static),
            ("mu_dynamic", mu_dynamic),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(TireError::NotPositive { name, value });
            }
        }
        if mu_dynamic > mu_static {
            return Err(TireError::FrictionOrder {
                mu: mu_dynamic,
                mu0: mu_static,
            });
        }
        let (c, fz, mu0, mu) = (cornering_stiffness, vertical_load, mu_static, mu_dynamic);
        let s = 3.0 * fz * mu0; // 3 F_z μ0
        Ok(Self {
            cornering_stiffness: c,
            vertical_load: fz,
            mu_static: mu0,
            mu_dynamic: mu,
            phi1: c,
            phi2: c * c / s * (mu / mu0 - 2.0),
            phi3: c * c * c / (s * s) * (1.0 - 2.0 * mu / (3.0 * mu0)),
            alpha_cr: (s / c).atan(),
            tan_alpha_cr: s / c,
        })
    }

    /// Coefficients (φ1, φ2, φ3) of eq. (15).
    pub fn coefficients(&self) -> (f64, f64, f64) {
        (self.phi1, self.phi2, self.phi3)
    }

    /// Sliding force F_z·μ \[N\] reached for |α| > α_cr.
    pub fn sliding_force(&self) -> f64 {
        self.vertical_load * self.mu_dynamic
    }
}

impl TireModel for BrushTire {
    /// Eq. (14): φ1 tan α + φ2 tan²α sgn α + φ3 tan³α for |α| ≤ α_cr, F_z μ sgn α beyond.
    fn lateral_force<D: DualNum<Primitive = f64> + Copy>(&self, alpha: D) -> D {
        let a = alpha.re();
        if a.abs() > self.alpha_cr {
            // constant: all derivatives vanish
            return D::from(self.sliding_force() * a.signum());
        }
        let t = alpha.tan();
        // tan²α·sgn α = tan α·|tan α|: C¹ at 0 and exact for dual numbers
        let t_abs = if a < 0.0 { -t } else { t };
        t * (D::from(self.phi1) + t_abs * self.phi2 + t * t * self.phi3)
    }

    /// Eq. (14) in terms of t = tan α: |t| > tan α_cr slides, else φ1 t + φ2 t|t| + φ3 t³.
    fn lateral_force_from_tan<D: DualNum<Primitive = f64> + Copy>(&self, t: D) -> D {
        let tr = t.re();
        if tr.abs() > self.tan_alpha_cr {
            return D::from(self.sliding_force() * tr.signum());
        }
        let t_abs = if tr < 0.0 { -t } else { t };
        t * (D::from(self.phi1) + t_abs * self.phi2 + t * t * self.phi3)
    }

    fn critical_slip_angle(&self) -> Option<f64> {
        Some(self.alpha_cr)
    }

    fn cornering_stiffness(&self) -> f64 {
        self.cornering_stiffness
    }
}

/// Linear tire F = C·α: the small-slip limit, useful as a reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinearTire {
    /// cornering stiffness C \[N/rad\]
    pub cornering_stiffness: f64,
}

impl TireModel for LinearTire {
    fn lateral_force<D: DualNum<Primitive = f64> + Copy>(&self, alpha: D) -> D {
        alpha * self.cornering_stiffness
    }

    fn critical_slip_angle(&self) -> Option<f64> {
        None
    }

    fn cornering_stiffness(&self) -> f64 {
        self.cornering_stiffness
    }
}

/// Magic Formula lateral tyre (Pacejka, *Tire and Vehicle Dynamics*, 3rd ed. 2012, §4.3.2,
/// eq. 4.49, the "simplified" form without shifts):
///
/// F(α) = D·sin(C·atan(B·α − E·(B·α − atan(B·α)))),
///
/// with stiffness factor B \[1/rad\], shape factor C \[-\], peak value D \[N\] and curvature
/// factor E \[-\]. The cornering stiffness is dF/dα(0) = B·C·D. The load dependence is the
/// form's own: D = μ_p·F_z (peak friction μ_p, vertical load F_z), B, C, E constant (built by
/// [`MagicFormulaTire::from_peak_friction`]). The law is smooth (C^∞) in α: it has no kinks and
/// declares no switching functions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MagicFormulaTire {
    /// stiffness factor B \[1/rad\]
    pub stiffness_factor: f64,
    /// shape factor C \[-\], 0 < C < 2
    pub shape_factor: f64,
    /// peak value D \[N\]
    pub peak_force: f64,
    /// curvature factor E \[-\], E ≤ 1
    pub curvature_factor: f64,
}

impl MagicFormulaTire {
    /// A Magic Formula tyre from B \[1/rad\], C, D \[N\], E.
    ///
    /// # Errors
    /// [`TireError::NotPositive`] for B, C or D not positive and finite,
    /// [`TireError::OutOfRange`] for C ≥ 2 (the force would change sign at large slip) or
    /// E > 1 (the curve folds back before the peak) or E not finite.
    pub fn new(
        stiffness_factor: f64,
        shape_factor: f64,
        peak_force: f64,
        curvature_factor: f64,
    ) -> Result<Self, TireError> {
        for (name, value) in [
            ("stiffness_factor", stiffness_factor),
            ("shape_factor", shape_factor),
            ("peak_force", peak_force),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(TireError::NotPositive { name, value });
            }
        }
        if shape_factor >= 2.0 {
            return Err(TireError::OutOfRange {
                name: "shape_factor",
                value: shape_factor,
                expected: "0 < C < 2 (C ≥ 2 reverses the force at large slip)",
            });
        }
        if !(curvature_factor.is_finite() && curvature_factor <= 1.0) {
            return Err(TireError::OutOfRange {
                name: "curvature_factor",
                value: curvature_factor,
                expected: "E ≤ 1 (E > 1 folds the curve back before its peak)",
            });
        }
        Ok(Self {
            stiffness_factor,
            shape_factor,
            peak_force,
            curvature_factor,
        })
    }

    /// The tyre whose peak is D = μ_p·F_z and whose cornering stiffness is C_α = B·C·D,
    /// i.e. B = C_α/(C·D): the form's load dependence with a given stiffness at this load.
    ///
    /// # Errors
    /// As [`MagicFormulaTire::new`], and [`TireError::NotPositive`] for C_α, F_z or μ_p.
    pub fn from_peak_friction(
        cornering_stiffness: f64,
        vertical_load: f64,
        peak_friction: f64,
        shape_factor: f64,
        curvature_factor: f64,
    ) -> Result<Self, TireError> {
        for (name, value) in [
            ("cornering_stiffness", cornering_stiffness),
            ("vertical_load", vertical_load),
            ("peak_friction", peak_friction),
            ("shape_factor", shape_factor),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(TireError::NotPositive { name, value });
            }
        }
        let d = peak_friction * vertical_load;
        Self::new(
            cornering_stiffness / (shape_factor * d),
            shape_factor,
            d,
            curvature_factor,
        )
    }

    /// Slip angle \[rad\] of the peak force D: B·α − E·(B·α − atan(B·α)) = tan(π/(2C)), solved
    /// by Newton's method on the monotone left side (for C ≤ 1 the force has no peak: +∞).
    pub fn peak_slip_angle(&self) -> f64 {
        if self.shape_factor <= 1.0 {
            return f64::INFINITY;
        }
        let target = (std::f64::consts::FRAC_PI_2 / self.shape_factor).tan();
        let e = self.curvature_factor;
        // φ(x) = x − E(x − atan x) with x = Bα; φ'(x) = 1 − E + E/(1 + x²) > 0 for E ≤ 1
        let mut x = target;
        for _ in 0..60 {
            let phi = x - e * (x - x.atan()) - target;
            let dphi = 1.0 - e + e / (1.0 + x * x);
            let step = phi / dphi;
            x -= step;
            if step.abs() <= 1e-15 * x.abs().max(1.0) {
                break;
            }
        }
        x / self.stiffness_factor
    }
}

impl TireModel for MagicFormulaTire {
    fn lateral_force<D: DualNum<Primitive = f64> + Copy>(&self, alpha: D) -> D {
        let x = alpha * self.stiffness_factor;
        let phi = x - (x - x.atan()) * self.curvature_factor;
        (phi.atan() * self.shape_factor).sin() * self.peak_force
    }

    fn critical_slip_angle(&self) -> Option<f64> {
        None
    }

    fn cornering_stiffness(&self) -> f64 {
        self.stiffness_factor * self.shape_factor * self.peak_force
    }
}

/// A tyre law chosen per axle: the brush tyre of the paper (default), the Magic Formula or
/// the linear tyre. Dispatches [`TireModel`] without dynamic allocation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum TireLaw {
    /// [`BrushTire`], eq. (14)–(15), with kinks at α = 0 (C¹) and |α| = α_cr (C⁰)
    Brush(BrushTire),
    /// [`MagicFormulaTire`] (smooth)
    MagicFormula(MagicFormulaTire),
    /// [`LinearTire`] (smooth)
    Linear(LinearTire),
}

/// Where a tyre law is not smooth: the places an integrator must land on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TireKinks {
    /// the law is only C¹ at α = 0 (the brush tyre's tan²α·sgn α): switching function tan α
    pub at_zero: bool,
    /// the law is only C⁰ at |α| = α_cr \[rad\]: switching function tan²α − tan²α_cr
    pub sliding_limit: Option<f64>,
}

impl TireLaw {
    /// The kinks of the law (none for the smooth laws).
    pub fn kinks(&self) -> TireKinks {
        match self {
            Self::Brush(t) => TireKinks {
                at_zero: true,
                sliding_limit: Some(t.critical_slip_angle().unwrap_or(f64::INFINITY)),
            },
            Self::MagicFormula(_) | Self::Linear(_) => TireKinks {
                at_zero: false,
                sliding_limit: None,
            },
        }
    }

    /// Slip angle \[rad\] beyond which the tyre is saturated (no more lateral force for more
    /// slip): α_cr of the brush tyre (full sliding), the Magic Formula's peak slip
    /// ([`MagicFormulaTire::peak_slip_angle`]), +∞ for the linear tyre. A validity guard
    /// ("the axle slides") compares |α| with it.
    pub fn saturation_slip_angle(&self) -> f64 {
        match self {
            Self::Brush(t) => t.critical_slip_angle().unwrap_or(f64::INFINITY),
            Self::MagicFormula(t) => t.peak_slip_angle(),
            Self::Linear(_) => f64::INFINITY,
        }
    }

    /// Name of the law as the vehicle file spells it (`brush`, `magic_formula`, `linear`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::Brush(_) => "brush",
            Self::MagicFormula(_) => "magic_formula",
            Self::Linear(_) => "linear",
        }
    }
}

impl TireModel for TireLaw {
    #[inline]
    fn lateral_force<D: DualNum<Primitive = f64> + Copy>(&self, alpha: D) -> D {
        match self {
            Self::Brush(t) => t.lateral_force(alpha),
            Self::MagicFormula(t) => t.lateral_force(alpha),
            Self::Linear(t) => t.lateral_force(alpha),
        }
    }

    #[inline]
    fn lateral_force_from_tan<D: DualNum<Primitive = f64> + Copy>(&self, tan_alpha: D) -> D {
        match self {
            Self::Brush(t) => t.lateral_force_from_tan(tan_alpha),
            Self::MagicFormula(t) => t.lateral_force_from_tan(tan_alpha),
            Self::Linear(t) => t.lateral_force_from_tan(tan_alpha),
        }
    }

    fn critical_slip_angle(&self) -> Option<f64> {
        match self {
            Self::Brush(t) => t.critical_slip_angle(),
            Self::MagicFormula(t) => t.critical_slip_angle(),
            Self::Linear(t) => t.critical_slip_angle(),
        }
    }

    fn cornering_stiffness(&self) -> f64 {
        match self {
            Self::Brush(t) => t.cornering_stiffness(),
            Self::MagicFormula(t) => t.cornering_stiffness(),
            Self::Linear(t) => t.cornering_stiffness(),
        }
    }
}

/// The tyre law of one axle as a vehicle file gives it (`law = "brush" | "magic_formula" |
/// "linear"`); the axle's cornering stiffness and static load complete it
/// ([`TireLawSpec::build`]).
///
/// ```toml
/// tire = { law = "magic_formula", shape_factor = 1.536, curvature_factor = 0.0, peak_friction = 0.9 }
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "snake_case", deny_unknown_fields)]
pub enum TireLawSpec {
    /// The brush tyre, eq. (14)–(15) (the default); its friction coefficients default to
    /// the vehicle's `[friction]` table.
    Brush {
        /// μ0 \[-\] of this axle (default: the vehicle's)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        mu_static: Option<f64>,
        /// μ \[-\] of this axle (default: the vehicle's)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        mu_dynamic: Option<f64>,
    },
    /// The Magic Formula ([`MagicFormulaTire`]). D is `peak_force` \[N\] or
    /// `peak_friction`·F_z (exactly one); B is `stiffness_factor` \[1/rad\] if given (then B·C·D
    /// must equal the axle's cornering stiffness within 1e-6), else C_α/(C·D).
    MagicFormula {
        /// C \[-\]
        shape_factor: f64,
        /// E \[-\]
        #[serde(default)]
        curvature_factor: f64,
        /// μ_p \[-\]: D = μ_p·F_z
        #[serde(default, skip_serializing_if = "Option::is_none")]
        peak_friction: Option<f64>,
        /// D \[N\]
        #[serde(default, skip_serializing_if = "Option::is_none")]
        peak_force: Option<f64>,
        /// B \[1/rad\]
        #[serde(default, skip_serializing_if = "Option::is_none")]
        stiffness_factor: Option<f64>,
    },
    /// F = C_α·α.
    Linear {},
}

impl Default for TireLawSpec {
    /// The brush tyre with the vehicle's friction.
    fn default() -> Self {
        Self::Brush {
            mu_static: None,
            mu_dynamic: None,
        }
    }
}

impl TireLawSpec {
    /// The tyre law for an axle of cornering stiffness C_α \[N/rad\] and static load F_z \[N\],
    /// with the vehicle's friction μ0, μ for the brush tyre.
    ///
    /// # Errors
    /// [`TireError`] naming the parameter: not positive, out of range, D given twice or not
    /// at all ([`TireError::PeakChoice`]), B·C·D ≠ C_α ([`TireError::StiffnessMismatch`]).
    pub fn build(
        &self,
        cornering_stiffness: f64,
        vertical_load: f64,
        mu_static: f64,
        mu_dynamic: f64,
    ) -> Result<TireLaw, TireError> {
        match *self {
            Self::Brush {
                mu_static: mu0,
                mu_dynamic: mu,
            } => BrushTire::new(
                cornering_stiffness,
                vertical_load,
                mu0.unwrap_or(mu_static),
                mu.unwrap_or(mu_dynamic),
            )
            .map(TireLaw::Brush),
            Self::Linear {} => {
                if !(cornering_stiffness.is_finite() && cornering_stiffness > 0.0) {
                    return Err(TireError::NotPositive {
                        name: "cornering_stiffness",
                        value: cornering_stiffness,
                    });
                }
                Ok(TireLaw::Linear(LinearTire {
                    cornering_stiffness,
                }))
            }
            Self::MagicFormula {
                shape_factor,
                curvature_factor,
                peak_friction,
                peak_force,
                stiffness_factor,
            } => {
                let d = match (peak_friction, peak_force) {
                    (Some(mu), None) => {
                        if !(mu.is_finite() && mu > 0.0) {
                            return Err(TireError::NotPositive {
                                name: "peak_friction",
                                value: mu,
                            });
                        }
                        if !(vertical_load.is_finite() && vertical_load > 0.0) {
                            return Err(TireError::NotPositive {
                                name: "vertical_load",
                                value: vertical_load,
                            });
                        }
                        mu * vertical_load
                    }
                    (None, Some(d)) => d,
                    (Some(_), Some(_)) => return Err(TireError::PeakChoice { given: 2 }),
                    (None, None) => return Err(TireError::PeakChoice { given: 0 }),
                };
                if !(shape_factor.is_finite() && shape_factor > 0.0) {
                    return Err(TireError::NotPositive {
                        name: "shape_factor",
                        value: shape_factor,
                    });
                }
                if !(d.is_finite() && d > 0.0) {
                    return Err(TireError::NotPositive {
                        name: "peak_force",
                        value: d,
                    });
                }
                let b = match stiffness_factor {
                    Some(b) => {
                        let bcd = b * shape_factor * d;
                        let close =
                            (bcd - cornering_stiffness).abs() <= 1e-6 * cornering_stiffness.abs();
                        if !close {
                            return Err(TireError::StiffnessMismatch {
                                bcd,
                                cornering_stiffness,
                            });
                        }
                        b
                    }
                    None => {
                        if !(cornering_stiffness.is_finite() && cornering_stiffness > 0.0) {
                            return Err(TireError::NotPositive {
                                name: "cornering_stiffness",
                                value: cornering_stiffness,
                            });
                        }
                        cornering_stiffness / (shape_factor * d)
                    }
                };
                MagicFormulaTire::new(b, shape_factor, d, curvature_factor)
                    .map(TireLaw::MagicFormula)
            }
        }
    }
}
