//! The sensor models against their configuration: noise and random-walk statistics over
//! long seeded runs (tolerances from the sample count), latency to the sample, quantisation
//! to the step, reproducibility by seed, the TOML form and its checks.

mod common;

use common::mean_sd;
use sway_detect::ConfigError;
use sway_detect::sensor::{
    Channel, MAX_LATENCY_SAMPLES, Sensor, SensorSpec, Sensors, SensorsConfig, Truth, quantise,
};

/// Samples of the long statistical runs: 1000 s at 100 Hz.
const N: usize = 100_000;

/// The yaw-rate channel with `spec` read at every frame k/100 s of a 100 Hz frame, its
/// true value `truth(k)`.
fn run(spec: SensorSpec, seed: u64, n: usize, truth: impl Fn(usize) -> f64) -> Vec<f64> {
    let mut sensor = Sensor::new(Channel::YawRate, spec, 100.0, seed).unwrap();
    (0..n)
        .map(|k| sensor.read(k as f64 / 100.0, truth(k)))
        .collect()
}

/// Lag-1 autocorrelation.
fn lag1_correlation(xs: &[f64]) -> f64 {
    let (mean, sd) = mean_sd(xs);
    let c: f64 = xs
        .windows(2)
        .map(|w| (w[0] - mean) * (w[1] - mean))
        .sum::<f64>();
    c / ((xs.len() - 1) as f64 * sd * sd)
}

#[test]
fn white_noise_has_the_configured_standard_deviation_zero_mean_and_no_memory() {
    let sd = 0.01;
    let spec = SensorSpec {
        noise_sd: sd,
        ..SensorSpec::ideal(100.0)
    };
    let xs = run(spec, 11, N, |_| 0.0);
    let (mean, measured_sd) = mean_sd(&xs);
    // reference: the sample sd's standard error σ/√(2N) (0.22 %), the mean's σ/√N and
    // the lag-1 correlation's 1/√N; tolerance 4 standard errors each
    let n = N as f64;
    assert!(
        (measured_sd / sd - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
        "sd {measured_sd} vs {sd}"
    );
    assert!(mean.abs() < 4.0 * sd / n.sqrt(), "mean {mean}");
    let rho = lag1_correlation(&xs);
    assert!(rho.abs() < 4.0 / n.sqrt(), "lag-1 correlation {rho}");
}

#[test]
fn random_walk_bias_has_independent_increments_of_the_configured_size() {
    let (bias, walk) = (0.3, 0.02); // unit, unit/√s
    let spec = SensorSpec {
        bias,
        bias_random_walk: walk,
        ..SensorSpec::ideal(100.0)
    };
    let xs = run(spec, 5, N + 1, |_| 0.0);
    // the first sample carries the constant bias alone
    assert_eq!(xs[0], bias);
    let increments: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
    let (mean, sd) = mean_sd(&increments);
    // reference: a Wiener process's increments over dt = 0.01 s are N(0, walk² dt);
    // tolerances 4 standard errors from the N increments, as for the white noise
    let expected = walk * 0.01_f64.sqrt();
    let n = N as f64;
    assert!(
        (sd / expected - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
        "increment sd {sd} vs {expected}"
    );
    assert!(mean.abs() < 4.0 * expected / n.sqrt(), "mean {mean}");
    let rho = lag1_correlation(&increments);
    assert!(rho.abs() < 4.0 / n.sqrt(), "lag-1 correlation {rho}");
}

#[test]
fn random_walk_variance_grows_linearly_with_time_over_seeds() {
    // reference: Var b(T) = walk² T; 400 seeds give the sample variance a relative
    // standard error √(2/400) = 7 %: tolerance 4 of them (28 %)
    let walk = 0.01;
    let spec = SensorSpec {
        bias_random_walk: walk,
        ..SensorSpec::ideal(100.0)
    };
    let t_end = 25.0;
    let finals: Vec<f64> = (0..400)
        .map(|seed| *run(spec, seed, 2501, |_| 0.0).last().unwrap())
        .collect();
    let var = finals.iter().map(|b| b * b).sum::<f64>() / finals.len() as f64;
    let expected = walk * walk * t_end;
    assert!(
        (var / expected - 1.0).abs() < 4.0 * (2.0_f64 / 400.0).sqrt(),
        "{var} vs {expected}"
    );
}

#[test]
fn a_constant_bias_shifts_every_sample_exactly() {
    let spec = SensorSpec {
        bias: -0.25,
        ..SensorSpec::ideal(100.0)
    };
    let xs = run(spec, 0, 100, |k| k as f64);
    for (k, x) in xs.iter().enumerate() {
        assert_eq!(*x, k as f64 - 0.25);
    }
}

#[test]
fn latency_delays_by_exactly_the_configured_samples() {
    for latency in [0, 1, 3, MAX_LATENCY_SAMPLES] {
        let spec = SensorSpec {
            latency_samples: latency,
            ..SensorSpec::ideal(100.0)
        };
        let xs = run(spec, 0, 200, |k| k as f64);
        for (k, x) in xs.iter().enumerate() {
            // before `latency` samples exist the first one is repeated
            assert_eq!(
                *x,
                k.saturating_sub(latency) as f64,
                "latency {latency}, k {k}"
            );
        }
    }
}

#[test]
fn a_slower_channel_is_held_between_its_samples_and_delayed_in_its_own_samples() {
    // speed at 50 Hz, latency 2 of its samples (40 ms), read in 100 Hz frames
    let config = SensorsConfig {
        speed: SensorSpec {
            latency_samples: 2,
            ..SensorSpec::ideal(50.0)
        },
        ..SensorsConfig::ideal(100.0)
    };
    let mut sensors = Sensors::new(&config).unwrap();
    for k in 0..100 {
        let truth = Truth {
            speed: k as f64,
            ..Truth::default()
        };
        let m = sensors.sample(k as f64 / 100.0, &truth).unwrap();
        // samples at the even frames 2j; the one read is two samples older
        let j: usize = k / 2;
        assert_eq!(m.speed, (2 * j.saturating_sub(2)) as f64, "frame {k}");
        assert_eq!(m.yaw_rate, 0.0);
    }
}

#[test]
fn quantisation_rounds_to_the_nearest_step() {
    let step = 0.01_f64.to_radians(); // the default yaw-rate resolution
    let spec = SensorSpec {
        quantisation_step: step,
        ..SensorSpec::ideal(100.0)
    };
    let truth = |k: usize| 1e-5 * k as f64 - 0.3;
    let xs = run(spec, 0, 60_000, truth);
    for (k, x) in xs.iter().enumerate() {
        let steps = x / step;
        assert!(
            (steps - steps.round()).abs() < 1e-9,
            "{x} is not on the grid"
        );
        assert!(
            (x - truth(k)).abs() <= 0.5 * step * (1.0 + 1e-9),
            "{x} is not the nearest step to {}",
            truth(k)
        );
    }
    assert_eq!(quantise(0.26, 0.1), 0.30000000000000004);
    assert_eq!(quantise(-0.24, 0.1), -0.2);
    assert_eq!(quantise(0.123, 0.0), 0.123);
}

/// Every signal of `n` frames of the default sensors with seed `seed` (the hitch-angle
/// sensor fitted or not) on a fixed truth trajectory.
fn recording(seed: u64, hitch: bool, n: usize) -> Vec<[f64; 5]> {
    let config = SensorsConfig {
        seed,
        hitch_angle: hitch.then(SensorSpec::hitch_angle),
        ..SensorsConfig::default()
    };
    let mut sensors = Sensors::new(&config).unwrap();
    (0..n)
        .filter_map(|k| {
            let t = k as f64 / 100.0;
            let truth = Truth {
                yaw_rate: 0.1 * (4.0 * t).sin(),
                lateral_acceleration: 2.0 * (4.0 * t).sin(),
                steering_wheel_angle: 0.3 * (4.0 * t).cos(),
                speed: 25.0,
                hitch_angle: 0.05 * (4.0 * t).sin(),
            };
            sensors.sample(t, &truth)
        })
        .map(|m| {
            [
                m.yaw_rate,
                m.lateral_acceleration,
                m.steering_wheel_angle,
                m.speed,
                m.hitch_angle.unwrap_or(f64::NAN),
            ]
        })
        .collect()
}

#[test]
fn the_same_seed_gives_the_same_numbers_and_channels_do_not_share_draws() {
    let a = recording(3, true, 3000);
    let b = recording(3, true, 3000);
    assert_eq!(format!("{a:?}"), format!("{b:?}")); // bit for bit (NaN-safe)
    let c = recording(4, true, 3000);
    assert!(a.iter().zip(&c).any(|(x, y)| x[0] != y[0]));
    // fitting the hitch-angle sensor changes no other channel's numbers
    let without = recording(3, false, 3000);
    for (x, y) in a.iter().zip(&without) {
        assert_eq!(x[..4], y[..4]);
    }
}

#[test]
fn the_same_seed_gives_the_same_numbers_on_other_threads() {
    let here = format!("{:?}", recording(9, true, 2000));
    let threads: Vec<_> = (0..2)
        .map(|_| std::thread::spawn(|| format!("{:?}", recording(9, true, 2000))))
        .collect();
    for t in threads {
        assert_eq!(t.join().unwrap(), here);
    }
}

#[test]
fn reset_replays_the_same_numbers() {
    let mut sensors = Sensors::new(&SensorsConfig::default()).unwrap();
    let truth = Truth {
        yaw_rate: 0.02,
        ..Truth::default()
    };
    let take = |s: &mut Sensors| {
        (0..500)
            .filter_map(|k| s.sample(k as f64 / 100.0, &truth))
            .map(|m| m.yaw_rate)
            .collect::<Vec<_>>()
    };
    let first = take(&mut sensors);
    sensors.reset();
    assert_eq!(take(&mut sensors), first);
}

#[test]
fn frames_come_at_the_frame_rate_whatever_the_callers_step() {
    let mut sensors = Sensors::new(&SensorsConfig::default()).unwrap();
    assert_eq!(sensors.next_sample_time(), None);
    let truth = Truth::default();
    // a caller stepping 1 ms from t = 0.3 s: a frame every 10th call
    let times: Vec<f64> = (0..1000)
        .map(|i| 0.3 + i as f64 * 0.001)
        .filter(|&t| sensors.sample(t, &truth).is_some())
        .collect();
    assert_eq!(times.len(), 100);
    for (j, t) in times.iter().enumerate() {
        assert!(
            (t - (0.3 + 0.01 * j as f64)).abs() < 1e-9,
            "frame {j} at {t}"
        );
    }
    assert!((sensors.next_sample_time().unwrap() - 1.3).abs() < 1e-9);
    // a NaN time is no frame
    assert!(sensors.sample(f64::NAN, &truth).is_none());
    assert_eq!(sensors.frame_period_s(), 0.01);
}

#[test]
fn toml_keys_override_the_channel_defaults_and_a_hitch_table_fits_the_sensor() {
    let config: SensorsConfig = toml::from_str(
        r#"
        seed = 7
        [yaw_rate]
        noise_sd = 0.003
        [speed]
        latency_samples = 3
        [hitch_angle]
        "#,
    )
    .unwrap();
    assert_eq!(config.seed, 7);
    assert_eq!(
        config.yaw_rate,
        SensorSpec {
            noise_sd: 0.003,
            ..SensorSpec::yaw_rate()
        }
    );
    assert_eq!(config.speed.latency_samples, 3);
    assert_eq!(config.speed.sample_rate_hz, 50.0);
    assert_eq!(
        config.lateral_acceleration,
        SensorSpec::lateral_acceleration()
    );
    assert_eq!(config.hitch_angle, Some(SensorSpec::hitch_angle()));
    let empty: SensorsConfig = toml::from_str("").unwrap();
    assert_eq!(empty, SensorsConfig::default());
    assert_eq!(empty.hitch_angle, None);
}

#[test]
fn toml_refuses_unknown_keys_and_bad_values_naming_the_key_and_number() {
    let unknown = toml::from_str::<SensorsConfig>("[yaw_rate]\nnoise_std = 0.1\n").unwrap_err();
    assert!(unknown.to_string().contains("noise_std"), "{unknown}");
    let top = toml::from_str::<SensorsConfig>("sed = 1\n").unwrap_err();
    assert!(top.to_string().contains("sed"), "{top}");
    let negative = toml::from_str::<SensorsConfig>("[yaw_rate]\nnoise_sd = -0.1\n").unwrap_err();
    assert!(
        negative.to_string().contains("yaw_rate.noise_sd") && negative.to_string().contains("-0.1"),
        "{negative}"
    );
    let fast = toml::from_str::<SensorsConfig>("[speed]\nsample_rate_hz = 200.0\n").unwrap_err();
    assert!(fast.to_string().contains("200"), "{fast}");
}

#[test]
fn configurations_that_cannot_run_are_errors_carrying_their_numbers() {
    let err = |config: SensorsConfig| Sensors::new(&config).unwrap_err();
    assert_eq!(
        err(SensorsConfig {
            frame_rate_hz: 0.0,
            ..SensorsConfig::default()
        }),
        ConfigError::NotPositive {
            key: "frame_rate_hz".into(),
            value: 0.0
        }
    );
    assert_eq!(
        err(SensorsConfig {
            yaw_rate: SensorSpec {
                sample_rate_hz: -100.0,
                ..SensorSpec::yaw_rate()
            },
            ..SensorsConfig::default()
        }),
        ConfigError::NotPositive {
            key: "yaw_rate.sample_rate_hz".into(),
            value: -100.0
        }
    );
    assert_eq!(
        err(SensorsConfig {
            speed: SensorSpec::ideal(400.0),
            ..SensorsConfig::default()
        }),
        ConfigError::FasterThanFrame {
            channel: "speed",
            rate_hz: 400.0,
            frame_rate_hz: 100.0
        }
    );
    assert_eq!(
        err(SensorsConfig {
            hitch_angle: Some(SensorSpec {
                latency_samples: 40,
                ..SensorSpec::hitch_angle()
            }),
            ..SensorsConfig::default()
        }),
        ConfigError::LatencyTooLong {
            channel: "hitch_angle",
            samples: 40,
            max: MAX_LATENCY_SAMPLES
        }
    );
    assert_eq!(
        err(SensorsConfig {
            steering_wheel_angle: SensorSpec {
                bias: f64::INFINITY,
                ..SensorSpec::steering_wheel_angle()
            },
            ..SensorsConfig::default()
        }),
        ConfigError::NotFinite {
            key: "steering_wheel_angle.bias".into(),
            value: f64::INFINITY
        }
    );
}

#[test]
fn the_default_cluster_is_what_its_docs_say() {
    // the reasons are on `SensorSpec::yaw_rate` & co.; the numbers in degrees here
    let c = SensorsConfig::default();
    assert_eq!(c.frame_rate_hz, 100.0);
    assert!((c.yaw_rate.noise_sd.to_degrees() - 0.1).abs() < 1e-12);
    assert!((c.yaw_rate.bias.to_degrees() - 0.2).abs() < 1e-12);
    assert!((c.yaw_rate.quantisation_step.to_degrees() - 0.01).abs() < 1e-12);
    assert_eq!(c.yaw_rate.latency_samples, 2);
    assert!((c.steering_wheel_angle.quantisation_step.to_degrees() - 0.1).abs() < 1e-12);
    for channel in Channel::ALL {
        let spec = channel.default_spec();
        spec.validate(channel, c.frame_rate_hz).unwrap();
        assert!(!channel.unit().is_empty());
    }
}
