//! The user guide (`docs/`) and the README kept true by the code. Reference: the code
//! itself — the task registry (`sway_tasks::tasks::registry`, what `cargo xtask list`
//! prints), the shipped configs in `configs/`, the config types (through the validation
//! `cargo xtask <task> --check` uses, `tasks::prepare_checked`), the runner's flags
//! (`xtask/src/*.rs`) and the files of the repository. Exact checks, no tolerance.
//!
//! - **Every task has its page**: `docs/src/tasks/<task>.md` for each task of the
//!   registry, listed in `docs/src/SUMMARY.md`, whose title names the task; every page of
//!   `docs/src/` is in `SUMMARY.md` (mdBook renders only those).
//! - **Every shipped config key is on its page.** A page documents keys in *key tables*:
//!   Markdown tables whose header's first cell is `key`; the first cell of each row holds
//!   one or more key paths in backticks (`` `panels.solver.rtol` ``; `[]` marks an array of
//!   tables: `` `axes[].points` ``). Each key path of the config file of a task (walking
//!   tables and arrays of tables; a relative speed `{ of_v_crit = f }` or
//!   `{ in_bistable = f }` is a value, not a table) must be in that task's page's key
//!   tables; each key of a vehicle file (`configs/vehicle.toml`, `configs/vehicles/`,
//!   `configs/fleet/`) must be in the key tables of `docs/src/vehicle-files.md`. Every
//!   `*.toml` of `configs/` is one of these.
//! - **No page documents a key the code does not read.** The rule: a key of a page's key
//!   tables is either a key of the shipped file(s) above, or inserting it with the value
//!   `"__probe__"` into the shipped file (the task's config; for the vehicle page
//!   `configs/vehicle.toml`) and validating that copy as `--check` does ends in success
//!   or in an error that names that key path or a table enclosing it (a table chosen by its
//!   `kind`, e.g. a `speed` profile or a `controller`, reports its errors at the table) and
//!   is not serde's "unknown field": the config type has the field and refused the value's
//!   type or variant. A misspelt key, a key of another task, or one the config type lost
//!   fails (every config type denies unknown fields).
//! - **Relative links resolve**: every Markdown link and image `[..](target)` of
//!   `README.md`, `ARCHITECTURE.md` and `docs/**/*.md` outside code that is not a URL points
//!   to an existing file, and its `#anchor`, if any, to a heading of the target Markdown
//!   file (GitHub's and mdBook's slug: lower case, punctuation dropped, spaces to `-`).
//! - **Commands in the guide are real**: in the `sh` blocks of the README and the guide,
//!   every `cargo xtask <name>` names a task, a group or a command of the runner, and every
//!   `--flag` is a flag of the runner; a command with `--check` runs here through the same
//!   library path as `cargo xtask … --check` (vehicle, task config, plan), since that is
//!   cheap; the others would need the release build, so only their names are checked.
//!   `cargo bench --bench <name>` names a bench of `crates/benches`, `--example <name>` an
//!   example file of the crate `-p` names.
//! - **Python in the guide is real**: every `ts.<name>` of a `python` block is exported by
//!   `trailer_sway` (`__all__`), every `ts.Vehicle.<method>` is a method of the stub. The
//!   blocks themselves run in the Python tests (`python/tests/test_docs.py`), which build
//!   the package.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use sway::progress::NoProgress;
use sway_tasks::tasks::{self, Task, TaskContext};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every file under `dir` (recursively) whose name ends with `ext`, sorted.
fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = entry.expect("a directory entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.to_string_lossy().ends_with(ext) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

fn guide_pages() -> Vec<PathBuf> {
    files(&root().join("docs/src"), ".md")
}

/// The user documentation whose links are checked.
fn documents() -> Vec<PathBuf> {
    let mut d = vec![root().join("README.md"), root().join("ARCHITECTURE.md")];
    d.extend(guide_pages());
    d
}

fn task_page(task: &Task) -> PathBuf {
    root()
        .join("docs/src/tasks")
        .join(format!("{}.md", task.name))
}

/// The lines of `text` outside fenced code blocks.
fn prose_lines(text: &str) -> Vec<&str> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push(line);
        }
    }
    out
}

/// The fenced code blocks of `text` as (info string, body).
fn code_blocks(text: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut current: Option<(String, String)> = None;
    for line in text.lines() {
        let t = line.trim_start();
        if let Some(info) = t.strip_prefix("```") {
            match current.take() {
                Some(block) => out.push(block),
                None => current = Some((info.trim().to_string(), String::new())),
            }
            continue;
        }
        if let Some((_, body)) = current.as_mut() {
            body.push_str(line);
            body.push('\n');
        }
    }
    out
}

/// The backticked spans of `s`.
fn code_spans(s: &str) -> Vec<&str> {
    s.split('`').skip(1).step_by(2).collect()
}

/// The keys of a page's key tables (see the module docs).
fn documented_keys(page: &Path) -> BTreeSet<String> {
    let text = read(page);
    let mut keys = BTreeSet::new();
    let mut in_table = false;
    for line in prose_lines(&text) {
        let t = line.trim();
        if !t.starts_with('|') {
            in_table = false;
            continue;
        }
        let first = t[1..].split('|').next().unwrap_or("").trim();
        if first.eq_ignore_ascii_case("key") {
            in_table = true;
            continue;
        }
        if in_table && !first.starts_with("---") {
            for k in code_spans(first) {
                keys.insert(k.to_string());
            }
        }
    }
    keys
}

/// A relative speed (`{ of_v_crit = f }`, `{ in_bistable = f }`) is a value, not a table.
fn is_speed_value(v: &toml::Value) -> bool {
    v.as_table()
        .is_some_and(|t| !t.is_empty() && t.keys().all(|k| k == "of_v_crit" || k == "in_bistable"))
}

/// Every key path of a TOML document (see the module docs).
fn key_paths(value: &toml::Value, path: &str, out: &mut BTreeSet<String>) {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match value {
        toml::Value::Table(t) if !is_speed_value(value) => {
            for (k, v) in t {
                key_paths(v, &join(k), out);
            }
        }
        toml::Value::Array(a)
            if !a.is_empty() && a.iter().all(|e| e.is_table() && !is_speed_value(e)) =>
        {
            for e in a {
                key_paths(e, &format!("{path}[]"), out);
            }
        }
        _ => {
            out.insert(path.to_string());
        }
    }
}

fn config_keys(file: &Path) -> BTreeSet<String> {
    let value: toml::Value =
        toml::from_str(&read(file)).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let mut out = BTreeSet::new();
    key_paths(&value, "", &mut out);
    out
}

fn is_vehicle_file(relative: &str) -> bool {
    relative == "vehicle.toml"
        || relative.starts_with("vehicles/")
        || relative.starts_with("fleet/")
        || relative.starts_with("combinations/")
}

fn relative_config(file: &Path) -> String {
    file.strip_prefix(root().join("configs"))
        .expect("under configs/")
        .to_string_lossy()
        .replace('\\', "/")
}

#[test]
fn every_task_has_its_guide_page() {
    let summary = read(&root().join("docs/src/SUMMARY.md"));
    for task in tasks::registry() {
        let page = task_page(&task);
        assert!(
            page.exists(),
            "task `{}` has no page {}",
            task.name,
            page.display()
        );
        assert!(
            summary.contains(&format!("(tasks/{}.md)", task.name)),
            "docs/src/SUMMARY.md does not list tasks/{}.md",
            task.name
        );
        let title = read(&page).lines().next().unwrap_or("").to_string();
        assert!(
            title.starts_with("# ") && title.contains(&format!("`{}`", task.name)),
            "{}: the title `{title}` does not name the task",
            page.display()
        );
    }
    let src = root().join("docs/src");
    for page in guide_pages() {
        let rel = page
            .strip_prefix(&src)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if rel != "SUMMARY.md" {
            assert!(
                summary.contains(&format!("]({rel})")),
                "docs/src/SUMMARY.md does not list {rel}: mdBook would not render it"
            );
        }
    }
    assert!(root().join("docs/book.toml").exists(), "docs/book.toml");
}

#[test]
fn every_shipped_config_key_is_on_its_page() {
    let registry = tasks::registry();
    let vehicle_page = root().join("docs/src/vehicle-files.md");
    let mut missing = Vec::new();
    for file in files(&root().join("configs"), ".toml") {
        let rel = relative_config(&file);
        let page = if is_vehicle_file(&rel) {
            vehicle_page.clone()
        } else {
            let task = registry
                .iter()
                .find(|t| t.config == rel)
                .unwrap_or_else(|| {
                    panic!("configs/{rel} is neither a task's config nor a vehicle file")
                });
            task_page(task)
        };
        let documented = documented_keys(&page);
        for key in config_keys(&file) {
            if !documented.contains(&key) {
                missing.push(format!(
                    "configs/{rel}: `{key}` is not in a key table of {}",
                    page.display()
                ));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "undocumented keys:\n{}",
        missing.join("\n")
    );
}

/// Inserts `key` (a path as in the key tables) with the value `"__probe__"` into `doc`;
/// None when a `[]` segment has no table to insert into.
fn insert_probe(doc: &mut toml::Table, key: &str) -> Option<()> {
    let segments: Vec<&str> = key.split('.').collect();
    let mut table = doc;
    for (i, seg) in segments.iter().enumerate() {
        let last = i + 1 == segments.len();
        let (name, array) = match seg.strip_suffix("[]") {
            Some(n) => (n, true),
            None => (*seg, false),
        };
        if last && !array {
            table.insert(name.to_string(), toml::Value::String("__probe__".into()));
            return Some(());
        }
        let entry = if array {
            table.get_mut(name)?.as_array_mut()?.first_mut()?
        } else {
            table
                .entry(name.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
        };
        table = entry.as_table_mut()?;
    }
    None
}

/// Copies `configs/` (files a config names are relative to it) into `dir`.
fn copy_configs(dir: &Path) {
    let src = root().join("configs");
    for file in files(&src, ".toml") {
        let to = dir.join(file.strip_prefix(&src).unwrap());
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(&file, &to).unwrap();
    }
}

/// The probe of the module docs: does the code read `key` of `base` (a path relative to
/// `configs/`)? `validate` validates a file as `--check` does.
fn probe_reads(
    dir: &Path,
    base: &str,
    key: &str,
    validate: &dyn Fn(&Path) -> Result<(), String>,
) -> Result<(), String> {
    let mut doc: toml::Table = toml::from_str(&read(&root().join("configs").join(base))).unwrap();
    insert_probe(&mut doc, key)
        .ok_or_else(|| format!("cannot insert `{key}` into configs/{base}"))?;
    let file = dir
        .join(base)
        .with_file_name(format!("probe_{}", base.replace('/', "_")));
    std::fs::write(&file, toml::to_string(&doc).unwrap()).unwrap();
    let outcome = validate(&file);
    std::fs::remove_file(&file).unwrap();
    match outcome {
        Ok(()) => Ok(()),
        Err(e) => {
            // the key path or an enclosing table (an internally tagged table, e.g. a
            // `speed` profile or a `controller`, reports its errors at the table)
            let path = key.replace("[]", "[0]");
            let named = path
                .match_indices('.')
                .map(|(i, _)| &path[..i])
                .chain([path.as_str()])
                .any(|p| e.contains(&format!("`{p}`: ")));
            if named && !e.contains("unknown field") {
                Ok(())
            } else {
                Err(format!("`{key}` inserted into configs/{base}: {e}"))
            }
        }
    }
}

#[test]
fn no_page_documents_a_key_the_code_does_not_read() {
    let dir = tempfile::tempdir().unwrap();
    copy_configs(dir.path());
    let configs = dir.path();
    let results = dir.path().join("results");
    let vehicle = configs.join("vehicle.toml");
    let mut unread = Vec::new();
    for task in tasks::registry() {
        let page = task_page(&task);
        let shipped = config_keys(&root().join("configs").join(task.config));
        for key in documented_keys(&page).difference(&shipped) {
            let validate = |file: &Path| -> Result<(), String> {
                let ctx = TaskContext::new(&vehicle, configs, &results, &NoProgress)
                    .map_err(|e| e.to_string())?;
                tasks::prepare_checked(&task, &ctx, file)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            };
            if let Err(e) = probe_reads(configs, task.config, key, &validate) {
                unread.push(format!("{}: {e}", page.display()));
            }
        }
    }
    let mut vehicle_keys = BTreeSet::new();
    for file in files(&root().join("configs"), ".toml") {
        if is_vehicle_file(&relative_config(&file)) {
            vehicle_keys.extend(config_keys(&file));
        }
    }
    let page = root().join("docs/src/vehicle-files.md");
    for key in documented_keys(&page).difference(&vehicle_keys) {
        let validate = |file: &Path| -> Result<(), String> {
            TaskContext::new(file, configs, &results, &NoProgress)
                .map(|_| ())
                .map_err(|e| e.to_string())
        };
        if let Err(e) = probe_reads(configs, "vehicle.toml", key, &validate) {
            unread.push(format!("{}: {e}", page.display()));
        }
    }
    assert!(
        unread.is_empty(),
        "documented keys the code does not read:\n{}",
        unread.join("\n")
    );
}

/// The `#anchor`s of a Markdown file's headings.
fn anchors(file: &Path) -> BTreeSet<String> {
    prose_lines(&read(file))
        .into_iter()
        .filter_map(|l| l.trim_start().strip_prefix('#'))
        .map(|h| slug(h.trim_start_matches('#')))
        .collect()
}

/// GitHub's (and mdBook's) heading id: lower case, alphanumerics, `-` and `_` kept, spaces
/// to `-`, everything else dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The link targets `[..](target)` of a line, outside inline code.
fn link_targets(line: &str) -> Vec<String> {
    let prose: String = line.split('`').step_by(2).collect::<Vec<_>>().join(" ");
    let mut out = Vec::new();
    let mut rest = prose.as_str();
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        if let Some(end) = rest.find(')') {
            let target = rest[..end].split_whitespace().next().unwrap_or("");
            out.push(target.to_string());
            rest = &rest[end..];
        }
    }
    out
}

#[test]
fn relative_links_resolve() {
    let mut broken = Vec::new();
    for doc in documents() {
        let text = read(&doc);
        for line in prose_lines(&text) {
            for target in link_targets(line) {
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let (path, anchor) = match target.split_once('#') {
                    Some((p, a)) => (p, Some(a)),
                    None => (target.as_str(), None),
                };
                let file = if path.is_empty() {
                    doc.clone()
                } else {
                    doc.parent().unwrap().join(path)
                };
                if !file.exists() {
                    broken.push(format!("{}: `{target}`: no such file", doc.display()));
                    continue;
                }
                if let Some(anchor) = anchor
                    && file.extension().is_some_and(|e| e == "md")
                    && !anchors(&file).contains(anchor)
                {
                    broken.push(format!(
                        "{}: `{target}`: no heading `#{anchor}`",
                        doc.display()
                    ));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// The runner's flags: the `#[arg(long…)]` fields of `xtask/src/*.rs` as `--kebab-case`.
fn runner_flags() -> BTreeSet<String> {
    let mut flags = BTreeSet::new();
    for file in files(&root().join("xtask/src"), ".rs") {
        let text = read(&file);
        let mut lines = text.lines();
        while let Some(line) = lines.next() {
            if !line.trim_start().starts_with("#[arg(long") {
                continue;
            }
            for next in lines.by_ref() {
                let t = next.trim_start().trim_start_matches("pub ");
                if t.starts_with("///") || t.starts_with("#[") {
                    continue;
                }
                if let Some((name, _)) = t.split_once(':') {
                    flags.insert(format!("--{}", name.trim().replace('_', "-")));
                }
                break;
            }
        }
    }
    flags
}

/// The `sh` command lines of the README and the guide: (file, line without comment).
fn command_lines() -> Vec<(PathBuf, String)> {
    let mut out = Vec::new();
    for doc in documents() {
        for (info, body) in code_blocks(&read(&doc)) {
            if !matches!(info.as_str(), "sh" | "bash" | "shell" | "console") {
                continue;
            }
            for line in body.lines() {
                let line = line.trim().trim_start_matches("$ ");
                let line = line.split(" #").next().unwrap_or("").trim();
                if !line.is_empty() {
                    out.push((doc.clone(), line.to_string()));
                }
            }
        }
    }
    out
}

/// Runs `cargo xtask <name> … --check` through the library: the vehicle and each task's
/// config validated and planned (`tasks::prepare_checked`), as the runner does.
fn run_check(args: &[&str]) -> Result<(), String> {
    let mut vehicle = root().join("configs/vehicle.toml");
    let mut config = None;
    let mut i = 1;
    while i < args.len() {
        match args[i] {
            "--vehicle" => {
                vehicle = root().join(args[i + 1]);
                i += 1;
            }
            "--config" => {
                config = Some(root().join(args[i + 1]));
                i += 1;
            }
            "--results" | "--max-speed" | "--shard" | "--shard-dir" | "--count" => i += 1,
            a if a.starts_with("--") => {}
            a => config = Some(root().join(a)),
        }
        i += 1;
    }
    let results = tempfile::tempdir().map_err(|e| e.to_string())?;
    let configs = root().join("configs");
    let list = tasks::resolve(args[0]).map_err(|e| e.to_string())?;
    for task in &list {
        let ctx = TaskContext::new(&vehicle, &configs, results.path(), &NoProgress)
            .map_err(|e| e.to_string())?;
        let file = config.clone().unwrap_or_else(|| configs.join(task.config));
        tasks::prepare_checked(task, &ctx, &file).map_err(|e| e.to_string())?;
    }
    Ok(())
}

#[test]
fn commands_in_the_guide_name_real_tasks_and_flags_and_checks_pass() {
    let flags = runner_flags();
    for f in [
        "--vehicle",
        "--config",
        "--results",
        "--check",
        "--shard",
        "--speed",
    ] {
        assert!(flags.contains(f), "the flag parser lost {f}: {flags:?}");
    }
    let mut names: BTreeSet<String> = tasks::registry()
        .iter()
        .map(|t| t.name.to_string())
        .collect();
    names.extend(tasks::groups().into_iter().map(|(g, _)| g.to_string()));
    names.extend(["list", "roots", "merge", "slurm"].map(String::from));
    let benches = read(&root().join("crates/benches/Cargo.toml"));
    let mut problems = Vec::new();
    let mut checked = 0;
    for (doc, line) in command_lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let at = |msg: String| format!("{}: `{line}`: {msg}", doc.display());
        match words.as_slice() {
            ["cargo", "xtask", name, rest @ ..] => {
                if !names.contains(*name) {
                    problems.push(at(format!("`{name}` is not a task, group or command")));
                    continue;
                }
                for w in rest.iter().filter(|w| w.starts_with("--")) {
                    if !flags.contains(*w) {
                        problems.push(at(format!("`{w}` is not a flag of the runner")));
                    }
                }
                let is_task = tasks::resolve(name).is_ok();
                if rest.contains(&"--check") && is_task {
                    checked += 1;
                    if let Err(e) = run_check(&words[2..]) {
                        problems.push(at(e));
                    }
                }
            }
            ["cargo", "bench", "--bench", name, ..]
                if !benches.contains(&format!("name = \"{name}\"")) =>
            {
                problems.push(at(format!("no bench `{name}` in crates/benches")));
            }
            ["cargo", "run", ..] => {
                let after =
                    |flag: &str| words.iter().position(|w| *w == flag).map(|i| words[i + 1]);
                if let (Some(package), Some(example)) = (after("-p"), after("--example")) {
                    let file = root()
                        .join("crates")
                        .join(package)
                        .join("examples")
                        .join(format!("{example}.rs"));
                    if !file.exists() {
                        problems.push(at(format!("no example {}", file.display())));
                    }
                }
            }
            _ => {}
        }
    }
    assert!(
        problems.is_empty(),
        "commands in the documentation:\n{}",
        problems.join("\n")
    );
    assert!(
        checked >= 19,
        "only {checked} `--check` commands ran: one per task page at least"
    );
}

#[test]
fn python_in_the_guide_uses_the_packages_names() {
    let init = read(&root().join("python/trailer_sway/__init__.py"));
    let all = init
        .split_once("__all__ = [")
        .and_then(|(_, r)| r.split_once(']'))
        .map(|(list, _)| list)
        .expect("__all__ in python/trailer_sway/__init__.py");
    let exported: BTreeSet<&str> = all
        .split(',')
        .map(|s| s.trim().trim_matches('"'))
        .filter(|s| !s.is_empty())
        .collect();
    let stub = read(&root().join("python/trailer_sway/_native.pyi"));
    let mut problems = Vec::new();
    let mut blocks = 0;
    for doc in documents() {
        for (info, body) in code_blocks(&read(&doc)) {
            if info != "python" {
                continue;
            }
            blocks += 1;
            let mut rest = body.as_str();
            while let Some(i) = rest.find("ts.") {
                let preceded =
                    i > 0 && rest[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_');
                rest = &rest[i + 3..];
                if preceded {
                    continue;
                }
                let path: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == '.')
                    .collect();
                let mut parts = path.split('.');
                let name = parts.next().unwrap_or("");
                if !exported.contains(name) {
                    problems.push(format!("{}: `ts.{name}` is not exported", doc.display()));
                } else if name == "Vehicle"
                    && let Some(method) = parts.next().filter(|m| !m.is_empty())
                    && !stub.contains(&format!("def {method}("))
                {
                    problems.push(format!(
                        "{}: `ts.Vehicle.{method}` is not a method",
                        doc.display()
                    ));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(blocks >= 2, "the README and the Python page show Python");
}

#[test]
fn no_issue_numbers_in_user_documentation() {
    // Reference: the rule that user documentation speaks of features, not of the tracker.
    let mut found = BTreeMap::new();
    for doc in documents()
        .into_iter()
        .filter(|d| !d.ends_with("ARCHITECTURE.md"))
    {
        for (n, line) in read(&doc).lines().enumerate() {
            let lower = line.to_lowercase();
            if let Some(i) = lower.find("issue ")
                && lower[i + 6..].starts_with(|c: char| c.is_ascii_digit())
            {
                found.insert(format!("{}:{}", doc.display(), n + 1), line.to_string());
            }
        }
    }
    assert!(found.is_empty(), "issue numbers: {found:#?}");
}

#[test]
fn the_fmu_page_names_every_input_output_and_setting_of_the_fmu() {
    // Reference: the FMU's own variable list (sway_fmu::variables), which its model
    // descriptions are written from; the vehicle's keys are on the vehicle-file page and the
    // initial states follow the outputs' names (`initial_<output>`).
    use sway_fmu::variables::{Causality, Slot, variables};
    let page = read(&root().join("docs/src/tasks/fmu.md"));
    let vars = variables(&sway_fmu::config::Defaults::default()).expect("variables");
    let missing: Vec<&str> = vars
        .iter()
        .filter(|v| !matches!(v.slot, Slot::Vehicle(_) | Slot::Initial(_) | Slot::Time))
        .filter(|v| v.causality != Causality::Independent)
        .map(|v| v.name.as_str())
        .filter(|name| !page.contains(&format!("`{name}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/src/tasks/fmu.md does not name: {missing:?}"
    );
}
