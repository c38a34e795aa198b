//! `cargo xtask lateral_stability`: the lateral stability test of car–trailer
//! combinations (ISO 9815, pulse steer) on the model, and its blind spot
//! ([`sway_studies::lateral_stability`]).
//!
//! `summary.json`: `"speeds"`, an array of `{"speed_mps", "steering_amplitude_deg",
//! "peak_lateral_acceleration_mps2", "damping_ratio", "frequency_hz", "peaks_used",
//! "zero_damping_amplitude_deg", "unstable_cycle_amplitude_deg",
//! "stable_cycle_amplitude_deg", "triggering_impulse_deg", "reason"}` (the damping of the
//! test's impulse; the amplitude where the impulses' local damping crosses zero beside the
//! sway cycle's, null with the `reason` where there is none); `"signal"`;
//! `"test_critical_speed_mps"` (the fit of D(V) over the decaying runs extrapolated to
//! D = 0; `"fit"` its kind and coefficients), `"v_crit_mps"`, `"v_fold_mps"` (null with
//! `"reason"`, and `"stable_up_to_mps"` when straight running is stable on the whole
//! range) and `"overestimate_mps"` (the test's speed minus V_fold, the lowest speed at
//! which a kick can trigger sway). `speeds.csv` holds the rows; `lateral_stability.svg/.png`
//! the figure: D against V with the fit, V_crit and V_fold; D(A) per speed with the sway
//! cycles' amplitudes; one run's trace with the impulse and the peaks used.
//!
//! With `--recording FILE` (repeatable) the task reads recorded runs instead
//! ([`crate::recording`]; [`recordings`]) and writes `results/lateral_stability_recordings/`.

use std::path::{Path, PathBuf};

use serde::Serialize;
use sway::config::{ensure, ensure_positive};
use sway_studies::lateral_stability::{
    DecaySignal, FitResult, LateralStability, LateralStabilityConfig, RecordingAnalysis,
    RecordingProblem, SpeedRow, analyse_recording, compute, decaying_runs, fit_damping,
};

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig};
use crate::limits::{MAX_SIMULATIONS, Plan, bound, human_seconds};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};
use crate::recording::{RecordedRun, read_recording};

/// The task.
pub const TASK: Task = Task::configured::<LateralStabilityConfig>(
    "lateral_stability",
    "the lateral stability test (ISO 9815 pulse steer): damping vs speed, the test's critical speed, and what it misses in the bistable range; --recording FILE reads recorded runs",
    "lateral_stability.toml",
)
.any_model();

/// The results directory of the recordings' analysis.
pub const RECORDINGS_NAME: &str = "lateral_stability_recordings";

/// Seconds of one 40 s run on one core (measured ≈ 2 ms in release).
const SECONDS_PER_RUN: f64 = 0.003;

/// The largest steering angle of an impulse \[deg\].
const MAX_STEERING_DEG: f64 = 30.0;

impl TaskConfig for LateralStabilityConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        let p = &self.pulse;
        let angle = |key: &str, a: f64| {
            ensure(a.is_finite() && a > 0.0 && a < MAX_STEERING_DEG, file, key, || {
                format!("expected a steering angle in (0, {MAX_STEERING_DEG}) deg, got {a}")
            })
        };
        angle("pulse.amplitude_deg", p.amplitude_deg)?;
        if let Some(a) = p.peak_lateral_acceleration_mps2 {
            ensure(
                a.is_finite() && a > 0.0 && a <= 15.0,
                file,
                "pulse.peak_lateral_acceleration_mps2",
                || format!("expected a lateral acceleration in (0, 15] m/s², got {a}"),
            )?;
        }
        // the pulse's times as every steering input checks them (its amplitude, in this
        // task's degrees, is checked above)
        p.input(p.amplitude_deg)
            .validate()
            .map_err(|(k, problem)| TaskError::config(file, format!("pulse.{k}"), problem))?;
        for (i, a) in self.amplitudes_deg.iter().enumerate() {
            angle(&format!("amplitudes_deg[{i}]"), *a)?;
        }
        ensure(self.periods >= 1, file, "periods", || {
            "expected at least one period".into()
        })?;
        ensure(!self.speeds.is_empty(), file, "speeds", || {
            "expected at least one test speed".into()
        })?;
        ensure_positive(self.horizon_s, file, "horizon_s", "a horizon > 0 s")?;
        ensure_positive(self.sample_step_s, file, "sample_step_s", "a step > 0 s")?;
        ensure(p.end_s() < self.horizon_s, file, "horizon_s", || {
            "expected the impulse to end before the horizon".into()
        })?;
        self.controller
            .validate()
            .map_err(|(k, problem)| TaskError::config(file, format!("controller.{k}"), problem))?;
        let r = &self.recording;
        for (key, v, hi) in [
            ("recording.impulse_fraction", r.impulse_fraction, 1.0),
            ("recording.prominence_fraction", r.prominence_fraction, 1.0),
        ] {
            ensure(v.is_finite() && v > 0.0 && v < hi, file, key, || {
                format!("expected a fraction in (0, 1), got {v}")
            })?;
        }
        ensure_positive(r.low_pass_hz, file, "recording.low_pass_hz", "a cut-off > 0 Hz")?;
        bound(
            file,
            "sample_step_s",
            self.horizon_s / self.sample_step_s,
            1e6,
            || "samples per run; raise sample_step_s".into(),
        )
    }

    fn load_named_files(&mut self, file: &Path) -> Result<(), TaskError> {
        crate::config_file::load_prediction_vehicle(&mut self.controller, file, "controller")
    }
}

/// A config speed the vehicle does not have.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unresolved {
    speed: String,
    reason: String,
}

/// `summary.json` of `lateral_stability` (before the common fields): [`summary`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    speeds: Vec<SpeedRow>,
    signal: DecaySignal,
    test_critical_speed_mps: Option<f64>,
    v_crit_mps: Option<f64>,
    v_fold_mps: Option<f64>,
    overestimate_mps: Option<f64>,
    /// why V_crit or V_fold is null
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<String>,
    /// without V_crit: stable up to here
    #[serde(skip_serializing_if = "Option::is_none")]
    stable_up_to_mps: Option<f64>,
    /// the fit of D(V) over the decaying runs
    fit: Option<FitResult>,
    /// test speeds of the config the vehicle does not have, with the reason
    #[serde(skip_serializing_if = "Vec::is_empty")]
    unresolved_speeds: Vec<Unresolved>,
}

#[derive(Debug, Clone, Default, Serialize)]
struct CsvRow {
    speed_mps: f64,
    steering_amplitude_deg: f64,
    peak_lateral_acceleration_mps2: Option<f64>,
    damping_ratio: Option<f64>,
    frequency_hz: Option<f64>,
    peaks_used: usize,
    zero_damping_amplitude_deg: Option<f64>,
    unstable_cycle_amplitude_deg: Option<f64>,
    stable_cycle_amplitude_deg: Option<f64>,
    triggering_impulse_deg: Option<f64>,
}

/// The fit as a curve from `from` to where it reaches zero (or to `to`).
fn fit_curve(fit: &FitResult, from: f64, to: f64) -> Vec<(f64, f64)> {
    let end = fit.zero_speed_mps.unwrap_or(to);
    (0..=40)
        .map(|k| {
            let v = from + (end - from) * k as f64 / 40.0;
            let d = fit
                .coefficients
                .iter()
                .rev()
                .fold(0.0, |acc, c| acc * v + c);
            (v, d)
        })
        .collect()
}

/// D against V with the fit and, where known, V_crit and V_fold.
fn damping_panel(
    points: Vec<(f64, f64)>,
    fit: Option<&FitResult>,
    references: &[(Option<f64>, &str, Rgb)],
    label: &str,
) -> Panel {
    let (lo, hi) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let (v0, v_max) = points
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let mut panel = Panel::new("Damping ratio vs speed", "speed V [m/s]", "damping ratio D [-]")
        .with(Layer::markers(points, Rgb::BLUE, Some(label)))
        .legend(Legend::UpperRight);
    let mut right = v_max;
    if let Some(f) = fit {
        let curve = fit_curve(f, v0, v_max);
        right = right.max(curve.last().map_or(v_max, |p| p.0));
        let label = match f.zero_speed_mps {
            Some(vt) => format!("fit: test critical speed {vt:.2} m/s"),
            None => "fit (does not reach D = 0)".to_string(),
        };
        panel
            .layers
            .push(Layer::line(curve, Rgb::BLUE, Stroke::Dashed, Some(&label)));
    }
    for &(v, label, color) in references {
        if let Some(v) = v {
            right = right.max(v);
            panel.layers.push(Layer::vline(
                v,
                (lo.min(0.0), hi.max(0.0)),
                color,
                Stroke::Dashed,
                Some(&format!("{label} {v:.2} m/s")),
            ));
        }
    }
    panel.layers.push(Layer::line(
        vec![(v0.min(right) * 0.95, 0.0), (right * 1.02, 0.0)],
        Rgb::GREY,
        Stroke::Dotted,
        None,
    ));
    panel
}

/// The local damping D(A) per speed with a sway cycle, with the cycles from continuation.
fn amplitude_panel(r: &LateralStability) -> Panel {
    let mut panel = Panel::new(
        "Impulses of rising size: local damping vs amplitude",
        "amplitude of θ over one period [deg]",
        "local damping ratio D [-]",
    )
    .legend(Legend::UpperRight);
    let mut a_max = 0.0f64;
    let with_cycle = r.speeds.iter().filter(|s| {
        s.unstable_cycle_amplitude_deg.is_some() || s.stable_cycle_amplitude_deg.is_some()
    });
    for (k, s) in with_cycle.enumerate() {
        let pts: Vec<(f64, f64)> = s
            .local_damping
            .iter()
            .copied()
            .filter(|(a, d)| a.is_finite() && d.is_finite() && *a < 30.0)
            .collect();
        a_max = pts.iter().fold(a_max, |m, p| m.max(p.0));
        let color = Rgb::palette(k);
        panel.layers.push(Layer::markers(
            pts,
            color,
            Some(&format!("V = {:.2} m/s", s.speed_mps)),
        ));
        for (c, stroke) in [
            (s.unstable_cycle_amplitude_deg, Stroke::Dashed),
            (s.stable_cycle_amplitude_deg, Stroke::Solid),
        ] {
            if let Some(c) = c.filter(|c| *c < 30.0) {
                panel
                    .layers
                    .push(Layer::vline(c, (-0.05, 0.05), color, stroke, None));
            }
        }
    }
    panel.layers.push(Layer::line(
        vec![(0.0, 0.0), (a_max, 0.0)],
        Rgb::GREY,
        Stroke::Dotted,
        Some("D = 0; dashed: unstable cycles, solid: stable cycles (continuation)"),
    ));
    panel
}

/// One run's signal with the steering (scaled onto it) and the peaks used.
fn trace_panel(
    title: &str,
    signal: (&str, &str),
    values: Vec<(f64, f64)>,
    steering: &[(f64, f64)],
    peaks: Vec<(f64, f64)>,
) -> Panel {
    let amplitude = |v: &[(f64, f64)]| v.iter().fold(0.0f64, |m, p| m.max(p.1.abs()));
    let (sig, st) = (amplitude(&values), amplitude(steering));
    let scale = if st > 0.0 { sig / st } else { 1.0 };
    Panel::new(title, "time t [s]", &format!("{} [{}]", signal.0, signal.1))
        .with(Layer::line(values, Rgb::BLUE, Stroke::Solid, Some(signal.0)))
        .with(Layer::line(
            steering.iter().map(|&(a, b)| (a, b * scale)).collect(),
            Rgb::GREY,
            Stroke::Dashed,
            Some(&format!("steering × {scale:.3}")),
        ))
        .with(Layer::markers(peaks, Rgb::RED, Some("peaks used")))
        .legend(Legend::UpperRight)
}

/// The signal's name in a figure.
fn signal_label(s: DecaySignal) -> &'static str {
    match s {
        DecaySignal::HitchAngle => "hitch angle θ",
        DecaySignal::TrailerYawRate => "trailer yaw rate",
        DecaySignal::CarYawRate => "car yaw rate",
        DecaySignal::RearmostArticulationAngle => "rearmost articulation angle",
    }
}

/// A number or a dash.
fn fmt(v: Option<f64>) -> String {
    v.map_or("–".to_string(), |v| format!("{v:.3}"))
}

/// The headline: the test's critical speed against V_crit and V_fold.
fn headline(test: Option<f64>, r: &LateralStability) -> String {
    let verdict = match r.overestimate_mps {
        Some(o) if o >= 0.0 => format!("the test overestimates the safe speed by {o:.3} m/s"),
        Some(o) => format!("the test is conservative by {:.3} m/s", -o),
        None => "no comparison".to_string(),
    };
    format!(
        "test critical speed {} m/s (D(V) extrapolated to 0) vs V_crit {} m/s and V_fold {} m/s: {verdict}",
        fmt(test),
        fmt(r.v_crit_mps),
        fmt(r.v_fold_mps),
    )
}

impl Prepared for Configured<LateralStabilityConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let per_speed = 1.0
            + c.amplitudes_deg.len() as f64
            + if c.pulse.peak_lateral_acceleration_mps2.is_some() {
                3.0
            } else {
                0.0
            };
        let runs = c.speeds.len() as f64 * per_speed;
        let time = runs * SECONDS_PER_RUN * c.horizon_s / 40.0 + 1.0;
        bound(&self.file, "amplitudes_deg", runs, MAX_SIMULATIONS as f64, || {
            format!("{runs} runs, ≈ {}", human_seconds(time))
        })?;
        Ok(Plan::new(
            vec![format!(
                "lateral_stability: {} speeds × (1 + {} impulses) = {runs} runs of {} s, and the diagram",
                c.speeds.len(),
                c.amplitudes_deg.len(),
                c.horizon_s
            )],
            runs * c.horizon_s / c.sample_step_s * 24.0,
            time,
        ))
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let steps = cfg.speeds.len() as u64;
        ctx.run_staged(TASK.name, "lateral stability test", steps, cfg, &self.file, |out| {
            let r = compute(cfg, &ctx.plant, &ctx.limits, ctx.progress)?;
            out.write_table(
                "speeds.csv",
                r.speeds.iter().map(|s| CsvRow {
                    speed_mps: s.speed_mps,
                    steering_amplitude_deg: s.steering_amplitude_deg,
                    peak_lateral_acceleration_mps2: s.peak_lateral_acceleration_mps2,
                    damping_ratio: s.damping_ratio,
                    frequency_hz: s.frequency_hz,
                    peaks_used: s.peaks_used,
                    zero_damping_amplitude_deg: s.zero_damping_amplitude_deg,
                    unstable_cycle_amplitude_deg: s.unstable_cycle_amplitude_deg,
                    stable_cycle_amplitude_deg: s.stable_cycle_amplitude_deg,
                    triggering_impulse_deg: s.triggering_impulse_deg,
                }),
            )?;
            figure(&r).render(&out.path("lateral_stability"))?;
            let mut lines = vec![headline(r.test_critical_speed_mps, &r)];
            for s in r.speeds.iter().filter(|s| s.zero_damping_amplitude_deg.is_some()) {
                let (cycle, kind) = match s.unstable_cycle_amplitude_deg {
                    Some(c) => (Some(c), "unstable"),
                    None => (s.stable_cycle_amplitude_deg, "stable"),
                };
                lines.push(format!(
                    "V = {:.2} m/s: D = {}, zero damping at {}° vs the {kind} cycle's {}°; smallest impulse that triggers sway {}°",
                    s.speed_mps,
                    fmt(s.damping_ratio),
                    fmt(s.zero_damping_amplitude_deg),
                    fmt(cycle),
                    fmt(s.triggering_impulse_deg)
                ));
            }
            if let Some(why) = &r.reference_reason {
                lines.push(why.clone());
            }
            let summary = summary(cfg, &r);
            Ok((summary, lines))
        })
    }
}

/// The summary of a test `r` run with `cfg`, as `summary.json` has it.
pub fn summary(cfg: &LateralStabilityConfig, r: &LateralStability) -> Summary {
    Summary {
        speeds: r.speeds.clone(),
        signal: cfg.signal,
        test_critical_speed_mps: r.test_critical_speed_mps,
        v_crit_mps: r.v_crit_mps,
        v_fold_mps: r.v_fold_mps,
        overestimate_mps: r.overestimate_mps,
        reason: r.reference_reason.clone(),
        stable_up_to_mps: r.stable_up_to_mps,
        fit: r.fit.clone(),
        unresolved_speeds: r
            .unresolved
            .iter()
            .map(|(speed, reason)| Unresolved {
                speed: speed.clone(),
                reason: reason.clone(),
            })
            .collect(),
    }
}

/// The task's figure: D(V) with the fit, D(A), and one run's trace.
fn figure(r: &LateralStability) -> Figure {
    let points = r
        .speeds
        .iter()
        .filter_map(|s| s.damping_ratio.map(|d| (s.speed_mps, d)))
        .collect();
    let mut panels = vec![
        damping_panel(
            points,
            r.fit.as_ref(),
            &[
                (r.v_crit_mps, "V_crit (Hopf)", Rgb::RED),
                (r.v_fold_mps, "V_fold (fold of cycles)", Rgb::palette(2)),
            ],
            "test runs",
        ),
        amplitude_panel(r),
    ];
    panels.push(threshold_panel(r));
    if let Some(t) = &r.trace {
        panels.push(trace_panel(
            &format!("The test impulse at V = {:.2} m/s", t.speed_mps),
            (signal_label(t.signal), t.signal.unit()),
            t.values.clone(),
            &t.steering_deg,
            t.peaks_used.clone(),
        ));
    }
    Figure::grid(panels, 2, 2, (1600, 1150))
}

/// The blind spot over speed: the amplitude at which the impulses' damping crosses zero
/// against the sway cycles' amplitudes from continuation.
fn threshold_panel(r: &LateralStability) -> Panel {
    let series = |f: fn(&SpeedRow) -> Option<f64>| -> Vec<(f64, f64)> {
        r.speeds
            .iter()
            .filter_map(|s| f(s).map(|a| (s.speed_mps, a)))
            .collect()
    };
    let mut panel = Panel::new(
        "Where the test's damping turns: amplitude vs speed",
        "speed V [m/s]",
        "max |θ| [deg]",
    )
    .with(Layer::line(
        series(|s| s.unstable_cycle_amplitude_deg),
        Rgb::RED,
        Stroke::Dashed,
        Some("unstable sway cycle (continuation)"),
    ))
    .with(Layer::line(
        series(|s| s.stable_cycle_amplitude_deg),
        Rgb::GREEN,
        Stroke::Solid,
        Some("stable sway cycle (continuation)"),
    ))
    .with(Layer::markers(
        series(|s| s.zero_damping_amplitude_deg),
        Rgb::BLUE,
        Some("impulses: local damping D(A) = 0"),
    ))
    .legend(Legend::UpperLeft);
    let top = r
        .speeds
        .iter()
        .flat_map(|s| [s.unstable_cycle_amplitude_deg, s.stable_cycle_amplitude_deg])
        .flatten()
        .fold(1.0f64, f64::max);
    if let Some(v) = r.v_crit_mps {
        panel.layers.push(Layer::vline(
            v,
            (0.0, top),
            Rgb::GREY,
            Stroke::Dotted,
            Some(&format!("V_crit {v:.2} m/s")),
        ));
    }
    panel
}

// ---------------------------------------------------------------------------------------
// Recordings
// ---------------------------------------------------------------------------------------

/// The analysis of recorded runs: the task's config (its analysis settings) and the files.
#[derive(Debug)]
pub struct Recordings {
    /// the config file
    pub file: PathBuf,
    /// its contents, checked
    pub config: LateralStabilityConfig,
    /// the recordings
    pub recordings: Vec<PathBuf>,
}

/// Loads and checks the config `file` for reading `recordings` (the files themselves are
/// read when the task runs: one bad recording does not stop the others).
///
/// # Errors
/// [`TaskError::Read`] / [`TaskError::Config`] naming the config file and key; a
/// [`TaskError::Config`] without recordings.
pub fn recordings(file: &Path, recordings: &[PathBuf]) -> Result<Recordings, TaskError> {
    let config: LateralStabilityConfig = super::load_checked(file)?;
    ensure(!recordings.is_empty(), file, "--recording", || {
        "expected at least one recording".into()
    })?;
    Ok(Recordings {
        file: file.to_path_buf(),
        config,
        recordings: recordings.to_vec(),
    })
}

/// One recording's result (a row of `recordings.csv` and of the summary).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
struct RecordingRow {
    file: String,
    /// the signal read
    signal: Option<DecaySignal>,
    /// the mean speed from the impulse's end to the last peak used \[m/s\]
    speed_mps: Option<f64>,
    damping_ratio: Option<f64>,
    frequency_hz: Option<f64>,
    peaks_used: Option<usize>,
    impulse_start_s: Option<f64>,
    impulse_end_s: Option<f64>,
    /// why the recording gives no damping
    error: Option<String>,
}

/// A recording's filtered signal, steering and peaks used (t \[s\], deg or deg/s), for the
/// figure.
struct RecordingTrace {
    values: Vec<(f64, f64)>,
    steering: Vec<(f64, f64)>,
    peaks: Vec<(f64, f64)>,
    signal: DecaySignal,
}

/// A recording read and analysed.
struct Analysed {
    row: RecordingRow,
    trace: RecordingTrace,
}

/// The problem of `run` as the task reports it: the file and the line of the row.
fn recording_error(run: &RecordedRun, signal: DecaySignal, p: &RecordingProblem) -> TaskError {
    let (place, problem) = match p {
        RecordingProblem::TimeNotIncreasing { row, t, previous } => (
            format!("line {}, column `time`", run.line(*row)),
            format!("time does not increase ({t} s after {previous} s)"),
        ),
        RecordingProblem::NotFinite { column, row } => {
            let name = match *column {
                "steering" => "steering_angle",
                "signal" => signal.as_str(),
                c => c,
            };
            (
                format!("line {}, column `{name}`", run.line(*row)),
                "not a finite number".to_string(),
            )
        }
        p => ("analysis".to_string(), p.to_string()),
    };
    TaskError::Recording {
        file: run.file.clone(),
        place,
        problem,
    }
}

/// Reads and analyses one recording.
fn analyse_file(file: &Path, cfg: &LateralStabilityConfig) -> Result<Analysed, TaskError> {
    let run = read_recording(file)?;
    let (signal, values) = run.signal(cfg.signal);
    let how = RecordingAnalysis::from(cfg);
    let rec = analyse_recording(&run.time_s, &run.steering_rad, values, &how)
        .map_err(|p| recording_error(&run, signal, &p))?;
    if let Some(i) = run.speed_mps.iter().position(|v| !v.is_finite()) {
        return Err(recording_error(
            &run,
            signal,
            &RecordingProblem::NotFinite {
                column: "speed",
                row: i,
            },
        ));
    }
    let last = rec.peaks_used.last().map_or(rec.impulse_s.1, |p| p.0);
    let window: Vec<f64> = run
        .time_s
        .iter()
        .zip(&run.speed_mps)
        .filter(|(t, _)| **t >= rec.impulse_s.1 && **t <= last)
        .map(|(_, v)| *v)
        .collect();
    let speed = window.iter().sum::<f64>() / window.len().max(1) as f64;
    let to_unit = |v: f64| v.to_degrees();
    let series = |ys: &[f64]| -> Vec<(f64, f64)> {
        run.time_s
            .iter()
            .zip(ys)
            .map(|(&t, &y)| (t, to_unit(y)))
            .collect()
    };
    Ok(Analysed {
        row: RecordingRow {
            file: file.display().to_string(),
            signal: Some(signal),
            speed_mps: Some(speed),
            damping_ratio: Some(rec.decay.damping_ratio),
            frequency_hz: Some(rec.decay.frequency_hz),
            peaks_used: Some(rec.decay.periods_used + 2),
            impulse_start_s: Some(rec.impulse_s.0),
            impulse_end_s: Some(rec.impulse_s.1),
            error: None,
        },
        trace: RecordingTrace {
            values: series(&rec.filtered),
            steering: series(&run.steering_rad),
            peaks: rec
                .peaks_used
                .iter()
                .map(|&(t, y)| (t, to_unit(y)))
                .collect(),
            signal,
        },
    })
}

/// `summary.json` of the recordings' analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
struct RecordingsSummary {
    recordings: Vec<RecordingRow>,
    analysed: usize,
    failed: usize,
    test_critical_speed_mps: Option<f64>,
    fit: Option<FitResult>,
}

impl Prepared for Recordings {
    fn plan(&self) -> Result<Plan, TaskError> {
        Ok(Plan::new(
            vec![format!(
                "lateral_stability: {} recording(s) → {RECORDINGS_NAME}/",
                self.recordings.len()
            )],
            1e6,
            0.1 * self.recordings.len() as f64,
        ))
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let steps = self.recordings.len() as u64;
        let analysed: Vec<Result<Analysed, TaskError>> = self
            .recordings
            .iter()
            .map(|f| {
                let a = analyse_file(f, cfg);
                ctx.progress.advance(1);
                a
            })
            .collect();
        if analysed.iter().all(Result::is_err) {
            let errors: Vec<String> = analysed
                .iter()
                .filter_map(|a| a.as_ref().err().map(ToString::to_string))
                .collect();
            return Err(TaskError::Recording {
                file: self.recordings[0].clone(),
                place: "every recording".into(),
                problem: format!("none could be analysed:\n  {}", errors.join("\n  ")),
            });
        }
        ctx.run_staged(RECORDINGS_NAME, "recordings", steps, cfg, &self.file, |out| {
            let mut rows = Vec::new();
            let mut trace = None;
            let mut lines = Vec::new();
            for (file, a) in self.recordings.iter().zip(analysed) {
                match a {
                    Ok(a) => {
                        // the trace of the run that decays slowest: the most peaks to see
                        let d = a.row.damping_ratio.unwrap_or(f64::INFINITY);
                        if trace.as_ref().is_none_or(|(best, _, _)| d < *best) {
                            trace = Some((d, file.display().to_string(), a.trace));
                        }
                        rows.push(a.row);
                    }
                    Err(e) => {
                        lines.push(format!("skipped: {e}"));
                        rows.push(RecordingRow {
                            file: file.display().to_string(),
                            error: Some(e.to_string()),
                            ..RecordingRow::default()
                        });
                    }
                }
            }
            let runs = decaying_runs(rows.iter().filter_map(|r| r.speed_mps.map(|v| (v, r.damping_ratio))));
            let fit = fit_damping(&runs, cfg.fit);
            let test_v = fit.as_ref().and_then(|f| f.zero_speed_mps);
            out.write_table("recordings.csv", rows.iter().cloned())?;
            let points = rows
                .iter()
                .filter_map(|r| r.speed_mps.zip(r.damping_ratio))
                .collect();
            let mut panels = vec![damping_panel(
                points,
                fit.as_ref(),
                &[],
                "recorded runs",
            )];
            if let Some((_, name, t)) = trace {
                let file_name = Path::new(&name)
                    .file_name()
                    .map_or(name.clone(), |f| f.to_string_lossy().into_owned());
                panels.push(trace_panel(
                    &format!("{file_name} (low-passed)"),
                    (signal_label(t.signal), t.signal.unit()),
                    t.values,
                    &t.steering,
                    t.peaks,
                ));
            }
            let n = panels.len();
            Figure::grid(panels, 1, n, (600 * n as u32, 560)).render(&out.path("recordings"))?;
            let analysed = rows.iter().filter(|r| r.error.is_none()).count();
            lines.insert(
                0,
                format!(
                    "{analysed} of {} recording(s) analysed; test critical speed {} m/s (fit of D(V) over the decaying runs extrapolated to 0)",
                    rows.len(),
                    fmt(test_v)
                ),
            );
            for r in rows.iter().filter(|r| r.error.is_none()) {
                lines.push(format!(
                    "{}: V = {} m/s, D = {}, f = {} Hz",
                    r.file,
                    fmt(r.speed_mps),
                    fmt(r.damping_ratio),
                    fmt(r.frequency_hz)
                ));
            }
            let failed = rows.len() - analysed;
            Ok((
                RecordingsSummary {
                    recordings: rows,
                    analysed,
                    failed,
                    test_critical_speed_mps: test_v,
                    fit,
                },
                lines,
            ))
        })
    }
}
