//! `detect`: recorded signals replayed through the sway detectors of `sway-detect`, one
//! frame per sample, as a controller would run them.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sway_detect::detector::{
    CounterOptions, DampingEstimator, DampingOptions, Detector, DetectorOutput, InputStatus,
    ModelObserver, ObserverEstimate, ObserverOptions, OscillationCounter,
};
use sway_detect::sensor::Measurement;

use crate::load_config;

/// A detector built by name, the observer apart: it also estimates (the hitch angle, the
/// trailer's parameters, V_crit), which `detect` returns per sample.
enum Built {
    Plain(Box<dyn Detector + Send>),
    Observer(Box<ModelObserver>),
}

impl Built {
    fn detector(&mut self) -> &mut dyn Detector {
        match self {
            Built::Plain(d) => d.as_mut(),
            Built::Observer(o) => o.as_mut(),
        }
    }

    fn update(&mut self, m: &Measurement) -> (DetectorOutput, Option<ObserverEstimate>) {
        match self {
            Built::Plain(d) => (d.update(m), None),
            Built::Observer(o) => (o.update(m), Some(o.estimate())),
        }
    }
}

/// The options of detector `what` from its dict (the TOML table's shape; `None`: the
/// defaults).
fn options_of<T: serde::de::DeserializeOwned + Default>(
    options: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> PyResult<T> {
    match options {
        Some(d) => Ok(load_config(d, what)?.0),
        None => Ok(T::default()),
    }
}

/// The detectors by the names of their tables and results, each built from its options.
fn build(name: &str, options: Option<&Bound<'_, PyAny>>) -> PyResult<Built> {
    let what = format!("detect(options['{name}'])");
    let bad = |e: sway_detect::ConfigError| PyValueError::new_err(format!("{what}: {e}"));
    Ok(match name {
        "oscillation_counter" => Built::Plain(Box::new(
            OscillationCounter::new(options_of::<CounterOptions>(options, &what)?).map_err(bad)?,
        )),
        "damping_estimator" => Built::Plain(Box::new(
            DampingEstimator::new(options_of::<DampingOptions>(options, &what)?).map_err(bad)?,
        )),
        "model_observer" => Built::Observer(Box::new(
            ModelObserver::new(options_of::<ObserverOptions>(options, &what)?).map_err(bad)?,
        )),
        other => {
            return Err(PyValueError::new_err(format!(
                "detectors: unknown detector {other:?}; expected one of {DETECTORS:?}"
            )));
        }
    })
}

/// Every detector `detect` runs, in the order of its results.
const DETECTORS: [&str; 3] = ["oscillation_counter", "damping_estimator", "model_observer"];

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
    /// the observer's estimates per sample, by name (empty for the other detectors)
    estimates: Vec<(&'static str, Vec<f64>)>,
}

/// The observer's estimates `detect` returns per sample, by their Python names: values
/// and standard deviations, NaN where there is none.
fn estimate_columns(e: &ObserverEstimate) -> [(&'static str, f64); 11] {
    let nan = f64::NAN;
    [
        ("hitch_angle", e.hitch_angle),
        ("hitch_angle_sd", e.hitch_angle_variance.sqrt()),
        ("hitch_rate", e.hitch_rate),
        ("hitch_rate_sd", e.hitch_rate_variance.sqrt()),
        ("trailer_mass", e.trailer_mass.value),
        ("trailer_mass_sd", e.trailer_mass.sd),
        ("trailer_yaw_inertia", e.trailer_yaw_inertia.value),
        ("trailer_cog", e.trailer_cog.value),
        ("v_crit_estimate_mps", e.v_crit_estimate_mps.unwrap_or(nan)),
        ("v_crit_sd_mps", e.v_crit_sd_mps.unwrap_or(nan)),
        ("sway_frequency_hz", e.sway_frequency_hz.unwrap_or(nan)),
    ]
}

/// detect(t, yaw_rate, lateral_acceleration, steering_wheel_angle, speed, hitch_angle,
/// detector, options) → dict of per-sample arrays (`flag`, `score`, `amplitude`,
/// `frequency_hz`, `damping_ratio` with NaN where the detector has no estimate, `status`),
/// the observer's `estimates` (a dict of per-sample arrays; empty for the others) and the
/// detector's `threshold`. Every signal has `t`'s length (NaN: not measured);
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
    let threshold = d.detector().threshold();
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
            let (out, estimate) = d.update(&m);
            if let Some(e) = estimate {
                let columns = estimate_columns(&e);
                if tr.estimates.is_empty() {
                    tr.estimates = columns
                        .iter()
                        .map(|&(n, _)| (n, Vec::with_capacity(t.len())))
                        .collect();
                }
                for ((_, col), (_, x)) in tr.estimates.iter_mut().zip(columns) {
                    col.push(x);
                }
            }
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
    r.set_item("name", d.detector().name())?;
    r.set_item("threshold", threshold)?;
    r.set_item("flag", trace.flag.into_pyarray(py))?;
    r.set_item("score", trace.score.into_pyarray(py))?;
    r.set_item("amplitude", trace.amplitude.into_pyarray(py))?;
    r.set_item("frequency_hz", trace.frequency_hz.into_pyarray(py))?;
    r.set_item("damping_ratio", trace.damping_ratio.into_pyarray(py))?;
    r.set_item("status", trace.status)?;
    let estimates = PyDict::new(py);
    for (name, col) in trace.estimates {
        estimates.set_item(name, col.into_pyarray(py))?;
    }
    r.set_item("estimates", estimates)?;
    Ok(r)
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(detect, m)?)?;
    m.add("DETECTORS", DETECTORS.to_vec())?;
    Ok(())
}
