//! Stability charts over a (V, D) grid for rank-one delayed feedback, parallel and
//! deterministic.
//!
//! The caller supplies a closure `V ↦ RankOneFeedback` (it builds A(V), B(V), C(V) and calls
//! [`RankOneFeedback::from_state_space`]); this module knows nothing about what V means.
//!
//! Per column (fixed V and τ) the work is:
//! 1. the D-subdivision crossings of the column ([`RankOneFeedback::crossings`]) — these give the
//!    exact number of unstable roots in every cell by crossing counting, and the boundary points;
//! 2. the spectral abscissa along the column by Newton continuation of the rightmost roots from
//!    cell to cell on the quasi-polynomial, reseeded from the confirmed spectral method
//!    ([`RankOneFeedback::rightmost_roots`]) at the first cell, every
//!    [`ChartOptions::reseed_interval`] cells, whenever roots merge, and whenever the tracked
//!    roots disagree with the exact count.
//!
//! Columns run in parallel with rayon and are collected in order, so the numbers do not depend on
//! the number of threads.

use std::fmt::Display;

use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Result, StabilityError};
use crate::rank_one::{Crossing, RankOneFeedback};
use crate::roots::RootOptions;

/// A cell-centred uniform axis: `count` values `min + (i + ½)·(max − min)/count`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    /// lower edge
    pub min: f64,
    /// upper edge
    pub max: f64,
    /// number of cells
    pub count: usize,
}

impl Axis {
    /// Checks the axis (`axis` names it in the error).
    pub fn validate(&self, axis: &'static str) -> Result<()> {
        if self.min.is_finite() && self.max.is_finite() && self.min < self.max && self.count >= 2 {
            Ok(())
        } else {
            Err(StabilityError::InvalidGrid {
                axis,
                min: self.min,
                max: self.max,
                count: self.count,
            })
        }
    }

    /// Cell width.
    pub fn step(&self) -> f64 {
        (self.max - self.min) / self.count as f64
    }

    /// The cell centres.
    pub fn values(&self) -> Vec<f64> {
        (0..self.count)
            .map(|i| self.min + (i as f64 + 0.5) * self.step())
            .collect()
    }
}

/// Options of [`stability_charts`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChartOptions {
    /// seeds for the rightmost roots (spectral method + Newton)
    pub roots: RootOptions,
    /// how many rightmost roots are followed along D (conjugates counted separately)
    pub tracked_roots: usize,
    /// a fresh confirmed seed every this many cells along D
    pub reseed_interval: usize,
    /// boundaries are computed for |D| up to this factor times the largest |D| of the grid
    /// (so that plotted curves reach the frame)
    pub boundary_margin: f64,
}

impl Default for ChartOptions {
    fn default() -> Self {
        Self {
            roots: RootOptions::default(),
            tracked_roots: 8,
            reseed_interval: 8,
            boundary_margin: 1.1,
        }
    }
}

/// One grid cell.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ChartCell {
    /// spectral abscissa max Re λ \[1/s\] (NaN if the roots could not be computed)
    pub spectral_abscissa: f64,
    /// number of characteristic roots with Re λ > 0 (exact, by crossing counting; `u32::MAX`
    /// if the column's system could not be built or its crossings not found)
    pub unstable_roots: u32,
}

impl ChartCell {
    /// Asymptotically stable (no root in the closed right half plane, up to boundaries).
    pub fn is_stable(&self) -> bool {
        self.unstable_roots == 0
    }
}

/// A point of a stability boundary.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoundaryPoint {
    /// parameter V
    pub v: f64,
    /// gain D
    pub d: f64,
    /// crossing frequency ω \[rad/s\]
    pub omega: f64,
}

/// A boundary curve as a polyline ordered along V.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Polyline {
    /// the points
    pub points: Vec<BoundaryPoint>,
}

/// The chart for one delay τ.
#[derive(Debug, Clone, PartialEq)]
pub struct StabilityChart {
    /// delay τ \[s\]
    pub tau: f64,
    /// V values (cell centres)
    pub v: Vec<f64>,
    /// D values (cell centres)
    pub d: Vec<f64>,
    /// cells, index `iv·d.len() + id`
    pub cells: Vec<ChartCell>,
    /// D-subdivision crossings of every V column (|D| ≤ margin·max|D|)
    pub crossings: Vec<Vec<Crossing>>,
    /// static boundary (λ = 0) polylines
    pub static_boundary: Vec<Polyline>,
    /// dynamic boundary (λ = ±iω) polylines
    pub dynamic_boundaries: Vec<Polyline>,
    /// how many cells needed a fresh spectral seed
    pub reseeds: usize,
    /// cells that could not be computed fully: (iv, id, message)
    pub failures: Vec<(usize, usize, String)>,
}

impl StabilityChart {
    /// The cell at (iv, id).
    pub fn cell(&self, iv: usize, id: usize) -> &ChartCell {
        &self.cells[iv * self.d.len() + id]
    }
}

struct Column {
    cells: Vec<ChartCell>,
    crossings: Vec<Crossing>,
    reseeds: usize,
    failures: Vec<(usize, String)>,
}

fn upper_half(roots: &[Complex64]) -> Vec<Complex64> {
    roots.iter().copied().filter(|r| r.im >= 0.0).collect()
}

fn multiplicity(r: &Complex64) -> usize {
    if r.im > 0.0 { 2 } else { 1 }
}

fn column(
    sys: &Result<RankOneFeedback>,
    tau: f64,
    ds: &[f64],
    d_lim: f64,
    opt: &ChartOptions,
) -> Column {
    let mut out = Column {
        cells: Vec::with_capacity(ds.len()),
        crossings: Vec::new(),
        reseeds: 0,
        failures: Vec::new(),
    };
    let crossings = match sys {
        Ok(sys) => sys.crossings(tau, d_lim).map(|c| (sys, c)),
        Err(e) => Err(e.clone()),
    };
    let sys = match crossings {
        Ok((sys, c)) => {
            out.crossings = c;
            sys
        }
        Err(e) => {
            for (k, _) in ds.iter().enumerate() {
                out.failures.push((k, e.to_string()));
                out.cells.push(ChartCell {
                    spectral_abscissa: f64::NAN,
                    unstable_roots: u32::MAX,
                });
            }
            return out;
        }
    };
    let newton = opt.roots.newton;
    let mut tracked: Vec<Complex64> = Vec::new();
    let mut expected = 0usize;
    let interval = opt.reseed_interval.max(1);
    for (k, &d) in ds.iter().enumerate() {
        // a cancelled chart stops here (`cancel::run` catches it)
        cancel::checkpoint();
        let count = sys.unstable_count_from(d, &out.crossings);
        let consistent = |roots: &[Complex64]| {
            let near_axis = roots.iter().any(|r| r.re.abs() < 1e-9 * r.norm().max(1.0));
            let n: usize = roots.iter().filter(|r| r.re > 0.0).map(multiplicity).sum();
            near_axis || n == count
        };
        let mut ok = false;
        if !tracked.is_empty() && k % interval != 0 {
            let mut next: Vec<Complex64> = Vec::with_capacity(tracked.len());
            for r in &tracked {
                if let Ok(mut x) = sys.polish_root(*r, d, tau, &newton) {
                    x.im = if x.im.abs() <= 1e-12 * x.norm().max(1.0) {
                        0.0
                    } else {
                        x.im.abs()
                    };
                    if !next
                        .iter()
                        .any(|y| (y - x).norm() <= 1e-9 * x.norm().max(1.0))
                    {
                        next.push(x);
                    }
                }
            }
            let listed: usize = next.iter().map(multiplicity).sum();
            if listed >= expected && consistent(&next) {
                tracked = next;
                ok = true;
            }
        }
        if !ok {
            out.reseeds += 1;
            let want = opt.tracked_roots.max(count + 2);
            match sys.rightmost_roots(d, tau, want, &opt.roots) {
                Ok(r) => {
                    tracked = upper_half(&r);
                    expected = tracked.iter().map(multiplicity).sum();
                    if !consistent(&tracked) {
                        out.failures.push((
                            k,
                            format!(
                                "{} roots right of the axis found, crossing count says {count}",
                                tracked
                                    .iter()
                                    .filter(|r| r.re > 0.0)
                                    .map(multiplicity)
                                    .sum::<usize>()
                            ),
                        ));
                    }
                }
                Err(e) => {
                    out.failures.push((k, e.to_string()));
                    tracked.clear();
                }
            }
        }
        let sa = tracked.iter().map(|r| r.re).fold(f64::NAN, f64::max);
        out.cells.push(ChartCell {
            spectral_abscissa: sa,
            unstable_roots: count as u32,
        });
    }
    out
}

/// Links per-column boundary points into polylines: a point continues the polyline whose last
/// point (in the previous column) is nearest in (D, ω), if close enough.
fn link(v: &[f64], columns: &[Vec<(f64, f64)>], d_span: f64) -> Vec<Polyline> {
    let w_span = columns.iter().flatten().map(|p| p.1).fold(1.0, f64::max);
    let cost = |a: &BoundaryPoint, b: &(f64, f64)| {
        (a.d - b.0).abs() / d_span + (a.omega - b.1).abs() / w_span
    };
    let mut done: Vec<Polyline> = Vec::new();
    let mut active: Vec<Polyline> = Vec::new();
    for (j, pts) in columns.iter().enumerate() {
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (ia, a) in active.iter().enumerate() {
            let last = a.points.last().expect("polylines are never empty");
            for (ip, p) in pts.iter().enumerate() {
                let c = cost(last, p);
                if c < 0.08 {
                    pairs.push((c, ia, ip));
                }
            }
        }
        pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let mut used_a = vec![false; active.len()];
        let mut used_p = vec![false; pts.len()];
        for (_, ia, ip) in pairs {
            if !used_a[ia] && !used_p[ip] {
                used_a[ia] = true;
                used_p[ip] = true;
                active[ia].points.push(BoundaryPoint {
                    v: v[j],
                    d: pts[ip].0,
                    omega: pts[ip].1,
                });
            }
        }
        let mut still = Vec::new();
        for (ia, a) in active.into_iter().enumerate() {
            if used_a[ia] {
                still.push(a)
            } else {
                done.push(a)
            }
        }
        for (ip, p) in pts.iter().enumerate() {
            if !used_p[ip] {
                still.push(Polyline {
                    points: vec![BoundaryPoint {
                        v: v[j],
                        d: p.0,
                        omega: p.1,
                    }],
                });
            }
        }
        active = still;
    }
    done.extend(active);
    done
}

/// Stability charts for every delay in `taus` over the (V, D) grid.
///
/// `system(V)` returns the loop at parameter V. A V column whose system or crossings fail is
/// recorded in [`StabilityChart::failures`] (NaN abscissa, `u32::MAX` count) and the chart goes
/// on. Deterministic: the same numbers for any number of rayon threads.
///
/// # Errors
/// [`StabilityError::InvalidGrid`] / [`StabilityError::InvalidDelay`] before any work.
pub fn stability_charts<F, E>(
    system: F,
    taus: &[f64],
    v_axis: Axis,
    d_axis: Axis,
    options: &ChartOptions,
) -> Result<Vec<StabilityChart>>
where
    F: Fn(f64) -> std::result::Result<RankOneFeedback, E> + Sync,
    E: Display,
{
    let system = |v: f64| {
        system(v).map_err(|e| StabilityError::System {
            v,
            message: e.to_string(),
        })
    };
    charts_of(&system, taus, v_axis, d_axis, options)
}

/// [`stability_charts`] with the system behind a `&dyn Fn`: the parallel columns are
/// compiled once, not once per caller's closure (and per plant of a generic caller).
fn charts_of(
    system: &(dyn Fn(f64) -> Result<RankOneFeedback> + Sync),
    taus: &[f64],
    v_axis: Axis,
    d_axis: Axis,
    options: &ChartOptions,
) -> Result<Vec<StabilityChart>> {
    v_axis.validate("V")?;
    d_axis.validate("D")?;
    for &t in taus {
        if !(t.is_finite() && t >= 0.0) {
            return Err(StabilityError::InvalidDelay { tau: t });
        }
    }
    let vs = v_axis.values();
    let ds = d_axis.values();
    // a failing V column is reported in `failures` and the chart goes on
    let systems: Vec<Result<RankOneFeedback>> = vs.par_iter().map(|&v| system(v)).collect();
    let d_lim = options.boundary_margin.max(1.0) * d_axis.min.abs().max(d_axis.max.abs());
    let jobs: Vec<(usize, usize)> = (0..taus.len())
        .flat_map(|t| (0..vs.len()).map(move |i| (t, i)))
        .collect();
    let columns: Vec<Column> = jobs
        .par_iter()
        .map(|&(t, i)| column(&systems[i], taus[t], &ds, d_lim, options))
        .collect();
    let mut charts = Vec::with_capacity(taus.len());
    let mut it = columns.into_iter();
    for &tau in taus {
        let cols: Vec<Column> = it.by_ref().take(vs.len()).collect();
        let mut cells = Vec::with_capacity(vs.len() * ds.len());
        let mut crossings = Vec::with_capacity(vs.len());
        let mut reseeds = 0;
        let mut failures = Vec::new();
        for (i, c) in cols.into_iter().enumerate() {
            cells.extend(c.cells);
            reseeds += c.reseeds;
            failures.extend(c.failures.into_iter().map(|(k, m)| (i, k, m)));
            crossings.push(c.crossings);
        }
        let stat: Vec<Vec<(f64, f64)>> = crossings
            .iter()
            .map(|c| {
                c.iter()
                    .filter(|x| x.omega == 0.0)
                    .map(|x| (x.d, 0.0))
                    .collect()
            })
            .collect();
        let dynamic: Vec<Vec<(f64, f64)>> = crossings
            .iter()
            .map(|c| {
                c.iter()
                    .filter(|x| x.omega > 0.0)
                    .map(|x| (x.d, x.omega))
                    .collect()
            })
            .collect();
        let d_span = 2.0 * d_lim;
        charts.push(StabilityChart {
            tau,
            v: vs.clone(),
            d: ds.clone(),
            cells,
            static_boundary: link(&vs, &stat, d_span),
            dynamic_boundaries: link(&vs, &dynamic, d_span),
            crossings,
            reseeds,
            failures,
        });
    }
    Ok(charts)
}

/// The lowest V in `[v_min, v_max]` at which gain `d` leaves at least one root in the right half
/// plane, located by scanning `samples` values of V and bisecting the exact crossing count to
/// `tolerance`. `None` if stable over the whole range.
pub fn first_unstable_parameter<F, E>(
    system: F,
    tau: f64,
    d: f64,
    v_min: f64,
    v_max: f64,
    samples: usize,
    tolerance: f64,
) -> Result<Option<f64>>
where
    F: Fn(f64) -> std::result::Result<RankOneFeedback, E>,
    E: Display,
{
    let unstable = |v: f64| -> Result<bool> {
        let s = system(v).map_err(|e| StabilityError::System {
            v,
            message: e.to_string(),
        })?;
        Ok(s.unstable_root_count(d, tau)? > 0)
    };
    let n = samples.max(2);
    let mut prev = v_min;
    if unstable(v_min)? {
        return Ok(Some(v_min));
    }
    for i in 1..n {
        let v = v_min + (v_max - v_min) * i as f64 / (n - 1) as f64;
        if unstable(v)? {
            let (mut a, mut b) = (prev, v);
            while b - a > tolerance {
                let m = 0.5 * (a + b);
                if unstable(m)? { b = m } else { a = m }
            }
            return Ok(Some(0.5 * (a + b)));
        }
        prev = v;
    }
    Ok(None)
}
