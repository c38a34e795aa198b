//! A sharded sweep on a real SLURM cluster: `xtask slurm FILE --shards 4`, its
//! `submit.sh`, the job array and the dependent merge job; the merged results equal a
//! single-machine run byte for byte (reference: `xtask sweep FILE` in this process's
//! machine; summary.json without wall_time_s).
//!
//! The cluster is the single-node one of `scripts/slurm-single-node.sh` (run as root;
//! `.ci/run` starts it). Without a cluster the test prints `SKIPPED` with the reason and
//! passes, unless `TRAILER_SWAY_REQUIRE_SLURM=1` (CI), where it fails.
//!
//! Jobs are awaited by polling `scontrol show job -o` every 0.2 s until every task has
//! ended, then their states are checked (`sbatch --wait` alone reports success for a
//! cancelled job and waits up to 10 s between its polls).
#![cfg(unix)]

mod common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use common::{SWEEP, assert_same_outputs, run_ok, s, vehicle};

/// How long the jobs may take: 4 shards of about 0.1 s of work plus scheduling.
const JOB_TIMEOUT: Duration = Duration::from_secs(300);

/// Why there is no usable cluster, or None.
fn no_cluster() -> Option<String> {
    match Command::new("scontrol").arg("ping").output() {
        Err(e) => Some(format!("no `scontrol` on PATH ({e})")),
        Ok(o) if !String::from_utf8_lossy(&o.stdout).contains("is UP") => Some(format!(
            "`scontrol ping`: {}",
            String::from_utf8_lossy(&o.stdout).trim()
        )),
        Ok(_) => None,
    }
}

/// The states of every task of job `id` (`scontrol show job -o`; an array has one line
/// per task or per pending range).
fn states(id: &str) -> Vec<String> {
    let out = Command::new("scontrol")
        .args(["show", "job", "-o", id])
        .output()
        .expect("scontrol runs");
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .filter_map(|w| w.strip_prefix("JobState="))
        .map(str::to_string)
        .collect()
}

fn running(state: &str) -> bool {
    matches!(
        state,
        "PENDING"
            | "RUNNING"
            | "CONFIGURING"
            | "COMPLETING"
            | "SUSPENDED"
            | "REQUEUED"
            | "REQUEUE_HOLD"
            | "RESIZING"
            | "SIGNALING"
            | "STAGE_OUT"
    )
}

/// Waits until every task of job `id` has ended; returns their states.
fn wait_job(id: &str, logs: &Path) -> Vec<String> {
    let end = Instant::now() + JOB_TIMEOUT;
    loop {
        let st = states(id);
        if !st.is_empty() && !st.iter().any(|s| running(s)) {
            return st;
        }
        assert!(
            Instant::now() < end,
            "job {id} still {st:?} after {JOB_TIMEOUT:?}\n{}",
            read_logs(logs)
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn read_logs(dir: &Path) -> String {
    let mut text = String::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        text += &format!(
            "--- {}\n{}\n",
            e.path().display(),
            std::fs::read_to_string(e.path()).unwrap_or_default()
        );
    }
    text
}

/// `KEY=value` of the submit script's `jobs.env`.
fn job_id(env: &str, key: &str) -> String {
    env.lines()
        .find_map(|l| l.strip_prefix(&format!("{key}=")))
        .unwrap_or_else(|| panic!("{key} in jobs.env: {env}"))
        .to_string()
}

#[test]
fn slurm_sharded_run_equals_a_single_machine_run() {
    if let Some(reason) = no_cluster() {
        let msg = format!(
            "SKIPPED slurm_sharded_run: no SLURM cluster: {reason} (run scripts/slurm-single-node.sh as root)"
        );
        if std::env::var("TRAILER_SWAY_REQUIRE_SLURM").as_deref() == Ok("1") {
            panic!("TRAILER_SWAY_REQUIRE_SLURM=1 but {msg}");
        }
        eprintln!("{msg}");
        return;
    }
    let t0 = Instant::now();
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("sweep.toml");
    std::fs::write(&cfg, SWEEP).expect("write");
    let veh = vehicle();
    let (single, cluster, jobs) = (
        tmp.path().join("single"),
        tmp.path().join("cluster"),
        tmp.path().join("job"),
    );
    run_ok(&[
        "sweep",
        s(&cfg),
        "--vehicle",
        s(&veh),
        "--results",
        s(&single),
    ]);
    run_ok(&[
        "slurm",
        s(&cfg),
        "--shards",
        "4",
        "--vehicle",
        s(&veh),
        "--results",
        s(&cluster),
        "--job-dir",
        s(&jobs),
        "--time",
        "5",
    ]);
    let submitted = Command::new("bash")
        .arg(jobs.join("submit.sh"))
        .output()
        .expect("submit.sh runs");
    assert!(
        submitted.status.success(),
        "submit.sh: {}",
        String::from_utf8_lossy(&submitted.stderr)
    );
    let env = std::fs::read_to_string(jobs.join("jobs.env")).expect("jobs.env");
    let (array, merge) = (job_id(&env, "ARRAY_JOB"), job_id(&env, "MERGE_JOB"));
    let logs = jobs.join("logs");
    let merge_states = wait_job(&merge, &logs);
    let array_states = wait_job(&array, &logs);
    assert_eq!(merge_states, ["COMPLETED"], "{}", read_logs(&logs));
    assert_eq!(array_states, ["COMPLETED"; 4], "{}", read_logs(&logs));
    assert_same_outputs(
        &single.join("cluster_check"),
        &cluster.join("cluster_check"),
    );
    eprintln!(
        "slurm_sharded_run: 4 shards + merge on SLURM, compared byte for byte, in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
}
