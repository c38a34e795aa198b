//! The nonlinear side of a controller's loop: the Hopf
//! point where straight running first loses stability and the fold of cycles of the sway
//! branch ([`hopf_and_fold`], [`fold_speed`]), for the `control_design` study and the
//! sweeps' `hopf_fold_speeds` points.

use trailer_model::Model;

use super::{LoopLaw, SpeedSearch, Structure};
use crate::SwayError;
use crate::bifurcation::chart::{ChartOptions, fold_of_cycles};
use crate::bifurcation::{CycleExtent, DiagramOutcome, DiagramSettings, cycle_diagram};
use sway_model::speeds::SpeedLimits;

/// The Hopf point and the fold of cycles of a controller's loop at one delay
/// ([`hopf_and_fold`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LoopHopfFold {
    /// the Hopf point of straight running where it first loses stability, located on the
    /// spectrum: speed \[m/s\], ω \[rad/s\] and criticality (from the cycle branch's
    /// direction); None without one (see `reason`)
    pub hopf: Option<(f64, f64, continuation::Criticality)>,
    /// the fold of cycles, corrected on the fold-of-cycles system at fixed gains; None
    /// without one (see `reason`)
    pub fold: Option<crate::bifurcation::chart::FoldCurvePoint>,
    /// why `hopf` or `fold` is None
    pub reason: Option<String>,
}

/// The Hopf point and the fold of cycles of the sway branch of a controller's loop
/// ([`crate::bifurcation::ClosedLoop`] with the [`LoopLaw`]: u = −(D·ψ̇ +
/// K_θ·θ + D_θ·θ̇)(t − τ) on steering or a yaw moment), the fold corrected on the
/// fold-of-cycles system as the nonlinear chart does. The cycle branch is continued without
/// Floquet multipliers (the fold comes from the tangent, the criticality from the
/// branch's direction). The diagram's speed range is derived from the vehicle
/// ([`cycle_diagram`]: from the lowest speed of `search` past the Hopf point)
/// unless `chart.cycles` gives both ends. Without a Hopf point (a stable loop, a static
/// divergence), without a fold, for the predictor or when the continuation fails: None
/// with the reason (one design's failure does not stop a study or a sweep).
///
/// # Errors
/// None today: every failure is a reason (the `Result` leaves room for the caller's).
pub fn hopf_and_fold(
    model: &Model,
    law: &LoopLaw,
    chart: &ChartOptions,
    search: &SpeedSearch,
) -> Result<LoopHopfFold, SwayError> {
    let none = |reason: String| LoopHopfFold {
        hopf: None,
        fold: None,
        reason: Some(reason),
    };
    if law.structure == Structure::Predictor {
        return Ok(none(format!(
            "not computed: the predictor's distributed delay (the integral of the commands \
             over [t − τ, t]) is not a continuation problem of bifurcation::closed_loop \
             ({} + {})",
            law.structure.as_str(),
            law.actuator.as_str()
        )));
    }
    let limits = SpeedLimits {
        min_speed_mps: search.v_min_mps,
        max_speed_mps: search.v_max_mps,
        ..SpeedLimits::default()
    };
    let settings = DiagramSettings {
        floquet_multipliers: continuation::FloquetMultipliers::OnRequest,
        ..DiagramSettings::from_options(&chart.cycles, None)
    };
    let failed = |e: SwayError| none(format!("the continuation failed: {e}"));
    let diagram = match cycle_diagram(model, *law, &settings, &limits, CycleExtent::FirstFold) {
        Ok(DiagramOutcome::Computed(d)) => d,
        Ok(DiagramOutcome::NoHopf(n)) => return Ok(none(n.reason)),
        Err(e) => return Ok(failed(e)),
    };
    let hopf = Some((
        diagram.hopf.parameter,
        diagram.hopf.omega.abs(),
        diagram.criticality,
    ));
    Ok(match fold_of_cycles(model, &diagram, chart) {
        Ok(Some(f)) => LoopHopfFold {
            hopf,
            fold: Some(f),
            reason: None,
        },
        Ok(None) => {
            LoopHopfFold {
                hopf,
                fold: None,
                reason: Some(diagram.fold_reason().unwrap_or_else(|| {
                    "the fold of the cycle branch could not be corrected".into()
                })),
            }
        }
        Err(e) => LoopHopfFold { hopf, ..failed(e) },
    })
}

/// The fold-of-cycles speed of [`hopf_and_fold`] \[m/s\], or None with the reason.
///
/// # Errors
/// As [`hopf_and_fold`].
pub fn fold_speed(
    model: &Model,
    law: &LoopLaw,
    chart: &ChartOptions,
    search: &SpeedSearch,
) -> Result<(Option<f64>, Option<String>), SwayError> {
    let r = hopf_and_fold(model, law, chart, search)?;
    Ok((r.fold.map(|f| f.v_mps), r.reason))
}
