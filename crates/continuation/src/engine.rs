//! Pseudo-arclength continuation engine (method), branch and solver state (data).
//!
//! The engine never owns the system: [`Continuation::start`] and [`Continuation::extend`]
//! borrow it, and a [`Branch`] (points + [`ContinuationState`]) is plain serialisable data,
//! so a branch can be saved, loaded and extended later.

use crate::error::{Error, Result};
use crate::linalg::{Entry, SparseLu};
use crate::stability::{Location, SpecialKind, SpecialPoint, Stability};
use serde::{Deserialize, Serialize};

/// A nonlinear system G(u) = 0 with N equations in N + 1 unknowns (one of them the free
/// parameter), ready for pseudo-arclength continuation.
pub trait ContinuationSystem {
    /// number of unknowns N + 1 (N equations)
    fn n_unknowns(&self) -> usize;
    /// index of the free parameter in `u`
    fn parameter_index(&self) -> usize;
    /// index in `u` of a second free parameter, for two-parameter curves of codimension-one
    /// points (Hopf, fold, fold of cycles); None for one-parameter branches
    fn secondary_parameter_index(&self) -> Option<usize> {
        None
    }
    /// residual G(u) (length N)
    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()>;
    /// Jacobian ∂G/∂u (N × (N+1)) appended to `entries` as triplets (duplicates are summed)
    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()>;
    /// weights of the arclength metric ‖u‖² = Σ w_i u_i² (length N + 1)
    fn weights(&self) -> Vec<f64>;
    /// called on every accepted point (e.g. to update a phase-condition reference)
    fn accept(&mut self, _u: &[f64]) {}
    /// stability of the solution `u` (None if the system does not compute it)
    fn stability(&mut self, _u: &[f64]) -> Result<Option<Stability>> {
        Ok(None)
    }
    /// which special point, if any, lies between two stabilities
    fn classify(&self, _a: &Stability, _b: &Stability) -> Option<SpecialKind> {
        None
    }
    /// a test function that changes sign at a special point of this kind
    /// (None: the kind is only detected, not located)
    fn test_function(&mut self, _kind: SpecialKind, _u: &[f64]) -> Result<Option<f64>> {
        Ok(None)
    }
}

/// What to do with special points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SpecialPoints {
    /// detect and locate them (a located point is inserted into the branch)
    Locate,
    /// only flag the first point after the crossing
    Detect,
    /// do nothing
    Ignore,
}

/// Options of the continuation method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContinuationOptions {
    /// first step length (weighted arclength)
    pub initial_step: f64,
    /// smallest step before giving up
    pub min_step: f64,
    /// largest step
    pub max_step: f64,
    /// Newton stops when the max-norm of the update is below this
    pub newton_tolerance: f64,
    /// maximum Newton iterations per corrector
    pub max_newton_iterations: usize,
    /// the step grows when Newton needs fewer iterations than this, shrinks when more
    pub target_newton_iterations: usize,
    /// factor of step growth after an easy step
    pub step_growth: f64,
    /// factor of step reduction after a failed or rejected step
    pub step_reduction: f64,
    /// minimum cosine between consecutive tangents (weighted metric); sharper turns are rejected
    pub min_tangent_cosine: f64,
    /// stop when the parameter leaves this range
    pub parameter_range: (f64, f64),
    /// special points
    pub special_points: SpecialPoints,
    /// location stops when successive parameter estimates differ by less than this
    pub location_tolerance: f64,
    /// maximum iterations of a location
    pub max_location_iterations: usize,
}

impl Default for ContinuationOptions {
    fn default() -> Self {
        Self {
            initial_step: 1e-2,
            min_step: 1e-9,
            max_step: 1.0,
            newton_tolerance: 1e-10,
            max_newton_iterations: 10,
            target_newton_iterations: 3,
            step_growth: 1.5,
            step_reduction: 0.5,
            min_tangent_cosine: 0.95,
            parameter_range: (f64::NEG_INFINITY, f64::INFINITY),
            special_points: SpecialPoints::Locate,
            location_tolerance: 1e-10,
            max_location_iterations: 60,
        }
    }
}

/// Solver state of a branch: everything needed to continue it later.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContinuationState {
    /// the next step length to try
    pub step: f64,
    /// accepted steps so far
    pub accepted_steps: usize,
    /// rejected steps so far
    pub rejected_steps: usize,
}

/// One solution on a branch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BranchPoint {
    /// unknowns (layout defined by the system), including the parameter
    pub u: Vec<f64>,
    /// value of the free parameter
    pub parameter: f64,
    /// value of the second free parameter on a two-parameter curve (None on a branch)
    #[serde(default)]
    pub secondary_parameter: Option<f64>,
    /// unit tangent (weighted metric), oriented in the direction of continuation
    pub tangent: Vec<f64>,
    /// stability (eigenvalues or Floquet multipliers)
    pub stability: Option<Stability>,
    /// special point at (Located) or just before (Detected) this point
    pub special: Option<SpecialPoint>,
    /// Newton iterations the corrector needed
    pub newton_iterations: usize,
}

impl BranchPoint {
    /// stable according to the recorded stability (None if unknown)
    pub fn is_stable(&self) -> Option<bool> {
        self.stability.as_ref().map(|s| s.is_stable())
    }
}

/// Why [`Continuation::extend`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Stop {
    /// the requested number of points was computed
    MaxPoints,
    /// the parameter left `parameter_range`
    ParameterRange,
    /// the step fell below `min_step` (the branch ends, or something is wrong)
    StepSizeUnderflow {
        /// the step that failed
        step: f64,
    },
}

/// A branch of solutions: points and the state needed to continue it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Branch {
    /// points in continuation order
    pub points: Vec<BranchPoint>,
    /// continuation state
    pub state: ContinuationState,
}

impl Branch {
    /// the special points with their indices
    pub fn special_points(&self) -> impl Iterator<Item = (usize, &SpecialPoint)> {
        self.points
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.special.as_ref().map(|s| (i, s)))
    }

    /// first special point of a kind
    pub fn first(&self, kind: SpecialKind) -> Option<(usize, &SpecialPoint)> {
        self.special_points().find(|(_, s)| s.kind == kind)
    }
}

/// The pseudo-arclength continuation method (options only; no problem, no state).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Continuation {
    /// options
    pub options: ContinuationOptions,
}

/// result of one corrector run
struct Corrected {
    u: Vec<f64>,
    tangent: Vec<f64>,
    iterations: usize,
}

fn weighted_dot(w: &[f64], a: &[f64], b: &[f64]) -> f64 {
    w.iter().zip(a).zip(b).map(|((w, a), b)| w * a * b).sum()
}

fn normalise(w: &[f64], t: &mut [f64]) {
    let n = weighted_dot(w, t, t).sqrt();
    if n > 0.0 {
        t.iter_mut().for_each(|v| *v /= n);
    }
}

impl Continuation {
    /// Method with the given options.
    pub fn new(options: ContinuationOptions) -> Self {
        Self { options }
    }

    /// Newton corrector for G(u) = 0, Σ w_i t_i (u_i − pred_i) = 0.
    /// Returns the solution, the new unit tangent (oriented along `t`) and the iterations.
    fn correct<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        pred: &[f64],
        t: &[f64],
        w: &[f64],
    ) -> Result<Corrected> {
        let nu = sys.n_unknowns();
        let ip = sys.parameter_index();
        let mut u = pred.to_vec();
        let mut r = vec![0.0; nu];
        let mut entries = Vec::new();
        let mut last_update = f64::INFINITY;
        let mut res_norm = f64::INFINITY;
        for it in 1..=self.options.max_newton_iterations {
            sys.residual(&u, &mut r[..nu - 1])?;
            r[nu - 1] = (0..nu).map(|i| w[i] * t[i] * (u[i] - pred[i])).sum();
            res_norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if !res_norm.is_finite() {
                return Err(Error::NonFinite { parameter: u[ip] });
            }
            entries.clear();
            sys.jacobian(&u, &mut entries)?;
            for i in 0..nu {
                let v = w[i] * t[i];
                if v != 0.0 {
                    entries.push(Entry::new(nu - 1, i, v));
                }
            }
            let lu = SparseLu::new(nu, &entries, "Newton corrector")?;
            let mut du: Vec<f64> = r.iter().map(|v| -v).collect();
            lu.solve(&mut du, "Newton corrector")?;
            let upd = du.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            u.iter_mut().zip(&du).for_each(|(a, b)| *a += b);
            if upd <= self.options.newton_tolerance * (1.0 + u[ip].abs()) {
                // tangent from the same factorisation: [J; w∘t] τ = e_N
                let mut tau = vec![0.0; nu];
                tau[nu - 1] = 1.0;
                lu.solve(&mut tau, "tangent")?;
                normalise(w, &mut tau);
                return Ok(Corrected {
                    u,
                    tangent: tau,
                    iterations: it,
                });
            }
            if it > 2 && upd > 2.0 * last_update {
                break;
            }
            last_update = upd;
        }
        Err(Error::NewtonDivergence {
            parameter: u[ip],
            iterations: self.options.max_newton_iterations,
            residual: res_norm,
            update: last_update,
        })
    }

    fn make_point<S: ContinuationSystem>(&self, sys: &mut S, c: Corrected) -> Result<BranchPoint> {
        let stability = sys.stability(&c.u)?;
        let ip = sys.parameter_index();
        let secondary_parameter = sys.secondary_parameter_index().map(|i| c.u[i]);
        Ok(BranchPoint {
            parameter: c.u[ip],
            secondary_parameter,
            u: c.u,
            tangent: c.tangent,
            stability,
            special: None,
            newton_iterations: c.iterations,
        })
    }

    /// Start a branch: correct `guess` under the constraint that its projection on
    /// `direction` stays fixed (Σ w_i d_i (u_i − guess_i) = 0); the tangent is oriented so that
    /// it has a positive component along `direction`.
    ///
    /// For an equilibrium, `direction` = the unit vector of the parameter; for branch
    /// switching onto cycles, the direction of growing amplitude.
    pub fn start<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        guess: &[f64],
        direction: &[f64],
    ) -> Result<Branch> {
        let nu = sys.n_unknowns();
        if guess.len() != nu || direction.len() != nu {
            return Err(Error::InvalidInput(format!(
                "start: guess has {} and direction {} entries, the system has {nu} unknowns",
                guess.len(),
                direction.len()
            )));
        }
        let w = sys.weights();
        let mut d = direction.to_vec();
        normalise(&w, &mut d);
        let c = self.correct(sys, guess, &d, &w)?;
        sys.accept(&c.u);
        let p = self.make_point(sys, c)?;
        Ok(Branch {
            points: vec![p],
            state: ContinuationState {
                step: self.options.initial_step,
                accepted_steps: 0,
                rejected_steps: 0,
            },
        })
    }

    /// Continue `branch` by up to `max_points` new points (located special points count too).
    pub fn extend<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        branch: &mut Branch,
        max_points: usize,
    ) -> Result<Stop> {
        let w = sys.weights();
        let ip = sys.parameter_index();
        let o = &self.options;
        let mut added = 0;
        let Some(last) = branch.points.last() else {
            return Err(Error::EmptyBranch);
        };
        if last.u.len() != sys.n_unknowns() {
            return Err(Error::InvalidInput(format!(
                "branch points have {} unknowns, the system has {}",
                last.u.len(),
                sys.n_unknowns()
            )));
        }
        sys.accept(&last.u.clone());
        while added < max_points {
            let a = branch.points.last().cloned().ok_or(Error::EmptyBranch)?;
            if a.parameter < o.parameter_range.0 || a.parameter > o.parameter_range.1 {
                return Ok(Stop::ParameterRange);
            }
            let ds = branch.state.step;
            if ds < o.min_step {
                return Ok(Stop::StepSizeUnderflow { step: ds });
            }
            let pred: Vec<f64> =
                a.u.iter()
                    .zip(&a.tangent)
                    .map(|(u, t)| u + ds * t)
                    .collect();
            let c = match self.correct(sys, &pred, &a.tangent, &w) {
                Ok(c)
                    if weighted_dot(&w, &c.tangent, &a.tangent) >= o.min_tangent_cosine
                        || ds <= 2.0 * o.min_step =>
                {
                    c
                }
                _ => {
                    branch.state.step *= o.step_reduction;
                    branch.state.rejected_steps += 1;
                    continue;
                }
            };
            // step control from the Newton iteration count
            let its = c.iterations;
            let mut next = if its < o.target_newton_iterations {
                ds * o.step_growth
            } else if its > o.target_newton_iterations {
                ds * o.step_reduction.max(0.7)
            } else {
                ds
            };
            next = next.min(o.max_step);
            let mut b = self.make_point(sys, c)?;
            branch.state.accepted_steps += 1;

            // special points between a and b
            let mut located: Option<BranchPoint> = None;
            if o.special_points != SpecialPoints::Ignore {
                let fold = a.tangent[ip] * b.tangent[ip] < 0.0;
                let stab_kind = match (&a.stability, &b.stability) {
                    (Some(sa), Some(sb)) => sys.classify(sa, sb),
                    _ => None,
                };
                let kind = if fold {
                    Some(SpecialKind::Fold)
                } else {
                    stab_kind
                };
                if let Some(kind) = kind {
                    let test_a = if kind == SpecialKind::Fold {
                        Some(a.tangent[ip])
                    } else {
                        sys.test_function(kind, &a.u)?
                    };
                    match (o.special_points, test_a) {
                        (SpecialPoints::Locate, Some(ga)) => {
                            let gb = if kind == SpecialKind::Fold {
                                b.tangent[ip]
                            } else {
                                sys.test_function(kind, &b.u)?.unwrap_or(ga)
                            };
                            if ga * gb < 0.0 {
                                let mut point = self.locate(sys, kind, &a, ds, ga, gb, &w)?;
                                let dp = b.parameter - a.parameter;
                                if let Some(sp) = point.special.as_mut()
                                    && kind != SpecialKind::Fold
                                    && dp != 0.0
                                {
                                    sp.transversality = Some((gb - ga) / dp);
                                }
                                located = Some(point);
                            } else {
                                b.special = Some(self.detected(kind, &b));
                            }
                        }
                        _ => b.special = Some(self.detected(kind, &b)),
                    }
                }
            }
            if let Some(p) = located {
                branch.points.push(p);
                added += 1;
            }
            sys.accept(&b.u);
            branch.points.push(b);
            added += 1;
            branch.state.step = next;
        }
        Ok(Stop::MaxPoints)
    }

    fn detected(&self, kind: SpecialKind, b: &BranchPoint) -> SpecialPoint {
        SpecialPoint {
            kind,
            location: Location::Detected,
            parameter: b.parameter,
            critical: b.stability.as_ref().and_then(|s| s.critical(kind)),
            transversality: None,
        }
    }

    /// Locate the zero of a test function between `a` (step 0) and the step `ds`
    /// (Illinois variant of regula falsi on the step length along a's tangent).
    fn locate<S: ContinuationSystem>(
        &self,
        sys: &mut S,
        kind: SpecialKind,
        a: &BranchPoint,
        ds: f64,
        ga: f64,
        gb: f64,
        w: &[f64],
    ) -> Result<BranchPoint> {
        let ip = sys.parameter_index();
        let (mut s0, mut g0, mut s1, mut g1) = (0.0, ga, ds, gb);
        let mut side = 0i8;
        let mut p_prev = f64::NAN;
        let mut best: Option<Corrected> = None;
        for it in 0..self.options.max_location_iterations {
            let s = s1 - g1 * (s1 - s0) / (g1 - g0);
            let pred: Vec<f64> = a.u.iter().zip(&a.tangent).map(|(u, t)| u + s * t).collect();
            let c = self.correct(sys, &pred, &a.tangent, w)?;
            let g = if kind == SpecialKind::Fold {
                c.tangent[ip]
            } else {
                sys.test_function(kind, &c.u)?
                    .ok_or(Error::LocationFailed {
                        kind: kind.to_string(),
                        p0: a.parameter,
                        p1: c.u[ip],
                        iterations: it,
                    })?
            };
            let p = c.u[ip];
            let done = (p - p_prev).abs() <= self.options.location_tolerance
                || g == 0.0
                || (s1 - s0).abs() < 1e-15 * ds;
            p_prev = p;
            best = Some(c);
            if done {
                break;
            }
            if g * g1 < 0.0 {
                (s0, g0) = (s1, g1);
                side = 0;
            } else {
                if side == 1 {
                    g0 *= 0.5;
                }
                side = 1;
            }
            (s1, g1) = (s, g);
            if it + 1 == self.options.max_location_iterations {
                return Err(Error::LocationFailed {
                    kind: kind.to_string(),
                    p0: a.parameter,
                    p1: p,
                    iterations: it + 1,
                });
            }
        }
        let c = best.ok_or(Error::LocationFailed {
            kind: kind.to_string(),
            p0: a.parameter,
            p1: a.parameter,
            iterations: 0,
        })?;
        let mut point = self.make_point(sys, c)?;
        point.special = Some(SpecialPoint {
            kind,
            location: Location::Located,
            parameter: point.parameter,
            critical: point.stability.as_ref().and_then(|s| s.critical(kind)),
            transversality: None,
        });
        Ok(point)
    }
}

/// One Newton step for the bordered system G(u) = 0, Σ w_i t_i (u_i − u_i) = 0 at `u`:
/// assembly of the residual and the sparse Jacobian, sparse LU and solve. Returns the
/// update Δu. (The building block of the corrector, exposed for benchmarks and tests.)
pub fn newton_step<S: ContinuationSystem>(
    sys: &mut S,
    u: &[f64],
    tangent: &[f64],
) -> Result<Vec<f64>> {
    let nu = sys.n_unknowns();
    let w = sys.weights();
    let mut r = vec![0.0; nu];
    sys.residual(u, &mut r[..nu - 1])?;
    let mut entries = Vec::new();
    sys.jacobian(u, &mut entries)?;
    for i in 0..nu {
        let v = w[i] * tangent[i];
        if v != 0.0 {
            entries.push(Entry::new(nu - 1, i, v));
        }
    }
    let lu = SparseLu::new(nu, &entries, "Newton step")?;
    let mut du: Vec<f64> = r.iter().map(|v| -v).collect();
    lu.solve(&mut du, "Newton step")?;
    Ok(du)
}

/// Solutions on `branch` at the parameter value `p`: for every pair of consecutive points
/// that brackets `p`, the linear interpolant is corrected with the parameter fixed.
pub fn points_at_parameter<S: ContinuationSystem>(
    cont: &Continuation,
    sys: &mut S,
    branch: &Branch,
    p: f64,
) -> Result<Vec<BranchPoint>> {
    let ip = sys.parameter_index();
    let nu = sys.n_unknowns();
    let mut out = Vec::new();
    let mut e = vec![0.0; nu];
    e[ip] = 1.0;
    for w in branch.points.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if (a.parameter - p) * (b.parameter - p) > 0.0
            || a.parameter == b.parameter
            || (b.parameter == p)
        {
            continue;
        }
        let t = (p - a.parameter) / (b.parameter - a.parameter);
        let guess: Vec<f64> = a.u.iter().zip(&b.u).map(|(x, y)| x + t * (y - x)).collect();
        sys.accept(&guess);
        let mut pt = cont.start(sys, &guess, &e)?.points.remove(0);
        pt.tangent = a
            .tangent
            .iter()
            .zip(&b.tangent)
            .map(|(x, y)| x + t * (y - x))
            .collect();
        out.push(pt);
    }
    Ok(out)
}
