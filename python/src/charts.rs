//! The chart and diagram pipelines: `stability_chart` (the `fig4a` task), `nonlinear_chart`
//! (`chart_nonlinear`) and `bifurcation_diagram` (the diagrams of `fig3a` and `fig4b`).
//! Each reads its settings into the task's config type, validates them with the task's
//! checks and limits, runs the task's computation and returns its summary as JSON (the
//! fields of the task's `summary.json`) beside the curves and grids as numpy arrays.

use std::path::{Path, PathBuf};

use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde::Serialize;
use sway::SwayError;
use sway::bifurcation::chart::{ChartOptions, critical_speeds};
use sway::bifurcation::{Diagram, DiagramOptions, Feedback, bifurcation_diagram as diagram};
use sway_tasks::config_file::{Configured, TaskConfig};
use sway_tasks::tasks::Prepared;
use sway_tasks::tasks::chart_nonlinear::{self, ChartNonlinearConfig};
use sway_tasks::tasks::fig4a::{self, Fig4aConfig};

use sway::charts::auto_range::SpeedBounds;
use sway::ranging::SpeedLimits;
use sway_tasks::TaskError;
use trailer_model::AnyVehicleModel;

use crate::{Vehicle, interruptible, load_config, py_err, to_json};

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
fn stability_chart<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    config: &Bound<'py, PyAny>,
) -> PyResult<(String, Bound<'py, PyList>)> {
    let (cfg, file): (Fig4aConfig, PathBuf) = load_config(config, "stability_chart()")?;
    cfg.check(&file).map_err(py_err)?;
    let prepared = Configured { file, config: cfg };
    let plan = prepared.plan().map_err(py_err)?;
    let cfg = prepared.config;
    // the CLI's plant of a paper-form vehicle and its default speed limits (--max-speed)
    let plant = AnyVehicleModel::Paper(vehicle.model.clone());
    let (charts, summary) = interruptible(py, plan.time_s, None, move || {
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
fn nonlinear_chart<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    config: &Bound<'py, PyAny>,
) -> PyResult<(String, Bound<'py, PyList>)> {
    let (cfg, file): (ChartNonlinearConfig, PathBuf) = load_config(config, "nonlinear_chart()")?;
    cfg.check(&file).map_err(py_err)?;
    let prepared = Configured { file, config: cfg };
    let plan = prepared.plan().map_err(py_err)?;
    let cfg = prepared.config;
    let model = vehicle.model.clone();
    let (summary, results) = interruptible(py, plan.time_s, None, move || {
        let limits = SpeedLimits::default();
        let study = chart_nonlinear::compute(
            &model,
            &cfg,
            &SpeedBounds::from(&limits),
            &sway::progress::NoProgress,
        )?;
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

/// The diagram's own numbers (the fields of fig3a's diagram summary that need no extra
/// continuation).
#[derive(Debug, Serialize)]
struct DiagramNumbers {
    hopf_v_mps: f64,
    hopf_omega_rad_s: f64,
    hopf_period_s: f64,
    criticality: String,
    fold_v_mps: Option<f64>,
    fold_amplitude_deg: Option<f64>,
    fold_period_s: Option<f64>,
    bistable_range_mps: Option<[f64; 2]>,
    cycle_points: usize,
}

/// The corrected Hopf and fold speeds, as fig4b's `"pairs"` entries.
#[derive(Debug, Serialize)]
struct Corrected {
    hopf_v_mps: f64,
    hopf_omega_rad_s: f64,
    criticality: String,
    fold_v_mps: Option<f64>,
    fold_amplitude_deg: Option<f64>,
    fold_period_s: Option<f64>,
    bistable_range_mps: Option<[f64; 2]>,
}

#[derive(Debug, Serialize)]
struct DiagramJson {
    diagram: DiagramNumbers,
    corrected: Option<Corrected>,
}

fn numbers(d: &Diagram) -> DiagramNumbers {
    let fold = d.fold;
    DiagramNumbers {
        hopf_v_mps: d.hopf.parameter,
        hopf_omega_rad_s: d.hopf.omega,
        hopf_period_s: 2.0 * std::f64::consts::PI / d.hopf.omega,
        criticality: d.criticality.to_string(),
        fold_v_mps: fold.map(|f| f.speed_mps),
        fold_amplitude_deg: fold.map(|f| f.amplitude_deg),
        fold_period_s: fold.map(|f| f.period_s),
        bistable_range_mps: d.bistable_range().map(|(a, b)| [a, b]),
        cycle_points: d.cycle_summary.len(),
    }
}

/// bifurcation_diagram(vehicle, gain, delay, continuation, correct) → (JSON, arrays): the
/// diagram of straight running and the sway cycles over V (fig3a's open loop, fig4b's
/// pairs), with `correct` the Hopf and fold speeds corrected as fig4b reports them.
#[pyfunction]
#[pyo3(signature = (vehicle, gain, delay, continuation, correct))]
fn bifurcation_diagram<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    gain: f64,
    delay: f64,
    continuation: &Bound<'py, PyAny>,
    correct: bool,
) -> PyResult<(String, Bound<'py, PyDict>)> {
    let what = "bifurcation_diagram()";
    let (options, file): (DiagramOptions, PathBuf) = load_config(continuation, what)?;
    sway_tasks::tasks::fig3a_diagram::validate_options(&options, &file, "continuation")
        .map_err(py_err)?;
    let check = |ok: bool, key: &str, problem: String| {
        sway::config::ensure(ok, Path::new(what), key, || problem).map_err(py_err)
    };
    check(
        gain.is_finite(),
        "controller.gain_s",
        format!("expected a finite gain [s], got {gain}"),
    )?;
    check(
        delay.is_finite() && delay >= 0.0,
        "controller.delay_s",
        format!("expected a delay ≥ 0 s, got {delay}"),
    )?;
    let model = vehicle.model.clone();
    let fb = Feedback {
        gain_d_s: gain,
        delay_s: delay,
    };
    let (d, corrected) = interruptible(py, 1.0, None, move || {
        let d = diagram(&model, fb, &options)?;
        let corrected = if correct {
            let cs = critical_speeds(&model, &d, &ChartOptions::correcting(&options))?;
            let fold = cs.fold;
            Some(Corrected {
                hopf_v_mps: cs.hopf_v_mps,
                hopf_omega_rad_s: cs.hopf_omega_rad_s,
                criticality: cs.criticality.to_string(),
                fold_v_mps: fold.map(|f| f.v_mps),
                fold_amplitude_deg: fold.map(|f| f.amplitude_deg),
                fold_period_s: fold.map(|f| f.period_s),
                bistable_range_mps: match (cs.criticality, fold) {
                    (continuation::Criticality::Subcritical, Some(f)) => {
                        Some([f.v_mps, cs.hopf_v_mps])
                    }
                    _ => None,
                },
            })
        } else {
            None
        };
        Ok::<_, SwayError>((d, corrected))
    })?
    .map_err(py_err)?;
    let json = to_json(&DiagramJson {
        diagram: numbers(&d),
        corrected,
    })?;
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
    Ok((json, out))
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(stability_chart, m)?)?;
    m.add_function(wrap_pyfunction!(nonlinear_chart, m)?)?;
    m.add_function(wrap_pyfunction!(bifurcation_diagram, m)?)?;
    Ok(())
}
