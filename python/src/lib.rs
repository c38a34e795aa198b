//! `trailer_sway._native`: the Python bindings of the trailer-sway crates (PyO3).
//!
//! A thin layer: every function reads its inputs into the task layer's config types
//! ([`sway_tasks`]), validates them with the task's own checks and limits (a bad value
//! raises `ValueError`, a value of the wrong type `TypeError`, with the problem `cargo
//! xtask` states, naming the Python argument or dict key), computes with the library
//! ([`sway`], [`trailer_model`], [`stability`]) with the GIL released, and returns plain
//! Python values: numpy arrays built from owned `Vec`s (no second copy), and the
//! structured results as the JSON the tasks write to `summary.json` (same numbers, bit for
//! bit). The Python package `trailer_sway` wraps these in typed result classes.
//!
//! Interrupts and progress: a call whose estimated cost is small runs on the calling
//! thread; a longer one runs on a worker thread (and a thread pool made for the call)
//! while the calling thread polls Python's signal handlers and reports progress
//! (`interruptible`). Ctrl-C cancels the call's `cancel::CancelToken`, every engine stops
//! at its next checkpoint, and `KeyboardInterrupt` is raised once the call's threads have
//! stopped: nothing keeps computing in the background.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use cancel::CancelToken;
use std::time::Duration;
use sway::progress::{NoProgress, Progress};

use numpy::{IntoPyArray, PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde::Serialize;
use serde::de::DeserializeOwned;
use sway::SwayError;
use sway_tasks::TaskError;
mod charts;
mod detect;
mod lateral;
mod sweep;

use sway::control::LoopModel;
use sway::ranging::SpeedLimits;
use sway_studies::linear::SearchConfig;
use sway_studies::roots::RootsConfig;
use sway_tasks::config_file::LoadedVehicle;
use sway_tasks::tasks::TaskContext;
use trailer_model::{AnyVehicleModel, Model, ModelError, PARAMETERS, VehicleParams, VehicleSpec};

// ---------------------------------------------------------------------------------------
// errors

/// The Python exception of a library error: `OSError` for an unreadable file,
/// `ValueError` for a bad config or vehicle, or a task that does not apply to the vehicle
/// (the CLI's message), `RuntimeError` for a
/// numerical failure.
pub(crate) fn py_err(e: impl Into<TaskError>) -> PyErr {
    let e: TaskError = e.into();
    exception(&e)(e.to_string())
}

/// The constructor of the Python exception of `e` (see [`py_err`]).
fn exception(e: &TaskError) -> fn(String) -> PyErr {
    match e {
        TaskError::Read { .. } => |m| PyOSError::new_err(m),
        TaskError::Config { .. }
        | TaskError::UnknownTask { .. }
        | TaskError::NotApplicable { .. }
        | TaskError::Sway(SwayError::Config { .. } | SwayError::Model(_)) => {
            |m| PyValueError::new_err(m)
        }
        _ => |m| PyRuntimeError::new_err(m),
    }
}

/// The Python exception of a config dict's error: `TypeError` for a value of the wrong
/// type (the reader's "invalid type: string \"60\", expected f64"), else [`py_err`]'s;
/// an unknown key is named by its own path (`speeed`, `continuation.mesh`), also where the
/// reader names the table that holds it (`<root>` of a table with flattened keys).
fn dict_err(e: TaskError) -> PyErr {
    let Some((file, key, problem)) = e.as_config() else {
        return py_err(e);
    };
    let unknown = problem
        .strip_prefix("unknown field `")
        .and_then(|rest| rest.split_once('`'))
        .map(|(name, _)| match key {
            "<root>" => name.to_string(),
            k if k == name || k.ends_with(&format!(".{name}")) => k.to_string(),
            table => format!("{table}.{name}"),
        });
    let e = match unknown {
        Some(path) => TaskError::config(file, path, problem),
        None => e,
    };
    match e.as_config() {
        Some((_, _, problem)) if problem.starts_with("invalid type") => {
            PyTypeError::new_err(e.to_string())
        }
        _ => py_err(e),
    }
}

/// A config error in the caller's terms: under the name `file` (the Python call, e.g.
/// `roots()`), its key renamed by `key` (a command-line option or a vehicle file's key
/// path as the Python argument); other errors unchanged.
pub(crate) fn renamed(
    e: impl Into<TaskError>,
    file: &str,
    key: impl Fn(&str) -> String,
) -> TaskError {
    let e: TaskError = e.into();
    match e.as_config() {
        Some((_, k, problem)) => TaskError::config(file, key(k), problem),
        None => e,
    }
}

fn json_err(e: serde_json::Error) -> PyErr {
    PyRuntimeError::new_err(format!("internal: cannot serialise a result: {e}"))
}

/// A result as JSON text (the package parses it with `json.loads`).
pub(crate) fn to_json<T: Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(json_err)
}

// ---------------------------------------------------------------------------------------
// configs from Python values

/// A Python value (dict, list, tuple, str, bool, int, float, numpy scalar or array) as
/// TOML; `what` (the call and argument) and `key` name it in a `TypeError`. None is not a
/// value: a key takes its default when it is left out, not when it is None.
fn toml_value(obj: &Bound<'_, PyAny>, what: &str, key: &str) -> PyResult<toml::Value> {
    let name = || {
        if key.is_empty() {
            "<root>".to_string()
        } else {
            key.to_string()
        }
    };
    if obj.is_none() {
        return Err(PyTypeError::new_err(format!(
            "{what}: `{}`: expected a value, got None (leave the key out for its default)",
            name()
        )));
    }
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        return match obj.extract::<i64>() {
            Ok(i) => Ok(toml::Value::Integer(i)),
            Err(_) => Err(PyValueError::new_err(format!(
                "{what}: `{}`: integer {} out of range",
                name(),
                obj.str()?
            ))),
        };
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(obj.extract()?));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, v) in d.iter() {
            let k: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!("{what}: `{}`: dict keys must be str", name()))
            })?;
            let sub = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            t.insert(k, toml_value(&v, what, &sub)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = obj.try_iter()?.collect::<PyResult<_>>()?;
        let mut a = Vec::with_capacity(items.len());
        for (i, v) in items.iter().enumerate() {
            a.push(toml_value(v, what, &format!("{}[{i}]", name()))?);
        }
        return Ok(toml::Value::Array(a));
    }
    if obj.hasattr("__fspath__")? {
        let p: PathBuf = obj.extract()?;
        return Ok(toml::Value::String(p.display().to_string()));
    }
    // numpy scalars and arrays
    if obj.hasattr("tolist")? {
        return toml_value(&obj.call_method0("tolist")?, what, key);
    }
    if let Ok(x) = obj.extract::<f64>() {
        return Ok(toml::Value::Float(x));
    }
    Err(PyTypeError::new_err(format!(
        "{what}: `{}`: unsupported type {} (expected dict, list, str, bool, int or float)",
        name(),
        obj.get_type().name()?
    )))
}

/// A config given as a TOML file path (str or os.PathLike) or as a dict in the file's
/// shape; `what` names the call and argument in messages (`simulate(scenario)`). Returns
/// the config and the file name its messages use. Both go through the CLI's reader
/// (`parse_toml`: unknown keys, wrong types, key paths, size limits).
pub(crate) fn load_config<T: DeserializeOwned>(
    obj: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<(T, PathBuf)> {
    if obj.is_instance_of::<PyString>() || obj.hasattr("__fspath__")? {
        let file = config_path(
            obj,
            what,
            "pass a dict of the file's shape (tomllib.loads(text) reads TOML text) or the path of a TOML file",
        )?;
        let cfg = sway_tasks::config_file::load_toml(&file).map_err(py_err)?;
        return Ok((cfg, file));
    }
    if !obj.is_instance_of::<PyDict>() {
        return Err(PyTypeError::new_err(format!(
            "{what}: expected a dict in the TOML file's shape or a path to a TOML file, got {}",
            obj.get_type().name()?
        )));
    }
    let file = PathBuf::from(what);
    let cfg =
        sway_tasks::config_file::parse_table(document(obj, what)?, &file).map_err(dict_err)?;
    Ok((cfg, file))
}

/// The path a str or os.PathLike names; a str that is no file but looks like TOML text (a
/// line break, `key = value` or a `[table]`) is a `ValueError` with `hint`.
fn config_path(obj: &Bound<'_, PyAny>, what: &str, hint: &str) -> PyResult<PathBuf> {
    let file: PathBuf = obj.extract()?;
    let text = file.to_string_lossy();
    let looks_like_toml =
        text.contains('\n') || text.contains('=') || text.trim_start().starts_with('[');
    if looks_like_toml && !file.exists() {
        let first = text.lines().next().unwrap_or_default();
        return Err(PyValueError::new_err(format!(
            "{what}: \"{first}…\" looks like TOML text, not a path: {hint}"
        )));
    }
    Ok(file)
}

/// The TOML document of a config dict (its keys strings, its values TOML's types).
fn document(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<toml::Table> {
    match toml_value(obj, what, "")? {
        toml::Value::Table(t) => Ok(t),
        _ => Err(PyTypeError::new_err(format!("{what}: expected a dict"))),
    }
}

/// [`load_config`] of a dict whose absent keys take their values from `base` (a section
/// whose defaults differ from its type's `Default`, e.g. fig4b's `[continuation]`): the
/// dict's keys replace `base`'s, table by table.
pub(crate) fn load_config_over<T: Serialize + DeserializeOwned>(
    obj: &Bound<'_, PyAny>,
    what: &str,
    base: &T,
) -> PyResult<(T, PathBuf)> {
    if !obj.is_instance_of::<PyDict>() {
        return load_config(obj, what);
    }
    fn merge(into: &mut toml::Table, from: toml::Table) {
        for (k, v) in from {
            match (into.get_mut(&k), v) {
                (Some(toml::Value::Table(a)), toml::Value::Table(b)) => merge(a, b),
                (_, v) => {
                    into.insert(k, v);
                }
            }
        }
    }
    let internal = |e: &dyn std::fmt::Display| {
        PyRuntimeError::new_err(format!("internal: the defaults of {what}: {e}"))
    };
    let mut table = toml::Table::try_from(base).map_err(|e| internal(&e))?;
    merge(&mut table, document(obj, what)?);
    let file = PathBuf::from(what);
    let cfg = sway_tasks::config_file::parse_table(table, &file).map_err(dict_err)?;
    Ok((cfg, file))
}

// ---------------------------------------------------------------------------------------
// running long calls

/// How often a waiting call checks Python's signal handlers.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Estimated cost \[s\] below which a call runs on the calling thread (no thread start in
/// a millisecond simulation; Ctrl-C is then seen when it returns).
const INLINE_BELOW_S: f64 = 0.25;

/// How long an interrupted call waits for its workers to stop before it raises anyway
/// (every engine reaches a checkpoint within milliseconds; this bounds a pathological one).
const STOP_WAIT: Duration = Duration::from_secs(5);

/// Runs `f` with the GIL released and returns its value: on the calling thread when
/// `estimated_s` is below [`INLINE_BELOW_S`], else on a worker thread (and a thread pool of
/// the package's size, made for this call) while this thread polls Python's signal
/// handlers and reports `f`'s progress to `progress`, a callable `(stage, done, total)`.
///
/// Ctrl-C (or an exception raised by `progress`) cancels the call's [`CancelToken`]: every
/// engine stops at its next checkpoint (`cancel::checkpoint`), this thread waits until the
/// worker and the pool's threads have stopped, and the exception is raised — no thread
/// keeps computing after the call returns.
pub(crate) fn interruptible<T, F>(
    py: Python<'_>,
    estimated_s: f64,
    progress: Option<Py<PyAny>>,
    f: F,
) -> PyResult<T>
where
    T: Send + 'static,
    F: FnOnce(&dyn Progress) -> T + Send + 'static,
{
    if estimated_s < INLINE_BELOW_S {
        // every computation runs in the package's pool (set_num_threads)
        let r = py.detach(|| in_pool(|| f(&NoProgress)));
        py.check_signals()?;
        return Ok(r);
    }
    let token = CancelToken::new();
    let pool = call_pool(&token)?;
    let reporter = Arc::new(Reporter::default());
    let (tx, rx) = std::sync::mpsc::sync_channel(1);
    let worker = {
        let (token, reporter) = (token.clone(), reporter.clone());
        std::thread::Builder::new()
            .name("trailer_sway".into())
            .spawn(move || {
                let r = cancel::run(&token, || pool.install(|| f(&*reporter)));
                // the pool's threads end once it is dropped (they are idle by now)
                drop(pool);
                let _ = tx.send(r);
            })
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start a worker thread: {e}")))?
    };
    // a Receiver is Send but not Sync: the detached closure borrows it through a Mutex
    let rx = std::sync::Mutex::new(rx);
    let receive = |timeout: Duration| {
        py.detach(|| match rx.lock() {
            Ok(r) => r.recv_timeout(timeout),
            Err(_) => Err(std::sync::mpsc::RecvTimeoutError::Disconnected),
        })
    };
    let mut reported = None;
    loop {
        match receive(SIGNAL_POLL) {
            Ok(Ok(r)) => {
                let _ = worker.join();
                report_progress(py, progress.as_ref(), &reporter, &mut reported)?;
                return Ok(r);
            }
            Ok(Err(cancel::Cancelled)) => return Err(interrupted()),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                let polled = py.check_signals().and_then(|()| {
                    report_progress(py, progress.as_ref(), &reporter, &mut reported)
                });
                if let Err(e) = polled {
                    token.cancel();
                    // wait for the engines to reach a checkpoint and the threads to end
                    if receive(STOP_WAIT).is_ok() {
                        let _ = worker.join();
                    }
                    return Err(e);
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(PyRuntimeError::new_err(
                    "internal: the worker thread ended without a result (a panic in the library)",
                ));
            }
        }
    }
}

/// `KeyboardInterrupt` for a computation stopped through its cancellation token.
pub(crate) fn interrupted() -> PyErr {
    PyKeyboardInterrupt::new_err("interrupted")
}

/// A thread pool for one long call, of the package's size ([`set_num_threads`], else
/// rayon's default), whose threads see `token` at every checkpoint.
fn call_pool(token: &CancelToken) -> PyResult<rayon::ThreadPool> {
    let threads =
        current_pool().map_or_else(rayon::current_num_threads, |p| p.current_num_threads());
    cancel::pool_builder(token)
        .num_threads(threads)
        .thread_name(|i| format!("trailer_sway-{i}"))
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start {threads} threads: {e}")))
}

/// The progress of a long call as the engines report it ([`Progress`]), read by the
/// polling thread.
#[derive(Default)]
struct Reporter {
    stage: std::sync::Mutex<String>,
    total: AtomicU64,
    done: AtomicU64,
}

impl Progress for Reporter {
    fn start(&self, stage: &str, total: u64) {
        let mut s = self.stage.lock().unwrap_or_else(|p| p.into_inner());
        stage.clone_into(&mut s);
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
    }
    fn advance(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }
    fn finish(&self) {
        self.done
            .store(self.total.load(Ordering::Relaxed), Ordering::Relaxed);
    }
}

/// Calls `progress(stage, done, total)` when the reported progress changed since the last
/// call (`reported`).
fn report_progress(
    py: Python<'_>,
    progress: Option<&Py<PyAny>>,
    reporter: &Reporter,
    reported: &mut Option<(String, u64, u64)>,
) -> PyResult<()> {
    let Some(callback) = progress else {
        return Ok(());
    };
    let stage = reporter
        .stage
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone();
    let now = (
        stage,
        reporter.done.load(Ordering::Relaxed),
        reporter.total.load(Ordering::Relaxed),
    );
    if now.0.is_empty() || reported.as_ref() == Some(&now) {
        return Ok(());
    }
    callback.call1(py, (now.0.as_str(), now.1, now.2))?;
    *reported = Some(now);
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Vehicle

/// Python name of parameter `i` of [`PARAMETERS`]: its key path with `_` for `.`
/// (`trailer.mass` → `trailer_mass`).
fn field_name(i: usize) -> String {
    PARAMETERS[i].0.replace('.', "_")
}

/// What setting the paper's axle key `index` does to a unit whose axles are a list
/// ([`VehicleSpec::with_parameter`]).
fn group_change(index: usize) -> &'static str {
    match index {
        2 | 4 => "moves the tractor's axle group",
        5 | 6 => "scales the tractor's axle group",
        10 => "moves the trailer's axle list",
        _ => "scales the trailer's axle list",
    }
}

/// A vehicle key path in Python's terms: the field name of a key of [`PARAMETERS`]
/// (`trailer.mass` → `trailer_mass`) followed by `suffix`; any other key unchanged.
fn python_field(key: &str, suffix: &str) -> String {
    match PARAMETERS.iter().position(|p| p.0 == key) {
        Some(i) => format!("{}{suffix}", field_name(i)),
        None => key.to_string(),
    }
}

fn field_index(name: &str) -> Option<usize> {
    (0..PARAMETERS.len()).find(|&i| field_name(i) == name)
}

/// The model of `params`; a failed physical check is the CLI's config error for `file`.
fn build_model(params: VehicleParams, file: &Path) -> Result<Model, SwayError> {
    Model::new(params).map_err(|e| match e {
        ModelError::InvalidParameter {
            key,
            value,
            expected,
        } => SwayError::config(
            file,
            key,
            format!("{value} is invalid: expected {expected}"),
        ),
        other => SwayError::config(file, "<root>", other.to_string()),
    })
}

/// Parameter `index` of [`PARAMETERS`] in a vehicle file with model variants: None where
/// the key does not exist there (an axle key of a unit given as a list of axles, a trailer
/// key of a chain of towed units), as [`VehicleSpec::with_parameter`] reads the keys.
fn spec_parameter(spec: &VehicleSpec, index: usize) -> Option<f64> {
    let (t, r) = (&spec.tractor, spec.trailer.as_ref());
    match index {
        0 => Some(t.mass),
        1 => Some(t.yaw_inertia),
        2 => t.front_axle,
        3 => Some(t.cog),
        4 => t.rear_axle,
        5 => t.front_cornering_stiffness,
        6 => t.rear_cornering_stiffness,
        7 => r.map(|r| r.mass),
        8 => r.map(|r| r.yaw_inertia),
        9 => r.map(|r| r.cog),
        10 => r.and_then(|r| r.axle),
        11 => r.and_then(|r| r.cornering_stiffness),
        12 => Some(spec.friction.mu_static),
        13 => Some(spec.friction.mu_dynamic),
        _ => Some(spec.gravity),
    }
}

/// A car–trailer combination, validated: the paper's form (Table I's keys) or a vehicle
/// file with model variants (tyre relaxation, axle lists, tyre laws, hitch torque).
#[pyclass(frozen, module = "trailer_sway._native")]
#[derive(Debug, Clone)]
pub struct Vehicle {
    /// the vehicle as the CLI loads a vehicle file: its spec, plant, paper-form parameters
    pub(crate) loaded: LoadedVehicle,
}

impl Vehicle {
    /// A vehicle of the paper's form (no variants): the paper's model, as the CLI's plant of
    /// such a file ([`AnyVehicleModel::Paper`]: results bit for bit as before).
    fn paper(params: VehicleParams, model: Model) -> Self {
        Self {
            loaded: LoadedVehicle {
                spec: VehicleSpec::from(params),
                plant: AnyVehicleModel::Paper(model.clone()),
                params,
                paper_model: model,
                variant_key: None,
            },
        }
    }

    /// The task context of this vehicle (no files are read or written through it: its
    /// directories are never used by the functions that take it), with the CLI's default
    /// limits (`--max-speed` 100 m/s).
    pub(crate) fn context<'a>(
        &self,
        progress: &'a dyn sway::progress::Progress,
    ) -> TaskContext<'a> {
        TaskContext {
            vehicle_file: PathBuf::from("<vehicle>"),
            vehicle: self.loaded.params,
            model: self.loaded.paper_model.clone(),
            spec: self.loaded.spec.clone(),
            plant: self.loaded.plant.clone(),
            variant_key: self.loaded.variant_key.clone(),
            configs_dir: PathBuf::from("."),
            results_dir: PathBuf::from("."),
            progress,
            limits: SpeedLimits::default(),
        }
    }

    /// The plant of every function (the paper's model for a vehicle of the paper's form).
    pub(crate) fn plant(&self) -> &AnyVehicleModel {
        &self.loaded.plant
    }

    /// The first key that makes the vehicle differ from the paper's model.
    fn variant(&self) -> Option<&str> {
        self.loaded.variant_key.as_deref()
    }

    /// Fields given by keyword, type-checked: (parameter index, value).
    fn changes(fields: Option<&Bound<'_, PyDict>>, what: &str) -> PyResult<Vec<(usize, f64)>> {
        let mut out = Vec::new();
        let Some(d) = fields else {
            return Ok(out);
        };
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            let Some(i) = field_index(&k) else {
                let known: Vec<String> = (0..PARAMETERS.len()).map(field_name).collect();
                return Err(PyTypeError::new_err(format!(
                    "{what}: unknown field `{k}`; fields: {}",
                    known.join(", ")
                )));
            };
            let unit = PARAMETERS[i].2;
            if v.is_instance_of::<PyBool>() || v.is_instance_of::<PyString>() {
                return Err(PyTypeError::new_err(format!(
                    "{what}: `{k}`: expected a number [{unit}], got {}",
                    v.get_type().name()?
                )));
            }
            let x: f64 = v.extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "{what}: `{k}`: expected a number [{unit}], got {}",
                    v.get_type()
                        .name()
                        .map(|n| n.to_string())
                        .unwrap_or_default()
                ))
            })?;
            out.push((i, x));
        }
        Ok(out)
    }

    /// A copy with `changes` (parameter index, value), validated: [`Vehicle::replace`]'s
    /// rules; `what` names the call and `suffix` follows a field's name in messages
    /// (`[3]` for an array's entry).
    fn with_changes(&self, changes: &[(usize, f64)], what: &str, suffix: &str) -> PyResult<Self> {
        let python_terms = |e: TaskError| py_err(renamed(e, what, |k| python_field(k, suffix)));
        if self.variant().is_none() {
            let mut params = self.loaded.params;
            for &(i, x) in changes {
                params = params.with(i, x);
            }
            let model = build_model(params, Path::new(what)).map_err(|e| python_terms(e.into()))?;
            return Ok(Self::paper(params, model));
        }
        let mut spec = self.loaded.spec.clone();
        for &(i, x) in changes {
            spec = spec
                .with_parameter(i, x)
                .map_err(|e| self.not_in_variant(i, what, &e))?;
        }
        let loaded =
            sway_tasks::config_file::vehicle_from_spec(spec, Path::new(what)).map_err(|e| {
                let e = renamed(e, what, |k| python_field(k, suffix));
                let groups: Vec<String> = changes
                    .iter()
                    .filter(|&&(i, _)| spec_parameter(&self.loaded.spec, i).is_none())
                    .map(|&(i, x)| {
                        format!(
                            "`{}{suffix}` = {x}, which {}",
                            field_name(i),
                            group_change(i)
                        )
                    })
                    .collect();
                match groups.is_empty() {
                    true => py_err(e),
                    false => exception(&e)(format!("{e} (set by {})", groups.join("; "))),
                }
            })?;
        Ok(Self { loaded })
    }

    /// Parameter `index`: [`Vehicle`]'s attribute of that field.
    fn field(&self, index: usize) -> PyResult<f64> {
        if self.variant().is_none() {
            return Ok(self.loaded.params.get(index));
        }
        match spec_parameter(&self.loaded.spec, index) {
            Some(v) => Ok(v),
            // an axle key of a unit given as a list: the group's value, as `replace` sets it
            None => self
                .loaded
                .spec
                .equivalent_params()
                .map(|p| p.get(index))
                .map_err(|e| self.not_in_variant(index, "Vehicle", &e)),
        }
    }

    /// The `ValueError` of a paper-form field that a vehicle with model variants cannot
    /// give or take (`e`: why not).
    fn not_in_variant(&self, index: usize, what: &str, e: &ModelError) -> PyErr {
        PyValueError::new_err(format!(
            "{what}: `{}`: `{}` has no value on this vehicle ({e}); the vehicle has model \
             variants (first: `{}`), change its file (to_toml()) instead",
            field_name(index),
            PARAMETERS[index].0,
            self.variant().unwrap_or_default()
        ))
    }
}

#[pymethods]
impl Vehicle {
    /// Vehicle(**fields): every field of Table I by name (`tractor_mass`, …,
    /// `friction_mu_dynamic`, optional `gravity` = 9.81), SI units.
    #[new]
    #[pyo3(signature = (**fields))]
    fn new(fields: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let what = "Vehicle()";
        let changes = Self::changes(fields, what)?;
        // gravity has a default, as in a vehicle file
        let missing: Vec<String> = (0..PARAMETERS.len())
            .filter(|&i| PARAMETERS[i].0 != "gravity" && !changes.iter().any(|c| c.0 == i))
            .map(field_name)
            .collect();
        if !missing.is_empty() {
            return Err(PyTypeError::new_err(format!(
                "{what}: missing field(s) {} (Vehicle.table1().replace(...) starts from Table I)",
                missing.join(", ")
            )));
        }
        Self::table1()?.with_changes(&changes, what, "")
    }

    /// The vehicle of paper Table I (μ0 = 0.9, μ = 0.6, g = 9.81 m/s²).
    #[staticmethod]
    fn table1() -> PyResult<Self> {
        let params = VehicleParams::default();
        let model = build_model(params, Path::new("Table I")).map_err(py_err)?;
        Ok(Self::paper(params, model))
    }

    /// A vehicle file (the form of `configs/vehicle.toml`, or with model variants as in
    /// `configs/vehicles/*.toml`), with the CLI's checks (`--vehicle FILE`).
    #[staticmethod]
    fn from_toml(path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let what = "Vehicle.from_toml()";
        if !(path.is_instance_of::<PyString>() || path.hasattr("__fspath__")?) {
            return Err(PyTypeError::new_err(format!(
                "{what}: path: expected a str or os.PathLike, got {}",
                path.get_type().name()?
            )));
        }
        let path = config_path(
            path,
            what,
            "Vehicle.from_toml_str(text) reads a vehicle file's text",
        )?;
        let loaded = sway_tasks::config_file::load_vehicle_spec(&path).map_err(py_err)?;
        Ok(Self { loaded })
    }

    /// A vehicle file's text (TOML), with the CLI's checks; `<vehicle>` names it in messages.
    #[staticmethod]
    fn from_toml_str(text: &str) -> PyResult<Self> {
        let file = Path::new("<vehicle>");
        let spec: VehicleSpec = sway_tasks::config_file::parse_toml(text, file).map_err(py_err)?;
        let loaded = sway_tasks::config_file::vehicle_from_spec(spec, file).map_err(py_err)?;
        Ok(Self { loaded })
    }

    /// A copy with some fields changed, validated. On a vehicle with model variants the
    /// paper's keys that its file has can be changed (masses, inertias, centres of gravity,
    /// friction, gravity; the axle keys of a unit with one axle per group); an axle key of
    /// a unit whose axles are a list raises `ValueError`.
    #[pyo3(signature = (**changes))]
    fn replace(&self, changes: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let what = "Vehicle.replace()";
        self.with_changes(&Self::changes(changes, what)?, what, "")
    }

    /// The field names, in Table I's order.
    #[staticmethod]
    fn fields() -> Vec<String> {
        (0..PARAMETERS.len()).map(field_name).collect()
    }

    /// Whether the vehicle has the paper's form (no model variants).
    #[getter]
    fn is_paper_form(&self) -> bool {
        self.variant().is_none()
    }

    /// The first key that makes the vehicle differ from the paper's model (None for the
    /// paper's form), e.g. `tractor.front_relaxation_length_m`.
    #[getter]
    fn variant_key(&self) -> Option<String> {
        self.loaded.variant_key.clone()
    }

    /// Number of states of the model (4 for the paper's model, one more per relaxing axle).
    #[getter]
    fn states(&self) -> usize {
        self.loaded.plant.states()
    }

    /// {field: value} (the paper's form only: a vehicle with model variants raises
    /// `ValueError`, its fields are read one by one or written with to_toml()).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        if let Some(k) = self.variant() {
            return Err(PyValueError::new_err(format!(
                "Vehicle.to_dict(): the vehicle has model variants (first: `{k}`), not the \
                 paper's 15 fields; to_toml() writes its file"
            )));
        }
        let d = PyDict::new(py);
        for i in 0..PARAMETERS.len() {
            d.set_item(field_name(i), self.loaded.params.get(i))?;
        }
        Ok(d)
    }

    /// The vehicle file's text (TOML), readable by `from_toml` and `--vehicle`.
    fn to_toml(&self) -> PyResult<String> {
        let text = if self.variant().is_none() {
            toml::to_string(&self.loaded.params)
        } else {
            toml::to_string(&self.loaded.spec)
        };
        text.map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    // the 15 fields of Table I, read-only, in its order (indices of `PARAMETERS`); on a
    // vehicle with model variants a key its file lacks raises ValueError

    /// m1: the tractor's mass [kg]
    #[getter]
    fn tractor_mass(&self) -> PyResult<f64> {
        self.field(0)
    }

    /// J1: the tractor's yaw moment of inertia about its centre of gravity [kg m²]
    #[getter]
    fn tractor_yaw_inertia(&self) -> PyResult<f64> {
        self.field(1)
    }

    /// f: hitch to the tractor's front axle [m]
    #[getter]
    fn tractor_front_axle(&self) -> PyResult<f64> {
        self.field(2)
    }

    /// d: hitch to the tractor's centre of gravity [m]
    #[getter]
    fn tractor_cog(&self) -> PyResult<f64> {
        self.field(3)
    }

    /// c: hitch to the tractor's rear axle [m]
    #[getter]
    fn tractor_rear_axle(&self) -> PyResult<f64> {
        self.field(4)
    }

    /// C_F: cornering stiffness of the tractor's front axle [N/rad]
    #[getter]
    fn tractor_front_cornering_stiffness(&self) -> PyResult<f64> {
        self.field(5)
    }

    /// C_R: cornering stiffness of the tractor's rear axle [N/rad]
    #[getter]
    fn tractor_rear_cornering_stiffness(&self) -> PyResult<f64> {
        self.field(6)
    }

    /// m2: the trailer's mass [kg]
    #[getter]
    fn trailer_mass(&self) -> PyResult<f64> {
        self.field(7)
    }

    /// J2: the trailer's yaw moment of inertia about its centre of gravity [kg m²]
    #[getter]
    fn trailer_yaw_inertia(&self) -> PyResult<f64> {
        self.field(8)
    }

    /// h: hitch to the trailer's centre of gravity [m]
    #[getter]
    fn trailer_cog(&self) -> PyResult<f64> {
        self.field(9)
    }

    /// l: hitch to the trailer's axle [m]
    #[getter]
    fn trailer_axle(&self) -> PyResult<f64> {
        self.field(10)
    }

    /// C_T: cornering stiffness of the trailer's axle [N/rad]
    #[getter]
    fn trailer_cornering_stiffness(&self) -> PyResult<f64> {
        self.field(11)
    }

    /// μ0: static friction coefficient of the tyres [-]
    #[getter]
    fn friction_mu_static(&self) -> PyResult<f64> {
        self.field(12)
    }

    /// μ: sliding friction coefficient of the tyres [-]
    #[getter]
    fn friction_mu_dynamic(&self) -> PyResult<f64> {
        self.field(13)
    }

    /// g: gravitational acceleration [m/s²]
    #[getter]
    fn gravity(&self) -> PyResult<f64> {
        self.field(14)
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Vehicle>().is_ok_and(|o| {
            let (a, b) = (&self.loaded, &o.get().loaded);
            match (&a.variant_key, &b.variant_key) {
                (None, None) => a.params == b.params,
                _ => a.spec == b.spec,
            }
        })
    }

    fn __repr__(&self) -> String {
        match self.variant() {
            None => {
                let f: Vec<String> = (0..PARAMETERS.len())
                    .map(|i| format!("{}={:?}", field_name(i), self.loaded.params.get(i)))
                    .collect();
                format!("Vehicle({})", f.join(", "))
            }
            Some(k) => format!(
                "<Vehicle with model variants (first: `{k}`), {} states>",
                self.loaded.plant.states()
            ),
        }
    }

    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyAny>,))> {
        let m = py.import("trailer_sway")?;
        if self.variant().is_none() {
            let ctor = m.getattr("_vehicle_from_dict")?;
            Ok((ctor, (self.to_dict(py)?.into_any(),)))
        } else {
            let ctor = py
                .import("trailer_sway._native")?
                .getattr("Vehicle")?
                .getattr("from_toml_str")?;
            Ok((ctor, (PyString::new(py, &self.to_toml()?).into_any(),)))
        }
    }
}

// ---------------------------------------------------------------------------------------
// critical speed

/// Where straight running loses stability, or that it does not on the scanned range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
enum CriticalOutcome {
    /// the spectral abscissa crosses zero at V_crit (a Hopf point when ω > 0)
    Crossing {
        v_crit_mps: f64,
        hopf_frequency_hz: f64,
        hopf_omega_rad_s: f64,
    },
    /// stable at every scanned speed up to the maximum
    StableUpToMax { stable_up_to_mps: f64 },
    /// already unstable at the lowest scanned speed
    UnstableAtMin { v_min_mps: f64 },
}

/// The one place that turns today's V_crit searches into the "stable up to" outcome
/// (the library's own version can replace its body), with the settings of the `linear`
/// task's `[critical_speed]` ([`SearchConfig`]): open loop by the model's scan and
/// bisection of the spectral abscissa (the `linear` task), closed loop by the exact
/// unstable-root count (the `fig4a` task's `v_crit_at_d`).
fn critical_outcome(
    model: &AnyVehicleModel,
    loop_: Option<(f64, f64)>,
    s: SearchConfig,
) -> Result<CriticalOutcome, SwayError> {
    match loop_ {
        None => match LoopModel::critical_speed_search(model, &s.options()) {
            Ok(Some(c)) => Ok(CriticalOutcome::Crossing {
                v_crit_mps: c.v_crit_mps,
                hopf_frequency_hz: c.hopf_frequency_hz,
                hopf_omega_rad_s: c.hopf_omega_rad_s,
            }),
            Ok(None) => Ok(CriticalOutcome::StableUpToMax {
                stable_up_to_mps: s.v_max_mps,
            }),
            Err(ModelError::NoCriticalSpeed { detail, .. })
                if detail.contains("already unstable at v_min") =>
            {
                Ok(CriticalOutcome::UnstableAtMin {
                    v_min_mps: s.v_min_mps,
                })
            }
            Err(e) => Err(SwayError::Model(e)),
        },
        Some((gain, delay)) => {
            // samples so that the scan's spacing is at most `step` (the fig4a task scans
            // its cell centres: spacing (v_max − v_min)/(samples − 1))
            let samples = ((s.v_max_mps - s.v_min_mps) / s.scan_step_mps - 1e-9)
                .ceil()
                .max(1.0) as usize
                + 1;
            let v = sway::charts::critical_speed_at_gain(
                model,
                delay,
                gain,
                s.v_min_mps,
                s.v_max_mps,
                samples,
                s.tolerance_mps,
            )?;
            match v {
                None => Ok(CriticalOutcome::StableUpToMax {
                    stable_up_to_mps: s.v_max_mps,
                }),
                Some(v) if v <= s.v_min_mps => Ok(CriticalOutcome::UnstableAtMin {
                    v_min_mps: s.v_min_mps,
                }),
                Some(v) => {
                    // the crossing root: the rightmost root there (ω = 0: a static crossing)
                    let r = sway::charts::rightmost_roots(model, v, gain, delay, 2)?;
                    let omega = r.first().map_or(0.0, |l| l.im.abs());
                    Ok(CriticalOutcome::Crossing {
                        v_crit_mps: v,
                        hopf_frequency_hz: omega / (2.0 * std::f64::consts::PI),
                        hopf_omega_rad_s: omega,
                    })
                }
            }
        }
    }
}

/// A V_crit search as the Python arguments give it: the loop (gain, delay; None for the
/// open loop), the search settings and the estimated cost of one search \[s\].
#[derive(Debug, Clone, Copy)]
struct Search {
    loop_: Option<(f64, f64)>,
    settings: SearchConfig,
    cost_s: f64,
}

impl Search {
    /// The search of `critical_speed()`'s arguments, each checked under its Python name.
    fn new(
        gain: Option<f64>,
        delay: Option<f64>,
        v_min_mps: f64,
        v_max_mps: f64,
        scan_step_mps: f64,
        tolerance_mps: f64,
    ) -> PyResult<Self> {
        let file = Path::new("critical_speed()");
        let check = |ok: bool, key: &str, problem: String| {
            sway::config::ensure(ok, file, key, || problem).map_err(py_err)
        };
        check(
            v_min_mps.is_finite() && v_min_mps > 0.0,
            "v_min_mps",
            format!("expected a speed > 0 m/s, got {v_min_mps}"),
        )?;
        check(
            v_max_mps.is_finite() && v_max_mps > v_min_mps,
            "v_max_mps",
            format!("expected a finite speed above v_min_mps = {v_min_mps} m/s, got {v_max_mps}"),
        )?;
        check(
            scan_step_mps.is_finite() && scan_step_mps > 0.0,
            "scan_step_mps",
            format!("must be positive, got {scan_step_mps}"),
        )?;
        let scan_points = (v_max_mps - v_min_mps) / scan_step_mps;
        sway_tasks::limits::bound(
            file,
            "scan_step_mps",
            scan_points,
            sway::config::MAX_GRID_POINTS as f64,
            || format!("{scan_points:.3e} scan points from v_min_mps to v_max_mps, one eigenvalue problem each; use a larger step"),
        )
        .map_err(py_err)?;
        check(
            tolerance_mps > 0.0 && tolerance_mps < 1e-2,
            "tolerance_mps",
            format!("expected 0 < tolerance < 0.01 m/s, got {tolerance_mps}"),
        )?;
        let loop_ = match (gain, delay) {
            (Some(g), Some(t)) => {
                check(
                    g.is_finite(),
                    "controller.gain_s",
                    format!("expected a finite gain [s], got {g}"),
                )?;
                check(
                    t.is_finite() && t >= 0.0,
                    "controller.delay_s",
                    format!("expected a delay ≥ 0 s, got {t}"),
                )?;
                Some((g, t))
            }
            _ => None,
        };
        // ≈ 10 µs per open-loop eigenvalue problem, ≈ 1 ms per closed-loop root count
        let per_point = if loop_.is_some() { 1e-3 } else { 1e-5 };
        Ok(Self {
            loop_,
            settings: SearchConfig {
                v_min_mps,
                v_max_mps,
                scan_step_mps,
                tolerance_mps,
            },
            cost_s: scan_points * per_point,
        })
    }

    fn run(&self, model: &AnyVehicleModel) -> Result<CriticalOutcome, SwayError> {
        critical_outcome(model, self.loop_, self.settings)
    }
}

/// critical_speed(vehicle, gain, delay, v_min_mps, v_max_mps, scan_step_mps,
/// tolerance_mps) → JSON {reason, …}; gain/delay None for the open loop.
#[pyfunction]
#[pyo3(signature = (vehicle, gain, delay, v_min_mps, v_max_mps, scan_step_mps, tolerance_mps))]
fn critical_speed(
    py: Python<'_>,
    vehicle: &Vehicle,
    gain: Option<f64>,
    delay: Option<f64>,
    v_min_mps: f64,
    v_max_mps: f64,
    scan_step_mps: f64,
    tolerance_mps: f64,
) -> PyResult<String> {
    let search = Search::new(
        gain,
        delay,
        v_min_mps,
        v_max_mps,
        scan_step_mps,
        tolerance_mps,
    )?;
    let model = vehicle.plant().clone();
    let r = interruptible(py, search.cost_s, None, move |_| search.run(&model))?;
    to_json(&r.map_err(py_err)?)
}

/// critical_speeds(vehicle, field, values, gain, delay, …) → (arrays, reasons): the search
/// of [`critical_speed`] on the vehicle with `field` set to each of `values`
/// (`Vehicle.replace`), in parallel; per value V_crit, the Hopf frequency and ω (NaN
/// without a crossing), the speed stable up to (NaN when unstable at v_min) and the
/// outcome's reason. Each value's numbers are those of the scalar call, bit for bit.
#[pyfunction]
#[pyo3(signature = (vehicle, field, values, gain, delay, v_min_mps, v_max_mps, scan_step_mps, tolerance_mps, progress = None))]
fn critical_speeds<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    field: &str,
    values: numpy::PyReadonlyArray1<'py, f64>,
    gain: Option<f64>,
    delay: Option<f64>,
    v_min_mps: f64,
    v_max_mps: f64,
    scan_step_mps: f64,
    tolerance_mps: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, Vec<&'static str>)> {
    let what = "critical_speed()";
    let index = field_index(field).ok_or_else(|| {
        PyTypeError::new_err(format!(
            "{what}: unknown field `{field}`; fields: {}",
            Vehicle::fields().join(", ")
        ))
    })?;
    let search = Search::new(
        gain,
        delay,
        v_min_mps,
        v_max_mps,
        scan_step_mps,
        tolerance_mps,
    )?;
    let values = values.as_slice()?.to_vec();
    let plants: Vec<AnyVehicleModel> = values
        .iter()
        .enumerate()
        .map(|(k, &x)| {
            Ok(vehicle
                .with_changes(&[(index, x)], what, &format!("[{k}]"))?
                .loaded
                .plant)
        })
        .collect::<PyResult<_>>()?;
    let cost = search.cost_s * plants.len() as f64 / get_num_threads() as f64;
    let outcomes = interruptible(py, cost, progress, move |progress| {
        progress.start("critical speeds", plants.len() as u64);
        let r = sway::parallel::try_map(&plants, sway::parallel::Split::Adaptive, &|k, m| {
            let r = search.run(m).map_err(|e| (k, e));
            progress.advance(1);
            r
        });
        progress.finish();
        r
    })?
    .map_err(|(k, e)| {
        let e = TaskError::from(e);
        exception(&e)(format!("{what}: `{field}[{k}]` = {}: {e}", values[k]))
    })?;
    let n = outcomes.len();
    let (mut v_crit, mut hz, mut omega, mut up_to) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut reasons = Vec::with_capacity(n);
    for o in outcomes {
        let (v, f, w, u, reason) = match o {
            CriticalOutcome::Crossing {
                v_crit_mps,
                hopf_frequency_hz,
                hopf_omega_rad_s,
            } => (
                v_crit_mps,
                hopf_frequency_hz,
                hopf_omega_rad_s,
                v_crit_mps,
                "crossing",
            ),
            CriticalOutcome::StableUpToMax { stable_up_to_mps } => (
                f64::NAN,
                f64::NAN,
                f64::NAN,
                stable_up_to_mps,
                "stable_up_to_max",
            ),
            CriticalOutcome::UnstableAtMin { .. } => {
                (f64::NAN, f64::NAN, f64::NAN, f64::NAN, "unstable_at_min")
            }
        };
        v_crit.push(v);
        hz.push(f);
        omega.push(w);
        up_to.push(u);
        reasons.push(reason);
    }
    let d = PyDict::new(py);
    d.set_item("v_crit_mps", v_crit.into_pyarray(py))?;
    d.set_item("hopf_frequency_hz", hz.into_pyarray(py))?;
    d.set_item("hopf_omega_rad_s", omega.into_pyarray(py))?;
    d.set_item("stable_up_to_mps", up_to.into_pyarray(py))?;
    Ok((d, reasons))
}

// ---------------------------------------------------------------------------------------
// roots

/// The `count` rightmost characteristic roots of eq. (13) at (V, D, τ), as `cargo xtask
/// roots` computes them (a conjugate pair is never split).
#[pyfunction]
#[pyo3(signature = (vehicle, speed, gain, delay, count = 6))]
fn roots<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    speed: f64,
    gain: f64,
    delay: f64,
    count: i64,
) -> PyResult<Bound<'py, PyArray1<num_complex::Complex64>>> {
    let what = "roots()";
    let count = usize::try_from(count)
        .ok()
        .filter(|&c| c > 0)
        .ok_or_else(|| {
            py_err(SwayError::config(
                what,
                "count",
                format!("expected at least 1, got {count}"),
            ))
        })?;
    // the CLI's checks, its options named as this function's arguments (`--speed` → speed)
    sway_tasks::tasks::roots::validate_args(speed, gain, delay, count).map_err(|e| {
        py_err(renamed(e, what, |k| {
            k.trim_start_matches("--").replace('-', "_")
        }))
    })?;
    let model = vehicle.plant().clone();
    let r = interruptible(py, 0.0, None, move |_| {
        sway_studies::roots::compute(&model, &RootsConfig::paper(speed, gain, delay, count), None)
    })?
    .map_err(py_err)?;
    Ok(r.into_pyarray(py))
}

// ---------------------------------------------------------------------------------------
// simulate

/// simulate(vehicle, scenario, trajectory) → (arrays dict, summary JSON): the `simulate`
/// task's run of a scenario (file path or dict), its trajectory columns (t, σ1, σ2, σ3, θ,
/// ψ, x_H, y_H, V, δ sampled every `output_step_s`; empty without `trajectory`) and its
/// summary (metrics, class, action_s, t_end_s, steps), as `summary.json` writes them.
#[pyfunction]
#[pyo3(signature = (vehicle, scenario, trajectory = true, progress = None))]
fn simulate<'py>(
    py: Python<'py>,
    vehicle: &Vehicle,
    scenario: &Bound<'py, PyAny>,
    trajectory: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use sway::ranging::SpeedSpec;
    use sway::sim::ScenarioConfig;
    use sway_tasks::config_file::{Configured, TaskConfig};
    use sway_tasks::tasks::Prepared;

    let (mut config, file): (ScenarioConfig<SpeedSpec>, PathBuf) =
        load_config(scenario, "simulate(scenario)")?;
    config.load_named_files(&file).map_err(py_err)?;
    config.check(&file).map_err(py_err)?;
    let prepared = Configured { file, config };
    let plan = prepared.plan().map_err(py_err)?;
    let Configured { file, config } = prepared;
    // the CLI's plant of a paper-form vehicle, and its default speed limits (--max-speed)
    let plant = vehicle.plant().clone();
    let run = move |progress: &dyn Progress| -> Result<_, TaskError> {
        let limits = SpeedLimits::default();
        let resolution =
            sway_studies::simulate::compute(&config, &plant, &limits, &file, trajectory, progress)?;
        let scenario = match resolution.outcome {
            Ok(s) => s,
            Err(u) => {
                return Err(TaskError::config(
                    &file,
                    u.key,
                    format!("no scenario for this vehicle: {}", u.reason),
                ));
            }
        };
        let summary = scenario.summary();
        let r = &scenario.run.result;
        // one pass over the samples into owned arrays (handed to numpy without a copy):
        // t, the states row-major (n × 7), V, δ
        let n = r.trajectory.len();
        let (mut t, mut x): (Vec<f64>, Vec<f64>) =
            (Vec::with_capacity(n), Vec::with_capacity(7 * n));
        let (mut v, mut delta) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for s in &r.trajectory {
            t.push(s.t);
            x.extend(s.x.iter());
            v.push(s.speed);
            delta.push(s.steering_angle);
        }
        let json = serde_json::to_string(&summary)
            .map_err(|e| TaskError::numerical("serialising the summary", e))?;
        Ok(((t, x, v, delta), json))
    };
    let ((t, x, v, delta), json) =
        interruptible(py, plan.time_s, progress, run)?.map_err(py_err)?;
    let n = t.len();
    let d = PyDict::new(py);
    d.set_item("t", t.into_pyarray(py))?;
    d.set_item("states", x.into_pyarray(py).reshape([n, 7])?)?;
    d.set_item("speed", v.into_pyarray(py))?;
    d.set_item("delta", delta.into_pyarray(py))?;
    Ok((d, json))
}

/// to_toml(config) → the TOML text of a config dict (for a file `cargo xtask` reads).
#[pyfunction]
fn to_toml(config: &Bound<'_, PyAny>) -> PyResult<String> {
    if !config.is_instance_of::<PyDict>() {
        return Err(PyTypeError::new_err(format!(
            "to_toml(): config: expected a dict, got {}",
            config.get_type().name()?
        )));
    }
    toml::to_string(&toml_value(config, "to_toml()", "")?)
        .map_err(|e| PyValueError::new_err(format!("not representable as TOML: {e}")))
}

// ---------------------------------------------------------------------------------------
// the module

/// The thread pool the package's computations run in: rayon's global pool until
/// [`set_num_threads`] gives one of its own (at any time: each call takes the pool current
/// when it starts; a running call keeps its own).
static POOL: std::sync::Mutex<Option<Arc<rayon::ThreadPool>>> = std::sync::Mutex::new(None);

/// The pool set by [`set_num_threads`], if any.
fn current_pool() -> Option<Arc<rayon::ThreadPool>> {
    POOL.lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
        .clone()
}

/// Runs `f` in the package's pool.
fn in_pool<T: Send, F: FnOnce() -> T + Send>(f: F) -> T {
    match current_pool() {
        Some(pool) => pool.install(f),
        None => f(),
    }
}

/// The most threads `set_num_threads` takes.
const MAX_THREADS: i64 = 1024;

/// Sets the number of threads of every later call (at any time; the default is rayon's,
/// one per core or `RAYON_NUM_THREADS`).
#[pyfunction]
fn set_num_threads(n: &Bound<'_, PyAny>) -> PyResult<()> {
    if n.is_instance_of::<PyBool>() || !n.is_instance_of::<PyInt>() {
        return Err(PyTypeError::new_err(format!(
            "set_num_threads: n: expected an int, got {}",
            n.get_type().name()?
        )));
    }
    let n: i64 = n.extract().map_err(|_| {
        PyValueError::new_err(format!(
            "set_num_threads: n: expected 1 to {MAX_THREADS} threads"
        ))
    })?;
    if !(1..=MAX_THREADS).contains(&n) {
        return Err(PyValueError::new_err(format!(
            "set_num_threads: n: expected 1 to {MAX_THREADS} threads, got {n}"
        )));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n as usize)
        .thread_name(|i| format!("trailer_sway-{i}"))
        .build()
        .map_err(|e| {
            PyRuntimeError::new_err(format!("set_num_threads: cannot start {n} threads: {e}"))
        })?;
    *POOL.lock().unwrap_or_else(|poisoned| poisoned.into_inner()) = Some(Arc::new(pool));
    Ok(())
}

/// The number of threads the next call will use.
#[pyfunction]
fn get_num_threads() -> usize {
    match current_pool() {
        Some(pool) => pool.current_num_threads(),
        None => rayon::current_num_threads(),
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Vehicle>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(critical_speed, m)?)?;
    m.add_function(wrap_pyfunction!(critical_speeds, m)?)?;
    m.add_function(wrap_pyfunction!(roots, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(set_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(get_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(to_toml, m)?)?;
    charts::register(m)?;
    detect::register(m)?;
    lateral::register(m)?;
    sweep::register(m)?;
    Ok(())
}
