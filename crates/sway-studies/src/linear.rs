//! The computation of `linear`: the open loop's V_crit, its eigenvalues along a speed grid
//! (derived from the vehicle where `configs/linear.toml` omits it), the sensitivities
//! dV_crit/dp of every parameter and V_crit along the trailer lengths h and l around the
//! vehicle's values (the rounding of Table I).

use crate::modes::{Modes, modes_of};
use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::config::Grid;
use sway::control::LoopModel;
use sway::linear::{
    EigenTable, Sensitivity, SensitivityOptions, derived_speed_grid, eigen_table, parameter_index,
    sensitivities, v_crit_curve,
};
use sway::progress::Progress;
use sway::ranging::SpeedLimits;
use trailer_model::{
    AnyVehicleModel, CriticalSpeed, CriticalSpeedOptions, VehicleParams, VehicleSpec,
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
    /// the speed at which each sway mode's frequency and damping are reported \[m/s\]
    /// (80 km/h, the heavy-vehicle standards' test speed)
    #[serde(default = "mode_reference")]
    pub mode_reference_speed_mps: f64,
}

fn mode_reference() -> f64 {
    80.0 / 3.6
}

fn paper_v_crit() -> f64 {
    34.1
}
fn rounding() -> f64 {
    0.05
}

/// The V_crit search settings (`[critical_speed]` of `configs/linear.toml`).
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

impl SearchConfig {
    /// As the model's search options.
    pub fn options(&self) -> CriticalSpeedOptions {
        CriticalSpeedOptions {
            v_min: self.v_min_mps,
            v_max: self.v_max_mps,
            scan_step: self.scan_step_mps,
            tolerance: self.tolerance_mps,
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

/// The vehicle of `linear`: its plant, its paper-form parameters, and its file where it has
/// model variants (then the sensitivities and the curves along h and l change the file's
/// keys).
#[derive(Debug, Clone, Copy)]
pub struct LinearVehicle<'a> {
    /// the plant ([`AnyVehicleModel::Paper`] for a vehicle of the paper's form)
    pub plant: &'a AnyVehicleModel,
    /// the paper-form parameters (for a vehicle with model variants the equivalent
    /// single-axle vehicle: the values of h and l, whether it is Table I)
    pub params: &'a VehicleParams,
    /// the vehicle file, for a vehicle with model variants (None: the paper's form)
    pub spec: Option<&'a VehicleSpec>,
}

/// V_crit along h and l around the vehicle's values (±0.1 m, the rounding of Table I).
#[derive(Debug, Clone, PartialEq)]
pub struct RoundingStudy {
    /// dV_crit/dh \[m/s per m\]
    pub dh: f64,
    /// dV_crit/dl \[m/s per m\]
    pub dl: f64,
    /// h of the vehicle \[m\]
    pub h0: f64,
    /// l of the vehicle \[m\]
    pub l0: f64,
    /// the changes of h and l along the curves \[m\]
    pub offsets_m: Vec<f64>,
    /// (h, V_crit) per offset; None where the changed vehicle has no V_crit nearby
    pub by_h: Vec<(f64, Option<f64>)>,
    /// (l, V_crit) per offset; None as for `by_h`
    pub by_l: Vec<(f64, Option<f64>)>,
    /// first-order V_crit change of the rounding \[m/s\]
    pub band: f64,
}

/// What follows from a V_crit: its sensitivities and the rounding study.
#[derive(Debug, Clone, PartialEq)]
pub struct Critical {
    /// V_crit, the frequency and the slope of the crossing
    pub speed: CriticalSpeed,
    /// dV_crit/dp of every parameter, in the order of [`trailer_model::PARAMETERS`]
    pub sensitivities: Vec<Sensitivity>,
    /// V_crit along h and l
    pub rounding: RoundingStudy,
    /// the paper's V_crit \[m/s\] (only for the paper's vehicle, Table I)
    pub paper_v_crit_mps: Option<f64>,
}

/// Where straight running loses stability, or that it does not.
#[derive(Debug, Clone, PartialEq)]
pub enum Onset {
    /// it loses stability at V_crit
    Critical(Box<Critical>),
    /// it is stable at every speed up to the end of the search
    Stable {
        /// the end of the search \[m/s\]
        up_to_mps: f64,
        /// the outcome in words, naming the key or option that set the end
        reason: String,
    },
}

/// Everything `linear` computes.
#[derive(Debug, Clone, PartialEq)]
pub struct Linear {
    /// the speed grid of the eigenvalue table (the config's, or derived from V_crit)
    pub grid: Grid,
    /// the eigenvalues along the grid
    pub table: EigenTable,
    /// V_crit and what follows from it, or the stable outcome
    pub onset: Onset,
    /// every oscillatory mode along the grid
    pub modes: Modes,
}

impl Linear {
    /// V_crit with its crossing, None when straight running is stable on the search.
    pub fn critical_speed(&self) -> Option<&CriticalSpeed> {
        match &self.onset {
            Onset::Critical(c) => Some(&c.speed),
            Onset::Stable { .. } => None,
        }
    }
}

/// V_crit along h and l (±0.1 m around the vehicle's values), from the sensitivities
/// `sens` at V_crit `v_crit` \[m/s\]; `rounding_m` is half a printed digit of h and l.
fn rounding_study(
    vehicle: &LinearVehicle<'_>,
    sens: &[Sensitivity],
    v_crit: f64,
    rounding_m: f64,
) -> Result<RoundingStudy, SwayError> {
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
            Some(spec) => v_crit_curve(spec, i, &values, v_crit),
        }
    };
    let (by_h, by_l) = (along(ih, h0)?, along(il, l0)?);
    Ok(RoundingStudy {
        dh,
        dl,
        h0,
        l0,
        offsets_m: offsets,
        by_h,
        by_l,
        band: (dh.abs() + dl.abs()) * rounding_m,
    })
}

/// The whole computation (no I/O): V_crit by the config's search (or the one of `limits`),
/// the eigenvalue table, and at a V_crit the sensitivities and the rounding study (on the
/// paper's parameters for a vehicle of the paper's form, on its file for one with model
/// variants). Advances `progress` by 3.
///
/// # Errors
/// [`SwayError::Model`] from the V_crit search, [`SwayError::Numerical`] from the
/// sensitivities.
pub fn compute(
    cfg: &LinearConfig,
    vehicle: &LinearVehicle<'_>,
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<Linear, SwayError> {
    let search = cfg
        .critical_speed
        .as_ref()
        .map_or_else(|| limits.critical_speed_options(), SearchConfig::options);
    let vc = LoopModel::critical_speed_search(vehicle.plant, &search)?;
    progress.advance(1);
    let grid = cfg
        .speed_grid
        .unwrap_or_else(|| derived_speed_grid(vc.as_ref().map(|c| c.v_crit_mps), limits));
    let table = eigen_table(vehicle.plant, &grid.values());
    let modes = modes_of(vehicle.plant, &grid.values(), cfg.mode_reference_speed_mps)?;
    progress.advance(1);
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
        progress.advance(1);
        return Ok(Linear {
            grid,
            table,
            onset: Onset::Stable {
                up_to_mps: search.v_max,
                reason,
            },
            modes,
        });
    };
    let sens = match vehicle.spec {
        None => sensitivities(
            vehicle.params,
            vc.v_crit_mps,
            &cfg.sensitivity,
            search.tolerance,
        )?,
        Some(spec) => sensitivities(spec, vc.v_crit_mps, &cfg.sensitivity, search.tolerance)?,
    };
    let rounding = rounding_study(vehicle, &sens, vc.v_crit_mps, cfg.length_rounding_m)?;
    progress.advance(1);
    let paper_v_crit_mps = vehicle.params.is_table_i().then_some(cfg.paper_v_crit_mps);
    Ok(Linear {
        grid,
        table,
        onset: Onset::Critical(Box::new(Critical {
            speed: vc,
            sensitivities: sens,
            rounding,
            paper_v_crit_mps,
        })),
        modes,
    })
}
