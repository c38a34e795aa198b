//! Result writing: a task writes into a staging directory which replaces
//! `results/<task>/` atomically when the task has succeeded, so a failed or interrupted
//! run leaves the previous results untouched and nothing half-written.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use serde_json::{Map, Value};

use crate::SwayError;

/// Formats a number for CSV: shortest round-trip form, exponent for very large/small
/// magnitudes, empty for NaN (a missing value).
pub fn fmt_num(x: f64) -> String {
    if x.is_nan() {
        String::new()
    } else {
        format!("{x:?}")
    }
}

/// Writes `bytes` to `path` through a temporary file and a rename.
///
/// # Errors
/// [`SwayError::Write`] naming the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SwayError> {
    let err = |source| SwayError::Write {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(err)?;
    }
    let tmp = path.with_extension(format!(
        "{}.tmp",
        path.extension().and_then(|e| e.to_str()).unwrap_or("")
    ));
    std::fs::write(&tmp, bytes).map_err(err)?;
    std::fs::rename(&tmp, path).map_err(err)
}

/// CSV text from a header and rows of numbers.
pub fn csv_text<R: AsRef<[f64]>>(header: &[&str], rows: impl IntoIterator<Item = R>) -> String {
    let mut s = header.join(",");
    s.push('\n');
    for row in rows {
        let cells: Vec<String> = row.as_ref().iter().map(|&x| fmt_num(x)).collect();
        let _ = writeln!(s, "{}", cells.join(","));
    }
    s
}

/// The output directory of one task run (`results/<name>/`), staged until [`commit`](Self::commit).
#[derive(Debug)]
pub struct OutputDir {
    name: String,
    final_dir: PathBuf,
    staging: PathBuf,
    started: Instant,
}

impl OutputDir {
    /// Starts a run of task `name` whose results go to `results_root/name/`.
    ///
    /// # Errors
    /// [`SwayError::Write`] if the staging directory cannot be created.
    pub fn create(results_root: &Path, name: &str) -> Result<Self, SwayError> {
        let final_dir = results_root.join(name);
        let staging = results_root.join(format!(".{name}.staging-{}", std::process::id()));
        let err = |source| SwayError::Write {
            path: staging.clone(),
            source,
        };
        if staging.exists() {
            std::fs::remove_dir_all(&staging).map_err(err)?;
        }
        std::fs::create_dir_all(&staging).map_err(err)?;
        Ok(Self {
            name: name.to_string(),
            final_dir,
            staging,
            started: Instant::now(),
        })
    }

    /// The task name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Path of `file` inside the (staged) output directory.
    pub fn path(&self, file: &str) -> PathBuf {
        self.staging.join(file)
    }

    /// Where the results will be once committed.
    pub fn final_dir(&self) -> &Path {
        &self.final_dir
    }

    /// Seconds since the run started.
    pub fn elapsed_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// Writes a CSV of numbers with a header row.
    ///
    /// # Errors
    /// [`SwayError::Write`].
    pub fn write_csv<R: AsRef<[f64]>>(
        &self,
        file: &str,
        header: &[&str],
        rows: impl IntoIterator<Item = R>,
    ) -> Result<(), SwayError> {
        write_atomic(&self.path(file), csv_text(header, rows).as_bytes())
    }

    /// Writes a CSV of already formatted cells (mixed text and numbers).
    ///
    /// # Errors
    /// [`SwayError::Write`].
    pub fn write_csv_cells(
        &self,
        file: &str,
        header: &[&str],
        rows: &[Vec<String>],
    ) -> Result<(), SwayError> {
        let mut s = header.join(",");
        s.push('\n');
        for row in rows {
            let _ = writeln!(s, "{}", row.join(","));
        }
        write_atomic(&self.path(file), s.as_bytes())
    }

    /// Writes any serialisable value as pretty JSON.
    ///
    /// # Errors
    /// [`SwayError::Write`].
    pub fn write_json(&self, file: &str, value: &impl Serialize) -> Result<(), SwayError> {
        let text = serde_json::to_string_pretty(value).map_err(|e| SwayError::Write {
            path: self.path(file),
            source: std::io::Error::other(e),
        })?;
        write_atomic(&self.path(file), text.as_bytes())
    }

    /// Writes `summary.json`: the task's headline fields, then `"task"`, `"config"` (the
    /// task config as it ran), `"vehicle"` (the parameters and their file) and
    /// `"wall_time_s"`.
    ///
    /// # Errors
    /// [`SwayError::Write`].
    pub fn write_summary(
        &self,
        headline: Map<String, Value>,
        config: &impl Serialize,
        vehicle: &RunInfo<'_>,
    ) -> Result<(), SwayError> {
        let mut m = headline;
        m.insert("task".into(), Value::from(self.name.clone()));
        m.insert(
            "config_file".into(),
            Value::from(display_path(vehicle.config_file)),
        );
        m.insert(
            "config".into(),
            serde_json::to_value(config).unwrap_or(Value::Null),
        );
        m.insert(
            "vehicle_file".into(),
            Value::from(display_path(vehicle.vehicle_file)),
        );
        m.insert(
            "vehicle".into(),
            serde_json::to_value(vehicle.vehicle).unwrap_or(Value::Null),
        );
        m.insert("wall_time_s".into(), Value::from(self.elapsed_s()));
        self.write_json("summary.json", &Value::Object(m))
    }

    /// Replaces `results/<name>/` by the staged directory.
    ///
    /// # Errors
    /// [`SwayError::Write`] if a rename fails (the previous results are then kept).
    pub fn commit(self) -> Result<PathBuf, SwayError> {
        let err = |path: &Path| {
            let path = path.to_path_buf();
            move |source| SwayError::Write { path, source }
        };
        let old =
            self.final_dir
                .with_file_name(format!(".{}.old-{}", self.name, std::process::id()));
        if self.final_dir.exists() {
            std::fs::rename(&self.final_dir, &old).map_err(err(&self.final_dir))?;
        }
        if let Err(source) = std::fs::rename(&self.staging, &self.final_dir) {
            let _ = std::fs::rename(&old, &self.final_dir);
            return Err(SwayError::Write {
                path: self.final_dir.clone(),
                source,
            });
        }
        if old.exists() {
            std::fs::remove_dir_all(&old).map_err(err(&old))?;
        }
        Ok(self.final_dir.clone())
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        // an uncommitted run leaves nothing behind
        if self.staging.exists() {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// A path as recorded in summaries: relative to the working directory when inside it,
/// so committed results do not carry one machine's absolute paths.
pub fn display_path(path: &Path) -> String {
    let rel = std::env::current_dir()
        .ok()
        .and_then(|cwd| path.strip_prefix(cwd).ok().map(Path::to_path_buf));
    rel.unwrap_or_else(|| path.to_path_buf())
        .display()
        .to_string()
}

/// What a summary records about the inputs of a run.
#[derive(Debug, Clone, Copy)]
pub struct RunInfo<'a> {
    /// the task config file
    pub config_file: &'a Path,
    /// the vehicle file
    pub vehicle_file: &'a Path,
    /// the vehicle parameters used
    pub vehicle: &'a trailer_model::VehicleParams,
}
