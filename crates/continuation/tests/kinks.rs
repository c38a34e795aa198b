//! The trivial Floquet multiplier (exactly 1 for every cycle of an autonomous equation) of
//! cycles whose right-hand side has declared C¹ kinks (ODE and DDE), and of a smooth
//! textbook cycle.
mod common;
use common::{colloc, cont};
use continuation::*;
use continuation_textbook::NormalForm;
use std::f64::consts::PI;

/// x' = −y + x(1 − r²) + a g(x_d), y' = x + y(1 − r²) with g(z) = z|z| (C¹: its Jacobian
/// 2|z| has a kink at z = 0) and x_d = x(t − τ) (DDE) or x(t) (ODE); the switching
/// function x_d is declared.
struct Kinked {
    a: f64,
    delayed: bool,
}

impl Problem for Kinked {
    fn dim(&self) -> usize {
        2
    }
    fn n_delays(&self) -> usize {
        usize::from(self.delayed)
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[1]
    }
    fn rhs(&self, z: &[f64], _p: &[f64], f: &mut [f64]) {
        let (x, y) = (z[0], z[1]);
        let xd = if self.delayed { z[2] } else { x };
        let r2 = x * x + y * y;
        f[0] = -y + x * (1.0 - r2) + self.a * xd * xd.abs();
        f[1] = x + y * (1.0 - r2);
    }
    fn jacobian(&self, z: &[f64], _p: &[f64], j: &mut [f64]) {
        let (x, y) = (z[0], z[1]);
        let nc = 2 * (1 + self.n_delays());
        j.iter_mut().for_each(|v| *v = 0.0);
        let r2 = x * x + y * y;
        j[0] = 1.0 - r2 - 2.0 * x * x;
        j[1] = -1.0 - 2.0 * x * y;
        j[nc] = 1.0 - 2.0 * x * y;
        j[nc + 1] = 1.0 - r2 - 2.0 * y * y;
        let xd = if self.delayed { z[2] } else { x };
        let g = 2.0 * self.a * xd.abs();
        if self.delayed {
            j[2] = g;
        } else {
            j[0] += g;
        }
    }
    fn dfdp(&self, _z: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
    }
    fn n_switching(&self) -> usize {
        1
    }
    fn switching(&self, z: &[f64], _p: &[f64], g: &mut [f64]) {
        g[0] = if self.delayed { z[2] } else { z[0] };
    }
}

/// the cycle of `k` (from the unit circle, the parameter p\[0\] fixed) on L intervals
fn kinked_cycle(k: &Kinked, l: usize) -> (PeriodicOrbitSystem<'_, Kinked>, Vec<f64>) {
    let mut po = PeriodicOrbitSystem::new(k, vec![0.0, 0.7], 0, colloc(l)).unwrap();
    let u0 = po.unknowns_from(
        |s| vec![(2.0 * PI * s).cos(), (2.0 * PI * s).sin()],
        2.0 * PI,
        0.0,
    );
    po.set_reference(&u0);
    let mut e = vec![0.0; u0.len()];
    e[u0.len() - 1] = 1.0;
    let br = cont(0.01, 0.01).start(&mut po, &u0, &e).unwrap();
    let u = br.points[0].u.clone();
    po.set_reference(&u);
    (po, u)
}

fn trivial_defect(mu: &[num_complex::Complex64]) -> f64 {
    mu.iter()
        .map(|z| (z - 1.0).norm())
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn trivial_multiplier_of_cycles_with_declared_kinks_is_one() {
    // reference: the trivial multiplier is exactly 1; the cycle crosses the kink x_d = 0
    // twice per period, inside mesh intervals of the uniform mesh. With the kinks resolved
    // (the cycle corrected on a mesh with points at the switching times, the monodromy
    // computed there) the collocation keeps its order: required 1e-9 on L = 20, m = 4 for
    // the ODE (measured 3.8e-10; 2.3e-6 with the kinks only inserted into the monodromy's
    // mesh, as before), 1e-6 for the DDE (measured 4.6e-8 with mesh points also at the
    // kinks carried along the delay, t + τ/T and t + 2τ/T; 7.3e-7 without).
    // Independently, the nontrivial multiplier of the ODE cycle equals the converged
    // (L = 160) value to 1e-8.
    for delayed in [false, true] {
        let k = Kinked { a: 0.4, delayed };
        let (mut po, u) = kinked_cycle(&k, 20);
        let mu = po.floquet_multipliers(&u).unwrap();
        let defect = trivial_defect(&mu);
        // the DDE's kinks propagate (derivative jumps one order higher one delay later,
        // resolved for two generations): required 1e-6 there (the target of the trailer
        // diagrams)
        let tolerance = if delayed { 1e-6 } else { 1e-9 };
        assert!(
            defect < tolerance,
            "delayed {delayed}: trivial multiplier off by {defect:e}"
        );
        if !delayed {
            let (mut fine, uf) = kinked_cycle(&k, 160);
            let reference = fine.floquet_multipliers(&uf).unwrap();
            let nontrivial = |mu: &[num_complex::Complex64]| {
                *mu.iter()
                    .min_by(|a, b| (*a - 1.0).norm().total_cmp(&(*b - 1.0).norm()).reverse())
                    .unwrap()
            };
            let (a, b) = (nontrivial(&mu), nontrivial(&reference));
            assert!((a - b).norm() < 1e-8, "nontrivial {a} vs converged {b}");
        }
    }
}

#[test]
fn trivial_multiplier_of_a_smooth_cycle_is_one() {
    // reference: the Stuart–Landau cycle of radius √μ (closed form), trivial multiplier 1;
    // collocation on L = 20, m = 4 of a circle is accurate to ~1e-11: required 1e-8
    // (the tolerance of the Stuart–Landau test in ode.rs)
    let p = NormalForm::stuart_landau(1.0, 0.0);
    let mu: f64 = 0.5;
    let mut po = PeriodicOrbitSystem::new(&p, vec![mu], 0, colloc(20)).unwrap();
    let r = mu.sqrt();
    let u = po.unknowns_from(
        |s| vec![r * (2.0 * PI * s).cos(), r * (2.0 * PI * s).sin()],
        2.0 * PI,
        mu,
    );
    po.set_reference(&u);
    let mut e = vec![0.0; u.len()];
    e[u.len() - 1] = 1.0;
    let u = cont(0.01, 0.01).start(&mut po, &u, &e).unwrap().points[0]
        .u
        .clone();
    let defect = trivial_defect(&po.floquet_multipliers(&u).unwrap());
    assert!(defect < 1e-8, "{defect:e}");
}
