//! The disturbances of the sway assist's evaluation: what starts sway (a steering impulse,
//! a crosswind gust on the trailer, a lane change) and what a detector must not take for it
//! (a slalom, lane changes, a ramp into a steady corner), as a steering input
//! ([`SteeringInput`]) beside a lateral force on the trailer.
//!
//! Manoeuvres sized by the car's lateral acceleration get their steering amplitude from the
//! linear model at the run's speed ([`steering_per_lateral_acceleration`]): the car's
//! lateral acceleration is approximated by V·ψ̇ (the lateral-velocity term is small against
//! it at the frequencies of driving), and the yaw-rate response to steering is the linear
//! model's at the manoeuvre's frequency (steady state for the corner).

use nalgebra::{Complex, Matrix4};
use serde::{Deserialize, Serialize};
use trailer_model::Model;

use crate::SwayError;
use crate::sim::{PulseShape, SteeringInput};

/// A disturbance of a run, starting at the run's `disturbance_start_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Disturbance {
    /// nothing: straight running
    None,
    /// a half-sine steering impulse (ISO 9815's pulse steer) of the front wheels
    SteeringImpulse {
        /// its peak front-wheel angle \[deg\]
        amplitude_deg: f64,
        /// its duration \[s\]
        duration_s: f64,
    },
    /// a crosswind gust: a rectangular lateral force pulse on the trailer at its centre of
    /// gravity, positive to its left (held per sensor frame: exact when the times are
    /// multiples of the 10 ms frame)
    CrosswindGust {
        /// the force \[N\]
        force_n: f64,
        /// its duration \[s\]
        duration_s: f64,
    },
    /// a single lane change: one period of sine steer sized for the car's peak lateral
    /// acceleration
    SingleLaneChange {
        /// the car's peak lateral acceleration \[m/s²\]
        lateral_acceleration_mps2: f64,
        /// the sine's frequency \[Hz\] (ISO 3888-2-like: 0.4–0.6 Hz at highway speed)
        frequency_hz: f64,
    },
    /// a double lane change (ISO 3888-1-like): a lane change out, a straight hold, and back
    DoubleLaneChange {
        /// the car's peak lateral acceleration \[m/s²\]
        lateral_acceleration_mps2: f64,
        /// the sine's frequency \[Hz\]
        frequency_hz: f64,
        /// the straight section between the two \[s\]
        hold_s: f64,
    },
    /// a slalom: sinusoidal steering of `periods` periods at f, sized for the car's peak
    /// lateral acceleration
    Slalom {
        /// f \[Hz\]
        frequency_hz: f64,
        /// the car's peak lateral acceleration \[m/s²\]
        lateral_acceleration_mps2: f64,
        /// the number of periods
        periods: f64,
    },
    /// a ramp into a steady corner: the steering rises linearly to the angle of the steady
    /// lateral acceleration and is held
    CorneringRamp {
        /// the car's steady lateral acceleration \[m/s²\]
        lateral_acceleration_mps2: f64,
        /// the ramp's duration \[s\]
        duration_s: f64,
    },
}

/// The kind and its sizes, for messages: `slalom 0.4 Hz 4 m/s²`, `steering_impulse 3° 0.4 s`.
impl std::fmt::Display for Disturbance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.kind())?;
        match *self {
            Disturbance::None => Ok(()),
            Disturbance::SteeringImpulse {
                amplitude_deg,
                duration_s,
            } => write!(f, " {amplitude_deg}° {duration_s} s"),
            Disturbance::CrosswindGust {
                force_n,
                duration_s,
            } => write!(f, " {force_n} N {duration_s} s"),
            Disturbance::SingleLaneChange {
                lateral_acceleration_mps2,
                frequency_hz,
            }
            | Disturbance::DoubleLaneChange {
                lateral_acceleration_mps2,
                frequency_hz,
                ..
            }
            | Disturbance::Slalom {
                frequency_hz,
                lateral_acceleration_mps2,
                ..
            } => write!(f, " {frequency_hz} Hz {lateral_acceleration_mps2} m/s²"),
            Disturbance::CorneringRamp {
                lateral_acceleration_mps2,
                duration_s,
            } => write!(f, " {lateral_acceleration_mps2} m/s² {duration_s} s"),
        }
    }
}

impl Disturbance {
    /// Whether it is driving that [`DrivingSequence`] strings together: steering that
    /// returns to zero (an impulse, a lane change, a slalom; not a gust, not a corner).
    pub fn is_driving(&self) -> bool {
        matches!(
            self,
            Disturbance::SteeringImpulse { .. }
                | Disturbance::SingleLaneChange { .. }
                | Disturbance::DoubleLaneChange { .. }
                | Disturbance::Slalom { .. }
        )
    }

    /// The snake_case name of the kind (CSV rows, figure titles).
    pub fn kind(&self) -> &'static str {
        match self {
            Disturbance::None => "none",
            Disturbance::SteeringImpulse { .. } => "steering_impulse",
            Disturbance::CrosswindGust { .. } => "crosswind_gust",
            Disturbance::SingleLaneChange { .. } => "single_lane_change",
            Disturbance::DoubleLaneChange { .. } => "double_lane_change",
            Disturbance::Slalom { .. } => "slalom",
            Disturbance::CorneringRamp { .. } => "cornering_ramp",
        }
    }

    /// Its size in its own unit (deg, N or m/s²), for tables.
    pub fn size(&self) -> f64 {
        match *self {
            Disturbance::None => 0.0,
            Disturbance::SteeringImpulse { amplitude_deg, .. } => amplitude_deg,
            Disturbance::CrosswindGust { force_n, .. } => force_n,
            Disturbance::SingleLaneChange {
                lateral_acceleration_mps2,
                ..
            }
            | Disturbance::DoubleLaneChange {
                lateral_acceleration_mps2,
                ..
            }
            | Disturbance::Slalom {
                lateral_acceleration_mps2,
                ..
            }
            | Disturbance::CorneringRamp {
                lateral_acceleration_mps2,
                ..
            } => lateral_acceleration_mps2,
        }
    }

    /// The steering input of this disturbance at speed `speed_mps` on `model`, from
    /// `start_s` \[s\].
    ///
    /// # Errors
    /// [`SwayError::Numerical`] when the linear model gives no finite steering gain (a
    /// manoeuvre sized by lateral acceleration at a speed where the car does not turn).
    pub fn steering(
        &self,
        model: &Model,
        speed_mps: f64,
        start_s: f64,
    ) -> Result<SteeringInput, SwayError> {
        let per = |a: f64, f: f64| -> Result<f64, SwayError> {
            let g = steering_per_lateral_acceleration(model, speed_mps, f);
            if g.is_finite() {
                Ok(a * g)
            } else {
                Err(SwayError::numerical(
                    format!("the steering of a {} at {speed_mps} m/s", self.kind()),
                    std::io::Error::other("the linear model's yaw-rate gain is 0 or not finite"),
                ))
            }
        };
        Ok(match *self {
            Disturbance::None | Disturbance::CrosswindGust { .. } => SteeringInput::None,
            Disturbance::SteeringImpulse {
                amplitude_deg,
                duration_s,
            } => SteeringInput::Pulse {
                shape: PulseShape::HalfSine,
                start_s,
                duration_s,
                amplitude_rad: amplitude_deg.to_radians(),
            },
            Disturbance::SingleLaneChange {
                lateral_acceleration_mps2,
                frequency_hz,
            } => SteeringInput::Sine {
                start_s,
                frequency_hz,
                amplitude_rad: per(lateral_acceleration_mps2, frequency_hz)?,
                periods: 1.0,
            },
            Disturbance::DoubleLaneChange {
                lateral_acceleration_mps2,
                frequency_hz,
                hold_s,
            } => SteeringInput::DoubleSine {
                start_s,
                frequency_hz,
                amplitude_rad: per(lateral_acceleration_mps2, frequency_hz)?,
                hold_s,
            },
            Disturbance::Slalom {
                frequency_hz,
                lateral_acceleration_mps2,
                periods,
            } => SteeringInput::Sine {
                start_s,
                frequency_hz,
                amplitude_rad: per(lateral_acceleration_mps2, frequency_hz)?,
                periods,
            },
            Disturbance::CorneringRamp {
                lateral_acceleration_mps2,
                duration_s,
            } => SteeringInput::Ramp {
                start_s,
                duration_s,
                amplitude_rad: per(lateral_acceleration_mps2, 0.0)?,
            },
        })
    }

    /// The lateral force on the trailer \[N\] at `t` for a disturbance from `start_s`.
    pub fn trailer_force(&self, t: f64, start_s: f64) -> f64 {
        match *self {
            Disturbance::CrosswindGust {
                force_n,
                duration_s,
            } if t >= start_s && t < start_s + duration_s => force_n,
            _ => 0.0,
        }
    }

    /// When the disturbance has ended \[s\] for a start at `start_s` (a corner's ramp: its
    /// top; a slalom: its last period).
    pub fn end_s(&self, model: &Model, speed_mps: f64, start_s: f64) -> f64 {
        match *self {
            Disturbance::None => start_s,
            Disturbance::CrosswindGust { duration_s, .. } => start_s + duration_s,
            _ => self
                .steering(model, speed_mps, start_s)
                .map_or(start_s, |s| s.end_s()),
        }
    }

    /// Checks; `Err((key, problem))` names the key inside the disturbance's table.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let positive = |key: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((key, format!("expected a finite value > 0, got {v}")))
            }
        };
        match *self {
            Disturbance::None => Ok(()),
            Disturbance::SteeringImpulse {
                amplitude_deg,
                duration_s,
            } => {
                positive("duration_s", duration_s)?;
                if amplitude_deg.is_finite() && amplitude_deg.abs() < 30.0 {
                    Ok(())
                } else {
                    Err((
                        "amplitude_deg",
                        format!("expected a front-wheel angle below 30 deg, got {amplitude_deg}"),
                    ))
                }
            }
            Disturbance::CrosswindGust {
                force_n,
                duration_s,
            } => {
                positive("duration_s", duration_s)?;
                if force_n.is_finite() {
                    Ok(())
                } else {
                    Err(("force_n", format!("expected a finite force, got {force_n}")))
                }
            }
            Disturbance::SingleLaneChange {
                lateral_acceleration_mps2,
                frequency_hz,
            } => {
                positive("lateral_acceleration_mps2", lateral_acceleration_mps2)?;
                positive("frequency_hz", frequency_hz)
            }
            Disturbance::DoubleLaneChange {
                lateral_acceleration_mps2,
                frequency_hz,
                hold_s,
            } => {
                positive("lateral_acceleration_mps2", lateral_acceleration_mps2)?;
                positive("frequency_hz", frequency_hz)?;
                if hold_s.is_finite() && hold_s >= 0.0 {
                    Ok(())
                } else {
                    Err(("hold_s", format!("expected a time >= 0 s, got {hold_s}")))
                }
            }
            Disturbance::Slalom {
                frequency_hz,
                lateral_acceleration_mps2,
                periods,
            } => {
                positive("lateral_acceleration_mps2", lateral_acceleration_mps2)?;
                positive("frequency_hz", frequency_hz)?;
                positive("periods", periods)
            }
            Disturbance::CorneringRamp {
                lateral_acceleration_mps2,
                duration_s,
            } => {
                positive("lateral_acceleration_mps2", lateral_acceleration_mps2)?;
                positive("duration_s", duration_s)
            }
        }
    }
}

/// Ordinary driving: manoeuvres whose steering returns to zero (slaloms, lane changes,
/// steering impulses) driven one after another, `gap_s` of straight driving between two,
/// the list repeated from `start_s` for as long as asked; the other disturbances (a ramp
/// into a held corner, a gust, none) are left out. The observer's evaluation drives it
/// ([`super::run_driving`]): the parameters are learned from the car's answers to the
/// driver's steering.
///
/// Unlike a single [`Disturbance`] it is not the problem's own [`SteeringInput`]: the
/// co-simulation holds its angle per sensor frame (sampled at the frame's start, 10 ms;
/// the manoeuvres' 0.4–1.2 Hz are 80–250 frames a period).
#[derive(Debug, Clone, PartialEq)]
pub struct DrivingSequence {
    steerings: Vec<SteeringInput>,
    end_s: f64,
}

impl DrivingSequence {
    /// The manoeuvres of `list` at `speed_mps` on `model`, repeated from `start_s` with
    /// `gap_s` between two, the last one starting before `until_s`.
    ///
    /// # Errors
    /// A manoeuvre's [`Disturbance::steering`] error; [`SwayError::Numerical`] when `list`
    /// has no manoeuvre whose steering returns to zero.
    pub fn new(
        list: &[Disturbance],
        model: &Model,
        speed_mps: f64,
        start_s: f64,
        gap_s: f64,
        until_s: f64,
    ) -> Result<Self, SwayError> {
        let kept: Vec<&Disturbance> = list.iter().filter(|d| d.is_driving()).collect();
        if kept.is_empty() {
            return Err(SwayError::numerical(
                "ordinary driving",
                std::io::Error::other(
                    "no slalom, lane change or steering impulse among the manoeuvres",
                ),
            ));
        }
        let mut steerings = Vec::new();
        let mut t = start_s;
        'outer: loop {
            for d in &kept {
                if t >= until_s {
                    break 'outer;
                }
                let s = d.steering(model, speed_mps, t)?;
                t = s.end_s().max(t) + gap_s.max(0.0);
                steerings.push(s);
            }
        }
        let end_s = steerings.last().map_or(start_s, SteeringInput::end_s);
        Ok(Self { steerings, end_s })
    }

    /// The front-wheel angle \[rad\] at `t`.
    pub fn angle(&self, t: f64) -> f64 {
        self.steerings
            .iter()
            .filter(|s| t < s.end_s())
            .map(|s| s.angle(t))
            .sum()
    }

    /// The manoeuvres driven, in order.
    pub fn manoeuvres(&self) -> usize {
        self.steerings.len()
    }

    /// When the last manoeuvre ends \[s\].
    pub fn end_s(&self) -> f64 {
        self.end_s
    }
}

/// The front-wheel angle \[rad\] per m/s² of the car's lateral acceleration for sinusoidal
/// steering at `frequency_hz` (0: steady state) at `speed_mps`: 1/(V·|G(iω)|) with G the
/// yaw-rate response of the linearised model (eq. 9–11), G(s) = C̃(sI − Ã)⁻¹B̃, and the
/// lateral acceleration ≈ V·ψ̇. Infinite (or NaN) where the car does not turn.
pub fn steering_per_lateral_acceleration(model: &Model, speed_mps: f64, frequency_hz: f64) -> f64 {
    let lin = model.linearize(speed_mps);
    let w = std::f64::consts::TAU * frequency_hz;
    let a: Matrix4<Complex<f64>> = lin.a4.map(|v| Complex::new(-v, 0.0))
        + Matrix4::from_diagonal_element(Complex::new(0.0, w));
    let b = lin.b4.map(|v| Complex::new(v, 0.0));
    let gain = match a.lu().solve(&b) {
        Some(x) => (lin.c4.map(|v| Complex::new(v, 0.0)) * x)[(0, 0)].norm(),
        None => 0.0,
    };
    1.0 / (speed_mps * gain)
}
