//! The oscillation counter on synthetic yaw rates: sway (sustained or growing at 0.8 Hz) is
//! flagged in its N-th half-oscillation above the threshold; a decaying oscillation, slow
//! cornering, a single steering pulse and a single lane change are not. Reference: the
//! half-oscillations of the band-passed signal counted offline (`half_oscillations`).

mod common;

use common::{DampedSine, GYRO_NOISE, Noise, frames};
use sway_detect::detector::{CounterOptions, Detector, DetectorOutput, OscillationCounter};
use sway_detect::filter::BandPass;
use sway_detect::sensor::Measurement;

/// Every output of a counter with `options` over `frames`.
fn outputs(
    options: CounterOptions,
    frames: impl Iterator<Item = Measurement>,
) -> Vec<(f64, DetectorOutput)> {
    let mut counter = OscillationCounter::new(options).unwrap();
    frames.map(|m| (m.t, counter.update(&m))).collect()
}

/// The first time a counter flags, if it does.
fn first_flag(outputs: &[(f64, DetectorOutput)]) -> Option<usize> {
    outputs.iter().position(|(_, o)| o.flag.is_sway())
}

/// A half-oscillation of the offline reference: the sample it starts at, and its peak |y|
/// up to each of its samples.
#[derive(Debug)]
struct HalfOscillation {
    start: usize,
    end: usize,
    peak: f64,
}

/// The offline reference: the band-passed signal's excursions beyond ± hysteresis, from one
/// change of side to the next.
fn half_oscillations(options: &CounterOptions, xs: &[f64]) -> Vec<HalfOscillation> {
    let mut filter = BandPass::new(options.band, options.sample_rate_hz).unwrap();
    filter.prime(xs[0]);
    let ys: Vec<f64> = xs.iter().map(|&x| filter.filter(x)).collect();
    let h = options.zero_hysteresis;
    let mut waves: Vec<HalfOscillation> = Vec::new();
    let mut side = 0.0;
    for (k, &y) in ys.iter().enumerate() {
        let now = if y > h {
            1.0
        } else if y < -h {
            -1.0
        } else {
            side
        };
        if now != side {
            if let Some(last) = waves.last_mut() {
                last.end = k;
            }
            waves.push(HalfOscillation {
                start: k,
                end: ys.len(),
                peak: 0.0,
            });
            side = now;
        }
        if let Some(last) = waves.last_mut() {
            last.peak = last.peak.max(y.abs());
        }
    }
    waves
}

#[test]
fn a_sustained_oscillation_is_flagged_in_its_nth_half_oscillation() {
    let sine = DampedSine {
        amplitude: 0.05,
        frequency_hz: 0.8,
        zeta: 0.0,
    };
    for n in [1, 2, 3, 5] {
        let options = CounterOptions {
            half_oscillations: n,
            ..CounterOptions::default()
        };
        let frames: Vec<Measurement> = frames(10.0, |t| sine.at(t), None).collect();
        let xs: Vec<f64> = frames.iter().map(|m| m.yaw_rate).collect();
        let out = outputs(options, frames.into_iter());
        let flag = first_flag(&out).expect("flagged");
        // reference: the flag comes in the n-th half-oscillation, at the first sample where
        // its peak so far reaches the threshold
        let waves = half_oscillations(&options, &xs);
        let nth = &waves[n - 1];
        assert!(
            nth.start <= flag && flag < nth.end,
            "n = {n}: flag at {flag}, {nth:?}"
        );
        assert!(
            waves[..n]
                .iter()
                .all(|w| w.peak >= options.amplitude_threshold)
        );
        let mut filter = BandPass::new(options.band, options.sample_rate_hz).unwrap();
        filter.prime(xs[0]);
        let ys: Vec<f64> = xs.iter().map(|&x| filter.filter(x)).collect();
        let first_above = (nth.start..nth.end)
            .find(|&k| ys[k].abs() >= options.amplitude_threshold)
            .unwrap();
        assert_eq!(flag, first_above, "n = {n}");
        // and stays flagged while the oscillation lasts
        assert!(out[flag..].iter().all(|(_, o)| o.flag.is_sway()), "n = {n}");
    }
}

#[test]
fn a_growing_oscillation_is_flagged_once_n_half_oscillations_exceed_the_threshold() {
    // ζ = −0.05 at 0.8 Hz from 0.004 rad/s (a fifth of the threshold), gyro noise
    let sine = DampedSine {
        amplitude: 0.004,
        frequency_hz: 0.8,
        zeta: -0.05,
    };
    let options = CounterOptions::default();
    for seed in 0..10 {
        let frames: Vec<Measurement> =
            frames(20.0, |t| sine.at(t), Some(Noise::new(seed, GYRO_NOISE))).collect();
        let xs: Vec<f64> = frames.iter().map(|m| m.yaw_rate).collect();
        let out = outputs(options, frames.into_iter());
        let flag = first_flag(&out).expect("flagged");
        // reference: the three half-oscillations up to the flag all peak above the
        // threshold, the one before them does not
        let waves = half_oscillations(&options, &xs);
        let i = waves
            .iter()
            .position(|w| w.start <= flag && flag < w.end)
            .unwrap();
        assert!(i >= 2, "seed {seed}");
        assert!(
            waves[i - 2..i]
                .iter()
                .all(|w| w.peak >= options.amplitude_threshold),
            "seed {seed}"
        );
        assert!(
            waves[i - 3].peak < options.amplitude_threshold,
            "seed {seed}"
        );
        // the true envelope then is above the threshold (the band-pass's gain at 0.8 Hz is
        // ≈ 1) and below twice it: early, not late
        let envelope = sine.envelope(out[flag].0);
        assert!(
            (0.02..0.04).contains(&envelope),
            "seed {seed}: envelope {envelope} at the flag"
        );
    }
}

#[test]
fn a_decaying_oscillation_is_not_flagged() {
    // ζ = 0.2 from 2.5 times the threshold: peaks ratio e^{−ζπ/√(1−ζ²)} = 0.53 per half
    // oscillation, so only two exceed the threshold
    let sine = DampedSine {
        amplitude: 0.05,
        frequency_hz: 0.8,
        zeta: 0.2,
    };
    for seed in 0..10 {
        let out = outputs(
            CounterOptions::default(),
            frames(10.0, |t| sine.at(t), Some(Noise::new(seed, GYRO_NOISE))),
        );
        assert_eq!(first_flag(&out), None, "seed {seed}");
        // the score is the smallest of the last three peaks: below the threshold
        let best = out.iter().map(|(_, o)| o.score).fold(0.0, f64::max);
        assert!(best < 0.02, "seed {seed}: best score {best}");
    }
}

#[test]
fn slow_cornering_is_not_flagged() {
    // a slow 0.1 Hz weave of ±0.25 rad/s (±14 °/s) and a ramp into a steady corner of
    // 0.3 rad/s over 3 s: the band-pass passes 18 % of the weave (0.045 rad/s, above the
    // threshold) but its half-oscillations last 5 s, beyond the longest 1.25 s
    let weave = |t: f64| 0.25 * (std::f64::consts::TAU * 0.1 * t).sin();
    let ramp = |t: f64| 0.1 * t.min(3.0);
    for signal in [&weave as &dyn Fn(f64) -> f64, &ramp] {
        let out = outputs(
            CounterOptions::default(),
            frames(60.0, signal, Some(Noise::new(1, GYRO_NOISE))),
        );
        assert_eq!(first_flag(&out), None);
        assert!(out.iter().all(|(_, o)| o.score < 0.02));
    }
}

#[test]
fn a_single_steering_pulse_is_not_flagged() {
    // the yaw rate of a 0.4 s steering pulse (half sine, 0.2 rad/s) at t = 2 s: after the
    // band-pass (zero gain at 0 Hz) a lobe and its undershoot (0.12 and 0.07 rad/s), then
    // the band-pass's own ringing (its damping ratio ≈ 0.7: 0.003 rad/s), so two
    // half-oscillations above the threshold, not three
    let pulse = |t: f64| {
        if (2.0..2.4).contains(&t) {
            0.2 * (std::f64::consts::PI * (t - 2.0) / 0.4).sin()
        } else {
            0.0
        }
    };
    for seed in 0..10 {
        let out = outputs(
            CounterOptions::default(),
            frames(10.0, pulse, Some(Noise::new(seed, GYRO_NOISE))),
        );
        assert_eq!(first_flag(&out), None, "seed {seed}");
    }
}

#[test]
fn known_limitation_a_brisk_single_lane_change_makes_three_half_oscillations() {
    // A single lane change's yaw rate is one period of a sine (left, then right); after
    // the band-pass it has three lobes (peaks 0.54, 0.83, 0.57 of its amplitude at 0.5 Hz),
    // so without the steering signal the counter flags one above ≈ 0.037 rad/s (0.9 m/s² of
    // lateral acceleration at 25 m/s). Telling it from sway needs the steering-wheel
    // angle: the sway assist's gate (issue 48, false-alarm set). This pins the behaviour.
    let lane_change = |amplitude: f64| {
        move |t: f64| {
            if (2.0..4.0).contains(&t) {
                amplitude * (std::f64::consts::TAU * 0.5 * (t - 2.0)).sin()
            } else {
                0.0
            }
        }
    };
    let flagged = |amplitude: f64| {
        let out = outputs(
            CounterOptions::default(),
            frames(10.0, lane_change(amplitude), None),
        );
        first_flag(&out).is_some()
    };
    assert!(!flagged(0.03));
    assert!(flagged(0.15));
}

#[test]
fn the_score_reproduces_the_counter_at_every_threshold() {
    // ROC curves sweep a threshold over the recorded score: the flag of a counter with
    // threshold T must be exactly score ≥ T of the default counter's score
    let sine = DampedSine {
        amplitude: 0.003,
        frequency_hz: 0.7,
        zeta: -0.04,
    };
    let signal = |t: f64| sine.at(t) + 0.05 * (0.3 * t).sin();
    let reference = outputs(
        CounterOptions::default(),
        frames(30.0, signal, Some(Noise::new(2, GYRO_NOISE))),
    );
    for threshold in [0.005, 0.01, 0.03, 0.06] {
        let out = outputs(
            CounterOptions {
                amplitude_threshold: threshold,
                ..CounterOptions::default()
            },
            frames(30.0, signal, Some(Noise::new(2, GYRO_NOISE))),
        );
        for ((t, o), (_, r)) in out.iter().zip(&reference) {
            assert_eq!(o.score, r.score, "t = {t}");
            assert_eq!(o.flag.is_sway(), r.score >= threshold, "t = {t}");
        }
        assert!(first_flag(&out).is_some(), "threshold {threshold}");
    }
}

#[test]
fn frequency_and_damping_estimates_from_the_half_oscillations() {
    // ζ = 0.1 at 0.8 Hz from 0.3 rad/s, five half-oscillations counted. Reference: the
    // signal's own frequency and damping. Tolerances: the half-periods are whole samples
    // (62.5 of them: ±1 is 1.6 %, 0.013 Hz), and the peak of a sampled sinusoid is low by
    // at most 1 − cos(π · 0.8/100) = 3·10⁻⁴ (ζ error ≪ 0.01); 0.02 Hz and 0.01
    let sine = DampedSine {
        amplitude: 0.3,
        frequency_hz: 0.8,
        zeta: 0.1,
    };
    let options = CounterOptions {
        half_oscillations: 5,
        ..CounterOptions::default()
    };
    let out = outputs(options, frames(6.0, |t| sine.at(t), None));
    let (t, last) = out
        .iter()
        .rev()
        .find(|(_, o)| o.damping_ratio.is_some())
        .unwrap();
    let (f, zeta) = (last.frequency_hz.unwrap(), last.damping_ratio.unwrap());
    assert!((f - 0.8).abs() < 0.02, "t = {t}: f = {f}");
    assert!((zeta - 0.1).abs() < 0.01, "t = {t}: ζ = {zeta}");
    assert!(last.amplitude.unwrap() > 0.0);
}
