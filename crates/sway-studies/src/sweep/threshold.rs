//! The θ(0) threshold of a threshold map: per value V of axis 1 (the speed), the
//! smallest θ(0) on axis 2 that ends in sustained sway, bisected between its grid cells to
//! `tolerance_deg`, with a horizon long enough that the outcome no longer changes (checked
//! by doubling it at both ends of the final bracket); and, as the reference, the amplitude
//! max |θ| of the unstable and stable cycles of the bifurcation diagram (fig3a) at V.
//!
//! The two are different measures of the same separatrix: the unstable cycle's stable
//! manifold separates the initial states that decay from those that end on the stable
//! cycle (sway). A kick θ(0) with the other states 0 is not a point on the cycle, so its
//! threshold is where the line {σ1 = σ2 = σ3 = 0} crosses that manifold — not the cycle's
//! largest |θ| — but both grow from 0 at V_crit towards the fold, where the unstable cycle
//! meets the stable one and the separatrix vanishes.
//!
//! Each threshold point recomputes its column (axis 2's grid values) with the threshold's
//! own horizon, so it depends on no other point.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{AxisParameter, PointModel, PointOutput, PointResult, SweepConfig, SweepParameter};
use super::{BaseScenario, PointKind, Sweep};
use sway::SwayError;
use sway::bifurcation::{CycleExtent, DiagramOutcome, DiagramSettings, LoopLaw, vehicle_diagram};
use sway::config::{Positive, ensure};
use sway::ranging::SpeedLimits;
use sway::sim::classify::SwayClass;
use sway::sim::{ControllerTable, InitialCondition, SpeedProfile, VehicleForm};
use sway_model::vehicle::Vehicle;

fn default_horizon() -> Positive {
    Positive::literal(240.0)
}
fn default_tolerance() -> Positive {
    Positive::literal(0.01)
}
fn yes() -> bool {
    true
}
fn default_doublings() -> u32 {
    3
}

/// The `[threshold]` table of a threshold map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThresholdSearch {
    /// horizon of the bisection's simulations \[s\] (checked by doubling it)
    #[serde(default = "default_horizon")]
    pub horizon_s: Positive,
    /// the bisection stops when the bracket is this narrow \[deg\]
    #[serde(default = "default_tolerance")]
    pub tolerance_deg: Positive,
    /// when doubling the horizon changes an outcome, the search is redone with the doubled
    /// horizon, at most this many times (near V_crit the escape from the unstable cycle is
    /// slow)
    #[serde(default = "default_doublings")]
    pub max_doublings: u32,
    /// also compute the cycles of the bifurcation diagram at the speeds of axis 1
    #[serde(default = "yes")]
    pub compare_cycles: bool,
    /// the diagram's settings (default: fig3a's, with the speed range derived from the
    /// vehicle, [`vehicle_diagram`])
    #[serde(default)]
    pub cycles: DiagramSettings,
}

impl ThresholdSearch {
    /// Checks that the sweep is a threshold map: simulations, axis 1 the speed, axis 2 θ(0)
    /// of a state start, constant speed, no sampling.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the key.
    pub fn validate(&self, file: &Path, cfg: &SweepConfig) -> Result<(), SwayError> {
        let param = |i: usize| cfg.axes.get(i).map(|a| a.parameter);
        ensure(
            cfg.kind == PointKind::Simulation
                && param(0) == Some(AxisParameter::Scenario(SweepParameter::SpeedMps))
                && param(1) == Some(AxisParameter::Scenario(SweepParameter::Theta0Deg)),
            file,
            "threshold",
            || {
                "a threshold search needs simulations with axes[0] = speed_mps and axes[1] = theta0_deg".into()
            },
        )?;
        ensure(
            matches!(cfg.base.initial, InitialCondition::State { .. })
                && matches!(cfg.base.speed, SpeedProfile::Constant { .. })
                && cfg.sampling.is_none(),
            file,
            "threshold",
            || "a threshold search needs a state start, a constant speed and no [sampling]".into(),
        )?;
        if self.compare_cycles {
            ensure(
                matches!(cfg.base.controller, ControllerTable::None),
                file,
                "threshold.compare_cycles",
                || "the cycle comparison is for the open loop (controller = none)".into(),
            )?;
        }
        ensure(
            self.max_doublings <= 10,
            file,
            "threshold.max_doublings",
            || format!("expected at most 10 doublings, got {}", self.max_doublings),
        )?;
        ensure(
            self.tolerance_deg.get() < 10.0,
            file,
            "threshold.tolerance_deg",
            || {
                format!(
                    "expected a tolerance < 10 deg, got {}",
                    self.tolerance_deg.get()
                )
            },
        )
    }
}

/// The θ(0) threshold at one speed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Theta0Threshold {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// the smallest grid value of axis 2 that ends in sustained sway with the threshold's
    /// horizon (null: none)
    pub grid_theta0_deg: Option<f64>,
    /// the bisected threshold: the smallest θ(0) found that ends in sustained sway \[deg\]
    pub theta0_threshold_deg: Option<f64>,
    /// the largest θ(0) found that does not \[deg\] (within `tolerance_deg` below; null when
    /// the first grid value already sways)
    pub theta0_below_deg: Option<f64>,
    /// the horizon of these simulations \[s\]
    pub horizon_s: f64,
    /// whether doubling the horizon leaves the class at both ends of the bracket unchanged
    pub horizon_verified: Option<bool>,
    /// simulations run for this point
    pub simulations: usize,
}

/// The cycles of the bifurcation diagram at one speed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CycleAtSpeed {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// max |θ| of the unstable cycle (the smallest if several) \[deg\]
    pub unstable_amplitude_deg: Option<f64>,
    /// max |θ| of the stable cycle (the largest if several) \[deg\]
    pub stable_amplitude_deg: Option<f64>,
}

/// The reference of a threshold map: the diagram's Hopf and fold and its cycles at the
/// speeds of axis 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CycleReference {
    /// V_crit, the Hopf speed \[m/s\]
    pub hopf_v_mps: f64,
    /// V_fold, the fold of cycles \[m/s\]
    pub fold_v_mps: Option<f64>,
    /// max |θ| at the fold \[deg\]
    pub fold_amplitude_deg: Option<f64>,
    /// the cycles at each speed of axis 1
    pub speeds: Vec<CycleAtSpeed>,
}

fn failed(values: Vec<f64>, e: String) -> PointResult {
    PointResult {
        values,
        output: Err(e),
        steps: 0,
    }
}

/// One simulation of the column: class and steps at θ(0) = `theta0` \[deg\].
fn class_at(
    model: &PointModel<'_>,
    base: &BaseScenario,
    theta0: f64,
    horizon: f64,
) -> Result<(SwayClass, usize), String> {
    let mut s = base.clone();
    super::set_scenario(&mut s, SweepParameter::Theta0Deg, theta0)?;
    let (m, steps) = super::simulate_point(model, &s, horizon)?;
    Ok((m.class, steps))
}

/// Threshold point `i`: the threshold at the `i`-th value of axis 1 (further axes at their
/// first value).
pub(super) fn run_threshold_point(sweep: &Sweep, i: usize) -> PointResult {
    let Some(search) = sweep.cfg.threshold.clone() else {
        return failed(Vec::new(), "no [threshold] table".into());
    };
    let (values, setup) = sweep.setup(i);
    let speed = values[0];
    let (model, base, _) = match setup {
        Ok(s) => s,
        Err(e) => return failed(vec![speed], e),
    };
    match search_with_doubling(&model, &base, &sweep.axis_values[1], &search, speed) {
        Ok((t, steps)) => PointResult {
            values: vec![speed],
            output: Ok(PointOutput::Theta0Threshold(t)),
            steps,
        },
        Err(e) => failed(vec![speed], e),
    }
}

/// [`bisect`] at the search's horizon, redone with a doubled horizon while the check fails
/// (at most `max_doublings` times); the simulations and steps of every attempt are counted.
fn search_with_doubling(
    model: &PointModel<'_>,
    base: &BaseScenario,
    column: &[f64],
    search: &ThresholdSearch,
    speed: f64,
) -> Result<(Theta0Threshold, usize), String> {
    let mut h = search.horizon_s.get();
    let (mut sims, mut steps) = (0, 0);
    for attempt in 0..=search.max_doublings {
        let (mut t, s) = bisect(model, base, column, search, speed, h)?;
        sims += t.simulations;
        steps += s;
        t.simulations = sims;
        if t.horizon_verified != Some(false) || attempt == search.max_doublings {
            return Ok((t, steps));
        }
        h *= 2.0;
    }
    Err("unreachable: the loop returns on its last attempt".into())
}

/// The scan of the grid column, the bisection and the horizon check, at horizon `h` \[s\].
fn bisect(
    model: &PointModel<'_>,
    base: &BaseScenario,
    column: &[f64],
    search: &ThresholdSearch,
    speed: f64,
    h: f64,
) -> Result<(Theta0Threshold, usize), String> {
    let (mut sims, mut steps) = (0, 0);
    let mut run = |theta0: f64, horizon: f64| -> Result<SwayClass, String> {
        let (c, s) = class_at(model, base, theta0, horizon)?;
        sims += 1;
        steps += s;
        Ok(c)
    };
    let mut first = None;
    for (j, &y) in column.iter().enumerate() {
        if run(y, h)? == SwayClass::SustainedSway {
            first = Some(j);
            break;
        }
    }
    let mut out = Theta0Threshold {
        speed_mps: speed,
        grid_theta0_deg: first.map(|j| column[j]),
        theta0_threshold_deg: None,
        theta0_below_deg: None,
        horizon_s: h,
        horizon_verified: None,
        simulations: 0,
    };
    if let Some(j) = first {
        let mut hi = column[j];
        let mut lo = (j > 0).then(|| column[j - 1]);
        if let Some(mut l) = lo {
            while hi - l > search.tolerance_deg.get() {
                let mid = 0.5 * (l + hi);
                if run(mid, h)? == SwayClass::SustainedSway {
                    hi = mid;
                } else {
                    l = mid;
                }
            }
            lo = Some(l);
        }
        // the outcome must not change with a doubled horizon at either end
        let hi_ok = run(hi, 2.0 * h)? == SwayClass::SustainedSway;
        let lo_ok = match lo {
            Some(l) => run(l, 2.0 * h)? != SwayClass::SustainedSway,
            None => true,
        };
        out.theta0_threshold_deg = Some(hi);
        out.theta0_below_deg = lo;
        out.horizon_verified = Some(hi_ok && lo_ok);
    }
    out.simulations = sims;
    Ok((out, steps))
}

/// The reference point: the bifurcation diagram of the base vehicle (open loop) and its
/// cycles at every speed of axis 1.
pub(super) fn run_reference_point(sweep: &Sweep) -> PointResult {
    let opts = sweep
        .cfg
        .threshold
        .as_ref()
        .map(|t| t.cycles.clone())
        .unwrap_or_default();
    let speeds = &sweep.axis_values[0];
    let computed = match sweep.variant_plant() {
        Some(plant) => {
            trailer_model::with_plant!(plant, m => reference(m, &opts, &sweep.limits, speeds))
        }
        None => reference(sweep.base_model(), &opts, &sweep.limits, speeds),
    };
    match computed {
        Ok(r) => PointResult {
            values: Vec::new(),
            output: Ok(PointOutput::CycleReference(r)),
            steps: 0,
        },
        Err(e) => failed(Vec::new(), e.to_string()),
    }
}

fn reference<P: Vehicle<N>, const N: usize>(
    model: &P,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
    speeds: &[f64],
) -> Result<CycleReference, SwayError> {
    let d = match vehicle_diagram(
        model,
        LoopLaw::OPEN_LOOP,
        settings,
        limits,
        CycleExtent::WholeRange,
    )? {
        DiagramOutcome::Computed(d) => d,
        DiagramOutcome::NoHopf(n) => {
            return Err(SwayError::numerical(
                "the reference diagram of the threshold map",
                std::io::Error::other(n.reason),
            ));
        }
    };
    let o = &d.options;
    let mut out = Vec::with_capacity(speeds.len());
    for &v in speeds {
        let inside = v > o.v_min_mps && v < o.v_max_mps;
        let c = if inside {
            d.cycles_at(model, v)?
        } else {
            Vec::new()
        };
        let amp = |stable: bool| {
            c.iter()
                .filter(move |c| c.stable == stable)
                .map(|c| c.amplitude_deg)
        };
        out.push(CycleAtSpeed {
            speed_mps: v,
            unstable_amplitude_deg: amp(false).min_by(f64::total_cmp),
            stable_amplitude_deg: amp(true).max_by(f64::total_cmp),
        });
    }
    Ok(CycleReference {
        hopf_v_mps: d.hopf.parameter,
        fold_v_mps: d.fold.map(|f| f.speed_mps),
        fold_amplitude_deg: d.fold.map(|f| f.amplitude_deg),
        speeds: out,
    })
}

/// The θ(0) threshold of `vehicle` at constant speed `speed` \[m/s\] of `base` (a state
/// start): the first value of `column` \[deg\] that ends in sustained sway, bisected, with
/// the horizon check of a threshold map (as its threshold points).
///
/// # Errors
/// A message when a simulation fails.
pub fn theta0_threshold<'a>(
    vehicle: impl Into<VehicleForm<'a>>,
    base: &BaseScenario,
    column: &[f64],
    search: &ThresholdSearch,
    speed: f64,
) -> Result<Theta0Threshold, String> {
    let model = PointModel::from(vehicle.into());
    search_with_doubling(&model, base, column, search, speed).map(|(t, _)| t)
}
