//! Nothing allocates per sample: a counting global allocator shows no allocation while the
//! sensors sample and every detector (the model observer included) updates over 100 000 frames (sway, straight driving,
//! NaN samples, time gaps, times out of order and a reset among them).
//! A binary without the test harness (`harness = false` in Cargo.toml): the counter is
//! global, and the harness's own thread (its output, its timers) could allocate while the
//! detectors are counted.

use std::alloc::System;

use stats_alloc::{INSTRUMENTED_SYSTEM, Region, StatsAlloc};
use sway_detect::detector::{
    CounterOptions, DampingEstimator, DampingOptions, Detector, ModelObserver, ObserverOptions,
    OscillationCounter,
};
use sway_detect::sensor::{SensorSpec, Sensors, SensorsConfig, Truth};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn count(f: impl FnOnce()) -> usize {
    let region = Region::new(GLOBAL);
    f();
    let c = region.change();
    c.allocations + c.reallocations
}

fn main() {
    let config = SensorsConfig {
        hitch_angle: Some(SensorSpec::hitch_angle()),
        ..SensorsConfig::default()
    };
    let mut sensors = Sensors::new(&config).unwrap();
    let mut counter = OscillationCounter::new(CounterOptions::default()).unwrap();
    let mut estimator = DampingEstimator::new(DampingOptions::default()).unwrap();
    let mut observer = ModelObserver::new(ObserverOptions::default()).unwrap();
    let mut estimates = 0.0;
    let (mut frames, mut flags) = (0_usize, 0_usize);
    let n = count(|| {
        for k in 0..100_000_usize {
            // 10 ms frames with a lost second every 200 s
            let t = k as f64 * 0.01 + (k / 20_000) as f64;
            let sway = if (k / 5000) % 2 == 1 {
                0.05 * (4.4 * t).sin()
            } else {
                0.0
            };
            let truth = Truth {
                yaw_rate: sway,
                lateral_acceleration: 25.0 * sway,
                steering_wheel_angle: 0.02,
                speed: 25.0,
                hitch_angle: 3.0 * sway,
            };
            let Some(mut m) = sensors.sample(t, &truth) else {
                continue;
            };
            frames += 1;
            match k % 7919 {
                0 => m.yaw_rate = f64::NAN,
                1 => m.t -= 0.05, // out of order
                _ => {}
            }
            for d in [
                &mut counter as &mut dyn Detector,
                &mut estimator,
                &mut observer,
            ] {
                flags += d.update(&m).flag.is_sway() as usize;
            }
            estimates += observer.estimate().hitch_angle;
            if k == 60_000 {
                counter.reset();
                estimator.reset();
                observer.reset();
            }
        }
    });
    assert!(frames > 99_000, "{frames} frames");
    assert!(flags > 1000, "the sway was flagged ({flags} flags)");
    assert!(estimates.is_finite(), "the observer's estimates are finite");
    assert_eq!(n, 0, "sampling and detecting allocated {n} times");
    println!("no_allocation_per_sample ... ok");
}
