//! Fold-of-cycles curves: cost of one Newton step of the extended defining system versus the
//! number of mesh intervals L, and of a whole curve of 80 points, on a 4-dimensional delayed
//! problem: two coupled Bautin oscillators with delayed cubic terms (the in-phase rotating
//! waves have folds of cycles).
use continuation::*;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::f64::consts::PI;
use std::hint::black_box;

/// z_o' = (μ1 + i) z_o + μ2 |z_o(t−τ)|² z_o(t−τ) − |z_o|⁴ z_o + ε (z_other − z_o), o = 1, 2;
/// p = [μ1, μ2, τ]
struct CoupledDelayedBautin {
    eps: f64,
}

fn dot2(a: &[f64], b: &[f64]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

impl Problem for CoupledDelayedBautin {
    fn dim(&self) -> usize {
        4
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
    fn rhs(&self, a: &[f64], p: &[f64], f: &mut [f64]) {
        for o in 0..2 {
            let (x, y, z) = (
                &a[2 * o..2 * o + 2],
                &a[4 + 2 * o..6 + 2 * o],
                &a[2 - 2 * o..4 - 2 * o],
            );
            let (r, s) = (dot2(x, x), dot2(y, y));
            for i in 0..2 {
                f[2 * o + i] = (p[0] - r * r - self.eps) * x[i] + p[1] * s * y[i] + self.eps * z[i];
            }
            f[2 * o] -= x[1];
            f[2 * o + 1] += x[0];
        }
    }
    fn jacobian(&self, a: &[f64], p: &[f64], j: &mut [f64]) {
        j.iter_mut().for_each(|v| *v = 0.0);
        for o in 0..2 {
            let (x, y) = (&a[2 * o..2 * o + 2], &a[4 + 2 * o..6 + 2 * o]);
            let (r, s) = (dot2(x, x), dot2(y, y));
            for i in 0..2 {
                let row = (2 * o + i) * 8;
                for k in 0..2 {
                    let id = if i == k { 1.0 } else { 0.0 };
                    j[row + 2 * o + k] = (p[0] - r * r - self.eps) * id - 4.0 * r * x[i] * x[k];
                    j[row + 4 + 2 * o + k] = p[1] * (s * id + 2.0 * y[i] * y[k]);
                }
                j[row + 2 - 2 * o + i] = self.eps;
            }
            j[(2 * o) * 8 + 2 * o + 1] -= 1.0;
            j[(2 * o + 1) * 8 + 2 * o] += 1.0;
        }
    }
    fn dfdp(&self, a: &[f64], _p: &[f64], ip: usize, out: &mut [f64]) {
        for o in 0..2 {
            let (x, y) = (&a[2 * o..2 * o + 2], &a[4 + 2 * o..6 + 2 * o]);
            for i in 0..2 {
                out[2 * o + i] = match ip {
                    0 => x[i],
                    1 => dot2(y, y) * y[i],
                    _ => 0.0,
                };
            }
        }
    }
    fn second_derivative(
        &self,
        args: &[f64],
        p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        for o in 0..2 {
            let (xr, yr) = (2 * o..2 * o + 2, 4 + 2 * o..6 + 2 * o);
            let (x, y) = (&args[xr.clone()], &args[yr.clone()]);
            let (ax, ay, bx, by) = (&a[xr.clone()], &a[yr.clone()], &b[xr], &b[yr]);
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
    fn jacobian_dp(
        &self,
        args: &[f64],
        _p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        for o in 0..2 {
            let y = &args[4 + 2 * o..6 + 2 * o];
            let ay = &a[4 + 2 * o..6 + 2 * o];
            let (s, ya) = (dot2(y, y), dot2(y, ay));
            for i in 0..2 {
                out[2 * o + i] = match ip {
                    0 => a[2 * o + i],
                    1 => s * ay[i] + 2.0 * ya * y[i],
                    _ => 0.0,
                };
            }
        }
        Ok(())
    }
}

const MU2: f64 = 1.0;
const TAU: f64 = 0.5;

/// the fold of the in-phase cycles at (μ2, τ) = (1, 0.5) on L intervals, as the start of
/// a fold-of-cycles curve in (μ1, μ2): system, corrected first point
fn fold_start(
    problem: &CoupledDelayedBautin,
    l: usize,
    multipliers: bool,
) -> (
    FoldOfCyclesSystem<'_, CoupledDelayedBautin>,
    Vec<f64>,
    Vec<f64>,
) {
    // in-phase rotating wave of radius 1: ω = 1 − μ2 sin ωτ, μ1 = 1 − μ2 cos ωτ
    let mut w: f64 = 1.0;
    for _ in 0..100 {
        w -= (w - 1.0 + MU2 * (w * TAU).sin()) / (1.0 + MU2 * TAU * (w * TAU).cos());
    }
    let mu1 = 1.0 - MU2 * (w * TAU).cos();
    let col = CollocationOptions {
        intervals: l,
        ..Default::default()
    };
    let mut po = PeriodicOrbitSystem::new(problem, vec![mu1, MU2, TAU], 0, col).expect("system");
    let u0 = po.unknowns_from(
        |s| {
            let (c, sn) = ((2.0 * PI * s).cos(), (2.0 * PI * s).sin());
            vec![c, sn, c, sn]
        },
        2.0 * PI / w,
        mu1,
    );
    po.set_reference(&u0);
    let mut dir = vec![0.0; u0.len()];
    dir[po.parameter_index()] = -1.0;
    let cont = Continuation::new(ContinuationOptions {
        initial_step: 0.05,
        max_step: 0.1,
        ..Default::default()
    });
    let mut br = cont.start(&mut po, &u0, &dir).expect("cycle");
    cont.extend(&mut po, &mut br, 60).expect("cycle branch");
    let (i, _) = br.first(SpecialKind::Fold).expect("fold of cycles");
    let opts = FoldCyclesOptions {
        multipliers,
        ..Default::default()
    };
    let (mut sys, guess, dir) =
        FoldOfCyclesSystem::from_fold(&po, &br.points[i], 1, opts).expect("fold system");
    let first = cont
        .start(&mut sys, &guess, &dir)
        .expect("fold curve start");
    let u = first.points[0].u.clone();
    let t = first.points[0].tangent.clone();
    sys.accept(&u);
    (sys, u, t)
}

fn bench(c: &mut Criterion) {
    let problem = CoupledDelayedBautin { eps: 0.1 };
    let mut group = c.benchmark_group("fold_cycles_4d_dde");
    for &l in &[20usize, 40, 80, 160] {
        let (mut sys, u, t) = fold_start(&problem, l, false);
        group.bench_with_input(BenchmarkId::new("newton_step", l), &l, |b, _| {
            b.iter(|| newton_step(&mut sys, black_box(&u), &t).expect("step"))
        });
    }
    group.sample_size(10);
    for multipliers in [false, true] {
        let (mut sys, u, t) = fold_start(&problem, 40, multipliers);
        let cont = Continuation::new(ContinuationOptions {
            initial_step: 0.05,
            max_step: 0.1,
            ..Default::default()
        });
        let name = if multipliers {
            "curve_80_points_with_multipliers"
        } else {
            "curve_80_points"
        };
        group.bench_function(BenchmarkId::new(name, 40), |b| {
            b.iter(|| {
                let mut curve = cont.start(&mut sys, &u, &t).expect("start");
                let stop = sys.extend_curve(&cont, &mut curve, 80).expect("curve");
                assert!(curve.points.len() > 80, "{stop:?}");
                curve
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
