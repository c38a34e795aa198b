//! `cargo xtask fig3a`, bifurcation diagram (paper Fig. 3a, top): open loop (δ ≡ 0), V as
//! parameter; straight running with its stable and unstable parts, the Hopf point, the cycle
//! branch (max |θ| vs V) with its stable and unstable parts and the fold, and the stable /
//! bistable / unstable speed ranges.
//!
//! [`run_diagram`] computes and writes the diagram into a given output directory and returns
//! the summary fields, the figure panel and printed lines; the `fig3a` task
//! ([`super::fig3a_panels`]) runs it together with the time panels of the same figure, from
//! the `[diagram]` section of `configs/fig3a.toml`.

use std::path::Path;
use sway_model::vehicle::Vehicle;

use crate::TaskError;
use serde::{Deserialize, Serialize};
use sway::bifurcation::chart::{ChartOptions, critical_speeds};
use sway::bifurcation::{
    CycleExtent, Diagram, DiagramOptions, DiagramOutcome, DiagramSettings, Feedback,
    vehicle_diagram,
};
use sway::config::ensure;
use sway::ranging::{RelativeSpeed, SpeedReferences, SpeedSpec};

use super::TaskContext;
use crate::io::{Keyed, OutputDir};
use crate::plot::{Layer, Legend, Panel, Rgb, Shape, Stroke};
use crate::report::CycleRow;

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

/// Most points of a cycle branch: 100 000 (default 600). A point stores its collocation
/// vector, so the memory also depends on the mesh ([`cycle_branch_bytes`]), which is
/// checked against [`crate::limits::MEMORY_BUDGET_BYTES`] as well.
pub const MAX_CYCLE_POINTS: usize = 100_000;

/// Estimated memory of a cycle branch \[bytes\]: each point stores the profile
/// ((L·m + 1) mesh values of the 4 reduced states, 8 bytes each) about four times over
/// (the point, its tangent, Floquet data and the written rows), an upper estimate.
pub fn cycle_branch_bytes(o: &DiagramSettings) -> f64 {
    let profile = (o.intervals as f64 * o.degree as f64 + 1.0) * 4.0 * 8.0;
    o.max_cycle_points as f64 * profile * 4.0
}

/// Checks diagram settings whose speed range may be derived (fig3a, fig4b; `prefix` is the
/// key path): the range if given, then the rest as [`validate_options`].
///
/// # Errors
/// [`TaskError::Config`] naming the file and key.
pub fn validate_settings(o: &DiagramSettings, file: &Path, prefix: &str) -> Result<(), TaskError> {
    let key = |k: &str| {
        if prefix.is_empty() {
            k.to_string()
        } else {
            format!("{prefix}.{k}")
        }
    };
    for (name, v) in [("v_min_mps", o.v_min_mps), ("v_max_mps", o.v_max_mps)] {
        ensure(
            v.is_none_or(|v| v.is_finite() && v > 0.0),
            file,
            &key(name),
            || {
                format!(
                    "expected a positive speed (or the key omitted: derived from the vehicle), got {v:?}"
                )
            },
        )?;
    }
    ensure(
        o.beyond_hopf.is_finite() && o.beyond_hopf > 0.0 && o.beyond_hopf <= 2.0,
        file,
        &key("beyond_hopf"),
        || format!("expected 0 < beyond_hopf ≤ 2, got {}", o.beyond_hopf),
    )?;
    let lo = o.v_min_mps.unwrap_or(f64::MIN_POSITIVE);
    let hi = o.v_max_mps.unwrap_or(f64::MAX);
    validate_options(&o.options(lo, hi), file, prefix)
}

/// Checks continuation settings with a given speed range (`prefix` is the key path).
///
/// # Errors
/// [`TaskError::Config`] naming the file and key.
pub fn validate_options(o: &DiagramOptions, file: &Path, prefix: &str) -> Result<(), TaskError> {
    let key = |k: &str| {
        if prefix.is_empty() {
            k.to_string()
        } else {
            format!("{prefix}.{k}")
        }
    };
    ensure(
        o.v_min_mps.is_finite()
            && o.v_min_mps > 0.0
            && o.v_max_mps.is_finite()
            && o.v_max_mps > o.v_min_mps,
        file,
        &key("v_min_mps"),
        || {
            format!(
                "expected 0 < v_min_mps < v_max_mps, got {} and {}",
                o.v_min_mps, o.v_max_mps
            )
        },
    )?;
    // a count `name` within `range`
    let within = |name: &str, value: usize, range: std::ops::RangeInclusive<usize>| {
        ensure(range.contains(&value), file, &key(name), || {
            let (lo, hi) = range.clone().into_inner();
            format!("expected {lo} ≤ {name} ≤ {hi}, got {value}")
        })
    };
    within("intervals", o.intervals, 4..=2000)?;
    within("degree", o.degree, 1..=continuation::MAX_DEGREE)?;
    ensure(
        o.hopf_amplitude > 0.0 && o.hopf_amplitude < 0.1,
        file,
        &key("hopf_amplitude"),
        || {
            format!(
                "expected 0 < hopf_amplitude < 0.1, got {}",
                o.hopf_amplitude
            )
        },
    )?;
    ensure(
        o.initial_step > 0.0 && o.max_step >= o.initial_step,
        file,
        &key("initial_step"),
        || {
            format!(
                "expected 0 < initial_step ≤ max_step, got {} and {}",
                o.initial_step, o.max_step
            )
        },
    )?;
    ensure(
        o.max_cycle_points >= 2,
        file,
        &key("max_cycle_points"),
        || format!("expected at least 2, got {}", o.max_cycle_points),
    )?;
    let bytes = cycle_branch_bytes(&DiagramSettings::from(o));
    crate::limits::bound(
        file,
        &key("max_cycle_points"),
        o.max_cycle_points as f64,
        MAX_CYCLE_POINTS as f64,
        || format!("≈ {} of stored cycles", crate::limits::human_bytes(bytes)),
    )?;
    crate::limits::bound(
        file,
        &key("max_cycle_points"),
        bytes,
        crate::limits::MEMORY_BUDGET_BYTES,
        || {
            format!(
                "estimated bytes of the stored branch: {} points × ({} intervals × degree {} + 1) × 4 states",
                o.max_cycle_points, o.intervals, o.degree
            )
        },
    )?;
    Ok(within("root_degree", o.root_degree, 4..=200)?)
}

impl DiagramConfig {
    /// Checks the keys (`prefix` is the section's key path).
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path, prefix: &str) -> Result<(), TaskError> {
        validate_settings(&self.options, file, &format!("{prefix}.continuation"))?;
        let o = &self.options;
        let lo = o.v_min_mps.unwrap_or(0.0);
        let hi = o.v_max_mps.unwrap_or(f64::INFINITY);
        for (k, list) in [
            ("stable_speeds_mps", &self.stable_speeds_mps),
            ("unstable_speeds_mps", &self.unstable_speeds_mps),
        ] {
            let absolute = list.iter().filter_map(|v| match v {
                SpeedSpec::Absolute(v) => Some(*v),
                SpeedSpec::Relative(_) => None,
            });
            ensure(
                absolute.clone().all(|v| v > lo && v < hi),
                file,
                &format!("{prefix}.{k}"),
                || format!("expected speeds inside ({lo}, {hi}) m/s, got {list:?}"),
            )?;
        }
        Ok(())
    }
}

/// Vertices of a plotted curve (V \[m/s\], max |θ| \[deg\]); NaN pairs break it.
pub type Polyline = Vec<(f64, f64)>;

/// The collocation mesh of the cycles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Mesh {
    /// mesh intervals L
    pub intervals: usize,
    /// polynomial degree m
    pub degree: usize,
}

/// The diagram's fields of fig3a's `summary.json` (speed keys as [`speed_key`] writes
/// them). A quantity that does not exist for the vehicle (no Hopf point below the maximum
/// speed, no fold) is null, with the reason in the `*_reason` field next to it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiagramSummary {
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
    pub amplitude_reasons: Keyed<String>,
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

/// What [`run_diagram`] returns: summary fields, the figure panel, printed lines.
pub type DiagramParts = (DiagramSummary, Panel, Vec<String>);

/// What [`compute_diagram`] returns: everything [`run_diagram`] reports, and the diagram
/// whose branches it writes.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagramRun {
    /// the summary fields
    pub summary: DiagramSummary,
    /// the diagram (None: straight running has no Hopf point, `summary` says why)
    pub diagram: Option<Box<Diagram>>,
    /// the figure panel
    pub panel: Panel,
    /// printed lines
    pub lines: Vec<String>,
}

/// Summary key of a speed: `35` for 35.0, `35.5` for 35.5; a resolved relative speed is
/// rounded to 1e-9 m/s first (Table I's `{ of_v_crit = 1.00725443747214 }` is `35`).
pub fn speed_key(v: f64) -> String {
    format!("{}", (v * 1e9).round() / 1e9)
}

/// Lines of a cycle branch split into stable and unstable parts (NaN breaks), in the
/// coordinates (V, max |θ| \[deg\]).
pub fn split_by_stability(d: &Diagram) -> (Polyline, Polyline) {
    let mut stable = Vec::new();
    let mut unstable = Vec::new();
    let gap = (f64::NAN, f64::NAN);
    let pts = &d.cycle_summary;
    for (i, c) in pts.iter().enumerate() {
        let p = (c.speed_mps, c.amplitude_deg);
        let (this, other) = if c.stable {
            (&mut stable, &mut unstable)
        } else {
            (&mut unstable, &mut stable)
        };
        // join the parts at the point where stability changes
        if i > 0 && pts[i - 1].stable != c.stable {
            this.push(gap);
            this.push((pts[i - 1].speed_mps, pts[i - 1].amplitude_deg));
            other.push(p);
            other.push(gap);
        }
        this.push(p);
    }
    (stable, unstable)
}

/// Straight running at 0 split into stable (V < V_Hopf) and unstable parts.
fn straight_running(d: &Diagram) -> (Polyline, Polyline) {
    let o = &d.options;
    let vh = d.hopf.parameter;
    (
        vec![(o.v_min_mps, 0.0), (vh, 0.0)],
        vec![(vh, 0.0), (o.v_max_mps, 0.0)],
    )
}

/// Computes the open-loop diagram on the configured or derived speed range, writes
/// `equilibria.csv` and `cycles.csv`, and returns the summary fields (`hopf_v_mps`,
/// `fold_v_mps`, `fold_amplitude_deg`, `stable_amplitude_deg`, `unstable_amplitude_deg`,
/// `criticality`, …), the figure panel and printed lines. Straight running stable up to the
/// maximum speed is an outcome: `hopf_v_mps` null with `hopf_reason`, a figure of the
/// stable straight running.
///
/// # Errors
/// Numerical failures with context, or write errors.
pub fn run_diagram(
    ctx: &TaskContext<'_>,
    cfg: &DiagramConfig,
    out: &OutputDir,
) -> Result<DiagramParts, TaskError> {
    let run = compute_diagram(ctx, cfg)?;
    write_branches(run.diagram.as_deref(), out)?;
    Ok((run.summary, run.panel, run.lines))
}

/// What [`run_diagram`] computes, without writing anything: the summary fields, the
/// diagram, the figure panel and printed lines (the Python package's diagram).
///
/// # Errors
/// Numerical failures with context.
pub fn compute_diagram(
    ctx: &TaskContext<'_>,
    cfg: &DiagramConfig,
) -> Result<DiagramRun, TaskError> {
    trailer_model::with_plant!(&ctx.plant, m => compute_diagram_on(m, ctx, cfg))
}

/// [`compute_diagram`] on the concrete plant of the vehicle (any model variant; the paper's
/// [`trailer_model::Model`] for a vehicle of the paper's form).
fn compute_diagram_on<P: Vehicle<N>, const N: usize>(
    model: &P,
    ctx: &TaskContext<'_>,
    cfg: &DiagramConfig,
) -> Result<DiagramRun, TaskError> {
    let outcome = vehicle_diagram(
        model,
        Feedback::OPEN_LOOP,
        &cfg.options,
        &ctx.limits,
        CycleExtent::WholeRange,
    )?;
    let d = match outcome {
        DiagramOutcome::Computed(d) => d,
        DiagramOutcome::NoHopf(n) => return Ok(no_hopf_diagram(cfg, &n)),
    };
    // the Hopf point and the fold corrected on their defining systems, as fig4b and the
    // nonlinear chart report them (one number per vehicle across the tasks)
    let cs = critical_speeds(model, &d, &ChartOptions::correcting(&d.options))?;
    let refs = SpeedReferences {
        v_crit_mps: Some(cs.hopf_v_mps),
        v_fold_mps: cs.fold.map(|f| f.v_mps),
        reason: d.fold_reason(),
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
            reasons
                .0
                .push((key.clone(), format!("no stable cycle at {key} m/s")));
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
            reasons
                .0
                .push((key.clone(), format!("no unstable cycle at {key} m/s")));
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

    let panel = diagram_panel(&d);
    let mut lines = vec![format!(
        "fig3a diagram: Hopf (V_crit) at {:.6} m/s ({}), ω = {:.4} rad/s",
        cs.hopf_v_mps, cs.criticality, cs.hopf_omega_rad_s
    )];
    match (fold, &summary.fold_reason) {
        (Some(f), _) => lines.push(format!(
            "fig3a diagram: fold of cycles at {:.6} m/s, max |θ| = {:.4}°; bistable {:.3}–{:.3} m/s",
            f.v_mps, f.amplitude_deg, f.v_mps, cs.hopf_v_mps
        )),
        (None, Some(r)) => lines.push(format!("fig3a diagram: no fold of cycles: {r}")),
        (None, None) => {}
    }
    Ok(DiagramRun {
        summary,
        diagram: Some(d),
        panel,
        lines,
    })
}

/// `equilibria.csv` and `cycles.csv` of a diagram (without one: the headers only).
fn write_branches(d: Option<&Diagram>, out: &OutputDir) -> Result<(), TaskError> {
    let eq_rows: Vec<[f64; 3]> = d
        .iter()
        .flat_map(|d| &d.equilibria.points)
        .map(|p| {
            let st = p.stability.as_ref();
            [
                p.parameter,
                f64::from(u8::from(p.is_stable() == Some(true))),
                st.and_then(|s| s.values.first()).map_or(f64::NAN, |z| z.re),
            ]
        })
        .collect();
    out.write_csv(
        "equilibria.csv",
        &["v_mps", "stable", "max_re_lambda_per_s"],
        &eq_rows,
    )?;
    out.write_table(
        "cycles.csv",
        d.iter().flat_map(|d| &d.cycle_summary).map(CycleRow::from),
    )?;
    Ok(())
}

/// A configured speed resolved to (summary key, speed \[m/s\]); None (with the reason
/// recorded under the spec) when its reference does not exist.
fn resolve_or_note(
    spec: &SpeedSpec,
    refs: &SpeedReferences,
    reasons: &mut Keyed<String>,
) -> Option<(String, f64)> {
    match spec.resolve(refs) {
        Ok(v) => Some((speed_key(v), v)),
        Err(e) => {
            let key = serde_json::to_string(spec).unwrap_or_else(|_| format!("{spec:?}"));
            reasons.0.push((key, e.reason));
            None
        }
    }
}

/// The outcome without a Hopf point: straight running only, said in the summary, the
/// console and the figure.
fn no_hopf_diagram(cfg: &DiagramConfig, n: &sway::bifurcation::NoHopf) -> DiagramRun {
    let hi = n.stable_up_to_mps.unwrap_or(n.searched_from_mps);
    let mut reasons = Keyed::default();
    for spec in cfg.stable_speeds_mps.iter().chain(&cfg.unstable_speeds_mps) {
        let key = serde_json::to_string(spec).unwrap_or_else(|_| format!("{spec:?}"));
        reasons.0.push((key, n.reason.clone()));
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
    let title = match n.divergence_v_mps {
        Some(v) => format!(
            "Open loop: straight running diverges statically at {v:.2} m/s (real eigenvalue, no Hopf point)"
        ),
        None => "Open loop: straight running (no Hopf point in the searched range)".to_string(),
    };
    let mut panel = Panel::new(&title, "V [m/s]", "max |θ| [deg]")
        .x_range(n.searched_from_mps, hi)
        .y_range(-0.5, 10.0)
        .legend(Legend::UpperLeft);
    let (color, label) = if n.stable_up_to_mps.is_some() {
        (Rgb::GREEN, "straight running, stable")
    } else {
        (Rgb::RED, "straight running, unstable")
    };
    panel
        .layers
        .push(Layer::band(n.searched_from_mps, hi, color, Some(label)));
    panel.layers.push(Layer::line(
        vec![(n.searched_from_mps, 0.0), (hi, 0.0)],
        color,
        Stroke::Solid,
        None,
    ));
    let lines = vec![format!("fig3a diagram: {}", n.reason)];
    DiagramRun {
        summary,
        diagram: None,
        panel,
        lines,
    }
}

/// An empty panel of cycle amplitudes max |θ| \[deg\] against V \[m/s\] over the speed range
/// of `o`, the θ axis up to 1.08 × the largest of `amplitudes`.
pub fn amplitude_panel(
    title: &str,
    o: &DiagramOptions,
    amplitudes: impl Iterator<Item = f64>,
) -> Panel {
    let y_max = amplitudes.fold(0.0, f64::max) * 1.08;
    Panel::new(title, "V [m/s]", "max |θ| [deg]")
        .x_range(o.v_min_mps, o.v_max_mps)
        .y_range(-0.03 * y_max, y_max)
}

/// The diagram as a figure panel (paper Fig. 3a, top).
pub fn diagram_panel(d: &Diagram) -> Panel {
    let o = &d.options;
    let vh = d.hopf.parameter;
    let mut p = amplitude_panel(
        "Open loop: straight running and sway cycles (max |θ|) vs speed",
        o,
        d.cycle_summary.iter().map(|c| c.amplitude_deg),
    )
    .legend(Legend::UpperLeft);
    // stable up to the fold of cycles (bistable from there) or the Hopf point
    let bistable = d.bistable_range();
    let stable_end = bistable.map_or(vh, |(vf, _)| vf);
    p.layers.push(Layer::band(
        o.v_min_mps,
        stable_end,
        Rgb::GREEN,
        Some("stable range"),
    ));
    if bistable.is_some() {
        p.layers.push(Layer::band(
            stable_end,
            vh,
            Rgb::ORANGE,
            Some("bistable range"),
        ));
    }
    p.layers.push(Layer::band(
        vh,
        o.v_max_mps,
        Rgb::RED,
        Some("unstable range"),
    ));
    let (eq_s, eq_u) = straight_running(d);
    let (cs, cu) = split_by_stability(d);
    for (points, color, stroke, label) in [
        (eq_s, Rgb::GREEN, Stroke::Solid, "straight running, stable"),
        (eq_u, Rgb::RED, Stroke::Solid, "straight running, unstable"),
        (cu, Rgb::RED, Stroke::Dashed, "unstable cycle (threshold)"),
        (cs, Rgb::GREEN, Stroke::Dashed, "stable cycle (sway)"),
    ] {
        p.layers
            .push(Layer::line(points, color, stroke, Some(label)));
    }
    p.layers.push(Layer::markers(
        vec![(vh, 0.0)],
        Rgb::BLACK,
        Some(&format!("Hopf, V = {vh:.2} m/s")),
    ));
    if let Some(f) = d.fold {
        p.layers.push(Layer::Markers {
            points: vec![(f.speed_mps, f.amplitude_deg)],
            color: Rgb::BLACK,
            shape: Shape::Triangle,
            size: 6,
            label: Some(format!("fold, V = {:.2} m/s", f.speed_mps)),
        });
    }
    p
}
