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
