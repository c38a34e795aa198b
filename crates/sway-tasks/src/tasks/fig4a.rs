//! `cargo xtask fig4a`: stability charts of the delayed yaw-rate feedback in the (V, D) plane
//! for several delays (paper Fig. 4(a)).

use std::path::Path;

use serde::Serialize;
use stability::StabilityChart;
use crate::TaskError;
use sway::charts::auto_range::SpeedBounds;
use sway::charts::open_loop_stability;
pub use sway_studies::fig4a::{
    Fig4a, Fig4aConfig, Fig4aRanges, GainAxis, NumericsConfig, SpeedAxis, SummaryConfig, compute,
};
use sway::config::ensure;
use sway::ranging::{CappedSpeed, SpeedLimits};
use trailer_model::AnyVehicleModel;

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
)
.any_model();

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

/// Checks the config; errors name the key.
///
/// # Errors
/// [`TaskError::Config`].
pub fn validate(cfg: &Fig4aConfig, file: &Path) -> Result<(), TaskError> {
    if let Some(c) = &cfg.controller {
        c.check()
            .map_err(|m| TaskError::config(file, "controller.structure", m))?;
    }
    let s = &cfg.speed;
    let (v0, v1) = (s.min_mps.unwrap_or(0.0), s.max_mps.unwrap_or(f64::INFINITY));
    let speed_ok = v0 >= 0.0 && v1 > v0 && s.max_mps.is_none_or(f64::is_finite);
    check_axis(file, "speed", (v0, v1, s.cells), speed_ok, "0 ≤ min_mps < max_mps")?;
    let g = &cfg.gain;
    let (d0, d1) = (g.min_s.unwrap_or(f64::NEG_INFINITY), g.max_s.unwrap_or(f64::INFINITY));
    let finite = g.min_s.is_none_or(f64::is_finite) && g.max_s.is_none_or(f64::is_finite);
    check_axis(file, "gain", (d0, d1, g.cells), finite && d0 < d1, "finite min_s < max_s")?;
    check_delays(file, "delays_s", &cfg.delays_s)?;
    let m = &cfg.summary;
    if let Some(v) = m.speed_for_gain_interval_mps {
        ensure(v > 0.0 && v.is_finite(), file, "summary.speed_for_gain_interval_mps", || {
            format!("expected a positive speed, got {v}")
        })?;
    }
    if let Some(d) = m.gain_for_critical_speed_s {
        ensure(d.is_finite(), file, "summary.gain_for_critical_speed_s", || {
            "expected a finite gain".into()
        })?;
    }
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
    let n = &cfg.numerics;
    for (key, count) in [
        ("numerics.reseed_interval", n.reseed_interval),
        ("numerics.tracked_roots", n.tracked_roots),
    ] {
        ensure(count >= 1, file, key, || "expected ≥ 1".into())?;
    }
    Ok(())
}

impl TaskConfig for Fig4aConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        validate(self, file)
    }
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
    /// the summary gain keeps straight running stable up to this speed \[m/s\], the top of
    /// the speed axis (absent: its V_crit was found below it)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_up_to_mps: Option<f64>,
    /// one key, `stable_d_interval_at_v_<V>` for the configured speed V: the stable gains
    #[serde(flatten)]
    pub stable_gains_at_speed: Keyed<GainIntervals>,
    /// fraction of the chart's cells that are stable
    pub stable_cell_fraction: f64,
    /// cells whose roots were computed afresh instead of tracked
    pub reseeded_cells: usize,
    /// cells whose roots could not be confirmed
    pub failed_cells: usize,
    /// what the chart shows as a whole or why a number is null (all safe, stable at the
    /// summary gain up to the axis' top, no stabilising gain); absent: nothing to say
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// `summary.json` of fig4a (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fig4aSummary {
    /// V_crit of the open loop \[m/s\] (null: stable up to the maximum speed, see
    /// `open_loop`)
    pub open_loop_v_crit_mps: Option<f64>,
    /// the open loop is stable up to this speed \[m/s\] (absent: it is not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub open_loop_stable_up_to_mps: Option<f64>,
    /// why `open_loop_v_crit_mps` is null (absent: it is not)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub open_loop_reason: Option<String>,
    /// the axes and summary settings used (derived where the config omits them)
    pub ranges: Fig4aRanges,
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
fn draw(out: &OutputDir, r: &Fig4a) -> Result<(), TaskError> {
    let charts = &r.charts;
    let reference = charts.iter().find(|c| c.tau == 0.0);
    let (sa, ga) = (r.ranges.speed_mps.axis(), r.ranges.gain_s.axis());
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
fn delay_entries(r: &Fig4a) -> (Vec<DelayEntry>, Vec<String>) {
    let (summaries, charts) = (&r.summaries, &r.charts);
    let gain_key = format!("v_crit_at_d_{}_mps", r.ranges.gain_for_critical_speed_s);
    let v_key = format!(
        "stable_d_interval_at_v_{}",
        r.ranges.speed_for_gain_interval_mps
    );
    let mut entries = Vec::new();
    let mut lines = Vec::new();
    let top = r.ranges.speed_mps.max;
    for (s, ch) in summaries.iter().zip(charts) {
        let stable = ch.cells.iter().filter(|c| c.is_stable()).count();
        let intervals = GainIntervals::from(s.stable_gain_intervals.as_slice());
        let v_crit = CappedSpeed::of(s.v_crit_at_gain_mps, top);
        lines.push(format!(
            "τ = {} s: {}, {v_key} = {}{}{}",
            s.delay_s,
            v_crit.label(&gain_key, 4),
            serde_json::to_string(&intervals).unwrap_or_default(),
            if ch.failures.is_empty() {
                String::new()
            } else {
                format!(" ({} cells failed)", ch.failures.len())
            },
            s.reason.as_ref().map_or(String::new(), |r| format!(" — {r}"))
        ));
        entries.push(DelayEntry {
            tau_s: s.delay_s,
            v_crit_at_gain: Keyed(vec![(gain_key.clone(), s.v_crit_at_gain_mps)]),
            stable_up_to_mps: v_crit.stable_up_to(),
            stable_gains_at_speed: Keyed(vec![(v_key.clone(), intervals)]),
            stable_cell_fraction: stable as f64 / ch.cells.len() as f64,
            reseeded_cells: ch.reseeds,
            failed_cells: ch.failures.len(),
            reason: s.reason.clone(),
        });
    }
    (entries, lines)
}

/// The task's `summary.json` headline and printed lines of a computed chart set `r` of
/// `cfg` (the open loop searched on `plant` within `limits`, as `linear` reports it).
///
/// # Errors
/// When the open-loop critical-speed search fails numerically.
pub fn summarize(
    plant: &AnyVehicleModel,
    limits: &SpeedLimits,
    cfg: &Fig4aConfig,
    r: &Fig4a,
) -> Result<(Fig4aSummary, Vec<String>), TaskError> {
    // the open loop as `linear` reports it (the one V_crit search of every task)
    let open = open_loop_stability(plant, limits)?.summary();
    let (per_tau, delay_lines) = delay_entries(r);
    let mut lines = vec![match (open.v_crit_mps, &open.reason) {
        (Some(v), _) => format!("open-loop V_crit = {v:.4} m/s"),
        (None, why) => format!("open loop: {}", why.clone().unwrap_or_default()),
    }];
    let rg = &r.ranges;
    if !rg.derivation.derived_keys.is_empty() {
        lines.push(format!(
            "axes V in [{}, {}] m/s, D in [{}, {}] s; summary at D = {} s, V = {} m/s (derived from the vehicle: {})",
            rg.speed_mps.min,
            rg.speed_mps.max,
            rg.gain_s.min,
            rg.gain_s.max,
            rg.gain_for_critical_speed_s,
            rg.speed_for_gain_interval_mps,
            rg.derivation.derived_keys.join(", ")
        ));
    }
    lines.extend(delay_lines);
    let summary = Fig4aSummary {
        open_loop_v_crit_mps: open.v_crit_mps,
        open_loop_stable_up_to_mps: open.stable_up_to_mps,
        open_loop_reason: open.reason,
        ranges: r.ranges.clone(),
        per_tau,
        grid_cells_per_tau: cfg.speed.cells * cfg.gain.cells,
    };
    Ok((summary, lines))
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
        ctx.run_staged(TASK.name, "fig4a: charts", 3, cfg, &self.file, |out| {
            let bounds = SpeedBounds::from(&ctx.limits);
            let r = compute(&ctx.plant, cfg, &bounds)?;
            ctx.progress.advance(1);
            for ch in &r.charts {
                write_chart(out, ch)?;
            }
            ctx.progress.advance(1);
            draw(out, &r)?;
            ctx.progress.advance(1);
            let (summary, lines) = summarize(&ctx.plant, &ctx.limits, cfg, &r)?;
            Ok((summary, lines))
        })
    }
}
