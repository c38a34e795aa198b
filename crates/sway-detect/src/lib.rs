//! Trailer-sway detection from the towing car's own sensors.
//!
//! A trailer stability program sees the car's yaw rate \[rad/s\], lateral acceleration
//! \[m/s²\], steering-wheel angle \[rad\] and wheel-speed-derived speed \[m/s\] — noisy,
//! biased, sampled, quantised and late — and perhaps a hitch angle \[rad\]. This crate
//! models those sensors and the detectors that run on their samples:
//!
//! - [`sensor`]: one model per signal ([`sensor::SensorSpec`]: sample rate, latency, white
//!   noise, constant and random-walk bias, quantisation), bundled as [`sensor::Sensors`],
//!   which turns true values ([`sensor::Truth`]) into the frames a controller reads
//!   ([`sensor::Measurement`]); seeded, configured in TOML ([`sensor::SensorsConfig`]),
//!   defaults of a production ESC sensor cluster.
//! - [`filter`]: the sway band ([`filter::SwayBand`], 0.4–1.5 Hz) and its band-pass.
//! - [`detector`]: the [`detector::Detector`] trait (flag, score for ROC curves,
//!   frequency and damping estimates, a status for bad input) and its implementations
//!   [`detector::OscillationCounter`] (band-pass, amplitude threshold, consecutive
//!   half-oscillations: the production approach), [`detector::DampingEstimator`]
//!   (recursive least squares on a second-order autoregressive model: low or negative
//!   damping before the amplitude is large) and [`detector::ModelObserver`] (an extended
//!   Kalman filter on the car–trailer linear model, [`detector::observer::model`], that
//!   estimates the hitch angle and rate from the car's signals and the trailer's mass, yaw
//!   inertia and centre of gravity as augmented states, and from them the hitched
//!   trailer's critical speed V_crit: sway once the speed reaches it or the hitch angle
//!   oscillates freely beyond a threshold).
//!
//! It knows nothing of the simulation: a detector sees only sampled sensor values, never a
//! model's state, and runs as it could on a controller (no allocation per sample, fixed-size
//! state, `f64`). Bad configurations are a [`ConfigError`].
//!
//! ```
//! use sway_detect::detector::{
//!     CounterOptions, DampingEstimator, DampingOptions, Detector, OscillationCounter,
//! };
//! use sway_detect::sensor::{Sensors, SensorsConfig, Truth};
//!
//! let mut sensors = Sensors::new(&SensorsConfig::default())?;
//! let mut counter = OscillationCounter::new(CounterOptions::default())?;
//! let mut estimator = DampingEstimator::new(DampingOptions::default())?;
//! // sway growing at 0.7 Hz (ζ = −0.02) in the car's yaw rate, from 0.01 rad/s
//! let (f, zeta) = (0.7, -0.02);
//! let w = std::f64::consts::TAU * f;
//! let (mut counter_flag_at, mut estimator_flag_at) = (None, None);
//! for k in 0..2000 {
//!     let t = k as f64 * 0.01; // the 100 Hz frames
//!     let truth = Truth {
//!         yaw_rate: 0.01 * (-zeta * w * t).exp() * (w * t).sin(),
//!         speed: 25.0,
//!         ..Truth::default()
//!     };
//!     let Some(m) = sensors.sample(t, &truth) else { continue };
//!     if counter.update(&m).flag.is_sway() && counter_flag_at.is_none() {
//!         counter_flag_at = Some(t);
//!     }
//!     let out = estimator.update(&m);
//!     if out.flag.is_sway() && estimator_flag_at.is_none() {
//!         estimator_flag_at = Some(t);
//!         // it sees the growth: ζ < 0.03, at 0.7 Hz
//!         assert!(out.damping_ratio.unwrap() < 0.03);
//!         assert!((out.frequency_hz.unwrap() - f).abs() < 0.05);
//!     }
//! }
//! // the estimator flags the low damping while the amplitude is small, the counter once
//! // three half-oscillations exceed 0.02 rad/s
//! assert!(estimator_flag_at.unwrap() < counter_flag_at.unwrap());
//! # Ok::<(), sway_detect::ConfigError>(())
//! ```

pub mod detector;
mod error;
pub mod filter;
pub mod sensor;

pub use error::ConfigError;
