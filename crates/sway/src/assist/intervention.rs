//! The intervention of the sway assist (issue 48, item 3), as a trailer stability program
//! on the towing car runs it: it reads only sensor frames and the detectors' flags, and
//! commands the brakes and the engine.
//!
//! - **Symmetric braking** of the car to a target deceleration, with the **engine torque
//!   cut** (a small deceleration of its own): the speed falls, V̇ < 0 enters the equations
//!   of motion (eq. 6) — the mitigation's braking ramps ([`crate::mitigation`]) are the
//!   reference.
//! - **Differential braking**: a yaw moment on the car opposing the sway,
//!   M_z = −D_M·s·r_bp, with r_bp the measured car yaw rate band-passed in the sway band
//!   (the signal the detectors see, not the model's state), s = C_F·(f − c) the scale of
//!   [`sway_model::law::Actuator::DifferentialBraking`] (so D_M \[s\] is the gain a steering
//!   loop of the same strength would have), and D_M = [`AssistOptions::yaw_moment_gain_s`].
//! - **Actuators**: the hydraulic brake pressure builds up as a first-order lag
//!   ([`AssistOptions::brake_lag_s`]), the engine's torque cut as a faster one; commands
//!   are updated every frame and held between (a zero-order hold).
//! - **Limits from the friction** μ0 available at the car's wheels (the trailer is
//!   unbraked): the combination decelerates at most μ0·(F_zF + F_zR)/(m1 + m2), and the
//!   braked wheels of one side give a yaw moment of at most
//!   (μ0·(F_zF + F_zR) − F_brake)·w/4, what the symmetric braking force F_brake leaves
//!   (w the track width; [`sway_model::law::Actuator::limit`] at F_brake = 0). The one-sided
//!   braking of the yaw moment also decelerates: by 2|M_z|/(w·(m1 + m2)).
//! - **Engage** on a gated detector flag ([`SteeringGate`]: no engagement while the driver
//!   steers in the sway band) at a speed above [`AssistOptions::min_speed_mps`]; **release**
//!   with hysteresis, when no detector has flagged for [`AssistOptions::release_hold_s`]
//!   and the speed has fallen by [`AssistOptions::release_speed_drop_mps`] since the
//!   engagement (or to the minimum speed).

use serde::{Deserialize, Serialize};
use sway_detect::ConfigError;
use sway_detect::filter::{BandPass, SwayBand};
use trailer_model::Model;

/// The assist's settings (every quantity with its unit; defaults of a production trailer
/// stability program where one exists).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AssistOptions {
    /// the symmetric braking's target deceleration \[m/s²\] (1 m/s², gentle: on the paper's
    /// vehicle at 1.05·V_crit, 2–3 m/s² from a 30° sway cycle jackknifes the trailer or
    /// loses control, as braking alone from the cycle does in `fig4c`, while 0.5–1 m/s²
    /// with the differential braking settles every sway run of the default evaluation)
    pub target_deceleration_mps2: f64,
    /// the engine torque cut's deceleration \[m/s²\] (engine drag at highway speed)
    pub torque_cut_deceleration_mps2: f64,
    /// D_M \[s\]: the differential braking's yaw-moment gain on the band-passed yaw rate,
    /// in units of a steering gain (see the module docs); 0: no differential braking.
    /// 0.5 s: it saturates at the friction limit from ≈ 0.02 rad/s of band-passed yaw
    /// rate on the paper's vehicle (the sway the counter flags)
    pub yaw_moment_gain_s: f64,
    /// the brake pressure's build-up time constant \[s\] (hydraulic first-order lag)
    pub brake_lag_s: f64,
    /// the engine torque cut's time constant \[s\]
    pub torque_cut_lag_s: f64,
    /// the car's track width w \[m\] (the differential braking's lever)
    pub track_width_m: f64,
    /// the assist does not brake below this speed \[m/s\]
    pub min_speed_mps: f64,
    /// release only when no detector has flagged for this long \[s\]
    pub release_hold_s: f64,
    /// and the speed has fallen by this much since the engagement \[m/s\]
    pub release_speed_drop_mps: f64,
    /// the steering gate
    pub gate: SteeringGateOptions,
}

impl Default for AssistOptions {
    fn default() -> Self {
        Self {
            target_deceleration_mps2: 1.0,
            torque_cut_deceleration_mps2: 0.5,
            yaw_moment_gain_s: 0.5,
            brake_lag_s: 0.15,
            torque_cut_lag_s: 0.1,
            track_width_m: 1.6,
            min_speed_mps: 10.0,
            release_hold_s: 1.0,
            release_speed_drop_mps: 5.0,
            gate: SteeringGateOptions::default(),
        }
    }
}

impl AssistOptions {
    /// Checks; `Err((key, problem))` names the key.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (key, v, strictly) in [
            (
                "target_deceleration_mps2",
                self.target_deceleration_mps2,
                false,
            ),
            (
                "torque_cut_deceleration_mps2",
                self.torque_cut_deceleration_mps2,
                false,
            ),
            ("yaw_moment_gain_s", self.yaw_moment_gain_s, false),
            ("brake_lag_s", self.brake_lag_s, true),
            ("torque_cut_lag_s", self.torque_cut_lag_s, true),
            ("track_width_m", self.track_width_m, true),
            ("min_speed_mps", self.min_speed_mps, false),
            ("release_hold_s", self.release_hold_s, false),
            ("release_speed_drop_mps", self.release_speed_drop_mps, false),
            (
                "gate.steering_threshold_rad",
                self.gate.steering_threshold_rad,
                true,
            ),
            ("gate.hold_s", self.gate.hold_s, true),
        ] {
            let ok = v.is_finite() && if strictly { v > 0.0 } else { v >= 0.0 };
            if !ok {
                let bound = if strictly { "> 0" } else { ">= 0" };
                return Err((key, format!("expected a finite value {bound}, got {v}")));
            }
        }
        Ok(())
    }
}

/// The steering gate's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SteeringGateOptions {
    /// the driver steers in the sway band while the band-passed steering-wheel angle
    /// reaches this in magnitude \[rad of steering wheel\] (0.02 rad = 1.1°: ≈ 10 times the
    /// sensor's resolution, a fifth of a brisk lane change's at 30 m/s)
    pub steering_threshold_rad: f64,
    /// how long the gate stays shut after the driver's last steering in the band \[s\]:
    /// the half-oscillation of the combination under way when the driver stops is still
    /// the driver's (1.0 s: half a period of a 0.5 Hz sway mode)
    pub hold_s: f64,
}

impl Default for SteeringGateOptions {
    fn default() -> Self {
        Self {
            steering_threshold_rad: 0.02,
            hold_s: 1.0,
        }
    }
}

/// Tells sway from the driver's own steering: the measured steering-wheel angle
/// band-passed in the sway band (0.4–1.5 Hz, removing the sensor's offset and steady
/// cornering). While it reaches the threshold, and for [`SteeringGateOptions::hold_s`]
/// after it last did, the oscillation of the yaw rate is the driver's (a slalom, a lane
/// change), and a detector's flag is not sway. The hold is a fixed time, not the decay of
/// the steering's envelope: a large steering input does not shut the gate for longer than
/// a small one once the wheel is still (its band-passed trace rings down within about a
/// second, e^(−b t/2) with the band's width b = 6.9 rad/s). Sway with a driver steering
/// against it in the band is not told apart (a limitation: the simulated driver holds the
/// wheel).
#[derive(Debug, Clone)]
pub struct SteeringGate {
    options: SteeringGateOptions,
    band_pass: BandPass,
    /// frames since the band-passed angle last reached the threshold (None: never)
    frames_since_steering: Option<u64>,
    hold_frames: u64,
    started: bool,
}

impl SteeringGate {
    /// A gate for frames at `frame_rate_hz`.
    ///
    /// # Errors
    /// The band-pass's [`ConfigError`] (a frame rate too low for the band).
    pub fn new(options: SteeringGateOptions, frame_rate_hz: f64) -> Result<Self, ConfigError> {
        Ok(Self {
            options,
            band_pass: BandPass::new(SwayBand::default(), frame_rate_hz)?,
            frames_since_steering: None,
            hold_frames: (options.hold_s * frame_rate_hz).round() as u64,
            started: false,
        })
    }

    /// Takes the next steering-wheel angle \[rad\] and says whether the driver is steering
    /// in the band or was within the hold (the gate is shut). A non-finite sample keeps the
    /// last verdict.
    pub fn update(&mut self, steering_wheel_angle: f64) -> bool {
        if steering_wheel_angle.is_finite() {
            if !self.started {
                self.band_pass.prime(steering_wheel_angle);
                self.started = true;
            }
            let y = self.band_pass.filter(steering_wheel_angle);
            self.frames_since_steering = if y.abs() >= self.options.steering_threshold_rad {
                Some(0)
            } else {
                self.frames_since_steering.map(|n| n.saturating_add(1))
            };
        }
        self.is_shut()
    }

    /// Whether the driver steers in the band or did within the hold.
    pub fn is_shut(&self) -> bool {
        self.frames_since_steering
            .is_some_and(|n| n <= self.hold_frames)
    }
}

/// Whether the assist brakes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AssistState {
    /// watching
    Standby,
    /// braking since a flag
    Engaged,
}

/// The commands of one frame, after the actuators' lags and limits.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Commands {
    /// the combination's deceleration \[m/s²\] (≥ 0)
    pub deceleration_mps2: f64,
    /// the yaw moment on the car \[N m\]
    pub yaw_moment_nm: f64,
}

/// The friction limits of a vehicle's car (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionLimits {
    /// μ0·(F_zF + F_zR) \[N\]: the largest braking force of the car's wheels
    pub max_brake_force_n: f64,
    /// m1 + m2 \[kg\]
    pub total_mass_kg: f64,
    /// s = C_F·(f − c) \[N m/rad\]: the yaw-moment gain's scale
    pub yaw_moment_scale: f64,
}

impl FrictionLimits {
    /// The limits of `model`'s car (its static axle loads, the hitch load included).
    pub fn of(model: &Model) -> Self {
        let p = model.params();
        let loads = model.axle_loads();
        Self {
            max_brake_force_n: p.friction.mu_static * (loads.front + loads.rear),
            total_mass_kg: p.tractor.mass + p.trailer.mass,
            yaw_moment_scale: sway_model::law::Actuator::DifferentialBraking.scale(model),
        }
    }

    /// The largest deceleration of the combination from the car's brakes \[m/s²\].
    pub fn max_deceleration_mps2(&self) -> f64 {
        self.max_brake_force_n / self.total_mass_kg
    }
}

/// The assist's controller: the state machine and the actuators' states.
#[derive(Debug, Clone)]
pub struct Controller {
    options: AssistOptions,
    limits: FrictionLimits,
    frame_s: f64,
    yaw_band_pass: BandPass,
    started: bool,
    state: AssistState,
    engaged_speed_mps: f64,
    clear_for_s: f64,
    brake: f64,
    torque_cut: f64,
    yaw_moment: f64,
}

impl Controller {
    /// A controller for frames every `frame_s` \[s\].
    ///
    /// # Errors
    /// The band-pass's [`ConfigError`] (a frame rate too low for the band).
    pub fn new(
        options: AssistOptions,
        limits: FrictionLimits,
        frame_s: f64,
    ) -> Result<Self, ConfigError> {
        Ok(Self {
            options,
            limits,
            frame_s,
            yaw_band_pass: BandPass::new(SwayBand::default(), 1.0 / frame_s)?,
            started: false,
            state: AssistState::Standby,
            engaged_speed_mps: 0.0,
            clear_for_s: 0.0,
            brake: 0.0,
            torque_cut: 0.0,
            yaw_moment: 0.0,
        })
    }

    /// The state.
    pub fn state(&self) -> AssistState {
        self.state
    }

    /// One frame: the measured yaw rate \[rad/s\] and speed \[m/s\], and whether a gated
    /// detector flags; returns the commands to hold until the next frame.
    pub fn update(&mut self, yaw_rate: f64, speed_mps: f64, flagged: bool) -> Commands {
        let o = &self.options;
        let r_bp = if yaw_rate.is_finite() {
            if !self.started {
                self.yaw_band_pass.prime(yaw_rate);
                self.started = true;
            }
            self.yaw_band_pass.filter(yaw_rate)
        } else {
            0.0
        };
        match self.state {
            AssistState::Standby => {
                if flagged && speed_mps > o.min_speed_mps {
                    self.state = AssistState::Engaged;
                    self.engaged_speed_mps = speed_mps;
                    self.clear_for_s = 0.0;
                }
            }
            AssistState::Engaged => {
                self.clear_for_s = if flagged {
                    0.0
                } else {
                    self.clear_for_s + self.frame_s
                };
                let slowed = speed_mps <= self.engaged_speed_mps - o.release_speed_drop_mps
                    || speed_mps <= o.min_speed_mps;
                if self.clear_for_s >= o.release_hold_s && slowed {
                    self.state = AssistState::Standby;
                }
            }
        }
        let engaged = self.state == AssistState::Engaged && speed_mps > o.min_speed_mps;
        let (brake_target, cut_target) = if engaged {
            (o.target_deceleration_mps2, o.torque_cut_deceleration_mps2)
        } else {
            (0.0, 0.0)
        };
        let lag = |tau: f64| 1.0 - (-self.frame_s / tau).exp();
        self.brake += lag(o.brake_lag_s) * (brake_target - self.brake);
        self.torque_cut += lag(o.torque_cut_lag_s) * (cut_target - self.torque_cut);
        let l = &self.limits;
        let symmetric = (self.brake + self.torque_cut).min(l.max_deceleration_mps2());
        let m_max =
            ((l.max_brake_force_n - l.total_mass_kg * symmetric) * o.track_width_m / 4.0).max(0.0);
        let moment_target = if engaged {
            -o.yaw_moment_gain_s * l.yaw_moment_scale * r_bp
        } else {
            0.0
        };
        // the one-sided brake pressure builds up as the symmetric one does
        self.yaw_moment += lag(o.brake_lag_s) * (moment_target - self.yaw_moment);
        let yaw_moment = self.yaw_moment.clamp(-m_max, m_max);
        let one_sided = 2.0 * yaw_moment.abs() / (o.track_width_m * l.total_mass_kg);
        Commands {
            deceleration_mps2: symmetric + one_sided,
            yaw_moment_nm: yaw_moment,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE_HZ: f64 = 100.0;

    /// The frames (as times \[s\]) at which the gate is shut for the steering trace `angle`
    /// over `seconds`.
    fn shut_times(angle: impl Fn(f64) -> f64, seconds: f64) -> Vec<f64> {
        let mut gate = SteeringGate::new(SteeringGateOptions::default(), RATE_HZ).unwrap();
        (0..(seconds * RATE_HZ) as usize)
            .map(|k| k as f64 / RATE_HZ)
            .filter(|&t| gate.update(angle(t)))
            .collect()
    }

    /// A 0.4 s half-sine steering pulse from t = 1 s: shut during it, open again after its
    /// band-passed ring-down (e^(−3.45 t): ≲ 1 s to fall from the pulse's peak below the
    /// threshold) plus the 1 s hold, whatever the pulse's size: a large pulse does not
    /// shut the gate much longer than a small one.
    #[test]
    fn a_steering_pulse_shuts_the_gate_for_its_ring_down_and_the_hold() {
        let pulse = |amplitude: f64| {
            move |t: f64| {
                if (1.0..1.4).contains(&t) {
                    amplitude * (std::f64::consts::PI * (t - 1.0) / 0.4).sin()
                } else {
                    0.0
                }
            }
        };
        let small = shut_times(pulse(0.1), 10.0);
        let large = shut_times(pulse(0.9), 10.0);
        for (name, shut) in [("small", &small), ("large", &large)] {
            let (first, last) = (shut[0], *shut.last().unwrap());
            assert!((1.0..1.2).contains(&first), "{name}: shut from {first} s");
            assert!((2.4..4.0).contains(&last), "{name}: shut until {last} s");
        }
        let (ls, ll) = (small.last().unwrap(), large.last().unwrap());
        assert!(ll - ls < 1.0, "large pulse {ll} s vs small {ls} s");
    }

    /// A slalom keeps the gate shut throughout; a steady corner (a ramp to a held angle)
    /// and the steering sensor's noise-sized wiggles (1 mrad) do not shut it after the
    /// ramp's own transient.
    #[test]
    fn a_slalom_shuts_the_gate_and_a_steady_corner_or_noise_does_not() {
        let slalom = |t: f64| 0.3 * (std::f64::consts::TAU * 0.8 * t).sin();
        let shut = shut_times(slalom, 10.0);
        assert!(shut.first().is_some_and(|&t| t < 0.5));
        assert!(shut.len() as f64 >= 0.95 * (10.0 - shut[0]) * RATE_HZ);
        let corner = |t: f64| 0.2 * (t / 3.0).min(1.0);
        assert!(shut_times(corner, 10.0).iter().all(|&t| t < 5.0));
        let wiggle = |t: f64| 1e-3 * (std::f64::consts::TAU * 0.7 * t).sin();
        assert!(shut_times(wiggle, 10.0).is_empty());
    }
}
