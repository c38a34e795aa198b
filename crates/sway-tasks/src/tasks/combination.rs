//! `cargo xtask combination`: for each vehicle file of the config (the shipped combinations
//! of `configs/combinations/`; none listed: the `--vehicle`), V_crit and V_fold, every sway
//! mode, and at the test speed the heavy-vehicle metrics — rearward amplification and
//! high-speed transient offtracking in a single sine-steer lane change, the yaw damping of
//! every articulation ([`sway_studies::combination`]). Writes `summary.json`
//! (`combinations`), `combination.csv` (one row per file), `combination.md` (the README's
//! table), `modes.csv` and `lane_change.csv` (every file's, keyed by file) and the figures
//! `lane_change` (every unit's lateral acceleration, and the paths of the steered and the
//! rearmost axle) and `modes` (each mode's damping ratio against the speed).

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sway_studies::combination::{Combination, CombinationEntry, CombinationOptions, combination};
use trailer_model::AnyVehicleModel;

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig, load_vehicle_spec};
use crate::io::OutputDir;
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<CombinationConfig>(
    "combination",
    "heavy-vehicle metrics (rearward amplification, offtracking, yaw damping) beside V_crit, V_fold and every sway mode, for the combinations of configs/combinations/",
    "combination.toml",
)
.any_model();

/// `configs/combination.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CombinationConfig {
    /// the vehicle files, relative to this file's directory (empty: the `--vehicle`)
    #[serde(default)]
    pub files: Vec<PathBuf>,
    /// what is computed for each
    #[serde(default)]
    pub test: CombinationOptions,
}

impl TaskConfig for CombinationConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        let t = &self.test;
        let positive = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(TaskError::config(file, key, format!("expected a positive number, got {v}")))
            }
        };
        positive("test.test_speed_mps", t.test_speed_mps)?;
        positive("test.mode_speed_step_mps", t.mode_speed_step_mps)?;
        positive("test.lane_change.frequency_hz", t.lane_change.frequency_hz)?;
        positive(
            "test.lane_change.towing_unit_peak_lateral_acceleration_mps2",
            t.lane_change.towing_unit_peak_lateral_acceleration_mps2,
        )?;
        positive("test.lane_change.sample_step_s", t.lane_change.sample_step_s)?;
        positive("test.yaw_damping.duration_s", t.yaw_damping.duration_s)?;
        positive("test.yaw_damping.amplitude_deg", t.yaw_damping.amplitude_deg)?;
        positive("test.yaw_damping.after_s", t.yaw_damping.after_s)?;
        positive("test.yaw_damping.sample_step_s", t.yaw_damping.sample_step_s)?;
        if !(t.lane_change.start_s >= 0.0 && t.lane_change.after_s >= 0.0) {
            return Err(TaskError::config(file, "test.lane_change", "expected start_s ≥ 0 and after_s ≥ 0"));
        }
        if t.yaw_damping.periods == 0 {
            return Err(TaskError::config(file, "test.yaw_damping.periods", "expected at least one period"));
        }
        t.solver.validate_at(file, "test.solver").map_err(TaskError::from)
    }
}

/// One vehicle of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CombinationRow {
    /// the vehicle file as written in the config (or given by `--vehicle`)
    pub vehicle_file: String,
    /// its numbers
    #[serde(flatten)]
    pub entry: CombinationEntry,
}

/// `summary.json` of `combination`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CombinationSummary {
    /// one entry per vehicle file, in the config's order
    pub combinations: Vec<CombinationRow>,
}

/// One row of `combination.csv`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
struct CsvRow {
    vehicle_file: String,
    units: usize,
    v_crit_mps: Option<f64>,
    stable_up_to_mps: Option<f64>,
    v_fold_mps: Option<f64>,
    modes: usize,
    modes_losing_stability: usize,
    test_speed_mps: f64,
    rearward_amplification: Option<f64>,
    rearward_amplification_yaw_rate: Option<f64>,
    high_speed_transient_offtracking_m: Option<f64>,
    yaw_damping_ratio: Option<f64>,
    reasons: String,
}

/// One row of `modes.csv`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
struct ModeCsvRow {
    vehicle_file: String,
    mode: usize,
    speed_mps: f64,
    real_per_s: f64,
    frequency_hz: f64,
    damping_ratio: f64,
    leading_unit: usize,
}

/// One row of `lane_change.csv`: the towing and the rearmost unit.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
struct LaneChangeRow {
    vehicle_file: String,
    time_s: f64,
    steering_angle_deg: f64,
    towing_unit_lateral_acceleration_mps2: f64,
    rearmost_lateral_acceleration_mps2: f64,
    towing_unit_yaw_rate_deg_s: f64,
    rearmost_yaw_rate_deg_s: f64,
    steer_axle_x_m: f64,
    steer_axle_y_m: f64,
    rearmost_axle_x_m: f64,
    rearmost_axle_y_m: f64,
}

/// The file's stem, for a panel's title.
fn stem(file: &str) -> String {
    Path::new(file)
        .file_stem()
        .map_or_else(|| file.to_string(), |s| s.to_string_lossy().into_owned())
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.digits$}"))
}

/// Every mode: "V_crit (kind, leading unit)" or "stable (ζ at the test speed, leading unit)".
fn mode_cells(e: &CombinationEntry) -> String {
    e.modes
        .iter()
        .map(|m| match m.crossing_speed_mps {
            Some(v) => format!("{v:.2} (Hopf, `{}`)", m.leading_unit_key),
            None => format!(
                "stable (ζ = {}, `{}`)",
                cell(m.damping_ratio, 2),
                m.leading_unit_key
            ),
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The markdown table of the README.
pub fn markdown(rows: &[CombinationRow]) -> String {
    let v = rows.first().map_or(80.0 / 3.6, |r| r.entry.test_speed_mps);
    let mut s = format!(
        "| combination | units | V_crit per mode [m/s] (kind, leading unit) | V_fold [m/s] | rearward amplification (a_y / yaw rate) | offtracking [m] | yaw damping at {:.0} km/h |\n|---|---|---|---|---|---|---|\n",
        v * 3.6
    );
    for r in rows {
        let e = &r.entry;
        s.push_str(&format!(
            "| `{}` | {} | {} | {} | {} / {} | {} | {} |\n",
            r.vehicle_file,
            e.units,
            mode_cells(e),
            cell(e.v_fold_mps, 2),
            cell(e.rearward_amplification, 2),
            cell(e.rearward_amplification_yaw_rate, 2),
            cell(e.high_speed_transient_offtracking_m, 2),
            cell(e.yaw_damping_ratio, 3),
        ));
    }
    s
}

fn write_tables(out: &OutputDir, rows: &[CombinationRow], runs: &[Combination]) -> Result<(), TaskError> {
    out.write_table(
        "combination.csv",
        rows.iter().map(|r| {
            let e = &r.entry;
            CsvRow {
                vehicle_file: r.vehicle_file.clone(),
                units: e.units,
                v_crit_mps: e.v_crit_mps,
                stable_up_to_mps: e.stable_up_to_mps,
                v_fold_mps: e.v_fold_mps,
                modes: e.modes.len(),
                modes_losing_stability: e.modes.iter().filter(|m| m.crossing_speed_mps.is_some()).count(),
                test_speed_mps: e.test_speed_mps,
                rearward_amplification: e.rearward_amplification,
                rearward_amplification_yaw_rate: e.rearward_amplification_yaw_rate,
                high_speed_transient_offtracking_m: e.high_speed_transient_offtracking_m,
                yaw_damping_ratio: e.yaw_damping_ratio,
                reasons: e.reasons.join("; "),
            }
        }),
    )?;
    out.write_table(
        "modes.csv",
        rows.iter().zip(runs).flat_map(|(r, c)| {
            c.modes.rows().into_iter().map(|m| ModeCsvRow {
                vehicle_file: r.vehicle_file.clone(),
                mode: m.mode,
                speed_mps: m.speed_mps,
                real_per_s: m.real_per_s,
                frequency_hz: m.frequency_hz,
                damping_ratio: m.damping_ratio,
                leading_unit: m.leading_unit,
            })
        }),
    )?;
    out.write_table(
        "lane_change.csv",
        rows.iter().zip(runs).flat_map(|(r, c)| {
            c.lane_change.iter().flat_map(|l| &l.samples).map(|s| {
                let last = s.lateral_accelerations_mps2.len() - 1;
                LaneChangeRow {
                    vehicle_file: r.vehicle_file.clone(),
                    time_s: s.time_s,
                    steering_angle_deg: s.steering_angle_deg,
                    towing_unit_lateral_acceleration_mps2: s.lateral_accelerations_mps2[0],
                    rearmost_lateral_acceleration_mps2: s.lateral_accelerations_mps2[last],
                    towing_unit_yaw_rate_deg_s: s.yaw_rates_deg_s[0],
                    rearmost_yaw_rate_deg_s: s.yaw_rates_deg_s[last],
                    steer_axle_x_m: s.steer_axle_m[0],
                    steer_axle_y_m: s.steer_axle_m[1],
                    rearmost_axle_x_m: s.rearmost_axle_m[0],
                    rearmost_axle_y_m: s.rearmost_axle_m[1],
                }
            })
        }),
    )?;
    let md = markdown(rows);
    std::fs::write(out.path("combination.md"), &md).map_err(|source| TaskError::Write {
        path: out.path("combination.md"),
        source,
    })
}

/// `lane_change.svg/.png`: per vehicle with a lane change, every unit's lateral
/// acceleration against time, and the paths of the steered and the rearmost axle.
fn draw_lane_changes(out: &OutputDir, rows: &[CombinationRow], runs: &[Combination]) -> Result<(), TaskError> {
    let mut panels = Vec::new();
    for (r, c) in rows.iter().zip(runs) {
        let Some(l) = &c.lane_change else { continue };
        let mut acc = Panel::new(
            &format!("{}: lane change at {:.0} km/h, RA = {:.2}", stem(&r.vehicle_file), l.speed_mps * 3.6, l.rearward_amplification),
            "t [s]",
            "lateral acceleration [m/s²]",
        )
        .legend(Legend::UpperRight);
        for u in 0..r.entry.units {
            let label = if u == 0 { "towing unit".to_string() } else { format!("towed unit {u}") };
            acc.layers.push(Layer::line(
                l.samples.iter().map(|s| (s.time_s, s.lateral_accelerations_mps2[u])).collect(),
                Rgb::palette(u),
                if u == 0 { Stroke::Solid } else { Stroke::Dashed },
                Some(&label),
            ));
        }
        let paths = Panel::new(
            &format!("paths: offtracking = {:.2} m", l.high_speed_transient_offtracking_m),
            "x [m]",
            "y [m]",
        )
        .with(Layer::line(
            l.samples.iter().map(|s| (s.steer_axle_m[0], s.steer_axle_m[1])).collect(),
            Rgb::BLUE,
            Stroke::Solid,
            Some("steered axle"),
        ))
        .with(Layer::line(
            l.samples.iter().map(|s| (s.rearmost_axle_m[0], s.rearmost_axle_m[1])).collect(),
            Rgb::RED,
            Stroke::Dashed,
            Some("rearmost axle group"),
        ))
        .legend(Legend::LowerRight);
        panels.push(acc);
        panels.push(paths);
    }
    if panels.is_empty() {
        return Ok(());
    }
    let rows_n = panels.len() / 2;
    Figure::grid(panels, rows_n, 2, (1400, 380 * rows_n as u32)).render(&out.path("lane_change"))
}

/// `modes.svg/.png`: per vehicle, every mode's damping ratio against the speed.
fn draw_modes(out: &OutputDir, rows: &[CombinationRow], runs: &[Combination]) -> Result<(), TaskError> {
    let panels: Vec<Panel> = rows
        .iter()
        .zip(runs)
        .map(|(r, c)| {
            let mut p = Panel::new(
                &format!("{}: sway modes of straight running", stem(&r.vehicle_file)),
                "V [m/s]",
                "damping ratio ζ [-]",
            )
            .y_range(-0.3, 1.0)
            .legend(Legend::UpperRight);
            let (lo, hi) = c.modes.modes.iter().flat_map(|m| &m.points).fold((f64::INFINITY, 0.0_f64), |(a, b), q| (a.min(q.speed_mps), b.max(q.speed_mps)));
            p.layers.push(Layer::line(vec![(lo, 0.0), (hi, 0.0)], Rgb::GREY, Stroke::Dotted, None));
            for (k, (m, s)) in c.modes.modes.iter().zip(&c.modes.summaries).enumerate() {
                p.layers.push(Layer::line(
                    m.points.iter().map(|q| (q.speed_mps, q.damping_ratio)).collect(),
                    Rgb::palette(k),
                    Stroke::Solid,
                    Some(&format!("mode {} (led by {})", s.mode, s.leading_unit_key)),
                ));
            }
            p
        })
        .collect();
    let n = panels.len();
    Figure::grid(panels, n.div_ceil(2), 2, (1400, 380 * n.div_ceil(2) as u32)).render(&out.path("modes"))
}

fn headline(r: &CombinationRow) -> String {
    let e = &r.entry;
    let mut l = format!(
        "{}: {} units; V_crit {}, V_fold {}; modes: {}; at {:.2} m/s: rearward amplification {} (yaw rate {}), offtracking {} m, yaw damping {}",
        r.vehicle_file,
        e.units,
        cell(e.v_crit_mps, 3),
        cell(e.v_fold_mps, 3),
        mode_cells(e).replace('`', ""),
        e.test_speed_mps,
        cell(e.rearward_amplification, 3),
        cell(e.rearward_amplification_yaw_rate, 3),
        cell(e.high_speed_transient_offtracking_m, 3),
        cell(e.yaw_damping_ratio, 3),
    );
    if !e.reasons.is_empty() {
        l.push_str(&format!(" ({})", e.reasons.join("; ")));
    }
    l
}

impl Prepared for Configured<CombinationConfig> {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let dir = self.file.parent().unwrap_or(Path::new("."));
        let vehicles: Vec<(String, AnyVehicleModel)> = if cfg.files.is_empty() {
            vec![(ctx.vehicle_file.display().to_string(), ctx.plant.clone())]
        } else {
            cfg.files
                .iter()
                .enumerate()
                .map(|(k, f)| {
                    let path = dir.join(f);
                    load_vehicle_spec(&path)
                        .map(|v| (f.display().to_string(), v.plant))
                        .map_err(|e| {
                            TaskError::config(&self.file, format!("files[{k}]"), format!("the vehicle file {} is not valid: {e}", path.display()))
                        })
                })
                .collect::<Result<_, _>>()?
        };
        let steps = vehicles.len() as u64;
        ctx.run_staged(TASK.name, "combination: per vehicle file", steps, cfg, &self.file, |out| {
            let runs: Vec<Result<Combination, sway::SwayError>> = vehicles
                .par_iter()
                .map(|(_, m)| {
                    let c = combination(m, &ctx.limits, &cfg.test);
                    ctx.progress.advance(1);
                    c
                })
                .collect();
            let runs: Vec<Combination> = runs.into_iter().collect::<Result<_, _>>()?;
            let rows: Vec<CombinationRow> = vehicles
                .iter()
                .zip(&runs)
                .map(|((f, _), c)| CombinationRow {
                    vehicle_file: f.clone(),
                    entry: c.entry.clone(),
                })
                .collect();
            write_tables(out, &rows, &runs)?;
            draw_lane_changes(out, &rows, &runs)?;
            draw_modes(out, &rows, &runs)?;
            let lines = rows.iter().map(headline).collect();
            Ok((CombinationSummary { combinations: rows }, lines))
        })
    }
}
