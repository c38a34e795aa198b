//! Loading TOML configs: typed, with `deny_unknown_fields`, and errors that name the
//! file, the key path and the problem. Nothing is computed before a config has loaded.

use std::path::Path;

use serde::de::DeserializeOwned;
use trailer_model::{Model, ModelError, VehicleParams};

use crate::SwayError;

/// Reads and deserialises a TOML file into `T`.
///
/// # Errors
/// [`SwayError::Read`] if the file cannot be read; [`SwayError::Config`] with the key path
/// (e.g. `tractor.mass`) and line for syntax errors, unknown keys and wrong types.
pub fn load_toml<T: DeserializeOwned>(file: &Path) -> Result<T, SwayError> {
    let text = std::fs::read_to_string(file).map_err(|source| SwayError::Read {
        file: file.to_path_buf(),
        source,
    })?;
    parse_toml(&text, file)
}

/// Deserialises TOML text; `file` is only used in error messages.
///
/// # Errors
/// [`SwayError::Config`] naming the key path, the line and the problem.
pub fn parse_toml<T: DeserializeOwned>(text: &str, file: &Path) -> Result<T, SwayError> {
    let located = |message: &str, span: Option<std::ops::Range<usize>>| match span {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            format!("{} (line {line})", message.trim())
        }
        None => message.trim().to_string(),
    };
    let de = toml::de::Deserializer::parse(text)
        .map_err(|e| SwayError::config(file, "<syntax>", located(e.message(), e.span())))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        let key = if key == "." {
            "<root>".to_string()
        } else {
            key
        };
        SwayError::config(file, key, located(inner.message(), inner.span()))
    })
}

/// Loads a vehicle file (the form of `configs/vehicle.toml`, Table I) and builds the model.
///
/// # Errors
/// As [`load_toml`], plus [`SwayError::Config`] naming the parameter when a physical
/// check fails (positive masses, 0 < c < f, 0 < d < f, 0 < μ ≤ μ0, …).
pub fn load_vehicle(file: &Path) -> Result<(VehicleParams, Model), SwayError> {
    let params: VehicleParams = load_toml(file)?;
    let model = Model::new(params).map_err(|e| match e {
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
    })?;
    Ok((params, model))
}

/// Returns a [`SwayError::Config`] for `key` unless `ok` holds.
pub fn ensure(
    ok: bool,
    file: &Path,
    key: &str,
    problem: impl FnOnce() -> String,
) -> Result<(), SwayError> {
    if ok {
        Ok(())
    } else {
        Err(SwayError::config(file, key, problem()))
    }
}

/// `value` must be finite and > 0 (`what` names the unit or meaning, e.g. "a horizon > 0 s").
///
/// # Errors
/// [`SwayError::Config`] naming `key`.
pub fn ensure_positive(value: f64, file: &Path, key: &str, what: &str) -> Result<(), SwayError> {
    ensure(value.is_finite() && value > 0.0, file, key, || {
        format!("expected {what}, got {value}")
    })
}

/// A simulated time span: `horizon` > 0 s and an output step in (0, horizon]; keys are
/// `<prefix>horizon_s` and `<prefix>output_step_s`.
///
/// # Errors
/// [`SwayError::Config`] naming the key.
pub fn ensure_time_span(
    horizon: f64,
    output_step: f64,
    file: &Path,
    prefix: &str,
) -> Result<(), SwayError> {
    ensure_positive(
        horizon,
        file,
        &format!("{prefix}horizon_s"),
        "a horizon > 0 s",
    )?;
    ensure(
        output_step > 0.0 && output_step <= horizon,
        file,
        &format!("{prefix}output_step_s"),
        || format!("expected 0 < output_step_s <= horizon_s, got {output_step}"),
    )
}

/// A uniform grid `[min, max]` with `points` points, as written in task configs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// first value
    pub min: f64,
    /// last value
    pub max: f64,
    /// number of points (≥ 2)
    pub points: usize,
}

impl Grid {
    /// Checks min < max (finite) and points ≥ 2; `key` names the grid in the error.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming `key`.
    pub fn validate(&self, file: &Path, key: &str) -> Result<(), SwayError> {
        ensure(
            self.min.is_finite() && self.max.is_finite() && self.min < self.max,
            file,
            key,
            || {
                format!(
                    "expected finite min < max, got min = {}, max = {}",
                    self.min, self.max
                )
            },
        )?;
        ensure(self.points >= 2, file, &format!("{key}.points"), || {
            format!("expected at least 2 points, got {}", self.points)
        })
    }

    /// The grid values (the last one is exactly `max`).
    pub fn values(&self) -> Vec<f64> {
        let n = self.points.max(2);
        (0..n)
            .map(|i| {
                if i + 1 == n {
                    self.max
                } else {
                    self.min + (self.max - self.min) * i as f64 / (n - 1) as f64
                }
            })
            .collect()
    }
}
