//! Ranges of the stability charts derived from the vehicle: the axes of `fig4a`,
//! the (V, D) box of the nonlinear chart (`chart_nonlinear`, `corners`) and the ranges of
//! `gain_design`, used where a config omits the key (a number in a config wins).
//!
//! Two vehicle quantities set the scales:
//! - the **reference speed** V_ref: the open-loop critical speed V_crit (D = 0), or the
//!   maximum speed when straight running is stable up to it (V_crit / 2 when straight
//!   running diverges statically at V_crit: a real eigenvalue through 0, where p(0) = 0 and
//!   the static boundary passes through D = 0);
//! - the **static gain** |D_static| = |p(0)/q(0)| at V_ref: eq. (13) at λ = 0, the gain at
//!   which the static loop gain D·G(0) is −1 (G(0) = q(0)/p(0), the steady-state yaw-rate
//!   gain ψ̇/δ): the static boundary of `fig4a`, the same line for every delay τ
//!   (0.26 s for Table I).
//!
//! From them the **reference gain** D₁ = 0.4·|D_static| rounded to one significant digit
//! (0.1 s for Table I), and the rules (the defaults of the omitted keys):
//! - `fig4a`: gain axis ±5·D₁ (the static boundary at about half of the negative axis);
//!   speed axis from 0 to [`speed_top`] over the axis' gains and the delays; the summary
//!   gain D₁; the summary speed the first whole m/s above V_crit ([`summary_speed`]);
//! - the nonlinear chart's box: gains [−D₁, 3·D₁]; speeds from [`speed_bottom`] to
//!   [`speed_top`] over the box's gains and the chart's delays; seeds at the middle, the top
//!   and the bottom of the gain range; the bistable gain at its middle; the summary gains
//!   0, h, 2h, … below the top, h = (D_max − D_min)/8 ([`summary_gains`]);
//! - `gain_design`: gains [0, 5·D₁], speeds [minimum, maximum speed].
//!
//! [`speed_top`] is the largest critical speed over the chart's gains and delays (the top of
//! the region of stable straight running that starts at low speed; a coarse scan of
//! [`SCAN_GAINS`] gains, speeds [`SCAN_STEP_MPS`] apart) plus 5 %, rounded up to a multiple
//! of 5 m/s and capped at the maximum speed. Its cost is bounded: at most
//! `SCAN_GAINS × delays` critical speeds, each at most one scan over [minimum, maximum
//! speed] and a bisection to [`SCAN_TOLERANCE_MPS`].
//!
//! For Table I the rules give the ranges the configs held before the ranges were derived, except the
//! speed axis of `fig4a` (0–75 m/s instead of 0–60 m/s: at τ = 0.1 s and D = 0.5 s straight
//! running is stable up to 67.9 m/s, above the old axis).

use crate::parallel::{Split, try_map};
use serde::{Deserialize, Serialize};

use super::{closed_loop, critical_speed_at_gain};
use crate::SwayError;
use sway_model::vehicle::LoopModel;

/// Gains of the coarse scan of the critical speed over a gain range (ends included).
pub const SCAN_GAINS: usize = 21;
/// Speed spacing of that scan \[m/s\].
pub const SCAN_STEP_MPS: f64 = 1.0;
/// Bisection tolerance of that scan \[m/s\] (it only sizes an axis).
pub const SCAN_TOLERANCE_MPS: f64 = 1e-3;
/// Margin of [`speed_top`] over the largest critical speed (5 %).
pub const SPEED_MARGIN: f64 = 0.05;
/// D₁ = this × |D_static| before rounding to one significant digit.
pub const REFERENCE_GAIN_FRACTION: f64 = 0.4;
/// Below this |D_static| at V_crit \[s\] the static boundary crosses D = 0 at V_crit (a
/// static divergence: a real eigenvalue through 0, p(0) = 0): the scale is taken at
/// V_crit / 2 instead (Table I: 0.26 s, far above).
pub const STATIC_DIVERGENCE_GAIN_S: f64 = 1e-3;

/// The speed interval every search stays in \[m/s\] (the vehicle-independent limits of the
/// task layer, `--max-speed`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpeedBounds {
    /// lowest speed searched \[m/s\]
    pub min_mps: f64,
    /// highest speed searched \[m/s\]
    pub max_mps: f64,
}

impl Default for SpeedBounds {
    fn default() -> Self {
        Self {
            min_mps: 1.0,
            max_mps: 100.0,
        }
    }
}

impl From<&sway_model::speeds::SpeedLimits> for SpeedBounds {
    fn from(l: &sway_model::speeds::SpeedLimits) -> Self {
        Self {
            min_mps: l.min_speed_mps,
            max_mps: l.max_speed_mps,
        }
    }
}

impl SpeedBounds {
    /// Speeds of a scan [`SCAN_STEP_MPS`] apart over the bounds (at least 2).
    fn scan_samples(&self) -> usize {
        (((self.max_mps - self.min_mps) / SCAN_STEP_MPS).ceil() as usize + 1).max(2)
    }
}

/// The vehicle's scales (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct VehicleScale {
    /// open-loop critical speed \[m/s\] (None: stable up to the maximum speed)
    pub v_crit_mps: Option<f64>,
    /// V_ref: V_crit, or the maximum speed \[m/s\]; V_crit / 2 when straight running
    /// diverges statically at V_crit ([`STATIC_DIVERGENCE_GAIN_S`])
    pub reference_speed_mps: f64,
    /// |D_static| = |p(0)/q(0)| at V_ref \[s\]
    pub static_gain_s: f64,
    /// D₁ \[s\]
    pub reference_gain_s: f64,
}

/// `x` with 12 significant digits: sums and multiples of round gains (0.1 + 0.2, 3·0.05)
/// read as the round numbers again.
pub fn tidy(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    format!("{x:.11e}").parse().unwrap_or(x)
}

/// `x` > 0 rounded to one significant digit (0.104 → 0.1, 0.26 → 0.3, 0.96 → 1).
pub fn round_to_one_digit(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return x;
    }
    let e = x.log10().floor();
    let unit = 10f64.powf(e);
    tidy((x / unit).round() * unit)
}

fn numerical(context: String, message: String) -> SwayError {
    SwayError::numerical(context, continuation::Error::InvalidInput(message))
}

/// The open-loop critical speed \[m/s\] (None: stable up to the maximum speed): the one
/// search every task uses ([`sway_model::speeds::open_loop_critical_speed`]) over the bounds.
///
/// # Errors
/// [`SwayError::Model`] when straight running is unstable at the lowest speed.
pub fn open_loop_critical_speed<M: LoopModel + ?Sized>(
    model: &M,
    b: &SpeedBounds,
) -> Result<Option<f64>, SwayError> {
    let limits = sway_model::speeds::SpeedLimits {
        min_speed_mps: b.min_mps,
        max_speed_mps: b.max_mps,
        ..sway_model::speeds::SpeedLimits::default()
    };
    Ok(super::open_loop_stability(model, &limits)?.v_crit())
}

/// The vehicle's scales (module documentation).
///
/// # Errors
/// [`SwayError::Numerical`] if the critical speed fails, or if the vehicle has no static
/// yaw-rate response at V_ref (q(0) = 0 or p(0) = 0: then the gain ranges must be given in
/// the config).
pub fn vehicle_scale<M: LoopModel + ?Sized>(
    model: &M,
    b: &SpeedBounds,
) -> Result<VehicleScale, SwayError> {
    let v_crit = open_loop_critical_speed(model, b)?;
    let mut v_ref = v_crit.unwrap_or(b.max_mps);
    let static_gain_at = |v: f64| -> Result<Option<f64>, SwayError> {
        let ctx = format!("the gain scale of the charts at V = {v} m/s");
        let sys = closed_loop(model, v).map_err(|e| SwayError::numerical(ctx, e))?;
        Ok(sys.static_crossing(0.0).map(|c| c.d.abs()))
    };
    let mut d_static = static_gain_at(v_ref)?;
    if d_static.is_some_and(|d| d < STATIC_DIVERGENCE_GAIN_S) {
        // a static divergence at V_crit: p(0) = 0 there, the static boundary passes through
        // D = 0; its distance from D = 0 at half the speed sets the scale instead
        v_ref = (0.5 * v_ref).max(b.min_mps);
        d_static = static_gain_at(v_ref)?;
    }
    let ctx = format!("the gain scale of the charts at V = {v_ref} m/s");
    let Some(static_gain) = d_static.filter(|d| d.is_finite() && *d > 0.0) else {
        return Err(numerical(
            ctx,
            "no static boundary (the steady-state yaw-rate gain ψ̇/δ is 0 or infinite): give the \
             gain range in the config (e.g. gain.min_s/max_s, chart.d_min_s/d_max_s)"
                .into(),
        ));
    };
    Ok(VehicleScale {
        v_crit_mps: v_crit,
        reference_speed_mps: v_ref,
        static_gain_s: static_gain,
        reference_gain_s: round_to_one_digit(REFERENCE_GAIN_FRACTION * static_gain),
    })
}

/// The critical speeds over a gain range: the lowest and the largest of V_crit(τ, D) over
/// the delays and [`SCAN_GAINS`] gains (a gain stable up to the maximum speed counts as the
/// maximum speed).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CriticalSpeedExtent {
    /// lowest critical speed \[m/s\]; the maximum speed when every gain is stable up to it
    pub lowest_mps: f64,
    /// largest critical speed \[m/s\]; the maximum speed when a gain is stable up to it
    /// (`stable_gains` > 0): the top of the chart's speed axis, not a measured speed
    pub highest_mps: f64,
    /// gains stable up to the maximum speed (at some delay)
    pub stable_gains: usize,
    /// critical speeds computed
    pub evaluations: usize,
}

impl CriticalSpeedExtent {
    /// Every scanned gain is stable up to the maximum speed at every delay.
    pub fn all_stable(&self) -> bool {
        self.stable_gains == self.evaluations
    }
}

/// The gains of the coarse scan over [d_min, d_max] \[s\], ends included.
pub fn scan_gains((d_min, d_max): (f64, f64)) -> Vec<f64> {
    let n = SCAN_GAINS;
    (0..n)
        .map(|i| d_min + (d_max - d_min) * i as f64 / (n - 1) as f64)
        .collect()
}

/// The lowest and largest critical speed over `delays` \[s\] and the gains of
/// [`scan_gains`] (parallel, deterministic).
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn critical_speed_extent<M: LoopModel + ?Sized>(
    model: &M,
    delays: &[f64],
    gains: (f64, f64),
    b: &SpeedBounds,
) -> Result<CriticalSpeedExtent, SwayError> {
    let samples = b.scan_samples();
    let pairs: Vec<(f64, f64)> = delays
        .iter()
        .flat_map(|&t| scan_gains(gains).into_iter().map(move |d| (t, d)))
        .collect();
    let speeds = try_map(&pairs, Split::Adaptive, &|_, &(tau, d)| {
        critical_speed_at_gain(
            model,
            tau,
            d,
            b.min_mps,
            b.max_mps,
            samples,
            SCAN_TOLERANCE_MPS,
        )
    })?;
    let value = |v: &Option<f64>| v.unwrap_or(b.max_mps);
    Ok(CriticalSpeedExtent {
        lowest_mps: speeds.iter().map(value).fold(f64::INFINITY, f64::min),
        highest_mps: speeds.iter().map(value).fold(f64::NEG_INFINITY, f64::max),
        stable_gains: speeds.iter().filter(|v| v.is_none()).count(),
        evaluations: speeds.len(),
    })
}

/// The top of a speed axis \[m/s\]: the largest critical speed plus [`SPEED_MARGIN`],
/// rounded up to a multiple of 5 m/s, at most the maximum speed (and above `floor`).
pub fn speed_top(e: &CriticalSpeedExtent, b: &SpeedBounds, floor: f64) -> f64 {
    let top = 5.0 * ((1.0 + SPEED_MARGIN) * e.highest_mps / 5.0).ceil();
    let top = top.min(b.max_mps);
    if top > floor {
        top
    } else {
        b.max_mps.min(floor + 5.0).max(floor + 1.0)
    }
}

/// The bottom of the nonlinear chart's box \[m/s\]: half the lowest critical speed, rounded
/// down to a multiple of 5 m/s (to a whole m/s below 10 m/s), at least the minimum speed.
pub fn speed_bottom(e: &CriticalSpeedExtent, b: &SpeedBounds) -> f64 {
    let half = 0.5 * e.lowest_mps;
    let v = if half >= 5.0 {
        5.0 * (half / 5.0).floor()
    } else {
        half.floor()
    };
    v.max(b.min_mps)
}

/// The speed of the stable-gain intervals of `fig4a`'s summary \[m/s\]: the first whole m/s
/// above the open-loop V_crit (35 m/s for Table I: just unstable without feedback, so the
/// intervals are the gains that stabilise), or the maximum speed if there is no V_crit.
pub fn summary_speed(s: &VehicleScale, b: &SpeedBounds) -> f64 {
    s.v_crit_mps
        .map_or(b.max_mps, |v| (v.floor() + 1.0).min(b.max_mps))
}

/// The summary gains of a gain range [d_min, d_max] \[s\]: 0, h, 2h, … (those ≥ d_min) up
/// to d_max − h/2, h = (d_max − d_min)/8 (Table I's [−0.1, 0.3] s: 0, 0.05, …, 0.25 s).
pub fn summary_gains((d_min, d_max): (f64, f64)) -> Vec<f64> {
    let h = tidy((d_max - d_min) / 8.0);
    if !(h.is_finite() && h > 0.0) {
        return Vec::new();
    }
    let k0 = (d_min / h).ceil().max(0.0) as i64;
    (k0..)
        .map(|k| tidy(k as f64 * h))
        .take_while(|&d| d <= d_max - 0.5 * h)
        .take(64)
        .collect()
}

/// The middle of a gain range \[s\].
pub fn middle((d_min, d_max): (f64, f64)) -> f64 {
    tidy(0.5 * (d_min + d_max))
}

/// The seed gains of the nonlinear chart's Hopf curves: the middle, the top and the bottom
/// of the gain range, then D = 0 (the open loop) if the range holds it \[s\] (Table I's
/// [−0.1, 0.3] s: 0.1, 0.3, −0.1, 0 s; the chart skips a seed whose Hopf point lies on a
/// computed curve, so D = 0 only adds a curve where the others miss the open-loop Hopf
/// point, as for a vehicle stable at D = ±D₁ but not at D = 0).
pub fn seed_gains(gains: (f64, f64)) -> Vec<f64> {
    let mut s = vec![middle(gains), gains.1, gains.0];
    if gains.0 < 0.0 && gains.1 > 0.0 && !s.contains(&0.0) {
        s.push(0.0);
    }
    s
}

/// The nonlinear chart's gain range [−D₁, 3·D₁] \[s\].
pub fn box_gains(s: &VehicleScale) -> (f64, f64) {
    let d1 = s.reference_gain_s;
    (-d1, tidy(3.0 * d1))
}

/// `fig4a`'s gain axis ±5·D₁ \[s\].
pub fn chart_gains(s: &VehicleScale) -> (f64, f64) {
    let d = tidy(5.0 * s.reference_gain_s);
    (-d, d)
}

/// `gain_design`'s gain range [0, 5·D₁] \[s\].
pub fn design_gains(s: &VehicleScale) -> (f64, f64) {
    (0.0, tidy(5.0 * s.reference_gain_s))
}

/// A (V, D) box \[m/s\], \[s\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpeedGainBox {
    /// lower speed \[m/s\]
    pub v_min_mps: f64,
    /// upper speed \[m/s\]
    pub v_max_mps: f64,
    /// lower gain \[s\]
    pub d_min_s: f64,
    /// upper gain \[s\]
    pub d_max_s: f64,
}

/// The keys of a box as a config gives them (None: derived).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BoxKeys {
    /// lower speed \[m/s\]
    pub v_min_mps: Option<f64>,
    /// upper speed \[m/s\]
    pub v_max_mps: Option<f64>,
    /// lower gain \[s\]
    pub d_min_s: Option<f64>,
    /// upper gain \[s\]
    pub d_max_s: Option<f64>,
}

impl BoxKeys {
    /// All four keys given.
    pub fn complete(&self) -> Option<SpeedGainBox> {
        Some(SpeedGainBox {
            v_min_mps: self.v_min_mps?,
            v_max_mps: self.v_max_mps?,
            d_min_s: self.d_min_s?,
            d_max_s: self.d_max_s?,
        })
    }
}

/// How a box was derived: the keys filled in, the scales and the scan behind them.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Derivation {
    /// the keys that were derived (config names)
    pub derived_keys: Vec<String>,
    /// the vehicle's scales (None: not needed)
    pub scale: Option<VehicleScale>,
    /// the scan of the critical speeds over the gains (None: not needed)
    pub extent: Option<CriticalSpeedExtent>,
}

/// The nonlinear chart's box: the given keys, the others derived (module documentation)
/// over `delays` \[s\]. `prefix` names the keys in [`Derivation::derived_keys`].
///
/// # Errors
/// [`SwayError::Numerical`] from the scales or the scan.
pub fn nonlinear_box<M: LoopModel + ?Sized>(
    model: &M,
    keys: &BoxKeys,
    delays: &[f64],
    b: &SpeedBounds,
    prefix: &str,
) -> Result<(SpeedGainBox, Derivation), SwayError> {
    let mut der = Derivation::default();
    if let Some(done) = keys.complete() {
        return Ok((done, der));
    }
    let mut name = |k: &str| der.derived_keys.push(format!("{prefix}{k}"));
    let gains = match (keys.d_min_s, keys.d_max_s) {
        (Some(a), Some(c)) => (a, c),
        (a, c) => {
            let s = vehicle_scale(model, b)?;
            let derived = box_gains(&s);
            if a.is_none() {
                name("d_min_s");
            }
            if c.is_none() {
                name("d_max_s");
            }
            der.scale = Some(s);
            (a.unwrap_or(derived.0), c.unwrap_or(derived.1))
        }
    };
    let mut v = (keys.v_min_mps, keys.v_max_mps);
    if v.0.is_none() || v.1.is_none() {
        let e = critical_speed_extent(model, delays, gains, b)?;
        if v.0.is_none() {
            name("v_min_mps");
            v.0 = Some(speed_bottom(&e, b));
        }
        if v.1.is_none() {
            name("v_max_mps");
            v.1 = Some(speed_top(&e, b, v.0.unwrap_or(b.min_mps)));
        }
        der.extent = Some(e);
    }
    let bx = SpeedGainBox {
        v_min_mps: v.0.unwrap_or(b.min_mps),
        v_max_mps: v.1.unwrap_or(b.max_mps),
        d_min_s: gains.0,
        d_max_s: gains.1,
    };
    Ok((bx, der))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_numbers() {
        // reference: the decimal digits by hand
        assert_eq!(round_to_one_digit(0.1043), 0.1);
        assert_eq!(round_to_one_digit(0.26), 0.3);
        assert_eq!(round_to_one_digit(0.96), 1.0);
        assert_eq!(round_to_one_digit(14.9), 10.0);
        assert_eq!(tidy(0.1 + 0.2), 0.3);
        assert_eq!(tidy(3.0 * 0.05), 0.15);
        assert_eq!(
            summary_gains((-0.1, 0.3)),
            vec![0.0, 0.05, 0.1, 0.15, 0.2, 0.25]
        );
        assert_eq!(seed_gains((-0.1, 0.3)), vec![0.1, 0.3, -0.1, 0.0]);
        assert_eq!(
            summary_gains((0.1, 0.5)),
            vec![0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45]
        );
    }
}
