//! The derived parts of a sweep's outputs: the heat map with its threshold line, the
//! threshold map's comparison with the bifurcation diagram, and the distributions of
//! sampled studies (all computed from the ordered point results only).

use serde::Serialize;
use crate::TaskError;
use sway::sampling::{Statistics, histogram};
use sway::sim::SwayClass;
use sway_studies::sweep::{
    AxisParameter, CycleReference, PointKind, PointOutput, PointResult, SweepConfig,
    Theta0Threshold,
};

use crate::io::{Keyed, OutputDir};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// A result quantity of a kind: (name, axis label, value of a point).
type Quantity = (&'static str, &'static str, fn(&PointOutput) -> Option<f64>);

/// The quantities of a point kind whose statistics and histograms a study reports.
fn quantities(kind: PointKind) -> Vec<Quantity> {
    match kind {
        PointKind::Simulation => vec![(
            "final_amplitude_deg",
            "final amplitude [deg]",
            |o| match o {
                PointOutput::Simulation(m) => m.final_amplitude_deg,
                _ => None,
            },
        )],
        PointKind::LinearCriticalSpeed => vec![
            ("v_crit_mps", "V_crit [m/s]", |o| match o {
                PointOutput::LinearCriticalSpeed(l) => l.v_crit_mps,
                _ => None,
            }),
            ("hopf_frequency_hz", "Hopf frequency [Hz]", |o| match o {
                PointOutput::LinearCriticalSpeed(l) => l.hopf_frequency_hz,
                _ => None,
            }),
        ],
        PointKind::HopfFoldSpeeds => vec![
            ("hopf_v_mps", "V_Hopf [m/s]", |o| match o {
                PointOutput::HopfFoldSpeeds(h) => h.hopf_v_mps,
                _ => None,
            }),
            ("fold_v_mps", "V_fold [m/s]", |o| match o {
                PointOutput::HopfFoldSpeeds(h) => h.fold_v_mps,
                _ => None,
            }),
        ],
    }
}

/// The names of the quantities a study of `kind` reports in `distributions`.
pub fn quantity_names(kind: PointKind) -> Vec<&'static str> {
    quantities(kind).iter().map(|q| q.0).collect()
}

fn value(r: &PointResult, q: &Quantity) -> Option<f64> {
    r.output.as_ref().ok().and_then(q.2)
}

/// The smallest swept value of axis 2 that ends in sustained sway, per value of axis 1,
/// with the bisected threshold and the unstable cycle at that speed (threshold maps).
#[derive(Debug, Clone, PartialEq)]
pub struct ThresholdPoint {
    /// axis 1's parameter and value
    pub x: (&'static str, f64),
    /// `min_<axis 2>_for_sway` (the smallest grid value in sustained sway) and its value
    pub y: (String, Option<f64>),
    /// the bisection at this speed (threshold maps)
    pub bisection: Option<Theta0Threshold>,
    /// max |θ| of the unstable cycle at this speed \[deg\] (threshold maps)
    pub unstable_cycle_amplitude_deg: Option<f64>,
}

impl Serialize for ThresholdPoint {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(None)?;
        m.serialize_entry(self.x.0, &self.x.1)?;
        m.serialize_entry(&self.y.0, &self.y.1)?;
        if let Some(b) = &self.bisection {
            m.serialize_entry("theta0_threshold_deg", &b.theta0_threshold_deg)?;
            m.serialize_entry("theta0_below_deg", &b.theta0_below_deg)?;
            m.serialize_entry("threshold_grid_theta0_deg", &b.grid_theta0_deg)?;
            m.serialize_entry("threshold_horizon_s", &b.horizon_s)?;
            m.serialize_entry("horizon_verified", &b.horizon_verified)?;
            m.serialize_entry(
                "unstable_cycle_amplitude_deg",
                &self.unstable_cycle_amplitude_deg,
            )?;
            let ratio = bracketed(b)
                .zip(self.unstable_cycle_amplitude_deg)
                .map(|(t, a)| t / a);
            m.serialize_entry("threshold_to_cycle_ratio", &ratio)?;
        }
        m.end()
    }
}

/// The bisected threshold when it was bracketed from below (not the first grid value,
/// which is only an upper bound).
fn bracketed(b: &Theta0Threshold) -> Option<f64> {
    b.theta0_below_deg.and(b.theta0_threshold_deg)
}

/// The heat map's part of a sweep summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeatmapSummary {
    /// the parameters of axis 1 and 2
    pub heatmap_axes: [&'static str; 2],
    /// simulations: per value of axis 1, the smallest value of axis 2 that ends in
    /// sustained sway (and, in a threshold map, the bisected threshold)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub threshold: Vec<ThresholdPoint>,
}

/// Cell edges of a uniform axis (midpoints, ends extended by half a spacing).
fn edges(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    if n == 1 {
        return vec![values[0] - 0.5, values[0] + 0.5];
    }
    let mut e = Vec::with_capacity(n + 1);
    e.push(values[0] - 0.5 * (values[1] - values[0]));
    for w in values.windows(2) {
        e.push(0.5 * (w[0] + w[1]));
    }
    e.push(values[n - 1] + 0.5 * (values[n - 1] - values[n - 2]));
    e
}

/// The threshold points and the reference of a threshold map, from the extra points.
fn threshold_parts(extra: &[PointResult]) -> (Vec<Theta0Threshold>, Option<CycleReference>) {
    let mut t = Vec::new();
    let mut reference = None;
    for r in extra {
        match &r.output {
            Ok(PointOutput::Theta0Threshold(x)) => t.push(*x),
            Ok(PointOutput::CycleReference(c)) => reference = Some(c.clone()),
            Err(e) => eprintln!("threshold point at {:?} failed: {e}", r.values),
            _ => {}
        }
    }
    (t, reference)
}

/// The bisection at speed `x` (matched by value: a failed bisection leaves its speed empty
/// instead of shifting the others).
fn bisection_at(bisections: &[Theta0Threshold], x: f64) -> Option<Theta0Threshold> {
    bisections.iter().find(|b| b.speed_mps == x).copied()
}

fn heat_value(kind: PointKind, r: &PointResult) -> f64 {
    let q = quantities(kind);
    let pick = match kind {
        PointKind::HopfFoldSpeeds => &q[1],
        _ => &q[0],
    };
    value(r, pick).unwrap_or(f64::NAN)
}

/// With two or more axes (and no sampling): `heatmap.svg/.png` over the first two axes
/// (every further axis at its first value): the final sway amplitude with the threshold
/// lines (simulations), V_crit (linear) or V_fold (Hopf/fold); its summary part and a
/// printed line.
pub(super) fn heatmap(
    out: &OutputDir,
    cfg: &SweepConfig,
    grid: &[PointResult],
    extra: &[PointResult],
) -> Result<Option<(HeatmapSummary, Option<String>)>, TaskError> {
    if cfg.axes.len() < 2 || cfg.sampling.is_some() {
        return Ok(None);
    }
    let (ax, ay) = (&cfg.axes[0], &cfg.axes[1]);
    let (xs, ys) = (ax.values(), ay.values());
    let (nx, ny) = (xs.len(), ys.len());
    let values: Vec<Vec<f64>> = (0..ny)
        .map(|j| (0..nx).map(|i| heat_value(cfg.kind, &grid[i + nx * j])).collect())
        .collect();
    let finite = values.iter().flatten().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let sim = cfg.kind == PointKind::Simulation;
    let range = if sim { (0.0, hi.max(1.0)) } else if lo <= hi { (lo, hi.max(lo + 1e-9)) } else { (0.0, 1.0) };
    let label = match cfg.kind {
        PointKind::Simulation => "final amplitude [deg] (grey: loss of control / failed)",
        PointKind::LinearCriticalSpeed => "V_crit [m/s] (grey: none in range / failed)",
        PointKind::HopfFoldSpeeds => "V_fold [m/s] (grey: no fold / failed)",
    };
    let title = match cfg.kind {
        PointKind::Simulation => format!(
            "{}: final sway amplitude (max |θ| over the last {} s)",
            cfg.name,
            cfg.base.settings.metrics.final_window_s.get()
        ),
        _ => format!("{}: {}", cfg.name, label.split(" (").next().unwrap_or(label)),
    };
    let mut p = Panel::new(&title, &ax.parameter.label(), &ay.parameter.label())
        .with(Layer::Heatmap {
            x_edges: edges(&xs),
            y_edges: edges(&ys),
            values,
            range,
            label: label.into(),
        })
        .legend(Legend::UpperRight);
    let mut summary = HeatmapSummary {
        heatmap_axes: [ax.parameter.as_str(), ay.parameter.as_str()],
        threshold: Vec::new(),
    };
    let mut line = None;
    if sim {
        let sustained = |r: &PointResult| r.metrics().is_some_and(|m| m.class == SwayClass::SustainedSway);
        let first: Vec<Option<f64>> = (0..nx)
            .map(|i| (0..ny).find(|&j| sustained(&grid[i + nx * j])).map(|j| ys[j]))
            .collect();
        let (bisections, reference) = threshold_parts(extra);
        summary.threshold = (0..nx)
            .map(|i| ThresholdPoint {
                x: (ax.parameter.as_str(), xs[i]),
                y: (format!("min_{}_for_sway", ay.parameter.as_str()), first[i]),
                bisection: bisection_at(&bisections, xs[i]),
                unstable_cycle_amplitude_deg: reference
                    .as_ref()
                    .and_then(|c| c.speeds.get(i))
                    .and_then(|c| c.unstable_amplitude_deg),
            })
            .collect();
        let y_edges = edges(&ys);
        let y_range = (y_edges[0], y_edges[y_edges.len() - 1]);
        threshold_layers(&mut p, &summary.threshold, reference.as_ref(), ay.parameter.as_str(), y_range);
        line = summary
            .threshold
            .iter()
            .find_map(|t| t.y.1.map(|y| (t.x.1, y)))
            .map(|(x, y)| {
                format!(
                    "lowest {} with sustained sway: {x:.3}, from {} = {y:.3}",
                    ax.parameter.as_str(),
                    ay.parameter.as_str()
                )
            });
    }
    Figure::single(p).render(&out.path("heatmap"))?;
    Ok(Some((summary, line)))
}

/// The threshold lines of a simulation heat map: the grid's smallest θ(0) in sustained sway,
/// the bisected threshold, the unstable cycle's amplitude and the fold and Hopf speeds.
fn threshold_layers(
    p: &mut Panel,
    t: &[ThresholdPoint],
    reference: Option<&CycleReference>,
    y_name: &str,
    y_range: (f64, f64),
) {
    let grid_line: Vec<(f64, f64)> = t.iter().filter_map(|t| t.y.1.map(|y| (t.x.1, y))).collect();
    if !grid_line.is_empty() {
        p.layers.push(Layer::line(
            grid_line,
            Rgb::RED,
            Stroke::Solid,
            Some(&format!("smallest {y_name} in sustained sway (grid)")),
        ));
    }
    let bisected: Vec<(f64, f64)> = t
        .iter()
        .filter_map(|t| t.bisection.and_then(|b| b.theta0_threshold_deg).map(|y| (t.x.1, y)))
        .collect();
    if !bisected.is_empty() {
        p.layers.push(Layer::line(
            bisected,
            Rgb::BLACK,
            Stroke::Dashed,
            Some("θ(0) threshold (bisection)"),
        ));
    }
    let Some(c) = reference else { return };
    let cycle: Vec<(f64, f64)> = c
        .speeds
        .iter()
        .filter_map(|s| s.unstable_amplitude_deg.map(|a| (s.speed_mps, a)))
        .filter(|&(_, a)| a <= y_range.1)
        .collect();
    if !cycle.is_empty() {
        p.layers.push(Layer::line(
            cycle,
            Rgb::ORANGE,
            Stroke::Dotted,
            Some("unstable cycle max |θ| (fig3a)"),
        ));
    }
    if let Some(f) = c.fold_v_mps {
        p.layers.push(Layer::vline(
            f,
            y_range,
            Rgb::GREY,
            Stroke::Dashed,
            Some(&format!("V_fold {f:.2} m/s (fig3a)")),
        ));
    }
}

/// The threshold map against the bifurcation diagram.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeparatrixSummary {
    /// V_crit of the diagram \[m/s\]
    pub hopf_v_mps: f64,
    /// V_fold of the diagram \[m/s\]
    pub fold_v_mps: Option<f64>,
    /// max |θ| at the fold \[deg\]
    pub fold_amplitude_deg: Option<f64>,
    /// the grid's lowest speed with a point in sustained sway \[m/s\]
    pub lowest_sustained_sway_speed_mps: Option<f64>,
    /// the lowest speed with a bisected threshold \[m/s\]
    pub lowest_threshold_speed_mps: Option<f64>,
    /// whether every bisection's outcome stayed the same with a doubled horizon
    pub all_horizons_verified: bool,
    /// θ(0) threshold / max |θ| of the unstable cycle over the speeds with both (and a
    /// threshold bracketed from below): min, mean, max (a kick with the other states 0 is
    /// not on the cycle: a different section of the same separatrix)
    pub threshold_to_cycle_ratio: Option<[f64; 3]>,
    /// speeds with both numbers
    pub speeds_compared: usize,
}

/// With a threshold map's extra points: its comparison with the diagram and printed lines.
pub(super) fn separatrix(
    cfg: &SweepConfig,
    grid: &[PointResult],
    extra: &[PointResult],
) -> Option<(SeparatrixSummary, Vec<String>)> {
    let (bisections, reference) = threshold_parts(extra);
    let c = reference?;
    let lowest_grid = grid
        .iter()
        .filter(|r| r.metrics().is_some_and(|m| m.class == SwayClass::SustainedSway))
        .map(|r| r.values[0])
        .min_by(f64::total_cmp);
    let lowest_t = bisections
        .iter()
        .filter(|b| b.theta0_threshold_deg.is_some())
        .map(|b| b.speed_mps)
        .min_by(f64::total_cmp);
    let ratios: Vec<f64> = c
        .speeds
        .iter()
        .filter_map(|s| {
            let b = bisection_at(&bisections, s.speed_mps)?;
            Some(bracketed(&b)? / s.unstable_amplitude_deg?)
        })
        .collect();
    let ratio = (!ratios.is_empty()).then(|| {
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        let min = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let max = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        [min, mean, max]
    });
    let s = SeparatrixSummary {
        hopf_v_mps: c.hopf_v_mps,
        fold_v_mps: c.fold_v_mps,
        fold_amplitude_deg: c.fold_amplitude_deg,
        lowest_sustained_sway_speed_mps: lowest_grid,
        lowest_threshold_speed_mps: lowest_t,
        all_horizons_verified: bisections.iter().all(|b| b.horizon_verified != Some(false)),
        threshold_to_cycle_ratio: ratio,
        speeds_compared: ratios.len(),
    };
    let fmt = |v: Option<f64>| v.map_or("none".to_string(), |v| format!("{v:.3}"));
    let mut lines = vec![format!(
        "{}: lowest sustained-sway speed {} m/s (grid), {} m/s (bisection); V_fold = {} m/s, V_crit = {:.3} m/s",
        cfg.name,
        fmt(lowest_grid),
        fmt(lowest_t),
        fmt(c.fold_v_mps),
        c.hopf_v_mps
    )];
    if let Some([lo, mean, hi]) = ratio {
        lines.push(format!(
            "θ(0) threshold / unstable-cycle max |θ|: {lo:.3}–{hi:.3} (mean {mean:.3}) over {} speeds",
            ratios.len()
        ));
    }
    Some((s, lines))
}

/// The statistics of one quantity at one grid point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DistributionEntry {
    /// the grid point's axis values (by parameter; empty without axes or over all points)
    pub at: Keyed<f64>,
    /// the statistics of its samples
    #[serde(flatten)]
    pub statistics: Option<Statistics>,
}

/// Per quantity, its statistics at each grid point (`summary.json`'s `distributions`).
pub type Distributions = Keyed<Vec<DistributionEntry>>;

/// Bins of the histogram figure.
const HISTOGRAM_BINS: usize = 30;

/// The distributions of the kind's quantities: with `[sampling]` per grid point (and the
/// histogram figure of grid point 0), otherwise over all points (linear and bifurcation
/// kinds). Printed lines give the quantiles.
pub(super) fn distributions(
    out: &OutputDir,
    cfg: &SweepConfig,
    grid: &[PointResult],
) -> Result<Option<(Distributions, Vec<String>)>, TaskError> {
    let sampled = cfg.sampling.is_some();
    if !sampled && cfg.kind == PointKind::Simulation {
        return Ok(None);
    }
    // with samples, one distribution per grid point; otherwise one over all points
    let per_sample: usize = if sampled {
        cfg.axes.iter().map(|a| a.len()).product()
    } else {
        1
    };
    let axis_values: Vec<Vec<f64>> = cfg.axes.iter().map(|a| a.values()).collect();
    let at = |g: usize| -> Keyed<f64> {
        if !sampled {
            return Keyed::default();
        }
        let mut r = g;
        Keyed(
            cfg.axes
                .iter()
                .zip(&axis_values)
                .map(|(a, v)| {
                    let x = v[r % v.len()];
                    r /= v.len();
                    (a.parameter.as_str().to_string(), x)
                })
                .collect(),
        )
    };
    let mut lines = Vec::new();
    let mut table = Keyed::default();
    let mut panels = Vec::new();
    for q in quantities(cfg.kind) {
        let column = |g: usize| -> Vec<f64> {
            grid.iter()
                .enumerate()
                .filter(|(k, _)| k % per_sample == g)
                .filter_map(|(_, r)| value(r, &q))
                .collect()
        };
        let entries: Vec<DistributionEntry> = (0..per_sample.min(grid.len()))
            .map(|g| DistributionEntry {
                at: at(g),
                statistics: Statistics::of(column(g)),
            })
            .collect();
        if let Some(Some(s)) = entries.first().map(|e| &e.statistics) {
            let qs = &s.quantiles;
            lines.push(format!(
                "{}: {} median {:.4}, 5–95 % [{:.4}, {:.4}], quartiles [{:.4}, {:.4}], mean {:.4}, sd {:.4} ({} values{})",
                cfg.name,
                q.0,
                qs.q50,
                qs.q05,
                qs.q95,
                qs.q25,
                qs.q75,
                s.mean,
                s.sd,
                s.count,
                if sampled && per_sample > 1 { ", grid point 0" } else { "" }
            ));
            if sampled {
                panels.push(histogram_panel(cfg, &q, &column(0), s));
            }
        }
        table.0.push((q.0.to_string(), entries));
    }
    if !panels.is_empty() {
        Figure::column(panels).render(&out.path("histogram"))?;
    }
    Ok(Some((table, lines)))
}

/// A histogram of `xs` with the median and the 5–95 % range marked.
fn histogram_panel(cfg: &SweepConfig, q: &Quantity, xs: &[f64], s: &Statistics) -> Panel {
    let (lo, hi) = if s.max > s.min { (s.min, s.max) } else { (s.min - 0.5, s.max + 0.5) };
    let counts = histogram(xs, lo, hi, HISTOGRAM_BINS);
    let w = (hi - lo) / HISTOGRAM_BINS as f64;
    let rects: Vec<[f64; 4]> = counts
        .iter()
        .enumerate()
        .map(|(i, &c)| [lo + w * i as f64, lo + w * (i + 1) as f64, 0.0, c as f64])
        .collect();
    let top = counts.iter().copied().max().unwrap_or(1) as f64 * 1.15;
    let qs = &s.quantiles;
    let fields: Vec<&str> = cfg
        .sampling
        .iter()
        .flat_map(|s| s.fields.iter().map(|f| f.key.as_str()))
        .collect();
    let mut p = Panel::new(
        &format!("{}: {} over {} samples of {}", cfg.name, q.0, s.count, fields.join(", ")),
        q.1,
        "samples per bin",
    )
    .with(Layer::Rects {
        rects,
        color: Rgb::BLUE,
        opacity: 0.7,
        label: Some("histogram".into()),
    })
    .legend(Legend::UpperRight)
    .y_range(0.0, top);
    p.layers.push(Layer::vline(
        qs.q50,
        (0.0, top),
        Rgb::RED,
        Stroke::Solid,
        Some(&format!("median {:.4}", qs.q50)),
    ));
    for (x, name) in [(qs.q05, "5 %"), (qs.q95, "95 %")] {
        p.layers.push(Layer::vline(
            x,
            (0.0, top),
            Rgb::ORANGE,
            Stroke::Dashed,
            Some(&format!("{name} quantile {x:.4}")),
        ));
    }
    p
}

/// One axis, a linear or bifurcation kind: `sweep.svg/.png`, the quantities over the axis.
pub(super) fn line_figure(
    out: &OutputDir,
    cfg: &SweepConfig,
    grid: &[PointResult],
) -> Result<(), TaskError> {
    let ax = &cfg.axes[0];
    let panels: Vec<Panel> = quantities(cfg.kind)
        .iter()
        .map(|q| {
            let pts: Vec<(f64, f64)> = grid
                .iter()
                .map(|r| (r.values[0], value(r, q).unwrap_or(f64::NAN)))
                .collect();
            let p = Panel::new(&format!("{}: {}", cfg.name, q.0), &ax.parameter.label(), q.1)
                .with(Layer::line(pts.clone(), Rgb::BLUE, Stroke::Solid, Some(q.0)));
            if ax.parameter == AxisParameter::VehicleFile || grid.len() < 40 {
                p.with(Layer::markers(pts, Rgb::BLUE, None))
            } else {
                p
            }
        })
        .collect();
    Figure::column(panels).render(&out.path("sweep"))
}
