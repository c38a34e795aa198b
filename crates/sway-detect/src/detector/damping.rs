//! The online damping estimator: recursive least squares on a second-order autoregressive
//! model of the band-passed signal.

use serde::{Deserialize, Serialize};

use super::{Core, Detector, DetectorOutput, Guarded, Signal, SwayFlag};
use crate::error::{ConfigError, in_range, non_negative, positive};
use crate::filter::{BandPass, SwayBand};
use crate::sensor::Measurement;

/// The longest autoregressive lag \[samples\].
pub const MAX_AR_LAG: usize = 25;

/// The running amplitude sums kept: the envelope's look-back of two periods of the band's
/// lowest frequency (validated: 2 × 250 samples at 0.4 Hz and 100 Hz).
const HISTORY: usize = 512;

/// The covariance's initial diagonal (of the scaled rows, so dimensionless): large
/// against the inverse information of a few rows, so the first estimates follow the data.
const INITIAL_COVARIANCE: f64 = 1e3;

/// The covariance's trace beyond which forgetting stops (anti-windup): without excitation
/// in some direction the covariance would grow by 1/λ per sample without bound.
const MAX_COVARIANCE_TRACE: f64 = 1e9;

/// The smallest row scale \[signal unit\]: with an amplitude floor of 0, a signal at rest
/// (exactly 0 after quantisation) weighs nothing instead of dividing by 0.
const MIN_ROW_SCALE: f64 = 1e-9;

/// The score of an output without a flaggable estimate: the damping ratio of critical
/// damping, ζ = 1 (the score is −ζ).
const NO_ESTIMATE_SCORE: f64 = -1.0;

/// The options of a [`DampingEstimator`]. Amplitudes are in the signal's unit (rad/s for
/// the default yaw rate).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DampingOptions {
    /// the signal estimated (the car's yaw rate)
    pub signal: Signal,
    /// the rate frames arrive at \[Hz\]: the sensors' frame rate (100 Hz)
    pub sample_rate_hz: f64,
    /// the band-pass applied first (0.4–1.5 Hz, see [`SwayBand`]); frequencies outside it
    /// are not flagged
    pub band: SwayBand,
    /// the autoregressive model's step h as a lag in samples: y_k = a1 y_{k−lag} +
    /// a2 y_{k−2 lag}, fitted at every sample. Default 10 (h = 0.1 s at 100 Hz): at 0.6 Hz
    /// the poles lie at arg z = 0.38 rad, where the damping is well conditioned (at
    /// h = 0.01 s they crowd z = 1: the two regressors are 0.9993 correlated and
    /// ζ ∝ ln|z|/(ωh), so the same noise moves ζ ≈ 100 times more), and the band's upper
    /// edge stays below the step's Nyquist frequency 5 Hz
    pub ar_lag_samples: usize,
    /// the forgetting time \[s\]: the forgetting factor λ = 1 − 1/(memory_s · rate) per
    /// sample. Default 4 s (λ = 0.9975): about 2.5 periods of sway at 0.6 Hz, long enough
    /// to average the noise (ζ's standard deviation ≈ 0.002 at the default gyro noise and
    /// 0.02 rad/s of amplitude), short enough that a change of damping shows within a few
    /// periods
    pub memory_s: f64,
    /// flag when the damping ratio is at most this. Default 0.03: an oscillation whose
    /// amplitude halves no faster than in ≈ 6 s (3.7 periods) at 0.6 Hz, which a driver
    /// feels as sway; the paper's Table I vehicle reaches it at ≈ 31 m/s, 90 % of V_crit
    pub damping_threshold: f64,
    /// flag only when the oscillation's amplitude is at least this \[signal unit\], and
    /// only once it has stayed above half of it for two periods after the band-pass's rise
    /// time; rows of the fit below half of it weigh as their amplitude squared (noise
    /// barely moves the fit). Default 0.005 rad/s (0.29 °/s, ≈ 1–1.5° of hitch angle on the
    /// Table I vehicle): a quarter of the counter's threshold, so low damping is flagged
    /// before the sway is large, yet ≈ 16 times the band-passed noise of the default gyro
    /// (3.2·10⁻⁴ rad/s), whose fit says nothing of the trailer
    pub amplitude_floor: f64,
}

impl Default for DampingOptions {
    fn default() -> Self {
        DampingOptions {
            signal: Signal::YawRate,
            sample_rate_hz: 100.0,
            band: SwayBand::default(),
            ar_lag_samples: 10,
            memory_s: 4.0,
            damping_threshold: 0.03,
            amplitude_floor: 0.005,
        }
    }
}

impl DampingOptions {
    /// The autoregressive step h \[s\].
    pub fn ar_step_s(&self) -> f64 {
        self.ar_lag_samples as f64 / self.sample_rate_hz
    }

    /// The forgetting factor λ per sample.
    pub fn forgetting_factor(&self) -> f64 {
        1.0 - 1.0 / (self.memory_s * self.sample_rate_hz)
    }

    /// Checks every option.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("sample_rate_hz", self.sample_rate_hz)?;
        self.band.validate(self.sample_rate_hz)?;
        in_range("ar_lag_samples", self.ar_lag_samples, 1, MAX_AR_LAG)?;
        let step_s = self.ar_step_s();
        if step_s >= 0.5 / self.band.high_hz {
            return Err(ConfigError::ArStep {
                lag: self.ar_lag_samples,
                step_s,
                high_hz: self.band.high_hz,
            });
        }
        let longest_period = (self.sample_rate_hz / self.band.low_hz).round() as usize;
        if 2 * longest_period >= HISTORY {
            return Err(ConfigError::PeriodTooLong {
                low_hz: self.band.low_hz,
                sample_rate_hz: self.sample_rate_hz,
                samples: 2 * longest_period,
                max: HISTORY - 1,
            });
        }
        let memory_s = positive("memory_s", self.memory_s)?;
        if memory_s < 2.0 * step_s {
            return Err(ConfigError::MemoryTooShort {
                memory_s,
                min_s: 2.0 * step_s,
            });
        }
        // ζ ∈ [−1, 1] for every complex pole pair: a threshold outside flags always or never
        crate::error::finite("damping_threshold", self.damping_threshold)?;
        non_negative("amplitude_floor", self.amplitude_floor)?;
        Ok(())
    }
}

/// The online damping estimator: the signal band-passed in the sway band, a second-order
/// autoregressive model y_k = a1 y_{k−d} + a2 y_{k−2d} (step h = d / rate) fitted at every
/// sample by recursive least squares with exponential forgetting; its poles z (the roots
/// of z² − a1 z − a2) give s = ln(z)/h, the damping ratio ζ = −Re s/|s| and the damped
/// frequency |Im s|/(2π). A damped sinusoid (any ζ, growing ones included) and its
/// band-passed image satisfy the model exactly, so the estimate is unbiased without noise.
///
/// Each row of the fit is divided by the oscillation's amplitude in it (the quadrature
/// amplitude of its two regressors at the band's centre, at least half the floor): a
/// weighted least squares that keeps the model's exact relation but lets every period of
/// an oscillation weigh alike. Unweighted, a large start of a decaying oscillation would
/// dominate the memory, and with it the start's transient.
///
/// An oscillation that a disturbance just started rises in the band-passed signal for
/// ≈ 0.7 s (the band-pass's rise time), which the fit reads as growth until it forgets it
/// (a few seconds). The flag therefore also needs the **envelope**: the mean amplitude over
/// the last whole period against the period before, both after the rise, must decay no
/// faster than the threshold damping (ζ_envelope = −σ/√(σ² + ω²) with
/// σ = ln(ratio)/period).
///
/// **Flag** when the fit's ζ and the envelope's ζ are both at most the damping threshold,
/// the amplitude at least the floor (and above half of it for the two periods after the
/// rise) and the frequency in the band: low or negative damping, before the amplitude is
/// large (growing sway from 0.002 rad/s with ζ = −0.03 at 0.62 Hz is flagged at
/// 0.006–0.009 rad/s, below half the counter's threshold).
///
/// **Score** −max(ζ, ζ_envelope) when the other conditions hold, else −1 (critical
/// damping); the estimator flags exactly when the score reaches −(damping threshold).
///
/// **Estimates** after a warm-up of 2d samples plus half the memory since the (re)start:
/// the amplitude (the quadrature amplitude of the newest samples), and the fit's frequency
/// and damping ratio when its poles are complex (an oscillation).
///
/// A steady oscillation forced by the driver's steering (a slalom) has ζ ≈ 0 in this model:
/// telling it from sway needs the steering signal (left to the sway assist).
#[derive(Debug, Clone)]
pub struct DampingEstimator {
    options: DampingOptions,
    guarded: Guarded<DampingCore>,
}

impl DampingEstimator {
    /// An estimator with `options`, checked.
    pub fn new(options: DampingOptions) -> Result<Self, ConfigError> {
        options.validate()?;
        Ok(DampingEstimator {
            options,
            guarded: Guarded::new(
                options.signal,
                options.sample_rate_hz,
                DampingCore::new(&options)?,
            ),
        })
    }

    /// The estimator's options.
    pub fn options(&self) -> &DampingOptions {
        &self.options
    }
}

impl Detector for DampingEstimator {
    fn update(&mut self, m: &Measurement) -> DetectorOutput {
        self.guarded.update(m)
    }

    fn reset(&mut self) {
        self.guarded.reset();
    }

    fn name(&self) -> &'static str {
        "damping_estimator"
    }

    fn threshold(&self) -> f64 {
        -self.options.damping_threshold
    }
}

/// Recursive least squares with forgetting for the two coefficients θ = (a1, a2).
#[derive(Debug, Clone, Copy)]
struct Rls {
    theta: [f64; 2],
    /// the (symmetric) covariance P
    p: [[f64; 2]; 2],
}

impl Rls {
    fn new() -> Self {
        Rls {
            theta: [0.0; 2],
            p: [[INITIAL_COVARIANCE, 0.0], [0.0, INITIAL_COVARIANCE]],
        }
    }

    /// One update with regressor `phi`, observation `y` and forgetting factor `lambda`,
    /// the row (φ, y) first divided by `scale` (the oscillation's amplitude in this row):
    /// a weighted least-squares row, so the model's exact relation is kept while every
    /// period weighs about the same whatever the amplitude (a large decaying start would
    /// otherwise dominate the memory and its transient bias the fit). Then K = Pφ/(λ + φᵀPφ),
    /// θ += K (y − φᵀθ), P = (P − K φᵀP)/λ (without the division once the trace exceeds
    /// [`MAX_COVARIANCE_TRACE`]). A non-finite result restarts the fit.
    fn update(&mut self, phi: [f64; 2], y: f64, lambda: f64, scale: f64) {
        let scale = scale.max(MIN_ROW_SCALE);
        let (phi, y) = ([phi[0] / scale, phi[1] / scale], y / scale);
        let p = self.p;
        let p_phi = [
            p[0][0] * phi[0] + p[0][1] * phi[1],
            p[1][0] * phi[0] + p[1][1] * phi[1],
        ];
        let denominator = lambda + phi[0] * p_phi[0] + phi[1] * p_phi[1];
        let gain = [p_phi[0] / denominator, p_phi[1] / denominator];
        let error = y - self.theta[0] * phi[0] - self.theta[1] * phi[1];
        self.theta[0] += gain[0] * error;
        self.theta[1] += gain[1] * error;
        let forget = if p[0][0] + p[1][1] > MAX_COVARIANCE_TRACE {
            1.0
        } else {
            1.0 / lambda
        };
        let off_diagonal = 0.5 * (p[0][1] - gain[0] * p_phi[1] + p[1][0] - gain[1] * p_phi[0]);
        self.p = [
            [
                (p[0][0] - gain[0] * p_phi[0]) * forget,
                off_diagonal * forget,
            ],
            [
                off_diagonal * forget,
                (p[1][1] - gain[1] * p_phi[1]) * forget,
            ],
        ];
        if !(self
            .theta
            .iter()
            .chain(self.p.as_flattened())
            .all(|v| v.is_finite()))
        {
            *self = Rls::new();
        }
    }
}

/// The damping ratio and damped frequency \[Hz\] of the model y_k = a1 y_{k−1} + a2 y_{k−2}
/// at step `step_s` \[s\], when its poles are a complex pair.
pub(crate) fn poles_to_damping(a1: f64, a2: f64, step_s: f64) -> Option<(f64, f64)> {
    let discriminant = a1 * a1 + 4.0 * a2;
    if discriminant.is_nan() || discriminant >= 0.0 {
        return None; // real poles (or NaN): no oscillation
    }
    // z = a1/2 ± i √(−disc)/2, |z|² = −a2 > 0
    let re = 0.5 * (-a2).ln() / step_s;
    let im = (-discriminant).sqrt().atan2(a1) / step_s;
    Some((-re / re.hypot(im), im / std::f64::consts::TAU))
}

/// The last `N` values of a sequence, in a fixed array.
#[derive(Debug, Clone, Copy)]
struct Ring<const N: usize> {
    values: [f64; N],
    /// index of the newest value
    head: usize,
}

impl<const N: usize> Ring<N> {
    fn new() -> Self {
        Ring {
            values: [0.0; N],
            head: 0,
        }
    }

    fn push(&mut self, x: f64) {
        self.head = (self.head + 1) % N;
        self.values[self.head] = x;
    }

    /// The value `back` pushes before the newest (0 the newest; `back` < N).
    fn back(&self, back: usize) -> f64 {
        self.values[(self.head + N - back) % N]
    }
}

#[derive(Debug, Clone)]
struct DampingCore {
    band_pass: BandPass,
    sample_rate_hz: f64,
    lag: usize,
    step_s: f64,
    forgetting: f64,
    warm_up: usize,
    band: SwayBand,
    /// cos and sin of ω_c h, ω_c the band's centre (geometric mean of its edges)
    centre_cos_sin: (f64, f64),
    amplitude_floor: f64,
    score_threshold: f64,
    /// the band-passed samples y (the newest 2·lag are read)
    band_passed: Ring<{ 2 * MAX_AR_LAG }>,
    /// the running sums of the quadrature amplitude A_k (sums over any window of the last
    /// [`HISTORY`] samples in O(1))
    amplitude_sums: Ring<HISTORY>,
    /// samples since the (re)start
    samples: usize,
    /// consecutive samples with the quadrature amplitude at least half the floor (the
    /// ripple across the band is within a factor 0.52–1.9)
    present: usize,
    /// the band-pass's rise time: 90 % of its response to a suddenly starting sinusoid,
    /// 2.3/(B/2) for bandwidth B \[samples\]
    rise_samples: usize,
    rls: Rls,
}

impl DampingCore {
    /// The core of checked `options`, at rest.
    fn new(options: &DampingOptions) -> Result<Self, ConfigError> {
        let band_pass = BandPass::new(options.band, options.sample_rate_hz)?;
        let rate = options.sample_rate_hz;
        let lag = options.ar_lag_samples;
        let centre_angle = std::f64::consts::TAU
            * (options.band.low_hz * options.band.high_hz).sqrt()
            * options.ar_step_s();
        Ok(DampingCore {
            band_pass,
            sample_rate_hz: rate,
            lag,
            step_s: options.ar_step_s(),
            forgetting: options.forgetting_factor(),
            warm_up: 2 * lag + (0.5 * options.memory_s * rate).round() as usize,
            band: options.band,
            centre_cos_sin: (centre_angle.cos(), centre_angle.sin()),
            amplitude_floor: options.amplitude_floor,
            score_threshold: -options.damping_threshold,
            band_passed: Ring::new(),
            amplitude_sums: Ring::new(),
            samples: 0,
            present: 0,
            rise_samples: (2.3 / (0.5 * band_pass.bandwidth_rad_s()) * rate).round() as usize,
            rls: Rls::new(),
        })
    }

    /// The amplitude of the sinusoid at the band's centre frequency ω_c through two
    /// samples d apart: A² = (u² − 2 cos(ω_c h) u v + v²)/sin²(ω_c h). Exact for a steady
    /// sinusoid at ω_c; off the centre it ripples with the phase (period half an
    /// oscillation) within a factor of a few across the band, a ripple that averages out
    /// over a period; free of any history, so it follows a fast decay.
    fn quadrature_amplitude(&self, u: f64, v: f64) -> f64 {
        let (c, s) = self.centre_cos_sin;
        (u * u - 2.0 * c * u * v + v * v).max(0.0).sqrt() / s
    }

    /// The damping ratio of the envelope at `frequency_hz`: the mean quadrature amplitude
    /// over the last period against that over the period before, σ = ln(ratio)/period,
    /// ζ = −σ/√(σ² + ω²) (exact for a damped sinusoid: the ripple averages out over whole
    /// periods). `None` unless the oscillation has been present for both periods after the
    /// band-pass's rise time: an oscillation that a disturbance just started rises in the
    /// band-passed signal for ≈ 0.7 s, which both this ratio and the autoregressive fit
    /// would read as growth.
    fn envelope_damping(&self, frequency_hz: f64) -> Option<f64> {
        let period = (self.sample_rate_hz / frequency_hz).round() as usize;
        if 2 * period >= HISTORY || 2 * period + self.rise_samples > self.present {
            return None;
        }
        let sums = &self.amplitude_sums;
        let last = sums.back(0) - sums.back(period);
        let before = sums.back(period) - sums.back(2 * period);
        if !(last > 0.0 && before > 0.0) {
            return None;
        }
        let sigma = (last / before).ln() * self.sample_rate_hz / period as f64;
        Some(-sigma / sigma.hypot(std::f64::consts::TAU * frequency_hz))
    }

    fn output(&self, amplitude: f64) -> DetectorOutput {
        if self.samples < self.warm_up {
            return DetectorOutput::clear(NO_ESTIMATE_SCORE);
        }
        let estimate = poles_to_damping(self.rls.theta[0], self.rls.theta[1], self.step_s);
        let score = match estimate {
            Some((zeta, frequency_hz))
                if amplitude >= self.amplitude_floor && self.band.contains(frequency_hz) =>
            {
                self.envelope_damping(frequency_hz)
                    .map_or(NO_ESTIMATE_SCORE, |envelope| -zeta.max(envelope))
            }
            _ => NO_ESTIMATE_SCORE,
        };
        DetectorOutput {
            flag: SwayFlag::from_score(score, self.score_threshold),
            score,
            amplitude: Some(amplitude),
            frequency_hz: estimate.map(|e| e.1),
            damping_ratio: estimate.map(|e| e.0),
            ..DetectorOutput::clear(score)
        }
    }
}

impl Core for DampingCore {
    fn restart(&mut self, x: f64) {
        self.band_pass.prime(x);
        self.band_passed = Ring::new();
        self.amplitude_sums = Ring::new();
        self.samples = 0;
        self.present = 0;
        self.rls = Rls::new();
    }

    fn step(&mut self, x: f64) -> DetectorOutput {
        let y = self.band_pass.filter(x);
        let d = self.lag;
        if self.samples >= 2 * d {
            // before the push, back(i) is y_{k−1−i}: the regressors y_{k−d}, y_{k−2d}
            let (u, v) = (
                self.band_passed.back(d - 1),
                self.band_passed.back(2 * d - 1),
            );
            // rows of an oscillation above the floor weigh alike; rows of noise below it
            // weigh as their amplitude squared (they barely move a fit of sway)
            let scale = self
                .quadrature_amplitude(u, v)
                .max(0.5 * self.amplitude_floor);
            self.rls.update([u, v], y, self.forgetting, scale);
        }
        let amplitude = self.quadrature_amplitude(y, self.band_passed.back(d - 1));
        self.present = if amplitude >= 0.5 * self.amplitude_floor {
            self.present.saturating_add(1)
        } else {
            0
        };
        self.band_passed.push(y);
        let sum = self.amplitude_sums.back(0) + amplitude;
        self.amplitude_sums.push(sum);
        self.samples = self.samples.saturating_add(1);
        self.output(amplitude)
    }

    fn initial_output(&self) -> DetectorOutput {
        DetectorOutput::clear(NO_ESTIMATE_SCORE)
    }
}

#[cfg(test)]
mod tests {
    use super::poles_to_damping;
    use std::f64::consts::TAU;

    #[test]
    fn poles_give_back_the_damping_and_frequency_they_were_made_from() {
        // reference: the poles z = e^{sh} of s = −ζω_n ± iω_n√(1 − ζ²), as AR(2)
        // coefficients a1 = 2 Re z, a2 = −|z|²
        let h = 0.1;
        for (zeta, f_hz) in [(0.05, 0.8), (0.0, 0.62), (-0.03, 1.2), (0.7, 0.5)] {
            let w_n = TAU * f_hz / (1.0_f64 - zeta * zeta).sqrt();
            let (re, im) = (-zeta * w_n, TAU * f_hz);
            let (r, arg) = ((re * h).exp(), im * h);
            let (a1, a2) = (2.0 * r * arg.cos(), -r * r);
            let (z, f) = poles_to_damping(a1, a2, h).unwrap();
            assert!((z - zeta).abs() < 1e-12, "{zeta}: {z}");
            assert!((f - f_hz).abs() < 1e-12, "{f_hz}: {f}");
        }
        // real poles (and NaN) are no oscillation
        assert_eq!(poles_to_damping(1.5, -0.5, h), None);
        assert_eq!(poles_to_damping(f64::NAN, -0.5, h), None);
    }
}
