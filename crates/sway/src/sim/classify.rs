//! The honest classification of a run: is the trailer still swaying at the
//! horizon, or only a transient that has not died out yet?
//!
//! The last two windows of the run, `[T − 2W, T − W]` and `[T − W, T]` (W = the final
//! window of [`MetricSettings`]), are watched on the fly: per window the largest and smallest
//! θ, and the turning points of θ (θ̇ = 0, located exactly as solver events). From them:
//! - the crossings of θ − mean in the final window (mean = (max + min)/2): the number of
//!   successive turning points (with the window's first and last values) on opposite sides;
//! - the oscillation amplitude of a window, A = the mean of |θ − mean| over its turning
//!   points, dated at their mean time (with fewer than two turning points: (max − min)/2 at
//!   the window's middle);
//! - the decay rate ln(A_previous / A_final) / Δt \[1/s\] between those dates (> 0: shrinking,
//!   < 0: growing).
//!
//! Then [`classify`]: `settled` if max |θ| over the final window is below the settle
//! threshold; `offset` if it is not, but θ does not oscillate (fewer than `min_crossings`
//! crossings, or a half range below the threshold); `decaying` if it oscillates but its
//! amplitude shrinks by more than `decay_tolerance` per window length W (decay rate · W >
//! −ln(1 − tolerance)); otherwise `sustained_sway` (an oscillation that persists or grows).

use serde::{Deserialize, Serialize};

use crate::config::Positive;

/// Settings of the metrics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricSettings {
    /// |θ| below this counts as settled \[deg\]
    pub settle_threshold_deg: Positive,
    /// `final_amplitude_deg` is max |θ| over the last this many seconds \[s\]; the
    /// classification compares this window with the one before it
    pub final_window_s: Positive,
    /// θ oscillates when θ − mean crosses zero at least this often in the final window
    /// (classification, see [`crate::sim::classify`])
    pub min_crossings: usize,
    /// an oscillation is `decaying` when its amplitude, from the window before the final one
    /// to the final one, shrinks faster than by this fraction per window length; otherwise
    /// it is sustained sway
    pub decay_tolerance: Positive,
}

impl Default for MetricSettings {
    fn default() -> Self {
        Self {
            settle_threshold_deg: Positive::literal(1.0),
            final_window_s: Positive::literal(5.0),
            min_crossings: 2,
            decay_tolerance: Positive::literal(1e-3),
        }
    }
}

/// The class of a simulated point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SwayClass {
    /// an oscillation that persists (or grows) between the last two windows
    SustainedSway,
    /// an oscillation above the threshold at the horizon, but shrinking
    Decaying,
    /// |θ| above the threshold, but not oscillating (e.g. a constant hitch angle)
    Offset,
    /// |θ| below the threshold over the final window
    Settled,
    /// the validity guard stopped the run
    LossOfControl,
    /// the run failed (solver error)
    Failed,
}

impl SwayClass {
    /// The snake_case name used in CSV and JSON.
    pub fn as_str(&self) -> &'static str {
        match self {
            SwayClass::SustainedSway => "sustained_sway",
            SwayClass::Decaying => "decaying",
            SwayClass::Offset => "offset",
            SwayClass::Settled => "settled",
            SwayClass::LossOfControl => "loss_of_control",
            SwayClass::Failed => "failed",
        }
    }

    /// Every class, in the order summaries count them.
    pub const ALL: [SwayClass; 6] = [
        SwayClass::SustainedSway,
        SwayClass::Decaying,
        SwayClass::Offset,
        SwayClass::Settled,
        SwayClass::LossOfControl,
        SwayClass::Failed,
    ];
}

/// What one window saw of θ \[rad\]: extremes, first and last value, turning points.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Window {
    /// largest θ
    pub max: f64,
    /// smallest θ
    pub min: f64,
    /// θ at the start of the window (None: nothing seen yet)
    pub first: Option<f64>,
    /// the last θ seen (the end of the window once the run is over)
    pub last: Option<f64>,
    /// the turning points (t, θ) (θ̇ = 0), in time order
    pub turning: Vec<(f64, f64)>,
}

impl Window {
    /// An empty window whose turning-point list can hold `capacity` values without
    /// allocating again.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            max: f64::NEG_INFINITY,
            min: f64::INFINITY,
            first: None,
            last: None,
            turning: Vec::with_capacity(capacity),
        }
    }

    /// Whether anything was seen.
    pub fn is_empty(&self) -> bool {
        self.first.is_none() && self.last.is_none() && self.turning.is_empty()
    }

    /// A value of θ somewhere in the window (extremes, first and last value).
    #[inline]
    pub fn value(&mut self, theta: f64) {
        self.max = self.max.max(theta);
        self.min = self.min.min(theta);
        if self.first.is_none() {
            self.first = Some(theta);
        }
        self.last = Some(theta);
    }

    /// θ at the window's start (replaces a first value seen later in the same step).
    #[inline]
    pub fn start(&mut self, theta: f64) {
        self.max = self.max.max(theta);
        self.min = self.min.min(theta);
        self.first = Some(theta);
    }

    /// A turning point of θ at time t.
    #[inline]
    pub fn turning_point(&mut self, t: f64, theta: f64) {
        self.max = self.max.max(theta);
        self.min = self.min.min(theta);
        self.turning.push((t, theta));
    }

    /// The half range (max − min)/2 (0 for an empty window).
    pub fn half_range(&self) -> f64 {
        if self.max >= self.min {
            0.5 * (self.max - self.min)
        } else {
            0.0
        }
    }

    /// The oscillation amplitude and its date: the mean |θ − mean| over the turning points
    /// and their mean time; None with fewer than two turning points.
    pub fn amplitude(&self) -> Option<(f64, f64)> {
        let n = self.turning.len();
        if n < 2 {
            return None;
        }
        let mid = 0.5 * (self.max + self.min);
        let a = self
            .turning
            .iter()
            .map(|(_, th)| (th - mid).abs())
            .sum::<f64>()
            / n as f64;
        let t = self.turning.iter().map(|(t, _)| t).sum::<f64>() / n as f64;
        Some((a, t))
    }

    /// Crossings of θ − mean (mean = (max + min)/2) along first value, turning points,
    /// last value.
    pub fn crossings(&self) -> usize {
        let mid = 0.5 * (self.max + self.min);
        let seq = self
            .first
            .iter()
            .chain(self.turning.iter().map(|(_, th)| th))
            .chain(self.last.iter());
        let mut side = 0.0_f64;
        let mut n = 0;
        for &v in seq {
            let s = (v - mid).signum() * f64::from(u8::from(v != mid));
            if s != 0.0 {
                if side != 0.0 && s != side {
                    n += 1;
                }
                side = s;
            }
        }
        n
    }
}

/// The classification's view of a run: its last two windows and max |θ| over the final one.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Windows {
    /// `[T − 2W, T − W]`
    pub previous: Window,
    /// `[T − W, T]`
    pub last: Window,
}

/// The verdict on a run that reached its horizon: `decaying` when the amplitude shrinks by
/// more than the tolerance per window length W, i.e. decay rate × W > −ln(1 − tolerance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// the class
    pub class: SwayClass,
    /// ln(A_previous / A_final) / Δt \[1/s\] of a sustained or decaying oscillation (None
    /// for the other classes)
    pub decay_rate_per_s: Option<f64>,
    /// crossings of θ − mean in the final window
    pub crossings: usize,
}

/// Classifies a run that reached its horizon from its two windows (θ in rad).
pub fn classify(w: &Windows, settings: &MetricSettings) -> Verdict {
    let thr = settings.settle_threshold_deg.get().to_radians();
    let window = settings.final_window_s.get();
    let ((a_prev, t_prev), (a_last, t_last)) = match (w.previous.amplitude(), w.last.amplitude()) {
        (Some(p), Some(l)) if l.1 > p.1 => (p, l),
        _ => (
            (w.previous.half_range(), 0.0),
            (w.last.half_range(), window),
        ),
    };
    let decay_rate_per_s = (a_prev > 0.0 && a_last > 0.0 && t_last > t_prev)
        .then(|| (a_prev / a_last).ln() / (t_last - t_prev))
        .filter(|r| r.is_finite());
    let crossings = w.last.crossings();
    let max_abs = w.last.max.abs().max(w.last.min.abs());
    let class = if w.last.is_empty() || max_abs < thr {
        SwayClass::Settled
    } else if crossings < settings.min_crossings || w.last.half_range() < thr {
        SwayClass::Offset
    } else if decay_rate_per_s
        .is_some_and(|r| r * window > -(1.0 - settings.decay_tolerance.get()).ln())
    {
        SwayClass::Decaying
    } else {
        SwayClass::SustainedSway
    };
    let oscillating = matches!(class, SwayClass::SustainedSway | SwayClass::Decaying);
    Verdict {
        class,
        decay_rate_per_s: decay_rate_per_s.filter(|_| oscillating),
        crossings,
    }
}

/// Classifies a sampled signal θ(t) \[rad\] (uniform or not, t increasing) ending at its
/// last time, with the same windows and rules as a simulation (turning points are the
/// samples that are local extrema). Used to test the rules on constructed signals.
pub fn classify_samples(t: &[f64], theta: &[f64], settings: &MetricSettings) -> Verdict {
    let n = t.len().min(theta.len());
    let Some(&end) = t.get(n.wrapping_sub(1)) else {
        return classify(&Windows::default(), settings);
    };
    let w = settings.final_window_s.get();
    let (from_prev, from_last) = (end - 2.0 * w, end - w);
    let mut ws = Windows {
        previous: Window::with_capacity(n),
        last: Window::with_capacity(n),
    };
    for i in 0..n {
        let win = if t[i] >= from_last {
            &mut ws.last
        } else if t[i] >= from_prev {
            &mut ws.previous
        } else {
            continue;
        };
        let turning =
            i > 0 && i + 1 < n && (theta[i] - theta[i - 1]) * (theta[i + 1] - theta[i]) < 0.0;
        if turning {
            win.turning_point(t[i], theta[i]);
        } else if win.first.is_none() {
            win.start(theta[i]);
        } else {
            win.value(theta[i]);
        }
    }
    if let Some(&v) = theta.get(n - 1) {
        ws.last.last = Some(v);
    }
    classify(&ws, settings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Positive;
    use std::f64::consts::PI;

    // Constructed signals over 60 s, sampled at 100 Hz, with the sway period of the model
    // (≈ 2.8 s); amplitudes in degrees. Reference: the class each signal is by construction.
    fn signal(f: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..=6000).map(|i| i as f64 * 0.01).collect();
        let th = t.iter().map(|&t| f(t).to_radians()).collect();
        (t, th)
    }

    fn settings() -> MetricSettings {
        MetricSettings::default()
    }

    const W: f64 = 2.0 * PI / 2.8;

    #[test]
    fn sustained_sine_is_sustained_sway() {
        let (t, th) = signal(|t| 5.0 * (W * t).sin());
        let v = classify_samples(&t, &th, &settings());
        assert_eq!(v.class, SwayClass::SustainedSway);
        // exact: equal amplitudes; sampling at 100 Hz resolves the peak to 1 − cos(W·0.005)
        assert!(v.decay_rate_per_s.unwrap().abs() < 1e-4, "{v:?}");
        assert!(v.crossings >= 3, "{v:?}");
    }

    #[test]
    fn decaying_sine_reports_its_decay_rate() {
        // 20° decaying at 0.03 /s: 3.3° at 60 s, still above the 1° threshold
        let (t, th) = signal(|t| 20.0 * (-0.03 * t).exp() * (W * t).sin());
        let v = classify_samples(&t, &th, &settings());
        assert_eq!(v.class, SwayClass::Decaying);
        // reference 0.03 /s; the (max − min)/2 of a window of a non-integer number of
        // periods is off by the envelope's change over ≈ half a period: 2 % here
        let r = v.decay_rate_per_s.unwrap();
        assert!((r - 0.03).abs() < 0.03 * 0.1, "rate {r}");
    }

    #[test]
    fn constant_offset_is_offset() {
        let (t, th) = signal(|_| 20.0);
        assert_eq!(
            classify_samples(&t, &th, &settings()).class,
            SwayClass::Offset
        );
        // a slow monotone drift at a large angle is not an oscillation either
        let (t, th) = signal(|t| 20.0 - 0.1 * t);
        assert_eq!(
            classify_samples(&t, &th, &settings()).class,
            SwayClass::Offset
        );
    }

    #[test]
    fn growing_oscillation_is_sustained_sway_with_negative_decay_rate() {
        let (t, th) = signal(|t| 0.5 * (0.05 * t).exp() * (W * t).sin());
        let v = classify_samples(&t, &th, &settings());
        assert_eq!(v.class, SwayClass::SustainedSway);
        let r = v.decay_rate_per_s.unwrap();
        assert!((r + 0.05).abs() < 0.05 * 0.1, "rate {r}");
    }

    #[test]
    fn small_signal_is_settled() {
        let (t, th) = signal(|t| 0.5 * (W * t).sin());
        assert_eq!(
            classify_samples(&t, &th, &settings()).class,
            SwayClass::Settled
        );
    }

    #[test]
    fn tolerance_decides_a_slow_decay() {
        // 1e-4 /s over a 5 s window: a relative drop of 5e-4 < the default tolerance 1e-3
        let (t, th) = signal(|t| 5.0 * (-1e-4 * t).exp() * (W * t).sin());
        assert_eq!(
            classify_samples(&t, &th, &settings()).class,
            SwayClass::SustainedSway
        );
        let strict = MetricSettings {
            decay_tolerance: Positive::literal(1e-5),
            ..settings()
        };
        assert_eq!(
            classify_samples(&t, &th, &strict).class,
            SwayClass::Decaying
        );
    }
}
