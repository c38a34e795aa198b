//! The Python package's tests from `cargo test --workspace`: puts the package
//! `trailer_sway` together from this build and runs its pytest suite
//! (`python/tests/test_*.py`, which also runs `python/examples/*.py`) in a virtual
//! environment under the target directory (created once: `python3 -m venv`, without a pip
//! of its own when python3's pip can install into it with `--python`; then numpy, pytest,
//! matplotlib and pandas from PyPI).
//!
//! The package is what `pip install ./python` installs: the Python sources of
//! `python/trailer_sway/` and the extension module `_native`. The extension is the cdylib
//! this very `cargo test` has just linked (`<target>/<profile>/deps/lib_native.so`, the
//! crate `trailer-sway-py`), copied in as `_native.abi3.so`, so the test compiles nothing twice
//! (maturin's own build resolves the dependencies' features for this crate alone and would
//! rebuild all of them). `TRAILER_SWAY_PIP_INSTALL=1` runs the real `pip install ./python`
//! (maturin, dev profile) instead. The suite compares its numbers with the `xtask` binary
//! of the same build (`TRAILER_SWAY_XTASK`) and with the committed `results/`. Without a
//! usable `python3` (with `venv` and `pip`) the test fails and says what to install;
//! `TRAILER_SWAY_PYTHON` names another interpreter. The venv also gets matplotlib and
//! pandas, the package's optional dependencies, so that `plot()` and `to_pandas()` are
//! tested (their tests skip where they are not installed: `pytest python/tests` in an
//! environment of one's own).

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

fn pip_install_requested() -> bool {
    std::env::var("TRAILER_SWAY_PIP_INSTALL").is_ok_and(|v| v == "1")
}

/// The venv under the target directory, created (and its tools installed) once.
fn venv(target: &Path) -> PathBuf {
    let dir = target.join("python-venv");
    let py = dir.join("bin").join("python");
    // matplotlib and pandas: plot() and to_pandas() (optional for users, tested here)
    let mut tools = vec!["pytest", "numpy", "matplotlib", "pandas"];
    if pip_install_requested() {
        tools.push("maturin>=1.16,<2");
    }
    let ready = dir.join(format!(".tools-installed-{}", tools.len()));
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
    if !py.exists() {
        let _ = std::fs::remove_dir_all(&dir);
        // without a pip of its own when the interpreter's pip can install into it
        // (`pip --python`): ensurepip took 3 of the venv's 3.1 s
        let own_pip = !pip_takes_python_option(&interpreter);
        let out = Command::new(&interpreter)
            .args(["-m", "venv"])
            .args((!own_pip).then_some("--without-pip"))
            .arg(&dir)
            .output()
            .unwrap_or_else(|e| panic!("cannot run {interpreter} -m venv: {e}"));
        assert!(
            out.status.success(),
            "`{interpreter} -m venv` failed — install the venv module (Debian/Ubuntu: \
             apt-get install python3-venv):\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    run(
        pip_install(&py).args(&tools),
        "installing the test tools from PyPI into the test venv",
    );
    std::fs::write(&ready, "").expect("marking the venv ready");
    py
}

/// Whether `interpreter`'s pip installs into another environment (`--python`, pip ≥ 22.3).
fn pip_takes_python_option(interpreter: &str) -> bool {
    let Ok(out) = Command::new(interpreter)
        .args(["-m", "pip", "--version"])
        .output()
    else {
        return false;
    };
    // "pip 23.2.1 from …"
    let text = String::from_utf8_lossy(&out.stdout);
    let mut version = text
        .split_whitespace()
        .nth(1)
        .unwrap_or("")
        .split('.')
        .map(|part| part.parse::<u32>().unwrap_or(0));
    let (major, minor) = (version.next().unwrap_or(0), version.next().unwrap_or(0));
    out.status.success() && (major, minor) >= (22, 3)
}

/// pip for the venv of `py`: the venv's own, or (a venv made without pip) the
/// interpreter's, pointed at the venv.
fn pip(py: &Path) -> Command {
    let venv_bin = py.parent().expect("the venv's bin/");
    if venv_bin.join("pip").exists() {
        let mut cmd = Command::new(py);
        cmd.args(["-m", "pip"]);
        cmd
    } else {
        let mut cmd = Command::new(python());
        cmd.args(["-m", "pip", "--python"]).arg(py);
        cmd
    }
}

/// `pip install`, quiet, into the venv of `py`.
fn pip_install(py: &Path) -> Command {
    let mut cmd = pip(py);
    cmd.args(["install", "--quiet", "--disable-pip-version-check"]);
    cmd
}

/// Whether the venv of `py` has a `trailer_sway` installed (by a run with
/// `TRAILER_SWAY_PIP_INSTALL=1`), which would shadow the package under test.
fn package_installed(py: &Path) -> bool {
    let lib = py
        .parent()
        .and_then(Path::parent)
        .expect("the venv")
        .join("lib");
    let Ok(versions) = std::fs::read_dir(lib) else {
        return false;
    };
    versions.flatten().any(|version| {
        std::fs::read_dir(version.path().join("site-packages")).is_ok_and(|entries| {
            entries.flatten().any(|entry| {
                entry
                    .file_name()
                    .to_string_lossy()
                    .starts_with("trailer_sway")
            })
        })
    })
}

/// PATH with `dir` first.
fn path_with(dir: &Path) -> std::ffi::OsString {
    let mut dirs = vec![dir.to_path_buf()];
    if let Some(p) = std::env::var_os("PATH") {
        dirs.extend(std::env::split_paths(&p));
    }
    std::env::join_paths(dirs).expect("PATH")
}

/// `<target>/<profile>`: where cargo put this test's own build (the test binary runs from
/// `<target>/<profile>/deps/`).
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    exe.parent()
        .and_then(Path::parent)
        .expect("<target>/<profile>/deps/<test binary>")
        .to_path_buf()
}

/// `python/trailer_sway/` and this build's extension module, copied into
/// `<target>/python-package/trailer_sway/`; returns the directory to put on `PYTHONPATH`.
fn assemble_package(manifest: &Path, target: &Path) -> PathBuf {
    // a library built for a test stays in deps/ (`cargo build` copies it up a level)
    let profile = profile_dir();
    let extension = [profile.join("deps"), profile]
        .iter()
        .map(|dir| dir.join("lib_native.so"))
        .find(|p| p.exists())
        .unwrap_or_else(|| {
            panic!(
                "lib_native.so is missing under {}: `cargo test` links the crate \
                 trailer-sway-py's cdylib (crate-type cdylib + rlib) before its tests run",
                profile_dir().display()
            )
        });
    let root = target.join("python-package");
    let package = root.join("trailer_sway");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&package).expect("creating the package directory");
    let sources = manifest.join("trailer_sway");
    for entry in std::fs::read_dir(&sources).expect("python/trailer_sway/") {
        let path = entry.expect("a package file").path();
        if path.is_file() {
            let name = path.file_name().expect("a file name");
            std::fs::copy(&path, package.join(name)).expect("copying a package file");
        }
    }
    std::fs::copy(&extension, package.join("_native.abi3.so"))
        .expect("copying the extension module");
    root
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
    let mut pytest = Command::new(&py);
    if pip_install_requested() {
        run(
            pip_install(&py)
                .args(["--no-build-isolation", "--force-reinstall", "--no-deps"])
                .arg(manifest)
                .env("MATURIN_PEP517_ARGS", "--profile dev")
                // the build backend runs the venv's `maturin` executable from PATH
                .env("PATH", path_with(py.parent().expect("venv bin")))
                .env("CARGO_TARGET_DIR", &target),
            "pip install ./python",
        );
    } else {
        if package_installed(&py) {
            run(
                pip(&py)
                    .args(["uninstall", "--quiet", "--yes"])
                    .arg("trailer_sway"),
                "removing an installed trailer_sway from the test venv",
            );
        }
        pytest.env("PYTHONPATH", assemble_package(manifest, &target));
    }
    pytest
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(manifest.join("tests"))
        // not python/ itself: its source trailer_sway/ would shadow the package under test
        .current_dir(env!("CARGO_TARGET_TMPDIR"))
        // where conftest.py looks for (or builds) the xtask binary
        .env("CARGO_TARGET_DIR", &target);
    let xtask = profile_dir().join("xtask");
    if xtask.exists() {
        pytest.env("TRAILER_SWAY_XTASK", &xtask);
    }
    run(&mut pytest, "the pytest suite of python/");
}
