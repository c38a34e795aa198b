//! Benchmarks: rightmost roots at a point, polynomial roots versus degree, chart cost versus grid size, semi-discretisation and
//! collocation cost versus resolution. The test loop is a synthetic 4-state single-input system
//! (this crate knows nothing about trailers; the full Fig. 4(a) bench lives in the app crate).

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use stability::{
    Axis, ChartOptions, ChebyshevCollocation, RootOptions, SemiDiscretisation, polynomial_roots,
    stability_charts,
};

#[path = "../tests/common/mod.rs"]
mod common;
use common::test_loop;

fn point(c: &mut Criterion) {
    let sys = test_loop(5.0).unwrap();
    let mut g = c.benchmark_group("rightmost_roots_point");
    for tau in [0.0, 0.2, 0.4] {
        g.bench_with_input(BenchmarkId::new("6_roots_tau", tau), &tau, |b, &tau| {
            b.iter(|| {
                sys.rightmost_roots(black_box(0.3), tau, 6, &RootOptions::default())
                    .unwrap()
            })
        });
    }
    g.bench_function("unstable_count_tau_0.2", |b| {
        b.iter(|| sys.unstable_root_count(black_box(0.3), 0.2).unwrap())
    });
    g.finish();
}

/// Roots of a degree-n polynomial with known, well-separated roots (the crossing search's
/// companion matrices are of degree ≤ ~40): this crate's small-matrix QR
/// ([`polynomial_roots`]) against faer's general eigensolver on the same companion matrix.
fn polynomial_degree(c: &mut Criterion) {
    let mut g = c.benchmark_group("polynomial_roots_degree");
    for n in [4usize, 8, 16, 32, 64] {
        // Π (z − r_k), r_k = −1 − k/n ± i·k: a stable, lightly damped spectrum
        let mut coeffs = vec![1.0];
        for k in 0..n / 2 {
            let (re, im) = (-1.0 - k as f64 / n as f64, k as f64 + 1.0);
            let quad = [re * re + im * im, -2.0 * re, 1.0];
            let mut next = vec![0.0; coeffs.len() + 2];
            for (i, a) in coeffs.iter().enumerate() {
                for (j, b) in quad.iter().enumerate() {
                    next[i + j] += a * b;
                }
            }
            coeffs = next;
        }
        g.bench_with_input(BenchmarkId::new("small_qr", n), &coeffs, |b, c| {
            b.iter(|| polynomial_roots(black_box(c)).unwrap())
        });
        g.bench_with_input(BenchmarkId::new("faer", n), &coeffs, |b, c| {
            b.iter(|| {
                let m = faer::Mat::from_fn(n, n, |i, j| {
                    if i == 0 {
                        -c[n - 1 - j] / c[n]
                    } else if i == j + 1 {
                        1.0
                    } else {
                        0.0
                    }
                });
                m.eigenvalues().unwrap()
            })
        });
    }
    g.finish();
}

fn resolution(c: &mut Criterion) {
    let sys = test_loop(5.0).unwrap();
    let dde = sys.closed_loop(0.3, 0.2).unwrap();
    let mut g = c.benchmark_group("resolution");
    // one benchmark `name`/size of `run(size)` per size
    let mut sizes = |name: &str, sizes: [usize; 4], run: &dyn Fn(usize)| {
        for size in sizes {
            g.bench_with_input(BenchmarkId::new(name, size), &size, |b, &size| {
                b.iter(|| run(size))
            });
        }
    };
    sizes("semi_discretisation_r", [10, 20, 40, 80], &|r| {
        let solver = SemiDiscretisation { steps_per_delay: r };
        black_box(solver.roots(black_box(&dde)).unwrap());
    });
    sizes("chebyshev_degree", [8, 16, 32, 64], &|n| {
        let solver = ChebyshevCollocation { degree: n };
        black_box(solver.eigenvalues(black_box(&dde)).unwrap());
    });
    g.finish();
}

fn charts(c: &mut Criterion) {
    let mut g = c.benchmark_group("chart_4_delays");
    g.sample_size(10);
    for (nv, nd) in [(75usize, 50usize), (150, 100), (300, 200)] {
        g.bench_with_input(
            BenchmarkId::new("grid", format!("{nv}x{nd}")),
            &(nv, nd),
            |b, &(nv, nd)| {
                b.iter(|| {
                    stability_charts(
                        test_loop,
                        &[0.0, 0.1, 0.2, 0.4],
                        Axis {
                            min: 0.0,
                            max: 12.0,
                            count: nv,
                        },
                        Axis {
                            min: -3.0,
                            max: 3.0,
                            count: nd,
                        },
                        &ChartOptions::default(),
                    )
                    .unwrap()
                })
            },
        );
    }
    g.finish();
}

criterion_group!(benches, point, polynomial_degree, resolution, charts);
criterion_main!(benches);
