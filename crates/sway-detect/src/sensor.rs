//! The towing car's sensors: one model per signal, bundled as [`Sensors`].
//!
//! Each channel ([`Channel`]) turns the true value of its signal into what the controller
//! reads, in this order:
//!
//! 1. **sampling** at the channel's own rate on a fixed grid that starts at the first call;
//! 2. **bias**: a constant offset plus a random walk (σ per √s, stepped by the time since
//!    the channel's previous sample);
//! 3. **white noise** with standard deviation σ;
//! 4. **quantisation** to the nearest multiple of the step (the CAN signal's resolution);
//! 5. **latency**: the value read is the one sampled `latency_samples` samples earlier
//!    (a ring buffer of fixed capacity [`MAX_LATENCY_SAMPLES`]; before that many samples
//!    exist the first sample is repeated, as if the sensor had seen the initial value for
//!    a while).
//!
//! [`Sensors`] reads every channel once per controller frame ([`SensorsConfig::frame_rate_hz`]):
//! a channel slower than the frame rate is held between its samples (the controller reads
//! the latest message). Every channel draws from its own ChaCha8 stream of the seed, so
//! enabling the hitch-angle sensor, or changing one channel's noise, leaves the numbers of
//! the other channels unchanged. Nothing allocates after [`Sensors::new`].
//!
//! The steering signal is the **steering-wheel angle** (what the column's angle sensor
//! measures): a simulation of the paper's model passes its road-wheel angle δ times the
//! steering ratio (≈ 15–17 for passenger cars) as [`Truth::steering_wheel_angle`].

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, finite, non_negative, positive};

/// The longest latency a channel can be configured with \[samples\]: the capacity of its
/// delay buffer less one. 310 ms at 100 Hz, far beyond the 10–40 ms of production sensors.
pub const MAX_LATENCY_SAMPLES: usize = 31;

/// Relative tolerance on the sample grids: a call at t within 10⁻⁹ periods before a sample
/// time takes that sample (times summed from steps carry rounding errors).
const GRID_TOLERANCE: f64 = 1e-9;

/// The measured signals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// the car's yaw rate ψ̇ \[rad/s\] (ESC yaw-rate gyro)
    YawRate,
    /// the car's lateral acceleration \[m/s²\] (ESC accelerometer)
    LateralAcceleration,
    /// the steering-wheel angle \[rad\] (column angle sensor; road-wheel angle × steering ratio)
    SteeringWheelAngle,
    /// the car's speed from the wheel speeds \[m/s\]
    Speed,
    /// the hitch (articulation) angle θ \[rad\] (optional sensor at the coupling)
    HitchAngle,
}

impl Channel {
    /// Every channel, in the order of their random streams.
    pub const ALL: [Channel; 5] = [
        Channel::YawRate,
        Channel::LateralAcceleration,
        Channel::SteeringWheelAngle,
        Channel::Speed,
        Channel::HitchAngle,
    ];

    /// The channel's key in a sensor configuration (and in error messages).
    pub fn key(self) -> &'static str {
        match self {
            Channel::YawRate => "yaw_rate",
            Channel::LateralAcceleration => "lateral_acceleration",
            Channel::SteeringWheelAngle => "steering_wheel_angle",
            Channel::Speed => "speed",
            Channel::HitchAngle => "hitch_angle",
        }
    }

    /// The unit of the signal (and of its noise σ, bias and quantisation step).
    pub fn unit(self) -> &'static str {
        match self {
            Channel::YawRate => "rad/s",
            Channel::LateralAcceleration => "m/s^2",
            Channel::SteeringWheelAngle | Channel::HitchAngle => "rad",
            Channel::Speed => "m/s",
        }
    }

    /// The channel's random stream of the seed.
    fn stream(self) -> u64 {
        match self {
            Channel::YawRate => 0,
            Channel::LateralAcceleration => 1,
            Channel::SteeringWheelAngle => 2,
            Channel::Speed => 3,
            Channel::HitchAngle => 4,
        }
    }

    /// The default model of the channel: a production ESC sensor cluster (see the reasons
    /// on [`SensorSpec`]'s constructors).
    pub fn default_spec(self) -> SensorSpec {
        match self {
            Channel::YawRate => SensorSpec::yaw_rate(),
            Channel::LateralAcceleration => SensorSpec::lateral_acceleration(),
            Channel::SteeringWheelAngle => SensorSpec::steering_wheel_angle(),
            Channel::Speed => SensorSpec::speed(),
            Channel::HitchAngle => SensorSpec::hitch_angle(),
        }
    }
}

/// The model of one sensor channel. Values are in the channel's unit ([`Channel::unit`]).
/// Its defaults differ per channel ([`Channel::default_spec`]); a TOML table of a channel
/// overrides only the keys it names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SensorSpec {
    /// samples per second \[Hz\]; at most the frame rate
    pub sample_rate_hz: f64,
    /// delay from sampling to the controller's read \[samples of this channel\]
    pub latency_samples: usize,
    /// standard deviation of the white noise added to each sample \[unit\]
    pub noise_sd: f64,
    /// constant offset \[unit\]
    pub bias: f64,
    /// random-walk bias: standard deviation of its change over one second \[unit/√s\]
    pub bias_random_walk: f64,
    /// resolution of the transmitted signal \[unit\]; 0 for none
    pub quantisation_step: f64,
}

/// One degree \[rad\].
const DEG: f64 = std::f64::consts::PI / 180.0;

impl SensorSpec {
    /// The yaw-rate gyro of an ESC sensor cluster (automotive MEMS):
    /// - 100 Hz: ESC clusters send yaw rate and lateral acceleration every 10 ms on CAN;
    /// - 2 samples (20 ms): the sensor's internal low-pass (a few ms of group delay at its
    ///   15–30 Hz bandwidth) plus one CAN cycle to the controller, within the 10–20 ms
    ///   typical of the signal path;
    /// - σ = 0.1 °/s: a noise density of ≈ 0.014 °/s/√Hz over the 50 Hz Nyquist band, the
    ///   order of automotive ESC gyros;
    /// - bias 0.2 °/s: the offset left after the ESC's standstill and straight-driving
    ///   offset learning (raw offsets over temperature are ±1–2 °/s);
    /// - random walk 0.01 °/s/√s: ≈ 0.1 °/s of drift over 100 s, the order of automotive
    ///   gyros' bias instability under temperature transients;
    /// - step 0.01 °/s: a common CAN resolution of the yaw-rate signal.
    pub fn yaw_rate() -> Self {
        SensorSpec {
            sample_rate_hz: 100.0,
            latency_samples: 2,
            noise_sd: 0.1 * DEG,
            bias: 0.2 * DEG,
            bias_random_walk: 0.01 * DEG,
            quantisation_step: 0.01 * DEG,
        }
    }

    /// The lateral accelerometer of the same cluster:
    /// - 100 Hz and 2 samples (20 ms), as the yaw rate (same cluster, same message);
    /// - σ = 0.02 m/s²: a noise density of ≈ 250 µg/√Hz over 50 Hz (≈ 2 mg);
    /// - bias 0.05 m/s² (5 mg): the offset after mounting calibration (road bank and body
    ///   roll, which add a gravity component, are not modelled);
    /// - random walk 0.001 m/s²/√s: ≈ 1 mg of drift over 100 s;
    /// - step 0.01 m/s²: a common CAN resolution.
    pub fn lateral_acceleration() -> Self {
        SensorSpec {
            sample_rate_hz: 100.0,
            latency_samples: 2,
            noise_sd: 0.02,
            bias: 0.05,
            bias_random_walk: 0.001,
            quantisation_step: 0.01,
        }
    }

    /// The steering-wheel angle sensor on the column (absolute, magnetic or optical):
    /// - 100 Hz and 1 sample (10 ms): its message every 10 ms, little internal filtering;
    /// - σ = 0.05°: below its resolution (the encoder's jitter);
    /// - bias 1°: the straight-ahead offset before the ESC's zero-point learning (absolute
    ///   accuracy specs are ±2.5°);
    /// - no random walk: an absolute angle encoder does not drift;
    /// - step 0.1°: the usual CAN resolution of the steering angle.
    pub fn steering_wheel_angle() -> Self {
        SensorSpec {
            sample_rate_hz: 100.0,
            latency_samples: 1,
            noise_sd: 0.05 * DEG,
            bias: 1.0 * DEG,
            bias_random_walk: 0.0,
            quantisation_step: 0.1 * DEG,
        }
    }

    /// The speed from the wheel-speed sensors (the ESC's reference speed):
    /// - 50 Hz and 1 sample (20 ms): wheel speeds are averaged over the tone wheel's edges
    ///   and the reference speed is sent every 20 ms;
    /// - σ = 0.02 m/s: edge-timing jitter of a 48-tooth tone wheel after averaging;
    /// - no bias: the tyre radius error (1–2 %) is a scale error, not an offset, and is
    ///   not modelled; no random walk;
    /// - step 0.01 km/h: a common CAN resolution of vehicle speed.
    pub fn speed() -> Self {
        SensorSpec {
            sample_rate_hz: 50.0,
            latency_samples: 1,
            noise_sd: 0.02,
            bias: 0.0,
            bias_random_walk: 0.0,
            quantisation_step: 0.01 / 3.6,
        }
    }

    /// An optional hitch-angle sensor (a rotary sensor at the coupling, or a rear camera's
    /// estimate as trailer-manoeuvring assistants have):
    /// - 50 Hz and 2 samples (40 ms): a camera's frame rate and processing delay (a rotary
    ///   sensor is faster; this is the conservative case);
    /// - σ = 0.1°, step 0.1°: the resolution of such signals;
    /// - bias 0.5°: the mounting or calibration offset; no random walk.
    pub fn hitch_angle() -> Self {
        SensorSpec {
            sample_rate_hz: 50.0,
            latency_samples: 2,
            noise_sd: 0.1 * DEG,
            bias: 0.5 * DEG,
            bias_random_walk: 0.0,
            quantisation_step: 0.1 * DEG,
        }
    }

    /// A perfect sensor at `sample_rate_hz`: no latency, noise, bias or quantisation.
    pub fn ideal(sample_rate_hz: f64) -> Self {
        SensorSpec {
            sample_rate_hz,
            latency_samples: 0,
            noise_sd: 0.0,
            bias: 0.0,
            bias_random_walk: 0.0,
            quantisation_step: 0.0,
        }
    }

    /// Checks every value of the channel `channel` against the frame rate.
    pub fn validate(&self, channel: Channel, frame_rate_hz: f64) -> Result<(), ConfigError> {
        let key = |field: &str| format!("{}.{field}", channel.key());
        let rate = positive(key("sample_rate_hz"), self.sample_rate_hz)?;
        if rate > frame_rate_hz * (1.0 + GRID_TOLERANCE) {
            return Err(ConfigError::FasterThanFrame {
                channel: channel.key(),
                rate_hz: rate,
                frame_rate_hz,
            });
        }
        if self.latency_samples > MAX_LATENCY_SAMPLES {
            return Err(ConfigError::LatencyTooLong {
                channel: channel.key(),
                samples: self.latency_samples,
                max: MAX_LATENCY_SAMPLES,
            });
        }
        non_negative(key("noise_sd"), self.noise_sd)?;
        finite(key("bias"), self.bias)?;
        non_negative(key("bias_random_walk"), self.bias_random_walk)?;
        non_negative(key("quantisation_step"), self.quantisation_step)?;
        Ok(())
    }
}

/// The configuration of every sensor: the TOML form, every key optional (a channel's
/// missing keys take that channel's defaults). The hitch-angle sensor is fitted when its
/// table is present (`[hitch_angle]`, empty for the defaults).
///
/// ```toml
/// seed = 7
/// [yaw_rate]
/// noise_sd = 0.003      # rad/s; the rest as the default gyro
/// [hitch_angle]         # fitted, with the default hitch-angle sensor
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SensorsFile")]
pub struct SensorsConfig {
    /// seed of every channel's random stream
    pub seed: u64,
    /// the controller's cycle: how often it reads every channel \[Hz\] (100 Hz, a 10 ms
    /// ESC cycle); the detectors' sample rate
    pub frame_rate_hz: f64,
    /// the car's yaw rate \[rad/s\]
    pub yaw_rate: SensorSpec,
    /// the car's lateral acceleration \[m/s²\]
    pub lateral_acceleration: SensorSpec,
    /// the steering-wheel angle \[rad\]
    pub steering_wheel_angle: SensorSpec,
    /// the car's speed from the wheel speeds \[m/s\]
    pub speed: SensorSpec,
    /// the hitch angle \[rad\], when a sensor is fitted
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hitch_angle: Option<SensorSpec>,
}

impl Default for SensorsConfig {
    /// Seed 0, a 100 Hz frame, every channel's default, no hitch-angle sensor.
    fn default() -> Self {
        SensorsConfig {
            seed: 0,
            frame_rate_hz: 100.0,
            yaw_rate: SensorSpec::yaw_rate(),
            lateral_acceleration: SensorSpec::lateral_acceleration(),
            steering_wheel_angle: SensorSpec::steering_wheel_angle(),
            speed: SensorSpec::speed(),
            hitch_angle: None,
        }
    }
}

impl SensorsConfig {
    /// Every channel perfect at the frame rate (no latency, noise, bias or quantisation);
    /// the hitch-angle sensor fitted.
    pub fn ideal(frame_rate_hz: f64) -> Self {
        let ideal = SensorSpec::ideal(frame_rate_hz);
        SensorsConfig {
            seed: 0,
            frame_rate_hz,
            yaw_rate: ideal,
            lateral_acceleration: ideal,
            steering_wheel_angle: ideal,
            speed: ideal,
            hitch_angle: Some(ideal),
        }
    }

    /// The model of `channel`, `None` for a hitch-angle sensor that is not fitted.
    pub fn spec(&self, channel: Channel) -> Option<&SensorSpec> {
        match channel {
            Channel::YawRate => Some(&self.yaw_rate),
            Channel::LateralAcceleration => Some(&self.lateral_acceleration),
            Channel::SteeringWheelAngle => Some(&self.steering_wheel_angle),
            Channel::Speed => Some(&self.speed),
            Channel::HitchAngle => self.hitch_angle.as_ref(),
        }
    }

    /// Checks the frame rate and every fitted channel.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("frame_rate_hz", self.frame_rate_hz)?;
        for channel in Channel::ALL {
            if let Some(spec) = self.spec(channel) {
                spec.validate(channel, self.frame_rate_hz)?;
            }
        }
        Ok(())
    }
}

/// The TOML form of [`SensorsConfig`]: every key optional.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorsFile {
    seed: Option<u64>,
    frame_rate_hz: Option<f64>,
    yaw_rate: Option<SpecFile>,
    lateral_acceleration: Option<SpecFile>,
    steering_wheel_angle: Option<SpecFile>,
    speed: Option<SpecFile>,
    hitch_angle: Option<SpecFile>,
}

/// The TOML form of one channel's [`SensorSpec`]: the keys it names override the
/// channel's defaults.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    sample_rate_hz: Option<f64>,
    latency_samples: Option<usize>,
    noise_sd: Option<f64>,
    bias: Option<f64>,
    bias_random_walk: Option<f64>,
    quantisation_step: Option<f64>,
}

impl SpecFile {
    fn over(self, base: SensorSpec) -> SensorSpec {
        SensorSpec {
            sample_rate_hz: self.sample_rate_hz.unwrap_or(base.sample_rate_hz),
            latency_samples: self.latency_samples.unwrap_or(base.latency_samples),
            noise_sd: self.noise_sd.unwrap_or(base.noise_sd),
            bias: self.bias.unwrap_or(base.bias),
            bias_random_walk: self.bias_random_walk.unwrap_or(base.bias_random_walk),
            quantisation_step: self.quantisation_step.unwrap_or(base.quantisation_step),
        }
    }
}

impl TryFrom<SensorsFile> for SensorsConfig {
    type Error = ConfigError;

    fn try_from(file: SensorsFile) -> Result<Self, ConfigError> {
        let d = SensorsConfig::default();
        let spec = |f: Option<SpecFile>, c: Channel| f.unwrap_or_default().over(c.default_spec());
        let config = SensorsConfig {
            seed: file.seed.unwrap_or(d.seed),
            frame_rate_hz: file.frame_rate_hz.unwrap_or(d.frame_rate_hz),
            yaw_rate: spec(file.yaw_rate, Channel::YawRate),
            lateral_acceleration: spec(file.lateral_acceleration, Channel::LateralAcceleration),
            steering_wheel_angle: spec(file.steering_wheel_angle, Channel::SteeringWheelAngle),
            speed: spec(file.speed, Channel::Speed),
            hitch_angle: file
                .hitch_angle
                .map(|f| f.over(Channel::HitchAngle.default_spec())),
        };
        config.validate()?;
        Ok(config)
    }
}

/// The true values of the signals at one instant (from a simulation or a test signal).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Truth {
    /// the car's yaw rate ψ̇ \[rad/s\]
    pub yaw_rate: f64,
    /// the car's lateral acceleration \[m/s²\]
    pub lateral_acceleration: f64,
    /// the steering-wheel angle \[rad\] (road-wheel angle δ × steering ratio)
    pub steering_wheel_angle: f64,
    /// the car's speed \[m/s\]
    pub speed: f64,
    /// the hitch angle θ \[rad\] (read only when a hitch-angle sensor is fitted)
    pub hitch_angle: f64,
}

impl Truth {
    /// The true value of `channel`.
    pub fn get(&self, channel: Channel) -> f64 {
        match channel {
            Channel::YawRate => self.yaw_rate,
            Channel::LateralAcceleration => self.lateral_acceleration,
            Channel::SteeringWheelAngle => self.steering_wheel_angle,
            Channel::Speed => self.speed,
            Channel::HitchAngle => self.hitch_angle,
        }
    }
}

/// What the controller reads in one frame: every signal as its sensor delivers it. This
/// (and only this) is what a detector sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// the frame's time \[s\] (the controller's clock)
    pub t: f64,
    /// the car's yaw rate \[rad/s\]
    pub yaw_rate: f64,
    /// the car's lateral acceleration \[m/s²\]
    pub lateral_acceleration: f64,
    /// the steering-wheel angle \[rad\]
    pub steering_wheel_angle: f64,
    /// the car's speed \[m/s\]
    pub speed: f64,
    /// the hitch angle \[rad\]; `None` without a hitch-angle sensor
    pub hitch_angle: Option<f64>,
}

impl Measurement {
    /// A frame at `t` with nothing measured (every signal NaN, no hitch angle): the base of
    /// a recorded signal's frames, `Measurement { yaw_rate: r, ..Measurement::at(t) }`.
    pub fn at(t: f64) -> Self {
        Measurement {
            t,
            yaw_rate: f64::NAN,
            lateral_acceleration: f64::NAN,
            steering_wheel_angle: f64::NAN,
            speed: f64::NAN,
            hitch_angle: None,
        }
    }

    /// The value of `channel`; `None` for a hitch angle that is not measured.
    pub fn get(&self, channel: Channel) -> Option<f64> {
        match channel {
            Channel::YawRate => Some(self.yaw_rate),
            Channel::LateralAcceleration => Some(self.lateral_acceleration),
            Channel::SteeringWheelAngle => Some(self.steering_wheel_angle),
            Channel::Speed => Some(self.speed),
            Channel::HitchAngle => self.hitch_angle,
        }
    }
}

/// A fixed sample grid: t0 + k·period, its origin set by the first call.
#[derive(Debug, Clone, Copy)]
struct Grid {
    period_s: f64,
    origin: Option<f64>,
    next: f64,
}

impl Grid {
    fn new(rate_hz: f64) -> Self {
        Grid {
            period_s: 1.0 / rate_hz,
            origin: None,
            next: f64::NEG_INFINITY,
        }
    }

    /// Whether `t` reached the next point of the grid; if so, the grid moves past `t`.
    fn tick(&mut self, t: f64) -> bool {
        if t.is_nan() || t + GRID_TOLERANCE * self.period_s < self.next {
            return false; // not yet
        }
        let origin = *self.origin.get_or_insert(t);
        let k = ((t - origin) / self.period_s + GRID_TOLERANCE).floor() + 1.0;
        self.next = origin + k * self.period_s;
        true
    }

    fn restart(&mut self) {
        self.origin = None;
        self.next = f64::NEG_INFINITY;
    }
}

/// One sensor channel while it runs: its random stream, bias state and delay buffer.
#[derive(Debug, Clone)]
pub struct Sensor {
    channel: Channel,
    spec: SensorSpec,
    seed: u64,
    rng: ChaCha8Rng,
    grid: Grid,
    last_sample_t: Option<f64>,
    /// the random-walk part of the bias \[unit\]
    bias_walk: f64,
    /// the last `MAX_LATENCY_SAMPLES + 1` samples, `head` the newest
    delay: [f64; MAX_LATENCY_SAMPLES + 1],
    head: usize,
    output: f64,
}

impl Sensor {
    /// A channel with model `spec` reading within frames of `frame_rate_hz`, drawing from
    /// the channel's stream of `seed`.
    pub fn new(
        channel: Channel,
        spec: SensorSpec,
        frame_rate_hz: f64,
        seed: u64,
    ) -> Result<Self, ConfigError> {
        spec.validate(channel, frame_rate_hz)?;
        let mut sensor = Sensor {
            channel,
            spec,
            seed,
            rng: ChaCha8Rng::seed_from_u64(seed),
            grid: Grid::new(spec.sample_rate_hz),
            last_sample_t: None,
            bias_walk: 0.0,
            delay: [f64::NAN; MAX_LATENCY_SAMPLES + 1],
            head: 0,
            output: f64::NAN,
        };
        sensor.reset();
        Ok(sensor)
    }

    /// Back to the state of [`Sensor::new`]: the random stream from its start, no bias walk,
    /// an empty delay buffer, the grid's origin at the next call.
    pub fn reset(&mut self) {
        self.rng = ChaCha8Rng::seed_from_u64(self.seed);
        self.rng.set_stream(self.channel.stream());
        self.grid.restart();
        self.last_sample_t = None;
        self.bias_walk = 0.0;
        self.delay = [f64::NAN; MAX_LATENCY_SAMPLES + 1];
        self.head = 0;
        self.output = f64::NAN;
    }

    /// The value the controller reads at `t` when the signal's true value is `truth`: a new
    /// sample if `t` reached the channel's next sample time, else the value held since its
    /// last sample (NaN before the first call).
    pub fn read(&mut self, t: f64, truth: f64) -> f64 {
        if self.grid.tick(t) {
            let first = self.last_sample_t.is_none();
            let sample = self.measure(t, truth);
            self.push(sample, first);
        }
        self.output
    }

    /// The channel's current bias, constant plus random walk \[unit\].
    pub fn bias(&self) -> f64 {
        self.spec.bias + self.bias_walk
    }

    /// The channel's model.
    pub fn spec(&self) -> &SensorSpec {
        &self.spec
    }

    /// One sample at `t`: the bias steps its random walk, noise is added, the sum quantised.
    /// Two normal draws per sample whatever the configuration, so that the stream's use does
    /// not depend on which effects are switched on.
    fn measure(&mut self, t: f64, truth: f64) -> f64 {
        let walk = standard_normal(&mut self.rng);
        let noise = standard_normal(&mut self.rng);
        if let Some(last) = self.last_sample_t {
            self.bias_walk += self.spec.bias_random_walk * (t - last).max(0.0).sqrt() * walk;
        }
        self.last_sample_t = Some(t);
        let value = truth + self.bias() + self.spec.noise_sd * noise;
        quantise(value, self.spec.quantisation_step)
    }

    /// Puts `sample` into the delay buffer and reads the one `latency_samples` older; the
    /// `first` sample fills the whole buffer.
    fn push(&mut self, sample: f64, first: bool) {
        let n = self.delay.len();
        if first {
            self.delay = [sample; MAX_LATENCY_SAMPLES + 1];
        }
        self.head = (self.head + 1) % n;
        self.delay[self.head] = sample;
        self.output = self.delay[(self.head + n - self.spec.latency_samples) % n];
    }
}

/// `value` rounded to the nearest multiple of `step` (unchanged for step 0).
pub fn quantise(value: f64, step: f64) -> f64 {
    if step > 0.0 {
        (value / step).round() * step
    } else {
        value
    }
}

/// A standard normal number (Box–Muller, the cosine branch): `u1` in (0, 1] so that its
/// logarithm is finite.
fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1 = 1.0 - rng.random::<f64>();
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Every sensor of the car, read once per controller frame.
///
/// ```
/// use sway_detect::sensor::{Sensors, SensorsConfig, Truth};
/// let mut sensors = Sensors::new(&SensorsConfig::default()).unwrap();
/// let truth = Truth { yaw_rate: 0.05, speed: 25.0, ..Truth::default() };
/// let first = sensors.sample(0.0, &truth).unwrap(); // the first call is a frame
/// assert!(sensors.sample(0.004, &truth).is_none()); // within the 10 ms frame
/// let next = sensors.sample(0.01, &truth).unwrap();
/// assert_eq!(next.t, 0.01);
/// assert!((first.yaw_rate - 0.05).abs() < 0.02); // bias 0.0035 rad/s + noise
/// ```
#[derive(Debug, Clone)]
pub struct Sensors {
    frame: Grid,
    yaw_rate: Sensor,
    lateral_acceleration: Sensor,
    steering_wheel_angle: Sensor,
    speed: Sensor,
    hitch_angle: Option<Sensor>,
}

impl Sensors {
    /// The sensors of `config`, checked.
    pub fn new(config: &SensorsConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let sensor =
            |c: Channel, spec: SensorSpec| Sensor::new(c, spec, config.frame_rate_hz, config.seed);
        Ok(Sensors {
            frame: Grid::new(config.frame_rate_hz),
            yaw_rate: sensor(Channel::YawRate, config.yaw_rate)?,
            lateral_acceleration: sensor(
                Channel::LateralAcceleration,
                config.lateral_acceleration,
            )?,
            steering_wheel_angle: sensor(Channel::SteeringWheelAngle, config.steering_wheel_angle)?,
            speed: sensor(Channel::Speed, config.speed)?,
            hitch_angle: config
                .hitch_angle
                .map(|spec| sensor(Channel::HitchAngle, spec))
                .transpose()?,
        })
    }

    /// The frame the controller reads at `t` if `t` reached the next frame time (the first
    /// call always does), else `None`. Call it at [`Sensors::next_sample_time`] (or more
    /// often); a caller that skips frames produces a time gap, which the detectors report.
    /// A NaN `t` is never a frame.
    pub fn sample(&mut self, t: f64, truth: &Truth) -> Option<Measurement> {
        if !self.frame.tick(t) {
            return None;
        }
        Some(Measurement {
            t,
            yaw_rate: self.yaw_rate.read(t, truth.yaw_rate),
            lateral_acceleration: self
                .lateral_acceleration
                .read(t, truth.lateral_acceleration),
            steering_wheel_angle: self
                .steering_wheel_angle
                .read(t, truth.steering_wheel_angle),
            speed: self.speed.read(t, truth.speed),
            hitch_angle: self
                .hitch_angle
                .as_mut()
                .map(|s| s.read(t, truth.hitch_angle)),
        })
    }

    /// When the next frame is due \[s\]; `None` before the first call (any time is).
    pub fn next_sample_time(&self) -> Option<f64> {
        self.frame.origin.map(|_| self.frame.next)
    }

    /// The frame period \[s\]: the detectors' sample time.
    pub fn frame_period_s(&self) -> f64 {
        self.frame.period_s
    }

    /// The channel `channel`, `None` for a hitch-angle sensor that is not fitted.
    pub fn sensor(&self, channel: Channel) -> Option<&Sensor> {
        match channel {
            Channel::YawRate => Some(&self.yaw_rate),
            Channel::LateralAcceleration => Some(&self.lateral_acceleration),
            Channel::SteeringWheelAngle => Some(&self.steering_wheel_angle),
            Channel::Speed => Some(&self.speed),
            Channel::HitchAngle => self.hitch_angle.as_ref(),
        }
    }

    /// Back to the state of [`Sensors::new`] (same seed: the same numbers again).
    pub fn reset(&mut self) {
        self.frame.restart();
        for s in [
            &mut self.yaw_rate,
            &mut self.lateral_acceleration,
            &mut self.steering_wheel_angle,
            &mut self.speed,
        ] {
            s.reset();
        }
        if let Some(s) = self.hitch_angle.as_mut() {
            s.reset();
        }
    }
}
