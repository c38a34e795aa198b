//! Textbook problems with closed-form answers, shared by the integration tests.
#![allow(dead_code)]

use continuation::Problem;

/// Polar normal form r' = r(μ + a r² − r⁴)·(sign), θ' = ω + b r², in Cartesian coordinates.
/// Parameter p[0] = μ.
/// - `a = −1` (with r⁴ term dropped, `quartic = false`): Stuart–Landau, supercritical
///   Hopf at μ = 0, cycles r = √μ, period 2π/(ω + bμ), nontrivial multiplier exp(−2μT).
/// - `a = 2`, `quartic = true`: subcritical Hopf at μ = 0, fold of cycles at μ = −1, r = 1.
#[derive(Debug)]
pub struct NormalForm {
    pub a: f64,
    pub quartic: bool,
    pub omega: f64,
    pub b: f64,
}

impl NormalForm {
    pub fn stuart_landau(omega: f64, b: f64) -> Self {
        Self {
            a: -1.0,
            quartic: false,
            omega,
            b,
        }
    }
    pub fn subcritical() -> Self {
        Self {
            a: 2.0,
            quartic: true,
            omega: 1.0,
            b: 0.0,
        }
    }
    /// g(r²) with r' = r g
    fn g(&self, mu: f64, r2: f64) -> (f64, f64) {
        let q = if self.quartic { 1.0 } else { 0.0 };
        (mu + self.a * r2 - q * r2 * r2, self.a - 2.0 * q * r2)
    }
}

impl Problem for NormalForm {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let (g, _) = self.g(p[0], r2);
        let w = self.omega + self.b * r2;
        f[0] = g * x[0] - w * x[1];
        f[1] = w * x[0] + g * x[1];
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let (g, dg) = self.g(p[0], r2);
        let w = self.omega + self.b * r2;
        let (x0, x1) = (x[0], x[1]);
        // ∂(r²)/∂x = 2x
        j[0] = g + dg * 2.0 * x0 * x0 - self.b * 2.0 * x0 * x1;
        j[1] = dg * 2.0 * x1 * x0 - w - self.b * 2.0 * x1 * x1;
        j[2] = w + self.b * 2.0 * x0 * x0 + dg * 2.0 * x0 * x1;
        j[3] = self.b * 2.0 * x1 * x0 + g + dg * 2.0 * x1 * x1;
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
        out[0] = x[0];
        out[1] = x[1];
    }
}

/// van der Pol oscillator x'' − μ(1 − x²)x' + x = 0, p[0] = μ.
#[derive(Debug)]
pub struct VanDerPol;

impl Problem for VanDerPol {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        f[0] = x[1];
        f[1] = p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0];
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        j[0] = 0.0;
        j[1] = 1.0;
        j[2] = -2.0 * p[0] * x[0] * x[1] - 1.0;
        j[3] = p[0] * (1.0 - x[0] * x[0]);
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
        out[0] = 0.0;
        out[1] = (1.0 - x[0] * x[0]) * x[1];
    }
}

/// Scalar DDE x'(t) = −a x(t − τ), p = [a, τ]: Hopf at aτ = π/2 with ω = a.
#[derive(Debug)]
pub struct LinearDelay;

impl Problem for LinearDelay {
    fn dim(&self) -> usize {
        1
    }
    fn n_delays(&self) -> usize {
        1
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[1]
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        f[0] = -p[0] * x[1];
    }
    fn jacobian(&self, _x: &[f64], p: &[f64], j: &mut [f64]) {
        j[0] = 0.0;
        j[1] = -p[0];
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        out[0] = if ip == 0 { -x[1] } else { 0.0 };
    }
}

/// Stuart–Landau oscillator with delayed coupling (complex z = x0 + i x1):
/// z' = (μ + i) z − |z|² z + κ (z(t−τ) − e^{−iτ} z(t)), p = [μ, κ, τ].
/// The coupling vanishes on z = √μ e^{it}: a known periodic solution (period 2π) for every τ,
/// and a Hopf point at μ = 0 with ω = 1. In the co-rotating frame w = z e^{−it} the cycle is
/// the equilibrium w = √μ of w' = (μ − |w|²) w + κ e^{−iτ}(w(t−τ) − w(t)), so its Floquet
/// multipliers are exp(2π λ) for the characteristic roots λ of that equilibrium.
#[derive(Debug)]
pub struct DelayedStuartLandau;

impl Problem for DelayedStuartLandau {
    fn dim(&self) -> usize {
        2
    }
    fn n_delays(&self) -> usize {
        1
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[2]
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        let (mu, k, tau) = (p[0], p[1], p[2]);
        let r2 = x[0] * x[0] + x[1] * x[1];
        let (c, s) = (tau.cos(), tau.sin());
        // e^{−iτ} z = (c x0 + s x1) + i(−s x0 + c x1)
        let rz = (c * x[0] + s * x[1], -s * x[0] + c * x[1]);
        f[0] = (mu - r2) * x[0] - x[1] + k * (x[2] - rz.0);
        f[1] = x[0] + (mu - r2) * x[1] + k * (x[3] - rz.1);
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        let (mu, k, tau) = (p[0], p[1], p[2]);
        let r2 = x[0] * x[0] + x[1] * x[1];
        let (c, s) = (tau.cos(), tau.sin());
        // row-major 2 × 4: [∂/∂x0, ∂/∂x1, ∂/∂x0(t−τ), ∂/∂x1(t−τ)]
        j[0] = mu - r2 - 2.0 * x[0] * x[0] - k * c;
        j[1] = -2.0 * x[0] * x[1] - 1.0 - k * s;
        j[2] = k;
        j[3] = 0.0;
        j[4] = 1.0 - 2.0 * x[0] * x[1] + k * s;
        j[5] = mu - r2 - 2.0 * x[1] * x[1] - k * c;
        j[6] = 0.0;
        j[7] = k;
    }
    fn dfdp(&self, x: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
        match ip {
            0 => {
                out[0] = x[0];
                out[1] = x[1];
            }
            1 => {
                // ∂/∂κ: z(t−τ) − e^{−iτ} z(t)
                let (c, s) = (p[2].cos(), p[2].sin());
                out[0] = x[2] - (c * x[0] + s * x[1]);
                out[1] = x[3] - (-s * x[0] + c * x[1]);
            }
            _ => {
                out[0] = f64::NAN;
                out[1] = f64::NAN;
            }
        }
    }
}
