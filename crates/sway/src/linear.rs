//! Open-loop linear stability of straight running: eigenvalues of Ã(V) (eq. 9–11),
//! the critical speed V_crit where the spectral abscissa changes sign, the Hopf
//! frequency there, and dV_crit/dp for every vehicle parameter.

use nalgebra::Complex;
use serde::{Deserialize, Serialize};
use trailer_model::{CriticalSpeedOptions, Model, PARAMETERS, VehicleParams};

use crate::SwayError;
use crate::config::Grid;

/// Eigenvalues of Ã along a speed grid, each column following one eigenvalue
/// continuously (matched to the previous speed by nearest distance).
#[derive(Debug, Clone, PartialEq)]
pub struct EigenTable {
    /// speeds V \[m/s\]
    pub speeds: Vec<f64>,
    /// eigenvalues λ \[1/s\] per speed, continuous branches in fixed columns
    pub eigenvalues: Vec<[Complex<f64>; 4]>,
}

/// Eigenvalues of Ã on `speeds`, ordered into continuous branches.
pub fn eigen_table(model: &Model, speeds: &[f64]) -> EigenTable {
    let mut out: Vec<[Complex<f64>; 4]> = Vec::with_capacity(speeds.len());
    for &v in speeds {
        let ev = model.open_loop_eigenvalues(v);
        let next = match out.last() {
            None => ev,
            Some(prev) => best_match(prev, &ev),
        };
        out.push(next);
    }
    EigenTable {
        speeds: speeds.to_vec(),
        eigenvalues: out,
    }
}

/// The permutation of `ev` closest to `prev` (sum of distances; 24 candidates).
fn best_match(prev: &[Complex<f64>; 4], ev: &[Complex<f64>; 4]) -> [Complex<f64>; 4] {
    let mut best = *ev;
    let mut best_cost = f64::INFINITY;
    let mut perm = [0usize, 1, 2, 3];
    // Heap's algorithm over the 24 permutations
    let mut c = [0usize; 4];
    let mut eval = |p: &[usize; 4]| {
        let cost: f64 = (0..4).map(|k| (ev[p[k]] - prev[k]).norm()).sum();
        if cost < best_cost {
            best_cost = cost;
            best = [ev[p[0]], ev[p[1]], ev[p[2]], ev[p[3]]];
        }
    };
    eval(&perm);
    let mut i = 0;
    while i < 4 {
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

/// V_crit of `params`, searched in `around ± window` \[m/s\].
fn v_crit_near(
    params: &VehicleParams,
    around: f64,
    window: f64,
    tolerance: f64,
) -> Result<f64, SwayError> {
    let model = Model::new(*params)?;
    let opts = CriticalSpeedOptions {
        v_min: (around - window).max(0.5),
        v_max: around + window,
        scan_step: 0.25,
        tolerance,
    };
    Ok(model.critical_speed(&opts)?.v_crit_mps)
}

/// dV_crit/dp for every parameter of [`PARAMETERS`] by central differences of V_crit
/// (each V_crit solved by bisection to `tolerance`). The loads, μ0, μ and g do not enter
/// the linearisation (the brush tire's slope at α = 0 is C), so their sensitivities are 0.
///
/// # Errors
/// If a perturbed vehicle has no critical speed near the nominal one.
pub fn sensitivities(
    params: &VehicleParams,
    v_crit: f64,
    opts: &SensitivityOptions,
    tolerance: f64,
) -> Result<Vec<Sensitivity>, SwayError> {
    PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, &(key, symbol, unit))| {
            let value = params.get(i);
            let h = opts.relative_step * value;
            let up = v_crit_near(&params.with(i, value + h), v_crit, 3.0, tolerance)?;
            let down = v_crit_near(&params.with(i, value - h), v_crit, 3.0, tolerance)?;
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

/// V_crit as parameter `index` of [`PARAMETERS`] takes each of `values`; None where the
/// changed vehicle has no critical speed within ±0.9·`around` (it became stable there, or
/// its V_crit moved far: a vehicle near the edge of stability).
///
/// # Errors
/// If a changed vehicle is invalid, or its eigenvalues are not finite.
pub fn v_crit_curve(
    params: &VehicleParams,
    index: usize,
    values: &[f64],
    around: f64,
) -> Result<Vec<(f64, Option<f64>)>, SwayError> {
    values
        .iter()
        .map(|&p| {
            let v = match v_crit_near(&params.with(index, p), around, 0.9 * around, 1e-9) {
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
pub fn derived_speed_grid(v_crit: Option<f64>, limits: &crate::ranging::SpeedLimits) -> Grid {
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
