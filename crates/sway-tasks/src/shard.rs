//! Sharding and merging of studies whose work is an indexed list of independent points: a
//! sweep of a million points runs as N slices on N machines (a SLURM job
//! array) and merges into exactly the files of a run on one machine.
//!
//! - [`ShardSpec`] `K/N` is the K-th of N contiguous, balanced slices of the points
//!   `0..total`, **K counted from 1** (`1/4` … `4/4`, the SLURM array `1-N`): slice K holds
//!   the points `⌊(K−1)·total/N⌋ .. ⌊K·total/N⌋`, so the N slices cover every point exactly
//!   once and their sizes differ by at most one.
//! - [`run_shard`] computes one slice of a [`PointwiseTask`] and writes the shard file
//!   `shard-K-of-N.json` atomically (temporary file + rename, [`crate::io::write_atomic`]).
//!   The file holds the [`Provenance`] (config hash, K, N, tool version, point range, the
//!   config and vehicle files), the parsed config, the vehicle parameters and the per-point
//!   results in point order. It carries no time stamp or host name: re-running a shard
//!   rewrites the same bytes (idempotent).
//! - [`merge_dir`] reads a directory of shard files, checks that they all belong to one
//!   config and together are complete ([`ShardError`] names every missing, failed,
//!   duplicated or foreign shard), concatenates the results in point order and writes the
//!   task's outputs through the same function as an unsharded run. Every point is a pure
//!   function of (model, config, k) and its result round-trips exactly through JSON, so the
//!   merged data are byte for byte those of the unsharded run whatever N.
//!
//! The config hash is FNV-1a (64 bit) of the canonical JSON of the task kind, the parsed
//! and normalised config (defaults filled in) and the vehicle parameters: two runs of the
//! same study hash alike whatever the formatting, comments or paths of their files. It
//! identifies a study for bookkeeping; it is not a cryptographic checksum.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::TaskError;
use rayon::prelude::*;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use sway::progress::Progress;
use sway::ranging::SpeedSpec;
use sway_studies::sweep::{PointResult, SweepConfig};
use trailer_model::{Model, VehicleParams, VehicleSpec};

use crate::config_file::{TaskConfig, load_toml};
use crate::io::OutputDir;
use crate::tasks::study_generated::{self, StudyGeneratedConfig};
use crate::tasks::sway_assist;
use crate::tasks::{Report, TaskContext};
use sway_studies::sway_assist::{AssistPlan, AssistPoint, SwayAssistConfig};

/// The format tag of a shard file.
pub const FORMAT: &str = "trailer-sway shard 1";

/// The version of the tool that writes shard files; shards of another version are
/// foreign (their results may differ in the last digits).
pub const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");

/// The largest shard count N (a SLURM array is limited to `MaxArraySize`, 1001 by default).
pub const MAX_SHARDS: usize = 100_000;

/// Errors of sharding and merging: each names the shard(s) or file and says what to do.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    /// `--shard` is not `K/N` with 1 ≤ K ≤ N ≤ [`MAX_SHARDS`].
    #[error(
        "`{given}` is not a shard K/N: {problem} (e.g. `--shard 2/4` is the 2nd of 4 slices; K counts from 1 to N ≤ {MAX_SHARDS})"
    )]
    BadSpec {
        /// what was given
        given: String,
        /// what is wrong
        problem: String,
    },
    /// The task cannot be sharded.
    #[error("task `{task}` cannot be sharded; tasks that can: {shardable}")]
    NotShardable {
        /// the task name
        task: String,
        /// the tasks that can, comma separated
        shardable: String,
    },
    /// The directory holds no shard file.
    #[error(
        "{}: no shard files (shard-K-of-N.json); write them with `cargo xtask TASK --config FILE --shard K/N --shard-dir {}` (TASK: sweep, brake_timing, study_generated, sway_assist or sway_assist_full)",
        dir.display(),
        dir.display()
    )]
    NoShards {
        /// the directory
        dir: PathBuf,
    },
    /// A file named like a shard is not a readable shard of this format.
    #[error("{}: not a readable shard file ({FORMAT}): {problem}; remove it or re-run its shard", file.display())]
    Unreadable {
        /// the file
        file: PathBuf,
        /// what is wrong
        problem: String,
    },
    /// A shard of another study (config, vehicle, task kind or tool version).
    #[error(
        "{}: foreign shard {shard}/{shards}: {reason}; this directory's study is config `{}` with hash {} (tool {}, {} shard file(s)); move the foreign shard out or use a separate --shard-dir per study",
        file.display(),
        expected.name,
        expected.config_hash,
        expected.tool_version,
        expected.shard_files
    )]
    Foreign {
        /// the foreign file
        file: PathBuf,
        /// its shard index K
        shard: usize,
        /// its shard count N
        shards: usize,
        /// how it differs
        reason: String,
        /// the study the directory holds
        expected: Box<Study>,
    },
    /// Shards of the same study cut into different counts N.
    #[error(
        "{}: shards of the same study with different shard counts N = {counts:?}; keep one run's shards per directory (use a fresh --shard-dir) and merge again",
        dir.display()
    )]
    MixedCounts {
        /// the directory
        dir: PathBuf,
        /// the counts found
        counts: Vec<usize>,
    },
    /// Two files hold the same shard.
    #[error(
        "shard {shard}/{shards} is duplicated: {}; keep one of them",
        list_paths(files)
    )]
    Duplicated {
        /// the shard index K
        shard: usize,
        /// the shard count N
        shards: usize,
        /// the files
        files: Vec<PathBuf>,
    },
    /// Shards are missing or failed.
    #[error(
        "{}: incomplete study, {} of {shards} shards have no results: {}; re-run them with `cargo xtask {task} --config FILE --shard K/{shards}` (under SLURM, see their logs), then merge again",
        dir.display(),
        missing.len() + failed.len(),
        describe_incomplete(missing, failed, *shards)
    )]
    Incomplete {
        /// the directory
        dir: PathBuf,
        /// the task whose shards these are (`TASK` when no shard says)
        task: String,
        /// the shard count N
        shards: usize,
        /// shards K without a file
        missing: Vec<usize>,
        /// shards K whose run failed, with the error it recorded
        failed: Vec<(usize, String)>,
    },
    /// A shard file contradicts its own provenance (edited or corrupted).
    #[error("{}: inconsistent shard: {problem}; re-run its shard", file.display())]
    Inconsistent {
        /// the file
        file: PathBuf,
        /// what is inconsistent
        problem: String,
    },
    /// The task itself failed (config, vehicle, computation or writing).
    #[error(transparent)]
    Task(#[from] TaskError),
}

fn list_paths(files: &[PathBuf]) -> String {
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    names.join(" and ")
}

fn describe_incomplete(missing: &[usize], failed: &[(usize, String)], n: usize) -> String {
    let mut parts = Vec::new();
    if !missing.is_empty() {
        let ks: Vec<String> = missing.iter().map(|k| format!("{k}/{n}")).collect();
        parts.push(format!("missing {}", ks.join(", ")));
    }
    for (k, e) in failed {
        parts.push(format!("failed {k}/{n} ({e})"));
    }
    parts.join("; ")
}

/// A study as a shard directory names it: the one with the most shard files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Study {
    /// its config name
    pub name: String,
    /// its config hash
    pub config_hash: String,
    /// the tool version that wrote it
    pub tool_version: String,
    /// how many shard files belong to it
    pub shard_files: usize,
}

/// One slice `K/N` of the points: K from 1 to N.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct ShardSpec {
    /// K, from 1
    pub shard: usize,
    /// N
    pub shards: usize,
}

impl ShardSpec {
    /// Shard `shard` of `shards`.
    ///
    /// # Errors
    /// [`ShardError::BadSpec`] unless 1 ≤ K ≤ N ≤ [`MAX_SHARDS`].
    pub fn new(shard: usize, shards: usize) -> Result<Self, ShardError> {
        let bad = |problem: String| ShardError::BadSpec {
            given: format!("{shard}/{shards}"),
            problem,
        };
        if shards == 0 || shards > MAX_SHARDS {
            return Err(bad(format!("N = {shards} is not in 1..={MAX_SHARDS}")));
        }
        if shard == 0 || shard > shards {
            return Err(bad(format!("K = {shard} is not in 1..={shards}")));
        }
        Ok(Self { shard, shards })
    }

    /// The points `⌊(K−1)·total/N⌋ .. ⌊K·total/N⌋` of `0..total`.
    pub fn range(&self, total: usize) -> Range<usize> {
        let cut = |k: usize| ((k as u128 * total as u128) / self.shards as u128) as usize;
        cut(self.shard - 1)..cut(self.shard)
    }

    /// The shard file's name, `shard-K-of-N.json` with K zero-padded to the width of N
    /// (so the files sort in point order).
    pub fn file_name(&self) -> String {
        format!("{}.json", self.stem())
    }

    /// The failure record's name, `shard-K-of-N.failed.json`.
    pub fn failure_name(&self) -> String {
        format!("{}.failed.json", self.stem())
    }

    fn stem(&self) -> String {
        let w = self.shards.to_string().len();
        format!("shard-{:0w$}-of-{}", self.shard, self.shards)
    }
}

impl std::fmt::Display for ShardSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.shard, self.shards)
    }
}

impl std::str::FromStr for ShardSpec {
    type Err = ShardError;

    /// Parses `K/N`.
    fn from_str(s: &str) -> Result<Self, ShardError> {
        let bad = |problem: &str| ShardError::BadSpec {
            given: s.to_string(),
            problem: problem.to_string(),
        };
        let (k, n) = s.split_once('/').ok_or_else(|| bad("expected K/N"))?;
        let k = k
            .trim()
            .parse()
            .map_err(|_| bad("K is not a whole number"))?;
        let n = n
            .trim()
            .parse()
            .map_err(|_| bad("N is not a whole number"))?;
        Self::new(k, n)
    }
}

/// A study whose work is an indexed list of independent points with serialisable results.
/// Implemented by marker types (e.g. [`SweepPoints`]); everything is an associated function.
pub trait PointwiseTask {
    /// The kind recorded in a shard file, which [`merge_dir`] dispatches on.
    const KIND: &'static str;
    /// The task config (parsed, normalised, serialisable).
    type Config: Serialize + DeserializeOwned + Sync;
    /// The result of one point; must round-trip exactly through JSON.
    type Point: Serialize + DeserializeOwned + Send;
    /// Everything a point needs, built once from the inputs ([`PointwiseTask::prepare`]).
    type Points: Sync;
    /// How the points of a shard share the machine.
    const SCHEDULE: PointSchedule = PointSchedule::SideBySide;

    /// Loads and validates a config file.
    ///
    /// # Errors
    /// Read and config errors naming the key.
    fn load(file: &Path) -> Result<Self::Config, TaskError>;
    /// The study's name (its results directory).
    fn name(config: &Self::Config) -> &str;
    /// Further vehicles the study reads besides `ctx`'s (a fleet), in a fixed order: they
    /// enter the config hash.
    ///
    /// # Errors
    /// Read and config errors naming the file and key.
    fn fleet(
        ctx: &TaskContext<'_>,
        config: &Self::Config,
        config_file: &Path,
    ) -> Result<Vec<VehicleParams>, TaskError>;
    /// Builds what the points need.
    ///
    /// # Errors
    /// Read, config and model errors.
    fn prepare(
        ctx: &TaskContext<'_>,
        config: &Self::Config,
        config_file: &Path,
    ) -> Result<Self::Points, TaskError>;
    /// The number of points.
    fn len(points: &Self::Points) -> usize;
    /// Point `k`: a pure function of the inputs and `k`.
    fn run_point(points: &Self::Points, k: usize) -> Self::Point;
    /// How many failures a point's result holds (a failed point stays a row of the
    /// results; the shard report counts them).
    fn failures(point: &Self::Point) -> usize;
    /// Writes the task's outputs from the ordered full list of results into `out` and
    /// commits it: the same function for an unsharded run and a merge.
    ///
    /// # Errors
    /// Write errors.
    fn write_outputs(
        ctx: &TaskContext<'_>,
        out: OutputDir,
        config_file: &Path,
        config: &Self::Config,
        points: &[Self::Point],
    ) -> Result<Report, TaskError>;
}

/// How the points of one shard run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointSchedule {
    /// Side by side on the thread pool: points that are small, sequential computations
    /// (a sweep's evaluations).
    SideBySide,
    /// One after another, each with the whole pool: points that parallelise inside
    /// themselves (a vehicle through every task). Side by side, a worker waiting inside
    /// one point's parallel loop steals a whole other point and that point's loop waits
    /// for it: the shard takes several times as long.
    OneAfterAnother,
}

/// The sweep (`cargo xtask sweep`, `brake_timing`, the studies): one evaluation per point
/// of [`sway_studies::sweep::Sweep`] (grid × samples, then threshold and reference points).
#[derive(Debug, Clone, Copy)]
pub struct SweepPoints;

impl PointwiseTask for SweepPoints {
    const KIND: &'static str = "sweep";
    type Config = SweepConfig<SpeedSpec>;
    type Point = PointResult;
    type Points = crate::tasks::sweep::SweepRun;

    fn load(file: &Path) -> Result<SweepConfig<SpeedSpec>, TaskError> {
        let config: SweepConfig<SpeedSpec> = load_toml(file)?;
        config.check(file)?;
        Ok(config)
    }
    fn name(config: &SweepConfig<SpeedSpec>) -> &str {
        &config.name
    }
    fn fleet(
        _ctx: &TaskContext<'_>,
        config: &SweepConfig<SpeedSpec>,
        file: &Path,
    ) -> Result<Vec<VehicleParams>, TaskError> {
        crate::tasks::sweep::fleet_paths(config, file)
            .iter()
            .map(|p| crate::config_file::load_vehicle(p).map(|(v, _)| v))
            .collect()
    }
    fn prepare(
        ctx: &TaskContext<'_>,
        config: &SweepConfig<SpeedSpec>,
        file: &Path,
    ) -> Result<crate::tasks::sweep::SweepRun, TaskError> {
        crate::tasks::sweep::prepare_run(ctx, config, file)
    }
    fn len(points: &crate::tasks::sweep::SweepRun) -> usize {
        points.len()
    }
    fn run_point(points: &crate::tasks::sweep::SweepRun, k: usize) -> PointResult {
        points.run_point(k)
    }
    fn failures(point: &PointResult) -> usize {
        usize::from(point.output.is_err())
    }
    fn write_outputs(
        ctx: &TaskContext<'_>,
        out: OutputDir,
        config_file: &Path,
        config: &SweepConfig<SpeedSpec>,
        points: &[PointResult],
    ) -> Result<Report, TaskError> {
        let resolution = crate::tasks::sweep::resolve(ctx, config)?;
        crate::tasks::sweep::write_sweep_outputs(ctx, config, &resolution, config_file, points, out)
    }
}

/// The generated vehicles' study (`cargo xtask study_generated --shard K/N`, then `cargo
/// xtask merge`): point k is generated vehicle k through every task, so a study of a
/// hundred vehicles runs as slices on several machines or one after another, and a slice
/// that is done stays done. Its shard files also record each run's wall time (the table's
/// time column): a re-run shard has the same results with other times.
#[derive(Debug, Clone, Copy)]
pub struct GeneratedVehicles;

impl GeneratedVehicles {
    /// The task this kind shards.
    pub const TASK_NAME: &'static str = study_generated::TASK.name;
}

impl PointwiseTask for GeneratedVehicles {
    const KIND: &'static str = Self::TASK_NAME;
    const SCHEDULE: PointSchedule = PointSchedule::OneAfterAnother;
    type Config = StudyGeneratedConfig;
    type Point = Vec<study_generated::Run>;
    type Points = study_generated::GeneratedPoints;

    fn load(file: &Path) -> Result<StudyGeneratedConfig, TaskError> {
        let config: StudyGeneratedConfig = load_toml(file)?;
        config.check(file)?;
        Ok(config)
    }
    fn name(_config: &StudyGeneratedConfig) -> &str {
        Self::TASK_NAME
    }
    fn fleet(
        _ctx: &TaskContext<'_>,
        _config: &StudyGeneratedConfig,
        _file: &Path,
    ) -> Result<Vec<VehicleParams>, TaskError> {
        Ok(Vec::new())
    }
    fn prepare(
        ctx: &TaskContext<'_>,
        config: &StudyGeneratedConfig,
        file: &Path,
    ) -> Result<study_generated::GeneratedPoints, TaskError> {
        Ok(study_generated::GeneratedPoints::new(ctx, config, file))
    }
    fn len(points: &study_generated::GeneratedPoints) -> usize {
        points.len()
    }
    fn run_point(points: &study_generated::GeneratedPoints, k: usize) -> Self::Point {
        points.run(k)
    }
    fn failures(point: &Self::Point) -> usize {
        point.iter().filter(|r| r.error.is_some()).count()
    }
    fn write_outputs(
        ctx: &TaskContext<'_>,
        out: OutputDir,
        config_file: &Path,
        config: &StudyGeneratedConfig,
        points: &[Self::Point],
    ) -> Result<Report, TaskError> {
        study_generated::write_outputs(ctx, out, config_file, config, points)
    }
}

/// The sway-assist evaluation (`cargo xtask sway_assist --shard K/N`, and
/// `sway_assist_full` with `FULL`): point k is one scenario's two runs (without and with
/// the assist) or one vehicle's ordinary-driving run of the observer
/// ([`AssistPlan::run_point`]). The merge assembles the metrics from the points in order and
/// runs the two runs of its figures again.
#[derive(Debug, Clone, Copy)]
pub struct SwayAssistRuns<const FULL: bool>;

impl<const FULL: bool> PointwiseTask for SwayAssistRuns<FULL> {
    const KIND: &'static str = if FULL {
        sway_assist::FULL.name
    } else {
        sway_assist::TASK.name
    };
    type Config = SwayAssistConfig;
    type Point = AssistPoint;
    type Points = AssistPlan;

    fn load(file: &Path) -> Result<SwayAssistConfig, TaskError> {
        sway_assist::load_config(file)
    }
    fn name(_config: &SwayAssistConfig) -> &str {
        Self::KIND
    }
    fn fleet(
        _ctx: &TaskContext<'_>,
        config: &SwayAssistConfig,
        file: &Path,
    ) -> Result<Vec<VehicleParams>, TaskError> {
        let dir = file.parent().unwrap_or(Path::new("."));
        config
            .vehicle_files
            .iter()
            .map(|rel| crate::config_file::load_vehicle(&dir.join(rel)).map(|(v, _)| v))
            .collect()
    }
    fn prepare(
        ctx: &TaskContext<'_>,
        config: &SwayAssistConfig,
        file: &Path,
    ) -> Result<AssistPlan, TaskError> {
        let vehicles = sway_assist::vehicles(ctx, config, file)?;
        Ok(AssistPlan::new(config, vehicles, &ctx.limits)?)
    }
    fn len(points: &AssistPlan) -> usize {
        points.len()
    }
    fn run_point(points: &AssistPlan, k: usize) -> AssistPoint {
        points.run_point(k)
    }
    fn failures(point: &AssistPoint) -> usize {
        match point {
            AssistPoint::Scenario(s) => {
                usize::from(s.without.is_err()) + usize::from(s.with.is_err())
            }
            AssistPoint::Observer(_) => 0,
        }
    }
    fn write_outputs(
        ctx: &TaskContext<'_>,
        out: OutputDir,
        config_file: &Path,
        config: &SwayAssistConfig,
        points: &[AssistPoint],
    ) -> Result<Report, TaskError> {
        let plan = Self::prepare(ctx, config, config_file)?;
        let evaluation = plan.assemble(points.to_vec());
        let (summary, lines) = sway_assist::write_evaluation(&out, config, &evaluation)?;
        ctx.conclude(out, summary, config, config_file, lines)
    }
}

/// The tasks that can run as shards: the sweeps (kind [`SweepPoints`]), the generated
/// vehicles' study (kind [`GeneratedVehicles`]) and the sway-assist evaluations (kinds
/// [`SwayAssistRuns`]).
pub const SHARDABLE_TASKS: [&str; 5] = [
    "sweep",
    "brake_timing",
    "study_generated",
    "sway_assist",
    "sway_assist_full",
];

/// Where a shard came from: everything [`merge_dir`] checks before it trusts the results.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// [`FORMAT`]
    pub format: String,
    /// the task kind ([`PointwiseTask::KIND`])
    pub kind: String,
    /// the study's name (its results directory)
    pub name: String,
    /// [`config_hash`] of the config and vehicle
    pub config_hash: String,
    /// [`TOOL_VERSION`] of the writer
    pub tool_version: String,
    /// K (from 1)
    pub shard: usize,
    /// N
    pub shards: usize,
    /// the study's number of points
    pub points_total: usize,
    /// the points of this shard, `[first, end)`
    pub point_range: [usize; 2],
    /// the config file (absolute)
    pub config_file: PathBuf,
    /// the vehicle file (absolute)
    pub vehicle_file: PathBuf,
}

/// A shard file: provenance, inputs and the results of its points in order.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardFile<C, P> {
    /// where it came from
    pub provenance: Provenance,
    /// the parsed config
    pub config: C,
    /// the vehicle parameters (Table I form; for a vehicle with model variants the
    /// equivalent single-axle vehicle)
    pub vehicle: VehicleParams,
    /// the vehicle file as written when it has model variants (relaxation, axle
    /// lists, tyre laws, hitch torque), absent for a vehicle of the paper's form
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle_spec: Option<VehicleSpec>,
    /// further vehicles of the study (a fleet), in order
    pub fleet: Vec<VehicleParams>,
    /// one result per point of `provenance.point_range`, in order
    pub results: Vec<P>,
}

/// The record a failed shard run leaves (`shard-K-of-N.failed.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardFailure {
    /// [`FORMAT`]
    pub format: String,
    /// K
    pub shard: usize,
    /// N
    pub shards: usize,
    /// the provenance, when the config had loaded
    pub provenance: Option<Provenance>,
    /// the error
    pub error: String,
}

/// FNV-1a, 64 bit.
#[doc(hidden)] // pub for tests/unit
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The config hash of a study: `fnv1a64:` and 16 hex digits of FNV-1a over the canonical
/// JSON of `{kind, config, vehicle, fleet}` (with `vehicle_spec` after `vehicle` for a
/// vehicle with model variants: [`config_hash_of`]).
///
/// # Errors
/// [`ShardError::Task`] if the config does not serialise (never for the shipped types).
pub fn config_hash<T: PointwiseTask>(
    config: &T::Config,
    vehicle: &VehicleParams,
    fleet: &[VehicleParams],
) -> Result<String, ShardError> {
    config_hash_of::<T>(config, vehicle, None, fleet)
}

/// [`config_hash`] with the vehicle file of a vehicle with model variants (`None` for one of
/// the paper's form: the hash of [`config_hash`]).
///
/// # Errors
/// As [`config_hash`].
pub fn config_hash_of<T: PointwiseTask>(
    config: &T::Config,
    vehicle: &VehicleParams,
    vehicle_spec: Option<&VehicleSpec>,
    fleet: &[VehicleParams],
) -> Result<String, ShardError> {
    #[derive(Serialize)]
    struct Inputs<'a, C> {
        kind: &'a str,
        config: &'a C,
        vehicle: &'a VehicleParams,
        #[serde(skip_serializing_if = "Option::is_none")]
        vehicle_spec: Option<&'a VehicleSpec>,
        fleet: &'a [VehicleParams],
    }
    let json = serde_json::to_vec(&Inputs {
        kind: T::KIND,
        config,
        vehicle,
        vehicle_spec,
        fleet,
    })
    .map_err(|e| numerical("serialising the config for its hash", e))?;
    Ok(format!("fnv1a64:{:016x}", fnv1a64(&json)))
}

/// The vehicle file of `ctx` when it has model variants (it enters the hash and the shard).
fn variant_spec<'c>(ctx: &'c TaskContext<'_>) -> Option<&'c VehicleSpec> {
    ctx.variant_key.as_ref().map(|_| &ctx.spec)
}

fn numerical(context: &str, e: impl std::error::Error + Send + Sync + 'static) -> ShardError {
    ShardError::Task(TaskError::numerical(context, e))
}

/// An absolute form of `path` (joined to the working directory when relative).
fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// The provenance of shard `spec` of a study of `total` points (`config` from
/// `config_file`, the vehicle of `ctx` and the `fleet`).
///
/// # Errors
/// As [`config_hash`].
pub fn provenance<T: PointwiseTask>(
    ctx: &TaskContext<'_>,
    config_file: &Path,
    config: &T::Config,
    fleet: &[VehicleParams],
    total: usize,
    spec: ShardSpec,
) -> Result<Provenance, ShardError> {
    let range = spec.range(total);
    Ok(Provenance {
        format: FORMAT.to_string(),
        kind: T::KIND.to_string(),
        name: T::name(config).to_string(),
        config_hash: config_hash_of::<T>(config, &ctx.vehicle, variant_spec(ctx), fleet)?,
        tool_version: TOOL_VERSION.to_string(),
        shard: spec.shard,
        shards: spec.shards,
        points_total: total,
        point_range: [range.start, range.end],
        config_file: absolute(config_file),
        vehicle_file: absolute(&ctx.vehicle_file),
    })
}

/// What [`run_shard`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShardReport {
    /// the shard
    pub spec: ShardSpec,
    /// its points
    pub range: Range<usize>,
    /// the study's number of points
    pub points_total: usize,
    /// the shard file written
    pub file: PathBuf,
    /// points whose run failed (reported in their rows, as in an unsharded run)
    pub points_failed: usize,
}

/// Computes shard `spec` of the study in parallel (rayon; results in point order whatever
/// the thread count) and writes `dir/shard-K-of-N.json` atomically, removing a failure
/// record of an earlier run of the same shard. A failure after the config has loaded is
/// recorded with [`record_failure`].
///
/// # Errors
/// Read, config and model errors of the inputs; [`ShardError::Task`] for write errors.
pub fn run_shard<T: PointwiseTask>(
    ctx: &TaskContext<'_>,
    config_file: &Path,
    config: &T::Config,
    spec: ShardSpec,
    dir: &Path,
) -> Result<ShardReport, ShardError> {
    let mut known = None;
    run_shard_inner::<T>(ctx, config_file, config, spec, dir, &mut known).inspect_err(|e| {
        let _ = record_failure(dir, spec, known, &e.to_string());
    })
}

fn run_shard_inner<T: PointwiseTask>(
    ctx: &TaskContext<'_>,
    config_file: &Path,
    config: &T::Config,
    spec: ShardSpec,
    dir: &Path,
    known: &mut Option<Provenance>,
) -> Result<ShardReport, ShardError> {
    let fleet = T::fleet(ctx, config, config_file)?;
    let points = T::prepare(ctx, config, config_file)?;
    let provenance = provenance::<T>(ctx, config_file, config, &fleet, T::len(&points), spec)?;
    *known = Some(provenance.clone());
    let range = spec.range(provenance.points_total);
    let label = format!("{} shard {spec}", T::name(config));
    let results = compute::<T>(&points, range.clone(), &label, ctx.progress);
    let points_failed = results.iter().map(T::failures).sum();
    let file = dir.join(spec.file_name());
    let shard = ShardFile {
        provenance,
        config,
        vehicle: ctx.vehicle,
        vehicle_spec: variant_spec(ctx).cloned(),
        fleet,
        results,
    };
    let mut bytes =
        serde_json::to_vec(&shard).map_err(|e| numerical("serialising the shard", e))?;
    bytes.push(b'\n');
    crate::io::write_atomic(&file, &bytes)?;
    remove_failure(dir, spec)?;
    Ok(ShardReport {
        spec,
        range,
        points_total: shard.provenance.points_total,
        file,
        points_failed,
    })
}

fn compute<T: PointwiseTask>(
    points: &T::Points,
    range: Range<usize>,
    label: &str,
    progress: &dyn Progress,
) -> Vec<T::Point> {
    progress.start(label, range.len() as u64);
    let point = |k| {
        let r = T::run_point(points, k);
        progress.advance(1);
        r
    };
    let out = match T::SCHEDULE {
        PointSchedule::SideBySide => range.into_par_iter().map(point).collect(),
        PointSchedule::OneAfterAnother => range.map(point).collect(),
    };
    progress.finish();
    out
}

fn remove_failure(dir: &Path, spec: ShardSpec) -> Result<(), ShardError> {
    let path = dir.join(spec.failure_name());
    match std::fs::remove_file(&path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(ShardError::Task(TaskError::Write { path, source: e }))
        }
        _ => Ok(()),
    }
}

/// Records that shard `spec` failed (`dir/shard-K-of-N.failed.json`, atomically), so that
/// [`merge_dir`] names it with its error. A result file of an earlier successful run of
/// the same shard is kept (a point's result does not depend on the run).
///
/// # Errors
/// [`ShardError::Task`] for write errors.
pub fn record_failure(
    dir: &Path,
    spec: ShardSpec,
    provenance: Option<Provenance>,
    error: &str,
) -> Result<PathBuf, ShardError> {
    let record = ShardFailure {
        format: FORMAT.to_string(),
        shard: spec.shard,
        shards: spec.shards,
        provenance,
        error: error.to_string(),
    };
    let path = dir.join(spec.failure_name());
    let bytes = serde_json::to_vec_pretty(&record)
        .map_err(|e| numerical("serialising a failure record", e))?;
    crate::io::write_atomic(&path, &bytes)?;
    Ok(path)
}

fn ensure_shardable(task: &str) -> Result<(), ShardError> {
    if SHARDABLE_TASKS.contains(&task) {
        Ok(())
    } else {
        Err(ShardError::NotShardable {
            task: task.to_string(),
            shardable: SHARDABLE_TASKS.join(", "),
        })
    }
}

/// The study name (results directory) of the shardable task `task`'s config file.
///
/// # Errors
/// [`ShardError::NotShardable`], read and config errors.
pub fn study_name(task: &str, config_file: &Path) -> Result<String, ShardError> {
    ensure_shardable(task)?;
    Ok(match task {
        GeneratedVehicles::TASK_NAME => {
            GeneratedVehicles::name(&GeneratedVehicles::load(config_file)?).to_string()
        }
        SwayAssistRuns::<false>::KIND | SwayAssistRuns::<true>::KIND => task.to_string(),
        _ => SweepPoints::load(config_file)?.name,
    })
}

/// Runs shard `spec` of the shardable task `task` (one of [`SHARDABLE_TASKS`]) on the
/// config file `config_file`, writing into `dir` ([`run_shard`]).
///
/// # Errors
/// [`ShardError::NotShardable`], config errors, and the errors of [`run_shard`].
pub fn run_task_shard(
    task: &str,
    ctx: &TaskContext<'_>,
    config_file: &Path,
    spec: ShardSpec,
    dir: &Path,
) -> Result<ShardReport, ShardError> {
    ensure_shardable(task)?;
    match task {
        GeneratedVehicles::TASK_NAME => {
            let config = GeneratedVehicles::load(config_file)?;
            run_shard::<GeneratedVehicles>(ctx, config_file, &config, spec, dir)
        }
        SwayAssistRuns::<false>::KIND => {
            let config = SwayAssistRuns::<false>::load(config_file)?;
            run_shard::<SwayAssistRuns<false>>(ctx, config_file, &config, spec, dir)
        }
        SwayAssistRuns::<true>::KIND => {
            let config = SwayAssistRuns::<true>::load(config_file)?;
            run_shard::<SwayAssistRuns<true>>(ctx, config_file, &config, spec, dir)
        }
        _ => {
            let config = SweepPoints::load(config_file)?;
            run_shard::<SweepPoints>(ctx, config_file, &config, spec, dir)
        }
    }
}

/// The head of a shard file: its provenance (the results are skipped).
#[derive(Debug, Deserialize)]
struct Head {
    provenance: Provenance,
}

/// The shard files and failure records of a directory.
#[derive(Debug, Default)]
struct Scan {
    shards: Vec<(PathBuf, Provenance)>,
    failures: Vec<(PathBuf, ShardFailure)>,
}

fn unreadable(file: &Path, problem: impl std::fmt::Display) -> ShardError {
    ShardError::Unreadable {
        file: file.to_path_buf(),
        problem: problem.to_string(),
    }
}

/// Reads the heads of every `shard-*.json` in `dir` (sorted by name); other files are
/// ignored.
fn scan(dir: &Path) -> Result<Scan, ShardError> {
    let read_err = |source| {
        ShardError::Task(TaskError::Read {
            file: dir.to_path_buf(),
            source,
        })
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(read_err)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("shard-") && n.ends_with(".json"))
        })
        .collect();
    files.sort();
    let mut out = Scan::default();
    for file in files {
        let bytes = std::fs::read(&file).map_err(|source| {
            ShardError::Task(TaskError::Read {
                file: file.clone(),
                source,
            })
        })?;
        if file.to_string_lossy().ends_with(".failed.json") {
            let f: ShardFailure =
                serde_json::from_slice(&bytes).map_err(|e| unreadable(&file, e))?;
            out.failures.push((file, f));
        } else {
            let h: Head = serde_json::from_slice(&bytes).map_err(|e| unreadable(&file, e))?;
            if h.provenance.format != FORMAT {
                let got = h.provenance.format;
                return Err(unreadable(&file, format!("format `{got}`")));
            }
            out.shards.push((file, h.provenance));
        }
    }
    if out.shards.is_empty() && out.failures.is_empty() {
        return Err(ShardError::NoShards {
            dir: dir.to_path_buf(),
        });
    }
    Ok(out)
}

/// What identifies a study: kind, hash and tool version.
fn study_key(p: &Provenance) -> (String, String, String) {
    (
        p.kind.clone(),
        p.config_hash.clone(),
        p.tool_version.clone(),
    )
}

/// The study the directory holds: the one with the most shard files (ties: the first
/// file by name). Every shard of another study is foreign.
fn expected_study(scan: &Scan) -> Result<Provenance, ShardError> {
    let mut count: BTreeMap<(String, String, String), usize> = BTreeMap::new();
    for (_, p) in &scan.shards {
        *count.entry(study_key(p)).or_default() += 1;
    }
    let best = count.values().copied().max().unwrap_or(0);
    let expected = scan
        .shards
        .iter()
        .find(|(_, p)| count[&study_key(p)] == best)
        .map(|(_, p)| p.clone());
    let Some(expected) = expected else {
        // failure records only: every shard is missing or failed
        return Err(incomplete_from_failures(scan));
    };
    let foreign = scan
        .shards
        .iter()
        .map(|(f, p)| (f, Some(p)))
        .chain(
            scan.failures
                .iter()
                .map(|(f, r)| (f, r.provenance.as_ref())),
        )
        .find_map(|(f, p)| p.and_then(|p| foreign_reason(p, &expected).map(|r| (f, p, r))));
    if let Some((file, p, reason)) = foreign {
        return Err(ShardError::Foreign {
            file: file.clone(),
            shard: p.shard,
            shards: p.shards,
            reason,
            expected: Box::new(Study {
                name: expected.name.clone(),
                config_hash: expected.config_hash.clone(),
                tool_version: expected.tool_version.clone(),
                shard_files: best,
            }),
        });
    }
    Ok(expected)
}

fn incomplete_from_failures(scan: &Scan) -> ShardError {
    let n = scan.failures.first().map_or(0, |(_, f)| f.shards);
    let failed: Vec<(usize, String)> = scan
        .failures
        .iter()
        .map(|(_, f)| (f.shard, f.error.clone()))
        .collect();
    let dir = scan
        .failures
        .first()
        .and_then(|(f, _)| f.parent())
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let missing = (1..=n)
        .filter(|k| !failed.iter().any(|(j, _)| j == k))
        .collect();
    let task = scan
        .failures
        .iter()
        .find_map(|(_, f)| f.provenance.as_ref().map(|p| p.kind.clone()))
        .unwrap_or_else(|| "TASK".to_string());
    ShardError::Incomplete {
        dir,
        task,
        shards: n,
        missing,
        failed,
    }
}

fn foreign_reason(p: &Provenance, expected: &Provenance) -> Option<String> {
    if p.kind != expected.kind {
        Some(format!("task kind `{}`, not `{}`", p.kind, expected.kind))
    } else if p.config_hash != expected.config_hash {
        Some(format!(
            "config `{}` with hash {} (another config or vehicle)",
            p.name, p.config_hash
        ))
    } else if p.tool_version != expected.tool_version {
        Some(format!("written by tool version {}", p.tool_version))
    } else {
        None
    }
}

/// The shard files of the expected study in K order, after the duplicate and completeness
/// checks.
fn select(dir: &Path, scan: &Scan, expected: &Provenance) -> Result<Vec<PathBuf>, ShardError> {
    let mut counts: Vec<usize> = scan.shards.iter().map(|(_, p)| p.shards).collect();
    counts.sort_unstable();
    counts.dedup();
    if counts.len() > 1 {
        return Err(ShardError::MixedCounts {
            dir: dir.to_path_buf(),
            counts,
        });
    }
    let n = expected.shards;
    let mut by_k: BTreeMap<usize, Vec<PathBuf>> = BTreeMap::new();
    for (f, p) in &scan.shards {
        by_k.entry(p.shard).or_default().push(f.clone());
    }
    if let Some((&k, files)) = by_k.iter().find(|(_, fs)| fs.len() > 1) {
        return Err(ShardError::Duplicated {
            shard: k,
            shards: n,
            files: files.clone(),
        });
    }
    let absent: Vec<usize> = (1..=n).filter(|k| !by_k.contains_key(k)).collect();
    if !absent.is_empty() {
        let failed_msg = |k: usize| {
            scan.failures
                .iter()
                .find(|(_, f)| f.shard == k && f.shards == n)
                .map(|(_, f)| f.error.clone())
        };
        let failed = absent
            .iter()
            .filter_map(|&k| failed_msg(k).map(|e| (k, e)))
            .collect();
        let missing = absent
            .into_iter()
            .filter(|&k| failed_msg(k).is_none())
            .collect();
        return Err(ShardError::Incomplete {
            dir: dir.to_path_buf(),
            task: expected.kind.clone(),
            shards: n,
            missing,
            failed,
        });
    }
    Ok(by_k.into_values().flatten().collect())
}

/// A merged study: the provenance of its first shard, its inputs and every result in
/// point order.
pub struct Merged<T: PointwiseTask> {
    /// the first shard's provenance
    pub provenance: Provenance,
    /// the config
    pub config: T::Config,
    /// the vehicle parameters
    pub vehicle: VehicleParams,
    /// the vehicle file when it has model variants
    pub vehicle_spec: Option<VehicleSpec>,
    /// further vehicles of the study (a fleet)
    pub fleet: Vec<VehicleParams>,
    /// all results, point 0 first
    pub results: Vec<T::Point>,
}

impl<T: PointwiseTask> std::fmt::Debug for Merged<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Merged")
            .field("provenance", &self.provenance)
            .field("results", &self.results.len())
            .finish_non_exhaustive()
    }
}

/// Reads and checks the shard files of one study (as [`merge_dir`] selects them) and
/// concatenates their results.
fn load<T: PointwiseTask>(files: &[PathBuf]) -> Result<Merged<T>, ShardError> {
    let mut merged: Option<Merged<T>> = None;
    for file in files {
        let bytes = std::fs::read(file).map_err(|source| {
            ShardError::Task(TaskError::Read {
                file: file.clone(),
                source,
            })
        })?;
        let s: ShardFile<T::Config, T::Point> =
            serde_json::from_slice(&bytes).map_err(|e| unreadable(file, e))?;
        check_consistent::<T>(file, &s)?;
        match &mut merged {
            None => {
                merged = Some(Merged {
                    provenance: s.provenance,
                    config: s.config,
                    vehicle: s.vehicle,
                    vehicle_spec: s.vehicle_spec,
                    fleet: s.fleet,
                    results: s.results,
                })
            }
            Some(m) => m.results.extend(s.results),
        }
    }
    merged.ok_or_else(|| ShardError::NoShards {
        dir: PathBuf::new(),
    })
}

/// A shard's config and vehicle hash to its recorded hash, its range is the one of its
/// K/N, and it holds one result per point.
fn check_consistent<T: PointwiseTask>(
    file: &Path,
    s: &ShardFile<T::Config, T::Point>,
) -> Result<(), ShardError> {
    let p = &s.provenance;
    let bad = |problem: String| ShardError::Inconsistent {
        file: file.to_path_buf(),
        problem,
    };
    let hash = config_hash_of::<T>(&s.config, &s.vehicle, s.vehicle_spec.as_ref(), &s.fleet)?;
    if hash != p.config_hash {
        return Err(bad(format!(
            "its config and vehicle hash to {hash}, its provenance says {}",
            p.config_hash
        )));
    }
    let spec = ShardSpec::new(p.shard, p.shards).map_err(|e| bad(e.to_string()))?;
    let total = p.points_total;
    let range = spec.range(total);
    if p.point_range != [range.start, range.end] {
        return Err(bad(format!(
            "points {:?} recorded, shard {spec} of {total} points is {range:?}",
            p.point_range
        )));
    }
    if s.results.len() != range.len() {
        return Err(bad(format!(
            "{} results for the {} points {range:?}",
            s.results.len(),
            range.len()
        )));
    }
    Ok(())
}

/// Reads and checks the shards of `dir` and returns the merged study of kind `T`.
///
/// # Errors
/// [`ShardError`] naming every missing, failed, duplicated, foreign or unreadable shard.
pub fn collect<T: PointwiseTask>(dir: &Path) -> Result<Merged<T>, ShardError> {
    let scan = scan(dir)?;
    let expected = expected_study(&scan)?;
    if expected.kind != T::KIND {
        return Err(ShardError::NotShardable {
            task: expected.kind,
            shardable: T::KIND.to_string(),
        });
    }
    let files = select(dir, &scan, &expected)?;
    load::<T>(&files)
}

/// Merges the complete shards of `dir` into `results_root/<name>/` (the files an unsharded
/// run writes, through the same writer), with the progress observer `progress`.
///
/// # Errors
/// [`ShardError`] naming every missing, failed, duplicated, foreign or unreadable shard;
/// the task's write errors.
pub fn merge_dir(
    dir: &Path,
    results_root: &Path,
    progress: &dyn Progress,
) -> Result<Report, ShardError> {
    let scan = scan(dir)?;
    let expected = expected_study(&scan)?;
    match expected.kind.as_str() {
        SweepPoints::KIND => merge_as::<SweepPoints>(dir, results_root, progress),
        GeneratedVehicles::KIND => merge_as::<GeneratedVehicles>(dir, results_root, progress),
        SwayAssistRuns::<false>::KIND => {
            merge_as::<SwayAssistRuns<false>>(dir, results_root, progress)
        }
        SwayAssistRuns::<true>::KIND => {
            merge_as::<SwayAssistRuns<true>>(dir, results_root, progress)
        }
        other => Err(ShardError::NotShardable {
            task: other.to_string(),
            shardable: SHARDABLE_TASKS.join(", "),
        }),
    }
}

fn merge_as<T: PointwiseTask>(
    dir: &Path,
    results_root: &Path,
    progress: &dyn Progress,
) -> Result<Report, ShardError> {
    let m = collect::<T>(dir)?;
    let out = OutputDir::create(results_root, &m.provenance.name)?;
    let (spec, plant, variant_key) = match &m.vehicle_spec {
        Some(spec) => (
            spec.clone(),
            trailer_model::AnyVehicleModel::new(spec).map_err(TaskError::from)?,
            spec.first_variant_key().map_err(TaskError::from)?,
        ),
        None => (
            m.vehicle.into(),
            trailer_model::AnyVehicleModel::Paper(Model::new(m.vehicle).map_err(TaskError::from)?),
            None,
        ),
    };
    let ctx = TaskContext {
        vehicle_file: m.provenance.vehicle_file.clone(),
        vehicle: m.vehicle,
        model: Model::new(m.vehicle).map_err(TaskError::from)?,
        spec,
        plant,
        variant_key,
        configs_dir: PathBuf::new(),
        results_dir: results_root.to_path_buf(),
        progress,
        limits: sway::ranging::SpeedLimits::default(),
    };
    Ok(T::write_outputs(
        &ctx,
        out,
        &m.provenance.config_file,
        &m.config,
        &m.results,
    )?)
}
