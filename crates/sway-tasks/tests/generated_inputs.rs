//! Generated inputs: seeded mutations of every file in `configs/` and of the
//! vehicle file, each run through the validation `cargo xtask <task> --check` uses
//! (`TaskContext::new` for the vehicle, `tasks::prepare_checked` for a task config).
//!
//! Mutations: remove a key, add an unknown one, change a value's type, NaN, ±inf, 0,
//! negative, 1e300, 1e-300, huge integers, empty and huge arrays, long strings, a
//! truncated file, random bytes, invalid UTF-8. Asserted for every input: no panic
//! (`catch_unwind`); either valid or an error naming the file and a key path or line;
//! validation time below a generous bound (the slowest is printed with `--nocapture`).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sway::progress::NoProgress;
use sway_tasks::tasks::{self, Task, TaskContext};

/// Mutations per config file (12 files: 1440 inputs in all).
const PER_FILE: usize = 120;

/// Generous bound on one validation (debug build, loaded CI machine); measured values are
/// milliseconds.
const MAX_VALIDATION: Duration = Duration::from_secs(5);

fn configs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}

/// The task whose default config is `file_name`, or the one that reads such files.
fn task_for(file_name: &str) -> Option<Task> {
    let reg = tasks::registry();
    let by = |n: &str| reg.iter().find(|t| t.name == n).copied();
    reg.iter()
        .find(|t| t.config == file_name)
        .copied()
        .or_else(|| {
            if file_name.starts_with("sweep") {
                by("sweep")
            } else if file_name == "vehicle.toml" {
                None
            } else {
                by("simulate")
            }
        })
}

/// Every key path of the document: (path of tables/arrays, leaf or table).
fn paths(value: &toml::Value, prefix: &mut Vec<Seg>, out: &mut Vec<Vec<Seg>>) {
    match value {
        toml::Value::Table(t) => {
            for (k, v) in t {
                prefix.push(Seg::Key(k.clone()));
                out.push(prefix.clone());
                paths(v, prefix, out);
                prefix.pop();
            }
        }
        toml::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                prefix.push(Seg::Index(i));
                out.push(prefix.clone());
                paths(v, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

#[derive(Debug, Clone)]
enum Seg {
    Key(String),
    Index(usize),
}

fn get_mut<'a>(root: &'a mut toml::Value, path: &[Seg]) -> Option<&'a mut toml::Value> {
    path.iter().try_fold(root, |v, seg| match (seg, v) {
        (Seg::Key(k), toml::Value::Table(t)) => t.get_mut(k),
        (Seg::Index(i), toml::Value::Array(a)) => a.get_mut(*i),
        _ => None,
    })
}

/// A replacement value of kind `k`.
fn value(k: usize, rng: &mut ChaCha8Rng) -> toml::Value {
    use toml::Value as V;
    match k {
        0 => V::Float(f64::NAN),
        1 => V::Float(f64::INFINITY),
        2 => V::Float(f64::NEG_INFINITY),
        3 => V::Integer(0),
        4 => V::Float(0.0),
        5 => V::Float(-1.0),
        6 => V::Integer(-1),
        7 => V::Float(1e300),
        8 => V::Float(1e-300),
        9 => V::Float(-1e300),
        10 => V::Integer(i64::MAX),
        11 => V::Integer(100_000_000),
        12 => V::String("x".repeat(rng.random_range(1..20_000))),
        13 => V::String(String::new()),
        14 => V::Boolean(true),
        15 => V::Array(Vec::new()),
        16 => V::Array(vec![V::Float(1.0); rng.random_range(1000..30_000)]),
        17 => V::Table(toml::Table::new()),
        18 => V::Float(rng.random_range(-1e3..1e3)),
        19 => V::Integer(rng.random_range(-10..100_000)),
        _ => V::Float(f64::MIN_POSITIVE),
    }
}

/// One mutated file: structural edits through the parsed document, or byte-level damage.
fn mutate(text: &str, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let kind = rng.random_range(0..10);
    let Ok(mut doc) = toml::from_str::<toml::Value>(text) else {
        return text.as_bytes().to_vec();
    };
    let mut all = Vec::new();
    paths(&doc, &mut Vec::new(), &mut all);
    if all.is_empty() || kind >= 8 {
        return damage(text, rng);
    }
    let path = all[rng.random_range(0..all.len())].clone();
    let (parent, last) = path.split_at(path.len() - 1);
    match kind {
        0 | 1 => {
            // remove the key (or array entry)
            match (get_mut(&mut doc, parent), &last[0]) {
                (Some(toml::Value::Table(t)), Seg::Key(k)) => {
                    t.remove(k);
                }
                (Some(toml::Value::Array(a)), Seg::Index(i)) => {
                    a.remove(*i);
                }
                _ => {}
            }
        }
        2 => {
            // an unknown key next to it
            if let Some(toml::Value::Table(t)) = get_mut(&mut doc, parent) {
                t.insert("no_such_key".into(), toml::Value::Float(1.0));
            } else if let toml::Value::Table(t) = &mut doc {
                t.insert("no_such_key".into(), toml::Value::Integer(1));
            }
        }
        _ => {
            let k = rng.random_range(0..21);
            let v = value(k, rng);
            if let Some(slot) = get_mut(&mut doc, &path) {
                *slot = v;
            }
        }
    }
    toml::to_string(&doc).unwrap_or_default().into_bytes()
}

/// Byte-level damage: truncation, random bytes, invalid UTF-8, an empty file.
fn damage(text: &str, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut bytes = text.as_bytes().to_vec();
    match rng.random_range(0..4) {
        0 => bytes.truncate(rng.random_range(0..bytes.len().max(1))),
        1 => {
            let n = rng.random_range(1..200);
            let at = rng.random_range(0..bytes.len().max(1));
            let noise: Vec<u8> = (0..n).map(|_| rng.random()).collect();
            bytes.splice(at..at, noise);
        }
        2 => {
            let at = rng.random_range(0..bytes.len().max(1));
            bytes.splice(at..at, [0xff, 0xfe, 0xc3]);
        }
        _ => bytes.clear(),
    }
    bytes
}

/// The `--check` validation of `file` as a vehicle file or as `task`'s config.
fn validate(task: Option<Task>, file: &Path, vehicle: &Path, results: &Path) -> Result<(), String> {
    match task {
        None => TaskContext::new(file, &configs_dir(), results, &NoProgress)
            .map(|_| ())
            .map_err(|e| e.to_string()),
        Some(t) => {
            let ctx = TaskContext::new(vehicle, &configs_dir(), results, &NoProgress)
                .map_err(|e| e.to_string())?;
            tasks::prepare_checked(&t, &ctx, file)
                .map(|_| ())
                .map_err(|e| e.to_string())
        }
    }
}

#[test]
fn generated_inputs_never_panic_and_errors_name_file_and_key() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let results = tmp.path().join("results");
    let vehicle = configs_dir().join("vehicle.toml");
    let mut files: Vec<PathBuf> = std::fs::read_dir(configs_dir())
        .expect("configs/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 11, "{files:?}");
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let (mut total, mut valid, mut panics, mut bad_messages) = (0, 0, Vec::new(), Vec::new());
    let mut slowest = (Duration::ZERO, String::new());
    for original in &files {
        let name = original.file_name().and_then(|n| n.to_str()).expect("name");
        let task = task_for(name);
        let text = std::fs::read_to_string(original).expect("read");
        let dir = tmp.path().join(format!("m-{name}"));
        std::fs::create_dir_all(&dir).expect("mkdir");
        let file = dir.join(name);
        for i in 0..PER_FILE {
            let bytes = mutate(&text, &mut rng);
            std::fs::write(&file, &bytes).expect("write");
            let t0 = Instant::now();
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                validate(task, &file, &vehicle, &results)
            }));
            let dt = t0.elapsed();
            total += 1;
            if dt > slowest.0 {
                slowest = (dt, format!("{name} #{i}"));
            }
            match outcome {
                Err(_) => panics.push(format!("{name} #{i}: {}", String::from_utf8_lossy(&bytes))),
                Ok(Ok(())) => valid += 1,
                Ok(Err(msg)) => {
                    let names_file = msg.contains(name);
                    let names_place = msg.contains('`') || msg.contains("line");
                    if !(names_file && names_place) {
                        bad_messages.push(format!("{name} #{i}: {msg}"));
                    }
                }
            }
        }
    }
    println!(
        "generated inputs: {total} ({valid} valid), slowest validation {:.1} ms ({})",
        slowest.0.as_secs_f64() * 1e3,
        slowest.1
    );
    assert!(total >= 1000);
    assert!(panics.is_empty(), "{} panics: {:#?}", panics.len(), panics);
    assert!(
        bad_messages.is_empty(),
        "{} errors without file and key: {:#?}",
        bad_messages.len(),
        bad_messages
    );
    assert!(
        slowest.0 < MAX_VALIDATION,
        "slowest validation {:?} ({})",
        slowest.0,
        slowest.1
    );
    assert!(!results.exists(), "validation wrote results");
}
