//! Result writing: a task writes into a staging directory which replaces
//! `results/<task>/` atomically when the task has succeeded, so a failed or interrupted
//! run leaves the previous results untouched and nothing half-written.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

use serde::Serialize;

use crate::TaskError;
pub use sway_studies::keyed::Keyed;

/// Formats a number for CSV: shortest round-trip form, exponent for very large/small
/// magnitudes, empty for NaN (a missing value).
pub fn fmt_num(x: f64) -> String {
    if x.is_nan() {
        String::new()
    } else {
        format!("{x:?}")
    }
}

/// Serialises the changes to `results/` (file writes, creating and committing a staging
/// directory) with [`interrupt`], so that an interruption never sees half a commit.
static RESULTS_LOCK: Mutex<()> = Mutex::new(());

/// Set by [`interrupt`]: no further result is written.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

fn results_lock() -> MutexGuard<'static, ()> {
    RESULTS_LOCK
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Whether [`interrupt`] has been called (a task may stop early).
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

fn refuse_if_interrupted(path: &Path) -> Result<(), TaskError> {
    if interrupted() {
        Err(TaskError::Write {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::Interrupted, "interrupted"),
        })
    } else {
        Ok(())
    }
}

/// Stops all result writing of this process and restores `results_root` to what it was
/// before the run: removes this process's staging directories and, if a commit was
/// between its two renames, puts the previous results back. Returns the removed
/// directories. Called from a signal handler thread (SIGINT, SIGTERM) right before the
/// process exits; the returned guard keeps every other writer blocked until then.
pub fn interrupt(results_root: &Path) -> (MutexGuard<'static, ()>, Vec<PathBuf>) {
    let guard = results_lock();
    INTERRUPTED.store(true, Ordering::SeqCst);
    let pid = std::process::id().to_string();
    let mut removed = Vec::new();
    let Ok(entries) = std::fs::read_dir(results_root) else {
        return (guard, removed);
    };
    for entry in entries.filter_map(Result::ok) {
        let Some(name) = entry.file_name().to_str().map(str::to_string) else {
            continue;
        };
        let path = entry.path();
        if staging_pid(&name).is_some_and(|p| p.to_string() == pid) {
            if std::fs::remove_dir_all(&path).is_ok() {
                removed.push(path);
            }
        } else if let Some(task) = name
            .strip_prefix('.')
            .and_then(|r| r.strip_suffix(&format!(".old-{pid}")))
        {
            // a commit was interrupted between its renames: the old results go back
            let final_dir = results_root.join(task);
            if !final_dir.exists() {
                let _ = std::fs::rename(&path, &final_dir);
            }
        }
    }
    (guard, removed)
}

/// Checks that results can be written under `results_root` (creating it if needed), by
/// creating and removing a probe directory: an unwritable `--results` is an error before
/// any work.
///
/// # Errors
/// [`TaskError::Write`] naming the directory.
pub fn ensure_writable(results_root: &Path) -> Result<(), TaskError> {
    let err = |source| TaskError::Write {
        path: results_root.to_path_buf(),
        source,
    };
    std::fs::create_dir_all(results_root).map_err(err)?;
    let probe = results_root.join(format!(".write-probe-{}", std::process::id()));
    std::fs::create_dir(&probe).map_err(err)?;
    std::fs::remove_dir(&probe).map_err(err)
}

/// Writes `bytes` to `path` through a temporary file and a rename.
///
/// # Errors
/// [`TaskError::Write`] naming the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), TaskError> {
    let err = |source| TaskError::Write {
        path: path.to_path_buf(),
        source,
    };
    let _lock = results_lock();
    refuse_if_interrupted(path)?;
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

/// A number in a CSV cell, written as [`fmt_num`] writes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl Serialize for Num {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&fmt_num(self.0))
    }
}

/// The cells of one CSV row and their column names: `value` serialised to JSON and
/// flattened in field order (nested objects and arrays contribute their leaves). Numbers
/// are written by [`fmt_num`] (the `csv` crate's own float format differs, e.g. `0.00005`
/// against `5e-5`), `null` as an empty cell.
///
/// # Errors
/// A value that does not serialise (a map with non-string keys).
pub fn row_cells(value: &impl Serialize) -> Result<(Vec<String>, Vec<String>), serde_json::Error> {
    fn leaves(key: &str, v: &serde_json::Value, names: &mut Vec<String>, cells: &mut Vec<String>) {
        use serde_json::Value;
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    leaves(k, x, names, cells);
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    leaves(&format!("{key}{i}"), x, names, cells);
                }
            }
            leaf => {
                names.push(key.to_string());
                cells.push(match leaf {
                    Value::Null => String::new(),
                    Value::String(s) => s.clone(),
                    Value::Number(n) if n.is_f64() => fmt_num(n.as_f64().unwrap_or(f64::NAN)),
                    other => other.to_string(),
                });
            }
        }
    }
    let (mut names, mut cells) = (Vec::new(), Vec::new());
    leaves("", &serde_json::to_value(value)?, &mut names, &mut cells);
    Ok((names, cells))
}

/// CSV text: the `header` row, then one record per `Serialize` row ([`row_cells`]), quoted
/// and escaped by the `csv` crate (RFC 4180).
///
/// # Errors
/// A row that does not serialise, or a CSV write error.
pub fn csv_text<H: AsRef<str>, R: Serialize>(
    header: &[H],
    rows: impl IntoIterator<Item = R>,
) -> Result<String, std::io::Error> {
    let mut w = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(Vec::new());
    w.write_record(header.iter().map(AsRef::as_ref))?;
    for row in rows {
        let (_, cells) = row_cells(&row).map_err(std::io::Error::other)?;
        w.write_record(&cells)?;
    }
    w.into_inner()
        .map_err(|e| std::io::Error::other(e.to_string()))
        .map(|bytes| String::from_utf8_lossy(&bytes).into_owned())
}

/// The column names of a row type: the leaves of `R::default()` ([`row_cells`]), so a
/// table's header is its row struct's field names and exists nowhere else.
///
/// # Errors
/// A row type that does not serialise.
pub fn columns<R: Serialize + Default>() -> Result<Vec<String>, serde_json::Error> {
    row_cells(&R::default()).map(|(names, _)| names)
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
    /// [`TaskError::Write`] if the staging directory cannot be created.
    pub fn create(results_root: &Path, name: &str) -> Result<Self, TaskError> {
        let final_dir = results_root.join(name);
        let staging = results_root.join(format!(".{name}.staging-{}", std::process::id()));
        let err = |source| TaskError::Write {
            path: staging.clone(),
            source,
        };
        let _lock = results_lock();
        refuse_if_interrupted(&staging)?;
        remove_stale_staging(results_root)?;
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
    /// [`TaskError::Write`].
    pub fn write_csv<R: AsRef<[f64]>>(
        &self,
        file: &str,
        header: &[&str],
        rows: impl IntoIterator<Item = R>,
    ) -> Result<(), TaskError> {
        let rows = rows
            .into_iter()
            .map(|r| r.as_ref().iter().copied().map(Num).collect::<Vec<_>>());
        self.write_rows(file, header, rows)
    }

    /// Writes a CSV of typed rows whose header is the row type's field names ([`columns`]).
    ///
    /// # Errors
    /// [`TaskError::Write`].
    pub fn write_table<R: Serialize + Default>(
        &self,
        file: &str,
        rows: impl IntoIterator<Item = R>,
    ) -> Result<(), TaskError> {
        let header = columns::<R>().map_err(|e| self.write_error(file, e))?;
        self.write_rows(file, &header, rows)
    }

    /// Writes a CSV of `Serialize` rows ([`csv_text`]) under `header`.
    ///
    /// # Errors
    /// [`TaskError::Write`].
    pub fn write_rows<H: AsRef<str>, R: Serialize>(
        &self,
        file: &str,
        header: &[H],
        rows: impl IntoIterator<Item = R>,
    ) -> Result<(), TaskError> {
        let text = csv_text(header, rows).map_err(|e| self.write_error(file, e))?;
        write_atomic(&self.path(file), text.as_bytes())
    }

    fn write_error(
        &self,
        file: &str,
        e: impl Into<Box<dyn std::error::Error + Send + Sync>>,
    ) -> TaskError {
        TaskError::Write {
            path: self.path(file),
            source: std::io::Error::other(e),
        }
    }

    /// Writes any serialisable value as pretty JSON.
    ///
    /// # Errors
    /// [`TaskError::Write`].
    pub fn write_json(&self, file: &str, value: &impl Serialize) -> Result<(), TaskError> {
        let text = serde_json::to_string_pretty(value).map_err(|e| self.write_error(file, e))?;
        write_atomic(&self.path(file), text.as_bytes())
    }

    /// Writes `summary.json` ([`Summary`]): the task's headline fields, then the inputs
    /// of the run and its wall time.
    ///
    /// # Errors
    /// [`TaskError::Write`].
    pub fn write_summary<H: Serialize, C: Serialize>(
        &self,
        headline: H,
        config: &C,
        run: &RunInfo<'_>,
    ) -> Result<(), TaskError> {
        let summary = Summary {
            headline,
            task: &self.name,
            config_file: display_path(run.config_file),
            config,
            vehicle_file: display_path(run.vehicle_file),
            vehicle: run.vehicle,
            wall_time_s: self.elapsed_s(),
        };
        self.write_json("summary.json", &summary)
    }

    /// Replaces `results/<name>/` by the staged directory.
    ///
    /// # Errors
    /// [`TaskError::Write`] if a rename fails (the previous results are then kept).
    pub fn commit(self) -> Result<PathBuf, TaskError> {
        let err = |path: &Path| {
            let path = path.to_path_buf();
            move |source| TaskError::Write { path, source }
        };
        let old =
            self.final_dir
                .with_file_name(format!(".{}.old-{}", self.name, std::process::id()));
        let _lock = results_lock();
        refuse_if_interrupted(&self.final_dir)?;
        if self.final_dir.exists() {
            std::fs::rename(&self.final_dir, &old).map_err(err(&self.final_dir))?;
        }
        if let Err(source) = std::fs::rename(&self.staging, &self.final_dir) {
            let _ = std::fs::rename(&old, &self.final_dir);
            return Err(TaskError::Write {
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

/// The pid of a staging directory name `.<task>.staging-<pid>`.
fn staging_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?;
    let (_, pid) = rest.rsplit_once(".staging-")?;
    pid.parse().ok()
}

/// Whether process `pid` is alive. Only Linux can tell (`/proc/<pid>`); elsewhere every
/// process counts as alive, so nothing of a running process is ever removed.
fn process_alive(pid: u32) -> bool {
    if cfg!(target_os = "linux") {
        Path::new("/proc").join(pid.to_string()).exists()
    } else {
        true
    }
}

/// Removes the staging directories `results_root/.<task>.staging-<pid>` left behind by
/// runs that were killed (their process `pid` is no longer alive); a running task's
/// staging directory is kept. Returns the removed directories.
///
/// # Errors
/// [`TaskError::Write`] if a stale directory cannot be removed.
pub fn remove_stale_staging(results_root: &Path) -> Result<Vec<PathBuf>, TaskError> {
    let Ok(entries) = std::fs::read_dir(results_root) else {
        return Ok(Vec::new()); // no results directory yet: nothing is stale
    };
    let mut removed = Vec::new();
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(staging_pid) else {
            continue;
        };
        if pid == std::process::id() || process_alive(pid) || !entry.path().is_dir() {
            continue;
        }
        let path = entry.path();
        std::fs::remove_dir_all(&path).map_err(|source| TaskError::Write {
            path: path.clone(),
            source,
        })?;
        removed.push(path);
    }
    Ok(removed)
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

/// The schema of every `summary.json`: the task's own headline fields first (a
/// `#[derive(Serialize)]` struct of the task, flattened into the top level), then
///
/// - `task`: the task name (the results directory),
/// - `config_file`, `config`: the task config file and its contents as the task ran them,
/// - `vehicle_file`, `vehicle`: the vehicle file and its parameters (Table I),
/// - `wall_time_s`: the run's wall-clock time \[s\] (the one field that differs between
///   two runs).
#[derive(Debug, Serialize)]
pub struct Summary<'a, H, C> {
    /// the task's headline fields
    #[serde(flatten)]
    pub headline: H,
    /// task name
    pub task: &'a str,
    /// the task config file, relative to the working directory when inside it
    pub config_file: String,
    /// the task config
    pub config: &'a C,
    /// the vehicle file, relative to the working directory when inside it
    pub vehicle_file: String,
    /// the vehicle: its paper-form parameters, or a chain's file
    pub vehicle: VehicleRecord<'a>,
    /// wall-clock time of the run \[s\]
    pub wall_time_s: f64,
}

/// Keys of a summary that name a search's cap or range rather than a speed it found.
const CAP_KEYS: [&str; 3] = ["v_max_mps", "max_speed_mps", "searched_mps"];

/// Words of a key that names a range, an axis or a limit (`v_range_mps`,
/// `diagram_range_mps`, `speed_for_gain_interval_mps`, a curve end's `limit_mps`): its
/// speeds are inputs or bounds, one end the cap when the range reaches it.
const RANGE_WORDS: [&str; 3] = ["range", "interval", "limit"];

/// A key whose speeds are a cap, a range or a limit, not speeds a search found.
fn names_a_bound(key: &str) -> bool {
    CAP_KEYS.contains(&key) || RANGE_WORDS.iter().any(|w| key.contains(w))
}

/// Keys of a summary whose whole subtree records how a chart's axes were chosen (a speed
/// there is a scale or an axis end, the cap where the vehicle is stable up to it), not a
/// finding: `sway::charts::Derivation`.
const AXIS_KEYS: [&str; 1] = ["derivation"];

/// The speeds of a `summary.json` that equal a search's `cap` \[m/s\] without saying so: the
/// JSON paths of the numbers under a key ending `_mps` (in an array under one too) that
/// equal `cap` in an object with no key ending `stable_up_to_mps`. The README's convention is
/// that a speed the cap cut off is null, with `stable_up_to_mps` = the cap and a `reason`
/// (`sway::ranging::CappedSpeed`); a number equal to the cap is then a capped value
/// reported as a measured one. Not reports, so not looked at: the keys naming a cap, a
/// searched range or a limit (`v_max_mps`, `max_speed_mps`, `searched_mps`, a key with
/// `range`, `interval` or `limit` in its name), the ones ending
/// `stable_up_to_mps`, the record of how a chart's axes were derived (`derivation`), and
/// the inputs echoed at the top level (`config`, `vehicle`).
pub fn speeds_at_cap(summary: &serde_json::Value, cap: f64) -> Vec<String> {
    use serde_json::Value;
    fn numbers(v: &Value, path: &str, cap: f64, out: &mut Vec<String>) {
        match v {
            Value::Number(n) if n.as_f64() == Some(cap) => out.push(path.to_string()),
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    numbers(x, &format!("{path}[{i}]"), cap, out);
                }
            }
            _ => {}
        }
    }
    fn walk(v: &Value, path: &str, cap: f64, out: &mut Vec<String>) {
        match v {
            Value::Object(m) => {
                let said = m
                    .iter()
                    .any(|(k, x)| k.ends_with("stable_up_to_mps") && !x.is_null());
                for (k, x) in m.iter().filter(|(k, _)| !AXIS_KEYS.contains(&k.as_str())) {
                    let here = format!("{path}.{k}");
                    let report = k.ends_with("_mps")
                        && !k.ends_with("stable_up_to_mps")
                        && !names_a_bound(k);
                    if report && !said {
                        numbers(x, &here, cap, out);
                    }
                    walk(x, &here, cap, out);
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    walk(x, &format!("{path}[{i}]"), cap, out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    match summary {
        Value::Object(m) => {
            let reports = Value::Object(
                m.iter()
                    .filter(|(k, _)| !matches!(k.as_str(), "config" | "vehicle"))
                    .map(|(k, x)| (k.clone(), x.clone()))
                    .collect(),
            );
            walk(&reports, "", cap, &mut out);
        }
        other => walk(other, "", cap, &mut out),
    }
    out
}

/// What a summary records about the inputs of a run.
#[derive(Debug, Clone, Copy)]
pub struct RunInfo<'a> {
    /// the task config file
    pub config_file: &'a Path,
    /// the vehicle file
    pub vehicle_file: &'a Path,
    /// the vehicle used
    pub vehicle: VehicleRecord<'a>,
}

/// The vehicle of a summary: the paper-form parameters of a two-unit vehicle (a file with
/// model variants: its equivalent single-axle vehicle, as before), or the whole file of a
/// chain of towed units, whose paper form would show only its first pair.
#[derive(Debug, Clone, Copy, Serialize)]
#[serde(untagged)]
pub enum VehicleRecord<'a> {
    /// a two-unit vehicle
    Pair(&'a trailer_model::VehicleParams),
    /// a chain of towed units (`[[trailers]]`)
    Chain(&'a trailer_model::VehicleSpec),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_field_with_a_comma_and_a_quote_round_trips() {
        // reference: the csv crate's reader (RFC 4180 unquoting) reads back what we wrote
        #[derive(Serialize, Default)]
        struct Row {
            name: String,
            value: f64,
            missing: Option<f64>,
        }
        let nasty = r#"solver said "no", twice"#.to_string();
        let text = csv_text(
            &columns::<Row>().expect("names"),
            [Row {
                name: nasty.clone(),
                value: 5e-5,
                missing: None,
            }],
        )
        .expect("writes");
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let header: Vec<String> = r
            .headers()
            .expect("header")
            .iter()
            .map(String::from)
            .collect();
        assert_eq!(header, ["name", "value", "missing"]);
        let rec = r.records().next().expect("one row").expect("parses");
        assert_eq!(&rec[0], nasty);
        // numbers as fmt_num writes them, None empty
        assert_eq!((&rec[1], &rec[2]), ("5e-5", ""));
    }

    #[test]
    fn numeric_tables_are_written_as_before() {
        // reference: the hand-joined format of earlier versions (committed results)
        let text = csv_text(
            &["a", "b"],
            [vec![Num(1.0), Num(f64::NAN)], vec![Num(-3e-7), Num(1e16)]],
        )
        .expect("writes");
        assert_eq!(text, "a,b\n1.0,\n-3e-7,1e16\n");
    }

    #[test]
    fn stale_staging_of_dead_processes_is_removed_and_live_ones_kept() {
        let tmp = tempfile::tempdir().expect("tempdir");
        // u32::MAX - 1 is above any pid limit (Linux allows at most 2^22): never alive
        let dead = tmp.path().join(format!(".fig3b.staging-{}", u32::MAX - 1));
        let own = tmp
            .path()
            .join(format!(".linear.staging-{}", std::process::id()));
        let other = tmp.path().join(".not-staging");
        for d in [&dead, &own, &other] {
            std::fs::create_dir_all(d).expect("mkdir");
        }
        let removed = remove_stale_staging(tmp.path()).expect("removes");
        if cfg!(target_os = "linux") {
            assert_eq!(removed, vec![dead.clone()]);
            assert!(!dead.exists());
        }
        assert!(own.exists() && other.exists());
        assert_eq!(staging_pid(".fig3a.staging-42"), Some(42));
        assert_eq!(staging_pid("fig3a"), None);
    }
}
