//! Reading TOML config files: typed, with `deny_unknown_fields`, and errors that name the
//! file, the key path and the problem. Nothing is computed before a config has loaded.

use std::path::Path;

use serde::de::DeserializeOwned;
use sway::SwayError;
use trailer_model::{Model, ModelError, VehicleParams};

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
