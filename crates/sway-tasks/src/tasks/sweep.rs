//! `cargo xtask sweep FILE.toml`: a grid of simulations in parallel (rayon) over any of
//! V, θ(0), D, τ and the braking time T; one CSV row per grid point with the metrics
//! (a failed point says why in its row), a heat map of the final sway amplitude over the
//! first two axes, and `summary.json`. Same numbers whatever the thread count.

use std::path::Path;

use serde::Serialize;
use sway::SwayError;
use sway::sim::sweep::{Axis, PointResult, SweepConfig, run_sweep};
use sway::sim::{Metrics, Outcome};

use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::{Configured, TaskConfig};
use crate::io::{OutputDir, row_cells};
use crate::limits::{
    BYTES_PER_ROW, MAX_AXIS_POINTS, MAX_SIMULATED_S, MAX_SIMULATIONS, Plan,
    SWEEP_SECONDS_PER_SIM_SECOND, bound, human_seconds, settle_s,
};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task (its default config is the bistability threshold map).
pub const TASK: Task = Task::configured::<SweepConfig>(
    "sweep",
    "parallel grid of simulations (TOML); default: which perturbations trigger sway",
    "sweep_threshold.toml",
);

/// The same sweep runner on `configs/sweep_brake_timing.toml`: when braking from sway
/// loses control (beyond the paper), so that `cargo xtask all` regenerates it too.
pub const BRAKE_TIMING: Task = Task::configured::<SweepConfig>(
    "brake_timing",
    "sweep of braking start t_b × duration T from sway: where braking loses control (beyond the paper)",
    "sweep_brake_timing.toml",
);

impl TaskConfig for SweepConfig {
    fn check(&self, file: &Path) -> Result<(), SwayError> {
        self.validate(file)
    }
}

/// One row of `sweep.csv`: the axis values (one column per axis, named by its parameter),
/// then the metrics (the field names of [`Metrics`]; empty when the point failed, with
/// `outcome = "error"`), the accepted steps and the error message of a failed point (quoted
/// and escaped as CSV needs it).
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow<'a> {
    /// the axis values
    pub values: &'a [f64],
    /// the metrics, or the error of a failed point
    pub metrics: Result<&'a Metrics, &'a str>,
    /// accepted steps (0 on failure)
    pub accepted_steps: usize,
}

/// The metric column names: the field names of [`Metrics`].
fn metric_columns() -> Vec<String> {
    let any = Metrics {
        peak_theta_deg_after_action: None,
        final_amplitude_deg: None,
        settle_time_s: None,
        outcome: Outcome::Ok,
        loss_of_control_time_s: None,
        loss_of_control_condition: None,
    };
    row_cells(&any).map(|(names, _)| names).unwrap_or_default()
}

impl SweepRow<'_> {
    /// The header: axis parameters, metric names, `accepted_steps`, `error`.
    pub fn header(axes: &[Axis]) -> Vec<String> {
        let mut h: Vec<String> = axes.iter().map(|a| a.parameter.as_str().to_string()).collect();
        h.extend(metric_columns());
        h.extend(["accepted_steps".to_string(), "error".to_string()]);
        h
    }

    /// The cells, in the order of [`SweepRow::header`].
    fn cells(&self) -> Vec<String> {
        let mut row: Vec<String> = self.values.iter().map(|&v| crate::io::fmt_num(v)).collect();
        match self.metrics {
            Ok(m) => {
                row.extend(row_cells(m).map(|(_, c)| c).unwrap_or_default());
                row.extend([self.accepted_steps.to_string(), String::new()]);
            }
            Err(e) => {
                row.extend(metric_columns().iter().map(|name| {
                    if name == "outcome" {
                        "error".to_string()
                    } else {
                        String::new()
                    }
                }));
                row.extend(["0".to_string(), e.replace(['\n', '\r'], " ")]);
            }
        }
        row
    }
}

impl Serialize for SweepRow<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.cells().serialize(s)
    }
}

/// The smallest swept value of axis 2 that ends in sway, per value of axis 1.
#[derive(Debug, Clone, PartialEq)]
pub struct ThresholdPoint {
    /// axis 1's parameter and value
    pub x: (&'static str, f64),
    /// `min_<axis 2>_for_sway` and its value (None: no sway on the swept range)
    pub y: (String, Option<f64>),
}

impl Serialize for ThresholdPoint {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry(self.x.0, &self.x.1)?;
        m.serialize_entry(&self.y.0, &self.y.1)?;
        m.end()
    }
}

/// `summary.json` of a sweep (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepSummary {
    /// grid points
    pub points: usize,
    /// points that ran to the horizon
    pub points_ok: usize,
    /// points that lost control
    pub points_loss_of_control: usize,
    /// points whose run failed
    pub points_failed: usize,
    /// points whose final amplitude is at least the settle threshold
    pub points_with_sway: usize,
    /// that threshold \[deg\]
    pub sway_threshold_deg: f64,
    /// with 2 or more axes: the heat map's axes and the threshold line
    #[serde(flatten)]
    pub heatmap: Option<HeatmapSummary>,
}

/// The heat map's part of a sweep summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeatmapSummary {
    /// the parameters of axis 1 and 2
    pub heatmap_axes: [&'static str; 2],
    /// per value of axis 1, the smallest value of axis 2 that ends in sway
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

/// With two or more axes: `heatmap.svg/.png`, the final sway amplitude over the first two
/// axes (every further axis at its first value) with the threshold line, its summary part
/// and a printed line.
fn heatmap(
    out: &OutputDir,
    cfg: &SweepConfig,
    results: &[PointResult],
    thr: f64,
) -> Result<Option<(HeatmapSummary, Option<String>)>, SwayError> {
    if cfg.axes.len() < 2 {
        return Ok(None);
    }
    let (ax, ay) = (cfg.axes[0], cfg.axes[1]);
    let (xs, ys) = (ax.values(), ay.values());
    let (nx, ny) = (xs.len(), ys.len());
    let value = |r: &PointResult| match &r.metrics {
        Ok(m) => m.final_amplitude_deg.unwrap_or(f64::NAN),
        Err(_) => f64::NAN,
    };
    // the slice with every further axis at its first value
    let grid: Vec<Vec<f64>> = (0..ny)
        .map(|j| (0..nx).map(|i| value(&results[i + nx * j])).collect())
        .collect();
    let vmax = grid
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold(1.0, f64::max);
    // smallest swept value of axis 2 that ends in sway, per value of axis 1
    let threshold: Vec<(f64, Option<f64>)> = (0..nx)
        .map(|i| (xs[i], (0..ny).find(|&j| grid[j][i] >= thr).map(|j| ys[j])))
        .collect();
    let mut p = Panel::new(
        &format!(
            "{}: final sway amplitude (max |θ| over the last {} s)",
            cfg.name,
            cfg.base.settings.metrics.final_window_s.get()
        ),
        ax.parameter.label(),
        ay.parameter.label(),
    )
    .with(Layer::Heatmap {
        x_edges: edges(&xs),
        y_edges: edges(&ys),
        values: grid,
        range: (0.0, vmax),
        label: "final amplitude [deg] (grey: loss of control / failed)".into(),
    })
    .legend(Legend::UpperRight);
    let line: Vec<(f64, f64)> = threshold
        .iter()
        .filter_map(|&(x, y)| y.map(|y| (x, y)))
        .collect();
    if !line.is_empty() {
        p.layers.push(Layer::line(
            line,
            Rgb::RED,
            Stroke::Solid,
            Some(&format!(
                "smallest {} ending in sway (≥ {thr}°)",
                ay.parameter.as_str()
            )),
        ));
    }
    Figure::single(p).render(&out.path("heatmap"))?;
    let y_key = format!("min_{}_for_sway", ay.parameter.as_str());
    let summary = HeatmapSummary {
        heatmap_axes: [ax.parameter.as_str(), ay.parameter.as_str()],
        threshold: threshold
            .iter()
            .map(|&(x, y)| ThresholdPoint {
                x: (ax.parameter.as_str(), x),
                y: (y_key.clone(), y),
            })
            .collect(),
    };
    let line = threshold
        .iter()
        .find_map(|&(x, y)| y.map(|y| (x, y)))
        .map(|(x, y)| {
            format!(
                "lowest {} with sway: {x:.3}, from {} = {y:.3}",
                ax.parameter.as_str(),
                ay.parameter.as_str()
            )
        });
    Ok(Some((summary, line)))
}

impl Prepared for Configured<SweepConfig> {
    fn plan(&self) -> Result<Plan, SwayError> {
        let c = &self.config;
        let file = self.file.as_path();
        let mut sims = 1.0_f64;
        for (i, a) in c.axes.iter().enumerate() {
            bound(
                file,
                &format!("axes[{i}].points"),
                a.points as f64,
                MAX_AXIS_POINTS as f64,
                || format!("{} simulations on this axis alone", a.points),
            )?;
            sims *= a.points as f64;
        }
        let settle = settle_s(&c.base.initial);
        bound(file, "base.initial.settle_s", settle, MAX_SIMULATED_S, || {
            format!("{} per simulation", human_seconds(settle * SWEEP_SECONDS_PER_SIM_SECOND))
        })?;
        let horizon = c.base.horizon_s.get();
        bound(file, "base.horizon_s", horizon, MAX_SIMULATED_S, || {
            format!("{} per simulation", human_seconds(horizon * SWEEP_SECONDS_PER_SIM_SECOND))
        })?;
        let per_sim = (horizon + settle) * SWEEP_SECONDS_PER_SIM_SECOND;
        let plan = Plan::new(
            vec![format!(
                "{}: {} axes, {sims} simulations of {horizon} s (+ {settle} s settling)",
                c.name,
                c.axes.len()
            )],
            sims * BYTES_PER_ROW,
            sims * per_sim / 2.0, // rayon on 2 cores
        );
        plan.within(file, "axes", sims, MAX_SIMULATIONS, || {
            format!("product of the axis points = {sims} simulations")
        })
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let cfg = &self.config;
        let out = OutputDir::create(&ctx.results_dir, &cfg.name)?;
        let results: Vec<PointResult> = run_sweep(&ctx.model, cfg, ctx.progress);
        write_sweep_outputs(ctx, cfg, &self.file, &results, out)
    }
}

/// Writes `sweep.csv`, the heat map and `summary.json` of the sweep `cfg` (from the config
/// file `file`) from the ordered full list of its point results into `out`, and commits
/// it: the one writer of an unsharded run and of a merge of shards
/// ([`crate::shard::merge_dir`]), so both write the same bytes.
///
/// # Errors
/// [`SwayError::Write`] / [`SwayError::Plot`].
pub fn write_sweep_outputs(
    ctx: &TaskContext<'_>,
    cfg: &SweepConfig,
    file: &Path,
    results: &[PointResult],
    out: OutputDir,
) -> Result<Report, SwayError> {
    let header = SweepRow::header(&cfg.axes);
    let rows = results.iter().map(|r| SweepRow {
        values: &r.values,
        metrics: r.metrics.as_ref().map_err(String::as_str),
        accepted_steps: r.steps,
    });
    out.write_rows("sweep.csv", &header, rows)?;

    let n_ok = results
        .iter()
        .filter(|r| matches!(&r.metrics, Ok(m) if m.outcome == Outcome::Ok))
        .count();
    let n_lost = results
        .iter()
        .filter(|r| matches!(&r.metrics, Ok(m) if m.outcome == Outcome::LossOfControl))
        .count();
    let n_err = results.iter().filter(|r| r.metrics.is_err()).count();
    let thr = cfg.base.settings.metrics.settle_threshold_deg.get();
    let n_sway = results
        .iter()
        .filter(
            |r| matches!(&r.metrics, Ok(m) if m.final_amplitude_deg.is_some_and(|a| a >= thr)),
        )
        .count();
    let mut summary = SweepSummary {
        points: results.len(),
        points_ok: n_ok,
        points_loss_of_control: n_lost,
        points_failed: n_err,
        points_with_sway: n_sway,
        sway_threshold_deg: thr,
        heatmap: None,
    };
    let mut lines = vec![format!(
        "{}: {} points: {n_ok} ok ({n_sway} end in sway, final amplitude >= {thr}°), {n_lost} loss of control, {n_err} failed",
        cfg.name,
        results.len()
    )];

    if let Some((heatmap, line)) = heatmap(&out, cfg, results, thr)? {
        summary.heatmap = Some(heatmap);
        lines.extend(line);
    }
    ctx.conclude(out, summary, cfg, file, lines)
}
