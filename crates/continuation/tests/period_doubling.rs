//! Period-doubling curves of cycles in two parameters (ODE and DDE) against a closed form
//! and against the multiplier −1 of the monodromy (an independent formulation), and the
//! exact Jacobian of the defining system against finite differences.
mod common;
use common::{colloc, cont, dense_jacobian, fd_jacobian_of};
use continuation::*;
use std::f64::consts::PI;

/// A cycle with a twisted normal bundle: (x, y) a Stuart–Landau oscillator of frequency
/// ω = 1 + p2 on the unit circle, (u, v) = w a transverse pair driven by the cycle,
///
/// w' = [a I + b [[x, y], [y, −x]] + (ω/2) J] w + e R(ωτ/2) w(t − τ),
///
/// a = (μ − 1)/2, b = (μ + 1)/2, μ = p1 − p2², J the rotation generator, R(φ) the
/// rotation by φ; p = [p1, p2, e, τ]. On the cycle (x, y) = (cos ωt, sin ωt) the frame
/// ξ = R(−ωt/2) w obeys ξ1' = μ ξ1 + e ξ1(t − τ), ξ2' = −ξ2 + e ξ2(t − τ), and w
/// turns by π per period: its multipliers are −e^{λT} with λ the characteristic roots of
/// those scalar equations. The root λ = 0 of the first exists for μ = −e: the cycle (period
/// 2π/ω) has the multiplier −1 exactly on p1 = p2² − e.
struct Flip {
    delayed: bool,
}

impl Flip {
    fn coefficients(&self, p: &[f64]) -> (f64, f64, f64, f64, f64, f64) {
        let mu = p[0] - p[1] * p[1];
        let omega = 1.0 + p[1];
        let phi = 0.5 * omega * p[3];
        (
            0.5 * (mu - 1.0),
            0.5 * (mu + 1.0),
            omega,
            if self.delayed { p[2] } else { 0.0 },
            phi.cos(),
            phi.sin(),
        )
    }
}

impl Problem for Flip {
    fn dim(&self) -> usize {
        4
    }
    fn n_delays(&self) -> usize {
        usize::from(self.delayed)
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[3]
    }
    fn delay_dp(&self, _j: usize, _p: &[f64], ip: usize) -> f64 {
        if ip == 3 { 1.0 } else { 0.0 }
    }
    fn rhs(&self, z: &[f64], p: &[f64], f: &mut [f64]) {
        let (a, b, w, e, c, s) = self.coefficients(p);
        let (x, y, u, v) = (z[0], z[1], z[2], z[3]);
        let r2 = x * x + y * y;
        f[0] = x - w * y - r2 * x;
        f[1] = w * x + y - r2 * y;
        f[2] = a * u + b * (x * u + y * v) - 0.5 * w * v;
        f[3] = a * v + b * (y * u - x * v) + 0.5 * w * u;
        if self.delayed {
            let (ud, vd) = (z[6], z[7]);
            f[2] += e * (c * ud - s * vd);
            f[3] += e * (s * ud + c * vd);
        }
    }
    fn jacobian(&self, z: &[f64], p: &[f64], j: &mut [f64]) {
        let (a, b, w, e, c, s) = self.coefficients(p);
        let (x, y, u, v) = (z[0], z[1], z[2], z[3]);
        let nc = 4 * (1 + self.n_delays());
        j.iter_mut().for_each(|q| *q = 0.0);
        let r2 = x * x + y * y;
        let rows: [[f64; 4]; 4] = [
            [1.0 - r2 - 2.0 * x * x, -w - 2.0 * x * y, 0.0, 0.0],
            [w - 2.0 * x * y, 1.0 - r2 - 2.0 * y * y, 0.0, 0.0],
            [b * u, b * v, a + b * x, b * y - 0.5 * w],
            [-b * v, b * u, b * y + 0.5 * w, a - b * x],
        ];
        for (r, row) in rows.iter().enumerate() {
            j[r * nc..r * nc + 4].copy_from_slice(row);
        }
        if self.delayed {
            j[2 * nc + 6] = e * c;
            j[2 * nc + 7] = -e * s;
            j[3 * nc + 6] = e * s;
            j[3 * nc + 7] = e * c;
        }
    }
    fn dfdp(&self, z: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
        fd_dfdp(self, z, p, ip, out)
    }
    fn second_derivative(
        &self,
        z: &[f64],
        p: &[f64],
        da: &[f64],
        db: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        // exact: the cubic Stuart–Landau terms and the bilinear coupling b·M(x, y)·w
        let (_, b, ..) = self.coefficients(p);
        let (x, y) = (z[0], z[1]);
        let (ax, ay, au, av) = (da[0], da[1], da[2], da[3]);
        let (bx, by, bu, bv) = (db[0], db[1], db[2], db[3]);
        // d²(r² x)[a, b] = 2(a_x b_x + a_y b_y) x + 2(x a_x + y a_y) b_x + 2(x b_x + y b_y) a_x
        let ab = ax * bx + ay * by;
        let xa = x * ax + y * ay;
        let xb = x * bx + y * by;
        out[0] = -(2.0 * ab * x + 2.0 * xa * bx + 2.0 * xb * ax);
        out[1] = -(2.0 * ab * y + 2.0 * xa * by + 2.0 * xb * ay);
        out[2] = b * (ax * bu + au * bx + ay * bv + av * by);
        out[3] = b * (ay * bu + au * by - ax * bv - av * bx);
        Ok(())
    }
    fn jacobian_dp(
        &self,
        z: &[f64],
        p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        fd_jacobian_dp(self, z, p, ip, a, out)
    }
}

const E: f64 = 0.3;
const TAU: f64 = 1.0;

/// the period-doubling point of the cycle branch in p1 at p2 (from μ = −e − 0.1 upwards),
/// on `intervals` mesh intervals: the cycle system and the located point
fn period_doubling_on_branch(
    flip: &Flip,
    p2: f64,
    intervals: usize,
) -> (PeriodicOrbitSystem<'_, Flip>, BranchPoint) {
    let e = if flip.delayed { E } else { 0.0 };
    let p1 = p2 * p2 - e - 0.1;
    let mut po =
        PeriodicOrbitSystem::new(flip, vec![p1, p2, E, TAU], 0, colloc(intervals)).unwrap();
    let w = 1.0 + p2;
    let u0 = po.unknowns_from(
        |s| vec![(2.0 * PI * s).cos(), (2.0 * PI * s).sin(), 0.0, 0.0],
        2.0 * PI / w,
        p1,
    );
    po.set_reference(&u0);
    let mut dir = vec![0.0; u0.len()];
    dir[po.parameter_index()] = 1.0;
    let c = cont(0.04, 0.04);
    let mut br = c.start(&mut po, &u0, &dir).unwrap();
    c.extend(&mut po, &mut br, 8).unwrap();
    let (i, sp) = br
        .first(SpecialKind::PeriodDoubling)
        .expect("a period-doubling point");
    assert_eq!(sp.location, Location::Located);
    let point = br.points[i].clone();
    (po, point)
}

/// distance of the multiplier nearest −1 to −1, from the monodromy of the cycle system at
/// the curve point u (an independent formulation of the period-doubling condition)
fn monodromy_defect(pd: &mut PeriodDoublingCurveSystem<'_, Flip>, u: &[f64]) -> f64 {
    pd.multipliers(u)
        .unwrap()
        .iter()
        .map(|z| (z + 1.0).norm())
        .fold(f64::INFINITY, f64::min)
}

fn check_curve(delayed: bool) {
    // reference: the closed form p1 = p2² − e, T = 2π/(1 + p2) (see `Flip`); the cycle
    // and the mode are resolved to ~1e-10 on L = 16 (m = 4), the tolerance is 1e-7.
    // Independently, the monodromy of the cycle at the curve points has the multiplier −1
    // to 1e-7 (the same collocation, a different formulation: eigenvalues of the
    // discretised monodromy operator).
    let flip = Flip { delayed };
    let e = if delayed { E } else { 0.0 };
    let (po, point) = period_doubling_on_branch(&flip, 0.2, 16);
    assert!(
        (point.parameter - (0.04 - e)).abs() < 1e-7,
        "{}",
        point.parameter
    );
    let (mut pd, guess, dir) =
        PeriodDoublingCurveSystem::from_period_doubling(&po, &point, 1, Default::default())
            .unwrap();
    let c = cont(0.05, 0.1);
    for sign in [1.0, -1.0] {
        let d: Vec<f64> = dir.iter().map(|x| sign * x).collect();
        let mut curve = c.start(&mut pd, &guess, &d).unwrap();
        c.extend(&mut pd, &mut curve, 8).unwrap();
        assert!(curve.points.len() >= 8);
        let p2_end = curve.points.last().unwrap().secondary_parameter.unwrap();
        assert!(
            sign * (p2_end - 0.2) > 0.08,
            "the curve moves in p2: {p2_end}"
        );
        for pt in &curve.points {
            let (p1, p2) = (pt.parameter, pt.secondary_parameter.unwrap());
            assert!((p1 - (p2 * p2 - e)).abs() < 1e-7, "p1 {p1} at p2 {p2}");
            let t = pd.period(&pt.u);
            assert!((t - 2.0 * PI / (1.0 + p2)).abs() < 1e-7, "T {t} at p2 {p2}");
        }
        for pt in [&curve.points[1], curve.points.last().unwrap()] {
            let defect = monodromy_defect(&mut pd, &pt.u);
            assert!(defect < 1e-7, "multiplier −1 off by {defect}");
        }
    }
}

#[test]
fn ode_period_doubling_curve_is_analytic_and_has_multiplier_minus_one() {
    check_curve(false);
}

#[test]
fn dde_period_doubling_curve_is_analytic_and_has_multiplier_minus_one() {
    check_curve(true);
}

/// a point near the curve with a generic, non-symmetric mode (so that every term of the
/// Jacobian is exercised)
fn generic_point(
    pd: &PeriodDoublingCurveSystem<'_, Flip>,
    po: &PeriodicOrbitSystem<'_, Flip>,
    p1: f64,
) -> Vec<f64> {
    let mut u = po.unknowns_from(
        |s| {
            let (c, sn) = ((2.0 * PI * s).cos(), (2.0 * PI * s).sin());
            vec![0.9 * c + 0.05 * sn, 1.1 * sn, 0.1 * c * c, 0.2 * sn - 0.1]
        },
        2.0 * PI / 1.2,
        p1,
    );
    u.push(0.2);
    let nodes = po.node_times();
    for s in nodes {
        // antiperiodic-looking mode with harmonics (the node values are what matters)
        let (c, sn) = ((PI * s).cos(), (PI * s).sin());
        u.extend([
            0.3 * c,
            0.2 * sn,
            c + 0.4 * (3.0 * PI * s).sin(),
            sn - 0.2 * c,
        ]);
    }
    assert_eq!(u.len(), pd.n_unknowns());
    u
}

#[test]
fn period_doubling_jacobian_matches_finite_differences() {
    // reference: central differences of the residual (h = 1e-6 (1 + |u|)): error ~1e-8
    // relative; plus the finite-difference ∂J/∂p of the problem (~1e-8). Tolerance 1e-5.
    // DDE with the delay as second parameter (the delayed points move with τ) and with
    // p2 = ω's parameter.
    let flip = Flip { delayed: true };
    for ip2 in [1, 3] {
        let params = vec![0.0, 0.2, E, TAU];
        let po = PeriodicOrbitSystem::new(&flip, params.clone(), 0, colloc(5)).unwrap();
        let mut pd =
            PeriodDoublingCurveSystem::new(&flip, params, (0, ip2), colloc(5), Default::default())
                .unwrap();
        let mut u = generic_point(&pd, &po, -0.26);
        if ip2 == 3 {
            let np = pd.n_unknowns() / 2 - 1;
            u[np + 2] = TAU;
        }
        pd.accept(&u);
        // move away from the reference so that the normalisation row is generic
        for (i, x) in u.iter_mut().enumerate() {
            *x += 1e-3 * ((i as f64 * 0.37).sin());
        }
        let jac = dense_jacobian(&mut pd, &u);
        let fd = fd_jacobian_of(&mut pd, &u);
        let err = jac
            .iter()
            .zip(fd.iter())
            .fold(0.0f64, |m, (j, f)| m.max((f - j).abs() / (1.0 + j.abs())));
        assert!(err < 1e-5, "ip2 {ip2}: Jacobian error {err}");
    }
}
