//! `cargo xtask mitigation` (beyond the paper): the braking-and-steering
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
//! mirror images (see [`sway::mitigation::PhaseStarts`]): φ ∈ \[0, ½) in the results stands for φ + ½ too.
//!
//! `summary.json`: `"optimum"` (`intervention` — the decision variables —,
//! `worst_case_settle_time_s`, `worst_case_peak_deg`, …), `"strategies"` (`"none"`,
//! `"steering"`, `"braking"`, `"combined"`: `worst_case_settle_time_s`,
//! `lost_control_phases`, …), `"ranking"` (best first), `"phase_refinement"` (the
//! worst case at refinement × N phases against its bound), `"cycle"`.
//!
//! Any vehicle file: the cycle, the phase starts and every run are of the vehicle's plant
//! (relaxation, tyre laws, axle lists, hitch torque), with relative speeds referred
//! to its own V_crit and fold; a vehicle of the paper's form gives the paper model's numbers.

use std::path::Path;

use serde::Serialize;
use sway_studies::mitigation::{
    MitigationConfig, MitigationOutcome, MitigationResult, MitigationSummary,
    run_mitigation, summary, theta_at_phase,
};
use sway::mitigation::{Evaluation, Setting, settled};
use sway::ranging::SpeedSpec;
use sway::progress::Progress;
use sway::ranging::resolve_speeds;
use sway::sim::{RampShape, ResolvedSpeed, SimulateOwn};

use super::series::{WithSpeeds, nothing_to_show, resolved_check};
use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig};
use crate::io::OutputDir;
use crate::limits::{Plan, bound, human_seconds};
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Shape, Stroke};

/// The task.
pub const TASK: Task = Task::configured::<MitigationConfig<SpeedSpec>>(
    "mitigation",
    "optimal braking + steering from any phase of the sway (worst case over phase) vs the paper's strategies",
    "mitigation.toml",
)
.any_model();

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

impl TaskConfig for MitigationConfig<SpeedSpec> {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        Ok(self.validate_spec(file)?)
    }
}

/// `summary.json` of a vehicle without sway at V0: why there is nothing to mitigate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoSwaySummary {
    /// why
    pub reason: String,
    /// V0 \[m/s\]
    pub speed_mps: f64,
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
    /// of them, trial points rejected as soon as their worst case was proven above the cost
    /// they were compared with (their runs stopped early)
    pub cut_short: usize,
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

fn phase_rows<const M: usize>(r: &MitigationResult<M>, setting: &Setting) -> Vec<PhaseRow> {
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

fn search_rows<const M: usize>(r: &MitigationResult<M>) -> Vec<SearchRow> {
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
            cut_short: run.cut_short,
        })
        .collect()
}

const STRATEGY_COLORS: [Rgb; 4] = [Rgb::RED, Rgb::BLUE, Rgb::ORANGE, Rgb::GREEN];

fn settle_panel<const M: usize>(r: &MitigationResult<M>, cfg: &MitigationConfig) -> Panel {
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

fn theta_panel<const M: usize>(
    optimum: &[(f64, f64)],
    combined: &[(f64, f64)],
    r: &MitigationResult<M>,
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

fn write_figures<P: SimulateOwn<M>, const M: usize>(
    out: &OutputDir,
    model: &P,
    r: &MitigationResult<M>,
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
    for (k, e) in &s.strategies {
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

/// The study on the plant `model` and its files (phases, search, figures): the headline of
/// `summary.json` and the report lines.
fn study<P: SimulateOwn<M>, const M: usize>(
    out: &OutputDir,
    model: &P,
    cfg: &MitigationConfig,
    speeds: &[ResolvedSpeed],
    progress: &dyn Progress,
) -> Result<(Headline, Vec<String>), TaskError> {
    let r = match run_mitigation(model, cfg, progress)? {
        MitigationOutcome::Mitigated(r) => r,
        MitigationOutcome::NoSway { reason } => {
            let lines = vec![format!(
                "{}: nothing to show for this vehicle — {reason}",
                TASK.name
            )];
            let s = NoSwaySummary {
                reason,
                speed_mps: cfg.speed(),
            };
            return Ok((Headline::NoSway(s), lines));
        }
    };
    let setting = cfg.setting(cfg.settings.solver);
    out.write_table("phases.csv", phase_rows(&r, &setting))?;
    out.write_table("search.csv", search_rows(&r))?;
    write_figures(out, model, &r, cfg)?;
    let s = summary(&r, cfg);
    let lines = headline(&s);
    let s = WithSpeeds {
        headline: s,
        resolved_speeds: speeds.to_vec(),
    };
    Ok((Headline::Mitigated(Box::new(s)), lines))
}

impl Prepared for Configured<MitigationConfig<SpeedSpec>> {
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
        let name = TASK.name;
        let resolution = resolve_speeds(&ctx.plant, &ctx.limits, &self.config)?;
        let cfg = match &resolution.outcome {
            Ok(c) => c,
            Err(u) => {
                return nothing_to_show(
                    ctx,
                    name,
                    "no sway to mitigate",
                    u,
                    &resolution.references,
                    &self.config,
                    &self.file,
                );
            }
        };
        resolved_check(cfg.validate(&self.file).map_err(Into::into), &resolution.speeds)?;
        let stage = "mitigation: strategies, optimisation, check";
        ctx.run_staged(name, stage, 3, &self.config, &self.file, |out| {
            let speeds = &resolution.speeds;
            trailer_model::with_plant!(&ctx.plant, m => study(out, m, cfg, speeds, ctx.progress))
        })
    }
}

/// The headline of `summary.json`: the study, or why there was nothing to mitigate.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Headline {
    /// the study (see [`MitigationSummary`])
    Mitigated(Box<WithSpeeds<MitigationSummary>>),
    /// no sway at V0
    NoSway(NoSwaySummary),
}
