//! Open-loop linear stability of straight running: eigenvalues of Ã(V) (eq. 9–11),
//! the critical speed V_crit where the spectral abscissa changes sign, the Hopf
//! frequency there, and dV_crit/dp for every vehicle parameter.

use nalgebra::Complex;
use serde::{Deserialize, Serialize};
use trailer_model::{CriticalSpeedOptions, PARAMETERS, VehicleParams};

use crate::SwayError;
use crate::config::Grid;
use sway_model::vehicle::{LoopModel, VehicleDescription};

/// Eigenvalues of Ã along a speed grid, each column following one eigenvalue
/// continuously (matched to the previous speed by nearest distance); n columns for a plant
/// of n states (4 for the paper's model).
#[derive(Debug, Clone, PartialEq)]
pub struct EigenTable {
    /// speeds V \[m/s\]
    pub speeds: Vec<f64>,
    /// eigenvalues λ \[1/s\] per speed (n each), continuous branches in fixed columns
    pub eigenvalues: Vec<Vec<Complex<f64>>>,
}

impl EigenTable {
    /// Number of eigenvalues per speed (the plant's state count).
    pub fn columns(&self) -> usize {
        self.eigenvalues.first().map_or(0, Vec::len)
    }
}

/// Plants of at most this many states are matched over all permutations (Heap's
/// algorithm, n! candidates: 24 for the paper's model, 5040 for 7 states); larger ones
/// greedily, closest pair first.
const EXHAUSTIVE_MATCH_STATES: usize = 7;

/// Eigenvalues of Ã on `speeds`, ordered into continuous branches, for any plant
/// ([`LoopModel`]: the paper's `Model`, a `VehicleModel<N>`, an `AnyVehicleModel`).
pub fn eigen_table<M: LoopModel + ?Sized>(model: &M, speeds: &[f64]) -> EigenTable {
    let mut out: Vec<Vec<Complex<f64>>> = Vec::with_capacity(speeds.len());
    for &v in speeds {
        let ev = model.open_loop_spectrum(v);
        let next = match out.last() {
            None => ev,
            Some(prev) if prev.len() == ev.len() && ev.len() <= EXHAUSTIVE_MATCH_STATES => {
                best_match(prev, &ev)
            }
            Some(prev) if prev.len() == ev.len() => greedy_match(prev, &ev),
            Some(_) => ev,
        };
        out.push(next);
    }
    EigenTable {
        speeds: speeds.to_vec(),
        eigenvalues: out,
    }
}

/// The permutation of `ev` closest to `prev` (sum of distances; all n! candidates).
fn best_match(prev: &[Complex<f64>], ev: &[Complex<f64>]) -> Vec<Complex<f64>> {
    let n = ev.len();
    let mut best = ev.to_vec();
    let mut best_cost = f64::INFINITY;
    let mut perm: Vec<usize> = (0..n).collect();
    // Heap's algorithm over the n! permutations
    let mut c = vec![0usize; n];
    let mut eval = |p: &[usize]| {
        let cost: f64 = (0..n).map(|k| (ev[p[k]] - prev[k]).norm()).sum();
        if cost < best_cost {
            best_cost = cost;
            for k in 0..n {
                best[k] = ev[p[k]];
            }
        }
    };
    eval(&perm);
    let mut i = 0;
    while i < n {
        if c[i] < i {
            if i % 2 == 0 {
                perm.swap(0, i);
            } else {
                perm.swap(c[i], i);
            }
            eval(&perm);
            c[i] += 1;
            i = 0;
        } else {
            c[i] = 0;
            i += 1;
        }
    }
    best
}

/// Column k of the result is the eigenvalue of `ev` assigned to `prev[k]`, pairs taken
/// closest first.
fn greedy_match(prev: &[Complex<f64>], ev: &[Complex<f64>]) -> Vec<Complex<f64>> {
    let n = ev.len();
    let mut pairs: Vec<(f64, usize, usize)> = (0..n)
        .flat_map(|k| (0..n).map(move |j| (k, j)))
        .map(|(k, j)| ((ev[j] - prev[k]).norm(), k, j))
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut used_k, mut used_j) = (vec![false; n], vec![false; n]);
    let mut out = ev.to_vec();
    for (_, k, j) in pairs {
        if !used_k[k] && !used_j[j] {
            used_k[k] = true;
            used_j[j] = true;
            out[k] = ev[j];
        }
    }
    out
}

/// dV_crit/dp of one parameter.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Sensitivity {
    /// key path in the vehicle file, e.g. `trailer.cog`
    pub key: &'static str,
    /// paper symbol, e.g. `h`
    pub symbol: &'static str,
    /// unit of the parameter
    pub unit: &'static str,
    /// parameter value
    pub value: f64,
    /// dV_crit/dp \[m/s per unit of p\] (central difference)
    pub dv_crit_dp: f64,
    /// elasticity (p / V_crit) dV_crit/dp \[-\]: % change of V_crit per % change of p
    pub elasticity: f64,
}

/// Options of the sensitivity computation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensitivityOptions {
    /// relative step of the central differences \[-\]
    pub relative_step: f64,
}

impl Default for SensitivityOptions {
    fn default() -> Self {
        Self {
            relative_step: 1e-4,
        }
    }
}

/// V_crit of `model`, searched in `around ± window` \[m/s\].
fn v_crit_near<M: LoopModel + ?Sized>(
    model: &M,
    around: f64,
    window: f64,
    tolerance: f64,
) -> Result<f64, SwayError> {
    let opts = CriticalSpeedOptions {
        v_min: (around - window).max(0.5),
        v_max: around + window,
        scan_step: 0.25,
        tolerance,
    };
    match LoopModel::critical_speed_search(model, &opts)? {
        Some(c) => Ok(c.v_crit_mps),
        None => Err(SwayError::Model(
            trailer_model::ModelError::NoCriticalSpeed {
                v_min: opts.v_min,
                v_max: opts.v_max,
                detail: "straight running stays stable up to v_max",
            },
        )),
    }
}

/// dV_crit/dp for every parameter of [`PARAMETERS`] by central differences of V_crit
/// (each V_crit solved by bisection to `tolerance`) of `vehicle`: the paper's parameters, or
/// a vehicle file of any form (tyre relaxation, tyre laws, axle lists, hitch damping), each
/// parameter changed on the file about its equivalent single-axle value
/// ([`VehicleDescription::with_paper_value`]); a key the file does not have (an axle key of
/// a unit given as a list of axles) gets NaN. The loads, μ0, μ and g do not enter the
/// linearisation (the brush tire's slope at α = 0 is C), so their sensitivities are 0.
///
/// # Errors
/// If the file is invalid or a changed vehicle has no critical speed near the nominal one.
pub fn sensitivities<D: VehicleDescription>(
    vehicle: &D,
    v_crit: f64,
    opts: &SensitivityOptions,
    tolerance: f64,
) -> Result<Vec<Sensitivity>, SwayError> {
    central_differences(
        &vehicle.paper_values()?,
        v_crit,
        opts,
        |i, value| vehicle.with_paper_value(i, value).ok(),
        |changed| v_crit_near(&changed.model()?, v_crit, 3.0, tolerance),
    )
}

/// dV_crit/dp for every parameter of [`PARAMETERS`] about its value in `params`: the
/// vehicle with parameter i changed to a value is `changed(i, value)` (None: it has no
/// such key, the sensitivity NaN), its V_crit `v_crit_of` it.
fn central_differences<T>(
    params: &VehicleParams,
    v_crit: f64,
    opts: &SensitivityOptions,
    changed: impl Fn(usize, f64) -> Option<T>,
    v_crit_of: impl Fn(&T) -> Result<f64, SwayError>,
) -> Result<Vec<Sensitivity>, SwayError> {
    PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, &(key, symbol, unit))| {
            let value = params.get(i);
            let h = opts.relative_step * value;
            let (Some(up), Some(down)) = (changed(i, value + h), changed(i, value - h)) else {
                return Ok(Sensitivity {
                    key,
                    symbol,
                    unit,
                    value,
                    dv_crit_dp: f64::NAN,
                    elasticity: f64::NAN,
                });
            };
            let up = v_crit_of(&up)?;
            let down = v_crit_of(&down)?;
            let d = (up - down) / (2.0 * h);
            Ok(Sensitivity {
                key,
                symbol,
                unit,
                value,
                dv_crit_dp: d,
                elasticity: d * value / v_crit,
            })
        })
        .collect()
}

/// V_crit of `vehicle` as parameter `index` of [`PARAMETERS`] takes each of `values`; None
/// where the changed vehicle has no critical speed within ±0.9·`around` (it became stable
/// there, or its V_crit moved far: a vehicle near the edge of stability), and every value
/// None where a vehicle file does not have the key (an axle key of a unit given as a list
/// of axles).
///
/// # Errors
/// If a changed vehicle is invalid, or its eigenvalues are not finite.
pub fn v_crit_curve<D: VehicleDescription>(
    vehicle: &D,
    index: usize,
    values: &[f64],
    around: f64,
) -> Result<Vec<(f64, Option<f64>)>, SwayError> {
    curve(
        values,
        |p| vehicle.with_paper_value(index, p).ok(),
        |changed| v_crit_near(&changed.model()?, around, 0.9 * around, 1e-9),
    )
}

/// V_crit of the vehicle `changed(p)` for each p of `values` (`v_crit_of` it); None where
/// the vehicle has no such key or no critical speed in the searched window.
fn curve<T>(
    values: &[f64],
    changed: impl Fn(f64) -> Option<T>,
    v_crit_of: impl Fn(&T) -> Result<f64, SwayError>,
) -> Result<Vec<(f64, Option<f64>)>, SwayError> {
    values
        .iter()
        .map(|&p| {
            let Some(changed) = changed(p) else {
                return Ok((p, None));
            };
            let v = match v_crit_of(&changed) {
                Ok(v) => Some(v),
                Err(SwayError::Model(trailer_model::ModelError::NoCriticalSpeed { .. })) => None,
                Err(e) => return Err(e),
            };
            Ok((p, v))
        })
        .collect()
}

/// Index of a parameter of [`PARAMETERS`] by its paper symbol.
pub fn parameter_index(symbol: &str) -> Option<usize> {
    PARAMETERS.iter().position(|&(_, s, _)| s == symbol)
}

/// Spacing of the derived speed grid of the eigenvalue table \[m/s\].
pub const DERIVED_GRID_STEP_MPS: f64 = 0.1;

/// The speed grid of the eigenvalue table derived from the vehicle: from the lowest speed
/// of `limits` to 1.5·V_crit rounded up to a multiple of 10 m/s (at most the maximum speed,
/// but at least 1.1·V_crit), or to the maximum speed when straight running is stable
/// there (`v_crit` None); spacing [`DERIVED_GRID_STEP_MPS`]. For Table I (V_crit =
/// 34.75 m/s): 1–60 m/s, 591 points.
pub fn derived_speed_grid(v_crit: Option<f64>, limits: &sway_model::speeds::SpeedLimits) -> Grid {
    let min = limits.min_speed_mps;
    let max = match v_crit {
        Some(v) => ((1.5 * v / 10.0).ceil() * 10.0)
            .min(limits.max_speed_mps)
            .max(1.1 * v),
        None => limits.max_speed_mps,
    }
    .max(min + 10.0 * DERIVED_GRID_STEP_MPS);
    let points = ((max - min) / DERIVED_GRID_STEP_MPS).round() as usize + 1;
    Grid {
        min,
        max,
        points: points.min(crate::config::MAX_GRID_POINTS),
    }
}
