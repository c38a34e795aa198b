//! `cargo xtask lateral_stability`: the lateral stability test of car–trailer
//! combinations (ISO 9815, pulse steer) on the model, and its blind spot
//! ([`sway_studies::lateral_stability`]).
//!
//! `summary.json`: `"speeds"`, an array of `{"speed_mps", "damping_ratio", "frequency_hz",
//! "peaks_used", "zero_damping_amplitude_deg", "unstable_cycle_amplitude_deg",
//! "triggering_impulse_deg", "reason"}` (the damping of the small impulse; the amplitude
//! where the impulses' local damping crosses zero beside the unstable sway cycle's, null
//! with the `reason` outside the bistable range); `"test_critical_speed_mps"` (the straight
//! line through D(V) below V_crit extrapolated to D = 0), `"v_crit_mps"`, `"v_fold_mps"`
//! and `"overestimate_mps"` (the test's speed minus V_fold, the lowest speed at which a
//! kick can trigger sway). `speeds.csv` holds the rows; `lateral_stability.svg/.png` the
//! figure: D against V with the fit, V_crit and V_fold; D(A) per speed with the unstable
//! cycles' amplitudes; one run's trace with the impulse and the peaks used.

use std::path::Path;

use serde::Serialize;
use sway::config::{ensure, ensure_positive};
use sway_studies::lateral_stability::{LateralStability, LateralStabilityConfig, SpeedRow, compute};

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig};
use crate::limits::{MAX_SIMULATIONS, Plan, bound, human_seconds};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<LateralStabilityConfig>(
    "lateral_stability",
    "the lateral stability test (ISO 9815 pulse steer): damping vs speed, the test's critical speed, and what it misses in the bistable range",
    "lateral_stability.toml",
)
.any_model();

/// Seconds of one 40 s run on one core (measured ≈ 2 ms in release).
const SECONDS_PER_RUN: f64 = 0.003;

impl TaskConfig for LateralStabilityConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        let p = &self.pulse;
        ensure(
            p.amplitude_deg.is_finite() && p.amplitude_deg > 0.0 && p.amplitude_deg < 30.0,
            file,
            "pulse.amplitude_deg",
            || format!("expected a steering angle in (0, 30) deg, got {}", p.amplitude_deg),
        )?;
        // the pulse's times as every steering input checks them (its amplitude, in this
        // task's degrees, is checked above)
        p.input(p.amplitude_deg)
            .validate()
            .map_err(|(k, problem)| TaskError::config(file, format!("pulse.{k}"), problem))?;
        for (i, a) in self.amplitudes_deg.iter().enumerate() {
            ensure(
                a.is_finite() && *a > 0.0 && *a < 30.0,
                file,
                &format!("amplitudes_deg[{i}]"),
                || format!("expected a steering angle in (0, 30) deg, got {a}"),
            )?;
        }
        ensure(self.periods >= 1, file, "periods", || {
            "expected at least one period".into()
        })?;
        ensure(!self.speeds.is_empty(), file, "speeds", || {
            "expected at least one test speed".into()
        })?;
        ensure_positive(self.horizon_s, file, "horizon_s", "a horizon > 0 s")?;
        ensure_positive(self.sample_step_s, file, "sample_step_s", "a step > 0 s")?;
        ensure(
            p.start_s + p.duration_s < self.horizon_s,
            file,
            "horizon_s",
            || "expected the impulse to end before the horizon".into(),
        )?;
        bound(
            file,
            "sample_step_s",
            self.horizon_s / self.sample_step_s,
            1e6,
            || "samples per run; raise sample_step_s".into(),
        )
    }
}

/// `summary.json` of `lateral_stability` (before the common fields).
#[derive(Debug, Clone, PartialEq, Serialize)]
struct Summary {
    speeds: Vec<SpeedRow>,
    test_critical_speed_mps: Option<f64>,
    v_crit_mps: Option<f64>,
    v_fold_mps: Option<f64>,
    overestimate_mps: Option<f64>,
    /// the fitted line D = intercept + slope·V below V_crit
    fit_intercept: Option<f64>,
    fit_slope_per_mps: Option<f64>,
    /// test speeds of the config the vehicle does not have, with the reason
    #[serde(skip_serializing_if = "Vec::is_empty")]
    unresolved_speeds: Vec<(String, String)>,
}

#[derive(Debug, Clone, Default, Serialize)]
struct CsvRow {
    speed_mps: f64,
    damping_ratio: Option<f64>,
    frequency_hz: Option<f64>,
    peaks_used: usize,
    zero_damping_amplitude_deg: Option<f64>,
    unstable_cycle_amplitude_deg: Option<f64>,
    triggering_impulse_deg: Option<f64>,
}

/// Panel 1: D against V with the fit, V_crit and V_fold.
fn damping_panel(r: &LateralStability) -> Panel {
    let points: Vec<(f64, f64)> = r
        .speeds
        .iter()
        .filter_map(|s| s.damping_ratio.map(|d| (s.speed_mps, d)))
        .collect();
    let (lo, hi) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let v_max = points.iter().fold(0.0f64, |m, p| m.max(p.0));
    let mut panel = Panel::new(
        "Small impulse: damping ratio vs speed",
        "speed V [m/s]",
        "damping ratio D [-]",
    )
    .with(Layer::markers(points, Rgb::BLUE, Some("test (small impulse)")))
    .with(Layer::line(
        vec![(0.0, 0.0), (v_max * 1.05, 0.0)],
        Rgb::GREY,
        Stroke::Dotted,
        None,
    ))
    .legend(Legend::UpperRight);
    if let (Some((a, b)), Some(vt)) = (r.fit, r.test_critical_speed_mps) {
        let v0 = r.speeds.first().map_or(0.0, |s| s.speed_mps);
        panel.layers.push(Layer::line(
            vec![(v0, a + b * v0), (vt, 0.0)],
            Rgb::BLUE,
            Stroke::Dashed,
            Some(&format!("fit: test critical speed {vt:.2} m/s")),
        ));
    }
    for (v, label, color) in [
        (r.v_crit_mps, "V_crit (Hopf)", Rgb::RED),
        (r.v_fold_mps, "V_fold (fold of cycles)", Rgb::palette(2)),
    ] {
        if let Some(v) = v {
            panel.layers.push(Layer::line(
                vec![(v, lo.min(0.0)), (v, hi.max(0.0))],
                color,
                Stroke::Dashed,
                Some(&format!("{label} {v:.2} m/s")),
            ));
        }
    }
    panel
}

/// Panel 2: the local damping D(A) per bistable speed with the unstable cycles.
fn amplitude_panel(r: &LateralStability) -> Panel {
    let mut panel = Panel::new(
        "Impulses of rising size: local damping vs amplitude",
        "amplitude of θ between two peaks [deg]",
        "local damping ratio D [-]",
    )
    .legend(Legend::UpperRight);
    let mut a_max = 0.0f64;
    for (k, s) in r
        .speeds
        .iter()
        .filter(|s| s.unstable_cycle_amplitude_deg.is_some())
        .enumerate()
    {
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
        if let Some(c) = s.unstable_cycle_amplitude_deg {
            panel.layers.push(Layer::line(
                vec![(c, -0.05), (c, 0.05)],
                color,
                Stroke::Dashed,
                None,
            ));
        }
    }
    panel.layers.push(Layer::line(
        vec![(0.0, 0.0), (a_max, 0.0)],
        Rgb::GREY,
        Stroke::Dotted,
        Some("D = 0; dashed: unstable cycles (continuation)"),
    ));
    panel
}

/// Panel 3: one run's trace with the impulse and the peaks used.
fn trace_panel(r: &LateralStability) -> Option<Panel> {
    let t = r.trace.as_ref()?;
    let scale = {
        let th = t.theta_deg.iter().fold(0.0f64, |m, p| m.max(p.1.abs()));
        let de = t.steering_deg.iter().fold(0.0f64, |m, p| m.max(p.1.abs()));
        if de > 0.0 { th / de } else { 1.0 }
    };
    Some(
        Panel::new(
            &format!("The small impulse at V = {:.2} m/s", t.speed_mps),
            "time t [s]",
            "hitch angle θ [deg]",
        )
        .with(Layer::line(
            t.theta_deg.clone(),
            Rgb::BLUE,
            Stroke::Solid,
            Some("θ"),
        ))
        .with(Layer::line(
            t.steering_deg.iter().map(|&(a, b)| (a, b * scale)).collect(),
            Rgb::GREY,
            Stroke::Dashed,
            Some(&format!("steering δ × {scale:.2}")),
        ))
        .with(Layer::markers(
            t.peaks_used_deg.clone(),
            Rgb::RED,
            Some("peaks used"),
        ))
        .legend(Legend::UpperRight),
    )
}

impl Prepared for Configured<LateralStabilityConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let runs = c.speeds.len() as f64 * (1.0 + c.amplitudes_deg.len() as f64);
        let time = runs * SECONDS_PER_RUN * c.horizon_s / 40.0 + 1.0;
        bound(&self.file, "amplitudes_deg", runs, MAX_SIMULATIONS as f64, || {
            format!("{runs} runs, ≈ {}", human_seconds(time))
        })?;
        Ok(Plan::new(
            vec![format!(
                "lateral_stability: {} speeds × (1 + {} impulses) = {runs} runs of {} s, and the open-loop diagram",
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
                    damping_ratio: s.damping_ratio,
                    frequency_hz: s.frequency_hz,
                    peaks_used: s.peaks_used,
                    zero_damping_amplitude_deg: s.zero_damping_amplitude_deg,
                    unstable_cycle_amplitude_deg: s.unstable_cycle_amplitude_deg,
                    triggering_impulse_deg: s.triggering_impulse_deg,
                }),
            )?;
            let mut panels = vec![damping_panel(&r), amplitude_panel(&r)];
            panels.extend(trace_panel(&r));
            let n = panels.len();
            Figure::grid(panels, 1, n, (600 * n as u32, 560)).render(&out.path("lateral_stability"))?;
            let fmt = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.3}"));
            let mut lines = vec![format!(
                "test critical speed {} m/s (D(V) extrapolated to 0) vs V_crit {} m/s and V_fold {} m/s: the test overestimates the safe speed by {} m/s",
                fmt(r.test_critical_speed_mps),
                fmt(r.v_crit_mps),
                fmt(r.v_fold_mps),
                fmt(r.overestimate_mps)
            )];
            for s in r.speeds.iter().filter(|s| s.unstable_cycle_amplitude_deg.is_some()) {
                lines.push(format!(
                    "V = {:.2} m/s: D = {}, zero damping at {}° vs the unstable cycle's {}°; smallest impulse that triggers sway {}°",
                    s.speed_mps,
                    fmt(s.damping_ratio),
                    fmt(s.zero_damping_amplitude_deg),
                    fmt(s.unstable_cycle_amplitude_deg),
                    fmt(s.triggering_impulse_deg)
                ));
            }
            let summary = Summary {
                speeds: r.speeds.clone(),
                test_critical_speed_mps: r.test_critical_speed_mps,
                v_crit_mps: r.v_crit_mps,
                v_fold_mps: r.v_fold_mps,
                overestimate_mps: r.overestimate_mps,
                fit_intercept: r.fit.map(|f| f.0),
                fit_slope_per_mps: r.fit.map(|f| f.1),
                unresolved_speeds: r.unresolved.clone(),
            };
            Ok((summary, lines))
        })
    }
}
