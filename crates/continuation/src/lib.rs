//! Numerical continuation for ordinary and constant-delay differential equations
//!
//! x'(t) = f(x(t), x(t−τ1), …, x(t−τk); p)   (k = 0: an ODE)
//!
//! - [`Problem`]: the system, with exact Jacobians supplied by the user (finite differences
//!   only as an explicit option: [`fd_jacobian`], [`fd_dfdp`]);
//! - [`Continuation`]: pseudo-arclength continuation with Newton-iteration step control,
//!   detection and location of special points (folds, branch points with
//!   [`Continuation::switch_branch`], and what the system classifies); a [`Branch`] is plain
//!   serialisable data (points + [`ContinuationState`]) and can be saved and extended later;
//!   an [`Observer`] sees every accepted point (progress, checkpoints, user stop rules);
//! - [`EquilibriumSystem`]: equilibria, stability from eigenvalues (ODE) or the rightmost
//!   characteristic roots (DDE; pluggable via [`CharacteristicRoots`], built in:
//!   [`ChebyshevRoots`], the `stability` crate's collocation and Newton polishing), Hopf points located by regula falsi on the real part of the
//!   critical pair;
//! - [`PeriodicOrbitSystem`]: periodic orbits by orthogonal collocation (Gauss–Legendre points,
//!   period as unknown, integral phase condition; delayed values read off the periodic
//!   profile), sparse LU (faer) so a Newton step costs O(L); Floquet multipliers from the
//!   discretised monodromy operator, folds located, period-doubling and torus points
//!   detected; branch switching from Hopf points with a finite amplitude; the free
//!   parameter may be a delay ([`Problem::delay_dp`]);
//! - [`HopfCurveSystem`], [`FoldCurveSystem`]: curves of Hopf points and of folds of
//!   equilibria in two free parameters (either may be a delay), with exact Jacobians from
//!   [`Problem::second_derivative`], [`Problem::jacobian_dp`] and [`Problem::delay_dp`];
//!   stability along the curve from the remaining spectrum; codimension-two points
//!   (double Hopf, zero-Hopf, Bogdanov–Takens, cusp) located as special points and
//!   collected as [`Codim2Point`]s.
//! - [`FoldOfCyclesSystem`]: folds of periodic orbits continued in two parameters (extended
//!   system with the null vector, exact second derivatives, sparse), with cusps of cycles and
//!   the end at a generalised Hopf point.
//! - [`torus`]: torus (Neimark–Sacker) points of cycles located on cycle branches and
//!   continued in two parameters ([`TorusCurveSystem`]: extended system with the periodic
//!   Floquet mode, exact second derivatives, sparse), with the multiplier angle and
//!   rotation number, strong resonances, and the start at a double-Hopf point
//!   ([`DoubleHopfPoint`]) onto both cycle families and both torus curves.
//!
//! - [`HopfNormalForm`], [`DoubleHopfNormalForm`]: normal-form coefficients of Hopf points
//!   (first Lyapunov coefficient l1) and double-Hopf points (Kuznetsov's θ, δ and unfolding
//!   type) of smooth ODEs and DDEs from exact third derivatives
//!   ([`Problem::third_derivative`]); generalised-Hopf (Bautin) points located on Hopf
//!   curves where l1 changes sign. Problems only C¹ at kinks ([`Smoothness::C1AtKinks`])
//!   get [`Error::NotSmooth`] instead of a number.
//!
//! Problems with closed-form answers (normal forms, delayed oscillators) with exact
//! derivatives, used by this crate's tests, benches and examples, are in the dev-only crate
//! `continuation-textbook`.
//!
//! The crate knows nothing about any application.
//!
//! # Example: Hopf point and cycle branch of the Stuart–Landau oscillator
//!
//! z' = (μ + i) z − |z|² z has a Hopf point at μ = 0 and cycles of radius √μ, period 2π.
//!
//! ```
//! use continuation::*;
//!
//! struct StuartLandau;
//! impl Problem for StuartLandau {
//!     fn dim(&self) -> usize { 2 }
//!     fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
//!         let r2 = x[0] * x[0] + x[1] * x[1];
//!         f[0] = p[0] * x[0] - x[1] - r2 * x[0];
//!         f[1] = x[0] + p[0] * x[1] - r2 * x[1];
//!     }
//!     fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
//!         fd_jacobian(self, x, p, j) // finite differences, chosen explicitly
//!     }
//!     fn dfdp(&self, x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
//!         out.copy_from_slice(&x[..2]);
//!     }
//! }
//!
//! # fn main() -> Result<()> {
//! let cont = Continuation::new(ContinuationOptions { initial_step: 0.05, max_step: 0.1, ..Default::default() });
//! // equilibrium branch x = 0 from μ = −0.5 upwards; the Hopf point is located
//! let mut eq = EquilibriumSystem::new(&StuartLandau, vec![-0.5], 0, ChebyshevRoots::default())?;
//! let dir = eq.parameter_direction();
//! let mut branch = cont.start(&mut eq, &[0.0, 0.0, -0.5], &dir)?;
//! cont.extend(&mut eq, &mut branch, 20)?;
//! let (i, hopf) = branch.first(SpecialKind::Hopf).expect("Hopf point");
//! assert!(hopf.parameter.abs() < 1e-8);
//! let hopf = eq.hopf_point(&branch.points[i].u, hopf.transversality.unwrap())?;
//! assert!((hopf.omega - 1.0).abs() < 1e-10);
//!
//! // cycles born there: radius √μ
//! let mut po = PeriodicOrbitSystem::new(&StuartLandau, vec![0.0], 0, CollocationOptions { intervals: 20, ..Default::default() })?;
//! let (guess, dir) = po.hopf_guess(&hopf, 0.1);
//! let mut cycles = cont.start(&mut po, &guess, &dir)?;
//! cont.extend(&mut po, &mut cycles, 10)?;
//! let last = cycles.points.last().unwrap();
//! let r = po.max_abs(&last.u, 0);
//! assert!((r - last.parameter.sqrt()).abs() < 1e-6);
//! assert_eq!(criticality(&hopf, &cycles), Some(Criticality::Supercritical));
//! # Ok(())
//! # }
//! ```

mod banded;
mod block_forward;
mod codim2;
mod collocation;
mod cycle_curve;
mod engine;
mod equilibrium;
mod error;
mod fold_curve;
mod fold_cycles;
mod hopf_curve;
mod linalg;
mod linear_solver;
mod normal_form;
mod period_doubling;
mod periodic;
mod problem;
mod roots;
mod stability;
pub mod torus;

pub use codim2::Codim2Point;
pub use collocation::{MAX_DEGREE, gauss_legendre, lagrange, lagrange_d2};
pub use cycle_curve::{CycleCurveSystem, CycleExtension};
pub use engine::{
    Branch, BranchPoint, Continuation, ContinuationOptions, ContinuationState, ContinuationSystem,
    Decision, NewtonMatrix, NewtonUpdate, NoObserver, Observer, SpecialPoints, Stagnation, Stop,
    newton_step, points_at_parameter,
};
pub use equilibrium::{EquilibriumSystem, HopfPoint};
pub use error::{Error, Result};
pub use fold_curve::FoldCurveSystem;
pub use fold_cycles::{FoldCyclesOptions, FoldCyclesStop, FoldOfCyclesSystem, HopfEnd};
pub use hopf_curve::HopfCurveSystem;
pub use linalg::{Entry, KRYLOV_TOLERANCE, MeshStructure};
pub use linear_solver::{KRYLOV_MIN_SIZE, LinearSolver};
pub use normal_form::{DoubleHopfCase, DoubleHopfNormalForm, HopfNormalForm};
pub use period_doubling::{PeriodDoublingCurveSystem, PeriodDoublingOptions};
pub use periodic::{
    ArclengthWeights, CollocationOptions, FloquetMultipliers, MeshAdaptation, PeriodicOrbitSystem,
};
pub use problem::{
    Problem, Smoothness, fd_dfdp, fd_jacobian, fd_jacobian_dp, fd_second_derivative,
    fd_third_derivative,
};
pub use roots::{CharacteristicRoots, ChebyshevRoots, Refinement, refine_root};
pub use stability::{Criticality, Location, SpecialKind, SpecialPoint, SpectrumKind, Stability};
pub use torus::{
    DoubleHopfEnd, DoubleHopfPoint, Resonance, TorusCurveOptions, TorusCurvePoint, TorusCurveStop,
    TorusCurveSystem, TorusPoint,
};

/// Criticality of a Hopf bifurcation from the computed cycle branch: subcritical if the
/// cycles emanate to the side of the parameter where the equilibrium is stable.
/// None if the branch does not move away from the Hopf parameter.
pub fn criticality(hopf: &HopfPoint, cycles: &Branch) -> Option<Criticality> {
    let dp = cycles
        .points
        .iter()
        .map(|p| p.parameter - hopf.parameter)
        .find(|d| d.abs() > 1e-9 * (1.0 + hopf.parameter.abs()))?;
    // the equilibrium is stable where transversality · (p − p*) < 0
    if hopf.transversality == 0.0 {
        return None;
    }
    Some(if dp * hopf.transversality < 0.0 {
        Criticality::Subcritical
    } else {
        Criticality::Supercritical
    })
}
