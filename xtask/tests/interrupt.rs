//! Interruption of a running task: SIGTERM to a running `xtask` process stops
//! it with a non-zero status and one line on stderr, leaves `--results` byte for byte as
//! it was and removes its staging directory; after SIGKILL (no handler runs) the staging
//! directory left behind is removed by the next run.
//!
//! The task is a sweep whose config (a temporary file) is far too large to finish within
//! the test (≈ 10⁵ simulations, minutes even in a release build): the signal is sent once
//! the task's staging directory exists and ~1 s later, so the task is always mid-run.
#![cfg(unix)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// A sweep config `name` over `speeds` (min, max, points) × the `theta0_deg` values of
/// `theta0` (None: no second axis), each simulation `horizon_s` long.
fn sweep_toml(
    name: &str,
    speeds: (f64, f64, usize),
    theta0: Option<(f64, f64, usize)>,
    horizon_s: f64,
) -> String {
    let axis = |parameter: &str, (min, max, points): (f64, f64, usize)| {
        format!(
            "[[axes]]\nparameter = \"{parameter}\"\nmin = {min:?}\nmax = {max:?}\npoints = {points}\n\n"
        )
    };
    let mut text = format!("name = \"{name}\"\n\n{}", axis("speed_mps", speeds));
    if let Some(t) = theta0 {
        text += &axis("theta0_deg", t);
    }
    text += &format!(
        "[base]\nhorizon_s = {horizon_s:?}\naction_s = 0.0\n\
         speed = {{ kind = \"constant\", speed_mps = 33.0 }}\n\
         controller = {{ kind = \"none\" }}\n\
         initial = {{ kind = \"state\", theta0_deg = 2.0 }}\nguard = \"stop\"\n\n\
         [base.solver]\nrtol = 1e-9\natol = 1e-11\n\n\
         [base.metrics]\nfinal_window_s = {:?}\n",
        (0.5f64).min(horizon_s / 2.0)
    );
    text
}

/// The sweep that cannot finish within the test: 320 × 320 points of 600 s each.
fn slow_sweep() -> String {
    sweep_toml(
        "slow_sweep",
        (28.0, 36.0, 320),
        Some((0.5, 15.0, 320)),
        600.0,
    )
}

/// A sweep of a few short simulations: the "next run" after a SIGKILL.
fn quick_sweep() -> String {
    sweep_toml("quick_sweep", (30.0, 31.0, 2), None, 1.0)
}

/// How long the staging directory may take to appear, and the process to exit after a
/// signal (generous: a debug build on a loaded machine).
const STARTUP: Duration = Duration::from_secs(20);
const EXIT: Duration = Duration::from_secs(10);

/// Every file under `dir` (relative path → bytes).
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).expect("read_dir") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                walk(root, &path, out);
            } else {
                let rel = path.strip_prefix(root).expect("inside").to_path_buf();
                out.insert(rel, std::fs::read(&path).expect("read"));
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// A results directory with earlier results: one of the slow sweep's own name (which a
/// finished run would replace) and one of another task.
fn results_with_earlier_runs(root: &Path) -> PathBuf {
    let results = root.join("results");
    for (dir, file, text) in [
        ("slow_sweep", "summary.json", "{ \"earlier\": true }\n"),
        ("slow_sweep", "sweep.csv", "speed_mps,theta0_deg\n1.0,2.0\n"),
        ("linear", "summary.json", "{ \"v_crit_mps\": 34.748 }\n"),
    ] {
        std::fs::create_dir_all(results.join(dir)).expect("mkdir");
        std::fs::write(results.join(dir).join(file), text).expect("write");
    }
    results
}

fn write_config(root: &Path, name: &str, text: &str) -> PathBuf {
    let path = root.join(name);
    std::fs::write(&path, text).expect("write config");
    path
}

fn xtask(args: &[&Path], results: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_xtask"));
    cmd.arg("sweep")
        .args(args)
        .arg("--results")
        .arg(results)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

/// The staging directories (`.<task>.staging-<pid>`) under `results`.
fn staging_dirs(results: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(results)
        .expect("read_dir")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with('.') && n.contains(".staging-"))
        })
        .collect()
}

/// Waits until `child` has created its staging directory, then ~1 s more (the task is
/// computing), and checks that it is still running.
fn wait_until_computing(child: &mut Child, results: &Path) -> PathBuf {
    let staging = results.join(format!(".slow_sweep.staging-{}", child.id()));
    let t0 = Instant::now();
    while !staging.is_dir() {
        if let Some(status) = child.try_wait().expect("try_wait") {
            panic!("xtask exited ({status}) before its staging directory appeared");
        }
        assert!(
            t0.elapsed() < STARTUP,
            "no staging directory after {STARTUP:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_secs(1));
    assert!(
        child.try_wait().expect("try_wait").is_none(),
        "the slow sweep finished within 1 s: the test needs a larger config"
    );
    staging
}

fn send(signal: &str, child: &Child) {
    let status = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .expect("run kill");
    assert!(status.success(), "kill {signal} failed");
}

/// Waits for `child` to exit (SIGKILL and a failed test after [`EXIT`]); its status,
/// stdout and stderr.
fn wait_with_timeout(mut child: Child) -> (ExitStatus, String, String) {
    let t0 = Instant::now();
    while child.try_wait().expect("try_wait").is_none() {
        if t0.elapsed() > EXIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("xtask did not exit within {EXIT:?} of the signal");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("output");
    (
        out.status,
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn sigterm_stops_the_task_and_leaves_results_as_they_were() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let results = results_with_earlier_runs(tmp.path());
    let before = snapshot(&results);
    let config = write_config(tmp.path(), "slow.toml", &slow_sweep());

    let mut child = xtask(&[&config], &results).spawn().expect("spawn xtask");
    let staging = wait_until_computing(&mut child, &results);
    send("-TERM", &child);
    let (status, stdout, stderr) = wait_with_timeout(child);

    use std::os::unix::process::ExitStatusExt;
    assert!(!status.success(), "exit status {status}");
    assert_eq!(
        status.code(),
        Some(130),
        "status {status} (signal {:?}); stderr: {stderr}",
        status.signal()
    );
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "one line on stderr, got: {stderr:?}");
    assert!(
        lines[0].starts_with("interrupted:") && lines[0].contains("1 staging directory removed"),
        "{}",
        lines[0]
    );
    assert!(!stdout.contains("done"), "stdout: {stdout}");
    assert!(!staging.exists(), "{} left behind", staging.display());
    assert_eq!(staging_dirs(&results), Vec::<PathBuf>::new());
    assert_eq!(snapshot(&results), before, "results changed");
}

#[test]
fn staging_left_by_sigkill_is_removed_by_the_next_run() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let results = results_with_earlier_runs(tmp.path());
    let before = snapshot(&results);
    let slow = write_config(tmp.path(), "slow.toml", &slow_sweep());
    let quick = write_config(tmp.path(), "quick.toml", &quick_sweep());

    let mut child = xtask(&[&slow], &results).spawn().expect("spawn xtask");
    let staging = wait_until_computing(&mut child, &results);
    send("-KILL", &child);
    // reaped: the pid is no longer alive (a zombie would still have /proc/<pid>)
    let (status, _, _) = wait_with_timeout(child);
    assert!(!status.success());
    assert!(
        staging.is_dir(),
        "SIGKILL runs no handler: the staging directory stays"
    );
    assert_eq!(snapshot(&results), before, "results changed");

    let out = xtask(&[&quick], &results).output().expect("run xtask");
    assert!(
        out.status.success(),
        "next run failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!staging.exists(), "stale {} not removed", staging.display());
    assert_eq!(staging_dirs(&results), Vec::<PathBuf>::new());
    // the earlier results are untouched; the next run added its own directory
    let after = snapshot(&results);
    for (path, bytes) in &before {
        assert_eq!(after.get(path), Some(bytes), "{} changed", path.display());
    }
    assert!(results.join("quick_sweep").join("summary.json").is_file());
}
