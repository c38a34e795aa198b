//! `cargo xtask sweep FILE.toml`: a grid of simulations in parallel (rayon) over any of
//! V, θ(0), D, τ and the braking time T; one CSV row per grid point with the metrics
//! (a failed point says why in its row), a heat map of the final sway amplitude over the
//! first two axes, and `summary.json`. Same numbers whatever the thread count.

use std::path::{Path, PathBuf};

use serde_json::{Map, json};

use super::{Prepared, Report, Task, TaskContext};
use crate::SwayError;
use crate::config::load_toml;
use crate::io::{OutputDir, fmt_num};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::sim::sweep::{PointResult, SweepConfig, run_sweep};

/// The task (its default config is the bistability threshold map).
pub const TASK: Task = Task {
    name: "sweep",
    about: "parallel grid of simulations (TOML); default: which perturbations trigger sway",
    config: "sweep_threshold.toml",
    prepare,
};

/// The same sweep runner on `configs/sweep_brake_timing.toml`: when braking from sway
/// loses control (beyond the paper), so that `cargo xtask all` regenerates it too.
pub const BRAKE_TIMING: Task = Task {
    name: "brake_timing",
    about: "sweep of braking start t_b × duration T from sway: where braking loses control (beyond the paper)",
    config: "sweep_brake_timing.toml",
    prepare,
};

struct SweepTask {
    file: PathBuf,
    config: SweepConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let config: SweepConfig = load_toml(file)?;
    config.validate(file)?;
    Ok(Box::new(SweepTask {
        file: file.to_path_buf(),
        config,
    }))
}

fn csv_escape(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "'").replace(['\n', '\r'], " "))
}

fn opt(x: Option<f64>) -> String {
    x.map_or(String::new(), fmt_num)
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

impl Prepared for SweepTask {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let cfg = &self.config;
        let out = OutputDir::create(&ctx.results_dir, &cfg.name)?;
        let results: Vec<PointResult> = run_sweep(&ctx.model, cfg, ctx.progress);

        // the table
        let mut header: Vec<&str> = cfg.axes.iter().map(|a| a.parameter.as_str()).collect();
        header.extend([
            "peak_theta_deg_after_action",
            "final_amplitude_deg",
            "settle_time_s",
            "outcome",
            "loss_of_control_time_s",
            "loss_of_control_condition",
            "accepted_steps",
            "error",
        ]);
        let rows: Vec<Vec<String>> = results
            .iter()
            .map(|r| {
                let mut row: Vec<String> = r.values.iter().map(|&v| fmt_num(v)).collect();
                match &r.metrics {
                    Ok(m) => row.extend([
                        opt(m.peak_theta_deg_after_action),
                        opt(m.final_amplitude_deg),
                        opt(m.settle_time_s),
                        m.outcome.as_str().to_string(),
                        opt(m.loss_of_control_time_s),
                        m.loss_of_control_condition
                            .map_or(String::new(), |c| c.as_str().to_string()),
                        r.steps.to_string(),
                        String::new(),
                    ]),
                    Err(e) => row.extend([
                        String::new(),
                        String::new(),
                        String::new(),
                        "error".to_string(),
                        String::new(),
                        String::new(),
                        "0".to_string(),
                        csv_escape(e),
                    ]),
                }
                row
            })
            .collect();
        out.write_csv_cells("sweep.csv", &header, &rows)?;

        let n_ok = results
            .iter()
            .filter(|r| matches!(&r.metrics, Ok(m) if m.outcome == crate::sim::Outcome::Ok))
            .count();
        let n_lost = results
            .iter()
            .filter(
                |r| matches!(&r.metrics, Ok(m) if m.outcome == crate::sim::Outcome::LossOfControl),
            )
            .count();
        let n_err = results.iter().filter(|r| r.metrics.is_err()).count();
        let thr = cfg.base.metrics.settle_threshold_deg;
        let n_sway = results
            .iter()
            .filter(
                |r| matches!(&r.metrics, Ok(m) if m.final_amplitude_deg.is_some_and(|a| a >= thr)),
            )
            .count();
        let mut summary = Map::new();
        summary.insert("points".into(), json!(results.len()));
        summary.insert("points_ok".into(), json!(n_ok));
        summary.insert("points_loss_of_control".into(), json!(n_lost));
        summary.insert("points_failed".into(), json!(n_err));
        summary.insert("points_with_sway".into(), json!(n_sway));
        summary.insert("sway_threshold_deg".into(), json!(thr));
        let mut lines = vec![format!(
            "{}: {} points: {n_ok} ok ({n_sway} end in sway, final amplitude >= {thr}°), {n_lost} loss of control, {n_err} failed",
            cfg.name,
            results.len()
        )];

        // heat map over the first two axes (first axis fastest in the grid order)
        if cfg.axes.len() >= 2 {
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
                    cfg.name, cfg.base.metrics.final_window_s
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
            summary.insert(
                "heatmap_axes".into(),
                json!([ax.parameter.as_str(), ay.parameter.as_str()]),
            );
            summary.insert(
                "threshold".into(),
                json!(threshold
                    .iter()
                    .map(|&(x, y)| json!({ ax.parameter.as_str(): x, format!("min_{}_for_sway", ay.parameter.as_str()): y }))
                    .collect::<Vec<_>>()),
            );
            if let Some((x, Some(y))) = threshold.iter().find(|(_, y)| y.is_some()) {
                lines.push(format!(
                    "lowest {} with sway: {x:.3}, from {} = {y:.3}",
                    ax.parameter.as_str(),
                    ay.parameter.as_str()
                ));
            }
        }
        out.write_summary(summary, cfg, &ctx.run_info(&self.file))?;
        let dir = out.commit()?;
        Ok(Report {
            task: cfg.name.clone(),
            output_dir: dir,
            lines,
        })
    }
}
