//! `cargo xtask chart_nonlinear` (issue 8, beyond the paper): the nonlinear stability chart
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

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use stability::{Axis, StabilityChart};
use crate::TaskError;
use sway::bifurcation::chart::{
    ChartOptions, Codim2Kind, NonlinearChart, Region, nonlinear_chart,
};
use sway::charts::fig4a_charts;
use sway::config::{ensure, ensure_positive};
use trailer_model::Model;

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
);

/// The shading grid (cells of the linear stability chart, exact unstable-root counts).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionGrid {
    /// cells along V
    pub speed_cells: usize,
    /// cells along D
    pub gain_cells: usize,
}

fn default_delays() -> Vec<f64> {
    vec![0.0, 0.1, 0.2, 0.4]
}
fn default_summary_gains() -> Vec<f64> {
    vec![0.0, 0.05, 0.1, 0.15, 0.2, 0.25]
}
fn default_bistable_gain() -> f64 {
    0.1
}
fn default_grid() -> RegionGrid {
    RegionGrid {
        speed_cells: 140,
        gain_cells: 80,
    }
}

/// `configs/chart_nonlinear.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChartNonlinearConfig {
    /// the delays τ \[s\], one panel each
    #[serde(default = "default_delays")]
    pub delays_s: Vec<f64>,
    /// gains of the `"curves"` entries of the summary \[s\]
    #[serde(default = "default_summary_gains")]
    pub summary_gains_s: Vec<f64>,
    /// gain of `"bistable_width_mps"` \[s\]
    #[serde(default = "default_bistable_gain")]
    pub bistable_gain_s: f64,
    /// the curves: ranges, seeds, steps, cycle mesh
    #[serde(default)]
    pub chart: ChartOptions,
    /// the shading grid
    #[serde(default = "default_grid")]
    pub regions: RegionGrid,
}

impl ChartNonlinearConfig {
    /// Checks the keys.
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path) -> Result<(), TaskError> {
        check_delays(file, "delays_s", &self.delays_s)?;
        let c = &self.chart;
        ensure(
            c.d_min_s.is_finite() && c.d_max_s.is_finite() && c.d_min_s < c.d_max_s,
            file,
            "chart.d_min_s",
            || {
                format!(
                    "expected d_min_s < d_max_s, got {} and {}",
                    c.d_min_s, c.d_max_s
                )
            },
        )?;
        ensure(
            c.v_min_mps > 0.0 && c.v_max_mps.is_finite() && c.v_min_mps < c.v_max_mps,
            file,
            "chart.v_min_mps",
            || {
                format!(
                    "expected 0 < v_min_mps < v_max_mps, got {} and {}",
                    c.v_min_mps, c.v_max_mps
                )
            },
        )?;
        ensure(
            !c.seed_gains_s.is_empty(),
            file,
            "chart.seed_gains_s",
            || "expected at least one seed gain".into(),
        )?;
        for (i, d) in c.seed_gains_s.iter().enumerate() {
            ensure(
                *d >= c.d_min_s && *d <= c.d_max_s,
                file,
                &format!("chart.seed_gains_s[{i}]"),
                || format!("seed gain {d} s outside [d_min_s, d_max_s]"),
            )?;
        }
        for (key, v) in [
            ("chart.hopf_step", c.hopf_step),
            ("chart.hopf_max_step", c.hopf_max_step),
            ("chart.fold_step", c.fold_step),
            ("chart.fold_max_step", c.fold_max_step),
            ("chart.fold_min_amplitude", c.fold_min_amplitude),
        ] {
            ensure_positive(v, file, key, "a positive number")?;
        }
        for (key, n) in [
            ("chart.hopf_max_points", c.hopf_max_points),
            ("chart.fold_max_points", c.fold_max_points),
            ("chart.criticality_samples", c.criticality_samples),
            ("chart.criticality_cycle_points", c.criticality_cycle_points),
            ("regions.speed_cells", self.regions.speed_cells),
            ("regions.gain_cells", self.regions.gain_cells),
        ] {
            ensure(n >= 2, file, key, || format!("expected ≥ 2, got {n}"))?;
        }
        validate_options(&c.cycles, file, "chart.cycles")
    }
}

impl TaskConfig for ChartNonlinearConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        self.validate(file)
    }
}

/// The summary row of one gain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CurvesAtGain {
    /// gain D \[s\]
    pub d_s: f64,
    /// lowest Hopf speed \[m/s\]
    pub v_hopf_mps: Option<f64>,
    /// lowest fold-of-cycles speed \[m/s\]
    pub v_fold_mps: Option<f64>,
}

/// Everything computed for one delay.
#[derive(Debug, Clone)]
pub struct DelayResult {
    /// the curves and codimension-two points
    pub chart: NonlinearChart,
    /// the linear stability chart of the shading grid (static boundary, regions)
    pub linear: StabilityChart,
    /// the speeds at the summary gains
    pub curves: Vec<CurvesAtGain>,
    /// V_hopf − V_fold at the bistable gain \[m/s\]
    pub bistable_width_mps: Option<f64>,
}

fn grid_axes(cfg: &ChartNonlinearConfig) -> (Axis, Axis) {
    let c = &cfg.chart;
    (
        Axis {
            min: 0.0,
            max: c.v_max_mps,
            count: cfg.regions.speed_cells,
        },
        Axis {
            min: c.d_min_s,
            max: c.d_max_s,
            count: cfg.regions.gain_cells,
        },
    )
}

fn speeds_at(model: &Model, chart: &NonlinearChart, d: f64) -> Result<CurvesAtGain, TaskError> {
    Ok(CurvesAtGain {
        d_s: d,
        v_hopf_mps: chart.hopf_speed_at(model, d)?,
        v_fold_mps: chart.fold_speed_at(model, d)?,
    })
}

/// The whole computation of one delay (no I/O).
///
/// # Errors
/// [`sway::SwayError::Numerical`].
pub fn compute_delay(
    model: &Model,
    cfg: &ChartNonlinearConfig,
    tau: f64,
) -> Result<DelayResult, TaskError> {
    // the curves and the linear chart side by side, then the speeds at every summary gain
    // and at the bistable gain (the last entry) in parallel; each piece is deterministic
    let (chart, linear) = rayon::join(
        || nonlinear_chart(model, tau, &cfg.chart),
        || linear_chart(model, cfg, tau),
    );
    let (chart, linear) = (chart?, linear?);
    let mut curves = cfg
        .summary_gains_s
        .par_iter()
        .chain([cfg.bistable_gain_s].par_iter())
        .map(|&d| speeds_at(model, &chart, d))
        .collect::<Result<Vec<_>, _>>()?;
    let at = curves.pop().ok_or_else(|| {
        TaskError::numerical(
            format!("speeds at D = {} s, τ = {tau} s", cfg.bistable_gain_s),
            continuation::Error::InvalidInput("no speeds returned".into()),
        )
    })?;
    let bistable_width_mps = match (at.v_hopf_mps, at.v_fold_mps) {
        (Some(h), Some(f)) => Some(h - f),
        _ => None,
    };
    Ok(DelayResult {
        chart,
        linear,
        curves,
        bistable_width_mps,
    })
}

/// fig4a's linear chart of delay τ on the shading grid (exact counts of unstable roots).
fn linear_chart(
    model: &Model,
    cfg: &ChartNonlinearConfig,
    tau: f64,
) -> Result<stability::StabilityChart, TaskError> {
    let (sa, ga) = grid_axes(cfg);
    fig4a_charts(model, &[tau], sa, ga, &stability::ChartOptions::default())?
        .into_iter()
        .next()
        .ok_or_else(|| {
            TaskError::numerical(
                format!("linear chart τ = {tau} s"),
                continuation::Error::InvalidInput("no chart returned".into()),
            )
        })
}

/// All delays of the config, in its order (parallel over delays; each is deterministic).
///
/// # Errors
/// The first failing delay's error (in config order).
pub fn compute(
    model: &Model,
    cfg: &ChartNonlinearConfig,
    progress: &dyn sway::progress::Progress,
) -> Result<Vec<DelayResult>, TaskError> {
    // the longest delays first (their collocation factors fill most, so they cost most):
    // rayon then starts them on separate threads instead of last; results in config order
    let mut order: Vec<usize> = (0..cfg.delays_s.len()).collect();
    order.sort_by(|&a, &b| cfg.delays_s[b].total_cmp(&cfg.delays_s[a]));
    let mut results: Vec<(usize, Result<DelayResult, TaskError>)> = order
        .par_iter()
        .map(|&i| {
            let r = compute_delay(model, cfg, cfg.delays_s[i]);
            progress.advance(1);
            (i, r)
        })
        .collect();
    results.sort_by_key(|(i, _)| *i);
    results.into_iter().map(|(_, r)| r).collect()
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
        }
    }
}

/// `summary.json` of chart_nonlinear (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChartNonlinearSummary {
    /// one entry per delay, in the config's order
    pub per_tau: Vec<DelayEntry>,
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
fn clip_to_gains(line: &[(f64, f64)], (d_min, d_max): (f64, f64)) -> Line {
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

fn panel(r: &DelayResult, cfg: &ChartNonlinearConfig) -> Panel {
    let c = &cfg.chart;
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
    ] {
        p = p.with(Layer::Rects {
            rects: region_rects(&r.linear, &regions, which),
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
        let seeds = c.chart.seed_gains_s.len() as f64;
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
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress.start(
            "chart_nonlinear: curves per delay",
            cfg.delays_s.len() as u64,
        );
        let results = compute(&ctx.model, cfg, ctx.progress)?;
        let mut lines = Vec::new();
        for r in &results {
            write_curves(&out, r)?;
            let at = r
                .curves
                .iter()
                .find(|c| (c.d_s - cfg.bistable_gain_s).abs() < 1e-12);
            lines.push(format!(
                "τ = {} s: {} Hopf and {} fold-of-cycles curves; at D = {} s V_hopf = {}, V_fold = {}, bistable width {}; codim-2: {}",
                r.chart.tau_s,
                r.chart.hopf_curves.len(),
                r.chart.fold_curves.len(),
                cfg.bistable_gain_s,
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
        }
        let panels: Vec<Panel> = results.iter().map(|r| panel(r, cfg)).collect();
        let n = panels.len();
        let cols = if n <= 1 { 1 } else { 2 };
        let rows = n.div_ceil(cols);
        Figure::grid(panels, rows, cols, (1300, 520 * rows as u32))
            .titled("Nonlinear stability chart of straight running, δ(t) = −D·dψ/dt(t − τ)")
            .render(&out.path("chart_nonlinear"))?;
        let summary = ChartNonlinearSummary {
            per_tau: results.iter().map(DelayEntry::from).collect(),
        };
        ctx.conclude(out, summary, cfg, &self.file, lines)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config_file::parse_toml;
    use std::path::PathBuf;

    fn shipped() -> (PathBuf, String) {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/chart_nonlinear.toml");
        let text = std::fs::read_to_string(&file).expect("shipped config");
        (file, text)
    }

    #[test]
    fn shipped_config_is_valid_and_as_the_issue_asks() {
        let (file, text) = shipped();
        let cfg: ChartNonlinearConfig = parse_toml(&text, &file).unwrap();
        cfg.validate(&file).unwrap();
        assert_eq!(cfg.delays_s, vec![0.0, 0.1, 0.2, 0.4]);
        assert_eq!((cfg.chart.d_min_s, cfg.chart.d_max_s), (-0.1, 0.3));
        assert_eq!(cfg.summary_gains_s, vec![0.0, 0.05, 0.1, 0.15, 0.2, 0.25]);
        assert_eq!(cfg.bistable_gain_s, 0.1);
    }

    #[test]
    fn lines_are_cut_at_the_gain_range() {
        // reference: the crossings of the segments with D = 0 and D = 1, by hand
        let line = [(0.0, -1.0), (2.0, 1.0), (4.0, 3.0), (6.0, 0.5), (8.0, 0.25)];
        let cut = clip_to_gains(&line, (0.0, 1.0));
        let nan = |p: &(f64, f64)| p.0.is_nan();
        assert!(nan(&cut[0]));
        assert_eq!(cut[1], (1.0, 0.0));
        assert_eq!(cut[2], (2.0, 1.0));
        assert_eq!(cut[3], (2.0, 1.0));
        assert!(nan(&cut[4]) && nan(&cut[5]));
        // (4, 3) → (6, 0.5) meets D = 1 at t = 0.8: V = 5.6 (round-off only)
        assert!((cut[6].0 - 5.6).abs() < 1e-12 && cut[6].1 == 1.0, "{:?}", cut[6]);
        assert_eq!(&cut[7..], &[(6.0, 0.5), (8.0, 0.25)]);
    }

    #[test]
    fn bad_values_name_their_key() {
        let (file, text) = shipped();
        let bad = text.replace("d_max_s = 0.3", "d_max_s = -0.3");
        let cfg: ChartNonlinearConfig = parse_toml(&bad, &file).unwrap();
        let e = cfg.validate(&file).unwrap_err().to_string();
        assert!(e.contains("chart.d_min_s"), "{e}");
        let unknown = text.replace("[regions]", "[regions]\nfoo = 1");
        let e = parse_toml::<ChartNonlinearConfig>(&unknown, &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("foo"), "{e}");
    }
}
