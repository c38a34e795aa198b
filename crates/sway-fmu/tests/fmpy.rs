//! The FMU checked by an independent importer, FMPy (installed from PyPI into a virtual
//! environment under the target directory, as `python/tests/pytest.rs` does for the Python
//! package): FMPy validates both model descriptions (FMI 2.0 and 3.0) without errors,
//! simulates them, and its hitch angle matches the native simulation
//! (`sway::sim::simulate`, one run to the horizon) to 1e-6 rad at a 10 ms communication
//! step: the paper's S1 (open loop, V = 33 m/s, θ(0) = 0.1 rad, 60 s) and the closed loop
//! with delay (D = 0.1 s, τ = 0.2 s, V = 35 m/s, 40 s; S3 of the simulation bench). Both
//! runs use rtol 1e-8: the FMU lands a step on every communication point, the native run
//! does not, so they differ by the integration error of either (S1's global error is
//! 1.6e-7, crates/sway/benches/simulation.rs). Rollback: get the state, step, restore,
//! step again: identical outputs (bit for bit), also through a serialised state. The
//! archive is made from the cdylib this `cargo test` linked (`<profile>/deps/`), with the
//! crate's own archive writer.

use std::path::{Path, PathBuf};
use std::process::Command;

use sway::sim::{LoopLaw, Recording, SimSpec, SpeedProfile, simulate};
use sway_fmu::archive::write_fmu;
use sway_fmu::config::Defaults;
use sway_fmu::description::FmiVersion;
use trailer_model::{Model, State7, VehicleParams};

fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    exe.parent()
        .and_then(Path::parent)
        .expect("<target>/<profile>/deps/<test binary>")
        .to_path_buf()
}

fn library() -> PathBuf {
    let profile = profile_dir();
    [profile.join("deps"), profile.clone()]
        .iter()
        .map(|d| d.join("libsway_fmu.so"))
        .find(|p| p.exists())
        .unwrap_or_else(|| {
            panic!(
                "libsway_fmu.so is missing under {}: `cargo test` links the cdylib of \
                 sway-fmu (crate-type cdylib + rlib) before its tests run",
                profile.display()
            )
        })
}

fn python() -> String {
    std::env::var("TRAILER_SWAY_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// The venv with FMPy under the target directory, made once.
fn venv() -> PathBuf {
    let target = profile_dir().parent().expect("<target>").to_path_buf();
    let dir = target.join("fmpy-venv");
    let py = dir.join("bin").join("python");
    let ready = dir.join(".fmpy-installed");
    if ready.exists() && py.exists() {
        return py;
    }
    let interpreter = python();
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new(&interpreter)
        .args(["-m", "venv"])
        .arg(&dir)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "the FMU test needs `{interpreter}` with venv and pip (Debian/Ubuntu: apt-get \
                 install python3 python3-venv), or TRAILER_SWAY_PYTHON: {e}"
            )
        });
    assert!(
        out.status.success(),
        "`{interpreter} -m venv` failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = Command::new(&py)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "fmpy==0.3.32",
        ])
        .output()
        .expect("pip runs");
    assert!(
        out.status.success(),
        "installing FMPy from PyPI failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::write(&ready, "").expect("marking the venv ready");
    py
}

/// θ of a native run every 10 ms.
fn native_theta(speed: f64, law: Option<LoopLaw>, horizon: f64) -> Vec<f64> {
    let model = Model::new(VehicleParams::default()).expect("Table I");
    let spec = SimSpec {
        early_stop: sway::sim::EarlyStop::Never,
        steering: Default::default(),
        profile: SpeedProfile::Constant { speed_mps: speed },
        controller: law,
        horizon_s: horizon,
        action_s: 0.0,
        settings: Default::default(),
    };
    let x0 = State7::from_column_slice(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0]);
    let r = simulate(&model, &spec, x0, Recording::Every { step_s: 0.01 }).expect("native run");
    r.trajectory.iter().map(|s| s.x[3]).collect()
}

const SCRIPT: &str = r#"
import json, sys, time
import numpy as np
from fmpy import read_model_description, simulate_fmu, extract
from fmpy.validation import validate_fmu
from fmpy.fmi2 import FMU2Slave

fmu2, fmu3, s1_path, cl_path, out_path = sys.argv[1:6]
report = {}
for name, path in [("fmi2", fmu2), ("fmi3", fmu3)]:
    report["validate_" + name] = [str(p) for p in validate_fmu(path)]

def theta(path, start, stop):
    t0 = time.perf_counter()
    r = simulate_fmu(path, start_time=0.0, stop_time=stop, step_size=0.01,
                     output_interval=0.01, start_values=start,
                     output=["hitch_angle_rad", "loss_of_control"])
    return r["hitch_angle_rad"], time.perf_counter() - t0

s1 = np.loadtxt(s1_path)
cl = np.loadtxt(cl_path)
start_s1 = {"initial_hitch_angle_rad": 0.1, "speed_mps": 33.0}
start_cl = {"initial_hitch_angle_rad": 0.1, "speed_mps": 35.0,
            "controller.structure": "yaw_rate", "controller.gain_s": 0.1,
            "controller.delay_s": 0.2}
for name, path in [("fmi2", fmu2), ("fmi3", fmu3)]:
    th, wall = theta(path, start_s1, 60.0)
    n = min(len(th), len(s1))
    report["s1_" + name] = {"max_abs_dtheta": float(np.max(np.abs(th[:n] - s1[:n]))),
                           "samples": int(n), "wall_s": wall}
    th, wall = theta(path, start_cl, 40.0)
    n = min(len(th), len(cl))
    report["closed_loop_" + name] = {"max_abs_dtheta": float(np.max(np.abs(th[:n] - cl[:n]))),
                                    "samples": int(n), "wall_s": wall}

# FMPy's own overhead: the same 6000 steps with nothing to compute (doStep of an FMU whose
# model is cheap is not available here, so: the loop of simulate_fmu with output recording
# measured by a run of 1 step of 60 s, whose doStep integrates the same interval at once)
t0 = time.perf_counter()
simulate_fmu(fmu2, start_time=0.0, stop_time=60.0, step_size=60.0, output_interval=60.0,
             start_values=start_s1, output=["hitch_angle_rad"])
report["s1_one_step_wall_s"] = time.perf_counter() - t0

# rollback: get state, step, set state, step again; and through a serialised state
md = read_model_description(fmu2)
vr = {v.name: v.valueReference for v in md.modelVariables}
unzipdir = extract(fmu2)
fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                modelIdentifier=md.coSimulation.modelIdentifier, instanceName="rollback")
fmu.instantiate()
fmu.setReal([vr["initial_hitch_angle_rad"]], [0.1])
fmu.setString([vr["controller.structure"]], ["yaw_rate"])
fmu.setReal([vr["controller.gain_s"], vr["controller.delay_s"]], [0.1, 0.2])
fmu.setupExperiment(startTime=0.0)
fmu.enterInitializationMode()
fmu.exitInitializationMode()
outs = [vr[n] for n in ["hitch_angle_rad", "car_yaw_rate_rad_s", "sigma1_mps", "car_lateral_acceleration_mps2"]]
t = 0.0
for k in range(100):
    fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
    t += 0.01
state = fmu.getFMUstate()
blob = fmu.serializeFMUstate(state)
fmu.setReal([vr["steering_angle_rad"]], [0.01])
fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.05)
first = fmu.getReal(outs)
fmu.setFMUstate(state)
fmu.setReal([vr["steering_angle_rad"]], [0.01])
fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.05)
second = fmu.getReal(outs)
restored = fmu.deSerializeFMUstate(blob)
fmu.setFMUstate(restored)
fmu.setReal([vr["steering_angle_rad"]], [0.01])
fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.05)
third = fmu.getReal(outs)
report["rollback"] = {"first": first, "second": second, "third": third,
                      "serialized_bytes": len(blob)}
# a bad input is an error, not a crash
fmu.setReal([vr["steering_angle_rad"]], [0.0])
try:
    fmu.setReal([vr["speed_mps"]], [float("nan")])
    report["nan_input"] = "accepted"
except Exception as e:
    report["nan_input"] = "refused: " + str(e)
fmu.freeFMUstate(state)
fmu.freeFMUstate(restored)
fmu.terminate()
fmu.freeInstance()

# a bad parameter: refused at initialisation with the vehicle file's message
try:
    simulate_fmu(fmu2, stop_time=1.0, step_size=0.01, start_values={"trailer.mass": -1.0})
    report["bad_parameter"] = "accepted"
except Exception as e:
    report["bad_parameter"] = "refused: " + str(e)
json.dump(report, open(out_path, "w"), indent=1)
"#;

#[test]
fn fmpy_validates_simulates_and_matches_the_native_simulation() {
    let lib = library();
    let dir = tempfile::tempdir().expect("a temporary directory");
    let defaults = Defaults::default();
    let fmu2 = dir.path().join("trailer_sway.fmu");
    let fmu3 = dir.path().join("trailer_sway_fmi3.fmu");
    write_fmu(&fmu2, &lib, &defaults, FmiVersion::V2).expect("the FMI 2.0 archive");
    write_fmu(&fmu3, &lib, &defaults, FmiVersion::V3).expect("the FMI 3.0 archive");
    let write = |name: &str, v: &[f64]| {
        let p = dir.path().join(name);
        let text: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
        std::fs::write(&p, text.join("\n")).expect("writing the native run");
        p
    };
    let s1 = write("s1.txt", &native_theta(33.0, None, 60.0));
    let cl = write(
        "closed_loop.txt",
        &native_theta(35.0, Some(LoopLaw::paper(0.1, 0.2)), 40.0),
    );
    let script = dir.path().join("check.py");
    std::fs::write(&script, SCRIPT).expect("writing the script");
    let report = dir.path().join("report.json");
    let py = venv();
    let out = Command::new(&py)
        .arg(&script)
        .args([&fmu2, &fmu3, &s1, &cl, &report])
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "the FMPy script failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&report).expect("the report");
    eprintln!("{text}");
    let r: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    for v in ["fmi2", "fmi3"] {
        let problems = r[format!("validate_{v}")].as_array().expect("a list");
        assert!(problems.is_empty(), "{v}: {problems:?}");
        for run in ["s1", "closed_loop"] {
            let case = &r[format!("{run}_{v}")];
            let err = case["max_abs_dtheta"].as_f64().expect("a number");
            let n = case["samples"].as_u64().expect("a count");
            let expected = if run == "s1" { 6001 } else { 4001 };
            assert_eq!(n, expected, "{run} {v}: samples");
            assert!(err < 1e-6, "{run} {v}: max |Δθ| = {err:e}");
        }
    }
    let rb = &r["rollback"];
    assert_eq!(rb["first"], rb["second"], "rollback through GetFMUstate");
    assert_eq!(
        rb["first"], rb["third"],
        "rollback through a serialised state"
    );
    assert!(r["nan_input"].as_str().unwrap_or("").starts_with("refused"));
    let bad = r["bad_parameter"].as_str().unwrap_or("");
    assert!(bad.starts_with("refused"), "{bad}");
}
