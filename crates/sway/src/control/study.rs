//! The control-design study of `cargo xtask control_design`: for every structure ×
//! actuator, the best gains on a grid of delays, the delay budget, and at chosen delays the
//! robust (5 %) critical speed under vehicle uncertainty and, for the paper's structure,
//! the fold-of-cycles speed of its optimum.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use trailer_model::{Model, VehicleParams};

use super::{
    Actuator, Controller, DelayBudget, Design, DesignSearch, Robustness, SpeedSearch, Structure,
    VehicleUncertainty, delay_budget, designs_over_delays, robust_critical_speed,
};
use crate::SwayError;
use crate::bifurcation::chart::{ChartOptions, critical_speeds};
use crate::bifurcation::{CycleExtent, DiagramOutcome, DiagramSettings, Feedback, vehicle_diagram};
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
    /// the fold-of-cycles computation (speed range, mesh) of the paper's structure
    pub fold: ChartOptions,
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
        let (v_fold_mps, v_fold_reason) =
            fold_speed(model, &c, d.tau_s, &s.fold, &s.robustness_speed)?;
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
    })
}

/// The fold-of-cycles speed of the sway branch of a controller's loop, where the
/// continuation problem has that loop: the paper's δ = −D·ψ̇(t − τ)
/// ([`crate::bifurcation::closed_loop`]), corrected on the fold-of-cycles system as the
/// nonlinear chart does. The diagram's speed range is derived from the vehicle
/// ([`vehicle_diagram`]: from the lowest speed of `search` past the Hopf point) unless
/// `chart.cycles` gives both ends. Otherwise, without a Hopf point (a stable loop, a static
/// divergence) or without a fold, None with the reason.
fn fold_speed(
    model: &Model,
    c: &Controller,
    tau: f64,
    chart: &ChartOptions,
    search: &SpeedSearch,
) -> Result<(Option<f64>, Option<String>), SwayError> {
    if !(c.structure == Structure::YawRate && c.actuator == Actuator::Steering) {
        return Ok((
            None,
            Some(format!(
                "not computed: the continuation problem (bifurcation::closed_loop) drives only \
                 the paper's yaw_rate + steering loop so far, not {} + {}",
                c.structure.as_str(),
                c.actuator.as_str()
            )),
        ));
    }
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
    let diagram =
        match vehicle_diagram(model, feedback, &settings, &limits, CycleExtent::FirstFold)? {
            DiagramOutcome::Computed(d) => d,
            DiagramOutcome::NoHopf(n) => return Ok((None, Some(n.reason))),
        };
    let fold = critical_speeds(model, &diagram, chart)?
        .fold
        .map(|f| f.v_mps);
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
