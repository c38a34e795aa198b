//! Cost of one Newton step (assembly + sparse LU + solve) and of the Floquet multipliers
//! versus the number of mesh intervals L, on a generic 4-dimensional problem: two coupled
//! Stuart–Landau oscillators (a stable cycle with a known closed form).
use continuation::*;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::hint::black_box;

/// z1' = (μ + i) z1 − |z1|² z1 + ε (z2 − z1), z2' = (μ + i) z2 − |z2|² z2 + ε (z1 − z2):
/// the in-phase cycle z1 = z2 = √μ e^{it} exists for all ε.
struct Coupled {
    eps: f64,
}

impl Problem for Coupled {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        let mu = p[0];
        for o in 0..2 {
            let (a, b) = (x[2 * o], x[2 * o + 1]);
            let (c, d) = (x[2 - 2 * o], x[3 - 2 * o]);
            let r2 = a * a + b * b;
            f[2 * o] = mu * a - b - r2 * a + self.eps * (c - a);
            f[2 * o + 1] = a + mu * b - r2 * b + self.eps * (d - b);
        }
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        let mu = p[0];
        j.iter_mut().for_each(|v| *v = 0.0);
        for o in 0..2 {
            let (a, b) = (x[2 * o], x[2 * o + 1]);
            let r2 = a * a + b * b;
            let (i0, i1) = (2 * o, 2 * o + 1);
            let other = 2 - 2 * o;
            j[i0 * 4 + i0] = mu - r2 - 2.0 * a * a - self.eps;
            j[i0 * 4 + i1] = -1.0 - 2.0 * a * b;
            j[i1 * 4 + i0] = 1.0 - 2.0 * a * b;
            j[i1 * 4 + i1] = mu - r2 - 2.0 * b * b - self.eps;
            j[i0 * 4 + other] = self.eps;
            j[i1 * 4 + other + 1] = self.eps;
        }
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
        out.copy_from_slice(&x[..4]);
    }
}

fn bench(c: &mut Criterion) {
    let problem = Coupled { eps: 0.1 };
    let mu: f64 = 1.0;
    let mut group = c.benchmark_group("collocation_4d");
    for &l in &[20usize, 40, 80, 160] {
        let mut sys = PeriodicOrbitSystem::new(
            &problem,
            vec![mu],
            0,
            CollocationOptions {
                intervals: l,
                ..Default::default()
            },
        )
        .expect("system");
        let two_pi = 2.0 * std::f64::consts::PI;
        let u = sys.unknowns_from(
            |s| {
                let r = mu.sqrt();
                let (c, sn) = ((two_pi * s).cos(), (two_pi * s).sin());
                vec![r * c, r * sn, r * c, r * sn]
            },
            two_pi,
            mu,
        );
        sys.set_reference(&u);
        let nu = sys.n_unknowns();
        let tangent: Vec<f64> = (0..nu)
            .map(|i| if i == nu - 1 { 1.0 } else { 0.0 })
            .collect();
        group.bench_with_input(BenchmarkId::new("newton_step", l), &l, |b, _| {
            b.iter(|| newton_step(&mut sys, black_box(&u), &tangent).expect("step"))
        });
        group.bench_with_input(BenchmarkId::new("floquet_multipliers", l), &l, |b, _| {
            b.iter(|| sys.floquet_multipliers(black_box(&u)).expect("multipliers"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
