//! `cargo xtask linear`: open-loop linear stability, V_crit, Hopf frequency, sensitivities.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use crate::TaskError;
use sway::config::{Grid, ensure};
use sway::linear::{
    EigenTable, Sensitivity, SensitivityOptions, eigen_table, parameter_index, sensitivities,
    sensitivities_spec, v_crit_curve, v_crit_curve_spec,
};
use sway::control::LoopModel;
use trailer_model::{CriticalSpeed, CriticalSpeedOptions, VehicleParams, VehicleSpec};

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
};

/// `configs/linear.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearConfig {
    /// speed grid of the eigenvalue table \[m/s\] (omitted: derived from the vehicle,
    /// [`sway::linear::derived_speed_grid`]: 1 m/s to 1.5·V_crit rounded up to 10 m/s)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_grid: Option<Grid>,
    /// V_crit search (omitted: the one search of every task, over the `--max-speed` limits,
    /// [`sway::ranging::open_loop_critical_speed`])
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub critical_speed: Option<SearchConfig>,
    /// sensitivity differences
    #[serde(default)]
    pub sensitivity: SensitivityOptions,
    /// the paper's value, for comparison \[m/s\] (reported only for Table I)
    #[serde(default = "paper_v_crit")]
    pub paper_v_crit_mps: f64,
    /// half a unit of the last printed digit of Table I's lengths h and l \[m\]
    #[serde(default = "rounding")]
    pub length_rounding_m: f64,
}

fn paper_v_crit() -> f64 {
    34.1
}
fn rounding() -> f64 {
    0.05
}

/// The V_crit search settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SearchConfig {
    /// lowest speed scanned \[m/s\]
    pub v_min_mps: f64,
    /// highest speed scanned \[m/s\]
    pub v_max_mps: f64,
    /// scan step \[m/s\]
    pub scan_step_mps: f64,
    /// bisection stops at this bracket width \[m/s\]
    pub tolerance_mps: f64,
}

impl Default for SearchConfig {
    fn default() -> Self {
        let d = CriticalSpeedOptions::default();
        Self {
            v_min_mps: d.v_min,
            v_max_mps: d.v_max,
            scan_step_mps: d.scan_step,
            tolerance_mps: d.tolerance,
        }
    }
}

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

/// How the rightmost eigenvalue crosses the imaginary axis at V_crit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LossOfStability {
    /// a complex pair ±iω, ω > 0: a Hopf point, sway starts
    Hopf,
    /// a real eigenvalue through 0: a static divergence (pitchfork of the symmetric vehicle)
    Divergence,
}

impl LossOfStability {
    /// The kind of crossing of `vc`: a divergence when its frequency is zero (a real
    /// eigenvalue is the rightmost one; the eigenvalue solver returns Im λ = 0 exactly).
    pub fn of(vc: &CriticalSpeed) -> Self {
        if vc.hopf_omega_rad_s == 0.0 {
            Self::Divergence
        } else {
            Self::Hopf
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
    /// dV_crit/dp of every parameter, keyed by its symbol
    pub sensitivities: Keyed<SensitivityEntry>,
}

/// A row of `v_crit_vs_h_l.csv` (an empty cell: no V_crit near the vehicle's there).
#[derive(Debug, Clone, Copy, Default, Serialize)]
struct RoundingRow {
    offset_m: f64,
    v_crit_varying_h_mps: Option<f64>,
    v_crit_varying_l_mps: Option<f64>,
}

/// The rounding study: V_crit along h and l around the vehicle's values.
struct RoundingStudy {
    /// dV_crit/dh, dV_crit/dl
    dh: f64,
    dl: f64,
    /// h and l of Table I \[m\]
    h0: f64,
    l0: f64,
    /// (h, V_crit) and (l, V_crit); None where the changed vehicle has no V_crit nearby
    by_h: Vec<(f64, Option<f64>)>,
    by_l: Vec<(f64, Option<f64>)>,
    /// first-order V_crit change of the rounding \[m/s\]
    band: f64,
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

impl SearchConfig {
    /// As the model's search options.
    fn options(&self) -> CriticalSpeedOptions {
        CriticalSpeedOptions {
            v_min: self.v_min_mps,
            v_max: self.v_max_mps,
            scan_step: self.scan_step_mps,
            tolerance: self.tolerance_mps,
        }
    }
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

/// The vehicle of the rounding study: its paper-form parameters, and its file where it has
/// model variants (then the curves change the file's keys).
struct Vehicle<'a> {
    params: &'a VehicleParams,
    spec: Option<&'a VehicleSpec>,
}

/// Step 3: V_crit along h and l (±0.1 m around Table I), `v_crit_vs_h_l.csv`.
fn rounding_study(
    vehicle: &Vehicle<'_>,
    sens: &[Sensitivity],
    v_crit: f64,
    rounding_m: f64,
    out: &OutputDir,
) -> Result<RoundingStudy, TaskError> {
    let (ih, il) = (
        parameter_index("h").unwrap_or(9),
        parameter_index("l").unwrap_or(10),
    );
    let (dh, dl) = (sens[ih].dv_crit_dp, sens[il].dv_crit_dp);
    let offsets: Vec<f64> = (0..=40).map(|k| -0.1 + 0.2 * k as f64 / 40.0).collect();
    let (h0, l0) = (vehicle.params.get(ih), vehicle.params.get(il));
    let along = |i: usize, p0: f64| {
        let values: Vec<f64> = offsets.iter().map(|o| p0 + o).collect();
        match vehicle.spec {
            None => v_crit_curve(vehicle.params, i, &values, v_crit),
            Some(spec) => v_crit_curve_spec(spec, i, &values, v_crit),
        }
    };
    let (by_h, by_l) = (along(ih, h0)?, along(il, l0)?);
    let rows = offsets
        .iter()
        .zip(by_h.iter().zip(&by_l))
        .map(|(&o, (a, b))| RoundingRow {
            offset_m: o,
            v_crit_varying_h_mps: a.1,
            v_crit_varying_l_mps: b.1,
        });
    out.write_table("v_crit_vs_h_l.csv", rows)?;
    Ok(RoundingStudy {
        dh,
        dl,
        h0,
        l0,
        by_h,
        by_l,
        band: (dh.abs() + dl.abs()) * rounding_m,
    })
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

/// Step 5: the headline numbers (`paper`: the paper's V_crit, Table I only).
fn summary(
    vc: &CriticalSpeed,
    paper: Option<f64>,
    study: &RoundingStudy,
    sens: &[Sensitivity],
) -> LinearSummary {
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
        dv_crit_dh_mps_per_m: Some(study.dh),
        dv_crit_dl_mps_per_m: Some(study.dl),
        v_crit_rounding_band_mps: Some([vc.v_crit_mps - study.band, vc.v_crit_mps + study.band]),
        sensitivities: sens
            .iter()
            .map(|x| (x.symbol.to_string(), SensitivityEntry::from(x)))
            .collect(),
    }
}

/// The summary of a vehicle stable up to the maximum speed `v_max` \[m/s\].
fn stable_summary(v_max: f64, reason: String) -> LinearSummary {
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
        sensitivities: Keyed::default(),
    }
}

/// The printed headline lines.
fn headline_lines(
    vc: &CriticalSpeed,
    cfg: &LinearConfig,
    study: &RoundingStudy,
    paper: Option<f64>,
) -> Vec<String> {
    let (dh, dl, band, r) = (study.dh, study.dl, study.band, cfg.length_rounding_m);
    let paper = paper.map_or_else(String::new, |p| format!(" (paper: {p} m/s)"));
    let crossing = match LossOfStability::of(vc) {
        LossOfStability::Hopf => format!(
            "Hopf frequency = {:.6} Hz (ω = {:.6} rad/s)",
            vc.hopf_frequency_hz, vc.hopf_omega_rad_s
        ),
        LossOfStability::Divergence => "a real eigenvalue crosses 0 at V_crit: static divergence, not sway (ω = 0)".to_string(),
    };
    vec![
        format!("V_crit = {:.9} m/s", vc.v_crit_mps),
        crossing,
        format!(
            "dV_crit/dh = {dh:.3} m/s per m, dV_crit/dl = {dl:.3} m/s per m; ±{r} m rounding of h and l moves V_crit by up to ±{band:.2} m/s{paper}"
        ),
    ]
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
            let search = cfg
                .critical_speed
                .as_ref()
                .map_or_else(|| ctx.limits.critical_speed_options(), SearchConfig::options);
            let vc = LoopModel::critical_speed_search(&ctx.plant, &search)?;
            ctx.progress.advance(1);
            let grid = cfg.speed_grid.unwrap_or_else(|| {
                sway::linear::derived_speed_grid(vc.as_ref().map(|c| c.v_crit_mps), &ctx.limits)
            });
            let table = eigen_table(&ctx.plant, &grid.values());
            write_eigenvalues(out, &table)?;
            ctx.progress.advance(1);
            draw_eigenvalues(out, &table, &grid, vc.as_ref())?;
            let Some(vc) = vc else {
                let reason = format!(
                    "straight running is stable at every speed up to {} m/s (the maximum speed{})",
                    search.v_max,
                    if cfg.critical_speed.is_some() {
                        ", critical_speed.v_max_mps"
                    } else {
                        ", --max-speed"
                    }
                );
                ctx.progress.advance(1);
                let lines = vec![format!("no V_crit: {reason}")];
                return Ok((stable_summary(search.v_max, reason), lines));
            };
            // a vehicle of the paper's form: the paper's parameters (the numbers of results/);
            // one with model variants: its file, each key changed on it
            let sens = match &ctx.variant_key {
                None => sensitivities(&ctx.vehicle, vc.v_crit_mps, &cfg.sensitivity, search.tolerance)?,
                Some(_) => sensitivities_spec(&ctx.spec, vc.v_crit_mps, &cfg.sensitivity, search.tolerance)?,
            };
            out.write_table("sensitivity.csv", sens.iter().cloned())?;
            let vehicle = Vehicle { params: &ctx.vehicle, spec: ctx.variant_key.is_some().then_some(&ctx.spec) };
            let study = rounding_study(&vehicle, &sens, vc.v_crit_mps, cfg.length_rounding_m, out)?;
            ctx.progress.advance(1);
            let paper = ctx.vehicle.is_table_i().then_some(cfg.paper_v_crit_mps);
            draw_rounding(out, &study, cfg, vc.v_crit_mps, paper)?;
            let lines = headline_lines(&vc, cfg, &study, paper);
            Ok((summary(&vc, paper, &study, &sens), lines))
        })
    }
}
