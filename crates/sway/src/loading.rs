//! Beyond the paper: how trailer loading moves the critical speed.
//!
//! The paper's V_crit is very sensitive to the trailer's centre of gravity relative to its
//! axle (h − l). Practitioners talk about the same thing as *tongue load*: the static
//! vertical force the trailer puts on the hitch, F_tongue = m2 g (1 − h/l) (statics of
//! Fig. 2; Table I has h > l, a negative tongue load, which lifts the hitch). This module
//! maps V_crit over a grid of trailer mass m2 and centre-of-gravity position h.

use crate::parallel::{Split, map};
use serde::{Deserialize, Serialize};
use trailer_model::{
    AnyVehicleModel, CriticalSpeedOptions, Model, Plant, VehicleParams, VehicleSpec,
};

/// How the trailer's yaw inertia follows its mass on the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum InertiaScaling {
    /// J2 ∝ m2 (same radius of gyration as the base vehicle): load spread like the base
    #[default]
    ScaleWithMass,
    /// J2 fixed at the base vehicle's value
    Fixed,
}

/// Tongue load as a fraction of the trailer weight, 1 − h/l \[-\].
pub fn tongue_load_fraction(params: &VehicleParams) -> f64 {
    1.0 - params.trailer.cog / params.trailer.axle
}

/// The base vehicle with trailer mass `m2` \[kg\] and centre of gravity `h` \[m\].
pub fn loaded(base: &VehicleParams, m2: f64, h: f64, inertia: InertiaScaling) -> VehicleParams {
    let mut p = *base;
    if inertia == InertiaScaling::ScaleWithMass {
        p.trailer.yaw_inertia = base.trailer.yaw_inertia * m2 / base.trailer.mass;
    }
    p.trailer.mass = m2;
    p.trailer.cog = h;
    p
}

/// V_crit \[m/s\] of one loading, NaN when straight running has no stability change in
/// `opts`' range (stable throughout, or unstable from the lowest speed) or the vehicle is
/// invalid.
pub fn v_crit_of(params: &VehicleParams, opts: &CriticalSpeedOptions) -> f64 {
    Model::new(*params)
        .and_then(|m| m.critical_speed(opts))
        .map_or(f64::NAN, |c| c.v_crit_mps)
}

/// What the loading study varies: the trailer of a two-unit vehicle.
const LOADED_TRAILER: &str = "one trailer to load (`trailer.mass` × `trailer.cog`)";

/// The vehicle `base` with trailer mass `m2` \[kg\] and centre of gravity `h` \[m\] (J2 as
/// `inertia` says): any two-unit vehicle file, model variants included (each loading is its
/// own plant; a file of the paper's form gives the paper's numbers).
///
/// # Errors
/// [`trailer_model::ModelError::InvalidSpec`] naming `trailers` for a chain of towed units
/// ([`VehicleSpec::two_unit_trailer`]).
pub fn loaded_vehicle(
    base: &VehicleSpec,
    m2: f64,
    h: f64,
    inertia: InertiaScaling,
) -> Result<VehicleSpec, trailer_model::ModelError> {
    let mut s = base.clone();
    let trailer = s.two_unit_trailer_mut(LOADED_TRAILER)?;
    if inertia == InertiaScaling::ScaleWithMass {
        trailer.yaw_inertia = trailer.yaw_inertia * m2 / trailer.mass;
    }
    trailer.mass = m2;
    trailer.cog = h;
    Ok(s)
}

/// The trailer mass m2 \[kg\] of a two-unit vehicle file, NaN for a chain.
pub fn base_trailer_mass(spec: &VehicleSpec) -> f64 {
    spec.two_unit_trailer(LOADED_TRAILER)
        .map_or(f64::NAN, |t| t.mass)
}

/// V_crit \[m/s\] of a vehicle file in `opts`' range, NaN as [`v_crit_of`].
pub fn vehicle_v_crit(spec: &VehicleSpec, opts: &CriticalSpeedOptions) -> f64 {
    AnyVehicleModel::new(spec)
        .and_then(|m| trailer_model::with_plant!(&m, p => Plant::critical_speed(p, opts)))
        .map_or(f64::NAN, |c| c.v_crit_mps)
}

/// l \[m\]: hitch → trailer axle (of a tandem: the mean position, where its load acts).
pub fn trailer_axle(spec: &VehicleSpec) -> f64 {
    spec.equivalent_params()
        .map_or(f64::NAN, |p| p.trailer.axle)
}

/// The tongue load fraction 1 − h/l \[-\] of a two-unit vehicle file, NaN for a chain.
pub fn vehicle_tongue_load_fraction(spec: &VehicleSpec) -> f64 {
    spec.two_unit_trailer(LOADED_TRAILER)
        .map_or(f64::NAN, |t| 1.0 - t.cog / trailer_axle(spec))
}

/// V_crit on the grid `masses × cogs`, row j for `cogs[j]`, column i for `masses[i]`.
/// Parallel over rows; each cell is independent, so the result does not depend on the
/// number of threads.
pub fn v_crit_map(
    base: &VehicleSpec,
    masses: &[f64],
    cogs: &[f64],
    inertia: InertiaScaling,
    opts: &CriticalSpeedOptions,
    progress: &(dyn Fn() + Sync),
) -> Vec<Vec<f64>> {
    map(cogs, Split::Adaptive, &|_, &h| {
        let row = masses
            .iter()
            .map(|&m2| {
                loaded_vehicle(base, m2, h, inertia).map_or(f64::NAN, |p| vehicle_v_crit(&p, opts))
            })
            .collect();
        progress();
        row
    })
}

/// The V_crit map of [`v_crit_map`] with the finer cut along h at the base mass and the
/// range of its finite values: everything `cargo xtask loading` draws and summarises.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadingMap {
    /// trailer masses m2 \[kg\] (columns)
    pub masses: Vec<f64>,
    /// centres of gravity h \[m\] (rows)
    pub cogs: Vec<f64>,
    /// V_crit \[m/s\], row j for `cogs[j]`, column i for `masses[i]` (NaN: no stability
    /// change in the search range)
    pub map: Vec<Vec<f64>>,
    /// (tongue load \[%\], V_crit \[m/s\]) along h at the base mass, `CUT_POINTS` + 1 points
    pub cut: Vec<(f64, f64)>,
    /// the smallest and largest finite V_crit of the map \[m/s\]
    pub range: (f64, f64),
}

/// Intervals of the cut along h at the base mass.
pub const CUT_POINTS: usize = 200;

/// The loading map of `base` over `masses × cogs`, and the cut along h ∈ \[first, last of
/// `cogs`\] at the base mass (`progress` is called once per row of the map).
pub fn loading_map(
    base: &VehicleSpec,
    masses: Vec<f64>,
    cogs: Vec<f64>,
    inertia: InertiaScaling,
    opts: &CriticalSpeedOptions,
    progress: &(dyn Fn() + Sync),
) -> LoadingMap {
    let map = v_crit_map(base, &masses, &cogs, inertia, opts, progress);
    let (h0, h1) = (cogs[0], cogs[cogs.len() - 1]);
    let cut = (0..=CUT_POINTS)
        .map(|k| {
            let h = h0 + (h1 - h0) * k as f64 / CUT_POINTS as f64;
            loaded_vehicle(base, base_trailer_mass(base), h, inertia).map_or(
                (f64::NAN, f64::NAN),
                |p| {
                    (
                        100.0 * vehicle_tongue_load_fraction(&p),
                        vehicle_v_crit(&p, opts),
                    )
                },
            )
        })
        .collect();
    let range = map
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
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

/// V_crit \[m/s\] of `base` with its trailer loaded to the tongue load `pct` \[% of the
/// trailer weight\] at its own mass (h = l (1 − pct/100)); NaN as [`v_crit_of`].
pub fn v_crit_at_tongue_load(
    base: &VehicleSpec,
    pct: f64,
    inertia: InertiaScaling,
    opts: &CriticalSpeedOptions,
) -> f64 {
    let h = trailer_axle(base) * (1.0 - pct / 100.0);
    loaded_vehicle(base, base_trailer_mass(base), h, inertia)
        .map_or(f64::NAN, |p| vehicle_v_crit(&p, opts))
}
