//! `cargo xtask slurm FILE --shards N [--task T] [--partition P] [--time T]`: a sharded
//! study (a sweep by default; any task of `sway_tasks::shard::SHARDABLE_TASKS`) as a SLURM
//! job array.
//!
//! Writes into the job directory (default `results/<name>.slurm/`):
//! - `shard.sbatch`: the job array `1-N`; array task K runs `xtask TASK FILE --shard K/N`
//!   with this very binary by absolute path (jobs never run cargo), one rayon thread per
//!   allocated CPU (`RAYON_NUM_THREADS=$SLURM_CPUS_PER_TASK`);
//! - `merge.sbatch`: `xtask merge SHARD_DIR`;
//! - `submit.sh`: submits the array, then the merge with `--dependency=afterany:<array>`:
//!   the merge runs however the shards ended and fails naming any missing or failed shard
//!   (with `afterok` a failed shard would leave the merge pending or cancelled, and
//!   `sbatch --wait` reports success for a cancelled job). It prints the job ids and
//!   writes them to `jobs.env` (`ARRAY_JOB=…`, `MERGE_JOB=…`);
//! - `logs/`: one log per array task (`shard-<array>_<K>.out`) and the merge's.
//!
//! Every path in the scripts is absolute, and the jobs run in the directory where
//! `xtask slurm` ran (`--chdir`), so the merged `summary.json` records the same paths as
//! a run on one machine from there.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Parser;
use sway_tasks::shard::{self, ShardSpec};
use sway_tasks::tasks;

/// The arguments of `cargo xtask slurm`.
#[derive(Debug, Parser)]
#[command(no_binary_name = true)]
pub struct SlurmArgs {
    /// the study's config file (TOML)
    file: PathBuf,
    /// the number of shards N (array tasks)
    #[arg(long)]
    shards: usize,
    /// the shardable task (`sweep`, `brake_timing`, `study_generated`, `sway_assist`,
    /// `sway_assist_full`)
    #[arg(long, default_value = "sweep")]
    task: String,
    /// the SLURM partition (default: the cluster's default partition)
    #[arg(long)]
    partition: Option<String>,
    /// the time limit of each array task, in SLURM's format (e.g. `30`, `2:00:00`)
    #[arg(long)]
    time: Option<String>,
    /// CPUs per array task (its rayon threads)
    #[arg(long, default_value_t = 1)]
    cpus_per_task: usize,
    /// vehicle parameters (the form of configs/vehicle.toml)
    #[arg(long)]
    vehicle: Option<PathBuf>,
    /// where the merged results/NAME/ goes
    #[arg(long)]
    results: Option<PathBuf>,
    /// where the shard files go (default: RESULTS/NAME.shards/)
    #[arg(long)]
    shard_dir: Option<PathBuf>,
    /// where the scripts and logs go (default: RESULTS/NAME.slurm/)
    #[arg(long)]
    job_dir: Option<PathBuf>,
    /// the xtask binary the jobs run (default: this one; build it with --release)
    #[arg(long)]
    binary: Option<PathBuf>,
}

/// Everything the scripts need, as absolute paths.
#[derive(Debug, Clone, PartialEq)]
pub struct JobPlan {
    /// the study name
    pub name: String,
    /// the shardable task
    pub task: String,
    /// N
    pub shards: usize,
    /// `--partition`
    pub partition: Option<String>,
    /// `--time`
    pub time: Option<String>,
    /// `--cpus-per-task`
    pub cpus_per_task: usize,
    /// the xtask binary
    pub binary: PathBuf,
    /// the study's config file
    pub config: PathBuf,
    /// the vehicle file
    pub vehicle: PathBuf,
    /// the results root
    pub results: PathBuf,
    /// the shard directory
    pub shard_dir: PathBuf,
    /// the job directory
    pub job_dir: PathBuf,
    /// the jobs' working directory
    pub workdir: PathBuf,
}

/// The three files of a job directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Scripts {
    /// `shard.sbatch`
    pub shard: String,
    /// `merge.sbatch`
    pub merge: String,
    /// `submit.sh`
    pub submit: String,
}

/// A word for a bash command line: single-quoted, `'` written as `'\''`.
fn quote(s: &Path) -> String {
    format!("'{}'", s.display().to_string().replace('\'', r"'\''"))
}

/// `#SBATCH` lines cannot quote: a value there must be one plain word.
fn plain_word(what: &str, value: &str) -> Result<()> {
    let ok = !value.is_empty()
        && value
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "/_.,:+-=%@".contains(c));
    if !ok {
        bail!(
            "{what} `{value}` cannot go into an #SBATCH line: use letters, digits and / _ . , : + - = % @ only (no spaces)"
        );
    }
    Ok(())
}

/// The `#SBATCH` lines every job shares.
fn common_directives(p: &JobPlan) -> String {
    let mut s = format!(
        "#SBATCH --ntasks=1\n#SBATCH --cpus-per-task={}\n#SBATCH --chdir={}\n",
        p.cpus_per_task,
        p.workdir.display()
    );
    if let Some(part) = &p.partition {
        s.push_str(&format!("#SBATCH --partition={part}\n"));
    }
    if let Some(t) = &p.time {
        s.push_str(&format!("#SBATCH --time={t}\n"));
    }
    s
}

/// The scripts of `p`.
pub fn scripts(p: &JobPlan) -> Scripts {
    let (n, name, logs) = (p.shards, &p.name, p.job_dir.join("logs"));
    let header = "#!/bin/bash\n# Written by `cargo xtask slurm`";
    let shard = format!(
        "{header}: array task K computes shard K/{n} of the study `{name}`.\n\
         #SBATCH --job-name=sway-{name}\n#SBATCH --array=1-{n}\n{}\
         #SBATCH --output={}/shard-%A_%a.out\n\
         set -euo pipefail\n\
         # one rayon thread per allocated CPU (without CPU binding a task sees every CPU)\n\
         export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\"\n\
         exec {} {} {} --vehicle {} --results {} --shard \"${{SLURM_ARRAY_TASK_ID}}/{n}\" --shard-dir {}\n",
        common_directives(p),
        logs.display(),
        quote(&p.binary),
        p.task,
        quote(&p.config),
        quote(&p.vehicle),
        quote(&p.results),
        quote(&p.shard_dir),
    );
    let merge = format!(
        "{header}: merges the {n} shards of `{name}` into {}/{name}/.\n\
         #SBATCH --job-name=sway-{name}-merge\n{}\
         #SBATCH --output={}/merge-%j.out\n\
         set -euo pipefail\n\
         export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\"\n\
         exec {} merge {} --results {}\n",
        p.results.display(),
        common_directives(p),
        logs.display(),
        quote(&p.binary),
        quote(&p.shard_dir),
        quote(&p.results),
    );
    let submit = format!(
        "{header}: submits the {n} shards of `{name}` as a job array, then the merge,\n\
         # which runs after all of them have ended however they ended (afterany) and fails\n\
         # naming any missing or failed shard. Its job state says whether the study is done:\n\
         #   scontrol show job -o $MERGE_JOB   (JobState=COMPLETED)\n\
         set -euo pipefail\n\
         cd {}\n\
         mkdir -p logs\n\
         array=$(sbatch --parsable shard.sbatch)\n\
         array=${{array%%;*}}\n\
         merge=$(sbatch --parsable --dependency=afterany:\"$array\" merge.sbatch)\n\
         merge=${{merge%%;*}}\n\
         printf 'ARRAY_JOB=%s\\nMERGE_JOB=%s\\n' \"$array\" \"$merge\" > jobs.env\n\
         echo \"submitted: shards = job array $array (1-{n}), merge = job $merge (after all shards)\"\n\
         echo \"results: {}/{name}/   logs: {}/   state: squeue -j $array,$merge\"\n",
        quote(&p.job_dir),
        p.results.display(),
        logs.display(),
    );
    Scripts {
        shard,
        merge,
        submit,
    }
}

fn absolute(p: &Path) -> Result<PathBuf> {
    std::path::absolute(p).with_context(|| format!("{}: cannot make it absolute", p.display()))
}

/// Validates the study's config and vehicle and resolves every path of the job.
fn plan(a: SlurmArgs, root: &Path) -> Result<JobPlan> {
    ShardSpec::new(1, a.shards)?;
    if a.cpus_per_task == 0 {
        bail!("--cpus-per-task must be at least 1");
    }
    for (what, v) in [("--partition", &a.partition), ("--time", &a.time)] {
        if let Some(v) = v {
            plain_word(what, v)?;
        }
    }
    let vehicle = a
        .vehicle
        .unwrap_or_else(|| root.join("configs").join("vehicle.toml"));
    sway_tasks::config_file::load_vehicle(&vehicle)?;
    let task = tasks::resolve(&a.task)?.remove(0);
    let name = shard::study_name(task.name, &a.file)?;
    let results = absolute(&a.results.unwrap_or_else(|| root.join("results")))?;
    let binary = match a.binary {
        Some(b) => absolute(&b)?,
        None => std::env::current_exe().context("cannot find this executable")?,
    };
    let p = JobPlan {
        shard_dir: absolute(
            &a.shard_dir
                .unwrap_or_else(|| results.join(format!("{name}.shards"))),
        )?,
        job_dir: absolute(
            &a.job_dir
                .unwrap_or_else(|| results.join(format!("{name}.slurm"))),
        )?,
        workdir: std::env::current_dir().context("no working directory")?,
        config: absolute(&a.file)?,
        vehicle: absolute(&vehicle)?,
        name,
        task: task.name.to_string(),
        shards: a.shards,
        partition: a.partition,
        time: a.time,
        cpus_per_task: a.cpus_per_task,
        binary,
        results,
    };
    for (what, dir) in [
        ("the job directory", &p.job_dir),
        ("the working directory", &p.workdir),
    ] {
        plain_word(what, &dir.display().to_string())?;
    }
    Ok(p)
}

fn write_file(path: &Path, text: &str, executable: bool) -> Result<()> {
    std::fs::write(path, text).with_context(|| format!("{}: cannot write", path.display()))?;
    #[cfg(unix)]
    if executable {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
            .with_context(|| format!("{}: cannot make it executable", path.display()))?;
    }
    #[cfg(not(unix))]
    let _ = executable;
    Ok(())
}

/// `cargo xtask slurm`: validates, writes the job directory and says how to submit it.
pub fn run(args: &[String], root: &Path) -> Result<()> {
    let a = SlurmArgs::try_parse_from(args).map_err(|e| anyhow::anyhow!("{e}"))?;
    let p = plan(a, root)?;
    std::fs::create_dir_all(p.job_dir.join("logs"))
        .with_context(|| format!("{}: cannot create", p.job_dir.display()))?;
    let s = scripts(&p);
    write_file(&p.job_dir.join("shard.sbatch"), &s.shard, false)?;
    write_file(&p.job_dir.join("merge.sbatch"), &s.merge, false)?;
    let submit = p.job_dir.join("submit.sh");
    write_file(&submit, &s.submit, true)?;
    println!(
        "[slurm] {} shards of `{}` → {}",
        p.shards,
        p.name,
        p.job_dir.display()
    );
    println!("  submit: {}", submit.display());
    println!("  jobs run {}", p.binary.display());
    if !p.binary.components().any(|c| c.as_os_str() == "release") {
        println!(
            "  note: not a release build; `cargo xtask slurm …` (the alias builds --release) runs much faster"
        );
    }
    let stale = std::fs::read_dir(&p.shard_dir)
        .map(|d| d.filter_map(Result::ok).count())
        .unwrap_or(0);
    if stale > 0 {
        println!(
            "  note: {} already holds {stale} file(s); shards of another study or shard count make the merge fail",
            p.shard_dir.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> JobPlan {
        JobPlan {
            name: "study".into(),
            task: "sweep".into(),
            shards: 4,
            partition: Some("debug".into()),
            time: None,
            cpus_per_task: 2,
            binary: "/opt/x/target/release/xtask".into(),
            config: "/home/a b/it's.toml".into(),
            vehicle: "/v.toml".into(),
            results: "/r".into(),
            shard_dir: "/r/study.shards".into(),
            job_dir: "/r/study.slurm".into(),
            workdir: "/w".into(),
        }
    }

    #[test]
    fn the_array_has_one_task_per_shard_and_the_merge_runs_after_any_end() {
        let s = scripts(&plan());
        assert!(s.shard.contains("#SBATCH --array=1-4\n"));
        assert!(s.shard.contains("--shard \"${SLURM_ARRAY_TASK_ID}/4\""));
        assert!(
            s.shard
                .contains("RAYON_NUM_THREADS=\"${SLURM_CPUS_PER_TASK:-1}\"")
        );
        assert!(
            s.shard
                .contains("#SBATCH --cpus-per-task=2\n#SBATCH --chdir=/w\n")
        );
        assert!(s.shard.contains("#SBATCH --partition=debug\n"));
        assert!(!s.shard.contains("--time"));
        assert!(s.shard.contains("exec '/opt/x/target/release/xtask' sweep"));
        // a quote inside a path survives bash quoting
        assert!(s.shard.contains(r"'/home/a b/it'\''s.toml'"));
        assert!(s.merge.contains("merge '/r/study.shards' --results '/r'\n"));
        assert!(
            s.submit
                .contains("--dependency=afterany:\"$array\" merge.sbatch")
        );
    }

    #[test]
    fn sbatch_values_must_be_plain_words() {
        assert!(plain_word("--time", "2:00:00").is_ok());
        let e = plain_word("--partition", "a\n#SBATCH --x").expect_err("refused");
        assert!(e.to_string().contains("--partition"));
    }
}
