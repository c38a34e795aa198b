//! The control-design study of `cargo xtask control_design`: for every structure ×
//! actuator, the best gains on a grid of delays, the delay budget, and at chosen delays the
//! robust (5 %) critical speed under vehicle uncertainty; for every optimum of the
//! output-feedback structures (`yaw_rate`, `yaw_rate_hitch`, either actuator) the
//! fold-of-cycles speed of its loop ([`crate::bifurcation::ClosedLoop`] with the
//! [`LoopLaw`] of the design) and, where the optimum sits on a double-Hopf corner, the gain a
//! little away from it that maximises the fold speed instead ([`AwayFromCorner`], issue 22
//! item 4). The `predictor` has no fold: its distributed delay is not a continuation problem
//! here.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use trailer_model::{Model, VehicleParams};

use super::{
    Actuator, Controller, DelayBudget, Design, DesignSearch, GainName, Gains, Robustness,
    SpeedSearch, Structure, VehicleUncertainty, delay_budget, designs_over_delays,
    robust_critical_speed,
};
use crate::SwayError;
use crate::bifurcation::chart::{ChartOptions, critical_speeds};
use crate::bifurcation::{
    CycleExtent, DiagramOutcome, DiagramSettings, Feedback, LoopLaw, vehicle_diagram_with_law,
};
use crate::progress::Progress;
use crate::ranging::SpeedLimits;

/// What the study computes (plain data; the task reads it from its config).
#[derive(Debug, Clone, PartialEq)]
pub struct StudySettings {
    /// the delays τ of the grid \[s\] (increasing)
    pub delays_s: Vec<f64>,
    /// the structures
    pub structures: Vec<Structure>,
    /// the actuators
    pub actuators: Vec<Actuator>,
    /// the design search
    pub search: DesignSearch,
    /// the delay budget: required rise over the open loop (0.1: 10 %)
    pub budget_rise_fraction: f64,
    /// the budget's bisection tolerance in τ \[s\]
    pub budget_tau_tolerance_s: f64,
    /// delays at which the robustness (and the fold of cycles) of the optima is computed;
    /// each is snapped to the nearest grid delay
    pub checked_delays_s: Vec<f64>,
    /// the uncertainty the optima are judged under
    pub uncertainty: VehicleUncertainty,
    /// the critical-speed search of the uncertainty samples
    pub robustness_speed: SpeedSearch,
    /// the fold-of-cycles computation (speed range, mesh) of every design
    pub fold: ChartOptions,
    /// gains tried on each side of a double-Hopf optimum, evenly in its near-optimal band of
    /// D (0: the search away from the corner is skipped)
    pub away_from_corner_samples: usize,
}

/// The fold of cycles of one optimum (one entry of [`Combination::designs`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignFold {
    /// the grid delay \[s\]
    pub tau_s: f64,
    /// the fold-of-cycles speed of the optimum \[m/s\] (no kick triggers sway below it)
    pub v_fold_mps: Option<f64>,
    /// why `v_fold_mps` is null, where it is
    pub v_fold_reason: Option<String>,
    /// where the optimum is a double-Hopf corner: the gains a little away from it with the
    /// largest fold speed
    pub away_from_corner: Option<AwayFromCorner>,
}

/// The gains near a double-Hopf optimum that maximise the fold-of-cycles speed (issue 22,
/// item 4): D varied over its near-optimal band ([`super::GainBand`], the gains whose
/// linear critical speed is within the band fraction of the best), `samples` evenly on each
/// side of the corner, the other gains kept at the optimum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AwayFromCorner {
    /// the gains (actuator units)
    pub gains: Gains,
    /// their fold-of-cycles speed \[m/s\]
    pub v_fold_mps: f64,
    /// their linear critical speed \[m/s\] (the top of the search range if stable there)
    pub v_crit_mps: f64,
    /// the gains tried (with a fold)
    pub tried: usize,
}

/// The checks of one optimum at one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckedDesign {
    /// the grid delay \[s\]
    pub tau_s: f64,
    /// the critical speed under the uncertainty
    pub robustness: Robustness,
    /// the fold-of-cycles speed of the optimum \[m/s\] (no kick triggers sway below it)
    pub v_fold_mps: Option<f64>,
    /// why `v_fold_mps` is null, where it is
    pub v_fold_reason: Option<String>,
}

/// The results of one structure × actuator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Combination {
    /// the structure
    pub structure: Structure,
    /// the actuator
    pub actuator: Actuator,
    /// the optimum at each grid delay
    pub designs: Vec<Design>,
    /// the delay budget
    pub budget: DelayBudget,
    /// the checks at the checked delays
    pub checked: Vec<CheckedDesign>,
    /// the fold of cycles of each optimum, in the order of `designs`
    pub folds: Vec<DesignFold>,
}

/// The whole study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControlStudy {
    /// the open-loop critical speed \[m/s\] (the reference of the budgets)
    pub open_loop_v_crit_mps: f64,
    /// structure × actuator, structure-major in the settings' order
    pub combinations: Vec<Combination>,
}

/// Runs the study: the combinations in parallel (each sequential in τ, so the results do
/// not depend on the number of threads), one progress step per combination.
///
/// # Errors
/// [`SwayError::Numerical`], also when the open loop has no critical speed in the search range
/// (then nothing is to be raised).
pub fn control_study(
    model: &Model,
    nominal: &VehicleParams,
    s: &StudySettings,
    progress: &dyn Progress,
) -> Result<ControlStudy, SwayError> {
    let open = super::critical_speed(model, &Controller::paper(0.0), 0.0, None, &s.search.speed)?
        .ok_or_else(|| {
        SwayError::numerical(
            "the open-loop critical speed of the control study",
            std::io::Error::other(format!(
                "straight running is stable up to {} m/s without control: nothing to design for \
                 (raise search.speed.v_max_mps)",
                s.search.speed.v_max_mps
            )),
        )
    })?;
    let pairs: Vec<(Structure, Actuator)> = s
        .structures
        .iter()
        .flat_map(|&st| s.actuators.iter().map(move |&a| (st, a)))
        .collect();
    let combinations = pairs
        .par_iter()
        .map(|&(structure, actuator)| {
            let r = combination(model, nominal, structure, actuator, open, s);
            progress.advance(1);
            r
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<Vec<_>, _>>()?;
    Ok(ControlStudy {
        open_loop_v_crit_mps: open,
        combinations,
    })
}

fn combination(
    model: &Model,
    nominal: &VehicleParams,
    structure: Structure,
    actuator: Actuator,
    v_open: f64,
    s: &StudySettings,
) -> Result<Combination, SwayError> {
    let designs = designs_over_delays(model, structure, actuator, &s.delays_s, None, &s.search)?;
    let budget = delay_budget(
        model,
        &designs,
        v_open,
        s.budget_rise_fraction,
        s.budget_tau_tolerance_s,
        None,
        &s.search,
    )?;
    // one continuation per design, each a pure function of its design: in parallel (the
    // combinations alone, six on two cores, leave the slow yaw_rate_hitch ones last)
    let folds = designs
        .par_iter()
        .map(|d| design_fold(model, d, s))
        .collect::<Result<Vec<_>, _>>()?;
    let mut checked = Vec::new();
    for &tau in &s.checked_delays_s {
        let Some(d) = designs
            .iter()
            .min_by(|a, b| (a.tau_s - tau).abs().total_cmp(&(b.tau_s - tau).abs()))
        else {
            continue;
        };
        let c = Controller {
            structure,
            actuator,
            gains: d.gains,
        };
        let robustness =
            robust_critical_speed(nominal, &c, d.tau_s, &s.uncertainty, &s.robustness_speed)?;
        let fold = designs
            .iter()
            .zip(&folds)
            .find(|(e, _)| e.tau_s == d.tau_s)
            .map(|(_, f)| f);
        let (v_fold_mps, v_fold_reason) =
            fold.map_or((None, None), |f| (f.v_fold_mps, f.v_fold_reason.clone()));
        checked.push(CheckedDesign {
            tau_s: d.tau_s,
            robustness,
            v_fold_mps,
            v_fold_reason,
        });
    }
    Ok(Combination {
        structure,
        actuator,
        designs,
        budget,
        checked,
        folds,
    })
}

/// The law of the continuation problem of a controller: None for the predictor.
pub fn loop_law(c: &Controller) -> Option<LoopLaw> {
    match c.structure {
        Structure::YawRate => Some(LoopLaw {
            actuator: c.actuator,
            ..LoopLaw::PAPER
        }),
        Structure::YawRateHitch => Some(LoopLaw {
            actuator: c.actuator,
            hitch_angle: c.gains.hitch_angle,
            hitch_rate: c.gains.hitch_rate,
        }),
        Structure::Predictor => None,
    }
}

/// The fold of one optimum and, at a double-Hopf corner, the best gains away from it.
fn design_fold(model: &Model, d: &Design, s: &StudySettings) -> Result<DesignFold, SwayError> {
    let c = Controller {
        structure: d.structure,
        actuator: d.actuator,
        gains: d.gains,
    };
    let (v_fold_mps, v_fold_reason) = fold_speed(model, &c, d.tau_s, &s.fold, &s.robustness_speed)?;
    let away_from_corner = match (d.at_double_hopf, v_fold_mps) {
        (true, Some(_)) if s.away_from_corner_samples > 0 => away_from_corner(model, d, s)?,
        _ => None,
    };
    Ok(DesignFold {
        tau_s: d.tau_s,
        v_fold_mps,
        v_fold_reason,
        away_from_corner,
    })
}

/// [`AwayFromCorner`] of a double-Hopf optimum `d`: None when no gain of the band has a fold.
fn away_from_corner(
    model: &Model,
    d: &Design,
    s: &StudySettings,
) -> Result<Option<AwayFromCorner>, SwayError> {
    let Some(band) = d.bands.iter().find(|b| b.gain == GainName::YawRate) else {
        return Ok(None);
    };
    let d0 = d.gains.yaw_rate;
    let n = s.away_from_corner_samples;
    let mut best: Option<AwayFromCorner> = None;
    let mut tried = 0;
    for k in 1..=n {
        let f = k as f64 / n as f64;
        for gain in [d0 - f * (d0 - band.lo), d0 + f * (band.hi - d0)] {
            if gain == d0 {
                continue;
            }
            let c = Controller {
                structure: d.structure,
                actuator: d.actuator,
                gains: d.gains.with(GainName::YawRate, gain),
            };
            let (Some(v), _) = fold_speed(model, &c, d.tau_s, &s.fold, &s.robustness_speed)? else {
                continue;
            };
            tried += 1;
            if best.as_ref().is_none_or(|b| v > b.v_fold_mps) {
                let v_crit = super::critical_speed(model, &c, d.tau_s, None, &s.search.speed)?
                    .unwrap_or(s.search.speed.v_max_mps);
                best = Some(AwayFromCorner {
                    gains: c.gains,
                    v_fold_mps: v,
                    v_crit_mps: v_crit,
                    tried: 0,
                });
            }
        }
    }
    Ok(best.map(|b| AwayFromCorner { tried, ..b }))
}

/// The fold-of-cycles speed of the sway branch of a controller's loop
/// ([`crate::bifurcation::ClosedLoop`] with the controller's [`LoopLaw`]: u = −(D·ψ̇ +
/// K_θ·θ + D_θ·θ̇)(t − τ) on steering or a yaw moment), corrected on the fold-of-cycles
/// system as the nonlinear chart does. The diagram's speed range is derived from the vehicle
/// ([`vehicle_diagram_with_law`]: from the lowest speed of `search` past the Hopf point)
/// unless `chart.cycles` gives both ends. Otherwise, without a Hopf point (a stable loop, a
/// static divergence), without a fold, for the predictor or when the continuation fails,
/// None with the reason (one design's failure does not stop the study).
pub fn fold_speed(
    model: &Model,
    c: &Controller,
    tau: f64,
    chart: &ChartOptions,
    search: &SpeedSearch,
) -> Result<(Option<f64>, Option<String>), SwayError> {
    let Some(law) = loop_law(c) else {
        return Ok((
            None,
            Some(format!(
                "not computed: the predictor's distributed delay (the integral of the commands \
                 over [t − τ, t]) is not a continuation problem of bifurcation::closed_loop \
                 ({} + {})",
                c.structure.as_str(),
                c.actuator.as_str()
            )),
        ));
    };
    let feedback = Feedback {
        gain_d_s: c.gains.yaw_rate,
        delay_s: tau,
    };
    let limits = SpeedLimits {
        min_speed_mps: search.v_min_mps,
        max_speed_mps: search.v_max_mps,
        ..SpeedLimits::default()
    };
    let settings = DiagramSettings::from_options(&chart.cycles, None);
    let failed = |e: SwayError| (None, Some(format!("the continuation failed: {e}")));
    let diagram = match vehicle_diagram_with_law(
        model,
        feedback,
        law,
        &settings,
        &limits,
        CycleExtent::FirstFold,
    ) {
        Ok(DiagramOutcome::Computed(d)) => d,
        Ok(DiagramOutcome::NoHopf(n)) => return Ok((None, Some(n.reason))),
        Err(e) => return Ok(failed(e)),
    };
    let fold = match critical_speeds(model, &diagram, chart) {
        Ok(cs) => cs.fold.map(|f| f.v_mps),
        Err(e) => return Ok(failed(e)),
    };
    Ok(match fold {
        Some(v) => (Some(v), None),
        None => (
            None,
            Some(diagram.fold_reason().unwrap_or_else(|| {
                "the fold of the cycle branch of the optimum could not be corrected".into()
            })),
        ),
    })
}
