//! The computation of `combination`: for a vehicle of any number of units, what
//! heavy-vehicle standards rate beside what the paper asks — the open loop's V_crit and fold
//! of cycles V_fold, every sway mode (where it loses stability, its frequency and damping
//! at the test speed, the unit that leads it), and at the test speed the rearward
//! amplification and high-speed transient offtracking of a single sine-steer lane change
//! and the yaw damping of every articulation after a steering pulse
//! ([`sway::combination`]).

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::combination::manoeuvres::{
    ArticulationDamping, LaneChange, LaneChangeSettings, YawDampingSettings, lane_change,
    yaw_damping,
};
use sway::ranging::SpeedLimits;
use sway::sim::{Outcome, SolverSettings};
use trailer_model::AnyVehicleModel;

use crate::fleet::open_loop_numbers;
use crate::modes::{ModeSummary, Modes, modes_of};

/// What `combination` computes for each vehicle (`configs/combination.toml`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CombinationOptions {
    /// the speed of the lane change, the yaw-damping pulse and the modes' damping \[m/s\]
    /// (80 km/h: the heavy-vehicle standards' test speed)
    pub test_speed_mps: f64,
    /// the modes are followed from the lowest speed of the limits to the highest in this
    /// step \[m/s\]
    pub mode_speed_step_mps: f64,
    /// the single sine-steer lane change
    pub lane_change: LaneChangeSettings,
    /// the steering pulse of the yaw damping
    pub yaw_damping: YawDampingSettings,
    /// the simulations' error control
    pub solver: SolverSettings,
}

impl Default for CombinationOptions {
    fn default() -> Self {
        Self {
            test_speed_mps: 80.0 / 3.6,
            mode_speed_step_mps: 0.5,
            lane_change: LaneChangeSettings::default(),
            yaw_damping: YawDampingSettings::default(),
            solver: SolverSettings::default(),
        }
    }
}

/// The headline numbers of one vehicle; a null has its reason in `reasons`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CombinationEntry {
    /// units, the towing unit included
    pub units: usize,
    /// the open loop's V_crit \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// how straight running loses stability there: `hopf` or `divergence`
    pub loss_of_stability: Option<&'static str>,
    /// straight running is stable at every speed up to this one \[m/s\] (when no V_crit)
    pub stable_up_to_mps: Option<f64>,
    /// the fold of cycles of the open loop \[m/s\] (the lower end of the bistable range)
    pub v_fold_mps: Option<f64>,
    /// every oscillatory mode of straight running
    pub modes: Vec<ModeSummary>,
    /// the test speed \[m/s\]
    pub test_speed_mps: f64,
    /// the lane change's steering amplitude \[deg\]
    pub steering_amplitude_deg: Option<f64>,
    /// the rearmost unit's peak lateral acceleration over the towing unit's \[-\]
    pub rearward_amplification: Option<f64>,
    /// the same for the yaw rates \[-\]
    pub rearward_amplification_yaw_rate: Option<f64>,
    /// the rearmost axle group's overshoot of the steered axle's final lane position \[m\]
    pub high_speed_transient_offtracking_m: Option<f64>,
    /// the damping ratio of the rearmost articulation after a steering pulse \[-\]
    pub yaw_damping_ratio: Option<f64>,
    /// the damping of every articulation, front to back
    pub articulations: Vec<ArticulationDamping>,
    /// why a number is null
    pub reasons: Vec<String>,
}

/// A vehicle's entry and its lane change (None where it was not run).
#[derive(Debug, Clone, PartialEq)]
pub struct Combination {
    /// the headline numbers
    pub entry: CombinationEntry,
    /// the modes along the speed
    pub modes: Modes,
    /// the lane change's record
    pub lane_change: Option<LaneChange>,
}

/// The numbers of `vehicle` (module docs).
///
/// # Errors
/// A numerical failure of the critical-speed search, the continuation or a simulation.
pub fn combination(
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    o: &CombinationOptions,
) -> Result<Combination, SwayError> {
    let mut reasons = Vec::new();
    let open = open_loop_numbers(vehicle, limits, "", &mut reasons)?;
    let (v_crit, v_fold) = (open.v_crit_mps, open.v_fold_mps);
    let kind = open
        .hopf_frequency_hz
        .map(|f| if f == 0.0 { "divergence" } else { "hopf" });
    let speeds = mode_speeds(limits, o.mode_speed_step_mps);
    let modes = modes_of(vehicle, &speeds, o.test_speed_mps)?;
    let v = o.test_speed_mps;
    let unstable_here = v_crit.filter(|&c| c <= v);
    let lc = match unstable_here {
        Some(c) => {
            reasons.push(format!(
                "no lane change at {v:.2} m/s: straight running is unstable there (V_crit = {c:.3} m/s), its response grows instead of settling"
            ));
            None
        }
        None => Some(lane_change(vehicle, v, &o.lane_change, &o.solver)?),
    };
    if let Some(l) = lc.as_ref().filter(|l| l.outcome != Outcome::Ok) {
        reasons.push(format!(
            "the lane change at {v:.2} m/s lost control (steering amplitude {:.3}°): no rearward amplification or offtracking",
            l.steering_amplitude_deg
        ));
    }
    let ok = lc.as_ref().filter(|l| l.outcome == Outcome::Ok);
    let articulations = yaw_damping(vehicle, v, &o.yaw_damping, &o.solver)?;
    let rearmost = articulations.last();
    if let Some(why) = rearmost.and_then(|a| a.reason.as_ref()) {
        reasons.push(format!(
            "no yaw damping of the rearmost articulation: {why}"
        ));
    }
    let entry = CombinationEntry {
        units: articulations.len() + 1,
        v_crit_mps: v_crit,
        loss_of_stability: kind,
        stable_up_to_mps: open.stable_up_to_mps,
        v_fold_mps: v_fold,
        modes: modes.summaries.clone(),
        test_speed_mps: v,
        steering_amplitude_deg: ok.map(|l| l.steering_amplitude_deg),
        rearward_amplification: ok.map(|l| l.rearward_amplification),
        rearward_amplification_yaw_rate: ok.map(|l| l.rearward_amplification_yaw_rate),
        high_speed_transient_offtracking_m: ok.map(|l| l.high_speed_transient_offtracking_m),
        yaw_damping_ratio: rearmost.and_then(|a| a.damping_ratio),
        articulations,
        reasons,
    };
    Ok(Combination {
        entry,
        modes,
        lane_change: lc,
    })
}

/// The speeds the modes are followed on: the limits' range in `step` \[m/s\].
fn mode_speeds(limits: &SpeedLimits, step: f64) -> Vec<f64> {
    let (lo, hi) = (limits.min_speed_mps, limits.max_speed_mps);
    let n = ((hi - lo) / step).floor() as usize;
    let mut v: Vec<f64> = (0..=n).map(|k| lo + k as f64 * step).collect();
    if v.last().is_some_and(|&l| l < hi) {
        v.push(hi);
    }
    v
}
