//! `cargo xtask fig3a`, bifurcation diagram (paper Fig. 3a, top): open loop (δ ≡ 0), V as
//! parameter; straight running with its stable and unstable parts, the Hopf point, the cycle
//! branch (max |θ| vs V) with its stable and unstable parts and the fold, and the stable /
//! bistable / unstable speed ranges.
//!
//! The diagram and its summary fields are computed by [`sway_studies::fig3a::diagram`];
//! this module checks the `[diagram]` section of `configs/fig3a.toml` (and the continuation
//! settings of the other diagram tasks), writes the branches and draws the diagram, for the
//! `fig3a` task ([`super::fig3a_panels`]) that runs it together with the time panels of
//! the same figure.

use std::path::Path;

use crate::TaskError;
use sway::bifurcation::{Diagram, DiagramOptions, DiagramSettings};
use sway::config::ensure;
use sway::ranging::SpeedSpec;
use sway_studies::fig3a::{AmplitudeKey, DiagramStudy};
pub use sway_studies::fig3a::{DiagramConfig, DiagramSummary, Mesh, speed_key};

use crate::io::OutputDir;
use crate::plot::{Layer, Legend, Panel, Rgb, Shape, Stroke};
use crate::report::CycleRow;

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

/// Checks the keys of a `[diagram]` section (`prefix` is the section's key path).
///
/// # Errors
/// [`TaskError::Config`] naming the file and key.
pub fn validate_diagram(cfg: &DiagramConfig, file: &Path, prefix: &str) -> Result<(), TaskError> {
    validate_settings(&cfg.options, file, &format!("{prefix}.continuation"))?;
    let o = &cfg.options;
    let lo = o.v_min_mps.unwrap_or(0.0);
    let hi = o.v_max_mps.unwrap_or(f64::INFINITY);
    for (k, list) in [
        ("stable_speeds_mps", &cfg.stable_speeds_mps),
        ("unstable_speeds_mps", &cfg.unstable_speeds_mps),
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

/// Vertices of a plotted curve (V \[m/s\], max |θ| \[deg\]); NaN pairs break it.
pub type Polyline = Vec<(f64, f64)>;

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

/// The diagram's fields of `summary.json`: a configured speed that did not resolve keyed
/// by its JSON text (e.g. `{"in_bistable":0.458}`).
pub fn summary_fields(s: DiagramSummary<AmplitudeKey>) -> DiagramSummary {
    s.rekeyed(|k| match k {
        AmplitudeKey::Speed(key) => key,
        AmplitudeKey::Spec(spec) => spec_key(&spec),
    })
}

fn spec_key(spec: &SpeedSpec) -> String {
    serde_json::to_string(spec).unwrap_or_else(|_| format!("{spec:?}"))
}

/// `equilibria.csv` and `cycles.csv` of a diagram (without one: the headers only).
///
/// # Errors
/// [`TaskError::Write`].
pub fn write_branches(d: Option<&Diagram>, out: &OutputDir) -> Result<(), TaskError> {
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

/// The figure panel of a diagram and its printed lines: the Hopf point, the fold of
/// cycles (or why there is none); without a Hopf point the straight running and why.
pub fn diagram_report(study: &DiagramStudy) -> (Panel, Vec<String>) {
    let s = &study.summary;
    let Some(d) = &study.diagram else {
        return (
            no_hopf_panel(s),
            vec![format!(
                "fig3a diagram: {}",
                s.hopf_reason.as_deref().unwrap_or_default()
            )],
        );
    };
    let hopf_v = s.hopf_v_mps.unwrap_or(f64::NAN);
    let mut lines = vec![format!(
        "fig3a diagram: Hopf (V_crit) at {:.6} m/s ({}), ω = {:.4} rad/s",
        hopf_v,
        s.criticality.as_deref().unwrap_or_default(),
        s.hopf_omega_rad_s.unwrap_or(f64::NAN)
    )];
    match (s.fold_v_mps.zip(s.fold_amplitude_deg), &s.fold_reason) {
        (Some((v_fold, amplitude)), _) => lines.push(format!(
            "fig3a diagram: fold of cycles at {v_fold:.6} m/s, max |θ| = {amplitude:.4}°; bistable {v_fold:.3}–{hopf_v:.3} m/s"
        )),
        (None, Some(r)) => lines.push(format!("fig3a diagram: no fold of cycles: {r}")),
        (None, None) => {}
    }
    (diagram_panel(d), lines)
}

/// The panel without a Hopf point: straight running over the searched speeds, stable or
/// unstable, and where it diverges statically.
fn no_hopf_panel<K>(s: &DiagramSummary<K>) -> Panel {
    let [lo, hi] = s.searched_mps;
    let title = match s.divergence_v_mps {
        Some(v) => format!(
            "Open loop: straight running diverges statically at {v:.2} m/s (real eigenvalue, no Hopf point)"
        ),
        None => "Open loop: straight running (no Hopf point in the searched range)".to_string(),
    };
    let mut panel = Panel::new(&title, "V [m/s]", "max |θ| [deg]")
        .x_range(lo, hi)
        .y_range(-0.5, 10.0)
        .legend(Legend::UpperLeft);
    let (color, label) = if s.stable_up_to_mps.is_some() {
        (Rgb::GREEN, "straight running, stable")
    } else {
        (Rgb::RED, "straight running, unstable")
    };
    panel.layers.push(Layer::band(lo, hi, color, Some(label)));
    panel.layers.push(Layer::line(
        vec![(lo, 0.0), (hi, 0.0)],
        color,
        Stroke::Solid,
        None,
    ));
    panel
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
