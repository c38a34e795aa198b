//! The stability chart of the Hayes equation (Hayes 1950), the textbook scalar DDE
//!
//! `x'(t) = a·x(t) + b·x(t − 1)`,
//!
//! written as rank-one delayed feedback `x' = a·x + u`, `u = −D·x(t − τ)` with `D = −b`,
//! `τ = 1`, so that the chart is over (a, D). The exact answer: the equation is asymptotically
//! stable iff `a < 1` and `a < D < ω/sin ω`, where ω ∈ (0, π) solves `ω·cot ω = a` — the static
//! boundary `D = a` (a root λ = 0) and the dynamic boundary (λ = ±iω).
//!
//! The program counts the roots in the right half plane of every cell by D-subdivision
//! ([`RankOneFeedback::crossings`], exact crossing counting), prints the chart as ASCII art
//! (`·` stable, a digit: the number of roots with Re λ > 0), compares every cell and the
//! stable D intervals with the exact boundary, and spot-checks a few cells with the
//! independent spectral method ([`stability::rightmost_roots`]: Chebyshev collocation and
//! Newton).
//!
//! Run with `cargo run -p stability --example hayes_chart`.

use nalgebra::{DMatrix, Matrix1};
use stability::{Axis, LinearDde, RankOneFeedback, RootOptions, StabilityError, rightmost_roots};

const TAU: f64 = 1.0;

/// The loop at parameter a: `x' = a·x + u`, measured output x.
fn hayes(a: f64) -> Result<RankOneFeedback, StabilityError> {
    RankOneFeedback::from_state_space(&Matrix1::new(a), &Matrix1::new(1.0), &Matrix1::new(1.0))
}

/// The exact stable interval of D at `a` (`None` for a ≥ 1): `(a, ω/sin ω)` with
/// `ω·cot ω = a`, ω ∈ (0, π), found by bisection (ω·cot ω falls from 1 to −∞ on (0, π)).
fn exact_interval(a: f64) -> Option<(f64, f64)> {
    if a >= 1.0 {
        return None;
    }
    let (mut lo, mut hi) = (1e-12, std::f64::consts::PI - 1e-12);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid / mid.tan() > a {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let omega = 0.5 * (lo + hi);
    Some((a, omega / omega.sin()))
}

fn main() -> Result<(), StabilityError> {
    let a_axis = Axis {
        min: -3.0,
        max: 1.5,
        count: 72,
    };
    let d_axis = Axis {
        min: -1.5,
        max: 4.5,
        count: 30,
    };
    let (a_values, d_values) = (a_axis.values(), d_axis.values());
    let d_lim = 10.0;

    // counts[ia][id]: roots with Re λ > 0, by D-subdivision
    let mut counts = Vec::with_capacity(a_values.len());
    for &a in &a_values {
        let sys = hayes(a)?;
        let crossings = sys.crossings(TAU, d_lim)?;
        let column: Vec<usize> = d_values
            .iter()
            .map(|&d| sys.unstable_count_from(d, &crossings))
            .collect();
        counts.push(column);
    }

    println!("Hayes equation x' = a x + b x(t - 1), D = -b: stability chart");
    println!("(·: stable; digit: number of roots with Re λ > 0)\n");
    for id in (0..d_values.len()).rev() {
        let row: String = counts
            .iter()
            .map(|column| match column[id] {
                0 => '·',
                n @ 1..=9 => char::from_digit(n as u32, 10).unwrap_or('+'),
                _ => '+',
            })
            .collect();
        println!("D = {:>5.2} |{row}", d_values[id]);
    }
    println!(
        "{:>11}a from {} to {} ({} columns)\n",
        "", a_axis.min, a_axis.max, a_axis.count
    );

    // every cell, and the stable intervals (end points: the exact crossings), against the
    // closed form
    let mut cell_mismatch = 0;
    let mut interval_mismatch = 0;
    let mut worst_end: f64 = 0.0;
    println!(
        "{:>7}  {:>22}  {:>22}",
        "a", "stable D (computed)", "stable D (exact)"
    );
    for (ia, &a) in a_values.iter().enumerate() {
        let exact = exact_interval(a);
        for (id, &d) in d_values.iter().enumerate() {
            let stable = exact.is_some_and(|(lo, hi)| d > lo && d < hi);
            if stable != (counts[ia][id] == 0) {
                cell_mismatch += 1;
            }
        }
        let got = hayes(a)?.stable_gain_intervals(TAU, -d_lim, d_lim)?;
        match (got.as_slice(), exact) {
            ([(d0, d1)], Some((e0, e1))) => {
                worst_end = worst_end.max((d0 - e0).abs()).max((d1 - e1).abs());
                if ia % 12 == 0 {
                    println!("{a:>7.3}  ({d0:>9.6}, {d1:>9.6})  ({e0:>9.6}, {e1:>9.6})");
                }
            }
            ([], None) => {}
            _ => interval_mismatch += 1,
        }
    }

    // spot checks with the spectral method: the sign of the rightmost root's real part
    let mut spectral_mismatch = 0;
    let spots = [
        (-2.0, 0.0),
        (-2.0, 3.5),
        (0.5, 1.0),
        (0.5, 1.5),
        (1.2, 1.0),
        (-1.0, -1.2),
    ];
    println!(
        "\n{:>6} {:>6}  {:>26}  count",
        "a", "D", "rightmost root (spectral)"
    );
    for (a, d) in spots {
        let dde = LinearDde::new(DMatrix::from_element(1, 1, a))?
            .with_delay(TAU, DMatrix::from_element(1, 1, -d))?;
        let root = rightmost_roots(&dde, 1, &RootOptions::default())?[0];
        let sys = hayes(a)?;
        let count = sys.unstable_count_from(d, &sys.crossings(TAU, d_lim)?);
        if (root.re > 0.0) != (count > 0) {
            spectral_mismatch += 1;
        }
        println!(
            "{a:>6.2} {d:>6.2}  {:>11.6} {:>+11.6}i  {count:>5}",
            root.re, root.im
        );
    }

    println!("\nlargest difference of an interval end from the exact boundary: {worst_end:.1e}");
    println!("columns whose stable set is not the one exact interval: {interval_mismatch}");
    println!(
        "cells classified differently from the exact boundary: {cell_mismatch} of {}",
        a_values.len() * d_values.len()
    );
    println!("spot checks where the spectral method disagrees: {spectral_mismatch}");
    let ok = worst_end < 1e-10 && interval_mismatch + cell_mismatch + spectral_mismatch == 0;
    println!("check: {}", if ok { "ok" } else { "FAILED" });
    if !ok {
        std::process::exit(1);
    }
    Ok(())
}
