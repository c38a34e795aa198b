//! `cargo xtask chart_nonlinear` (beyond the paper): the nonlinear stability chart
//! of the delayed yaw-rate feedback δ(t) = −D·ψ̇(t − τ) (eq. 8) in the (V, D) plane, one
//! panel per delay τ of `configs/chart_nonlinear.toml`: the Hopf curves V_hopf(D) (the
//! dynamic boundary of `fig4a`, marked sub- or supercritical), the fold-of-cycles curve
//! V_fold(D), the regions safe / bistable / self-excited sway, the static boundary of
//! `fig4a` and the codimension-two points.
//!
//! `summary.json`: `"per_tau"`, an array of `{"tau_s", "curves", "codim2_points",
//! "bistable_width_mps"}`; `"curves"` holds `{"d_s", "v_hopf_mps", "v_fold_mps"}` at the
//! summary gains (lowest speed of each curve there, null where there is none),
//! `"codim2_points"` holds `{"kind", "d_s", "v_mps", "omega_rad_s"}`, and
//! `"bistable_width_mps"` is V_hopf − V_fold at the `bistable_gain_s` of the config.

use std::path::Path;

use serde::Serialize;
use stability::StabilityChart;
use crate::TaskError;
use sway_studies::chart::ResolvedChart;
pub use sway_studies::chart::{
    ChartConfig, ChartNonlinearConfig, ChartStudy, CurvesAtGain, DelayResult, RegionGrid, compute,
    compute_delay,
};
use sway::bifurcation::chart::{ChartOptions, Codim2Kind, CurveEnd, EndedCurve, Region};
use sway::charts::auto_range::{Derivation, SpeedBounds};
use sway::config::{ensure, ensure_positive};

use super::fig3a_diagram::validate_options;
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::{Configured, TaskConfig, check_delays};
use crate::io::OutputDir;
use crate::limits::{Plan, bound, human_seconds};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Shape, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<ChartNonlinearConfig>(
    "chart_nonlinear",
    "nonlinear stability chart: Hopf and fold-of-cycles curves in (V, D), bistable band, codim-2 points",
    "chart_nonlinear.toml",
)
.any_model();

/// Checks the keys (the derived ones are checked once derived).
///
/// # Errors
/// [`TaskError::Config`] naming the file and key.
pub fn validate(cfg: &ChartNonlinearConfig, file: &Path) -> Result<(), TaskError> {
    check_delays(file, "delays_s", &cfg.delays_s)?;
    validate_chart(&cfg.chart, file, "chart.")?;
    for (key, n) in [
        ("regions.speed_cells", cfg.regions.speed_cells),
        ("regions.gain_cells", cfg.regions.gain_cells),
    ] {
        ensure(n >= 2, file, key, || format!("expected ≥ 2, got {n}"))?;
    }
    Ok(())
}

/// Checks a `[chart]` table (`prefix` = "chart." or "nonlinear.chart."): the box keys that
/// are given, the seeds inside the given gain range, the steps and counts, the cycles.
///
/// # Errors
/// [`TaskError::Config`] naming the file and key.
pub fn validate_chart(c: &ChartConfig, file: &Path, prefix: &str) -> Result<(), TaskError> {
    let key = |k: &str| format!("{prefix}{k}");
    let (d0, d1) = (c.d_min_s.unwrap_or(f64::NEG_INFINITY), c.d_max_s.unwrap_or(f64::INFINITY));
    let finite = c.d_min_s.is_none_or(f64::is_finite) && c.d_max_s.is_none_or(f64::is_finite);
    ensure(finite && d0 < d1, file, &key("d_min_s"), || {
        format!("expected d_min_s < d_max_s, got {d0} and {d1}")
    })?;
    let (v0, v1) = (c.v_min_mps.unwrap_or(0.5), c.v_max_mps.unwrap_or(f64::INFINITY));
    ensure(
        v0 > 0.0 && c.v_max_mps.is_none_or(f64::is_finite) && v0 < v1,
        file,
        &key("v_min_mps"),
        || format!("expected 0 < v_min_mps < v_max_mps, got {v0} and {v1}"),
    )?;
    if let Some(seeds) = &c.seed_gains_s {
        ensure(!seeds.is_empty(), file, &key("seed_gains_s"), || {
            "expected at least one seed gain".into()
        })?;
        for (i, d) in seeds.iter().enumerate() {
            ensure(*d >= d0 && *d <= d1, file, &key(&format!("seed_gains_s[{i}]")), || {
                format!("seed gain {d} s outside [d_min_s, d_max_s]")
            })?;
        }
    }
    for (k, v) in [
        ("hopf_step", c.hopf_step),
        ("hopf_max_step", c.hopf_max_step),
        ("fold_step", c.fold_step),
        ("fold_max_step", c.fold_max_step),
        ("fold_min_amplitude", c.fold_min_amplitude),
    ] {
        ensure_positive(v, file, &key(k), "a positive number")?;
    }
    for (k, n) in [
        ("hopf_max_points", c.hopf_max_points),
        ("fold_max_points", c.fold_max_points),
        ("criticality_samples", c.criticality_samples),
        ("criticality_cycle_points", c.criticality_cycle_points),
    ] {
        ensure(n >= 2, file, &key(k), || format!("expected ≥ 2, got {n}"))?;
    }
    validate_options(&c.cycles, file, &key("cycles"))
}

impl TaskConfig for ChartNonlinearConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        validate(self, file)
    }
}

/// One entry of `"codim2_points"`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Codim2Entry {
    /// `"double_hopf"`, `"zero_hopf"`, `"bogdanov_takens"`, `"criticality_change"` or
    /// `"cusp_of_cycles"`
    pub kind: &'static str,
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// the critical frequencies \[rad/s\] (two at a double Hopf point)
    pub omega_rad_s: Vec<f64>,
}

/// One entry of `"per_tau"`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DelayEntry {
    /// the delay τ \[s\]
    pub tau_s: f64,
    /// the lowest Hopf and fold-of-cycles speeds at the summary gains
    pub curves: Vec<CurvesAtGain>,
    /// the codimension-two points found on the curves
    pub codim2_points: Vec<Codim2Entry>,
    /// V_hopf − V_fold at the bistable gain \[m/s\] (null: no bistable band there)
    pub bistable_width_mps: Option<f64>,
    /// what the pipeline noticed (curves that stopped early, seeds that failed)
    pub notes: Vec<String>,
    /// why `bistable_width_mps` is null (absent: it is not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bistable_reason: Option<String>,
    /// why there is no Hopf curve (absent: there is one)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hopf_reason: Option<String>,
    /// why there is no fold-of-cycles curve (absent: there is one)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fold_reason: Option<String>,
    /// the chart is all safe (absent: it is not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub safe_reason: Option<String>,
    /// curves that ended early and speeds that could not be read off them, each with its
    /// `end` (`reason` and numbers); the stable cells an incomplete fold-of-cycles curve does
    /// not reach are unknown (absent: none)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub curves_ended_early: Vec<EndedCurve>,
}

impl From<&DelayResult> for DelayEntry {
    fn from(r: &DelayResult) -> Self {
        Self {
            tau_s: r.chart.tau_s,
            curves: r.curves.clone(),
            codim2_points: r
                .chart
                .codim2_points
                .iter()
                .map(|c| Codim2Entry {
                    kind: c.kind.name(),
                    d_s: c.d_s,
                    v_mps: c.v_mps,
                    omega_rad_s: c.omega_rad_s.clone(),
                })
                .collect(),
            bistable_width_mps: r.bistable_width_mps,
            notes: r.chart.notes.clone(),
            bistable_reason: r.bistable_reason.clone(),
            hopf_reason: r.chart.hopf_reason.clone(),
            fold_reason: r.chart.fold_reason.clone(),
            safe_reason: r.safe_reason.clone(),
            curves_ended_early: r.curves_ended_early.clone(),
        }
    }
}

/// `summary.json` of chart_nonlinear (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChartNonlinearSummary {
    /// one entry per delay, in the config's order
    pub per_tau: Vec<DelayEntry>,
    /// the box, seeds and summary gains used (derived where the config omits them)
    pub ranges: ResolvedRanges,
}

/// The settings in use, as `summary.json` records them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResolvedRanges {
    /// the box \[m/s\], \[s\]
    pub v_min_mps: f64,
    /// see `v_min_mps`
    pub v_max_mps: f64,
    /// see `v_min_mps`
    pub d_min_s: f64,
    /// see `v_min_mps`
    pub d_max_s: f64,
    /// the seed gains \[s\]
    pub seed_gains_s: Vec<f64>,
    /// the summary gains \[s\]
    pub summary_gains_s: Vec<f64>,
    /// the bistable gain \[s\]
    pub bistable_gain_s: f64,
    /// which keys were derived, and from what
    pub derivation: Derivation,
}

impl From<&ResolvedChart> for ResolvedRanges {
    fn from(r: &ResolvedChart) -> Self {
        let o = &r.options;
        Self {
            v_min_mps: o.v_min_mps,
            v_max_mps: o.v_max_mps,
            d_min_s: o.d_min_s,
            d_max_s: o.d_max_s,
            seed_gains_s: o.seed_gains_s.clone(),
            summary_gains_s: r.summary_gains_s.clone(),
            bistable_gain_s: r.bistable_gain_s,
            derivation: r.derivation.clone(),
        }
    }
}

/// One row of `hopf_tau_<τ>_<k>.csv`: a point of a Hopf curve.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct HopfRow {
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// Hopf frequency ω \[rad/s\]
    pub omega_rad_s: f64,
    /// 1 subcritical, 0 supercritical, empty where the criticality is not known
    pub subcritical: Option<u8>,
}

/// One row of `fold_cycles_tau_<τ>_<k>.csv`: a fold of cycles.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct FoldRow {
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// period of the cycle at the fold \[s\]
    pub period_s: f64,
    /// max |θ| over the cycle at the fold \[deg\]
    pub max_abs_theta_deg: f64,
}

fn write_curves(out: &OutputDir, r: &DelayResult) -> Result<(), TaskError> {
    let tau = r.chart.tau_s;
    for (k, h) in r.chart.hopf_curves.iter().enumerate() {
        let rows = h.points.iter().enumerate().map(|(i, p)| HopfRow {
            d_s: p.d_s,
            v_mps: p.v_mps,
            omega_rad_s: p.omega_rad_s.abs(),
            subcritical: h
                .criticality_at(i)
                .map(|c| u8::from(c == continuation::Criticality::Subcritical)),
        });
        out.write_table(&format!("hopf_tau_{tau}_{k}.csv"), rows)?;
    }
    for (k, f) in r.chart.fold_curves.iter().enumerate() {
        let rows = f.points.iter().map(|p| FoldRow {
            d_s: p.d_s,
            v_mps: p.v_mps,
            period_s: p.period_s,
            max_abs_theta_deg: p.amplitude_deg,
        });
        out.write_table(&format!("fold_cycles_tau_{tau}_{k}.csv"), rows)?;
    }
    Ok(())
}

/// Shading rectangles [V0, V1, D0, D1] of one region: runs along D in every V column.
fn region_rects(lin: &StabilityChart, regions: &[Region], which: Region) -> Vec<[f64; 4]> {
    let nd = lin.d.len();
    let dv = lin.v.get(1).map_or(1.0, |v1| v1 - lin.v[0]);
    let dd = lin.d.get(1).map_or(1.0, |d1| d1 - lin.d[0]);
    let mut rects = Vec::new();
    for (iv, &v) in lin.v.iter().enumerate() {
        let mut start: Option<usize> = None;
        for id in 0..=nd {
            let here = id < nd && regions[iv * nd + id] == which;
            match (here, start) {
                (true, None) => start = Some(id),
                (false, Some(s)) => {
                    rects.push([
                        v - 0.5 * dv,
                        v + 0.5 * dv,
                        lin.d[s] - 0.5 * dd,
                        lin.d[id - 1] + 0.5 * dd,
                    ]);
                    start = None;
                }
                _ => {}
            }
        }
    }
    rects
}

/// Curve points (V, D) split into runs of equal criticality, as two NaN-separated lines.
/// A polyline in the (V, D) plane; NaN points split it.
type Line = Vec<(f64, f64)>;

/// `line` cut to the gain range [d_min, d_max]: a segment that leaves the range ends at the
/// boundary (linear interpolation) and the line is broken until it comes back, so that no
/// piece of a curve outside the chart is drawn along its edge.
#[doc(hidden)] // pub for tests/unit
pub fn clip_to_gains(line: &[(f64, f64)], (d_min, d_max): (f64, f64)) -> Line {
    let inside = |p: &(f64, f64)| p.1 >= d_min && p.1 <= d_max;
    let crossing = |a: (f64, f64), b: (f64, f64)| {
        let d = if (a.1 - d_min) * (b.1 - d_min) < 0.0 { d_min } else { d_max };
        let t = (d - a.1) / (b.1 - a.1);
        (a.0 + t * (b.0 - a.0), d)
    };
    let mut out = Vec::with_capacity(line.len());
    let mut prev: Option<(f64, f64)> = None;
    for &p in line {
        if p.0.is_nan() || p.1.is_nan() {
            out.push(p);
            prev = None;
            continue;
        }
        match (prev, inside(&p)) {
            (Some(a), true) if !inside(&a) => {
                out.push((f64::NAN, f64::NAN));
                out.push(crossing(a, p));
                out.push(p);
            }
            (Some(a), false) if inside(&a) => {
                out.push(crossing(a, p));
                out.push((f64::NAN, f64::NAN));
            }
            (_, true) => out.push(p),
            (_, false) => {}
        }
        prev = Some(p);
    }
    out
}

fn hopf_lines(r: &DelayResult) -> (Line, Line) {
    let (mut sub, mut sup) = (Vec::new(), Vec::new());
    for h in &r.chart.hopf_curves {
        let mut prev: Option<bool> = None;
        for (i, p) in h.points.iter().enumerate() {
            let is_sub = h.criticality_at(i) != Some(continuation::Criticality::Supercritical);
            let pt = (p.v_mps, p.d_s);
            if prev != Some(is_sub) {
                // close the other run at this point so the line is continuous
                if prev.is_some() {
                    let other = if is_sub { &mut sup } else { &mut sub };
                    other.push(pt);
                }
                let this = if is_sub { &mut sub } else { &mut sup };
                this.push((f64::NAN, f64::NAN));
            }
            let this = if is_sub { &mut sub } else { &mut sup };
            this.push(pt);
            prev = Some(is_sub);
        }
        sub.push((f64::NAN, f64::NAN));
        sup.push((f64::NAN, f64::NAN));
    }
    (sub, sup)
}

/// The static boundary (λ = 0) of the linear chart as (V, D) lines, without the points on
/// the gain range's edges (where the chart clamps crossings that lie outside it).
fn static_boundary(lin: &StabilityChart, (d_min, d_max): (f64, f64)) -> Vec<(f64, f64)> {
    let eps = 1e-9 * (d_max - d_min);
    let mut pts = Vec::new();
    for l in &lin.static_boundary {
        pts.push((f64::NAN, f64::NAN));
        for p in &l.points {
            if p.d > d_min + eps && p.d < d_max - eps {
                pts.push((p.v, p.d));
            } else {
                pts.push((f64::NAN, f64::NAN));
            }
        }
    }
    pts
}

fn codim2_label(kind: Codim2Kind) -> &'static str {
    match kind {
        Codim2Kind::DoubleHopf => "double Hopf",
        Codim2Kind::ZeroHopf => "zero-Hopf",
        Codim2Kind::BogdanovTakens => "Bogdanov–Takens",
        Codim2Kind::CriticalityChange => "criticality change",
        Codim2Kind::CuspOfCycles => "cusp of cycles",
    }
}

fn panel(r: &DelayResult, c: &ChartOptions) -> Panel {
    let regions = r.chart.regions(&r.linear);
    let mut p = Panel::new(&format!("τ = {} s", r.chart.tau_s), "V [m/s]", "D [s]")
        .x_range(0.0, c.v_max_mps)
        .y_range(c.d_min_s, c.d_max_s)
        .legend(Legend::UpperLeft);
    for (which, color, label) in [
        (Region::Safe, Rgb::GREEN, "safe"),
        (
            Region::Bistable,
            Rgb::ORANGE,
            "bistable (a kick triggers sway)",
        ),
        (Region::SelfExcited, Rgb::RED, "self-excited sway"),
        (
            Region::Unknown,
            Rgb::GREY,
            "unknown (the fold-of-cycles curve ended early)",
        ),
    ] {
        let rects = region_rects(&r.linear, &regions, which);
        // the unknown region only where there is one (the other layers as always)
        if which == Region::Unknown && rects.is_empty() {
            continue;
        }
        p = p.with(Layer::Rects {
            rects,
            color,
            opacity: 0.3,
            label: Some(label.into()),
        });
    }
    let gains = (c.d_min_s, c.d_max_s);
    let (sub, sup) = hopf_lines(r);
    let (sub, sup) = (clip_to_gains(&sub, gains), clip_to_gains(&sup, gains));
    p = p
        .with(Layer::line(
            static_boundary(&r.linear, (c.d_min_s, c.d_max_s)),
            Rgb::BLUE,
            Stroke::Dotted,
            Some("static boundary (fig4a)"),
        ))
        .with(Layer::line(
            sub,
            Rgb::BLACK,
            Stroke::Solid,
            Some("Hopf, subcritical"),
        ))
        .with(Layer::line(
            sup,
            Rgb::BLACK,
            Stroke::Dashed,
            Some("Hopf, supercritical"),
        ));
    let mut fold = Vec::new();
    for f in &r.chart.fold_curves {
        fold.push((f64::NAN, f64::NAN));
        fold.extend(f.points.iter().map(|q| (q.v_mps, q.d_s)));
    }
    p = p.with(Layer::line(
        clip_to_gains(&fold, gains),
        Rgb::BLUE,
        Stroke::Solid,
        Some("fold of cycles"),
    ));
    let pts: Vec<(f64, f64)> = r
        .chart
        .codim2_points
        .iter()
        .map(|q| (q.v_mps, q.d_s))
        .collect();
    if !pts.is_empty() {
        p = p.with(Layer::Markers {
            points: pts,
            color: Rgb::BLACK,
            shape: Shape::Cross,
            size: 7,
            label: Some("codimension-two points".into()),
        });
    }
    // where curves stopped early: their last points, marked
    let ends: Vec<(f64, f64)> = r
        .curves_ended_early
        .iter()
        .filter_map(|e| end_point(&e.end))
        .collect();
    if !ends.is_empty() {
        p = p.with(Layer::Markers {
            points: ends,
            color: Rgb::RED,
            shape: Shape::Triangle,
            size: 7,
            label: Some("curve ended early".into()),
        });
    }
    for q in &r.chart.codim2_points {
        let freqs: Vec<String> = q.omega_rad_s.iter().map(|w| format!("{w:.1}")).collect();
        p = p.with(Layer::Text {
            x: q.v_mps - 0.22 * c.v_max_mps,
            y: q.d_s + 0.02 * (c.d_max_s - c.d_min_s),
            text: format!("{} (ω = {} rad/s)", codim2_label(q.kind), freqs.join(", ")),
            color: Rgb::BLACK,
        });
    }
    p
}

/// (V, D) of the last point of a curve that ended, where it has one.
fn end_point(e: &CurveEnd) -> Option<(f64, f64)> {
    match *e {
        CurveEnd::StepUnderflow { d_s, v_mps } => Some((v_mps, d_s)),
        CurveEnd::CorrectorFailure {
            d_s: Some(d), v_mps: Some(v), ..
        }
        | CurveEnd::Failure {
            d_s: Some(d), v_mps: Some(v), ..
        } => Some((v, d)),
        _ => None,
    }
}

/// chart_nonlinear: the most points of one curve in one direction (`chart.hopf_max_points`,
/// `chart.fold_max_points`): 20 000 (defaults 400 and 300, 50×); a fold-of-cycles point
/// keeps its orbit and null vector (≈ 2·L·m·n numbers), so 20 000 points at L = 40 are
/// ≈ 200 MB.
pub const MAX_CURVE_POINTS: usize = 20_000;

/// chart_nonlinear: the most delays (panels): 64 (default 4).
pub const MAX_DELAYS: usize = 64;

/// chart_nonlinear: cost of one Hopf-curve point \[s\] (release, 2 cores): the
/// `hopf_curve_4d_dde_100_points` bench (245 ms per 100 points at Chebyshev degree 20),
/// doubled for the model's degree 24.
pub const HOPF_SECONDS_PER_POINT: f64 = 5e-3;

/// chart_nonlinear: cost of one fold-of-cycles point per mesh interval \[s\] (release):
/// about 3 Newton steps of the `fold_cycles` bench (22.8 ms at L = 40). The delay widens
/// the factorisation's band, so a point at τ = 0.4 s costs up to 10× this; the plan
/// multiplies by the *largest* number of points (the curves stop far earlier), and the
/// resulting bound (≈ 2 min for the default config) is above the measured 20 s.
pub const FOLD_SECONDS_PER_POINT_INTERVAL: f64 = 2e-3;

impl Prepared for Configured<ChartNonlinearConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let file = self.file.as_path();
        let n_tau = c.delays_s.len();
        bound(file, "delays_s", n_tau as f64, MAX_DELAYS as f64, || {
            "one panel and one set of curves each".into()
        })?;
        for (key, n) in [
            ("chart.hopf_max_points", c.chart.hopf_max_points),
            ("chart.fold_max_points", c.chart.fold_max_points),
        ] {
            bound(file, key, n as f64, MAX_CURVE_POINTS as f64, || {
                "points per curve and direction, each kept in memory".into()
            })?;
        }
        let cells = c.regions.speed_cells * c.regions.gain_cells;
        bound(
            file,
            "regions.speed_cells",
            (cells * n_tau) as f64,
            crate::limits::MAX_CHART_CELLS as f64,
            || "shading cells over all delays".into(),
        )?;
        let intervals = c.chart.cycles.intervals as f64;
        let seeds = c.chart.seed_gains_s.as_ref().map_or(3, Vec::len) as f64;
        // each seed starts a Hopf curve in two directions; one fold curve per delay
        let hopf_points = 2.0 * seeds * c.chart.hopf_max_points as f64;
        let fold_points = 2.0 * c.chart.fold_max_points as f64;
        let per_tau_s = hopf_points * HOPF_SECONDS_PER_POINT
            + fold_points * intervals * FOLD_SECONDS_PER_POINT_INTERVAL
            + cells as f64 * crate::limits::FIG4A_SECONDS_PER_CELL;
        let state_numbers = 2.0 * intervals * (c.chart.cycles.degree as f64) * 4.0 + 8.0;
        let memory = n_tau as f64
            * (fold_points * state_numbers * 8.0 * 4.0
                + hopf_points * 200.0
                + cells as f64 * crate::limits::FIG4A_BYTES_PER_CELL);
        // the delays run in parallel on the two cores
        let time = per_tau_s * (n_tau as f64 / 2.0).ceil();
        Ok(Plan::new(
            vec![
                format!(
                    "chart_nonlinear: {n_tau} delays, each ≤ {} Hopf-curve points from {} seeds and ≤ {} fold-of-cycles points (mesh L = {})",
                    hopf_points, seeds, fold_points, c.chart.cycles.intervals
                ),
                format!(
                    "shading: {} × {} linear chart cells per delay",
                    c.regions.speed_cells, c.regions.gain_cells
                ),
                format!("upper bound on the time (curves usually stop early): {}", human_seconds(time)),
            ],
            memory,
            time,
        ))
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        ctx.run_staged(TASK.name, "chart_nonlinear: curves per delay", cfg.delays_s.len() as u64, cfg, &self.file, |out| {
        let bounds = SpeedBounds::from(&ctx.limits);
        let study = trailer_model::with_plant!(&ctx.plant, m => compute(m, cfg, &bounds, ctx.progress))?;
        let (res, results) = (&study.resolved, &study.delays);
        let bistable = res.bistable_gain_s;
        let mut lines = Vec::new();
        if !res.derivation.derived_keys.is_empty() {
            let o = &res.options;
            lines.push(format!(
                "box V in [{}, {}] m/s, D in [{}, {}] s, seeds {:?} s (derived from the vehicle: {})",
                o.v_min_mps,
                o.v_max_mps,
                o.d_min_s,
                o.d_max_s,
                o.seed_gains_s,
                res.derivation.derived_keys.join(", ")
            ));
        }
        for r in results {
            write_curves(out, r)?;
            let at = r.curves.iter().find(|c| (c.d_s - bistable).abs() < 1e-12);
            lines.push(format!(
                "τ = {} s: {} Hopf and {} fold-of-cycles curves; at D = {} s V_hopf = {}, V_fold = {}, bistable width {}; codim-2: {}",
                r.chart.tau_s,
                r.chart.hopf_curves.len(),
                r.chart.fold_curves.len(),
                bistable,
                at.and_then(|c| c.v_hopf_mps).map_or("–".into(), |v| format!("{v:.4} m/s")),
                at.and_then(|c| c.v_fold_mps).map_or("–".into(), |v| format!("{v:.4} m/s")),
                r.bistable_width_mps.map_or("–".into(), |v| format!("{v:.4} m/s")),
                r.chart
                    .codim2_points
                    .iter()
                    .map(|c| format!("{} at D = {:.4} s, V = {:.3} m/s", c.kind.name(), c.d_s, c.v_mps))
                    .collect::<Vec<_>>()
                    .join("; ")
            ));
            for why in [&r.safe_reason, &r.chart.hopf_reason, &r.chart.fold_reason, &r.bistable_reason]
                .into_iter()
                .flatten()
            {
                lines.push(format!("τ = {} s: {why}", r.chart.tau_s));
            }
            for e in &r.curves_ended_early {
                lines.push(format!("τ = {} s: {} {}", r.chart.tau_s, e.curve, e.end.describe()));
            }
        }
        let panels: Vec<Panel> = results.iter().map(|r| panel(r, &res.options)).collect();
        let n = panels.len();
        let cols = if n <= 1 { 1 } else { 2 };
        let rows = n.div_ceil(cols);
        Figure::grid(panels, rows, cols, (1300, 520 * rows as u32))
            .titled("Nonlinear stability chart of straight running, δ(t) = −D·dψ/dt(t − τ)")
            .render(&out.path("chart_nonlinear"))?;
        let summary = ChartNonlinearSummary {
            per_tau: results.iter().map(DelayEntry::from).collect(),
            ranges: ResolvedRanges::from(res),
        };
        Ok((summary, lines))
        })
    }
}
