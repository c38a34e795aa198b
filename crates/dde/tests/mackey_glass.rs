//! Mackey–Glass `x' = β·x(t − τ)/(1 + x(t − τ)ⁿ) − γ·x` (β = 0.2, γ = 0.1, n = 10, τ = 17,
//! `x ≡ 0.5` for `t ≤ 0`), the example of `examples/mackey_glass.rs`, against two independent
//! references: the closed form on `[0, τ]`, and a fixed-step classical Runge–Kutta method of
//! steps written here (grid step h = τ/1700, delayed values read off the grid, midpoints by
//! cubic Hermite interpolation; global error O(h⁴)).

use dde::{DdeProblem, Options, Solution, solve_dde};
use nalgebra::SVector;

type V1 = SVector<f64, 1>;

const BETA: f64 = 0.2;
const GAMMA: f64 = 0.1;
const N: f64 = 10.0;
const TAU: f64 = 17.0;
const X0: f64 = 0.5;

fn production(u: f64) -> f64 {
    BETA * u / (1.0 + u.powf(N))
}

struct MackeyGlass;

impl DdeProblem<1> for MackeyGlass {
    fn delays(&self) -> &[f64] {
        &[TAU]
    }
    fn history(&self, _t: f64) -> V1 {
        V1::from([X0])
    }
    fn rhs(&self, _t: f64, x: &V1, xd: &[V1], dx: &mut V1) {
        dx[0] = production(xd[0][0]) - GAMMA * x[0];
    }
}

/// Classical RK4 on the grid `t_k = k·h` with `τ = m·h`: the delayed argument of a stage is a
/// grid value (stages 1 and 4) or a midpoint, from the cubic Hermite interpolant of the grid
/// values and their derivatives (stages 2 and 3). Returns `x(t_k)` for `k = 0 … steps`.
fn method_of_steps_rk4(m: usize, steps: usize) -> Vec<f64> {
    let h = TAU / m as f64;
    let mut x = vec![X0];
    let mut f: Vec<f64> = Vec::new(); // f(t_k) = x'(t_k), filled as the steps go
    // x(t) for t = (j + θ)·h, j possibly negative (history)
    let past = |x: &[f64], f: &[f64], j: isize, theta: f64| -> f64 {
        if j < 0 {
            return X0;
        }
        let j = j as usize;
        if theta == 0.0 {
            return x[j];
        }
        // midpoint of [t_j, t_{j+1}] from the Hermite cubic
        (x[j] + x[j + 1]) / 2.0 + h * (f[j] - f[j + 1]) / 8.0
    };
    for k in 0..steps {
        let d = k as isize - m as isize; // grid index of t_k − τ
        let u0 = past(&x, &f, d, 0.0);
        // on [t_{d}, t_{d+1}] ⊂ (−∞, 0] the history is constant
        let uh = if d < 0 { X0 } else { past(&x, &f, d, 0.5) };
        let u1 = past(&x, &f, d + 1, 0.0);
        let xk = x[k];
        let k1 = production(u0) - GAMMA * xk;
        let k2 = production(uh) - GAMMA * (xk + 0.5 * h * k1);
        let k3 = production(uh) - GAMMA * (xk + 0.5 * h * k2);
        let k4 = production(u1) - GAMMA * (xk + h * k3);
        f.push(k1);
        x.push(xk + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4));
    }
    x
}

/// the solution on [0, `t_end`] at rtol 1e-10, atol 1e-13
fn accurate(t_end: f64) -> Solution<1> {
    solve_dde(
        &MackeyGlass,
        0.0,
        t_end,
        Options::with_tolerances(1e-10, 1e-13),
    )
    .unwrap()
}

#[test]
fn first_interval_matches_closed_form() {
    // on [0, τ] the delayed term is the history: x = c/γ + (x₀ − c/γ) e^{−γt}, c = β x₀/(1 + x₀ⁿ)
    let sol = accurate(TAU);
    let c = production(X0);
    for k in 0..=34 {
        let t = 0.5 * f64::from(k);
        let exact = c / GAMMA + (X0 - c / GAMMA) * (-GAMMA * t).exp();
        let got = sol.eval(t).unwrap()[0];
        // tolerance: 10× the requested rtol, the continuous extension included
        assert!((got - exact).abs() < 1e-9, "t = {t}: {got} vs {exact}");
    }
}

#[test]
fn matches_independent_fixed_step_rk4_over_six_delays() {
    // t ∈ [0, 102]: six delay intervals, several oscillations, before chaos amplifies the
    // difference of two accurate solutions noticeably (largest Lyapunov exponent ≈ 0.007)
    let m = 1700; // h = 0.01
    let steps = 6 * m;
    let reference = method_of_steps_rk4(m, steps);
    let t_end = 6.0 * TAU;
    let sol = accurate(t_end);
    let h = TAU / m as f64;
    let mut worst: f64 = 0.0;
    for k in (0..=steps).step_by(100) {
        let got = sol.eval(k as f64 * h).unwrap()[0];
        worst = worst.max((got - reference[k]).abs());
    }
    // measured: 1.6e-9 (the adaptive solution at rtol 1e-10 and the O(h⁴) error of the
    // reference, grown over six delays); 1e-7 leaves a margin for other platforms' libm
    assert!(worst < 1e-7, "largest difference {worst:e}");
}
