//! The Python package's tests from `cargo test --workspace`: builds `trailer_sway` with
//! `pip install ./python` into a virtual environment under the target directory (created
//! once: `python3 -m venv`, then numpy, pytest and maturin from PyPI) and runs its pytest
//! suite (`python/tests/test_*.py`, which also runs `python/examples/*.py`).
//!
//! The package is built with the dev profile (`MATURIN_PEP517_ARGS=--profile dev`), so it
//! reuses the dependencies `cargo test` has just compiled; the suite compares its numbers
//! with the `xtask` binary of the same build (`TRAILER_SWAY_XTASK`) and with the
//! committed `results/`. Without a usable `python3` (with `venv` and `pip`) the test fails
//! and says what to install; `TRAILER_SWAY_PYTHON` names another interpreter.

use std::path::{Path, PathBuf};
use std::process::Command;

fn run(cmd: &mut Command, what: &str) {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start {cmd:?}: {e}"));
    if !out.status.success() {
        panic!(
            "{what} failed ({}):\n{cmd:?}\n--- stdout\n{}\n--- stderr\n{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

fn python() -> String {
    std::env::var("TRAILER_SWAY_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// The venv under the target directory, created (and its tools installed) once.
fn venv(target: &Path) -> PathBuf {
    let dir = target.join("python-venv");
    let py = dir.join("bin").join("python");
    let ready = dir.join(".tools-installed");
    if ready.exists() && py.exists() {
        return py;
    }
    let interpreter = python();
    let version = Command::new(&interpreter).arg("--version").output();
    match version {
        Ok(o) if o.status.success() => {}
        _ => panic!(
            "the Python tests need `{interpreter}` (CPython ≥ 3.10 with venv and pip; on \
             Debian/Ubuntu: apt-get install python3 python3-venv python3-pip), or \
             TRAILER_SWAY_PYTHON=/path/to/python"
        ),
    }
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new(&interpreter)
        .args(["-m", "venv"])
        .arg(&dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {interpreter} -m venv: {e}"));
    assert!(
        out.status.success(),
        "`{interpreter} -m venv` failed — install the venv module (Debian/Ubuntu: apt-get \
         install python3-venv):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    run(
        Command::new(&py).args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "maturin>=1.16,<2",
            "pytest",
            "numpy",
        ]),
        "installing maturin, pytest and numpy from PyPI into the test venv",
    );
    std::fs::write(&ready, "").expect("marking the venv ready");
    py
}

/// PATH with `dir` first.
fn path_with(dir: &Path) -> std::ffi::OsString {
    let mut dirs = vec![dir.to_path_buf()];
    if let Some(p) = std::env::var_os("PATH") {
        dirs.extend(std::env::split_paths(&p));
    }
    std::env::join_paths(dirs).expect("PATH")
}

#[test]
fn python_package_installs_and_its_pytest_suite_passes() {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    // CARGO_TARGET_TMPDIR is <target>/tmp
    let target = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("target directory")
        .to_path_buf();
    let py = venv(&target);
    run(
        Command::new(&py)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
                "--no-build-isolation",
                "--force-reinstall",
                "--no-deps",
            ])
            .arg(manifest)
            .env("MATURIN_PEP517_ARGS", "--profile dev")
            // the build backend runs the venv's `maturin` executable from PATH
            .env("PATH", path_with(py.parent().expect("venv bin")))
            .env("CARGO_TARGET_DIR", &target),
        "pip install ./python",
    );
    let mut pytest = Command::new(&py);
    pytest
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(manifest.join("tests"))
        // not python/ itself: its source trailer_sway/ would shadow the installed package
        .current_dir(env!("CARGO_TARGET_TMPDIR"))
        // where conftest.py looks for (or builds) the xtask binary
        .env("CARGO_TARGET_DIR", &target);
    let xtask = target.join("debug").join("xtask");
    if xtask.exists() {
        pytest.env("TRAILER_SWAY_XTASK", &xtask);
    }
    run(&mut pytest, "the pytest suite of python/");
}
