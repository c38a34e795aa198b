//! Characteristic roots and stability charts of linear constant-coefficient delay differential
//! equations
//!
//! `x'(t) = A0·x(t) + Σ_k A_k·x(t − τ_k)`.
//!
//! General purpose: nothing here knows what the equations model.
//!
//! * [`LinearDde`] — the problem, with its characteristic matrix `Δ(λ)` and Newton polishing of
//!   roots on `det Δ(λ) = 0`;
//! * [`SemiDiscretisation`] — Insperger–Stépán first-order semi-discretisation (roots from the
//!   multipliers of the discrete map, order 2 in the step);
//! * [`ChebyshevCollocation`] — spectral collocation of the infinitesimal generator (Breda, Maset,
//!   Vermiglio), the independent second method;
//! * [`rightmost_roots`], [`spectral_abscissa`], [`unstable_root_count`] — confirmed and polished
//!   rightmost roots; [`collocation_roots`] — polished rightmost roots at one fixed degree;
//! * [`RankOneFeedback`] — single-input delayed feedback `u = −D·C·x(t − τ)`: the quasi-polynomial
//!   `p(λ) + D e^{−λτ} q(λ)`, D-subdivision (static and dynamic boundaries), exact unstable-root
//!   counting by signed crossings, stable gain intervals;
//! * [`stability_charts`] — (V, D) charts for a user closure `V ↦ (A, B, C)`, parallel and
//!   deterministic.
//!
//! # Accuracy
//!
//! Polished roots are accurate to ~1e-14 relative (simple roots; Newton's step below
//! `1e-14·max(1, |λ|)`). The unstable-root count of a chart cell is exact unless the cell lies
//! within round-off of a boundary. The spectral abscissa of a chart cell is the real part of the
//! rightmost polished root among those followed along D (see [`chart`]): a root overtaking the
//! followed ones between two reseeds would be missed, so this is checked, not assumed — on whole
//! charts against the confirmed spectral method in the tests (with the default options all
//! 240 000 cells of the app's default Fig. 4(a) agree to 1e-9 relative).
//!
//! # Example
//!
//! The scalar equation `x'(t) = −x(t − τ)` is stable exactly for τ < π/2 (Hayes 1950):
//!
//! ```
//! use nalgebra::{DMatrix, Matrix1};
//! use stability::{LinearDde, RankOneFeedback, RootOptions, rightmost_roots};
//!
//! // as a general DDE
//! let dde = LinearDde::new(DMatrix::zeros(1, 1))?
//!     .with_delay(1.0, DMatrix::from_element(1, 1, -1.0))?;
//! let roots = rightmost_roots(&dde, 2, &RootOptions::default())?;
//! assert!(roots[0].re < 0.0); // τ = 1 < π/2: stable
//!
//! // as rank-one feedback x' = u, u = −D·x(t − τ): the dynamic boundary is D = π/(2τ)
//! let sys = RankOneFeedback::from_state_space(
//!     &Matrix1::new(0.0), &Matrix1::new(1.0), &Matrix1::new(1.0))?;
//! let crossings = sys.crossings(1.0, 2.0)?;
//! let dynamic = crossings.iter().find(|c| c.omega > 0.0).unwrap();
//! assert!((dynamic.d - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
//! assert_eq!(sys.unstable_root_count(1.0, 1.0)?, 0);
//! assert_eq!(sys.unstable_root_count(1.6, 1.0)?, 2);
//! # Ok::<(), stability::StabilityError>(())
//! ```

pub mod chart;
pub mod dde;
mod eigen;
pub mod error;
pub mod rank_one;
pub mod roots;
pub mod semi_discretisation;
mod small_eigen;
pub mod spectral;

pub use chart::{
    Axis, BoundaryPoint, ChartCell, ChartOptions, Polyline, StabilityChart,
    first_unstable_parameter, stability_charts,
};
pub use dde::{DelayedTerm, LinearDde, NewtonOptions, sort_rightmost};
pub use error::{Result, StabilityError};
pub use num_complex::Complex64;
pub use rank_one::{Crossing, RankOneFeedback, polynomial_roots};
pub use roots::{
    RootOptions, collocation_roots, rightmost_roots, spectral_abscissa, unstable_root_count,
};
pub use semi_discretisation::SemiDiscretisation;
pub use spectral::{ChebyshevCollocation, chebyshev_differentiation};
