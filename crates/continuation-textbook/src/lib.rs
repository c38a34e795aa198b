//! Textbook problems with closed-form answers, with exact Jacobians (and, where the
//! two-parameter systems need them, exact second derivatives and parameter derivatives of
//! the Jacobian).
//!
//! They serve the `continuation` crate's tests, benchmarks and examples (this crate is its
//! dev-dependency, outside its public surface), and users who want to test their own setup
//! (options, root finders, meshes) against a known answer before trusting it on their own
//! system. Each type's documentation gives the equation, the parameter vector `p` and the
//! closed forms it is checked against.

use continuation::{Problem, Result};
use num_dual::{Dual64, DualNum, HyperDual64, HyperHyperDual64};

/// Writes `impl Problem for $ty` from compact method headers, so that each problem states
/// only its equations. `fn name(self, a, b, …) { … }` becomes the [`Problem`] method of that
/// name with the trait's argument types (and `-> Result<()>` where the trait has it).
/// `delay = p[k]` after the type declares one delay τ = p\[k\] \[time units\]; with `, free`
/// the delay also reports ∂τ/∂p_k = 1, so p\[k\] may be a free (continuation) parameter.
macro_rules! textbook_problem {
    ($ty:ty $(, delay = p[$k:literal] $(, $free:ident)?)?; $(fn $name:ident($($arg:tt)*) $body:block)*) => {
        impl Problem for $ty {
            $(textbook_problem!(@delay $k $($free)?);)?
            $(textbook_problem!(@fn $name($($arg)*) $body);)*
        }
    };
    (@delay $k:literal) => {
        fn n_delays(&self) -> usize {
            1
        }
        fn delay(&self, _j: usize, p: &[f64]) -> f64 {
            p[$k]
        }
    };
    (@delay $k:literal free) => {
        textbook_problem!(@delay $k);
        fn delay_dp(&self, _j: usize, _p: &[f64], ip: usize) -> f64 {
            if ip == $k { 1.0 } else { 0.0 }
        }
    };
    (@fn dim($s:ident) $body:block) => {
        fn dim(&$s) -> usize $body
    };
    (@fn n_delays($s:ident) $body:block) => {
        fn n_delays(&$s) -> usize $body
    };
    (@fn delay($s:ident, $j:pat, $p:pat) $body:block) => {
        fn delay(&$s, $j: usize, $p: &[f64]) -> f64 $body
    };
    (@fn delay_dp($s:ident, $j:pat, $p:pat, $ip:pat) $body:block) => {
        fn delay_dp(&$s, $j: usize, $p: &[f64], $ip: usize) -> f64 $body
    };
    (@fn rhs($s:ident, $x:pat, $p:pat, $f:pat) $body:block) => {
        fn rhs(&$s, $x: &[f64], $p: &[f64], $f: &mut [f64]) $body
    };
    (@fn jacobian($s:ident, $x:pat, $p:pat, $j:pat) $body:block) => {
        fn jacobian(&$s, $x: &[f64], $p: &[f64], $j: &mut [f64]) $body
    };
    (@fn dfdp($s:ident, $x:pat, $p:pat, $ip:pat, $out:pat) $body:block) => {
        fn dfdp(&$s, $x: &[f64], $p: &[f64], $ip: usize, $out: &mut [f64]) $body
    };
    (@fn second_derivative($s:ident, $x:pat, $p:pat, $a:pat, $b:pat, $out:pat) $body:block) => {
        fn second_derivative(
            &$s,
            $x: &[f64],
            $p: &[f64],
            $a: &[f64],
            $b: &[f64],
            $out: &mut [f64],
        ) -> Result<()> $body
    };
    (@fn third_derivative($s:ident, $x:pat, $p:pat, $a:pat, $b:pat, $c:pat, $out:pat) $body:block) => {
        fn third_derivative(
            &$s,
            $x: &[f64],
            $p: &[f64],
            $a: &[f64],
            $b: &[f64],
            $c: &[f64],
            $out: &mut [f64],
        ) -> Result<()> $body
    };
    (@fn jacobian_dp($s:ident, $x:pat, $p:pat, $ip:pat, $a:pat, $out:pat) $body:block) => {
        fn jacobian_dp(
            &$s,
            $x: &[f64],
            $p: &[f64],
            $ip: usize,
            $a: &[f64],
            $out: &mut [f64],
        ) -> Result<()> $body
    };
}

/// Polar normal form r' = r(μ + a r² − r⁴)·(sign), θ' = ω + b r², in Cartesian coordinates.
/// Parameter p\[0\] = μ.
/// - `a = −1` (with r⁴ term dropped, `quartic = false`): Stuart–Landau, supercritical
///   Hopf at μ = 0, cycles r = √μ, period 2π/(ω + bμ), nontrivial multiplier exp(−2μT).
/// - `a = 2`, `quartic = true`: subcritical Hopf at μ = 0, fold of cycles at μ = −1, r = 1.
#[derive(Debug)]
pub struct NormalForm {
    /// coefficient of r² in the radial equation
    pub a: f64,
    /// whether the −r⁴ term is present
    pub quartic: bool,
    /// frequency ω at r = 0
    pub omega: f64,
    /// frequency shift b per r²
    pub b: f64,
}

impl NormalForm {
    /// Stuart–Landau: r' = r(μ − r²), θ' = ω + b r² (supercritical Hopf at μ = 0).
    pub fn stuart_landau(omega: f64, b: f64) -> Self {
        Self {
            a: -1.0,
            quartic: false,
            omega,
            b,
        }
    }
    /// r' = r(μ + 2r² − r⁴), θ' = 1: subcritical Hopf at μ = 0, fold of cycles at μ = −1, r = 1.
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

textbook_problem! { NormalForm;
    fn dim(self) { 2 }
    fn rhs(self, x, p, f) {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let (g, _) = self.g(p[0], r2);
        let w = self.omega + self.b * r2;
        f[0] = g * x[0] - w * x[1];
        f[1] = w * x[0] + g * x[1];
    }
    fn jacobian(self, x, p, j) {
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
    fn dfdp(self, x, _p, _ip, out) {
        out[0] = x[0];
        out[1] = x[1];
    }
    fn second_derivative(self, x, p, a, b, out) {
        ad_second(|x, f| self.rhs_g(x, p, f), x, a, b, out);
        Ok(())
    }
    fn third_derivative(self, x, p, a, b, c, out) {
        ad_third(|x, f| self.rhs_g(x, p, f), x, [a, b, c], out);
        Ok(())
    }
}

impl NormalForm {
    /// the right-hand side for any dual number type (exact higher derivatives)
    fn rhs_g<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], p: &[f64], f: &mut [D]) {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let q = if self.quartic { 1.0 } else { 0.0 };
        let g = r2 * self.a - r2 * r2 * q + p[0];
        let w = r2 * self.b + self.omega;
        f[0] = g * x[0] - w * x[1];
        f[1] = w * x[0] + g * x[1];
    }

    /// Closed form of the Hopf normal form at μ = 0 (‖q‖ = 1): in w with
    /// x = w q + w̄ q̄, z = x0 + i x1 = √2 w, so c1 = 2(a + i b) and l1 = 2a/ω.
    pub fn hopf_c1(&self) -> (f64, f64) {
        (2.0 * self.a, 2.0 * self.b)
    }
}

/// van der Pol oscillator x'' − μ(1 − x²)x' + x = 0, p\[0\] = μ.
#[derive(Debug)]
pub struct VanDerPol;

textbook_problem! { VanDerPol;
    fn dim(self) { 2 }
    fn rhs(self, x, p, f) {
        f[0] = x[1];
        f[1] = p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0];
    }
    fn jacobian(self, x, p, j) {
        j[0] = 0.0;
        j[1] = 1.0;
        j[2] = -2.0 * p[0] * x[0] * x[1] - 1.0;
        j[3] = p[0] * (1.0 - x[0] * x[0]);
    }
    fn dfdp(self, x, _p, _ip, out) {
        out[0] = 0.0;
        out[1] = (1.0 - x[0] * x[0]) * x[1];
    }
}

/// Scalar DDE x'(t) = −a x(t − τ), p = [a, τ]: Hopf at aτ = π/2 with ω = a.
#[derive(Debug)]
pub struct LinearDelay;

textbook_problem! { LinearDelay, delay = p[1];
    fn dim(self) { 1 }
    fn rhs(self, x, p, f) {
        f[0] = -p[0] * x[1];
    }
    fn jacobian(self, _x, p, j) {
        j[0] = 0.0;
        j[1] = -p[0];
    }
    fn dfdp(self, x, _p, ip, out) {
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

textbook_problem! { DelayedStuartLandau, delay = p[2];
    fn dim(self) { 2 }
    fn rhs(self, x, p, f) {
        let (mu, k, tau) = (p[0], p[1], p[2]);
        let r2 = x[0] * x[0] + x[1] * x[1];
        let (c, s) = (tau.cos(), tau.sin());
        // e^{−iτ} z = (c x0 + s x1) + i(−s x0 + c x1)
        let rz = (c * x[0] + s * x[1], -s * x[0] + c * x[1]);
        f[0] = (mu - r2) * x[0] - x[1] + k * (x[2] - rz.0);
        f[1] = x[0] + (mu - r2) * x[1] + k * (x[3] - rz.1);
    }
    fn jacobian(self, x, p, j) {
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
    fn dfdp(self, x, p, ip, out) {
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

/// x' = −γ x + b x(t − τ), p = [γ, b, τ]; the delay is a parameter.
/// Hopf points (b < −γ < 0): ω = √(b² − γ²), τ = arccos(γ/b)/ω.
#[derive(Debug)]
pub struct ScalarDelay;

textbook_problem! { ScalarDelay, delay = p[2], free;
    fn dim(self) { 1 }
    fn rhs(self, x, p, f) {
        f[0] = -p[0] * x[0] + p[1] * x[1];
    }
    fn jacobian(self, _x, p, j) {
        j[0] = -p[0];
        j[1] = p[1];
    }
    fn dfdp(self, x, _p, ip, out) {
        out[0] = match ip {
            0 => -x[0],
            1 => x[1],
            _ => 0.0,
        };
    }
    fn second_derivative(self, _x, _p, _a, _b, out) {
        out[0] = 0.0;
        Ok(())
    }
    fn jacobian_dp(self, _x, _p, ip, a, out) {
        out[0] = match ip {
            0 => -a[0],
            1 => a[1],
            _ => 0.0,
        };
        Ok(())
    }
}

impl ScalarDelay {
    /// Closed form of the Hopf curve: (ω, τ) of the first Hopf point at (γ, b), b < −|γ|.
    pub fn hopf(gamma: f64, b: f64) -> (f64, f64) {
        let omega = (b * b - gamma * gamma).sqrt();
        (omega, (gamma / b).acos() / omega)
    }
}

/// Bogdanov–Takens normal form x' = y, y' = β1 + β2 y + x² − x y, p = [β1, β2].
/// Equilibria (x, 0) with x² = −β1; fold curve β1 = 0 (x = 0); Hopf curve x = β2 < 0,
/// β1 = −β2², ω² = −2β2; Bogdanov–Takens point at (0, 0).
#[derive(Debug)]
pub struct BogdanovTakens;

textbook_problem! { BogdanovTakens;
    fn dim(self) { 2 }
    fn rhs(self, x, p, f) {
        f[0] = x[1];
        f[1] = p[0] + p[1] * x[1] + x[0] * x[0] - x[0] * x[1];
    }
    fn jacobian(self, x, p, j) {
        j[0] = 0.0;
        j[1] = 1.0;
        j[2] = 2.0 * x[0] - x[1];
        j[3] = p[1] - x[0];
    }
    fn dfdp(self, x, _p, ip, out) {
        out[0] = 0.0;
        out[1] = if ip == 0 { 1.0 } else { x[1] };
    }
    fn second_derivative(self, _x, _p, a, b, out) {
        out[0] = 0.0;
        out[1] = 2.0 * a[0] * b[0] - a[0] * b[1] - a[1] * b[0];
        Ok(())
    }
    fn jacobian_dp(self, _x, _p, ip, a, out) {
        out[0] = 0.0;
        out[1] = if ip == 1 { a[1] } else { 0.0 };
        Ok(())
    }
}

/// x' = p1 + p2 x − x³: fold curve p1 = −2x³, p2 = 3x² (27 p1² = 4 p2³), cusp at (0, 0)
#[derive(Debug)]
pub struct Cubic;

textbook_problem! { Cubic;
    fn dim(self) { 1 }
    fn rhs(self, x, p, f) {
        f[0] = p[0] + p[1] * x[0] - x[0].powi(3);
    }
    fn jacobian(self, x, p, j) {
        j[0] = p[1] - 3.0 * x[0] * x[0];
    }
    fn dfdp(self, x, _p, ip, out) {
        out[0] = if ip == 0 { 1.0 } else { x[0] };
    }
    fn second_derivative(self, x, _p, a, b, out) {
        out[0] = -6.0 * x[0] * a[0] * b[0];
        Ok(())
    }
    fn jacobian_dp(self, _x, _p, ip, a, out) {
        out[0] = if ip == 1 { a[0] } else { 0.0 };
        Ok(())
    }
}

/// Two decoupled modes with a common delay τ, p = [b1, τ]:
/// x1' = −γ1 x1 + b1 x1(t − τ) and either x2' = −γ2 x2 + b2 x2(t − τ) (`real = None`)
/// or x2' = (b1 + β) x2 (`real = Some(β)`, a real root through 0 at b1 = −β).
#[derive(Debug)]
pub struct TwoModes {
    /// γ1 of mode 1
    pub gamma1: f64,
    /// γ2 of the delayed mode 2 (unused with `real`)
    pub gamma2: f64,
    /// b2 of the delayed mode 2 (unused with `real`)
    pub b2: f64,
    /// `Some(β)`: mode 2 is the real mode x2' = (b1 + β) x2
    pub real: Option<f64>,
}

impl TwoModes {
    /// γ, b of x' = −γx + b x(t − τ) with the first Hopf point at (τ, ω):
    /// γ = −ω cot(ωτ), b = −ω / sin(ωτ) (π/2 < ωτ < π)
    pub fn mode(tau: f64, omega: f64) -> (f64, f64) {
        let th = omega * tau;
        (-omega * th.cos() / th.sin(), -omega / th.sin())
    }
    fn row2(&self, p: &[f64]) -> [f64; 4] {
        match self.real {
            Some(beta) => [0.0, p[0] + beta, 0.0, 0.0],
            None => [0.0, -self.gamma2, 0.0, self.b2],
        }
    }
}

textbook_problem! { TwoModes, delay = p[1], free;
    fn dim(self) { 2 }
    fn rhs(self, x, p, f) {
        let r2 = self.row2(p);
        f[0] = -self.gamma1 * x[0] + p[0] * x[2];
        f[1] = (0..4).map(|i| r2[i] * x[i]).sum();
    }
    fn jacobian(self, _x, p, j) {
        j[..4].copy_from_slice(&[-self.gamma1, 0.0, p[0], 0.0]);
        j[4..].copy_from_slice(&self.row2(p));
    }
    fn dfdp(self, x, _p, ip, out) {
        let b1 = ip == 0;
        out[0] = if b1 { x[2] } else { 0.0 };
        out[1] = if b1 && self.real.is_some() { x[1] } else { 0.0 };
    }
    fn second_derivative(self, _x, _p, _a, _b, out) {
        out.iter_mut().for_each(|o| *o = 0.0);
        Ok(())
    }
    fn jacobian_dp(self, _x, p, ip, a, out) {
        // f is linear in the state and in b1: ∂J/∂b1 · a = ∂f/∂b1 evaluated at a
        self.dfdp(a, p, ip, out);
        Ok(())
    }
}

/// A nonlinear test problem with two parameter-dependent delays, p = [a, b, c, τ]:
/// f1 = −a x1 + b tanh(y2) + c x1 z2, f2 = −x2 + a tanh(y1) − b x2² + c z1,
/// y = x(t − τ), z = x(t − cτ).
#[derive(Debug)]
pub struct TanhNet;

textbook_problem! { TanhNet;
    fn dim(self) { 2 }
    fn n_delays(self) {
        2
    }
    fn delay(self, j, p) {
        if j == 0 { p[3] } else { p[3] * p[2] }
    }
    fn delay_dp(self, j, p, ip) {
        match (j, ip) {
            (0, 3) => 1.0,
            (1, 3) => p[2],
            (1, 2) => p[3],
            _ => 0.0,
        }
    }
    fn rhs(self, x, p, f) {
        let (a, b, c) = (p[0], p[1], p[2]);
        f[0] = -a * x[0] + b * x[3].tanh() + c * x[0] * x[5];
        f[1] = -x[1] + a * x[2].tanh() - b * x[1] * x[1] + c * x[4];
    }
    fn jacobian(self, x, p, j) {
        let (a, b, c) = (p[0], p[1], p[2]);
        let s = |v: f64| 1.0 / v.cosh().powi(2);
        j.iter_mut().for_each(|v| *v = 0.0);
        j[0] = -a + c * x[5];
        j[3] = b * s(x[3]);
        j[5] = c * x[0];
        j[6 + 1] = -1.0 - 2.0 * b * x[1];
        j[6 + 2] = a * s(x[2]);
        j[6 + 4] = c;
    }
    fn dfdp(self, x, _p, ip, out) {
        let v = match ip {
            0 => [-x[0], x[2].tanh()],
            1 => [x[3].tanh(), -x[1] * x[1]],
            2 => [x[0] * x[5], x[4]],
            _ => [0.0, 0.0],
        };
        out.copy_from_slice(&v);
    }
    fn second_derivative(self, x, p, a, b, out) {
        let d2 = |v: f64| -2.0 * v.tanh() / v.cosh().powi(2);
        out[0] = p[1] * d2(x[3]) * a[3] * b[3] + p[2] * (a[0] * b[5] + a[5] * b[0]);
        out[1] = -2.0 * p[1] * a[1] * b[1] + p[0] * d2(x[2]) * a[2] * b[2];
        Ok(())
    }
    fn jacobian_dp(self, x, _p, ip, a, out) {
        let s = |v: f64| 1.0 / v.cosh().powi(2);
        let v = match ip {
            0 => [-a[0], s(x[2]) * a[2]],
            1 => [s(x[3]) * a[3], -2.0 * x[1] * a[1]],
            2 => [x[5] * a[0] + x[0] * a[5], a[4]],
            _ => [0.0, 0.0],
        };
        out.copy_from_slice(&v);
        Ok(())
    }
}

/// Radial normal form in Cartesian coordinates, p = [μ1, μ2]:
/// x' = g(ρ) x − y + ε x², y' = x + g(ρ) y with ρ = x² + y², g = μ1 + μ2 ρ + c2 ρ² + c3 ρ³.
/// For ε = 0 the cycles are circles of radius √ρ with g(ρ) = 0 and period 2π.
/// - Bautin (generalised Hopf) normal form: c2 = −1, c3 = 0 (z' = (μ1 + i)z + μ2|z|²z − |z|⁴z);
/// - a cusp of cycles: c2 = 3, c3 = −1.
#[derive(Debug)]
pub struct Radial {
    /// coefficient of ρ² in g
    pub c2: f64,
    /// coefficient of ρ³ in g
    pub c3: f64,
    /// ε of the symmetry-breaking term ε x²
    pub eps: f64,
}

impl Radial {
    /// The Bautin normal form (c2 = −1, c3 = 0, ε = 0).
    pub const BAUTIN: Radial = Radial {
        c2: -1.0,
        c3: 0.0,
        eps: 0.0,
    };
    /// g, g', g'' in ρ
    fn g(&self, p: &[f64], r: f64) -> (f64, f64, f64) {
        (
            p[0] + p[1] * r + self.c2 * r * r + self.c3 * r * r * r,
            p[1] + 2.0 * self.c2 * r + 3.0 * self.c3 * r * r,
            2.0 * self.c2 + 6.0 * self.c3 * r,
        )
    }
}

impl Radial {
    /// the right-hand side for any dual number type (exact higher derivatives)
    fn rhs_g<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], p: &[f64], f: &mut [D]) {
        let r = x[0] * x[0] + x[1] * x[1];
        let g = r * p[1] + r * r * self.c2 + r * r * r * self.c3 + p[0];
        f[0] = g * x[0] - x[1] + x[0] * x[0] * self.eps;
        f[1] = x[0] + g * x[1];
    }
}

/// a₀b₀ + a₁b₁
fn dot2(a: &[f64], b: &[f64]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

textbook_problem! { Radial;
    fn dim(self) { 2 }
    fn rhs(self, x, p, f) {
        let (g, _, _) = self.g(p, dot2(x, x));
        f[0] = g * x[0] - x[1] + self.eps * x[0] * x[0];
        f[1] = x[0] + g * x[1];
    }
    fn jacobian(self, x, p, j) {
        let (g, dg, _) = self.g(p, dot2(x, x));
        for r in 0..2 {
            for c in 0..2 {
                j[r * 2 + c] = 2.0 * dg * x[r] * x[c] + if r == c { g } else { 0.0 };
            }
        }
        j[1] -= 1.0;
        j[2] += 1.0;
        j[0] += 2.0 * self.eps * x[0];
    }
    fn dfdp(self, x, _p, ip, out) {
        let s = if ip == 0 { 1.0 } else { dot2(x, x) };
        out[0] = s * x[0];
        out[1] = s * x[1];
    }
    fn second_derivative(self, x, p, a, b, out) {
        let (_, dg, ddg) = self.g(p, dot2(x, x));
        let (xa, xb, ab) = (dot2(x, a), dot2(x, b), dot2(a, b));
        for i in 0..2 {
            out[i] = 2.0 * dg * (xa * b[i] + xb * a[i] + ab * x[i]) + 4.0 * ddg * xa * xb * x[i];
        }
        out[0] += 2.0 * self.eps * a[0] * b[0];
        Ok(())
    }
    fn third_derivative(self, x, p, a, b, c, out) {
        ad_third(|x, f| self.rhs_g(x, p, f), x, [a, b, c], out);
        Ok(())
    }
    fn jacobian_dp(self, x, _p, ip, a, out) {
        // ∂g/∂μ1 = 1, ∂g'/∂μ1 = 0; ∂g/∂μ2 = ρ, ∂g'/∂μ2 = 1
        let (gp, dgp) = if ip == 0 {
            (1.0, 0.0)
        } else {
            (dot2(x, x), 1.0)
        };
        let xa = dot2(x, a);
        for i in 0..2 {
            out[i] = gp * a[i] + 2.0 * dgp * xa * x[i];
        }
        Ok(())
    }
}

/// Bautin normal form with the cubic term delayed, p = [μ1, μ2, τ], for one oscillator or
/// two coupled ones (z_o = x_{2o} + i x_{2o+1}, o = 1, 2):
/// z_o' = (μ1 + i) z_o + μ2 |z_o(t−τ)|² z_o(t−τ) − |z_o|⁴ z_o + ε (z_other − z_o).
/// (In-phase) rotating waves z = √ρ e^{iωt} solve μ1 + μ2 ρ cos ωτ − ρ² = 0,
/// ω = 1 − μ2 ρ sin ωτ, and have folds of cycles.
#[derive(Debug, Clone, Copy)]
pub struct DelayedBautin {
    /// `Some(ε)`: two oscillators coupled with strength ε; `None`: one oscillator
    pub coupling: Option<f64>,
}

impl DelayedBautin {
    /// One oscillator (dimension 2).
    pub const SINGLE: DelayedBautin = DelayedBautin { coupling: None };

    /// Two oscillators coupled with strength ε (dimension 4).
    pub fn coupled(eps: f64) -> Self {
        Self {
            coupling: Some(eps),
        }
    }

    fn oscillators(&self) -> usize {
        if self.coupling.is_some() { 2 } else { 1 }
    }

    /// oscillator `o`'s current and delayed components of the argument vector
    fn split<'a>(&self, args: &'a [f64], o: usize) -> (&'a [f64], &'a [f64]) {
        let n = self.dim();
        (&args[2 * o..2 * o + 2], &args[n + 2 * o..n + 2 * o + 2])
    }
}

textbook_problem! { DelayedBautin, delay = p[2], free;
    fn dim(self) { 2 * self.oscillators() }
    fn rhs(self, a, p, f) {
        for o in 0..self.oscillators() {
            let (x, y) = self.split(a, o);
            let (r, s) = (dot2(x, x), dot2(y, y));
            for i in 0..2 {
                f[2 * o + i] = (p[0] - r * r) * x[i] + p[1] * s * y[i];
                if let Some(eps) = self.coupling {
                    f[2 * o + i] += eps * (a[2 - 2 * o + i] - x[i]);
                }
            }
            f[2 * o] -= x[1];
            f[2 * o + 1] += x[0];
        }
    }
    fn jacobian(self, a, p, j) {
        let n = self.dim();
        j.iter_mut().for_each(|v| *v = 0.0);
        for o in 0..self.oscillators() {
            let (x, y) = self.split(a, o);
            let (r, s) = (dot2(x, x), dot2(y, y));
            for i in 0..2 {
                let row = (2 * o + i) * 2 * n;
                for k in 0..2 {
                    let id = if i == k { 1.0 } else { 0.0 };
                    j[row + 2 * o + k] = (p[0] - r * r) * id - 4.0 * r * x[i] * x[k];
                    j[row + n + 2 * o + k] = p[1] * (s * id + 2.0 * y[i] * y[k]);
                }
                if let Some(eps) = self.coupling {
                    j[row + 2 * o + i] -= eps;
                    j[row + 2 - 2 * o + i] = eps;
                }
            }
            j[2 * o * 2 * n + 2 * o + 1] -= 1.0;
            j[(2 * o + 1) * 2 * n + 2 * o] += 1.0;
        }
    }
    fn dfdp(self, a, _p, ip, out) {
        for o in 0..self.oscillators() {
            let (x, y) = self.split(a, o);
            for i in 0..2 {
                out[2 * o + i] = match ip {
                    0 => x[i],
                    1 => dot2(y, y) * y[i],
                    _ => 0.0,
                };
            }
        }
    }
    fn second_derivative(self, args, p, a, b, out) {
        for o in 0..self.oscillators() {
            let (x, y) = self.split(args, o);
            let ((ax, ay), (bx, by)) = (self.split(a, o), self.split(b, o));
            let r = dot2(x, x);
            let (xa, xb, ab) = (dot2(x, ax), dot2(x, bx), dot2(ax, bx));
            let (ya, yb, aby) = (dot2(y, ay), dot2(y, by), dot2(ay, by));
            for i in 0..2 {
                out[2 * o + i] = -4.0 * r * (xa * bx[i] + xb * ax[i] + ab * x[i])
                    - 8.0 * xa * xb * x[i]
                    + 2.0 * p[1] * (ya * by[i] + yb * ay[i] + aby * y[i]);
            }
        }
        Ok(())
    }
    fn third_derivative(self, args, p, a, b, c, out) {
        ad_third(|x, f| self.rhs_g(x, p, f), args, [a, b, c], out);
        Ok(())
    }
    fn jacobian_dp(self, args, _p, ip, a, out) {
        for o in 0..self.oscillators() {
            let ((_, y), (ax, ay)) = (self.split(args, o), self.split(a, o));
            let (s, ya) = (dot2(y, y), dot2(y, ay));
            for i in 0..2 {
                out[2 * o + i] = match ip {
                    0 => ax[i],
                    1 => s * ay[i] + 2.0 * ya * y[i],
                    _ => 0.0,
                };
            }
        }
        Ok(())
    }
}

impl DelayedBautin {
    /// the right-hand side for any dual number type (exact higher derivatives)
    fn rhs_g<D: DualNum<Primitive = f64> + Copy>(&self, a: &[D], p: &[f64], f: &mut [D]) {
        let n = self.dim();
        for o in 0..self.oscillators() {
            let (x, y) = (&a[2 * o..2 * o + 2], &a[n + 2 * o..n + 2 * o + 2]);
            let r = x[0] * x[0] + x[1] * x[1];
            let s = y[0] * y[0] + y[1] * y[1];
            for i in 0..2 {
                f[2 * o + i] = x[i] * p[0] - r * r * x[i] + s * y[i] * p[1];
                if let Some(eps) = self.coupling {
                    f[2 * o + i] += (a[2 - 2 * o + i] - x[i]) * eps;
                }
            }
            f[2 * o] -= x[1];
            f[2 * o + 1] += x[0];
        }
    }

    /// Closed form of the Hopf normal form of one oscillator at μ1 = 0 (‖q‖ = 1): the
    /// cubic term μ2|z(t−τ)|²z(t−τ) seen through φ(θ) = q e^{iθ} gives c1 = 2μ2 e^{−iτ},
    /// l1 = 2μ2 cos τ (ω = 1).
    pub fn hopf_c1(mu2: f64, tau: f64) -> (f64, f64) {
        (2.0 * mu2 * tau.cos(), -2.0 * mu2 * tau.sin())
    }
}

/// x' = p − x²: saddle-node of equilibria at p = 0, x = 0 (branches x = ±√p).
/// First derivatives only: the trait's default [`Problem::second_derivative`] reports
/// that it is missing.
#[derive(Debug)]
pub struct SaddleNode;

textbook_problem! { SaddleNode;
    fn dim(self) { 1 }
    fn rhs(self, x, p, f) {
        f[0] = p[0] - x[0] * x[0];
    }
    fn jacobian(self, x, _p, j) {
        j[0] = -2.0 * x[0];
    }
    fn dfdp(self, _x, _p, _ip, out) {
        out[0] = 1.0;
    }
}

/// x' = μx − x³, p = \[μ\]: supercritical pitchfork at (x, μ) = (0, 0), a branch point of
/// the trivial branch x = 0 (the system is odd in x); the crossing branches are x = ±√μ.
#[derive(Debug)]
pub struct Pitchfork;

textbook_problem! { Pitchfork;
    fn dim(self) { 1 }
    fn rhs(self, x, p, f) {
        f[0] = p[0] * x[0] - x[0].powi(3);
    }
    fn jacobian(self, x, p, j) {
        j[0] = p[0] - 3.0 * x[0] * x[0];
    }
    fn dfdp(self, x, _p, _ip, out) {
        out[0] = x[0];
    }
    fn second_derivative(self, x, _p, a, b, out) {
        out[0] = -6.0 * x[0] * a[0] * b[0];
        Ok(())
    }
    fn jacobian_dp(self, _x, _p, _ip, a, out) {
        out[0] = a[0];
        Ok(())
    }
}

/// q_i'' = −2ζ q_i' − q_i − k q_i(t − τ) + ε (q_j − q_i) − q_i³, state [q1, q1', q2, q2'],
/// p = [k, τ]. The linearisation at 0 splits into the in-phase mode (ε drops out) and the
/// anti-phase mode (stiffness 1 + 2ε): each has Hopf points where
/// −ω² + 2ζiω + s + k e^{−iωτ} = 0 (s = 1 or 1 + 2ε), and their crossings are double-Hopf
/// points.
#[derive(Debug)]
pub struct DelayedOscillators {
    /// damping ratio ζ
    pub zeta: f64,
    /// coupling ε
    pub eps: f64,
}

textbook_problem! { DelayedOscillators, delay = p[1], free;
    fn dim(self) { 4 }
    fn rhs(self, x, p, f) {
        let (z, e, k) = (self.zeta, self.eps, p[0]);
        f[0] = x[1];
        f[1] = -2.0 * z * x[1] - x[0] - k * x[4] + e * (x[2] - x[0]) - x[0].powi(3);
        f[2] = x[3];
        f[3] = -2.0 * z * x[3] - x[2] - k * x[6] + e * (x[0] - x[2]) - x[2].powi(3);
    }
    fn jacobian(self, x, p, j) {
        let (z, e, k) = (self.zeta, self.eps, p[0]);
        j.iter_mut().for_each(|v| *v = 0.0);
        j[1] = 1.0;
        j[8] = -1.0 - e - 3.0 * x[0] * x[0];
        j[8 + 1] = -2.0 * z;
        j[8 + 2] = e;
        j[8 + 4] = -k;
        j[16 + 3] = 1.0;
        j[24] = e;
        j[24 + 2] = -1.0 - e - 3.0 * x[2] * x[2];
        j[24 + 3] = -2.0 * z;
        j[24 + 6] = -k;
    }
    fn dfdp(self, x, _p, ip, out) {
        out.iter_mut().for_each(|v| *v = 0.0);
        if ip == 0 {
            out[1] = -x[4];
            out[3] = -x[6];
        }
    }
    fn second_derivative(self, x, _p, a, b, out) {
        out.iter_mut().for_each(|v| *v = 0.0);
        out[1] = -6.0 * x[0] * a[0] * b[0];
        out[3] = -6.0 * x[2] * a[2] * b[2];
        Ok(())
    }
    fn jacobian_dp(self, _x, _p, ip, a, out) {
        out.iter_mut().for_each(|v| *v = 0.0);
        if ip == 0 {
            out[1] = -a[4];
            out[3] = -a[6];
        }
        Ok(())
    }
}

/// Two oscillators with a delayed coupling, built so that the double-Hopf point, both cycle
/// families and the torus (Neimark–Sacker) curves of one of them are known in closed form
/// (z1 = x0 + i x1, z2 = x2 + i x3, p = [μ, ν, τ]):
///
/// z1' = (μ + i(ω1 + b|z1|²) − |z1|² + e|z2|²) z1,
/// z2' = (ν + iω2 + c|z1(t−τ)|² − |z2|²) z2 + κ (z2(t−τ) − z2(t)).
///
/// With `delayed = false` the system is the ODE with τ = 0 (|z1(t)|² in the z2 equation, no
/// κ term). Let Ω solve Ω = ω2 − κ sin Ωτ (unique for κτ < 1; ODE: Ω = ω2) and
/// D = κ(1 − cos Ωτ) (ODE: 0). Then
/// - the equilibrium 0 has Hopf points on μ = 0 (frequency ω1) and on ν = D (frequency Ω),
///   a double-Hopf point at (μ, ν) = (0, D);
/// - cycle 1: |z1|² = μ, z2 = 0, period T = 2π/(ω1 + bμ); along it the z2-block is
///   time-invariant, so its Neimark–Sacker curve is ν = −cμ + D (μ > 0) with the multiplier
///   e^{iθ}, θ = ΩT mod 2π ([`TorusTestBed::torus_curve_one`]);
/// - cycle 2: z1 = 0, |z2|² = ν − D, frequency Ω; its Neimark–Sacker curve is
///   μ = −e(ν − D) (ν > D), θ = 2πω1/Ω mod 2π.
#[derive(Debug, Clone, Copy)]
pub struct TorusTestBed {
    /// frequency ω1 of oscillator 1 at zero amplitude \[rad / time unit\]
    pub omega1: f64,
    /// frequency shift b of oscillator 1 per |z1|²
    pub b: f64,
    /// effect c of the (delayed) |z1|² on the growth rate of oscillator 2
    pub c: f64,
    /// effect e of |z2|² on the growth rate of oscillator 1
    pub e: f64,
    /// frequency ω2 of oscillator 2 \[rad / time unit\]
    pub omega2: f64,
    /// delayed self-coupling κ of oscillator 2 (ignored without delay)
    pub kappa: f64,
    /// whether the delay τ = p\[2\] is present (false: the ODE)
    pub delayed: bool,
}

impl TorusTestBed {
    /// The example of the torus research note: ω1 = 1, b = 0.2, c = 0.5, e = 0.3, ω2 = 1.3,
    /// κ = 0.3 (use τ = 2.5 = p\[2\], so that τ/T ≈ 0.4 and the delayed points wrap).
    pub fn delayed() -> Self {
        Self {
            omega1: 1.0,
            b: 0.2,
            c: 0.5,
            e: 0.3,
            omega2: 1.3,
            kappa: 0.3,
            delayed: true,
        }
    }

    /// The same oscillators without delay (κ = 0, τ unused): an ODE.
    pub fn ode() -> Self {
        Self {
            kappa: 0.0,
            delayed: false,
            ..Self::delayed()
        }
    }

    /// (Ω, D) for the delay τ: Ω = ω2 − κ sin Ωτ (fixed-point iteration, a contraction for
    /// κτ < 1) and D = κ(1 − cos Ωτ); the second Hopf curve is ν = D with frequency Ω.
    pub fn second_hopf(&self, tau: f64) -> (f64, f64) {
        if !self.delayed {
            return (self.omega2, 0.0);
        }
        let mut w = self.omega2;
        for _ in 0..500 {
            w = self.omega2 - self.kappa * (w * tau).sin();
        }
        (w, self.kappa * (1.0 - (w * tau).cos()))
    }

    /// The Neimark–Sacker curve of cycle 1 at μ > 0 for the delay τ: (ν, T, θ) with
    /// ν = −cμ + D, the period T = 2π/(ω1 + bμ) and the angle θ = ΩT reduced to \[0, 2π).
    pub fn torus_curve_one(&self, mu: f64, tau: f64) -> (f64, f64, f64) {
        let (w, d) = self.second_hopf(tau);
        let period = 2.0 * std::f64::consts::PI / (self.omega1 + self.b * mu);
        let theta = (w * period).rem_euclid(2.0 * std::f64::consts::PI);
        (-self.c * mu + d, period, theta)
    }

    /// Jacobian with respect to [x, y] (4 × 8, row-major), y = x(t − τ) (y = x without delay)
    fn jacobian8(&self, x: &[f64], y: &[f64], p: &[f64], j: &mut [f64; 32]) {
        let (r1, r2) = (dot2(&x[..2], &x[..2]), dot2(&x[2..], &x[2..]));
        let s = dot2(&y[..2], &y[..2]);
        let (g1, w1) = (p[0] - r1 + self.e * r2, self.omega1 + self.b * r1);
        let kappa = if self.delayed { self.kappa } else { 0.0 };
        let g2 = p[1] - kappa + self.c * s - r2;
        let (b, e, c) = (self.b, self.e, self.c);
        *j = [0.0; 32];
        // f0 = g1 x0 − w1 x1, f1 = w1 x0 + g1 x1
        j[0] = g1 - 2.0 * x[0] * x[0] - 2.0 * b * x[0] * x[1];
        j[1] = -2.0 * x[0] * x[1] - w1 - 2.0 * b * x[1] * x[1];
        j[2] = 2.0 * e * x[0] * x[2];
        j[3] = 2.0 * e * x[0] * x[3];
        j[8] = w1 + 2.0 * b * x[0] * x[0] - 2.0 * x[0] * x[1];
        j[9] = 2.0 * b * x[0] * x[1] + g1 - 2.0 * x[1] * x[1];
        j[10] = 2.0 * e * x[1] * x[2];
        j[11] = 2.0 * e * x[1] * x[3];
        // f2 = g2 x2 − ω2 x3 + κ y2, f3 = ω2 x2 + g2 x3 + κ y3
        j[18] = g2 - 2.0 * x[2] * x[2];
        j[19] = -2.0 * x[2] * x[3] - self.omega2;
        j[20] = 2.0 * c * y[0] * x[2];
        j[21] = 2.0 * c * y[1] * x[2];
        j[22] = kappa;
        j[26] = self.omega2 - 2.0 * x[2] * x[3];
        j[27] = g2 - 2.0 * x[3] * x[3];
        j[28] = 2.0 * c * y[0] * x[3];
        j[29] = 2.0 * c * y[1] * x[3];
        j[31] = kappa;
    }

    /// the stacked arguments' current and delayed parts (the same without delay)
    fn split<'a>(&self, args: &'a [f64]) -> (&'a [f64], &'a [f64]) {
        if self.delayed {
            (&args[..4], &args[4..8])
        } else {
            (&args[..4], &args[..4])
        }
    }

    /// J·v of the arguments' Jacobian (4 × 8) applied to the stacked direction v, with the
    /// delayed columns folded onto the current ones without delay
    fn apply8(&self, j: &[f64; 32], v: &[f64], out: &mut [f64]) {
        let (vx, vy) = self.split(v);
        for (r, o) in out.iter_mut().enumerate().take(4) {
            *o = (0..4)
                .map(|k| j[r * 8 + k] * vx[k] + j[r * 8 + 4 + k] * vy[k])
                .sum();
        }
    }
}

textbook_problem! { TorusTestBed;
    fn dim(self) { 4 }
    fn n_delays(self) { usize::from(self.delayed) }
    fn delay(self, _j, p) { p[2] }
    fn delay_dp(self, _j, _p, ip) { if ip == 2 { 1.0 } else { 0.0 } }
    fn rhs(self, args, p, f) {
        let (x, y) = self.split(args);
        let (r1, r2) = (dot2(&x[..2], &x[..2]), dot2(&x[2..], &x[2..]));
        let s = dot2(&y[..2], &y[..2]);
        let (g1, w1) = (p[0] - r1 + self.e * r2, self.omega1 + self.b * r1);
        let kappa = if self.delayed { self.kappa } else { 0.0 };
        let g2 = p[1] - kappa + self.c * s - r2;
        f[0] = g1 * x[0] - w1 * x[1];
        f[1] = w1 * x[0] + g1 * x[1];
        f[2] = g2 * x[2] - self.omega2 * x[3] + kappa * y[2];
        f[3] = self.omega2 * x[2] + g2 * x[3] + kappa * y[3];
    }
    fn jacobian(self, args, p, j) {
        let (x, y) = self.split(args);
        let mut j8 = [0.0; 32];
        self.jacobian8(x, y, p, &mut j8);
        for r in 0..4 {
            for k in 0..4 {
                if self.delayed {
                    j[r * 8 + k] = j8[r * 8 + k];
                    j[r * 8 + 4 + k] = j8[r * 8 + 4 + k];
                } else {
                    j[r * 4 + k] = j8[r * 8 + k] + j8[r * 8 + 4 + k];
                }
            }
        }
    }
    fn dfdp(self, args, _p, ip, out) {
        out.iter_mut().for_each(|v| *v = 0.0);
        match ip {
            0 => out[..2].copy_from_slice(&args[..2]),
            1 => out[2..4].copy_from_slice(&args[2..4]),
            _ => {}
        }
    }
    // The Jacobian is a quadratic polynomial of the arguments X, so
    // (J(X + a) − J(X − a))·b / 2 = f_XX[a, b] exactly (up to rounding).
    fn second_derivative(self, args, p, a, b, out) {
        let na = args.len();
        let (mut plus, mut minus) = ([0.0; 8], [0.0; 8]);
        for i in 0..na {
            plus[i] = args[i] + a[i];
            minus[i] = args[i] - a[i];
        }
        let (mut jp, mut jm) = ([0.0; 32], [0.0; 32]);
        let ((xp, yp), (xm, ym)) = (self.split(&plus[..na]), self.split(&minus[..na]));
        self.jacobian8(xp, yp, p, &mut jp);
        self.jacobian8(xm, ym, p, &mut jm);
        let (mut op, mut om) = ([0.0; 4], [0.0; 4]);
        self.apply8(&jp, b, &mut op);
        self.apply8(&jm, b, &mut om);
        for r in 0..4 {
            out[r] = 0.5 * (op[r] - om[r]);
        }
        Ok(())
    }
    // f is a cubic polynomial, so f_XX(X)[a, b] is linear in X and
    // f_XX(X + c)[a, b] − f_XX(X)[a, b] = f_XXX[a, b, c] exactly (up to rounding).
    fn third_derivative(self, args, p, a, b, c, out) {
        let na = args.len();
        let mut shifted = [0.0; 8];
        for i in 0..na {
            shifted[i] = args[i] + c[i];
        }
        let (mut hi, mut lo) = ([0.0; 4], [0.0; 4]);
        self.second_derivative(&shifted[..na], p, a, b, &mut hi)?;
        self.second_derivative(args, p, a, b, &mut lo)?;
        for r in 0..4 {
            out[r] = hi[r] - lo[r];
        }
        Ok(())
    }
    fn jacobian_dp(self, _args, _p, ip, a, out) {
        out.iter_mut().for_each(|v| *v = 0.0);
        match ip {
            0 => out[..2].copy_from_slice(&a[..2]),
            1 => out[2..4].copy_from_slice(&a[2..4]),
            _ => {}
        }
        Ok(())
    }
}

impl TorusTestBed {
    /// Closed form of the double-Hopf normal form at (μ, ν) = (0, D) for the delay τ
    /// (pair 1: ω1, pair 2: Ω; ‖q‖ = 1, so z_o = √2 w_o): with s = 1 + κτ e^{−iΩτ}
    /// (= Δ'(iΩ) of the z2 block; 1 without delay), g2100 = 2(−1 + i b), g1011 = 2e,
    /// g1110 = 2c/s, g0021 = −2/s. Returns [g2100, g1011, g1110, g0021].
    pub fn double_hopf_coefficients(&self, tau: f64) -> [num_complex::Complex64; 4] {
        use num_complex::Complex64 as C;
        let (w, _) = self.second_hopf(tau);
        let s = if self.delayed {
            C::new(1.0, 0.0) + self.kappa * tau * C::new(0.0, -w * tau).exp()
        } else {
            C::new(1.0, 0.0)
        };
        [
            C::new(-2.0, 2.0 * self.b),
            C::new(2.0 * self.e, 0.0),
            C::new(2.0 * self.c, 0.0) / s,
            C::new(-2.0, 0.0) / s,
        ]
    }
}

// ---------------------------------------------------------------------------------------
// Exact derivatives by nested dual numbers, for right-hand sides written once for any
// dual number type: `eval(x, f)` with the stacked arguments x.

/// f_x(x)\[a, b\] = ∂²f/∂ε1∂ε2 f(x + ε1 a + ε2 b)
fn ad_second(
    eval: impl Fn(&[HyperDual64], &mut [HyperDual64]),
    x: &[f64],
    a: &[f64],
    b: &[f64],
    out: &mut [f64],
) {
    let xs: Vec<HyperDual64> = (0..x.len())
        .map(|i| HyperDual64::new(x[i], a[i], b[i], 0.0))
        .collect();
    let mut f = vec![HyperDual64::from(0.0); out.len()];
    eval(&xs, &mut f);
    for (o, v) in out.iter_mut().zip(&f) {
        *o = v.eps1eps2;
    }
}

/// f_xxx(x)\[a, b, c\] = ∂³/∂ε1∂ε2∂ε3 f(x + ε1 a + ε2 b + ε3 c)
fn ad_third(
    eval: impl Fn(&[HyperHyperDual64], &mut [HyperHyperDual64]),
    x: &[f64],
    [a, b, c]: [&[f64]; 3],
    out: &mut [f64],
) {
    let xs: Vec<HyperHyperDual64> = (0..x.len())
        .map(|i| HyperHyperDual64::new(x[i], a[i], b[i], c[i], 0.0, 0.0, 0.0, 0.0))
        .collect();
    let mut f = vec![HyperHyperDual64::from(0.0); out.len()];
    eval(&xs, &mut f);
    for (o, v) in out.iter_mut().zip(&f) {
        *o = v.eps1eps2eps3;
    }
}

/// A right-hand side written once for any dual number type, in its arguments and its
/// parameters: every derivative of [`Problem`] follows exactly.
trait DualRhs {
    fn eval<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], p: &[D], f: &mut [D]);
}

/// the parameters as constants of a dual type
fn constants<D: DualNum<Primitive = f64> + Copy>(p: &[f64]) -> Vec<D> {
    p.iter().map(|&v| D::from(v)).collect()
}

fn dual_rhs<R: DualRhs>(r: &R, x: &[f64], p: &[f64], f: &mut [f64]) {
    r.eval(x, p, f);
}

fn dual_jacobian<R: DualRhs>(r: &R, n: usize, x: &[f64], p: &[f64], jac: &mut [f64]) {
    let na = x.len();
    let pd: Vec<Dual64> = constants(p);
    let mut f = vec![Dual64::from(0.0); n];
    let mut xs: Vec<Dual64> = x.iter().map(|&v| Dual64::from(v)).collect();
    for j in 0..na {
        xs[j].eps = 1.0;
        r.eval(&xs, &pd, &mut f);
        xs[j].eps = 0.0;
        for i in 0..n {
            jac[i * na + j] = f[i].eps;
        }
    }
}

fn dual_dfdp<R: DualRhs>(r: &R, x: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
    let xs: Vec<Dual64> = x.iter().map(|&v| Dual64::from(v)).collect();
    let mut pd: Vec<Dual64> = constants(p);
    pd[ip].eps = 1.0;
    let mut f = vec![Dual64::from(0.0); out.len()];
    r.eval(&xs, &pd, &mut f);
    for (o, v) in out.iter_mut().zip(&f) {
        *o = v.eps;
    }
}

fn dual_jacobian_dp<R: DualRhs>(
    r: &R,
    x: &[f64],
    p: &[f64],
    ip: usize,
    a: &[f64],
    out: &mut [f64],
) {
    let xs: Vec<HyperDual64> = (0..x.len())
        .map(|i| HyperDual64::new(x[i], a[i], 0.0, 0.0))
        .collect();
    let mut pd: Vec<HyperDual64> = constants(p);
    pd[ip].eps2 = 1.0;
    let mut f = vec![HyperDual64::from(0.0); out.len()];
    r.eval(&xs, &pd, &mut f);
    for (o, v) in out.iter_mut().zip(&f) {
        *o = v.eps1eps2;
    }
}

/// `impl Problem` for a [`DualRhs`] type: dimension, delays (`delay(self, j, p)` and
/// `delay_dp(self, j, p, ip)` bodies) and every derivative by dual numbers.
macro_rules! dual_problem {
    ($ty:ty, dim = $n:expr, delays = $k:expr,
     delay($s1:ident, $j:ident, $p:ident) $dbody:block,
     delay_dp($s2:ident, $j2:ident, $p2:ident, $ip:ident) $dpbody:block) => {
        impl Problem for $ty {
            fn dim(&self) -> usize {
                $n
            }
            fn n_delays(&self) -> usize {
                $k
            }
            fn delay(&$s1, $j: usize, $p: &[f64]) -> f64 $dbody
            fn delay_dp(&$s2, $j2: usize, $p2: &[f64], $ip: usize) -> f64 $dpbody
            fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
                dual_rhs(self, x, p, f);
            }
            fn jacobian(&self, x: &[f64], p: &[f64], jac: &mut [f64]) {
                dual_jacobian(self, $n, x, p, jac);
            }
            fn dfdp(&self, x: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
                dual_dfdp(self, x, p, ip, out);
            }
            fn second_derivative(
                &self,
                x: &[f64],
                p: &[f64],
                a: &[f64],
                b: &[f64],
                out: &mut [f64],
            ) -> Result<()> {
                let pc: Vec<HyperDual64> = constants(p);
                ad_second(|x, f| self.eval(x, &pc, f), x, a, b, out);
                Ok(())
            }
            fn third_derivative(
                &self,
                x: &[f64],
                p: &[f64],
                a: &[f64],
                b: &[f64],
                c: &[f64],
                out: &mut [f64],
            ) -> Result<()> {
                let pc: Vec<HyperHyperDual64> = constants(p);
                ad_third(|x, f| self.eval(x, &pc, f), x, [a, b, c], out);
                Ok(())
            }
            fn jacobian_dp(
                &self,
                x: &[f64],
                p: &[f64],
                ip: usize,
                a: &[f64],
                out: &mut [f64],
            ) -> Result<()> {
                dual_jacobian_dp(self, x, p, ip, a, out);
                Ok(())
            }
        }
    };
}

/// The Mackey–Glass equation x' = β x(t−τ)/(1 + x(t−τ)ⁿ) − γ x, p = [β, n, τ] (DDE-Biftool's
/// demo `Mackey-Glass`, γ = 1 there). Nontrivial equilibrium x* = (β/γ − 1)^{1/n}.
/// For β = 2, n = 10, γ = 1: x* = 1, A0 = −1, A1 = −4, so the first Hopf point in τ has
/// ω = √15, τ = arccos(−1/4)/√15 (from iω = −1 − 4e^{−iωτ}).
#[derive(Debug, Clone, Copy)]
pub struct MackeyGlass {
    /// decay rate γ \[1 / time unit\]
    pub gamma: f64,
}

impl DualRhs for MackeyGlass {
    fn eval<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], p: &[D], f: &mut [D]) {
        let y = x[1];
        let yn = (y.ln() * p[1]).exp();
        f[0] = p[0] * y / (yn + 1.0) - x[0] * self.gamma;
    }
}

dual_problem!(MackeyGlass, dim = 1, delays = 1,
    delay(self, _j, p) { p[2] },
    delay_dp(self, _j, _p, ip) { if ip == 2 { 1.0 } else { 0.0 } });

/// DDE-Biftool's neuron demo (Shayer & Campbell 2000), p = [κ, β, a12, a21, τ1, τ2, τs]
/// (DDE-Biftool's order):
/// x1' = −κ x1 + β tanh x1(t−τs) + a12 tanh x2(t−τ2),
/// x2' = −κ x2 + β tanh x2(t−τs) + a21 tanh x1(t−τ1).
/// Delays in the order τ1, τ2, τs (stacked arguments [x, x(t−τ1), x(t−τ2), x(t−τs)]).
/// x = 0 is an equilibrium for all parameters; the system is odd (x ↦ −x).
#[derive(Debug, Clone, Copy)]
pub struct Neuron;

impl DualRhs for Neuron {
    fn eval<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], p: &[D], f: &mut [D]) {
        let (kappa, beta, a12, a21) = (p[0], p[1], p[2], p[3]);
        f[0] = -kappa * x[0] + beta * x[6].tanh() + a12 * x[5].tanh();
        f[1] = -kappa * x[1] + beta * x[7].tanh() + a21 * x[2].tanh();
    }
}

dual_problem!(Neuron, dim = 2, delays = 3,
    delay(self, j, p) { p[4 + j] },
    delay_dp(self, j, _p, ip) { if ip == 4 + j { 1.0 } else { 0.0 } });
