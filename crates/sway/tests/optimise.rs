//! The generic optimisation layer (issue 10): known optima of a smooth bounded problem
//! (Rosenbrock) and of a problem with the mitigation's structure (bounded variables, a
//! discrete choice, worst case over samples) whose optimum is known in closed form.

use sway::SwayError;
use sway::mitigation::optimise::{
    Bound, MixedProblem, OptimiserSettings, minimise, starting_points, worst_case,
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
