//! `cargo xtask linear`: open-loop linear stability, V_crit, Hopf frequency, sensitivities
//! ([`sway_studies::linear`]).

use std::path::{Path, PathBuf};

use serde::Serialize;
use crate::TaskError;
use sway::config::{Grid, ensure};
use sway::linear::{EigenTable, Sensitivity};
use sway_studies::linear::{Critical, LinearVehicle, Onset, RoundingStudy, compute};
use sway_studies::modes::{ModeSummary, Modes};
pub use sway_studies::linear::{LinearConfig, LossOfStability, SearchConfig};
use trailer_model::{CriticalSpeed, VehicleSpec};

use crate::limits::{BYTES_PER_ROW, LINEAR_SECONDS_PER_POINT, Plan};
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::load_toml;
use crate::io::{Keyed, OutputDir};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task.
pub const TASK: Task = Task {
    name: "linear",
    about: "open-loop eigenvalues vs V, V_crit, Hopf frequency, dV_crit/dp",
    config: "linear.toml",
    prepare,
    models: super::Models::Any,
    runs: super::Runs::InAll,
};

/// One parameter's entry in `summary.json`'s `"sensitivities"` (keyed by its symbol).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensitivityEntry {
    /// key path in the vehicle file
    pub key: &'static str,
    /// unit of the parameter
    pub unit: &'static str,
    /// parameter value
    pub value: f64,
    /// dV_crit/dp (m/s per unit of p)
    pub dv_crit_dp: f64,
    /// (p / V_crit) dV_crit/dp
    pub elasticity: f64,
}

impl From<&Sensitivity> for SensitivityEntry {
    fn from(x: &Sensitivity) -> Self {
        Self {
            key: x.key,
            unit: x.unit,
            value: x.value,
            dv_crit_dp: x.dv_crit_dp,
            elasticity: x.elasticity,
        }
    }
}

/// `summary.json` of `linear` (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearSummary {
    /// V_crit \[m/s\]: the speed where straight running loses stability (Hopf); null when
    /// straight running is stable up to the maximum speed (`stable_up_to_mps`, `reason`)
    pub v_crit_mps: Option<f64>,
    /// straight running is stable at every speed up to this one \[m/s\] (when no V_crit)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_up_to_mps: Option<f64>,
    /// why `v_crit_mps` and the quantities at V_crit are null
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// how straight running loses stability at V_crit: `"hopf"` (a complex pair, the
    /// onset of sway) or `"divergence"` (a real eigenvalue, ω = 0: a static divergence,
    /// no sway cycles); absent when it does not (then `reason` says why)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub loss_of_stability: Option<LossOfStability>,
    /// the Hopf frequency \[Hz\] (0 for a divergence)
    pub hopf_frequency_hz: Option<f64>,
    /// the Hopf angular frequency ω \[rad/s\]
    pub hopf_omega_rad_s: Option<f64>,
    /// d(max Re λ)/dV at V_crit \[1/m\] (the transversality of the crossing)
    pub spectral_abscissa_slope_per_m: Option<f64>,
    /// the paper's V_crit \[m/s\] (only for the paper's vehicle, Table I)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_v_crit_mps: Option<f64>,
    /// ours minus the paper's \[m/s\] (only for Table I)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_crit_minus_paper_mps: Option<f64>,
    /// dV_crit/dh (m/s per m)
    pub dv_crit_dh_mps_per_m: Option<f64>,
    /// dV_crit/dl (m/s per m)
    pub dv_crit_dl_mps_per_m: Option<f64>,
    /// V_crit ± the first-order effect of rounding h and l to 0.1 m (as Table I prints
    /// them) \[m/s\]
    pub v_crit_rounding_band_mps: Option<[f64; 2]>,
    /// why the three fields above are null where V_crit is found (h and l are the
    /// trailer's of a two-unit vehicle; a chain of towed units has none)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_crit_rounding_reason: Option<String>,
    /// dV_crit/dp of every parameter, keyed by its symbol
    pub sensitivities: Keyed<SensitivityEntry>,
    /// every oscillatory mode of straight running (`modes.csv` has each along the grid):
    /// where it loses stability, its frequency and damping at `reference_speed_mps`, the
    /// unit that leads it
    pub modes: Vec<ModeSummary>,
}

/// A row of `v_crit_vs_h_l.csv` (an empty cell: no V_crit near the vehicle's there).
#[derive(Debug, Clone, Copy, Default, Serialize)]
struct RoundingRow {
    offset_m: f64,
    v_crit_varying_h_mps: Option<f64>,
    v_crit_varying_l_mps: Option<f64>,
}

struct LinearTask {
    file: PathBuf,
    config: LinearConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    let config: LinearConfig = load_toml(file)?;
    if let Some(g) = &config.speed_grid {
        ensure(g.min > 0.0, file, "speed_grid.min", || {
            format!("speeds must be positive (slip angles divide by V), got {}", g.min)
        })?;
    }
    if let Some(s) = &config.critical_speed {
        validate_search(s, file)?;
    }
    let r = config.sensitivity.relative_step;
    ensure(
        r > 1e-9 && r < 1e-2,
        file,
        "sensitivity.relative_step",
        || format!("expected a value in (1e-9, 1e-2), got {r}"),
    )?;
    Ok(Box::new(LinearTask {
        file: file.to_path_buf(),
        config,
    }))
}

/// Checks an explicit `[critical_speed]` section.
fn validate_search(s: &SearchConfig, file: &Path) -> Result<(), TaskError> {
    ensure(
        s.v_min_mps > 0.0 && s.v_max_mps > s.v_min_mps,
        file,
        "critical_speed",
        || {
            format!(
                "expected 0 < v_min_mps < v_max_mps, got {} and {}",
                s.v_min_mps, s.v_max_mps
            )
        },
    )?;
    ensure(
        s.scan_step_mps > 0.0,
        file,
        "critical_speed.scan_step_mps",
        || format!("must be positive, got {}", s.scan_step_mps),
    )?;
    let scan_points = (s.v_max_mps - s.v_min_mps) / s.scan_step_mps;
    crate::limits::bound(
        file,
        "critical_speed.scan_step_mps",
        scan_points,
        sway::config::MAX_GRID_POINTS as f64,
        || {
            format!(
                "{scan_points:.3e} scan points from v_min_mps to v_max_mps, one eigenvalue problem each; use a larger step"
            )
        },
    )?;
    ensure(
        s.tolerance_mps > 0.0 && s.tolerance_mps < 1e-3,
        file,
        "critical_speed.tolerance_mps",
        || format!("expected 0 < tolerance < 1e-3 m/s, got {}", s.tolerance_mps),
    )?;
    Ok(())
}

/// Step 1: the eigenvalues along the speed grid, `eigenvalues.csv`.
fn write_eigenvalues(out: &OutputDir, table: &EigenTable) -> Result<(), TaskError> {
    let rows: Vec<Vec<f64>> = table
        .speeds
        .iter()
        .zip(&table.eigenvalues)
        .map(|(&v, ev)| {
            let mut r = vec![v];
            for l in ev {
                r.extend([l.re, l.im]);
            }
            r
        })
        .collect();
    let mut header = vec!["v_mps".to_string()];
    for k in 1..=table.columns() {
        header.extend([format!("re{k}"), format!("im{k}")]);
    }
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    out.write_csv("eigenvalues.csv", &header, &rows)
}

/// Step 3: `v_crit_vs_h_l.csv`, V_crit along h and l (±0.1 m around Table I).
fn write_rounding(out: &OutputDir, study: &RoundingStudy) -> Result<(), TaskError> {
    let rows = study
        .offsets_m
        .iter()
        .zip(study.by_h.iter().zip(&study.by_l))
        .map(|(&o, (a, b))| RoundingRow {
            offset_m: o,
            v_crit_varying_h_mps: a.1,
            v_crit_varying_l_mps: b.1,
        });
    out.write_table("v_crit_vs_h_l.csv", rows)
}

/// One line per eigenvalue, `part` of each (real part, or frequency), solid and dashed
/// alternating.
fn eigenvalue_layers(table: &EigenTable, part: impl Fn(num_complex::Complex64) -> f64) -> Vec<Layer> {
    (0..table.columns())
        .map(|k| {
            Layer::line(
                table
                    .speeds
                    .iter()
                    .zip(&table.eigenvalues)
                    .map(|(&v, ev)| (v, part(ev[k])))
                    .collect(),
                Rgb::palette(k),
                if k % 2 == 0 {
                    Stroke::Solid
                } else {
                    Stroke::Dashed
                },
                Some(&format!("λ{}", k + 1)),
            )
        })
        .collect()
}

/// Step 4a: `eigenvalues.svg/.png`, real parts and frequencies against V.
fn draw_eigenvalues(
    out: &OutputDir,
    table: &EigenTable,
    grid: &Grid,
    vc: Option<&CriticalSpeed>,
) -> Result<(), TaskError> {
    let v_range = (grid.min, grid.max);
    let clip = 8.0;
    let mut p1 = Panel::new(
        "Open loop: real parts of the eigenvalues of Ã(V)",
        "V [m/s]",
        "Re λ [1/s]",
    )
    .x_range(v_range.0, v_range.1)
    .y_range(-clip, 2.0)
    .legend(Legend::LowerLeft);
    if let Some(vc) = vc {
        p1.layers.push(Layer::band(
            vc.v_crit_mps,
            v_range.1,
            Rgb::RED,
            Some("unstable straight running"),
        ));
    }
    p1.layers.push(Layer::line(
        vec![(v_range.0, 0.0), (v_range.1, 0.0)],
        Rgb::GREY,
        Stroke::Dotted,
        None,
    ));
    p1.layers.extend(eigenvalue_layers(table, |l| l.re));
    if let Some(vc) = vc {
        p1.layers.push(Layer::markers(
            vec![(vc.v_crit_mps, 0.0)],
            Rgb::BLACK,
            Some(&format!("V_crit = {:.3} m/s", vc.v_crit_mps)),
        ));
    }
    let mut p2 = Panel::new("Frequencies Im λ / 2π", "V [m/s]", "Im λ / 2π [Hz]")
        .x_range(v_range.0, v_range.1)
        .legend(Legend::UpperRight);
    p2.layers.extend(eigenvalue_layers(table, |l| {
        l.im / (2.0 * std::f64::consts::PI)
    }));
    if let Some(vc) = vc {
        p2.layers.push(Layer::markers(
            vec![
                (vc.v_crit_mps, vc.hopf_frequency_hz),
                (vc.v_crit_mps, -vc.hopf_frequency_hz),
            ],
            Rgb::BLACK,
            Some(&match LossOfStability::of(vc) {
                LossOfStability::Hopf => format!("Hopf: {:.3} Hz", vc.hopf_frequency_hz),
                LossOfStability::Divergence => "divergence: real eigenvalue, 0 Hz".to_string(),
            }),
        ));
    }
    Figure::column(vec![p1, p2]).render(&out.path("eigenvalues"))
}

/// Step 4b: `sensitivity.svg/.png`, V_crit against the change of h and l.
fn draw_rounding(
    out: &OutputDir,
    study: &RoundingStudy,
    cfg: &LinearConfig,
    v_crit: f64,
    paper: Option<f64>,
) -> Result<(), TaskError> {
    let r = cfg.length_rounding_m;
    let who = if paper.is_some() { "Table I" } else { "the vehicle" };
    let mut p3 = Panel::new(
        "V_crit vs trailer geometry (h, l printed to 0.1 m as in Table I)",
        &format!("change of the length from {who} [m]"),
        "V_crit [m/s]",
    )
    .with(Layer::band(
        -r,
        r,
        Rgb::GREY,
        Some(&format!("rounding to 0.1 m (±{r} m)")),
    ))
    .with(Layer::line(
        study.by_h.iter().filter_map(|&(p, v)| Some((p - study.h0, v?))).collect(),
        Rgb::BLUE,
        Stroke::Solid,
        Some("vary h (trailer CG)"),
    ))
    .with(Layer::line(
        study.by_l.iter().filter_map(|&(p, v)| Some((p - study.l0, v?))).collect(),
        Rgb::ORANGE,
        Stroke::Solid,
        Some("vary l (trailer axle)"),
    ))
    .with(Layer::markers(
        vec![(0.0, v_crit)],
        Rgb::BLACK,
        Some(&format!("{who}: {v_crit:.3} m/s")),
    ))
    .legend(Legend::UpperRight);
    if let Some(paper) = paper {
        p3.layers.push(Layer::line(
            vec![(-0.1, paper), (0.1, paper)],
            Rgb::RED,
            Stroke::Dashed,
            Some(&format!("paper: {paper} m/s")),
        ));
    }
    Figure::single(p3).render(&out.path("sensitivity"))
}

/// Step 5: the headline numbers of a vehicle with a V_crit.
fn summary(c: &Critical, rounding_reason: Option<String>, modes: &Modes) -> LinearSummary {
    let (vc, paper, study) = (&c.speed, c.paper_v_crit_mps, &c.rounding);
    let rounded = |v: f64| rounding_reason.is_none().then_some(v);
    LinearSummary {
        v_crit_mps: Some(vc.v_crit_mps),
        stable_up_to_mps: None,
        reason: None,
        loss_of_stability: Some(LossOfStability::of(vc)),
        hopf_frequency_hz: Some(vc.hopf_frequency_hz),
        hopf_omega_rad_s: Some(vc.hopf_omega_rad_s),
        spectral_abscissa_slope_per_m: Some(vc.crossing_speed),
        paper_v_crit_mps: paper,
        v_crit_minus_paper_mps: paper.map(|p| vc.v_crit_mps - p),
        dv_crit_dh_mps_per_m: rounded(study.dh),
        dv_crit_dl_mps_per_m: rounded(study.dl),
        v_crit_rounding_band_mps: rounding_reason
            .is_none()
            .then_some([vc.v_crit_mps - study.band, vc.v_crit_mps + study.band]),
        v_crit_rounding_reason: rounding_reason,
        sensitivities: c
            .sensitivities
            .iter()
            .map(|x| (x.symbol.to_string(), SensitivityEntry::from(x)))
            .collect(),
        modes: modes.summaries.clone(),
    }
}

/// The summary of a vehicle stable up to the maximum speed `v_max` \[m/s\].
fn stable_summary(v_max: f64, reason: String, modes: &Modes) -> LinearSummary {
    LinearSummary {
        v_crit_mps: None,
        stable_up_to_mps: Some(v_max),
        reason: Some(reason),
        loss_of_stability: None,
        hopf_frequency_hz: None,
        hopf_omega_rad_s: None,
        spectral_abscissa_slope_per_m: None,
        paper_v_crit_mps: None,
        v_crit_minus_paper_mps: None,
        dv_crit_dh_mps_per_m: None,
        dv_crit_dl_mps_per_m: None,
        v_crit_rounding_band_mps: None,
        v_crit_rounding_reason: None,
        sensitivities: Keyed::default(),
        modes: modes.summaries.clone(),
    }
}

/// One printed line per mode.
pub fn mode_lines(modes: &Modes) -> Vec<String> {
    modes
        .summaries
        .iter()
        .map(|m| {
            let crossing = match (m.crossing_speed_mps, m.crossing_frequency_hz) {
                (Some(v), Some(f)) => format!("loses stability at {v:.4} m/s ({f:.3} Hz)"),
                _ => m.reason.clone().unwrap_or_default(),
            };
            let at = match (m.frequency_hz, m.damping_ratio) {
                (Some(f), Some(z)) => format!(
                    "{f:.3} Hz, damping ratio {z:.3} at {:.2} m/s",
                    m.reference_speed_mps
                ),
                _ => format!("not oscillatory at {:.2} m/s", m.reference_speed_mps),
            };
            format!(
                "mode {}: led by {} (unit {}); {at}; {crossing}",
                m.mode, m.leading_unit_key, m.leading_unit
            )
        })
        .collect()
}

/// The printed headline lines.
fn headline_lines(c: &Critical, cfg: &LinearConfig, rounding_reason: Option<&str>) -> Vec<String> {
    let (vc, study) = (&c.speed, &c.rounding);
    let (dh, dl, band, r) = (study.dh, study.dl, study.band, cfg.length_rounding_m);
    let paper = c
        .paper_v_crit_mps
        .map_or_else(String::new, |p| format!(" (paper: {p} m/s)"));
    let crossing = match LossOfStability::of(vc) {
        LossOfStability::Hopf => format!(
            "Hopf frequency = {:.6} Hz (ω = {:.6} rad/s)",
            vc.hopf_frequency_hz, vc.hopf_omega_rad_s
        ),
        LossOfStability::Divergence => "a real eigenvalue crosses 0 at V_crit: static divergence, not sway (ω = 0)".to_string(),
    };
    let rounding = match rounding_reason {
        Some(why) => format!("dV_crit/dh, dV_crit/dl: none ({why})"),
        None => format!(
            "dV_crit/dh = {dh:.3} m/s per m, dV_crit/dl = {dl:.3} m/s per m; ±{r} m rounding of h and l moves V_crit by up to ±{band:.2} m/s{paper}"
        ),
    };
    vec![
        format!("V_crit = {:.9} m/s", vc.v_crit_mps),
        crossing,
        rounding,
    ]
}

/// Why the rounding study of h and l has no numbers for this vehicle, if it has none.
fn rounding_reason(c: &Critical, spec: &VehicleSpec) -> Option<String> {
    let study = &c.rounding;
    if study.dh.is_finite() && study.dl.is_finite() {
        return None;
    }
    Some(if spec.is_chain() {
        format!(
            "h and l are the trailer's of a two-unit vehicle (`trailer.cog`, `trailer.axle`), as are m2, J2 and C_T, whose sensitivities are null too; a chain of {} towed units has no `[trailer]`",
            spec.towed_units()
        )
    } else {
        "no V_crit near this vehicle's at the varied h or l".to_string()
    })
}

impl Prepared for LinearTask {
    fn plan(&self) -> Result<Plan, TaskError> {
        // the derived grid of Table I has 591 points; a vehicle's at most (100 − 1)/0.1 + 1
        let n = self.config.speed_grid.as_ref().map_or(591, |g| g.points) as f64;
        Ok(Plan::new(
            vec![format!(
                "linear: eigenvalues at {n} speeds, V_crit, sensitivities of every parameter"
            )],
            n * BYTES_PER_ROW,
            n * LINEAR_SECONDS_PER_POINT + 0.05,
        ))
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        ctx.run_staged(TASK.name, "linear: eigenvalues", 3, cfg, &self.file, |out| {
            // a vehicle of the paper's form: the paper's parameters (the numbers of results/);
            // one with model variants: its file, each key changed on it
            let vehicle = LinearVehicle {
                plant: &ctx.plant,
                params: &ctx.vehicle,
                spec: ctx.variant_key.is_some().then_some(&ctx.spec),
            };
            let r = compute(cfg, &vehicle, &ctx.limits, ctx.progress)?;
            write_eigenvalues(out, &r.table)?;
            out.write_table("modes.csv", r.modes.rows())?;
            draw_eigenvalues(out, &r.table, &r.grid, r.critical_speed())?;
            let c = match &r.onset {
                Onset::Critical(c) => c,
                Onset::Stable { up_to_mps, reason } => {
                    let mut lines = vec![format!("no V_crit: {reason}")];
                    lines.extend(mode_lines(&r.modes));
                    return Ok((stable_summary(*up_to_mps, reason.clone(), &r.modes), lines));
                }
            };
            out.write_table("sensitivity.csv", c.sensitivities.iter().cloned())?;
            write_rounding(out, &c.rounding)?;
            draw_rounding(out, &c.rounding, cfg, c.speed.v_crit_mps, c.paper_v_crit_mps)?;
            let why = rounding_reason(c, &ctx.spec);
            let mut lines = headline_lines(c, cfg, why.as_deref());
            lines.extend(mode_lines(&r.modes));
            Ok((summary(c, why, &r.modes), lines))
        })
    }
}
