//! The sway band and the band-pass filter both detectors start with.

use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// The frequency band in which trailer sway lives \[Hz\].
///
/// Default 0.4–1.5 Hz: car–trailer combinations sway at 0.5–1.5 Hz (the paper's Table I
/// vehicle at 0.62 Hz at its V_crit = 34.7 m/s, `results/linear`; caravans typically
/// 0.5–1 Hz, light trailers behind heavy cars faster). Below 0.4 Hz lies the driver's
/// cornering and the slow part of lane changes; above 1.5 Hz the car's own yaw and roll
/// modes and road excitation. Slaloms (0.4–1.2 Hz) lie inside the band: a band-pass alone
/// cannot tell them from sway.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SwayBand {
    /// lower edge \[Hz\] (−3 dB of the band-pass)
    pub low_hz: f64,
    /// upper edge \[Hz\] (−3 dB of the band-pass)
    pub high_hz: f64,
}

impl Default for SwayBand {
    fn default() -> Self {
        SwayBand {
            low_hz: 0.4,
            high_hz: 1.5,
        }
    }
}

impl SwayBand {
    /// Whether `frequency_hz` lies in the band (edges included).
    pub fn contains(&self, frequency_hz: f64) -> bool {
        (self.low_hz..=self.high_hz).contains(&frequency_hz)
    }

    /// Checks 0 < low < high < sample_rate_hz / 2.
    pub fn validate(&self, sample_rate_hz: f64) -> Result<(), ConfigError> {
        let nyquist_hz = 0.5 * sample_rate_hz;
        if self.low_hz > 0.0 && self.low_hz < self.high_hz && self.high_hz < nyquist_hz {
            Ok(())
        } else {
            Err(ConfigError::Band {
                low_hz: self.low_hz,
                high_hz: self.high_hz,
                nyquist_hz,
            })
        }
    }
}

/// A second-order band-pass (one biquad, transposed direct form II): the analog
/// H(s) = B s / (s² + B s + ω0²) with B = ω_high − ω_low and ω0² = ω_low ω_high, its edges
/// prewarped and discretised by the bilinear transform, so the digital filter's −3 dB
/// points are the band's edges exactly and its peak gain (at the edges' geometric mean in
/// the analog domain) is 1. Its gain at 0 Hz is 0: a constant bias or a steady cornering
/// yaw rate does not pass. Fixed size, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandPass {
    // H(z) = b0 (1 − z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²)
    b0: f64,
    a1: f64,
    a2: f64,
    s1: f64,
    s2: f64,
    bandwidth_rad_s: f64,
}

impl BandPass {
    /// The band-pass of `band` at `sample_rate_hz`, at rest.
    pub fn new(band: SwayBand, sample_rate_hz: f64) -> Result<Self, ConfigError> {
        crate::error::positive("sample_rate_hz", sample_rate_hz)?;
        band.validate(sample_rate_hz)?;
        let k = 2.0 * sample_rate_hz;
        let warp = |f: f64| k * (std::f64::consts::PI * f / sample_rate_hz).tan();
        let (w_low, w_high) = (warp(band.low_hz), warp(band.high_hz));
        let (b, w0_sq) = (w_high - w_low, w_low * w_high);
        let a0 = k * k + b * k + w0_sq;
        Ok(BandPass {
            b0: b * k / a0,
            a1: 2.0 * (w0_sq - k * k) / a0,
            a2: (k * k - b * k + w0_sq) / a0,
            s1: 0.0,
            s2: 0.0,
            bandwidth_rad_s: b,
        })
    }

    /// The analog bandwidth B = ω_high − ω_low \[rad/s\] (edges prewarped): the filter's
    /// poles have real part −B/2, so its transients decay as e^{−Bt/2}.
    pub fn bandwidth_rad_s(&self) -> f64 {
        self.bandwidth_rad_s
    }

    /// The filter's state as after a constant input `x0` forever: its output 0 (no
    /// transient when a signal starts at a bias or in a steady corner).
    pub fn prime(&mut self, x0: f64) {
        // steady state of transposed DF-II with y = 0: s1 = −b0 x0, s2 = b2 x0 = −b0 x0
        self.s1 = -self.b0 * x0;
        self.s2 = -self.b0 * x0;
    }

    /// The output for the next input sample `x`.
    pub fn filter(&mut self, x: f64) -> f64 {
        let y = self.b0 * x + self.s1;
        self.s1 = -self.a1 * y + self.s2;
        self.s2 = -self.b0 * x - self.a2 * y;
        y
    }

    /// The filter's gain |H(e^{iωh})| at `frequency_hz` for `sample_rate_hz` (that of
    /// [`BandPass::new`]).
    pub fn gain(&self, frequency_hz: f64, sample_rate_hz: f64) -> f64 {
        let w = std::f64::consts::TAU * frequency_hz / sample_rate_hz;
        let (c1, s1) = (w.cos(), -w.sin()); // z⁻¹
        let (c2, s2) = ((2.0 * w).cos(), -(2.0 * w).sin()); // z⁻²
        let num = (self.b0 * (1.0 - c2)).hypot(-self.b0 * s2);
        let den = (1.0 + self.a1 * c1 + self.a2 * c2).hypot(self.a1 * s1 + self.a2 * s2);
        num / den
    }
}
