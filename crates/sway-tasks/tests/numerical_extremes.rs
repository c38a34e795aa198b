//! Numerical extremes that pass validation: seeded samples over the
//! allowed ranges of `linear`, `roots`, `simulate` and a continuation run (`fig3a`: the
//! bifurcation diagram and its time panels), bounds included (speeds from 0.1 to 10⁴ m/s,
//! gains and delays up to 10³, tolerances at their limits, |θ(0)| just below 90°, mesh
//! sizes at their minimum).
//!
//! Every sample must end in a result or a typed error: no panic (`catch_unwind`), no hang
//! (a per-case time bound), and no non-finite number written: every CSV cell of the
//! results is a finite number or text (no empty "missing" cells, no `NaN`/`inf`), and
//! `summary.json` has `null` only for the optional metrics. Small resolutions keep it fast
//! in a debug build; the sample counts are printed with `--nocapture`.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sway::progress::NoProgress;
use sway_tasks::tasks::{self, TaskContext};

/// Generous bound on one case (debug build, loaded machine); a hang fails the test.
const CASE_TIMEOUT: Duration = Duration::from_secs(120);

/// `summary.json` keys that may be `null` (optional metrics and settings, not NaN).
const NULLABLE: &[&str] = &[
    "peak_theta_deg_after_action",
    "final_amplitude_deg",
    "settle_time_s",
    "loss_of_control_time_s",
    "loss_of_control_condition",
    // a run that does not oscillate has no decay rate
    "decay_rate_per_s",
    "action_s",
    "max_steps",
    "initial_step",
    // fig3a: quantities that need not exist (no fold, no cycle at a speed)
    "fold_v_mps",
    "fold_amplitude_deg",
    "fold_period_s",
    "stable_amplitude_deg",
    "unstable_amplitude_deg",
    "stable_period_s",
    "unstable_period_s",
    "bistable_range_mps",
    // linear and fig3a: straight running stable up to the maximum speed is an
    // outcome, the quantities at V_crit are null (with `stable_up_to_mps` and a reason)
    "v_crit_mps",
    "hopf_frequency_hz",
    "hopf_omega_rad_s",
    "spectral_abscissa_slope_per_m",
    "dv_crit_dh_mps_per_m",
    "dv_crit_dl_mps_per_m",
    "v_crit_rounding_band_mps",
    // linear's sway modes: a mode that stays damped has no crossing (with its reason), one
    // not oscillatory at the reference speed no frequency or damping there
    "crossing_speed_mps",
    "crossing_frequency_hz",
    "frequency_hz",
    "damping_ratio",
    "hopf_v_mps",
    "hopf_period_s",
    "criticality",
    // a scenario with nothing to show (no sway cycle to start from): the fold of cycles
    // is computed only for an `in_bistable` speed
    "v_fold_mps",
];

fn configs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}

/// A value of `[lo, hi]`: either bound (one time in four each) or log-uniform inside
/// (`lo > 0`), else uniform.
fn sample(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    match rng.random_range(0..4) {
        0 => lo,
        1 => hi,
        _ if lo > 0.0 => (lo.ln() + rng.random::<f64>() * (hi.ln() - lo.ln())).exp(),
        _ => lo + rng.random::<f64>() * (hi - lo),
    }
}

/// A signed value with |x| in `[lo, hi]`.
fn signed(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    let x = sample(rng, lo, hi);
    if rng.random_bool(0.5) { -x } else { x }
}

/// The outcome of one case.
#[derive(Debug)]
enum Outcome {
    /// results written (and checked)
    Ok,
    /// a typed error (its message)
    Error(String),
}

/// Runs `f` on its own thread under `catch_unwind` and [`CASE_TIMEOUT`]; a panic or a
/// hang fails the test naming the case.
fn guarded(case: &str, f: impl FnOnce() -> Result<(), String> + Send + 'static) -> Outcome {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let r = catch_unwind(AssertUnwindSafe(f));
        let _ = tx.send(r);
    });
    match rx.recv_timeout(CASE_TIMEOUT) {
        Ok(Ok(Ok(()))) => Outcome::Ok,
        Ok(Ok(Err(e))) => Outcome::Error(e),
        Ok(Err(p)) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!("panic ({msg}) for\n{case}")
        }
        Err(_) => panic!("no result within {CASE_TIMEOUT:?} for\n{case}"),
    }
}

/// Every written number is finite: CSV cells are numbers that parse as finite or text,
/// never empty or `NaN`/`inf`; JSON `null` only under [`NULLABLE`] keys.
fn check_written(dir: &Path) -> Result<(), String> {
    for entry in std::fs::read_dir(dir).map_err(|e| e.to_string())? {
        let path = entry.map_err(|e| e.to_string())?.path();
        let name = path.display().to_string();
        match path.extension().and_then(|e| e.to_str()) {
            Some("csv") => {
                let mut r = csv::Reader::from_path(&path).map_err(|e| format!("{name}: {e}"))?;
                let header = r.headers().map_err(|e| e.to_string())?.clone();
                for (i, rec) in r.records().enumerate() {
                    let rec = rec.map_err(|e| format!("{name}: {e}"))?;
                    for (col, cell) in header.iter().zip(rec.iter()) {
                        let bad = cell.is_empty()
                            || cell.parse::<f64>().is_ok_and(|x| !x.is_finite())
                            || ["nan", "inf", "+inf", "-inf", "infinity"]
                                .contains(&cell.to_ascii_lowercase().as_str());
                        if bad {
                            return Err(format!("{name}: row {} column {col} is {cell:?}", i + 1));
                        }
                    }
                }
            }
            Some("json") => {
                let text = std::fs::read_to_string(&path).map_err(|e| e.to_string())?;
                let v: serde_json::Value =
                    serde_json::from_str(&text).map_err(|e| format!("{name}: {e}"))?;
                check_json(&v, false, &name)?;
            }
            _ => {}
        }
    }
    Ok(())
}

/// `null` only under a [`NULLABLE`] key (or inside one: keyed speeds, arrays).
fn check_json(v: &serde_json::Value, nullable: bool, file: &str) -> Result<(), String> {
    use serde_json::Value;
    match v {
        Value::Null if !nullable => Err(format!("{file}: a null (NaN?) in {v}")),
        Value::Object(m) => m.iter().try_for_each(|(k, x)| {
            check_json(x, nullable || NULLABLE.contains(&k.as_str()), file)
                .map_err(|e| format!("{e} under `{k}`"))
        }),
        Value::Array(a) => a.iter().try_for_each(|x| check_json(x, nullable, file)),
        _ => Ok(()),
    }
}

/// Runs task `task` on the config text `toml` into a fresh results directory; checks what
/// it wrote.
fn run_task(task: &'static str, toml: String) -> Result<(), String> {
    let tmp = tempfile::tempdir().map_err(|e| e.to_string())?;
    let file = tmp.path().join("config.toml");
    std::fs::write(&file, &toml).map_err(|e| e.to_string())?;
    let results = tmp.path().join("results");
    let progress = NoProgress;
    let configs = configs_dir();
    let ctx = TaskContext::new(&configs.join("vehicle.toml"), &configs, &results, &progress)
        .map_err(|e| e.to_string())?;
    let t = tasks::registry()
        .into_iter()
        .find(|t| t.name == task)
        .expect("task in the registry");
    // the samples are inside the allowed ranges: validation must accept them
    let (prepared, _plan) = match tasks::prepare_checked(&t, &ctx, &file) {
        Ok(p) => p,
        Err(e) => panic!("valid config refused: {e}"),
    };
    let report = prepared.run(&ctx).map_err(|e| e.to_string())?;
    if let Err(e) = check_written(&report.output_dir) {
        panic!("non-finite output: {e}");
    }
    Ok(())
}

/// Runs `n` cases of `make`, printing the tally; returns the typed errors seen.
fn property(
    what: &str,
    n: usize,
    seed: u64,
    mut make: impl FnMut(&mut ChaCha8Rng) -> (String, Box<dyn FnOnce() -> Result<(), String> + Send>),
) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut ok, mut errors) = (0, Vec::new());
    let t0 = Instant::now();
    for _ in 0..n {
        let (case, f) = make(&mut rng);
        match guarded(&case, f) {
            Outcome::Ok => ok += 1,
            Outcome::Error(e) => errors.push(e),
        }
    }
    println!(
        "{what}: {n} samples in {:.1} s: {ok} results, {} typed errors",
        t0.elapsed().as_secs_f64(),
        errors.len()
    );
    for e in errors.iter().take(5) {
        println!("  e.g. {e}");
    }
}

#[test]
fn linear_at_the_extremes_of_its_ranges() {
    property("linear", 24, 0x11ea, |rng| {
        let v_min = sample(rng, 0.1, 1e4);
        let v_max = v_min * (1.0 + sample(rng, 1e-6, 1e3));
        let points = rng.random_range(2..=12);
        // mostly a range around V_crit ≈ 34.7 m/s (the bisection runs), else anywhere
        let (c_min, c_max) = if rng.random_bool(0.7) {
            (sample(rng, 0.1, 34.0), sample(rng, 35.0, 1e4))
        } else {
            let lo = sample(rng, 0.1, 40.0);
            (lo, lo + sample(rng, 1e-3, 1e4))
        };
        // the scan step at its limit: at most MAX_GRID_POINTS scan points
        let step = (c_max - c_min) / sample(rng, 1.0, 1e5);
        let tol = sample(rng, 1e-300, 0.99e-3);
        let rel = sample(rng, 1.0001e-9, 0.9999e-2);
        let toml = format!(
            "speed_grid = {{ min = {v_min:e}, max = {v_max:e}, points = {points} }}\n\
             [critical_speed]\nv_min_mps = {c_min:e}\nv_max_mps = {c_max:e}\n\
             scan_step_mps = {step:e}\ntolerance_mps = {tol:e}\n\
             [sensitivity]\nrelative_step = {rel:e}\n"
        );
        (toml.clone(), Box::new(move || run_task("linear", toml)))
    });
}

#[test]
fn roots_at_the_extremes_of_their_ranges() {
    property("roots", 60, 0x2005, |rng| {
        let speed = sample(rng, 0.1, 1e4);
        let gain = signed(rng, 1e-9, 1e3);
        let delay = if rng.random_bool(0.2) {
            0.0
        } else {
            sample(rng, 1e-9, 1e3)
        };
        let count = if rng.random_bool(0.2) {
            sway_tasks::tasks::roots::MAX_COUNT
        } else {
            rng.random_range(1..=12)
        };
        let case =
            format!("roots --speed {speed:e} --gain {gain:e} --delay {delay:e} --count {count}");
        (
            case,
            Box::new(move || {
                let (_, model) =
                    sway_tasks::config_file::load_vehicle(&configs_dir().join("vehicle.toml"))
                        .map_err(|e| e.to_string())?;
                let r = sway_tasks::tasks::roots::roots(&model, speed, gain, delay, count)
                    .map_err(|e| e.to_string())?;
                if r.is_empty() || r.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
                    panic!("non-finite or no roots: {r:?}");
                }
                Ok(())
            }),
        )
    });
}

/// `[solver]` at the limits: rtol from its round-off floor (with atol = 0) to 1, atol
/// from 0 to 1.
fn solver(rng: &mut ChaCha8Rng) -> String {
    let (rtol, atol) = match rng.random_range(0..4) {
        0 => (2.3e-13, 0.0),
        1 => (0.0, sample(rng, 1e-14, 1.0)),
        2 => (1.0, 1.0),
        _ => (sample(rng, 1e-12, 1.0), sample(rng, 1e-14, 1.0)),
    };
    format!("rtol = {rtol:e}\natol = {atol:e}\n")
}

#[test]
fn simulate_at_the_extremes_of_its_ranges() {
    property("simulate", 40, 0x5113, |rng| {
        let horizon = sample(rng, 1e-3, 3.0);
        let step = horizon / sample(rng, 1.0, 500.0);
        let v0 = sample(rng, 0.1, 1e4);
        let speed = if rng.random_bool(0.5) {
            format!("{{ kind = \"constant\", speed_mps = {v0:e} }}")
        } else {
            // the final speed just above 0 or far above the start
            let change = if rng.random_bool(0.5) {
                -v0 * (1.0 - 1e-9)
            } else {
                sample(rng, 1e-9, 1e4)
            };
            let start = sample(rng, 0.0, horizon);
            let dur = sample(rng, 1e-9, 1e3);
            format!(
                "{{ kind = \"ramp\", initial_mps = {v0:e}, change_mps = {change:e}, start_s = {start:e}, duration_s = {dur:e} }}"
            )
        };
        let controller = if rng.random_bool(0.3) {
            "{ kind = \"none\" }".to_string()
        } else {
            format!(
                "{{ kind = \"yaw_rate_feedback\", gain_s = {:e}, delay_s = {:e}, on_s = {:e}, off_s = {:e} }}",
                signed(rng, 1e-9, 1e3),
                if rng.random_bool(0.2) {
                    0.0
                } else {
                    sample(rng, 1e-9, 1e3)
                },
                sample(rng, 0.0, horizon),
                sample(rng, horizon, 1e3),
            )
        };
        let initial = if rng.random_bool(0.8) {
            format!(
                "{{ kind = \"state\", theta0_deg = {:e}, sigma1_mps = {:e}, sigma2_per_s = {:e}, sigma3_per_s = {:e}, psi0_deg = {:e} }}",
                signed(rng, 1e-9, 89.999),
                signed(rng, 1e-9, 1e2),
                signed(rng, 1e-9, 1e2),
                signed(rng, 1e-9, 1e2),
                signed(rng, 1e-9, 1e4),
            )
        } else {
            format!(
                "{{ kind = \"sway_cycle\", speed_mps = {:e}, settle_s = {:e}, theta0_rad = {:e} }}",
                sample(rng, 0.1, 1e4),
                sample(rng, 0.0, 5.0),
                signed(rng, 1e-9, 1.499),
            )
        };
        let guard = if rng.random_bool(0.5) { "stop" } else { "off" };
        let toml = format!(
            "name = \"extreme\"\nhorizon_s = {horizon:e}\noutput_step_s = {step:e}\nguard = \"{guard}\"\n\
             speed = {speed}\ncontroller = {controller}\ninitial = {initial}\n\
             [solver]\n{}\
             [metrics]\nfinal_window_s = {:e}\nsettle_threshold_deg = {:e}\n",
            solver(rng),
            sample(rng, 1e-9, 1e3),
            sample(rng, 1e-9, 89.0),
        );
        (toml.clone(), Box::new(move || run_task("simulate", toml)))
    });
}

#[test]
fn a_continuation_run_at_the_extremes_of_its_ranges() {
    property("fig3a (continuation)", 10, 0xf13a, |rng| {
        let v_min = sample(rng, 0.1, 34.0);
        let v_max = if rng.random_bool(0.5) {
            sample(rng, 35.0, 1e4)
        } else {
            v_min * (1.0 + sample(rng, 1e-6, 1.0))
        };
        let initial_step = sample(rng, 1e-9, 1.0);
        let max_step = initial_step * sample(rng, 1.0, 1e3);
        let mid = 0.5 * (v_min + v_max);
        let toml = format!(
            "[panels]\nspeed_mps = {:e}\ntheta0_deg = [{:e}, {:e}]\nhorizon_s = {:e}\noutput_step_s = 0.05\n\
             [panels.solver]\n{}\
             [diagram]\nstable_speeds_mps = [{mid:e}]\nunstable_speeds_mps = [{mid:e}]\n\
             [diagram.continuation]\nv_min_mps = {v_min:e}\nv_max_mps = {v_max:e}\n\
             intervals = {}\ndegree = {}\nhopf_amplitude = {:e}\ninitial_step = {initial_step:e}\n\
             max_step = {max_step:e}\nmax_cycle_points = {}\n",
            sample(rng, 0.1, 1e4),
            signed(rng, 1e-9, 89.999),
            signed(rng, 1e-9, 89.999),
            sample(rng, 0.05, 2.0),
            solver(rng),
            rng.random_range(4..=8),
            rng.random_range(1..=4),
            sample(rng, 1e-12, 0.0999),
            rng.random_range(2..=25),
        );
        (toml.clone(), Box::new(move || run_task("fig3a", toml)))
    });
}
