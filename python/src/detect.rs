//! `detect`: recorded signals replayed through the sway detectors of `sway-detect`, one
//! frame per sample, as a controller would run them.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sway_detect::detector::{
    CounterOptions, DampingEstimator, DampingOptions, Detector, InputStatus, OscillationCounter,
};
use sway_detect::sensor::Measurement;

use crate::load_config;

/// The detectors by the names of their tables and results, each built from its options
/// dict (the TOML table's shape; `None`: the defaults).
fn build(name: &str, options: Option<&Bound<'_, PyAny>>) -> PyResult<Box<dyn Detector + Send>> {
    let what = format!("detect(options['{name}'])");
    let bad = |e: sway_detect::ConfigError| PyValueError::new_err(format!("{what}: {e}"));
    match name {
        "oscillation_counter" => {
            let o: CounterOptions = match options {
                Some(d) => load_config(d, &what)?.0,
                None => CounterOptions::default(),
            };
            Ok(Box::new(OscillationCounter::new(o).map_err(bad)?))
        }
        "damping_estimator" => {
            let o: DampingOptions = match options {
                Some(d) => load_config(d, &what)?.0,
                None => DampingOptions::default(),
            };
            Ok(Box::new(DampingEstimator::new(o).map_err(bad)?))
        }
        other => Err(PyValueError::new_err(format!(
            "detectors: unknown detector {other:?}; expected one of {DETECTORS:?}"
        ))),
    }
}

/// Every detector `detect` runs, in the order of its results.
const DETECTORS: [&str; 2] = ["oscillation_counter", "damping_estimator"];

/// The status of one sample as the Python result names it.
fn status_name(s: InputStatus) -> &'static str {
    match s {
        InputStatus::Ok => "ok",
        InputStatus::Invalid => "invalid",
        InputStatus::OutOfOrder { .. } => "out_of_order",
        InputStatus::Gap { .. } => "gap",
    }
}

/// One detector's outputs over a recording, per sample.
#[derive(Default)]
struct Trace {
    flag: Vec<bool>,
    score: Vec<f64>,
    amplitude: Vec<f64>,
    frequency_hz: Vec<f64>,
    damping_ratio: Vec<f64>,
    status: Vec<&'static str>,
}

/// detect(t, yaw_rate, lateral_acceleration, steering_wheel_angle, speed, hitch_angle,
/// detector, options) → dict of per-sample arrays (`flag`, `score`, `amplitude`,
/// `frequency_hz`, `damping_ratio` with NaN where the detector has no estimate, `status`)
/// and the detector's `threshold`. Every signal has `t`'s length (NaN: not measured);
/// `hitch_angle` None without a hitch-angle sensor.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (t, yaw_rate, lateral_acceleration, steering_wheel_angle, speed, hitch_angle, detector, options=None))]
pub(crate) fn detect<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    yaw_rate: PyReadonlyArray1<'py, f64>,
    lateral_acceleration: PyReadonlyArray1<'py, f64>,
    steering_wheel_angle: PyReadonlyArray1<'py, f64>,
    speed: PyReadonlyArray1<'py, f64>,
    hitch_angle: Option<PyReadonlyArray1<'py, f64>>,
    detector: &str,
    options: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut d = build(detector, options.as_ref())?;
    let t = t.as_slice()?;
    let signals = [
        yaw_rate.as_slice()?,
        lateral_acceleration.as_slice()?,
        steering_wheel_angle.as_slice()?,
        speed.as_slice()?,
    ];
    let hitch = hitch_angle.as_ref().map(|h| h.as_slice()).transpose()?;
    if let Some(n) = signals
        .iter()
        .map(|s| s.len())
        .chain(hitch.map(<[f64]>::len))
        .find(|&n| n != t.len())
    {
        return Err(PyValueError::new_err(format!(
            "detect(): a signal has {n} samples, t has {}",
            t.len()
        )));
    }
    let threshold = d.threshold();
    let trace = py.detach(|| {
        let mut tr = Trace::default();
        for (k, &tk) in t.iter().enumerate() {
            let m = Measurement {
                yaw_rate: signals[0][k],
                lateral_acceleration: signals[1][k],
                steering_wheel_angle: signals[2][k],
                speed: signals[3][k],
                hitch_angle: hitch.map(|h| h[k]),
                ..Measurement::at(tk)
            };
            let out = d.update(&m);
            tr.flag.push(out.flag.is_sway());
            tr.score.push(out.score);
            tr.amplitude.push(out.amplitude.unwrap_or(f64::NAN));
            tr.frequency_hz.push(out.frequency_hz.unwrap_or(f64::NAN));
            tr.damping_ratio.push(out.damping_ratio.unwrap_or(f64::NAN));
            tr.status.push(status_name(out.status));
        }
        tr
    });
    let r = PyDict::new(py);
    r.set_item("name", d.name())?;
    r.set_item("threshold", threshold)?;
    r.set_item("flag", trace.flag.into_pyarray(py))?;
    r.set_item("score", trace.score.into_pyarray(py))?;
    r.set_item("amplitude", trace.amplitude.into_pyarray(py))?;
    r.set_item("frequency_hz", trace.frequency_hz.into_pyarray(py))?;
    r.set_item("damping_ratio", trace.damping_ratio.into_pyarray(py))?;
    r.set_item("status", trace.status)?;
    Ok(r)
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(detect, m)?)?;
    m.add("DETECTORS", DETECTORS.to_vec())?;
    Ok(())
}
