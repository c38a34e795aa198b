//! The computation of `fig3a` (paper Fig. 3a): the bifurcation diagram of the open loop
//! (δ ≡ 0) with V as parameter ([`diagram`]: straight running, the Hopf point, the cycle
//! branch and its fold, the cycle amplitudes at configured speeds), and the time panels at
//! one speed in the bistable range (θ(0) = 2° decays, 8° grows into sway), their speed
//! resolved against the diagram's own V_crit and fold of cycles.
//!
//! A vehicle without a Hopf point below the maximum speed, or without a bistable range, is
//! an outcome: the summary's fields are null with the reason beside them, and the time
//! panels say why they are absent.

use std::path::Path;

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::bifurcation::{Diagram, DiagramSettings, LoopLaw, NoHopf};
use sway::config::{Positive, ensure, ensure_positive};
use sway::parallel::Split;
use sway::progress::Progress;
use sway::ranging::{
    CorrectedDiagram, RelativeSpeed, SpeedLimits, SpeedReferences, SpeedSpec, corrected_diagram,
};
use sway::sim::speeds::{
    ResolveSpeeds, ResolvedSpeed, Resolver, SpeedValue, UnresolvedSpeed, resolve_against,
};
use sway::sim::{RunSettings, SimSpec, SpeedProfile};
use sway_model::vehicle::Vehicle;
use trailer_model::AnyVehicleModel;

use crate::keyed::Keyed;
use crate::simulate::{Runs, every, run, with_resolved_speeds};

/// Table I's 35, 36 and 38 m/s as fractions of its V_crit (34.74792336267873 m/s).
fn default_stable() -> Vec<SpeedSpec> {
    [1.00725443747214, 1.0360331356856298, 1.0935905321126091]
        .map(|f| SpeedSpec::Relative(RelativeSpeed::OfVCrit(f)))
        .to_vec()
}
/// Table I's 33 m/s as a fraction of its bistable range (fold 31.52277210344242 m/s to
/// V_crit), as this diagram locates them.
fn default_unstable() -> Vec<SpeedSpec> {
    vec![SpeedSpec::Relative(RelativeSpeed::InBistable(
        0.4580338136231522,
    ))]
}

/// The `[diagram]` section of `configs/fig3a.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagramConfig {
    /// continuation and discretisation settings (`[diagram.continuation]`); the speed
    /// range omitted: derived from the vehicle ([`sway::bifurcation::vehicle_diagram`])
    #[serde(default, rename = "continuation")]
    pub options: DiagramSettings,
    /// speeds at which the stable cycle's amplitude is reported (`stable_amplitude_deg`):
    /// numbers \[m/s\] or relative ([`SpeedSpec`], resolved with this diagram's V_crit and fold)
    #[serde(default = "default_stable")]
    pub stable_speeds_mps: Vec<SpeedSpec>,
    /// speeds at which the unstable cycle's amplitude is reported (`unstable_amplitude_deg`)
    #[serde(default = "default_unstable")]
    pub unstable_speeds_mps: Vec<SpeedSpec>,
}

impl Default for DiagramConfig {
    fn default() -> Self {
        Self {
            options: DiagramSettings::default(),
            stable_speeds_mps: default_stable(),
            unstable_speeds_mps: default_unstable(),
        }
    }
}

fn default_speed<S: From<f64>>() -> S {
    S::from(33.0)
}
fn default_thetas() -> Vec<f64> {
    vec![2.0, 8.0]
}
fn default_horizon() -> Positive {
    Positive::literal(60.0)
}
fn default_output_step() -> Positive {
    Positive::literal(0.02)
}

/// The `[panels]` section of `configs/fig3a.toml`. `S`: the type of the speed,
/// [`SpeedSpec`] as written (a number or relative to the vehicle), `f64` when run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(
    serialize = "S: Serialize",
    deserialize = "S: Deserialize<'de> + From<f64>"
))]
pub struct PanelsConfig<S = f64> {
    /// constant speed V \[m/s\] (default 33 m/s)
    #[serde(default = "default_speed")]
    pub speed_mps: S,
    /// initial hitch angles θ(0) \[deg\], one panel each (other states 0)
    #[serde(default = "default_thetas")]
    pub theta0_deg: Vec<f64>,
    /// horizon \[s\]
    #[serde(default = "default_horizon")]
    pub horizon_s: Positive,
    /// sampling of the plotted series \[s\]
    #[serde(default = "default_output_step")]
    pub output_step_s: Positive,
    /// validity guard, tolerances, metric settings (final window 5 s)
    #[serde(flatten)]
    pub settings: RunSettings,
}

impl<S: SpeedValue> ResolveSpeeds for PanelsConfig<S> {
    type Resolved = PanelsConfig;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<PanelsConfig, UnresolvedSpeed> {
        Ok(PanelsConfig {
            speed_mps: self.speed_mps.resolve_speed("panels.speed_mps", r)?,
            theta0_deg: self.theta0_deg.clone(),
            horizon_s: self.horizon_s,
            output_step_s: self.output_step_s,
            settings: self.settings,
        })
    }
}

impl PanelsConfig<SpeedSpec> {
    /// Checks the keys that can be checked before the speed is resolved; with a number,
    /// every key ([`PanelsConfig::validate`]).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate_spec(&self, file: &Path, prefix: &str) -> Result<(), SwayError> {
        match self.all_numbers() {
            Some(c) => c.validate(file, prefix),
            None => Ok(()),
        }
    }
}

impl PanelsConfig {
    /// Checks the keys that do not validate themselves (`prefix` is the section's key
    /// path).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), SwayError> {
        ensure_positive(
            self.speed_mps,
            file,
            &format!("{prefix}.speed_mps"),
            "a speed > 0 m/s",
        )?;
        ensure(
            !self.theta0_deg.is_empty()
                && self
                    .theta0_deg
                    .iter()
                    .all(|t| t.is_finite() && t.abs() < 90.0),
            file,
            &format!("{prefix}.theta0_deg"),
            || {
                format!(
                    "expected a list of angles with |θ| < 90 deg, got {:?}",
                    self.theta0_deg
                )
            },
        )?;
        ensure(
            self.output_step_s <= self.horizon_s,
            file,
            &format!("{prefix}.output_step_s"),
            || {
                format!(
                    "expected 0 < output_step_s <= horizon_s, got {}",
                    self.output_step_s.get()
                )
            },
        )?;
        self.settings
            .solver
            .validate_at(file, &format!("{prefix}.solver"))
    }

    /// The run at constant speed (every panel; they differ in θ(0)).
    pub fn spec(&self) -> SimSpec {
        SimSpec {
            early_stop: sway::sim::EarlyStop::Never,
            steering: Default::default(),
            profile: SpeedProfile::Constant {
                speed_mps: self.speed_mps,
            },
            controller: None,
            horizon_s: self.horizon_s.get(),
            action_s: 0.0,
            settings: self.settings,
        }
    }
}

/// `configs/fig3a.toml`: `[panels]` for the time panels, `[diagram]` for the bifurcation
/// diagram (defaults when absent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig3aConfig {
    /// time panels
    pub panels: PanelsConfig<SpeedSpec>,
    /// the bifurcation diagram
    #[serde(default)]
    pub diagram: DiagramConfig,
}

/// The key of a panel in `"time_panels"`: `theta0_2deg`, `theta0_8deg`, `theta0_2.5deg`.
pub fn panel_key(theta0_deg: f64) -> String {
    format!("theta0_{theta0_deg}deg")
}

/// What distinguishes a panel's run (beside its metrics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PanelRun {
    /// θ(0) \[deg\]
    pub theta0_deg: f64,
    /// V \[m/s\]
    pub speed_mps: f64,
}

/// Summary key of a speed: `35` for 35.0, `35.5` for 35.5; a resolved relative speed is
/// rounded to 1e-9 m/s first (Table I's `{ of_v_crit = 1.00725443747214 }` is `35`).
pub fn speed_key(v: f64) -> String {
    format!("{}", (v * 1e9).round() / 1e9)
}

/// The collocation mesh of the cycles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Mesh {
    /// mesh intervals L
    pub intervals: usize,
    /// polynomial degree m
    pub degree: usize,
}

/// The key of a reason why a configured speed has no amplitude: the speed's key
/// ([`speed_key`]) when it resolved, else the speed as configured (which the caller writes
/// as its JSON text).
#[derive(Debug, Clone, PartialEq)]
pub enum AmplitudeKey {
    /// the resolved speed's key
    Speed(String),
    /// the configured speed that did not resolve
    Spec(SpeedSpec),
}

/// The diagram's fields of fig3a's `summary.json` (speed keys as [`speed_key`] writes
/// them). A quantity that does not exist for the vehicle (no Hopf point below the maximum
/// speed, no fold) is null, with the reason in the `*_reason` field next to it. `K`: the
/// keys of `amplitude_reasons` (see [`AmplitudeKey`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiagramSummary<K = String> {
    /// V at the Hopf point (V_crit) \[m/s\]; null: no Hopf point in the searched range
    pub hopf_v_mps: Option<f64>,
    /// why there is no Hopf point (only when `hopf_v_mps` is null)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hopf_reason: Option<String>,
    /// straight running is stable up to this speed \[m/s\] (only without a Hopf point)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_up_to_mps: Option<f64>,
    /// straight running loses stability here through a real eigenvalue (a static
    /// divergence, no sway cycles) \[m/s\] (only without a Hopf point)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub divergence_v_mps: Option<f64>,
    /// V at the fold of cycles \[m/s\], corrected on the fold-of-cycles defining system
    /// (as `fig4b` and `chart_nonlinear` report it)
    pub fold_v_mps: Option<f64>,
    /// V at the fold as located on the cycle branch, before the correction \[m/s\]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fold_located_v_mps: Option<f64>,
    /// why there is no fold (only when `fold_v_mps` is null)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fold_reason: Option<String>,
    /// max |θ| at the fold \[deg\]
    pub fold_amplitude_deg: Option<f64>,
    /// max |θ| of the stable cycle at the configured speeds \[deg\]
    pub stable_amplitude_deg: Keyed<Option<f64>>,
    /// max |θ| of the unstable cycle at the configured speeds \[deg\]
    pub unstable_amplitude_deg: Keyed<Option<f64>>,
    /// why a configured speed has no amplitude (relative speed without its reference, or
    /// no cycle of that stability there), by speed key or spec
    #[serde(skip_serializing_if = "Keyed::is_empty")]
    pub amplitude_reasons: Keyed<String, K>,
    /// "subcritical" or "supercritical"
    pub criticality: Option<String>,
    /// ω at the Hopf point \[rad/s\]
    pub hopf_omega_rad_s: Option<f64>,
    /// 2π/ω \[s\]
    pub hopf_period_s: Option<f64>,
    /// period of the cycle at the fold \[s\]
    pub fold_period_s: Option<f64>,
    /// period of the stable cycle at the configured speeds \[s\]
    pub stable_period_s: Keyed<Option<f64>>,
    /// from the fold to the Hopf point \[m/s\]
    pub bistable_range_mps: Option<[f64; 2]>,
    /// points on the cycle branch
    pub cycle_points: usize,
    /// why the cycle branch ended ([`sway::bifurcation::BranchEnd::reason`])
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cycle_branch_end: Option<String>,
    /// the speeds searched for the Hopf point and the cycle branch \[m/s\]
    pub searched_mps: [f64; 2],
    /// the speed range of the figure \[m/s\] (derived from the vehicle unless configured)
    pub diagram_range_mps: [f64; 2],
    /// the collocation mesh
    pub mesh: Mesh,
}

impl<K> DiagramSummary<K> {
    /// The same summary with the keys of `amplitude_reasons` that `key` makes of these.
    pub fn rekeyed<L>(self, key: impl Fn(K) -> L) -> DiagramSummary<L> {
        DiagramSummary {
            amplitude_reasons: self.amplitude_reasons.rekeyed(key),
            hopf_v_mps: self.hopf_v_mps,
            hopf_reason: self.hopf_reason,
            stable_up_to_mps: self.stable_up_to_mps,
            divergence_v_mps: self.divergence_v_mps,
            fold_v_mps: self.fold_v_mps,
            fold_located_v_mps: self.fold_located_v_mps,
            fold_reason: self.fold_reason,
            fold_amplitude_deg: self.fold_amplitude_deg,
            stable_amplitude_deg: self.stable_amplitude_deg,
            unstable_amplitude_deg: self.unstable_amplitude_deg,
            criticality: self.criticality,
            hopf_omega_rad_s: self.hopf_omega_rad_s,
            hopf_period_s: self.hopf_period_s,
            fold_period_s: self.fold_period_s,
            stable_period_s: self.stable_period_s,
            bistable_range_mps: self.bistable_range_mps,
            cycle_points: self.cycle_points,
            cycle_branch_end: self.cycle_branch_end,
            searched_mps: self.searched_mps,
            diagram_range_mps: self.diagram_range_mps,
            mesh: self.mesh,
        }
    }
}

/// The diagram of the open loop and its summary fields.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagramStudy {
    /// the summary fields, the reasons keyed by the configured speeds of the config
    pub summary: DiagramSummary<AmplitudeKey>,
    /// the diagram (None: straight running has no Hopf point, `summary` says why)
    pub diagram: Option<Box<Diagram>>,
}

/// The open-loop diagram of `vehicle` on the configured speed range, or the one derived
/// from the vehicle within `limits`, with the Hopf point and the fold corrected on their
/// defining systems (one number per vehicle across `fig3a`, `fig4b` and
/// `chart_nonlinear`), and the cycle amplitudes at the configured speeds. Straight running
/// stable up to the maximum speed is an outcome: no diagram, `hopf_v_mps` null with
/// `hopf_reason`.
///
/// # Errors
/// Numerical failures with context.
pub fn diagram(
    vehicle: &AnyVehicleModel,
    cfg: &DiagramConfig,
    limits: &SpeedLimits,
) -> Result<DiagramStudy, SwayError> {
    trailer_model::with_plant!(vehicle, m => diagram_on(m, cfg, limits))
}

/// [`diagram`] on the concrete plant of the vehicle (any model variant; the paper's
/// [`trailer_model::Model`] for a vehicle of the paper's form).
fn diagram_on<P: Vehicle<N>, const N: usize>(
    model: &P,
    cfg: &DiagramConfig,
    limits: &SpeedLimits,
) -> Result<DiagramStudy, SwayError> {
    let CorrectedDiagram {
        diagram: d,
        speeds: cs,
        references: refs,
    } = match corrected_diagram(model, LoopLaw::OPEN_LOOP, &cfg.options, limits)? {
        Ok(c) => c,
        Err(n) => return Ok(no_hopf_diagram(cfg, &n)),
    };
    let mut reasons = Keyed::default();
    let mut stable_amp = Keyed::default();
    let mut stable_period = Keyed::default();
    for spec in &cfg.stable_speeds_mps {
        let Some((key, v)) = resolve_or_note(spec, &refs, &mut reasons) else {
            continue;
        };
        let c = d.cycles_at(model, v)?;
        let s = c
            .iter()
            .filter(|c| c.stable)
            .max_by(|a, b| a.amplitude_deg.total_cmp(&b.amplitude_deg));
        if s.is_none() {
            reasons.0.push((
                AmplitudeKey::Speed(key.clone()),
                format!("no stable cycle at {key} m/s"),
            ));
        }
        stable_amp.0.push((key.clone(), s.map(|c| c.amplitude_deg)));
        stable_period.0.push((key, s.map(|c| c.period_s)));
    }
    let mut unstable_amp = Keyed::default();
    for spec in &cfg.unstable_speeds_mps {
        let Some((key, v)) = resolve_or_note(spec, &refs, &mut reasons) else {
            continue;
        };
        let c = d.cycles_at(model, v)?;
        let s = c
            .iter()
            .filter(|c| !c.stable)
            .min_by(|a, b| a.amplitude_deg.total_cmp(&b.amplitude_deg));
        if s.is_none() {
            reasons.0.push((
                AmplitudeKey::Speed(key.clone()),
                format!("no unstable cycle at {key} m/s"),
            ));
        }
        unstable_amp.0.push((key, s.map(|c| c.amplitude_deg)));
    }
    let fold = cs.fold;
    let fold_reason = match (fold, d.fold_reason()) {
        (None, None) => Some(
            "the fold of the cycle branch could not be corrected on the fold-of-cycles system"
                .into(),
        ),
        (None, r) => r,
        (Some(_), _) => None,
    };
    let summary = DiagramSummary {
        hopf_v_mps: Some(cs.hopf_v_mps),
        hopf_reason: None,
        stable_up_to_mps: None,
        divergence_v_mps: None,
        fold_v_mps: fold.map(|f| f.v_mps),
        fold_located_v_mps: d.fold.map(|f| f.speed_mps),
        fold_reason,
        fold_amplitude_deg: fold.map(|f| f.amplitude_deg),
        stable_amplitude_deg: stable_amp,
        unstable_amplitude_deg: unstable_amp,
        amplitude_reasons: reasons,
        criticality: Some(cs.criticality.to_string()),
        hopf_omega_rad_s: Some(cs.hopf_omega_rad_s),
        hopf_period_s: Some(2.0 * std::f64::consts::PI / cs.hopf_omega_rad_s),
        fold_period_s: fold.map(|f| f.period_s),
        stable_period_s: stable_period,
        bistable_range_mps: match (cs.criticality, fold) {
            (continuation::Criticality::Subcritical, Some(f)) => Some([f.v_mps, cs.hopf_v_mps]),
            _ => None,
        },
        cycle_points: d.cycle_summary.len(),
        cycle_branch_end: Some(d.cycle_branch_end.reason()),
        searched_mps: d.searched_mps,
        diagram_range_mps: [d.options.v_min_mps, d.options.v_max_mps],
        mesh: Mesh {
            intervals: d.options.intervals,
            degree: d.options.degree,
        },
    };
    Ok(DiagramStudy {
        summary,
        diagram: Some(d),
    })
}

/// A configured speed resolved to (summary key, speed \[m/s\]); None (with the reason
/// recorded under the spec) when its reference does not exist.
fn resolve_or_note(
    spec: &SpeedSpec,
    refs: &SpeedReferences,
    reasons: &mut Keyed<String, AmplitudeKey>,
) -> Option<(String, f64)> {
    match spec.resolve(refs) {
        Ok(v) => Some((speed_key(v), v)),
        Err(e) => {
            reasons.0.push((AmplitudeKey::Spec(*spec), e.reason));
            None
        }
    }
}

/// The outcome without a Hopf point: straight running only, every configured speed
/// without an amplitude for the same reason.
fn no_hopf_diagram(cfg: &DiagramConfig, n: &NoHopf) -> DiagramStudy {
    let hi = n.stable_up_to_mps.unwrap_or(n.searched_from_mps);
    let mut reasons = Keyed::default();
    for spec in cfg.stable_speeds_mps.iter().chain(&cfg.unstable_speeds_mps) {
        reasons
            .0
            .push((AmplitudeKey::Spec(*spec), n.reason.clone()));
    }
    let summary = DiagramSummary {
        hopf_v_mps: None,
        hopf_reason: Some(n.reason.clone()),
        stable_up_to_mps: n.stable_up_to_mps,
        divergence_v_mps: n.divergence_v_mps,
        fold_v_mps: None,
        fold_located_v_mps: None,
        fold_reason: Some(n.reason.clone()),
        fold_amplitude_deg: None,
        stable_amplitude_deg: Keyed::default(),
        unstable_amplitude_deg: Keyed::default(),
        amplitude_reasons: reasons,
        criticality: None,
        hopf_omega_rad_s: None,
        hopf_period_s: None,
        fold_period_s: None,
        stable_period_s: Keyed::default(),
        bistable_range_mps: None,
        cycle_points: 0,
        cycle_branch_end: None,
        searched_mps: [n.searched_from_mps, hi],
        diagram_range_mps: [n.searched_from_mps, hi],
        mesh: Mesh {
            intervals: cfg.options.intervals,
            degree: cfg.options.degree,
        },
    };
    DiagramStudy {
        summary,
        diagram: None,
    }
}

/// The time panels of fig3a: the panel config with its speed resolved, one run per θ(0)
/// (keyed [`panel_key`]).
pub type Panels = Runs<PanelsConfig, PanelRun>;

/// The outcome of fig3a: the diagram, the time panels or why there are none, and the panel
/// speed when it was given relative to the vehicle.
#[derive(Debug, Clone)]
pub struct Fig3a {
    /// the bifurcation diagram and its summary fields
    pub diagram: DiagramStudy,
    /// the time panels, or why there are none (no speed in the bistable range, or a
    /// vehicle with a model variant)
    pub panels: Result<Panels, String>,
    /// the panel speed, when given relative to the vehicle, and its value
    pub resolved_speeds: Vec<ResolvedSpeed>,
}

/// The whole computation of fig3a (`config` as read and checked before the panel speed is
/// resolved): the diagram of `vehicle` ([`diagram`], within `limits`), then the panel
/// speed resolved against the diagram's own V_crit and fold (so that one factor means the
/// same speed in both sections, and nothing more is computed), the resolved panels checked
/// (`file` names the config in the messages) and simulated side by side. A vehicle with a
/// model variant (`variant_key`, its first key) gets the diagram without time panels.
/// Progress: one step for the diagram, one for the panels.
///
/// # Errors
/// A config error of the resolved panels (naming the resolved speed), or numerical
/// failures with context.
pub fn compute(
    config: &Fig3aConfig,
    vehicle: &AnyVehicleModel,
    variant_key: Option<&str>,
    limits: &SpeedLimits,
    file: &Path,
    progress: &dyn Progress,
) -> Result<Fig3a, SwayError> {
    let diagram = diagram(vehicle, &config.diagram, limits)?;
    progress.advance(1);
    let s = &diagram.summary;
    let refs = SpeedReferences {
        v_crit_mps: s.hopf_v_mps,
        v_fold_mps: s.fold_v_mps,
        reason: s.hopf_reason.clone().or_else(|| s.fold_reason.clone()),
    };
    let resolution = resolve_against(&refs, &config.panels);
    let panels = match resolution.outcome {
        Ok(_) if variant_key.is_some() => Err(format!(
            "no time panels: the vehicle has a model variant ({}) and the time panels simulate the paper's model",
            variant_key.unwrap_or_default()
        )),
        Ok(panels) => {
            panels
                .validate(file, "panels")
                .map_err(|e| with_resolved_speeds(e, &resolution.speeds))?;
            Ok(run_panels(vehicle, panels)?)
        }
        Err(u) => Err(format!(
            "no time panels (no speed in the bistable range): {}",
            u.reason
        )),
    };
    progress.advance(1);
    Ok(Fig3a {
        diagram,
        panels,
        resolved_speeds: resolution.speeds,
    })
}

/// The panels' runs side by side, θ(0) from the config and every other state 0.
fn run_panels(vehicle: &AnyVehicleModel, cfg: PanelsConfig) -> Result<Panels, SwayError> {
    let spec = cfg.spec();
    let speed_mps = cfg.speed_mps;
    let recording = every(cfg.output_step_s.get());
    let runs = sway::parallel::try_map(&cfg.theta0_deg, Split::OnePerTask, &|_, &th| {
        let x0 = trailer_model::State7::from_column_slice(&[
            0.0,
            0.0,
            0.0,
            th.to_radians(),
            0.0,
            0.0,
            0.0,
        ]);
        let about = PanelRun {
            theta0_deg: th,
            speed_mps,
        };
        run(vehicle, x0, (panel_key(th), about, spec.clone()), recording)
    })?;
    Ok(Runs { config: cfg, runs })
}
