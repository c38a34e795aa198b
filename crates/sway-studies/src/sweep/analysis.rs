//! The non-simulation point kinds: the linear critical speed with its Hopf frequency, and
//! the Hopf and fold-of-cycles speeds.

use std::path::Path;

use continuation::Criticality;
use serde::{Deserialize, Serialize};
use trailer_model::{AnyVehicleModel, Inputs, Model, State4, sorted_eigenvalues};

use super::PointKind;
use sway::SwayError;
use sway::bifurcation::chart::{ChartOptions, critical_speeds};
use sway::bifurcation::{CycleExtent, LoopLaw};
use sway::bifurcation::{DiagramOutcome, DiagramSettings, vehicle_diagram};
use sway::charts::{critical_speed_at_gain, rightmost_roots};
use sway::config::{ensure, ensure_count};
use sway::control;
use sway::ranging::SpeedLimits;
use sway::sim::VehicleForm;
use sway_model::vehicle::Vehicle;

/// Settings of the linear and bifurcation point kinds (`[analysis]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AnalysisOptions {
    /// V_crit is searched in \[v_min, v_max\] \[m/s\] (omitted: the lowest speed of the
    /// [`SpeedLimits`], 1 m/s)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_min_mps: Option<f64>,
    /// upper end of the search \[m/s\] (omitted: the maximum speed, `--max-speed`)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_max_mps: Option<f64>,
    /// scan step of the open-loop search for the sign change of max Re λ \[m/s\]
    pub scan_step_mps: f64,
    /// bisection ends at this bracket width \[m/s\]
    pub tolerance_mps: f64,
    /// closed loop: speeds scanned for the first unstable root count
    pub closed_loop_samples: usize,
    /// `hopf_fold_speeds`: the bifurcation diagram's settings (default: fig3a's, with the
    /// speed range derived from the vehicle, [`vehicle_diagram`])
    pub diagram: DiagramSettings,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        Self {
            v_min_mps: None,
            v_max_mps: None,
            scan_step_mps: 2.0,
            tolerance_mps: 1e-8,
            closed_loop_samples: 71,
            diagram: DiagramSettings::default(),
        }
    }
}

impl AnalysisOptions {
    /// Whether these are the defaults (then they are not written out).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The V_crit search range \[m/s\]: the config's numbers, else the limits'.
    pub fn range(&self, limits: &SpeedLimits) -> (f64, f64) {
        (
            self.v_min_mps.unwrap_or(limits.min_speed_mps),
            self.v_max_mps.unwrap_or(limits.max_speed_mps),
        )
    }

    /// Checks the keys under `analysis`.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the key.
    pub fn validate(&self, file: &Path, _kind: PointKind) -> Result<(), SwayError> {
        // an omitted end is checked against the other with the default limits (the
        // maximum speed is checked by the command line)
        let (lo, hi) = self.range(&SpeedLimits::default());
        ensure(
            lo > 0.0 && hi > lo && hi.is_finite(),
            file,
            if self.v_min_mps.is_some() {
                "analysis.v_min_mps"
            } else {
                "analysis.v_max_mps"
            },
            || format!("expected 0 < v_min_mps < v_max_mps, got {lo} and {hi}"),
        )?;
        ensure(
            self.scan_step_mps > 0.0 && self.scan_step_mps.is_finite(),
            file,
            "analysis.scan_step_mps",
            || format!("expected a step > 0, got {}", self.scan_step_mps),
        )?;
        ensure(
            self.tolerance_mps > 0.0 && self.tolerance_mps.is_finite(),
            file,
            "analysis.tolerance_mps",
            || format!("expected a tolerance > 0, got {}", self.tolerance_mps),
        )?;
        ensure_count(
            self.closed_loop_samples,
            (2, sway::config::MAX_GRID_POINTS),
            file,
            "analysis.closed_loop_samples",
            "samples",
            || "speeds of the scan for a closed-loop V_crit, one root count each".into(),
        )
    }
}

/// The linear critical speed of one point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinearCriticalSpeed {
    /// V_crit \[m/s\]: the lowest speed of the search range with an unstable root (null:
    /// stable on the whole range)
    pub v_crit_mps: Option<f64>,
    /// ω of the critical pair at V_crit \[rad/s\]
    pub hopf_omega_rad_s: Option<f64>,
    /// ω/2π \[Hz\]
    pub hopf_frequency_hz: Option<f64>,
}

/// The Hopf and fold-of-cycles speeds of one point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HopfFoldSpeeds {
    /// the Hopf speed \[m/s\] (null: no Hopf point below the maximum speed, see `reason`)
    pub hopf_v_mps: Option<f64>,
    /// the Hopf frequency \[rad/s\]
    pub hopf_omega_rad_s: Option<f64>,
    /// "Subcritical" or "Supercritical"
    pub criticality: Option<Criticality>,
    /// the fold-of-cycles speed \[m/s\] (null: the branch does not fold in the range)
    pub fold_v_mps: Option<f64>,
    /// max |θ| on the fold's cycle \[deg\]
    pub fold_amplitude_deg: Option<f64>,
    /// why a value is null
    #[serde(default)]
    pub reason: Option<String>,
}

/// A law other than the paper's (`yaw_rate_hitch`, `predictor`, or braking) as a loop of
/// [`sway::control`], with, for the predictor, the model it predicts with
/// ([`LoopLaw::prediction_params`]).
struct AnalysedLoop {
    law: LoopLaw,
    prediction: Option<Model>,
}

impl AnalysedLoop {
    /// The loop of `law` on `model`; None for the open loop and the paper's structure
    /// (analysed as the feedback (D, τ), [`feedback`]).
    fn of(model: &Model, law: Option<&LoopLaw>) -> Result<Option<Self>, String> {
        let Some(law) = law.filter(|l| !l.is_paper_structure()) else {
            return Ok(None);
        };
        let prediction = if law.structure == control::Structure::Predictor {
            let params = law.prediction_params(model.params());
            Some(Model::new(params).map_err(|e| format!("the predictor's model: {e}"))?)
        } else {
            None
        };
        Ok(Some(Self {
            law: *law,
            prediction,
        }))
    }

    fn prediction(&self) -> Option<&dyn control::LoopModel> {
        self.prediction
            .as_ref()
            .map(|m| m as &dyn control::LoopModel)
    }

    /// V_crit by the loop's exact unstable-root count ([`control::critical_speed`]: the
    /// scan of `closed_loop_samples` speeds and bisection to `tolerance_mps`) and ω of its
    /// rightmost root there.
    fn critical_speed(
        &self,
        model: &Model,
        (v_min_mps, v_max_mps): (f64, f64),
        o: &AnalysisOptions,
    ) -> Result<LinearCriticalSpeed, String> {
        let search = control::SpeedSearch {
            v_min_mps,
            v_max_mps,
            samples: o.closed_loop_samples,
            tolerance_mps: o.tolerance_mps,
        };
        let v = control::critical_speed(model, &self.law, self.prediction(), &search)
            .map_err(|e| e.to_string())?;
        let omega = match v {
            Some(v) => {
                let roots = control::LinearLoop::new(model, &self.law, v, self.prediction())
                    .and_then(|l| {
                        l.rightmost_roots(2).map_err(|e| {
                            SwayError::numerical(format!("the roots at V = {v} m/s"), e)
                        })
                    })
                    .map_err(|e| e.to_string())?;
                roots.first().map(|r| r.im.abs())
            }
            None => None,
        };
        Ok(LinearCriticalSpeed {
            v_crit_mps: v,
            hopf_omega_rad_s: omega,
            hopf_frequency_hz: omega.map(|w| w / std::f64::consts::TAU),
        })
    }
}

impl AnalysedLoop {
    /// The Hopf and fold speeds of the loop ([`control::hopf_and_fold`]: the Hopf point
    /// located on the spectrum, the fold corrected at fixed gains) on the speed range of
    /// `[analysis.diagram]` (derived from `limits` where it gives none); the predictor's,
    /// and any failure, null with the reason.
    fn hopf_fold_speeds(
        &self,
        model: &Model,
        o: &AnalysisOptions,
        limits: &SpeedLimits,
    ) -> HopfFoldSpeeds {
        let (lo, hi) = o.diagram.searched(limits);
        let search = control::SpeedSearch {
            v_min_mps: lo,
            v_max_mps: hi,
            ..control::SpeedSearch::default()
        };
        let chart = ChartOptions::correcting(&o.diagram.options(lo, hi));
        match sway::control::hopf_and_fold(model, &self.law, &chart, &search) {
            Ok(r) => HopfFoldSpeeds {
                hopf_v_mps: r.hopf.map(|h| h.0),
                hopf_omega_rad_s: r.hopf.map(|h| h.1),
                criticality: r.hopf.map(|h| h.2),
                fold_v_mps: r.fold.map(|f| f.v_mps),
                fold_amplitude_deg: r.fold.map(|f| f.amplitude_deg),
                reason: r.reason,
            },
            Err(e) => HopfFoldSpeeds {
                hopf_v_mps: None,
                hopf_omega_rad_s: None,
                criticality: None,
                fold_v_mps: None,
                fold_amplitude_deg: None,
                reason: Some(e.to_string()),
            },
        }
    }
}

/// The feedback (D, τ) of a law for the linear and bifurcation analyses (open loop:
/// D = τ = 0); a rate-limited or saturated actuator is nonlinear and refused.
fn feedback(law: Option<&LoopLaw>) -> Result<LoopLaw, String> {
    match law {
        None => Ok(LoopLaw::OPEN_LOOP),
        Some(l) if !l.is_paper_structure() => Err(
            "a vehicle with model variants takes the open loop or a yaw_rate_feedback controller in the linear and bifurcation kinds of sweeps; yaw_rate_hitch and predictor are analysed on the paper's model (or simulated)".into(),
        ),
        Some(l) if !l.steering_limits.is_default() => {
            Err("the linear and bifurcation kinds need an actuator without limits".into())
        }
        Some(l) => Ok(LoopLaw::paper(l.gains.yaw_rate, l.delay_s)),
    }
}

/// The rightmost eigenvalue of Ã(V) (eq. 11, exact Jacobian of the reduced model): its real
/// part and |imaginary part|.
fn critical_pair(model: &Model, v: f64) -> (f64, f64) {
    let (a, _) = model.jacobian4(&State4::zeros(), &Inputs::constant_speed(v));
    let ev = sorted_eigenvalues(&a);
    (ev[0].re, ev[0].im.abs())
}

/// The lowest speed in \[v_min, v_max\] ([`AnalysisOptions::range`]) where max Re λ(Ã(V)) changes sign: a scan in
/// `scan_step_mps`, then the Illinois variant of regula falsi on the bracket down to
/// `tolerance_mps` (superlinear where the abscissa is smooth, i.e. at a crossing of a
/// simple pair; the bracket always shrinks). None if stable on the whole range.
///
/// # Errors
/// When straight running is already unstable at v_min, or the abscissa is not finite.
pub fn open_loop_critical_speed(
    model: &Model,
    o: &AnalysisOptions,
    limits: &SpeedLimits,
) -> Result<Option<f64>, String> {
    open_loop_scan(|v| critical_pair(model, v).0, o, limits)
}

/// The rightmost eigenvalue's real part and |imaginary part| of any plant's A(V).
fn plant_critical_pair<P: trailer_model::Plant<M>, const M: usize>(
    plant: &P,
    v: f64,
) -> (f64, f64) {
    let ev = trailer_model::sorted_spectrum(&plant.plant_linearization(v).a);
    (ev[0].re, ev[0].im.abs())
}

/// V_crit and the Hopf frequency of the delayed feedback `fb` (D ≠ 0) of any vehicle: the
/// exact unstable-root count of eq. (13) ([`critical_speed_at_gain`]) and its rightmost
/// root at V_crit.
fn closed_loop_critical_speed<M: control::LoopModel + ?Sized>(
    model: &M,
    fb: &LoopLaw,
    (v_min, v_max): (f64, f64),
    o: &AnalysisOptions,
) -> Result<(Option<f64>, Option<f64>), String> {
    let v = critical_speed_at_gain(
        model,
        fb.delay_s,
        fb.gains.yaw_rate,
        v_min,
        v_max,
        o.closed_loop_samples,
        o.tolerance_mps,
    )
    .map_err(|e| e.to_string())?;
    let omega = match v {
        Some(v) => {
            let roots = rightmost_roots(model, v, fb.gains.yaw_rate, fb.delay_s, 2)
                .map_err(|e| e.to_string())?;
            roots.first().map(|r| r.im.abs())
        }
        None => None,
    };
    Ok((v, omega))
}

/// V_crit and the Hopf frequency of a model variant: in open loop by the scan and regula
/// falsi of [`open_loop_critical_speed`] on its own spectral abscissa, with delayed
/// yaw-rate feedback as the paper's model ([`closed_loop_critical_speed`]).
fn variant_linear_critical_speed(
    vehicle: &AnyVehicleModel,
    controller: Option<&LoopLaw>,
    o: &AnalysisOptions,
    limits: &SpeedLimits,
) -> Result<LinearCriticalSpeed, String> {
    let fb = feedback(controller)?;
    if fb.gains.yaw_rate != 0.0 {
        let (v, omega) = closed_loop_critical_speed(vehicle, &fb, o.range(limits), o)?;
        return Ok(LinearCriticalSpeed {
            v_crit_mps: v,
            hopf_omega_rad_s: omega,
            hopf_frequency_hz: omega.map(|w| w / std::f64::consts::TAU),
        });
    }
    let (v, omega) = trailer_model::with_plant!(vehicle, m => {
        match open_loop_scan(|v| plant_critical_pair(m, v).0, o, limits)? {
            Some(v) => (Some(v), Some(plant_critical_pair(m, v).1)),
            None => (None, None),
        }
    });
    Ok(LinearCriticalSpeed {
        v_crit_mps: v,
        hopf_omega_rad_s: omega,
        hopf_frequency_hz: omega.map(|w| w / std::f64::consts::TAU),
    })
}

/// The scan and regula falsi of [`open_loop_critical_speed`] on the spectral abscissa
/// `abscissa(V)` \[1/s\].
fn open_loop_scan(
    abscissa: impl Fn(f64) -> f64,
    o: &AnalysisOptions,
    limits: &SpeedLimits,
) -> Result<Option<f64>, String> {
    let (v_min, v_max) = o.range(limits);
    let f = |v: f64| {
        let a = abscissa(v);
        if a.is_finite() {
            Ok(a)
        } else {
            Err(format!(
                "the eigenvalues of Ã are not finite at V = {v} m/s"
            ))
        }
    };
    let (mut lo, mut f_lo) = (v_min, f(v_min)?);
    if f_lo >= 0.0 {
        return Err(format!(
            "straight running is already unstable at v_min = {v_min} m/s"
        ));
    }
    let (mut hi, mut f_hi);
    loop {
        hi = (lo + o.scan_step_mps).min(v_max);
        f_hi = f(hi)?;
        if f_hi >= 0.0 {
            break;
        }
        if hi >= v_max {
            return Ok(None);
        }
        (lo, f_lo) = (hi, f_hi);
    }
    // Illinois: the end that stays is halved in weight, so both ends move
    let mut side = 0;
    for _ in 0..200 {
        if hi - lo <= o.tolerance_mps {
            break;
        }
        let mut m = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        if !(m > lo && m < hi) {
            m = 0.5 * (lo + hi);
        }
        let fm = f(m)?;
        if fm < 0.0 {
            (lo, f_lo) = (m, fm);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, f_hi) = (m, fm);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    Ok(Some(0.5 * (lo + hi)))
}

/// V_crit and the Hopf frequency of `vehicle` with `controller`'s feedback. The paper's
/// model: open loop by the sign change of max Re λ(Ã(V)) ([`open_loop_critical_speed`]);
/// closed loop by the exact unstable-root count of eq. (13) ([`critical_speed_at_gain`]) and
/// its rightmost root; `yaw_rate_hitch` and `predictor` by the count of their loop
/// ([`control::critical_speed`]). A model variant: open loop by the same scan and regula
/// falsi on its own spectral abscissa, delayed yaw-rate feedback by the same root count.
///
/// # Errors
/// A message naming the failing step.
pub fn linear_critical_speed<'a>(
    vehicle: impl Into<VehicleForm<'a>>,
    controller: Option<&LoopLaw>,
    o: &AnalysisOptions,
    limits: &SpeedLimits,
) -> Result<LinearCriticalSpeed, String> {
    let model = match vehicle.into() {
        VehicleForm::Paper(m) | VehicleForm::Variants(AnyVehicleModel::Paper(m)) => m,
        VehicleForm::Variants(v) => {
            return variant_linear_critical_speed(v, controller, o, limits);
        }
    };
    let (v_min, v_max) = o.range(limits);
    if let Some(l) = AnalysedLoop::of(model, controller)? {
        return l.critical_speed(model, (v_min, v_max), o);
    }
    let fb = feedback(controller)?;
    let (v, omega) = if fb.gains.yaw_rate == 0.0 {
        match open_loop_critical_speed(model, o, limits)? {
            Some(v) => (Some(v), Some(critical_pair(model, v).1)),
            None => (None, None),
        }
    } else {
        closed_loop_critical_speed(model, &fb, (v_min, v_max), o)?
    };
    Ok(LinearCriticalSpeed {
        v_crit_mps: v,
        hopf_omega_rad_s: omega,
        hopf_frequency_hz: omega.map(|w| w / std::f64::consts::TAU),
    })
}

/// The Hopf and fold speeds of `model` with `controller`'s feedback: the bifurcation diagram
/// up to its first fold (on the range derived from the vehicle unless `[analysis.diagram]`
/// gives it, [`vehicle_diagram`]), corrected on the two-parameter defining systems at fixed
/// D ([`critical_speeds`], as `fig4b` reports them); a `yaw_rate_hitch` loop as
/// [`control::hopf_and_fold`] computes them (the predictor: null, with the reason). No Hopf
/// point below the maximum speed is an outcome: all fields null, with the reason.
///
/// # Errors
/// A message naming the failing stage.
pub fn hopf_fold_speeds(
    model: &Model,
    controller: Option<&LoopLaw>,
    o: &AnalysisOptions,
    limits: &SpeedLimits,
) -> Result<HopfFoldSpeeds, String> {
    if let Some(l) = AnalysedLoop::of(model, controller)? {
        return Ok(l.hopf_fold_speeds(model, o, limits));
    }
    diagram_hopf_fold_speeds(model, controller, o, limits)
}

/// [`hopf_fold_speeds`] of any vehicle (model variants too) with the open loop or a
/// `yaw_rate_feedback` controller: read off its bifurcation diagram.
///
/// # Errors
/// A message naming the failing stage, or the controller a diagram does not take.
pub fn diagram_hopf_fold_speeds<P: Vehicle<N>, const N: usize>(
    model: &P,
    controller: Option<&LoopLaw>,
    o: &AnalysisOptions,
    limits: &SpeedLimits,
) -> Result<HopfFoldSpeeds, String> {
    let fb = feedback(controller)?;
    let outcome = vehicle_diagram(model, fb, &o.diagram, limits, CycleExtent::FirstFold)
        .map_err(|e| e.to_string())?;
    let d = match outcome {
        DiagramOutcome::Computed(d) => d,
        DiagramOutcome::NoHopf(n) => {
            return Ok(HopfFoldSpeeds {
                hopf_v_mps: None,
                hopf_omega_rad_s: None,
                criticality: None,
                fold_v_mps: None,
                fold_amplitude_deg: None,
                reason: Some(n.reason),
            });
        }
    };
    let c = critical_speeds(model, &d, &ChartOptions::correcting(&d.options))
        .map_err(|e| e.to_string())?;
    // a correction that failed is the reason of its null (the located Hopf point stands)
    let failed: Vec<String> = c
        .curves_ended_early
        .iter()
        .map(|e| format!("{} {}", e.curve, e.end.describe()))
        .collect();
    let reason = if !failed.is_empty() {
        Some(failed.join("; "))
    } else if c.fold.is_none() {
        d.fold_reason()
    } else {
        None
    };
    Ok(HopfFoldSpeeds {
        hopf_v_mps: Some(c.hopf_v_mps),
        hopf_omega_rad_s: Some(c.hopf_omega_rad_s.abs()),
        criticality: Some(c.criticality),
        fold_v_mps: c.fold.map(|f| f.v_mps),
        fold_amplitude_deg: c.fold.map(|f| f.amplitude_deg),
        reason,
    })
}
