//! Sway detectors: the [`Detector`] trait, its output, and the implementations
//! [`OscillationCounter`] (the production approach), [`DampingEstimator`] (recursive
//! least squares on an autoregressive model) and [`ModelObserver`] (an extended Kalman
//! filter on the car–trailer model, [`observer`]).
//!
//! A detector sees only the sampled sensor values of a [`Measurement`], never a model's
//! state. The counter and the estimator read one [`Signal`] at a fixed sample rate (the
//! sensors' frame rate), the observer the yaw rate, lateral acceleration, steering-wheel
//! angle and speed together; each checks every sample before using it ([`InputStatus`]):
//! - a NaN or infinite time, a value that is NaN, infinite or beyond ±[`MAX_INPUT`] (a
//!   sensor fault), or a hitch angle that is not measured, is ignored and the previous
//!   output repeated with status [`InputStatus::Invalid`];
//! - a time not later than the last used sample's is ignored
//!   ([`InputStatus::OutOfOrder`]);
//! - more than [`GAP_TOLERANCE`] sample periods since the last used sample (frames lost,
//!   or invalid samples between) restart the detector from this sample
//!   ([`InputStatus::Gap`]): its filters assume equally spaced samples (the observer
//!   restarts its lateral states and keeps what it learned of the trailer).
//!
//! No detector panics on its input, allocates per sample or grows its state: every buffer
//! is a fixed-size array, every number an `f64`.

mod counter;
mod damping;
pub mod observer;

pub use counter::{CounterOptions, MAX_HALF_OSCILLATIONS, OscillationCounter};
pub use damping::{DampingEstimator, DampingOptions, MAX_AR_LAG};
pub use observer::{ModelObserver, ObserverEstimate, ObserverOptions};

use serde::{Deserialize, Serialize};

use crate::sensor::{Channel, Measurement};

/// A sway detector: fed one frame at a time, it says whether the combination sways.
pub trait Detector {
    /// Takes the next frame (frames in time order at the detector's sample rate) and
    /// returns the detector's verdict after it.
    fn update(&mut self, m: &Measurement) -> DetectorOutput;
    /// Back to the state of a new detector (as after construction).
    fn reset(&mut self);
    /// A short name for tables and figures (`oscillation_counter`, `damping_estimator`,
    /// `model_observer`).
    fn name(&self) -> &'static str;
    /// The detector flags exactly when its score is at least this: sweeping a threshold
    /// over recorded scores gives the detector's ROC curve.
    fn threshold(&self) -> f64;
}

/// Whether a detector sees sway.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SwayFlag {
    /// no sway detected
    Clear,
    /// sway detected
    Sway,
}

impl SwayFlag {
    /// [`SwayFlag::Sway`] when `score` ≥ `threshold`.
    pub fn from_score(score: f64, threshold: f64) -> Self {
        if score >= threshold {
            SwayFlag::Sway
        } else {
            SwayFlag::Clear
        }
    }

    /// Whether this is [`SwayFlag::Sway`].
    pub fn is_sway(self) -> bool {
        self == SwayFlag::Sway
    }
}

/// What a detector made of the last frame's input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InputStatus {
    /// the sample was used
    Ok,
    /// the time is NaN or infinite, or the signal is NaN, infinite, beyond ±[`MAX_INPUT`]
    /// or not measured: the sample was ignored, the output is the previous one
    Invalid,
    /// the time `t` \[s\] is not later than the last used sample's `last_t` \[s\]: the
    /// sample was ignored, the output is the previous one
    OutOfOrder {
        /// the frame's time \[s\]
        t: f64,
        /// the last used sample's time \[s\]
        last_t: f64,
    },
    /// `dt_s` \[s\] since the last used sample, more than [`GAP_TOLERANCE`] periods: the
    /// detector restarted from this sample
    Gap {
        /// time since the last used sample \[s\]
        dt_s: f64,
    },
}

/// A detector's verdict after one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorOutput {
    /// what became of the frame's input
    pub status: InputStatus,
    /// sway or not: `score` ≥ the detector's [`Detector::threshold`]
    pub flag: SwayFlag,
    /// the continuous score the flag thresholds (units per detector)
    pub score: f64,
    /// the oscillation's amplitude in the band-passed signal \[signal unit\], where the
    /// detector has one
    pub amplitude: Option<f64>,
    /// the oscillation's (damped) frequency \[Hz\], where the detector estimates it
    pub frequency_hz: Option<f64>,
    /// the oscillation's damping ratio ζ (negative when it grows), where the detector
    /// estimates it
    pub damping_ratio: Option<f64>,
}

impl DetectorOutput {
    /// No sway, score `score`, no estimates.
    pub fn clear(score: f64) -> Self {
        DetectorOutput {
            status: InputStatus::Ok,
            flag: SwayFlag::Clear,
            score,
            amplitude: None,
            frequency_hz: None,
            damping_ratio: None,
        }
    }
}

/// The signal a detector reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Signal {
    /// the car's yaw rate \[rad/s\]: what every car with ESC measures (the default)
    #[default]
    YawRate,
    /// the car's lateral acceleration \[m/s²\]
    LateralAcceleration,
    /// the hitch angle \[rad\], when a hitch-angle sensor is fitted
    HitchAngle,
}

impl Signal {
    /// The signal's value in `m`; NaN when it is not measured.
    pub fn read(self, m: &Measurement) -> f64 {
        let channel = match self {
            Signal::YawRate => Channel::YawRate,
            Signal::LateralAcceleration => Channel::LateralAcceleration,
            Signal::HitchAngle => Channel::HitchAngle,
        };
        m.get(channel).unwrap_or(f64::NAN)
    }
}

/// The largest magnitude of a usable sample \[signal unit\]: far beyond any yaw rate,
/// acceleration or angle of a car, yet small enough that its squares stay finite in the
/// filters and fits.
pub const MAX_INPUT: f64 = 1e6;

/// A sample more than this many sample periods after the last used one is a gap: the
/// detector restarts. 1.5 accepts any jitter of up to half a period and catches one lost
/// frame.
pub const GAP_TOLERANCE: f64 = 1.5;

/// A detector's computation on clean, equally spaced samples: what the input check of
/// [`Guarded`] feeds.
trait Core {
    /// Back to the initial state, to start again from the sample `x`.
    fn restart(&mut self, x: f64);
    /// The verdict after the next sample `x` (its status [`InputStatus::Ok`]).
    fn step(&mut self, x: f64) -> DetectorOutput;
    /// The output before any sample.
    fn initial_output(&self) -> DetectorOutput;
}

/// The input check every detector shares: a [`Core`] behind the rules of the module docs.
#[derive(Debug, Clone)]
struct Guarded<C> {
    signal: Signal,
    period_s: f64,
    last_t: Option<f64>,
    last_output: DetectorOutput,
    core: C,
}

impl<C: Core> Guarded<C> {
    fn new(signal: Signal, sample_rate_hz: f64, core: C) -> Self {
        let last_output = core.initial_output();
        Guarded {
            signal,
            period_s: 1.0 / sample_rate_hz,
            last_t: None,
            last_output,
            core,
        }
    }

    fn update(&mut self, m: &Measurement) -> DetectorOutput {
        let (t, x) = (m.t, self.signal.read(m));
        if !(t.is_finite() && x.abs() <= MAX_INPUT) {
            return self.repeat(InputStatus::Invalid);
        }
        let status = match self.last_t {
            Some(last_t) if t <= last_t => {
                return self.repeat(InputStatus::OutOfOrder { t, last_t });
            }
            Some(last_t) if t - last_t > GAP_TOLERANCE * self.period_s => {
                self.core.restart(x);
                InputStatus::Gap { dt_s: t - last_t }
            }
            Some(_) => InputStatus::Ok,
            None => {
                self.core.restart(x);
                InputStatus::Ok
            }
        };
        self.last_t = Some(t);
        self.last_output = DetectorOutput {
            status,
            ..self.core.step(x)
        };
        self.last_output
    }

    fn repeat(&self, status: InputStatus) -> DetectorOutput {
        DetectorOutput {
            status,
            ..self.last_output
        }
    }

    fn reset(&mut self) {
        self.last_t = None;
        self.last_output = self.core.initial_output();
    }
}
