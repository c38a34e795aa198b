//! `cargo xtask loading`: V_crit over trailer mass × centre-of-gravity position, with
//! lines of constant tongue load (beyond the paper; [`sway_studies::loading`]).

use std::path::{Path, PathBuf};

use serde::Serialize;
use crate::TaskError;
use sway::config::ensure;
use sway::ranging::Reference;
use sway::sim::speeds::SpeedValue;
pub use sway_studies::loading::{LoadingConfig, SCAN_STEP_MPS};
use sway_studies::loading::{Loading, compute};
use trailer_model::VehicleSpec;

use crate::limits::{
    BYTES_PER_ROW, LOADING_SECONDS_PER_CELL, MAX_SIMULATIONS, Plan, bound, human_seconds,
};
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::load_toml;
use crate::io::OutputDir;
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task.
pub const TASK: Task = Task {
    name: "loading",
    about: "V_crit vs trailer mass and centre of gravity, tongue-load lines (beyond the paper)",
    config: "loading.toml",
    prepare,
    models: super::Models::Any,
    runs: super::Runs::InAll,
};

/// `summary.json` of `loading` (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadingSummary {
    /// tongue load of Table I (1 − h/l) \[% of the trailer weight\]
    pub tongue_load_pct_table_i: f64,
    /// V_crit of Table I \[m/s\]
    pub v_crit_table_i_mps: f64,
    /// V_crit at Table I's trailer mass with 0 % tongue load \[m/s\]
    pub v_crit_at_tongue_load_0pct_mps: f64,
    /// … with 5 % tongue load \[m/s\]
    pub v_crit_at_tongue_load_5pct_mps: f64,
    /// … with 10 % tongue load \[m/s\]
    pub v_crit_at_tongue_load_10pct_mps: f64,
    /// the smallest V_crit of the map \[m/s\]
    pub v_crit_map_min_mps: f64,
    /// the largest V_crit of the map \[m/s\]
    pub v_crit_map_max_mps: f64,
    /// map cells without a critical speed in the search range
    pub cells_without_critical_speed: usize,
    /// the V_crit search range of every cell \[m/s\]
    pub v_range_mps: [f64; 2],
    /// the centres of gravity of the map \[m\] (first and last row)
    pub trailer_cog_range_m: [f64; 2],
    /// why the search range is not the config's (a relative end without V_crit)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_range_reason: Option<String>,
}

struct LoadingTask {
    file: PathBuf,
    config: LoadingConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    let config: LoadingConfig = load_toml(file)?;
    ensure(
        config.trailer_mass_kg.min > 0.0,
        file,
        "trailer_mass_kg.min",
        || {
            format!(
                "masses must be positive, got {}",
                config.trailer_mass_kg.min
            )
        },
    )?;
    let cog_key = match (config.trailer_cog_m, config.trailer_cog_of_axle) {
        (Some(_), None) => "trailer_cog_m",
        (None, Some(_)) => "trailer_cog_of_axle",
        _ => {
            return Err(TaskError::config(
                file,
                "trailer_cog_m",
                "give exactly one of trailer_cog_m (h in m) and trailer_cog_of_axle (h/l)",
            ));
        }
    };
    let cogs = config.trailer_cog_m.or(config.trailer_cog_of_axle);
    let cog_min = cogs.map_or(0.0, |g| g.min);
    ensure(cog_min > 0.0, file, &format!("{cog_key}.min"), || {
        format!("h must be positive, got {cog_min}")
    })?;
    if let Some([a, b]) = config.v_range_mps {
        if let (Some(a), Some(b)) = (a.absolute(), b.absolute()) {
            ensure(a > 0.0 && b > a, file, "v_range_mps", || {
                format!("expected 0 < min < max, got [{a}, {b}]")
            })?;
            // every cell scans the range in steps of SCAN_STEP_MPS until straight running
            // turns unstable: at most MAX_GRID_POINTS steps
            let scan_points = (b - a) / SCAN_STEP_MPS;
            crate::limits::bound(
                file,
                "v_range_mps",
                scan_points,
                sway::config::MAX_GRID_POINTS as f64,
                || {
                    format!(
                        "{scan_points:.3e} scan steps of {SCAN_STEP_MPS} m/s per cell; narrow the range"
                    )
                },
            )?;
        }
        for (k, end) in [a, b].iter().enumerate() {
            if end.needs() == Reference::Fold {
                return Err(TaskError::config(
                    file,
                    format!("v_range_mps[{k}]"),
                    "expected a number [m/s] or { of_v_crit = f }",
                ));
            }
        }
    }
    Ok(Box::new(LoadingTask {
        file: file.to_path_buf(),
        config,
    }))
}

/// Step 2: `v_crit_map.csv` and `v_crit_vs_tongue_load.csv`.
fn write_tables(out: &OutputDir, r: &Loading) -> Result<(), TaskError> {
    let (m, axle_m) = (&r.map, r.axle_m);
    let mut rows = Vec::with_capacity(m.masses.len() * m.cogs.len());
    for (j, &h) in m.cogs.iter().enumerate() {
        for (i, &m2) in m.masses.iter().enumerate() {
            rows.push([m2, h, 100.0 * (1.0 - h / axle_m), m.map[j][i]]);
        }
    }
    out.write_csv(
        "v_crit_map.csv",
        &[
            "trailer_mass_kg",
            "trailer_cog_m",
            "tongue_load_pct",
            "v_crit_mps",
        ],
        &rows,
    )?;
    out.write_csv(
        "v_crit_vs_tongue_load.csv",
        &["tongue_load_pct", "v_crit_mps"],
        m.cut.iter().map(|&(a, b)| [a, b]),
    )
}

/// Cell edges of a uniform axis (midpoints, ends extended by half a spacing).
fn edges(v: &[f64]) -> Vec<f64> {
    let n = v.len();
    let mut e = Vec::with_capacity(n + 1);
    e.push(v[0] - 0.5 * (v[1] - v[0]));
    for k in 0..n - 1 {
        e.push(0.5 * (v[k] + v[k + 1]));
    }
    e.push(v[n - 1] + 0.5 * (v[n - 1] - v[n - 2]));
    e
}

/// Step 3: `loading.svg/.png`, the map with tongue-load lines and the cut.
fn draw(
    out: &OutputDir,
    cfg: &LoadingConfig,
    base: &VehicleSpec,
    who: &str,
    r: &Loading,
) -> Result<(), TaskError> {
    let m = &r.map;
    // (the study refuses a chain of towed units: the base is a two-unit vehicle here)
    let base_mass = sway::loading::base_trailer_mass(base);
    let base_cog = base.trailer.as_ref().map_or(f64::NAN, |t| t.cog);
    let (lo, hi) = m.range;
    let (masses, cogs, map, cut) = (&m.masses, &m.cogs, &m.map, &m.cut);
    let l = r.axle_m;
    let mut map_panel = Panel::new(
        "Critical speed of straight running vs trailer loading",
        "trailer mass m2 [kg]",
        "trailer CG behind hitch h [m]",
    )
    .with(Layer::Heatmap {
        x_edges: edges(masses),
        y_edges: edges(cogs),
        values: map.clone(),
        range: (lo, hi),
        label: "V_crit [m/s]".into(),
    })
    .legend(Legend::LowerRight);
    // tongue load is independent of m2 as a fraction: horizontal lines h = l (1 − q)
    for (k, &q) in cfg.tongue_load_lines_pct.iter().enumerate() {
        let h = l * (1.0 - q / 100.0);
        if h >= m.cogs[0] && h <= m.cogs[m.cogs.len() - 1] {
            map_panel.layers.push(Layer::line(
                vec![(cfg.trailer_mass_kg.min, h), (cfg.trailer_mass_kg.max, h)],
                if q.abs() < 1e-12 {
                    Rgb::BLACK
                } else {
                    Rgb::palette(k + 3)
                },
                Stroke::Dashed,
                Some(&format!("tongue load {q}%")),
            ));
        }
    }
    map_panel.layers.push(Layer::markers(
        vec![(base_mass, base_cog)],
        Rgb::RED,
        Some(who),
    ));
    let cut_panel = Panel::new(
        &format!("Cut at m2 = {base_mass} kg"),
        "tongue load 1 − h/l [% of trailer weight]",
        "V_crit [m/s]",
    )
    .with(Layer::line(
        cut.clone(),
        Rgb::BLUE,
        Stroke::Solid,
        Some("V_crit"),
    ))
    .with(Layer::markers(
        vec![(r.tongue_load_pct, r.v_crit_mps)],
        Rgb::RED,
        Some(who),
    ))
    .legend(Legend::UpperLeft);
    Figure::grid(vec![map_panel, cut_panel], 1, 2, (1500, 620)).render(&out.path("loading"))?;
    Ok(())
}

impl Prepared for LoadingTask {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let cog_points = c.cogs(1.0).points;
        let cells = c.trailer_mass_kg.points as f64 * cog_points as f64;
        let plan = Plan::new(
            vec![format!(
                "loading: {} masses × {cog_points} centres of gravity = {cells} V_crit searches",
                c.trailer_mass_kg.points
            )],
            cells * BYTES_PER_ROW,
            cells * LOADING_SECONDS_PER_CELL,
        );
        // each axis is a Grid (≤ MAX_GRID_POINTS); the product is bounded like a sweep
        bound(&self.file, "trailer_mass_kg.points", cells, MAX_SIMULATIONS as f64, || {
            format!(
                "mass × cog = {cells} cells, ≈ {}",
                human_seconds(plan.time_s)
            )
        })?;
        Ok(plan)
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        // the map varies the file's trailer (any model variant: its own plant in every cell;
        // a tandem's l is the mean position of its axles, where their load acts)
        let base = &ctx.spec;
        let who = if ctx.variant_key.is_none() && ctx.vehicle.is_table_i() {
            "Table I"
        } else {
            "this vehicle"
        };
        let rows = cfg.cogs(1.0).points as u64;
        ctx.run_staged(TASK.name, "loading: V_crit map", rows, cfg, &self.file, |out| {
            if ctx.spec.is_chain() {
                return Err(TaskError::NotApplicable {
                    key: "trailers".to_string(),
                    reason: format!(
                        "the map varies the mass and centre of gravity of a two-unit vehicle's \
                         trailer; a chain of {} towed units has no such trailer (its units' \
                         loads are edited in `[[trailers]]` of the vehicle file)",
                        ctx.spec.towed_units()
                    ),
                });
            }
            let r = compute(cfg, base, &ctx.plant, &ctx.limits, ctx.progress)?;
            write_tables(out, &r)?;
            draw(out, cfg, base, who, &r)?;
            let [v_min, v_max] = [r.search.v_min, r.search.v_max];
            let [at_0, at_5, at_10] = r.v_crit_at_tongue_load_mps;
            let summary = LoadingSummary {
                tongue_load_pct_table_i: r.tongue_load_pct,
                v_crit_table_i_mps: r.v_crit_mps,
                v_crit_at_tongue_load_0pct_mps: at_0,
                v_crit_at_tongue_load_5pct_mps: at_5,
                v_crit_at_tongue_load_10pct_mps: at_10,
                v_crit_map_min_mps: r.map.range.0,
                v_crit_map_max_mps: r.map.range.1,
                cells_without_critical_speed: r.cells_without_critical_speed,
                v_range_mps: [v_min, v_max],
                trailer_cog_range_m: [r.cogs.min, r.cogs.max],
                v_range_reason: r.v_range_reason.clone(),
            };
            let mut lines = vec![format!(
                "V_crit at this vehicle's loading (tongue load {:.1}%) = {:.3} m/s; at 10% tongue load = {:.3} m/s (searched in [{v_min:.3}, {v_max:.3}] m/s)",
                summary.tongue_load_pct_table_i,
                summary.v_crit_table_i_mps,
                summary.v_crit_at_tongue_load_10pct_mps
            )];
            if let Some(r) = &r.v_range_reason {
                lines.push(r.clone());
            }
            Ok((summary, lines))
        })
    }
}
