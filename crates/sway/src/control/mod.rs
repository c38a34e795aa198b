//! Sway control beyond the paper's controller: which controller structure and
//! which actuator keep straight running stable for which loop delay τ.
//!
//! The paper closes the loop with δ(t) = −D·ψ̇(t − τ) (eq. 8) and ends with the remark
//! that "at large delay values the system becomes more unstable". This module gives the
//! linear closed loop of three **structures** ([`Structure`]) driving either of two
//! **actuators** ([`Actuator`]) as one quasi-polynomial each, so that every tool built on
//! [`stability::RankOneFeedback`] (exact unstable-root counts by D-subdivision, rightmost
//! roots, critical speeds) applies to all of them:
//!
//! - `yaw_rate`: u(t) = −D·ψ̇(t − τ) (the paper's);
//! - `yaw_rate_hitch`: u(t) = −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ), a hitch-angle sensor
//!   (rear camera) beside the yaw-rate sensor;
//! - `predictor`: u(t) = −D·ψ̇_p(t), the yaw rate predicted τ ahead ([`predictor`]).
//!
//! The actuator is the tractor's front-wheel steering u = δ \[rad\] (the paper's) or
//! differential braking of the tow vehicle, u = M_z \[N m\], a yaw moment on the tractor
//! ([`trailer_model::Model::rhs4_with_yaw_moment`]). With the linearisation
//! x' = Ã x + B̃_u u of eq. (9)–(11) (B̃_u = B̃ or B̃_M) and the measured output row K (the
//! gains times the sensed quantities), the loop of the two output-feedback structures is
//! x' = Ã x − B̃_u K x(t − τ): rank one, with characteristic function
//! p(λ) + e^{−λτ} q_K(λ), p = det(λI − Ã), q_K = K adj(λI − Ã) B̃_u (eq. 13 with D folded
//! into K). For `yaw_rate` K = D·C̃ exactly as in [`crate::charts`], so its critical speeds
//! equal those of `fig4a` and `gain_design`.
//!
//! Gains carry the actuator's units: for steering D and D_θ in s, K_θ in rad/rad; for
//! braking D and D_θ in N m s/rad, K_θ in N m/rad.

mod design;
mod loop_fold;

pub use sway_model::law::{
    Actuator, GainName, Gains, LoopLaw, LoopLinearization, Structure, loop_output_row, output_row,
    predictor,
};
pub use sway_model::vehicle::{LoopModel, VehicleDescription};

pub use design::{
    CommandLimits, DelayBudget, Design, DesignSearch, DesignStart, GainBand, GainBounds,
    Robustness, VehicleUncertainty, delay_budget, design, designs_over_delays,
    perfect_predictor_designs, robust_critical_speed,
};
pub use loop_fold::{LoopHopfFold, fold_speed, hopf_and_fold};

use serde::{Deserialize, Serialize};
use stability::{Complex64, RankOneFeedback, RootOptions, StabilityError};

use crate::SwayError;

/// The linear closed loop of one controller at one speed, as a quasi-polynomial
/// p(λ) + D·e^{−λτ}·q(λ) with the count of its roots that are not roots of the loop.
#[derive(Debug, Clone)]
pub struct LinearLoop {
    /// the quasi-polynomial (for the predictor: its characteristic function cleared of
    /// denominators, [`predictor`])
    pub feedback: RankOneFeedback,
    /// the gain D that multiplies q: the paper's D for `yaw_rate` (so that its numbers are
    /// those of `fig4a`), 1 where the gains are inside q
    pub gain: f64,
    /// the predictor's spurious roots, the eigenvalues of its model's Ã (roots of the
    /// cleared function, not of the loop): removed from counts and root lists
    pub spurious: Vec<Complex64>,
    /// the delay τ \[s\] the loop is built for (the predictor's q depends on it)
    pub delay: f64,
    /// s \[1/s\]: `feedback` is written in μ = λ/s with the delay s·τ (1 but for the
    /// predictor of a plant or model with more than 4 states, whose cleared function is
    /// balanced so, [`predictor::cleared_loop_dyn`])
    pub time_scale: f64,
    /// the predictor with a perfect model ((Â, B̂, C̃) = (A, B, C̃)): the delayed terms
    /// cancel identically and `feedback` is the delay-free loop p + q_K, whose roots are the
    /// eigenvalues of A − B K whatever `delay` (finite spectrum assignment, [`predictor`]);
    /// counts and roots are then taken at τ = 0
    pub delay_free: bool,
}

impl LinearLoop {
    /// The loop of `law` on `model` (the paper's [`trailer_model::Model`], a
    /// [`trailer_model::VehicleModel`] or an [`trailer_model::AnyVehicleModel`]) at speed V \[m/s\] with the law's delay τ; the predictor predicts
    /// with `prediction_model` (the vehicle itself when `None`; it may have another state
    /// count than the vehicle).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if the linearisation is not finite.
    pub fn new<M: LoopModel + ?Sized>(
        model: &M,
        law: &LoopLaw,
        speed: f64,
        prediction_model: Option<&dyn LoopModel>,
    ) -> Result<Self, SwayError> {
        let lin = model.loop_linearization(speed);
        let model_lin = match (law.structure, prediction_model) {
            (Structure::Predictor, Some(m)) => Some(m.loop_linearization(speed)),
            _ => None,
        };
        Self::from_linearization(&lin, law, model_lin.as_ref())
    }

    /// The loop of `law` on the linearisation `lin` with the law's delay τ; the predictor
    /// predicts with `prediction` (`lin` itself when `None`).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if the linearisation is not finite.
    pub fn from_linearization(
        lin: &LoopLinearization,
        law: &LoopLaw,
        prediction: Option<&LoopLinearization>,
    ) -> Result<Self, SwayError> {
        let (speed, delay) = (lin.speed, law.delay_s);
        let context = || {
            format!(
                "{} loop with {} at V = {speed} m/s, τ = {delay} s",
                law.structure.as_str(),
                law.actuator.as_str()
            )
        };
        let b = law.actuator.loop_input_column(lin);
        let built = match law.structure {
            Structure::YawRate => RankOneFeedback::from_state_space(&lin.a, b, &lin.c)
                .map(|f| (f, law.gains.yaw_rate, Vec::new(), 1.0, false)),
            Structure::YawRateHitch => {
                let k = loop_output_row(lin, law.structure, &law.gains);
                RankOneFeedback::from_state_space(&lin.a, b, &k)
                    .map(|f| (f, 1.0, Vec::new(), 1.0, false))
            }
            Structure::Predictor => {
                let model_lin = prediction.unwrap_or(lin);
                let b_model = law.actuator.loop_input_column(model_lin);
                let k = &model_lin.c * law.gains.yaw_rate;
                if predictor::is_perfect_model(lin, model_lin) {
                    // P₁ ≡ 0 analytically (finite spectrum assignment): the loop is
                    // p + K adj(λI − A) B, the delay-free loop. Building the cleared form
                    // instead leaves a round-off remainder of P₁ (≈ 1e-16 relative) whose
                    // e^{−λτ}-weighted roots far in the left half-plane are artefacts
                    RankOneFeedback::from_state_space(&lin.a, b, &k)
                        .map(|f| (f, 1.0, Vec::new(), 1.0, true))
                } else {
                    predictor::cleared_loop_dyn(&lin.a, b, &model_lin.a, b_model, &k, delay)
                        .map(|(f, spurious, s)| (f, 1.0, spurious, s, false))
                }
            }
        };
        let (feedback, gain, spurious, time_scale, delay_free) =
            built.map_err(|e| SwayError::numerical(context(), e))?;
        Ok(Self {
            feedback,
            gain,
            spurious,
            delay,
            time_scale,
            delay_free,
        })
    }

    /// The delay of `feedback` in its own time variable: s·τ, or 0 for the delay-free loop
    /// of a perfectly predicted predictor.
    fn feedback_delay(&self) -> f64 {
        if self.delay_free {
            0.0
        } else {
            self.delay * self.time_scale
        }
    }

    /// Number of roots of the loop with Re λ > 0 (exact crossing count; the predictor's
    /// spurious roots subtracted).
    ///
    /// # Errors
    /// [`StabilityError`] from the crossing count.
    pub fn unstable_root_count(&self) -> Result<usize, StabilityError> {
        let n = self
            .feedback
            .unstable_root_count(self.gain, self.feedback_delay())?;
        let spurious = self.spurious.iter().filter(|z| z.re > 0.0).count();
        Ok(n.saturating_sub(spurious))
    }

    /// The `count` rightmost roots of the loop (Newton-polished), sorted by decreasing real
    /// part; for the predictor the roots at its model's eigenvalues are left out.
    ///
    /// # Errors
    /// [`StabilityError`] if the roots cannot be confirmed.
    pub fn rightmost_roots(&self, count: usize) -> Result<Vec<Complex64>, StabilityError> {
        if self.gain == 0.0 || self.feedback.q().is_empty() {
            // no feedback: the loop is the open loop, a polynomial with n roots
            let mut roots: Vec<Complex64> = self
                .feedback
                .open_loop_eigenvalues()
                .iter()
                .map(|z| z * self.time_scale)
                .collect();
            stability::sort_rightmost(&mut roots);
            return Ok(predictor::without_spurious(roots, &self.spurious, count));
        }
        // a collocation fine enough for the roots asked for (and the spurious ones)
        let options = RootOptions::for_count(count + self.spurious.len());
        // the feedback is in μ = λ/s with the delay s·τ (s = 1 but for a predictor with
        // more than four states)
        let s = self.time_scale;
        let tau = self.feedback_delay();
        let roots_of = |want: usize| -> Result<Vec<Complex64>, StabilityError> {
            Ok(self
                .feedback
                .rightmost_roots(self.gain, tau, want, &options)?
                .into_iter()
                .map(|z| z * s)
                .collect())
        };
        // the spurious roots (the model's eigenvalues) are asked for only when they turn up
        // among the rightmost: a stable model's lie left of the loop's rightmost roots, and
        // a model with more states (tyre relaxation) has them far in the left half-plane
        // (−V/σ), where the cleared function is ill-conditioned (its delayed term,
        // cancelling only up to round-off, is weighted by e^{−Re λ·τ}); each round asks for
        // as many more roots as spurious ones were found
        // an unstable model's eigenvalues are the rightmost roots of the cleared function
        // whenever the loop's own are stable: asked for at once (each round is a new
        // collocation, the cost of one evaluation)
        let mut want = count + self.spurious.iter().filter(|z| z.re > 0.0).count();
        loop {
            let roots = roots_of(want)?;
            let found = roots.len();
            let kept = predictor::without_spurious(roots, &self.spurious, count);
            if kept.len() >= count || found < want || want >= count + self.spurious.len() {
                return Ok(kept);
            }
            want += count - kept.len();
        }
    }
}

/// Settings of a critical-speed search: the lowest speed at which straight running under
/// a controller is unstable, scanned in V and bisected on the exact unstable-root count.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpeedSearch {
    /// lowest speed \[m/s\]
    pub v_min_mps: f64,
    /// highest speed \[m/s\]: a controller stable up to here is reported as stable up to it
    pub v_max_mps: f64,
    /// speeds scanned (evenly, ends included) before bisection; an unstable interval
    /// shorter than the spacing may be missed
    pub samples: usize,
    /// bisection tolerance \[m/s\]
    pub tolerance_mps: f64,
}

impl Default for SpeedSearch {
    fn default() -> Self {
        Self {
            v_min_mps: 1.0,
            v_max_mps: 100.0,
            samples: 100,
            tolerance_mps: 1e-9,
        }
    }
}

/// The linear critical speed of a controller: the lowest speed in the search range at which
/// straight running is unstable, or `None` if it is stable on the whole range.
///
/// # Errors
/// [`SwayError::Numerical`] if a loop cannot be built or counted.
pub fn critical_speed<M: LoopModel + ?Sized>(
    model: &M,
    law: &LoopLaw,
    prediction_model: Option<&dyn LoopModel>,
    search: &SpeedSearch,
) -> Result<Option<f64>, SwayError> {
    let delay = law.delay_s;
    let unstable = |v: f64| -> Result<bool, SwayError> {
        let l = LinearLoop::new(model, law, v, prediction_model)?;
        l.unstable_root_count().map(|n| n > 0).map_err(|e| {
            SwayError::numerical(
                format!(
                    "unstable roots of the {} loop at V = {v} m/s, τ = {delay} s",
                    law.structure.as_str()
                ),
                e,
            )
        })
    };
    first_unstable(search, unstable)
}

/// Spectral abscissa \[1/s\] within which an interval of [`verified_critical_speed`]'s scan
/// is searched for a narrow window of instability.
const WINDOW_MARGIN_PER_S: f64 = 0.05;

/// Sub-samples of such an interval.
const WINDOW_SUBSAMPLES: usize = 64;

/// Golden-section steps on a sampled local maximum of the spectral abscissa (the bracket
/// shrinks by 0.618 each: 40 steps resolve a spacing of 1/64 m/s to ~1e-10 m/s).
const WINDOW_GOLDEN_STEPS: usize = 40;

/// [`critical_speed`]'s value `v_crit` checked for windows of instability narrower than its
/// scan's spacing below it: a root pair that touches the imaginary axis and returns between
/// two samples, which a search over several gains can push a loop into (the bisection
/// inside a bracket then finds the window's far end, or the scan misses it). Each interval
/// of the scan below `v_crit` (the last ending at `v_crit`) whose spectral abscissa comes
/// within 0.05 1/s of zero at an end is sampled 64 times,
/// the sampled local maxima of the abscissa are refined by golden section, and the first
/// speed found with an unstable root is bracketed and bisected to `search.tolerance_mps`.
/// Returns the lowest unstable speed so found (`v_crit` when there is no window). A window
/// shallower than the golden section resolves (max Re λ ≲ 1e-12 1/s) can still be missed.
///
/// # Errors
/// [`SwayError::Numerical`] if a loop cannot be built, counted or its roots confirmed.
pub fn verified_critical_speed<M: LoopModel + ?Sized>(
    model: &M,
    law: &LoopLaw,
    prediction_model: Option<&dyn LoopModel>,
    search: &SpeedSearch,
    v_crit: Option<f64>,
) -> Result<Option<f64>, SwayError> {
    let delay = law.delay_s;
    let at = |v: f64| LinearLoop::new(model, law, v, prediction_model);
    let context = |v: f64| {
        format!(
            "the {} loop at V = {v} m/s, τ = {delay} s (window check)",
            law.structure.as_str()
        )
    };
    let abscissa = |v: f64| -> Result<f64, SwayError> {
        let roots = at(v)?
            .rightmost_roots(1)
            .map_err(|e| SwayError::numerical(context(v), e))?;
        Ok(roots.first().map_or(f64::NEG_INFINITY, |z| z.re))
    };
    let unstable = |v: f64| -> Result<bool, SwayError> {
        at(v)?
            .unstable_root_count()
            .map(|n| n > 0)
            .map_err(|e| SwayError::numerical(context(v), e))
    };
    // the first unstable speed in (a, b], a stable and b unstable: bisection
    let first_in = |mut a: f64, mut b: f64| -> Result<f64, SwayError> {
        while b - a > search.tolerance_mps {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            if unstable(m)? { b = m } else { a = m }
        }
        Ok(0.5 * (a + b))
    };
    let hi = v_crit.unwrap_or(search.v_max_mps);
    let n = search.samples.max(2);
    let mut grid: Vec<f64> = (0..n)
        .map(|i| {
            search.v_min_mps + (search.v_max_mps - search.v_min_mps) * i as f64 / (n - 1) as f64
        })
        .filter(|&v| v < hi)
        .collect();
    grid.push(hi);
    // the abscissa at the grid; at v_crit it is the crossing's, zero
    let mut alpha = grid[..grid.len() - 1]
        .iter()
        .map(|&v| abscissa(v))
        .collect::<Result<Vec<_>, _>>()?;
    alpha.push(if v_crit.is_some() { 0.0 } else { abscissa(hi)? });
    for (k, w) in grid.windows(2).enumerate() {
        let (a, b) = (w[0], w[1]);
        if alpha[k].max(alpha[k + 1]) < -WINDOW_MARGIN_PER_S {
            continue;
        }
        let h = (b - a) / WINDOW_SUBSAMPLES as f64;
        let subs: Vec<f64> = (0..WINDOW_SUBSAMPLES).map(|j| a + h * j as f64).collect();
        let sub_alpha = subs
            .iter()
            .map(|&v| abscissa(v))
            .collect::<Result<Vec<_>, _>>()?;
        for j in 1..subs.len() {
            if sub_alpha[j] >= 0.0 && unstable(subs[j])? {
                return first_in(subs[j - 1], subs[j]).map(Some);
            }
        }
        for j in 1..subs.len() - 1 {
            let (l, c, r) = (sub_alpha[j - 1], sub_alpha[j], sub_alpha[j + 1]);
            if !(c >= l && c >= r && c > -WINDOW_MARGIN_PER_S) {
                continue;
            }
            if let Some(v) = golden_unstable(&abscissa, &unstable, subs[j - 1], subs[j + 1])? {
                return first_in(subs[j - 1], v).map(Some);
            }
        }
    }
    Ok(v_crit)
}

/// Golden-section maximisation of `abscissa` on \[a, b\]; the first point met where it is
/// ≥ 0 and `unstable` confirms it, if any.
fn golden_unstable(
    abscissa: &impl Fn(f64) -> Result<f64, SwayError>,
    unstable: &impl Fn(f64) -> Result<bool, SwayError>,
    mut a: f64,
    mut b: f64,
) -> Result<Option<f64>, SwayError> {
    const INV_PHI: f64 = 0.618_033_988_749_894_8;
    let mut x1 = b - INV_PHI * (b - a);
    let mut x2 = a + INV_PHI * (b - a);
    let (mut f1, mut f2) = (abscissa(x1)?, abscissa(x2)?);
    for _ in 0..WINDOW_GOLDEN_STEPS {
        for (x, f) in [(x1, f1), (x2, f2)] {
            if f >= 0.0 && unstable(x)? {
                return Ok(Some(x));
            }
        }
        if f1 >= f2 {
            (b, x2, f2) = (x2, x1, f1);
            x1 = b - INV_PHI * (b - a);
            f1 = abscissa(x1)?;
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + INV_PHI * (b - a);
            f2 = abscissa(x2)?;
        }
    }
    Ok(None)
}

/// The lowest v in the search range where `unstable(v)`: scan, then bisection.
fn first_unstable(
    s: &SpeedSearch,
    unstable: impl Fn(f64) -> Result<bool, SwayError>,
) -> Result<Option<f64>, SwayError> {
    if unstable(s.v_min_mps)? {
        return Ok(Some(s.v_min_mps));
    }
    let n = s.samples.max(2);
    let mut prev = s.v_min_mps;
    for i in 1..n {
        let v = s.v_min_mps + (s.v_max_mps - s.v_min_mps) * i as f64 / (n - 1) as f64;
        if unstable(v)? {
            let (mut a, mut b) = (prev, v);
            while b - a > s.tolerance_mps {
                let m = 0.5 * (a + b);
                if m <= a || m >= b {
                    break;
                }
                if unstable(m)? { b = m } else { a = m }
            }
            return Ok(Some(0.5 * (a + b)));
        }
        prev = v;
    }
    Ok(None)
}
