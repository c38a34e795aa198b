//! The chart and diagram pipelines: `stability_chart` (the `fig4a` task), `nonlinear_chart`
//! (`chart_nonlinear`) and `bifurcation_diagram` (the diagrams of `fig3a` and `fig4b`).
//! Each reads its settings into the task's config type, validates them with the task's
//! checks and limits, runs the task's computation and returns its summary as JSON (the
//! fields of the task's `summary.json`) beside the curves and grids as numpy arrays.

use std::path::{Path, PathBuf};

use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde::{Deserialize, Serialize};
use sway::bifurcation::{CycleExtent, DiagramSettings, LoopLaw};
use sway_studies::fig4b::{PairDiagram, closed_loop_diagram};
use sway_tasks::config_file::{Configured, TaskConfig};
use sway_tasks::tasks::Prepared;
use sway_tasks::tasks::chart_nonlinear::{self, ChartNonlinearConfig};
use sway_tasks::tasks::fig3a_diagram::{
    DiagramConfig, summary_fields, validate_diagram, validate_settings,
};
use sway_tasks::tasks::fig4a::{self, Fig4aConfig};

use sway::charts::auto_range::SpeedBounds;
use sway::ranging::SpeedLimits;
use sway_tasks::TaskError;

use crate::{Vehicle, interruptible, load_config, load_config_over, py_err, to_json};

/// Points of boundary polylines as rows (branch, V \[m/s\], D \[s\], ω \[rad/s\]), n × 4.
fn boundary_rows<'py>(
    py: Python<'py>,
    lines: &[stability::Polyline],
) -> PyResult<Bound<'py, PyAny>> {
    let mut rows = Vec::new();
    for (k, l) in lines.iter().enumerate() {
        for p in &l.points {
            rows.extend([k as f64, p.v, p.d, p.omega]);
        }
    }
    let n = rows.len() / 4;
    Ok(rows.into_pyarray(py).reshape([n, 4])?.into_any())
}

/// stability_chart(vehicle, config) → (summary JSON, [per delay: dict of arrays]): the
/// `fig4a` task on a config dict of `configs/fig4a.toml`'s shape.
#[pyfunction]
#[pyo3(signature = (vehicle, config, progress = None))]
fn stability_chart<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    config: &Bound<'py, PyAny>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Bound<'py, PyList>)> {
    let (cfg, file): (Fig4aConfig, PathBuf) = load_config(config, "stability_chart()")?;
    cfg.check(&file).map_err(py_err)?;
    let prepared = Configured { file, config: cfg };
    let plan = prepared.plan().map_err(py_err)?;
    let cfg = prepared.config;
    // the vehicle's plant and the CLI's default speed limits (--max-speed)
    let plant = vehicle.plant().clone();
    let (charts, summary) = interruptible(py, plan.time_s, progress, move |progress| {
        progress.start("stability charts", 0);
        let limits = SpeedLimits::default();
        let r = fig4a::compute(&plant, &cfg, &SpeedBounds::from(&limits))?;
        let (summary, _) = fig4a::summarize(&plant, &limits, &cfg, &r)?;
        Ok::<_, TaskError>((r.charts, summary))
    })?
    .map_err(py_err)?;
    let out = PyList::empty(py);
    for ch in charts {
        let (nv, nd) = (ch.v.len(), ch.d.len());
        let d = PyDict::new(py);
        d.set_item("tau_s", ch.tau)?;
        let abscissa: Vec<f64> = ch.cells.iter().map(|c| c.spectral_abscissa).collect();
        // u32::MAX marks a cell whose count failed: -1
        let counts: Vec<i64> = ch
            .cells
            .iter()
            .map(|c| {
                if c.unstable_roots == u32::MAX {
                    -1
                } else {
                    i64::from(c.unstable_roots)
                }
            })
            .collect();
        d.set_item("static_boundary", boundary_rows(py, &ch.static_boundary)?)?;
        d.set_item(
            "dynamic_boundary",
            boundary_rows(py, &ch.dynamic_boundaries)?,
        )?;
        d.set_item("v_mps", ch.v.into_pyarray(py))?;
        d.set_item("d_s", ch.d.into_pyarray(py))?;
        d.set_item(
            "spectral_abscissa_per_s",
            abscissa.into_pyarray(py).reshape([nv, nd])?,
        )?;
        d.set_item("unstable_roots", counts.into_pyarray(py).reshape([nv, nd])?)?;
        let failures: Vec<(usize, usize, String)> = ch.failures;
        d.set_item("failures", failures)?;
        out.append(d)?;
    }
    Ok((to_json(&summary)?, out))
}

/// nonlinear_chart(vehicle, config) → (summary JSON, [per delay: dict]): the
/// `chart_nonlinear` task on a config dict of `configs/chart_nonlinear.toml`'s shape.
#[pyfunction]
#[pyo3(signature = (vehicle, config, progress = None))]
fn nonlinear_chart<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    config: &Bound<'py, PyAny>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Bound<'py, PyList>)> {
    let (cfg, file): (ChartNonlinearConfig, PathBuf) = load_config(config, "nonlinear_chart()")?;
    cfg.check(&file).map_err(py_err)?;
    let prepared = Configured { file, config: cfg };
    let plan = prepared.plan().map_err(py_err)?;
    let cfg = prepared.config;
    let plant = vehicle.plant().clone();
    let (summary, results) = interruptible(py, plan.time_s, progress, move |progress| {
        let limits = SpeedLimits::default();
        let bounds = SpeedBounds::from(&limits);
        let study = trailer_model::with_plant!(&plant, m => chart_nonlinear::compute(m, &cfg, &bounds, progress))?;
        // the task's summary, from the same public pieces its run uses
        let summary = chart_nonlinear::ChartNonlinearSummary {
            per_tau: study
                .delays
                .iter()
                .map(chart_nonlinear::DelayEntry::from)
                .collect(),
            ranges: chart_nonlinear::ResolvedRanges::from(&study.resolved),
        };
        Ok::<_, TaskError>((summary, study.delays))
    })?
    .map_err(py_err)?;
    let out = PyList::empty(py);
    for r in results {
        let d = PyDict::new(py);
        d.set_item("tau_s", r.chart.tau_s)?;
        let hopf = PyList::empty(py);
        for h in &r.chart.hopf_curves {
            let c = PyDict::new(py);
            let n = h.points.len();
            let (mut ds, mut vs, mut ws, mut sub) = (
                Vec::with_capacity(n),
                Vec::with_capacity(n),
                Vec::with_capacity(n),
                Vec::with_capacity(n),
            );
            for (i, p) in h.points.iter().enumerate() {
                ds.push(p.d_s);
                vs.push(p.v_mps);
                ws.push(p.omega_rad_s.abs());
                // 1 subcritical, 0 supercritical, NaN unknown (the CSV's empty cell)
                sub.push(h.criticality_at(i).map_or(f64::NAN, |c| {
                    f64::from(u8::from(c == continuation::Criticality::Subcritical))
                }));
            }
            c.set_item("seed_d_s", h.seed_d_s)?;
            c.set_item("d_s", ds.into_pyarray(py))?;
            c.set_item("v_mps", vs.into_pyarray(py))?;
            c.set_item("omega_rad_s", ws.into_pyarray(py))?;
            c.set_item("subcritical", sub.into_pyarray(py))?;
            hopf.append(c)?;
        }
        let folds = PyList::empty(py);
        for f in &r.chart.fold_curves {
            let c = PyDict::new(py);
            c.set_item("seed_d_s", f.seed_d_s)?;
            let col = |g: fn(&sway::bifurcation::chart::FoldCurvePoint) -> f64| -> Vec<f64> {
                f.points.iter().map(g).collect()
            };
            c.set_item("d_s", col(|p| p.d_s).into_pyarray(py))?;
            c.set_item("v_mps", col(|p| p.v_mps).into_pyarray(py))?;
            c.set_item("period_s", col(|p| p.period_s).into_pyarray(py))?;
            c.set_item("amplitude_deg", col(|p| p.amplitude_deg).into_pyarray(py))?;
            folds.append(c)?;
        }
        d.set_item("hopf_curves", hopf)?;
        d.set_item("fold_curves", folds)?;
        out.append(d)?;
    }
    Ok((to_json(&summary)?, out))
}

/// The settings of a closed-loop diagram: fig4b's `[continuation]` section under its key, as
/// the open loop's `[diagram]` section has it (messages name `continuation.<key>` either way).
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ClosedLoopSettings {
    continuation: DiagramSettings,
}

/// bifurcation_diagram(vehicle, gain, delay, settings) → (summary JSON, arrays or None):
/// the diagram of straight running and the sway cycles over V on the vehicle's plant.
/// Open loop (gain and delay None): the `fig3a` task's diagram
/// ([`sway_studies::fig3a::diagram`], what the task writes) on a dict of the `[diagram]`
/// section's shape; the summary is fig3a's diagram fields. Closed loop: one pair of the `fig4b` task
/// ([`closed_loop_diagram`]) on a dict `{"continuation": {…}}` of its `[continuation]`
/// section's shape (absent keys: fig4b's defaults); the summary is its `"pairs"` entry. Without a Hopf point the summary
/// says why and there are no arrays.
#[pyfunction]
#[pyo3(signature = (vehicle, gain, delay, settings, progress = None))]
fn bifurcation_diagram<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    gain: Option<f64>,
    delay: Option<f64>,
    settings: &Bound<'py, PyAny>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Option<Bound<'py, PyDict>>)> {
    let what = "bifurcation_diagram()";
    let (json, d) = match (gain, delay) {
        (Some(gain), Some(delay)) => {
            let file = Path::new(what);
            let check = |ok: bool, key: &str, problem: String| {
                sway::config::ensure(ok, file, key, || problem).map_err(py_err)
            };
            // fig4b's checks of a pair
            check(
                delay.is_finite() && delay >= 0.0,
                "controller.delay_s",
                format!("expected a delay τ ≥ 0 s, got {delay}"),
            )?;
            check(
                gain.is_finite() && gain.abs() <= 5.0,
                "controller.gain_s",
                format!("expected a finite gain |D| ≤ 5 s, got {gain}"),
            )?;
            let base = ClosedLoopSettings {
                continuation: DiagramSettings::closed_loop(),
            };
            let (ClosedLoopSettings { continuation: s }, file) =
                load_config_over(settings, what, &base)?;
            validate_settings(&s, &file, "continuation").map_err(py_err)?;
            let plant = vehicle.plant().clone();
            let fb = LoopLaw::paper(gain, delay);
            let pd = interruptible(py, 1.0, progress, move |progress| {
                progress.start("closed-loop diagram", 0);
                let limits = SpeedLimits::default();
                trailer_model::with_plant!(&plant, m => closed_loop_diagram(m, fb, &s, &limits, CycleExtent::WholeRange))
            })?
            .map_err(py_err)?;
            let json = to_json(&pd.summary(fb))?;
            let d = match pd {
                PairDiagram::Computed { diagram, .. } => Some(diagram),
                PairDiagram::NoHopf { .. } => None,
            };
            (json, d)
        }
        _ => {
            let (cfg, file): (DiagramConfig, PathBuf) = load_config(settings, what)?;
            // the keys as this function's arguments: `continuation.…`, `stable_speeds_mps`
            validate_diagram(&cfg, &file, "diagram").map_err(|e| {
                let python = |k: &str| k.strip_prefix("diagram.").unwrap_or(k).to_string();
                py_err(crate::renamed(e, what, python))
            })?;
            let plant = vehicle.plant().clone();
            let (summary, diagram) = interruptible(py, 1.0, progress, move |progress| {
                progress.start("bifurcation diagram", 0);
                let limits = SpeedLimits::default();
                let study = sway_studies::fig3a::diagram(&plant, &cfg, &limits)?;
                Ok::<_, sway::SwayError>((summary_fields(study.summary), study.diagram))
            })?
            .map_err(py_err)?;
            (to_json(&summary)?, diagram)
        }
    };
    let Some(d) = d else {
        return Ok((json, None));
    };
    let out = PyDict::new(py);
    // straight running: as equilibria.csv (V, stable, max Re λ)
    let eq = &d.equilibria.points;
    let v: Vec<f64> = eq.iter().map(|p| p.parameter).collect();
    let stable: Vec<bool> = eq.iter().map(|p| p.is_stable() == Some(true)).collect();
    let re: Vec<f64> = eq
        .iter()
        .map(|p| {
            p.stability
                .as_ref()
                .and_then(|s| s.values.first())
                .map_or(f64::NAN, |z| z.re)
        })
        .collect();
    let e = PyDict::new(py);
    e.set_item("v_mps", v.into_pyarray(py))?;
    e.set_item("stable", stable.into_pyarray(py))?;
    e.set_item("max_re_lambda_per_s", re.into_pyarray(py))?;
    out.set_item("equilibria", e)?;
    // the cycle branch: as cycles.csv
    let cs = &d.cycle_summary;
    let c = PyDict::new(py);
    let col =
        |g: fn(&sway::bifurcation::CycleSummary) -> f64| -> Vec<f64> { cs.iter().map(g).collect() };
    c.set_item("v_mps", col(|p| p.speed_mps).into_pyarray(py))?;
    c.set_item("amplitude_deg", col(|p| p.amplitude_deg).into_pyarray(py))?;
    c.set_item("period_s", col(|p| p.period_s).into_pyarray(py))?;
    c.set_item("max_multiplier", col(|p| p.max_multiplier).into_pyarray(py))?;
    let st: Vec<bool> = cs.iter().map(|p| p.stable).collect();
    c.set_item("stable", st.into_pyarray(py))?;
    out.set_item("cycles", c)?;
    Ok((json, Some(out)))
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(stability_chart, m)?)?;
    m.add_function(wrap_pyfunction!(nonlinear_chart, m)?)?;
    m.add_function(wrap_pyfunction!(bifurcation_diagram, m)?)?;
    Ok(())
}
