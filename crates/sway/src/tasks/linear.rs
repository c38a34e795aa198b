//! `cargo xtask linear`: open-loop linear stability, V_crit, Hopf frequency, sensitivities.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};
use trailer_model::CriticalSpeedOptions;

use super::{Prepared, Report, Task, TaskContext};
use crate::SwayError;
use crate::config::{Grid, ensure, load_toml};
use crate::io::OutputDir;
use crate::linear::{
    SensitivityOptions, eigen_table, parameter_index, sensitivities, v_crit_curve,
};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task.
pub const TASK: Task = Task {
    name: "linear",
    about: "open-loop eigenvalues vs V, V_crit, Hopf frequency, dV_crit/dp",
    config: "linear.toml",
    prepare,
};

/// `configs/linear.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearConfig {
    /// speed grid of the eigenvalue table [m/s]
    pub speed_grid: Grid,
    /// V_crit search
    #[serde(default)]
    pub critical_speed: SearchConfig,
    /// sensitivity differences
    #[serde(default)]
    pub sensitivity: SensitivityOptions,
    /// the paper's value, for comparison [m/s]
    #[serde(default = "paper_v_crit")]
    pub paper_v_crit_mps: f64,
    /// half a unit of the last printed digit of Table I's lengths h and l [m]
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
    /// lowest speed scanned [m/s]
    pub v_min_mps: f64,
    /// highest speed scanned [m/s]
    pub v_max_mps: f64,
    /// scan step [m/s]
    pub scan_step_mps: f64,
    /// bisection stops at this bracket width [m/s]
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

struct LinearTask {
    file: PathBuf,
    config: LinearConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, SwayError> {
    let config: LinearConfig = load_toml(file)?;
    config.speed_grid.validate(file, "speed_grid")?;
    ensure(config.speed_grid.min > 0.0, file, "speed_grid.min", || {
        format!(
            "speeds must be positive (slip angles divide by V), got {}",
            config.speed_grid.min
        )
    })?;
    let s = &config.critical_speed;
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
    ensure(
        s.tolerance_mps > 0.0 && s.tolerance_mps < 1e-3,
        file,
        "critical_speed.tolerance_mps",
        || format!("expected 0 < tolerance < 1e-3 m/s, got {}", s.tolerance_mps),
    )?;
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

impl Prepared for LinearTask {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, SwayError> {
        let cfg = &self.config;
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        let model = &ctx.model;
        ctx.progress.start("linear: eigenvalues", 3);

        // 1. eigenvalues along the grid
        let table = eigen_table(model, &cfg.speed_grid.values());
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
        out.write_csv(
            "eigenvalues.csv",
            &[
                "v_mps", "re1", "im1", "re2", "im2", "re3", "im3", "re4", "im4",
            ],
            &rows,
        )?;
        ctx.progress.advance(1);

        // 2. V_crit
        let s = &cfg.critical_speed;
        let search = CriticalSpeedOptions {
            v_min: s.v_min_mps,
            v_max: s.v_max_mps,
            scan_step: s.scan_step_mps,
            tolerance: s.tolerance_mps,
        };
        let vc = model.critical_speed(&search)?;
        ctx.progress.advance(1);

        // 3. sensitivities and the rounding band of h and l
        let sens = sensitivities(
            &ctx.vehicle,
            vc.v_crit_mps,
            &cfg.sensitivity,
            s.tolerance_mps,
        )?;
        let sens_rows: Vec<Vec<String>> = sens
            .iter()
            .map(|x| {
                vec![
                    x.key.to_string(),
                    x.symbol.to_string(),
                    x.unit.to_string(),
                    crate::io::fmt_num(x.value),
                    crate::io::fmt_num(x.dv_crit_dp),
                    crate::io::fmt_num(x.elasticity),
                ]
            })
            .collect();
        out.write_csv_cells(
            "sensitivity.csv",
            &["key", "symbol", "unit", "value", "dv_crit_dp", "elasticity"],
            &sens_rows,
        )?;
        let (ih, il) = (
            parameter_index("h").unwrap_or(9),
            parameter_index("l").unwrap_or(10),
        );
        let dh = sens[ih].dv_crit_dp;
        let dl = sens[il].dv_crit_dp;
        let r = cfg.length_rounding_m;
        let band = (dh.abs() + dl.abs()) * r;
        let offsets: Vec<f64> = (0..=40).map(|k| -0.1 + 0.2 * k as f64 / 40.0).collect();
        let h0 = ctx.vehicle.get(ih);
        let l0 = ctx.vehicle.get(il);
        let by_h = v_crit_curve(
            &ctx.vehicle,
            ih,
            &offsets.iter().map(|o| h0 + o).collect::<Vec<_>>(),
            vc.v_crit_mps,
        )?;
        let by_l = v_crit_curve(
            &ctx.vehicle,
            il,
            &offsets.iter().map(|o| l0 + o).collect::<Vec<_>>(),
            vc.v_crit_mps,
        )?;
        let curve_rows: Vec<[f64; 3]> = offsets
            .iter()
            .zip(by_h.iter().zip(&by_l))
            .map(|(&o, (a, b))| [o, a.1, b.1])
            .collect();
        out.write_csv(
            "v_crit_vs_h_l.csv",
            &["offset_m", "v_crit_varying_h_mps", "v_crit_varying_l_mps"],
            &curve_rows,
        )?;
        ctx.progress.advance(1);

        // figures
        let real: Vec<Layer> = (0..4)
            .map(|k| {
                Layer::line(
                    table
                        .speeds
                        .iter()
                        .zip(&table.eigenvalues)
                        .map(|(&v, ev)| (v, ev[k].re))
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
            .collect();
        let v_range = (cfg.speed_grid.min, cfg.speed_grid.max);
        let clip = 8.0;
        let mut p1 = Panel::new(
            "Open loop: real parts of the eigenvalues of Ã(V)",
            "V [m/s]",
            "Re λ [1/s]",
        )
        .x_range(v_range.0, v_range.1)
        .y_range(-clip, 2.0)
        .legend(Legend::LowerLeft);
        p1.layers.push(Layer::band(
            vc.v_crit_mps,
            v_range.1,
            Rgb::RED,
            Some("unstable straight running"),
        ));
        p1.layers.push(Layer::line(
            vec![(v_range.0, 0.0), (v_range.1, 0.0)],
            Rgb::GREY,
            Stroke::Dotted,
            None,
        ));
        p1.layers.extend(real);
        p1.layers.push(Layer::markers(
            vec![(vc.v_crit_mps, 0.0)],
            Rgb::BLACK,
            Some(&format!("V_crit = {:.3} m/s", vc.v_crit_mps)),
        ));
        let imag: Vec<Layer> = (0..4)
            .map(|k| {
                Layer::line(
                    table
                        .speeds
                        .iter()
                        .zip(&table.eigenvalues)
                        .map(|(&v, ev)| (v, ev[k].im / (2.0 * std::f64::consts::PI)))
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
            .collect();
        let mut p2 = Panel::new("Frequencies Im λ / 2π", "V [m/s]", "Im λ / 2π [Hz]")
            .x_range(v_range.0, v_range.1)
            .legend(Legend::UpperRight);
        p2.layers.extend(imag);
        p2.layers.push(Layer::markers(
            vec![
                (vc.v_crit_mps, vc.hopf_frequency_hz),
                (vc.v_crit_mps, -vc.hopf_frequency_hz),
            ],
            Rgb::BLACK,
            Some(&format!("Hopf: {:.3} Hz", vc.hopf_frequency_hz)),
        ));
        Figure::column(vec![p1, p2]).render(&out.path("eigenvalues"))?;

        let p3 = Panel::new(
            "V_crit vs trailer geometry (Table I prints h, l to 0.1 m)",
            "change of the length from Table I [m]",
            "V_crit [m/s]",
        )
        .with(Layer::band(
            -r,
            r,
            Rgb::GREY,
            Some("rounding of Table I (±0.05 m)"),
        ))
        .with(Layer::line(
            by_h.iter().map(|&(p, v)| (p - h0, v)).collect(),
            Rgb::BLUE,
            Stroke::Solid,
            Some("vary h (trailer CG)"),
        ))
        .with(Layer::line(
            by_l.iter().map(|&(p, v)| (p - l0, v)).collect(),
            Rgb::ORANGE,
            Stroke::Solid,
            Some("vary l (trailer axle)"),
        ))
        .with(Layer::line(
            vec![(-0.1, cfg.paper_v_crit_mps), (0.1, cfg.paper_v_crit_mps)],
            Rgb::RED,
            Stroke::Dashed,
            Some(&format!("paper: {} m/s", cfg.paper_v_crit_mps)),
        ))
        .with(Layer::markers(
            vec![(0.0, vc.v_crit_mps)],
            Rgb::BLACK,
            Some(&format!("Table I: {:.3} m/s", vc.v_crit_mps)),
        ))
        .legend(Legend::UpperRight);
        Figure::single(p3).render(&out.path("sensitivity"))?;

        let mut sens_json = Map::new();
        for x in &sens {
            sens_json.insert(
                x.symbol.to_string(),
                json!({"key": x.key, "unit": x.unit, "value": x.value, "dv_crit_dp": x.dv_crit_dp, "elasticity": x.elasticity}),
            );
        }
        let mut summary = Map::new();
        summary.insert("v_crit_mps".into(), json!(vc.v_crit_mps));
        summary.insert("hopf_frequency_hz".into(), json!(vc.hopf_frequency_hz));
        summary.insert("hopf_omega_rad_s".into(), json!(vc.hopf_omega_rad_s));
        summary.insert(
            "spectral_abscissa_slope_per_m".into(),
            json!(vc.crossing_speed),
        );
        summary.insert("paper_v_crit_mps".into(), json!(cfg.paper_v_crit_mps));
        summary.insert(
            "v_crit_minus_paper_mps".into(),
            json!(vc.v_crit_mps - cfg.paper_v_crit_mps),
        );
        summary.insert("dv_crit_dh_mps_per_m".into(), json!(dh));
        summary.insert("dv_crit_dl_mps_per_m".into(), json!(dl));
        summary.insert(
            "v_crit_rounding_band_mps".into(),
            json!([vc.v_crit_mps - band, vc.v_crit_mps + band]),
        );
        summary.insert("sensitivities".into(), Value::Object(sens_json));
        out.write_summary(summary, cfg, &ctx.run_info(&self.file))?;
        ctx.progress.finish();
        let dir = out.commit()?;
        Ok(Report {
            task: TASK.name.into(),
            output_dir: dir,
            lines: vec![
                format!("V_crit = {:.9} m/s", vc.v_crit_mps),
                format!(
                    "Hopf frequency = {:.6} Hz (ω = {:.6} rad/s)",
                    vc.hopf_frequency_hz, vc.hopf_omega_rad_s
                ),
                format!(
                    "dV_crit/dh = {dh:.3} m/s per m, dV_crit/dl = {dl:.3} m/s per m; ±{r} m rounding of h and l moves V_crit by up to ±{band:.2} m/s (paper: {} m/s)",
                    cfg.paper_v_crit_mps
                ),
            ],
        })
    }
}
