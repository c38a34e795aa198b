//! The computation of `loading`: V_crit over trailer mass × centre-of-gravity position of
//! the vehicle file's trailer, the cut along the tongue load at its own mass, and the
//! vehicle's V_crit at a few tongue loads, each searched in one speed range (the config's,
//! or relative to the vehicle's V_crit, or the limits').

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::config::Grid;
use sway::loading::{
    InertiaScaling, LoadingMap, loading_map, trailer_axle, v_crit_at_tongue_load,
    vehicle_tongue_load_fraction, vehicle_v_crit,
};
use sway::progress::Progress;
use sway::ranging::{SpeedLimits, SpeedSpec, open_loop_references};
use trailer_model::{AnyVehicleModel, CriticalSpeedOptions, VehicleSpec};

/// `configs/loading.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadingConfig {
    /// trailer mass m2 \[kg\]
    pub trailer_mass_kg: Grid,
    /// trailer centre of gravity behind the hitch h \[m\] (or `trailer_cog_of_axle`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trailer_cog_m: Option<Grid>,
    /// h relative to the vehicle's trailer axle, h/l \[-\] (or `trailer_cog_m`): the same
    /// range of tongue loads 1 − h/l for a short and a long trailer
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trailer_cog_of_axle: Option<Grid>,
    /// how J2 follows m2
    #[serde(default)]
    pub inertia: InertiaScaling,
    /// tongue loads to draw as lines \[% of trailer weight\]
    #[serde(default = "default_tongue")]
    pub tongue_load_lines_pct: Vec<f64>,
    /// V_crit search range \[m/s\] (numbers, or relative to the vehicle's V_crit,
    /// `{ of_v_crit = f }`): cells outside are left empty. Omitted: from the lowest to the
    /// maximum speed (`--max-speed`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub v_range_mps: Option<[SpeedSpec; 2]>,
}

impl LoadingConfig {
    /// The centres of gravity h \[m\] of the map's rows for a trailer axle at `axle_m`.
    ///
    /// # Panics
    /// When the config gives neither `trailer_cog_m` nor `trailer_cog_of_axle` (the task
    /// refuses such a config when it reads it).
    pub fn cogs(&self, axle_m: f64) -> Grid {
        match (self.trailer_cog_m, self.trailer_cog_of_axle) {
            (Some(g), _) => g,
            (None, Some(g)) => Grid {
                min: g.min * axle_m,
                max: g.max * axle_m,
                points: g.points,
            },
            (None, None) => unreachable!("checked by prepare"),
        }
    }
}

fn default_tongue() -> Vec<f64> {
    vec![-4.0, 0.0, 4.0, 7.0, 10.0]
}

/// Scan step of each cell's V_crit search \[m/s\].
pub const SCAN_STEP_MPS: f64 = 0.5;

/// The V_crit search range for this vehicle \[m/s\], and why it is not the config's
/// (a relative end of a vehicle without V_crit falls back to the limits).
///
/// # Errors
/// [`SwayError::Numerical`] from the open-loop references of a relative end.
pub fn v_range(
    cfg: &LoadingConfig,
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
) -> Result<([f64; 2], Option<String>), SwayError> {
    let Some([a, b]) = cfg.v_range_mps else {
        return Ok(([limits.min_speed_mps, limits.max_speed_mps], None));
    };
    let need = a.needs().max(b.needs());
    let refs = trailer_model::with_plant!(vehicle, m => open_loop_references(m, limits, need))?;
    let fallback = [limits.min_speed_mps, limits.max_speed_mps];
    match (a.resolve(&refs), b.resolve(&refs)) {
        (Ok(lo), Ok(hi)) => Ok(([lo, hi], None)),
        (ra, rb) => {
            let why = ra.err().or(rb.err()).map(|u| u.reason).unwrap_or_default();
            let lo = a.resolve(&refs).unwrap_or(fallback[0]);
            let hi = b.resolve(&refs).unwrap_or(fallback[1]);
            Ok((
                [lo, hi],
                Some(format!(
                    "v_range_mps relative to V_crit does not resolve ({why}): the search runs over [{lo}, {hi}] m/s"
                )),
            ))
        }
    }
}

/// Everything `loading` computes.
#[derive(Debug, Clone, PartialEq)]
pub struct Loading {
    /// l \[m\]: hitch → trailer axle of the vehicle (of a tandem: the mean position of its
    /// axles, where their load acts)
    pub axle_m: f64,
    /// the centres of gravity of the map's rows \[m\]
    pub cogs: Grid,
    /// the V_crit search of every cell
    pub search: CriticalSpeedOptions,
    /// why the search range is not the config's (a relative end without V_crit)
    pub v_range_reason: Option<String>,
    /// the map, its cut at the vehicle's trailer mass and the range of its values
    pub map: LoadingMap,
    /// the vehicle's tongue load 1 − h/l \[% of the trailer weight\]
    pub tongue_load_pct: f64,
    /// the vehicle's V_crit \[m/s\] (NaN: none in the search range)
    pub v_crit_mps: f64,
    /// V_crit at the vehicle's trailer mass with 0 %, 5 % and 10 % tongue load \[m/s\]
    pub v_crit_at_tongue_load_mps: [f64; 3],
    /// map cells without a critical speed in the search range
    pub cells_without_critical_speed: usize,
}

/// The tongue loads of [`Loading::v_crit_at_tongue_load_mps`] \[% of the trailer weight\].
pub const TONGUE_LOADS_PCT: [f64; 3] = [0.0, 5.0, 10.0];

/// The whole computation (no I/O): the search range, the map over the config's masses and
/// centres of gravity of the trailer of `spec` (any model variant: its own plant in every
/// cell) and the vehicle's numbers; `plant` is the plant of `spec`, whose V_crit a range
/// relative to V_crit refers to. Advances `progress` by one per row of the map.
///
/// # Errors
/// [`SwayError::Numerical`] from the search range; [`SwayError::Model`] naming `trailers`
/// for a chain of towed units (the map varies the one trailer's mass and centre of gravity).
pub fn compute(
    cfg: &LoadingConfig,
    spec: &VehicleSpec,
    plant: &AnyVehicleModel,
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<Loading, SwayError> {
    spec.two_unit_trailer("trailer loading map (`trailer.mass` × `trailer.cog`)")?;
    let axle_m = trailer_axle(spec);
    let ([v_min, v_max], v_range_reason) = v_range(cfg, plant, limits)?;
    let search = CriticalSpeedOptions {
        v_min,
        v_max,
        scan_step: SCAN_STEP_MPS,
        tolerance: 1e-6,
    };
    let cogs = cfg.cogs(axle_m);
    let map = loading_map(
        spec,
        cfg.trailer_mass_kg.values(),
        cogs.values(),
        cfg.inertia,
        &search,
        &|| progress.advance(1),
    );
    let v_crit_mps = vehicle_v_crit(spec, &search);
    let v_crit_at_tongue_load_mps =
        TONGUE_LOADS_PCT.map(|q| v_crit_at_tongue_load(spec, q, cfg.inertia, &search));
    let cells_without_critical_speed = map.map.iter().flatten().filter(|v| !v.is_finite()).count();
    Ok(Loading {
        axle_m,
        cogs,
        search,
        v_range_reason,
        map,
        tongue_load_pct: 100.0 * vehicle_tongue_load_fraction(spec),
        v_crit_mps,
        v_crit_at_tongue_load_mps,
        cells_without_critical_speed,
    })
}
