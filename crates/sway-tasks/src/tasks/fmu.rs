//! `cargo xtask fmu`: the vehicle (`--vehicle FILE`, any model variant) with the settings
//! of `configs/fmu.toml` as a Co-Simulation FMU ([`sway_fmu`]) for FMI 2.0 and FMI 3.0.
//! Not part of `cargo xtask all` ([`super::Runs::OnDemand`]): it packs a build artefact.
//!
//! Outputs: `trailer_sway.fmu` (FMI 2.0), `trailer_sway_fmi3.fmu` (FMI 3.0) — both
//! ignored by git, rebuilt by this task —, `summary.json` (variable counts, versions, file
//! sizes, the vehicle and the settings) and `variables.md` (every variable with its
//! causality, type, start value and meaning).
//!
//! **The shared library.** The archives carry the cdylib of the `sway-fmu` crate built for
//! this platform. The task takes the one cargo built with the running program: cargo
//! compiles a library of crate types `cdylib` and `rlib` as both whenever it is a
//! dependency, so `cargo xtask fmu` (a `cargo run --release -p xtask`, which links
//! `sway-fmu` through this crate) leaves `libsway_fmu.so` in `target/release/deps/`, from
//! the same sources and in the same build as the code that writes the descriptions. Only if
//! it is not there (a runner started from elsewhere) does the task run
//! `cargo build --release -p sway-fmu` itself (the `cargo` of `$CARGO`, else of `PATH`,
//! on the workspace of this source tree) and take the library cargo reports.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Serialize;
use sway_fmu::MODEL_IDENTIFIER;
use sway_fmu::archive::fmu_bytes;
use sway_fmu::config::{Defaults, FmuConfig};
use sway_fmu::description::FmiVersion;
use sway_fmu::instance::Instance;
use sway_fmu::variables::{Causality, Value, Variable, variables};

use super::{Prepared, Report, Task, TaskContext};
use crate::TaskError;
use crate::config_file::{Configured, TaskConfig};

/// The task.
pub const TASK: Task = Task::configured::<FmuConfig>(
    "fmu",
    "the vehicle as a Co-Simulation FMU for FMI 2.0 and 3.0 (Simulink, OpenModelica, FMPy); on demand, not in `all`",
    "fmu.toml",
)
.any_model()
.on_demand();

/// The FMI 2.0 archive's name (importers and scripts refer to it).
pub const FMI2_FILE: &str = "trailer_sway.fmu";
/// The FMI 3.0 archive's name.
pub const FMI3_FILE: &str = "trailer_sway_fmi3.fmu";

impl TaskConfig for FmuConfig {
    fn check(&self, file: &Path) -> Result<(), TaskError> {
        self.validate().map_err(|e| match e {
            sway_fmu::FmuError::Parameter { key, problem } => TaskError::config(file, key, problem),
            other => TaskError::config(file, "<root>", other.to_string()),
        })
    }
}

/// One archive in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArchiveEntry {
    /// its file name in `results/fmu/`
    pub file: String,
    /// "2.0" or "3.0"
    pub fmi_version: &'static str,
    /// its size \[bytes\]
    pub bytes: u64,
}

/// How many variables of each causality the FMU has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct VariableCounts {
    /// all of them (time included)
    pub total: usize,
    /// inputs
    pub inputs: usize,
    /// outputs
    pub outputs: usize,
    /// parameters (initial states, controller, solver, vehicle)
    pub parameters: usize,
    /// of the parameters, the vehicle file's keys
    pub vehicle_parameters: usize,
}

/// `summary.json`'s headline.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FmuSummary {
    /// the model identifier (the library is `binaries/<platform>/<identifier>.so`)
    pub model_identifier: &'static str,
    /// the archives
    pub archives: Vec<ArchiveEntry>,
    /// the size of the shared library inside them \[bytes\]
    pub library_bytes: u64,
    /// the variable counts
    pub variables: VariableCounts,
    /// the reduced states of the vehicle's plant (4 for the paper's model: σ1, σ2, σ3, θ;
    /// the FMU integrates ψ, x_H, y_H besides, and a law's own states)
    pub plant_states: usize,
}

fn counts(vars: &[Variable]) -> VariableCounts {
    let n = |c: Causality| vars.iter().filter(|v| v.causality == c).count();
    VariableCounts {
        total: vars.len(),
        inputs: n(Causality::Input),
        outputs: n(Causality::Output),
        parameters: n(Causality::Parameter),
        vehicle_parameters: vars
            .iter()
            .filter(|v| matches!(v.slot, sway_fmu::variables::Slot::Vehicle(_)))
            .count(),
    }
}

/// `variables.md`: the variables in value-reference order.
fn variables_table(vars: &[Variable]) -> String {
    let mut s = String::from(
        "# The variables of trailer_sway.fmu\n\n\
         Written by `cargo xtask fmu` from the FMU's own list (value reference = row number \
         from 0). Units are SI and part of each name or description; parameters are fixed \
         (set them before initialisation), inputs are held between communication points.\n\n\
         | vr | name | causality | type | start | meaning |\n\
         | --- | --- | --- | --- | --- | --- |\n",
    );
    for (vr, v) in vars.iter().enumerate() {
        let causality = match v.causality {
            Causality::Parameter => "parameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Independent => "independent",
        };
        let kind = v.kind.fmi2_name();
        let start = match &v.start {
            None => String::new(),
            Some(Value::Real(x)) => format!("{x:?}"),
            Some(Value::Integer(i)) => i.to_string(),
            Some(Value::Boolean(b)) => b.to_string(),
            Some(Value::String(t)) => format!("`{t}`"),
        };
        s.push_str(&format!(
            "| {vr} | `{}` | {causality} | {kind} | {start} | {} |\n",
            v.name,
            v.description.replace('|', "\\|")
        ));
    }
    s
}

/// The cdylib of `sway-fmu` beside the running program (`<dir>/` or `<dir>/deps/`), or
/// None.
fn library_beside_the_program() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent()?;
    let name = format!(
        "{}sway_fmu{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    [dir.join(&name), dir.join("deps").join(&name)]
        .into_iter()
        .find(|p| p.is_file())
}

/// `cargo build --release -p sway-fmu` on this source tree's workspace; the cdylib cargo
/// reports.
fn build_library() -> Result<PathBuf, TaskError> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../Cargo.toml");
    let command = format!(
        "{cargo} build --release -p sway-fmu --manifest-path {}",
        manifest.display()
    );
    let failed = |problem: String| TaskError::Build {
        command: command.clone(),
        problem,
    };
    let out = Command::new(&cargo)
        .args(["build", "--release", "-p", "sway-fmu", "--manifest-path"])
        .arg(&manifest)
        .arg("--message-format=json-render-diagnostics")
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| failed(e.to_string()))?;
    if !out.status.success() {
        return Err(failed(format!("exit status {}", out.status)));
    }
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|m| m["reason"] == "compiler-artifact" && m["target"]["name"] == "sway_fmu")
        .flat_map(|m| {
            m["filenames"]
                .as_array()
                .cloned()
                .unwrap_or_default()
                .into_iter()
                .filter_map(|f| f.as_str().map(PathBuf::from))
        })
        .find(|p| {
            p.to_string_lossy()
                .ends_with(std::env::consts::DLL_SUFFIX)
        })
        .ok_or_else(|| failed("cargo reported no cdylib of sway-fmu".into()))
}

impl Prepared for Configured<FmuConfig> {
    fn run(self: Box<Self>, ctx: &TaskContext<'_>) -> Result<Report, TaskError> {
        if !cfg!(all(target_os = "linux", target_arch = "x86_64")) {
            return Err(TaskError::Build {
                command: "cargo xtask fmu".into(),
                problem: "the FMU's descriptions name the platform x86_64-linux only".into(),
            });
        }
        let defaults = Defaults {
            vehicle: ctx.spec.clone(),
            config: self.config,
        };
        // the defaults must start an engine (a predictor on a vehicle it cannot linearise,
        // a law that does not fit the plant) before anything is packed
        let mut probe = Instance::new(defaults.clone())?;
        probe.enter_initialization()?;
        probe.exit_initialization()?;
        let library = match library_beside_the_program() {
            Some(p) => p,
            None => build_library()?,
        };
        let lib = std::fs::read(&library).map_err(|source| TaskError::Read {
            file: library.clone(),
            source,
        })?;
        let vars = variables(&defaults)?;
        ctx.run_staged(
            TASK.name,
            "fmu: packing the FMI 2.0 and 3.0 archives",
            2,
            &self.config,
            &self.file,
            |out| {
                let mut archives = Vec::new();
                for (file, version, name) in [
                    (FMI2_FILE, FmiVersion::V2, "2.0"),
                    (FMI3_FILE, FmiVersion::V3, "3.0"),
                ] {
                    let bytes = fmu_bytes(&lib, &defaults, version)?;
                    crate::io::write_atomic(&out.path(file), &bytes)?;
                    archives.push(ArchiveEntry {
                        file: file.into(),
                        fmi_version: name,
                        bytes: bytes.len() as u64,
                    });
                    ctx.progress.advance(1);
                }
                crate::io::write_atomic(
                    &out.path("variables.md"),
                    variables_table(&vars).as_bytes(),
                )?;
                let summary = FmuSummary {
                    model_identifier: MODEL_IDENTIFIER,
                    archives,
                    library_bytes: lib.len() as u64,
                    variables: counts(&vars),
                    plant_states: ctx.plant.states(),
                };
                let mut lines: Vec<String> = summary
                    .archives
                    .iter()
                    .map(|a| {
                        format!(
                            "FMI {}: {} ({:.1} MB)",
                            a.fmi_version,
                            out.final_dir().join(&a.file).display(),
                            a.bytes as f64 / 1e6
                        )
                    })
                    .collect();
                let c = summary.variables;
                lines.push(format!(
                    "{} variables: {} inputs, {} outputs, {} parameters ({} of the vehicle file); library {}",
                    c.total,
                    c.inputs,
                    c.outputs,
                    c.parameters,
                    c.vehicle_parameters,
                    library.display()
                ));
                Ok((summary, lines))
            },
        )
    }
}
