//! Gain design for the delayed yaw-rate feedback δ(t) = −D·ψ̇(t − τ) (eq. 8,
//! beyond the paper): for a given delay τ, the gain D that makes straight running safe up
//! to the highest speed.
//!
//! - **Linear optimum** ([`linear_optimum`]): the gain D\*(τ) that maximises the linear
//!   critical speed V_crit(D), the speed up to which straight running is stable at every
//!   lower speed (the `fig4a` computation, [`critical_speed_at_gain`]: exact counts of
//!   unstable roots of eq. (13) scanned in V and bisected). V_crit(D) is continuous but
//!   not smooth: it has a kink where two Hopf curves cross (a double-Hopf point, e.g.
//!   τ = 0.2 s, D ≈ 0.26 s) and may jump where the stable speeds are a union of
//!   intervals. So the maximum is found by a coarse scan over the gain range, then refined
//!   inside the bracket of the best sample by Brent's method (argmin's `BrentOpt`, which
//!   falls back on golden sections where the parabola fails, as at a kink). The gains
//!   within 1 % of the maximum are the connected interval around D\*, both ends located by
//!   bisection. Without delay V_crit rises with D on the whole range: the optimum is then
//!   flagged as lying on the range end ([`RangeEnd`]).
//! - **Nonlinear optimum** ([`fold_optimum`]): the gain that maximises the speed below
//!   which no perturbation triggers sway, V_safe(D) = min(V_fold(D), V_crit(D)), where
//!   V_fold(D) is the fold-of-cycles speed of the two-parameter continuation
//!   ([`crate::bifurcation::chart`]); V_crit caps it where another mode's Hopf curve lies
//!   below the sway mode's fold (there the fold of cycles coexists with unstable straight
//!   running and protects nothing). The curve's points bracket the maximum, which Brent
//!   refines on fold speeds corrected at fixed D ([`NonlinearChart::fold_speed_at`]).
//! - **Delay budget** ([`delay_budget`]): the largest τ at which the best gain still raises
//!   the critical speed by a given fraction (10 %) over the open loop, bisected in τ
//!   between the grid delays that bracket the last crossing.
//!
//! Everything is deterministic: the scans are sequential per delay and the delays of
//! [`linear_optima`] are computed in parallel but returned in grid order.

use crate::parallel::{Split, try_map};
use argmin::core::{CostFunction, Error as ArgminError, Executor, State};
use argmin::solver::brent::BrentOpt;
use serde::{Deserialize, Serialize};
use trailer_model::Model;

use sway_model::speeds::CappedSpeed;
use sway_model::vehicle::LoopModel;

use crate::SwayError;
use crate::bifurcation::chart::{
    ChartOptions, CurveEnd, EndedCurve, NonlinearChart, critical_speeds, nonlinear_chart,
};
use crate::bifurcation::{CycleExtent, DiagramOptions, LoopLaw, bifurcation_diagram_until};
use crate::charts::critical_speed_at_gain;

/// Settings of the search for the best gain at one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GainSearch {
    /// lower end of the gain range \[s\]
    pub d_min_s: f64,
    /// upper end of the gain range \[s\]
    pub d_max_s: f64,
    /// gains of the coarse scan, evenly spaced over the range ends included (≥ 3)
    pub gain_samples: usize,
    /// lower end of the speed range of the critical speed \[m/s\]
    pub v_min_mps: f64,
    /// upper end of the speed range \[m/s\]: a gain stable up to here gets V_crit = v_max
    pub v_max_mps: f64,
    /// speeds scanned for the first instability (then bisected); an unstable speed
    /// interval shorter than the spacing may be missed
    pub speed_samples: usize,
    /// bisection tolerance of the critical speed \[m/s\]
    pub speed_tolerance_mps: f64,
    /// tolerance of the optimal gain and of the band ends \[s\]
    pub gain_tolerance_s: f64,
    /// the band: gains whose critical speed is within this fraction of the maximum (0.01)
    pub band_fraction: f64,
    /// most Brent iterations of one refinement
    pub max_iterations: u64,
}

impl Default for GainSearch {
    fn default() -> Self {
        Self {
            d_min_s: 0.0,
            d_max_s: 0.5,
            gain_samples: 101,
            v_min_mps: 1.0,
            v_max_mps: 100.0,
            speed_samples: 100,
            speed_tolerance_mps: 1e-9,
            gain_tolerance_s: 1e-6,
            band_fraction: 0.01,
            max_iterations: 200,
        }
    }
}

impl GainSearch {
    /// The gains of the coarse scan \[s\], range ends included.
    pub fn gains(&self) -> Vec<f64> {
        let n = self.gain_samples.max(2);
        let span = self.d_max_s - self.d_min_s;
        (0..n)
            .map(|i| self.d_min_s + span * i as f64 / (n - 1) as f64)
            .collect()
    }
}

/// The end of the gain range an optimum lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RangeEnd {
    /// D = d_min
    Lower,
    /// D = d_max (e.g. τ = 0: V_crit keeps rising with D)
    Upper,
}

impl RangeEnd {
    /// Which end `d` is on (within `tol` \[s\]), if any.
    fn of(d: f64, o: &GainSearch) -> Option<Self> {
        if (d - o.d_min_s).abs() <= o.gain_tolerance_s {
            Some(Self::Lower)
        } else if (o.d_max_s - d).abs() <= o.gain_tolerance_s {
            Some(Self::Upper)
        } else {
            None
        }
    }
}

/// The linear optimum of one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearOptimum {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// the gain D\* maximising the critical speed \[s\]
    pub d_opt_s: f64,
    /// the maximal critical speed V_crit(D\*) \[m/s\] (the top of the speed range if capped:
    /// the optimiser's objective; a summary reports [`LinearOptimum::v_crit_max`])
    pub v_crit_max_mps: f64,
    /// the gains whose critical speed is within `band_fraction` of the maximum (the
    /// connected interval around D\*; an end equals a range end if the band reaches it) \[s\]
    pub band_s: [f64; 2],
    /// the optimum lies on an end of the gain range (the true maximum may lie beyond)
    pub on_range_end: Option<RangeEnd>,
    /// V_crit,max is the top of the speed range: stable up to v_max, the true critical
    /// speed is higher
    pub speed_capped: bool,
    /// the rightmost characteristic roots confirm V_crit,max (see [`roots_confirm`]);
    /// false flags a disagreement with the crossing count of [`critical_speed_at_gain`]
    pub roots_confirm: bool,
    /// evaluations of the critical speed
    pub evaluations: usize,
}

impl LinearOptimum {
    /// V_crit,max as a summary reports it: found, or straight running stable up to the top
    /// of the speed range (`speed_capped`: `v_crit_max_mps` is that top, not a measured
    /// speed).
    pub fn v_crit_max(&self) -> CappedSpeed {
        if self.speed_capped {
            CappedSpeed::StableUpTo(self.v_crit_max_mps)
        } else {
            CappedSpeed::Found(self.v_crit_max_mps)
        }
    }
}

/// Speed offset of the check of [`roots_confirm`] \[m/s\].
pub const CONFIRM_OFFSET_MPS: f64 = 1e-4;

/// Whether the rightmost characteristic roots of eq. (13) (Chebyshev collocation of the
/// generator, Newton-polished: [`crate::charts::rightmost_roots`], independent of the
/// crossing count behind [`critical_speed_at_gain`]) confirm that V \[m/s\] is the critical
/// speed at (τ, D): Re λ < 0 at V − [`CONFIRM_OFFSET_MPS`] and > 0 at V +
/// [`CONFIRM_OFFSET_MPS`] (only the first when V is the top of the speed range). An
/// independent check of every optimum: it found the crossing count missing a pair of
/// crossings where a Hopf curve turns back in D (the tip at τ = 0.4 s, D ≈ 0.148 s; fixed
/// in `stability` since), which showed as a plateau of V_crit(D) below the true maximum.
///
/// # Errors
/// [`SwayError::Numerical`] if the roots cannot be confirmed.
pub fn roots_confirm<M: LoopModel + ?Sized>(
    model: &M,
    tau: f64,
    d: f64,
    v: f64,
    o: &GainSearch,
) -> Result<bool, SwayError> {
    let abscissa = |v: f64| -> Result<f64, SwayError> {
        Ok(crate::charts::rightmost_roots(model, v, d, tau, 2)?
            .first()
            .map_or(f64::NAN, |z| z.re))
    };
    let below = abscissa(v - CONFIRM_OFFSET_MPS)? < 0.0;
    if v >= o.v_max_mps {
        return Ok(below);
    }
    Ok(below && abscissa(v + CONFIRM_OFFSET_MPS)? > 0.0)
}

/// The linear critical speed \[m/s\] at delay τ \[s\] and gain D \[s\]: the lowest speed in
/// the search's speed range at which straight running is unstable
/// ([`critical_speed_at_gain`]); `v_max_mps` if it is stable on the whole range.
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn critical_speed<M: LoopModel + ?Sized>(
    model: &M,
    tau: f64,
    d: f64,
    o: &GainSearch,
) -> Result<f64, SwayError> {
    let v = critical_speed_at_gain(
        model,
        tau,
        d,
        o.v_min_mps,
        o.v_max_mps,
        o.speed_samples,
        o.speed_tolerance_mps,
    )?;
    Ok(v.unwrap_or(o.v_max_mps))
}

/// −f as an argmin cost function, counting its evaluations; a failure of f is carried
/// through argmin's error and recovered by [`maximise`].
struct Negated<'a, F>(F, &'a std::cell::Cell<usize>);

impl<F: Fn(f64) -> Result<f64, SwayError>> CostFunction for Negated<'_, F> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, d: &f64) -> Result<f64, ArgminError> {
        self.1.set(self.1.get() + 1);
        (self.0)(*d).map(|v| -v).map_err(ArgminError::new)
    }
}

/// The maximum of `f` on [a, b] by Brent's method (argmin `BrentOpt`) to `tol`, compared
/// with the already known sample `known` (the better of the two is returned; a tie keeps
/// `known`). Returns (argmax, max, evaluations).
///
/// # Errors
/// The error of `f`, or [`SwayError::Numerical`] if argmin fails.
pub fn maximise(
    f: impl Fn(f64) -> Result<f64, SwayError>,
    (a, b): (f64, f64),
    known: (f64, f64),
    tol: f64,
    max_iterations: u64,
) -> Result<(f64, f64, usize), SwayError> {
    if b - a <= tol {
        return Ok((known.0, known.1, 0));
    }
    // |x − x*| < 3·tol_brent with tol_brent = eps·|x| + t
    let solver = BrentOpt::new(a, b).set_tolerance(f64::EPSILON.sqrt() * 1e-2, tol / 3.0);
    let count = std::cell::Cell::new(0);
    let run = Executor::new(Negated(f, &count), solver)
        .configure(|s| s.max_iters(max_iterations))
        .run();
    let result = match run {
        Ok(r) => r,
        Err(e) => {
            return Err(match e.downcast::<SwayError>() {
                Ok(sway) => sway,
                Err(other) => SwayError::numerical(
                    format!("Brent maximisation on [{a}, {b}]"),
                    std::io::Error::other(other.to_string()),
                ),
            });
        }
    };
    let state = result.state();
    let evaluations = count.get();
    let (x, fx) = (
        state.get_best_param().copied().unwrap_or(known.0),
        -state.get_best_cost(),
    );
    if fx > known.1 {
        Ok((x, fx, evaluations))
    } else {
        Ok((known.0, known.1, evaluations))
    }
}

/// The end of the set {g ≥ thr} between `inside` (g ≥ thr) and `outside` (g < thr), by
/// bisection to `tol`: the last point known inside. Returns (point, evaluations).
pub(crate) fn band_end(
    g: &impl Fn(f64) -> Result<f64, SwayError>,
    mut inside: f64,
    mut outside: f64,
    thr: f64,
    tol: f64,
) -> Result<(f64, usize), SwayError> {
    let mut n = 0;
    while (outside - inside).abs() > tol {
        let m = 0.5 * (inside + outside);
        n += 1;
        if g(m)? >= thr {
            inside = m;
        } else {
            outside = m;
        }
    }
    Ok((inside, n))
}

/// The maximum of a function sampled at `xs` (values `ys`): the first best sample refined
/// by [`maximise`] between its neighbours, and the band {f ≥ (1 − fraction)·max} around it
/// with both ends bisected (a range end if the band reaches it). Returns (argmax, max,
/// band, evaluations).
pub(crate) fn refine_sampled(
    f: &impl Fn(f64) -> Result<f64, SwayError>,
    xs: &[f64],
    ys: &[f64],
    o: &GainSearch,
) -> Result<(f64, f64, [f64; 2], usize), SwayError> {
    let k = first_argmax(ys);
    let (a, b) = (xs[k.saturating_sub(1)], xs[(k + 1).min(xs.len() - 1)]);
    let (x, fx, mut n) = maximise(
        f,
        (a, b),
        (xs[k], ys[k]),
        o.gain_tolerance_s,
        o.max_iterations,
    )?;
    let thr = (1.0 - o.band_fraction) * fx;
    let mut lo = k;
    while lo > 0 && ys[lo - 1] >= thr {
        lo -= 1;
    }
    let mut hi = k;
    while hi + 1 < xs.len() && ys[hi + 1] >= thr {
        hi += 1;
    }
    // the inner end of a bisection: the refined maximum itself where the best sample is
    // already outside the band (a peak narrower than the scan's spacing)
    let inner = |i: usize, toward_lower: bool| match (i == k, ys[k] >= thr, toward_lower) {
        (true, false, _) => x,
        (true, true, true) => xs[k].min(x),
        (true, true, false) => xs[k].max(x),
        _ => xs[i],
    };
    let band_lo = if lo == 0 {
        xs[0]
    } else {
        let (e, m) = band_end(f, inner(lo, true), xs[lo - 1], thr, o.gain_tolerance_s)?;
        n += m;
        e
    };
    let band_hi = if hi + 1 == xs.len() {
        xs[hi]
    } else {
        let (e, m) = band_end(f, inner(hi, false), xs[hi + 1], thr, o.gain_tolerance_s)?;
        n += m;
        e
    };
    Ok((x, fx, [band_lo, band_hi], n))
}

/// Index of the first largest value (NaN never wins).
#[doc(hidden)] // pub for tests/unit
pub fn first_argmax(ys: &[f64]) -> usize {
    let mut k = 0;
    for (i, &y) in ys.iter().enumerate() {
        if y > ys[k] || ys[k].is_nan() {
            k = i;
        }
    }
    k
}

/// The gain D\*(τ) maximising the linear critical speed at delay τ \[s\] (see the module
/// documentation): coarse scan, Brent refinement in the best bracket, the band within
/// `band_fraction` of the maximum, the range-end flag.
///
/// # Errors
/// [`SwayError::Numerical`] if a critical speed cannot be computed.
pub fn linear_optimum<M: LoopModel + ?Sized>(
    model: &M,
    tau: f64,
    o: &GainSearch,
) -> Result<LinearOptimum, SwayError> {
    let f = |d: f64| critical_speed(model, tau, d, o);
    let gains = o.gains();
    let speeds = gains.iter().map(|&d| f(d)).collect::<Result<Vec<_>, _>>()?;
    let (d, v, band, n) = refine_sampled(&f, &gains, &speeds, o)?;
    Ok(LinearOptimum {
        tau_s: tau,
        d_opt_s: d,
        v_crit_max_mps: v,
        band_s: band,
        on_range_end: RangeEnd::of(d, o),
        speed_capped: v >= o.v_max_mps,
        roots_confirm: roots_confirm(model, tau, d, v, o)?,
        evaluations: gains.len() + n,
    })
}

/// [`linear_optimum`] at every delay of `taus` \[s\], in parallel, returned in the order of
/// `taus` (each delay is computed sequentially, so the result does not depend on the
/// number of threads).
///
/// # Errors
/// The first failing delay's error (in the order of `taus`).
pub fn linear_optima<M: LoopModel + ?Sized>(
    model: &M,
    taus: &[f64],
    o: &GainSearch,
) -> Result<Vec<LinearOptimum>, SwayError> {
    try_map(taus, Split::Adaptive, &|_, &tau| {
        linear_optimum(model, tau, o)
    })
}

/// What limits the safe speed at the nonlinear optimum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SafeSpeedLimit {
    /// the fold of cycles of the sway mode: above it a large enough kick triggers sway
    FoldOfCycles,
    /// the linear critical speed (another mode's Hopf curve lies below the fold)
    CriticalSpeed,
}

/// The nonlinear optimum of one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoldOptimum {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// the gain maximising V_safe(D) = min(V_fold(D), V_crit(D)) over the gains the
    /// fold-of-cycles curve crosses \[s\]
    pub d_fold_s: f64,
    /// the maximal safe speed V_safe(D_fold\*) \[m/s\]
    pub v_fold_max_mps: f64,
    /// the fold-of-cycles speed there \[m/s\]
    pub v_fold_at_optimum_mps: f64,
    /// the linear critical speed there \[m/s\]
    pub v_crit_at_optimum_mps: f64,
    /// which of the two is the smaller
    pub limited_by: SafeSpeedLimit,
    /// the optimum lies on an end of the gain range
    pub on_range_end: Option<RangeEnd>,
    /// points of the fold-of-cycles curve inside the gain range
    pub curve_points: usize,
    /// fold speeds corrected at fixed D during the refinement
    pub evaluations: usize,
}

/// The nonlinear part of one delay: the optimum (None where no fold-of-cycles curve
/// crosses the gain range) and what was noticed.
#[derive(Debug, Clone, PartialEq)]
pub struct FoldResult {
    /// the optimum, if a fold-of-cycles curve exists
    pub optimum: Option<FoldOptimum>,
    /// the fold-of-cycles curve points (D \[s\], V \[m/s\]) in the gain range, in curve order
    pub curve: Vec<(f64, f64)>,
    /// why there is no optimum, or the chart's notes
    pub notes: Vec<String>,
    /// the curves that ended early (and fold speeds that could not be corrected), with how
    pub curves_ended_early: Vec<EndedCurve>,
}

/// The chart options of the nonlinear search: `chart` with the gain range of `o`, and the
/// Hopf curves cut short (2 points, 2 criticality samples of 2 cycle points), since only
/// the fold-of-cycles curve started at the first seed gain is used.
pub fn fold_chart_options(chart: &ChartOptions, o: &GainSearch) -> ChartOptions {
    ChartOptions {
        d_min_s: o.d_min_s,
        d_max_s: o.d_max_s,
        hopf_max_points: 2,
        criticality_samples: 2,
        criticality_cycle_points: 2,
        ..chart.clone()
    }
}

/// The safe speed min(V_fold(D), V_crit(D)) \[m/s\] at gain D \[s\] with V_fold corrected at
/// fixed D; V_crit alone where the fold-of-cycles curve does not cross D.
fn safe_speed(
    model: &Model,
    chart: &NonlinearChart,
    d: f64,
    o: &GainSearch,
) -> Result<(f64, Option<f64>, f64), SwayError> {
    let vc = critical_speed(model, chart.tau_s, d, o)?;
    let vf = chart.fold_speed_at(model, d)?;
    Ok((vf.map_or(vc, |f| f.min(vc)), vf, vc))
}

/// The fold-of-cycles points of `chart` inside the gain range of `o` (and the chart's
/// speed range), in curve order.
fn fold_points_in_range(chart: &NonlinearChart, o: &GainSearch) -> Vec<(f64, f64)> {
    let co = &chart.options;
    chart
        .fold_curves
        .iter()
        .flat_map(|c| c.points.iter())
        .filter(|p| p.d_s >= o.d_min_s && p.d_s <= o.d_max_s)
        .filter(|p| p.v_mps >= co.v_min_mps && p.v_mps <= co.v_max_mps)
        .map(|p| (p.d_s, p.v_mps))
        .collect()
}

/// The nonlinear optimum at delay τ \[s\] (see the module documentation): the fold-of-cycles
/// curve of `chart` (with [`fold_chart_options`]), V_safe at its points, Brent between the
/// neighbours of the best point (or the end of the gain range beyond the first or last
/// point, where V_safe = V_crit if no fold crosses) on fold speeds corrected at fixed D. A delay whose curve
/// cannot be computed is not an error: the result then has no optimum and a note.
///
/// # Errors
/// [`SwayError::Numerical`] if a critical speed or a corrected fold speed fails during the
/// refinement.
pub fn fold_optimum(
    model: &Model,
    tau: f64,
    o: &GainSearch,
    chart: &ChartOptions,
) -> Result<FoldResult, SwayError> {
    let co = fold_chart_options(chart, o);
    let ch = match nonlinear_chart(model, tau, &co) {
        Ok(c) => c,
        Err(e) => {
            return Ok(FoldResult {
                optimum: None,
                curve: Vec::new(),
                notes: vec![format!("no fold-of-cycles curve: {e}")],
                curves_ended_early: vec![EndedCurve {
                    curve: format!("nonlinear chart τ = {tau} s"),
                    end: CurveEnd::from_error(None, &e),
                }],
            });
        }
    };
    let mut notes = ch.notes.clone();
    let ended = ch.curves_ended_early.clone();
    let curve = fold_points_in_range(&ch, o);
    // the curve may turn back in D: sorted by D for the bracket (stable, deterministic)
    let mut pts = curve.clone();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if pts.is_empty() {
        notes.push(match (&ch.fold_reason, ch.fold_incomplete) {
            (Some(why), true) => why.clone(),
            _ => format!(
                "no fold-of-cycles curve in the gain range (the Hopf point at the seed gain D = {} s is supercritical or its cycles do not fold in the speed range)",
                co.seed_gains_s.first().copied().unwrap_or(f64::NAN)
            ),
        });
        return Ok(FoldResult {
            optimum: None,
            curve,
            notes,
            curves_ended_early: ended,
        });
    }
    match refined_fold_optimum(model, tau, o, &ch, &pts) {
        Ok(optimum) => {
            if ch.fold_incomplete {
                notes.push(format!(
                    "the fold-of-cycles curve ended early: the optimum is searched only on the gains it reaches, [{:.4}, {:.4}] s",
                    pts[0].0,
                    pts[pts.len() - 1].0
                ));
            }
            Ok(FoldResult {
                optimum: Some(optimum),
                curve,
                notes,
                curves_ended_early: ended,
            })
        }
        // a fold speed that cannot be corrected during the refinement: no optimum, the
        // curve as far as it went and the reason
        Err(e) => {
            let end = CurveEnd::from_error(None, &e);
            notes.push(format!("no fold-of-cycles optimum: {}", end.describe()));
            let mut ended = ended;
            ended.push(EndedCurve {
                curve: format!("fold-of-cycles optimum τ = {tau} s"),
                end,
            });
            Ok(FoldResult {
                optimum: None,
                curve,
                notes,
                curves_ended_early: ended,
            })
        }
    }
}

/// The refinement of [`fold_optimum`] on the fold-of-cycles points `pts` (sorted by D) of
/// `ch`: V_safe at the points, Brent between the neighbours of the best one (or the end of
/// the gain range beyond the first or last point; the last point itself where the curve
/// ended early, so that no gain it does not reach is taken as safe).
fn refined_fold_optimum(
    model: &Model,
    tau: f64,
    o: &GainSearch,
    ch: &NonlinearChart,
    pts: &[(f64, f64)],
) -> Result<FoldOptimum, SwayError> {
    let xs: Vec<f64> = pts.iter().map(|p| p.0).collect();
    let ys = xs
        .iter()
        .zip(pts)
        .map(|(&d, p)| Ok(p.1.min(critical_speed(model, tau, d, o)?)))
        .collect::<Result<Vec<_>, SwayError>>()?;
    let g = |d: f64| safe_speed(model, ch, d, o).map(|s| s.0);
    let k = first_argmax(&ys);
    // the bracket: the neighbours of the best point, or the range end beyond the first or
    // last point (the curve's points may stop short of it; not where it ended early)
    let (lo, hi) = if ch.fold_incomplete {
        (xs[0], xs[xs.len() - 1])
    } else {
        (o.d_min_s, o.d_max_s)
    };
    let a = if k == 0 { lo } else { xs[k - 1] };
    let b = if k + 1 == xs.len() { hi } else { xs[k + 1] };
    let mut known = (xs[k], g(xs[k])?);
    let mut n = 1;
    for end in [(k == 0).then_some(a), (k + 1 == xs.len()).then_some(b)]
        .into_iter()
        .flatten()
    {
        let v = g(end)?;
        n += 1;
        if v > known.1 {
            known = (end, v);
        }
    }
    let (d, m) = if a < b {
        let (d, _, m) = maximise(g, (a, b), known, o.gain_tolerance_s, o.max_iterations)?;
        (d, m)
    } else {
        (known.0, 0)
    };
    let n = n + m;
    let (v, vf, vc) = safe_speed(model, ch, d, o)?;
    let vf = vf.unwrap_or(f64::INFINITY);
    Ok(FoldOptimum {
        tau_s: tau,
        d_fold_s: d,
        v_fold_max_mps: v,
        v_fold_at_optimum_mps: vf,
        v_crit_at_optimum_mps: vc,
        limited_by: if vf <= vc {
            SafeSpeedLimit::FoldOfCycles
        } else {
            SafeSpeedLimit::CriticalSpeed
        },
        on_range_end: RangeEnd::of(d, o),
        curve_points: pts.len(),
        evaluations: n,
    })
}

/// The open-loop fold-of-cycles speed V_fold(D = 0) \[m/s\] (the delay plays no role
/// without feedback): the fold of the cycle branch of straight running, corrected on the
/// fold-of-cycles system with the mesh of `chart`; None if the branch does not fold in
/// the chart's speed range.
///
/// # Errors
/// [`SwayError::Numerical`] if the diagram or the correction fails.
pub fn open_loop_fold_speed(model: &Model, chart: &ChartOptions) -> Result<Option<f64>, SwayError> {
    let options = DiagramOptions {
        v_min_mps: chart.v_min_mps,
        v_max_mps: chart.v_max_mps,
        ..chart.cycles.clone()
    };
    let feedback = LoopLaw::paper(0.0, 0.0);
    let diagram = bifurcation_diagram_until(model, feedback, &options, CycleExtent::FirstFold)?;
    Ok(critical_speeds(model, &diagram, chart)?
        .fold
        .map(|f| f.v_mps))
}

/// The delay budget.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DelayBudget {
    /// the largest delay at which the best gain raises the critical speed by at least
    /// `gain_fraction` over the open loop \[s\] (None: not even at the first delay)
    pub tau_s: Option<f64>,
    /// the required rise: V_crit,max ≥ (1 + fraction)·V_crit(D = 0)
    pub gain_fraction: f64,
    /// the open-loop critical speed V_crit(D = 0) \[m/s\]
    pub open_loop_v_crit_mps: f64,
    /// the budget is the last delay of the grid (the true budget may be larger)
    pub at_grid_end: bool,
}

/// The delay budget from the linear optima of a τ grid (increasing `optima[i].tau_s`):
/// the last grid delay whose V_crit,max reaches (1 + `fraction`)·`v_open`, refined by
/// bisection in τ (a [`linear_optimum`] per step) towards the next grid delay to
/// `tau_tolerance` \[s\].
///
/// # Errors
/// [`SwayError::Numerical`] from a [`linear_optimum`].
pub fn delay_budget<M: LoopModel + ?Sized>(
    model: &M,
    optima: &[LinearOptimum],
    v_open: f64,
    fraction: f64,
    tau_tolerance: f64,
    o: &GainSearch,
) -> Result<DelayBudget, SwayError> {
    let thr = (1.0 + fraction) * v_open;
    let last = optima.iter().rposition(|p| p.v_crit_max_mps >= thr);
    let mut budget = DelayBudget {
        tau_s: None,
        gain_fraction: fraction,
        open_loop_v_crit_mps: v_open,
        at_grid_end: false,
    };
    let Some(j) = last else {
        return Ok(budget);
    };
    if j + 1 == optima.len() {
        budget.tau_s = Some(optima[j].tau_s);
        budget.at_grid_end = true;
        return Ok(budget);
    }
    let g = |tau: f64| linear_optimum(model, tau, o).map(|p| p.v_crit_max_mps);
    let (tau, _) = band_end(&g, optima[j].tau_s, optima[j + 1].tau_s, thr, tau_tolerance)?;
    budget.tau_s = Some(tau);
    Ok(budget)
}
