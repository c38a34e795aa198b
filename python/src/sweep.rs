//! `sweep`: a study of `cargo xtask sweep FILE.toml` (a file path or a dict of its shape),
//! validated and planned as the task does, its grid points computed in parallel on rayon
//! ([`sway_studies::sweep::Sweep::run_point`], the task's own point function: the same
//! numbers whatever the thread count), checking a cancellation flag between points.
//! Returned as columns in the order of the task's `sweep.csv` header.

use std::path::PathBuf;

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rayon::prelude::*;
use serde_json::Value;
use sway::ranging::SpeedSpec;
use sway_studies::sweep::{AxisParameter, PointOutput, PointResult, SweepConfig};
use sway_tasks::TaskError;
use sway_tasks::config_file::{Configured, TaskConfig};
use sway_tasks::tasks::Prepared;
use sway_tasks::tasks::sweep::{header, prepare_run};

use crate::{Vehicle, interruptible, load_config, py_err};

/// The result fields of the kinds that are text (enums and reasons: `outcome`, `class`, …
/// of a simulation's metrics, `criticality` and `reason` of the Hopf and fold speeds); every
/// other result field is a number or null.
const TEXT_COLUMNS: [&str; 5] = [
    "outcome",
    "loss_of_control_condition",
    "class",
    "criticality",
    "reason",
];

/// A column: numbers (null → NaN) or text (null → None).
enum Column {
    Numbers(Vec<f64>),
    Text(Vec<Option<String>>),
}

/// The leaves of a JSON value under the names `sweep.csv` gives them
/// ([`sway_tasks::io::row_cells`]: an object's fields by their own names, an array's
/// entries as the key followed by the index).
fn leaves(key: &str, v: Value, out: &mut serde_json::Map<String, Value>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                leaves(&k, x, out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.into_iter().enumerate() {
                leaves(&format!("{key}{i}"), x, out);
            }
        }
        leaf => {
            out.insert(key.to_string(), leaf);
        }
    }
}

/// The result fields of a point by the names of `sweep.csv`'s columns; None for a point
/// the CSV writes as failed.
fn output_fields(r: &PointResult) -> Option<serde_json::Map<String, Value>> {
    let v = match &r.output {
        Ok(PointOutput::Simulation(m)) => serde_json::to_value(m),
        Ok(PointOutput::LinearCriticalSpeed(l)) => serde_json::to_value(l),
        Ok(PointOutput::HopfFoldSpeeds(h)) => serde_json::to_value(h),
        _ => return None,
    };
    let mut out = serde_json::Map::new();
    leaves("", v.ok()?, &mut out);
    (!out.is_empty()).then_some(out)
}

/// sweep(vehicle, config) → (name, kind, columns, column names): the grid points of the
/// study, one entry per `sweep.csv` row.
#[pyfunction]
#[pyo3(signature = (vehicle, config, progress = None))]
fn sweep<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    config: &Bound<'py, PyAny>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, String, Bound<'py, PyDict>, Bound<'py, PyList>)> {
    let (mut spec, file): (SweepConfig<SpeedSpec>, PathBuf) = load_config(config, "sweep(config)")?;
    spec.load_named_files(&file).map_err(py_err)?;
    spec.check(&file).map_err(py_err)?;
    let prepared = Configured { file, config: spec };
    let plan = prepared.plan().map_err(py_err)?;
    let (file, spec) = (prepared.file, prepared.config);
    // the task's context for the vehicle (no files are read or written through it), with
    // the CLI's default limits
    let ctx = vehicle.context(&sway::progress::NoProgress);
    let run = prepare_run(&ctx, &spec, &file).map_err(py_err)?;
    let (cfg, sw) = match (run.resolution.outcome, run.sweep) {
        (Ok(cfg), Some(sw)) => (cfg, sw),
        (Err(u), _) => {
            return Err(py_err(TaskError::config(
                &file,
                u.key,
                format!("no sweep for this vehicle: {}", u.reason),
            )));
        }
        (Ok(_), None) => {
            return Err(py_err(TaskError::config(
                &file,
                "<root>",
                "no sweep points",
            )));
        }
    };
    let results = interruptible(py, plan.time_s, progress, move |progress| {
        let n = sw.grid_len();
        progress.start("sweep points", n as u64);
        let r: Vec<PointResult> = (0..n)
            .into_par_iter()
            .map(|k| {
                // a cancelled sweep stops before its next point
                cancel::checkpoint();
                let point = sw.run_point(k);
                progress.advance(1);
                point
            })
            .collect();
        progress.finish();
        r
    })?;

    let names = header(&cfg);
    let n_values = results.first().map_or(0, |r| r.values.len());
    let n = results.len();
    let mut columns: Vec<Column> = Vec::with_capacity(names.len());
    // the axis values (a fleet axis: the vehicle file) and the sampled fields
    for i in 0..n_values.min(names.len()) {
        match cfg.axes.get(i) {
            Some(a) if a.parameter == AxisParameter::VehicleFile => {
                columns.push(Column::Text(
                    results
                        .iter()
                        .map(|r| {
                            a.files
                                .get(r.values[i] as usize)
                                .map(|f| f.display().to_string())
                        })
                        .collect(),
                ));
            }
            _ => columns.push(Column::Numbers(
                results.iter().map(|r| r.values[i]).collect(),
            )),
        }
    }
    // the kind's result fields: failed points as the CSV writes them (outcome "error",
    // class "failed", the rest empty)
    let fields: Vec<Option<serde_json::Map<String, Value>>> =
        results.iter().map(output_fields).collect();
    let result_names = &names[n_values.min(names.len())..names.len().saturating_sub(2)];
    for name in result_names {
        let values: Vec<Value> = fields
            .iter()
            .map(|f| match f {
                Some(m) => m.get(name).cloned().unwrap_or(Value::Null),
                None => match name.as_str() {
                    "outcome" => Value::String("error".into()),
                    "class" => Value::String("failed".into()),
                    _ => Value::Null,
                },
            })
            .collect();
        // numbers by the column's type, not its values: a column of numbers that are all
        // absent (no loss of control: no `loss_of_control_time_s`) is still float64 NaN
        let numeric = !TEXT_COLUMNS.contains(&name.as_str())
            && values.iter().all(|v| v.is_number() || v.is_null());
        columns.push(if numeric {
            Column::Numbers(
                values
                    .iter()
                    .map(|v| v.as_f64().unwrap_or(f64::NAN))
                    .collect(),
            )
        } else {
            Column::Text(
                values
                    .iter()
                    .map(|v| match v {
                        Value::Null => None,
                        Value::String(s) => Some(s.clone()),
                        other => Some(other.to_string()),
                    })
                    .collect(),
            )
        });
    }
    // a failed point: 0 steps and its message on one line, as the CSV writes them
    let steps: Vec<i64> = results
        .iter()
        .zip(&fields)
        .map(|(r, f)| if f.is_some() { r.steps as i64 } else { 0 })
        .collect();
    let errors: Vec<Option<String>> = results
        .iter()
        .zip(&fields)
        .map(|(r, f)| match (&r.output, f) {
            (_, Some(_)) => None,
            (Err(e), None) => Some(e.replace(['\n', '\r'], " ")),
            (Ok(_), None) => Some("unexpected point output".into()),
        })
        .collect();

    let d = PyDict::new(py);
    let order = PyList::empty(py);
    for (name, col) in names.iter().zip(columns) {
        match col {
            Column::Numbers(v) => d.set_item(name, v.into_pyarray(py))?,
            Column::Text(v) => d.set_item(name, v)?,
        }
        order.append(name)?;
    }
    debug_assert_eq!(steps.len(), n);
    d.set_item("accepted_steps", steps.into_pyarray(py))?;
    d.set_item("error", errors)?;
    order.append("accepted_steps")?;
    order.append("error")?;
    Ok((cfg.name.clone(), cfg.kind.as_str().to_string(), d, order))
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    Ok(())
}
