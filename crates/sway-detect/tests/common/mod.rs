//! Synthetic signals for the tests: damped sinusoids, seeded white noise and the frames a
//! detector reads.
#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::TAU;
use sway_detect::sensor::Measurement;

/// The default frame rate \[Hz\].
pub const RATE_HZ: f64 = 100.0;

/// The default gyro's white noise \[rad/s\] (0.1 °/s).
pub const GYRO_NOISE: f64 = 0.1 * std::f64::consts::PI / 180.0;

/// A sinusoid of damped frequency `frequency_hz` and damping ratio `zeta` (negative:
/// growing) starting at amplitude `amplitude`: A e^{σt} sin(ω_d t) with
/// σ = −ζ ω_d / √(1 − ζ²).
#[derive(Debug, Clone, Copy)]
pub struct DampedSine {
    pub amplitude: f64,
    pub frequency_hz: f64,
    pub zeta: f64,
}

impl DampedSine {
    pub fn growth_rate(&self) -> f64 {
        -self.zeta * TAU * self.frequency_hz / (1.0 - self.zeta * self.zeta).sqrt()
    }

    pub fn at(&self, t: f64) -> f64 {
        self.amplitude * (self.growth_rate() * t).exp() * (TAU * self.frequency_hz * t).sin()
    }

    /// The envelope A e^{σt}.
    pub fn envelope(&self, t: f64) -> f64 {
        self.amplitude * (self.growth_rate() * t).exp()
    }
}

/// Seeded white Gaussian noise (Box–Muller on ChaCha8), independent of the crate's.
#[derive(Debug, Clone)]
pub struct Noise {
    rng: ChaCha8Rng,
    sd: f64,
}

impl Noise {
    pub fn new(seed: u64, sd: f64) -> Self {
        Noise {
            rng: ChaCha8Rng::seed_from_u64(seed),
            sd,
        }
    }

    pub fn next(&mut self) -> f64 {
        let u1 = 1.0 - self.rng.random::<f64>();
        let u2 = self.rng.random::<f64>();
        self.sd * (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
    }
}

/// The frame `k` at `RATE_HZ` whose yaw rate is `yaw_rate`.
pub fn frame(k: usize, yaw_rate: f64) -> Measurement {
    Measurement {
        yaw_rate,
        ..Measurement::at(k as f64 / RATE_HZ)
    }
}

/// The frames of `signal` (a function of t) plus `noise`, `seconds` long at `RATE_HZ`.
pub fn frames(
    seconds: f64,
    signal: impl Fn(f64) -> f64,
    mut noise: Option<Noise>,
) -> impl Iterator<Item = Measurement> {
    let n = (seconds * RATE_HZ).round() as usize;
    (0..n).map(move |k| {
        let t = k as f64 / RATE_HZ;
        let e = noise.as_mut().map_or(0.0, Noise::next);
        frame(k, signal(t) + e)
    })
}

/// Mean and (sample) standard deviation.
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}
