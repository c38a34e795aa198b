//! Two-parameter curves of Hopf points and folds of equilibria, codimension-two points:
//! every check against a closed form (or, for the Jacobians, central differences).

use continuation::*;
use nalgebra::DMatrix;
use num_complex::Complex64;

fn cont(step: f64, max_step: f64) -> Continuation {
    Continuation::new(ContinuationOptions {
        initial_step: step,
        max_step,
        ..Default::default()
    })
}

/// x' = −γ x + b x(t − τ), p = [γ, b, τ]; the delay is a parameter.
/// Hopf points (b < −γ < 0): ω = √(b² − γ²), τ = arccos(γ/b)/ω.
struct ScalarDelay;

impl Problem for ScalarDelay {
    fn dim(&self) -> usize {
        1
    }
    fn n_delays(&self) -> usize {
        1
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[2]
    }
    fn delay_dp(&self, _j: usize, _p: &[f64], ip: usize) -> f64 {
        if ip == 2 { 1.0 } else { 0.0 }
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        f[0] = -p[0] * x[0] + p[1] * x[1];
    }
    fn jacobian(&self, _x: &[f64], p: &[f64], j: &mut [f64]) {
        j[0] = -p[0];
        j[1] = p[1];
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        out[0] = match ip {
            0 => -x[0],
            1 => x[1],
            _ => 0.0,
        };
    }
    fn second_derivative(
        &self,
        _x: &[f64],
        _p: &[f64],
        _a: &[f64],
        _b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out[0] = 0.0;
        Ok(())
    }
    fn jacobian_dp(
        &self,
        _x: &[f64],
        _p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out[0] = match ip {
            0 => -a[0],
            1 => a[1],
            _ => 0.0,
        };
        Ok(())
    }
}

/// closed form of the Hopf curve of [`ScalarDelay`]: (ω, τ) at b
fn scalar_hopf(gamma: f64, b: f64) -> (f64, f64) {
    let omega = (b * b - gamma * gamma).sqrt();
    (omega, (gamma / b).acos() / omega)
}

/// Hopf point of an equilibrium branch x = 0 continued in parameter `ip` from `p[ip]`
fn hopf_on_branch<P: Problem>(problem: &P, p: Vec<f64>, ip: usize, steps: usize) -> HopfPoint {
    let c = cont(0.05, 0.1);
    let p0 = p[ip];
    let mut eq = EquilibriumSystem::new(problem, p, ip, ChebyshevRoots::default()).unwrap();
    let dir = eq.parameter_direction();
    let mut u0 = vec![0.0; problem.dim()];
    u0.push(p0);
    let mut br = c.start(&mut eq, &u0, &dir).unwrap();
    c.extend(&mut eq, &mut br, steps).unwrap();
    let (i, sp) = br.first(SpecialKind::Hopf).expect("a Hopf point");
    assert_eq!(sp.location, Location::Located);
    eq.hopf_point(&br.points[i].u, sp.transversality.unwrap())
        .unwrap()
}

#[test]
fn delay_as_free_parameter_of_equilibria_and_hopf_points() {
    // reference: closed form τ* = arccos(γ/b)/ω, ω = √(b² − γ²) at γ = 1, b = −2;
    // location tolerance 1e-10 in τ, required 1e-8; ω from Newton-refined roots, 1e-10
    let hopf = hopf_on_branch(&ScalarDelay, vec![1.0, -2.0, 0.3], 2, 40);
    let (omega, tau) = scalar_hopf(1.0, -2.0);
    assert!(
        (hopf.parameter - tau).abs() < 1e-8,
        "τ = {}",
        hopf.parameter
    );
    assert!((hopf.omega - omega).abs() < 1e-10 * omega);
    assert!(hopf.transversality > 0.0, "unstable beyond the Hopf delay");
}

#[test]
fn analytic_hopf_curve_with_the_delay_as_parameter() {
    // reference: closed form ω = √(b² − γ²), τ = arccos(γ/b)/ω (γ = 1). Tolerance 1e-9
    // relative: Newton stops at updates below 1e-10 and converges quadratically, so the
    // points are exact to ~1e-14; 1e-9 leaves room for the conditioning of the defining
    // system (its Jacobian has entries up to |b|τ ~ 5).
    let hopf = hopf_on_branch(&ScalarDelay, vec![1.0, -2.0, 0.3], 2, 40);
    let c = cont(0.05, 0.2);
    for sign in [1.0, -1.0] {
        let mut hc = HopfCurveSystem::new(
            &ScalarDelay,
            vec![1.0, -2.0, 0.3],
            [2, 1],
            ChebyshevRoots::default(),
        )
        .unwrap();
        let (guess, dir) = hc.start_at_hopf(&hopf, 2).unwrap();
        let dir: Vec<f64> = dir.iter().map(|d| sign * d).collect();
        let mut curve = c.start(&mut hc, &guess, &dir).unwrap();
        c.extend(&mut hc, &mut curve, 30).unwrap();
        let mut checked = 0;
        for pt in &curve.points {
            let (tau, b) = (pt.parameter, pt.secondary_parameter.unwrap());
            assert!(b < -1.0, "b = {b}");
            let (omega, tau_exact) = scalar_hopf(1.0, b);
            assert!(
                (hc.omega(&pt.u) - omega).abs() < 1e-9 * omega,
                "ω at b = {b}"
            );
            assert!((tau - tau_exact).abs() < 1e-9 * tau_exact, "τ at b = {b}");
            assert!(hc.state(&pt.u)[0].abs() < 1e-12);
            // the eigenvector solves Δ(iω) v = 0 and the remaining roots are stable
            let v = hc.eigenvector(&pt.u)[0];
            let delta = Complex64::new(1.0, omega) - b * Complex64::new(0.0, -omega * tau).exp();
            assert!((delta * v).norm() < 1e-9);
            assert_eq!(pt.is_stable(), Some(true));
            checked += 1;
        }
        assert!(checked > 30);
        // the curve moves along b in the requested direction
        let b_end = curve.points.last().unwrap().secondary_parameter.unwrap();
        assert!(sign * (b_end + 2.0) > 0.1, "b_end = {b_end}");
    }
}

/// Bogdanov–Takens normal form x' = y, y' = β1 + β2 y + x² − x y, p = [β1, β2].
/// Equilibria (x, 0) with x² = −β1; fold curve β1 = 0 (x = 0); Hopf curve x = β2 < 0,
/// β1 = −β2², ω² = −2β2; Bogdanov–Takens point at (0, 0).
struct BogdanovTakens;

impl Problem for BogdanovTakens {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        f[0] = x[1];
        f[1] = p[0] + p[1] * x[1] + x[0] * x[0] - x[0] * x[1];
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        j[0] = 0.0;
        j[1] = 1.0;
        j[2] = 2.0 * x[0] - x[1];
        j[3] = p[1] - x[0];
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        out[0] = 0.0;
        out[1] = if ip == 0 { 1.0 } else { x[1] };
    }
    fn second_derivative(
        &self,
        _x: &[f64],
        _p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out[0] = 0.0;
        out[1] = 2.0 * a[0] * b[0] - a[0] * b[1] - a[1] * b[0];
        Ok(())
    }
    fn jacobian_dp(
        &self,
        _x: &[f64],
        _p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out[0] = 0.0;
        out[1] = if ip == 1 { a[1] } else { 0.0 };
        Ok(())
    }
}

#[test]
fn ode_hopf_curve_ends_at_a_bogdanov_takens_point() {
    // reference: closed form of the normal form, Hopf curve β1 = −β2², x = β2, ω = √(−2β2),
    // BT point at (0, 0). Curve points to 1e-9 (Newton-converged, see the DDE test).
    // The BT point is a turning point of p1 = β2 located to 1e-10 in p1 by the engine;
    // required |β2|, |β1| < 1e-8.
    // Hopf point on the equilibrium x = −1 (β1 = −1) continued in β2 from −2: β2 = −1
    let c = cont(0.05, 0.1);
    let mut eq = EquilibriumSystem::new(
        &BogdanovTakens,
        vec![-1.0, -2.0],
        1,
        ChebyshevRoots::default(),
    )
    .unwrap();
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[-1.0, 0.0, -2.0], &dir).unwrap();
    c.extend(&mut eq, &mut br, 40).unwrap();
    let (i, sp) = br.first(SpecialKind::Hopf).expect("Hopf point");
    let hopf = eq
        .hopf_point(&br.points[i].u, sp.transversality.unwrap())
        .unwrap();
    assert!((hopf.parameter + 1.0).abs() < 1e-8);
    assert!((hopf.omega - 2f64.sqrt()).abs() < 1e-10);

    let mut hc = HopfCurveSystem::new(
        &BogdanovTakens,
        vec![-1.0, -1.0],
        [1, 0],
        ChebyshevRoots::default(),
    )
    .unwrap();
    let (guess, dir) = hc.start_at_hopf(&hopf, 1).unwrap();
    let mut curve = c.start(&mut hc, &guess, &dir).unwrap();
    c.extend(&mut hc, &mut curve, 80).unwrap();
    for pt in &curve.points {
        let (beta2, beta1) = hc.parameters(&pt.u);
        let w = hc.omega(&pt.u);
        assert!(
            (beta1 + beta2 * beta2).abs() < 1e-9,
            "β1 = {beta1}, β2 = {beta2}"
        );
        assert!((w * w + 2.0 * beta2).abs() < 1e-9, "ω = {w}, β2 = {beta2}");
        assert!((hc.state(&pt.u)[0] - beta2).abs() < 1e-9);
    }
    let bt: Vec<_> = hc
        .codim2_points(&curve)
        .into_iter()
        .filter(|c| c.kind == SpecialKind::BogdanovTakens)
        .collect();
    assert_eq!(bt.len(), 1, "{bt:?}");
    assert!(
        bt[0].p1.abs() < 1e-8 && bt[0].p2.abs() < 1e-8,
        "{:?}",
        bt[0]
    );
    assert!(bt[0].omegas.is_empty());
}

#[test]
fn fold_curve_of_the_bt_normal_form_and_its_bt_point() {
    // reference: closed form, fold curve β1 = 0 with x = y = 0; the second zero eigenvalue
    // (remaining eigenvalue β2) at β2 = 0. Points to 1e-12 (exact zeros, Newton-converged),
    // BT located to 1e-10 in p1 = β2, required 1e-8.
    let c = cont(0.05, 0.1);
    // fold of the equilibrium x = −√(−β1) at β1 = 0, β2 = 0.5
    let mut eq = EquilibriumSystem::new(
        &BogdanovTakens,
        vec![-1.0, 0.5],
        0,
        ChebyshevRoots::default(),
    )
    .unwrap();
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[-1.0, 0.0, -1.0], &dir).unwrap();
    c.extend(&mut eq, &mut br, 60).unwrap();
    let (i, sp) = br.first(SpecialKind::Fold).expect("fold");
    assert!(sp.parameter.abs() < 1e-8);
    let x_fold = br.points[i].u[..2].to_vec();

    let mut fc = FoldCurveSystem::new(
        &BogdanovTakens,
        vec![0.0, 0.5],
        [1, 0],
        ChebyshevRoots::default(),
    )
    .unwrap();
    let (guess, dir) = fc.start_at_fold(&x_fold, 0, sp.parameter).unwrap();
    let dir: Vec<f64> = dir.iter().map(|d| -d).collect(); // β2 decreasing
    let mut curve = c.start(&mut fc, &guess, &dir).unwrap();
    c.extend(&mut fc, &mut curve, 30).unwrap();
    for pt in &curve.points {
        let (beta2, beta1) = fc.parameters(&pt.u);
        assert!(beta1.abs() < 1e-12 && fc.state(&pt.u).iter().all(|x| x.abs() < 1e-12));
        // remaining eigenvalue β2
        if beta2.abs() > 1e-6 {
            assert_eq!(pt.is_stable(), Some(beta2 < 0.0));
        }
    }
    let c2 = fc.codim2_points(&curve).unwrap();
    assert_eq!(c2.len(), 1, "{c2:?}");
    assert_eq!(c2[0].kind, SpecialKind::BogdanovTakens);
    assert!(
        c2[0].p1.abs() < 1e-8 && c2[0].p2.abs() < 1e-12,
        "{:?}",
        c2[0]
    );
}

/// x' = p1 + p2 x − x³: fold curve p1 = −2x³, p2 = 3x² (27 p1² = 4 p2³), cusp at (0, 0)
struct Cubic;

impl Problem for Cubic {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        f[0] = p[0] + p[1] * x[0] - x[0].powi(3);
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        j[0] = p[1] - 3.0 * x[0] * x[0];
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        out[0] = if ip == 0 { 1.0 } else { x[0] };
    }
    fn second_derivative(
        &self,
        x: &[f64],
        _p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out[0] = -6.0 * x[0] * a[0] * b[0];
        Ok(())
    }
    fn jacobian_dp(
        &self,
        _x: &[f64],
        _p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out[0] = if ip == 1 { a[0] } else { 0.0 };
        Ok(())
    }
}

#[test]
fn fold_curve_with_a_cusp() {
    // reference: closed form 27 p1² = 4 p2³ (p1 = −2x³, p2 = 3x²), cusp at (0, 0).
    // Points to 1e-9 relative (Newton-converged); the cusp is located by regula falsi on
    // the quadratic coefficient until p1 changes by < 1e-10; required |p1|, |p2| < 1e-8.
    let c = cont(0.05, 0.1);
    let mut eq =
        EquilibriumSystem::new(&Cubic, vec![-2.0, 3.0], 0, ChebyshevRoots::default()).unwrap();
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[-2.0, -2.0], &dir).unwrap();
    c.extend(&mut eq, &mut br, 80).unwrap();
    let (i, sp) = br.first(SpecialKind::Fold).expect("fold");
    assert!((sp.parameter - 2.0).abs() < 1e-8);

    let mut fc =
        FoldCurveSystem::new(&Cubic, vec![2.0, 3.0], [0, 1], ChebyshevRoots::default()).unwrap();
    let (guess, dir) = fc
        .start_at_fold(&br.points[i].u[..1], 0, sp.parameter)
        .unwrap();
    let dir: Vec<f64> = dir.iter().map(|d| -d).collect(); // p2 decreasing, towards the cusp
    let c = cont(0.1, 0.3);
    let mut curve = c.start(&mut fc, &guess, &dir).unwrap();
    c.extend(&mut fc, &mut curve, 80).unwrap();
    for pt in &curve.points {
        let (p1, p2) = fc.parameters(&pt.u);
        let x = fc.state(&pt.u)[0];
        assert!((p1 + 2.0 * x.powi(3)).abs() < 1e-9 * (1.0 + p1.abs()));
        assert!((p2 - 3.0 * x * x).abs() < 1e-9 * (1.0 + p2.abs()));
        assert!((27.0 * p1 * p1 - 4.0 * p2.powi(3)).abs() < 1e-9 * (1.0 + p2.powi(3)));
    }
    // the curve passed through the cusp to the other side (x > 0)
    assert!(fc.state(&curve.points.last().unwrap().u)[0] > 0.2);
    let c2 = fc.codim2_points(&curve).unwrap();
    assert_eq!(c2.len(), 1, "{c2:?}");
    assert_eq!(c2[0].kind, SpecialKind::Cusp);
    assert!(
        c2[0].p1.abs() < 1e-8 && c2[0].p2.abs() < 1e-8,
        "{:?}",
        c2[0]
    );
    assert_eq!(
        curve.points[c2[0].index].special.as_ref().unwrap().location,
        Location::Located
    );
}

/// Two decoupled modes with a common delay τ, p = [b1, τ]:
/// x1' = −γ1 x1 + b1 x1(t − τ) and either x2' = −γ2 x2 + b2 x2(t − τ) (`real = None`)
/// or x2' = (b1 + β) x2 (`real = Some(β)`, a real root through 0 at b1 = −β).
struct TwoModes {
    gamma1: f64,
    gamma2: f64,
    b2: f64,
    real: Option<f64>,
}

impl TwoModes {
    /// γ, b of x' = −γx + b x(t − τ) with the first Hopf point at (τ, ω):
    /// γ = −ω cot(ωτ), b = −ω / sin(ωτ) (π/2 < ωτ < π)
    fn mode(tau: f64, omega: f64) -> (f64, f64) {
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

impl Problem for TwoModes {
    fn dim(&self) -> usize {
        2
    }
    fn n_delays(&self) -> usize {
        1
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[1]
    }
    fn delay_dp(&self, _j: usize, _p: &[f64], ip: usize) -> f64 {
        if ip == 1 { 1.0 } else { 0.0 }
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        let r2 = self.row2(p);
        f[0] = -self.gamma1 * x[0] + p[0] * x[2];
        f[1] = (0..4).map(|i| r2[i] * x[i]).sum();
    }
    fn jacobian(&self, _x: &[f64], p: &[f64], j: &mut [f64]) {
        j[..4].copy_from_slice(&[-self.gamma1, 0.0, p[0], 0.0]);
        j[4..].copy_from_slice(&self.row2(p));
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        let b1 = ip == 0;
        out[0] = if b1 { x[2] } else { 0.0 };
        out[1] = if b1 && self.real.is_some() { x[1] } else { 0.0 };
    }
    fn second_derivative(
        &self,
        _x: &[f64],
        _p: &[f64],
        _a: &[f64],
        _b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        out.iter_mut().for_each(|o| *o = 0.0);
        Ok(())
    }
    fn jacobian_dp(
        &self,
        _x: &[f64],
        p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        // f is linear in the state and in b1: ∂J/∂b1 · a = ∂f/∂b1 evaluated at a
        self.dfdp(a, p, ip, out);
        Ok(())
    }
}

/// Hopf curve of mode 1 of `problem` from b1 = −3, in (τ, b1) with b1 increasing
fn mode_one_curve(
    problem: &TwoModes,
    points: usize,
) -> (HopfCurveSystem<'_, TwoModes, ChebyshevRoots>, Branch) {
    let hopf = hopf_on_branch(problem, vec![-3.0, 0.3], 1, 40);
    let mut hc =
        HopfCurveSystem::new(problem, vec![-3.0, 0.3], [1, 0], ChebyshevRoots::default()).unwrap();
    let (guess, dir) = hc.start_at_hopf(&hopf, 1).unwrap();
    let mut c = cont(0.05, 0.1);
    // stop before mode 2's next crossing at τ = (2.5 + 2π)/2.5 ≈ 3.5
    c.options.parameter_range = (0.0, 3.0);
    let mut curve = c.start(&mut hc, &guess, &dir).unwrap();
    c.extend(&mut hc, &mut curve, points).unwrap();
    (hc, curve)
}

fn double_hopf_problem() -> (TwoModes, f64) {
    // both modes critical at τ* = 1: mode 1 with ω1 = 2 at b1* = −2/sin 2, mode 2 with
    // ω2 = 2.5 for every b1
    let (gamma1, b1_star) = TwoModes::mode(1.0, 2.0);
    let (gamma2, b2) = TwoModes::mode(1.0, 2.5);
    let p = TwoModes {
        gamma1,
        gamma2,
        b2,
        real: None,
    };
    (p, b1_star)
}

#[test]
fn double_hopf_point_of_two_delayed_modes() {
    // reference: by construction (closed form γ = −ω cot ωτ, b = −ω/sin ωτ) both modes have
    // their first Hopf point at τ* = 1, mode 1 with ω1 = 2 at b1* = −2/sin 2, mode 2 with
    // ω2 = 2.5. The double-Hopf point is located by regula falsi on Re of the second pair
    // until τ changes by < 1e-10; required 1e-8 on (τ, b1) and on both frequencies.
    let (p, b1_star) = double_hopf_problem();
    let (hc, curve) = mode_one_curve(&p, 40);
    let dh: Vec<_> = hc
        .codim2_points(&curve)
        .into_iter()
        .filter(|c| c.kind == SpecialKind::DoubleHopf)
        .collect();
    assert_eq!(dh.len(), 1, "{dh:?}");
    let d = &dh[0];
    assert!((d.p1 - 1.0).abs() < 1e-8, "τ = {}", d.p1);
    assert!((d.p2 - b1_star).abs() < 1e-8, "b1 = {} vs {b1_star}", d.p2);
    assert_eq!(d.omegas.len(), 2);
    assert!((d.omegas[0] - 2.0).abs() < 1e-8, "ω1 = {}", d.omegas[0]);
    assert!((d.omegas[1] - 2.5).abs() < 1e-8, "ω2 = {}", d.omegas[1]);
    let sp = curve.points[d.index].special.as_ref().unwrap();
    assert_eq!(sp.location, Location::Located);
    assert!((sp.critical.unwrap().im - 2.5).abs() < 1e-8);
    // remaining spectrum stable before, unstable after (b1 increasing)
    assert_eq!(curve.points[d.index - 1].is_stable(), Some(true));
    assert_eq!(curve.points[d.index + 1].is_stable(), Some(false));
    // every point on mode 1's closed-form curve τ = arccos(γ1/b1)/√(b1² − γ1²)
    for pt in &curve.points {
        let (tau, b1) = (pt.parameter, pt.secondary_parameter.unwrap());
        let (omega, tau_exact) = scalar_hopf(p.gamma1, b1);
        assert!((tau - tau_exact).abs() < 1e-9 * tau_exact);
        assert!((hc.omega(&pt.u) - omega).abs() < 1e-9 * omega);
    }
}

#[test]
fn zero_hopf_point_of_a_delayed_mode_and_a_real_mode() {
    // reference: the real root b1 + β of x2' = (b1 + β) x2 passes 0 at b1 = −β = −2.5 on
    // mode 1's Hopf curve, τ = arccos(γ1/b1)/√(b1² − γ1²) there (closed form); located to
    // 1e-10 in τ, required 1e-8.
    let (gamma1, _) = TwoModes::mode(1.0, 2.0);
    let p = TwoModes {
        gamma1,
        gamma2: 0.0,
        b2: 0.0,
        real: Some(2.5),
    };
    let (hc, curve) = mode_one_curve(&p, 30);
    let zh: Vec<_> = hc
        .codim2_points(&curve)
        .into_iter()
        .filter(|c| c.kind == SpecialKind::ZeroHopf)
        .collect();
    assert_eq!(zh.len(), 1, "{zh:?}");
    let (omega, tau) = scalar_hopf(gamma1, -2.5);
    assert!((zh[0].p2 + 2.5).abs() < 1e-8, "b1 = {}", zh[0].p2);
    assert!((zh[0].p1 - tau).abs() < 1e-8);
    assert!((zh[0].omegas[0] - omega).abs() < 1e-8);
}

#[test]
fn hopf_curve_resumed_from_json_equals_an_uninterrupted_run() {
    // reference: the uninterrupted run (40 points, through the double-Hopf point); the
    // resumed run saves the branch after 20 points to JSON, loads it into a fresh system
    // and extends it by 20. JSON keeps f64 exactly (shortest round-trip representation), and
    // the system's only state (the normalisation vector) is rebuilt from the last point, so
    // the points agree to rounding (1e-13).
    let (p, _) = double_hopf_problem();
    let (_, full) = mode_one_curve(&p, 40);
    let (_, half) = mode_one_curve(&p, 20);
    let json = serde_json::to_string(&half).unwrap();
    let mut loaded: Branch = serde_json::from_str(&json).unwrap();
    let mut hc =
        HopfCurveSystem::new(&p, vec![-3.0, 0.3], [1, 0], ChebyshevRoots::default()).unwrap();
    let mut c = cont(0.05, 0.1);
    c.options.parameter_range = (0.0, 3.0);
    c.extend(&mut hc, &mut loaded, 20).unwrap();
    assert_eq!(loaded.points.len(), full.points.len());
    for (a, b) in loaded.points.iter().zip(&full.points) {
        for (x, y) in a.u.iter().zip(&b.u) {
            assert!((x - y).abs() < 1e-13 * (1.0 + y.abs()), "{x} vs {y}");
        }
        assert_eq!(
            a.special.as_ref().map(|s| s.kind),
            b.special.as_ref().map(|s| s.kind)
        );
    }
    assert!(loaded.first(SpecialKind::DoubleHopf).is_some());
}

/// A nonlinear test problem with two parameter-dependent delays, p = [a, b, c, τ]:
/// f1 = −a x1 + b tanh(y2) + c x1 z2, f2 = −x2 + a tanh(y1) − b x2² + c z1,
/// y = x(t − τ), z = x(t − cτ).
struct TanhNet;

impl Problem for TanhNet {
    fn dim(&self) -> usize {
        2
    }
    fn n_delays(&self) -> usize {
        2
    }
    fn delay(&self, j: usize, p: &[f64]) -> f64 {
        if j == 0 { p[3] } else { p[3] * p[2] }
    }
    fn delay_dp(&self, j: usize, p: &[f64], ip: usize) -> f64 {
        match (j, ip) {
            (0, 3) => 1.0,
            (1, 3) => p[2],
            (1, 2) => p[3],
            _ => 0.0,
        }
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        let (a, b, c) = (p[0], p[1], p[2]);
        f[0] = -a * x[0] + b * x[3].tanh() + c * x[0] * x[5];
        f[1] = -x[1] + a * x[2].tanh() - b * x[1] * x[1] + c * x[4];
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
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
    fn dfdp(&self, x: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        let v = match ip {
            0 => [-x[0], x[2].tanh()],
            1 => [x[3].tanh(), -x[1] * x[1]],
            2 => [x[0] * x[5], x[4]],
            _ => [0.0, 0.0],
        };
        out.copy_from_slice(&v);
    }
    fn second_derivative(
        &self,
        x: &[f64],
        p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        let d2 = |v: f64| -2.0 * v.tanh() / v.cosh().powi(2);
        out[0] = p[1] * d2(x[3]) * a[3] * b[3] + p[2] * (a[0] * b[5] + a[5] * b[0]);
        out[1] = -2.0 * p[1] * a[1] * b[1] + p[0] * d2(x[2]) * a[2] * b[2];
        Ok(())
    }
    fn jacobian_dp(
        &self,
        x: &[f64],
        _p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
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

/// dense Jacobian of a continuation system from its triplets
fn dense_jacobian<S: ContinuationSystem>(sys: &mut S, u: &[f64]) -> DMatrix<f64> {
    let nu = sys.n_unknowns();
    let mut entries = Vec::new();
    sys.jacobian(u, &mut entries).unwrap();
    let mut j = DMatrix::zeros(nu - 1, nu);
    for e in entries {
        j[(e.row, e.col)] += e.val;
    }
    j
}

/// central differences of the residual, h = 1e-6 (1 + |u_i|)
fn fd_jacobian_of<S: ContinuationSystem>(sys: &mut S, u: &[f64]) -> DMatrix<f64> {
    let nu = sys.n_unknowns();
    let mut j = DMatrix::zeros(nu - 1, nu);
    let (mut rp, mut rm) = (vec![0.0; nu - 1], vec![0.0; nu - 1]);
    let mut x = u.to_vec();
    for col in 0..nu {
        let h = 1e-6 * (1.0 + u[col].abs());
        x[col] = u[col] + h;
        sys.residual(&x, &mut rp).unwrap();
        x[col] = u[col] - h;
        sys.residual(&x, &mut rm).unwrap();
        x[col] = u[col];
        for row in 0..nu - 1 {
            j[(row, col)] = (rp[row] - rm[row]) / (2.0 * h);
        }
    }
    j
}

/// deterministic pseudo-random numbers in (−1, 1)
fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn assert_close(exact: &DMatrix<f64>, fd: &DMatrix<f64>, what: &str) {
    for (e, f) in exact.iter().zip(fd.iter()) {
        assert!(
            (e - f).abs() < 1e-6 * (1.0 + e.abs()),
            "{what}: exact {e} vs central differences {f}"
        );
    }
}

#[test]
fn exact_jacobians_of_the_curve_systems_match_central_differences() {
    // reference: central differences of the residual (h = 1e-6, error O(h²) ≈ 1e-12 plus
    // rounding ≈ 1e-10); tolerance 1e-6 relative. Random points (not on the curves), both
    // delays depending on the free parameters (τ and c), and a pair without delays (a, b).
    let params = vec![0.7, 1.3, 0.4, 0.9];
    let mut seed = 42u64;
    for free in [[3, 2], [2, 3], [0, 1]] {
        for _ in 0..5 {
            let mut hc =
                HopfCurveSystem::new(&TanhNet, params.clone(), free, ChebyshevRoots::default())
                    .unwrap();
            let mut u: Vec<f64> = (0..hc.n_unknowns()).map(|_| lcg(&mut seed)).collect();
            let nu = u.len();
            u[nu - 3] += 1.0; // ω
            u[nu - 2] = 1.0 + 0.5 * u[nu - 2].abs(); // keep the delays positive
            u[nu - 1] = 1.0 + 0.5 * u[nu - 1].abs();
            let c: Vec<f64> = (0..nu).map(|_| lcg(&mut seed)).collect();
            hc.set_reference(&c);
            let exact = dense_jacobian(&mut hc, &u);
            let fd = fd_jacobian_of(&mut hc, &u);
            assert_close(&exact, &fd, "Hopf curve");

            let mut fc =
                FoldCurveSystem::new(&TanhNet, params.clone(), free, ChebyshevRoots::default())
                    .unwrap();
            let mut u: Vec<f64> = (0..fc.n_unknowns()).map(|_| lcg(&mut seed)).collect();
            let nu = u.len();
            u[nu - 2] = 1.0 + 0.5 * u[nu - 2].abs();
            u[nu - 1] = 1.0 + 0.5 * u[nu - 1].abs();
            let c: Vec<f64> = (0..nu).map(|_| lcg(&mut seed)).collect();
            fc.set_reference(&c);
            let exact = dense_jacobian(&mut fc, &u);
            let fd = fd_jacobian_of(&mut fc, &u);
            assert_close(&exact, &fd, "fold curve");
        }
    }
}

#[test]
fn missing_second_derivatives_are_reported() {
    // reference: the trait default reports MissingDerivative instead of guessing
    struct NoSecond;
    impl Problem for NoSecond {
        fn dim(&self) -> usize {
            1
        }
        fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
            f[0] = p[0] - x[0] * x[0];
        }
        fn jacobian(&self, x: &[f64], _p: &[f64], j: &mut [f64]) {
            j[0] = -2.0 * x[0];
        }
        fn dfdp(&self, _x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
            out[0] = 1.0;
        }
    }
    let mut fc =
        FoldCurveSystem::new(&NoSecond, vec![0.0, 0.0], [0, 1], ChebyshevRoots::default()).unwrap();
    let mut entries = Vec::new();
    let err = fc
        .jacobian(&[0.0, 1.0, 0.0, 0.0], &mut entries)
        .unwrap_err();
    assert!(matches!(err, Error::MissingDerivative { .. }), "{err}");
}
