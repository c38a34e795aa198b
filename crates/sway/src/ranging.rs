//! The open-loop reference speeds of a vehicle that need its bifurcation diagram: V_crit
//! and the fold of cycles ([`open_loop_references`], [`open_loop_fold`]), and the
//! resolution of a config's relative speeds against them ([`resolve_speeds`]). The speed
//! types themselves and the critical-speed search are [`sway_model::speeds`]'s.

pub use sway_model::speeds::{
    CappedSpeed, CriticalSpeedSummary, MAX_SPEED, OpenLoopStability, Reference, RelativeSpeed,
    SpeedLimits, SpeedReferences, SpeedSpec, Unresolved, open_loop_critical_speed,
    stable_up_to_reason,
};

use sway_model::speeds::resolve::{Resolution, ResolveSpeeds, resolve_against};
use sway_model::vehicle::Vehicle;

use crate::SwayError;
use crate::bifurcation::chart::{ChartOptions, CriticalSpeeds, critical_speeds};
use crate::bifurcation::{
    CycleExtent, Diagram, DiagramOptions, DiagramOutcome, DiagramSettings, LoopLaw, NoHopf,
    bifurcation_diagram_until, vehicle_diagram,
};
use crate::sim::VehicleForm;

/// The open-loop reference speeds of `model` that `need` asks for: V_crit
/// ([`open_loop_critical_speed`]) and, for [`Reference::Fold`], the fold of cycles of the
/// open-loop diagram ([`open_loop_fold`]).
///
/// # Errors
/// A numerical failure of the critical-speed search (a failure of the cycle continuation
/// leaves the fold null, with the reason).
pub fn open_loop_references<P: Vehicle<N>, const N: usize>(
    model: &P,
    limits: &SpeedLimits,
    need: Reference,
) -> Result<SpeedReferences, SwayError> {
    if need == Reference::None {
        return Ok(SpeedReferences::default());
    }
    let stability = open_loop_critical_speed(model, limits)?;
    let Some(v_crit) = stability.v_crit() else {
        return Ok(SpeedReferences {
            reason: stability.summary().reason,
            ..Default::default()
        });
    };
    let mut refs = SpeedReferences {
        v_crit_mps: Some(v_crit),
        ..Default::default()
    };
    if need == Reference::Fold {
        if stability.is_divergence() {
            refs.reason = Some(format!(
                "straight running loses stability at V_crit = {v_crit} m/s through a real eigenvalue (static divergence, ω = 0), not a Hopf point: no sway cycles, no fold of cycles, no bistable range"
            ));
            return Ok(refs);
        }
        // a continuation that fails is said as the reason, not an error: the user has
        // nothing to fix in the config
        match open_loop_fold(model, v_crit, limits) {
            Ok(Ok(v_fold)) => refs.v_fold_mps = Some(v_fold),
            Ok(Err(reason)) => refs.reason = Some(reason),
            Err(e) => {
                refs.reason = Some(format!(
                    "the fold of cycles of the open loop could not be computed: {e}"
                ));
            }
        }
    }
    Ok(refs)
}

/// The fold of cycles of the open loop \[m/s\] (the lower end of the bistable range): the
/// cycle branch from the Hopf point at `v_crit` continued to its first fold, corrected on
/// the fold-of-cycles defining system ([`critical_speeds`]). `Err(reason)` when the Hopf
/// point is supercritical or the branch does not fold above `min_speed_mps`.
///
/// # Errors
/// A numerical failure of the continuation.
pub fn open_loop_fold<P: Vehicle<N>, const N: usize>(
    model: &P,
    v_crit: f64,
    limits: &SpeedLimits,
) -> Result<Result<f64, String>, SwayError> {
    let options = DiagramOptions {
        v_min_mps: (0.25 * v_crit).max(limits.min_speed_mps),
        v_max_mps: (v_crit * 1.5).min(limits.max_speed_mps).max(v_crit + 1.0),
        ..DiagramOptions::default()
    };
    let diagram =
        bifurcation_diagram_until(model, LoopLaw::OPEN_LOOP, &options, CycleExtent::FirstFold)?;
    if diagram.fold.is_none() {
        return Ok(Err(format!(
            "the open loop has no fold of cycles between {:.3} and {:.3} m/s ({:?} Hopf point at V_crit = {v_crit} m/s): no bistable range",
            options.v_min_mps, options.v_max_mps, diagram.criticality
        )));
    }
    let speeds = critical_speeds(model, &diagram, &ChartOptions::correcting(&options))?;
    Ok(speeds
        .fold
        .map(|f| f.v_mps)
        .ok_or_else(|| "the fold of cycles could not be corrected".to_string()))
}

/// A loop's whole diagram with its Hopf point and fold of cycles corrected on their
/// defining systems ([`critical_speeds`], the numbers fig4b and the nonlinear chart report:
/// one per vehicle across the tasks) and the reference speeds they give.
#[derive(Debug, Clone)]
pub struct CorrectedDiagram {
    /// the diagram ([`vehicle_diagram`], the cycle branch over the whole range)
    pub diagram: Box<Diagram>,
    /// its Hopf point and fold, corrected
    pub speeds: CriticalSpeeds,
    /// V_crit and V_fold from them, with the reason where the fold is missing
    pub references: SpeedReferences,
}

/// The diagram of `law`'s loop on `model` on the range `settings` give (derived from the
/// vehicle where they give none), corrected ([`CorrectedDiagram`]); `Err(NoHopf)` when
/// straight running does not lose stability below the maximum speed (an outcome).
///
/// # Errors
/// A numerical failure of the continuation or the correction.
pub fn corrected_diagram<P: Vehicle<N>, const N: usize>(
    model: &P,
    law: LoopLaw,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
) -> Result<Result<CorrectedDiagram, NoHopf>, SwayError> {
    let d = match vehicle_diagram(model, law, settings, limits, CycleExtent::WholeRange)? {
        DiagramOutcome::Computed(d) => d,
        DiagramOutcome::NoHopf(n) => return Ok(Err(n)),
    };
    let speeds = critical_speeds(model, &d, &ChartOptions::correcting(&d.options))?;
    let references = SpeedReferences {
        v_crit_mps: Some(speeds.hopf_v_mps),
        v_fold_mps: speeds.fold.map(|f| f.v_mps),
        reason: d.fold_reason(),
    };
    Ok(Ok(CorrectedDiagram {
        diagram: d,
        speeds,
        references,
    }))
}

/// Resolves `cfg` for `vehicle`: computes the references its speeds need (none, V_crit, or
/// V_crit and the fold) once, on the vehicle's own model ([`open_loop_references`]: a model
/// variant refers `of_v_crit` speeds to its own V_crit and `in_bistable` speeds to its own
/// fold of cycles), then every speed.
///
/// # Errors
/// When computing a reference fails numerically (an unresolvable speed is not an error).
pub fn resolve_speeds<'a, C: ResolveSpeeds>(
    vehicle: impl Into<VehicleForm<'a>>,
    limits: &SpeedLimits,
    cfg: &C,
) -> Result<Resolution<C::Resolved>, SwayError> {
    let refs = match cfg.needs().reference() {
        None => SpeedReferences::default(),
        Some(need) => match vehicle.into() {
            VehicleForm::Paper(model) => open_loop_references(model, limits, need)?,
            VehicleForm::Variants(v) => {
                trailer_model::with_plant!(v, m => open_loop_references(m, limits, need))?
            }
        },
    };
    Ok(resolve_against(&refs, cfg))
}

#[cfg(test)]
mod tests {
    use super::*;
    use trailer_model::{Model, VehicleParams};

    #[test]
    fn stable_up_to_the_maximum_speed_is_an_outcome() {
        // Table I is unstable from 34.75 m/s: below that maximum it is stable throughout
        let model = Model::new(VehicleParams::default()).unwrap();
        let limits = SpeedLimits {
            max_speed_mps: 30.0,
            ..SpeedLimits::default()
        };
        let got = open_loop_critical_speed(&model, &limits).unwrap();
        assert_eq!(
            got,
            OpenLoopStability::StableUpTo {
                stable_up_to_mps: 30.0
            }
        );
        let s = got.summary();
        assert_eq!((s.v_crit_mps, s.stable_up_to_mps), (None, Some(30.0)));
        assert!(s.reason.unwrap().contains("up to 30 m/s"));
        // a relative speed then has nothing to refer to: an outcome with the reason
        let refs = open_loop_references(&model, &limits, Reference::VCrit).unwrap();
        let e = SpeedSpec::Relative(RelativeSpeed::OfVCrit(0.9))
            .resolve(&refs)
            .unwrap_err();
        assert!(e.reason.contains("stable at every speed"), "{e}");
    }

    #[test]
    fn table_i_fold_reference_is_the_fold_of_cycles() {
        // reference: fig3a / chart_nonlinear's fold of cycles of Table I, 31.5228 m/s
        // (results/chart_nonlinear/summary.json: 31.522823…; meshes L = 40–60 agree to
        // ~1e-4 m/s)
        let model = Model::new(VehicleParams::default()).unwrap();
        let refs = open_loop_references(&model, &SpeedLimits::default(), Reference::Fold).unwrap();
        let v_fold = refs.v_fold_mps.unwrap();
        assert!((v_fold - 31.5228).abs() < 2e-4, "{v_fold}");
    }
}
