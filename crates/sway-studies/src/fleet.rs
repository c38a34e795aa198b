//! The headline numbers of every task for one vehicle (task `fleet`):
//! the open-loop critical speed V_crit ([`sway::ranging::open_loop_critical_speed`]), the
//! fold of cycles V_fold and the width of the bistable range V_crit − V_fold
//! ([`sway::ranging::open_loop_references`]), the best gain D\*(τ) of the delayed feedback
//! at τ = 0.2 s ([`sway::gain_design::linear_optimum`]) and the θ(0) threshold of sway at
//! the middle of the bistable range (`{ in_bistable = 0.5 }`, the bisection of the threshold
//! map, [`crate::sweep::threshold`]). Every number that a vehicle does not have is null with
//! a reason next to it.

use serde::{Deserialize, Serialize};
use trailer_model::{AnyVehicleModel, with_plant};

use crate::sweep::threshold::{ThresholdSearch, theta0_threshold};
use crate::sweep::{Axis, AxisParameter, BaseScenario, SweepParameter};
use sway::SwayError;
use sway::config::Positive;
use sway::gain_design::{GainSearch, linear_optimum};
use sway::ranging::{
    OpenLoopStability, Reference, SpeedLimits, open_loop_critical_speed, open_loop_references,
};
use sway::sim::{ControllerTable, InitialCondition, SpeedProfile};
use sway::sim::{MetricSettings, RunSettings, SolverSettings};

/// Settings of the fleet table (`configs/fleet.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FleetOptions {
    /// τ of the best gain D\*(τ) \[s\]
    pub delay_s: f64,
    /// the search of D\* (its speed range is the limits', `--max-speed`)
    pub gain_search: GainSearch,
    /// where in the bistable range the θ(0) threshold is found (0: fold, 1: V_crit)
    pub threshold_in_bistable: f64,
    /// θ(0) grid of the threshold scan \[deg\]: min, max, points
    pub theta0_deg: [f64; 3],
    /// the bisection (horizon, tolerance, doublings)
    pub threshold: ThresholdSearch,
    /// solver tolerances of the threshold simulations
    pub solver: SolverSettings,
}

impl Default for FleetOptions {
    fn default() -> Self {
        Self {
            delay_s: 0.2,
            gain_search: GainSearch::default(),
            threshold_in_bistable: 0.5,
            theta0_deg: [0.5, 15.0, 16.0],
            threshold: ThresholdSearch {
                horizon_s: Positive::literal(240.0),
                tolerance_deg: Positive::literal(0.01),
                max_doublings: 3,
                compare_cycles: false,
                cycles: Default::default(),
            },
            solver: SolverSettings {
                rtol: 1e-6,
                atol: 1e-8,
                ..SolverSettings::default()
            },
        }
    }
}

/// The headline numbers of one vehicle; every null has its reason.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FleetEntry {
    /// V_crit \[m/s\] of the open loop (null: stable up to the maximum speed)
    pub v_crit_mps: Option<f64>,
    /// the Hopf frequency at V_crit \[Hz\]
    pub hopf_frequency_hz: Option<f64>,
    /// straight running is stable at every speed up to this \[m/s\] (when no V_crit)
    pub stable_up_to_mps: Option<f64>,
    /// the fold of cycles V_fold \[m/s\] (null: no bistable range)
    pub v_fold_mps: Option<f64>,
    /// V_crit − V_fold \[m/s\]
    pub bistable_width_mps: Option<f64>,
    /// τ of the best gain \[s\]
    pub delay_s: f64,
    /// D\*(τ) \[s\]
    pub d_opt_s: Option<f64>,
    /// V_crit(D\*) \[m/s\]
    pub v_crit_at_d_opt_mps: Option<f64>,
    /// the speed of the threshold, V_fold + f·(V_crit − V_fold) \[m/s\]
    pub threshold_speed_mps: Option<f64>,
    /// the smallest θ(0) (other states 0) that ends in sustained sway there \[deg\]
    pub theta0_threshold_deg: Option<f64>,
    /// why some of the numbers above are null (empty when none is)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub reasons: Vec<String>,
}

/// The open loop's V_crit (with the Hopf frequency) or the speed it is stable up to, and
/// its fold of cycles: the first numbers of every per-vehicle table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpenLoopNumbers {
    /// V_crit \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// the frequency of the crossing pair \[Hz\] (0: a static divergence)
    pub hopf_frequency_hz: Option<f64>,
    /// stable at every speed up to this one \[m/s\] (when no V_crit)
    pub stable_up_to_mps: Option<f64>,
    /// the fold of cycles V_fold \[m/s\]
    pub v_fold_mps: Option<f64>,
}

/// [`OpenLoopNumbers`] of `vehicle` on its own plant ([`open_loop_critical_speed`],
/// [`open_loop_references`]); a missing number's reason goes to `reasons`, with `also`
/// (e.g. ", no threshold") naming what the table loses with it.
///
/// # Errors
/// A numerical failure of the critical-speed search.
pub fn open_loop_numbers(
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    also: &str,
    reasons: &mut Vec<String>,
) -> Result<OpenLoopNumbers, SwayError> {
    let stability = with_plant!(vehicle, m => open_loop_critical_speed(m, limits))?;
    let (v_crit, freq, stable_up_to) = match stability {
        OpenLoopStability::Critical {
            v_crit_mps,
            hopf_omega_rad_s,
        } => (
            Some(v_crit_mps),
            Some(hopf_omega_rad_s / std::f64::consts::TAU),
            None,
        ),
        OpenLoopStability::StableUpTo { stable_up_to_mps } => {
            reasons.push(format!(
                "straight running is stable at every speed up to {stable_up_to_mps} m/s (the maximum speed): no V_crit, no fold{also}"
            ));
            (None, None, Some(stable_up_to_mps))
        }
    };
    let fold = match v_crit {
        Some(_) => {
            let r = with_plant!(vehicle, m => open_loop_references(m, limits, Reference::Fold))?;
            if r.v_fold_mps.is_none() {
                reasons.push(format!(
                    "no bistable range{also}: {}",
                    r.reason
                        .as_deref()
                        .unwrap_or("no fold of cycles below V_crit")
                ));
            }
            r.v_fold_mps
        }
        None => None,
    };
    Ok(OpenLoopNumbers {
        v_crit_mps: v_crit,
        hopf_frequency_hz: freq,
        stable_up_to_mps: stable_up_to,
        v_fold_mps: fold,
    })
}

/// The headline numbers of the plant of a vehicle file, any model variant (the paper's
/// [`trailer_model::Model`] for a vehicle of the paper's form: the same calls, so the
/// same numbers): V_crit and the fold of cycles on the plant itself
/// ([`open_loop_references`]), D\* on its own linearisation ([`linear_optimum`] through
/// [`sway::control::LoopModel`]) and the threshold by simulating it
/// ([`theta0_threshold`]).
///
/// # Errors
/// [`SwayError::Numerical`] when a computation fails (a missing reference is not an error).
pub fn fleet_entry(
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    o: &FleetOptions,
) -> Result<FleetEntry, SwayError> {
    let mut reasons = Vec::new();
    let OpenLoopNumbers {
        v_crit_mps: v_crit,
        hopf_frequency_hz: freq,
        stable_up_to_mps: stable_up_to,
        v_fold_mps: fold,
    } = open_loop_numbers(vehicle, limits, ", no threshold", &mut reasons)?;
    let width = v_crit.zip(fold).map(|(c, f)| c - f);
    // the gain search up to the maximum speed: a gain stable up to there has no optimum
    let search = GainSearch {
        v_min_mps: limits.min_speed_mps,
        v_max_mps: limits.max_speed_mps,
        ..o.gain_search.clone()
    };
    let (d_opt, v_at_d_opt) = match linear_optimum(vehicle, o.delay_s, &search) {
        Ok(opt) if opt.v_crit_max_mps < search.v_max_mps => {
            (Some(opt.d_opt_s), Some(opt.v_crit_max_mps))
        }
        Ok(_) => {
            reasons.push(format!(
                "with the best gain at τ = {} s straight running is stable up to the maximum speed {} m/s: no D*",
                o.delay_s, search.v_max_mps
            ));
            (None, None)
        }
        Err(e) => {
            reasons.push(format!("no D* at τ = {} s: {e}", o.delay_s));
            (None, None)
        }
    };
    let threshold_speed = v_crit
        .zip(fold)
        .map(|(c, f)| f + o.threshold_in_bistable * (c - f));
    let theta0 = match threshold_speed {
        Some(v) => {
            let (t, failed) = match threshold_at(vehicle, v, o) {
                Ok(t) => (t, false),
                Err(e) => {
                    reasons.push(format!("the θ(0) threshold at {v} m/s failed: {e}"));
                    (None, true)
                }
            };
            if t.is_none() && !failed {
                reasons.push(format!(
                    "no θ(0) up to {}° ends in sustained sway at {v} m/s",
                    o.theta0_deg[1]
                ));
            }
            t
        }
        None => None,
    };
    Ok(FleetEntry {
        v_crit_mps: v_crit,
        hopf_frequency_hz: freq,
        stable_up_to_mps: stable_up_to,
        v_fold_mps: fold,
        bistable_width_mps: width,
        delay_s: o.delay_s,
        d_opt_s: d_opt,
        v_crit_at_d_opt_mps: v_at_d_opt,
        threshold_speed_mps: threshold_speed,
        theta0_threshold_deg: theta0,
        reasons,
    })
}

/// The bisected θ(0) threshold \[deg\] at constant speed `v` \[m/s\] (open loop, state
/// start, other states 0; the plant's own states in the tyres' steady state) over the scan
/// `o.theta0_deg`, None when no θ(0) of the scan ends in sustained sway.
///
/// # Errors
/// [`SwayError::Numerical`] when a simulation fails.
pub fn threshold_at(
    vehicle: &AnyVehicleModel,
    v: f64,
    o: &FleetOptions,
) -> Result<Option<f64>, SwayError> {
    let base = BaseScenario {
        horizon_s: o.threshold.horizon_s,
        action_s: Some(0.0),
        speed: SpeedProfile::Constant { speed_mps: v },
        controller: ControllerTable::None,
        initial: InitialCondition::State {
            sigma1_mps: 0.0,
            sigma2_per_s: 0.0,
            sigma3_per_s: 0.0,
            theta0_deg: 0.0,
            psi0_deg: 0.0,
        },
        settings: RunSettings {
            solver: o.solver,
            metrics: MetricSettings::default(),
            ..RunSettings::default()
        },
    };
    let [min, max, points] = o.theta0_deg;
    let column = Axis::range(
        AxisParameter::Scenario(SweepParameter::Theta0Deg),
        min,
        max,
        points.max(1.0) as usize,
    )
    .values();
    theta0_threshold(vehicle, &base, &column, &o.threshold, v)
        .map(|t| t.theta0_threshold_deg)
        .map_err(|e| {
            SwayError::numerical(
                format!("the θ(0) threshold at {v} m/s"),
                std::io::Error::other(e),
            )
        })
}
