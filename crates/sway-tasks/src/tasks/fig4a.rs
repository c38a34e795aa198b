//! `cargo xtask fig4a`: stability charts of the delayed yaw-rate feedback in the (V, D) plane
//! for several delays (paper Fig. 4(a)).

use std::path::Path;

use serde::{Deserialize, Serialize};
use stability::{Axis, ChartOptions, StabilityChart};
use crate::TaskError;
use sway::charts::{critical_speed_at_gain, fig4a_charts, stable_gain_intervals};
use sway::config::ensure;
use trailer_model::CriticalSpeedOptions;

use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::{Configured, TaskConfig, check_delays};
use crate::figures::chart_panel;
use crate::io::{Keyed, OutputDir};
use crate::limits::{
    FIG4A_BYTES_PER_CELL, FIG4A_SECONDS_PER_CELL, MAX_AXIS_POINTS, MAX_CHART_CELLS, Plan, bound,
    human_bytes,
};
use crate::plot::Figure;

/// The task.
pub const TASK: Task = Task::configured::<Fig4aConfig>(
    "fig4a",
    "stability charts in the (V, D) plane for several delays τ (Fig. 4a)",
    "fig4a.toml",
);

/// Speed axis \[m/s\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedAxis {
    /// lower edge \[m/s\]
    pub min_mps: f64,
    /// upper edge \[m/s\]
    pub max_mps: f64,
    /// number of cells
    pub cells: usize,
}

/// Gain axis \[s\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainAxis {
    /// lower edge \[s\]
    pub min_s: f64,
    /// upper edge \[s\]
    pub max_s: f64,
    /// number of cells
    pub cells: usize,
}

/// Where the headline numbers are taken.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SummaryConfig {
    /// gain of `v_crit_at_d_0.1_mps` \[s\]
    pub gain_for_critical_speed_s: f64,
    /// speed of `stable_d_interval_at_v_35` \[m/s\]
    pub speed_for_gain_interval_mps: f64,
    /// bisection tolerance of the critical speed \[m/s\]
    pub speed_tolerance_mps: f64,
}

impl Default for SummaryConfig {
    fn default() -> Self {
        Self {
            gain_for_critical_speed_s: 0.1,
            speed_for_gain_interval_mps: 35.0,
            speed_tolerance_mps: 1e-9,
        }
    }
}

/// Numerical settings of the charts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NumericsConfig {
    /// fresh spectral seed every this many cells along D
    pub reseed_interval: usize,
    /// rightmost roots followed from cell to cell
    pub tracked_roots: usize,
}

impl Default for NumericsConfig {
    fn default() -> Self {
        let o = ChartOptions::default();
        Self {
            reseed_interval: o.reseed_interval,
            tracked_roots: o.tracked_roots,
        }
    }
}

/// `configs/fig4a.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig4aConfig {
    /// speed axis
    pub speed: SpeedAxis,
    /// gain axis
    pub gain: GainAxis,
    /// delays τ \[s\], one panel each
    pub delays_s: Vec<f64>,
    /// headline numbers
    #[serde(default)]
    pub summary: SummaryConfig,
    /// numerics
    #[serde(default)]
    pub numerics: NumericsConfig,
}

/// Checks the chart axis `key` with (min, max, cells): `range_ok` (else "expected
/// `expected`, got min and max" under `key`) and at least 2 cells (under `key.cells`).
fn check_axis(
    file: &Path,
    key: &str,
    (min, max, cells): (f64, f64, usize),
    range_ok: bool,
    expected: &str,
) -> Result<(), TaskError> {
    ensure(range_ok, file, key, || {
        format!("expected {expected}, got {min} and {max}")
    })?;
    Ok(ensure(cells >= 2, file, &format!("{key}.cells"), || {
        format!("expected ≥ 2, got {cells}")
    })?)
}

impl Fig4aConfig {
    /// The speed axis.
    pub fn speed_axis(&self) -> Axis {
        Axis {
            min: self.speed.min_mps,
            max: self.speed.max_mps,
            count: self.speed.cells,
        }
    }
    /// The gain axis.
    pub fn gain_axis(&self) -> Axis {
        Axis {
            min: self.gain.min_s,
            max: self.gain.max_s,
            count: self.gain.cells,
        }
    }
    /// Chart options.
    pub fn chart_options(&self) -> ChartOptions {
        ChartOptions {
            reseed_interval: self.numerics.reseed_interval,
            tracked_roots: self.numerics.tracked_roots,
            ..ChartOptions::default()
        }
    }

    /// Checks the config; errors name the key.
    ///
    /// # Errors
    /// [`TaskError::Config`].
    pub fn validate(&self, file: &Path) -> Result<(), TaskError> {
        let s = &self.speed;
        let speed_ok = s.min_mps >= 0.0 && s.max_mps > s.min_mps && s.max_mps.is_finite();
        let speed = (s.min_mps, s.max_mps, s.cells);
        check_axis(file, "speed", speed, speed_ok, "0 ≤ min_mps < max_mps")?;
        let g = &self.gain;
        let gain_ok = g.min_s.is_finite() && g.max_s.is_finite() && g.min_s < g.max_s;
        check_axis(file, "gain", (g.min_s, g.max_s, g.cells), gain_ok, "finite min_s < max_s")?;
        check_delays(file, "delays_s", &self.delays_s)?;
        let m = &self.summary;
        ensure(
            m.speed_for_gain_interval_mps > 0.0 && m.speed_for_gain_interval_mps.is_finite(),
            file,
            "summary.speed_for_gain_interval_mps",
            || {
                format!(
                    "expected a positive speed, got {}",
                    m.speed_for_gain_interval_mps
                )
            },
        )?;
        ensure(
            m.gain_for_critical_speed_s.is_finite(),
            file,
            "summary.gain_for_critical_speed_s",
            || "expected a finite gain".into(),
        )?;
        ensure(
            m.speed_tolerance_mps > 0.0 && m.speed_tolerance_mps < 1e-2,
            file,
            "summary.speed_tolerance_mps",
            || {
                format!(
                    "expected 0 < tolerance < 0.01 m/s, got {}",
                    m.speed_tolerance_mps
                )
            },
        )?;
        let n = &self.numerics;
        for (key, count) in [
            ("numerics.reseed_interval", n.reseed_interval),
            ("numerics.tracked_roots", n.tracked_roots),
        ] {
            ensure(count >= 1, file, key, || "expected ≥ 1".into())?;
        }
        Ok(())
    }
}

impl TaskConfig for Fig4aConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        self.validate(file)
    }
}

/// Headline numbers of one chart.
#[derive(Debug, Clone, PartialEq)]
pub struct ChartSummary {
    /// delay \[s\]
    pub delay_s: f64,
    /// lowest speed at which the summary gain is unstable \[m/s\]
    pub v_crit_at_gain_mps: Option<f64>,
    /// stable gain intervals at the summary speed \[s\]
    pub stable_gain_intervals: Vec<(f64, f64)>,
}

/// Computes the charts and the headline numbers (no I/O): the whole Fig. 4(a) computation,
/// also used by the benchmark.
///
/// # Errors
/// [`sway::SwayError::Numerical`].
pub fn compute(
    model: &trailer_model::Model,
    cfg: &Fig4aConfig,
) -> Result<(Vec<StabilityChart>, Vec<ChartSummary>), TaskError> {
    let charts = fig4a_charts(
        model,
        &cfg.delays_s,
        cfg.speed_axis(),
        cfg.gain_axis(),
        &cfg.chart_options(),
    )?;
    let s = &cfg.summary;
    let v_lo = cfg.speed_axis().values()[0];
    let mut summaries = Vec::new();
    for &tau in &cfg.delays_s {
        let v_crit = critical_speed_at_gain(
            model,
            tau,
            s.gain_for_critical_speed_s,
            v_lo,
            cfg.speed.max_mps,
            cfg.speed.cells,
            s.speed_tolerance_mps,
        )?;
        let intervals = stable_gain_intervals(
            model,
            tau,
            s.speed_for_gain_interval_mps,
            cfg.gain.min_s,
            cfg.gain.max_s,
        )?;
        summaries.push(ChartSummary {
            delay_s: tau,
            v_crit_at_gain_mps: v_crit,
            stable_gain_intervals: intervals,
        });
    }
    Ok((charts, summaries))
}

/// Stable gain intervals as `summary.json` writes them: one interval as `[lo, hi]`, several
/// (or none) as a list of intervals.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum GainIntervals {
    /// exactly one interval \[s\]
    One([f64; 2]),
    /// none, or several \[s\]
    Many(Vec<[f64; 2]>),
}

impl From<&[(f64, f64)]> for GainIntervals {
    fn from(iv: &[(f64, f64)]) -> Self {
        match iv {
            [one] => Self::One([one.0, one.1]),
            many => Self::Many(many.iter().map(|x| [x.0, x.1]).collect()),
        }
    }
}

/// One delay's entry of `"per_tau"` in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DelayEntry {
    /// the delay τ \[s\]
    pub tau_s: f64,
    /// one key, `v_crit_at_d_<D>_mps` for the configured gain D: the lowest speed at which
    /// D is unstable \[m/s\] (null: stable on the whole speed range)
    #[serde(flatten)]
    pub v_crit_at_gain: Keyed<Option<f64>>,
    /// one key, `stable_d_interval_at_v_<V>` for the configured speed V: the stable gains
    #[serde(flatten)]
    pub stable_gains_at_speed: Keyed<GainIntervals>,
    /// fraction of the chart's cells that are stable
    pub stable_cell_fraction: f64,
    /// cells whose roots were computed afresh instead of tracked
    pub reseeded_cells: usize,
    /// cells whose roots could not be confirmed
    pub failed_cells: usize,
}

/// `summary.json` of fig4a (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fig4aSummary {
    /// V_crit of the open loop \[m/s\]
    pub open_loop_v_crit_mps: f64,
    /// one entry per delay, in the config's order
    pub per_tau: Vec<DelayEntry>,
    /// cells of each chart
    pub grid_cells_per_tau: usize,
}

/// The CSV tables of one chart: the grid, the dynamic and the static boundaries.
fn write_chart(out: &OutputDir, ch: &StabilityChart) -> Result<(), TaskError> {
    let rows: Vec<[f64; 4]> =
        ch.v.iter()
            .enumerate()
            .flat_map(|(iv, &v)| {
                ch.d.iter().enumerate().map(move |(id, &d)| {
                    let c = ch.cell(iv, id);
                    [v, d, c.spectral_abscissa, c.unstable_roots as f64]
                })
            })
            .collect();
    out.write_csv(
        &format!("grid_tau_{}.csv", ch.tau),
        &["v_mps", "d_s", "spectral_abscissa_per_s", "unstable_roots"],
        &rows,
    )?;
    let boundary_rows = |lines: &[stability::Polyline]| -> Vec<[f64; 4]> {
        lines
            .iter()
            .enumerate()
            .flat_map(|(k, l)| l.points.iter().map(move |p| [k as f64, p.v, p.d, p.omega]))
            .collect()
    };
    out.write_csv(
        &format!("dynamic_boundary_tau_{}.csv", ch.tau),
        &["branch", "v_mps", "d_s", "omega_rad_s"],
        boundary_rows(&ch.dynamic_boundaries),
    )?;
    out.write_csv(
        &format!("static_boundary_tau_{}.csv", ch.tau),
        &["branch", "v_mps", "d_s", "omega_rad_s"],
        boundary_rows(&ch.static_boundary),
    )
}

/// The figure: one panel per τ, the τ = 0 dynamic boundary dotted on the others.
fn draw(out: &OutputDir, cfg: &Fig4aConfig, charts: &[StabilityChart]) -> Result<(), TaskError> {
    let reference = charts.iter().find(|c| c.tau == 0.0);
    let (sa, ga) = (cfg.speed_axis(), cfg.gain_axis());
    let panels: Vec<_> = charts
        .iter()
        .map(|c| chart_panel(c, reference, &sa, &ga))
        .collect();
    let n = panels.len();
    let cols = if n <= 1 { 1 } else { 2 };
    let rows = n.div_ceil(cols);
    Figure::grid(panels, rows, cols, (1200, 450 * rows as u32))
        .titled("Stability of straight running under yaw-rate feedback δ(t) = −D·dψ/dt(t − τ)")
        .render(&out.path("fig4a"))
}

/// The `"per_tau"` entries and their printed lines.
fn delay_entries(
    cfg: &Fig4aConfig,
    summaries: &[ChartSummary],
    charts: &[StabilityChart],
) -> (Vec<DelayEntry>, Vec<String>) {
    let gain_key = format!("v_crit_at_d_{}_mps", cfg.summary.gain_for_critical_speed_s);
    let v_key = format!(
        "stable_d_interval_at_v_{}",
        cfg.summary.speed_for_gain_interval_mps
    );
    let mut entries = Vec::new();
    let mut lines = Vec::new();
    for (s, ch) in summaries.iter().zip(charts) {
        let stable = ch.cells.iter().filter(|c| c.is_stable()).count();
        let intervals = GainIntervals::from(s.stable_gain_intervals.as_slice());
        lines.push(format!(
            "τ = {} s: {gain_key} = {}, {v_key} = {}{}",
            s.delay_s,
            s.v_crit_at_gain_mps
                .map_or("stable on the range".to_string(), |v| format!("{v:.4}")),
            serde_json::to_string(&intervals).unwrap_or_default(),
            if ch.failures.is_empty() {
                String::new()
            } else {
                format!(" ({} cells failed)", ch.failures.len())
            }
        ));
        entries.push(DelayEntry {
            tau_s: s.delay_s,
            v_crit_at_gain: Keyed(vec![(gain_key.clone(), s.v_crit_at_gain_mps)]),
            stable_gains_at_speed: Keyed(vec![(v_key.clone(), intervals)]),
            stable_cell_fraction: stable as f64 / ch.cells.len() as f64,
            reseeded_cells: ch.reseeds,
            failed_cells: ch.failures.len(),
        });
    }
    (entries, lines)
}

impl Prepared for Configured<Fig4aConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let file = self.file.as_path();
        let axis_cost = |n: usize| {
            move || format!("≈ {} per delay at the other axis' size", human_bytes(n as f64 * 200.0 * FIG4A_BYTES_PER_CELL))
        };
        bound(file, "speed.cells", c.speed.cells as f64, MAX_AXIS_POINTS as f64, axis_cost(c.speed.cells))?;
        bound(file, "gain.cells", c.gain.cells as f64, MAX_AXIS_POINTS as f64, axis_cost(c.gain.cells))?;
        let cells = c.speed.cells as f64 * c.gain.cells as f64 * c.delays_s.len() as f64;
        let plan = Plan::new(
            vec![format!(
                "fig4a: {} speed × {} gain cells × {} delays = {cells} chart cells",
                c.speed.cells,
                c.gain.cells,
                c.delays_s.len()
            )],
            cells * FIG4A_BYTES_PER_CELL,
            cells * FIG4A_SECONDS_PER_CELL,
        );
        plan.within(file, "speed.cells", cells, MAX_CHART_CELLS, || {
            format!("speed × gain × delays = {cells} cells")
        })
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress.start("fig4a: charts", 3);
        let (charts, summaries) = compute(&ctx.model, cfg)?;
        ctx.progress.advance(1);
        for ch in &charts {
            write_chart(&out, ch)?;
        }
        ctx.progress.advance(1);
        draw(&out, cfg, &charts)?;
        ctx.progress.advance(1);
        let vc = ctx.model.critical_speed(&CriticalSpeedOptions::default())?;
        let (per_tau, delay_lines) = delay_entries(cfg, &summaries, &charts);
        let mut lines = vec![format!("open-loop V_crit = {:.4} m/s", vc.v_crit_mps)];
        lines.extend(delay_lines);
        let summary = Fig4aSummary {
            open_loop_v_crit_mps: vc.v_crit_mps,
            per_tau,
            grid_cells_per_tau: cfg.speed.cells * cfg.gain.cells,
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
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/fig4a.toml");
        let text = std::fs::read_to_string(&file).unwrap();
        (file, text)
    }

    #[test]
    fn shipped_config_is_valid_and_as_the_issue_asks() {
        let (file, text) = shipped();
        let cfg: Fig4aConfig = parse_toml(&text, &file).unwrap();
        cfg.validate(&file).unwrap();
        assert!(cfg.speed.cells >= 300 && cfg.gain.cells >= 200);
        assert_eq!(cfg.delays_s, vec![0.0, 0.1, 0.2, 0.4]);
        assert_eq!((cfg.speed.min_mps, cfg.speed.max_mps), (0.0, 60.0));
        assert_eq!((cfg.gain.min_s, cfg.gain.max_s), (-0.5, 0.5));
    }

    #[test]
    fn bad_values_name_their_key() {
        let (file, text) = shipped();
        let bad = text.replace("delays_s = [0.0, 0.1, 0.2, 0.4]", "delays_s = [0.0, -0.1]");
        let cfg: Fig4aConfig = parse_toml(&bad, &file).unwrap();
        let e = cfg.validate(&file).unwrap_err().to_string();
        assert!(e.contains("delays_s[1]"), "{e}");
        let unknown = text.replace("[numerics]", "[numerics]\nfoo = 1");
        let e = parse_toml::<Fig4aConfig>(&unknown, &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("foo"), "{e}");
    }
}
