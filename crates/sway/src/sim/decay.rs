//! The damping of a decaying (or growing) oscillation read from its peaks, as a lateral
//! stability test reads it (ISO 9815): the logarithmic decrement δ over one period between
//! peaks of the same sign, and the damping ratio D = δ / √(4π² + δ²).
//!
//! For one mode y = a·e^{σt}·cos(ωt + φ) the peaks of the same sign are one period
//! T = 2π/ω apart and their ratio is e^{σT} exactly (the peaks are shifted from those of
//! the cosine, all by the same phase), so δ = −σT and D = −σ/√(σ² + ω²): the damping
//! ratio of the root pair σ ± iω. The peaks of a sampled signal are refined by the parabola
//! through the largest sample and its neighbours (error O(h²) in the sample step h).
//!
//! Measured signals carry noise: [`low_pass`] filters them forwards and backwards (zero
//! phase, so the peaks do not move), and [`peaks`] keeps only extrema whose prominence
//! exceeds a threshold, not every local maximum of the noise.

/// An extremum of a sampled signal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// its time \[s\] (refined between samples)
    pub t: f64,
    /// its value (refined; positive for a maximum, negative for a minimum of a signal
    /// oscillating about 0)
    pub value: f64,
}

/// The damping read from a run of peaks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decay {
    /// the mean logarithmic decrement δ over one period \[-\] (negative: growing)
    pub log_decrement: f64,
    /// D = δ / √(4π² + δ²) \[-\]
    pub damping_ratio: f64,
    /// the frequency 1/T of the mean period between the peaks used \[Hz\]
    pub frequency_hz: f64,
    /// the number of period ratios averaged
    pub periods_used: usize,
}

/// D = δ / √(4π² + δ²) for the logarithmic decrement δ over one period.
pub fn damping_ratio(log_decrement: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    log_decrement / (two_pi * two_pi + log_decrement * log_decrement).sqrt()
}

/// The alternating extrema (maxima and minima) of `y` sampled at times `t` from `from_s`
/// on: an extremum is kept when the signal has moved by more than `min_prominence` (same
/// units as y) from the previous kept extremum of the other kind, so noise riding on the
/// oscillation does not make peaks. Each is refined by the parabola through its sample and
/// the two neighbours.
pub fn peaks(t: &[f64], y: &[f64], from_s: f64, min_prominence: f64) -> Vec<Peak> {
    let n = t.len().min(y.len());
    let start = t[..n].partition_point(|&s| s < from_s);
    let mut out: Vec<Peak> = Vec::new();
    if n < 3 || start + 2 >= n {
        return out;
    }
    // candidate extremum: index of the running max (rising) or min (falling)
    let mut best = start;
    let mut rising: Option<bool> = None;
    let mut last_kept = y[start];
    for i in start + 1..n {
        match rising {
            None => {
                if (y[i] - y[start]).abs() > min_prominence {
                    rising = Some(y[i] > y[start]);
                    best = i;
                    last_kept = y[start];
                }
            }
            Some(true) => {
                if y[i] > y[best] {
                    best = i;
                } else if y[best] - y[i] > min_prominence && y[best] - last_kept > min_prominence {
                    out.push(refine(t, y, best));
                    last_kept = y[best];
                    rising = Some(false);
                    best = i;
                }
            }
            Some(false) => {
                if y[i] < y[best] {
                    best = i;
                } else if y[i] - y[best] > min_prominence && last_kept - y[best] > min_prominence {
                    out.push(refine(t, y, best));
                    last_kept = y[best];
                    rising = Some(true);
                    best = i;
                }
            }
        }
    }
    out
}

/// The extremum at sample `i` refined by the parabola through samples i − 1, i, i + 1.
fn refine(t: &[f64], y: &[f64], i: usize) -> Peak {
    if i == 0 || i + 1 >= y.len() {
        return Peak {
            t: t[i],
            value: y[i],
        };
    }
    let (h0, h1) = (t[i] - t[i - 1], t[i + 1] - t[i]);
    let (ya, yb, yc) = (y[i - 1], y[i], y[i + 1]);
    // the parabola p(s) = yb + b·s + c·s² through (−h0, ya), (0, yb), (h1, yc)
    let c = ((yc - yb) / h1 + (ya - yb) / h0) / (h0 + h1);
    let b = (yc - yb) / h1 - c * h1;
    if c == 0.0 {
        return Peak { t: t[i], value: yb };
    }
    let s = (-b / (2.0 * c)).clamp(-h0, h1);
    Peak {
        t: t[i] + s,
        value: yb + b * s + c * s * s,
    }
}

/// The decay over the peaks `peaks[skip..]`, using `periods` period ratios (each between
/// a peak and the next of the same sign, two extrema later): the mean of
/// δᵢ = ln(|yᵢ| / |yᵢ₊₂|) and of the periods tᵢ₊₂ − tᵢ. `None` when there are fewer than
/// `skip + periods + 2` peaks or `periods` is 0.
pub fn decay(peaks: &[Peak], skip: usize, periods: usize) -> Option<Decay> {
    if periods == 0 || peaks.len() < skip + periods + 2 {
        return None;
    }
    let used = &peaks[skip..skip + periods + 2];
    let (mut sum_delta, mut sum_period) = (0.0, 0.0);
    for w in used.windows(3) {
        sum_delta += (w[0].value.abs() / w[2].value.abs()).ln();
        sum_period += w[2].t - w[0].t;
    }
    let log_decrement = sum_delta / periods as f64;
    Some(Decay {
        log_decrement,
        damping_ratio: damping_ratio(log_decrement),
        frequency_hz: periods as f64 / sum_period,
        periods_used: periods,
    })
}

/// The local damping of the oscillation against its amplitude: for each run of three
/// successive extrema (yᵢ, yᵢ₊₁, yᵢ₊₂), one period between the outer two, δ = ln(|yᵢ| / |yᵢ₊₂|)
/// and D(δ), at the amplitude |yᵢ₊₁| of the middle one (their geometric mean for one
/// exponential mode). A full period, not half of one, so that whatever makes the positive
/// and negative half-waves differ (a second, slower decaying mode near the sway frequency
/// in a delayed loop; an offset) does not make successive values alternate. Where D changes
/// sign the oscillation neither grows nor decays: a periodic orbit of that amplitude.
pub fn local_damping(peaks: &[Peak]) -> Vec<(f64, f64)> {
    peaks
        .windows(3)
        .map(|w| {
            let (a, m, b) = (w[0].value.abs(), w[1].value.abs(), w[2].value.abs());
            (m, damping_ratio((a / b).ln()))
        })
        .collect()
}

/// A zero-phase low-pass: a first-order filter with cut-off `cutoff_hz` run forwards and
/// then backwards over the samples (step from `t`), so that the peaks keep their times.
/// Starts from the first (last) sample to avoid a start-up transient.
pub fn low_pass(t: &[f64], y: &[f64], cutoff_hz: f64) -> Vec<f64> {
    let n = t.len().min(y.len());
    let mut out = y[..n].to_vec();
    if n < 2 {
        return out;
    }
    let tau = 1.0 / (std::f64::consts::TAU * cutoff_hz);
    let alpha = |h: f64| h / (tau + h);
    for i in 1..n {
        let a = alpha(t[i] - t[i - 1]);
        out[i] = out[i - 1] + a * (out[i] - out[i - 1]);
    }
    for i in (0..n - 1).rev() {
        let a = alpha(t[i + 1] - t[i]);
        out[i] = out[i + 1] + a * (out[i] - out[i + 1]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn damped(sigma: f64, omega: f64, h: f64, end: f64) -> (Vec<f64>, Vec<f64>) {
        let n = (end / h) as usize;
        let t: Vec<f64> = (0..=n).map(|k| k as f64 * h).collect();
        let y = t
            .iter()
            .map(|&s| (sigma * s).exp() * (omega * s + 0.3).cos())
            .collect();
        (t, y)
    }

    #[test]
    fn a_damped_cosine_gives_its_root_pairs_damping_ratio() {
        // reference: y = e^{σt}·cos(ωt + 0.3) has D = −σ/√(σ² + ω²) exactly; sampled at
        // 1 ms with parabolic peaks the error is O(h²·ω²) ≈ 1e-6 here: tolerance 1e-5
        for (sigma, omega) in [(-0.2, 2.3), (-0.05, 9.0), (0.1, 2.0)] {
            let (t, y) = damped(sigma, omega, 1e-3, 12.0);
            let p = peaks(&t, &y, 0.0, 1e-6);
            let d = decay(&p, 1, 4).unwrap();
            let exact = -sigma / (sigma * sigma + omega * omega).sqrt();
            assert!((d.damping_ratio - exact).abs() < 1e-5, "{d:?} vs {exact}");
            let f = omega / std::f64::consts::TAU;
            assert!((d.frequency_hz - f).abs() < 1e-5 * f, "{d:?} vs {f}");
        }
    }

    #[test]
    fn noise_makes_no_peaks_after_the_zero_phase_filter() {
        // reference: the clean signal's damping (above); a deterministic ±0.01 alternating
        // disturbance at the sample rate (50 Hz) is removed by the 3 Hz low-pass, and the
        // prominence of 0.05 keeps only the oscillation's extrema: D within 0.01
        let (t, y) = damped(-0.2, 2.3, 0.02, 20.0);
        let noisy: Vec<f64> = y
            .iter()
            .enumerate()
            .map(|(k, v)| v + if k % 2 == 0 { 0.01 } else { -0.01 })
            .collect();
        let filtered = low_pass(&t, &noisy, 3.0);
        let p = peaks(&t, &filtered, 0.0, 0.05);
        let d = decay(&p, 1, 4).unwrap();
        let exact = 0.2 / (0.04f64 + 2.3 * 2.3).sqrt();
        assert!((d.damping_ratio - exact).abs() < 0.01, "{d:?} vs {exact}");
    }

    #[test]
    fn local_damping_is_the_decay_of_each_period() {
        // reference: for one mode every period decays by e^{2πσ/ω}, so each local D is the
        // mode's damping ratio (1e-5 as above), read at the middle peak's amplitude
        let (t, y) = damped(-0.1, 3.0, 1e-3, 10.0);
        let exact = 0.1 / (0.01f64 + 9.0).sqrt();
        for (_, d) in local_damping(&peaks(&t, &y, 0.0, 1e-6)) {
            assert!((d - exact).abs() < 1e-5, "{d} vs {exact}");
        }
    }
}
