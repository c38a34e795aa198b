//! The generic optimisation layer: known optima of a smooth bounded problem
//! (Rosenbrock) and of a problem with the mitigation's structure (bounded variables, a
//! discrete choice, worst case over samples) whose optimum is known in closed form.

use sway::SwayError;
use sway_model::optimise::{
    Bound, Bounded, MixedProblem, OptimiserSettings, minimise, starting_points, worst_case,
};

struct Rosenbrock {
    bounds: [Bound; 2],
}

impl MixedProblem for Rosenbrock {
    fn bounds(&self) -> &[Bound] {
        &self.bounds
    }
    fn choices(&self) -> usize {
        1
    }
    fn cost(&self, _choice: usize, x: &[f64]) -> Result<f64, SwayError> {
        Ok((1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2))
    }
}

fn tight() -> OptimiserSettings {
    OptimiserSettings {
        seed: 7,
        random_starts: 3,
        max_iters: 3000,
        sd_tolerance: 1e-15,
        initial_step: 0.5,
    }
}

#[test]
fn rosenbrock_interior_minimum() {
    // reference: the minimum (1, 1), f = 0, inside [−2, 2] × [−1, 3]; tolerance 1e-4 on x
    // (Nelder–Mead run to a simplex cost spread of 1e-15)
    let p = Rosenbrock {
        bounds: [Bound::new(-2.0, 2.0), Bound::new(-1.0, 3.0)],
    };
    let m = minimise(&p, &[vec![-1.5, 2.0]], &tight()).unwrap();
    assert!(
        (m.x[0] - 1.0).abs() < 1e-4 && (m.x[1] - 1.0).abs() < 1e-4,
        "{:?}",
        m.x
    );
    assert!(m.cost < 1e-8, "{}", m.cost);
}

#[test]
fn rosenbrock_minimum_on_a_bound() {
    // reference: with x ≤ 0.5 the minimum is at x = 0.5, y = x² = 0.25, f = (1 − 0.5)² = 0.25
    // (for fixed x, y = x² is best, and (1 − x)² decreases up to the bound); tolerance 1e-4
    let p = Rosenbrock {
        bounds: [Bound::new(-2.0, 0.5), Bound::new(-1.0, 3.0)],
    };
    let m = minimise(&p, &[vec![-1.5, 2.0]], &tight()).unwrap();
    assert!(
        (m.x[0] - 0.5).abs() < 1e-4 && (m.x[1] - 0.25).abs() < 1e-4,
        "{:?}",
        m.x
    );
    assert!((m.cost - 0.25).abs() < 1e-8, "{}", m.cost);
}

/// max over samples s of a_c + |x₀ − s| + (x₁ − b_c)², x ∈ \[0, 1\]², choice c ∈ {0, 1, 2}
struct WorstOverSamples {
    bounds: [Bound; 2],
}

const A: [f64; 3] = [0.3, 0.1, 0.2];
const B: [f64; 3] = [0.5, 1.2, 0.3];
const SAMPLES: [f64; 3] = [0.2, 0.5, 0.9];

impl MixedProblem for WorstOverSamples {
    fn bounds(&self) -> &[Bound] {
        &self.bounds
    }
    fn choices(&self) -> usize {
        3
    }
    fn cost(&self, c: usize, x: &[f64]) -> Result<f64, SwayError> {
        let (values, worst) = worst_case(
            &SAMPLES,
            |s| Ok::<f64, SwayError>(A[c] + (x[0] - s).abs() + (x[1] - B[c]).powi(2)),
            |v| *v,
        )?;
        Ok(values[worst.unwrap()])
    }
}

#[test]
fn bounded_discrete_worst_case_minimum() {
    // reference, in closed form: max_s |x₀ − s| is smallest at the mid-range
    // x₀ = (0.2 + 0.9)/2 = 0.55 (value 0.35); (x₁ − b_c)² is smallest at b_c clipped to
    // [0, 1]. Choice 0: 0.3 + 0.35 = 0.65; choice 1: 0.1 + 0.35 + (1 − 1.2)² = 0.49 with
    // x₁ = 1 on the bound; choice 2: 0.2 + 0.35 = 0.55. Optimum: choice 1, (0.55, 1), 0.49.
    // Tolerance 1e-4 on x and cost (the kink of the max at x₀ = 0.55 is where Nelder–Mead
    // converges slowest).
    let p = WorstOverSamples {
        bounds: [Bound::new(0.0, 1.0), Bound::new(0.0, 1.0)],
    };
    let m = minimise(&p, &[vec![0.1, 0.1]], &tight()).unwrap();
    assert_eq!(m.choice, 1);
    assert!(
        (m.x[0] - 0.55).abs() < 1e-4 && (m.x[1] - 1.0).abs() < 1e-4,
        "{:?}",
        m.x
    );
    assert!((m.cost - 0.49).abs() < 1e-4, "{}", m.cost);
    // every choice was tried from every start
    assert_eq!(m.runs.len(), 3 * (1 + 3));
}

#[test]
fn results_depend_only_on_the_seed() {
    // reference: a second run on a 1-thread pool must agree bit for bit; another seed
    // draws other starting points
    let p = WorstOverSamples {
        bounds: [Bound::new(0.0, 1.0), Bound::new(0.0, 1.0)],
    };
    let s = OptimiserSettings {
        max_iters: 50,
        ..tight()
    };
    let a = minimise(&p, &[], &s).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = pool.install(|| minimise(&p, &[], &s).unwrap());
    assert_eq!(a, b);
    let other = OptimiserSettings { seed: 8, ..s };
    assert_ne!(
        starting_points(&p.bounds, &[], &s),
        starting_points(&p.bounds, &[], &other)
    );
}

#[test]
fn the_bound_transform_round_trips() {
    // reference: x = lo + (hi − lo)(1 + sin z)/2 inverted by asin, to 1e-12
    let b = Bound::new(-10.0, 0.0);
    for x in [-10.0, -7.3, -5.0, -0.1, 0.0] {
        assert!((b.to_bounded(b.to_free(x)) - x).abs() < 1e-12);
    }
    assert_eq!(b.to_bounded(1e6), b.to_bounded(1e6).clamp(-10.0, 0.0));
}

/// Rosenbrock, answering [`Bounded::Above`] for every trial proven above its cutoff (as a
/// problem whose evaluation stops early does)
struct CutShort(Rosenbrock);

impl MixedProblem for CutShort {
    fn bounds(&self) -> &[Bound] {
        self.0.bounds()
    }
    fn choices(&self) -> usize {
        1
    }
    fn cost(&self, c: usize, x: &[f64]) -> Result<f64, SwayError> {
        self.0.cost(c, x)
    }
    fn cost_unless_above(&self, c: usize, x: &[f64], cutoff: f64) -> Result<Bounded, SwayError> {
        let f = self.0.cost(c, x)?;
        Ok(if f > cutoff {
            Bounded::Above
        } else {
            Bounded::Exact(f)
        })
    }
}

#[test]
fn nelder_mead_follows_argmins_path() {
    // reference: argmin's NelderMead (an independent implementation of the same method and
    // decision order) from the same simplex: the same best point and cost, bit for bit, and
    // the same number of cost evaluations (200 iterations, no spread test)
    use argmin::core::{CostFunction, Executor, State};
    struct Free<'a>(&'a Rosenbrock, &'a std::cell::Cell<usize>);
    impl CostFunction for Free<'_> {
        type Param = Vec<f64>;
        type Output = f64;
        fn cost(&self, z: &Vec<f64>) -> Result<f64, argmin::core::Error> {
            self.1.set(self.1.get() + 1);
            let x: Vec<f64> = self
                .0
                .bounds
                .iter()
                .zip(z)
                .map(|(b, &z)| b.to_bounded(z))
                .collect();
            Ok(self.0.cost(0, &x).unwrap())
        }
    }
    let p = Rosenbrock {
        bounds: [Bound::new(-2.0, 2.0), Bound::new(-1.0, 3.0)],
    };
    let settings = OptimiserSettings {
        random_starts: 0,
        max_iters: 200,
        sd_tolerance: 0.0,
        initial_step: 0.5,
        ..tight()
    };
    let x0 = [-1.5, 2.0];
    let ours = minimise(&p, &[x0.to_vec()], &settings).unwrap();

    let z0: Vec<f64> = p
        .bounds
        .iter()
        .zip(&x0)
        .map(|(b, &x)| b.to_free(x))
        .collect();
    let mut simplex = vec![z0.clone()];
    for i in 0..2 {
        let mut z = z0.clone();
        z[i] += if z[i] + 0.5 > std::f64::consts::FRAC_PI_2 {
            -0.5
        } else {
            0.5
        };
        simplex.push(z);
    }
    let count = std::cell::Cell::new(0);
    let solver = argmin::solver::neldermead::NelderMead::new(simplex)
        .with_sd_tolerance(0.0)
        .unwrap();
    let theirs = Executor::new(Free(&p, &count), solver)
        .configure(|s| s.max_iters(200))
        .run()
        .unwrap();
    let z = theirs.state().get_best_param().unwrap();
    let x: Vec<f64> = p
        .bounds
        .iter()
        .zip(z)
        .map(|(b, &z)| b.to_bounded(z))
        .collect();
    assert_eq!(ours.x, x);
    assert_eq!(ours.cost, theirs.state().get_best_cost());
    assert_eq!(ours.evaluations, count.get());
    assert_eq!(ours.runs[0].cut_short, 0);
}

#[test]
fn trials_cut_short_leave_the_path_unchanged() {
    // reference: the same problem evaluated exactly — the optimum, its cost and the number
    // of evaluations agree bit for bit, while a good part of the trials were rejected
    // without their exact cost
    let bounds = [Bound::new(-2.0, 2.0), Bound::new(-1.0, 3.0)];
    let s = OptimiserSettings {
        max_iters: 300,
        ..tight()
    };
    let exact = minimise(&Rosenbrock { bounds }, &[vec![-1.5, 2.0]], &s).unwrap();
    let cut = minimise(&CutShort(Rosenbrock { bounds }), &[vec![-1.5, 2.0]], &s).unwrap();
    assert_eq!(
        (cut.choice, &cut.x, cut.cost),
        (exact.choice, &exact.x, exact.cost)
    );
    assert_eq!(cut.evaluations, exact.evaluations);
    let rejected: usize = cut.runs.iter().map(|r| r.cut_short).sum();
    assert!(
        rejected * 10 > cut.evaluations,
        "{rejected} of {}",
        cut.evaluations
    );
    assert!(exact.runs.iter().all(|r| r.cut_short == 0));
}
