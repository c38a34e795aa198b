//! Stability charts against point-wise confirmed roots, and determinism.

use stability::{Axis, ChartOptions, RootOptions, StabilityError, stability_charts};

mod common;
use common::test_loop;

fn axes() -> (Axis, Axis) {
    (
        Axis {
            min: 0.0,
            max: 12.0,
            count: 12,
        },
        Axis {
            min: -3.0,
            max: 3.0,
            count: 30,
        },
    )
}

#[test]
fn chart_cells_match_pointwise_roots() {
    // reference: at every cell, the confirmed and polished rightmost roots of the spectral method
    // (independent of the tracking and of the crossing count). Tolerance 1e-9 on the spectral
    // abscissa (both are Newton-polished to ~1e-14; the slack covers ill-conditioned roots).
    let (va, da) = axes();
    let taus = [0.0, 0.3, 1.0];
    let charts = stability_charts(test_loop, &taus, va, da, &ChartOptions::default()).unwrap();
    for ch in &charts {
        assert!(ch.failures.is_empty(), "{:?}", ch.failures);
        for (iv, &v) in ch.v.iter().enumerate() {
            let sys = test_loop(v).unwrap();
            for (id, &d) in ch.d.iter().enumerate() {
                let cell = ch.cell(iv, id);
                let n = cell.unstable_roots as usize;
                let r = sys
                    .rightmost_roots(d, ch.tau, n + 2, &RootOptions::default())
                    .unwrap();
                let diff = (cell.spectral_abscissa - r[0].re).abs();
                assert!(
                    diff < 1e-9 * r[0].norm().max(1.0),
                    "τ={} v={v} d={d}: {} vs {}",
                    ch.tau,
                    cell.spectral_abscissa,
                    r[0]
                );
                assert_eq!(
                    n,
                    r.iter().filter(|z| z.re > 0.0).count(),
                    "τ={} v={v} d={d}",
                    ch.tau
                );
                assert_eq!(cell.is_stable(), r[0].re < 0.0);
            }
        }
        assert!(
            !ch.static_boundary.is_empty()
                || ch.crossings.iter().all(|c| c.iter().all(|x| x.omega > 0.0))
        );
    }
}

#[test]
fn charts_do_not_depend_on_thread_count() {
    let (va, da) = axes();
    let taus = [0.0, 0.3, 1.0];
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                stability_charts(test_loop, &taus, va, da, &ChartOptions::default()).unwrap()
            })
    };
    let (one, two) = (run(1), run(3));
    for (a, b) in one.iter().zip(&two) {
        assert_eq!(a.cells.len(), b.cells.len());
        for (x, y) in a.cells.iter().zip(&b.cells) {
            assert_eq!(x.unstable_roots, y.unstable_roots);
            assert_eq!(x.spectral_abscissa.to_bits(), y.spectral_abscissa.to_bits());
        }
        assert_eq!(a.crossings, b.crossings);
        assert_eq!(a.dynamic_boundaries, b.dynamic_boundaries);
    }
}

#[test]
fn invalid_grid_is_reported() {
    let bad = Axis {
        min: 1.0,
        max: 0.0,
        count: 10,
    };
    let (va, _) = axes();
    let e = stability_charts(test_loop, &[0.1], va, bad, &ChartOptions::default()).unwrap_err();
    assert!(matches!(e, StabilityError::InvalidGrid { axis: "D", .. }));
}

#[test]
fn a_failing_column_is_reported_and_the_chart_goes_on() {
    let (va, da) = axes();
    let sys = |v: f64| {
        if v > 5.0 && v < 6.0 {
            Err("no linearisation here".to_string())
        } else {
            test_loop(v).map_err(|e| e.to_string())
        }
    };
    let ch = &stability_charts(sys, &[0.3], va, da, &ChartOptions::default()).unwrap()[0];
    let bad_column = ch.v.iter().position(|&v| v > 5.0 && v < 6.0).unwrap();
    assert_eq!(ch.failures.len(), ch.d.len());
    assert!(
        ch.failures
            .iter()
            .all(|f| f.0 == bad_column && f.2.contains("no linearisation"))
    );
    assert!(ch.cell(bad_column, 0).spectral_abscissa.is_nan());
    // the other columns are computed
    assert!(ch.cell(0, 0).spectral_abscissa.is_finite());
}
