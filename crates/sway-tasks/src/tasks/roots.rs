//! `cargo xtask roots --speed V --gain D --delay τ [--count N]`: the N rightmost characteristic roots of
//! the closed loop (eq. 13) at one point ([`sway_studies::roots`]), one `<re> <im>` line
//! each, sorted by decreasing real part, conjugates both listed (a pair is never split: if
//! the N-th root is complex, its conjugate is printed as well). Roots are Newton-polished on
//! the exact quasi-polynomial (relative accuracy ~1e-14, well inside the promised 1e-9).

use stability::Complex64;
use sway::control::LoopModel;
pub use sway_studies::roots::RootsConfig;

use crate::TaskError;

/// Default number of roots printed.
pub const DEFAULT_COUNT: usize = 6;

/// Most roots one call computes: 200 (default 6). The root finder's matrices grow with the
/// count; 200 roots reach far into the left half-plane, where nothing is of interest.
pub const MAX_COUNT: usize = 200;

/// The roots at speed V \[m/s\], gain D \[s\], delay τ \[s\] of the paper's controller
/// δ = −D·ψ̇(t − τ) on any plant.
///
/// # Errors
/// As [`validate_args`], and [`sway::SwayError::Numerical`] if the roots cannot be confirmed.
pub fn roots<M: LoopModel + ?Sized>(
    model: &M,
    speed: f64,
    gain: f64,
    delay: f64,
    count: usize,
) -> Result<Vec<Complex64>, TaskError> {
    run(model, &RootsConfig::paper(speed, gain, delay, count), None)
}

/// The roots of any controller (structure, actuator, gains) on any plant at `cfg`'s speed
/// and delay ([`sway_studies::roots::compute`]); the predictor predicts with `prediction`
/// (the vehicle itself when `None`).
///
/// # Errors
/// As [`validate`], and [`sway::SwayError::Numerical`] if the loop cannot be built or its
/// roots confirmed.
pub fn run<M: LoopModel + ?Sized>(
    model: &M,
    cfg: &RootsConfig,
    prediction: Option<&dyn LoopModel>,
) -> Result<Vec<Complex64>, TaskError> {
    validate(cfg)?;
    Ok(sway_studies::roots::compute(model, cfg, prediction)?)
}

/// Checks a point of `roots`: [`validate_args`] (the yaw-rate gain as `--gain`) and finite
/// hitch gains.
///
/// # Errors
/// [`TaskError::Config`] naming the command-line option.
pub fn validate(cfg: &RootsConfig) -> Result<(), TaskError> {
    let g = &cfg.law.gains;
    validate_args(cfg.speed_mps, g.yaw_rate, cfg.law.delay_s, cfg.count)?;
    if !(g.hitch_angle.is_finite() && g.hitch_rate.is_finite()) {
        return Err(TaskError::config(
            "command line",
            "--hitch-angle-gain",
            format!(
                "expected finite gains, got {} and {}",
                g.hitch_angle, g.hitch_rate
            ),
        ));
    }
    Ok(())
}

/// Checks the command-line arguments of `roots` (what `--check` validates).
///
/// # Errors
/// [`TaskError::Config`] for a non-positive speed, a non-finite gain, a negative delay, a
/// zero count or one above [`MAX_COUNT`] (naming the command-line option).
pub fn validate_args(speed: f64, gain: f64, delay: f64, count: usize) -> Result<(), TaskError> {
    let arg = |key: &str, problem: String| TaskError::config("command line", key, problem);
    if !(speed.is_finite() && speed > 0.0) {
        return Err(arg(
            "--speed",
            format!("expected a positive speed [m/s], got {speed}"),
        ));
    }
    if !gain.is_finite() {
        return Err(arg(
            "--gain",
            format!("expected a finite gain [s], got {gain}"),
        ));
    }
    if !(delay.is_finite() && delay >= 0.0) {
        return Err(arg(
            "--delay",
            format!("expected a delay ≥ 0 s, got {delay}"),
        ));
    }
    if count == 0 {
        return Err(arg("--count", "expected at least 1".into()));
    }
    if count > MAX_COUNT {
        return Err(arg(
            "--count",
            format!(
                "{count} exceeds the limit {MAX_COUNT} (the root finder's matrices grow with the count)"
            ),
        ));
    }
    Ok(())
}

/// Formats roots as `<re> <im>` lines (shortest round-trip representation of each number).
pub fn format_roots(roots: &[Complex64]) -> String {
    let mut s = String::new();
    for r in roots {
        s.push_str(&format!("{:e} {:e}\n", r.re, r.im));
    }
    s
}
