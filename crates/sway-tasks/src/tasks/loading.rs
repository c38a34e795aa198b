//! `cargo xtask loading`: V_crit over trailer mass × centre-of-gravity position, with
//! lines of constant tongue load (beyond the paper).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use crate::TaskError;
use sway::config::{Grid, ensure};
use sway::loading::{InertiaScaling, loaded, tongue_load_fraction, v_crit_map, v_crit_of};
use trailer_model::{CriticalSpeedOptions, VehicleParams};

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
};

/// `configs/loading.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadingConfig {
    /// trailer mass m2 \[kg\]
    pub trailer_mass_kg: Grid,
    /// trailer centre of gravity behind the hitch h \[m\]
    pub trailer_cog_m: Grid,
    /// how J2 follows m2
    #[serde(default)]
    pub inertia: InertiaScaling,
    /// tongue loads to draw as lines \[% of trailer weight\]
    #[serde(default = "default_tongue")]
    pub tongue_load_lines_pct: Vec<f64>,
    /// V_crit search range \[m/s\]: cells outside are left empty
    #[serde(default = "default_v_range")]
    pub v_range_mps: [f64; 2],
}

fn default_tongue() -> Vec<f64> {
    vec![-4.0, 0.0, 4.0, 7.0, 10.0]
}
/// Scan step of each cell's V_crit search \[m/s\].
const SCAN_STEP_MPS: f64 = 0.5;

fn default_v_range() -> [f64; 2] {
    [1.0, 120.0]
}

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
    ensure(
        config.trailer_cog_m.min > 0.0,
        file,
        "trailer_cog_m.min",
        || format!("h must be positive, got {}", config.trailer_cog_m.min),
    )?;
    let [a, b] = config.v_range_mps;
    ensure(a > 0.0 && b > a, file, "v_range_mps", || {
        format!("expected 0 < min < max, got [{a}, {b}]")
    })?;
    // every cell scans the range in steps of SCAN_STEP_MPS until straight running turns
    // unstable: at most MAX_GRID_POINTS steps (a trailer stable at every speed scans it all)
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
    Ok(Box::new(LoadingTask {
        file: file.to_path_buf(),
        config,
    }))
}

/// The V_crit map over the grid and the cut along h at the base mass.
struct LoadingMap {
    masses: Vec<f64>,
    cogs: Vec<f64>,
    /// V_crit \[m/s\], row j for `cogs[j]`, column i for `masses[i]`
    map: Vec<Vec<f64>>,
    /// (tongue load \[%\], V_crit \[m/s\]) along h at the base mass
    cut: Vec<(f64, f64)>,
    /// smallest and largest finite V_crit of the map
    range: (f64, f64),
}

/// Step 1: V_crit over mass × centre of gravity, and the finer cut along h.
fn compute(ctx: &TaskContext<'_>, cfg: &LoadingConfig, opts: &CriticalSpeedOptions) -> LoadingMap {
    let masses = cfg.trailer_mass_kg.values();
    let cogs = cfg.trailer_cog_m.values();
    ctx.progress.start("loading: V_crit map", cogs.len() as u64);
    let map = v_crit_map(&ctx.vehicle, &masses, &cogs, cfg.inertia, opts, &|| {
        ctx.progress.advance(1)
    });
    ctx.progress.finish();
    let base = &ctx.vehicle;
    let cut: Vec<(f64, f64)> = (0..=200)
        .map(|k| {
            let h = cfg.trailer_cog_m.min
                + (cfg.trailer_cog_m.max - cfg.trailer_cog_m.min) * k as f64 / 200.0;
            let p = loaded(base, base.trailer.mass, h, cfg.inertia);
            (100.0 * tongue_load_fraction(&p), v_crit_of(&p, opts))
        })
        .collect();
    let finite = map.iter().flatten().copied().filter(|v| v.is_finite());
    let range = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    LoadingMap {
        masses,
        cogs,
        map,
        cut,
        range,
    }
}

/// Step 2: `v_crit_map.csv` and `v_crit_vs_tongue_load.csv`.
fn write_tables(out: &OutputDir, m: &LoadingMap, axle_m: f64) -> Result<(), TaskError> {
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
    base: &VehicleParams,
    m: &LoadingMap,
    opts: &CriticalSpeedOptions,
) -> Result<(), TaskError> {
    let (lo, hi) = m.range;
    let (masses, cogs, map, cut) = (&m.masses, &m.cogs, &m.map, &m.cut);
    let l = base.trailer.axle;
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
        if h >= cfg.trailer_cog_m.min && h <= cfg.trailer_cog_m.max {
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
        vec![(base.trailer.mass, base.trailer.cog)],
        Rgb::RED,
        Some("Table I"),
    ));
    let cut_panel = Panel::new(
        &format!("Cut at m2 = {} kg", base.trailer.mass),
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
        vec![(100.0 * tongue_load_fraction(base), v_crit_of(base, opts))],
        Rgb::RED,
        Some("Table I"),
    ))
    .legend(Legend::UpperLeft);
    Figure::grid(vec![map_panel, cut_panel], 1, 2, (1500, 620)).render(&out.path("loading"))?;
    Ok(())
}

impl Prepared for LoadingTask {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let cells = c.trailer_mass_kg.points as f64 * c.trailer_cog_m.points as f64;
        let plan = Plan::new(
            vec![format!(
                "loading: {} masses × {} centres of gravity = {cells} V_crit searches",
                c.trailer_mass_kg.points, c.trailer_cog_m.points
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
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        let opts = CriticalSpeedOptions {
            v_min: cfg.v_range_mps[0],
            v_max: cfg.v_range_mps[1],
            scan_step: SCAN_STEP_MPS,
            tolerance: 1e-6,
        };
        let m = compute(ctx, cfg, &opts);
        let base = &ctx.vehicle;
        let l = base.trailer.axle;
        write_tables(&out, &m, l)?;
        draw(&out, cfg, base, &m, &opts)?;
        let at = |q: f64| {
            let p = loaded(base, base.trailer.mass, l * (1.0 - q / 100.0), cfg.inertia);
            v_crit_of(&p, &opts)
        };
        let summary = LoadingSummary {
            tongue_load_pct_table_i: 100.0 * tongue_load_fraction(base),
            v_crit_table_i_mps: v_crit_of(base, &opts),
            v_crit_at_tongue_load_0pct_mps: at(0.0),
            v_crit_at_tongue_load_5pct_mps: at(5.0),
            v_crit_at_tongue_load_10pct_mps: at(10.0),
            v_crit_map_min_mps: m.range.0,
            v_crit_map_max_mps: m.range.1,
            cells_without_critical_speed: m.map.iter().flatten().filter(|v| !v.is_finite()).count(),
        };
        let lines = vec![format!(
            "V_crit at Table I (tongue load {:.1}%) = {:.3} m/s; at 10% tongue load = {:.3} m/s",
            summary.tongue_load_pct_table_i,
            summary.v_crit_table_i_mps,
            summary.v_crit_at_tongue_load_10pct_mps
        )];
        ctx.conclude(out, summary, cfg, &self.file, lines)
    }
}
