//! The computation of `lateral_stability`: the lateral stability test of car–trailer
//! combinations as test engineers run it (ISO 9815, pulse steer), on the model.
//!
//! At each test speed the combination runs straight, gets one steering impulse
//! ([`SteeringInput::Pulse`]) and the wheel is then held straight; the damping ratio
//! D = δ/√(4π² + δ²) is read from the logarithmic decrement δ of successive peaks of the
//! hitch angle θ ([`sway::sim::decay`]). The test's critical speed is where a straight
//! line through D(V) reaches D = 0 — what an engineer extrapolates — beside the true V_crit
//! (the Hopf point) and V_fold (the fold of cycles) of the bifurcation diagram.
//!
//! The test's blind spot: in the bistable range V_fold < V < V_crit a small impulse decays
//! (D > 0) while a large one triggers sway. The local damping between successive peaks
//! against their amplitude, D(A), over a family of impulses crosses zero at the amplitude of
//! the unstable sway cycle; [`compute`] reports that amplitude beside the cycle's max |θ|
//! from continuation, and the smallest impulse of the family that triggers sway.

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::bifurcation::{Diagram, DiagramSettings};
use sway::parallel::{Split, try_map};
use sway::progress::Progress;
use sway::ranging::{RelativeSpeed, SpeedLimits, SpeedReferences, SpeedSpec, corrected_diagram};
use sway::sim::decay::{Decay, Peak, decay, local_damping, peaks};
use sway::sim::{
    LoopLaw, Outcome, PulseShape, Recording, RunSettings, SimSpec, SpeedProfile, SteeringInput,
    SwayClass, simulate_in_paper_layout,
};
use sway_model::vehicle::Vehicle;
use trailer_model::{AnyVehicleModel, HITCH_ANGLE, State4};

/// The steering impulse of the test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PulseConfig {
    /// `half_sine`, `triangle` or `rectangle`
    pub shape: PulseShape,
    /// when the impulse starts \[s\] (straight running before)
    pub start_s: f64,
    /// its duration \[s\]
    pub duration_s: f64,
    /// the small impulse's peak front-wheel steering angle \[deg\] (the damping per speed)
    pub amplitude_deg: f64,
}

impl Default for PulseConfig {
    fn default() -> Self {
        Self {
            shape: PulseShape::HalfSine,
            start_s: 0.5,
            duration_s: 0.4,
            amplitude_deg: 0.05,
        }
    }
}

impl PulseConfig {
    /// The steering input of an impulse of `amplitude_deg` \[deg\] of this shape and timing.
    pub fn input(&self, amplitude_deg: f64) -> SteeringInput {
        SteeringInput::Pulse {
            shape: self.shape,
            start_s: self.start_s,
            duration_s: self.duration_s,
            amplitude_rad: amplitude_deg.to_radians(),
        }
    }
}

/// The test (the task's config without the vehicle).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LateralStabilityConfig {
    /// the test speeds, in m/s or relative to the vehicle (`{ of_v_crit = f }`,
    /// `{ in_bistable = f }`); the default runs from V_crit/2 to above V_crit with four
    /// speeds inside the bistable range
    pub speeds: Vec<SpeedSpec>,
    /// the impulse
    pub pulse: PulseConfig,
    /// peaks skipped after the impulse before the decrement is read (the fast mode dies
    /// out meanwhile)
    pub skip_peaks: usize,
    /// periods averaged (each between a peak and the next of the same sign)
    pub periods: usize,
    /// the family of impulse amplitudes for D(A) \[deg of front-wheel angle\]
    pub amplitudes_deg: Vec<f64>,
    /// simulated time per run \[s\]
    pub horizon_s: f64,
    /// sampling of the runs \[s\]
    pub sample_step_s: f64,
    /// the bifurcation diagram (V_crit, V_fold, the unstable cycles); its range derived from
    /// the vehicle where it gives none
    pub diagram: DiagramSettings,
}

impl Default for LateralStabilityConfig {
    fn default() -> Self {
        let of_v_crit = |f| SpeedSpec::Relative(RelativeSpeed::OfVCrit(f));
        let in_bistable = |f| SpeedSpec::Relative(RelativeSpeed::InBistable(f));
        Self {
            speeds: vec![
                of_v_crit(0.5),
                of_v_crit(0.6),
                of_v_crit(0.7),
                of_v_crit(0.8),
                in_bistable(0.2),
                in_bistable(0.4),
                in_bistable(0.6),
                in_bistable(0.8),
                of_v_crit(1.02),
                of_v_crit(1.05),
            ],
            pulse: PulseConfig::default(),
            skip_peaks: 2,
            periods: 3,
            amplitudes_deg: vec![0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0, 8.0],
            horizon_s: 40.0,
            sample_step_s: 0.005,
            diagram: DiagramSettings::default(),
        }
    }
}

/// One test speed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpeedRow {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// D of the small impulse \[-\] (None: too few peaks, with `reason`)
    pub damping_ratio: Option<f64>,
    /// the frequency of the sway \[Hz\]
    pub frequency_hz: Option<f64>,
    /// the peaks the decrement read (two more than the periods averaged)
    pub peaks_used: usize,
    /// the amplitude where the local damping D(A) of the family crosses zero \[deg\]
    pub zero_damping_amplitude_deg: Option<f64>,
    /// the unstable sway cycle's max |θ| from continuation \[deg\]
    pub unstable_cycle_amplitude_deg: Option<f64>,
    /// the smallest impulse of the family that ends in sustained sway or loss of control
    /// \[deg of steering\]
    pub triggering_impulse_deg: Option<f64>,
    /// why a value is None
    pub reason: Option<String>,
    /// the local damping points (amplitude \[deg\], D) of the family, for the figure
    #[serde(skip)]
    pub local_damping: Vec<(f64, f64)>,
}

/// A run's trace for the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// (t \[s\], θ \[deg\])
    pub theta_deg: Vec<(f64, f64)>,
    /// (t \[s\], δ \[deg\])
    pub steering_deg: Vec<(f64, f64)>,
    /// the peaks the decrement used (t \[s\], θ \[deg\])
    pub peaks_used_deg: Vec<(f64, f64)>,
}

/// What the test gives.
#[derive(Debug, Clone, PartialEq)]
pub struct LateralStability {
    /// per test speed
    pub speeds: Vec<SpeedRow>,
    /// the speeds the config gives that the vehicle does not have, with the reason
    pub unresolved: Vec<(String, String)>,
    /// the straight line D = a + b·V through the small-impulse dampings: (a, b)
    pub fit: Option<(f64, f64)>,
    /// where it reaches D = 0 \[m/s\] (None: fewer than two dampings, or D does not fall)
    pub test_critical_speed_mps: Option<f64>,
    /// the open loop's V_crit (Hopf point) \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// the fold of cycles \[m/s\]
    pub v_fold_mps: Option<f64>,
    /// by how much the test's critical speed exceeds the lowest speed at which a kick can
    /// trigger sway (V_fold, else V_crit) \[m/s\]
    pub overestimate_mps: Option<f64>,
    /// one run of the small impulse (the test speed nearest V_crit below it)
    pub trace: Option<Trace>,
}

/// One impulse's run, sampled.
struct ImpulseRun {
    /// t \[s\]
    t: Vec<f64>,
    /// θ \[rad\]
    theta: Vec<f64>,
    /// δ \[rad\]
    steering: Vec<f64>,
    /// sustained sway or loss of control
    sways: bool,
}

/// Runs one impulse of `amplitude_deg` at `speed`.
fn run(
    vehicle: &AnyVehicleModel,
    cfg: &LateralStabilityConfig,
    speed: f64,
    amplitude_deg: f64,
) -> Result<ImpulseRun, SwayError> {
    let spec = SimSpec {
        early_stop: sway::sim::EarlyStop::Never,
        steering: cfg.pulse.input(amplitude_deg),
        profile: SpeedProfile::Constant { speed_mps: speed },
        controller: None::<LoopLaw>,
        horizon_s: cfg.horizon_s,
        action_s: cfg.pulse.start_s,
        settings: RunSettings::default(),
    };
    let r = simulate_in_paper_layout::<4>(
        vehicle,
        &spec,
        State4::zeros(),
        Recording::Every {
            step_s: cfg.sample_step_s,
        },
    )?;
    Ok(ImpulseRun {
        t: r.trajectory.iter().map(|s| s.t).collect(),
        theta: r.trajectory.iter().map(|s| s.x[HITCH_ANGLE]).collect(),
        steering: r.trajectory.iter().map(|s| s.steering_angle).collect(),
        sways: r.metrics.outcome != Outcome::Ok || r.metrics.class == SwayClass::SustainedSway,
    })
}

/// The peaks of θ after the impulse (prominence: 1e-6 of the largest |θ|).
fn theta_peaks(t: &[f64], theta: &[f64], after_s: f64) -> Vec<Peak> {
    let scale = theta.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    peaks(t, theta, after_s, 1e-6 * scale)
}

/// The small impulse's decay at `speed`.
fn small_impulse(
    vehicle: &AnyVehicleModel,
    cfg: &LateralStabilityConfig,
    speed: f64,
) -> Result<(Option<Decay>, Trace), SwayError> {
    let ImpulseRun {
        t,
        theta,
        steering: delta,
        ..
    } = run(vehicle, cfg, speed, cfg.pulse.amplitude_deg)?;
    let after = cfg.pulse.start_s + cfg.pulse.duration_s;
    let p = theta_peaks(&t, &theta, after);
    let d = decay(&p, cfg.skip_peaks, cfg.periods);
    let used = p
        .iter()
        .skip(cfg.skip_peaks)
        .take(cfg.periods + 2)
        .map(|q| (q.t, q.value.to_degrees()))
        .collect();
    let deg = |ys: &[f64]| {
        t.iter()
            .zip(ys)
            .map(|(&a, &b)| (a, b.to_degrees()))
            .collect()
    };
    Ok((
        d,
        Trace {
            speed_mps: speed,
            theta_deg: deg(&theta),
            steering_deg: deg(&delta),
            peaks_used_deg: used,
        },
    ))
}

/// The family of impulses at one speed: the local damping points (amplitude \[deg\], D)
/// of all runs, sorted by amplitude, and the smallest impulse that triggers sway.
struct Family {
    points: Vec<(f64, f64)>,
    triggering_deg: Option<f64>,
}

/// Runs the family of impulses at `speed`.
fn family(
    vehicle: &AnyVehicleModel,
    cfg: &LateralStabilityConfig,
    speed: f64,
) -> Result<Family, SwayError> {
    let after = cfg.pulse.start_s + cfg.pulse.duration_s;
    let runs = try_map(&cfg.amplitudes_deg, Split::OnePerTask, &|_, &a| {
        run(vehicle, cfg, speed, a)
    })?;
    let mut points = Vec::new();
    let mut triggering = None;
    for (&a, r) in cfg.amplitudes_deg.iter().zip(&runs) {
        let p = theta_peaks(&r.t, &r.theta, after);
        // from the first peak after the fast mode has died out
        let tail = p.get(cfg.skip_peaks..).unwrap_or(&[]);
        points.extend(
            local_damping(tail)
                .into_iter()
                .map(|(amp, d)| (amp.to_degrees(), d)),
        );
        if r.sways && triggering.is_none_or(|b: f64| a < b) {
            triggering = Some(a);
        }
    }
    points.sort_by(|x, y| x.0.total_cmp(&y.0));
    Ok(Family {
        points,
        triggering_deg: triggering,
    })
}

/// The amplitude where D(A) changes sign from positive (small amplitudes decay) to negative
/// (large ones grow), interpolated linearly between the two points around the first such
/// change that stays negative beyond; None without one.
fn zero_damping_amplitude(points: &[(f64, f64)]) -> Option<f64> {
    points.windows(2).find_map(|w| {
        let ((a0, d0), (a1, d1)) = (w[0], w[1]);
        (d0 > 0.0 && d1 <= 0.0 && a1 > a0).then(|| a0 + d0 * (a1 - a0) / (d0 - d1))
    })
}

/// The least-squares line D = a + b·V through the points, and where it reaches 0 if it
/// falls.
fn fit_line(points: &[(f64, f64)]) -> Option<((f64, f64), Option<f64>)> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (sxx, sxy) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (x - mx), b + (x - mx) * (y - my))
    });
    if sxx == 0.0 {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    Some(((a, b), (b < 0.0).then(|| -a / b)))
}

/// The open loop's diagram and its corrected V_crit and V_fold ([`corrected_diagram`]).
fn diagram_on<P: Vehicle<N>, const N: usize>(
    model: &P,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
) -> Result<(Option<Diagram>, SpeedReferences), SwayError> {
    Ok(
        match corrected_diagram(model, LoopLaw::OPEN_LOOP, settings, limits)? {
            Ok(c) => (Some(*c.diagram), c.references),
            Err(n) => (
                None,
                SpeedReferences {
                    v_crit_mps: None,
                    v_fold_mps: None,
                    reason: Some(n.reason),
                },
            ),
        },
    )
}

/// The unstable cycle's max |θ| at `speed` \[deg\] (the smallest unstable cycle there).
fn unstable_cycle<P: Vehicle<N>, const N: usize>(
    model: &P,
    d: &Diagram,
    speed: f64,
) -> Result<Option<f64>, SwayError> {
    Ok(d.cycles_at(model, speed)?
        .iter()
        .filter(|c| !c.stable)
        .map(|c| c.amplitude_deg)
        .min_by(f64::total_cmp))
}

/// Runs the test on `vehicle` (any model variant; the open loop); `progress` advances by
/// one per test speed.
///
/// # Errors
/// [`SwayError::Numerical`] when the diagram or a run fails.
pub fn compute(
    cfg: &LateralStabilityConfig,
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<LateralStability, SwayError> {
    let (diagram, refs) =
        trailer_model::with_plant!(vehicle, m => diagram_on(m, &cfg.diagram, limits))?;
    let mut unresolved = Vec::new();
    let mut speeds: Vec<f64> = Vec::new();
    for spec in &cfg.speeds {
        match spec.resolve(&refs) {
            Ok(v) => speeds.push(v),
            Err(e) => unresolved.push((format!("{spec:?}"), e.reason)),
        }
    }
    speeds.sort_by(f64::total_cmp);
    let (v_crit, v_fold) = (refs.v_crit_mps, refs.v_fold_mps);
    let mut rows = Vec::with_capacity(speeds.len());
    let mut trace: Option<Trace> = None;
    for &v in &speeds {
        let (small, run_trace) = small_impulse(vehicle, cfg, v)?;
        if v_crit.is_some_and(|vc| v < vc) || v_crit.is_none() {
            trace = Some(run_trace);
        }
        let Family {
            points,
            triggering_deg: triggering,
        } = family(vehicle, cfg, v)?;
        let bistable = matches!((v_fold, v_crit), (Some(f), Some(c)) if v > f && v < c);
        let (zero, cycle, reason) = if bistable {
            let cycle = match &diagram {
                Some(d) => trailer_model::with_plant!(vehicle, m => unstable_cycle(m, d, v))?,
                None => None,
            };
            let zero = zero_damping_amplitude(&points);
            let reason = zero
                .is_none()
                .then(|| "the family's local damping does not cross zero".to_string());
            (zero, cycle, reason)
        } else {
            (
                None,
                None,
                Some("outside the bistable range: no unstable sway cycle".to_string()),
            )
        };
        let reason = match (&small, reason) {
            (None, _) => Some("too few peaks after the impulse".to_string()),
            (_, r) => r,
        };
        rows.push(SpeedRow {
            speed_mps: v,
            damping_ratio: small.map(|d| d.damping_ratio),
            frequency_hz: small.map(|d| d.frequency_hz),
            peaks_used: small.map_or(0, |d| d.periods_used + 2),
            zero_damping_amplitude_deg: zero,
            unstable_cycle_amplitude_deg: cycle,
            triggering_impulse_deg: triggering,
            reason,
            local_damping: points,
        });
        progress.advance(1);
    }
    let below: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| v_crit.is_none_or(|vc| r.speed_mps < vc))
        .filter_map(|r| r.damping_ratio.map(|d| (r.speed_mps, d)))
        .collect();
    let fitted = fit_line(&below);
    let test_v = fitted.and_then(|(_, v)| v);
    let lowest_unsafe = v_fold.or(v_crit);
    Ok(LateralStability {
        speeds: rows,
        unresolved,
        fit: fitted.map(|(l, _)| l),
        test_critical_speed_mps: test_v,
        v_crit_mps: v_crit,
        v_fold_mps: v_fold,
        overestimate_mps: test_v.zip(lowest_unsafe).map(|(t, l)| t - l),
        trace,
    })
}

/// How a recording is read ([`analyse_recording`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordingAnalysis {
    /// the steering angle above which the impulse has started \[rad\] (a fraction of its
    /// peak: 5 % by default)
    pub impulse_fraction: f64,
    /// cut-off of the zero-phase low-pass applied to the read signal \[Hz\] (well above the
    /// sway frequency of ≈ 0.5–1 Hz, well below sensor noise)
    pub low_pass_hz: f64,
    /// the prominence a peak needs, as a fraction of the largest |signal| after the
    /// impulse \[-\]
    pub prominence_fraction: f64,
    /// peaks skipped after the impulse ends
    pub skip_peaks: usize,
    /// periods averaged
    pub periods: usize,
}

impl Default for RecordingAnalysis {
    fn default() -> Self {
        Self {
            impulse_fraction: 0.05,
            low_pass_hz: 3.0,
            prominence_fraction: 0.05,
            skip_peaks: 2,
            periods: 3,
        }
    }
}

/// What one recording shows.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedDecay {
    /// when the impulse started and ended \[s\]
    pub impulse_s: (f64, f64),
    /// the damping read from the filtered signal's peaks
    pub decay: Decay,
    /// the peaks used (t \[s\], value of the filtered signal)
    pub peaks_used: Vec<(f64, f64)>,
}

/// Reads the damping of one recorded pulse-steer run: `t` \[s\] increasing, `steering`
/// \[rad\] and the read `signal` (θ or a yaw rate, any unit) sampled at `t`. The impulse is
/// where |steering| first exceeds `impulse_fraction` of its largest value until it falls
/// back below; the signal after it is low-passed forwards and backwards (zero phase) and
/// its peaks of sufficient prominence give the decrement.
///
/// # Errors
/// A message naming the problem: too few samples, non-increasing time, a non-finite
/// sample, no impulse, too few peaks.
pub fn analyse_recording(
    t: &[f64],
    steering: &[f64],
    signal: &[f64],
    how: &RecordingAnalysis,
) -> Result<RecordedDecay, String> {
    let n = t.len();
    if n < 10 || steering.len() != n || signal.len() != n {
        return Err(format!(
            "expected at least 10 samples of time, steering and signal of equal length, got {}, {} and {}",
            n,
            steering.len(),
            signal.len()
        ));
    }
    if let Some(i) =
        (1..n).find(|&i| t[i].partial_cmp(&t[i - 1]) != Some(std::cmp::Ordering::Greater))
    {
        return Err(format!(
            "time does not increase at row {i} ({} after {})",
            t[i],
            t[i - 1]
        ));
    }
    for (name, v) in [("time", t), ("steering", steering), ("signal", signal)] {
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(format!("{name} is not finite at row {i}"));
        }
    }
    let peak = steering.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let threshold = how.impulse_fraction * peak;
    let start = steering
        .iter()
        .position(|v| v.abs() > threshold && peak > 0.0);
    let Some(start) = start else {
        return Err("no steering impulse found (the steering angle is zero)".into());
    };
    let end = (start..n)
        .find(|&i| steering[i].abs() <= threshold)
        .ok_or("the steering impulse does not end within the recording")?;
    let filtered = sway::sim::decay::low_pass(t, signal, how.low_pass_hz);
    let after = &filtered[end..];
    let scale = after.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let p = peaks(t, &filtered, t[end], how.prominence_fraction * scale);
    let d = decay(&p, how.skip_peaks, how.periods).ok_or_else(|| {
        format!(
            "too few peaks after the impulse: {} found, {} needed (skip {} and average {} periods)",
            p.len(),
            how.skip_peaks + how.periods + 2,
            how.skip_peaks,
            how.periods
        )
    })?;
    Ok(RecordedDecay {
        impulse_s: (t[start], t[end]),
        decay: d,
        peaks_used: p
            .iter()
            .skip(how.skip_peaks)
            .take(how.periods + 2)
            .map(|q| (q.t, q.value))
            .collect(),
    })
}
