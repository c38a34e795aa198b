//! The ground truth of the sway assist's evaluation, defined once: whether a run sways,
//! when the sway started, and when the trailer settled — from the simulated hitch
//! (articulation) angle θ, which no detector sees.
//!
//! **Sway** ([`SwayCriterion::judge`]): the run lost control (the validity guard,
//! [`crate::sim::LossOfControl`]), or the oscillation of θ over the final window
//! ([`SwayCriterion::final_window_s`]) has every peak |θ| at least
//! [`SWAY_AMPLITUDE_DEG`] = 3° and does not decay: its last peak is at least
//! (1 − [`SwayCriterion::decay_tolerance`]) times its first (peaks by
//! [`crate::sim::decay::peaks`]). 3° of articulation is the sway a driver notices and the
//! order of the smallest sway cycles of the bistable range.
//!
//! **Onset**: the first time |θ| reaches [`ONSET_AMPLITUDE_DEG`] = 1° after the disturbance
//! started; the latencies of detectors count from it.
//!
//! **Settled**: |θ| stays below [`ONSET_AMPLITUDE_DEG`] from some time to the run's end (the
//! settle time counts from the disturbance's end).
//!
//! **Swung**: after the disturbance started, θ reached [`SWAY_AMPLITUDE_DEG`] to both sides
//! (two alternating extrema of at least 3°) — before the loss of control in a run that lost
//! it. A loss of control that did not swing is a divergence (the trailer jackknifes
//! during or right after the manoeuvre, or a statically unstable trailer runs off to one
//! side): there is no sway to detect, and a sway assist cannot be asked to prevent it.

use serde::{Deserialize, Serialize};

use crate::sim::decay::peaks;

/// The amplitude of θ \[deg\] a sway oscillation keeps (see the module docs).
pub const SWAY_AMPLITUDE_DEG: f64 = 3.0;

/// The amplitude of θ \[deg\] whose first crossing is the sway's onset (and below which the
/// trailer has settled).
pub const ONSET_AMPLITUDE_DEG: f64 = 1.0;

/// The ground truth's settings: the final window and the decay tolerance (the amplitudes
/// are the constants of the module).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SwayCriterion {
    /// the window at the end of the run whose peaks are judged \[s\] (≥ two periods of the
    /// sway mode, ≈ 0.5–0.8 Hz)
    pub final_window_s: f64,
    /// the relative decay of the peaks over the window still counted as not decaying \[-\]
    pub decay_tolerance: f64,
}

impl Default for SwayCriterion {
    fn default() -> Self {
        Self {
            final_window_s: 5.0,
            decay_tolerance: 0.05,
        }
    }
}

/// The truth of one run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RunTruth {
    /// sustained sway at the end (without loss of control)
    pub sustained_sway: bool,
    /// the first time |θ| reached the onset amplitude after the disturbance started \[s\]
    pub onset_s: Option<f64>,
    /// the sway's period from the final window's peaks \[s\] (two half-periods between
    /// successive extrema), when it has two peaks
    pub period_s: Option<f64>,
    /// max |θ| \[deg\] over the run
    pub peak_hitch_angle_deg: f64,
    /// the time from `settle_from_s` until |θ| stays below the onset amplitude to the end
    /// \[s\] (None: it does not settle, or control was lost)
    pub settle_time_s: Option<f64>,
    /// θ reached the sway amplitude to both sides after the disturbance started (before
    /// the loss of control, if any): the run swung (see the module docs)
    pub swung: bool,
}

impl SwayCriterion {
    /// The truth of a run sampled at times `t` \[s\] with hitch angles `theta` \[rad\], its
    /// disturbance from `from_s`, the settle time counted from `settle_from_s`; `lost`:
    /// the run lost control.
    pub fn judge(
        &self,
        t: &[f64],
        theta: &[f64],
        from_s: f64,
        settle_from_s: f64,
        lost: bool,
    ) -> RunTruth {
        let onset = ONSET_AMPLITUDE_DEG.to_radians();
        let onset_s = t
            .iter()
            .zip(theta)
            .find(|(s, th)| **s >= from_s && th.abs() >= onset)
            .map(|(s, _)| *s);
        let peak = theta.iter().fold(0.0f64, |m, th| m.max(th.abs()));
        let t_end = t.last().copied().unwrap_or(0.0);
        let window_from = t_end - self.final_window_s;
        let p = peaks(t, theta, window_from.max(from_s), 0.1f64.to_radians());
        let amplitude = SWAY_AMPLITUDE_DEG.to_radians();
        let sustained_sway = !lost
            && p.len() >= 3
            && p.iter().all(|q| q.value.abs() >= amplitude)
            && p.last().map_or(0.0, |q| q.value.abs())
                >= (1.0 - self.decay_tolerance) * p[0].value.abs();
        let period_s = (p.len() >= 2).then(|| {
            let (first, last) = (p[0].t, p[p.len() - 1].t);
            2.0 * (last - first) / (p.len() - 1) as f64
        });
        let swung = {
            let all = peaks(t, theta, from_s, 0.1f64.to_radians());
            let left = all.iter().any(|q| q.value >= amplitude);
            let right = all.iter().any(|q| q.value <= -amplitude);
            left && right
        };
        let settle_time_s = if lost {
            None
        } else {
            let last_above = t
                .iter()
                .zip(theta)
                .rev()
                .find(|(_, th)| th.abs() >= onset)
                .map(|(s, _)| *s);
            match last_above {
                None => Some(0.0),
                Some(s) if s < t_end => Some((s - settle_from_s).max(0.0)),
                Some(_) => None,
            }
        };
        RunTruth {
            sustained_sway,
            onset_s,
            period_s,
            peak_hitch_angle_deg: peak.to_degrees(),
            settle_time_s,
            swung,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// θ(t) \[rad\] sampled at 100 Hz over `seconds`.
    fn sampled(theta_deg: impl Fn(f64) -> f64, seconds: f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..=(seconds * 100.0) as usize)
            .map(|k| k as f64 / 100.0)
            .collect();
        let th = t.iter().map(|&s| theta_deg(s).to_radians()).collect();
        (t, th)
    }

    /// Reference: the definitions of the module docs on signals whose answer is known —
    /// a steady 5° oscillation sways and swung; a decaying one from 5° neither sways nor
    /// settles late; a monotonic run-off to 60° (a jackknife) lost control without swinging;
    /// one full swing of 4° before the run-off swung.
    #[test]
    fn the_truth_of_known_signals() {
        let c = SwayCriterion::default();
        let w = std::f64::consts::TAU * 0.5;
        let (t, th) = sampled(|s| 5.0 * (w * (s - 1.0)).sin() * f64::from(s >= 1.0), 30.0);
        let r = c.judge(&t, &th, 1.0, 1.0, false);
        assert!(r.sustained_sway && r.swung, "{r:?}");
        assert!((r.period_s.unwrap() - 2.0).abs() < 0.01, "{r:?}");
        assert!((r.peak_hitch_angle_deg - 5.0).abs() < 1e-3);

        let decaying = |s: f64| 5.0 * (-0.3 * (s - 1.0)).exp() * (w * (s - 1.0)).sin();
        let (t, th) = sampled(|s| if s >= 1.0 { decaying(s) } else { 0.0 }, 30.0);
        let r = c.judge(&t, &th, 1.0, 1.0, false);
        assert!(!r.sustained_sway && r.swung, "{r:?}");
        // below 1° after e^(−0.3 τ)·5 < 1: τ ≈ 5.4 s, at most a period later
        let settle = r.settle_time_s.unwrap();
        assert!((3.0..7.5).contains(&settle), "{r:?}");

        let (t, th) = sampled(
            |s| {
                if s >= 1.0 {
                    60.0 * ((s - 1.0) / 2.0).min(1.0)
                } else {
                    0.0
                }
            },
            3.0,
        );
        let r = c.judge(&t, &th, 1.0, 1.0, true);
        assert!(
            !r.swung && !r.sustained_sway && r.settle_time_s.is_none(),
            "{r:?}"
        );

        let swing_then_off = |s: f64| {
            let tau = s - 1.0;
            if tau < 0.0 {
                0.0
            } else if tau < 2.0 {
                4.0 * (w * tau).sin()
            } else {
                -20.0 * (tau - 2.0)
            }
        };
        let (t, th) = sampled(swing_then_off, 5.0);
        assert!(c.judge(&t, &th, 1.0, 1.0, true).swung);
    }
}
