//! The sharp corners of the stability chart (the paper's open question at the end
//! of §IV-B: "quasiperiodic motions are expected in the vicinity of the sharp corners of
//! the stability boundary"): the double-Hopf points of straight running under the delayed
//! yaw-rate feedback δ(t) = −D·ψ̇(t − τ) (eq. 8), the curves that meet there, and what the
//! vehicle does nearby, from simulations classified as equilibrium / periodic /
//! quasi-periodic / loss of control ([`motion`]).
//!
//! Pipeline for one delay τ (no plotting, no I/O):
//! 1. **Double-Hopf points** ([`double_hopf_points`]): the D-subdivision of eq. (13) (the
//!    `fig4a` computation: at each speed V all gains D at which a pair of roots ±iω sits on
//!    the imaginary axis, exact from the phase condition) scanned over the speed range; a
//!    double-Hopf point is where two crossings of *different* frequency have the same D at
//!    the same V. Every sign change of D_a(V) − D_b(V) between scan speeds is refined by
//!    regula falsi in V (the crossings followed by frequency), so intersections of two
//!    different Hopf curves are found wherever they lie, whichever seeds a continuation
//!    started from. A Hopf curve that turns back in V (the tip at τ = 0.4 s) is no
//!    double-Hopf point: both crossings there have the same frequency, and such pairs are
//!    rejected. Each point is checked on the rightmost characteristic roots (an
//!    independent root finder): two pairs on the imaginary axis, and the number of further
//!    unstable roots (0: a corner of the stability region itself).
//! 2. **Near each point** ([`Corner`]): the two Hopf curves traced on the D-subdivision in a
//!    zoom window, their criticality and the fold-of-cycles curves from the nonlinear chart
//!    ([`super::chart`]), the torus (Neimark–Sacker) curves ([`TorusCurve`], from the
//!    `continuation` crate's torus-curve continuation when available), and the regions on
//!    the cells of the linear chart (number of unstable roots 0, 2, 4).
//! 3. **Probes**: points on the bisectors of the sectors between the Hopf curves' half-lines
//!    at the double-Hopf point (one per region, at each configured radius), each simulated
//!    from a small and a large hitch-angle kick ([`crate::sim::simulate`], the closed-loop
//!    DDE) and classified from the hitch angle θ(t) after the transient, with the Poincaré
//!    section θ at the upward zero crossings of the tractor yaw rate ψ̇.

pub mod motion;

use continuation::Criticality;
use serde::{Deserialize, Serialize};
use stability::{Axis, StabilityChart};
use sway_model::vehicle::Vehicle;
use trailer_model::{HITCH_ANGLE, State4};

use self::motion::{MotionClass, MotionEvidence, MotionOptions, Spectrum};
use super::chart::{ChartOptions, CurveEnd, EndedCurve, NonlinearChart, nonlinear_chart};
use crate::SwayError;
use crate::charts::{closed_loop, fig4a_charts, rightmost_roots};
use crate::parallel::{Split, join, map, try_map};
use crate::sim::{LoopLaw, Outcome, Recording, RunSettings, SimSpec, SimulateOwn, SpeedProfile};
use sway_model::vehicle::LoopModel;

/// Settings of the simulations at the probe points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProbeSimulation {
    /// simulated time before the analysis window (transient, discarded) \[s\]
    pub transient_s: f64,
    /// analysis window \[s\] (spectral resolution 2π/window)
    pub window_s: f64,
    /// sampling step of θ and ψ̇ \[s\]
    pub sample_step_s: f64,
    /// initial hitch angles θ(t ≤ 0) \[deg\], one run each (constant history, other states 0)
    pub kicks_deg: Vec<f64>,
    /// guard, tolerances, metrics
    pub settings: RunSettings,
}

impl Default for ProbeSimulation {
    fn default() -> Self {
        Self {
            transient_s: 200.0,
            window_s: 200.0,
            sample_step_s: 0.02,
            kicks_deg: vec![0.5, 5.0],
            settings: RunSettings::default(),
        }
    }
}

/// Options of the corner analysis of one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CornerOptions {
    /// speeds of the D-subdivision scan over the chart's speed range (evenly spaced)
    pub v_samples: usize,
    /// the scan for double-Hopf points beyond the chart's gain range (reported apart):
    /// |D| up to this \[s\] (0: none; omitted: 5·D₁, the half width of `fig4a`'s derived
    /// gain axis, [`crate::charts::auto_range`])
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beyond_gain_s: Option<f64>,
    /// half width of the zoom window in V \[m/s\]
    pub zoom_half_width_v_mps: f64,
    /// half width of the zoom window in D \[s\]
    pub zoom_half_width_d_s: f64,
    /// speeds at which the Hopf curves are traced across the zoom window
    pub zoom_curve_samples: usize,
    /// cells per axis of the region shading in the zoom window
    pub zoom_cells: usize,
    /// probe radii as fractions of the zoom window (scaled so that the window is ±1)
    pub probe_radii: Vec<f64>,
    /// the simulations at the probes
    pub simulation: ProbeSimulation,
    /// the classifier's thresholds
    pub motion: MotionOptions,
    /// the search for attracting quasi-periodic motion by simulation
    pub torus_scan: TorusScan,
    /// the torus-curve continuation from each double-Hopf point (`max_points = 0`: none)
    pub torus_curves: TorusContinuation,
}

/// The search for attracting tori by simulation: at each speed V_HH + offset and for each
/// kick, D is scanned upwards from near the double-Hopf gain and the first change
/// periodic → quasi-periodic is bisected in D (the small kick finds the torus born from the
/// small fast-mode cycles near the double-Hopf point, the large kick the torus bifurcation
/// of the large sway cycles). Independent of the torus-curve continuation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TorusScan {
    /// speeds V_HH + offset \[m/s\] (empty: no scan)
    pub speed_offsets_mps: Vec<f64>,
    /// the scan in D starts at D_HH + this \[s\]
    pub d_start_offset_s: f64,
    /// and ends at D_HH + this \[s\]
    pub d_end_offset_s: f64,
    /// gains of the coarse scan (evenly spaced, ends included)
    pub d_samples: usize,
    /// bisection down to this width in D \[s\]
    pub tolerance_s: f64,
    /// the flanking probes lie this far below and above the bisected boundary \[s\]
    /// (close to the boundary the motion settles slowly)
    pub flank_s: f64,
}

impl Default for TorusScan {
    fn default() -> Self {
        Self {
            speed_offsets_mps: vec![-6.0, -3.0, 0.0, 3.0],
            d_start_offset_s: -0.02,
            d_end_offset_s: 0.1,
            d_samples: 13,
            tolerance_s: 1e-3,
            flank_s: 4e-3,
        }
    }
}

impl Default for CornerOptions {
    fn default() -> Self {
        Self {
            v_samples: 131,
            beyond_gain_s: None,
            zoom_half_width_v_mps: 8.0,
            zoom_half_width_d_s: 0.07,
            zoom_curve_samples: 161,
            zoom_cells: 48,
            probe_radii: vec![0.15, 0.5],
            simulation: ProbeSimulation::default(),
            motion: MotionOptions::default(),
            torus_scan: TorusScan::default(),
            torus_curves: TorusContinuation::default(),
        }
    }
}

/// A double-Hopf point: two pairs of roots ±iω1, ±iω2 on the imaginary axis at once.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DoubleHopfPoint {
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
    /// slopes dD/dV of the Hopf curves of ω1 and ω2 at the point \[s/(m/s)\]
    pub slopes_s_per_mps: [f64; 2],
    /// roots with Re λ > 1e-8 besides the two critical pairs (0: a corner of the stable
    /// region)
    pub other_unstable_roots: usize,
    /// largest |Re λ| of the four critical roots from the rightmost-root finder (a check)
    pub critical_real_part: f64,
}

/// A dynamic crossing of the D-subdivision: gain and frequency.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Crossing {
    d: f64,
    omega: f64,
}

fn num(context: String) -> impl FnOnce(stability::StabilityError) -> SwayError {
    move |e| SwayError::numerical(context, e)
}

/// The dynamic crossings (ω > 0) with |D| ≤ `d_lim` at speed V, sorted by ω.
fn dynamic_crossings<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    v: f64,
    d_lim: f64,
) -> Result<Vec<Crossing>, SwayError> {
    let ctx = || format!("D-subdivision at V = {v} m/s, τ = {tau} s");
    let sys = closed_loop(model, v).map_err(num(ctx()))?;
    let mut out: Vec<Crossing> = sys
        .crossings(tau, d_lim)
        .map_err(num(ctx()))?
        .into_iter()
        .filter(|c| c.omega > 0.0)
        .map(|c| Crossing {
            d: c.d,
            omega: c.omega,
        })
        .collect();
    // comparators in generic functions are `fn` items, not closures: a closure is a new type
    // per plant, and so would be the sort compiled for it
    fn by_frequency(a: &Crossing, b: &Crossing) -> std::cmp::Ordering {
        a.omega.total_cmp(&b.omega)
    }
    out.sort_by(by_frequency);
    Ok(out)
}

/// The crossing whose frequency is nearest to ω, if within `tol` \[rad/s\].
fn nearest(cs: &[Crossing], omega: f64, tol: f64) -> Option<Crossing> {
    cs.iter()
        .copied()
        .min_by(|a, b| (a.omega - omega).abs().total_cmp(&(b.omega - omega).abs()))
        .filter(|c| (c.omega - omega).abs() <= tol)
}

/// Two frequencies count as different modes when they differ by more than 1 %.
fn distinct_modes(w1: f64, w2: f64) -> bool {
    (w1 - w2).abs() > 0.01 * w1.max(w2)
}

/// D_a − D_b at speed V, following the two modes from frequencies (ω_a, ω_b); also returns
/// the crossings found.
fn gap<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    v: f64,
    d_lim: f64,
    (wa, wb): (f64, f64),
) -> Result<Option<(f64, Crossing, Crossing)>, SwayError> {
    let cs = dynamic_crossings(model, tau, v, d_lim)?;
    let tol = 0.25 * (wa - wb).abs();
    Ok(match (nearest(&cs, wa, tol), nearest(&cs, wb, tol)) {
        (Some(a), Some(b)) if a != b => Some((a.d - b.d, a, b)),
        _ => None,
    })
}

/// Regula falsi (Illinois) in V for D_a(V) = D_b(V) inside [v0, v1].
fn refine_intersection<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    d_lim: f64,
    (mut v0, mut v1): (f64, f64),
    (mut wa, mut wb): (f64, f64),
) -> Result<Option<(f64, Crossing, Crossing)>, SwayError> {
    let Some((mut g0, ..)) = gap(model, tau, v0, d_lim, (wa, wb))? else {
        return Ok(None);
    };
    let Some((mut g1, ..)) = gap(model, tau, v1, d_lim, (wa, wb))? else {
        return Ok(None);
    };
    let mut best = None;
    let mut side = 0;
    for _ in 0..100 {
        let v = if g1 != g0 {
            v1 - g1 * (v1 - v0) / (g1 - g0)
        } else {
            0.5 * (v0 + v1)
        };
        let Some((g, a, b)) = gap(model, tau, v, d_lim, (wa, wb))? else {
            return Ok(None);
        };
        (wa, wb) = (a.omega, b.omega);
        best = Some((v, a, b));
        if g == 0.0 || (v1 - v0).abs() < 1e-12 * v.abs().max(1.0) {
            break;
        }
        if g * g1 < 0.0 {
            (v0, g0) = (v1, g1);
            side = 0;
        } else {
            g0 *= if side == 1 { 0.5 } else { 1.0 };
            side = 1;
        }
        (v1, g1) = (v, g);
    }
    Ok(best)
}

/// Sign changes of D_a − D_b between consecutive scan speeds: (bracket, (ω_a, ω_b)).
fn bracketed_intersections(vs: &[f64], cols: &[Vec<Crossing>]) -> Vec<((f64, f64), (f64, f64))> {
    let mut out = Vec::new();
    for j in 0..vs.len().saturating_sub(1) {
        let (c0, c1) = (&cols[j], &cols[j + 1]);
        for (ia, a) in c0.iter().enumerate() {
            for b in &c0[ia + 1..] {
                if !distinct_modes(a.omega, b.omega) {
                    continue;
                }
                let tol = 0.25 * (b.omega - a.omega);
                let (Some(a1), Some(b1)) = (nearest(c1, a.omega, tol), nearest(c1, b.omega, tol))
                else {
                    continue;
                };
                if a1 != b1 && (a.d - b.d) * (a1.d - b1.d) < 0.0 {
                    out.push(((vs[j], vs[j + 1]), (a.omega, b.omega)));
                }
            }
        }
    }
    out
}

/// Every double-Hopf point of delay τ \[s\] with V in `v_range` \[m/s\] and D in `d_range`
/// \[s\] (step 1 of the module documentation), sorted by V. `v_samples` speeds are scanned.
///
/// # Errors
/// [`SwayError::Numerical`] if the D-subdivision or the root check fails.
pub fn double_hopf_points<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    v_range: (f64, f64),
    d_range: (f64, f64),
    v_samples: usize,
) -> Result<Vec<DoubleHopfPoint>, SwayError> {
    let d_lim = 1.5 * d_range.0.abs().max(d_range.1.abs());
    let n = v_samples.max(2);
    let vs: Vec<f64> = (0..n)
        .map(|i| v_range.0 + (v_range.1 - v_range.0) * i as f64 / (n - 1) as f64)
        .collect();
    let cols = try_map(&vs, Split::Adaptive, &|_, &v| {
        dynamic_crossings(model, tau, v, d_lim)
    })?;
    let refined = try_map(
        &bracketed_intersections(&vs, &cols),
        Split::Adaptive,
        &|_, &(bracket, modes)| refine_intersection(model, tau, d_lim, bracket, modes),
    )?;
    let mut out: Vec<DoubleHopfPoint> = Vec::new();
    for (v, a, b) in refined.into_iter().flatten() {
        let d = 0.5 * (a.d + b.d);
        let inside = d >= d_range.0 && d <= d_range.1 && v >= v_range.0 && v <= v_range.1;
        let dup = out
            .iter()
            .any(|p| (p.v_mps - v).abs() < 1e-6 && (p.d_s - d).abs() < 1e-6);
        if inside && !dup && distinct_modes(a.omega, b.omega) {
            out.push(checked_point(model, tau, d_lim, v, d, (a.omega, b.omega))?);
        }
    }
    fn by_speed(p: &DoubleHopfPoint, q: &DoubleHopfPoint) -> std::cmp::Ordering {
        p.v_mps.total_cmp(&q.v_mps)
    }
    out.sort_by(by_speed);
    Ok(out)
}

/// The double-Hopf point at (V, D) with its slopes and the root check.
fn checked_point<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    d_lim: f64,
    v: f64,
    d: f64,
    (wa, wb): (f64, f64),
) -> Result<DoubleHopfPoint, SwayError> {
    let (w1, w2) = if wa < wb { (wa, wb) } else { (wb, wa) };
    let h = 1e-4;
    let slope = |w: f64| -> Result<f64, SwayError> {
        let cs = |v| dynamic_crossings(model, tau, v, d_lim);
        let tol = 0.1 * w;
        match (nearest(&cs(v + h)?, w, tol), nearest(&cs(v - h)?, w, tol)) {
            (Some(p), Some(m)) => Ok((p.d - m.d) / (2.0 * h)),
            _ => Ok(f64::NAN),
        }
    };
    let roots = rightmost_roots(model, v, d, tau, 12)?;
    let near = |w: f64| {
        roots
            .iter()
            .filter(|r| r.im > 0.0)
            .min_by(|a, b| (a.im - w).abs().total_cmp(&(b.im - w).abs()))
            .map_or(f64::INFINITY, |r| r.re.abs())
    };
    let critical_real_part = near(w1).max(near(w2));
    let unstable = roots.iter().filter(|r| r.re > 1e-8).count();
    Ok(DoubleHopfPoint {
        tau_s: tau,
        d_s: d,
        v_mps: v,
        omega1_rad_s: w1,
        omega2_rad_s: w2,
        ratio: w2 / w1,
        slopes_s_per_mps: [slope(w1)?, slope(w2)?],
        other_unstable_roots: unstable,
        critical_real_part,
    })
}

/// A point of a Hopf curve traced on the D-subdivision.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ModePoint {
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// gain D \[s\]
    pub d_s: f64,
    /// frequency ω \[rad/s\]
    pub omega_rad_s: f64,
}

/// One Hopf curve through a double-Hopf point, inside the zoom window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModeCurve {
    /// its frequency at the double-Hopf point \[rad/s\]
    pub omega_at_corner_rad_s: f64,
    /// criticality of its Hopf points near the corner (from the nonlinear chart's
    /// sample nearest to the corner on the curve of this frequency), if known
    pub criticality: Option<Criticality>,
    /// the points, in increasing V
    pub points: Vec<ModePoint>,
}

/// A point of a torus (Neimark–Sacker) curve.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TorusPoint {
    /// gain D \[s\]
    pub d_s: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// period of the cycle that loses stability there \[s\]
    pub period_s: f64,
    /// angle φ ∈ \[0, π\] of the critical Floquet multipliers e^{±iφ} \[rad\]
    pub multiplier_angle_rad: f64,
    /// rotation number φ/2π of the critical Floquet multipliers e^{±iφ}
    pub rotation_number: f64,
    /// amplitude of the cycle (half peak-to-peak, largest state component: σ1 \[m/s\],
    /// σ2, σ3 \[1/s\], θ \[rad\])
    pub amplitude: f64,
    /// Floquet multipliers of the cycle outside the unit circle besides the critical pair
    /// (0: the cycle is attracting on the side of the curve where the pair is inside, so
    /// an attracting torus can be born there); None when not computed
    pub other_unstable_multipliers: Option<usize>,
    /// the cycle's state at its first mesh node \[σ1 m/s, σ2 1/s, σ3 1/s, θ rad\] (a
    /// start on the cycle for simulations, [`run_from`]; a plant's own states beyond these
    /// four are left out; not written to files)
    #[serde(skip)]
    pub cycle_state: [f64; 4],
}

/// Where the torus curve, continued back towards amplitude 0, meets the double-Hopf point
/// (a check of the start: the branch switching should lead back to the point).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TorusCurveEnd {
    /// speed V of the extrapolated end \[m/s\]
    pub v_mps: f64,
    /// gain D of the extrapolated end \[s\]
    pub d_s: f64,
    /// frequency of the vanishing cycle 2π/T \[rad/s\]
    pub omega_cycle_rad_s: f64,
    /// frequency of the critical mode θ/T \[rad/s\]
    pub omega_mode_rad_s: f64,
    /// cycle amplitude at the last point computed before the end
    pub amplitude: f64,
}

/// A torus curve: cycles of one family with a pair of Floquet multipliers on the unit
/// circle; quasi-periodic motion (a torus) is born across it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorusCurve {
    /// frequency of the cycle family at the double-Hopf point \[rad/s\]
    pub family_omega_rad_s: f64,
    /// frequency of the other mode there (the critical multipliers' source) \[rad/s\]
    pub other_omega_rad_s: f64,
    /// the points in curve order (the first one next to the double-Hopf point)
    pub points: Vec<TorusPoint>,
    /// why the continuation stopped
    pub stop: String,
    /// the curve continued backwards to the double-Hopf point, if it got there
    pub end: Option<TorusCurveEnd>,
}

impl TorusCurve {
    /// The multiplier angle the curve starts with at the double-Hopf point:
    /// φ = 2π·ω_other/ω_own reduced to \[0, π\] \[rad\].
    pub fn angle_at_double_hopf(&self) -> f64 {
        continuation::torus::multiplier_angle(
            2.0 * std::f64::consts::PI * self.other_omega_rad_s / self.family_omega_rad_s,
        )
    }

    /// Whether the cycles along the curve are attracting apart from the critical pair
    /// (no other multiplier outside the unit circle at every point with multipliers);
    /// None if no multipliers were computed.
    pub fn cycles_attracting(&self) -> Option<bool> {
        let counts: Vec<usize> = self
            .points
            .iter()
            .filter_map(|p| p.other_unstable_multipliers)
            .collect();
        (!counts.is_empty()).then(|| counts.iter().all(|&n| n == 0))
    }

    /// The gain D \[s\] where the curve passes speed V \[m/s\], linearly interpolated
    /// between its points, on stretches whose cycles are attracting apart from the
    /// critical pair when `attracting_only` (the first such passage in curve order); None
    /// if it does not pass V there.
    pub fn gain_at_speed(&self, v: f64, attracting_only: bool) -> Option<f64> {
        self.at_speed(v, attracting_only).map(|(d, _)| d)
    }

    /// (D \[s\], period \[s\]) where the curve passes V (see [`TorusCurve::gain_at_speed`]).
    pub fn at_speed(&self, v: f64, attracting_only: bool) -> Option<(f64, f64)> {
        let ok = |p: &TorusPoint| !attracting_only || p.other_unstable_multipliers == Some(0);
        self.points.windows(2).find_map(|w| {
            let (a, b) = (&w[0], &w[1]);
            let inside = (a.v_mps - v) * (b.v_mps - v) <= 0.0 && a.v_mps != b.v_mps;
            let t = (v - a.v_mps) / (b.v_mps - a.v_mps);
            (inside && ok(a) && ok(b)).then_some((
                a.d_s + (b.d_s - a.d_s) * t,
                a.period_s + (b.period_s - a.period_s) * t,
            ))
        })
    }
}

/// The computed torus curve against the torus boundary observed by simulation at one
/// speed and kick.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TorusComparison {
    /// the initial hitch angle of the scan \[deg\]
    pub kick_deg: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// frequency of the curve's cycle family at the double-Hopf point \[rad/s\]
    pub family_omega_rad_s: f64,
    /// midpoint of the observed bracket \[s\]
    pub d_observed_s: f64,
    /// half width of the observed bracket \[s\]
    pub d_observed_half_width_s: f64,
    /// the curve's gain at V on its attracting stretch \[s\]
    pub d_curve_s: f64,
    /// frequency 2π/T of the curve's cycle at V \[rad/s\]
    pub omega_curve_cycle_rad_s: f64,
    /// base frequency of the periodic motion the scan saw just below its boundary
    /// \[rad/s\]: the comparison holds where it is the curve's cycle (the kick reached it)
    pub omega_observed_cycle_rad_s: Option<f64>,
    /// observed − curve \[s\]
    pub difference_s: f64,
}

/// One simulation at a probe point.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeRun {
    /// initial hitch angle \[deg\]
    pub kick_deg: f64,
    /// the classification with its evidence (θ in radians)
    pub evidence: MotionEvidence,
    /// when the validity guard stopped the run \[s\] (loss of control), if it did
    pub loss_of_control_time_s: Option<f64>,
    /// the θ spectrum of the analysis window
    pub spectrum: Spectrum,
    /// the Poincaré section: (θ \[rad\], θ̇ \[rad/s\]) at the upward zero crossings of ψ̇
    pub section: Vec<(f64, f64)>,
}

/// A probe point near a double-Hopf point and its simulations.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// where it lies: `sector <k>` (bisector of a sector between the Hopf curves), or
    /// `outside torus` / `inside torus` (flanking the observed torus boundary)
    pub label: String,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// gain D \[s\]
    pub d_s: f64,
    /// frequencies of the unstable root pairs of straight running there \[rad/s\] (empty:
    /// straight running is stable)
    pub unstable_modes_rad_s: Vec<f64>,
    /// the runs, one per kick
    pub runs: Vec<ProbeRun>,
}

impl Probe {
    /// The region's name: which modes of straight running are unstable there.
    pub fn region(&self) -> String {
        if self.unstable_modes_rad_s.is_empty() {
            return "stable".into();
        }
        let w: Vec<String> = self
            .unstable_modes_rad_s
            .iter()
            .map(|w| format!("{w:.2}"))
            .collect();
        format!("unstable ω = {} rad/s", w.join(", "))
    }
}

/// A point of the torus boundary observed by simulation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ObservedTorusPoint {
    /// the initial hitch angle of the scan \[deg\]
    pub kick_deg: f64,
    /// speed V \[m/s\]
    pub v_mps: f64,
    /// the largest gain seen periodic \[s\]
    pub d_periodic_s: f64,
    /// the smallest gain seen quasi-periodic \[s\]
    pub d_quasi_periodic_s: f64,
    /// base frequency of the periodic motion just below the boundary (which cycle the
    /// kick reached) \[rad/s\]
    pub omega_periodic_rad_s: Option<f64>,
}

/// Everything near one double-Hopf point.
#[derive(Debug, Clone)]
pub struct Corner {
    /// the point
    pub point: DoubleHopfPoint,
    /// the zoom window \[V0, V1, D0, D1\] (m/s, s)
    pub window: [f64; 4],
    /// the two Hopf curves through it
    pub mode_curves: Vec<ModeCurve>,
    /// the fold-of-cycles curves of the nonlinear chart inside the window (V, D)
    pub fold_curves: Vec<Vec<(f64, f64)>>,
    /// the torus curves that emanate from it
    pub torus_curves: Vec<TorusCurve>,
    /// the linear chart on the window (regions: 0, 2, 4 unstable roots)
    pub regions: StabilityChart,
    /// the probes: the sector bisectors, then the pairs flanking the observed torus
    /// boundary
    pub probes: Vec<Probe>,
    /// the torus boundary observed by simulation ([`TorusScan`]): (V, D) where the large
    /// sway cycle turns quasi-periodic, to within the scan's tolerance in D
    pub observed_torus_boundary: Vec<ObservedTorusPoint>,
    /// the torus curves against the observed boundary: every observed speed that a curve
    /// passes on a stretch of attracting cycles
    pub torus_comparison: Vec<TorusComparison>,
    /// what the analysis noticed (torus curves that could not be started)
    pub notes: Vec<String>,
    /// distance in V \[m/s\] to the double-Hopf point the continuation of the nonlinear
    /// chart located on its Hopf curves (an independent computation), if it found one
    pub continuation_offset_mps: Option<f64>,
}

/// The corner analysis of one delay.
#[derive(Debug, Clone)]
pub struct CornerStudy {
    /// delay τ \[s\]
    pub tau_s: f64,
    /// the double-Hopf points inside the chart's range
    pub double_hopf: Vec<DoubleHopfPoint>,
    /// double-Hopf points beyond the chart's gain range (|D| ≤ `beyond_gain_s`)
    pub beyond_range: Vec<DoubleHopfPoint>,
    /// the analysis near each point inside the range
    pub corners: Vec<Corner>,
    /// what the pipeline noticed
    pub notes: Vec<String>,
    /// curves of the nonlinear chart that ended early and corners whose analysis could not
    /// be completed, each with its end
    pub curves_ended_early: Vec<EndedCurve>,
}

/// Settings of the torus-curve continuation from a double-Hopf point
/// ([`continued_torus_curves`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TorusContinuation {
    /// amplitude of the first cycle along the critical eigenvector (unit norm in
    /// \[σ1 m/s, σ2 1/s, σ3 1/s, θ rad\])
    pub amplitude: f64,
    /// mesh intervals L of the cycles (degree 4)
    pub intervals: usize,
    /// first continuation step (weighted arclength)
    pub initial_step: f64,
    /// largest step
    pub max_step: f64,
    /// at most this many points per torus curve (0: no torus curves)
    pub max_points: usize,
    /// the curve ends at a double-Hopf point when the cycle amplitude falls below this
    pub min_amplitude: f64,
    /// Floquet multipliers of the cycle at every point (which stretches have attracting
    /// cycles; one monodromy matrix per point)
    pub multipliers: bool,
    /// the check of the start: at most this many points continued backwards to the
    /// double-Hopf point (0: no check)
    pub back_points: usize,
}

impl Default for TorusContinuation {
    fn default() -> Self {
        Self {
            amplitude: 0.02,
            intervals: 30,
            initial_step: 0.05,
            max_step: 0.5,
            max_points: 80,
            min_amplitude: 5e-3,
            multipliers: true,
            back_points: 12,
        }
    }
}

/// The torus curves T1, T2 that emanate from the double-Hopf point `p` (cycle family i of
/// frequency ω_i losing stability to the other mode), continued in (V, D) with the
/// `continuation` crate's [`continuation::TorusCurveSystem`] from the point itself
/// (branch switching without normal-form coefficients), each until it leaves the zoom
/// `window`, reaches a strong resonance or `max_points`; each also continued backwards to
/// its end at the double-Hopf point ([`TorusCurve::end`]). A family whose continuation
/// fails is reported in the notes (second value) instead of failing the analysis.
pub fn continued_torus_curves<P: Vehicle<N>, const N: usize>(
    model: &P,
    p: &DoubleHopfPoint,
    window: [f64; 4],
    o: &TorusContinuation,
) -> (Vec<TorusCurve>, Vec<String>) {
    let fb = LoopLaw::paper(p.d_s, p.tau_s);
    let problem = super::ClosedLoop::new(model, fb);
    let results = map(&[0, 1], Split::Adaptive, &|_, &family| {
        (family, torus_curve(&problem, p, family, window, o))
    });
    let mut curves = Vec::new();
    let mut notes = Vec::new();
    for (family, r) in results {
        match r {
            Ok(c) => curves.push(c),
            Err(e) => notes.push(format!(
                "torus curve of the ω = {:.3} rad/s cycles from the double Hopf at V = {:.3} m/s: {e}",
                [p.omega1_rad_s, p.omega2_rad_s][family],
                p.v_mps
            )),
        }
    }
    (curves, notes)
}

/// One torus curve from the double-Hopf point (family 0: the ω1 cycles, 1: the ω2 cycles).
#[doc(hidden)] // pub for tests/unit
pub fn torus_curve<P: Vehicle<N>, const N: usize>(
    problem: &super::ClosedLoop<'_, P, N>,
    p: &DoubleHopfPoint,
    family: usize,
    w: [f64; 4],
    o: &TorusContinuation,
) -> Result<TorusCurve, continuation::Error> {
    use continuation::{
        CollocationOptions, Continuation, ContinuationOptions, TorusCurveOptions, TorusCurveStop,
        TorusCurveSystem,
    };
    let hh = continuation::DoubleHopfPoint::new(
        problem,
        problem.parameters(p.v_mps),
        vec![0.0; N],
        [p.omega1_rad_s, p.omega2_rad_s],
    )?;
    let colloc = CollocationOptions {
        intervals: o.intervals,
        ..CollocationOptions::default()
    };
    let options = TorusCurveOptions {
        min_amplitude: o.min_amplitude,
        multipliers: o.multipliers,
        ..TorusCurveOptions::default()
    };
    let free = [super::SPEED, super::GAIN];
    let start = || {
        TorusCurveSystem::from_double_hopf(
            problem,
            &hh,
            free,
            family,
            o.amplitude,
            colloc.clone(),
            options.clone(),
        )
    };
    let cont = Continuation::new(ContinuationOptions {
        initial_step: o.initial_step,
        max_step: o.max_step,
        parameter_range: (w[0], w[1]),
        ..Default::default()
    });
    // backwards first (a system of its own: the references follow the branch)
    let end = if o.back_points > 0 {
        let (mut sys, guess, dir) = start()?;
        let back: Vec<f64> = dir.iter().map(|x| -x).collect();
        let mut b = cont.start(&mut sys, &guess, &back)?;
        match sys.extend_curve(&cont, &mut b, o.back_points)? {
            TorusCurveStop::DoubleHopfEnd(e) => Some(TorusCurveEnd {
                v_mps: e.parameters[0],
                d_s: e.parameters[1],
                omega_cycle_rad_s: e.omegas[0],
                omega_mode_rad_s: e.omegas[1],
                amplitude: e.amplitude,
            }),
            _ => None,
        }
    } else {
        None
    };
    let (mut sys, guess, dir) = start()?;
    let mut b = cont.start(&mut sys, &guess, &dir)?;
    let running = TorusCurveStop::Continuation(continuation::Stop::MaxPoints);
    let mut stop = running.clone();
    while b.points.len() < o.max_points {
        stop = sys.extend_curve(&cont, &mut b, 4)?;
        let d = sys.curve_point(&b.points[b.points.len() - 1].u).parameters[1];
        if d < w[2] || d > w[3] {
            stop = TorusCurveStop::Continuation(continuation::Stop::ParameterRange);
            break;
        }
        if stop != running {
            break;
        }
    }
    let points = b
        .points
        .iter()
        .map(|pt| {
            let c = sys.curve_point(&pt.u);
            TorusPoint {
                v_mps: c.parameters[0],
                d_s: c.parameters[1],
                period_s: c.period,
                multiplier_angle_rad: c.multiplier_angle,
                rotation_number: c.rotation_number,
                amplitude: c.amplitude,
                other_unstable_multipliers: pt.stability.as_ref().map(|s| s.unstable),
                cycle_state: std::array::from_fn(|k| pt.u[k]),
            }
        })
        .collect();
    let stop = match stop {
        TorusCurveStop::Continuation(continuation::Stop::ParameterRange) => {
            "left the zoom window".to_string()
        }
        TorusCurveStop::Continuation(continuation::Stop::MaxPoints) => {
            format!("{} points (max_points)", b.points.len())
        }
        TorusCurveStop::Continuation(s) => format!("continuation stopped: {s:?}"),
        TorusCurveStop::DoubleHopfEnd(e) => format!(
            "ended at a double-Hopf point near V = {:.3} m/s, D = {:.4} s",
            e.parameters[0], e.parameters[1]
        ),
        TorusCurveStop::StrongResonance { order, angle, .. } => {
            format!("strong resonance 1:{order} (φ = {angle:.4} rad)")
        }
    };
    Ok(TorusCurve {
        family_omega_rad_s: [p.omega1_rad_s, p.omega2_rad_s][family],
        other_omega_rad_s: [p.omega2_rad_s, p.omega1_rad_s][family],
        points,
        stop,
        end,
    })
}

/// The torus curves at the speeds of the observed boundary: every (observed point, curve)
/// pair where the curve passes the observed speed on a stretch of attracting cycles.
pub fn compare_torus(
    curves: &[TorusCurve],
    observed: &[ObservedTorusPoint],
) -> Vec<TorusComparison> {
    let mut out = Vec::new();
    for b in observed {
        for c in curves {
            if let Some((d, period)) = c.at_speed(b.v_mps, true) {
                let mid = 0.5 * (b.d_periodic_s + b.d_quasi_periodic_s);
                out.push(TorusComparison {
                    kick_deg: b.kick_deg,
                    v_mps: b.v_mps,
                    family_omega_rad_s: c.family_omega_rad_s,
                    d_observed_s: mid,
                    d_observed_half_width_s: 0.5 * (b.d_quasi_periodic_s - b.d_periodic_s),
                    d_curve_s: d,
                    omega_curve_cycle_rad_s: 2.0 * std::f64::consts::PI / period,
                    omega_observed_cycle_rad_s: b.omega_periodic_rad_s,
                    difference_s: mid - d,
                });
            }
        }
    }
    out
}

/// The corner analysis of delay τ \[s\] (module documentation), with the nonlinear chart's
/// options `chart` (its box is the range searched).
///
/// # Errors
/// [`SwayError::Numerical`] naming the failing stage.
pub fn corner_study<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    tau: f64,
    chart: &ChartOptions,
    o: &CornerOptions,
) -> Result<CornerStudy, SwayError> {
    let (v_range, d_range) = (
        (chart.v_min_mps, chart.v_max_mps),
        (chart.d_min_s, chart.d_max_s),
    );
    let (points, nl) = join(
        &|| double_hopf_points(model, tau, v_range, d_range, o.v_samples),
        &|| nonlinear_chart(model, tau, chart),
    );
    let double_hopf = points?;
    // a chart that cannot be computed is a result with its reason: the corners stand on
    // their own continuation
    let nl = nl.unwrap_or_else(|e| NonlinearChart::not_computed(tau, chart, &e));
    let beyond_range = beyond(model, tau, v_range, d_range, o)?;
    // a corner whose analysis cannot be completed is left out with its reason
    let mut curves_ended_early = nl.curves_ended_early.clone();
    let mut corners = Vec::new();
    let mut failed_notes = Vec::new();
    for p in &double_hopf {
        match corner(model, &nl, p, o) {
            Ok(c) => corners.push(c),
            Err(e) => {
                let end = CurveEnd::from_error(Some((p.d_s, p.v_mps)), &e);
                failed_notes.push(format!(
                    "the corner at D = {:.4} s, V = {:.3} m/s could not be analysed: {}",
                    p.d_s,
                    p.v_mps,
                    end.describe()
                ));
                curves_ended_early.push(EndedCurve {
                    curve: format!("corner at D = {:.4} s, V = {:.3} m/s", p.d_s, p.v_mps),
                    end,
                });
            }
        }
    }
    let mut notes = nl.notes.clone();
    notes.extend(failed_notes);
    notes.extend(corners.iter().flat_map(|c| c.notes.iter().cloned()));
    if double_hopf.is_empty() {
        notes.push(format!(
            "no double-Hopf point for V in [{}, {}] m/s, D in [{}, {}] s",
            v_range.0, v_range.1, d_range.0, d_range.1
        ));
    }
    Ok(CornerStudy {
        tau_s: tau,
        double_hopf,
        beyond_range,
        corners,
        notes,
        curves_ended_early,
    })
}

/// The double-Hopf points with |D| ≤ `beyond_gain_s` outside the chart's gain range.
fn beyond<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    v_range: (f64, f64),
    d_range: (f64, f64),
    o: &CornerOptions,
) -> Result<Vec<DoubleHopfPoint>, SwayError> {
    let beyond_gain = o.beyond_gain_s.unwrap_or(0.0);
    if beyond_gain <= d_range.0.abs().max(d_range.1.abs()) {
        return Ok(Vec::new());
    }
    let wide = (-beyond_gain, beyond_gain);
    let mut all = double_hopf_points(model, tau, v_range, wide, o.v_samples)?;
    all.retain(|p| p.d_s < d_range.0 || p.d_s > d_range.1);
    Ok(all)
}

/// The analysis near one double-Hopf point.
fn corner<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    nl: &NonlinearChart,
    p: &DoubleHopfPoint,
    o: &CornerOptions,
) -> Result<Corner, SwayError> {
    let (hv, hd) = (o.zoom_half_width_v_mps, o.zoom_half_width_d_s);
    let window = [p.v_mps - hv, p.v_mps + hv, p.d_s - hd, p.d_s + hd];
    let mode_curves = [p.omega1_rad_s, p.omega2_rad_s]
        .iter()
        .map(|&w| mode_curve(model, nl, p, w, window, o.zoom_curve_samples))
        .collect::<Result<Vec<_>, _>>()?;
    let regions = window_chart(model, p.tau_s, window, o.zoom_cells)?;
    let lines: Vec<(f64, f64)> = o
        .simulation
        .kicks_deg
        .iter()
        .flat_map(|&k| o.torus_scan.speed_offsets_mps.iter().map(move |dv| (k, dv)))
        .map(|(k, dv)| (k, p.v_mps + dv))
        .collect();
    // the continuation (two curves) and the simulations side by side
    let ((torus_curves, notes), simulated) = join(
        &|| {
            if o.torus_curves.max_points > 0 {
                continued_torus_curves(model, p, window, &o.torus_curves)
            } else {
                (Vec::new(), Vec::new())
            }
        },
        &|| {
            let probes = try_map(&probe_points(p, o), Split::Adaptive, &|k, &(v, d)| {
                probe(model, p.tau_s, v, d, format!("sector {k}"), o)
            })?;
            let scans = try_map(&lines, Split::Adaptive, &|_, &(k, v)| {
                torus_boundary_at(model, p, v, k, o)
            })?;
            Ok::<_, SwayError>((probes, scans))
        },
    );
    let (mut probes, scans) = simulated?;
    let mut observed_torus_boundary = Vec::new();
    for (point, flank) in scans.into_iter().flatten() {
        observed_torus_boundary.push(point);
        probes.extend(flank);
    }
    let torus_comparison = compare_torus(&torus_curves, &observed_torus_boundary);
    Ok(Corner {
        point: *p,
        window,
        mode_curves,
        fold_curves: fold_curves_in(nl, window),
        torus_curves,
        notes,
        regions,
        probes,
        observed_torus_boundary,
        torus_comparison,
        continuation_offset_mps: continuation_offset(nl, p),
    })
}

/// The chart's fold-of-cycles curves as (V, D) lines, kept where they pass the window
/// (with a margin of one window so that lines run to its edges).
fn fold_curves_in(nl: &NonlinearChart, w: [f64; 4]) -> Vec<Vec<(f64, f64)>> {
    let (mv, md) = (w[1] - w[0], w[3] - w[2]);
    let near = |v: f64, d: f64| v > w[0] - mv && v < w[1] + mv && d > w[2] - md && d < w[3] + md;
    nl.fold_curves
        .iter()
        .map(|f| {
            f.points
                .iter()
                .map(|q| (q.v_mps, q.d_s))
                .collect::<Vec<_>>()
        })
        .filter(|l: &Vec<(f64, f64)>| l.iter().any(|&(v, d)| near(v, d)))
        .collect()
}

/// |V − V_HH| of the nearest double-Hopf point the chart's continuation located.
fn continuation_offset(nl: &NonlinearChart, p: &DoubleHopfPoint) -> Option<f64> {
    nl.codim2_points
        .iter()
        .filter(|c| c.kind == super::chart::Codim2Kind::DoubleHopf)
        .filter(|c| (c.d_s - p.d_s).abs() < 0.01)
        .map(|c| (c.v_mps - p.v_mps).abs())
        .reduce(f64::min)
}

/// The Hopf curve of frequency ω through the corner, traced on the D-subdivision across
/// the window's speeds (outwards from the corner, following ω).
fn mode_curve<L: LoopModel + ?Sized>(
    model: &L,
    nl: &NonlinearChart,
    p: &DoubleHopfPoint,
    w: f64,
    window: [f64; 4],
    samples: usize,
) -> Result<ModeCurve, SwayError> {
    let d_lim = 1.5 * window[2].abs().max(window[3].abs());
    let n = samples.max(3);
    let vs: Vec<f64> = (0..n)
        .map(|i| window[0] + (window[1] - window[0]) * i as f64 / (n - 1) as f64)
        .collect();
    let cols = try_map(&vs, Split::Adaptive, &|_, &v| {
        dynamic_crossings(model, p.tau_s, v, d_lim)
    })?;
    let centre = vs.iter().position(|&v| v >= p.v_mps).unwrap_or(n - 1);
    let mut points = Vec::new();
    for range in [(0..centre).rev().collect::<Vec<_>>(), (centre..n).collect()] {
        let mut omega = w;
        for i in range {
            let Some(c) = nearest(&cols[i], omega, 0.05 * w) else {
                break;
            };
            omega = c.omega;
            points.push(ModePoint {
                v_mps: vs[i],
                d_s: c.d,
                omega_rad_s: c.omega,
            });
        }
    }
    fn by_speed(a: &ModePoint, b: &ModePoint) -> std::cmp::Ordering {
        a.v_mps.total_cmp(&b.v_mps)
    }
    points.sort_by(by_speed);
    Ok(ModeCurve {
        omega_at_corner_rad_s: w,
        criticality: criticality_near(nl, p, w),
        points,
    })
}

/// The criticality the chart sampled nearest to the corner on a curve of frequency ω.
fn criticality_near(nl: &NonlinearChart, p: &DoubleHopfPoint, w: f64) -> Option<Criticality> {
    let dist = |d: f64, v: f64| ((d - p.d_s) / 0.01).powi(2) + (v - p.v_mps).powi(2);
    nl.hopf_curves
        .iter()
        .flat_map(|c| {
            c.criticality.iter().filter_map(move |s| {
                let wi = c.points.get(s.index)?.omega_rad_s.abs();
                ((wi - w).abs() < 0.1 * w).then_some((dist(s.d_s, s.v_mps), s.criticality))
            })
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
}

/// The linear chart (exact unstable-root counts) on the window.
fn window_chart<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    w: [f64; 4],
    cells: usize,
) -> Result<StabilityChart, SwayError> {
    let speed = Axis {
        min: w[0],
        max: w[1],
        count: cells.max(2),
    };
    let gain = Axis {
        min: w[2],
        max: w[3],
        count: cells.max(2),
    };
    fig4a_charts(
        model,
        &[tau],
        speed,
        gain,
        &stability::ChartOptions::default(),
    )?
    .into_iter()
    .next()
    .ok_or_else(|| {
        SwayError::numerical(
            format!("linear chart near the corner, τ = {tau} s"),
            std::io::Error::other("no chart returned"),
        )
    })
}

/// Probe points: on the bisectors of the four sectors between the Hopf curves' half-lines
/// at the corner (in window-scaled coordinates), at each radius.
pub fn probe_points(p: &DoubleHopfPoint, o: &CornerOptions) -> Vec<(f64, f64)> {
    let (hv, hd) = (o.zoom_half_width_v_mps, o.zoom_half_width_d_s);
    let mut angles: Vec<f64> = p
        .slopes_s_per_mps
        .iter()
        .filter(|s| s.is_finite())
        .flat_map(|s| {
            let a = (s * hv / hd).atan();
            [a, a + std::f64::consts::PI]
        })
        .map(|a| a.rem_euclid(2.0 * std::f64::consts::PI))
        .collect();
    angles.sort_by(f64::total_cmp);
    let k = angles.len();
    let bisectors: Vec<f64> = (0..k)
        .map(|i| {
            let (a, b) = (angles[i], angles[(i + 1) % k]);
            let b = if b <= a {
                b + 2.0 * std::f64::consts::PI
            } else {
                b
            };
            0.5 * (a + b)
        })
        .collect();
    let mut out = Vec::new();
    for &r in &o.probe_radii {
        for &phi in &bisectors {
            out.push((p.v_mps + r * hv * phi.cos(), p.d_s + r * hd * phi.sin()));
        }
    }
    out
}

/// The unstable root pairs' frequencies at (V, D).
#[doc(hidden)] // pub for tests/unit
pub fn unstable_modes<L: LoopModel + ?Sized>(
    model: &L,
    tau: f64,
    v: f64,
    d: f64,
) -> Result<Vec<f64>, SwayError> {
    let roots = rightmost_roots(model, v, d, tau, 12)?;
    Ok(roots
        .iter()
        .filter(|r| r.re > 0.0 && r.im > 0.0)
        .map(|r| r.im)
        .collect())
}

/// The simulations at one probe point.
fn probe<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    tau: f64,
    v: f64,
    d: f64,
    label: String,
    o: &CornerOptions,
) -> Result<Probe, SwayError> {
    let runs = o
        .simulation
        .kicks_deg
        .iter()
        .map(|&k| run_at(model, tau, v, d, k, o))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Probe {
        label,
        v_mps: v,
        d_s: d,
        unstable_modes_rad_s: unstable_modes(model, tau, v, d)?,
        runs,
    })
}

/// The class of the run at (V, D) from the kick \[deg\].
fn class_at<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    p: &DoubleHopfPoint,
    (v, d): (f64, f64),
    kick: f64,
    o: &CornerOptions,
) -> Result<MotionClass, SwayError> {
    Ok(run_at(model, p.tau_s, v, d, kick, o)?.evidence.class)
}

/// The torus boundary at speed V: the first periodic → quasi-periodic change of the
/// coarse scan in D, bisected; with the probes flanking it (periodic below, quasi-periodic
/// above). None if the scan shows no such change.
fn torus_boundary_at<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    p: &DoubleHopfPoint,
    v: f64,
    kick: f64,
    o: &CornerOptions,
) -> Result<Option<(ObservedTorusPoint, [Probe; 2])>, SwayError> {
    let s = &o.torus_scan;
    let n = s.d_samples.max(2);
    let ds: Vec<f64> = (0..n)
        .map(|i| {
            p.d_s
                + s.d_start_offset_s
                + (s.d_end_offset_s - s.d_start_offset_s) * i as f64 / (n - 1) as f64
        })
        .collect();
    let classes = ds
        .iter()
        .map(|&d| class_at(model, p, (v, d), kick, o))
        .collect::<Result<Vec<_>, _>>()?;
    let Some(j) = (0..n - 1).find(|&j| {
        classes[j] == MotionClass::Periodic && classes[j + 1] == MotionClass::QuasiPeriodic
    }) else {
        return Ok(None);
    };
    let (mut lo, mut hi) = (ds[j], ds[j + 1]);
    while hi - lo > s.tolerance_s {
        let mid = 0.5 * (lo + hi);
        match class_at(model, p, (v, mid), kick, o)? {
            MotionClass::Periodic => lo = mid,
            MotionClass::QuasiPeriodic => hi = mid,
            _ => break,
        }
    }
    let flank = |d: f64, label: &str| {
        let mut one = o.clone();
        one.simulation.kicks_deg = vec![kick];
        probe(model, p.tau_s, v, d, label.into(), &one)
    };
    let below = flank(lo - s.flank_s, "outside torus")?;
    let above = flank(hi + s.flank_s, "inside torus")?;
    let point = ObservedTorusPoint {
        kick_deg: kick,
        v_mps: v,
        d_periodic_s: lo,
        d_quasi_periodic_s: hi,
        omega_periodic_rad_s: below
            .runs
            .first()
            .filter(|r| r.evidence.class == MotionClass::Periodic)
            .and_then(|r| r.evidence.base_frequencies_rad_s.first().copied()),
    };
    Ok(Some((point, [below, above])))
}

/// One closed-loop simulation at (V, D, τ) of the plant `model` (in its own layout) from θ(t ≤ 0) = kick, classified; a run still
/// growing at the end of the window (without loss of control) is repeated with a
/// transient three times as long, so that the class is that of where the motion settles.
pub fn run_at<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    tau: f64,
    v: f64,
    d: f64,
    kick_deg: f64,
    o: &CornerOptions,
) -> Result<ProbeRun, SwayError> {
    let x0 = [0.0, 0.0, 0.0, kick_deg.to_radians()];
    let mut r = run_from(model, tau, v, d, x0, o)?;
    r.kick_deg = kick_deg;
    Ok(r)
}

/// As [`run_at`], from the constant history x(t ≤ 0) = `x0` \[σ1 m/s, σ2 1/s, σ3 1/s,
/// θ rad\] (e.g. a state of a cycle; the run's `kick_deg` is θ0 in degrees). A plant's own
/// states (the lagged slips of relaxing axles) start in steady state of the tyres
/// ([`sway_model::vehicle::Vehicle::initial_state`] at V).
pub fn run_from<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    tau: f64,
    v: f64,
    d: f64,
    x0: [f64; 4],
    o: &CornerOptions,
) -> Result<ProbeRun, SwayError> {
    let first = run_once(model, tau, v, d, x0, o)?;
    let growing = first.evidence.class == MotionClass::LossOfControl
        && first.loss_of_control_time_s.is_none();
    if !growing {
        return Ok(first);
    }
    let mut longer = o.clone();
    longer.simulation.transient_s *= 3.0;
    run_once(model, tau, v, d, x0, &longer)
}

fn run_once<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    tau: f64,
    v: f64,
    d: f64,
    x: [f64; 4],
    o: &CornerOptions,
) -> Result<ProbeRun, SwayError> {
    let kick_deg = x[3].to_degrees();
    let s = &o.simulation;
    let spec = SimSpec {
        early_stop: crate::sim::EarlyStop::Never,
        steering: Default::default(),
        profile: SpeedProfile::Constant { speed_mps: v },
        controller: Some(LoopLaw::paper(d, tau)),
        horizon_s: s.transient_s + s.window_s,
        action_s: 0.0,
        settings: s.settings,
    };
    // a plant's own states (lagged slips) start in steady state of the tyres
    let x0 = model.initial_state(&State4::new(x[0], x[1], x[2], x[3]), v);
    let rec = Recording::Every {
        step_s: s.sample_step_s,
    };
    let r = model.simulate_own(&spec, x0, rec)?;
    let from = s.transient_s - 1e-9;
    let tail: Vec<_> = r.trajectory.iter().filter(|p| p.t >= from).collect();
    let theta: Vec<f64> = tail.iter().map(|p| p.x[HITCH_ANGLE]).collect();
    let yaw: Vec<f64> = tail.iter().map(|p| model.yaw_rate(&p.x)).collect();
    let rate: Vec<f64> = tail.iter().map(|p| model.hitch_angle_rate(&p.x)).collect();
    let section_theta = motion::poincare_section(&yaw, &theta);
    let section_rate = motion::poincare_section(&yaw, &rate);
    let lost = r.metrics.outcome == Outcome::LossOfControl;
    let mut evidence = motion::classify(&theta, s.sample_step_s, &section_theta, &o.motion);
    if lost {
        evidence.class = MotionClass::LossOfControl;
    }
    Ok(ProbeRun {
        kick_deg,
        spectrum: motion::spectrum(&theta, s.sample_step_s),
        evidence,
        loss_of_control_time_s: r.metrics.loss_of_control_time_s,
        section: section_theta.into_iter().zip(section_rate).collect(),
    })
}
