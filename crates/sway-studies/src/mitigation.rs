//! The mitigation study of `cargo xtask mitigation` as a library pipeline: its config
//! ([`MitigationConfig`], `configs/mitigation.toml`), the whole computation
//! ([`run_mitigation`]: the sway cycle, the N phase starts, the paper's four strategies, the
//! optimisation, the check at refinement × N phases) and its summary
//! ([`MitigationSummary`]). The task writes the files and draws the figures.
//!
//! Speeds (V0, the final-speed floor, the paper's ΔV) may be given relative to the vehicle
//! ([`sway::sim::speeds`]); a vehicle without sway at V0 (stable at every speed up to the
//! maximum, or V0 below where it sways) has nothing to mitigate: [`MitigationOutcome::NoSway`]
//! with the reason.

use std::path::Path;

use serde::{Deserialize, Serialize};

use sway::SwayError;
use sway::config::{Positive, ensure, ensure_positive};
use sway::mitigation::{
    DecisionBounds, Evaluation, Intervention, MitigationProblem, Optimum, PhaseStarts, Setting,
    SwayCycle, evaluate, find_sway_cycle, optimise, settled,
};
use sway::progress::Progress;
use sway::sim::speeds::{ResolveSpeeds, Resolver, SpeedValue, UnresolvedSpeed, check_change};
use sway::sim::{
    ActuatorLimits, Outcome, RampShape, Recording, RunSettings, SimulateOwn, SolverSettings,
    SwayStart,
};
use sway_model::optimise::OptimiserSettings;

/// The paper's strategies (Fig. 4c): braking ΔV over T (linear), steering gain D.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct PaperStrategies<S = f64> {
    /// ΔV \[m/s\] of "braking" and "combined" (a number or `{ of_v_crit = f }`)
    pub speed_change_mps: S,
    /// T \[s\]
    pub duration_s: f64,
    /// D \[s\] of "steering" and "combined"
    pub gain_s: f64,
}

fn default_search_solver() -> SolverSettings {
    SolverSettings {
        rtol: 1e-6,
        atol: 1e-8,
        ..SolverSettings::default()
    }
}
fn default_refinement() -> usize {
    4
}
fn default_true() -> bool {
    true
}

/// `configs/mitigation.toml`. `S`: the type of the speeds (see [`sway::sim::speeds`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct MitigationConfig<S = f64> {
    /// the sway-cycle start (V0, settling)
    pub start: SwayStart<S>,
    /// N: phases of the cycle where the intervention may start (runs per evaluation)
    pub phases: usize,
    /// place the N phases over half a period, the other half being their mirror images
    /// (same settle times; see [`PhaseStarts`]): spacing 1/(2N) instead of 1/N
    #[serde(default = "default_true")]
    pub mirror_symmetry: bool,
    /// the worst-case check runs the optimum at this many times N phases
    #[serde(default = "default_refinement")]
    pub refinement: usize,
    /// H: horizon after the intervention starts \[s\]
    pub horizon_s: Positive,
    /// τ: the hardware's feedback delay \[s\]
    pub delay_s: f64,
    /// the constraint on max |θ| after the intervention starts \[deg\]
    pub peak_limit_deg: Positive,
    /// the constraint V0 + ΔV ≥ this \[m/s\] (a bound on ΔV)
    pub min_final_speed_mps: S,
    /// sampling of the plotted θ(t) \[s\]
    pub output_step_s: Positive,
    /// ranges of the continuous decision variables
    pub bounds: DecisionBounds,
    /// steering actuator limits (e.g. `max_angle_deg`), fixed hardware
    #[serde(default)]
    pub actuator: ActuatorLimits,
    /// the paper's four strategies
    pub paper: PaperStrategies<S>,
    /// seed, starts, iterations
    #[serde(default)]
    pub optimiser: OptimiserSettings,
    /// the solver tolerances during the search (the results use `[solver]`)
    #[serde(default = "default_search_solver")]
    pub search_solver: SolverSettings,
    /// validity guard, tolerances, metric settings of every run
    #[serde(flatten)]
    pub settings: RunSettings,
}

/// How long after settling the period is looked for \[s\] (three upward zero crossings of θ).
pub const CYCLE_SEARCH_S: f64 = 20.0;

impl<S: SpeedValue> ResolveSpeeds for MitigationConfig<S> {
    type Resolved = MitigationConfig;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<MitigationConfig, UnresolvedSpeed> {
        Ok(MitigationConfig {
            start: self.start.resolve_speeds("start", r)?,
            phases: self.phases,
            mirror_symmetry: self.mirror_symmetry,
            refinement: self.refinement,
            horizon_s: self.horizon_s,
            delay_s: self.delay_s,
            peak_limit_deg: self.peak_limit_deg,
            min_final_speed_mps: self
                .min_final_speed_mps
                .resolve_speed("min_final_speed_mps", r)?,
            output_step_s: self.output_step_s,
            bounds: self.bounds,
            actuator: self.actuator,
            paper: PaperStrategies {
                speed_change_mps: self
                    .paper
                    .speed_change_mps
                    .resolve_change("paper.speed_change_mps", r)?,
                duration_s: self.paper.duration_s,
                gain_s: self.paper.gain_s,
            },
            optimiser: self.optimiser,
            search_solver: self.search_solver,
            settings: self.settings,
        })
    }
}

impl<S: SpeedValue> MitigationConfig<S> {
    /// Checks what can be checked before the speeds are resolved (the paper's ΔV is not
    /// `in_bistable`); a config whose speeds are all numbers is checked completely
    /// ([`MitigationConfig::validate`]).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate_spec(&self, file: &Path) -> Result<(), SwayError> {
        check_change(&self.paper.speed_change_mps, "paper.speed_change_mps")
            .map_err(|(k, p)| SwayError::config(file, k, p))?;
        match self.all_numbers() {
            Some(c) => c.validate(file),
            None => Ok(()),
        }
    }
}

impl MitigationConfig {
    /// V0 \[m/s\].
    pub fn speed(&self) -> f64 {
        self.start.speed_mps
    }

    /// The span of the phases: ½ with the mirror symmetry, else 1.
    pub fn span(&self) -> f64 {
        if self.mirror_symmetry { 0.5 } else { 1.0 }
    }

    /// The bounds with ΔV ≥ min_final_speed − V0.
    pub fn effective_bounds(&self) -> DecisionBounds {
        let mut b = self.bounds;
        let lo = self.min_final_speed_mps - self.speed();
        b.speed_change_mps.lo = b.speed_change_mps.lo.max(lo);
        b
    }

    /// The evaluation setting at the given solver tolerances.
    pub fn setting(&self, solver: SolverSettings) -> Setting {
        Setting {
            speed_mps: self.speed(),
            delay_s: self.delay_s,
            actuator: self.actuator,
            horizon_s: self.horizon_s.get(),
            peak_limit_deg: self.peak_limit_deg.get(),
            settings: RunSettings {
                solver,
                ..self.settings
            },
        }
    }

    /// The paper's strategies as interventions, keyed "none", "steering", "braking",
    /// "combined" (all from the intervention start, the controller never off).
    pub fn paper_strategies(&self) -> Vec<(&'static str, Intervention)> {
        let p = &self.paper;
        [
            ("none", false, false),
            ("steering", false, true),
            ("braking", true, false),
            ("combined", true, true),
        ]
        .into_iter()
        .map(|(k, brake, steer)| {
            (
                k,
                Intervention {
                    speed_change_mps: if brake { p.speed_change_mps } else { 0.0 },
                    duration_s: p.duration_s,
                    shape: RampShape::Linear,
                    gain_s: if steer { p.gain_s } else { 0.0 },
                    on_s: 0.0,
                    off_s: None,
                },
            )
        })
        .collect()
    }

    fn check_bounds(&self, file: &Path) -> Result<(), SwayError> {
        let b = &self.bounds;
        for (key, bd, lo_min, hi_max) in [
            (
                "bounds.speed_change_mps",
                b.speed_change_mps,
                f64::NEG_INFINITY,
                0.0,
            ),
            ("bounds.duration_s", b.duration_s, 1e-3, f64::INFINITY),
            ("bounds.gain_s", b.gain_s, 0.0, f64::INFINITY),
            ("bounds.on_s", b.on_s, 0.0, f64::INFINITY),
            ("bounds.on_duration_s", b.on_duration_s, 1e-3, f64::INFINITY),
        ] {
            ensure(
                bd.is_valid() && bd.lo >= lo_min && bd.hi <= hi_max,
                file,
                key,
                || format!("expected finite {lo_min} ≤ lo ≤ hi ≤ {hi_max}, got {bd:?}"),
            )?;
        }
        let e = self.effective_bounds().speed_change_mps;
        ensure(e.lo <= e.hi, file, "min_final_speed_mps", || {
            format!(
                "V0 + ΔV ≥ {} m/s leaves no braking range in bounds.speed_change_mps {:?} (V0 = {} m/s)",
                self.min_final_speed_mps,
                self.bounds.speed_change_mps,
                self.speed()
            )
        })
    }

    /// Checks every key (speeds resolved).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path) -> Result<(), SwayError> {
        self.start.validate(file, "start")?;
        ensure(self.phases >= 2, file, "phases", || {
            format!("expected at least 2 phases, got {}", self.phases)
        })?;
        ensure(self.refinement >= 1, file, "refinement", || {
            format!("expected a factor ≥ 1, got {}", self.refinement)
        })?;
        ensure(
            self.delay_s.is_finite() && self.delay_s >= 0.0,
            file,
            "delay_s",
            || format!("expected a delay ≥ 0 s, got {}", self.delay_s),
        )?;
        ensure_positive(
            self.min_final_speed_mps,
            file,
            "min_final_speed_mps",
            "a speed > 0 m/s",
        )?;
        ensure(
            self.output_step_s.get() <= self.horizon_s.get(),
            file,
            "output_step_s",
            || "expected output_step_s ≤ horizon_s".into(),
        )?;
        self.check_bounds(file)?;
        self.actuator
            .validate()
            .map_err(|(k, p)| SwayError::config(file, k, p))?;
        let p = &self.paper;
        ensure(
            p.speed_change_mps <= 0.0 && self.speed() + p.speed_change_mps > 0.0,
            file,
            "paper.speed_change_mps",
            || format!("expected −V0 < ΔV ≤ 0 m/s, got {}", p.speed_change_mps),
        )?;
        ensure(
            p.duration_s.is_finite() && p.duration_s > 0.0,
            file,
            "paper.duration_s",
            || format!("expected T > 0 s, got {}", p.duration_s),
        )?;
        ensure(p.gain_s.is_finite(), file, "paper.gain_s", || {
            format!("expected a finite gain, got {}", p.gain_s)
        })?;
        self.optimiser
            .validate()
            .map_err(|(k, p)| SwayError::config(file, format!("optimiser.{k}"), p))?;
        self.search_solver.validate_at(file, "search_solver")?;
        self.settings.solver.validate_at(file, "solver")
    }
}

/// Everything the study computes, for a plant with M reduced states (4: the paper's model).
#[derive(Debug, Clone)]
pub struct MitigationResult<const M: usize = 4> {
    /// the cycle
    pub cycle: SwayCycle<M>,
    /// the N phase starts
    pub starts: PhaseStarts<M>,
    /// the optimiser's result
    pub optimum: Optimum,
    /// the optimum at `[solver]`
    pub optimum_eval: Evaluation,
    /// the optimum at the search tolerance
    pub optimum_search_eval: Evaluation,
    /// the paper's strategies at `[solver]`
    pub strategies: Vec<(&'static str, Intervention, Evaluation)>,
    /// the optimum at refinement × N phases
    pub refined: (PhaseStarts<M>, Evaluation),
}

/// The study's result, or why there is nothing to mitigate.
#[derive(Debug, Clone)]
pub enum MitigationOutcome<const M: usize = 4> {
    /// the study
    Mitigated(Box<MitigationResult<M>>),
    /// no sway at V0: nothing to mitigate
    NoSway {
        /// why (the amplitude or crossings of θ after settling)
        reason: String,
    },
}

/// The whole computation (3 progress steps: strategies, optimisation, check).
///
/// # Errors
/// [`SwayError::Numerical`] if a solver or the optimiser fails.
pub fn run_mitigation<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    cfg: &MitigationConfig,
    progress: &dyn Progress,
) -> Result<MitigationOutcome<M>, SwayError> {
    let solver = cfg.settings.solver;
    let s = &cfg.start;
    let cycle = match find_sway_cycle(
        model,
        s.speed_mps,
        s.theta0_rad,
        s.settle_s.get(),
        CYCLE_SEARCH_S,
        &solver,
    )? {
        Ok(c) => c,
        Err(reason) => return Ok(MitigationOutcome::NoSway { reason }),
    };
    let threshold = cfg.settings.metrics.settle_threshold_deg.get();
    if cycle.amplitude_deg < threshold {
        return Ok(MitigationOutcome::NoSway {
            reason: format!(
                "no sway to mitigate at V0 = {} m/s: after settling for {} s the oscillation has max |θ| = {:.3e}° < {threshold}° (the settle threshold); straight running is stable there",
                s.speed_mps,
                s.settle_s.get(),
                cycle.amplitude_deg
            ),
        });
    }
    let lead = cfg.delay_s;
    let starts = PhaseStarts::new(model, &cycle, cfg.phases, cfg.span(), lead, &solver)?;
    let setting = cfg.setting(solver);
    let strategies = cfg
        .paper_strategies()
        .into_iter()
        .map(|(k, iv)| evaluate(model, &setting, &starts, &iv).map(|e| (k, iv, e)))
        .collect::<Result<Vec<_>, _>>()?;
    progress.advance(1);
    let problem = MitigationProblem {
        model,
        setting: cfg.setting(cfg.search_solver),
        starts: &starts,
        bounds: cfg.effective_bounds().to_array(),
    };
    let combined = strategies[3].1;
    let optimum = optimise(&problem, &[combined], &cfg.optimiser)?;
    progress.advance(1);
    let optimum_search_eval = evaluate(model, &problem.setting, &starts, &optimum.intervention)?;
    let optimum_eval = evaluate(model, &setting, &starts, &optimum.intervention)?;
    let fine = PhaseStarts::new(
        model,
        &cycle,
        cfg.phases * cfg.refinement,
        cfg.span(),
        lead,
        &solver,
    )?;
    let fine_eval = evaluate(model, &setting, &fine, &optimum.intervention)?;
    progress.advance(1);
    Ok(MitigationOutcome::Mitigated(Box::new(MitigationResult {
        cycle,
        starts,
        optimum,
        optimum_eval,
        optimum_search_eval,
        strategies,
        refined: (fine, fine_eval),
    })))
}

/// The bound on how much the worst case can grow between the N-grid's phases.
///
/// Between two grid phases the settle time s(φ) moves continuously (by a measured ≤ 0.1 s
/// per 1/32 cycle at the default optimum) except where a local maximum of |θ| passes
/// through the 1° threshold: there the last falling 1° crossing moves to the neighbouring
/// half-oscillation and s jumps by the time between two successive maxima of |θ|, half a
/// period of the decaying oscillation (measured 0.48–0.66 s). The bound is one such jump,
/// taken as half the period of the sway cycle at V0 (the decaying oscillation under
/// feedback is faster than the free sway cycle), plus the largest change of s between
/// neighbouring grid phases; None if a grid phase did not settle.
pub fn refinement_bound(e: &Evaluation, setting: &Setting, period_s: f64) -> Option<f64> {
    let s: Option<Vec<f64>> = e.phases.iter().map(|m| settled(m, setting)).collect();
    let s = s?;
    let n = s.len();
    let smooth = (0..n.saturating_sub(1))
        .map(|k| (s[k + 1] - s[k]).abs())
        .fold(0.0, f64::max);
    Some(0.5 * period_s + smooth)
}

/// θ(t) \[deg\] of `iv` from phase `k`, sampled every `cfg.output_step_s`, t from the
/// intervention start.
///
/// # Errors
/// [`SwayError::Numerical`] if the solver fails.
pub fn theta_at_phase<P: SimulateOwn<M>, const M: usize>(
    model: &P,
    cfg: &MitigationConfig,
    starts: &PhaseStarts<M>,
    iv: &Intervention,
    k: usize,
) -> Result<Vec<(f64, f64)>, SwayError> {
    let setting = cfg.setting(cfg.settings.solver);
    let step = cfg.output_step_s.get();
    let r = setting.run(
        model,
        iv,
        starts.states[k],
        starts.lead_in_s,
        Recording::Every { step_s: step },
    )?;
    Ok(r.trajectory
        .iter()
        .map(|s| (s.t - starts.lead_in_s, s.x[3].to_degrees()))
        .collect())
}

/// One strategy (or the optimum) evaluated over the phases, as in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StrategyEntry {
    /// worst case over the phases of the settle time \[s\] (null: some phase never settles
    /// within the horizon or loses control)
    pub worst_case_settle_time_s: Option<f64>,
    /// worst case of max |θ| after the intervention starts \[deg\]
    pub worst_case_peak_deg: f64,
    /// the phase φ ∈ \[0, 1) of the worst case (largest penalised cost)
    pub worst_phase: f64,
    /// the phases φ that lose control
    pub lost_control_phases: Vec<f64>,
    /// the phases φ that do not settle within the horizon (without losing control)
    pub unsettled_phases: Vec<f64>,
    /// every constraint holds at every phase
    pub feasible: bool,
    /// the penalised worst-case cost (the objective; ≤ H when feasible)
    pub cost: f64,
}

impl StrategyEntry {
    fn new(e: &Evaluation, phases: &[f64], setting: &Setting) -> Self {
        let at = |ks: Vec<usize>| ks.into_iter().map(|k| phases[k]).collect();
        let unsettled = (0..e.phases.len())
            .filter(|&k| {
                e.phases[k].outcome == Outcome::Ok && settled(&e.phases[k], setting).is_none()
            })
            .collect();
        Self {
            worst_case_settle_time_s: e.worst_settle_time_s,
            worst_case_peak_deg: e.worst_peak_deg,
            worst_phase: phases[e.worst_phase],
            lost_control_phases: at(e.lost_phases.clone()),
            unsettled_phases: at(unsettled),
            feasible: e.feasible,
            cost: e.cost,
        }
    }
}

/// `"optimum"` of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OptimumEntry {
    /// the decision variables (times from the intervention start; `off_s` null: never off)
    pub intervention: Intervention,
    /// τ \[s\] the gain is designed for
    pub delay_s: f64,
    /// the steering-angle limit δ_max \[deg\] (null: none)
    pub max_angle_deg: Option<f64>,
    /// worst case over the phases at `[solver]` \[s\]
    pub worst_case_settle_time_s: Option<f64>,
    /// worst-case peak |θ| \[deg\]
    pub worst_case_peak_deg: f64,
    /// the worst phase φ
    pub worst_phase: f64,
    /// feasible at every phase
    pub feasible: bool,
    /// the worst case as the search saw it (at `search_solver`) \[s\]
    pub search_worst_case_settle_time_s: Option<f64>,
    /// the phases φ that lose control (empty when feasible)
    pub lost_control_phases: Vec<f64>,
    /// objective evaluations of the search (each: N simulations)
    pub evaluations: usize,
}

/// `"phase_refinement"`: the optimum at refinement × N phases.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RefinementEntry {
    /// the number of phases
    pub phases: usize,
    /// the worst case there \[s\]
    pub worst_case_settle_time_s: Option<f64>,
    /// its increase over the N-phase worst case \[s\]
    pub change_s: Option<f64>,
    /// the bound on that increase: one jump of the settle time (half the sway period) plus
    /// the largest change between neighbouring phases of the N-grid (see
    /// [`refinement_bound`]) \[s\]
    pub bound_s: Option<f64>,
    /// change ≤ bound
    pub within_bound: Option<bool>,
}

/// The study's headline (`summary.json` of the task, before its common fields): the
/// optimum, the paper's strategies keyed "none", "steering", "braking", "combined", the
/// phase-robust ranking, the check at more phases, the cycle.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MitigationSummary {
    /// the optimal intervention
    pub optimum: OptimumEntry,
    /// the paper's strategies, keyed "none", "steering", "braking", "combined", in that order
    /// (a JSON object)
    #[serde(serialize_with = "as_map")]
    pub strategies: Vec<(String, StrategyEntry)>,
    /// the phase-robust ranking: "optimum" and the strategies by worst-case cost, best first
    pub ranking: Vec<String>,
    /// the worst-case check at more phases
    pub phase_refinement: RefinementEntry,
    /// the sway cycle the interventions start from
    pub cycle: SwayCycle,
    /// N
    pub phases: usize,
    /// the phases span \[0, phase_span) of the period (½: mirror symmetry)
    pub phase_span: f64,
}

fn refinement_entry<const M: usize>(r: &MitigationResult<M>, setting: &Setting) -> RefinementEntry {
    let coarse = r.optimum_eval.worst_settle_time_s;
    let fine = r.refined.1.worst_settle_time_s;
    let change = coarse.zip(fine).map(|(c, f)| f - c);
    let bound_s = refinement_bound(&r.optimum_eval, setting, r.cycle.period_s);
    RefinementEntry {
        phases: r.refined.0.phases.len(),
        worst_case_settle_time_s: fine,
        change_s: change,
        bound_s,
        within_bound: change.zip(bound_s).map(|(c, b)| c.abs() <= b),
    }
}

/// The summary of a study.
pub fn summary<const M: usize>(
    r: &MitigationResult<M>,
    cfg: &MitigationConfig,
) -> MitigationSummary {
    let setting = cfg.setting(cfg.settings.solver);
    let phases = &r.starts.phases;
    let o = &r.optimum_eval;
    let optimum = OptimumEntry {
        intervention: r.optimum.intervention,
        delay_s: cfg.delay_s,
        max_angle_deg: cfg.actuator.max_angle_deg,
        worst_case_settle_time_s: o.worst_settle_time_s,
        worst_case_peak_deg: o.worst_peak_deg,
        worst_phase: phases[o.worst_phase],
        feasible: o.feasible,
        search_worst_case_settle_time_s: r.optimum_search_eval.worst_settle_time_s,
        lost_control_phases: o.lost_phases.iter().map(|&k| phases[k]).collect(),
        evaluations: r.optimum.minimum.evaluations,
    };
    let strategies = r
        .strategies
        .iter()
        .map(|(k, _, e)| (k.to_string(), StrategyEntry::new(e, phases, &setting)))
        .collect();
    let mut ranked: Vec<(String, f64)> = vec![("optimum".into(), o.cost)];
    ranked.extend(r.strategies.iter().map(|(k, _, e)| (k.to_string(), e.cost)));
    ranked.sort_by(|a, b| a.1.total_cmp(&b.1));
    MitigationSummary {
        optimum,
        strategies,
        ranking: ranked.into_iter().map(|(k, _)| k).collect(),
        phase_refinement: refinement_entry(r, &setting),
        cycle: r.cycle.paper_form(),
        phases: cfg.phases,
        phase_span: cfg.span(),
    }
}

/// Serialises pairs as a JSON object in their order.
fn as_map<T: Serialize, Ser: serde::Serializer>(
    pairs: &[(String, T)],
    s: Ser,
) -> Result<Ser::Ok, Ser::Error> {
    use serde::ser::SerializeMap;
    let mut m = s.serialize_map(Some(pairs.len()))?;
    for (k, v) in pairs {
        m.serialize_entry(k, v)?;
    }
    m.end()
}
