//! `cargo xtask mitigation` (issue 10, beyond the paper): the braking-and-steering
//! intervention that ends trailer sway fastest from **any** phase of the sway cycle, next
//! to the paper's four strategies of Fig. 4(c) evaluated the same way.
//!
//! From the sway cycle at V0 (35 m/s), the intervention starts at N phases of the cycle
//! (16); the objective is the worst case over the phases of the settle time (until |θ| stays
//! below 1°), the constraints (no loss of control, peak |θ| ≤ 45°, final speed ≥ 25 m/s,
//! |δ| ≤ δ_max) are an exact penalty (see [`sway::mitigation`]). The optimiser searches at a
//! looser solver tolerance (`search_solver`); the optimum and the strategies are evaluated
//! at `[solver]`, and the optimum once more at `refinement` × N phases. With
//! `mirror_symmetry` (default) the N phases span half a period, the other half being their
//! mirror images (see [`PhaseStarts`]): φ ∈ \[0, ½) in the results stands for φ + ½ too.
//!
//! `summary.json`: `"optimum"` (`intervention` — the decision variables —,
//! `worst_case_settle_time_s`, `worst_case_peak_deg`, …), `"strategies"` (`"none"`,
//! `"steering"`, `"braking"`, `"combined"`: `worst_case_settle_time_s`,
//! `lost_control_phases`, …), `"ranking"` (best first), `"phase_refinement"` (the
//! worst case at refinement × N phases against its bound), `"cycle"`.

use std::path::Path;

use serde::{Deserialize, Serialize};
use crate::TaskError;
use sway::config::{Positive, ensure};
use sway::mitigation::optimise::OptimiserSettings;
use sway::mitigation::{
    DecisionBounds, Evaluation, Intervention, MitigationProblem, PhaseStarts, Setting, SwayCycle,
    evaluate, optimise, settled, sway_cycle,
};
use sway::sim::{ActuatorLimits, RampShape, Recording, RunSettings, SolverSettings};
use trailer_model::Model;

use super::fig3b::SwayStart;
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::{Configured, TaskConfig};
use crate::io::{Keyed, OutputDir};
use crate::limits::{Plan, bound, human_seconds};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Shape, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<MitigationConfig>(
    "mitigation",
    "optimal braking + steering from any phase of the sway (worst case over phase) vs the paper's strategies",
    "mitigation.toml",
);

/// The paper's strategies (Fig. 4c): braking ΔV over T (linear), steering gain D.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperStrategies {
    /// ΔV \[m/s\] of "braking" and "combined"
    pub speed_change_mps: f64,
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

/// `configs/mitigation.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MitigationConfig {
    /// the sway-cycle start (V0, settling)
    pub start: SwayStart,
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
    pub min_final_speed_mps: Positive,
    /// sampling of the plotted θ(t) \[s\]
    pub output_step_s: Positive,
    /// ranges of the continuous decision variables
    pub bounds: DecisionBounds,
    /// steering actuator limits (e.g. `max_angle_deg`), fixed hardware
    #[serde(default)]
    pub actuator: ActuatorLimits,
    /// the paper's four strategies
    pub paper: PaperStrategies,
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

/// mitigation: the most phases N (default 16).
pub const MAX_PHASES: usize = 4096;
/// mitigation: the largest refinement factor (default 4).
pub const MAX_REFINEMENT: usize = 64;
/// mitigation: the most Nelder–Mead iterations per run (default 60).
pub const MAX_ITERS: u64 = 100_000;
/// mitigation: the most random starts (default 2).
pub const MAX_STARTS: usize = 1000;
/// mitigation: cost of one simulated second of a phase run \[s\] on 2 cores, release: the
/// `mitigation` bench (one evaluation, 16 runs × 40.2 s: median 8.4 ms at the search
/// tolerance rtol 1e-6, 13.7 ms at rtol 1e-8, i.e. 1.3e-5 and 2.1e-5 s per simulated
/// second) rounded to the larger. The plan assumes 2 evaluations per iteration (measured
/// ≈ 1.5), so it is an upper bound (default config: ≈ 40 s planned, 19 s measured).
pub const SECONDS_PER_SIM_SECOND: f64 = 2e-5;

impl MitigationConfig {
    /// V0 \[m/s\].
    pub fn speed(&self) -> f64 {
        self.start.speed_mps.get()
    }

    /// The span of the phases: ½ with the mirror symmetry, else 1.
    pub fn span(&self) -> f64 {
        if self.mirror_symmetry { 0.5 } else { 1.0 }
    }

    /// The bounds with ΔV ≥ min_final_speed − V0.
    pub fn effective_bounds(&self) -> DecisionBounds {
        let mut b = self.bounds;
        let lo = self.min_final_speed_mps.get() - self.speed();
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

    fn check_bounds(&self, file: &Path) -> Result<(), TaskError> {
        let b = &self.bounds;
        for (key, bd, lo_min, hi_max) in [
            ("bounds.speed_change_mps", b.speed_change_mps, f64::NEG_INFINITY, 0.0),
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
        Ok(ensure(e.lo <= e.hi, file, "min_final_speed_mps", || {
            format!(
                "V0 + ΔV ≥ {} m/s leaves no braking range in bounds.speed_change_mps {:?}",
                self.min_final_speed_mps.get(),
                self.bounds.speed_change_mps
            )
        })?)
    }
}

impl TaskConfig for MitigationConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
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
        ensure(
            self.output_step_s.get() <= self.horizon_s.get(),
            file,
            "output_step_s",
            || "expected output_step_s ≤ horizon_s".into(),
        )?;
        self.check_bounds(file)?;
        self.actuator
            .validate()
            .map_err(|(k, p)| TaskError::config(file, k, p))?;
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
            .map_err(|(k, p)| TaskError::config(file, format!("optimiser.{k}"), p))?;
        self.search_solver.validate_at(file, "search_solver")?;
        Ok(self.settings.solver.validate_at(file, "solver")?)
    }
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
                e.phases[k].outcome == sway::sim::Outcome::Ok
                    && settled(&e.phases[k], setting).is_none()
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

/// `summary.json` of mitigation (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MitigationSummary {
    /// the optimal intervention
    pub optimum: OptimumEntry,
    /// the paper's strategies, keyed "none", "steering", "braking", "combined"
    pub strategies: Keyed<StrategyEntry>,
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

/// One row of `phases.csv`: one strategy at one phase.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct PhaseRow {
    /// "optimum" or the paper strategy's key
    pub strategy: String,
    /// φ ∈ \[0, 1)
    pub phase: f64,
    /// settle time from the intervention start \[s\] (empty: not settled)
    pub settle_time_s: Option<f64>,
    /// max |θ| after the intervention starts \[deg\]
    pub peak_theta_deg: Option<f64>,
    /// "ok" or "loss_of_control"
    pub outcome: String,
    /// the penalised cost \[s\]
    pub cost: f64,
}

/// One row of `search.csv`: one Nelder–Mead run.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct SearchRow {
    /// ramp shape
    pub shape: String,
    /// start index (0: the paper's combined strategy, then the seeded random ones)
    pub start: usize,
    /// the run's best worst-case cost at the search tolerance \[s\]
    pub cost: f64,
    /// ΔV \[m/s\]
    pub speed_change_mps: f64,
    /// T \[s\]
    pub duration_s: f64,
    /// D \[s\]
    pub gain_s: f64,
    /// t_on \[s\]
    pub on_s: f64,
    /// t_off − t_on \[s\]
    pub on_duration_s: f64,
    /// objective evaluations
    pub evaluations: usize,
}

/// One row of `theta_worst.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ThetaRow {
    /// time from the intervention start \[s\]
    pub t_s: f64,
    /// θ of the optimum at its worst phase \[deg\]
    pub theta_optimum_deg: f64,
    /// θ of the paper's combined strategy at its worst phase \[deg\]
    pub theta_combined_deg: f64,
}

/// Everything the task computes (no I/O).
#[derive(Debug, Clone)]
pub struct MitigationResult {
    /// the cycle
    pub cycle: SwayCycle,
    /// the N phase starts
    pub starts: PhaseStarts,
    /// the optimiser's result
    pub optimum: sway::mitigation::Optimum,
    /// the optimum at `[solver]`
    pub optimum_eval: Evaluation,
    /// the optimum at the search tolerance
    pub optimum_search_eval: Evaluation,
    /// the paper's strategies at `[solver]`
    pub strategies: Vec<(&'static str, Intervention, Evaluation)>,
    /// the optimum at refinement × N phases
    pub refined: (PhaseStarts, Evaluation),
}

/// The whole computation.
///
/// # Errors
/// [`sway::SwayError::Numerical`] if a solver or the optimiser fails.
pub fn compute(
    model: &Model,
    cfg: &MitigationConfig,
    progress: &dyn sway::progress::Progress,
) -> Result<MitigationResult, TaskError> {
    let solver = cfg.settings.solver;
    let s = &cfg.start;
    let cycle = sway_cycle(
        model,
        s.speed_mps.get(),
        s.theta0_rad,
        s.settle_s.get(),
        CYCLE_SEARCH_S,
        &solver,
    )?;
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
    Ok(MitigationResult {
        cycle,
        starts,
        optimum,
        optimum_eval,
        optimum_search_eval,
        strategies,
        refined: (fine, fine_eval),
    })
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

fn refinement_entry(r: &MitigationResult, setting: &Setting) -> RefinementEntry {
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

fn summary(r: &MitigationResult, cfg: &MitigationConfig) -> MitigationSummary {
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
    let strategies: Keyed<StrategyEntry> = r
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
        cycle: r.cycle,
        phases: cfg.phases,
        phase_span: cfg.span(),
    }
}

fn phase_rows(r: &MitigationResult, setting: &Setting) -> Vec<PhaseRow> {
    let mut all: Vec<(&str, &Evaluation)> = vec![("optimum", &r.optimum_eval)];
    all.extend(r.strategies.iter().map(|(k, _, e)| (*k, e)));
    all.into_iter()
        .flat_map(|(k, e)| {
            e.phases.iter().enumerate().map(move |(i, m)| PhaseRow {
                strategy: k.to_string(),
                phase: r.starts.phases[i],
                settle_time_s: settled(m, setting),
                peak_theta_deg: m.peak_theta_deg_after_action,
                outcome: m.outcome.as_str().to_string(),
                cost: e.costs[i],
            })
        })
        .collect()
}

fn search_rows(r: &MitigationResult) -> Vec<SearchRow> {
    r.optimum
        .minimum
        .runs
        .iter()
        .map(|run| SearchRow {
            shape: RampShape::ALL[run.choice].as_str().to_string(),
            start: run.start,
            cost: run.cost,
            speed_change_mps: run.x[0],
            duration_s: run.x[1],
            gain_s: run.x[2],
            on_s: run.x[3],
            on_duration_s: run.x[4],
            evaluations: run.evaluations,
        })
        .collect()
}

/// θ(t) \[deg\] of `iv` from phase `k`, t from the intervention start.
fn theta_at_phase(
    model: &Model,
    cfg: &MitigationConfig,
    starts: &PhaseStarts,
    iv: &Intervention,
    k: usize,
) -> Result<Vec<(f64, f64)>, TaskError> {
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

const STRATEGY_COLORS: [Rgb; 4] = [Rgb::RED, Rgb::BLUE, Rgb::ORANGE, Rgb::GREEN];

fn settle_panel(r: &MitigationResult, cfg: &MitigationConfig) -> Panel {
    let setting = cfg.setting(cfg.settings.solver);
    let h = cfg.horizon_s.get();
    let phases = &r.starts.phases;
    let mut p = Panel::new(
        &format!(
            "Settle time vs the phase where the intervention starts (V0 = {} m/s, period {:.2} s)",
            cfg.speed(),
            r.cycle.period_s
        ),
        if cfg.mirror_symmetry {
            "phase φ of the sway cycle at the intervention start [cycles] (φ + ½: the mirror image, same settle time)"
        } else {
            "phase φ of the sway cycle at the intervention start [cycles]"
        },
        "settle time (|θ| < 1° to the end) [s]",
    )
    .x_range(0.0, cfg.span())
    .y_range(0.0, h + 2.0)
    .legend(Legend::LowerRight);
    let mut series: Vec<(String, &Evaluation, Rgb)> = r
        .strategies
        .iter()
        .zip(STRATEGY_COLORS)
        .map(|((k, _, e), c)| (format!("paper: {k}"), e, c))
        .collect();
    series.push(("optimum".into(), &r.optimum_eval, Rgb::BLACK));
    for (label, e, color) in &series {
        let pts: Vec<(f64, f64)> = (0..phases.len())
            .map(|k| (phases[k], settled(&e.phases[k], &setting).unwrap_or(f64::NAN)))
            .collect();
        let any = pts.iter().any(|q| q.1.is_finite());
        if any {
            p = p.with(Layer::line(pts.clone(), *color, Stroke::Solid, Some(label)));
            p = p.with(Layer::markers(pts, *color, None));
        }
        let (mut unsettled, mut lost) = (Vec::new(), Vec::new());
        for k in 0..phases.len() {
            match (e.phases[k].outcome, settled(&e.phases[k], &setting)) {
                (sway::sim::Outcome::LossOfControl, _) => lost.push((phases[k], h + 1.0)),
                (_, None) => unsettled.push((phases[k], h)),
                _ => {}
            }
        }
        let unsettled_label = format!("{label}: not settled within {h} s");
        let lost_label = format!("{label}: loss of control");
        for (pts, shape, text) in [
            (unsettled, Shape::Circle, unsettled_label),
            (lost, Shape::Cross, lost_label),
        ] {
            if !pts.is_empty() {
                p = p.with(Layer::Markers {
                    points: pts,
                    color: *color,
                    shape,
                    size: 7,
                    label: Some(text),
                });
            }
        }
    }
    p
}

fn theta_panel(
    optimum: &[(f64, f64)],
    combined: &[(f64, f64)],
    r: &MitigationResult,
    cfg: &MitigationConfig,
) -> Panel {
    let iv = &r.optimum.intervention;
    let phases = &r.starts.phases;
    let lim = optimum
        .iter()
        .chain(combined)
        .map(|q| q.1.abs())
        .fold(5.0, f64::max)
        * 1.1;
    let combined_phase = phases[r.strategies[3].2.worst_phase];
    Panel::new(
        &format!(
            "θ(t) at the worst phase: optimum (ΔV = {:.2} m/s over {:.2} s, {}, D = {:.3} s) vs the paper's combined strategy",
            iv.speed_change_mps,
            iv.duration_s,
            iv.shape.as_str(),
            iv.gain_s
        ),
        "time from the intervention start [s]",
        "hitch angle θ [deg]",
    )
    .x_range(-cfg.delay_s, cfg.horizon_s.get())
    .y_range(-lim, lim)
    .with(Layer::line(
        combined.to_vec(),
        Rgb::GREEN,
        Stroke::Solid,
        Some(&format!("paper combined, φ = {combined_phase:.4}")),
    ))
    .with(Layer::line(
        optimum.to_vec(),
        Rgb::BLACK,
        Stroke::Solid,
        Some(&format!(
            "optimum, φ = {:.4}",
            phases[r.optimum_eval.worst_phase]
        )),
    ))
}

fn write_figures(
    out: &OutputDir,
    model: &Model,
    r: &MitigationResult,
    cfg: &MitigationConfig,
) -> Result<(), TaskError> {
    let opt = theta_at_phase(
        model,
        cfg,
        &r.starts,
        &r.optimum.intervention,
        r.optimum_eval.worst_phase,
    )?;
    let (_, comb_iv, comb_e) = &r.strategies[3];
    let comb = theta_at_phase(model, cfg, &r.starts, comb_iv, comb_e.worst_phase)?;
    let rows = opt.iter().zip(&comb).map(|(a, b)| ThetaRow {
        t_s: a.0,
        theta_optimum_deg: a.1,
        theta_combined_deg: b.1,
    });
    out.write_table("theta_worst.csv", rows)?;
    Figure::single(theta_panel(&opt, &comb, r, cfg)).render(&out.path("theta_worst"))?;
    Figure::single(settle_panel(r, cfg)).render(&out.path("settle_vs_phase"))
}

fn headline(s: &MitigationSummary) -> Vec<String> {
    let fmt = |v: Option<f64>| v.map_or("never (within the horizon)".into(), |v| format!("{v:.2} s"));
    let iv = &s.optimum.intervention;
    let mut lines = vec![format!(
        "optimum: ΔV = {:.2} m/s over T = {:.2} s ({}), D = {:.3} s on at {:.2} s{}; worst-case settle time {}, peak {:.1}°",
        iv.speed_change_mps,
        iv.duration_s,
        iv.shape.as_str(),
        iv.gain_s,
        iv.on_s,
        iv.off_s.map_or(String::new(), |t| format!(", off at {t:.2} s")),
        fmt(s.optimum.worst_case_settle_time_s),
        s.optimum.worst_case_peak_deg
    )];
    for (k, e) in &s.strategies.0 {
        lines.push(format!(
            "paper {k}: worst-case settle time {}, loss of control at {} of {} phases",
            fmt(e.worst_case_settle_time_s),
            e.lost_control_phases.len(),
            s.phases
        ));
    }
    lines.push(format!("ranking (worst case over phase): {}", s.ranking.join(" < ")));
    let r = &s.phase_refinement;
    lines.push(format!(
        "optimum at {} phases: worst case {} (change {}, bound {})",
        r.phases,
        fmt(r.worst_case_settle_time_s),
        r.change_s.map_or("–".into(), |c| format!("{c:.3} s")),
        r.bound_s.map_or("–".into(), |b| format!("{b:.3} s")),
    ));
    lines
}

impl Prepared for Configured<MitigationConfig> {
    fn plan(&self) -> Result<Plan, TaskError> {
        let c = &self.config;
        let file = self.file.as_path();
        bound(file, "phases", c.phases as f64, MAX_PHASES as f64, || {
            "one simulation per phase and objective evaluation".into()
        })?;
        bound(file, "refinement", c.refinement as f64, MAX_REFINEMENT as f64, || {
            "refinement × phases simulations for the worst-case check".into()
        })?;
        bound(
            file,
            "optimiser.max_iters",
            c.optimiser.max_iters as f64,
            MAX_ITERS as f64,
            || "Nelder–Mead iterations per run".into(),
        )?;
        bound(
            file,
            "optimiser.random_starts",
            c.optimiser.random_starts as f64,
            MAX_STARTS as f64,
            || "Nelder–Mead runs per ramp shape".into(),
        )?;
        let runs = (RampShape::ALL.len() * (1 + c.optimiser.random_starts)) as f64;
        // at most 2 evaluations per iteration (reflection + expansion/contraction) plus the
        // initial simplex; shrinks are rare
        let evaluations = runs * (2.0 * c.optimiser.max_iters as f64 + 6.0) + 6.0;
        let n = c.phases as f64;
        let sims = evaluations * n + n * c.refinement as f64;
        let sim_s = c.horizon_s.get() + c.delay_s;
        let time = sims * sim_s * SECONDS_PER_SIM_SECOND + c.start.settle_s.get() * 1e-4;
        let plan = Plan::new(
            vec![
                format!(
                    "mitigation: {} Nelder–Mead runs (3 ramp shapes × {} starts) of ≤ {} iterations, each evaluation {} phases × {} s",
                    runs,
                    1 + c.optimiser.random_starts,
                    c.optimiser.max_iters,
                    c.phases,
                    sim_s
                ),
                format!(
                    "the paper's 4 strategies at {} phases, the optimum at {} phases",
                    c.phases,
                    c.phases * c.refinement
                ),
                format!("upper bound on the time: {}", human_seconds(time)),
            ],
            1e6 + n * 1e3,
            time,
        );
        plan.within(
            file,
            "phases",
            sims,
            crate::limits::MAX_SIMULATIONS,
            || "simulations in all".into(),
        )
    }

    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let out = OutputDir::create(&ctx.results_dir, TASK.name)?;
        ctx.progress
            .start("mitigation: strategies, optimisation, check", 3);
        let r = compute(&ctx.model, cfg, ctx.progress)?;
        let setting = cfg.setting(cfg.settings.solver);
        out.write_table("phases.csv", phase_rows(&r, &setting))?;
        out.write_table("search.csv", search_rows(&r))?;
        write_figures(&out, &ctx.model, &r, cfg)?;
        let s = summary(&r, cfg);
        let lines = headline(&s);
        ctx.conclude(out, s, cfg, &self.file, lines)
    }
}


#[cfg(test)]
mod tests {
    use super::*;
    use crate::config_file::parse_toml;
    use std::path::PathBuf;
    use trailer_model::VehicleParams;

    fn shipped() -> (PathBuf, String) {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/mitigation.toml");
        let text = std::fs::read_to_string(&file).expect("shipped config");
        (file, text)
    }

    fn config() -> (PathBuf, MitigationConfig) {
        let (file, text) = shipped();
        let cfg: MitigationConfig = parse_toml(&text, &file).unwrap();
        cfg.check(&file).unwrap();
        (file, cfg)
    }

    #[test]
    fn shipped_config_is_valid_and_as_the_issue_asks() {
        let (_, cfg) = config();
        assert_eq!((cfg.speed(), cfg.phases, cfg.refinement), (35.0, 16, 4));
        assert_eq!((cfg.horizon_s.get(), cfg.delay_s), (40.0, 0.2));
        assert_eq!(cfg.peak_limit_deg.get(), 45.0);
        assert_eq!(cfg.effective_bounds().speed_change_mps.lo, -10.0);
        assert_eq!(cfg.actuator, ActuatorLimits::NONE);
    }

    #[test]
    fn bad_values_name_their_key() {
        let (file, text) = shipped();
        for (from, to, key) in [
            ("phases = 16", "phases = 1", "phases"),
            ("gain_s = { lo = 0.0, hi = 0.5 }", "gain_s = { lo = 0.6, hi = 0.5 }", "bounds.gain_s"),
            ("# max_angle_deg = 2.0", "max_angle_deg = -2.0", "actuator.max_angle_deg"),
            ("max_iters = 100", "max_iters = 0", "optimiser.max_iters"),
            ("min_final_speed_mps = 25.0", "min_final_speed_mps = 36.0", "min_final_speed_mps"),
        ] {
            assert!(text.contains(from), "{from}");
            let cfg: MitigationConfig = parse_toml(&text.replace(from, to), &file).unwrap();
            let e = cfg.check(&file).unwrap_err().to_string();
            assert!(e.contains(&format!("`{key}`")), "{key}: {e}");
        }
        let unknown = text.replace("[paper]", "[paper]\nfoo = 1");
        let e = parse_toml::<MitigationConfig>(&unknown, &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("foo"), "{e}");
    }

    /// The committed optimum (results/mitigation/summary.json).
    fn committed() -> serde_json::Value {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../results/mitigation/summary.json");
        serde_json::from_str(&std::fs::read_to_string(file).expect("committed summary")).unwrap()
    }

    #[test]
    fn the_worst_case_over_phase_is_a_true_worst_case() {
        // reference: the committed optimum evaluated at N = 16 and 4N = 64 phases (the
        // N-grid is a subset of the 4N-grid, so the change is ≥ 0). Bound (see
        // `refinement_bound`): one jump of the settle time, half the sway period, plus the
        // largest change between neighbouring N-grid phases. Also checks that the committed
        // numbers regenerate (to 1e-9 s).
        let (_, cfg) = config();
        let model = Model::new(VehicleParams::default()).unwrap();
        let summary = committed();
        let iv: Intervention =
            serde_json::from_value(summary["optimum"]["intervention"].clone()).unwrap();
        let solver = cfg.settings.solver;
        let s = &cfg.start;
        let cycle = sway_cycle(
            &model,
            s.speed_mps.get(),
            s.theta0_rad,
            s.settle_s.get(),
            CYCLE_SEARCH_S,
            &solver,
        )
        .unwrap();
        let setting = cfg.setting(solver);
        let eval = |n: usize| {
            let starts =
                PhaseStarts::new(&model, &cycle, n, cfg.span(), cfg.delay_s, &solver).unwrap();
            evaluate(&model, &setting, &starts, &iv).unwrap()
        };
        let (coarse, fine) = (eval(16), eval(64));
        let (wc, wf) = (
            coarse.worst_settle_time_s.unwrap(),
            fine.worst_settle_time_s.unwrap(),
        );
        let committed_wc = summary["optimum"]["worst_case_settle_time_s"].as_f64().unwrap();
        assert!((wc - committed_wc).abs() < 1e-9, "{wc} vs {committed_wc}");
        let bound = refinement_bound(&coarse, &setting, cycle.period_s).unwrap();
        let change = wf - wc;
        eprintln!("worst case: {wc} s at 16 phases, {wf} s at 64; change {change} s ≤ {bound} s");
        assert!(change >= 0.0 && change <= bound, "{change} vs {bound}");
    }
}
