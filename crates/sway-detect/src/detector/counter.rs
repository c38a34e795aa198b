//! The oscillation counter: the production approach to trailer-sway detection.

use serde::{Deserialize, Serialize};

use super::{Core, Detector, DetectorOutput, Guarded, Signal, SwayFlag};
use crate::error::{ConfigError, in_range, non_negative, positive};
use crate::filter::{BandPass, SwayBand};
use crate::sensor::Measurement;

/// The most half-oscillations the counter can be asked to count (its buffer's size).
pub const MAX_HALF_OSCILLATIONS: usize = 16;

/// The options of an [`OscillationCounter`]. Amplitudes are in the signal's unit (rad/s
/// for the default yaw rate).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CounterOptions {
    /// the signal counted (the car's yaw rate)
    pub signal: Signal,
    /// the rate frames arrive at \[Hz\]: the sensors' frame rate (100 Hz)
    pub sample_rate_hz: f64,
    /// the band-pass applied first (0.4–1.5 Hz, see [`SwayBand`])
    pub band: SwayBand,
    /// a half-oscillation counts when its peak reaches this \[signal unit\]. Default
    /// 0.02 rad/s (1.15 °/s): on the paper's Table I vehicle the car's yaw-rate amplitude
    /// in the sway mode is 0.28–0.39 times the hitch-angle amplitude at 20–35 m/s (the
    /// linearisation's eigenvector), so 0.02 rad/s is 3–4° of hitch angle, the sway a
    /// driver notices; it is ≈ 60 times the band-passed noise of the default gyro
    /// (3.2·10⁻⁴ rad/s)
    pub amplitude_threshold: f64,
    /// flag after this many consecutive half-oscillations above the threshold. Default 3
    /// (one and a half periods, ≈ 2.4 s at 0.62 Hz): a single steering correction and the
    /// car's overshoot make at most two; each more delays the flag by half a period
    pub half_oscillations: usize,
    /// the band-passed signal changes sign only when it passes ± this \[signal unit\], so
    /// noise around zero makes no extra half-oscillations. Default 0.002 rad/s: a tenth of
    /// the threshold, ≈ 6 times the band-passed noise of the default gyro
    pub zero_hysteresis: f64,
    /// the shortest and longest half-oscillation that counts \[s\]; `None` (the default)
    /// for those of the band's edges, \[1/(2·high), 1/(2·low)\] = \[0.33, 1.25\] s
    pub half_period_window_s: Option<[f64; 2]>,
}

impl Default for CounterOptions {
    fn default() -> Self {
        CounterOptions {
            signal: Signal::YawRate,
            sample_rate_hz: 100.0,
            band: SwayBand::default(),
            amplitude_threshold: 0.02,
            half_oscillations: 3,
            zero_hysteresis: 0.002,
            half_period_window_s: None,
        }
    }
}

impl CounterOptions {
    /// The half-period window \[s\]: the configured one or that of the band.
    pub fn half_period_window(&self) -> [f64; 2] {
        self.half_period_window_s
            .unwrap_or([0.5 / self.band.high_hz, 0.5 / self.band.low_hz])
    }

    /// Checks every option.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("sample_rate_hz", self.sample_rate_hz)?;
        self.band.validate(self.sample_rate_hz)?;
        positive("amplitude_threshold", self.amplitude_threshold)?;
        in_range(
            "half_oscillations",
            self.half_oscillations,
            1,
            MAX_HALF_OSCILLATIONS,
        )?;
        non_negative("zero_hysteresis", self.zero_hysteresis)?;
        let [min_s, max_s] = self.half_period_window();
        if !(min_s > 0.0 && min_s < max_s && max_s.is_finite()) {
            return Err(ConfigError::HalfPeriods { min_s, max_s });
        }
        Ok(())
    }
}

/// The oscillation counter: the signal band-passed in the sway band, its half-oscillations
/// (the excursions between sign changes, with hysteresis) counted while they alternate,
/// last between the half-period window's bounds and peak above the amplitude threshold;
/// sway after [`CounterOptions::half_oscillations`] consecutive ones. A half-oscillation
/// counts as soon as its peak passes the threshold (the last one need not have ended);
/// one that ends below the threshold, too short, or lasts too long breaks the count.
///
/// **Score** \[signal unit\]: the smallest peak of the latest run of
/// `half_oscillations` consecutive half-oscillations (those that ended, or all but the
/// newest ended and the newest so far), 0 where a half-oscillation in it broke the timing.
/// The counter flags exactly when the score reaches the amplitude threshold, so sweeping
/// the threshold over the score reproduces the counter at every threshold.
///
/// **Estimates** once two consecutive valid half-oscillations ended: the frequency from
/// their mean duration, 1/(2·mean), and the damping ratio from the decrement of their peaks
/// per half-period δ = ln(p_first/p_last)/(n − 1), ζ = δ/√(π² + δ²); the amplitude is the
/// newest half-oscillation's peak.
///
/// A steady oscillation of the driver's steering (a slalom) in the band is counted as
/// sway, and so is a brisk single lane change (its yaw rate's one period leaves the
/// band-pass as three lobes: flagged above ≈ 0.037 rad/s with the defaults): telling them
/// apart needs the steering signal (left to the sway assist).
#[derive(Debug, Clone)]
pub struct OscillationCounter {
    options: CounterOptions,
    guarded: Guarded<CounterCore>,
}

impl OscillationCounter {
    /// A counter with `options`, checked.
    pub fn new(options: CounterOptions) -> Result<Self, ConfigError> {
        options.validate()?;
        Ok(OscillationCounter {
            options,
            guarded: Guarded::new(
                options.signal,
                options.sample_rate_hz,
                CounterCore::new(&options)?,
            ),
        })
    }

    /// The counter's options.
    pub fn options(&self) -> &CounterOptions {
        &self.options
    }
}

impl Detector for OscillationCounter {
    fn update(&mut self, m: &Measurement) -> DetectorOutput {
        self.guarded.update(m)
    }

    fn reset(&mut self) {
        self.guarded.reset();
    }

    fn name(&self) -> &'static str {
        "oscillation_counter"
    }

    fn threshold(&self) -> f64 {
        self.options.amplitude_threshold
    }
}

/// The side of zero the band-passed signal is on (beyond the hysteresis).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Positive,
    Negative,
}

impl Side {
    /// The side `y` is on, `None` within ± `hysteresis`.
    fn of(y: f64, hysteresis: f64) -> Option<Side> {
        if y > hysteresis {
            Some(Side::Positive)
        } else if y < -hysteresis {
            Some(Side::Negative)
        } else {
            None
        }
    }
}

/// The half-oscillation under way.
#[derive(Debug, Clone, Copy, PartialEq)]
enum HalfWave {
    /// no excursion beyond the hysteresis since the start
    Waiting,
    /// on `side` for `samples` sample periods, its peak |y| so far `peak`
    Running {
        side: Side,
        samples: usize,
        peak: f64,
    },
    /// on `side` longer than the longest half-period: already recorded as breaking the
    /// count; the next half-oscillation starts at the next change of side
    TooLong { side: Side },
}

/// The half-oscillations that ended, newest last: peak (0 for one that broke the timing)
/// and duration \[samples\], in ring buffers of fixed size.
#[derive(Debug, Clone, Copy, Default)]
struct Ended {
    peaks: [f64; MAX_HALF_OSCILLATIONS],
    samples: [usize; MAX_HALF_OSCILLATIONS],
    /// index of the newest entry
    head: usize,
    /// entries recorded (at most the capacity)
    len: usize,
}

impl Ended {
    fn record(&mut self, peak: f64, samples: usize) {
        self.head = (self.head + 1) % MAX_HALF_OSCILLATIONS;
        self.peaks[self.head] = peak;
        self.samples[self.head] = samples;
        self.len = (self.len + 1).min(MAX_HALF_OSCILLATIONS);
    }

    /// The `i`-th newest entry (0 the newest): (peak, samples), a breaking one (0, 0)
    /// beyond those recorded.
    fn get(&self, i: usize) -> (f64, usize) {
        if i < self.len {
            let j = (self.head + MAX_HALF_OSCILLATIONS - i) % MAX_HALF_OSCILLATIONS;
            (self.peaks[j], self.samples[j])
        } else {
            (0.0, 0)
        }
    }

    /// The smallest peak of the `n` newest entries (+∞ for n = 0).
    fn min_peak(&self, n: usize) -> f64 {
        (0..n).map(|i| self.get(i).0).fold(f64::INFINITY, f64::min)
    }

    /// How many of the newest entries, at most `n`, are valid (peak > 0) in a row.
    fn valid_run(&self, n: usize) -> usize {
        (0..n).take_while(|&i| self.get(i).0 > 0.0).count()
    }
}

#[derive(Debug, Clone)]
struct CounterCore {
    band_pass: BandPass,
    hysteresis: f64,
    min_samples: f64,
    max_samples: f64,
    period_s: f64,
    count: usize,
    threshold: f64,
    half_wave: HalfWave,
    ended: Ended,
}

impl CounterCore {
    /// The core of checked `options`, at rest.
    fn new(options: &CounterOptions) -> Result<Self, ConfigError> {
        let [min_s, max_s] = options.half_period_window();
        let period_s = 1.0 / options.sample_rate_hz;
        Ok(CounterCore {
            band_pass: BandPass::new(options.band, options.sample_rate_hz)?,
            hysteresis: options.zero_hysteresis,
            // half-period bounds in samples (a duration is a whole number of them)
            min_samples: min_s / period_s,
            max_samples: max_s / period_s,
            period_s,
            count: options.half_oscillations,
            threshold: options.amplitude_threshold,
            half_wave: HalfWave::Waiting,
            ended: Ended::default(),
        })
    }

    /// The half-oscillation on `side` ended after `samples` periods with peak `peak`.
    fn end(&mut self, samples: usize, peak: f64) {
        let valid = (self.min_samples..=self.max_samples).contains(&(samples as f64));
        self.ended.record(if valid { peak } else { 0.0 }, samples);
    }

    /// The next state after the band-passed sample `y`.
    fn advance(&mut self, y: f64) -> HalfWave {
        let now = Side::of(y, self.hysteresis);
        let start = |side| HalfWave::Running {
            side,
            samples: 0,
            peak: y.abs(),
        };
        match self.half_wave {
            HalfWave::Waiting => now.map_or(HalfWave::Waiting, start),
            HalfWave::Running {
                side,
                samples,
                peak,
            } => {
                let samples = samples + 1;
                match now {
                    Some(new) if new != side => {
                        self.end(samples, peak);
                        start(new)
                    }
                    _ if samples as f64 > self.max_samples => {
                        self.ended.record(0.0, samples);
                        HalfWave::TooLong { side }
                    }
                    _ => HalfWave::Running {
                        side,
                        samples,
                        peak: peak.max(y.abs()),
                    },
                }
            }
            HalfWave::TooLong { side } => match now {
                Some(new) if new != side => start(new),
                _ => HalfWave::TooLong { side },
            },
        }
    }

    /// The peak of the half-oscillation under way (0 when none counts).
    fn running_peak(&self) -> f64 {
        match self.half_wave {
            HalfWave::Running { peak, .. } => peak,
            HalfWave::Waiting | HalfWave::TooLong { .. } => 0.0,
        }
    }

    fn output(&self) -> DetectorOutput {
        let n = self.count;
        let running = self.running_peak();
        let score = self
            .ended
            .min_peak(n)
            .max(running.min(self.ended.min_peak(n - 1)));
        let amplitude = match self.half_wave {
            HalfWave::Running { peak, .. } => Some(peak),
            _ if self.ended.len > 0 => Some(self.ended.get(0).0),
            _ => None,
        };
        let (frequency_hz, damping_ratio) = self.estimates();
        DetectorOutput {
            flag: SwayFlag::from_score(score, self.threshold),
            score,
            amplitude,
            frequency_hz,
            damping_ratio,
            ..DetectorOutput::clear(0.0)
        }
    }

    /// Frequency \[Hz\] and damping ratio from the newest run of valid half-oscillations
    /// that ended (at most `count` of them), when it has two or more.
    fn estimates(&self) -> (Option<f64>, Option<f64>) {
        let run = self.ended.valid_run(self.count.max(2));
        if run < 2 {
            return (None, None);
        }
        let samples: usize = (0..run).map(|i| self.ended.get(i).1).sum();
        let half_period_s = samples as f64 * self.period_s / run as f64;
        let (newest, oldest) = (self.ended.get(0).0, self.ended.get(run - 1).0);
        let decrement = (oldest / newest).ln() / (run - 1) as f64;
        let zeta = decrement / (std::f64::consts::PI.powi(2) + decrement.powi(2)).sqrt();
        (Some(0.5 / half_period_s), Some(zeta))
    }
}

impl Core for CounterCore {
    fn restart(&mut self, x: f64) {
        self.band_pass.prime(x);
        self.half_wave = HalfWave::Waiting;
        self.ended = Ended::default();
    }

    fn step(&mut self, x: f64) -> DetectorOutput {
        let y = self.band_pass.filter(x);
        self.half_wave = self.advance(y);
        self.output()
    }

    fn initial_output(&self) -> DetectorOutput {
        DetectorOutput::clear(0.0)
    }
}
