//! Resource bounds and the work plan of a task (`cargo xtask <task> --check`).
//!
//! Every task states, before any work, what it would compute ([`Plan`]: grid sizes,
//! number of simulations or cells) with an estimate of memory and time from the
//! benchmarks' per-unit costs (the constants below, each with its source). A config whose
//! work exceeds a limit is refused by [`bound`] with a message naming the file, the key,
//! the value, the limit and the estimated cost. The limits are generous: 40× to 1000×
//! the defaults (the table of the guide's page `docs/src/limits.md`), so that only a
//! typo or an unbounded value hits them.

use std::path::Path;

use crate::TaskError;

/// Memory budget of one task \[bytes\]: 4 GiB. A config whose estimated peak memory is
/// above it is refused (the largest default run, `fig4a`, needs well under 100 MB).
pub const MEMORY_BUDGET_BYTES: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;

/// Longest array in any config file (entries): 10 000. The longest default array has 5
/// entries; the generic check in `config_file` refuses longer ones before deserialising.
pub const MAX_ARRAY_LEN: usize = 10_000;

/// Longest string in any config file (bytes): 4096 (names and kinds are a few words).
pub const MAX_STRING_LEN: usize = 4096;

/// Points of one grid axis (`Grid::points`, sweep axes, fig4a cells per axis): 100 000
/// (defaults: at most 591).
pub const MAX_AXIS_POINTS: usize = sway::config::MAX_GRID_POINTS;

/// fig4a: cells over all panels (speed × gain × delays): 20 000 000 (default 240 000,
/// 83×): ≈ 1.3 GB at [`FIG4A_BYTES_PER_CELL`] and ≈ 2.7 min at [`FIG4A_SECONDS_PER_CELL`].
/// Measured (release build, 2 shared cores, `/usr/bin/time -v`): 5000 × 1000 cells × 4
/// delays ran in 171 s with a peak RSS of 1.25 GB and wrote 0.9 GB of CSV; 1000 × 600 × 4
/// (2.4 M cells) in 16 s with 180 MB; the default 240 000 cells in 2.0 s with 37 MB.
pub const MAX_CHART_CELLS: usize = 20_000_000;

/// Simulations of one sweep (product of the axis points): 1 000 000 (defaults 1024 and
/// 1281, ≈ 800×): ≈ 500 MB of rows and ≈ 15 min of 60 s simulations at
/// [`SWEEP_SECONDS_PER_SIM_SECOND`] on 2 cores.
pub const MAX_SIMULATIONS: usize = 1_000_000;

/// Output samples of one task (horizon / output step, summed over its runs): 5 000 000
/// (defaults ≤ 12 000, 400×): ≈ 2 GB at [`BYTES_PER_SAMPLE`].
pub const MAX_SAMPLES: f64 = 5_000_000.0;

/// Simulated time of one run (horizon, settling time) \[s\]: 100 000 s (defaults ≤ 200 s,
/// 500×): ≈ 13 s of integration at [`SIM_SECONDS_PER_SIM_SECOND`] (the DDE history is
/// bounded by the delay, so memory does not grow with it).
pub const MAX_SIMULATED_S: f64 = 100_000.0;

/// Cost of one output sample of a time series \[bytes\]: the trajectory sample (t, seven
/// states, V, δ: ≈ 100 bytes), its CSV row (≈ 200 bytes) and the figure polylines
/// (≈ 100 bytes); an upper estimate.
pub const BYTES_PER_SAMPLE: f64 = 400.0;

/// Integration cost per simulated second \[s\]: `crates/sway/benches/simulation.rs`, S3
/// (closed loop, 40 s in ≤ 5 ms, rtol 1e-8), rounded up to 1.3e-4 s/s.
pub const SIM_SECONDS_PER_SIM_SECOND: f64 = 1.3e-4;

/// Cost of a sweep's simulations per simulated second \[s\] (CPU time; the plan divides by
/// the 2 cores): the 4-state model without recording, measured on release runs of the two
/// default sweeps on 2 cores, wall × 2 / (simulations × simulated s):
/// `sweep_brake_timing` (rtol 1e-8, settling per point: 1281 × 240 s) in 3.4 s (committed
/// summary; 6.5 s on a loaded machine), 2.2e-5 (4.2e-5 loaded), and `sweep_threshold`
/// (rtol 1e-6, 1024 × 60 s) in 0.33 s (0.56 s loaded), 1.1e-5 (1.8e-5); set to 3e-5 s/s.
/// The closed-loop 7-state rate [`SIM_SECONDS_PER_SIM_SECOND`] used before made `--check`
/// 6× (brake timing: 20 s) to 12× (threshold: 4.0 s) too pessimistic for sweeps.
pub const SWEEP_SECONDS_PER_SIM_SECOND: f64 = 3e-5;

/// fig4a: cost of one chart cell \[s\] on 2 cores: release runs of 240 000 cells (the
/// committed `results/fig4a/summary.json`: 1.66 s, 6.9e-6 s per cell), 2.4 M cells (16.2 s,
/// 6.8e-6 s) and 20 M cells (171 s on a loaded machine, 8.6e-6 s), rounded to 8e-6 s
/// (was 3e-6 s, 2–3× optimistic).
pub const FIG4A_SECONDS_PER_CELL: f64 = 8e-6;

/// fig4a: memory per chart cell \[bytes\]: the stored cell (unstable-root count,
/// rightmost real part) plus the CSV row and figure raster; the measured peak RSS is
/// 63 bytes per cell at 20 M cells and 75 at 2.4 M (a fixed ≈ 20 MB included).
pub const FIG4A_BYTES_PER_CELL: f64 = 64.0;

/// loading: cost of one (mass, cog) cell \[s\] (a V_crit search): the committed
/// `results/loading/summary.json` (4026 cells in 0.47 s), rounded up to 1.2e-4 s.
pub const LOADING_SECONDS_PER_CELL: f64 = 1.2e-4;

/// linear: cost of one speed point \[s\] (eigenvalues of a 4×4 matrix and the table row),
/// from `results/linear/summary.json` (591 points and the sensitivities in 0.04 s).
pub const LINEAR_SECONDS_PER_POINT: f64 = 5e-5;

/// Memory per result row of a grid task (linear, loading, sweep) \[bytes\]: the row and
/// its CSV text, an upper estimate.
pub const BYTES_PER_ROW: f64 = 500.0;

/// What a task would do: printed by `--check` before (instead of) the work.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// what would run, one line each (grids, counts)
    pub work: Vec<String>,
    /// estimated peak memory \[bytes\]
    pub memory_bytes: f64,
    /// estimated wall time \[s\] (2 cores, release build)
    pub time_s: f64,
}

impl Plan {
    /// A plan of `work` lines with its estimates.
    pub fn new(work: Vec<String>, memory_bytes: f64, time_s: f64) -> Self {
        Self {
            work,
            memory_bytes,
            time_s,
        }
    }

    /// The plan of a task without a cost model: its work described, small estimates.
    pub fn described(work: impl Into<String>) -> Self {
        Self::new(vec![work.into()], 0.0, 0.0)
    }

    /// The plan, or [`TaskError::Config`] under `key` when its `count` of units (cells,
    /// simulations) exceeds `limit`: the message `what()` followed by the plan's memory
    /// and time, `…, ≈ 1.3 GB and 60.00 s`.
    ///
    /// # Errors
    /// As [`bound`].
    pub fn within(
        self,
        file: &Path,
        key: &str,
        count: f64,
        limit: usize,
        what: impl FnOnce() -> String,
    ) -> Result<Self, TaskError> {
        bound(file, key, count, limit as f64, || {
            let (memory, time) = (human_bytes(self.memory_bytes), human_seconds(self.time_s));
            format!("{}, ≈ {memory} and {time}", what())
        })?;
        Ok(self)
    }

    /// The plan as printed: the work lines, then `memory ≈ …, time ≈ …`.
    pub fn lines(&self) -> Vec<String> {
        let mut l = self.work.clone();
        l.push(format!(
            "estimate: memory ≈ {}, time ≈ {}",
            human_bytes(self.memory_bytes),
            human_seconds(self.time_s)
        ));
        l
    }
}

/// `1.5 GB`, `12 MB`, `300 kB`.
pub fn human_bytes(b: f64) -> String {
    scaled(b, [(1e9, 1e9, "GB"), (1e6, 1e6, "MB")], |b| {
        format!("{:.0} kB", (b / 1e3).max(1.0))
    })
}

/// `0.2 s`, `3.5 min`, `2.0 h`.
pub fn human_seconds(s: f64) -> String {
    scaled(s, [(7200.0, 3600.0, "h"), (120.0, 60.0, "min")], |s| {
        format!("{s:.2} s")
    })
}

/// `v` in the first of `units` (from, divisor, name) that it reaches (v ≥ from), with one
/// decimal; below them all, `small(v)`.
fn scaled(v: f64, units: [(f64, f64, &str); 2], small: impl Fn(f64) -> String) -> String {
    units
        .iter()
        .find(|(from, _, _)| v >= *from)
        .map(|(_, divisor, name)| format!("{:.1} {name}", v / divisor))
        .unwrap_or_else(|| small(v))
}

/// Refuses `value` of `key` above `limit`; `cost` says what the value would cost (memory,
/// time) and is only evaluated on failure.
///
/// # Errors
/// [`TaskError::Config`] naming the key, the value, the limit and the cost.
pub fn bound(
    file: &Path,
    key: &str,
    value: f64,
    limit: f64,
    cost: impl FnOnce() -> String,
) -> Result<(), TaskError> {
    if value.is_finite() && value <= limit {
        Ok(())
    } else {
        Err(TaskError::config(
            file,
            key,
            format!("{value} exceeds the limit {limit} ({}); reduce it", cost()),
        ))
    }
}

/// Refuses a plan whose memory estimate exceeds [`MEMORY_BUDGET_BYTES`]; `key` names the
/// setting that drives it.
///
/// # Errors
/// [`TaskError::Config`].
pub fn check_memory(file: &Path, key: &str, plan: &Plan) -> Result<(), TaskError> {
    bound(file, key, plan.memory_bytes, MEMORY_BUDGET_BYTES, || {
        "estimated peak memory in bytes above the 4 GiB budget".into()
    })
}

/// Cost of one output sample of a time series after the integration \[s\]: its CSV row
/// and its share of the figure. Measured: `simulate` at the sample limit (5 000 000
/// samples over 100 000 s, release build) ran 159 s, of which ≈ 13 s integration, with a
/// peak RSS of 1.46 GB (estimate 2.0 GB); rounded up to 3e-5 s.
pub const SECONDS_PER_SAMPLE: f64 = 3e-5;

/// The cost (memory \[bytes\], time \[s\]) of `samples` output samples over `simulated_s`
/// simulated seconds.
pub fn series_cost(samples: f64, simulated_s: f64) -> (f64, f64) {
    (
        samples * BYTES_PER_SAMPLE,
        simulated_s * SIM_SECONDS_PER_SIM_SECOND + samples * SECONDS_PER_SAMPLE,
    )
}

/// Checks a horizon and its output step: the horizon below [`MAX_SIMULATED_S`] and the
/// samples `horizon / step × runs` below [`MAX_SAMPLES`]; returns the samples.
///
/// # Errors
/// [`TaskError::Config`] naming `<prefix>horizon_s` or `<prefix>output_step_s`.
pub fn check_series(
    file: &Path,
    prefix: &str,
    horizon_s: f64,
    output_step_s: f64,
    runs: usize,
) -> Result<f64, TaskError> {
    bound(
        file,
        &format!("{prefix}horizon_s"),
        horizon_s,
        MAX_SIMULATED_S,
        || {
            format!(
                "≈ {} of integration per run",
                human_seconds(horizon_s * SIM_SECONDS_PER_SIM_SECOND)
            )
        },
    )?;
    let samples = (horizon_s / output_step_s).ceil() * runs as f64;
    bound(
        file,
        &format!("{prefix}output_step_s"),
        samples,
        MAX_SAMPLES,
        || {
            format!(
                "output_step_s = {output_step_s} gives {samples} samples over {runs} run(s), ≈ {}",
                human_bytes(samples * BYTES_PER_SAMPLE)
            )
        },
    )?;
    Ok(samples)
}

/// The settling time of an initial condition \[s\] (0 for a given state).
pub fn settle_s(initial: &sway::sim::InitialCondition) -> f64 {
    match initial {
        sway::sim::InitialCondition::SwayCycle { settle_s, .. } => *settle_s,
        sway::sim::InitialCondition::State { .. } => 0.0,
    }
}

/// The plan of `runs` time series of `horizon_s` each, sampled every `output_step_s`,
/// after a settling run of `settle_s` (run once, shared); checks [`check_series`] and the
/// settling time (key `<settle_key>`).
///
/// # Errors
/// [`TaskError::Config`] naming the key over its limit.
pub fn series_plan(
    file: &Path,
    prefix: &str,
    (horizon_s, output_step_s): (f64, f64),
    runs: usize,
    (settle_key, settle): (&str, f64),
    what: &str,
) -> Result<Plan, TaskError> {
    bound(file, settle_key, settle, MAX_SIMULATED_S, || {
        format!(
            "≈ {} of integration",
            human_seconds(settle * SIM_SECONDS_PER_SIM_SECOND)
        )
    })?;
    let samples = check_series(file, prefix, horizon_s, output_step_s, runs)?;
    let (memory, time) = series_cost(samples, horizon_s * runs as f64 + settle);
    let plan = Plan::new(
        vec![format!(
            "{what}: {runs} run(s) of {horizon_s} s (+ {settle} s settling), {samples} output samples"
        )],
        memory,
        time,
    );
    check_memory(file, &format!("{prefix}output_step_s"), &plan)?;
    Ok(plan)
}
