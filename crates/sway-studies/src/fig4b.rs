//! Bifurcation diagrams of the closed loop δ(t) = −D·ψ̇(t − τ) (eq. 8) for several
//! feedback settings (paper Fig. 4b), each on the speed range derived from the vehicle
//! ([`vehicle_diagram`]), with the Hopf and fold speeds corrected on the two-parameter
//! defining systems of the nonlinear chart ([`critical_speeds`]), so that `fig4b`,
//! `chart_nonlinear` and the `hopf_fold_speeds` sweep kind share one implementation.

use continuation::Criticality;
use serde::Serialize;
use sway::parallel::{Split, try_map};
use sway_model::vehicle::Vehicle;

use sway::SwayError;
use sway::bifurcation::chart::{ChartOptions, CriticalSpeeds, EndedCurve, critical_speeds};
use sway::bifurcation::{
    BranchEnd, CycleExtent, Diagram, DiagramOutcome, DiagramSettings, LoopLaw, vehicle_diagram,
};
use sway::progress::Progress;
use sway::ranging::SpeedLimits;

/// The diagram of one feedback setting.
#[derive(Debug, Clone, PartialEq)]
pub enum PairDiagram {
    /// the diagram and its corrected Hopf and fold speeds
    Computed {
        /// the diagram
        diagram: Box<Diagram>,
        /// Hopf and fold corrected on their defining systems
        speeds: CriticalSpeeds,
    },
    /// straight running has no Hopf point in the searched range
    NoHopf {
        /// the feedback
        feedback: LoopLaw,
        /// what straight running does instead
        outcome: sway::bifurcation::NoHopf,
    },
}

impl PairDiagram {
    /// The diagram and its speeds, if computed.
    pub fn computed(&self) -> Option<(&Diagram, &CriticalSpeeds)> {
        match self {
            PairDiagram::Computed { diagram, speeds } => Some((diagram, speeds)),
            PairDiagram::NoHopf { .. } => None,
        }
    }

    /// The summary entry (`"pairs"` of fig4b's `summary.json`).
    pub fn summary(&self, feedback: LoopLaw) -> PairSummary {
        let base = PairSummary {
            tau_s: feedback.delay_s,
            d_s: feedback.gains.yaw_rate,
            hopf_v_mps: None,
            fold_v_mps: None,
            criticality: None,
            fold_amplitude_deg: None,
            fold_period_s: None,
            hopf_omega_rad_s: None,
            bistable_range_mps: None,
            cycle_points: 0,
            searched_mps: None,
            cycle_branch_end: None,
            stable_up_to_mps: None,
            reason: None,
            curves_ended_early: Vec::new(),
        };
        match self {
            PairDiagram::NoHopf { outcome, .. } => PairSummary {
                stable_up_to_mps: outcome.stable_up_to_mps,
                reason: Some(outcome.reason.clone()),
                ..base
            },
            PairDiagram::Computed { diagram: d, speeds } => {
                let fold = speeds.fold;
                let bistable_range_mps = match (speeds.criticality, fold) {
                    (Criticality::Subcritical, Some(f)) => Some([f.v_mps, speeds.hopf_v_mps]),
                    _ => None,
                };
                let failed = speeds
                    .curves_ended_early
                    .iter()
                    .find(|e| e.curve.starts_with("fold"));
                let reason = match (fold, failed) {
                    (Some(_), _) => None,
                    (None, Some(e)) => Some(format!("the fold of cycles is unknown: its correction {}", e.end.describe())),
                    (None, None) => Some(d.fold_reason().unwrap_or_else(|| {
                        "the fold of the cycle branch could not be corrected on the fold-of-cycles system".into()
                    })),
                };
                PairSummary {
                    hopf_v_mps: Some(speeds.hopf_v_mps),
                    fold_v_mps: fold.map(|f| f.v_mps),
                    criticality: Some(speeds.criticality.to_string()),
                    fold_amplitude_deg: fold.map(|f| f.amplitude_deg),
                    fold_period_s: fold.map(|f| f.period_s),
                    hopf_omega_rad_s: Some(speeds.hopf_omega_rad_s),
                    bistable_range_mps,
                    cycle_points: d.cycle_summary.len(),
                    searched_mps: Some(d.searched_mps),
                    cycle_branch_end: Some(d.cycle_branch_end),
                    reason,
                    curves_ended_early: speeds.curves_ended_early.clone(),
                    ..base
                }
            }
        }
    }
}

/// One feedback setting's entry of fig4b's `summary.json` (`"pairs"`); a null number has
/// its `reason`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairSummary {
    /// the delay τ \[s\]
    pub tau_s: f64,
    /// the gain D \[s\]
    pub d_s: f64,
    /// V at the Hopf point \[m/s\] (null: no Hopf point, see `reason`)
    pub hopf_v_mps: Option<f64>,
    /// V at the fold of cycles \[m/s\] (null: no fold, see `reason`)
    pub fold_v_mps: Option<f64>,
    /// "subcritical" or "supercritical" (null: no Hopf point)
    pub criticality: Option<String>,
    /// max |θ| at the fold \[deg\]
    pub fold_amplitude_deg: Option<f64>,
    /// period of the cycle at the fold \[s\]
    pub fold_period_s: Option<f64>,
    /// ω at the Hopf point \[rad/s\]
    pub hopf_omega_rad_s: Option<f64>,
    /// from the fold to the Hopf point \[m/s\] (null: no bistable range, see `reason`)
    pub bistable_range_mps: Option<[f64; 2]>,
    /// points on the cycle branch
    pub cycle_points: usize,
    /// the speeds searched \[m/s\]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub searched_mps: Option<[f64; 2]>,
    /// why the cycle branch ended
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cycle_branch_end: Option<BranchEnd>,
    /// without a Hopf point: straight running is stable up to this speed \[m/s\]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_up_to_mps: Option<f64>,
    /// why a number above is null (no Hopf point; supercritical; fold outside the range;
    /// branch ended by the guard or the budget)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// corrections on the defining systems that failed, each with its `end` (absent: none)
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub curves_ended_early: Vec<EndedCurve>,
}

/// The diagram of `model` with `feedback` on the range of `settings` (derived from the
/// vehicle where omitted), its Hopf and fold speeds corrected as the nonlinear chart
/// corrects them.
///
/// # Errors
/// Numerical failures naming the stage.
pub fn closed_loop_diagram<P: Vehicle<N>, const N: usize>(
    model: &P,
    feedback: LoopLaw,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
    extent: CycleExtent,
) -> Result<PairDiagram, SwayError> {
    match vehicle_diagram(model, feedback, settings, limits, extent)? {
        DiagramOutcome::NoHopf(outcome) => Ok(PairDiagram::NoHopf { feedback, outcome }),
        DiagramOutcome::Computed(diagram) => {
            let speeds =
                critical_speeds(model, &diagram, &ChartOptions::correcting(&diagram.options))?;
            Ok(PairDiagram::Computed { diagram, speeds })
        }
    }
}

/// [`closed_loop_diagram`] for every feedback setting, in their order (parallel over the
/// settings; each is deterministic, so the result does not depend on the thread count).
/// `progress` advances by one per setting.
///
/// # Errors
/// The first failing setting's error (in their order).
pub fn closed_loop_diagrams<P: Vehicle<N>, const N: usize>(
    model: &P,
    feedbacks: &[LoopLaw],
    settings: &DiagramSettings,
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<Vec<PairDiagram>, SwayError> {
    try_map(feedbacks, Split::Adaptive, &|_, &fb| {
        let r = closed_loop_diagram(model, fb, settings, limits, CycleExtent::WholeRange);
        progress.advance(1);
        r
    })
}

/// The speed range \[m/s\] covering every computed diagram's figure range (None: none
/// computed).
pub fn common_range(diagrams: &[PairDiagram]) -> Option<(f64, f64)> {
    diagrams
        .iter()
        .filter_map(PairDiagram::computed)
        .map(|(d, _)| (d.options.v_min_mps, d.options.v_max_mps))
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
}
