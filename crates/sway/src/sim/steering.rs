//! A steering input of its own beside the feedback law's command: the steering-wheel
//! impulse of a lateral stability test (ISO 9815, pulse steer), after which the wheel is
//! held straight, and the driver's manoeuvres of the sway assist's evaluation (sine steer:
//! slalom and single lane change; double lane change; a ramp into a steady corner). The front-wheel angle is δ(t) = δ_law(t) + δ_in(t) with δ_in from
//! [`SteeringInput`]; without one (the default) δ is the law's alone, unchanged.

use serde::{Deserialize, Serialize};

/// The shape s(u) of a pulse over its duration, u = (t − t₀)/T ∈ [0, 1), peak 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PulseShape {
    /// s = sin(πu): smooth at its peak, its rate jumps at both ends
    #[default]
    HalfSine,
    /// s = 1 − |2u − 1|: the peak at mid-pulse, kinks at both ends and the peak
    Triangle,
    /// s = 1: the angle jumps at both ends
    Rectangle,
}

impl PulseShape {
    /// All shapes, in the order they are listed.
    pub const ALL: [PulseShape; 3] = [
        PulseShape::HalfSine,
        PulseShape::Triangle,
        PulseShape::Rectangle,
    ];

    /// s(u) for u ∈ [0, 1).
    #[inline]
    pub fn value(&self, u: f64) -> f64 {
        match self {
            PulseShape::HalfSine => (std::f64::consts::PI * u).sin(),
            PulseShape::Triangle => 1.0 - (2.0 * u - 1.0).abs(),
            PulseShape::Rectangle => 1.0,
        }
    }

    /// The mean of s over the pulse: the steering-angle impulse is A·T·mean \[rad s\].
    pub fn mean(&self) -> f64 {
        match self {
            PulseShape::HalfSine => 2.0 / std::f64::consts::PI,
            PulseShape::Triangle => 0.5,
            PulseShape::Rectangle => 1.0,
        }
    }

    /// The name used in configs and summaries.
    pub fn as_str(&self) -> &'static str {
        match self {
            PulseShape::HalfSine => "half_sine",
            PulseShape::Triangle => "triangle",
            PulseShape::Rectangle => "rectangle",
        }
    }
}

/// A steering input δ_in(t) \[rad\] added to the law's command.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum SteeringInput {
    /// none: δ is the law's command alone
    #[default]
    None,
    /// δ_in(t) = A·s((t − t₀)/T) for t₀ ≤ t < t₀ + T and 0 otherwise (the wheel held
    /// straight after the pulse)
    Pulse {
        /// s(u)
        shape: PulseShape,
        /// t₀ \[s\]
        start_s: f64,
        /// T \[s\] (> 0)
        duration_s: f64,
        /// A \[rad\]
        amplitude_rad: f64,
    },
    /// Sine steer: δ_in(t) = A·sin(2πf(t − t₀)) for t₀ ≤ t < t₀ + n/f and 0 otherwise (a
    /// slalom of n periods; one period is a single lane change, ISO 3888-2's timing by a
    /// sine-steer input)
    Sine {
        /// t₀ \[s\]
        start_s: f64,
        /// f \[Hz\] (> 0)
        frequency_hz: f64,
        /// A \[rad\]
        amplitude_rad: f64,
        /// n, the number of periods (> 0; may be fractional)
        periods: f64,
    },
    /// A double lane change (ISO 3888-1-like timing): one period of sine steer
    /// A·sin(2πf(t − t₀)) out into the other lane, a straight hold of `hold_s`, and one
    /// period of −A·sin back
    DoubleSine {
        /// t₀ \[s\]
        start_s: f64,
        /// f \[Hz\] (> 0)
        frequency_hz: f64,
        /// A \[rad\]
        amplitude_rad: f64,
        /// the straight section between the two lane changes \[s\] (≥ 0)
        hold_s: f64,
    },
    /// A ramp into a steady corner: δ_in rises linearly from 0 at t₀ to A at t₀ + T and is
    /// held there
    Ramp {
        /// t₀ \[s\]
        start_s: f64,
        /// T \[s\] (> 0)
        duration_s: f64,
        /// A \[rad\]
        amplitude_rad: f64,
    },
}

/// A·sin(2πf·u) for 0 ≤ u < n/f, else 0.
#[inline]
fn sine_periods(u: f64, frequency_hz: f64, amplitude_rad: f64, periods: f64) -> f64 {
    if u >= 0.0 && u * frequency_hz < periods {
        amplitude_rad * (std::f64::consts::TAU * frequency_hz * u).sin()
    } else {
        0.0
    }
}

impl SteeringInput {
    /// δ_in(t) \[rad\].
    #[inline]
    pub fn angle(&self, t: f64) -> f64 {
        match *self {
            SteeringInput::None => 0.0,
            SteeringInput::Pulse {
                shape,
                start_s,
                duration_s,
                amplitude_rad,
            } => {
                let u = (t - start_s) / duration_s;
                if (0.0..1.0).contains(&u) {
                    amplitude_rad * shape.value(u)
                } else {
                    0.0
                }
            }
            SteeringInput::Sine {
                start_s,
                frequency_hz,
                amplitude_rad,
                periods,
            } => sine_periods(t - start_s, frequency_hz, amplitude_rad, periods),
            SteeringInput::DoubleSine {
                start_s,
                frequency_hz,
                amplitude_rad,
                hold_s,
            } => {
                let back = start_s + 1.0 / frequency_hz + hold_s;
                sine_periods(t - start_s, frequency_hz, amplitude_rad, 1.0)
                    - sine_periods(t - back, frequency_hz, amplitude_rad, 1.0)
            }
            SteeringInput::Ramp {
                start_s,
                duration_s,
                amplitude_rad,
            } => amplitude_rad * ((t - start_s) / duration_s).clamp(0.0, 1.0),
        }
    }

    /// When the input has ended \[s\] (its last change; a ramp's top is held after it).
    pub fn end_s(&self) -> f64 {
        match *self {
            SteeringInput::None => 0.0,
            SteeringInput::Pulse {
                start_s,
                duration_s,
                ..
            }
            | SteeringInput::Ramp {
                start_s,
                duration_s,
                ..
            } => start_s + duration_s,
            SteeringInput::Sine {
                start_s,
                frequency_hz,
                periods,
                ..
            } => start_s + periods / frequency_hz,
            SteeringInput::DoubleSine {
                start_s,
                frequency_hz,
                hold_s,
                ..
            } => start_s + 2.0 / frequency_hz + hold_s,
        }
    }

    /// Whether there is an input.
    #[inline]
    pub fn is_none(&self) -> bool {
        matches!(self, SteeringInput::None)
    }

    /// Times \[s\] where δ_in jumps or kinks: the pulse's ends (and the triangle's peak).
    pub fn breakpoints(&self) -> Vec<f64> {
        match *self {
            SteeringInput::None => Vec::new(),
            SteeringInput::Pulse {
                shape,
                start_s,
                duration_s,
                ..
            } => {
                let mut v = vec![start_s, start_s + duration_s];
                if shape == PulseShape::Triangle {
                    v.push(start_s + 0.5 * duration_s);
                }
                v
            }
            SteeringInput::Sine { start_s, .. } | SteeringInput::Ramp { start_s, .. } => {
                vec![start_s, self.end_s()]
            }
            SteeringInput::DoubleSine {
                start_s,
                frequency_hz,
                hold_s,
                ..
            } => {
                let out = start_s + 1.0 / frequency_hz;
                vec![start_s, out, out + hold_s, self.end_s()]
            }
        }
    }

    /// Checks; `Err((key, problem))` names the offending key.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if let SteeringInput::Pulse {
            start_s,
            duration_s,
            amplitude_rad,
            ..
        } = *self
        {
            if !(start_s.is_finite() && start_s >= 0.0) {
                return Err(("start_s", format!("expected a time >= 0 s, got {start_s}")));
            }
            if !(duration_s.is_finite() && duration_s > 0.0) {
                return Err((
                    "duration_s",
                    format!("expected a duration > 0 s, got {duration_s}"),
                ));
            }
            if !(amplitude_rad.is_finite() && amplitude_rad.abs() < 1.0) {
                return Err((
                    "amplitude_rad",
                    format!("expected a finite steering angle below 1 rad, got {amplitude_rad}"),
                ));
            }
        }
        let (start_s, amplitude_rad) = match *self {
            SteeringInput::None | SteeringInput::Pulse { .. } => return Ok(()),
            SteeringInput::Sine {
                start_s,
                frequency_hz,
                amplitude_rad,
                periods,
            } => {
                positive_finite("frequency_hz", frequency_hz)?;
                positive_finite("periods", periods)?;
                (start_s, amplitude_rad)
            }
            SteeringInput::DoubleSine {
                start_s,
                frequency_hz,
                amplitude_rad,
                hold_s,
            } => {
                positive_finite("frequency_hz", frequency_hz)?;
                if !(hold_s.is_finite() && hold_s >= 0.0) {
                    return Err(("hold_s", format!("expected a time >= 0 s, got {hold_s}")));
                }
                (start_s, amplitude_rad)
            }
            SteeringInput::Ramp {
                start_s,
                duration_s,
                amplitude_rad,
            } => {
                positive_finite("duration_s", duration_s)?;
                (start_s, amplitude_rad)
            }
        };
        if !(start_s.is_finite() && start_s >= 0.0) {
            return Err(("start_s", format!("expected a time >= 0 s, got {start_s}")));
        }
        if !(amplitude_rad.is_finite() && amplitude_rad.abs() < 1.0) {
            return Err((
                "amplitude_rad",
                format!("expected a finite steering angle below 1 rad, got {amplitude_rad}"),
            ));
        }
        Ok(())
    }
}

fn positive_finite(key: &'static str, v: f64) -> Result<(), (&'static str, String)> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err((key, format!("expected a finite value > 0, got {v}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pulses_have_their_impulse_and_end_at_zero() {
        // reference: ∫ A·s(u) dt over the pulse = A·T·mean(s), by the midpoint rule on
        // 100 000 steps (error ~1e-10 for the kinked shapes, far below 1e-8)
        for shape in PulseShape::ALL {
            let p = SteeringInput::Pulse {
                shape,
                start_s: 1.0,
                duration_s: 0.5,
                amplitude_rad: 0.02,
            };
            let n = 100_000;
            let h = 0.5 / n as f64;
            let integral: f64 = (0..n)
                .map(|k| p.angle(1.0 + (k as f64 + 0.5) * h) * h)
                .sum();
            assert!(
                (integral - 0.02 * 0.5 * shape.mean()).abs() < 1e-8,
                "{shape:?}: {integral}"
            );
            assert_eq!(p.angle(0.999), 0.0);
            assert_eq!(p.angle(1.5), 0.0);
            assert!(p.validate().is_ok());
        }
    }

    #[test]
    fn manoeuvres_start_and_end_at_zero() {
        // reference: the definitions; the double lane change returns to straight
        // (∫ of its two opposite periods is 0 to rounding)
        let dlc = SteeringInput::DoubleSine {
            start_s: 1.0,
            frequency_hz: 0.5,
            amplitude_rad: 0.02,
            hold_s: 1.0,
        };
        assert_eq!(dlc.end_s(), 6.0);
        assert_eq!(dlc.breakpoints(), vec![1.0, 3.0, 4.0, 6.0]);
        assert!((dlc.angle(1.5) - 0.02).abs() < 1e-12);
        assert!((dlc.angle(4.5) + 0.02).abs() < 1e-12);
        assert_eq!(dlc.angle(3.5), 0.0);
        assert_eq!(dlc.angle(6.0), 0.0);
        let ramp = SteeringInput::Ramp {
            start_s: 1.0,
            duration_s: 2.0,
            amplitude_rad: 0.01,
        };
        assert!((ramp.angle(2.0) - 0.005).abs() < 1e-15);
        assert_eq!(ramp.angle(10.0), 0.01);
        let slalom = SteeringInput::Sine {
            start_s: 0.0,
            frequency_hz: 1.0,
            amplitude_rad: 0.01,
            periods: 3.0,
        };
        assert!((slalom.angle(2.25) - 0.01).abs() < 1e-12);
        assert_eq!(slalom.angle(3.25), 0.0);
        for input in [dlc, ramp, slalom] {
            assert!(input.validate().is_ok());
        }
    }
}
