//! The Mackey–Glass equation of blood-cell production (Mackey & Glass, *Science* 1977),
//!
//! `x'(t) = β·x(t − τ) / (1 + x(t − τ)ⁿ) − γ·x(t)`,
//!
//! with the classical β = 0.2, γ = 0.1, n = 10 and τ = 17, where the solution is chaotic. The
//! history is `x ≡ 0.5` for `t ≤ 0`.
//!
//! The program integrates to t = 500, prints a few values, and checks what is known of the
//! solution: on `[0, τ]` it has a closed form (the delayed term is the constant history there);
//! it stays in (0, 1.5) — positive because the production term is, so `x' ≥ −γx`; bounded
//! because the production term `β·u/(1 + uⁿ)` is at most `β·0.9·9^{−1/10}` ≈ 0.1445 (at
//! `uⁿ = 1/(n − 1)`), so `x' < 0` wherever `x > 1.445`; and it oscillates around the positive
//! equilibrium `x* = (β/γ − 1)^{1/n} = 1`.
//!
//! Run with `cargo run -p dde --example mackey_glass`.

use dde::{DdeProblem, DdeSolver, Flow, Options, StepView};
use nalgebra::SVector;

type V1 = SVector<f64, 1>;

/// Mackey–Glass with a constant history.
struct MackeyGlass {
    beta: f64,
    gamma: f64,
    n: f64,
    tau: [f64; 1],
    history: f64,
}

impl DdeProblem<1> for MackeyGlass {
    fn delays(&self) -> &[f64] {
        &self.tau
    }
    fn history(&self, _t: f64) -> V1 {
        V1::from([self.history])
    }
    fn rhs(&self, _t: f64, x: &V1, xd: &[V1], dx: &mut V1) {
        let u = xd[0][0];
        dx[0] = self.beta * u / (1.0 + u.powf(self.n)) - self.gamma * x[0];
    }
}

/// The solution on `[0, τ]`, where `x(t − τ)` is the history `x₀`: a linear ODE with the
/// constant input `c = β·x₀/(1 + x₀ⁿ)`, so `x(t) = c/γ + (x₀ − c/γ)·e^{−γt}`.
fn first_interval(p: &MackeyGlass, t: f64) -> f64 {
    let x0 = p.history;
    let c = p.beta * x0 / (1.0 + x0.powf(p.n));
    c / p.gamma + (x0 - c / p.gamma) * (-p.gamma * t).exp()
}

fn main() -> Result<(), dde::Error> {
    let p = MackeyGlass {
        beta: 0.2,
        gamma: 0.1,
        n: 10.0,
        tau: [17.0],
        history: 0.5,
    };
    let t_end = 500.0;
    let mut solver = DdeSolver::new(&p, 0.0, Options::with_tolerances(1e-9, 1e-12))?;

    // on the fly: the range of x, its largest values after the transient (t ≥ 200), and
    // the worst deviation from the closed form on [0, τ]
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut maxima: Vec<(f64, f64)> = Vec::new();
    let mut first_error: f64 = 0.0;
    let mut samples = Vec::new();
    let mut next_sample = 0.0;
    let mut prev_slope = f64::NAN;
    let mut observer = |s: &StepView<'_, 1>| {
        let (t0, t1) = (s.t_start(), s.t_end());
        for k in 0..=8 {
            let t = t0 + (t1 - t0) * f64::from(k) / 8.0;
            let x = s.eval(t)[0];
            lo = lo.min(x);
            hi = hi.max(x);
            if t <= p.tau[0] {
                first_error = first_error.max((x - first_interval(&p, t)).abs());
            }
        }
        // a local maximum: the slope x(t) − x(t − h) changes sign from + to −
        let slope = s.x()[0] - s.eval(t0)[0];
        if t0 >= 200.0 && prev_slope > 0.0 && slope <= 0.0 {
            maxima.push((t0, s.eval(t0)[0]));
        }
        prev_slope = slope;
        while next_sample <= t1 {
            samples.push((next_sample, s.eval(next_sample)[0]));
            next_sample += 50.0;
        }
        Flow::Continue
    };
    solver.integrate(&p, t_end, &[], &mut observer)?;

    println!("Mackey–Glass, β = 0.2, γ = 0.1, n = 10, τ = 17, x ≡ 0.5 for t ≤ 0");
    println!("{:>8}  {:>12}", "t", "x(t)");
    for (t, x) in &samples {
        println!("{t:>8.1}  {x:>12.8}");
    }
    let stats = solver.stats();
    println!(
        "{} steps accepted, {} rejected, {} right-hand side evaluations",
        stats.accepted, stats.rejected, stats.rhs_evals
    );
    maxima.sort_by(|a, b| b.1.total_cmp(&a.1));
    println!("largest maxima for t ≥ 200 (approximate, at step ends):");
    for (t, x) in maxima.iter().take(3) {
        println!("    x ≈ {x:.6} near t = {t:.2}");
    }
    println!("range of x on [0, {t_end}]: [{lo:.6}, {hi:.6}]");
    println!("largest deviation from the closed form on [0, τ]: {first_error:.2e}");

    let equilibrium = (p.beta / p.gamma - 1.0).powf(1.0 / p.n);
    let checks = [
        ("x stays in (0, 1.5)", lo > 0.0 && hi < 1.5),
        ("closed form on [0, τ] to 1e-8", first_error < 1e-8),
        (
            "oscillates around x* = 1",
            lo < equilibrium && hi > equilibrium,
        ),
        ("keeps oscillating after t = 200", maxima.len() >= 10),
    ];
    let mut ok = true;
    for (what, passed) in checks {
        println!("check: {what}: {}", if passed { "ok" } else { "FAILED" });
        ok &= passed;
    }
    if !ok {
        std::process::exit(1);
    }
    Ok(())
}
