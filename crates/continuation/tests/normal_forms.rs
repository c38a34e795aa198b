//! Normal forms of Hopf and double-Hopf points (first Lyapunov coefficient, Bautin points
//! on Hopf curves, Kuznetsov's double-Hopf coefficients) against closed forms, a formula
//! independent of ours (Guckenheimer–Holmes), the amplitudes of computed cycles and
//! DDE-Biftool's published demo values.
mod common;

use common::{cont, continued, curve_system, single_codim2};
use continuation::*;
use continuation_textbook::*;
use num_complex::Complex64;

fn close(a: Complex64, b: Complex64, tol: f64) -> bool {
    (a - b).norm() <= tol * (1.0 + b.norm())
}

#[test]
fn stuart_landau_and_subcritical_normal_forms_have_c1_2a_plus_2ib() {
    // reference: closed form (NormalForm::hopf_c1): z = x0 + i x1 = √2 w for ‖q‖ = 1, so
    // z' = (μ + iω)z + (a + ib)|z|²z gives c1 = 2(a + ib), l1 = 2a/ω. The derivatives are
    // exact (dual numbers): tolerance 1e-12 relative (rounding).
    for (nf, omega) in [
        (NormalForm::stuart_landau(1.3, 0.4), 1.3),
        (NormalForm::subcritical(), 1.0),
    ] {
        let h = HopfNormalForm::compute(&nf, &[0.0, 0.0], &[0.0], omega).unwrap();
        let (re, im) = nf.hopf_c1();
        assert!(close(h.c1, Complex64::new(re, im), 1e-12), "c1 = {}", h.c1);
        assert!((h.l1 - re / omega).abs() < 1e-12 * re.abs());
        let expected = if nf.a < 0.0 {
            Criticality::Supercritical
        } else {
            Criticality::Subcritical
        };
        assert_eq!(h.criticality(), Some(expected));
    }
}

#[test]
fn hopf_point_of_an_equilibrium_branch_gives_its_normal_form() {
    // reference: as above, c1 = 2(a + ib) = −2 + 0.8i for Stuart–Landau with ω = 1.3,
    // b = 0.4; the Hopf point is located to 1e-10 in μ, and c1 varies by O(μ) with μ,
    // so 1e-8
    let nf = NormalForm::stuart_landau(1.3, 0.4);
    let hopf = common::hopf_on_branch(&nf, vec![-0.3], 0, 20);
    let eq = EquilibriumSystem::new(&nf, vec![-0.3], 0, ChebyshevRoots::default()).unwrap();
    let h = eq.hopf_normal_form(&hopf).unwrap();
    assert!(
        close(h.c1, Complex64::new(-2.0, 0.8), 1e-8),
        "c1 = {}",
        h.c1
    );
}

/// x' = −y + f(x, y), y' = x + g(x, y) with quadratic and cubic f, g (p unused)
#[derive(Debug)]
struct Planar {
    /// f = a20 x² + a11 xy + a02 y² + a30 x³ + a12 x y²
    f: [f64; 5],
    /// g = b20 x² + b11 xy + b02 y² + b21 x² y + b03 y³
    g: [f64; 5],
}

impl Planar {
    /// (value, gradient, Hessian, third derivatives ∂³/∂x^i∂y^(3−i) for i = 3, 2, 1, 0)
    #[allow(clippy::type_complexity)]
    fn parts(c: &[f64; 5], cubic_xy2: bool, x: f64, y: f64) -> (f64, [f64; 2], [f64; 3], [f64; 4]) {
        let [q20, q11, q02, c1, c2] = *c;
        if cubic_xy2 {
            // c1 x³ + c2 x y²
            (
                q20 * x * x + q11 * x * y + q02 * y * y + c1 * x.powi(3) + c2 * x * y * y,
                [
                    2.0 * q20 * x + q11 * y + 3.0 * c1 * x * x + c2 * y * y,
                    q11 * x + 2.0 * q02 * y + 2.0 * c2 * x * y,
                ],
                [
                    2.0 * q20 + 6.0 * c1 * x,
                    q11 + 2.0 * c2 * y,
                    2.0 * q02 + 2.0 * c2 * x,
                ],
                [6.0 * c1, 0.0, 2.0 * c2, 0.0],
            )
        } else {
            // c1 x² y + c2 y³
            (
                q20 * x * x + q11 * x * y + q02 * y * y + c1 * x * x * y + c2 * y.powi(3),
                [
                    2.0 * q20 * x + q11 * y + 2.0 * c1 * x * y,
                    q11 * x + 2.0 * q02 * y + c1 * x * x + 3.0 * c2 * y * y,
                ],
                [
                    2.0 * q20 + 2.0 * c1 * y,
                    q11 + 2.0 * c1 * x,
                    2.0 * q02 + 6.0 * c2 * y,
                ],
                [0.0, 2.0 * c1, 0.0, 6.0 * c2],
            )
        }
    }
}

impl Problem for Planar {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, x: &[f64], _p: &[f64], out: &mut [f64]) {
        out[0] = -x[1] + Self::parts(&self.f, true, x[0], x[1]).0;
        out[1] = x[0] + Self::parts(&self.g, false, x[0], x[1]).0;
    }
    fn jacobian(&self, x: &[f64], _p: &[f64], j: &mut [f64]) {
        let (_, df, _, _) = Self::parts(&self.f, true, x[0], x[1]);
        let (_, dg, _, _) = Self::parts(&self.g, false, x[0], x[1]);
        j.copy_from_slice(&[df[0], df[1] - 1.0, dg[0] + 1.0, dg[1]]);
    }
    fn dfdp(&self, _x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
    }
    fn second_derivative(
        &self,
        x: &[f64],
        _p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        for (i, (c, xy2)) in [(&self.f, true), (&self.g, false)].into_iter().enumerate() {
            let (_, _, h, _) = Self::parts(c, xy2, x[0], x[1]);
            out[i] = h[0] * a[0] * b[0] + h[1] * (a[0] * b[1] + a[1] * b[0]) + h[2] * a[1] * b[1];
        }
        Ok(())
    }
    fn third_derivative(
        &self,
        x: &[f64],
        _p: &[f64],
        a: &[f64],
        b: &[f64],
        c: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        for (i, (co, xy2)) in [(&self.f, true), (&self.g, false)].into_iter().enumerate() {
            let (_, _, _, t) = Self::parts(co, xy2, x[0], x[1]);
            // t = [f_xxx, f_xxy, f_xyy, f_yyy]
            let idx = |u: usize, v: usize, w: usize| {
                t[(u == 1) as usize + (v == 1) as usize + (w == 1) as usize]
            };
            let dirs = [a, b, c];
            let mut s = 0.0;
            for u in 0..2 {
                for v in 0..2 {
                    for w in 0..2 {
                        s += idx(u, v, w) * dirs[0][u] * dirs[1][v] * dirs[2][w];
                    }
                }
            }
            out[i] = s;
        }
        Ok(())
    }
}

#[test]
fn planar_first_lyapunov_coefficient_matches_guckenheimer_holmes() {
    // reference: Guckenheimer & Holmes (1983), eq. (3.4.11), for x' = −ωy + f, y' = ωx + g
    // (ω = 1): 16a = f_xxx + f_xyy + g_xxy + g_yyy
    //        + f_xy(f_xx + f_yy) − g_xy(g_xx + g_yy) − f_xx g_xx + f_yy g_yy,
    // the polar coefficient r' = a r³; with ‖q‖ = 1, |x| = √2|w|, so l1 = 2a.
    // A derivation independent of ours (no eigenvectors, no resolvents). Tolerance 1e-12.
    let p = Planar {
        f: [0.7, -0.4, 0.3, -0.9, 0.5],
        g: [0.2, 0.6, -0.8, 0.4, -0.3],
    };
    let [a20, a11, a02, a30, a12] = p.f;
    let [b20, b11, b02, b21, b03] = p.g;
    let (fxx, fxy, fyy) = (2.0 * a20, a11, 2.0 * a02);
    let (gxx, gxy, gyy) = (2.0 * b20, b11, 2.0 * b02);
    let sixteen_a = 6.0 * a30 + 2.0 * a12 + 2.0 * b21 + 6.0 * b03 + fxy * (fxx + fyy)
        - gxy * (gxx + gyy)
        - fxx * gxx
        + fyy * gyy;
    let l1 = 2.0 * sixteen_a / 16.0;
    let h = HopfNormalForm::compute(&p, &[0.0, 0.0], &[0.0], 1.0).unwrap();
    assert!(
        (h.l1 - l1).abs() < 1e-12 * (1.0 + l1.abs()),
        "l1 = {} vs {l1}",
        h.l1
    );
    // the same with finite-difference third derivatives (explicit fallback): O(h²) ~ 1e-8
    #[derive(Debug)]
    struct Fd<'a>(&'a Planar);
    impl Problem for Fd<'_> {
        fn dim(&self) -> usize {
            2
        }
        fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
            self.0.rhs(x, p, f)
        }
        fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
            self.0.jacobian(x, p, j)
        }
        fn dfdp(&self, x: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
            self.0.dfdp(x, p, ip, out)
        }
        fn second_derivative(
            &self,
            x: &[f64],
            p: &[f64],
            a: &[f64],
            b: &[f64],
            out: &mut [f64],
        ) -> Result<()> {
            self.0.second_derivative(x, p, a, b, out)
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
            fd_third_derivative(self, x, p, [a, b, c], out)
        }
    }
    let hf = HopfNormalForm::compute(&Fd(&p), &[0.0, 0.0], &[0.0], 1.0).unwrap();
    assert!((hf.l1 - l1).abs() < 1e-7, "fd l1 = {}", hf.l1);
}

#[test]
fn delayed_cubic_term_gives_c1_2mu2_exp_minus_i_tau() {
    // reference: closed form (DelayedBautin::hopf_c1): the cubic term μ2|z(t−τ)|²z(t−τ)
    // through φ(θ) = q e^{iθ} gives c1 = 2μ2 e^{−iτ}. Exact derivatives: 1e-12.
    for (mu2, tau) in [(0.7, 0.9), (-0.4, 2.3)] {
        let h = HopfNormalForm::compute(&DelayedBautin::SINGLE, &[0.0, 0.0], &[0.0, mu2, tau], 1.0)
            .unwrap();
        let (re, im) = DelayedBautin::hopf_c1(mu2, tau);
        assert!(close(h.c1, Complex64::new(re, im), 1e-12), "c1 = {}", h.c1);
    }
}

/// the Hopf point x = 0 of a problem with the Hopf curve μ1 = p[0] = 0 (frequency 1)
fn hopf_at_origin(params: &[f64], ip: usize, n: usize) -> HopfPoint {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let mut v = vec![Complex64::new(0.0, 0.0); n];
    v[0] = Complex64::new(s, 0.0);
    v[1] = Complex64::new(0.0, -s);
    HopfPoint {
        parameter: params[ip],
        state: vec![0.0; n],
        omega: 1.0,
        eigenvector: v,
        transversality: 1.0,
    }
}

#[test]
fn bautin_point_of_the_radial_normal_form_is_located_at_mu2_zero() {
    // reference: closed form l1 = 2μ2 on the Hopf curve μ1 = 0 of
    // x' = g x − y + εx², y' = x + g y, g = μ1 + μ2ρ − ρ² (the quadratic εx² adds nothing
    // to l1: Guckenheimer–Holmes' formula, its terms f_xy, g_xx, g_xy, g_yy vanish), so the
    // generalised-Hopf point is at μ2 = 0 exactly. Location tolerance 1e-10, required 1e-9;
    // l1 along the curve to 1e-10.
    let p = Radial {
        c2: -1.0,
        c3: 0.0,
        eps: 0.4,
    };
    let params = vec![0.0, -0.5];
    let hopf = hopf_at_origin(&params, 0, 2);
    let mut hc = curve_system(HopfCurveSystem::new, &p, params, [1, 0]);
    let (guess, dir) = hc.start_at_hopf(&hopf, 0).unwrap();
    let curve = continued(&cont(0.1, 0.2), &mut hc, &guess, &dir, 10);
    for pt in &curve.points {
        let mu2 = pt.parameter;
        let l1 = hc.normal_form(&pt.u).unwrap().l1;
        assert!((l1 - 2.0 * mu2).abs() < 1e-10, "l1 = {l1} at μ2 = {mu2}");
    }
    let gh = single_codim2(hc.codim2_points(&curve), SpecialKind::CriticalityChange);
    assert!(gh.p1.abs() < 1e-9 && gh.p2.abs() < 1e-9, "{gh:?}");
    assert!((gh.omegas[0] - 1.0).abs() < 1e-9);
}

#[test]
fn bautin_point_of_the_delayed_cubic_term_is_at_tau_pi_over_2() {
    // reference: closed form l1 = 2μ2 cos τ (DelayedBautin::hopf_c1) on the Hopf curve
    // μ1 = 0 (ω = 1 for every τ): with μ2 = 0.5 the criticality changes at τ = π/2, a
    // generalised-Hopf point of a DDE on a curve with the delay as a parameter.
    // Location tolerance 1e-10, required 1e-9.
    let p = DelayedBautin::SINGLE;
    let params = vec![0.0, 0.5, 1.0];
    let hopf = hopf_at_origin(&params, 0, 2);
    let mut hc = curve_system(HopfCurveSystem::new, &p, params, [2, 0]);
    let (guess, dir) = hc.start_at_hopf(&hopf, 0).unwrap();
    let curve = continued(&cont(0.1, 0.2), &mut hc, &guess, &dir, 10);
    let gh = single_codim2(hc.codim2_points(&curve), SpecialKind::CriticalityChange);
    assert!(
        (gh.p1 - std::f64::consts::FRAC_PI_2).abs() < 1e-9 && gh.p2.abs() < 1e-9,
        "{gh:?}"
    );
}

#[test]
fn double_hopf_coefficients_of_the_torus_test_bed() {
    // reference: closed form (TorusTestBed::double_hopf_coefficients): with ‖q‖ = 1 the
    // cubic coefficients are twice the model's, those of oscillator 2 divided by
    // Δ'(iΩ) = 1 + κτe^{−iΩτ} of its delayed linear part. Exact derivatives; Ω from a
    // contraction iterated to rounding: tolerance 1e-11 relative.
    for (bed, tau, subtype) in [
        (TorusTestBed::ode(), 0.0, "V"),
        (TorusTestBed::delayed(), 2.5, "V"),
    ] {
        let (omega2, d) = bed.second_hopf(tau);
        let x = [0.0; 4];
        let nf =
            DoubleHopfNormalForm::compute(&bed, &x, &[0.0, d, tau], [bed.omega1, omega2]).unwrap();
        let g = bed.double_hopf_coefficients(tau);
        for (got, want) in [nf.g2100, nf.g1011, nf.g1110, nf.g0021].into_iter().zip(g) {
            assert!(close(got, want, 1e-11), "{got} vs {want}");
        }
        assert!((nf.theta - g[1].re / g[3].re).abs() < 1e-11);
        assert!((nf.delta - g[2].re / g[0].re).abs() < 1e-11);
        // p11 = −2, p22 < 0: the simple case; θ, δ < 0 with θδ < 1: Kuznetsov's type V
        assert_eq!(nf.case, DoubleHopfCase::Simple);
        assert_eq!(
            nf.subtype,
            Some(subtype),
            "θ = {}, δ = {}",
            nf.theta,
            nf.delta
        );
    }
}

#[test]
fn mackey_glass_first_lyapunov_coefficient_matches_dde_biftool() {
    // reference: DDE-Biftool's demo Mackey-Glass (MackeyGlass_demo.html, rev. 161): at the
    // Hopf point of the nontrivial equilibrium continued in τ (β = 2, n = 10, γ = 1)
    // "L1: -5.69527799058398", computed there with finite-difference derivatives (the
    // demo's error estimate along the Hopf curve is 4e-3). That release normalised the
    // eigenvectors of a scalar equation as p = q = 1/√Δ'(iω) (|q|² = 1/|Δ'(iω)|, while
    // ‖q‖ = 1 here and in DDE-Biftool's current `nmfm_nullvector`); l1 scales with |q|², so
    // its value is ours divided by |Δ'(iω)|. (Our own normalisation is checked
    // independently against the cycle amplitudes below.) The Hopf point is exact here:
    // x* = 1, ω = √15, τ = arccos(−1/4)/√15, Δ'(iω) = 1 + A1 τ e^{−iωτ} with A1 = −4.
    // Tolerance 1e-3 relative (their finite differences).
    let mg = MackeyGlass { gamma: 1.0 };
    let omega = 15f64.sqrt();
    let tau = (-0.25f64).acos() / omega;
    let h = HopfNormalForm::compute(&mg, &[1.0], &[2.0, 10.0, tau], omega).unwrap();
    let dprime = 1.0 - 4.0 * tau * Complex64::new(0.0, -omega * tau).exp();
    let theirs = h.l1 / dprime.norm();
    let reference = -5.695_277_990_583_98;
    assert!(
        (theirs - reference).abs() < 1e-3 * reference.abs(),
        "l1/|Δ'(iω)| = {theirs} (l1 = {}) vs DDE-Biftool {reference}",
        h.l1
    );
}

#[test]
fn mackey_glass_l1_predicts_the_amplitude_of_the_computed_cycles() {
    // reference: the computed cycles (collocation, independent of the normal form): near the
    // Hopf point x ≈ x* + 2 Re(w q e^{iωt}) with |w|² = −Re λ'(τ*) Δτ / Re c1 (q = 1 for a
    // scalar equation), so the first Fourier amplitude A1 of x(t) satisfies
    // A1² = −4 Re λ'(τ*) Δτ / Re c1 · (1 + O(Δτ)). λ'(τ*) in closed form from
    // λ + 1 + 4e^{−λτ} = 0: λ' = 4λe^{−λτ} / (1 − 4τe^{−λτ}). The O(Δτ) term is removed by
    // fitting A1² = k1 Δτ + k2 Δτ² through the cycles with A1 < 0.06; tolerance 1e-3
    // relative on k1 (the fit's remainder O(Δτ²) with Δτ ≲ 1e-3, and the collocation
    // error).
    let mg = MackeyGlass { gamma: 1.0 };
    let omega = 15f64.sqrt();
    let tau0 = (-0.25f64).acos() / omega;
    let params = vec![2.0, 10.0, tau0];
    let h = HopfNormalForm::compute(&mg, &[1.0], &params, omega).unwrap();
    let lambda = Complex64::new(0.0, omega);
    let e = (-lambda * tau0).exp();
    let dlambda = 4.0 * lambda * e / (1.0 - 4.0 * tau0 * e);
    let k1_expected = -4.0 * dlambda.re / h.c1.re;
    let hopf = HopfPoint {
        parameter: tau0,
        state: vec![1.0],
        omega,
        eigenvector: vec![Complex64::new(1.0, 0.0)],
        transversality: dlambda.re,
    };
    let mut po = PeriodicOrbitSystem::new(&mg, params, 2, common::colloc(20)).unwrap();
    let (guess, dir) = po.hopf_guess(&hopf, 0.01);
    let c = Continuation::new(ContinuationOptions {
        initial_step: 0.005,
        max_step: 0.01,
        ..Default::default()
    });
    let br = continued(&c, &mut po, &guess, &dir, 8);
    // first Fourier amplitude from 512 samples of the collocation polynomial
    let a1 = |u: &[f64]| {
        let (mut x, mut dx) = ([0.0], [0.0]);
        let m = 512;
        let s: Complex64 = (0..m)
            .map(|i| {
                let t = i as f64 / m as f64;
                po.eval(u, t, &mut x, &mut dx);
                x[0] * Complex64::new(0.0, -2.0 * std::f64::consts::PI * t).exp()
            })
            .sum();
        2.0 * s.norm() / m as f64
    };
    let data: Vec<(f64, f64)> = br
        .points
        .iter()
        .map(|p| (p.parameter - tau0, a1(&p.u).powi(2)))
        .filter(|&(d, a)| d.abs() > 1e-12 && a < 0.06f64.powi(2))
        .collect();
    assert!(data.len() >= 4, "{data:?}");
    // least squares A1² = k1 d + k2 d²
    let (mut s11, mut s12, mut s22, mut r1, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(d, a) in &data {
        s11 += d * d;
        s12 += d * d * d;
        s22 += d * d * d * d;
        r1 += d * a;
        r2 += d * d * a;
    }
    let k1 = (r1 * s22 - r2 * s12) / (s11 * s22 - s12 * s12);
    assert!(
        (k1 - k1_expected).abs() < 1e-3 * k1_expected.abs(),
        "A1²/Δτ = {k1} from the cycles, {k1_expected} from l1 = {}",
        h.l1
    );
}

/// DDE-Biftool's neuron demo parameters [κ, β, a12, a21, τ1, τ2, τs] at a21, τs
fn neuron_params(a21: f64, taus: f64) -> Vec<f64> {
    vec![0.5, -1.0, 1.0, a21, 0.2, 0.2, taus]
}

/// the Hopf point of x = 0 of the neuron at τs = 1.5, continued in a21 from 0.5
fn neuron_hopf() -> (HopfPoint, HopfNormalForm) {
    let hopf = common::hopf_on_branch(&Neuron, neuron_params(0.5, 1.5), 3, 30);
    let eq = EquilibriumSystem::new(
        &Neuron,
        neuron_params(0.5, 1.5),
        3,
        ChebyshevRoots::default(),
    )
    .unwrap();
    let h = eq.hopf_normal_form(&hopf).unwrap();
    (hopf, h)
}

#[test]
fn neuron_first_lyapunov_coefficient_matches_dde_biftool() {
    // reference: DDE-Biftool's demo1_simple.html (rev. 178, symbolic derivatives): the Hopf
    // point of the trivial equilibrium continued in a21 at τs = 1.5 has "L1: -0.39616"
    // (5 digits printed). Tolerance: half a unit of the last printed digit, 5e-6.
    let (hopf, h) = neuron_hopf();
    assert!(
        (hopf.parameter - 0.807).abs() < 1e-3,
        "a21 = {}",
        hopf.parameter
    );
    assert!(
        (h.l1 - (-0.39616)).abs() < 5e-6,
        "l1 = {} at a21 = {}",
        h.l1,
        hopf.parameter
    );
    assert_eq!(h.criticality(), Some(Criticality::Supercritical));
}

#[test]
fn neuron_double_hopf_point_matches_dde_biftool() {
    // reference: DDE-Biftool's demo1_simple.html (rev. 178, symbolic derivatives): on the
    // Hopf curve in (a21, τs) started at τs = 1.5, a double-Hopf point at (a21, τs) = (0.207296, 8.63407) with
    // ω1 = 0.328715 (the continued pair), ω2 = 0.915712 and θ = 1.0605, δ = 3.7719.
    // Here the curve of the ω1 pair is started from the equilibrium branch at τs = 8
    // (a21 increasing from 0.12, Hopf point at a21 ≈ 0.201) and continued towards larger τs. Tolerances: half a unit of the last
    // printed digit (5e-7 on a21 and the frequencies, 5e-6 on τs, 5e-5 on θ and δ).
    let hopf = common::hopf_on_branch(&Neuron, neuron_params(0.12, 8.0), 3, 4);
    assert!((hopf.omega - 0.35).abs() < 0.01, "ω = {}", hopf.omega);
    let mut hc = curve_system(
        HopfCurveSystem::new,
        &Neuron,
        neuron_params(hopf.parameter, 8.0),
        [3, 6],
    );
    let (guess, dir) = hc.start_at_hopf(&hopf, 3).unwrap();
    let curve = continued(&cont(0.05, 0.1), &mut hc, &guess, &dir, 16);
    let hh = single_codim2(hc.codim2_points(&curve), SpecialKind::DoubleHopf);
    assert!((hh.p1 - 0.207296).abs() < 5e-7, "{hh:?}");
    assert!((hh.p2 - 8.63407).abs() < 5e-6, "{hh:?}");
    let [w1, w2] = [hh.omegas[0], hh.omegas[1]];
    assert!(
        (w1 - 0.328715).abs() < 5e-7 && (w2 - 0.915712).abs() < 5e-7,
        "{hh:?}"
    );
    let u = &curve.points[hh.index].u;
    let nf = hc.double_hopf_normal_form(u, w2).unwrap();
    assert!((nf.theta - 1.0605).abs() < 5e-5, "θ = {}", nf.theta);
    assert!((nf.delta - 3.7719).abs() < 5e-5, "δ = {}", nf.delta);
    // the coefficients themselves (same normalisation, ‖q‖ = 1, pᴴΔ'q = 1):
    // g2100 = −0.030007 − 0.0094837i, g1011 = −0.060013 − 0.018967i,
    // g1110 = −0.11318 + 0.037831i, g0021 = −0.056592 + 0.018915i (5e-6: the last digit)
    for (got, want) in [
        (nf.g2100, Complex64::new(-0.030007, -0.0094837)),
        (nf.g1011, Complex64::new(-0.060013, -0.018967)),
        (nf.g1110, Complex64::new(-0.11318, 0.037831)),
        (nf.g0021, Complex64::new(-0.056592, 0.018915)),
    ] {
        assert!(
            (got.re - want.re).abs() < 5e-6 && (got.im - want.im).abs() < 5e-6,
            "{got}"
        );
    }
    // p11 p22 > 0, θ, δ > 0, θδ > 1: the simple case, type I
    assert_eq!(nf.case, DoubleHopfCase::Simple);
    assert_eq!(nf.subtype, Some("I"));
    // swapping the pairs swaps θ and δ
    let swapped =
        DoubleHopfNormalForm::compute(&Neuron, hc.state(u), &hc.parameters_at(u), [w2, w1])
            .unwrap();
    assert!((swapped.theta - nf.delta).abs() < 1e-9 && (swapped.delta - nf.theta).abs() < 1e-9);
}

#[test]
fn neuron_third_derivative_matches_finite_differences() {
    // reference: central differences of the exact second derivative (fd_third_derivative),
    // error O(h²) with h = 1e-4: tolerance 1e-6
    let x = [0.3, -0.2, 0.1, 0.25, -0.15, 0.05, 0.4, -0.35];
    let a = [0.1, 0.2, -0.3, 0.4, 0.5, -0.6, 0.7, 0.8];
    let b = [-0.5, 0.1, 0.2, 0.3, -0.1, 0.6, 0.2, 0.1];
    let cc = [0.3, -0.4, 0.5, 0.1, 0.2, 0.3, -0.2, 0.6];
    let p = neuron_params(0.8, 1.5);
    let (mut exact, mut fd) = ([0.0; 2], [0.0; 2]);
    Neuron
        .third_derivative(&x, &p, &a, &b, &cc, &mut exact)
        .unwrap();
    fd_third_derivative(&Neuron, &x, &p, [&a, &b, &cc], &mut fd).unwrap();
    for i in 0..2 {
        assert!((exact[i] - fd[i]).abs() < 1e-6, "{exact:?} vs {fd:?}");
    }
}

#[test]
fn non_smooth_and_underived_problems_get_no_number() {
    // a problem that says it is only C¹ (as the trailer's brush tyre) gets NotSmooth, one
    // without third derivatives MissingDerivative; neither gets a number
    #[derive(Debug)]
    struct Kinked(NormalForm);
    impl Problem for Kinked {
        fn dim(&self) -> usize {
            2
        }
        fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
            self.0.rhs(x, p, f)
        }
        fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
            self.0.jacobian(x, p, j)
        }
        fn dfdp(&self, x: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
            self.0.dfdp(x, p, ip, out)
        }
        fn smoothness(&self) -> Smoothness {
            Smoothness::C1AtKinks
        }
    }
    let k = Kinked(NormalForm::stuart_landau(1.0, 0.0));
    let e = HopfNormalForm::compute(&k, &[0.0, 0.0], &[0.0], 1.0).unwrap_err();
    assert!(matches!(e, Error::NotSmooth { .. }), "{e}");
    let e = HopfNormalForm::compute(&VanDerPol, &[0.0, 0.0], &[0.0], 1.0).unwrap_err();
    assert!(matches!(e, Error::MissingDerivative { .. }), "{e}");
}
