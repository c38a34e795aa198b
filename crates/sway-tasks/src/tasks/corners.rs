//! `cargo xtask corners` (the paper's open question at the end of §IV-B): the
//! sharp corners of the stability chart of the delayed yaw-rate feedback
//! δ(t) = −D·ψ̇(t − τ) (eq. 8). For each delay of `configs/corners.toml`
//! ([`sway::bifurcation::corners`]): every double-Hopf point inside the nonlinear chart's
//! (V, D) box, the Hopf, fold-of-cycles and torus curves near it and the regions they
//! bound (a zoomed figure), and simulations at probe points of every region, classified as
//! equilibrium / periodic / quasi-periodic / loss of control from the hitch-angle spectrum
//! and a Poincaré section (figures of both).
//!
//! `summary.json`: `"double_hopf"` (array of `{"tau_s", "d_s", "v_mps", "omega1_rad_s",
//! "omega2_rad_s", "ratio", …}`), `"double_hopf_beyond_range"` (same, outside the chart's
//! gain range), `"torus_curves"` (per τ: count and D–V extent), `"quasi_periodic_examples"`
//! (τ, D, V and the two frequencies of every run classified quasi-periodic),
//! `"simulations"` (every run with its class and evidence) and `"notes"`.
//! `simulations.csv` holds the same rows; `hopf_near_corner_tau_<τ in ms>ms_<k>_omega_<100ω>.csv`
//! the traced Hopf curves; figures `corner_tau_<τ in ms>ms_<k>` (the zoom) and
//! `evidence_tau_<τ in ms>ms_<k>` (spectra and sections).
//!
//! Any vehicle file: the D-subdivision, the curves, the torus continuation and the
//! simulations run on the vehicle's plant (relaxation, tyre laws, axle lists, hitch torque);
//! a vehicle of the paper's form gives the paper model's numbers.

use std::path::Path;

use serde::Serialize;
use crate::TaskError;
use sway::bifurcation::chart::EndedCurve;
use sway::bifurcation::corners::motion::MotionClass;
pub use sway_studies::corners::{Corners, CornersConfig, ResolvedCorners, compute};
use sway::bifurcation::corners::{
    Corner, CornerStudy, ProbeRun, TorusComparison, TorusCurve, TorusPoint,
};
use sway::charts::auto_range::SpeedBounds;
use sway::config::{ensure, ensure_positive};

use super::chart_nonlinear::validate_chart;
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::{Configured, TaskConfig, check_delays};
use crate::io::OutputDir;
use crate::limits::{Plan, bound, human_seconds};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Shape, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<CornersConfig>(
    "corners",
    "corners of the chart: double-Hopf points, torus curves, quasi-periodic sway (spectra, Poincaré sections)",
    "corners.toml",
)
.any_model();

/// Checks the keys (the derived ones are checked once derived).
///
/// # Errors
/// [`TaskError::Config`] naming the file and key.
pub fn validate(cfg: &CornersConfig, file: &Path) -> Result<(), TaskError> {
        check_delays(file, "delays_s", &cfg.delays_s)?;
        validate_chart(&cfg.chart, file, "chart.")?;
        let o = &cfg.corners;
        if let Some(b) = o.beyond_gain_s {
            ensure(b.is_finite() && b >= 0.0, file, "corners.beyond_gain_s", || {
                format!("expected a gain ≥ 0 s, got {b}")
            })?;
        }
        let s = &o.simulation;
        for (key, v) in [
            ("corners.zoom_half_width_v_mps", o.zoom_half_width_v_mps),
            ("corners.zoom_half_width_d_s", o.zoom_half_width_d_s),
            ("corners.simulation.transient_s", s.transient_s),
            ("corners.simulation.window_s", s.window_s),
            ("corners.simulation.sample_step_s", s.sample_step_s),
        ] {
            ensure_positive(v, file, key, "a positive number")?;
        }
        ensure(
            o.v_samples >= 2 && o.zoom_curve_samples >= 3 && o.zoom_cells >= 2,
            file,
            "corners.v_samples",
            || "expected v_samples ≥ 2, zoom_curve_samples ≥ 3, zoom_cells ≥ 2".into(),
        )?;
        ensure(
            s.window_s >= 64.0 * s.sample_step_s,
            file,
            "corners.simulation.window_s",
            || "the analysis window needs at least 64 samples".into(),
        )?;
        ensure(
            o.probe_radii.iter().all(|r| *r > 0.0 && *r <= 1.0),
            file,
            "corners.probe_radii",
            || "radii are fractions of the zoom window in (0, 1]".into(),
        )?;
        ensure(
            s.kicks_deg.iter().all(|k| k.is_finite() && k.abs() < 90.0),
            file,
            "corners.simulation.kicks_deg",
            || "kicks are hitch angles in (−90°, 90°)".into(),
        )?;
        Ok(s.settings.solver.validate_at(file, "corners.simulation.settings.solver")?)
    }

impl TaskConfig for CornersConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        validate(self, file)
    }
}

/// One entry of `"double_hopf"`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DoubleHopfEntry {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// the lower frequency \[rad/s\]
    pub omega1_rad_s: f64,
    /// the higher frequency \[rad/s\]
    pub omega2_rad_s: f64,
    /// ω2/ω1
    pub ratio: f64,
    /// unstable roots besides the two critical pairs (0: a corner of the stable region)
    pub other_unstable_roots: usize,
    /// |ΔV| to the point the chart's Hopf-curve continuation located \[m/s\] (null: none)
    pub continuation_offset_mps: Option<f64>,
}

/// One entry of `"torus_curves"`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TorusExtent {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// number of torus curves computed near the delay's double-Hopf points
    pub count: usize,
    /// their D range \[s\] (null without curves)
    pub d_range_s: Option<[f64; 2]>,
    /// their V range \[m/s\] (null without curves)
    pub v_range_mps: Option<[f64; 2]>,
    /// every curve
    pub curves: Vec<TorusCurveEntry>,
}

/// One torus curve in `"torus_curves"`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TorusCurveEntry {
    /// index of the double-Hopf point of this delay
    pub corner: usize,
    /// frequency of the cycle family at the double-Hopf point \[rad/s\]
    pub family_omega_rad_s: f64,
    /// frequency of the other mode \[rad/s\]
    pub other_omega_rad_s: f64,
    /// points computed
    pub points: usize,
    /// D range \[s\]
    pub d_range_s: Option<[f64; 2]>,
    /// V range \[m/s\]
    pub v_range_mps: Option<[f64; 2]>,
    /// expected multiplier angle at the double-Hopf point, 2π·ω_other/ω_family reduced
    /// to \[0, π\] \[rad\]
    pub angle_at_double_hopf_rad: f64,
    /// multiplier angle at the first point (amplitude `amplitude`) \[rad\]
    pub first_angle_rad: Option<f64>,
    /// multiplier angle at the last point \[rad\]
    pub last_angle_rad: Option<f64>,
    /// rotation numbers (φ/2π) at the first and last point
    pub rotation_number_range: Option<[f64; 2]>,
    /// the curve continued backwards: distance of its extrapolated end to the
    /// double-Hopf point in V \[m/s\] and D \[s\], and its frequencies (cycle, mode)
    /// \[rad/s\]; null if it did not get there
    pub end_offset_v_mps: Option<f64>,
    /// see `end_offset_v_mps` \[s\]
    pub end_offset_d_s: Option<f64>,
    /// see `end_offset_v_mps` \[rad/s\]
    pub end_omegas_rad_s: Option<[f64; 2]>,
    /// Floquet multipliers outside the unit circle besides the critical pair, smallest
    /// and largest over the curve (0: attracting cycles)
    pub other_unstable_multipliers: Option<[usize; 2]>,
    /// why the continuation stopped
    pub stop: String,
}

/// One entry of `"torus_curve_vs_observed"`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TorusComparisonEntry {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// the comparison
    #[serde(flatten)]
    pub comparison: TorusComparison,
}

/// One entry of `"quasi_periodic_examples"`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct QuasiPeriodicExample {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// initial hitch angle \[deg\]
    pub kick_deg: f64,
    /// the base frequencies \[rad/s\]
    pub omega1_rad_s: f64,
    /// second base frequency \[rad/s\]
    pub omega2_rad_s: f64,
    /// rotation number of the Poincaré section
    pub rotation_number: Option<f64>,
}

/// One row of `"simulations"` / `simulations.csv`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct SimulationRow {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// index of the double-Hopf point of this delay
    pub corner: usize,
    /// where the probe lies: `sector <k>`, `outside torus`, `inside torus`
    pub probe: String,
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// which modes of straight running are unstable there
    pub region: String,
    /// initial hitch angle \[deg\]
    pub kick_deg: f64,
    /// equilibrium / periodic / quasi_periodic / loss_of_control / irregular
    pub class: String,
    /// half peak-to-peak θ, first half of the window \[deg\]
    pub amplitude_first_deg: f64,
    /// half peak-to-peak θ, second half of the window \[deg\]
    pub amplitude_second_deg: f64,
    /// largest spectral peak \[rad/s\]
    pub peak1_rad_s: Option<f64>,
    /// second spectral peak \[rad/s\]
    pub peak2_rad_s: Option<f64>,
    /// number of spectral peaks above the threshold
    pub peaks: usize,
    /// first base frequency \[rad/s\]
    pub omega1_rad_s: Option<f64>,
    /// second base frequency \[rad/s\] (quasi-periodic)
    pub omega2_rad_s: Option<f64>,
    /// ω2/ω1 (quasi-periodic) or the period multiple (periodic)
    pub frequency_ratio: Option<f64>,
    /// section points
    pub section_points: usize,
    /// distinct section values
    pub section_clusters: usize,
    /// the section repeats after this many returns (empty: it does not, a closed curve)
    pub section_period: Option<usize>,
    /// rotation number of the section
    pub rotation_number: Option<f64>,
    /// when control was lost \[s\]
    pub loss_of_control_time_s: Option<f64>,
}

/// One entry of `"observed_torus_boundary"`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObservedTorusEntry {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// initial hitch angle of the scan \[deg\]
    pub kick_deg: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// the largest gain seen periodic \[s\]
    pub d_periodic_s: f64,
    /// the smallest gain seen quasi-periodic \[s\]
    pub d_quasi_periodic_s: f64,
    /// base frequency of the periodic motion just below (which cycle the kick reached)
    /// \[rad/s\]
    pub omega_periodic_rad_s: Option<f64>,
}

/// `summary.json` of corners (before the common fields).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CornersSummary {
    /// where simulations turn quasi-periodic (the torus bifurcation of the large sway
    /// cycles, bisected in D at fixed V)
    pub observed_torus_boundary: Vec<ObservedTorusEntry>,
    /// the continued torus curves (attracting stretches) at the observed speeds
    pub torus_curve_vs_observed: Vec<TorusComparisonEntry>,
    /// every double-Hopf point inside the chart's range
    pub double_hopf: Vec<DoubleHopfEntry>,
    /// double-Hopf points beyond the chart's gain range
    pub double_hopf_beyond_range: Vec<DoubleHopfEntry>,
    /// torus curves per delay
    pub torus_curves: Vec<TorusExtent>,
    /// every run classified quasi-periodic
    pub quasi_periodic_examples: Vec<QuasiPeriodicExample>,
    /// every run
    pub simulations: Vec<SimulationRow>,
    /// what the pipeline noticed
    pub notes: Vec<String>,
    /// curves that ended early and corners that could not be analysed, each with its
    /// `end` (absent: none)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub curves_ended_early: Vec<EndedCurve>,
    /// per delay: the double-Hopf points found in the box, or why there is none
    pub per_tau: Vec<DelayOutcome>,
    /// the box, seeds and `beyond_gain_s` used (derived where the config omits them)
    pub ranges: ResolvedCorners,
}

/// One delay's outcome in `"per_tau"`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DelayOutcome {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// double-Hopf points inside the box
    pub double_hopf_points: usize,
    /// why there is none (absent: there is one)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

fn entry(p: &sway::bifurcation::corners::DoubleHopfPoint, offset: Option<f64>) -> DoubleHopfEntry {
    DoubleHopfEntry {
        tau_s: p.tau_s,
        d_s: p.d_s,
        v_mps: p.v_mps,
        omega1_rad_s: p.omega1_rad_s,
        omega2_rad_s: p.omega2_rad_s,
        ratio: p.ratio,
        other_unstable_roots: p.other_unstable_roots,
        continuation_offset_mps: offset,
    }
}

/// [min, max] of `f` over `pts` (None when empty).
fn range_of(pts: &[TorusPoint], f: fn(&TorusPoint) -> f64) -> Option<[f64; 2]> {
    let lo = pts.iter().map(f).fold(f64::INFINITY, f64::min);
    let hi = pts.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
    (lo <= hi).then_some([lo, hi])
}

fn curve_entry(k: usize, c: &Corner, t: &TorusCurve) -> TorusCurveEntry {
    let counts: Vec<usize> = t
        .points
        .iter()
        .filter_map(|p| p.other_unstable_multipliers)
        .collect();
    TorusCurveEntry {
        corner: k,
        family_omega_rad_s: t.family_omega_rad_s,
        other_omega_rad_s: t.other_omega_rad_s,
        points: t.points.len(),
        d_range_s: range_of(&t.points, |p| p.d_s),
        v_range_mps: range_of(&t.points, |p| p.v_mps),
        angle_at_double_hopf_rad: t.angle_at_double_hopf(),
        first_angle_rad: t.points.first().map(|p| p.multiplier_angle_rad),
        last_angle_rad: t.points.last().map(|p| p.multiplier_angle_rad),
        rotation_number_range: t
            .points
            .first()
            .zip(t.points.last())
            .map(|(a, b)| [a.rotation_number, b.rotation_number]),
        end_offset_v_mps: t.end.map(|e| e.v_mps - c.point.v_mps),
        end_offset_d_s: t.end.map(|e| e.d_s - c.point.d_s),
        end_omegas_rad_s: t.end.map(|e| [e.omega_cycle_rad_s, e.omega_mode_rad_s]),
        other_unstable_multipliers: counts
            .iter()
            .min()
            .zip(counts.iter().max())
            .map(|(a, b)| [*a, *b]),
        stop: t.stop.clone(),
    }
}

fn torus_extent(s: &CornerStudy) -> TorusExtent {
    let pts: Vec<TorusPoint> = s
        .corners
        .iter()
        .flat_map(|c| c.torus_curves.iter())
        .flat_map(|t| t.points.iter().copied())
        .collect();
    TorusExtent {
        tau_s: s.tau_s,
        count: s.corners.iter().map(|c| c.torus_curves.len()).sum(),
        d_range_s: range_of(&pts, |p| p.d_s),
        v_range_mps: range_of(&pts, |p| p.v_mps),
        curves: s
            .corners
            .iter()
            .enumerate()
            .flat_map(|(k, c)| c.torus_curves.iter().map(move |t| curve_entry(k, c, t)))
            .collect(),
    }
}

fn row(tau: f64, k: usize, probe: &sway::bifurcation::corners::Probe, r: &ProbeRun) -> SimulationRow {
    let e = &r.evidence;
    SimulationRow {
        tau_s: tau,
        corner: k,
        probe: probe.label.clone(),
        d_s: probe.d_s,
        v_mps: probe.v_mps,
        region: probe.region(),
        kick_deg: r.kick_deg,
        class: e.class.as_str().into(),
        amplitude_first_deg: e.amplitude_first_half.to_degrees(),
        amplitude_second_deg: e.amplitude_second_half.to_degrees(),
        peak1_rad_s: e.peaks.first().map(|p| p.omega_rad_s),
        peak2_rad_s: e.peaks.get(1).map(|p| p.omega_rad_s),
        peaks: e.peaks.len(),
        omega1_rad_s: e.base_frequencies_rad_s.first().copied(),
        omega2_rad_s: e.base_frequencies_rad_s.get(1).copied(),
        frequency_ratio: e.frequency_ratio,
        section_points: e.section_points,
        section_clusters: e.section_clusters,
        section_period: e.section_period,
        rotation_number: e.section_rotation_number,
        loss_of_control_time_s: r.loss_of_control_time_s,
    }
}

/// The summary of all delays.
pub fn summary(c: &Corners) -> CornersSummary {
    let studies: Vec<&CornerStudy> = c.delays.iter().map(|d| &d.study).collect();
    let mut s = CornersSummary {
        per_tau: c
            .delays
            .iter()
            .map(|d| DelayOutcome {
                tau_s: d.study.tau_s,
                double_hopf_points: d.study.double_hopf.len(),
                reason: d.reason.clone(),
            })
            .collect(),
        ranges: c.resolved.clone(),
        observed_torus_boundary: Vec::new(),
        torus_curve_vs_observed: Vec::new(),
        double_hopf: Vec::new(),
        double_hopf_beyond_range: Vec::new(),
        torus_curves: studies.iter().map(|st| torus_extent(st)).collect(),
        quasi_periodic_examples: Vec::new(),
        simulations: Vec::new(),
        notes: Vec::new(),
        curves_ended_early: Vec::new(),
    };
    for st in studies {
        s.curves_ended_early.extend(st.curves_ended_early.iter().map(|e| EndedCurve {
            curve: format!("τ = {} s: {}", st.tau_s, e.curve),
            end: e.end.clone(),
        }));
        s.double_hopf.extend(
            st.corners
                .iter()
                .map(|c| entry(&c.point, c.continuation_offset_mps)),
        );
        s.double_hopf_beyond_range
            .extend(st.beyond_range.iter().map(|p| entry(p, None)));
        s.notes
            .extend(st.notes.iter().map(|n| format!("τ = {} s: {n}", st.tau_s)));
        for (k, c) in st.corners.iter().enumerate() {
            s.observed_torus_boundary
                .extend(c.observed_torus_boundary.iter().map(|b| ObservedTorusEntry {
                    tau_s: st.tau_s,
                    kick_deg: b.kick_deg,
                    v_mps: b.v_mps,
                    d_periodic_s: b.d_periodic_s,
                    d_quasi_periodic_s: b.d_quasi_periodic_s,
                    omega_periodic_rad_s: b.omega_periodic_rad_s,
                }));
            s.torus_curve_vs_observed
                .extend(c.torus_comparison.iter().map(|&comparison| TorusComparisonEntry {
                    tau_s: st.tau_s,
                    comparison,
                }));
            for p in &c.probes {
                for r in &p.runs {
                    s.simulations.push(row(st.tau_s, k, p, r));
                    let e = &r.evidence;
                    if e.class == MotionClass::QuasiPeriodic {
                        s.quasi_periodic_examples.push(QuasiPeriodicExample {
                            tau_s: st.tau_s,
                            d_s: p.d_s,
                            v_mps: p.v_mps,
                            kick_deg: r.kick_deg,
                            omega1_rad_s: e.base_frequencies_rad_s[0],
                            omega2_rad_s: e.base_frequencies_rad_s[1],
                            rotation_number: e.section_rotation_number,
                        });
                    }
                }
            }
        }
    }
    s
}

fn class_color(c: MotionClass) -> Rgb {
    match c {
        MotionClass::Equilibrium => Rgb::GREEN,
        MotionClass::Periodic => Rgb::BLUE,
        MotionClass::QuasiPeriodic => Rgb::palette(4),
        MotionClass::LossOfControl => Rgb::RED,
        MotionClass::Irregular => Rgb::BLACK,
    }
}

/// Shading rectangles of the window's cells with `n` unstable roots.
fn cells_with(c: &Corner, n: u32) -> Vec<[f64; 4]> {
    let lin = &c.regions;
    let dv = lin.v.get(1).map_or(1.0, |v1| v1 - lin.v[0]);
    let dd = lin.d.get(1).map_or(1.0, |d1| d1 - lin.d[0]);
    let mut out = Vec::new();
    for (iv, &v) in lin.v.iter().enumerate() {
        for (id, &d) in lin.d.iter().enumerate() {
            if lin.cell(iv, id).unstable_roots == n {
                out.push([v - 0.5 * dv, v + 0.5 * dv, d - 0.5 * dd, d + 0.5 * dd]);
            }
        }
    }
    out
}

fn criticality_name(c: Option<continuation::Criticality>) -> &'static str {
    match c {
        Some(continuation::Criticality::Subcritical) => "subcritical",
        Some(continuation::Criticality::Supercritical) => "supercritical",
        None => "criticality unknown",
    }
}

/// `line` with the points outside the window `w` = \[V0, V1, D0, D1\] replaced by breaks
/// (plotters would draw them on the frame).
fn inside_window(line: Vec<(f64, f64)>, w: [f64; 4]) -> Vec<(f64, f64)> {
    line.into_iter()
        .map(|(v, d)| {
            if v >= w[0] && v <= w[1] && d >= w[2] && d <= w[3] {
                (v, d)
            } else {
                (f64::NAN, f64::NAN)
            }
        })
        .collect()
}

/// The zoomed figure near one corner.
fn corner_panel(c: &Corner) -> Panel {
    let p = &c.point;
    let w = c.window;
    let mut panel = Panel::new(
        &format!(
            "τ = {} s: double Hopf at V = {:.2} m/s, D = {:.4} s",
            p.tau_s, p.v_mps, p.d_s
        ),
        "V [m/s]",
        "D [s]",
    )
    .x_range(w[0], w[1])
    .y_range(w[2], w[3])
    .legend(Legend::UpperLeft);
    for (n, color, label) in [
        (0, Rgb::GREEN, "straight running stable"),
        (2, Rgb::ORANGE, "one pair unstable"),
        (4, Rgb::RED, "two pairs unstable"),
    ] {
        panel = panel.with(Layer::Rects {
            rects: cells_with(c, n),
            color,
            opacity: 0.25,
            label: Some(label.into()),
        });
    }
    for (i, m) in c.mode_curves.iter().enumerate() {
        let stroke = match m.criticality {
            Some(continuation::Criticality::Supercritical) => Stroke::Dashed,
            _ => Stroke::Solid,
        };
        let pts = m.points.iter().map(|q| (q.v_mps, q.d_s)).collect();
        let label = format!(
            "Hopf ω ≈ {:.2} rad/s ({})",
            m.omega_at_corner_rad_s,
            criticality_name(m.criticality)
        );
        let pts = inside_window(pts, w);
        panel = panel.with(Layer::line(pts, Rgb::palette(i), stroke, Some(&label)));
    }
    let mut fold = Vec::new();
    for f in &c.fold_curves {
        fold.push((f64::NAN, f64::NAN));
        fold.extend(f.iter().copied());
    }
    let fold = inside_window(fold, w);
    if fold.iter().any(|p| p.0.is_finite()) {
        panel = panel.with(Layer::line(fold, Rgb::BLUE, Stroke::Dotted, Some("fold of cycles")));
    }
    for (i, t) in c.torus_curves.iter().enumerate() {
        // solid where the cycles are attracting apart from the critical pair (an
        // attracting torus can be born), dashed where they are not
        let color = [Rgb::palette(4), Rgb::palette(5)][i % 2];
        for attracting in [true, false] {
            let stretch = |q: &TorusPoint| (q.other_unstable_multipliers == Some(0)) == attracting;
            let mut pts = Vec::new();
            for pair in t.points.windows(2) {
                if stretch(&pair[0]) && stretch(&pair[1]) {
                    pts.push((pair[0].v_mps, pair[0].d_s));
                    pts.push((pair[1].v_mps, pair[1].d_s));
                } else {
                    pts.push((f64::NAN, f64::NAN));
                }
            }
            let pts = inside_window(pts, w);
            if pts.iter().any(|p| p.0.is_finite()) {
                let label = format!(
                    "torus curve of the ω = {:.2} rad/s cycles ({})",
                    t.family_omega_rad_s,
                    if attracting { "cycles attracting" } else { "cycles unstable" }
                );
                let stroke = if attracting { Stroke::Solid } else { Stroke::Dashed };
                panel = panel.with(Layer::line(pts, color, stroke, Some(&label)));
            }
        }
    }
    let observed: Vec<(f64, f64)> = c
        .observed_torus_boundary
        .iter()
        .map(|b| (b.v_mps, 0.5 * (b.d_periodic_s + b.d_quasi_periodic_s)))
        .collect();
    if !observed.is_empty() {
        panel = panel.with(Layer::Markers {
            points: observed,
            color: Rgb::palette(4),
            shape: Shape::Triangle,
            size: 8,
            label: Some("torus boundary observed in simulations".into()),
        });
    }
    panel = panel.with(Layer::Markers {
        points: vec![(p.v_mps, p.d_s)],
        color: Rgb::BLACK,
        shape: Shape::Cross,
        size: 9,
        label: Some("double Hopf".into()),
    });
    for class in [
        MotionClass::Equilibrium,
        MotionClass::Periodic,
        MotionClass::QuasiPeriodic,
        MotionClass::LossOfControl,
        MotionClass::Irregular,
    ] {
        // a probe is marked with the class of its small kick (its first run)
        let pts: Vec<(f64, f64)> = c
            .probes
            .iter()
            .filter(|q| q.runs.first().is_some_and(|r| r.evidence.class == class))
            .map(|q| (q.v_mps, q.d_s))
            .collect();
        if !pts.is_empty() {
            let label = format!("simulation: {}", class.as_str().replace('_', " "));
            panel = panel.with(Layer::Markers {
                points: pts,
                color: class_color(class),
                shape: Shape::Circle,
                size: 6,
                label: Some(label),
            });
        }
    }
    panel
}

/// The spectrum panel of one run: amplitude in dB below the largest peak.
fn spectrum_panel(tau: f64, q: &sway::bifurcation::corners::Probe, r: &ProbeRun) -> Panel {
    let s = &r.spectrum;
    let top = s.amplitude.iter().copied().fold(0.0, f64::max);
    let pts: Vec<(f64, f64)> = (1..s.amplitude.len())
        .map(|k| (s.omega(k), 20.0 * (s.amplitude[k] / top).max(1e-6).log10()))
        .take_while(|(w, _)| *w <= 25.0)
        .collect();
    let peaks: Vec<(f64, f64)> = r
        .evidence
        .peaks
        .iter()
        .filter(|p| p.omega_rad_s <= 25.0)
        .map(|p| (p.omega_rad_s, 20.0 * (p.amplitude / top).log10()))
        .collect();
    Panel::new(
        &format!(
            "τ = {tau} s, V = {:.2} m/s, D = {:.4} s, θ0 = {}°: {}",
            q.v_mps,
            q.d_s,
            r.kick_deg,
            r.evidence.class.as_str().replace('_', " ")
        ),
        "ω [rad/s]",
        "θ amplitude [dB]",
    )
    .x_range(0.0, 25.0)
    .y_range(-120.0, 5.0)
    .legend(Legend::UpperRight)
    .with(Layer::line(pts, Rgb::BLACK, Stroke::Solid, Some("spectrum (Hann)")))
    .with(Layer::Markers {
        points: peaks,
        color: Rgb::RED,
        shape: Shape::Triangle,
        size: 6,
        label: Some("peaks".into()),
    })
}

/// The Poincaré-section panel of one run: the returns of the window's first half in grey
/// (they may still carry the transient), those of the second half — the ones the section's
/// period is read from — in the class colour.
fn section_panel(r: &ProbeRun) -> Panel {
    let pts: Vec<(f64, f64)> = r
        .section
        .iter()
        .map(|(a, b)| (a.to_degrees(), b.to_degrees()))
        .collect();
    let (first, second) = pts.split_at(pts.len() / 2);
    let rho = r
        .evidence
        .section_rotation_number
        .map_or("–".into(), |x| format!("{x:.4}"));
    let shape = match r.evidence.section_period {
        Some(1) => "a point".to_string(),
        Some(k) => format!("a set of {k} points"),
        None => format!("no repetition, ρ = {rho}"),
    };
    Panel::new(
        &format!(
            "section ψ̇ = 0↑ ({} returns): {shape}",
            r.evidence.section_points
        ),
        "θ [deg]",
        "dθ/dt [deg/s]",
    )
    .with(Layer::Markers {
        points: first.to_vec(),
        color: Rgb::GREY,
        shape: Shape::Circle,
        size: 2,
        label: Some("first half".into()),
    })
    .with(Layer::Markers {
        points: second.to_vec(),
        color: class_color(r.evidence.class),
        shape: Shape::Circle,
        size: 3,
        label: Some("second half".into()),
    })
}

/// The runs shown in the evidence figure: the first of every class, then further
/// quasi-periodic ones, at most `max`.
fn shown_runs(c: &Corner, max: usize) -> Vec<(&sway::bifurcation::corners::Probe, &ProbeRun)> {
    let all: Vec<_> = c
        .probes
        .iter()
        .flat_map(|p| p.runs.iter().map(move |r| (p, r)))
        .filter(|(_, r)| !r.spectrum.amplitude.is_empty())
        .collect();
    let mut out: Vec<_> = Vec::new();
    for (p, r) in &all {
        if !out.iter().any(|(_, q): &(_, &ProbeRun)| q.evidence.class == r.evidence.class) {
            out.push((*p, *r));
        }
    }
    for (p, r) in &all {
        let qp = r.evidence.class == MotionClass::QuasiPeriodic;
        if qp && out.len() < max && !out.iter().any(|(_, q)| std::ptr::eq(*q, *r)) {
            out.push((*p, *r));
        }
    }
    out.truncate(max);
    out
}

/// File-name stem of delay τ: `tau_200ms` (no dot, which would read as an extension).
fn tau_stem(tau: f64) -> String {
    format!("tau_{}ms", (tau * 1000.0).round())
}

fn render(out: &OutputDir, st: &CornerStudy) -> Result<(), TaskError> {
    let tau = st.tau_s;
    let stem = tau_stem(tau);
    for (k, c) in st.corners.iter().enumerate() {
        let panel = corner_panel(c);
        let w = c.window;
        let fold_inside = c
            .fold_curves
            .iter()
            .flatten()
            .any(|&(v, d)| v >= w[0] && v <= w[1] && d >= w[2] && d <= w[3]);
        let title = if !fold_inside {
            "Near the corner (no fold-of-cycles curve in this window)"
        } else {
            "Near the corner: Hopf, fold-of-cycles and torus curves, simulated motion"
        };
        Figure::single(panel)
            .titled(title)
            .render(&out.path(&format!("corner_{stem}_{k}")))?;
        let runs = shown_runs(c, 5);
        let panels: Vec<Panel> = runs
            .iter()
            .flat_map(|(p, r)| [spectrum_panel(tau, p, r), section_panel(r)])
            .collect();
        if !panels.is_empty() {
            let rows = runs.len();
            Figure::grid(panels, rows, 2, (1300, 330 * rows as u32))
                .titled("Hitch-angle spectra and Poincaré sections (θ, dθ/dt at upward zero crossings of ψ̇)")
                .render(&out.path(&format!("evidence_{stem}_{k}")))?;
        }
        for t in &c.torus_curves {
            out.write_table(
                &format!(
                    "torus_curve_{stem}_{k}_omega_{:.0}.csv",
                    100.0 * t.family_omega_rad_s
                ),
                t.points.iter().copied(),
            )?;
        }
        for m in &c.mode_curves {
            out.write_table(
                &format!(
                    "hopf_near_corner_{stem}_{k}_omega_{:.0}.csv",
                    100.0 * m.omega_at_corner_rad_s
                ),
                m.points.iter().copied(),
            )?;
        }
    }
    Ok(())
}

/// corners: the most delays: 16 (default 2).
pub const MAX_DELAYS: usize = 16;
/// corners: the most simulations per double-Hopf point (radii × 4 sectors × kicks): 256.
pub const MAX_RUNS_PER_CORNER: usize = 256;
/// corners: the most simulated seconds of one run: 5 000 s (default 400 s).
pub const MAX_RUN_S: f64 = 5_000.0;
/// corners: the most zoom cells per axis: 400 (default 48).
pub const MAX_ZOOM_CELLS: usize = 400;
/// corners: the nonlinear chart of one delay \[s\] (release, 2 cores; measured ≈ 10 s at
/// τ = 0.4 s with the default box), doubled.
pub const CHART_SECONDS_PER_DELAY: f64 = 20.0;
/// corners: double-Hopf points assumed per delay for the estimate (1 at τ = 0.2 s).
pub const ASSUMED_CORNERS_PER_DELAY: f64 = 2.0;

impl Prepared for Configured<CornersConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let o = &c.corners;
        let file = self.file.as_path();
        let n_tau = c.delays_s.len() as f64;
        bound(file, "delays_s", n_tau, MAX_DELAYS as f64, || "one corner study each".into())?;
        let runs = (o.probe_radii.len() * 4 * o.simulation.kicks_deg.len()) as f64;
        bound(file, "corners.probe_radii", runs, MAX_RUNS_PER_CORNER as f64, || {
            "simulations per corner (radii × 4 × kicks)".into()
        })?;
        let horizon = o.simulation.transient_s + o.simulation.window_s;
        bound(file, "corners.simulation.window_s", horizon, MAX_RUN_S, || {
            "simulated seconds per run (transient + window)".into()
        })?;
        bound(file, "corners.zoom_cells", o.zoom_cells as f64, MAX_ZOOM_CELLS as f64, || {
            "region cells per axis".into()
        })?;
        let samples = horizon / o.simulation.sample_step_s;
        bound(file, "corners.simulation.sample_step_s", samples, crate::limits::MAX_SAMPLES, || {
            "samples per run".into()
        })?;
        let corners = n_tau * ASSUMED_CORNERS_PER_DELAY;
        let sim_s = corners * runs * horizon * crate::limits::SIM_SECONDS_PER_SIM_SECOND;
        let cells = corners * (o.zoom_cells * o.zoom_cells) as f64;
        let time = (n_tau * CHART_SECONDS_PER_DELAY + sim_s + cells * crate::limits::FIG4A_SECONDS_PER_CELL) / 2.0;
        let memory = corners * runs * samples * 8.0 * 8.0 + cells * crate::limits::FIG4A_BYTES_PER_CELL;
        Ok(Plan::new(
            vec![
                format!("corners: {n_tau} delays, each a nonlinear chart and a D-subdivision scan of {} speeds", o.v_samples),
                format!(
                    "per double-Hopf point (≈ {ASSUMED_CORNERS_PER_DELAY} per delay assumed): {runs} simulations of {horizon} s, {} × {} region cells",
                    o.zoom_cells, o.zoom_cells
                ),
                format!("estimated time: {}", human_seconds(time)),
            ],
            memory,
            time,
        ))
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let stage = "corners: double-Hopf points, curves, simulations";
        ctx.run_staged(TASK.name, stage, cfg.delays_s.len() as u64, cfg, &self.file, |out| {
        let bounds = SpeedBounds::from(&ctx.limits);
        let c = trailer_model::with_plant!(&ctx.plant, m => compute(m, cfg, &bounds))?;
        ctx.progress.advance(cfg.delays_s.len() as u64);
        for d in &c.delays {
            render(out, &d.study)?;
        }
        let s = summary(&c);
        out.write_table("simulations.csv", s.simulations.iter().cloned())?;
        let mut lines: Vec<String> = s
            .double_hopf
            .iter()
            .map(|p| {
                format!(
                    "τ = {} s: double Hopf at D = {:.5} s, V = {:.4} m/s, ω = {:.4} / {:.4} rad/s (ratio {:.4})",
                    p.tau_s, p.d_s, p.v_mps, p.omega1_rad_s, p.omega2_rad_s, p.ratio
                )
            })
            .collect();
        for t in &s.torus_curves {
            lines.push(format!("τ = {} s: {} torus curves", t.tau_s, t.count));
        }
        for d in &c.delays {
            if let Some(r) = &d.reason {
                lines.push(format!("τ = {} s: {r}", d.study.tau_s));
            }
        }
        lines.push(format!(
            "{} simulations, {} quasi-periodic",
            s.simulations.len(),
            s.quasi_periodic_examples.len()
        ));
        for e in &s.curves_ended_early {
            lines.push(format!("{} {}", e.curve, e.end.describe()));
        }
        Ok((s, lines))
        })
    }
}
