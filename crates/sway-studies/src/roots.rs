//! The computation of `roots`: the rightmost characteristic roots of a delayed closed loop
//! at one speed, sorted by decreasing real part, a conjugate pair never split (if the N-th
//! root is complex, its conjugate is listed as well). Roots are Newton-polished on the exact
//! quasi-polynomial.

use stability::Complex64;
use sway::SwayError;
use sway::control::{LinearLoop, LoopLaw, LoopModel};

/// The point of the loop and how many roots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootsConfig {
    /// speed V \[m/s\]
    pub speed_mps: f64,
    /// how many roots (one more where the last two are a conjugate pair)
    pub count: usize,
    /// the law (structure, actuator, gains, delay τ)
    pub law: LoopLaw,
}

impl RootsConfig {
    /// The paper's controller δ = −D·ψ̇(t − τ) with gain D \[s\] at speed V \[m/s\] and
    /// delay τ \[s\].
    pub fn paper(speed_mps: f64, gain_s: f64, delay_s: f64, count: usize) -> Self {
        Self {
            speed_mps,
            count,
            law: LoopLaw::paper(gain_s, delay_s),
        }
    }
}

/// `r` (count + 1 roots, rightmost first) cut to `count`, or to count + 1 where the last two
/// are a conjugate pair (a pair is never split).
fn without_split_pair(mut r: Vec<Complex64>, count: usize) -> Vec<Complex64> {
    if r.len() > count {
        let (last, next) = (r[count - 1], r[count]);
        let pair = last.im != 0.0 && (next - last.conj()).norm() <= 1e-9 * last.norm().max(1.0);
        r.truncate(if pair { count + 1 } else { count });
    }
    r
}

/// The roots of `cfg` on any plant: for the paper's controller those of
/// [`sway::charts::rightmost_roots`] (the quasi-polynomial of eq. 13); for any other the
/// roots of its [`LinearLoop`], whose predictor predicts with `prediction` (the vehicle
/// itself when `None`). `cfg.count` must be at least 1.
///
/// # Errors
/// [`SwayError::Numerical`] if the loop cannot be built or its roots confirmed.
pub fn compute<M: LoopModel + ?Sized>(
    model: &M,
    cfg: &RootsConfig,
    prediction: Option<&dyn LoopModel>,
) -> Result<Vec<Complex64>, SwayError> {
    let RootsConfig {
        speed_mps: speed,
        count,
        law,
    } = *cfg;
    let (gain, delay) = (law.gains.yaw_rate, law.delay_s);
    // one more root than asked, so that a conjugate pair is never split
    if law.is_paper_structure() && law.gains == sway::control::Gains::yaw_rate(gain) {
        let r = sway::charts::rightmost_roots(model, speed, gain, delay, count + 1)?;
        return Ok(without_split_pair(r, count));
    }
    let ctx = || {
        format!(
            "rightmost roots of the {} loop with {} at V = {speed} m/s, τ = {delay} s",
            law.structure.as_str(),
            law.actuator.as_str()
        )
    };
    let l = LinearLoop::new(model, &law, speed, prediction)?;
    let r = l
        .rightmost_roots(count + 1)
        .map_err(|e| SwayError::numerical(ctx(), e))?;
    Ok(without_split_pair(r, count))
}
