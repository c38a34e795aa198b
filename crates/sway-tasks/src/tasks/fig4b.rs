//! `cargo xtask fig4b` (paper Fig. 4b): bifurcation diagrams of the closed loop with the
//! delayed yaw-rate feedback δ(t) = −D·ψ̇(t − τ) (eq. 8) for the (τ, D) pairs of
//! `configs/fig4b.toml`, overlaid in one figure. The delayed cases are delay differential
//! equations: their periodic orbits are computed by collocation with the delayed values read
//! off the periodic profile, their stability from the DDE Floquet multipliers.
//!
//! `summary.json`: `"pairs"`, an array with, per pair, `"tau_s"`, `"d_s"`, `"hopf_v_mps"`,
//! `"fold_v_mps"`, `"criticality"` (plus the fold amplitude and the bistable range).
//!
//! The Hopf and fold speeds are read off the two-parameter machinery of the nonlinear
//! chart ([`sway::bifurcation::chart::critical_speeds`]): the Hopf point and the fold of
//! cycles located on the diagram are corrected on the Hopf and fold-of-cycles defining
//! systems, so `fig4b` and `chart_nonlinear` share one implementation.
//!
//! Any vehicle file: the diagrams are computed on the vehicle's plant (relaxation, tyre
//! laws, axle lists, hitch torque; `sway::bifurcation::ClosedLoop` over any
//! `trailer_model::Plant`).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use crate::TaskError;
use sway::bifurcation::chart::CriticalSpeeds;
use sway::bifurcation::{Diagram, DiagramSettings, LoopLaw};
use sway_studies::fig4b::{PairDiagram, PairSummary, closed_loop_diagrams, common_range};
use sway::config::ensure;

use super::fig3a_diagram::{split_by_stability, validate_settings};
use super::{Prepared, Report, Task, TaskContext};
use crate::config_file::load_toml;
use crate::io::OutputDir;
use crate::plot::{Figure, Layer, Legend, Panel, Rgb, Shape, Stroke};
use crate::report::CycleRow;

/// The task.
pub const TASK: Task = Task {
    name: "fig4b",
    about: "paper Fig. 4b: bifurcation diagrams with delayed yaw-rate feedback for several (τ, D)",
    config: "fig4b.toml",
    prepare,
    models: super::Models::Any,
    runs: super::Runs::InAll,
};

/// One feedback setting: `{ delay_s = τ, gain_s = D }` in the config. The config echo in
/// `summary.json` keeps the historical names `tau_s` and `d_s` (other tools read them).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pair {
    /// delay τ \[s\] (0 with D = 0: open loop)
    #[serde(rename(serialize = "tau_s", deserialize = "delay_s"))]
    pub delay_s: f64,
    /// gain D \[s\]
    #[serde(rename(serialize = "d_s", deserialize = "gain_s"))]
    pub gain_s: f64,
}

fn default_pairs() -> Vec<Pair> {
    vec![
        Pair {
            delay_s: 0.0,
            gain_s: 0.0,
        },
        Pair {
            delay_s: 0.1,
            gain_s: 0.1,
        },
        Pair {
            delay_s: 0.2,
            gain_s: 0.1,
        },
        Pair {
            delay_s: 0.2,
            gain_s: 0.2,
        },
    ]
}

fn default_options() -> DiagramSettings {
    DiagramSettings::closed_loop()
}

/// `configs/fig4b.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig4bConfig {
    /// the (τ, D) pairs
    #[serde(default = "default_pairs")]
    pub pairs: Vec<Pair>,
    /// continuation and discretisation settings, shared by all pairs; the speed range
    /// omitted: derived from the vehicle per pair ([`sway::bifurcation::vehicle_diagram`])
    #[serde(default = "default_options")]
    pub continuation: DiagramSettings,
}

impl Fig4bConfig {
    /// Checks the keys.
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path) -> Result<(), TaskError> {
        ensure(!self.pairs.is_empty(), file, "pairs", || {
            "expected at least one (delay_s, gain_s) pair".into()
        })?;
        for (i, p) in self.pairs.iter().enumerate() {
            ensure(
                p.delay_s.is_finite() && p.delay_s >= 0.0,
                file,
                &format!("pairs[{i}].delay_s"),
                || format!("expected a delay τ ≥ 0 s, got {}", p.delay_s),
            )?;
            ensure(
                p.gain_s.is_finite() && p.gain_s.abs() <= 5.0,
                file,
                &format!("pairs[{i}].gain_s"),
                || format!("expected a finite gain |D| ≤ 5 s, got {}", p.gain_s),
            )?;
        }
        validate_settings(&self.continuation, file, "continuation")
    }
}

fn label(p: &Pair) -> String {
    if p.gain_s == 0.0 {
        "open loop".into()
    } else {
        format!("τ = {} s, D = {} s", p.delay_s, p.gain_s)
    }
}

fn file_stem(p: &Pair) -> String {
    format!("cycles_tau{}_d{}", p.delay_s, p.gain_s)
}

struct Fig4bTask {
    file: PathBuf,
    config: Fig4bConfig,
}

fn prepare(_ctx: &TaskContext<'_>, file: &Path) -> Result<Box<dyn Prepared>, TaskError> {
    let config: Fig4bConfig = load_toml(file)?;
    config.validate(file)?;
    Ok(Box::new(Fig4bTask {
        file: file.to_path_buf(),
        config,
    }))
}

/// One pair's layers: stable cycles solid (labelled), unstable dashed, the Hopf point and
/// the fold.
fn add_pair(panel: &mut Panel, d: &Diagram, cs: &CriticalSpeeds, color: Rgb, label: &str) {
    let (stable, unstable) = split_by_stability(d);
    panel
        .layers
        .push(Layer::line(stable, color, Stroke::Solid, Some(label)));
    panel
        .layers
        .push(Layer::line(unstable, color, Stroke::Dashed, None));
    panel
        .layers
        .push(Layer::markers(vec![(cs.hopf_v_mps, 0.0)], color, None));
    if let Some(f) = cs.fold {
        panel.layers.push(Layer::Markers {
            points: vec![(f.v_mps, f.amplitude_deg)],
            color,
            shape: Shape::Triangle,
            size: 6,
            label: None,
        });
    }
}

/// `summary.json` of fig4b (before the common fields of [`crate::io::Summary`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fig4bSummary {
    /// one entry per pair, in the config's order
    pub pairs: Vec<PairSummary>,
}

/// The feedback of a pair.
fn feedback(p: &Pair) -> LoopLaw {
    LoopLaw::paper(p.gain_s, p.delay_s)
}

/// All diagrams of the config with their corrected Hopf and fold speeds, in config order
/// ([`closed_loop_diagrams()`]: parallel over pairs, deterministic).
///
/// # Errors
/// The first failing pair's error (in config order).
pub fn diagrams<P: sway_model::vehicle::Vehicle<N>, const N: usize>(
    model: &P,
    cfg: &Fig4bConfig,
    limits: &sway::ranging::SpeedLimits,
    progress: &dyn sway::progress::Progress,
) -> Result<Vec<PairDiagram>, TaskError> {
    let feedbacks: Vec<LoopLaw> = cfg.pairs.iter().map(feedback).collect();
    Ok(closed_loop_diagrams(
        model,
        &feedbacks,
        &cfg.continuation,
        limits,
        progress,
    )?)
}

/// The console line of a pair.
fn pair_line(p: &Pair, d: &PairDiagram, entry: &PairSummary) -> String {
    match d.computed() {
        Some((_, cs)) => format!(
            "fig4b {}: Hopf at {:.4} m/s ({}), fold at {}",
            label(p),
            cs.hopf_v_mps,
            cs.criticality,
            cs.fold.map_or_else(
                || format!("none ({})", entry.reason.as_deref().unwrap_or("no fold")),
                |f| format!("{:.4} m/s, {:.2}°", f.v_mps, f.amplitude_deg)
            )
        ),
        None => format!(
            "fig4b {}: {}",
            label(p),
            entry.reason.as_deref().unwrap_or("no Hopf point")
        ),
    }
}

impl Prepared for Fig4bTask {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        let cfg = &self.config;
        let steps = cfg.pairs.len() as u64;
        ctx.run_staged(TASK.name, "fig4b: bifurcation diagrams", steps, cfg, &self.file, |out| {
            let ds = trailer_model::with_plant!(&ctx.plant, m => diagrams(m, cfg, &ctx.limits, ctx.progress))?;
            let (lines, entries) = write_pairs(cfg, &ds, out)?;
            diagrams_figure(cfg, &ds).render(&out.path("diagrams"))?;
            Ok((Fig4bSummary { pairs: entries }, lines))
        })
    }
}

/// The cycles CSV of every computed pair; the console lines and summary entries.
fn write_pairs(
    cfg: &Fig4bConfig,
    ds: &[PairDiagram],
    out: &OutputDir,
) -> Result<(Vec<String>, Vec<PairSummary>), TaskError> {
    let mut lines = Vec::new();
    let mut entries = Vec::new();
    for (p, pd) in cfg.pairs.iter().zip(ds) {
        if let Some((d, _)) = pd.computed() {
            out.write_table(
                &format!("{}.csv", file_stem(p)),
                d.cycle_summary.iter().map(CycleRow::from),
            )?;
        }
        let entry = pd.summary(feedback(p));
        lines.push(pair_line(p, pd, &entry));
        entries.push(entry);
    }
    Ok((lines, entries))
}

/// The overlaid diagrams (paper Fig. 4b) on the range covering every computed pair.
fn diagrams_figure(cfg: &Fig4bConfig, ds: &[PairDiagram]) -> Figure {
    let (v_lo, v_hi) = common_range(ds).unwrap_or_else(|| {
        cfg.continuation
            .v_min_mps
            .zip(cfg.continuation.v_max_mps)
            .unwrap_or((0.0, 100.0))
    });
    let y_max = ds
        .iter()
        .filter_map(PairDiagram::computed)
        .flat_map(|(d, _)| d.cycle_summary.iter().map(|c| c.amplitude_deg))
        .fold(0.0, f64::max)
        .max(1.0)
        * 1.08;
    let mut panel = Panel::new(
        "Closed loop δ(t) = −D·dψ/dt(t − τ): cycles (max |θ|) vs speed; solid stable (sway), dashed unstable",
        "V [m/s]",
        "max |θ| [deg]",
    )
    .x_range(v_lo, v_hi)
    .y_range(-0.03 * y_max, 1.25 * y_max)
    .legend(Legend::UpperLeft);
    for (i, (p, pd)) in cfg.pairs.iter().zip(ds).enumerate() {
        match pd.computed() {
            Some((d, cs)) => add_pair(&mut panel, d, cs, Rgb::palette(i), &label(p)),
            None => panel.layers.push(Layer::line(
                vec![(f64::NAN, f64::NAN)],
                Rgb::palette(i),
                Stroke::Solid,
                Some(&format!("{}: no Hopf point", label(p))),
            )),
        }
    }
        // legend entries only (no points): what the coloured markers mean
        for (shape, size, label) in [
            (
                Shape::Circle,
                4,
                "Hopf points (straight running loses stability)",
            ),
            (Shape::Triangle, 6, "folds of cycles"),
        ] {
            panel.layers.push(Layer::Markers {
                points: vec![(f64::NAN, f64::NAN)],
                color: Rgb::BLACK,
                shape,
                size,
                label: Some(label.into()),
            });
        }
    Figure::single(panel).titled("Fig. 4b: bifurcation diagrams with delayed yaw-rate feedback")
}
