//! The sharding command line: `xtask sweep FILE --shard K/N` for every K, then
//! `xtask merge DIR`, writes the same results as `xtask sweep FILE` (reference: that
//! unsharded run; byte equality, summary.json without wall_time_s); a missing shard makes
//! the merge fail with a message naming it; `xtask slurm` writes the job scripts.

mod common;

use common::{SWEEP, assert_same_outputs, run, run_ok, s, vehicle};

#[test]
fn shards_merged_on_the_command_line_equal_the_unsharded_run() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("sweep.toml");
    std::fs::write(&cfg, SWEEP).expect("write");
    let (single, merged, shards) = (
        tmp.path().join("single"),
        tmp.path().join("merged"),
        tmp.path().join("shards"),
    );
    let veh = vehicle();
    run_ok(&[
        "sweep",
        s(&cfg),
        "--vehicle",
        s(&veh),
        "--results",
        s(&single),
    ]);
    for k in 1..=4 {
        let spec = format!("{k}/4");
        let out = run_ok(&[
            "sweep",
            s(&cfg),
            "--vehicle",
            s(&veh),
            "--shard",
            &spec,
            "--shard-dir",
            s(&shards),
        ]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains(&format!("shard {spec}")), "{text}");
    }
    run_ok(&["merge", s(&shards), "--results", s(&merged)]);
    assert_same_outputs(&single.join("cluster_check"), &merged.join("cluster_check"));

    // one shard gone: the merge fails and names it
    std::fs::remove_file(shards.join("shard-2-of-4.json")).expect("rm");
    let out = run(&["merge", s(&shards), "--results", s(&merged)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("missing 2/4"),
        "{err}"
    );

    // a bad K/N is refused before any work
    let out = run(&[
        "sweep",
        s(&cfg),
        "--shard",
        "5/4",
        "--shard-dir",
        s(&shards),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("5/4"), "{err}");
}

#[test]
fn slurm_writes_a_job_array_a_dependent_merge_and_a_submit_script() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let cfg = tmp.path().join("sweep.toml");
    std::fs::write(&cfg, SWEEP).expect("write");
    let jobs = tmp.path().join("job");
    let results = tmp.path().join("results");
    run_ok(&[
        "slurm",
        s(&cfg),
        "--shards",
        "3",
        "--partition",
        "batch",
        "--time",
        "10:00",
        "--results",
        s(&results),
        "--job-dir",
        s(&jobs),
    ]);
    let shard = std::fs::read_to_string(jobs.join("shard.sbatch")).expect("shard.sbatch");
    assert!(shard.contains("#SBATCH --array=1-3\n"), "{shard}");
    assert!(shard.contains("#SBATCH --partition=batch\n#SBATCH --time=10:00\n"));
    assert!(shard.contains(&format!("exec '{}' sweep", common::xtask().display())));
    let submit = std::fs::read_to_string(jobs.join("submit.sh")).expect("submit.sh");
    assert!(submit.contains("--dependency=afterany:"), "{submit}");
    assert!(jobs.join("logs").is_dir() && jobs.join("merge.sbatch").is_file());
    // a value that would break an #SBATCH line is refused
    let out = run(&["slurm", s(&cfg), "--shards", "3", "--time", "1 2"]);
    assert!(!out.status.success());
}
