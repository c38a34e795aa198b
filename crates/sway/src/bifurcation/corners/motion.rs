//! What a recorded oscillation is: at rest (equilibrium), periodic, quasi-periodic, growing
//! (loss of control) or irregular — generic, for any uniformly sampled signal, with the
//! evidence: the amplitude spectrum (Hann window, [`rustfft`]) and its peaks, the base
//! frequencies, a Poincaré section and its rotation number.
//!
//! The decision, in order ([`classify`]):
//! 1. amplitude (half peak-to-peak) of the second half of the window below
//!    [`MotionOptions::rest_amplitude`], or second/first half below
//!    [`MotionOptions::decay_ratio`]: **equilibrium** (the motion dies out);
//! 2. second/first half above [`MotionOptions::growth_ratio`]: **loss of control** (the
//!    motion grows without bound in the window);
//! 3. every spectral peak (local maximum above [`MotionOptions::peak_threshold`] of the
//!    largest) a harmonic n·ω0 of ω0 = ω_max/k, k ≤ [`MotionOptions::max_subharmonic`]:
//!    **periodic** (period k times that of the largest peak);
//! 4. else, with ω1 the largest peak and ω2 the largest peak that is not a harmonic of ω1,
//!    the combinations |m·ω1 + n·ω2| (|m| + |n| ≤ [`MotionOptions::max_combination_order`])
//!    explain at least [`MotionOptions::explained_fraction`] of the peaks' power:
//!    **quasi-periodic** with base frequencies ω1, ω2 (two incommensurate frequencies: a
//!    rational ω2/ω1 = p/k with k ≤ `max_subharmonic` was caught by step 3);
//! 5. otherwise **irregular** (a broad spectrum: chaotic or not yet settled).
//!
//! A second frequency that dies out is a transient, not a torus: when steps 3–4 find two
//! base frequencies, the amplitude of ω2 in the second half of the window over that in the
//! first half ([`MotionEvidence::second_frequency_trend`], Hann-windowed Fourier sums at ω2)
//! below [`MotionOptions::decay_ratio`] makes the motion **periodic** (settling onto the
//! cycle of ω1: near a torus bifurcation the transverse mode decays slowly, at a rate
//! proportional to the distance, and would otherwise be taken for a torus).
//!
//! A frequency "matches" a combination when they differ by less than
//! [`MotionOptions::frequency_tolerance_bins`] bins of the spectrum (2π/T_window) plus
//! 1e-3 relative; peak frequencies are refined by a parabola through the log magnitudes of
//! the three bins around the maximum (accurate to a few hundredths of a bin for a clean
//! tone).
//!
//! The Poincaré section (values of the signal where a second signal crosses zero upwards,
//! [`poincare_section`]) is further evidence: a fixed point or a finite set of values
//! ([`MotionEvidence::section_clusters`] small) for periodic motion, a closed invariant
//! curve (as many distinct values as section points) for quasi-periodic motion. Its
//! rotation number ([`section_rotation_number`]) is the mean turning angle per return /2π
//! of the delay embedding (s_k, s_{k+1}), whitened so that the invariant curve of a
//! rigid rotation becomes a circle (exact for s_k = A cos(2πρk + φ)), folded to [0, ½].

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use serde::{Deserialize, Serialize};

/// The classes of motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionClass {
    /// the oscillation dies out: straight running (or the equilibrium) is reached
    Equilibrium,
    /// a limit cycle (one base frequency)
    Periodic,
    /// a torus: two incommensurate base frequencies
    QuasiPeriodic,
    /// the oscillation grows without bound, or the model's validity guard stopped the run
    LossOfControl,
    /// none of the above (broad spectrum)
    Irregular,
}

impl MotionClass {
    /// The snake_case name used in CSV and JSON.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Equilibrium => "equilibrium",
            Self::Periodic => "periodic",
            Self::QuasiPeriodic => "quasi_periodic",
            Self::LossOfControl => "loss_of_control",
            Self::Irregular => "irregular",
        }
    }
}

/// Thresholds of [`classify`] (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionOptions {
    /// an amplitude below this counts as rest (units of the signal)
    pub rest_amplitude: f64,
    /// second-half / first-half amplitude below this: decaying
    pub decay_ratio: f64,
    /// second-half / first-half amplitude above this: growing
    pub growth_ratio: f64,
    /// a spectral peak counts when its amplitude is at least this fraction of the largest
    pub peak_threshold: f64,
    /// frequencies match within this many bins (plus 1e-3 relative)
    pub frequency_tolerance_bins: f64,
    /// periodic test: fundamentals ω_max/k for k up to this
    pub max_subharmonic: usize,
    /// quasi-periodic test: combinations m·ω1 + n·ω2 with |m| + |n| up to this
    pub max_combination_order: i32,
    /// quasi-periodic test: fraction of the peaks' power the combinations must explain
    pub explained_fraction: f64,
    /// two section values are one cluster when closer than this fraction of the amplitude
    pub section_tolerance: f64,
}

impl Default for MotionOptions {
    fn default() -> Self {
        Self {
            rest_amplitude: 1e-5,
            decay_ratio: 0.8,
            growth_ratio: 1.25,
            peak_threshold: 1e-3,
            frequency_tolerance_bins: 0.35,
            max_subharmonic: 6,
            max_combination_order: 6,
            explained_fraction: 0.95,
            section_tolerance: 1e-3,
        }
    }
}

/// A one-sided amplitude spectrum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// bin spacing 2π/T of the window \[rad/s\]
    pub resolution_rad_s: f64,
    /// amplitude of bin k (at ω = k·resolution), scaled so that a sine of amplitude A on a
    /// bin shows A
    pub amplitude: Vec<f64>,
}

impl Spectrum {
    /// The frequency of bin k \[rad/s\].
    pub fn omega(&self, k: usize) -> f64 {
        k as f64 * self.resolution_rad_s
    }
}

/// A peak of a spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpectralPeak {
    /// frequency \[rad/s\] (parabolic refinement)
    pub omega_rad_s: f64,
    /// amplitude at the peak bin
    pub amplitude: f64,
}

/// The Hann-windowed amplitude spectrum of `signal` sampled every `dt` (mean removed).
pub fn spectrum(signal: &[f64], dt: f64) -> Spectrum {
    let n = signal.len();
    if n < 4 || dt.is_nan() || dt <= 0.0 {
        return Spectrum {
            resolution_rad_s: f64::NAN,
            amplitude: Vec::new(),
        };
    }
    let mean = signal.iter().sum::<f64>() / n as f64;
    let hann = |i: usize| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
    let mut buf: Vec<Complex<f64>> = signal
        .iter()
        .enumerate()
        .map(|(i, x)| Complex::new((x - mean) * hann(i), 0.0))
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    // a sine of amplitude A on a bin gives |X_k| = A·n/4 with the Hann window (coherent gain ½)
    let scale = 4.0 / n as f64;
    Spectrum {
        resolution_rad_s: 2.0 * std::f64::consts::PI / (n as f64 * dt),
        amplitude: buf[..n / 2].iter().map(|z| z.norm() * scale).collect(),
    }
}

/// The peaks of `s`: bins that are the largest within ±2 bins and at least `threshold`
/// times the largest amplitude, in decreasing amplitude; the DC bin and its neighbour are
/// skipped.
pub fn spectral_peaks(s: &Spectrum, threshold: f64) -> Vec<SpectralPeak> {
    let a = &s.amplitude;
    let top = a.iter().skip(2).copied().fold(0.0, f64::max);
    if a.len() < 5 || top.is_nan() || top <= 0.0 {
        return Vec::new();
    }
    let mut peaks: Vec<SpectralPeak> = (2..a.len() - 2)
        .filter(|&k| a[k] >= threshold * top && (k - 2..=k + 2).all(|j| a[j] <= a[k]))
        .map(|k| SpectralPeak {
            omega_rad_s: refined_omega(s, k),
            amplitude: a[k],
        })
        .collect();
    peaks.sort_by(|p, q| q.amplitude.total_cmp(&p.amplitude));
    peaks
}

/// Parabolic interpolation of the log magnitude around bin k.
fn refined_omega(s: &Spectrum, k: usize) -> f64 {
    let l = |j: usize| s.amplitude[j].max(f64::MIN_POSITIVE).ln();
    let (y0, y1, y2) = (l(k - 1), l(k), l(k + 1));
    let den = y0 - 2.0 * y1 + y2;
    let shift = if den < 0.0 {
        0.5 * (y0 - y2) / den
    } else {
        0.0
    };
    (k as f64 + shift.clamp(-0.5, 0.5)) * s.resolution_rad_s
}

/// Values of `value` where `trigger` crosses zero upwards, both sampled at the same
/// instants (linear interpolation between the two samples around the crossing).
pub fn poincare_section(trigger: &[f64], value: &[f64]) -> Vec<f64> {
    trigger
        .windows(2)
        .zip(value.windows(2))
        .filter(|(t, _)| t[0] < 0.0 && t[1] >= 0.0)
        .map(|(t, v)| {
            let s = -t[0] / (t[1] - t[0]);
            v[0] + s * (v[1] - v[0])
        })
        .collect()
}

/// The rotation number of a section sequence s_k (see the module documentation), folded to
/// [0, ½]; None for fewer than 8 values or a degenerate (point or segment) embedding.
pub fn section_rotation_number(s: &[f64]) -> Option<f64> {
    if s.len() < 8 {
        return None;
    }
    let pts: Vec<(f64, f64)> = s.windows(2).map(|w| (w[0], w[1])).collect();
    let n = pts.len() as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
    let (mut cxx, mut cxy, mut cyy) = (0.0, 0.0, 0.0);
    for p in &pts {
        let (x, y) = (p.0 - mx, p.1 - my);
        cxx += x * x / n;
        cxy += x * y / n;
        cyy += y * y / n;
    }
    // Cholesky C = L·Lᵀ; whitened w = L⁻¹ (z − mean)
    let l11 = cxx.sqrt();
    let l21 = cxy / l11;
    let l22_sq = cyy - l21 * l21;
    if l11.is_nan() || l11 <= 0.0 || l22_sq.is_nan() || l22_sq <= 1e-12 * (cxx + cyy) {
        return None;
    }
    let l22 = l22_sq.sqrt();
    let angle = |p: &(f64, f64)| {
        let x = (p.0 - mx) / l11;
        let y = ((p.1 - my) - l21 * x) / l22;
        y.atan2(x)
    };
    let angles: Vec<f64> = pts.iter().map(angle).collect();
    let tau = 2.0 * std::f64::consts::PI;
    let mean_turn = angles
        .windows(2)
        .map(|w| {
            let d = (w[1] - w[0]).rem_euclid(tau);
            if d > std::f64::consts::PI { d - tau } else { d }
        })
        .sum::<f64>()
        / (angles.len() - 1) as f64;
    Some((mean_turn / tau).abs())
}

/// The period of a section sequence: the smallest k ≤ `max_k` with |s_{i+k} − s_i| ≤ `tol`
/// for every i of the second half (a fixed point: 1, a finite set of k points: k); None if
/// the sequence does not repeat (a closed curve or a cloud) or has fewer than 2·`max_k` + 2
/// values.
pub fn section_period(s: &[f64], max_k: usize, tol: f64) -> Option<usize> {
    if s.len() < 2 * max_k + 2 {
        return None;
    }
    let tail = &s[s.len() / 2..];
    (1..=max_k).find(|&k| tail.windows(k + 1).all(|w| (w[k] - w[0]).abs() <= tol))
}

/// Number of clusters of `values`: sorted, a gap larger than `tol` starts a new one.
pub fn cluster_count(values: &[f64], tol: f64) -> usize {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0;
    }
    v.sort_by(f64::total_cmp);
    1 + v.windows(2).filter(|w| w[1] - w[0] > tol).count()
}

/// What [`classify`] found, with the evidence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotionEvidence {
    /// the class
    pub class: MotionClass,
    /// half peak-to-peak amplitude over the first half of the window
    pub amplitude_first_half: f64,
    /// half peak-to-peak amplitude over the second half of the window
    pub amplitude_second_half: f64,
    /// spectral resolution 2π/T_window \[rad/s\]
    pub resolution_rad_s: f64,
    /// the spectral peaks, largest first (at most 12 kept)
    pub peaks: Vec<SpectralPeak>,
    /// the base frequencies \[rad/s\]: one (periodic), two (quasi-periodic), none otherwise
    pub base_frequencies_rad_s: Vec<f64>,
    /// ω2/ω1 of the base frequencies (quasi-periodic), or the period multiple k (periodic)
    pub frequency_ratio: Option<f64>,
    /// number of section points
    pub section_points: usize,
    /// number of distinct section values (clusters at `section_tolerance` × amplitude)
    pub section_clusters: usize,
    /// the section repeats after this many returns (a finite set; `section_tolerance` ×
    /// amplitude, up to 2·`max_subharmonic`); None: it does not repeat (a curve)
    pub section_period: Option<usize>,
    /// rotation number of the section, folded to [0, ½]
    pub section_rotation_number: Option<f64>,
    /// amplitude of the second base frequency in the second half of the window over that
    /// in the first half (< `decay_ratio`: a decaying transient, classified periodic);
    /// None without a second frequency
    pub second_frequency_trend: Option<f64>,
}

/// Amplitude of the component of frequency ω \[rad/s\] in `x` (sampled every `dt`):
/// Hann-windowed Fourier sum, mean removed (a sine of amplitude A at ω gives ≈ A).
pub fn component_amplitude(x: &[f64], dt: f64, omega: f64) -> f64 {
    let n = x.len();
    if n < 4 {
        return 0.0;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let (mut re, mut im) = (0.0, 0.0);
    for (i, v) in x.iter().enumerate() {
        let h = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
        let (s, c) = (omega * i as f64 * dt).sin_cos();
        re += (v - mean) * h * c;
        im += (v - mean) * h * s;
    }
    4.0 * (re * re + im * im).sqrt() / n as f64
}

/// Half peak-to-peak range.
fn half_range(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if lo <= hi { 0.5 * (hi - lo) } else { 0.0 }
}

/// Classifies `signal` (sampled every `dt`, the transient already cut off) with the
/// Poincaré section `section` (values of the signal on a transversal, e.g. from
/// [`poincare_section`]); see the module documentation for the rules.
pub fn classify(signal: &[f64], dt: f64, section: &[f64], o: &MotionOptions) -> MotionEvidence {
    let half = signal.len() / 2;
    let a1 = half_range(&signal[..half]);
    let a2 = half_range(&signal[half..]);
    let spec = spectrum(signal, dt);
    let mut peaks = spectral_peaks(&spec, o.peak_threshold);
    let finite = signal.iter().all(|x| x.is_finite());
    let mut ev = MotionEvidence {
        class: MotionClass::Irregular,
        amplitude_first_half: a1,
        amplitude_second_half: a2,
        resolution_rad_s: spec.resolution_rad_s,
        peaks: Vec::new(),
        base_frequencies_rad_s: Vec::new(),
        frequency_ratio: None,
        section_points: section.len(),
        section_clusters: cluster_count(section, o.section_tolerance * a2.max(o.rest_amplitude)),
        section_period: section_period(
            section,
            2 * o.max_subharmonic,
            o.section_tolerance * a2.max(o.rest_amplitude),
        ),
        section_rotation_number: section_rotation_number(section),
        second_frequency_trend: None,
    };
    ev.class = if !finite || (a1 > 0.0 && a2 > o.growth_ratio * a1) {
        MotionClass::LossOfControl
    } else if a2 < o.rest_amplitude || a2 < o.decay_ratio * a1 {
        MotionClass::Equilibrium
    } else if let Some((w0, k)) = periodic_fundamental(&peaks, spec.resolution_rad_s, o) {
        // the section must agree: a periodic motion returns to a finite set; if it does
        // not, a weak second frequency below the threshold modulates it
        let weak = spectral_peaks(&spec, 1e-2 * o.peak_threshold);
        let repeats = ev.section_period.is_some() || section.len() < 4 * o.max_subharmonic + 2;
        match torus_frequencies(&weak, spec.resolution_rad_s, o) {
            Some((w1, w2)) if !repeats => {
                ev.base_frequencies_rad_s = vec![w1, w2];
                ev.frequency_ratio = Some(w2 / w1);
                peaks = weak;
                MotionClass::QuasiPeriodic
            }
            _ => {
                ev.base_frequencies_rad_s = vec![w0];
                ev.frequency_ratio = Some(k as f64);
                MotionClass::Periodic
            }
        }
    } else if let Some((w1, w2)) = torus_frequencies(&peaks, spec.resolution_rad_s, o) {
        ev.base_frequencies_rad_s = vec![w1, w2];
        ev.frequency_ratio = Some(w2 / w1);
        MotionClass::QuasiPeriodic
    } else {
        MotionClass::Irregular
    };
    if ev.class == MotionClass::QuasiPeriodic {
        let (w1, w2) = (ev.base_frequencies_rad_s[0], ev.base_frequencies_rad_s[1]);
        let first = component_amplitude(&signal[..half], dt, w2);
        let second = component_amplitude(&signal[half..], dt, w2);
        let trend = second / first;
        ev.second_frequency_trend = Some(trend);
        if trend < o.decay_ratio {
            ev.class = MotionClass::Periodic;
            ev.base_frequencies_rad_s = vec![w1];
            ev.frequency_ratio = Some(1.0);
        }
    }
    peaks.truncate(12);
    ev.peaks = peaks;
    ev
}

fn matches(w: f64, target: f64, resolution: f64, o: &MotionOptions) -> bool {
    (w - target).abs() <= o.frequency_tolerance_bins * resolution + 1e-3 * target.abs()
}

/// ω0 and k if every peak is a harmonic of ω0 = ω_max/k (smallest k).
fn periodic_fundamental(
    peaks: &[SpectralPeak],
    resolution: f64,
    o: &MotionOptions,
) -> Option<(f64, usize)> {
    let top = peaks.first()?.omega_rad_s;
    (1..=o.max_subharmonic.max(1)).find_map(|k| {
        let w0 = top / k as f64;
        let all = peaks.iter().all(|p| {
            let n = (p.omega_rad_s / w0).round().max(1.0);
            matches(p.omega_rad_s, n * w0, resolution, o)
        });
        all.then_some((w0, k))
    })
}

/// (ω1, ω2) if the combinations of the largest peak and the largest non-harmonic peak
/// explain the peaks' power.
fn torus_frequencies(
    peaks: &[SpectralPeak],
    resolution: f64,
    o: &MotionOptions,
) -> Option<(f64, f64)> {
    let w1 = peaks.first()?.omega_rad_s;
    let is_harmonic = |w: f64| {
        let n = (w / w1).round();
        n >= 1.0 && matches(w, n * w1, resolution, o)
    };
    let w2 = peaks
        .iter()
        .find(|p| !is_harmonic(p.omega_rad_s))?
        .omega_rad_s;
    let order = o.max_combination_order;
    let explained = |w: f64| {
        (-order..=order).any(|m| {
            (-order..=order).any(|n| {
                m.abs() + n.abs() <= order
                    && (m, n) != (0, 0)
                    && matches(
                        w,
                        (f64::from(m) * w1 + f64::from(n) * w2).abs(),
                        resolution,
                        o,
                    )
            })
        })
    };
    let power = |p: &SpectralPeak| p.amplitude * p.amplitude;
    let total: f64 = peaks.iter().map(power).sum();
    let covered: f64 = peaks
        .iter()
        .filter(|p| explained(p.omega_rad_s))
        .map(power)
        .sum();
    (covered >= o.explained_fraction * total).then_some((w1, w2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const DT: f64 = 0.01;
    /// a window of 200 s: resolution 2π/200 = 0.0314 rad/s
    const N: usize = 20_000;

    fn sampled(f: impl Fn(f64) -> f64) -> Vec<f64> {
        (0..N).map(|i| f(i as f64 * DT)).collect()
    }

    /// the section of x at the upward zero crossings of sin(ω t + φ)
    fn section_of(x: &[f64], w: f64) -> Vec<f64> {
        let trig = sampled(|t| (w * t + 0.3).sin());
        poincare_section(&trig, x)
    }

    #[test]
    fn a_single_sine_with_harmonics_is_periodic() {
        // reference: the constructed signal's own frequency 3.7 rad/s (off the bin grid);
        // tolerance 0.01 rad/s (a third of a bin: parabolic peak interpolation)
        let w = 3.7;
        let x = sampled(|t| (w * t).sin() + 0.1 * (2.0 * w * t + 1.0).cos());
        let ev = classify(&x, DT, &section_of(&x, w), &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::Periodic, "{ev:?}");
        assert!((ev.base_frequencies_rad_s[0] - w).abs() < 0.01, "{ev:?}");
        // the section is one point (one cluster, period 1)
        assert_eq!(ev.section_clusters, 1, "{ev:?}");
        assert_eq!(ev.section_period, Some(1), "{ev:?}");
    }

    #[test]
    fn a_period_two_signal_is_periodic_with_k_2() {
        // reference: the constructed subharmonic ω/2 (a period-doubled cycle)
        let w = 4.0;
        let x = sampled(|t| (w * t).sin() + 0.2 * (0.5 * w * t).sin());
        let ev = classify(&x, DT, &[], &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::Periodic, "{ev:?}");
        assert_eq!(ev.frequency_ratio, Some(2.0));
        assert!((ev.base_frequencies_rad_s[0] - 2.0).abs() < 0.01, "{ev:?}");
    }

    #[test]
    fn two_incommensurate_sines_are_quasi_periodic() {
        // reference: ω1 = 3.9, ω2 = 3.9·(1 + √5)/2 (golden ratio, the most irrational);
        // frequencies to 0.01 rad/s, the section's rotation number ρ = frac(ω2/ω1) folded,
        // to 1e-3 (a rigid rotation seen through the whitened delay embedding is exact up to
        // the finite number of returns)
        let (w1, g) = (3.9, 0.5 * (1.0 + 5f64.sqrt()));
        let w2 = w1 * g;
        let x = sampled(|t| (w1 * t).sin() + 0.3 * (w2 * t + 0.4).sin());
        let s = section_of(&x, w1);
        let ev = classify(&x, DT, &s, &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::QuasiPeriodic, "{ev:?}");
        assert!((ev.base_frequencies_rad_s[0] - w1).abs() < 0.01, "{ev:?}");
        assert!((ev.base_frequencies_rad_s[1] - w2).abs() < 0.01, "{ev:?}");
        let rho = g.fract().min(1.0 - g.fract());
        let r = ev.section_rotation_number.unwrap();
        assert!((r - rho).abs() < 1e-3, "{r} vs {rho}");
        // the section fills a closed curve: almost every return is a new value (a few of
        // the 124 land within the cluster tolerance 1e-3·amplitude of an earlier one)
        assert!(ev.section_clusters > 8 * s.len() / 10, "{ev:?}");
        assert_eq!(ev.section_period, None, "{ev:?}");
    }

    #[test]
    fn a_rational_frequency_pair_is_periodic() {
        // reference: ω2/ω1 = 5/2 exactly: a common period 2·2π/ω1, so periodic with k = 2
        let w1 = 3.0;
        let x = sampled(|t| (w1 * t).sin() + 0.3 * (2.5 * w1 * t).sin());
        let ev = classify(&x, DT, &section_of(&x, w1), &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::Periodic, "{ev:?}");
        assert_eq!(ev.section_clusters, 2, "{ev:?}");
        assert_eq!(ev.section_period, Some(2), "{ev:?}");
    }

    #[test]
    fn a_weak_second_frequency_seen_in_the_section_is_quasi_periodic() {
        // reference: a second, incommensurate sine at 3e-4 of the first (below the 1e-3
        // peak threshold, above 1e-2 of it): the spectrum alone says periodic, the section
        // does not repeat (at a section tolerance of 1e-5 of the amplitude, below the
        // modulation 3e-4), so the weak peaks decide: quasi-periodic with ω2 to 0.01 rad/s
        let (w1, w2) = (3.9, 3.9 * 0.5 * (1.0 + 5f64.sqrt()));
        let x = sampled(|t| (w1 * t).sin() + 3e-4 * (w2 * t).sin());
        let o = MotionOptions {
            section_tolerance: 1e-5,
            ..MotionOptions::default()
        };
        let ev = classify(&x, DT, &section_of(&x, w1), &o);
        assert_eq!(ev.class, MotionClass::QuasiPeriodic, "{ev:?}");
        assert!((ev.base_frequencies_rad_s[1] - w2).abs() < 0.01, "{ev:?}");
    }

    #[test]
    fn a_decaying_second_frequency_is_periodic() {
        // reference: the constructed signal, a cycle of 3.7 rad/s with a transverse mode of
        // 9.1 rad/s decaying as e^{−0.01 t}: between the window halves (100 s apart) its
        // amplitude falls to e^{−1} = 0.37 (tolerance 0.05: Hann leakage of the cycle at
        // 9.1 rad/s), below decay_ratio = 0.8, so the motion settles onto the cycle
        let x = sampled(|t| (3.7 * t).sin() + 0.05 * (-0.01 * t).exp() * (9.1 * t + 0.4).sin());
        let ev = classify(&x, DT, &section_of(&x, 3.7), &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::Periodic, "{ev:?}");
        let trend = ev.second_frequency_trend.expect("two frequencies seen");
        assert!((trend - (-1.0f64).exp()).abs() < 0.05, "{trend}");
        // the same mode growing: a torus being approached, not a cycle
        let y = sampled(|t| (3.7 * t).sin() + 0.05 * (0.002 * t).exp() * (9.1 * t + 0.4).sin());
        let ev = classify(&y, DT, &section_of(&y, 3.7), &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::QuasiPeriodic, "{ev:?}");
    }

    #[test]
    fn a_decaying_oscillation_is_equilibrium() {
        // reference: e^{−0.02 t}: the second half is e^{−2} = 0.14 of the first (< 0.8)
        let x = sampled(|t| (-0.02 * t).exp() * (4.0 * t).sin());
        let ev = classify(&x, DT, &[], &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::Equilibrium, "{ev:?}");
    }

    #[test]
    fn a_growing_or_diverging_oscillation_is_loss_of_control() {
        // reference: e^{+0.01 t}: second/first half = e = 2.7 (> 1.25); a NaN sample
        // (a diverged integration) likewise
        let x = sampled(|t| (0.01 * t).exp() * (4.0 * t).sin());
        let ev = classify(&x, DT, &[], &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::LossOfControl, "{ev:?}");
        let mut y = sampled(|t| (4.0 * t).sin());
        y[N - 1] = f64::NAN;
        let ev = classify(&y, DT, &[], &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::LossOfControl, "{ev:?}");
    }

    #[test]
    fn broadband_noise_is_irregular() {
        // reference: a deterministic pseudo-random sequence (logistic map at r = 4, chaotic)
        let mut z = 0.3;
        let x: Vec<f64> = (0..N)
            .map(|_| {
                z = 4.0 * z * (1.0 - z);
                z - 0.5
            })
            .collect();
        let ev = classify(&x, DT, &[], &MotionOptions::default());
        assert_eq!(ev.class, MotionClass::Irregular, "{ev:?}");
    }

    #[test]
    fn spectrum_amplitude_of_an_on_bin_sine() {
        // reference: a sine of amplitude 2 exactly on bin 100 shows 2 (Hann coherent gain
        // compensated), to 1e-12
        let w = 100.0 * 2.0 * PI / (N as f64 * DT);
        let s = spectrum(&sampled(|t| 2.0 * (w * t).sin()), DT);
        assert!(
            (s.amplitude[100] - 2.0).abs() < 1e-12,
            "{}",
            s.amplitude[100]
        );
        assert!((s.omega(100) - w).abs() < 1e-12);
    }
}
