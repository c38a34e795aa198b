//! The computation of `variants`: how the paper's conclusions move when its simplifications
//! are lifted. For Table I with tyre relaxation σ on every axle
//! ([`VehicleSpec::table_i_with_relaxation`]) and for vehicle files (Magic Formula tyres, a
//! tandem trailer axle, hitch friction): the headline numbers of [`crate::fleet`] (V_crit,
//! V_fold, the bistable width, D\*(τ), the θ(0) threshold of sway) and the threshold at one
//! speed common to all rows; and V_crit and V_fold over a finer σ grid.

use std::borrow::Cow;
use std::path::PathBuf;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::config::Grid;
use sway::progress::Progress;
use sway::ranging::{Reference, SpeedLimits, open_loop_references};
use trailer_model::{AnyVehicleModel, VehicleSpec, with_plant};

use crate::fleet::{FleetEntry, FleetOptions, fleet_entry, threshold_at};

fn default_sigmas() -> Vec<f64> {
    vec![0.0, 0.3, 0.6]
}

fn default_curve() -> Grid {
    Grid {
        min: 0.0,
        max: 0.6,
        points: 13,
    }
}

/// `configs/variants.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VariantsConfig {
    /// rows of Table I with this relaxation length σ on every axle \[m\] (0: the paper's model)
    #[serde(default = "default_sigmas")]
    pub relaxation_lengths_m: Vec<f64>,
    /// further rows: vehicle files, relative to this file's directory
    #[serde(default)]
    pub vehicle_files: Vec<PathBuf>,
    /// the figure's σ grid \[m\] (V_crit and V_fold only)
    #[serde(default = "default_curve")]
    pub curve_relaxation_lengths_m: Grid,
    /// the θ(0) threshold also at this speed, the same for every row \[m/s\] (below the
    /// row's V_crit; omitted: not computed)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub common_speed_mps: Option<f64>,
    /// what is computed for each row (as `fleet`'s `[headline]`)
    #[serde(default)]
    pub headline: FleetOptions,
}

/// One row of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VariantRow {
    /// what differs from Table I (`"Table I"`, `"σ = 0.3 m on every axle"`, the file)
    pub variant: String,
    /// the relaxation length on every axle \[m\] (rows of `relaxation_lengths_m`)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relaxation_length_m: Option<f64>,
    /// the vehicle file (rows of `vehicle_files`), as written in the config
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vehicle_file: Option<String>,
    /// reduced states of its plant (4: the paper's model)
    pub states: usize,
    /// the headline numbers (V_crit, V_fold, bistable width, D\*, threshold; `reasons`)
    #[serde(flatten)]
    pub entry: FleetEntry,
    /// the θ(0) threshold at `common_speed_mps` \[deg\] (null: see `reasons`)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub theta0_threshold_at_common_speed_deg: Option<f64>,
}

/// One point of the σ curve.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct CurvePoint {
    /// σ on every axle \[m\]
    pub relaxation_length_m: f64,
    /// open-loop V_crit \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// fold of cycles \[m/s\]
    pub v_fold_mps: Option<f64>,
    /// V_crit − V_fold \[m/s\]
    pub bistable_width_mps: Option<f64>,
    /// why a number is null (null: none is)
    pub reason: Option<String>,
}

/// Everything `variants` computes.
#[derive(Debug, Clone, PartialEq)]
pub struct Variants {
    /// one row per σ, then one per vehicle file, in the config's order
    pub rows: Vec<VariantRow>,
    /// V_crit and V_fold over `curve_relaxation_lengths_m`
    pub curve: Vec<CurvePoint>,
}

/// A row to compute: its name, σ or file, and plant (built for a σ row, the caller's for
/// a file).
struct Row<'a> {
    variant: String,
    sigma: Option<f64>,
    file: Option<String>,
    plant: Cow<'a, AnyVehicleModel>,
}

/// The plant of Table I with σ on every axle.
fn relaxed(sigma: f64) -> Result<AnyVehicleModel, SwayError> {
    AnyVehicleModel::new(&VehicleSpec::table_i_with_relaxation(sigma))
        .map_err(|e| SwayError::numerical(format!("Table I with σ = {sigma} m"), e))
}

fn row_name(sigma: f64) -> String {
    if sigma == 0.0 {
        "Table I (paper's model)".into()
    } else {
        format!("σ = {sigma} m on every axle")
    }
}

/// The headline numbers of one row, with the threshold at the common speed.
fn compute_row(
    row: &Row<'_>,
    cfg: &VariantsConfig,
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<VariantRow, SwayError> {
    let plant = row.plant.as_ref();
    let mut entry = fleet_entry(plant, limits, &cfg.headline)?;
    let mut common = None;
    if let Some(v) = cfg.common_speed_mps {
        match entry.v_crit_mps {
            Some(vc) if v >= vc => entry.reasons.push(format!(
                "the common speed {v} m/s is not below V_crit: straight running is unstable there, no threshold"
            )),
            _ => {
                common = threshold_at(plant, v, &cfg.headline)?;
                if common.is_none() {
                    let below = match entry.v_fold_mps {
                        Some(f) if v < f => format!(" (below its fold of cycles V_fold = {f:.4} m/s: no sway cycle there)"),
                        _ => String::new(),
                    };
                    entry.reasons.push(format!(
                        "no θ(0) up to {}° ends in sustained sway at the common speed {v} m/s{below}",
                        cfg.headline.theta0_deg[1]
                    ));
                }
            }
        }
    }
    progress.advance(1);
    Ok(VariantRow {
        variant: row.variant.clone(),
        relaxation_length_m: row.sigma,
        vehicle_file: row.file.clone(),
        states: plant.states(),
        entry,
        theta0_threshold_at_common_speed_deg: common,
    })
}

/// V_crit and V_fold of Table I with σ on every axle.
fn curve_point(
    sigma: f64,
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<CurvePoint, SwayError> {
    let plant = relaxed(sigma)?;
    let r = with_plant!(&plant, m => open_loop_references(m, limits, Reference::Fold))?;
    progress.advance(1);
    Ok(CurvePoint {
        relaxation_length_m: sigma,
        v_crit_mps: r.v_crit_mps,
        v_fold_mps: r.v_fold_mps,
        bistable_width_mps: r.v_crit_mps.zip(r.v_fold_mps).map(|(c, f)| c - f),
        reason: r.reason,
    })
}

/// The number of progress steps of [`compute`]: one per row and one per point of the curve.
pub fn steps(cfg: &VariantsConfig) -> u64 {
    (cfg.relaxation_lengths_m.len()
        + cfg.vehicle_files.len()
        + cfg.curve_relaxation_lengths_m.values().len()) as u64
}

/// The whole computation (no I/O): the rows and the curve side by side on the thread pool
/// (each row and point deterministic, results in the config's order). `files` are the
/// plants of `cfg.vehicle_files`, in their order (the caller reads the files). Advances
/// `progress` by [`steps`].
///
/// # Errors
/// [`SwayError::Config`] when `files` does not hold one plant per vehicle file;
/// [`SwayError::Numerical`] from a row or a point.
pub fn compute(
    cfg: &VariantsConfig,
    files: &[AnyVehicleModel],
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<Variants, SwayError> {
    if files.len() != cfg.vehicle_files.len() {
        return Err(SwayError::config(
            "variants",
            "vehicle_files",
            format!(
                "expected one plant per vehicle file ({}), got {}",
                cfg.vehicle_files.len(),
                files.len()
            ),
        ));
    }
    let mut rows = Vec::new();
    for &sigma in &cfg.relaxation_lengths_m {
        rows.push(Row {
            variant: row_name(sigma),
            sigma: Some(sigma),
            file: None,
            plant: Cow::Owned(relaxed(sigma)?),
        });
    }
    for (f, plant) in cfg.vehicle_files.iter().zip(files) {
        rows.push(Row {
            variant: f
                .file_stem()
                .map_or_else(|| f.display().to_string(), |s| s.to_string_lossy().into()),
            sigma: None,
            file: Some(f.display().to_string()),
            plant: Cow::Borrowed(plant),
        });
    }
    let sigmas = cfg.curve_relaxation_lengths_m.values();
    let (table, curve) = rayon::join(
        || {
            rows.par_iter()
                .map(|r| compute_row(r, cfg, limits, progress))
                .collect::<Vec<_>>()
        },
        || {
            sigmas
                .par_iter()
                .map(|&s| curve_point(s, limits, progress))
                .collect::<Vec<_>>()
        },
    );
    Ok(Variants {
        rows: table.into_iter().collect::<Result<Vec<_>, _>>()?,
        curve: curve.into_iter().collect::<Result<Vec<_>, _>>()?,
    })
}
