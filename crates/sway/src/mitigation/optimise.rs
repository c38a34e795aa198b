//! A small generic optimisation layer on top of [`argmin`]'s Nelder–Mead: bounded
//! continuous variables, one discrete choice, seeded multi-start. It knows nothing about
//! trailers: a problem is a cost `f(choice, x)` to minimise over `x` in a box and a choice
//! among `n` alternatives.
//!
//! - **Bounds** by a transform: the optimiser works on free variables z ∈ ℝ and the problem
//!   sees x = lo + (hi − lo)·(1 + sin z)/2 ∈ \[lo, hi\] ([`Bound::to_bounded`]); every point
//!   the optimiser visits is feasible for the bounds, and a bound can be attained.
//! - **Discrete choice** by enumeration: each choice is optimised separately and the best
//!   (lowest cost; the first on ties) is returned.
//! - **Multi-start**: from the caller's starting points (e.g. a known good design) and
//!   `random_starts` points drawn uniformly in the box from a ChaCha8 generator seeded
//!   with `seed`; the same starts serve every choice. Starts and runs are sequential, so
//!   the result depends only on the seed (the cost function may be parallel inside).
//! - **Worst case over samples** ([`worst_case`]): the maximum of per-sample costs
//!   evaluated in parallel and reduced in sample order.
//!
//! Constraints other than bounds are the problem's business (e.g. penalties in its cost).

use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::SwayError;

/// A bounded variable lo ≤ x ≤ hi.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bound {
    /// lower bound
    pub lo: f64,
    /// upper bound (≥ lo)
    pub hi: f64,
}

impl Bound {
    /// lo ≤ x ≤ hi.
    pub const fn new(lo: f64, hi: f64) -> Self {
        Self { lo, hi }
    }

    /// x = lo + (hi − lo)·(1 + sin z)/2.
    #[inline]
    pub fn to_bounded(&self, z: f64) -> f64 {
        let x = self.lo + (self.hi - self.lo) * 0.5 * (1.0 + z.sin());
        x.clamp(self.lo, self.hi)
    }

    /// The free variable z ∈ \[−π/2, π/2\] of x (x clamped into the bounds first).
    pub fn to_free(&self, x: f64) -> f64 {
        if self.hi <= self.lo {
            return 0.0;
        }
        let s = 2.0 * (x.clamp(self.lo, self.hi) - self.lo) / (self.hi - self.lo) - 1.0;
        s.clamp(-1.0, 1.0).asin()
    }

    /// Whether lo ≤ hi, both finite.
    pub fn is_valid(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite() && self.lo <= self.hi
    }
}

/// A problem with bounded continuous variables and one discrete choice.
pub trait MixedProblem: Sync {
    /// The bounds of the continuous variables (their number is the dimension).
    fn bounds(&self) -> &[Bound];

    /// The number of discrete alternatives (≥ 1).
    fn choices(&self) -> usize;

    /// The cost to minimise at alternative `choice` and point `x` (inside the bounds).
    ///
    /// # Errors
    /// Whatever the problem's evaluation can fail with; the optimisation stops with it.
    fn cost(&self, choice: usize, x: &[f64]) -> Result<f64, SwayError>;
}

/// Settings of [`minimise`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OptimiserSettings {
    /// seed of the random starting points
    pub seed: u64,
    /// random starting points (besides the caller's)
    pub random_starts: usize,
    /// Nelder–Mead iterations per start and choice
    pub max_iters: u64,
    /// stop a run when the standard deviation of the simplex's costs falls below this
    pub sd_tolerance: f64,
    /// edge of the initial simplex in the free variables z \[rad\] (x moves by up to
    /// (hi − lo)·sin(edge)/2)
    pub initial_step: f64,
}

impl Default for OptimiserSettings {
    fn default() -> Self {
        Self {
            seed: 1,
            random_starts: 4,
            max_iters: 100,
            sd_tolerance: 1e-3,
            initial_step: 0.6,
        }
    }
}

impl OptimiserSettings {
    /// Checks; `Err((key, problem))` names the key.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.max_iters == 0 {
            return Err(("max_iters", "expected at least 1 iteration".into()));
        }
        if !(self.sd_tolerance.is_finite() && self.sd_tolerance >= 0.0) {
            return Err((
                "sd_tolerance",
                format!("expected a tolerance >= 0, got {}", self.sd_tolerance),
            ));
        }
        if !(self.initial_step.is_finite() && self.initial_step > 0.0) {
            return Err((
                "initial_step",
                format!("expected a step > 0, got {}", self.initial_step),
            ));
        }
        Ok(())
    }
}

/// One Nelder–Mead run: where it started and ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Run {
    /// the discrete alternative
    pub choice: usize,
    /// index of the starting point (caller's first, then the random ones)
    pub start: usize,
    /// the best point found (bounded variables)
    pub x: Vec<f64>,
    /// its cost
    pub cost: f64,
    /// cost evaluations of this run
    pub evaluations: usize,
}

/// The result of [`minimise`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Minimum {
    /// the best alternative
    pub choice: usize,
    /// the best point (bounded variables)
    pub x: Vec<f64>,
    /// its cost
    pub cost: f64,
    /// every run, in the order they were made (choice-major)
    pub runs: Vec<Run>,
    /// cost evaluations in total
    pub evaluations: usize,
}

/// The starting points: the caller's, then `random_starts` uniform ones in the box drawn
/// from ChaCha8 seeded with `seed`.
pub fn starting_points(
    bounds: &[Bound],
    given: &[Vec<f64>],
    settings: &OptimiserSettings,
) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let mut starts: Vec<Vec<f64>> = given.to_vec();
    for _ in 0..settings.random_starts {
        starts.push(
            bounds
                .iter()
                .map(|b| b.lo + (b.hi - b.lo) * rng.random::<f64>())
                .collect(),
        );
    }
    starts
}

/// Minimises `problem` over every choice from every starting point (the caller's
/// `starts`, in bounded variables, then the seeded random ones); the best run wins, the
/// earliest on ties.
///
/// # Errors
/// The first error of the problem's cost; [`SwayError::Numerical`] if a start has the wrong
/// dimension or argmin fails.
pub fn minimise<P: MixedProblem>(
    problem: &P,
    starts: &[Vec<f64>],
    settings: &OptimiserSettings,
) -> Result<Minimum, SwayError> {
    let bounds = problem.bounds();
    let starts = starting_points(bounds, starts, settings);
    if let Some(bad) = starts.iter().find(|s| s.len() != bounds.len()) {
        return Err(numerical(format!(
            "a starting point has {} components, the problem {}",
            bad.len(),
            bounds.len()
        )));
    }
    let mut runs = Vec::new();
    for choice in 0..problem.choices() {
        for (k, x0) in starts.iter().enumerate() {
            runs.push(nelder_mead(problem, choice, k, x0, settings)?);
        }
    }
    let best = runs
        .iter()
        .fold(None::<&Run>, |b, r| match b {
            Some(b) if b.cost <= r.cost => Some(b),
            _ => Some(r),
        })
        .ok_or_else(|| numerical("no starting point".into()))?;
    Ok(Minimum {
        choice: best.choice,
        x: best.x.clone(),
        cost: best.cost,
        evaluations: runs.iter().map(|r| r.evaluations).sum(),
        runs,
    })
}

fn numerical(message: String) -> SwayError {
    SwayError::numerical("optimisation", std::io::Error::other(message))
}

/// The cost in free variables, as argmin sees it; remembers the first error (argmin's
/// Nelder–Mead unwraps the costs of its first simplex, so errors are not passed through it).
struct FreeCost<'p, P> {
    problem: &'p P,
    choice: usize,
    evaluations: &'p AtomicUsize,
    error: &'p Mutex<Option<SwayError>>,
}

impl<P: MixedProblem> CostFunction for FreeCost<'_, P> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, z: &Self::Param) -> Result<f64, argmin::core::Error> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let x = to_bounded(self.problem.bounds(), z);
        match self.problem.cost(self.choice, &x) {
            Ok(c) if c.is_finite() => Ok(c),
            Ok(_) => Ok(f64::MAX),
            Err(e) => {
                if let Ok(mut slot) = self.error.lock() {
                    slot.get_or_insert(e);
                }
                Ok(f64::MAX)
            }
        }
    }
}

fn to_bounded(bounds: &[Bound], z: &[f64]) -> Vec<f64> {
    bounds
        .iter()
        .zip(z)
        .map(|(b, &z)| b.to_bounded(z))
        .collect()
}

/// One Nelder–Mead run from `x0`: the initial simplex is z0 and z0 + h·eᵢ (z0 − h·eᵢ where
/// z0 sits at the upper end of its range).
fn nelder_mead<P: MixedProblem>(
    problem: &P,
    choice: usize,
    start: usize,
    x0: &[f64],
    settings: &OptimiserSettings,
) -> Result<Run, SwayError> {
    let bounds = problem.bounds();
    let z0: Vec<f64> = bounds.iter().zip(x0).map(|(b, &x)| b.to_free(x)).collect();
    let mut simplex = vec![z0.clone()];
    for i in 0..z0.len() {
        let mut z = z0.clone();
        let h = settings.initial_step;
        z[i] += if z[i] + h > std::f64::consts::FRAC_PI_2 {
            -h
        } else {
            h
        };
        simplex.push(z);
    }
    let (evaluations, error) = (AtomicUsize::new(0), Mutex::new(None));
    let cost = FreeCost {
        problem,
        choice,
        evaluations: &evaluations,
        error: &error,
    };
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(settings.sd_tolerance)
        .map_err(|e| numerical(format!("Nelder–Mead settings: {e}")))?;
    let result = Executor::new(cost, solver)
        .configure(|state| state.max_iters(settings.max_iters))
        .run();
    if let Some(e) = error.lock().ok().and_then(|mut slot| slot.take()) {
        return Err(e);
    }
    let result = result.map_err(|e| numerical(format!("Nelder–Mead: {e}")))?;
    let state = result.state();
    let z = state
        .get_best_param()
        .cloned()
        .ok_or_else(|| numerical("Nelder–Mead returned no point".into()))?;
    Ok(Run {
        choice,
        start,
        x: to_bounded(bounds, &z),
        cost: state.get_best_cost(),
        evaluations: evaluations.load(Ordering::Relaxed),
    })
}

/// The worst (largest) of `f` over `samples`, evaluated in parallel and reduced in sample
/// order (the same result on any number of threads): every value and the index of the
/// first largest.
///
/// # Errors
/// The first error in sample order.
pub fn worst_case<S: Sync, T: Send, E: Send>(
    samples: &[S],
    f: impl Fn(&S) -> Result<T, E> + Sync + Send,
    value: impl Fn(&T) -> f64,
) -> Result<(Vec<T>, Option<usize>), E> {
    let results: Vec<Result<T, E>> = samples.par_iter().map(f).collect();
    let values = results.into_iter().collect::<Result<Vec<T>, E>>()?;
    let worst = (0..values.len()).fold(None::<usize>, |w, k| match w {
        Some(w) if value(&values[w]) >= value(&values[k]) => Some(w),
        _ => Some(k),
    });
    Ok((values, worst))
}
