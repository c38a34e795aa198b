//! The model-based observer: an extended Kalman filter on its own car–trailer model with
//! brush tyres ([`model`]) that estimates the hitch angle and its rate from the car's own
//! signals and, as augmented states, the trailer's mass, yaw inertia and centre-of-gravity
//! distance; from them it predicts the hitched trailer's critical speed V_crit (that of the
//! model's linearisation, as the toolkit's).
//!
//! # What the observer knows, and what it assumes
//! - The towing car's parameters ([`CarParams`]): the ESC knows its car.
//! - The trailer's hitch → axle distance l and its axle's cornering stiffness C_T are
//!   **nominal values** of the options, not estimated. With them fixed, the car's yaw rate
//!   and lateral acceleration determine the trailer's mass m2, yaw inertia J2 and centre of
//!   gravity h: the hitch force the car feels is set by how the trailer's inertia
//!   (m2, J2 + m2 h², m2 h) answers its axle force C_T α_T, and α_T's lever is l. Were C_T and
//!   l free too, a trailer with a stiffer axle and more inertia could feel the same to the
//!   car (the parameters would not all be identifiable from two signals). An error in them
//!   is absorbed by wrong estimates of m2, J2 and h that reproduce the car's response as
//!   well as they can: the V_crit of the estimated model then carries the error (C_T too
//!   high by 10 % makes the trailer look better damped; the toolkit's sensitivities of
//!   V_crit to C_T and l say how much). The estimated parameters are those of an equivalent
//!   trailer with the nominal axle, not necessarily the true ones.
//! - The tyre–road friction (μ0, μ) of the brush tyres ([`ObserverOptions::friction`]): an
//!   ESC's friction estimate, by default the paper's dry road. It sets how far below the
//!   linear tyre the forces fall in hard driving (a lane change at 3 m/s² uses half the
//!   sliding friction: 17 % less force than the linear tyre); a linear model there explains
//!   the missing force by a wrong trailer (its V_crit was 10 % low on Table I).
//! - The lateral acceleration is measured at the car's centre of gravity C1.
//! - The steering-wheel angle divided by the steering ratio is the road-wheel angle δ.
//!
//! # Filter
//! Augmented state X = [v, r, θ, θ̇, m2, J2, h, b_r, b_a, b_δ]: the model's lateral
//! states ([`model`]), the three trailer parameters (random walks of small intensity: a
//! trailer's load does not change while driving) and the biases of the yaw-rate gyro, the
//! accelerometer and the steering (random walks: the sensors' offsets and drift, which
//! would otherwise read as a steady turn). The model is driven by the road-wheel angle
//! δ = δ_measured − b_δ. Measurements: y = [r + b_r, a_y + b_a], a_y = v̇ + V r. In steady
//! driving the three biases are seen through two equations, so by default b_δ is not
//! estimated (prior 0 ± 0, [`ObserverOptions::steering_bias_sd`]): b_r and b_a then absorb
//! most of a steering offset's steady effect (all of it in the linear range of the tyres).
//!
//! - **Prediction** over one frame h: the nonlinear model integrated by the classical
//!   Runge–Kutta method with the steering linear between its two samples (first-order
//!   hold), on as many equal substeps as keep ‖h_s A‖_∞ ≤ 0.5 for the linearisation A at
//!   zero slip (the brush tyre's slope is largest there, so the model is nowhere stiffer;
//!   it stiffens as 1/V at low speed; at highway speeds one substep).
//! - **Jacobians** exact: the same step evaluated in forward-mode dual numbers in eight
//!   directions — the four lateral states, the three trailer parameters (which move the
//!   mass matrix and, through the static axle loads, the tyres' saturation) and a steering
//!   offset held over the frame — gives the state-transition matrix, its parameter columns
//!   and the columns of the steering bias and noise at once; the lateral acceleration's
//!   row of the measurement Jacobian likewise.
//! - **Process noise**: the steering sensor's noise through the input column, a white
//!   lateral force on the trailer at C2 (gusts, road; [`ObserverOptions::trailer_force_psd`]),
//!   and the random walks of the parameters and biases.
//! - **Update** with both measurements at once, Joseph form; the parameters are then
//!   clamped to their bounds.
//! - The steering is delayed by [`ObserverOptions::steering_delay_samples`] frames to line
//!   it up with the yaw rate and lateral acceleration, which arrive later (the default
//!   sensors: 20 ms against 10 ms): the estimate refers to the time the gyro sampled.
//!
//! # Critical speed
//! Every [`ObserverOptions::v_crit_interval_samples`] frames, the model's linearisation with
//! the estimated parameters (the brush tyres' slope at zero slip is their cornering
//! stiffness, so friction and axle loads do not enter) gives V_crit by bisection on the
//! Hurwitz conditions of its characteristic polynomial
//! ([`model::LinearModel::critical_speed`]), and its standard deviation from the
//! parameters' covariance through the exact gradient of V_crit (implicit function theorem
//! on the failing Hurwitz condition). Its standard deviation covers the estimation's noise
//! (on its own model over 20 seeds the squared error over the variance averages 0.8), not
//! the error of the model itself: against the toolkit's simulation (the paper's
//! kinematics) the estimate's error is several standard deviations (the sway-assist
//! evaluation). A caller computes V_fold from [`ModelObserver::trailer_estimate`] with the
//! toolkit: the paper's model with brush tyres, the same tyre law as here (with the
//! vehicle's friction, which should be the one given to the observer).
//!
//! # Flag and score
//! Two conditions each make sway, both normalised so that 1 is their threshold, and the
//! **score** is the larger:
//! - the **speed ratio** V / V̂_crit, once the estimate is trusted (its standard deviation at
//!   most [`ObserverOptions::v_crit_trusted_rel_sd`] of it): at or beyond V_crit, straight
//!   running is unstable and any disturbance grows into sway;
//! - the **free hitch-angle amplitude** over its threshold
//!   ([`ObserverOptions::amplitude_threshold_rad`]): the amplitude √(θ_f² + (θ̇_f/ω)²) at the
//!   sway frequency ω (the Hopf frequency of the estimate; the sway band's centre before
//!   one) of the part of the estimated hitch angle that the driver's steering does not
//!   explain (the estimate minus the model's response to the steering alone, the nonlinear
//!   model's, so that a hard slalom's softer tyres are explained too). A slalom's forced
//!   hitch angle is explained by the steering and does not count; sway after a gust or
//!   beyond V_crit does, below V_crit too (the bistable range, where straight running is
//!   stable but a large disturbance sways the trailer). Where the model's own response to
//!   the steering grows beyond any hitch angle the model holds for (1.5 rad: steering that
//!   sways the model's trailer), it restarts from the estimate. The free part counts from when the
//!   model is trusted (the V_crit condition above, or straight running stable up to the
//!   search's highest speed): a model still being learned explains the steering badly
//!   (its first seconds), and what it misses is not sway.
//!
//! Before the model is trusted the score is 0: the observer flags nothing in the first
//! seconds of driving with a new trailer (1–20 s of slalom and lane changes in the tests).
//!
//! The observer **flags** when the score is at least 1 ([`Detector::threshold`]).
//!
//! # Input
//! Every frame needs the yaw rate, lateral acceleration, steering-wheel angle and speed: a
//! NaN, infinite or huge one is ignored ([`InputStatus::Invalid`]), an out-of-order time
//! too; after a gap of more than [`GAP_TOLERANCE`] frames the lateral states restart from
//! straight running while the learned parameters and biases are kept (the trailer did not
//! change). Below [`ObserverOptions::min_speed_mps`] the single-track model does not hold
//! (and the lateral states are at rest): the lateral states are held at rest, nothing is
//! learned, the score is 0.

//!
//! ```
//! use sway_detect::detector::observer::model::{
//!     CarParams, CriticalSpeedSearch, LinearModel, TrailerParams,
//! };
//! use sway_detect::detector::{Detector, ModelObserver, ObserverOptions};
//! use sway_detect::sensor::Measurement;
//!
//! // the observer's model of Table I loses stability where the toolkit's does
//! let table_i = LinearModel::new(CarParams::default(), TrailerParams::default())?;
//! let critical = table_i.critical_speed(&CriticalSpeedSearch::default()).unwrap();
//! assert!((critical.v_crit_mps - 34.748).abs() < 0.01);
//! assert!((critical.frequency_hz - 0.621).abs() < 0.001);
//!
//! // straight driving at 25 m/s: no sway, the hitch angle stays at 0
//! let mut observer = ModelObserver::new(ObserverOptions::default())?;
//! for k in 0..500 {
//!     let m = Measurement {
//!         yaw_rate: 0.0,
//!         lateral_acceleration: 0.0,
//!         steering_wheel_angle: 0.0,
//!         speed: 25.0,
//!         ..Measurement::at(k as f64 * 0.01)
//!     };
//!     assert!(!observer.update(&m).flag.is_sway());
//! }
//! let estimate = observer.estimate();
//! assert!(estimate.hitch_angle.abs() < 1e-9);
//! println!("V_crit {:?} ± {:?} m/s", estimate.v_crit_estimate_mps, estimate.v_crit_sd_mps);
//! # Ok::<(), sway_detect::ConfigError>(())
//! ```

pub(crate) mod dual;
pub mod model;

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

use self::dual::Dual;
use self::model::{
    CarParams, CriticalSpeed, CriticalSpeedSearch, Friction, NoCriticalSpeed, Plant, Trailer,
    TrailerParams, critical_speed, critical_speed_gradient, system,
};
use super::{Detector, DetectorOutput, GAP_TOLERANCE, InputStatus, MAX_INPUT, SwayFlag};
use crate::error::{ConfigError, in_range, non_negative, positive};
use crate::filter::SwayBand;
use crate::sensor::{MAX_LATENCY_SAMPLES, Measurement, SensorSpec};

/// The augmented state's dimension: 4 lateral states, 3 trailer parameters, 3 biases.
const N: usize = 10;
type MatN = SMatrix<f64, N, N>;
type VecN = SVector<f64, N>;

/// Index of the first trailer parameter (m2, J2, h) in the augmented state.
const PARAMS: usize = 4;
/// Index of the yaw-rate gyro's bias.
const YAW_BIAS: usize = 7;
/// Index of the accelerometer's bias.
const ACC_BIAS: usize = 8;
/// Index of the steering's bias (in road-wheel angle).
const STEER_BIAS: usize = 9;

/// The derivative directions of a frame's dual numbers: the lateral states [v, r, θ, θ̇]
/// (0–3), the trailer's parameters (m2, J2, h) (4–6) and a road-wheel angle offset held
/// over the frame (7).
const DIRECTIONS: usize = 8;
/// The direction of the steering offset.
const OFFSET: usize = 7;
type D8 = Dual<DIRECTIONS>;

/// The largest hitch angle of the steering's own response \[rad\]: 1.5 rad is far beyond
/// where the single-track model holds.
const MAX_FORCED_HITCH_ANGLE: f64 = 1.5;

/// The largest ‖h_s A‖_∞ of a substep: the truncated series' error per substep is then
/// below 0.5⁵/5! ≈ 3·10⁻⁴ of the state in the stiffest direction, and that direction is a
/// fast-decaying one (its error does not accumulate).
const MAX_STEP_NORM: f64 = 0.5;
/// The most substeps per frame; a model stiffer than this (speeds far below
/// [`ObserverOptions::min_speed_mps`]) is not predicted.
const MAX_SUBSTEPS: usize = 16;

/// The initial standard deviations of the lateral states [v, r, θ, θ̇]: the combination
/// starts from straight running, give or take 0.2 m/s of side slip velocity, 0.02 rad/s of
/// yaw rate, 0.02 rad (1.1°) of hitch angle and 0.05 rad/s of its rate — a lane change's
/// size, so that the first measurements correct a start during one.
const INITIAL_LATERAL_SD: [f64; 4] = [0.2, 0.02, 0.02, 0.05];

/// The standard deviation of a sensor's sample about its true value: its white noise and
/// its quantisation (uniform, step²/12).
fn sample_sd(spec: &SensorSpec) -> f64 {
    (spec.noise_sd.powi(2) + spec.quantisation_step.powi(2) / 12.0).sqrt()
}

/// A trailer parameter's prior, its random walk and its bounds (a TOML table of it names
/// every key).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterPrior {
    /// the initial estimate \[unit\]
    pub mean: f64,
    /// its standard deviation \[unit\]; 0 for a parameter known exactly
    pub sd: f64,
    /// the random walk's standard deviation of change over one second \[unit/√s\]
    pub random_walk: f64,
    /// the smallest physical value \[unit\]; the estimate is clamped to [min, max]
    pub min: f64,
    /// the largest physical value \[unit\]
    pub max: f64,
}

impl ParameterPrior {
    fn validate(&self, key: &'static str) -> Result<(), ConfigError> {
        positive(key, self.min)?;
        positive(key, self.max)?;
        if self.max <= self.min {
            return Err(ConfigError::Bounds {
                key,
                value: self.max,
                low: self.min,
                high: f64::INFINITY,
            });
        }
        if !(self.mean >= self.min && self.mean <= self.max) {
            return Err(ConfigError::Bounds {
                key,
                value: self.mean,
                low: self.min,
                high: self.max,
            });
        }
        non_negative(key, self.sd)?;
        non_negative(key, self.random_walk)?;
        Ok(())
    }
}

/// The options of a [`ModelObserver`]: the car, the trailer's nominal axle, the priors of
/// the estimated parameters, the sensors' noise, and the flag's thresholds. The defaults
/// fit Table I's car, a typical caravan as prior, and the crate's default sensors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObserverOptions {
    /// the rate frames arrive at \[Hz\]: the sensors' frame rate (100 Hz)
    pub sample_rate_hz: f64,
    /// the towing car, known to the observer (default Table I's car)
    pub car: CarParams,
    /// steering-wheel angle / road-wheel angle \[-\]. Default 16: passenger cars have
    /// 15–17; it must be the car's, as a simulation's sensors are fed δ times it
    pub steering_ratio: f64,
    /// the trailer's hitch → axle distance l \[m\], nominal (not estimated; see the module
    /// docs). Default 2.8 m, Table I's: a single-axle caravan's drawbar and half its box
    pub trailer_axle_m: f64,
    /// the trailer axle's cornering stiffness C_T \[N/rad\], nominal (not estimated).
    /// Default 50 kN/rad, Table I's
    pub trailer_cornering_stiffness: f64,
    /// the tyre–road friction the brush tyres of the observer's model have (μ0, μ). An ESC
    /// estimates the road's friction: give it here. Default the paper's dry road, 0.9 and
    /// 0.6; V_crit does not depend on it (the tyres' slope at zero slip is their cornering
    /// stiffness), the estimated parameters do, through the tyres' force in the driving
    pub friction: Friction,
    /// the trailer's mass m2 \[kg\]. Default 1300 ± 600 kg (a mid-size caravan; the prior
    /// covers 500–2500 kg within 2σ), walk 0.5 kg/√s (≈ 4 kg in a minute: a steady load),
    /// bounds [100, 4000] kg (a bicycle trailer to the heaviest car-towable trailers)
    pub mass: ParameterPrior,
    /// the trailer's yaw inertia J2 about its centre of gravity \[kg m²\]. Default
    /// 2000 ± 1200 kg m² (a caravan of 1300 kg with a radius of gyration ≈ 1.2 m; Table I has
    /// 1416 kg m² for 985 kg), walk 1 kg m²/√s, bounds [50, 20000] kg m²
    pub yaw_inertia: ParameterPrior,
    /// the trailer's hitch → centre of gravity distance h \[m\]. Default 2.5 ± 0.6 m, walk
    /// 0.001 m/√s, bounds [0.3, 4.5] m: the centre of gravity may lie behind the axle
    /// (Table I's h = 2.9 m behind l = 2.8 m, a lifting hitch), so the bound is not l
    pub cog: ParameterPrior,
    /// the yaw-rate sample's standard deviation \[rad/s\]. Default that of the default gyro
    /// (white noise and quantisation, ≈ 0.1 °/s)
    pub yaw_rate_noise_sd: f64,
    /// the lateral-acceleration sample's standard deviation \[m/s²\]. Default that of the
    /// default accelerometer (≈ 0.02 m/s²)
    pub lateral_acceleration_noise_sd: f64,
    /// the steering-wheel angle sample's standard deviation \[rad\], process noise through
    /// the input. Default that of the default sensor (≈ 0.06°)
    pub steering_noise_sd: f64,
    /// the power spectral density of a white lateral force on the trailer at its centre of
    /// gravity \[N² s\]: the process noise of gusts, road and what the model leaves out.
    /// Default
    /// (50 N)²·s: 50 N rms in a 1 Hz band, a few percent of the trailer axle's force in sway
    pub trailer_force_psd: f64,
    /// the gyro bias's prior standard deviation \[rad/s\]. Default 0.5 °/s: beyond the
    /// default sensor's 0.2 °/s offset after the ESC's learning
    pub yaw_rate_bias_sd: f64,
    /// the gyro bias's random walk \[rad/s/√s\]. Default the default gyro's, 0.01 °/s/√s
    pub yaw_rate_bias_random_walk: f64,
    /// the accelerometer bias's prior standard deviation \[m/s²\]. Default 0.1 m/s²: twice
    /// the default sensor's offset (road bank and roll add more)
    pub lateral_acceleration_bias_sd: f64,
    /// the accelerometer bias's random walk \[m/s²/√s\]. Default the default sensor's,
    /// 0.001 m/s²/√s
    pub lateral_acceleration_bias_random_walk: f64,
    /// the steering-wheel angle bias's prior standard deviation \[rad\]. Default 0: not
    /// estimated. Its steady effect is that of constant gyro and accelerometer offsets
    /// (which are estimated), leaving a hitch-angle offset of ≈ 10⁻³ rad at the default
    /// sensor's 1°; estimated as well (tried with 2°), the three biases are told apart only
    /// by transients, and in 2 of 20 seeds it drifted to 3° and pulled the trailer's
    /// parameters 5–10 % off, the hitch angle's error far outside its covariance
    pub steering_bias_sd: f64,
    /// the steering-wheel angle bias's random walk \[rad/√s\]. Default 0: an absolute
    /// angle encoder does not drift (the default sensor's)
    pub steering_bias_random_walk: f64,
    /// frames the steering is delayed by before use, to line it up with the yaw rate and
    /// lateral acceleration: their latency minus the steering sensor's. Default 1 (20 ms
    /// and 10 ms at the default sensors)
    pub steering_delay_samples: usize,
    /// below this speed \[m/s\] the observer rests (the single-track model with slip angles
    /// needs rolling wheels; at walking pace no trailer sways). Default 5 m/s
    pub min_speed_mps: f64,
    /// the critical-speed search
    pub v_crit_search: CriticalSpeedSearch,
    /// frames between two critical-speed searches. Default 10 (0.1 s): the parameters
    /// change slowly, a search costs ≈ 30 model evaluations
    pub v_crit_interval_samples: usize,
    /// the model is trusted (the speed ratio and the free amplitude count) once V_crit's
    /// standard deviation is at most this fraction of it. Default 0.02: well inside the 5 %
    /// the observer aims for, because the filter's covariance is optimistic in its first
    /// seconds (linearised about wrong parameters: 3 % of standard deviation for a 7 % error
    /// after 1.7 s in the tests); 2 % is reached after ≈ 5 s of slalom and lane changes
    pub v_crit_trusted_rel_sd: f64,
    /// the free hitch-angle amplitude that is sway \[rad\]. Default 0.035 rad (2°): beyond a
    /// gust's or a kerb's transient on a well-damped trailer (tenths of a degree to a
    /// degree) and ≈ 10 times the estimate's standard deviation with the default sensors,
    /// yet within the linear range of the trailer tyre, so sway is flagged while small
    pub amplitude_threshold_rad: f64,
}

impl Default for ObserverOptions {
    fn default() -> Self {
        let deg = std::f64::consts::PI / 180.0;
        ObserverOptions {
            sample_rate_hz: 100.0,
            car: CarParams::default(),
            steering_ratio: 16.0,
            trailer_axle_m: 2.8,
            trailer_cornering_stiffness: 50e3,
            friction: Friction::default(),
            mass: ParameterPrior {
                mean: 1300.0,
                sd: 600.0,
                random_walk: 0.5,
                min: 100.0,
                max: 4000.0,
            },
            yaw_inertia: ParameterPrior {
                mean: 2000.0,
                sd: 1200.0,
                random_walk: 1.0,
                min: 50.0,
                max: 20000.0,
            },
            cog: ParameterPrior {
                mean: 2.5,
                sd: 0.6,
                random_walk: 0.001,
                min: 0.3,
                max: 4.5,
            },
            yaw_rate_noise_sd: sample_sd(&SensorSpec::yaw_rate()),
            lateral_acceleration_noise_sd: sample_sd(&SensorSpec::lateral_acceleration()),
            steering_noise_sd: sample_sd(&SensorSpec::steering_wheel_angle()),
            trailer_force_psd: 50.0 * 50.0,
            yaw_rate_bias_sd: 0.5 * deg,
            yaw_rate_bias_random_walk: SensorSpec::yaw_rate().bias_random_walk,
            lateral_acceleration_bias_sd: 0.1,
            lateral_acceleration_bias_random_walk: SensorSpec::lateral_acceleration()
                .bias_random_walk,
            steering_bias_sd: 0.0,
            steering_bias_random_walk: SensorSpec::steering_wheel_angle().bias_random_walk,
            steering_delay_samples: 1,
            min_speed_mps: 5.0,
            v_crit_search: CriticalSpeedSearch::default(),
            v_crit_interval_samples: 10,
            v_crit_trusted_rel_sd: 0.02,
            amplitude_threshold_rad: 2.0 * deg,
        }
    }
}

impl ObserverOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("sample_rate_hz", self.sample_rate_hz)?;
        self.car.validate()?;
        positive("steering_ratio", self.steering_ratio)?;
        positive("trailer_axle_m", self.trailer_axle_m)?;
        positive(
            "trailer_cornering_stiffness",
            self.trailer_cornering_stiffness,
        )?;
        self.friction.validate()?;
        self.mass.validate("mass")?;
        self.yaw_inertia.validate("yaw_inertia")?;
        self.cog.validate("cog")?;
        positive("yaw_rate_noise_sd", self.yaw_rate_noise_sd)?;
        positive(
            "lateral_acceleration_noise_sd",
            self.lateral_acceleration_noise_sd,
        )?;
        non_negative("steering_noise_sd", self.steering_noise_sd)?;
        non_negative("trailer_force_psd", self.trailer_force_psd)?;
        non_negative("yaw_rate_bias_sd", self.yaw_rate_bias_sd)?;
        non_negative("yaw_rate_bias_random_walk", self.yaw_rate_bias_random_walk)?;
        non_negative(
            "lateral_acceleration_bias_sd",
            self.lateral_acceleration_bias_sd,
        )?;
        non_negative(
            "lateral_acceleration_bias_random_walk",
            self.lateral_acceleration_bias_random_walk,
        )?;
        non_negative("steering_bias_sd", self.steering_bias_sd)?;
        non_negative("steering_bias_random_walk", self.steering_bias_random_walk)?;
        in_range(
            "steering_delay_samples",
            self.steering_delay_samples,
            0,
            MAX_LATENCY_SAMPLES,
        )?;
        positive("min_speed_mps", self.min_speed_mps)?;
        self.v_crit_search.validate()?;
        in_range(
            "v_crit_interval_samples",
            self.v_crit_interval_samples,
            1,
            usize::MAX,
        )?;
        positive("v_crit_trusted_rel_sd", self.v_crit_trusted_rel_sd)?;
        positive("amplitude_threshold_rad", self.amplitude_threshold_rad)?;
        Ok(())
    }

    /// The priors of (m2, J2, h) in the augmented state's order.
    fn priors(&self) -> [ParameterPrior; 3] {
        [self.mass, self.yaw_inertia, self.cog]
    }
}

/// An estimated parameter and its standard deviation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ParameterEstimate {
    /// the estimate \[unit\]
    pub value: f64,
    /// its standard deviation \[unit\]
    pub sd: f64,
}

/// What the observer estimates after the last frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObserverEstimate {
    /// the speed of the last used frame \[m/s\]
    pub speed_mps: f64,
    /// the hitch angle θ \[rad\]
    pub hitch_angle: f64,
    /// its variance \[rad²\]
    pub hitch_angle_variance: f64,
    /// the hitch angle's rate θ̇ \[rad/s\]
    pub hitch_rate: f64,
    /// its variance \[rad²/s²\]
    pub hitch_rate_variance: f64,
    /// the covariance of the hitch angle and its rate \[rad²/s\]
    pub hitch_covariance: f64,
    /// the car's yaw rate, without the gyro's bias \[rad/s\]
    pub yaw_rate: f64,
    /// the lateral velocity of the car's centre of gravity \[m/s\]
    pub lateral_velocity: f64,
    /// the trailer's mass m2 \[kg\]
    pub trailer_mass: ParameterEstimate,
    /// the trailer's yaw inertia J2 \[kg m²\]
    pub trailer_yaw_inertia: ParameterEstimate,
    /// the trailer's hitch → centre of gravity distance h \[m\]
    pub trailer_cog: ParameterEstimate,
    /// the gyro's bias \[rad/s\]
    pub yaw_rate_bias: ParameterEstimate,
    /// the accelerometer's bias \[m/s²\]
    pub lateral_acceleration_bias: ParameterEstimate,
    /// the steering-wheel angle sensor's bias \[rad of steering-wheel angle\]
    pub steering_bias: ParameterEstimate,
    /// V_crit of the estimated model's linearisation \[m/s\]; `None` with the reason in
    /// `v_crit_reason`
    pub v_crit_estimate_mps: Option<f64>,
    /// V_crit's standard deviation \[m/s\] (from the parameters' covariance)
    pub v_crit_sd_mps: Option<f64>,
    /// why there is no V_crit estimate
    pub v_crit_reason: Option<NoCriticalSpeed>,
    /// the sway frequency at V_crit \[Hz\] (the Hopf crossing's)
    pub sway_frequency_hz: Option<f64>,
    /// the amplitude of the hitch angle's free oscillation \[rad\] (module docs)
    pub free_amplitude_rad: f64,
}

impl ObserverEstimate {
    /// V_crit − V \[m/s\]: positive while straight running is stable ("sway needs a large
    /// disturbance from here on" below V_crit; the fold V_fold below it is the caller's).
    pub fn margin_mps(&self) -> Option<f64> {
        self.v_crit_estimate_mps.map(|v| v - self.speed_mps)
    }

    /// (V_crit − V)/V_crit \[-\].
    pub fn margin_relative(&self) -> Option<f64> {
        self.v_crit_estimate_mps.map(|v| (v - self.speed_mps) / v)
    }
}

/// The model-based observer (module docs): an extended Kalman filter on the car–trailer
/// model with brush tyres with the trailer's mass, yaw inertia and centre of gravity as augmented
/// states, and the V_crit they give.
#[derive(Debug, Clone)]
pub struct ModelObserver {
    options: ObserverOptions,
    trailer_axle: f64,
    period_s: f64,
    /// the initial covariance's diagonal
    initial_variance: [f64; N],
    /// the process noise's diagonal per frame (parameters and biases)
    walk_variance: [f64; N],
    /// the free-amplitude's frequency before any V_crit estimate \[rad/s\]
    fallback_omega: f64,
    x: VecN,
    p: MatN,
    /// the model's response to the steering alone [v, r, θ, θ̇]
    forced: [f64; 4],
    /// the last road-wheel angles, newest at `head`
    steering: [f64; MAX_LATENCY_SAMPLES + 1],
    head: usize,
    /// the aligned road-wheel angle of the last used frame (`None` at a (re)start)
    last_steering: Option<f64>,
    last_t: Option<f64>,
    speed: f64,
    samples: usize,
    v_crit: Result<CriticalSpeed, NoCriticalSpeed>,
    v_crit_sd: f64,
    free_amplitude: f64,
    last_output: DetectorOutput,
}

impl ModelObserver {
    /// An observer with `options`, checked.
    pub fn new(options: ObserverOptions) -> Result<Self, ConfigError> {
        options.validate()?;
        let period_s = 1.0 / options.sample_rate_hz;
        let priors = options.priors();
        let mut initial_variance = [0.0; N];
        let mut walk_variance = [0.0; N];
        for i in 0..4 {
            initial_variance[i] = INITIAL_LATERAL_SD[i].powi(2);
        }
        for (j, prior) in priors.iter().enumerate() {
            initial_variance[PARAMS + j] = prior.sd.powi(2);
            walk_variance[PARAMS + j] = prior.random_walk.powi(2) * period_s;
        }
        initial_variance[YAW_BIAS] = options.yaw_rate_bias_sd.powi(2);
        initial_variance[ACC_BIAS] = options.lateral_acceleration_bias_sd.powi(2);
        walk_variance[YAW_BIAS] = options.yaw_rate_bias_random_walk.powi(2) * period_s;
        walk_variance[ACC_BIAS] = options.lateral_acceleration_bias_random_walk.powi(2) * period_s;
        let ratio = options.steering_ratio;
        initial_variance[STEER_BIAS] = (options.steering_bias_sd / ratio).powi(2);
        walk_variance[STEER_BIAS] = (options.steering_bias_random_walk / ratio).powi(2) * period_s;
        let band = SwayBand::default();
        let mut observer = ModelObserver {
            options,
            trailer_axle: options.trailer_axle_m,
            period_s,
            initial_variance,
            walk_variance,
            fallback_omega: std::f64::consts::TAU * (band.low_hz * band.high_hz).sqrt(),
            x: VecN::zeros(),
            p: MatN::zeros(),
            forced: [0.0; 4],
            steering: [0.0; MAX_LATENCY_SAMPLES + 1],
            head: 0,
            last_steering: None,
            last_t: None,
            speed: 0.0,
            samples: 0,
            v_crit: Err(NoCriticalSpeed::NotComputed),
            v_crit_sd: f64::NAN,
            free_amplitude: 0.0,
            last_output: DetectorOutput::clear(0.0),
        };
        observer.reset();
        Ok(observer)
    }

    /// The observer's options.
    pub fn options(&self) -> &ObserverOptions {
        &self.options
    }

    /// The trailer of the estimated parameters with the nominal axle and stiffness: the
    /// vehicle the caller computes V_fold (or anything else) of with the toolkit.
    pub fn trailer_estimate(&self) -> TrailerParams {
        TrailerParams {
            mass: self.x[PARAMS],
            yaw_inertia: self.x[PARAMS + 1],
            cog: self.x[PARAMS + 2],
            axle: self.trailer_axle,
            cornering_stiffness: self.options.trailer_cornering_stiffness,
        }
    }

    /// The estimate after the last used frame.
    pub fn estimate(&self) -> ObserverEstimate {
        let est = |i: usize| ParameterEstimate {
            value: self.x[i],
            sd: self.p[(i, i)].max(0.0).sqrt(),
        };
        let (v_crit, sd, reason, frequency) = match self.v_crit {
            Ok(c) => (
                Some(c.v_crit_mps),
                Some(self.v_crit_sd),
                None,
                (c.frequency_hz > 0.0).then_some(c.frequency_hz),
            ),
            Err(e) => (None, None, Some(e), None),
        };
        ObserverEstimate {
            speed_mps: self.speed,
            hitch_angle: self.x[2],
            hitch_angle_variance: self.p[(2, 2)],
            hitch_rate: self.x[3],
            hitch_rate_variance: self.p[(3, 3)],
            hitch_covariance: self.p[(2, 3)],
            yaw_rate: self.x[1],
            lateral_velocity: self.x[0],
            trailer_mass: est(PARAMS),
            trailer_yaw_inertia: est(PARAMS + 1),
            trailer_cog: est(PARAMS + 2),
            yaw_rate_bias: est(YAW_BIAS),
            lateral_acceleration_bias: est(ACC_BIAS),
            steering_bias: ParameterEstimate {
                value: self.x[STEER_BIAS] * self.options.steering_ratio,
                sd: self.p[(STEER_BIAS, STEER_BIAS)].max(0.0).sqrt() * self.options.steering_ratio,
            },
            v_crit_estimate_mps: v_crit,
            v_crit_sd_mps: sd,
            v_crit_reason: reason,
            sway_frequency_hz: frequency,
            free_amplitude_rad: self.free_amplitude,
        }
    }

    /// The trailer of the current estimate in the frame's dual numbers (directions 4–6).
    fn dual_trailer(&self) -> Trailer<D8> {
        Trailer {
            mass: Dual::variable(self.x[PARAMS], PARAMS),
            yaw_inertia: Dual::variable(self.x[PARAMS + 1], PARAMS + 1),
            cog: Dual::variable(self.x[PARAMS + 2], PARAMS + 2),
            axle: self.trailer_axle,
            cornering_stiffness: self.options.trailer_cornering_stiffness,
        }
    }

    /// The lateral states in the frame's dual numbers (directions 0–3).
    fn dual_state(&self) -> [D8; 4] {
        std::array::from_fn(|i| Dual::variable(self.x[i], i))
    }

    fn plain_trailer(&self) -> Trailer<f64> {
        let t = self.trailer_estimate();
        Trailer {
            mass: t.mass,
            yaw_inertia: t.yaw_inertia,
            cog: t.cog,
            axle: t.axle,
            cornering_stiffness: t.cornering_stiffness,
        }
    }

    /// The lateral states back to straight running with their initial covariance (and no
    /// correlation with the kept parameters and biases).
    fn restart_lateral(&mut self) {
        for i in 0..4 {
            self.x[i] = 0.0;
            for j in 0..N {
                self.p[(i, j)] = 0.0;
                self.p[(j, i)] = 0.0;
            }
            self.p[(i, i)] = self.initial_variance[i];
        }
        self.forced = [0.0; 4];
        self.last_steering = None;
        self.free_amplitude = 0.0;
    }

    /// Everything back to the priors.
    fn restart_all(&mut self) {
        self.x = VecN::zeros();
        for (j, prior) in self.options.priors().iter().enumerate() {
            self.x[PARAMS + j] = prior.mean;
        }
        self.p = MatN::from_diagonal(&VecN::from(self.initial_variance));
        self.restart_lateral();
        self.samples = 0;
        self.v_crit = Err(NoCriticalSpeed::NotComputed);
        self.v_crit_sd = f64::NAN;
    }

    /// Pushes the road-wheel angle `delta` and returns the one
    /// [`ObserverOptions::steering_delay_samples`] frames older (the oldest at a (re)start).
    fn aligned_steering(&mut self, delta: f64, first: bool) -> f64 {
        let n = self.steering.len();
        if first {
            self.steering = [delta; MAX_LATENCY_SAMPLES + 1];
        }
        self.head = (self.head + 1) % n;
        self.steering[self.head] = delta;
        self.steering[(self.head + n - self.options.steering_delay_samples) % n]
    }

    /// The prediction over one frame from the steering `u0` to `u1` on `plant` (the model
    /// of the current estimate in the frame's dual numbers; `plain` the same in numbers);
    /// `false` when the model is too stiff at this speed to be predicted.
    fn predict(&mut self, plant: &Plant<D8>, plain: &Plant<f64>, u0: f64, u1: f64) -> bool {
        let h = self.period_s;
        // the substeps by the linearisation at zero slip: the brush tyre's slope is largest
        // there (C, falling to 0 at full sliding), so the model is nowhere stiffer
        let linear = system(&self.options.car, &self.plain_trailer(), self.speed);
        let norm = linear
            .a
            .iter()
            .map(|row| row.iter().map(|a| a.abs()).sum::<f64>())
            .fold(0.0, f64::max)
            * h;
        if !norm.is_finite() {
            return false;
        }
        let substeps = (norm / MAX_STEP_NORM).ceil().max(1.0) as usize;
        if substeps > MAX_SUBSTEPS {
            return false;
        }
        let offset = Dual::variable(0.0, OFFSET);
        let next = plant.step(
            &self.dual_state(),
            Dual::from(u0) + offset,
            Dual::from(u1) + offset,
            h,
            substeps,
        );
        // the model's response to the steering alone (module docs); where the model's own
        // response sways without bound (its small-angle kinematics beyond the fold),
        // it restarts from the estimate, whose free part is then counted again from zero
        self.forced = plain.step(&self.forced, u0, u1, h, substeps);
        if !(self.forced.iter().all(|x| x.is_finite())
            && self.forced[2].abs() <= MAX_FORCED_HITCH_ANGLE)
        {
            self.forced.copy_from_slice(&next.map(|x| x.re));
        }
        // the transition's Jacobian from the duals: ∂/∂(v, r, θ, θ̇), ∂/∂(m2, J2, h), and
        // the column of a steering offset held over the frame (δ = δ_measured − b_δ; the
        // sensitivity to the steering noise too)
        let steering_column: [f64; 4] = std::array::from_fn(|i| next[i].eps[OFFSET]);
        let mut f = MatN::identity();
        for i in 0..4 {
            self.x[i] = next[i].re;
            for j in 0..4 {
                f[(i, j)] = next[i].eps[j];
            }
            for j in 0..3 {
                f[(i, PARAMS + j)] = next[i].eps[PARAMS + j];
            }
            f[(i, STEER_BIAS)] = -steering_column[i];
        }
        let mut q = MatN::from_diagonal(&VecN::from(self.walk_variance));
        let steering_variance =
            (self.options.steering_noise_sd / self.options.steering_ratio).powi(2);
        let force = self.options.trailer_force_psd * h;
        let g = plain.trailer_force_column();
        for i in 0..4 {
            for j in 0..4 {
                q[(i, j)] += steering_column[i] * steering_column[j] * steering_variance
                    + g[i] * g[j] * force;
            }
        }
        self.p = f * self.p * f.transpose() + q;
        true
    }

    /// The update with the yaw rate `r` \[rad/s\] and lateral acceleration `a_y` \[m/s²\] at
    /// road-wheel angle `delta` \[rad\] on `plant` (as in [`Self::predict`]).
    fn correct(&mut self, plant: &Plant<D8>, r: f64, a_y: f64, delta: f64) {
        // a_y = v̇ + V r of the model, with its derivatives in every direction
        let delta = Dual::from(delta - self.x[STEER_BIAS]) + Dual::variable(0.0, OFFSET);
        let acc = plant.lateral_acceleration(&self.dual_state(), delta);
        let predicted = [self.x[1] + self.x[YAW_BIAS], acc.re + self.x[ACC_BIAS]];
        let mut h = SMatrix::<f64, 2, N>::zeros();
        h[(0, 1)] = 1.0;
        h[(0, YAW_BIAS)] = 1.0;
        for j in 0..4 {
            h[(1, j)] = acc.eps[j];
        }
        for j in 0..3 {
            h[(1, PARAMS + j)] = acc.eps[PARAMS + j];
        }
        h[(1, ACC_BIAS)] = 1.0;
        h[(1, STEER_BIAS)] = -acc.eps[OFFSET];
        let r_cov = SMatrix::<f64, 2, 2>::new(
            self.options.yaw_rate_noise_sd.powi(2),
            0.0,
            0.0,
            self.options.lateral_acceleration_noise_sd.powi(2),
        );
        let ph = self.p * h.transpose();
        let s = h * ph + r_cov;
        let Some(s_inv) = s.try_inverse() else {
            return;
        };
        let gain = ph * s_inv;
        let innovation = SVector::<f64, 2>::new(r - predicted[0], a_y - predicted[1]);
        self.x += gain * innovation;
        let i_kh = MatN::identity() - gain * h;
        self.p = i_kh * self.p * i_kh.transpose() + gain * r_cov * gain.transpose();
        self.p = 0.5 * (self.p + self.p.transpose());
        for (j, prior) in self.options.priors().iter().enumerate() {
            self.x[PARAMS + j] = self.x[PARAMS + j].clamp(prior.min, prior.max);
        }
    }

    /// The critical speed of the current estimate and its standard deviation.
    fn update_v_crit(&mut self) {
        let trailer = self.plain_trailer();
        let hint = self.v_crit.ok().map(|c| c.v_crit_mps);
        self.v_crit = critical_speed(
            &self.options.car,
            &trailer,
            &self.options.v_crit_search,
            hint,
        );
        self.v_crit_sd = match &self.v_crit {
            Ok(c) => {
                let g = critical_speed_gradient(&self.options.car, &trailer, c);
                let mut variance = 0.0;
                for i in 0..3 {
                    for j in 0..3 {
                        variance += g[i] * self.p[(PARAMS + i, PARAMS + j)] * g[j];
                    }
                }
                variance.max(0.0).sqrt()
            }
            Err(_) => f64::NAN,
        };
    }

    /// The score and output after a used frame.
    fn output(&mut self, status: InputStatus) -> DetectorOutput {
        let omega = match self.v_crit {
            Ok(c) if c.frequency_hz > 0.0 => std::f64::consts::TAU * c.frequency_hz,
            _ => self.fallback_omega,
        };
        let trusted = match self.v_crit {
            Ok(c) => self.v_crit_sd <= self.options.v_crit_trusted_rel_sd * c.v_crit_mps,
            Err(NoCriticalSpeed::StableUpTo { .. }) => true,
            Err(_) => false,
        };
        if !trusted {
            // a model still being learned explains the steering badly: what it does not
            // explain is not yet free oscillation, which counts from when it is trusted
            self.forced.copy_from_slice(&self.x.as_slice()[..4]);
        }
        let (theta, rate) = (self.x[2] - self.forced[2], self.x[3] - self.forced[3]);
        self.free_amplitude = theta.hypot(rate / omega);
        let amplitude_ratio = self.free_amplitude / self.options.amplitude_threshold_rad;
        let speed_ratio = match self.v_crit {
            Ok(c) if trusted => self.speed / c.v_crit_mps,
            _ => 0.0,
        };
        let score = amplitude_ratio.max(speed_ratio);
        DetectorOutput {
            status,
            flag: SwayFlag::from_score(score, 1.0),
            score,
            amplitude: Some(self.free_amplitude),
            frequency_hz: Some(omega / std::f64::consts::TAU),
            damping_ratio: None,
        }
    }

    fn repeat(&self, status: InputStatus) -> DetectorOutput {
        DetectorOutput {
            status,
            ..self.last_output
        }
    }
}

impl Detector for ModelObserver {
    fn update(&mut self, m: &Measurement) -> DetectorOutput {
        let usable = |x: f64| x.abs() <= MAX_INPUT; // false for NaN
        if !(m.t.is_finite()
            && usable(m.yaw_rate)
            && usable(m.lateral_acceleration)
            && usable(m.steering_wheel_angle)
            && usable(m.speed))
        {
            return self.repeat(InputStatus::Invalid);
        }
        let status = match self.last_t {
            Some(last_t) if m.t <= last_t => {
                return self.repeat(InputStatus::OutOfOrder { t: m.t, last_t });
            }
            Some(last_t) if m.t - last_t > GAP_TOLERANCE * self.period_s => {
                self.restart_lateral();
                InputStatus::Gap { dt_s: m.t - last_t }
            }
            _ => InputStatus::Ok,
        };
        self.last_t = Some(m.t);
        self.speed = m.speed;
        let first = self.last_steering.is_none();
        let delta =
            self.aligned_steering(m.steering_wheel_angle / self.options.steering_ratio, first);
        if m.speed < self.options.min_speed_mps {
            self.restart_lateral();
            self.last_output = DetectorOutput {
                status,
                amplitude: Some(0.0),
                ..DetectorOutput::clear(0.0)
            };
            return self.last_output;
        }
        let (car, friction) = (&self.options.car, &self.options.friction);
        let plant = Plant::new(car, &self.dual_trailer(), friction, m.speed);
        let plain = Plant::new(car, &self.plain_trailer(), friction, m.speed);
        let bias = self.x[STEER_BIAS];
        if let Some(u0) = self.last_steering
            && !self.predict(&plant, &plain, u0 - bias, delta - bias)
        {
            self.restart_lateral();
        }
        self.correct(&plant, m.yaw_rate, m.lateral_acceleration, delta);
        self.last_steering = Some(delta);
        if !(self.x.iter().all(|v| v.is_finite()) && self.p.iter().all(|v| v.is_finite())) {
            // a numerical failure (never seen with physical inputs): start again
            self.restart_all();
        }
        if self
            .samples
            .is_multiple_of(self.options.v_crit_interval_samples)
        {
            self.update_v_crit();
        }
        self.samples = self.samples.wrapping_add(1);
        self.last_output = self.output(status);
        self.last_output
    }

    fn reset(&mut self) {
        self.restart_all();
        self.last_t = None;
        self.speed = 0.0;
        self.last_output = DetectorOutput::clear(0.0);
    }

    fn name(&self) -> &'static str {
        "model_observer"
    }

    fn threshold(&self) -> f64 {
        1.0
    }
}
