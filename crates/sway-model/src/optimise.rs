//! A small generic optimisation layer around the Nelder–Mead method: bounded
//! continuous variables, one discrete choice, seeded multi-start. It knows nothing about
//! trailers: a problem is a cost `f(choice, x)` to minimise over `x` in a box and a choice
//! among `n` alternatives.
//!
//! Why not argmin's `NelderMead`, whose decisions this one reproduces: argmin asks for the
//! exact cost of every trial point, while this one passes on the cost the trial is compared
//! with, so that in the mitigation study a trial's phase runs stop once a settle time
//! exceeds it and the phases not started yet are skipped. Without that cutoff the search
//! does 1.3× the solver work (2.5·10⁸ right-hand-side evaluations instead of 1.9·10⁸,
//! 29 040 phase runs instead of about 23 300) and the whole study takes 1.3× as long on
//! 2 cores, for the same result.
//!
//! - **Bounds** by a transform: the optimiser works on free variables z ∈ ℝ and the problem
//!   sees x = lo + (hi − lo)·(1 + sin z)/2 ∈ \[lo, hi\] ([`Bound::to_bounded`]); every point
//!   the optimiser visits is feasible for the bounds, and a bound can be attained.
//! - **Discrete choice** by enumeration: each choice is optimised separately and the best
//!   (lowest cost; the first on ties) is returned.
//! - **Multi-start**: from the caller's starting points (e.g. a known good design) and
//!   `random_starts` points drawn uniformly in the box from a ChaCha8 generator seeded
//!   with `seed`; the same starts serve every choice. The runs (one per choice and start)
//!   go side by side, each a pure function of its start, and the best is picked in their
//!   order, so the result depends only on the seed, on any number of threads (the cost
//!   function may be parallel inside).
//! - **Trials cut short**: Nelder–Mead compares a trial point with one cost only (the
//!   worst vertex's or the reflected point's), so it asks the problem for the cost *unless
//!   it is above* that one ([`MixedProblem::cost_unless_above`]); a problem that can stop
//!   an evaluation early (the mitigation's runs stop once their settle time exceeds it)
//!   saves that work, and the path of the method does not change.
//! - **Worst case over samples** ([`worst_case`]): the maximum of per-sample costs
//!   evaluated in parallel and reduced in sample order.
//!
//! Constraints other than bounds are the problem's business (e.g. penalties in its cost).

use crate::parallel::{Split, try_map};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

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

    /// The cost, or [`Bounded::Above`] once it is proven larger than `cutoff` (the
    /// optimiser only compares it with `cutoff` then). The default evaluates it exactly; a
    /// problem whose evaluation can stop early overrides it. It must answer `Above` only
    /// when the cost is strictly larger than `cutoff`.
    ///
    /// # Errors
    /// As [`MixedProblem::cost`].
    fn cost_unless_above(
        &self,
        choice: usize,
        x: &[f64],
        cutoff: f64,
    ) -> Result<Bounded, SwayError> {
        let _ = cutoff;
        self.cost(choice, x).map(Bounded::Exact)
    }
}

/// A cost evaluated against a cutoff ([`MixedProblem::cost_unless_above`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bounded {
    /// the cost
    Exact(f64),
    /// proven larger than the cutoff (its exact value not computed)
    Above,
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
    /// of them, trial points rejected as soon as their cost was proven above the one they
    /// were compared with ([`MixedProblem::cost_unless_above`])
    pub cut_short: usize,
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
/// The first error of the problem's cost (in the order of the runs); [`SwayError::Numerical`]
/// if a start has the wrong dimension.
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
    let jobs: Vec<(usize, usize)> = (0..problem.choices())
        .flat_map(|choice| (0..starts.len()).map(move |k| (choice, k)))
        .collect();
    let runs = try_map(&jobs, Split::OnePerTask, &|_, &(choice, k)| {
        nelder_mead(problem, choice, k, &starts[k], settings)
    })?;
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

/// The bounded variables of the free ones z.
fn to_bounded(bounds: &[Bound], z: &[f64]) -> Vec<f64> {
    bounds
        .iter()
        .zip(z)
        .map(|(b, &z)| b.to_bounded(z))
        .collect()
}

/// A vertex of the simplex: free variables and their cost.
#[derive(Debug, Clone)]
struct Vertex {
    z: Vec<f64>,
    cost: f64,
}

/// `a + (b − a)·s`, component by component (reflection, expansion, contraction, shrink).
fn along(a: &[f64], b: &[f64], s: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| a + (b - a) * s).collect()
}

/// The Nelder–Mead method (Nelder & Mead 1965, with the coefficients and the order of
/// decisions of argmin's `NelderMead`: reflection α = 1, expansion γ = 2, contraction
/// ρ = ½, shrink σ = ½; stop when the standard deviation of the simplex's costs falls below
/// `sd_tolerance` or after `max_iters` iterations) on one choice of a [`MixedProblem`].
///
/// A trial point is only ever compared with one cost (the worst vertex, or the reflected
/// point), so it is evaluated by [`MixedProblem::cost_unless_above`] with that cost as the
/// cutoff: a trial proven worse is rejected without its exact cost, the path of the method
/// is the same.
struct NelderMead<'p, P> {
    problem: &'p P,
    choice: usize,
    simplex: Vec<Vertex>,
    best: Vertex,
    evaluations: usize,
    cut_short: usize,
}

impl<P: MixedProblem> NelderMead<'_, P> {
    /// The cost at z, or `None` when it is proven above `cutoff`; a non-finite cost counts
    /// as `f64::MAX`.
    fn cost(&mut self, z: &[f64], cutoff: f64) -> Result<Option<f64>, SwayError> {
        self.evaluations += 1;
        let x = to_bounded(self.problem.bounds(), z);
        Ok(
            match self.problem.cost_unless_above(self.choice, &x, cutoff)? {
                Bounded::Exact(c) if c.is_finite() => Some(c),
                Bounded::Exact(_) => Some(f64::MAX),
                Bounded::Above => {
                    self.cut_short += 1;
                    None
                }
            },
        )
    }

    fn exact_cost(&mut self, z: &[f64]) -> Result<f64, SwayError> {
        Ok(self.cost(z, f64::INFINITY)?.unwrap_or(f64::MAX))
    }

    /// Sorts the simplex by cost (stable: ties keep their order).
    fn sort(&mut self) {
        // a `fn` item, not a closure: the sort is compiled once, not once per problem
        fn by_cost(a: &Vertex, b: &Vertex) -> std::cmp::Ordering {
            a.cost
                .partial_cmp(&b.cost)
                .unwrap_or(std::cmp::Ordering::Equal)
        }
        self.simplex.sort_by(by_cost);
    }

    /// The sample standard deviation of the vertices' costs.
    fn spread(&self) -> f64 {
        let n = self.simplex.len() as f64;
        let mean = self.simplex.iter().map(|v| v.cost).sum::<f64>() / n;
        let squares: f64 = self.simplex.iter().map(|v| (v.cost - mean).powi(2)).sum();
        (1.0 / (n - 1.0) * squares).sqrt()
    }

    /// The centroid of every vertex but the worst.
    fn centroid(&self) -> Vec<f64> {
        let m = self.simplex.len() - 1;
        let mut c = self.simplex[0].z.clone();
        for v in &self.simplex[1..m] {
            c.iter_mut().zip(&v.z).for_each(|(c, z)| *c += z);
        }
        let scale = 1.0 / m as f64;
        c.iter_mut().for_each(|c| *c *= scale);
        c
    }

    /// Every vertex but the best moved halfway towards it.
    fn shrink(&mut self) -> Result<(), SwayError> {
        let best = self.simplex[0].z.clone();
        for k in 1..self.simplex.len() {
            let z = along(&best, &self.simplex[k].z, 0.5);
            let cost = self.exact_cost(&z)?;
            self.simplex[k] = Vertex { z, cost };
        }
        Ok(())
    }

    /// One iteration: reflect the worst vertex through the centroid of the others, then
    /// expand, contract or shrink.
    fn iterate(&mut self) -> Result<(), SwayError> {
        let n = self.simplex.len();
        let centroid = self.centroid();
        let (best, second, worst) = (
            self.simplex[0].cost,
            self.simplex[n - 2].cost,
            self.simplex[n - 1].cost,
        );
        let worst_z = self.simplex[n - 1].z.clone();
        let zr = along(&centroid, &worst_z, -1.0);
        let replace = match self.cost(&zr, worst)? {
            Some(fr) if fr < second && fr >= best => Some(Vertex { z: zr, cost: fr }),
            Some(fr) if fr < best => {
                let ze = along(&centroid, &zr, 2.0);
                Some(match self.cost(&ze, fr)? {
                    Some(fe) if fe < fr => Vertex { z: ze, cost: fe },
                    _ => Vertex { z: zr, cost: fr },
                })
            }
            Some(fr) if fr < worst => {
                let zc = along(&centroid, &zr, 0.5);
                match self.cost(&zc, fr)? {
                    Some(fc) if fc <= fr => Some(Vertex { z: zc, cost: fc }),
                    _ => None,
                }
            }
            _ => {
                let zc = along(&centroid, &worst_z, 0.5);
                match self.cost(&zc, worst)? {
                    Some(fc) if fc < worst => Some(Vertex { z: zc, cost: fc }),
                    _ => None,
                }
            }
        };
        match replace {
            Some(v) => self.simplex[n - 1] = v,
            None => self.shrink()?,
        }
        self.sort();
        if self.simplex[0].cost < self.best.cost {
            self.best = self.simplex[0].clone();
        }
        Ok(())
    }
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
    let mut corners = vec![z0.clone()];
    for i in 0..z0.len() {
        let mut z = z0.clone();
        let h = settings.initial_step;
        z[i] += if z[i] + h > std::f64::consts::FRAC_PI_2 {
            -h
        } else {
            h
        };
        corners.push(z);
    }
    let mut nm = NelderMead {
        problem,
        choice,
        simplex: Vec::with_capacity(corners.len()),
        best: Vertex {
            z: z0,
            cost: f64::INFINITY,
        },
        evaluations: 0,
        cut_short: 0,
    };
    for z in corners {
        let cost = nm.exact_cost(&z)?;
        nm.simplex.push(Vertex { z, cost });
    }
    nm.sort();
    nm.best = nm.simplex[0].clone();
    let mut iterations = 0;
    while nm.spread() >= settings.sd_tolerance && iterations < settings.max_iters {
        nm.iterate()?;
        iterations += 1;
    }
    Ok(Run {
        choice,
        start,
        x: to_bounded(bounds, &nm.best.z),
        cost: nm.best.cost,
        evaluations: nm.evaluations,
        cut_short: nm.cut_short,
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
    let values = try_map(samples, Split::Adaptive, &|_, s| f(s))?;
    let worst = (0..values.len()).fold(None::<usize>, |w, k| match w {
        Some(w) if value(&values[w]) >= value(&values[k]) => Some(w),
        _ => Some(k),
    });
    Ok((values, worst))
}
