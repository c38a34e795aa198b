//! The lateral stability test: `lateral_stability` (the task on the model) and
//! `analyse_recording` (one recorded run), as `cargo xtask lateral_stability` and its
//! `--recording` analysis compute them.

use std::path::PathBuf;

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use sway::ranging::SpeedLimits;
use sway_studies::lateral_stability::{
    LateralStabilityConfig, RecordingAnalysis, RecordingProblem, RecordingSettings,
    analyse_recording as analyse, compute,
};
use sway_tasks::TaskError;
use sway_tasks::config_file::{Configured, TaskConfig};
use sway_tasks::tasks::Prepared;
use sway_tasks::tasks::lateral_stability::summary;

use crate::{Vehicle, interruptible, load_config, py_err};

/// (t, y) pairs as an n × 2 array.
fn pairs<'py>(py: Python<'py>, points: &[(f64, f64)]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = points.iter().flat_map(|&(a, b)| [a, b]).collect();
    Ok(flat.into_pyarray(py).reshape([points.len(), 2])?.into_any())
}

/// lateral_stability(vehicle, config) → (summary JSON, arrays): the task on a config dict
/// of `configs/lateral_stability.toml`'s shape; the arrays are the local damping points
/// (amplitude \[deg\], D) per test speed and the trace of one run.
#[pyfunction]
#[pyo3(signature = (vehicle, config, progress = None))]
pub(crate) fn lateral_stability<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    config: &Bound<'py, PyAny>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Bound<'py, PyDict>)> {
    let (mut cfg, file): (LateralStabilityConfig, PathBuf) =
        load_config(config, "lateral_stability()")?;
    cfg.load_named_files(&file).map_err(py_err)?;
    cfg.check(&file).map_err(py_err)?;
    let prepared = Configured { file, config: cfg };
    let plan = prepared.plan().map_err(py_err)?;
    let cfg = prepared.config;
    let plant = vehicle.plant().clone();
    let (json, r) = interruptible(py, plan.time_s, progress, move |progress| {
        let r = compute(&cfg, &plant, &SpeedLimits::default(), progress)?;
        let json = serde_json::to_string(&summary(&cfg, &r))
            .map_err(|e| TaskError::numerical("serialising the summary", e))?;
        Ok::<_, TaskError>((json, r))
    })?
    .map_err(py_err)?;
    let arrays = PyDict::new(py);
    let local = PyList::empty(py);
    for row in &r.speeds {
        local.append(pairs(py, &row.local_damping)?)?;
    }
    arrays.set_item("local_damping", local)?;
    if let Some(t) = &r.trace {
        let trace = PyDict::new(py);
        trace.set_item("speed_mps", t.speed_mps)?;
        trace.set_item("signal", t.signal.as_str())?;
        trace.set_item("values", pairs(py, &t.values)?)?;
        trace.set_item("steering_deg", pairs(py, &t.steering_deg)?)?;
        trace.set_item("peaks_used", pairs(py, &t.peaks_used)?)?;
        arrays.set_item("trace", trace)?;
    }
    let fit = PyDict::new(py);
    if let Some(f) = &r.fit {
        fit.set_item("coefficients", f.coefficients.clone().into_pyarray(py))?;
    }
    arrays.set_item("fit", fit)?;
    Ok((json, arrays))
}

/// A recording's problem with the samples named as `analyse_recording()`'s arguments: `t`,
/// `signals['steering_angle']` and `signal_name` (the read signal's key, e.g.
/// `signals['hitch_angle']`), rows counted from 0.
fn in_python_terms(problem: &RecordingProblem, signal_name: &str) -> String {
    let steering = "signals['steering_angle']";
    match problem {
        RecordingProblem::TooShort { lengths: [t, s, y] } => format!(
            "expected at least 10 samples of t, {steering} and {signal_name} of equal length, got {t}, {s} and {y}"
        ),
        RecordingProblem::TimeNotIncreasing { row, t, previous } => {
            format!("row {row}: t does not increase ({t} s after {previous} s)")
        }
        RecordingProblem::NotFinite { column, row } => {
            let name = match *column {
                "time" => "t",
                "steering" => steering,
                _ => signal_name,
            };
            format!("row {row}: {name} is not a finite number")
        }
        other => other.to_string(),
    }
}

/// analyse_recording(t, steering, signal, signal_name, skip_peaks, periods,
/// impulse_fraction, low_pass_hz, prominence_fraction) → dict: one recorded run read as the
/// task reads a `--recording` file. A bad recording raises `ValueError` with the problem
/// (rows from 0), the samples named as the Python arguments ([`in_python_terms`]).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub(crate) fn analyse_recording<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    steering: PyReadonlyArray1<'py, f64>,
    signal: PyReadonlyArray1<'py, f64>,
    signal_name: &str,
    skip_peaks: usize,
    periods: usize,
    impulse_fraction: f64,
    low_pass_hz: f64,
    prominence_fraction: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let how = RecordingAnalysis {
        settings: RecordingSettings {
            impulse_fraction,
            low_pass_hz,
            prominence_fraction,
        },
        skip_peaks,
        periods,
    };
    let (t, steering, signal) = (t.as_slice()?, steering.as_slice()?, signal.as_slice()?);
    let r = analyse(t, steering, signal, &how)
        .map_err(|e| PyValueError::new_err(in_python_terms(&e, signal_name)))?;
    let d = PyDict::new(py);
    d.set_item("damping_ratio", r.decay.damping_ratio)?;
    d.set_item("log_decrement", r.decay.log_decrement)?;
    d.set_item("frequency_hz", r.decay.frequency_hz)?;
    d.set_item("periods_used", r.decay.periods_used)?;
    d.set_item("impulse_s", r.impulse_s)?;
    d.set_item("peaks_used", pairs(py, &r.peaks_used)?)?;
    d.set_item("filtered", r.filtered.into_pyarray(py))?;
    Ok(d)
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(lateral_stability, m)?)?;
    m.add_function(wrap_pyfunction!(analyse_recording, m)?)?;
    Ok(())
}
