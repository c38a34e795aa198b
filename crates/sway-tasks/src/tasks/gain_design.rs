//! `cargo xtask gain_design` (beyond the paper): the best gain D of the delayed
//! yaw-rate feedback δ(t) = −D·ψ̇(t − τ) (eq. 8) for each delay τ of a grid
//! ([`sway::gain_design`]): the gain D\*(τ) maximising the linear critical speed, the
//! maximal critical speed, the gains within 1 % of it and whether the optimum sits on an
//! end of the gain range; at every `nonlinear.every`-th delay the nonlinear counterpart
//! (the gain maximising the speed below which no perturbation triggers sway, from the
//! fold-of-cycles curve of the two-parameter continuation); and the delay budget, the
//! largest τ at which the best gain still raises the critical speed by 10 % over the open
//! loop.
//!
//! `summary.json`: `"optimal_gain"`, an array of `{"tau_s", "d_s", "v_crit_mps",
//! "v_fold_mps", "d_within_1pct_s", "on_range_end", "d_fold_s", "d_fold_minus_d_s", …}`
//! (`v_fold_mps` and the fold fields are null at the delays without the nonlinear part or
//! without a fold-of-cycles curve), `"delay_budget_s"`, `"open_loop_v_crit_mps"` and
//! `"open_loop_v_fold_mps"`. `optimal_gain.csv` holds the same rows; `fold_cycles_tau_<τ>.csv`
//! the fold-of-cycles curve points used at each nonlinear delay.

use std::path::Path;

use serde::Serialize;
use crate::TaskError;
use sway_studies::chart::ChartConfig;
use sway::charts::auto_range::SpeedBounds;
use sway::config::{ensure, ensure_positive};
pub use sway_studies::gain_design::{
    BudgetConfig, GainDesign, GainDesignConfig, GainSearchConfig, NonlinearConfig, ResolvedDesign,
    compute, default_chart,
};
use sway::bifurcation::chart::EndedCurve;
use sway::gain_design::{RangeEnd, SafeSpeedLimit};

use super::fig3a_diagram::validate_options;
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::{Configured, TaskConfig};
use crate::io::{Keyed, OutputDir};
use crate::limits::{Plan, bound, human_seconds};
use crate::figures::{capped_speed_layers, stable_up_to_key};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Shape, Stroke};
use sway::ranging::{CappedSpeed, stable_up_to_reason};

/// The task.
pub const TASK: Task = Task::configured::<GainDesignConfig>(
    "gain_design",
    "best feedback gain D*(τ) for each delay: linear and fold-of-cycles optimum, 1 % band, delay budget",
    "gain_design.toml",
)
.any_model();

/// Checks the keys (the derived ones are checked once derived).
///
/// # Errors
/// [`TaskError::Config`] naming the file and key.
pub fn validate(cfg: &GainDesignConfig, file: &Path) -> Result<(), TaskError> {
    ensure(cfg.delays_s.min >= 0.0, file, "delays_s.min", || {
        format!("expected a delay ≥ 0 s, got {}", cfg.delays_s.min)
    })?;
    for (i, t) in cfg.headline_delays_s.iter().enumerate() {
        ensure(t.is_finite(), file, &format!("headline_delays_s[{i}]"), || {
            format!("expected a finite delay, got {t}")
        })?;
    }
    validate_search(&cfg.search, file)?;
    let b = &cfg.budget;
    ensure_positive(b.rise_fraction, file, "budget.rise_fraction", "a fraction > 0")?;
    ensure_positive(b.tau_tolerance_s, file, "budget.tau_tolerance_s", "a tolerance > 0 s")?;
    validate_chart(&cfg.nonlinear.chart, &cfg.search, file)
}

fn validate_search(s: &GainSearchConfig, file: &Path) -> Result<(), TaskError> {
    let (d0, d1) = (s.d_min_s.unwrap_or(0.0), s.d_max_s.unwrap_or(f64::INFINITY));
    let finite = s.d_min_s.is_none_or(f64::is_finite) && s.d_max_s.is_none_or(f64::is_finite);
    ensure(finite && d0 < d1, file, "search.d_min_s", || {
        format!("expected finite d_min_s < d_max_s, got {d0} and {d1}")
    })?;
    let (v0, v1) = (s.v_min_mps.unwrap_or(0.5), s.v_max_mps.unwrap_or(f64::INFINITY));
    ensure(
        v0.is_finite() && v0 > 0.0 && s.v_max_mps.is_none_or(f64::is_finite) && v0 < v1,
        file,
        "search.v_min_mps",
        || format!("expected 0 < v_min_mps < v_max_mps, got {v0} and {v1}"),
    )?;
    for (key, n) in [("search.gain_samples", s.gain_samples), ("search.speed_samples", s.speed_samples)] {
        ensure(n >= 3, file, key, || format!("expected ≥ 3, got {n}"))?;
    }
    ensure(s.max_iterations >= 1, file, "search.max_iterations", || "expected ≥ 1".into())?;
    ensure(
        s.speed_tolerance_mps > 0.0 && s.speed_tolerance_mps < 1e-2,
        file,
        "search.speed_tolerance_mps",
        || format!("expected 0 < tolerance < 0.01 m/s, got {}", s.speed_tolerance_mps),
    )?;
    // the span is checked against the tolerance once the range is known (derived ranges
    // are at least 0.1 s wide: 5·D₁ with D₁ ≥ 0.01 s at one significant digit … in practice)
    let span = if d1.is_finite() { d1 - d0 } else { f64::INFINITY };
    ensure(
        s.gain_tolerance_s > 0.0 && s.gain_tolerance_s < 1e-2 * span,
        file,
        "search.gain_tolerance_s",
        || format!("expected 0 < tolerance < 1 % of the gain range, got {}", s.gain_tolerance_s),
    )?;
    Ok(ensure(
        s.band_fraction > 0.0 && s.band_fraction < 1.0,
        file,
        "search.band_fraction",
        || format!("expected 0 < fraction < 1, got {}", s.band_fraction),
    )?)
}

fn validate_chart(c: &ChartConfig, s: &GainSearchConfig, file: &Path) -> Result<(), TaskError> {
    let (v0, v1) = (c.v_min_mps.unwrap_or(0.5), c.v_max_mps.unwrap_or(f64::INFINITY));
    ensure(
        v0.is_finite() && v0 > 0.0 && c.v_max_mps.is_none_or(f64::is_finite) && v0 < v1,
        file,
        "nonlinear.chart.v_min_mps",
        || format!("expected 0 < v_min_mps < v_max_mps, got {v0} and {v1}"),
    )?;
    if let Some(seeds) = &c.seed_gains_s {
        // a derived gain range starts at 0 (its top is checked once derived)
        let (d0, d1) = (s.d_min_s.unwrap_or(0.0), s.d_max_s.unwrap_or(f64::INFINITY));
        let seed = seeds.first().copied();
        ensure(
            seed.is_some_and(|d| d >= d0 && d <= d1),
            file,
            "nonlinear.chart.seed_gains_s",
            || format!("expected a first seed gain inside the search's gain range [{d0}, {d1}] s"),
        )?;
    }
    for (key, v) in [
        ("nonlinear.chart.fold_step", c.fold_step),
        ("nonlinear.chart.fold_max_step", c.fold_max_step),
        ("nonlinear.chart.fold_min_amplitude", c.fold_min_amplitude),
        ("nonlinear.chart.hopf_step", c.hopf_step),
        ("nonlinear.chart.hopf_max_step", c.hopf_max_step),
    ] {
        ensure_positive(v, file, key, "a positive number")?;
    }
    ensure(
        c.curve_min_tangent_cosine.is_finite() && c.curve_min_tangent_cosine < 1.0,
        file,
        "nonlinear.chart.curve_min_tangent_cosine",
        || format!("expected a cosine < 1, got {}", c.curve_min_tangent_cosine),
    )?;
    ensure(c.fold_max_points >= 2, file, "nonlinear.chart.fold_max_points", || {
        format!("expected ≥ 2, got {}", c.fold_max_points)
    })?;
    bound(file, "nonlinear.chart.fold_max_points", c.fold_max_points as f64, MAX_FOLD_POINTS as f64, || {
        "points per direction, each kept with its orbit".into()
    })?;
    validate_options(&c.cycles, file, "nonlinear.chart.cycles")
}

impl TaskConfig for GainDesignConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        validate(self, file)
    }
}

/// One entry of `"optimal_gain"` in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OptimalGainEntry {
    /// the delay τ \[s\]
    pub tau_s: f64,
    /// the gain D\* maximising the linear critical speed \[s\]
    pub d_s: f64,
    /// the maximal critical speed V_crit(D\*) \[m/s\] (null: stable up to the top of the
    /// speed range, see `stable_up_to_mps` and `reason`)
    pub v_crit_mps: Option<f64>,
    /// straight running with D\* is stable up to this speed \[m/s\], the top of the speed
    /// range (absent: `v_crit_mps` was found below it)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_up_to_mps: Option<f64>,
    /// the largest speed below which no perturbation triggers sway, max over D of
    /// min(V_fold(D), V_crit(D)) \[m/s\] (null: not computed at this delay, or no
    /// fold-of-cycles curve)
    pub v_fold_mps: Option<f64>,
    /// one key, `d_within_<p>pct_s` (p = 100·band_fraction): the gains whose critical
    /// speed is within p % of the maximum, `[lo, hi]` \[s\]
    #[serde(flatten)]
    pub band: Keyed<[f64; 2]>,
    /// `"lower"` / `"upper"` if D\* is an end of the gain range (the maximum may lie beyond),
    /// else null
    pub on_range_end: Option<RangeEnd>,
    /// the rightmost characteristic roots confirm `v_crit_mps` (false: the crossing count
    /// of `fig4a` disagrees with the roots there, see `sway::gain_design::roots_confirm`)
    pub v_crit_confirmed_by_roots: bool,
    /// the gain of `v_fold_mps` \[s\]
    pub d_fold_s: Option<f64>,
    /// D_fold\* − D\* \[s\]
    pub d_fold_minus_d_s: Option<f64>,
    /// what limits `v_fold_mps`: `"fold_of_cycles"` or `"critical_speed"`
    pub fold_limited_by: Option<SafeSpeedLimit>,
    /// `"lower"` / `"upper"` if D_fold\* is an end of the gain range
    pub fold_on_range_end: Option<RangeEnd>,
    /// notes of the nonlinear part (no curve, failed seeds)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub fold_notes: Vec<String>,
    /// what is special about this optimum: stable up to the top of the speed range
    /// (`stable_up_to_mps`), no gain raising the critical speed over the open loop (absent:
    /// nothing)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// curves of the nonlinear part that ended early (and fold speeds that could not be
    /// corrected), each with its `end` (absent: none)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub curves_ended_early: Vec<EndedCurve>,
}

/// `summary.json` of gain_design (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GainDesignSummary {
    /// one entry per delay of the grid
    pub optimal_gain: Vec<OptimalGainEntry>,
    /// the largest delay at which the best gain raises the critical speed by
    /// `budget_rise_fraction` over the open loop \[s\] (null: not even at the first delay, or
    /// at every delay of the grid, `delay_budget_at_least_s`; see `delay_budget_reason`)
    pub delay_budget_s: Option<f64>,
    /// the budget reaches the last grid delay: it is at least this \[s\] (absent: it does not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delay_budget_at_least_s: Option<f64>,
    /// why `delay_budget_s` is null (absent: it is not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delay_budget_reason: Option<String>,
    /// the required rise (0.1: 10 %)
    pub budget_rise_fraction: f64,
    /// V_crit(D = 0) \[m/s\] (null: stable up to the top of the speed range, see
    /// `open_loop_stable_up_to_mps` and `open_loop_reason`)
    pub open_loop_v_crit_mps: Option<f64>,
    /// the open loop is stable up to this speed \[m/s\] (absent: it is not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub open_loop_stable_up_to_mps: Option<f64>,
    /// the open loop is stable up to the top of the speed range (absent: it is not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub open_loop_reason: Option<String>,
    /// V_fold(D = 0) \[m/s\]
    pub open_loop_v_fold_mps: Option<f64>,
    /// the delays with the nonlinear part \[s\]
    pub nonlinear_delays_s: Vec<f64>,
    /// why the nonlinear part was left out (absent: it ran where the config asks; present
    /// for a vehicle with model variants)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nonlinear_reason: Option<String>,
    /// the search's ranges and the fold chart's box and seed used (derived where the config
    /// omits them)
    pub ranges: ResolvedDesign,
}

/// One row of `optimal_gain.csv`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct OptimalGainRow {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// D\* \[s\]
    pub d_s: f64,
    /// V_crit(D\*) \[m/s\] (empty: stable up to `stable_up_to_mps`)
    pub v_crit_mps: Option<f64>,
    /// the top of the speed range where V_crit(D\*) is above it \[m/s\] (empty: V_crit found)
    pub stable_up_to_mps: Option<f64>,
    /// lower end of the band \[s\]
    pub d_band_lo_s: f64,
    /// upper end of the band \[s\]
    pub d_band_hi_s: f64,
    /// `lower` / `upper` / empty
    pub on_range_end: Option<RangeEnd>,
    /// 1 if the rightmost roots confirm V_crit(D\*), 0 if not
    pub confirmed_by_roots: u8,
    /// max min(V_fold, V_crit) \[m/s\] (empty: not computed)
    pub v_fold_mps: Option<f64>,
    /// its gain \[s\]
    pub d_fold_s: Option<f64>,
}

/// One row of `fold_cycles_tau_<τ>.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct FoldPointRow {
    /// gain D \[s\]
    pub d_s: f64,
    /// fold-of-cycles speed \[m/s\]
    pub v_mps: f64,
}

/// A fraction as a percentage for names and labels (0.01 → "1", 0.005 → "0.5").
fn percent(fraction: f64) -> String {
    format!("{}", (fraction * 100.0 * 1e6).round() / 1e6)
}

fn entries(r: &GainDesign) -> Vec<OptimalGainEntry> {
        let key = format!("d_within_{}pct_s", percent(r.resolved.search.band_fraction));
        r.linear
            .iter()
            .zip(&r.fold)
            .zip(&r.linear_reasons)
            .map(|((l, f), why)| {
                let opt = f.as_ref().and_then(|f| f.optimum.as_ref());
                OptimalGainEntry {
                    reason: why.clone(),
                    tau_s: l.tau_s,
                    d_s: l.d_opt_s,
                    v_crit_mps: l.v_crit_max().found(),
                    stable_up_to_mps: l.v_crit_max().stable_up_to(),
                    v_fold_mps: opt.map(|o| o.v_fold_max_mps),
                    band: Keyed(vec![(key.clone(), l.band_s)]),
                    on_range_end: l.on_range_end,
                    v_crit_confirmed_by_roots: l.roots_confirm,
                    d_fold_s: opt.map(|o| o.d_fold_s),
                    d_fold_minus_d_s: opt.map(|o| o.d_fold_s - l.d_opt_s),
                    fold_limited_by: opt.map(|o| o.limited_by),
                    fold_on_range_end: opt.and_then(|o| o.on_range_end),
                    fold_notes: f.as_ref().map(|f| f.notes.clone()).unwrap_or_default(),
                    curves_ended_early: f
                        .as_ref()
                        .map(|f| f.curves_ended_early.clone())
                        .unwrap_or_default(),
                }
            })
            .collect()
    }

fn rows(r: &GainDesign) -> Vec<OptimalGainRow> {
        r.linear
            .iter()
            .zip(&r.fold)
            .map(|(l, f)| {
                let opt = f.as_ref().and_then(|f| f.optimum.as_ref());
                OptimalGainRow {
                    tau_s: l.tau_s,
                    d_s: l.d_opt_s,
                    v_crit_mps: l.v_crit_max().found(),
                    stable_up_to_mps: l.v_crit_max().stable_up_to(),
                    d_band_lo_s: l.band_s[0],
                    d_band_hi_s: l.band_s[1],
                    on_range_end: l.on_range_end,
                    confirmed_by_roots: u8::from(l.roots_confirm),
                    v_fold_mps: opt.map(|o| o.v_fold_max_mps),
                    d_fold_s: opt.map(|o| o.d_fold_s),
                }
            })
            .collect()
    }

    /// The headline line of the grid delay nearest to `tau`.
fn headline(r: &GainDesign, tau: f64) -> Option<String> {
        let i = (0..r.delays_s.len())
            .min_by(|&a, &b| (r.delays_s[a] - tau).abs().total_cmp(&(r.delays_s[b] - tau).abs()))?;
        let l = &r.linear[i];
        let fold = r.fold[i].as_ref().and_then(|f| f.optimum.as_ref());
        Some(format!(
            "τ = {} s: D* = {:.4} s{} (within 1 %: {:.4}…{:.4} s), {}{}; {}",
            l.tau_s,
            l.d_opt_s,
            match l.on_range_end {
                Some(_) => " (range end)",
                None => "",
            },
            l.band_s[0],
            l.band_s[1],
            l.v_crit_max().label("V_crit,max", 3),
            if l.roots_confirm {
                ""
            } else {
                " (not confirmed by the roots: the crossing count misses a crossing here)"
            },
            match (fold, &r.fold[i]) {
                (Some(f), _) => format!(
                    "V_fold,max = {:.3} m/s at D = {:.4} s",
                    f.v_fold_max_mps, f.d_fold_s
                ),
                (None, Some(f)) => format!(
                    "no V_fold,max: {}",
                    f.notes.last().map_or("no fold-of-cycles curve", String::as_str)
                ),
                (None, None) => "V_fold,max: not computed at this delay".into(),
            }
        ))
    }

fn write_tables(out: &OutputDir, r: &GainDesign) -> Result<(), TaskError> {
    out.write_table("optimal_gain.csv", rows(r))?;
    for f in r.fold.iter().flatten() {
        if let (Some(o), false) = (&f.optimum, f.curve.is_empty()) {
            out.write_table(
                &format!("fold_cycles_tau_{}.csv", o.tau_s),
                f.curve.iter().map(|&(d_s, v_mps)| FoldPointRow { d_s, v_mps }),
            )?;
        }
    }
    Ok(())
}

/// The speed panel: V_crit,max(τ), V_fold,max(τ), the open-loop values, the 10 % line and
/// the delay budget.
fn speed_panel(r: &GainDesign, cfg: &GainDesignConfig) -> Panel {
    let (t0, t1) = (cfg.delays_s.min, cfg.delays_s.max);
    let v_open = r.budget.open_loop_v_crit_mps;
    let crit: Vec<(f64, CappedSpeed)> = r.linear.iter().map(|l| (l.tau_s, l.v_crit_max())).collect();
    let fold: Vec<(f64, f64)> = r
        .fold
        .iter()
        .flatten()
        .filter_map(|f| f.optimum.as_ref().map(|o| (o.tau_s, o.v_fold_max_mps)))
        .collect();
    let v_hi = crit.iter().map(|p| p.1.lower_bound()).fold(v_open, f64::max);
    let v_lo = fold
        .iter()
        .map(|p| p.1)
        .chain(r.open_loop_v_fold_mps)
        .fold(v_open, f64::min);
    let (y0, y1) = (5.0 * (0.18 * v_lo).floor(), 1.1 * v_hi);
    let mut p = Panel::new("Best achievable speeds", "delay τ [s]", "speed [m/s]")
        .x_range(t0, t1)
        .y_range(y0, y1)
        .legend(Legend::LowerLeft);
    p.layers.extend(capped_speed_layers(
        &crit,
        Rgb::BLACK,
        Stroke::Solid,
        Some("V_crit,max(τ) (linear, best D)"),
    ));
    p.layers.extend(stable_up_to_key(crit.iter().map(|c| c.1)));
    p = if r.open_loop_stable {
        // no open-loop V_crit to draw: the cap is not one
        p.with(Layer::line(
            vec![(t0, v_open), (t1, v_open)],
            Rgb::GREY,
            Stroke::Dashed,
            Some(&format!("open loop (D = 0): stable up to {v_open} m/s (the speed cap)")),
        ))
    } else {
        p.with(Layer::line(
            vec![(t0, v_open), (t1, v_open)],
            Rgb::GREY,
            Stroke::Dashed,
            Some("open loop V_crit (D = 0)"),
        ))
        .with(Layer::line(
            vec![(t0, (1.0 + r.budget.gain_fraction) * v_open), (t1, (1.0 + r.budget.gain_fraction) * v_open)],
            Rgb::GREY,
            Stroke::Dotted,
            Some("open loop V_crit + 10 %"),
        ))
    };
    if let Some(vf) = r.open_loop_v_fold_mps {
        p = p.with(Layer::line(
            vec![(t0, vf), (t1, vf)],
            Rgb::BLUE,
            Stroke::Dashed,
            Some("open loop V_fold (D = 0)"),
        ));
    }
    if !fold.is_empty() {
        // markers only: V_fold,max is computed at every few delays, and a line between them
        // would cross V_crit,max where it falls steeply (V_fold,max ≤ V_crit,max everywhere)
        p = p.with(Layer::Markers {
                points: fold,
                color: Rgb::BLUE,
                shape: Shape::Circle,
                size: 5,
                label: Some("V_fold,max(τ): no kick triggers sway below".into()),
            });
    }
    if let Some(tb) = r.budget.tau_s {
        p = p.with(Layer::vline(tb, (y0, y1), Rgb::RED, Stroke::Dashed, Some("delay budget")));
    }
    p
}

/// The gain panel: D\*(τ) with its 1 % band shaded, D_fold\*(τ), range-end optima marked.
fn gain_panel(r: &GainDesign, cfg: &GainDesignConfig) -> Panel {
    let s = &r.resolved.search;
    let dt = if r.delays_s.len() > 1 {
        (cfg.delays_s.max - cfg.delays_s.min) / (r.delays_s.len() - 1) as f64
    } else {
        0.01
    };
    let rects: Vec<[f64; 4]> = r
        .linear
        .iter()
        .map(|l| [l.tau_s - 0.5 * dt, l.tau_s + 0.5 * dt, l.band_s[0], l.band_s[1]])
        .collect();
    let opt: Vec<(f64, f64)> = r.linear.iter().map(|l| (l.tau_s, l.d_opt_s)).collect();
    let ends: Vec<(f64, f64)> = r
        .linear
        .iter()
        .filter(|l| l.on_range_end.is_some())
        .map(|l| (l.tau_s, l.d_opt_s))
        .collect();
    let fold: Vec<(f64, f64)> = r
        .fold
        .iter()
        .flatten()
        .filter_map(|f| f.optimum.as_ref().map(|o| (o.tau_s, o.d_fold_s)))
        .collect();
    let pct = percent(s.band_fraction);
    let mut p = Panel::new("Best gain", "delay τ [s]", "gain D [s]")
        .x_range(cfg.delays_s.min, cfg.delays_s.max)
        .y_range(s.d_min_s, s.d_max_s + 0.05 * (s.d_max_s - s.d_min_s))
        .legend(Legend::UpperRight)
        .with(Layer::Rects {
            rects,
            color: Rgb::BLACK,
            opacity: 0.15,
            label: Some(format!("V_crit within {pct} % of the maximum")),
        })
        .with(Layer::line(opt, Rgb::BLACK, Stroke::Solid, Some("D*(τ): maximal V_crit")));
    if !ends.is_empty() {
        p = p.with(Layer::Markers {
            points: ends,
            color: Rgb::RED,
            shape: Shape::Triangle,
            size: 6,
            label: Some("optimum on the end of the gain range".into()),
        });
    }
    if !fold.is_empty() {
        p = p.with(Layer::markers(fold, Rgb::BLUE, Some("D_fold*(τ): maximal V_fold")));
    }
    p
}

/// gain_design: the most fold-of-cycles points per direction
/// (`nonlinear.chart.fold_max_points`): 20 000, as `chart_nonlinear`.
pub const MAX_FOLD_POINTS: usize = 20_000;

/// gain_design: the most critical speeds V_crit(D) of one run (delays × scanned and
/// refining gains): 10 000 000 (default ≈ 8 000, 1250×; ≈ 3.5 h at
/// [`SECONDS_PER_CRITICAL_SPEED`] on 2 cores).
pub const MAX_CRITICAL_SPEEDS: usize = 10_000_000;

/// gain_design: cost of one critical speed V_crit(D) \[s\] (one core): a scan of exact
/// root counts at ≈ 50 speeds and ≈ 35 bisection steps; 3 ms measured in the dev profile
/// (the root counts run in the optimised dependencies), ≈ 2.5 ms in release from the
/// default run (≈ 55 s of CPU: ≈ 7 200 critical speeds and six fold-of-cycles curves of
/// ≈ 30 s together).
pub const SECONDS_PER_CRITICAL_SPEED: f64 = 2.5e-3;

/// gain_design: evaluations of V_crit(D) per delay beyond the coarse scan: Brent (≈ 15–30)
/// and the two band bisections (≈ 2 × 14 at 1e-6 s).
pub const REFINEMENT_EVALUATIONS: f64 = 60.0;

/// gain_design: cost of the nonlinear part of one delay \[s\] per cycle-mesh interval
/// (release, one core): the fold-of-cycles curve and its Brent refinement took 0.8 to 9 s
/// at L = 20 (τ = 0 to 0.4 s); 0.5 s per interval bounds it.
pub const FOLD_SECONDS_PER_INTERVAL: f64 = 0.5;

impl Prepared for Configured<GainDesignConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let file = self.file.as_path();
        let n_tau = c.delays_s.points as f64;
        let s = &c.search;
        bound(file, "search.gain_samples", s.gain_samples as f64, crate::limits::MAX_AXIS_POINTS as f64, || {
            "critical speeds per delay".into()
        })?;
        bound(file, "search.speed_samples", s.speed_samples as f64, crate::limits::MAX_AXIS_POINTS as f64, || {
            "root counts per critical speed".into()
        })?;
        let per_speed = SECONDS_PER_CRITICAL_SPEED * (s.speed_samples as f64 / 100.0).max(0.5);
        let evals = n_tau * (s.gain_samples as f64 + REFINEMENT_EVALUATIONS);
        let n_nl = (0..c.delays_s.points).filter(|&i| c.is_nonlinear(i)).count() as f64;
        let nl_s = n_nl * FOLD_SECONDS_PER_INTERVAL * c.nonlinear.chart.cycles.intervals as f64;
        // the budget bisects τ: log2(spacing / tolerance) linear optima
        let spacing = (c.delays_s.max - c.delays_s.min) / (n_tau - 1.0).max(1.0);
        let steps = (spacing / c.budget.tau_tolerance_s).log2().max(1.0).ceil();
        let budget_s = steps * (s.gain_samples as f64 + REFINEMENT_EVALUATIONS) * per_speed;
        let time = (evals * per_speed + nl_s) / 2.0 + budget_s;
        let plan = Plan::new(
            vec![
                format!(
                    "gain_design: {} delays × ({} scanned + ≈ {REFINEMENT_EVALUATIONS} refining) critical speeds",
                    c.delays_s.points, s.gain_samples
                ),
                format!(
                    "fold-of-cycles optimum at {n_nl} delays (mesh L = {}), delay budget in {steps} bisection steps",
                    c.nonlinear.chart.cycles.intervals
                ),
                format!("estimated time on 2 cores: {}", human_seconds(time)),
            ],
            n_tau * 2000.0 + n_nl * c.nonlinear.chart.fold_max_points as f64 * 2.0 * 100_000.0,
            time,
        );
        plan.within(file, "delays_s.points", evals, MAX_CRITICAL_SPEEDS, || {
            format!("{evals} critical speeds ≈ {}", human_seconds(evals * per_speed / 2.0))
        })
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let n_nl = (0..cfg.delays_s.points).filter(|&i| cfg.is_nonlinear(i)).count();
        let steps = (cfg.delays_s.points + n_nl + 1) as u64;
        ctx.run_staged(TASK.name, "gain_design: optimum per delay", steps, cfg, &self.file, |out| {
        // a vehicle with model variants: the linear part on its plant, the nonlinear part
        // (fold of cycles) only for the paper's model (`nonlinear_reason`)
        let nonlinear_model = ctx.variant_key.is_none().then_some(&ctx.model);
        let r = compute(&ctx.plant, nonlinear_model, cfg, &SpeedBounds::from(&ctx.limits), ctx.progress)?;
        write_tables(out, &r)?;
        Figure::column(vec![speed_panel(&r, cfg), gain_panel(&r, cfg)])
            .titled("Best gain D of the yaw-rate feedback δ(t) = −D·dψ/dt(t − τ) for each delay τ")
            .render(&out.path("gain_design"))?;
        let mut lines: Vec<String> = cfg.headline_delays_s.iter().filter_map(|&t| headline(&r, t)).collect();
        lines.push(match (r.budget.tau_s, r.budget.at_grid_end) {
            (Some(t), false) => format!(
                "delay budget (best gain still ≥ {} % above the open-loop V_crit = {:.3} m/s): τ ≤ {:.4} s",
                percent(r.budget.gain_fraction),
                r.budget.open_loop_v_crit_mps,
                t,
            ),
            _ => format!(
                "delay budget: {}",
                r.budget_reason.clone().unwrap_or_else(|| "none".into())
            ),
        });
        let open_loop_reason = r.open_loop_stable.then(|| {
            stable_up_to_reason(
                "straight running without feedback",
                r.resolved.search.v_max_mps,
                cfg.cap_name(),
            )
        });
        if let Some(why) = &open_loop_reason {
            lines.push(why.clone());
        }
        if let Some(why) = &r.nonlinear_reason {
            lines.push(why.clone());
        }
        for (l, why) in r.linear.iter().zip(&r.linear_reasons) {
            if let Some(why) = why
                && cfg.headline_delays_s.iter().any(|t| (t - l.tau_s).abs() < 1e-9)
            {
                lines.push(format!("τ = {} s: {why}", l.tau_s));
            }
        }
        for (tau, f) in r.delays_s.iter().zip(&r.fold) {
            for e in f.iter().flat_map(|f| &f.curves_ended_early) {
                lines.push(format!("τ = {tau} s: {} {}", e.curve, e.end.describe()));
            }
        }
        let summary = GainDesignSummary {
            optimal_gain: entries(&r),
            delay_budget_s: r.budget.tau_s.filter(|_| !r.budget.at_grid_end),
            delay_budget_at_least_s: r.budget.tau_s.filter(|_| r.budget.at_grid_end),
            delay_budget_reason: r.budget_reason.clone(),
            open_loop_reason,
            budget_rise_fraction: r.budget.gain_fraction,
            open_loop_v_crit_mps: (!r.open_loop_stable).then_some(r.budget.open_loop_v_crit_mps),
            open_loop_stable_up_to_mps: r.open_loop_stable.then_some(r.resolved.search.v_max_mps),
            open_loop_v_fold_mps: r.open_loop_v_fold_mps,
            nonlinear_delays_s: (0..r.delays_s.len())
                .filter(|&i| cfg.is_nonlinear(i) && r.nonlinear_reason.is_none())
                .map(|i| r.delays_s[i])
                .collect(),
            nonlinear_reason: r.nonlinear_reason.clone(),
            ranges: r.resolved.clone(),
        };
        Ok((summary, lines))
        })
    }
}
