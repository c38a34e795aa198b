//! `cargo xtask fleet`: the headline numbers of every task for each
//! vehicle file of `configs/fleet/` ([`sway_studies::fleet`]): V_crit, the fold of cycles, the
//! width of the bistable range, the best gain D\* at τ = 0.2 s and the θ(0) threshold of
//! sway at the middle of the bistable range. `summary.json`: `"vehicles"` (one entry per
//! file, every null with its reason), `fleet.csv` (one row per file) and `fleet.md` (the
//! table of the `fleet` page of the guide). A file may be a vehicle with model variants: its
//! numbers are those of its own plant.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sway_studies::fleet::{FleetEntry, FleetOptions, fleet_entry};
use trailer_model::AnyVehicleModel;

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig, load_vehicle_spec};

/// The task.
pub const TASK: Task = Task::configured::<FleetConfig>(
    "fleet",
    "headline numbers of every task (V_crit, fold, bistable width, D* at τ = 0.2 s, threshold) for each vehicle file of configs/fleet/",
    "fleet.toml",
)
.any_model();

/// `configs/fleet.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FleetConfig {
    /// the vehicle files, relative to this file's directory
    pub files: Vec<PathBuf>,
    /// what is computed for each
    #[serde(default)]
    pub headline: FleetOptions,
}

impl TaskConfig for FleetConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        if self.files.is_empty() {
            return Err(TaskError::config(file, "files", "expected at least one vehicle file"));
        }
        let h = &self.headline;
        let [min, max, points] = h.theta0_deg;
        if !(min > 0.0 && max > min && max < 90.0 && (2.0..=200.0).contains(&points)) {
            return Err(TaskError::config(
                file,
                "headline.theta0_deg",
                format!("expected [min, max, points] with 0 < min < max < 90 deg and 2 to 200 points, got {:?}", h.theta0_deg),
            ));
        }
        if !(h.delay_s.is_finite() && h.delay_s >= 0.0) {
            return Err(TaskError::config(file, "headline.delay_s", format!("expected a delay ≥ 0 s, got {}", h.delay_s)));
        }
        if !h.threshold_in_bistable.is_finite() {
            return Err(TaskError::config(file, "headline.threshold_in_bistable", "expected a finite number"));
        }
        Ok(())
    }
}

/// One vehicle of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FleetRow {
    /// the vehicle file as written in the config
    pub vehicle_file: String,
    /// its headline numbers
    #[serde(flatten)]
    pub entry: FleetEntry,
}

/// `summary.json` of the fleet table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FleetSummary {
    /// one entry per vehicle file, in the config's order
    pub vehicles: Vec<FleetRow>,
}

/// One row of `fleet.csv`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct CsvRow {
    /// the vehicle file
    pub vehicle_file: String,
    /// V_crit \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// stable up to \[m/s\]
    pub stable_up_to_mps: Option<f64>,
    /// V_fold \[m/s\]
    pub v_fold_mps: Option<f64>,
    /// V_crit − V_fold \[m/s\]
    pub bistable_width_mps: Option<f64>,
    /// D\* \[s\]
    pub d_opt_s: Option<f64>,
    /// V_crit(D\*) \[m/s\]
    pub v_crit_at_d_opt_mps: Option<f64>,
    /// V of the threshold \[m/s\]
    pub threshold_speed_mps: Option<f64>,
    /// θ(0) threshold \[deg\]
    pub theta0_threshold_deg: Option<f64>,
    /// why some are empty
    pub reasons: String,
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.digits$}"))
}

/// The markdown table of the `fleet` page of the guide.
pub fn markdown(rows: &[FleetRow], delay_s: f64) -> String {
    let mut s = format!(
        "| vehicle file | V_crit [m/s] | V_fold [m/s] | bistable width [m/s] | D* at τ = {delay_s} s [s] (V_crit there [m/s]) | θ(0) threshold at the bistable midpoint [deg] (at V [m/s]) |\n|---|---|---|---|---|---|\n"
    );
    for r in rows {
        let e = &r.entry;
        let vc = match (e.v_crit_mps, e.stable_up_to_mps) {
            // a real eigenvalue crosses: a static divergence, not sway
            (Some(v), _) if e.hopf_frequency_hz == Some(0.0) => {
                format!("{v:.3} (static divergence, ω = 0)")
            }
            (Some(v), _) => format!("{v:.3}"),
            (None, Some(m)) => format!("none (stable up to {m} m/s)"),
            (None, None) => "–".into(),
        };
        s.push_str(&format!(
            "| `{}` | {vc} | {} | {} | {} ({}) | {} ({}) |\n",
            r.vehicle_file,
            cell(e.v_fold_mps, 3),
            cell(e.bistable_width_mps, 3),
            cell(e.d_opt_s, 4),
            cell(e.v_crit_at_d_opt_mps, 2),
            cell(e.theta0_threshold_deg, 2),
            cell(e.threshold_speed_mps, 2),
        ));
    }
    s
}

impl Prepared for Configured<FleetConfig> {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let dir = self.file.parent().unwrap_or(Path::new("."));
        let models = cfg
            .files
            .iter()
            .map(|f| load_vehicle_spec(&dir.join(f)).map(|v| v.plant))
            .collect::<Result<Vec<AnyVehicleModel>, _>>()?;
        let steps = models.len() as u64;
        ctx.run_staged(TASK.name, "fleet: headline numbers per vehicle file", steps, cfg, &self.file, |out| {
            let entries: Vec<Result<FleetEntry, sway::SwayError>> = models
                .par_iter()
                .map(|m| {
                    let e = fleet_entry(m, &ctx.limits, &cfg.headline);
                    ctx.progress.advance(1);
                    e
                })
                .collect();
            let mut rows = Vec::with_capacity(entries.len());
            for (f, e) in cfg.files.iter().zip(entries) {
                rows.push(FleetRow {
                    vehicle_file: f.display().to_string(),
                    entry: e?,
                });
            }
            out.write_table(
                "fleet.csv",
                rows.iter().map(|r| CsvRow {
                    vehicle_file: r.vehicle_file.clone(),
                    v_crit_mps: r.entry.v_crit_mps,
                    stable_up_to_mps: r.entry.stable_up_to_mps,
                    v_fold_mps: r.entry.v_fold_mps,
                    bistable_width_mps: r.entry.bistable_width_mps,
                    d_opt_s: r.entry.d_opt_s,
                    v_crit_at_d_opt_mps: r.entry.v_crit_at_d_opt_mps,
                    threshold_speed_mps: r.entry.threshold_speed_mps,
                    theta0_threshold_deg: r.entry.theta0_threshold_deg,
                    reasons: r.entry.reasons.join("; "),
                }),
            )?;
            let md = markdown(&rows, cfg.headline.delay_s);
            std::fs::write(out.path("fleet.md"), &md).map_err(|source| TaskError::Write {
                path: out.path("fleet.md"),
                source,
            })?;
            let lines = rows
                .iter()
                .map(|r| {
                    let e = &r.entry;
                    let mut l = format!(
                        "{}: V_crit {}, V_fold {}, bistable width {}, D* {} s, θ(0) threshold {}°",
                        r.vehicle_file,
                        cell(e.v_crit_mps, 3),
                        cell(e.v_fold_mps, 3),
                        cell(e.bistable_width_mps, 3),
                        cell(e.d_opt_s, 4),
                        cell(e.theta0_threshold_deg, 2)
                    );
                    if !e.reasons.is_empty() {
                        l.push_str(&format!(" ({})", e.reasons.join("; ")));
                    }
                    l
                })
                .collect();
            Ok((FleetSummary { vehicles: rows }, lines))
        })
    }
}
