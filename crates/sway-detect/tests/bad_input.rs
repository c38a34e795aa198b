//! Bad input to every detector: NaN and infinite samples, sensor faults beyond range, a
//! missing hitch angle, time gaps and times out of order are reported and recovered from,
//! never a panic; `reset` is a new detector; bad options are errors carrying their numbers.

mod common;

use common::{DampedSine, frame};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sway_detect::ConfigError;
use sway_detect::detector::{
    CounterOptions, DampingEstimator, DampingOptions, Detector, InputStatus, MAX_AR_LAG,
    MAX_HALF_OSCILLATIONS, OscillationCounter, Signal,
};
use sway_detect::sensor::Measurement;

fn detectors() -> Vec<Box<dyn Detector>> {
    vec![
        Box::new(OscillationCounter::new(CounterOptions::default()).unwrap()),
        Box::new(DampingEstimator::new(DampingOptions::default()).unwrap()),
    ]
}

/// Sway: 0.05 rad/s at 0.7 Hz, sustained.
fn sway(t: f64) -> f64 {
    DampedSine {
        amplitude: 0.05,
        frequency_hz: 0.7,
        zeta: 0.0,
    }
    .at(t)
}

/// Feeds frames `from..to` of the sway; whether the detector flagged at the last one.
fn feed(d: &mut dyn Detector, from: usize, to: usize) -> bool {
    let mut flagged = false;
    for k in from..to {
        let o = d.update(&frame(k, sway(k as f64 / 100.0)));
        assert_eq!(o.status, InputStatus::Ok, "{} at frame {k}", d.name());
        flagged = o.flag.is_sway();
    }
    flagged
}

#[test]
fn a_nan_sample_is_reported_then_the_detector_restarts_and_flags_again() {
    for mut d in detectors() {
        assert!(feed(d.as_mut(), 0, 1000), "{} flags the sway", d.name());
        let before = d.update(&frame(1000, sway(10.0)));
        for bad in [f64::NAN, f64::INFINITY, -1e300] {
            let o = d.update(&frame(1001, bad));
            assert_eq!(o.status, InputStatus::Invalid, "{}", d.name());
            // the previous verdict, repeated
            assert_eq!(o.flag, before.flag);
            assert_eq!(o.score, before.score);
        }
        // the next good sample is two periods after the last used one: a gap, a restart
        let o = d.update(&frame(1002, sway(10.02)));
        assert!(
            matches!(o.status, InputStatus::Gap { dt_s } if (dt_s - 0.02).abs() < 1e-12),
            "{}: {:?}",
            d.name(),
            o.status
        );
        assert!(!o.flag.is_sway(), "{} restarted", d.name());
        // and it flags the sway again within 5 s
        assert!(feed(d.as_mut(), 1003, 1500), "{} recovered", d.name());
    }
}

#[test]
fn a_time_gap_restarts_the_detector() {
    for mut d in detectors() {
        feed(d.as_mut(), 0, 800);
        // one second of frames lost
        let o = d.update(&frame(900, sway(9.0)));
        assert!(
            matches!(o.status, InputStatus::Gap { dt_s } if (dt_s - 1.01).abs() < 1e-9),
            "{}: {:?}",
            d.name(),
            o.status
        );
        assert!(feed(d.as_mut(), 901, 1400), "{} recovered", d.name());
    }
}

#[test]
fn a_time_out_of_order_is_ignored() {
    for mut d in detectors() {
        feed(d.as_mut(), 0, 300);
        let last = d.update(&frame(300, sway(3.0)));
        for t in [3.0, 2.5] {
            let o = d.update(&Measurement {
                t,
                ..frame(301, 0.3)
            });
            assert_eq!(
                o.status,
                InputStatus::OutOfOrder { t, last_t: 3.0 },
                "{}",
                d.name()
            );
            assert_eq!(o.score, last.score);
        }
        // the next frame in order is used as if nothing happened
        assert_eq!(d.update(&frame(301, sway(3.01))).status, InputStatus::Ok);
    }
}

#[test]
fn a_hitch_angle_detector_without_the_sensor_reports_every_sample() {
    let mut counter = OscillationCounter::new(CounterOptions {
        signal: Signal::HitchAngle,
        ..CounterOptions::default()
    })
    .unwrap();
    let mut estimator = DampingEstimator::new(DampingOptions {
        signal: Signal::HitchAngle,
        ..DampingOptions::default()
    })
    .unwrap();
    for k in 0..200 {
        let m = frame(k, 0.1);
        assert_eq!(counter.update(&m).status, InputStatus::Invalid);
        assert_eq!(estimator.update(&m).status, InputStatus::Invalid);
        let with_hitch = Measurement {
            hitch_angle: Some(0.01),
            ..m
        };
        assert_ne!(counter.update(&with_hitch).status, InputStatus::Invalid);
    }
}

#[test]
fn garbage_never_panics_and_scores_stay_finite() {
    let mut rng = ChaCha8Rng::seed_from_u64(48);
    for mut d in detectors() {
        let mut t = 0.0;
        for _ in 0..50_000 {
            t += match rng.random_range(0..20) {
                0 => -0.5,
                1 => 0.0,
                2 => 3.0,
                3 => f64::NAN,
                _ => 0.01,
            };
            if t.is_nan() {
                t = 0.0;
            }
            let yaw_rate = match rng.random_range(0..20) {
                0 => f64::NAN,
                1 => f64::NEG_INFINITY,
                2 => 1e300,
                3 => 1e6 * rng.random::<f64>(),
                4 => 1e-300,
                _ => 0.05 * (4.4 * t).sin(),
            };
            let o = d.update(&Measurement {
                yaw_rate,
                ..Measurement::at(t)
            });
            assert!(o.score.is_finite(), "{}: {o:?}", d.name());
        }
    }
}

#[test]
fn reset_gives_a_new_detector() {
    let fresh = detectors();
    for (mut d, mut new) in detectors().into_iter().zip(fresh) {
        feed(d.as_mut(), 0, 700);
        d.reset();
        for k in 0..700 {
            let m = frame(k, sway(k as f64 / 100.0) + 0.01);
            assert_eq!(d.update(&m), new.update(&m), "{} at frame {k}", d.name());
        }
    }
}

#[test]
fn options_that_cannot_run_are_errors_carrying_their_numbers() {
    let counter = |o: CounterOptions| OscillationCounter::new(o).unwrap_err();
    let estimator = |o: DampingOptions| DampingEstimator::new(o).unwrap_err();
    assert_eq!(
        counter(CounterOptions {
            sample_rate_hz: 0.0,
            ..CounterOptions::default()
        }),
        ConfigError::NotPositive {
            key: "sample_rate_hz".into(),
            value: 0.0
        }
    );
    let band = sway_detect::filter::SwayBand {
        low_hz: 1.0,
        high_hz: 60.0,
    };
    assert_eq!(
        counter(CounterOptions {
            band,
            ..CounterOptions::default()
        }),
        ConfigError::Band {
            low_hz: 1.0,
            high_hz: 60.0,
            nyquist_hz: 50.0
        }
    );
    assert_eq!(
        counter(CounterOptions {
            half_oscillations: 0,
            ..CounterOptions::default()
        }),
        ConfigError::OutOfRange {
            key: "half_oscillations",
            value: 0,
            min: 1,
            max: MAX_HALF_OSCILLATIONS
        }
    );
    assert_eq!(
        counter(CounterOptions {
            half_period_window_s: Some([1.0, 0.5]),
            ..CounterOptions::default()
        }),
        ConfigError::HalfPeriods {
            min_s: 1.0,
            max_s: 0.5
        }
    );
    assert_eq!(
        estimator(DampingOptions {
            ar_lag_samples: 30,
            ..DampingOptions::default()
        }),
        ConfigError::OutOfRange {
            key: "ar_lag_samples",
            value: 30,
            min: 1,
            max: MAX_AR_LAG
        }
    );
    assert_eq!(
        estimator(DampingOptions {
            ar_lag_samples: 25,
            band: sway_detect::filter::SwayBand {
                low_hz: 0.4,
                high_hz: 2.5
            },
            ..DampingOptions::default()
        }),
        ConfigError::ArStep {
            lag: 25,
            step_s: 0.25,
            high_hz: 2.5
        }
    );
    let message = estimator(DampingOptions {
        memory_s: 0.1,
        ..DampingOptions::default()
    })
    .to_string();
    assert!(
        message.contains("0.1") && message.contains("0.2"),
        "{message}"
    );
}

#[test]
fn options_read_from_toml_with_defaults_and_no_unknown_keys() {
    let o: CounterOptions = toml::from_str(
        "amplitude_threshold = 0.03\nsignal = \"hitch_angle\"\n[band]\nlow_hz = 0.5\n",
    )
    .unwrap();
    assert_eq!(o.amplitude_threshold, 0.03);
    assert_eq!(o.signal, Signal::HitchAngle);
    assert_eq!(o.band.low_hz, 0.5);
    assert_eq!(o.band.high_hz, 1.5);
    assert_eq!(o.half_oscillations, 3);
    assert!(toml::from_str::<DampingOptions>("memory = 3.0\n").is_err());
    let d: DampingOptions = toml::from_str("memory_s = 3.0\n").unwrap();
    assert_eq!(
        d,
        DampingOptions {
            memory_s: 3.0,
            ..DampingOptions::default()
        }
    );
}
