//! The heavy-vehicle tests of a combination, run on the model with every unit in view
//! (performance-based standards rate these; ISO 14791 describes the manoeuvres):
//!
//! - **Rearward amplification** in a single sine-steer lane change ([`lane_change`]): the
//!   towing unit's steered wheels follow one period of δ(t) = A sin(2πf(t − t₀)) at constant
//!   speed, A chosen so that the towing unit's peak lateral acceleration (at its centre of
//!   gravity) is the configured one; RA is the rearmost unit's peak lateral acceleration over
//!   the towing unit's (and the same for the yaw rates).
//! - **High-speed transient offtracking** in the same run: how far the centre of the
//!   rearmost unit's axle group tracks outside the path of the steered axle, on the side of
//!   the lane change: max over x of s·(y_rear(x) − y_steer(x)), s the side.
//! - **Yaw damping** ([`yaw_damping`]): after a steering pulse, the damping ratio of every
//!   articulation angle read from its decaying peaks ([`crate::sim::decay`], the reading of
//!   `lateral_stability`); the rearmost articulation's is the standards' figure.
//!
//! The runs use the engines' simulation of the vehicle's own plant; every unit's motion is
//! read from the recorded states through the vehicle's chain model ([`AsChain`]).

use nalgebra::SVector;
use serde::{Deserialize, Serialize};
use trailer_model::{AnyVehicleModel, AsChain, ChainModel, Inputs, Pose, UnitMotion};

use crate::SwayError;
use crate::sim::decay::{Decay, decay, peaks};
use crate::sim::{
    ControllerStates, EarlyStop, Layout, Outcome, PulseShape, Recording, RunSettings, SimSpec,
    SolverSettings, SpeedProfile, SteeringInput, simulate,
};
use sway_model::vehicle::Vehicle;

/// Most units of a chain (towing unit included).
const MAX_UNITS: usize = trailer_model::MAX_TOWED_UNITS + 1;

/// The single sine-steer lane change.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LaneChangeSettings {
    /// the steering frequency f \[Hz\] (ISO 14791 and the standards use 0.4 Hz)
    pub frequency_hz: f64,
    /// the towing unit's peak lateral acceleration the steering amplitude is set to \[m/s²\]
    /// (0.15 g in the standards: small enough to be the linear response)
    pub towing_unit_peak_lateral_acceleration_mps2: f64,
    /// straight running before the steering starts \[s\]
    pub start_s: f64,
    /// running on after the steering ends, for the rearmost unit to overshoot and settle \[s\]
    pub after_s: f64,
    /// the recorded sample step \[s\] (peaks and paths are read from the samples)
    pub sample_step_s: f64,
}

impl Default for LaneChangeSettings {
    fn default() -> Self {
        Self {
            frequency_hz: 0.4,
            towing_unit_peak_lateral_acceleration_mps2: 0.15 * 9.81,
            start_s: 0.5,
            after_s: 8.0,
            sample_step_s: 0.005,
        }
    }
}

/// One recorded sample of a lane change.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LaneChangeSample {
    /// t \[s\]
    pub time_s: f64,
    /// the front-wheel steering angle δ \[deg\]
    pub steering_angle_deg: f64,
    /// every unit's lateral acceleration at its centre of gravity \[m/s²\], towing unit first
    pub lateral_accelerations_mps2: Vec<f64>,
    /// every unit's yaw rate \[deg/s\]
    pub yaw_rates_deg_s: Vec<f64>,
    /// the steered axle's position on the road \[m\] (x along the initial heading, y to its
    /// left)
    pub steer_axle_m: [f64; 2],
    /// the centre of the rearmost unit's axle group on the road \[m\]
    pub rearmost_axle_m: [f64; 2],
}

/// What a lane change shows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LaneChange {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// the steering amplitude A that gives the towing unit's peak lateral acceleration \[deg\]
    pub steering_amplitude_deg: f64,
    /// "ok", or "loss_of_control" when the validity guard stopped the run
    pub outcome: Outcome,
    /// the towing unit's peak |lateral acceleration| \[m/s²\]
    pub towing_unit_peak_lateral_acceleration_mps2: f64,
    /// the rearmost unit's peak |lateral acceleration| \[m/s²\]
    pub rearmost_peak_lateral_acceleration_mps2: f64,
    /// their ratio \[-\]
    pub rearward_amplification: f64,
    /// the towing unit's peak |yaw rate| \[deg/s\]
    pub towing_unit_peak_yaw_rate_deg_s: f64,
    /// the rearmost unit's peak |yaw rate| \[deg/s\]
    pub rearmost_peak_yaw_rate_deg_s: f64,
    /// their ratio \[-\]
    pub rearward_amplification_yaw_rate: f64,
    /// the steered axle's largest lateral displacement (its sign the side of the lane
    /// change) \[m\]
    pub lane_offset_m: f64,
    /// the largest distance by which the rearmost axle group tracks outside the steered
    /// axle's path on the side of the lane change, the paths compared at equal x \[m\]
    /// (≤ 0: it never does)
    pub high_speed_transient_offtracking_m: f64,
    /// the recorded run
    pub samples: Vec<LaneChangeSample>,
}

/// The steered axle's largest lateral displacement (signed: the side of the lane change)
/// and the rearmost axle group's largest distance outside the steered axle's path on that
/// side, the paths compared at equal x (the steered axle's y interpolated at the rearmost
/// axle's x) \[m\].
fn offtracking(samples: &[LaneChangeSample]) -> (f64, f64) {
    let offset = samples
        .iter()
        .map(|s| s.steer_axle_m[1])
        .fold(0.0_f64, |m, y| if y.abs() > m.abs() { y } else { m });
    let side = if offset < 0.0 { -1.0 } else { 1.0 };
    let xs: Vec<f64> = samples.iter().map(|s| s.steer_axle_m[0]).collect();
    let overshoot = samples
        .iter()
        .filter_map(|s| {
            let [x, y] = s.rearmost_axle_m;
            let k = xs.partition_point(|&v| v < x);
            if k == 0 || k == xs.len() {
                return None;
            }
            let (a, b) = (&samples[k - 1].steer_axle_m, &samples[k].steer_axle_m);
            let y_steer = a[1] + (b[1] - a[1]) * (x - a[0]) / (b[0] - a[0]);
            Some(side * (y - y_steer))
        })
        .fold(f64::NEG_INFINITY, f64::max);
    (offset, overshoot)
}

/// The pulse-steer yaw damping.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct YawDampingSettings {
    /// the pulse's shape
    pub shape: PulseShape,
    /// when it starts \[s\]
    pub start_s: f64,
    /// its duration \[s\]
    pub duration_s: f64,
    /// its peak front-wheel angle \[deg\] (small: the damping read is the linear one)
    pub amplitude_deg: f64,
    /// the run after the pulse \[s\]
    pub after_s: f64,
    /// peaks skipped after the pulse before the decrement is read
    pub skip_peaks: usize,
    /// periods averaged
    pub periods: usize,
    /// the recorded sample step \[s\]
    pub sample_step_s: f64,
}

impl Default for YawDampingSettings {
    fn default() -> Self {
        Self {
            shape: PulseShape::HalfSine,
            start_s: 0.5,
            duration_s: 0.4,
            amplitude_deg: 0.5,
            after_s: 30.0,
            skip_peaks: 1,
            periods: 3,
            sample_step_s: 0.005,
        }
    }
}

/// The damping of one articulation after the pulse.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArticulationDamping {
    /// the coupling (1: the towing unit's, i: in front of the i-th towed unit)
    pub coupling: usize,
    /// D from the decrement of its articulation angle's peaks \[-\]; None with `reason`
    pub damping_ratio: Option<f64>,
    /// the frequency of the peaks used \[Hz\]
    pub frequency_hz: Option<f64>,
    /// why no damping was read
    pub reason: Option<String>,
}

/// Runs `f::<P, M, M + 3>(plant, args…)` on the concrete plant of an [`AnyVehicleModel`].
macro_rules! on_plant {
    ($any:expr, $f:ident($($arg:expr),*)) => {
        match $any {
            AnyVehicleModel::Paper(m) => $f::<_, 4, 7>(m, $($arg),*),
            AnyVehicleModel::N4(m) => $f::<_, 4, 7>(m, $($arg),*),
            AnyVehicleModel::N5(m) => $f::<_, 5, 8>(m, $($arg),*),
            AnyVehicleModel::N6(m) => $f::<_, 6, 9>(m, $($arg),*),
            AnyVehicleModel::N7(m) => $f::<_, 7, 10>(m, $($arg),*),
            AnyVehicleModel::N8(m) => $f::<_, 8, 11>(m, $($arg),*),
            AnyVehicleModel::N9(m) => $f::<_, 9, 12>(m, $($arg),*),
            AnyVehicleModel::N10(m) => $f::<_, 10, 13>(m, $($arg),*),
        }
    };
}

/// The single sine-steer lane change of `vehicle` at `speed_mps` (module docs), its
/// amplitude found by the secant on the towing unit's peak lateral acceleration (it is
/// nearly proportional: two or three runs reach 0.1 %).
///
/// # Errors
/// A solver failure, with the run's amplitude; [`SwayError::Model`] when the chain model
/// does not build.
pub fn lane_change(
    vehicle: &AnyVehicleModel,
    speed_mps: f64,
    settings: &LaneChangeSettings,
    solver: &SolverSettings,
) -> Result<LaneChange, SwayError> {
    on_plant!(vehicle, lane_change_on(speed_mps, settings, solver))
}

/// The pulse-steer yaw damping of every articulation of `vehicle` at `speed_mps`.
///
/// # Errors
/// As [`lane_change`].
pub fn yaw_damping(
    vehicle: &AnyVehicleModel,
    speed_mps: f64,
    settings: &YawDampingSettings,
    solver: &SolverSettings,
) -> Result<Vec<ArticulationDamping>, SwayError> {
    on_plant!(vehicle, yaw_damping_on(speed_mps, settings, solver))
}

fn run_spec(
    speed_mps: f64,
    steering: SteeringInput,
    horizon_s: f64,
    solver: &SolverSettings,
) -> SimSpec {
    SimSpec {
        profile: SpeedProfile::Constant { speed_mps },
        controller: None,
        steering,
        horizon_s,
        action_s: 0.0,
        settings: RunSettings {
            solver: *solver,
            ..RunSettings::default()
        },
        early_stop: EarlyStop::Never,
    }
}

/// The chain state and the inputs of a recorded sample of an M-state plant in its layout
/// (the first M of S states).
fn chain_sample<const M: usize, const S: usize>(
    chain: &ChainModel<M>,
    x: &SVector<f64, S>,
    speed: f64,
    steering_angle: f64,
) -> (SVector<f64, M>, Inputs) {
    let reduced = SVector::<f64, M>::from_fn(|i, _| x[i]);
    (
        chain.from_paper_layout(&reduced),
        Inputs {
            speed,
            acceleration: 0.0,
            steering_angle,
        },
    )
}

fn lane_change_on<P, const M: usize, const S: usize>(
    plant: &P,
    speed_mps: f64,
    settings: &LaneChangeSettings,
    solver: &SolverSettings,
) -> Result<LaneChange, SwayError>
where
    P: Vehicle<M> + AsChain<M>,
    Layout<S>: ControllerStates<S>,
{
    let chain = plant.as_chain()?;
    let target = settings.towing_unit_peak_lateral_acceleration_mps2;
    // first guess: 1° of steering; then the secant through the origin (the response is
    // nearly linear at the standards' sizes)
    let mut amplitude = 1f64.to_radians();
    let mut run =
        lane_change_run::<P, M, S>(plant, &chain, speed_mps, amplitude, settings, solver)?;
    for _ in 0..6 {
        let peak = run.towing_unit_peak_lateral_acceleration_mps2;
        let positive = peak.is_finite() && peak > 0.0;
        if run.outcome != Outcome::Ok || !positive || (peak / target - 1.0).abs() < 1e-3 {
            break;
        }
        amplitude *= target / peak;
        run = lane_change_run::<P, M, S>(plant, &chain, speed_mps, amplitude, settings, solver)?;
    }
    Ok(run)
}

fn lane_change_run<P, const M: usize, const S: usize>(
    plant: &P,
    chain: &ChainModel<M>,
    speed_mps: f64,
    amplitude_rad: f64,
    settings: &LaneChangeSettings,
    solver: &SolverSettings,
) -> Result<LaneChange, SwayError>
where
    P: Vehicle<M>,
    Layout<S>: ControllerStates<S>,
{
    let steering = SteeringInput::Sine {
        start_s: settings.start_s,
        frequency_hz: settings.frequency_hz,
        amplitude_rad,
        periods: 1.0,
    };
    let horizon = settings.start_s + 1.0 / settings.frequency_hz + settings.after_s;
    let straight = plant.initial_state(&Default::default(), speed_mps);
    let x0 = SVector::<f64, S>::from_fn(|i, _| if i < M { straight[i] } else { 0.0 });
    let result = simulate::<P, M, S>(
        plant,
        &run_spec(speed_mps, steering, horizon, solver),
        x0,
        Recording::Every {
            step_s: settings.sample_step_s,
        },
    )
    .map_err(|e| {
        with_context(
            e,
            &format!(
                "the lane change at V = {speed_mps} m/s, A = {:.4}°",
                amplitude_rad.to_degrees()
            ),
        )
    })?;
    let units = chain.units();
    let steer_axle = chain.axles().iter().position(|a| a.steered).unwrap_or(0);
    let rear_group: Vec<usize> = (0..chain.axles().len())
        .filter(|&k| chain.axles()[k].unit == units - 1)
        .collect();
    let rear_x = rear_group
        .iter()
        .map(|&k| chain.axle_coordinate(k))
        .sum::<f64>()
        / rear_group.len().max(1) as f64;
    let mut motions = [UnitMotion::default(); MAX_UNITS];
    let samples: Vec<LaneChangeSample> = result
        .trajectory
        .iter()
        .map(|s| {
            let (y, u) = chain_sample(chain, &s.x, s.speed, s.steering_angle);
            chain.unit_motions(&y, &u, &mut motions);
            let pose = Pose {
                heading_rad: s.x[M],
                x_m: s.x[M + 1],
                y_m: s.x[M + 2],
            };
            LaneChangeSample {
                time_s: s.t,
                steering_angle_deg: s.steering_angle.to_degrees(),
                lateral_accelerations_mps2: motions[..units]
                    .iter()
                    .map(|m| m.lateral_acceleration_mps2)
                    .collect(),
                yaw_rates_deg_s: motions[..units]
                    .iter()
                    .map(|m| m.yaw_rate_rad_s.to_degrees())
                    .collect(),
                steer_axle_m: chain.point_position(&y, &pose, 0, chain.axle_coordinate(steer_axle)),
                rearmost_axle_m: chain.point_position(&y, &pose, units - 1, rear_x),
            }
        })
        .collect();
    let peak = |f: &dyn Fn(&LaneChangeSample) -> f64| {
        samples.iter().map(|s| f(s).abs()).fold(0.0, f64::max)
    };
    let a0 = peak(&|s| s.lateral_accelerations_mps2[0]);
    let an = peak(&|s| s.lateral_accelerations_mps2[units - 1]);
    let r0 = peak(&|s| s.yaw_rates_deg_s[0]);
    let rn = peak(&|s| s.yaw_rates_deg_s[units - 1]);
    let (lane_offset, overshoot) = offtracking(&samples);
    Ok(LaneChange {
        speed_mps,
        steering_amplitude_deg: amplitude_rad.to_degrees(),
        outcome: result.metrics.outcome,
        towing_unit_peak_lateral_acceleration_mps2: a0,
        rearmost_peak_lateral_acceleration_mps2: an,
        rearward_amplification: an / a0,
        towing_unit_peak_yaw_rate_deg_s: r0,
        rearmost_peak_yaw_rate_deg_s: rn,
        rearward_amplification_yaw_rate: rn / r0,
        lane_offset_m: lane_offset,
        high_speed_transient_offtracking_m: overshoot,
        samples,
    })
}

fn yaw_damping_on<P, const M: usize, const S: usize>(
    plant: &P,
    speed_mps: f64,
    settings: &YawDampingSettings,
    solver: &SolverSettings,
) -> Result<Vec<ArticulationDamping>, SwayError>
where
    P: Vehicle<M> + AsChain<M>,
    Layout<M>: ControllerStates<M>,
{
    let chain = plant.as_chain()?;
    let steering = SteeringInput::Pulse {
        shape: settings.shape,
        start_s: settings.start_s,
        duration_s: settings.duration_s,
        amplitude_rad: settings.amplitude_deg.to_radians(),
    };
    let end = settings.start_s + settings.duration_s;
    let x0 = plant.initial_state(&Default::default(), speed_mps);
    let result = simulate::<P, M, M>(
        plant,
        &run_spec(speed_mps, steering, end + settings.after_s, solver),
        x0,
        Recording::Every {
            step_s: settings.sample_step_s,
        },
    )
    .map_err(|e| with_context(e, &format!("the yaw-damping pulse at V = {speed_mps} m/s")))?;
    let t: Vec<f64> = result.trajectory.iter().map(|s| s.t).collect();
    let lost = (result.metrics.outcome != Outcome::Ok).then(|| {
        format!(
            "control was lost after the pulse at t = {:.2} s",
            result
                .metrics
                .loss_of_control_time_s
                .unwrap_or(result.t_end)
        )
    });
    Ok((1..chain.units())
        .map(|i| {
            // the paper layout keeps every articulation angle where the chain has it (it
            // differs in the rates σ2, σ3 only): no map of the state is needed
            let k = ChainModel::<M>::articulation_angle_index(i);
            let theta: Vec<f64> = result.trajectory.iter().map(|s| s.x[k]).collect();
            let scale = theta.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let p = peaks(&t, &theta, end, 1e-6 * scale);
            articulation_damping(
                i,
                decay(&p, settings.skip_peaks, settings.periods),
                lost.clone(),
            )
        })
        .collect())
}

fn articulation_damping(
    coupling: usize,
    d: Option<Decay>,
    lost: Option<String>,
) -> ArticulationDamping {
    match (d, lost) {
        (_, Some(reason)) => ArticulationDamping {
            coupling,
            damping_ratio: None,
            frequency_hz: None,
            reason: Some(reason),
        },
        (Some(d), None) => ArticulationDamping {
            coupling,
            damping_ratio: Some(d.damping_ratio),
            frequency_hz: Some(d.frequency_hz),
            reason: None,
        },
        (None, None) => ArticulationDamping {
            coupling,
            damping_ratio: None,
            frequency_hz: None,
            reason: Some("too few peaks after the pulse to read a decrement (the articulation does not oscillate, or the run is too short: raise `after_s`)".into()),
        },
    }
}

fn with_context(e: SwayError, what: &str) -> SwayError {
    match e {
        SwayError::Numerical { context, cause } => SwayError::Numerical {
            context: format!("{what}: {context}"),
            cause,
        },
        e => e,
    }
}
