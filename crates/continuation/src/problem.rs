//! The dynamical system: x'(t) = f(x(t), x(t−τ1), …, x(t−τk); p).

/// A system of ordinary (k = 0) or constant-delay (k ≥ 1) differential equations
///
/// x'(t) = f(x(t), x(t−τ1), …, x(t−τk); p)
///
/// with state dimension n = [`Problem::dim`] and parameter vector p.
///
/// Arguments are passed stacked: `args = [x(t), x(t−τ1), …, x(t−τk)]`, length n·(k+1).
/// The Jacobian is the n × n·(k+1) matrix [∂f/∂x, ∂f/∂x_τ1, …, ∂f/∂x_τk] stored row-major.
///
/// Exact derivatives are expected (e.g. from automatic differentiation with `num-dual`).
/// Finite differences are available as an explicit option: call [`fd_jacobian`] and
/// [`fd_dfdp`] from your implementation.
///
/// Values outside the model's domain should be returned as NaN; the solvers then report
/// [`crate::Error::NonFinite`].
///
/// The delays may depend on parameters. A delay that depends on a free (continuation)
/// parameter must report that dependence through [`Problem::delay_dp`], so that the
/// defining systems can differentiate x(t − τ(p)) exactly.
pub trait Problem {
    /// state dimension n
    fn dim(&self) -> usize;
    /// number of delays k (0 for an ODE)
    fn n_delays(&self) -> usize {
        0
    }
    /// delay τ_j (> 0) for the parameters p [time units of the model]
    fn delay(&self, _j: usize, _p: &[f64]) -> f64 {
        0.0
    }
    /// derivative ∂τ_j/∂p_ip of delay j with respect to parameter `ip` (0 when the delay
    /// does not depend on it, the default) [time units per parameter unit]
    fn delay_dp(&self, _j: usize, _p: &[f64], _ip: usize) -> f64 {
        0.0
    }
    /// right-hand side f(args; p) written to `f` (length n)
    fn rhs(&self, args: &[f64], p: &[f64], f: &mut [f64]);
    /// Jacobian n × n·(k+1), row-major: `jac[i * n * (k+1) + j] = ∂f_i/∂args_j`
    fn jacobian(&self, args: &[f64], p: &[f64], jac: &mut [f64]);
    /// derivative ∂f/∂p_ip written to `out` (length n)
    fn dfdp(&self, args: &[f64], p: &[f64], ip: usize, out: &mut [f64]);
    /// Second derivative of f along two directions of the stacked arguments:
    /// `out = Σ_jk ∂²f/∂args_j∂args_k · a_j · b_k` (length n; `a`, `b` of length n·(k+1)).
    ///
    /// Needed by the codimension-one defining systems (Hopf and fold curves, folds of
    /// cycles), whose Jacobians contain derivatives of ∂f/∂x. Exact values are expected
    /// (e.g. nested dual numbers); [`fd_second_derivative`] is the explicit finite-difference
    /// fallback. The default reports [`crate::Error::MissingDerivative`].
    fn second_derivative(
        &self,
        _args: &[f64],
        _p: &[f64],
        _a: &[f64],
        _b: &[f64],
        _out: &mut [f64],
    ) -> crate::Result<()> {
        Err(crate::Error::MissingDerivative {
            what: "second_derivative",
        })
    }
    /// Mixed derivative of f: `out = Σ_j ∂²f/∂args_j∂p_ip · a_j` (length n), i.e. the
    /// derivative of the Jacobian with respect to parameter `ip` applied to `a`.
    /// [`fd_jacobian_dp`] is the explicit finite-difference fallback. The default reports
    /// [`crate::Error::MissingDerivative`].
    fn jacobian_dp(
        &self,
        _args: &[f64],
        _p: &[f64],
        _ip: usize,
        _a: &[f64],
        _out: &mut [f64],
    ) -> crate::Result<()> {
        Err(crate::Error::MissingDerivative {
            what: "jacobian_dp",
        })
    }
    /// Third derivative of f along three directions of the stacked arguments:
    /// `out = Σ_jkl ∂³f/∂args_j∂args_k∂args_l · a_j · b_k · c_l` (length n; `a`, `b`, `c`
    /// of length n·(k+1)).
    ///
    /// Needed by the normal forms ([`crate::HopfNormalForm`], [`crate::DoubleHopfNormalForm`]:
    /// the cubic coefficients of the reduced equations). Exact values are expected (e.g.
    /// nested dual numbers, `num_dual::HyperHyperDual64`); [`fd_third_derivative`] is the
    /// explicit finite-difference fallback. The default reports
    /// [`crate::Error::MissingDerivative`].
    fn third_derivative(
        &self,
        _args: &[f64],
        _p: &[f64],
        _a: &[f64],
        _b: &[f64],
        _c: &[f64],
        _out: &mut [f64],
    ) -> crate::Result<()> {
        Err(crate::Error::MissingDerivative {
            what: "third_derivative",
        })
    }
    /// How smooth f is where the normal forms would be computed. The normal forms need f
    /// to be C³ at the equilibrium; a problem that is only C¹ there (e.g. a brush tyre at
    /// zero slip) answers [`Smoothness::C1AtKinks`], and the normal-form functions then
    /// report [`crate::Error::NotSmooth`] instead of a number (decide criticality from the
    /// cycles, [`crate::criticality`]). Default: [`Smoothness::Smooth`].
    fn smoothness(&self) -> Smoothness {
        Smoothness::Smooth
    }
    /// number of switching functions (0 for a smooth f)
    fn n_switching(&self) -> usize {
        0
    }
    /// Switching functions g(args; p) (length [`Problem::n_switching`]) whose zeros mark where
    /// f is less smooth (e.g. a C¹ kink of a tire curve at zero slip). The Floquet computation
    /// puts mesh points there, which restores the collocation's order of convergence.
    fn switching(&self, _args: &[f64], _p: &[f64], _g: &mut [f64]) {}
}

/// How smooth the right-hand side is at the equilibria of interest
/// ([`Problem::smoothness`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Smoothness {
    /// f is (at least) C³: normal-form coefficients are defined
    Smooth,
    /// f is only C¹ where switching functions vanish (kinks of the second derivative, e.g.
    /// the brush tyre at zero slip, which is where a straight-running equilibrium sits):
    /// no normal form; criticality comes from the computed cycles
    C1AtKinks,
}

/// Central-difference Jacobian (an explicit fallback for problems without exact derivatives;
/// error O(h²) for smooth f, but biased by O(h) where f is only C¹).
pub fn fd_jacobian<P: Problem + ?Sized>(problem: &P, args: &[f64], p: &[f64], jac: &mut [f64]) {
    let n = problem.dim();
    let na = args.len();
    let mut a = args.to_vec();
    let mut fp = vec![0.0; n];
    let mut fm = vec![0.0; n];
    for j in 0..na {
        let h = 1e-6 * (1.0 + args[j].abs());
        a[j] = args[j] + h;
        problem.rhs(&a, p, &mut fp);
        a[j] = args[j] - h;
        problem.rhs(&a, p, &mut fm);
        a[j] = args[j];
        for i in 0..n {
            jac[i * na + j] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
}

/// Central-difference derivative with respect to parameter `ip` (explicit fallback).
pub fn fd_dfdp<P: Problem + ?Sized>(
    problem: &P,
    args: &[f64],
    p: &[f64],
    ip: usize,
    out: &mut [f64],
) {
    let n = problem.dim();
    let mut q = p.to_vec();
    let mut fp = vec![0.0; n];
    let mut fm = vec![0.0; n];
    let h = 1e-6 * (1.0 + p[ip].abs());
    q[ip] = p[ip] + h;
    problem.rhs(args, &q, &mut fp);
    q[ip] = p[ip] - h;
    problem.rhs(args, &q, &mut fm);
    for i in 0..n {
        out[i] = (fp[i] - fm[i]) / (2.0 * h);
    }
}

/// Central-difference second derivative along `a` and `b` from the exact Jacobian
/// (explicit fallback for [`Problem::second_derivative`]): the derivative of J(args)·b
/// in direction `a`; error O(h²) for smooth f.
pub fn fd_second_derivative<P: Problem + ?Sized>(
    problem: &P,
    args: &[f64],
    p: &[f64],
    a: &[f64],
    b: &[f64],
    out: &mut [f64],
) -> crate::Result<()> {
    let n = problem.dim();
    let na = args.len();
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 {
        out[..n].iter_mut().for_each(|o| *o = 0.0);
        return Ok(());
    }
    let args_norm = args.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let h = 1e-5 * (1.0 + args_norm) / scale;
    let mut jac = vec![0.0; n * na];
    let mut shifted = args.to_vec();
    let mut jb = |sign: f64, acc: &mut [f64]| {
        for (s, (x, d)) in shifted.iter_mut().zip(args.iter().zip(a)) {
            *s = x + sign * h * d;
        }
        problem.jacobian(&shifted, p, &mut jac);
        for i in 0..n {
            let row: f64 = (0..na).map(|j| jac[i * na + j] * b[j]).sum();
            acc[i] += sign * row / (2.0 * h);
        }
    };
    out[..n].iter_mut().for_each(|o| *o = 0.0);
    jb(1.0, out);
    jb(-1.0, out);
    Ok(())
}

/// Central-difference mixed derivative (∂J/∂p_ip)·a from the exact Jacobian (explicit
/// fallback for [`Problem::jacobian_dp`]); error O(h²) for smooth f.
pub fn fd_jacobian_dp<P: Problem + ?Sized>(
    problem: &P,
    args: &[f64],
    p: &[f64],
    ip: usize,
    a: &[f64],
    out: &mut [f64],
) -> crate::Result<()> {
    let n = problem.dim();
    let na = args.len();
    let h = 1e-6 * (1.0 + p[ip].abs());
    let mut q = p.to_vec();
    let mut jac = vec![0.0; n * na];
    out[..n].iter_mut().for_each(|o| *o = 0.0);
    for sign in [1.0, -1.0] {
        q[ip] = p[ip] + sign * h;
        problem.jacobian(args, &q, &mut jac);
        for i in 0..n {
            let row: f64 = (0..na).map(|j| jac[i * na + j] * a[j]).sum();
            out[i] += sign * row / (2.0 * h);
        }
    }
    Ok(())
}

/// Central-difference third derivative along `a`, `b`, `c` from the exact second
/// derivative (explicit fallback for [`Problem::third_derivative`]): the derivative of
/// f_xx(args)\[a, b\] in direction `c`; error O(h²) for smooth f.
pub fn fd_third_derivative<P: Problem + ?Sized>(
    problem: &P,
    args: &[f64],
    p: &[f64],
    abc: [&[f64]; 3],
    out: &mut [f64],
) -> crate::Result<()> {
    let [a, b, c] = abc;
    let n = problem.dim();
    let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    out[..n].iter_mut().for_each(|o| *o = 0.0);
    if scale == 0.0 {
        return Ok(());
    }
    let args_norm = args.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let h = 1e-4 * (1.0 + args_norm) / scale;
    let mut shifted = args.to_vec();
    let mut buf = vec![0.0; n];
    for sign in [1.0, -1.0] {
        for (s, (x, d)) in shifted.iter_mut().zip(args.iter().zip(c)) {
            *s = x + sign * h * d;
        }
        problem.second_derivative(&shifted, p, a, b, &mut buf)?;
        for i in 0..n {
            out[i] += sign * buf[i] / (2.0 * h);
        }
    }
    Ok(())
}
