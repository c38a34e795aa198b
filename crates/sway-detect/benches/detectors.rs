//! Cost per sample of each detector's update (issue 48: ≤ 1 µs for the oscillation counter
//! and the damping estimator, ≤ 20 µs for the model observer) and of sampling every sensor
//! once. The observer's update includes its critical-speed search every tenth frame (the
//! default interval): criterion's median is that of the ordinary frames, its mean carries
//! the search's share. The detectors run on a
//! sustained sway at 0.625 Hz with the default gyro's noise, so every update takes the full
//! path (band-pass, counting or fit, estimates, envelope); time advances by one 10 ms frame
//! per iteration, as on a controller.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use sway_detect::detector::{
    CounterOptions, DampingEstimator, DampingOptions, Detector, ModelObserver, ObserverOptions,
    OscillationCounter,
};
use sway_detect::sensor::{Measurement, SensorSpec, Sensors, SensorsConfig, Truth};

/// Frames of the recorded signal, replayed in a loop: 25 whole periods of 0.625 Hz at
/// 100 Hz (160 frames each), so the loop is seamless.
const RECORDED: usize = 4000;

/// The true values of frame `k`: sway of 0.03 rad/s of yaw rate at 0.625 Hz.
fn truth(k: usize) -> Truth {
    let phase = std::f64::consts::TAU * 0.625 * k as f64 * 0.01;
    Truth {
        yaw_rate: 0.03 * phase.sin(),
        lateral_acceleration: 0.5 * phase.sin(),
        steering_wheel_angle: 0.01,
        speed: 25.0,
        hitch_angle: 0.08 * phase.cos(),
    }
}

/// `RECORDED` yaw rates as the default sensors deliver them.
fn recorded_yaw_rates() -> Vec<f64> {
    let mut sensors = Sensors::new(&SensorsConfig::default()).expect("defaults");
    (0..RECORDED)
        .map(|k| {
            sensors
                .sample(k as f64 * 0.01, &truth(k))
                .expect("a frame every 10 ms")
                .yaw_rate
        })
        .collect()
}

/// One update per iteration on frames with increasing time, after two loops of the
/// recording (the detector then flags the sway).
fn bench_detector(c: &mut Criterion, name: &str, mut detector: impl Detector) {
    let yaw_rates = recorded_yaw_rates();
    let frame = |k: usize| Measurement {
        yaw_rate: yaw_rates[k % RECORDED],
        ..Measurement::at(k as f64 * 0.01)
    };
    let mut k = 0;
    for _ in 0..2 * RECORDED {
        detector.update(&frame(k));
        k += 1;
    }
    assert!(
        detector.update(&frame(k)).flag.is_sway(),
        "{name} flags the sway"
    );
    c.bench_function(name, |b| {
        b.iter(|| {
            k += 1;
            detector.update(black_box(&frame(k)))
        })
    });
}

/// The model observer on every signal of the recorded sway (yaw rate, lateral acceleration,
/// steering, speed from the default sensors), after two loops of the recording: its filter
/// is then in its steady state, every update takes the full path (prediction with the
/// parameter Jacobian, update, free amplitude).
fn bench_observer(c: &mut Criterion) {
    let mut sensors = Sensors::new(&SensorsConfig::default()).expect("defaults");
    let recorded: Vec<Measurement> = (0..RECORDED)
        .map(|k| {
            sensors
                .sample(k as f64 * 0.01, &truth(k))
                .expect("a frame every 10 ms")
        })
        .collect();
    let frame = |k: usize| Measurement {
        t: k as f64 * 0.01,
        ..recorded[k % RECORDED]
    };
    let mut observer = ModelObserver::new(ObserverOptions::default()).expect("defaults");
    let mut k = 0;
    for _ in 0..2 * RECORDED {
        observer.update(&frame(k));
        k += 1;
    }
    c.bench_function("model_observer update", |b| {
        b.iter(|| {
            k += 1;
            observer.update(black_box(&frame(k)))
        })
    });
}

fn bench(c: &mut Criterion) {
    bench_detector(
        c,
        "oscillation_counter update",
        OscillationCounter::new(CounterOptions::default()).expect("defaults"),
    );
    bench_detector(
        c,
        "damping_estimator update",
        DampingEstimator::new(DampingOptions::default()).expect("defaults"),
    );
    bench_observer(c);
    let mut sensors = Sensors::new(&SensorsConfig {
        hitch_angle: Some(SensorSpec::hitch_angle()),
        ..SensorsConfig::default()
    })
    .expect("defaults");
    let mut k = 0;
    c.bench_function("sensors sample (5 channels, one frame)", |b| {
        b.iter(|| {
            k += 1;
            sensors.sample(black_box(k as f64 * 0.01), black_box(&truth(k % RECORDED)))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
