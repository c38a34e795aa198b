//! Reading TOML config files: typed, with `deny_unknown_fields`, and errors that name the
//! file, the key path and the problem. Nothing is computed before a config has loaded.

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

use crate::TaskError;
use crate::limits::{self, MAX_ARRAY_LEN, MAX_STRING_LEN};
use sway::config::ensure;
use sway::sim::RunSettings;
use trailer_model::{AnyVehicleModel, Model, ModelError, VehicleParams, VehicleSpec};

/// Reads and deserialises a TOML file into `T`.
///
/// # Errors
/// [`TaskError::Read`] if the file cannot be read; [`TaskError::Config`] with the key path
/// (e.g. `tractor.mass`) and line for syntax errors, unknown keys and wrong types.
pub fn load_toml<T: DeserializeOwned>(file: &Path) -> Result<T, TaskError> {
    let bytes = std::fs::read(file).map_err(|source| TaskError::Read {
        file: file.to_path_buf(),
        source,
    })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = good.iter().filter(|b| **b == b'\n').count() + 1;
        TaskError::config(
            file,
            "<syntax>",
            format!("invalid UTF-8 (line {line}); config files are UTF-8 text"),
        )
    })?;
    parse_toml(&text, file)
}

/// Refuses arrays longer than [`MAX_ARRAY_LEN`] and strings longer than
/// [`MAX_STRING_LEN`] anywhere in the document, naming the key path.
fn check_sizes(value: &toml::Value, key: &str, file: &Path) -> Result<(), TaskError> {
    let sub = |k: &str| {
        if key.is_empty() {
            k.to_string()
        } else {
            format!("{key}.{k}")
        }
    };
    let key_or_root = || {
        if key.is_empty() {
            "<root>".to_string()
        } else {
            key.to_string()
        }
    };
    match value {
        toml::Value::Array(a) => {
            limits::bound(
                file,
                &key_or_root(),
                a.len() as f64,
                MAX_ARRAY_LEN as f64,
                || "array entries; every array of a config is a short list".into(),
            )?;
            a.iter()
                .enumerate()
                .try_for_each(|(i, v)| check_sizes(v, &format!("{}[{i}]", key_or_root()), file))
        }
        toml::Value::Table(t) => t.iter().try_for_each(|(k, v)| {
            limits::bound(file, &sub(k), k.len() as f64, MAX_STRING_LEN as f64, || {
                "bytes in a key".into()
            })?;
            check_sizes(v, &sub(k), file)
        }),
        toml::Value::String(s) => limits::bound(
            file,
            &key_or_root(),
            s.len() as f64,
            MAX_STRING_LEN as f64,
            || "bytes in a string".into(),
        ),
        _ => Ok(()),
    }
}

/// Deserialises TOML text; `file` is only used in error messages.
///
/// # Errors
/// [`TaskError::Config`] naming the key path, the line and the problem.
pub fn parse_toml<T: DeserializeOwned>(text: &str, file: &Path) -> Result<T, TaskError> {
    let syntax = |e: toml::de::Error| {
        let message = match e.span() {
            Some(span) => format!(
                "{} (line {})",
                e.message().trim(),
                line_at(text, span.start)
            ),
            None => e.message().trim().to_string(),
        };
        TaskError::config(file, "<syntax>", message)
    };
    let document = toml::Value::Table(toml::from_str(text).map_err(syntax)?);
    deserialise(document, file, |path, message| {
        match key_offset(text, path) {
            Some(at) => format!("{message} (line {})", line_at(text, at)),
            None => message.to_string(),
        }
    })
}

/// Deserialises a TOML document already in memory (a table built by a program, e.g. the
/// Python package's dicts) with the checks and messages of [`parse_toml`], without its
/// text: the messages name the key path but no line.
///
/// # Errors
/// [`TaskError::Config`] naming the key path and the problem.
pub fn parse_table<T: DeserializeOwned>(
    document: toml::Table,
    file: &Path,
) -> Result<T, TaskError> {
    deserialise(toml::Value::Table(document), file, |_, message| {
        message.to_string()
    })
}

/// `T` from a parsed document, the one deserialiser of every config type (the document's
/// own, not the text's: each config type compiles against one deserialiser). `message`
/// renders the problem at a key path (adding the line where the text is known).
fn deserialise<T: DeserializeOwned>(
    document: toml::Value,
    file: &Path,
    message: impl Fn(&serde_path_to_error::Path, &str) -> String,
) -> Result<T, TaskError> {
    check_sizes(&document, "", file)?;
    serde_path_to_error::deserialize(document.clone()).map_err(|e| {
        let message = message(e.path(), e.inner().message().trim());
        config_error(e, &document, file, message)
    })
}

/// The 1-based line of byte offset `at` in `text`.
fn line_at(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// The byte offset in `text` of the deepest key of `path` that the document has (a key the
/// type does not know, the table that misses a key, the key of a bad value); None at the
/// root.
fn key_offset(text: &str, path: &serde_path_to_error::Path) -> Option<usize> {
    use serde_path_to_error::Segment;
    use toml::de::DeValue;
    let root = toml::de::DeTable::parse(text).ok()?;
    let mut table = Some(root.get_ref());
    let mut array: Option<&toml::de::DeArray<'_>> = None;
    let mut at = None;
    for segment in path.iter() {
        let value = match segment {
            Segment::Map { key } => {
                let (k, v) = table?
                    .iter()
                    .find(|(k, _)| k.get_ref().as_ref() == key.as_str())?;
                at = Some(k.span().start);
                v
            }
            Segment::Seq { index } => {
                let v = array?.get(*index)?;
                at = Some(v.span().start);
                v
            }
            Segment::Enum { .. } | Segment::Unknown => continue,
        };
        (table, array) = match value.get_ref() {
            DeValue::Table(t) => (Some(t), None),
            DeValue::Array(a) => (None, Some(a)),
            _ => (None, None),
        };
    }
    at
}

/// The [`TaskError::Config`] of a deserialisation error at key path `e.path()` of
/// `document` with the problem `message`; a bad value inside flattened run settings is
/// found again by [`run_settings_error`].
fn config_error(
    e: serde_path_to_error::Error<toml::de::Error>,
    document: &toml::Value,
    file: &Path,
    message: String,
) -> TaskError {
    let key = e.path().to_string();
    if let Some((inside, problem)) = run_settings_error(document)
        && (key == "." || inside.starts_with(&format!("{key}.")))
    {
        return TaskError::config(file, inside, problem);
    }
    let key = if key == "." {
        "<root>".to_string()
    } else {
        key
    };
    TaskError::config(file, key, message)
}

/// The key path and problem of a bad value inside the run settings (`guard`, `[solver]`,
/// `[metrics]`) of any table of the document. Configs flatten [`RunSettings`] into their
/// tables, and serde reads flattened fields from a buffer that has lost the key path; this
/// reads each table that has such keys as `RunSettings` alone to find it again.
fn run_settings_error(document: &toml::Value) -> Option<(String, String)> {
    fn walk(table: &toml::Table, prefix: &str) -> Option<(String, String)> {
        if ["guard", "solver", "metrics"]
            .iter()
            .any(|k| table.contains_key(*k))
        {
            let value = toml::Value::Table(table.clone());
            if let Err(e) = serde_path_to_error::deserialize::<_, RunSettings>(value) {
                let inner_key = e.path().to_string();
                let key = if prefix.is_empty() {
                    inner_key
                } else {
                    format!("{prefix}.{inner_key}")
                };
                return Some((key, e.into_inner().message().trim().to_string()));
            }
        }
        table.iter().find_map(|(k, v)| match v {
            toml::Value::Table(sub) if prefix.is_empty() => walk(sub, k),
            toml::Value::Table(sub) => walk(sub, &format!("{prefix}.{k}")),
            _ => None,
        })
    }
    walk(document.as_table()?, "")
}

/// A vehicle file read in its general form ([`VehicleSpec`]: axle lists, tyre laws,
/// relaxation, hitch torque), validated, with its plant and the paper-form equivalent.
#[derive(Debug, Clone)]
pub struct LoadedVehicle {
    /// the file as written
    pub spec: VehicleSpec,
    /// the plant of every task that takes any model ([`AnyVehicleModel::Paper`] for a
    /// vehicle of the paper's form: the paper's [`Model`])
    pub plant: AnyVehicleModel,
    /// the paper-form parameters ([`VehicleSpec::equivalent_params`]: identical to the
    /// file's keys for a vehicle of the paper's form; for a vehicle with variants the
    /// single-axle brush-tyre vehicle with the same statics and cornering stiffnesses; for a
    /// chain of towed units the towing unit with the first towed unit,
    /// [`trailer_model::ChainSpec::first_pair_params`]; for ranges and names only, never for
    /// its dynamics)
    pub params: VehicleParams,
    /// the paper's model of [`Self::params`]
    pub paper_model: Model,
    /// the first key that makes the vehicle differ from the paper's model
    /// ([`VehicleSpec::first_variant_key`]); None for a vehicle of the paper's form
    pub variant_key: Option<String>,
}

impl LoadedVehicle {
    /// Whether the vehicle is of the paper's form (one brush-tyre axle per group, σ = 0, a
    /// free hitch).
    pub fn is_paper_form(&self) -> bool {
        self.variant_key.is_none()
    }
}

/// A model error of a vehicle file as a config error naming the key.
fn vehicle_error(file: &Path, e: ModelError) -> TaskError {
    match e {
        ModelError::InvalidParameter {
            key,
            value,
            expected,
        } => TaskError::config(
            file,
            key,
            format!("{value} is invalid: expected {expected}"),
        ),
        ModelError::InvalidSpec {
            key,
            value,
            expected,
        } => TaskError::config(
            file,
            key,
            format!("{value} is invalid: expected {expected}"),
        ),
        ModelError::TireSpec { key, source } => TaskError::config(file, key, source.to_string()),
        other => TaskError::config(file, "<root>", other.to_string()),
    }
}

/// Loads a vehicle file in its general form (the paper's keys of `configs/vehicle.toml`,
/// plus the optional model variants of `configs/vehicles/*.toml`), validates it and builds
/// its plant.
///
/// # Errors
/// As [`load_toml`], plus [`TaskError::Config`] naming the key when a physical check
/// fails (positive masses, 0 < c < f, overlapping axles, a bad tyre law, …).
pub fn load_vehicle_spec(file: &Path) -> Result<LoadedVehicle, TaskError> {
    vehicle_from_spec(load_toml(file)?, file)
}

/// A vehicle given as a [`VehicleSpec`] (read from `file`, or built in memory and named
/// `file` in messages), validated as [`load_vehicle_spec`] validates a file, with its plant.
///
/// # Errors
/// [`TaskError::Config`] naming the key when a physical check fails.
pub fn vehicle_from_spec(spec: VehicleSpec, file: &Path) -> Result<LoadedVehicle, TaskError> {
    let checked = || -> Result<LoadedVehicle, ModelError> {
        spec.validate()?;
        if spec.is_chain() {
            // no paper-form equivalent: the towing unit with the first towed unit, as the
            // plant's own paper form (ranges, actuator scales and names)
            let plant = AnyVehicleModel::new(&spec)?;
            let paper_model = sway_model::vehicle::LoopModel::paper_model(&plant).clone();
            return Ok(LoadedVehicle {
                params: *paper_model.params(),
                paper_model,
                plant,
                variant_key: spec.first_variant_key()?,
                spec: spec.clone(),
            });
        }
        let params = spec.equivalent_params()?;
        Ok(LoadedVehicle {
            plant: AnyVehicleModel::new(&spec)?,
            paper_model: Model::new(params)?,
            variant_key: spec.first_variant_key()?,
            params,
            spec: spec.clone(),
        })
    };
    checked().map_err(|e| vehicle_error(file, e))
}

/// Loads a vehicle file (the form of `configs/vehicle.toml`, Table I) and builds the model.
///
/// # Errors
/// As [`load_toml`], plus [`TaskError::Config`] naming the parameter when a physical
/// check fails (positive masses, 0 < c < f, 0 < d < f, 0 < μ ≤ μ0, …).
pub fn load_vehicle(file: &Path) -> Result<(VehicleParams, Model), TaskError> {
    let params: VehicleParams = load_toml(file)?;
    let model = Model::new(params).map_err(|e| vehicle_error(file, e))?;
    Ok((params, model))
}

/// A task's config that can check itself beyond what deserialisation checks (ranges,
/// consistency between keys), so that the task can be prepared by the registry's
/// `prepare_config`.
pub trait TaskConfig: DeserializeOwned + Send + 'static {
    /// Checks the loaded config of `file`.
    ///
    /// # Errors
    /// [`TaskError::Config`] naming the key.
    fn check(&self, file: &Path) -> Result<(), TaskError>;

    /// Reads the files the config names (paths relative to `file`'s directory, e.g. a
    /// predictor's `prediction_vehicle`) into it; called after parsing, before
    /// [`Self::check`]. Nothing to read by default.
    ///
    /// # Errors
    /// [`TaskError::Config`] naming `file`, the key and the named file's problem.
    fn load_named_files(&mut self, _file: &Path) -> Result<(), TaskError> {
        Ok(())
    }
}

/// A vehicle file named under `key` of the config `file` (`relative` to its directory),
/// loaded and validated; its problems become the config's error under `key`.
///
/// # Errors
/// [`TaskError::Config`] naming `file`, `key` and the vehicle file's own error.
pub fn load_named_vehicle(
    file: &Path,
    key: &str,
    relative: &Path,
) -> Result<LoadedVehicle, TaskError> {
    let path = file.parent().unwrap_or(Path::new(".")).join(relative);
    load_vehicle_spec(&path).map_err(|e| {
        TaskError::config(
            file,
            key,
            format!(
                "the prediction vehicle {} is not valid: {e}",
                path.display()
            ),
        )
    })
}

/// Loads the `prediction_vehicle` of a predictor (`controller` under `key` of the config
/// `file`) as [`sway::sim::PredictionVehicle::loaded`]: the paper-form parameters of the
/// file's equivalent single-axle vehicle. Other controllers, and a predictor without
/// one, are left as they are.
///
/// # Errors
/// As [`load_named_vehicle`] under `key.prediction_vehicle`.
pub fn load_prediction_vehicle(
    controller: &mut sway::sim::ControllerTable,
    file: &Path,
    key: &str,
) -> Result<(), TaskError> {
    if let sway::sim::ControllerTable::Predictor {
        prediction_vehicle: Some(p),
        ..
    } = controller
    {
        let key = format!("{key}.prediction_vehicle");
        let loaded = load_named_vehicle(file, &key, &p.file)?;
        if loaded.spec.is_chain() {
            return Err(TaskError::config(
                file,
                key,
                format!(
                    "a vehicle of two units: the predictor's model is the paper's 4-state model, and `{}` is a chain of {} towed units",
                    p.file.display(),
                    loaded.spec.towed_units()
                ),
            ));
        }
        p.params = Some(loaded.params);
    }
    Ok(())
}

/// Checks a list of delays τ \[s\] under `key`: at least one, each finite and ≥ 0.
///
/// # Errors
/// [`TaskError::Config`] naming `key` or the failing entry `key[i]`.
pub fn check_delays(file: &Path, key: &str, delays_s: &[f64]) -> Result<(), TaskError> {
    ensure(!delays_s.is_empty(), file, key, || {
        "expected at least one delay".into()
    })?;
    for (i, t) in delays_s.iter().enumerate() {
        ensure(
            t.is_finite() && *t >= 0.0,
            file,
            &format!("{key}[{i}]"),
            || format!("delays must be finite and ≥ 0 s, got {t}"),
        )?;
    }
    Ok(())
}

/// A prepared task that is a config file and its checked contents (the common shape of the
/// tasks' `Prepared` values, made by the task registry's `prepare_config`).
#[derive(Debug)]
pub struct Configured<C> {
    /// the config file
    pub file: PathBuf,
    /// its contents, checked
    pub config: C,
}
