//! Replays a synthetic yaw rate through the default sensors and the two signal-based
//! detectors (the oscillation counter and the damping estimator), and prints their verdicts
//! on a time axis. The third detector, the model observer (`ModelObserver`), needs every
//! signal of one consistent vehicle (yaw rate, lateral acceleration, steering, speed), which
//! a yaw rate alone is not: `tests/observer.rs` drives it with its own linear model of
//! Table I, the sway assist task with the simulation.
//!
//! The signal \[rad/s\]: straight driving; at 10 s a disturbance of a well-damped trailer
//! (ζ = 0.15 at 0.62 Hz, 0.04 rad/s), which decays; at 30 s sway that grows (ζ = −0.03 at
//! 0.62 Hz from 0.003 rad/s), the Table I vehicle's sway frequency.
//!
//! ```text
//! cargo run -p sway-detect --example replay
//! ```

use std::f64::consts::TAU;

use sway_detect::ConfigError;
use sway_detect::detector::{
    CounterOptions, DampingEstimator, DampingOptions, Detector, DetectorOutput, OscillationCounter,
};
use sway_detect::sensor::{Sensors, SensorsConfig, Truth};

/// A mode's response from `start` \[s\]: amplitude e^{σ(t − start)} sin(ω_d (t − start)).
fn mode(t: f64, start: f64, amplitude: f64, frequency_hz: f64, zeta: f64) -> f64 {
    if t < start {
        return 0.0;
    }
    let w = TAU * frequency_hz;
    let sigma = -zeta * w / (1.0 - zeta * zeta).sqrt();
    amplitude * (sigma * (t - start)).exp() * (w * (t - start)).sin()
}

fn yaw_rate(t: f64) -> f64 {
    mode(t, 10.0, 0.04, 0.62, 0.15) + mode(t, 30.0, 0.003, 0.62, -0.03)
}

/// The true amplitude of the growing sway at `t`.
fn sway_envelope(t: f64) -> f64 {
    let sigma = 0.03 * TAU * 0.62 / (1.0 - 0.03_f64 * 0.03).sqrt();
    if t < 30.0 {
        0.0
    } else {
        0.003 * (sigma * (t - 30.0)).exp()
    }
}

fn flag(o: &DetectorOutput) -> &'static str {
    if o.flag.is_sway() { "SWAY" } else { "-" }
}

fn estimate(x: Option<f64>) -> String {
    x.map_or("-".into(), |v| format!("{v:.3}"))
}

fn main() -> Result<(), ConfigError> {
    let mut sensors = Sensors::new(&SensorsConfig::default())?;
    let mut counter = OscillationCounter::new(CounterOptions::default())?;
    let mut estimator = DampingEstimator::new(DampingOptions::default())?;
    let mut first_flags: [Option<f64>; 2] = [None, None];
    println!(
        "{:>6} {:>9} {:>9} | {:>7} {:>7} | {:>7} {:>6} {:>6} {:>7}",
        "t [s]", "yaw rate", "envelope", "counter", "score", "damping", "zeta", "f [Hz]", "flag"
    );
    for k in 0..6000 {
        let t = k as f64 * 0.01;
        let truth = Truth {
            yaw_rate: yaw_rate(t),
            speed: 25.0,
            ..Truth::default()
        };
        let Some(m) = sensors.sample(t, &truth) else {
            continue;
        };
        let c = counter.update(&m);
        let d = estimator.update(&m);
        for (first, out) in first_flags.iter_mut().zip([&c, &d]) {
            if out.flag.is_sway() && first.is_none() && t >= 30.0 {
                *first = Some(t);
            }
        }
        if k % 100 == 0 {
            println!(
                "{t:>6.1} {:>9.4} {:>9.4} | {:>7} {:>7.4} | {:>7} {:>6} {:>6} {:>7}",
                m.yaw_rate,
                sway_envelope(t),
                flag(&c),
                c.score,
                estimate(d.amplitude),
                estimate(d.damping_ratio),
                estimate(d.frequency_hz),
                flag(&d),
            );
        }
    }
    for (detector, first) in [counter.name(), estimator.name()].iter().zip(first_flags) {
        match first {
            Some(t) => println!(
                "{detector}: sway flagged {:.2} s after its onset, at {:.4} rad/s",
                t - 30.0,
                sway_envelope(t)
            ),
            None => println!("{detector}: sway not flagged"),
        }
    }
    Ok(())
}
