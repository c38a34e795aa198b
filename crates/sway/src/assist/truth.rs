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

use serde::Serialize;

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
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
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
        }
    }
}
