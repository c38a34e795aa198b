//! `cargo xtask variants`: how the paper's conclusions move when its simplifications are
//! lifted ([`sway_studies::variants`]): for Table I with tyre relaxation σ on every axle and
//! for the example vehicles of `configs/vehicles/` (Magic Formula tyres, a tandem trailer
//! axle, hitch friction) the headline numbers of the `fleet` task, plus the threshold at one
//! speed common to all variants. A number a variant does not have is null with its reason.
//! The figure: V_crit and V_fold against σ on a finer grid.
//!
//! Outputs: `summary.json` (`"variants"`: one entry per row; `"relaxation_curve"`: the
//! figure's points), `variants.csv`, `v_crit_v_fold_vs_sigma.csv` and
//! `v_crit_v_fold_vs_sigma.{svg,png}`.

use std::path::Path;

use serde::Serialize;
use sway_studies::fleet::FleetEntry;
use sway_studies::variants::{Variants, compute, steps};
pub use sway_studies::variants::{CurvePoint, VariantRow, VariantsConfig};

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig, load_vehicle_spec};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Shape, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<VariantsConfig>(
    "variants",
    "model variants: V_crit, fold, bistable width, D* at τ = 0.2 s and threshold for Table I with tyre relaxation, Magic Formula tyres, a tandem axle, hitch friction",
    "variants.toml",
)
.any_model();

impl TaskConfig for VariantsConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        let sigma_ok = |s: &f64| s.is_finite() && (0.0..=5.0).contains(s);
        if self.relaxation_lengths_m.is_empty() && self.vehicle_files.is_empty() {
            return Err(TaskError::config(
                file,
                "relaxation_lengths_m",
                "expected at least one row (a relaxation length or a vehicle file)",
            ));
        }
        if !self.relaxation_lengths_m.iter().all(sigma_ok) {
            return Err(TaskError::config(
                file,
                "relaxation_lengths_m",
                format!(
                    "expected lengths 0 ≤ σ ≤ 5 m, got {:?}",
                    self.relaxation_lengths_m
                ),
            ));
        }
        let g = &self.curve_relaxation_lengths_m;
        if !(sigma_ok(&g.min) && sigma_ok(&g.max)) {
            return Err(TaskError::config(
                file,
                "curve_relaxation_lengths_m",
                format!("expected 0 ≤ min < max ≤ 5 m, got {g:?}"),
            ));
        }
        if let Some(v) = self.common_speed_mps
            && !(v.is_finite() && v > 0.0)
        {
            return Err(TaskError::config(
                file,
                "common_speed_mps",
                format!("expected a positive speed, got {v}"),
            ));
        }
        let h = &self.headline;
        let [min, max, points] = h.theta0_deg;
        if !(min > 0.0 && max > min && max < 90.0 && (2.0..=200.0).contains(&points)) {
            return Err(TaskError::config(
                file,
                "headline.theta0_deg",
                format!(
                    "expected [min, max, points] with 0 < min < max < 90 deg and 2 to 200 points, got {:?}",
                    h.theta0_deg
                ),
            ));
        }
        if !(h.delay_s.is_finite() && h.delay_s >= 0.0) {
            return Err(TaskError::config(
                file,
                "headline.delay_s",
                format!("expected a delay ≥ 0 s, got {}", h.delay_s),
            ));
        }
        if !h.threshold_in_bistable.is_finite() {
            return Err(TaskError::config(
                file,
                "headline.threshold_in_bistable",
                "expected a finite number",
            ));
        }
        Ok(())
    }
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VariantsSummary {
    /// one entry per row: the σ rows, then the files, in the config's order
    pub variants: Vec<VariantRow>,
    /// the speed of `theta0_threshold_at_common_speed_deg` \[m/s\]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub common_speed_mps: Option<f64>,
    /// V_crit and V_fold over the σ grid of the figure
    pub relaxation_curve: Vec<CurvePoint>,
}

/// One row of `variants.csv`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
struct CsvRow {
    variant: String,
    states: usize,
    v_crit_mps: Option<f64>,
    v_fold_mps: Option<f64>,
    bistable_width_mps: Option<f64>,
    d_opt_s: Option<f64>,
    v_crit_at_d_opt_mps: Option<f64>,
    threshold_speed_mps: Option<f64>,
    theta0_threshold_deg: Option<f64>,
    theta0_threshold_at_common_speed_deg: Option<f64>,
    reasons: String,
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.digits$}"))
}

/// The figure: V_crit and V_fold against σ, the bistable range between them.
fn figure(curve: &[CurvePoint], rows: &[VariantRow]) -> Panel {
    let pts = |f: fn(&CurvePoint) -> Option<f64>| -> Vec<(f64, f64)> {
        curve
            .iter()
            .map(|p| (p.relaxation_length_m, f(p).unwrap_or(f64::NAN)))
            .collect()
    };
    let crit = pts(|p| p.v_crit_mps);
    let fold = pts(|p| p.v_fold_mps);
    // the band between the two polylines, in thin slices (linear between the grid points)
    const SLICES: usize = 16;
    let rects: Vec<[f64; 4]> = curve
        .windows(2)
        .filter_map(|w| {
            let (f0, f1) = (w[0].v_fold_mps?, w[1].v_fold_mps?);
            let (c0, c1) = (w[0].v_crit_mps?, w[1].v_crit_mps?);
            let (s0, s1) = (w[0].relaxation_length_m, w[1].relaxation_length_m);
            let at = |a: f64, b: f64, t: f64| a + (b - a) * t;
            Some((0..SLICES).filter_map(move |k| {
                let (t0, t1) = (k as f64 / SLICES as f64, (k + 1) as f64 / SLICES as f64);
                let lo = at(f0, f1, t0).max(at(f0, f1, t1));
                let hi = at(c0, c1, t0).min(at(c0, c1, t1));
                (hi > lo).then_some([at(s0, s1, t0), at(s0, s1, t1), lo, hi])
            }))
        })
        .flatten()
        .collect();
    let table = |f: fn(&FleetEntry) -> Option<f64>| -> Vec<(f64, f64)> {
        rows.iter()
            .filter_map(|r| Some((r.relaxation_length_m?, f(&r.entry)?)))
            .collect()
    };
    let mut p = Panel::new(
        "Table I with tyre relaxation σ on every axle: open-loop V_crit and fold of cycles",
        "relaxation length σ [m]",
        "speed V [m/s]",
    )
    .legend(Legend::UpperRight);
    p.layers.push(Layer::Rects {
        rects,
        color: Rgb::ORANGE,
        opacity: 0.2,
        label: Some("bistable range (V_fold < V < V_crit)".into()),
    });
    p.layers.push(Layer::line(
        crit,
        Rgb::RED,
        Stroke::Solid,
        Some("V_crit (Hopf point of straight running)"),
    ));
    p.layers.push(Layer::line(
        fold,
        Rgb::BLUE,
        Stroke::Dashed,
        Some("V_fold (fold of the sway cycles)"),
    ));
    p.layers.push(Layer::Markers {
        points: table(|e| e.v_crit_mps)
            .into_iter()
            .chain(table(|e| e.v_fold_mps))
            .collect(),
        color: Rgb::BLACK,
        shape: Shape::Circle,
        size: 5,
        label: Some("rows of the table".into()),
    });
    p
}

impl Prepared for Configured<VariantsConfig> {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let dir = self.file.parent().unwrap_or(Path::new("."));
        let files = cfg
            .vehicle_files
            .iter()
            .map(|f| Ok(load_vehicle_spec(&dir.join(f))?.plant))
            .collect::<Result<Vec<_>, TaskError>>()?;
        ctx.run_staged(
            TASK.name,
            "variants: headline numbers per model variant",
            steps(cfg),
            cfg,
            &self.file,
            |out| {
                let Variants { rows: table, curve } =
                    compute(cfg, &files, &ctx.limits, ctx.progress)?;
                out.write_table(
                    "variants.csv",
                    table.iter().map(|r| CsvRow {
                        variant: r.variant.clone(),
                        states: r.states,
                        v_crit_mps: r.entry.v_crit_mps,
                        v_fold_mps: r.entry.v_fold_mps,
                        bistable_width_mps: r.entry.bistable_width_mps,
                        d_opt_s: r.entry.d_opt_s,
                        v_crit_at_d_opt_mps: r.entry.v_crit_at_d_opt_mps,
                        threshold_speed_mps: r.entry.threshold_speed_mps,
                        theta0_threshold_deg: r.entry.theta0_threshold_deg,
                        theta0_threshold_at_common_speed_deg: r
                            .theta0_threshold_at_common_speed_deg,
                        reasons: r.entry.reasons.join("; "),
                    }),
                )?;
                out.write_table("v_crit_v_fold_vs_sigma.csv", curve.iter().cloned())?;
                Figure::single(figure(&curve, &table))
                    .render(&out.path("v_crit_v_fold_vs_sigma"))?;
                let lines = table
                    .iter()
                    .map(|r| {
                        let e = &r.entry;
                        let mut l = format!(
                            "{}: V_crit {}, V_fold {}, bistable width {}, D* {} s (V_crit {}), θ(0) threshold {}°",
                            r.variant,
                            cell(e.v_crit_mps, 4),
                            cell(e.v_fold_mps, 4),
                            cell(e.bistable_width_mps, 3),
                            cell(e.d_opt_s, 4),
                            cell(e.v_crit_at_d_opt_mps, 2),
                            cell(e.theta0_threshold_deg, 2)
                        );
                        if let Some(v) = cfg.common_speed_mps {
                            l.push_str(&format!(
                                " ({}° at {v} m/s)",
                                cell(r.theta0_threshold_at_common_speed_deg, 2)
                            ));
                        }
                        l
                    })
                    .collect();
                Ok((
                    VariantsSummary {
                        variants: table,
                        common_speed_mps: cfg.common_speed_mps,
                        relaxation_curve: curve,
                    },
                    lines,
                ))
            },
        )
    }
}
