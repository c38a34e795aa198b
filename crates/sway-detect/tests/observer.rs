//! The model-based observer: its linear model against the toolkit's V_crit, reproduction of
//! its own model's hitch angle without noise, consistency of its covariance over seeds,
//! convergence of the trailer's parameters from a wrong prior, bad input and its options.
//! The truth is the observer's own model with brush tyres ([`BrushModel`]) with Table I's
//! parameters and the paper's friction, integrated by the classical Runge–Kutta method at
//! 1 ms (10 steps per frame: its error is far below every tolerance here); the comparison
//! against the toolkit's simulation (the paper's kinematics) belongs to the sway-assist
//! evaluation.

use sway_detect::ConfigError;
use sway_detect::detector::observer::model::{
    BrushModel, CarParams, CriticalSpeedSearch, Friction, LinearModel, TrailerParams,
};
use sway_detect::detector::{Detector, InputStatus, ModelObserver, ObserverOptions};
use sway_detect::sensor::{Measurement, Sensors, SensorsConfig, Truth};

/// The toolkit's linear V_crit of Table I (results/linear/summary.json) \[m/s\].
const TABLE_I_V_CRIT: f64 = 34.747923362676374;
/// The steering ratio of the observer's default options.
const STEERING_RATIO: f64 = 16.0;
/// Integration steps per 10 ms frame.
const FINE_STEPS: usize = 10;

fn table_i() -> LinearModel {
    LinearModel::new(CarParams::default(), TrailerParams::default()).expect("Table I")
}

fn table_i_brush() -> BrushModel {
    BrushModel::new(
        CarParams::default(),
        TrailerParams::default(),
        Friction::default(),
    )
    .expect("Table I")
}

/// The truth of the brush model driven by a road-wheel angle δ(t) at constant speed:
/// RK4 at 1 ms with δ evaluated at the stages.
struct Truth4<F> {
    model: BrushModel,
    speed: f64,
    steering: F,
    x: [f64; 4],
    t: f64,
    frames: usize,
}

impl<F: Fn(f64) -> f64> Truth4<F> {
    fn new(speed: f64, steering: F) -> Self {
        Truth4 {
            model: table_i_brush(),
            speed,
            steering,
            x: [0.0; 4],
            t: 0.0,
            frames: 0,
        }
    }

    /// The true signals now (road-wheel angle times the steering ratio).
    fn signals(&self) -> Truth {
        let delta = (self.steering)(self.t);
        Truth {
            yaw_rate: self.x[1],
            lateral_acceleration: self.model.lateral_acceleration(&self.x, delta, self.speed),
            steering_wheel_angle: delta * STEERING_RATIO,
            speed: self.speed,
            hitch_angle: self.x[2],
        }
    }

    /// Advances one frame of 10 ms.
    fn advance(&mut self) {
        let h = 0.01 / FINE_STEPS as f64;
        for _ in 0..FINE_STEPS {
            let f = |t: f64, x: &[f64; 4]| self.model.derivative(x, (self.steering)(t), self.speed);
            let add = |x: &[f64; 4], k: &[f64; 4], c: f64| -> [f64; 4] {
                std::array::from_fn(|i| x[i] + c * k[i])
            };
            let k1 = f(self.t, &self.x);
            let k2 = f(self.t + 0.5 * h, &add(&self.x, &k1, 0.5 * h));
            let k3 = f(self.t + 0.5 * h, &add(&self.x, &k2, 0.5 * h));
            let k4 = f(self.t + h, &add(&self.x, &k3, h));
            self.x = std::array::from_fn(|i| {
                self.x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
            self.t += h;
        }
        // the frame's time exactly, as the sensors' grid expects it
        self.frames += 1;
        self.t = self.frames as f64 * 0.01;
    }
}

/// Slalom- and lane-change-like steering \[rad of road-wheel angle\], periodic in 12 s: a
/// single lane change (one period of 0.4 Hz, 2.5 s), 1.5 s straight, a slalom at 0.8 Hz
/// (4 periods, 5 s), 3 s of a gentle 0.25 Hz weave. About 2–3 m/s² of lateral acceleration
/// at 25 m/s.
fn driving(t: f64) -> f64 {
    use std::f64::consts::TAU;
    let s = t % 12.0;
    if s < 2.5 {
        0.02 * (TAU * 0.4 * s).sin()
    } else if s < 4.0 {
        0.0
    } else if s < 9.0 {
        0.012 * (TAU * 0.8 * (s - 4.0)).sin()
    } else {
        0.01 * (TAU * (s - 9.0) / 3.0).sin()
    }
}

#[test]
fn v_crit_of_table_i_is_the_toolkits_linear_v_crit() {
    // reference: trailer-model's eigenvalue search on the paper's Appellian linearisation,
    // 34.747923362676374 m/s; an independent formulation of the same linear model, so equal
    // to 1e-6 relative (the bisection stops at 1e-9 m/s)
    let search = CriticalSpeedSearch {
        tolerance_mps: 1e-9,
        ..CriticalSpeedSearch::default()
    };
    let c = table_i().critical_speed(&search).expect("Table I sways");
    let rel = (c.v_crit_mps - TABLE_I_V_CRIT).abs() / TABLE_I_V_CRIT;
    assert!(
        rel < 1e-6,
        "V_crit {} m/s, relative error {rel:e}",
        c.v_crit_mps
    );
    // the toolkit's Hopf frequency 0.6211036770923187 Hz (same summary)
    assert!(
        (c.frequency_hz - 0.6211036770923187).abs() < 1e-5,
        "{}",
        c.frequency_hz
    );
}

/// Options for the true trailer known exactly (prior sd and walk 0) and no steering delay.
fn known_trailer() -> ObserverOptions {
    let d = ObserverOptions::default();
    let t = TrailerParams::default();
    let known = |prior: sway_detect::detector::observer::ParameterPrior, mean: f64| {
        sway_detect::detector::observer::ParameterPrior {
            mean,
            sd: 0.0,
            random_walk: 0.0,
            ..prior
        }
    };
    ObserverOptions {
        mass: known(d.mass, t.mass),
        yaw_inertia: known(d.yaw_inertia, t.yaw_inertia),
        cog: known(d.cog, t.cog),
        steering_delay_samples: 0,
        ..d
    }
}

#[test]
fn without_noise_and_with_the_true_parameters_it_reproduces_its_own_nonlinear_model() {
    // reference: the brush model integrated by RK4 at 1 ms (error ~1e-12 of the
    // amplitude), driven hard enough that the tyres are nonlinear (the trailer axle's force
    // at least 15 % below the linear tyre's at its peak, checked); the observer's own
    // prediction integrates the same model by RK4 at its 10 ms frames with the steering
    // linear over each frame (first-order hold): the interpolation of a 0.8 Hz sine errs by
    // (ωh)²/8 ≈ 1.3e-4 of its amplitude, RK4's own error at 10 ms is ~1e-7. Tolerance 1e-3
    // of the hitch angle's peak, after 1 s for the filter to settle on the initial state
    let mut truth = Truth4::new(25.0, |t: f64| 1.5 * driving(t));
    let mut sensors = Sensors::new(&SensorsConfig::ideal(100.0)).unwrap();
    let mut observer = ModelObserver::new(known_trailer()).unwrap();
    // the linear tyre's force C_T tan α_T, tan α_T = θ − (v − (d + l) r − l θ̇)/V
    let (d, trailer) = (CarParams::default().cog, TrailerParams::default());
    let l = trailer.axle;
    let linear_trailer_force = |x: &[f64; 4]| {
        trailer.cornering_stiffness * (x[2] - (x[0] - (d + l) * x[1] - l * x[3]) / 25.0)
    };
    let (mut worst, mut peak, mut softest) = (0.0_f64, 0.0_f64, 1.0_f64);
    for k in 0..3000 {
        let m = sensors.sample(truth.t, &truth.signals()).expect("a frame");
        let out = observer.update(&m);
        assert_eq!(out.status, InputStatus::Ok);
        let e = observer.estimate();
        peak = peak.max(truth.x[2].abs());
        let linear = linear_trailer_force(&truth.x);
        if linear.abs() > 1000.0 {
            let brush = truth
                .model
                .axle_forces(&truth.x, (truth.steering)(truth.t), 25.0)[2];
            softest = softest.min(brush / linear);
        }
        if k >= 100 {
            worst = worst.max((e.hitch_angle - truth.x[2]).abs());
        }
        truth.advance();
    }
    eprintln!(
        "reproduction: worst |θ̂ − θ| = {worst:e} rad, peak |θ| = {peak:e} rad, ratio {:e}; \
         the trailer tyre's force down to {softest:.3} of the linear tyre's",
        worst / peak
    );
    assert!(softest < 0.85, "the tyres stayed nearly linear: {softest}");
    assert!(worst < 1e-3 * peak, "{worst:e} against {peak:e}");
}

/// One run of `seconds` at 25 m/s with the default sensors of `seed`: calls `each` with the
/// frame's time, the observer and the true state when the gyro sampled (two frames before,
/// the default latency).
fn run(
    options: ObserverOptions,
    seed: u64,
    seconds: f64,
    mut each: impl FnMut(f64, &ModelObserver, &[f64; 4]),
) {
    let mut truth = Truth4::new(25.0, driving);
    let mut sensors = Sensors::new(&SensorsConfig {
        seed,
        ..SensorsConfig::default()
    })
    .unwrap();
    let mut observer = ModelObserver::new(options).unwrap();
    let mut past = [[0.0; 4]; 3];
    for k in 0..(seconds * 100.0).round() as usize {
        past[k % 3] = truth.x;
        let m = sensors.sample(truth.t, &truth.signals()).expect("a frame");
        observer.update(&m);
        if k >= 2 {
            each(truth.t, &observer, &past[(k - 2) % 3]);
        }
        truth.advance();
    }
}

/// The normalised estimation error squared of (θ, θ̇): eᵀ P⁻¹ e with the estimate's 2×2
/// covariance.
fn nees(e: &sway_detect::detector::ObserverEstimate, x: &[f64; 4]) -> f64 {
    let (a, b) = (e.hitch_angle - x[2], e.hitch_rate - x[3]);
    let (p, q, c) = (
        e.hitch_angle_variance,
        e.hitch_rate_variance,
        e.hitch_covariance,
    );
    (q * a * a - 2.0 * c * a * b + p * b * b) / (p * q - c * c)
}

#[test]
fn its_covariance_contains_the_true_error_over_seeds() {
    // reference: a consistent filter's NEES of (θ, θ̇) is χ² with 2 degrees of freedom, and
    // V_crit's squared error over its variance is χ² with 1. 20 seeds of the default
    // sensors (noise, biases, latency, quantisation), 60 s of the driving at 25 m/s (the
    // tyres up to half their sliding friction) with the default options (parameters
    // estimated from the default prior), the NEES at every 3 s from 10 s on (3 s apart:
    // longer than the filter's memory of the lateral states, so nearly independent).
    //
    // What holds, measured: a run can settle in a wrong local optimum of the parameters
    // (seed 16: m2 ≈ 200 kg, h ≈ 3.75 m after a jump in its first second, where the
    // estimated hitch lifts the car's rear axle and the linearisation about the prior is
    // poor; its V_crit is still within 0.2 %, its hitch angle is not): at most 1 of 20
    // here (3 of 100 seeds). Over the others the covariance is optimistic by about a third
    // (mean NEES 2.7 instead of 2: the first-order filter in the tyres' nonlinear range; the
    // linear observer on its linear truth gave 3.6 over 100 seeds, 2.0 over these 20).
    // Asserted: the mean NEES within [1.71, 3.43] (the 99 % interval of a consistent filter,
    // its upper end stretched by 1.5 for the optimism), the fraction of frames with
    // |θ̂ − θ| ≤ 2σ_θ at least 85 % (95.4 % when consistent), and V_crit's mean squared
    // error over its variance at most 3 (its sd honest to a factor √3)
    let (mut sum, mut samples, mut within, mut frames) = (0.0, 0, 0, 0);
    let (mut wrong, mut v_crit_z2, mut v_crit_runs) = (0, 0.0, 0);
    for seed in 0..20 {
        let (mut run_sum, mut run_samples, mut run_within, mut run_frames) = (0.0, 0, 0, 0);
        let mut last = None;
        run(ObserverOptions::default(), seed, 60.0, |t, obs, x| {
            let k = (t * 100.0).round() as usize;
            let e = obs.estimate();
            last = Some(e);
            if k < 1000 {
                return;
            }
            run_frames += 1;
            run_within +=
                usize::from((e.hitch_angle - x[2]).abs() <= 2.0 * e.hitch_angle_variance.sqrt());
            if k.is_multiple_of(300) {
                run_sum += nees(&e, x);
                run_samples += 1;
            }
        });
        let e = last.expect("estimates");
        let mass = e.trailer_mass.value;
        if (mass - TrailerParams::default().mass).abs() > 0.5 * TrailerParams::default().mass {
            eprintln!("consistency: seed {seed} in a wrong optimum, m2 = {mass:.0} kg");
            wrong += 1;
            continue;
        }
        (sum, samples, within, frames) = (
            sum + run_sum,
            samples + run_samples,
            within + run_within,
            frames + run_frames,
        );
        if let (Some(v), Some(sd)) = (e.v_crit_estimate_mps, e.v_crit_sd_mps) {
            v_crit_z2 += ((v - TABLE_I_V_CRIT) / sd).powi(2);
            v_crit_runs += 1;
        }
    }
    let (mean, fraction) = (sum / samples as f64, within as f64 / frames as f64);
    let z2 = v_crit_z2 / v_crit_runs as f64;
    eprintln!(
        "consistency: {wrong} wrong optima; mean NEES {mean:.3} over {samples} samples, \
         |error| ≤ 2σ in {:.2} % of {frames} frames; V_crit mean (error/sd)² {z2:.2} over \
         {v_crit_runs} runs",
        100.0 * fraction
    );
    assert!(wrong <= 1, "{wrong} runs in a wrong optimum");
    assert_eq!(samples, 16 * (20 - wrong));
    assert!((1.71..=3.43).contains(&mean), "mean NEES {mean}");
    assert!(fraction >= 0.85, "within 2σ: {fraction}");
    assert!(z2 <= 3.0, "V_crit (error/sd)²: {z2}");
}

#[test]
fn v_crit_converges_from_a_wrong_trailer_mass() {
    // reference: Table I's linear V_crit (above); the goal: within 5 % after 60 s
    // of slalom and lane-change driving with the default sensor noise. The prior mass is
    // 1500 kg (true 985 kg), the rest of the default prior (J2 2000 kg m², h 2.5 m: also
    // wrong). Convergence time: from when on the error stays within 5 %. Five seeds
    let prior = LinearModel::new(
        CarParams::default(),
        TrailerParams {
            mass: 1500.0,
            yaw_inertia: ObserverOptions::default().yaw_inertia.mean,
            cog: ObserverOptions::default().cog.mean,
            ..TrailerParams::default()
        },
    )
    .unwrap();
    let prior_v_crit = prior
        .critical_speed(&CriticalSpeedSearch::default())
        .map_or(f64::INFINITY, |c| c.v_crit_mps);
    eprintln!("convergence: the prior's V_crit {prior_v_crit} m/s");
    // the prior is far from the truth: the test is not won at the start
    assert!((prior_v_crit - TABLE_I_V_CRIT).abs() / TABLE_I_V_CRIT > 0.1);
    let mut worst_final: f64 = 0.0;
    let mut worst_time: f64 = 0.0;
    for seed in 0..5 {
        let mut options = ObserverOptions::default();
        options.mass.mean = 1500.0;
        let (mut last_outside, mut final_error) = (0.0, f64::NAN);
        run(options, seed, 60.0, |t, obs, _| {
            let e = obs.estimate();
            let error = e.v_crit_estimate_mps.map_or(f64::INFINITY, |v| {
                (v - TABLE_I_V_CRIT).abs() / TABLE_I_V_CRIT
            });
            if error > 0.05 {
                last_outside = t;
            }
            final_error = error;
        });
        eprintln!(
            "convergence seed {seed}: final V_crit error {:.3} %, within 5 % from {last_outside:.2} s",
            100.0 * final_error
        );
        worst_final = worst_final.max(final_error);
        worst_time = worst_time.max(last_outside);
    }
    assert!(worst_final < 0.05, "V_crit error after 60 s: {worst_final}");
    assert!(worst_time < 60.0, "{worst_time}");
}

/// The frames of 20 s of the driving at 25 m/s from the default sensors of `seed`, with the
/// true state when the gyro sampled.
fn recorded(seed: u64) -> Vec<(Measurement, [f64; 4])> {
    let mut truth = Truth4::new(25.0, driving);
    let mut sensors = Sensors::new(&SensorsConfig {
        seed,
        ..SensorsConfig::default()
    })
    .unwrap();
    let mut past = [[0.0; 4]; 3];
    (0..2000)
        .map(|k| {
            past[k % 3] = truth.x;
            let m = sensors.sample(truth.t, &truth.signals()).expect("a frame");
            truth.advance();
            (m, past[(k + 1) % 3])
        })
        .collect()
}

#[test]
fn bad_input_is_reported_and_the_observer_recovers() {
    // reference: the crate's input rules (detector module docs); recovery: 9.5 s after a
    // gap of 0.5 s the hitch angle is within 4σ of the truth, and the parameters were kept
    // over the gap
    let frames = recorded(3);
    let mut observer = ModelObserver::new(ObserverOptions::default()).unwrap();
    let mut last = None;
    let mut mass_before_gap = f64::NAN;
    for (k, (m, x)) in frames.iter().enumerate() {
        let mut m = *m;
        let expected = match k {
            300 => {
                m.yaw_rate = f64::NAN;
                Some(InputStatus::Invalid)
            }
            310 => {
                m.steering_wheel_angle = f64::INFINITY;
                Some(InputStatus::Invalid)
            }
            320 => {
                m.lateral_acceleration = 1e300;
                Some(InputStatus::Invalid)
            }
            330 => {
                m.speed = f64::NAN;
                Some(InputStatus::Invalid)
            }
            340 => {
                m.t = f64::NAN;
                Some(InputStatus::Invalid)
            }
            400 => {
                m.t -= 0.5;
                Some(InputStatus::OutOfOrder {
                    t: m.t,
                    last_t: frames[399].0.t,
                })
            }
            1000..1050 => continue, // half a second lost
            _ => None,
        };
        if k == 999 {
            mass_before_gap = observer.estimate().trailer_mass.value;
        }
        let out = observer.update(&m);
        match expected {
            Some(status) => {
                assert_eq!(out.status, status, "frame {k}");
                let previous: sway_detect::detector::DetectorOutput = last.unwrap();
                assert_eq!(out.score, previous.score, "frame {k} repeats the output");
            }
            // the frame after an ignored one is two periods after the last used one: a
            // gap by the crate's rule (1.5 periods), from which the observer restarts
            None if matches!(k, 301 | 311 | 321 | 331 | 341 | 401) => {
                assert!(
                    matches!(out.status, InputStatus::Gap { dt_s } if (dt_s - 0.02).abs() < 1e-9),
                    "frame {k}: {:?}",
                    out.status
                );
            }
            None if k == 1050 => {
                assert!(
                    matches!(out.status, InputStatus::Gap { dt_s } if (dt_s - 0.51).abs() < 1e-9),
                    "{:?}",
                    out.status
                );
                let mass = observer.estimate().trailer_mass.value;
                assert!(
                    (mass - mass_before_gap).abs() < 50.0,
                    "{mass} vs {mass_before_gap}"
                );
            }
            None => {
                assert_eq!(out.status, InputStatus::Ok, "frame {k}");
                last = Some(out);
            }
        }
        if k == 1999 {
            let e = observer.estimate();
            let error = (e.hitch_angle - x[2]).abs();
            assert!(error < 4.0 * e.hitch_angle_variance.sqrt(), "{error}");
        }
    }
    // standing still: the observer rests, score 0, no panic
    let standing = Measurement {
        t: 100.0,
        speed: 0.0,
        ..frames[0].0
    };
    let out = observer.update(&standing);
    assert_eq!(out.score, 0.0);
    assert!(!out.flag.is_sway());
}

#[test]
fn same_seed_same_numbers_and_reset_starts_again() {
    // reference: a second observer, and the same one after reset, on the same frames give
    // bit-identical estimates
    let frames = recorded(11);
    let estimates = |observer: &mut ModelObserver| -> Vec<sway_detect::detector::ObserverEstimate> {
        frames
            .iter()
            .map(|(m, _)| {
                observer.update(m);
                observer.estimate()
            })
            .collect()
    };
    let mut a = ModelObserver::new(ObserverOptions::default()).unwrap();
    let mut b = ModelObserver::new(ObserverOptions::default()).unwrap();
    let first = estimates(&mut a);
    assert_eq!(first, estimates(&mut b));
    a.reset();
    assert_eq!(first, estimates(&mut a));
}

#[test]
fn options_read_from_toml_and_bad_values_are_config_errors() {
    // reference: the defaults' own TOML reads back to them; a partial file keeps the other
    // defaults; unknown keys and unphysical values are refused
    let defaults = ObserverOptions::default();
    let text = toml::to_string(&defaults).unwrap();
    assert_eq!(toml::from_str::<ObserverOptions>(&text).unwrap(), defaults);
    let partial: ObserverOptions = toml::from_str(
        "steering_ratio = 15.5\n\
         [mass]\nmean = 1500.0\nsd = 600.0\nrandom_walk = 0.5\nmin = 100.0\nmax = 4000.0\n\
         [car]\nmass = 2000.0\n",
    )
    .unwrap();
    assert_eq!(partial.steering_ratio, 15.5);
    assert_eq!(partial.mass.mean, 1500.0);
    assert_eq!(partial.car.mass, 2000.0);
    assert_eq!(partial.car.yaw_inertia, defaults.car.yaw_inertia);
    assert_eq!(partial.cog, defaults.cog);
    assert!(ModelObserver::new(partial).is_ok());
    assert!(toml::from_str::<ObserverOptions>("steering_rato = 15.0").is_err());
    assert!(toml::from_str::<ObserverOptions>("[v_crit_search]\nv_max = 90.0").is_err());

    let bad = |o: ObserverOptions| ModelObserver::new(o).unwrap_err();
    assert!(matches!(
        bad(ObserverOptions {
            steering_ratio: -1.0,
            ..defaults
        }),
        ConfigError::NotPositive { .. }
    ));
    let mut o = defaults;
    o.mass.mean = 5000.0; // beyond its bound
    assert!(matches!(bad(o), ConfigError::Bounds { key: "mass", .. }));
    let mut o = defaults;
    o.cog.min = 5.0; // above its max
    assert!(matches!(bad(o), ConfigError::Bounds { key: "cog", .. }));
    let mut o = defaults;
    o.yaw_inertia.sd = f64::NAN;
    assert!(matches!(bad(o), ConfigError::Negative { .. }));
    let mut o = defaults;
    o.car.cog = 6.0; // ahead of the front axle
    assert!(matches!(bad(o), ConfigError::Bounds { key: "car.cog", .. }));
    assert!(matches!(
        bad(ObserverOptions {
            v_crit_interval_samples: 0,
            ..defaults
        }),
        ConfigError::OutOfRange { .. }
    ));
    assert!(matches!(
        bad(ObserverOptions {
            steering_delay_samples: 40,
            ..defaults
        }),
        ConfigError::OutOfRange { .. }
    ));
    let mut o = defaults;
    o.v_crit_search.v_max_mps = 0.5;
    assert!(matches!(bad(o), ConfigError::Bounds { .. }));
}

/// The observer's scores over `seconds` of `steering` at `speed` with the default sensors:
/// the largest score, the time of the first flag and the truth's largest hitch angle.
fn scores(speed: f64, seconds: f64, steering: impl Fn(f64) -> f64) -> (f64, Option<f64>, f64) {
    let mut truth = Truth4::new(speed, steering);
    let mut sensors = Sensors::new(&SensorsConfig::default()).unwrap();
    let mut observer = ModelObserver::new(ObserverOptions::default()).unwrap();
    let (mut worst, mut first, mut peak) = (0.0_f64, None, 0.0_f64);
    for _ in 0..(seconds * 100.0).round() as usize {
        let m = sensors.sample(truth.t, &truth.signals()).expect("a frame");
        let out = observer.update(&m);
        worst = worst.max(out.score);
        peak = peak.max(truth.x[2].abs());
        if out.flag.is_sway() && first.is_none() {
            first = Some(truth.t);
        }
        truth.advance();
    }
    (worst, first, peak)
}

#[test]
fn the_slalom_below_v_crit_is_no_sway_and_the_speed_beyond_it_is() {
    // reference: Table I's linear V_crit 34.75 m/s. At 25 m/s the slalom and lane changes
    // and at 30 m/s half of them (forced, explained by the steering; the truth's hitch
    // angle stays below 0.2 rad, checked) never reach the score 1 (at 30 m/s the largest is
    // the speed ratio, 0.87); at 37 m/s (6.5 % beyond V_crit) gentler driving first teaches
    // the observer the trailer, then the speed ratio flags, within the first 20 s. (The full
    // driving at 30 m/s sways the brush model's trailer to 0.8 rad: the nonlinear model is
    // bistable there, and that is sway, flagged.)
    for (speed, scale) in [(25.0, 1.0), (30.0, 0.5)] {
        let (worst, first, peak) = scores(speed, 60.0, |t| scale * driving(t));
        eprintln!("flag: {speed} m/s, largest score {worst:.3}, largest hitch angle {peak:.3} rad");
        assert!(peak < 0.2, "{speed} m/s: the trailer swayed ({peak} rad)");
        assert!(
            first.is_none() && worst < 1.0,
            "{speed} m/s: {worst}, {first:?}"
        );
    }
    let (worst, first, _) = scores(37.0, 20.0, |t| 0.3 * driving(t));
    eprintln!("flag: 37 m/s, largest score {worst:.3}, first flag {first:?}");
    assert!(first.is_some(), "{worst}");
}
