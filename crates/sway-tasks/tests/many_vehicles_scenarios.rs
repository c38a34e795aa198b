//! Issue 20, items 3 and 5: the scenario tasks and the sweep kinds on many plausible
//! car–trailer combinations, not only Table I.
//!
//! The seeded generator of `common/vehicles.rs` (its module docs give the ranges: the named
//! nose-heavy, tail-heavy, heavy-trailer, very light, long and stable combinations, plus
//! random ones) gives the vehicles. Each is written as a vehicle file and run, exactly as
//! `cargo xtask <task> --vehicle FILE` runs, through `fig3b`, `fig4c`, `simulate`,
//! `mitigation`, `loading` and `sweep` with the shipped configs' relative speeds
//! (`{ of_v_crit = … }`, `{ in_bistable = … }`) at small resolutions (short settling and
//! horizons, few phases and iterations, small grids).
//!
//! Checked, per vehicle:
//! - no error, no panic: every task ends with a summary (exit status 0);
//! - a task with nothing to show (a vehicle stable up to the maximum speed: no sway to brake
//!   from; no bistable range for an `in_bistable` speed) says so with a `reason`;
//! - V_crit of the sweep kinds — the `linear_critical_speed` point (regula falsi on the
//!   spectral abscissa to 1e-8 m/s) and the `hopf_fold_speeds` point (the Hopf point of the
//!   continued equilibrium branch, corrected on its defining system) — equals `linear`'s
//!   (bisection to 1e-11 m/s) to 1e-8 relative: independent computations of one number;
//! - the resolved scenario speeds are the factors times `linear`'s V_crit (1e-12 relative).

#[path = "common/vehicles.rs"]
mod vehicles;

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde_json::Value;
use sway::progress::NoProgress;
use sway_tasks::tasks::{self, TaskContext};
use trailer_model::VehicleParams;

fn configs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}

/// The shipped factors (configs/fig3b.toml, fig4c.toml, mitigation.toml): 35 m/s, −10 m/s
/// and 25 m/s for Table I.
const V0: f64 = 1.0072544374722083;
const DV: f64 = -0.2877869821349167;

const LINEAR: &str = "";

pub(crate) fn fig3b() -> String {
    format!(
        "brake_start_s = 1.0
speed_change_mps = {{ of_v_crit = {DV} }}
brake_durations_s = [2.0]
horizon_s = 4.0
output_step_s = 0.1
[start]
speed_mps = {{ of_v_crit = {V0} }}
settle_s = 5.0
theta0_rad = 0.1
[solver]
rtol = 1e-6
atol = 1e-8
"
    )
}

pub(crate) fn fig4c() -> String {
    format!(
        "action_s = 1.0
horizon_s = 4.0
output_step_s = 0.1
[start]
speed_mps = {{ of_v_crit = {V0} }}
settle_s = 5.0
theta0_rad = 0.1
[steering]
gain_s = 0.1
delay_s = 0.2
[braking]
speed_change_mps = {{ of_v_crit = {DV} }}
duration_s = 2.0
[solver]
rtol = 1e-6
atol = 1e-8
"
    )
}

fn simulate() -> String {
    format!(
        "name = \"scenario\"
horizon_s = 4.0
output_step_s = 0.1
speed = {{ kind = \"ramp\", initial_mps = {{ of_v_crit = {V0} }}, change_mps = {{ of_v_crit = -0.23022958570793337 }}, start_s = 1.0, duration_s = 2.0 }}
controller = {{ kind = \"yaw_rate_feedback\", gain_s = 0.1, delay_s = 0.2, on_s = 1.0 }}
initial = {{ kind = \"sway_cycle\", speed_mps = {{ of_v_crit = {V0} }}, settle_s = 5.0, theta0_rad = 0.1 }}
[solver]
rtol = 1e-6
atol = 1e-8
"
    )
}

pub(crate) fn mitigation() -> String {
    format!(
        "phases = 2
refinement = 1
horizon_s = 4.0
delay_s = 0.2
peak_limit_deg = 45.0
min_final_speed_mps = {{ of_v_crit = 0.7194674553372917 }}
output_step_s = 0.1
[start]
speed_mps = {{ of_v_crit = {V0} }}
settle_s = 10.0
theta0_rad = 0.1
[bounds]
speed_change_mps = {{ lo = -100.0, hi = 0.0 }}
duration_s = {{ lo = 1.0, hi = 3.0 }}
gain_s = {{ lo = 0.0, hi = 0.5 }}
on_s = {{ lo = 0.0, hi = 1.0 }}
on_duration_s = {{ lo = 2.0, hi = 4.0 }}
[paper]
speed_change_mps = {{ of_v_crit = {DV} }}
duration_s = 2.0
gain_s = 0.1
[optimiser]
seed = 1
random_starts = 0
max_iters = 2
[search_solver]
rtol = 1e-5
atol = 1e-7
[solver]
rtol = 1e-6
atol = 1e-8
"
    )
}

pub(crate) const LOADING: &str = "\
trailer_mass_kg = { min = 500.0, max = 1800.0, points = 3 }
trailer_cog_of_axle = { min = 0.8571428571428572, max = 1.0714285714285714, points = 3 }
v_range_mps = [1.0, { of_v_crit = 3.453443785619 }]
";

/// A V_crit point: the vehicle's own trailer mass on a one-point axis.
fn sweep_linear(m2: f64) -> String {
    format!(
        "name = \"v_crit_point\"
kind = \"linear_critical_speed\"
[[axes]]
parameter = \"trailer.mass\"
min = {m2:?}
max = {m2:?}
points = 1
[base]
speed = {{ kind = \"constant\", speed_mps = 30.0 }}
controller = {{ kind = \"none\" }}
initial = {{ kind = \"state\", theta0_deg = 0.0 }}
"
    )
}

/// A Hopf/fold point, mesh L = 20, range derived from the vehicle.
fn sweep_hopf(m2: f64) -> String {
    format!(
        "name = \"hopf_point\"
kind = \"hopf_fold_speeds\"
[[axes]]
parameter = \"trailer.mass\"
min = {m2:?}
max = {m2:?}
points = 1
[base]
speed = {{ kind = \"constant\", speed_mps = 30.0 }}
controller = {{ kind = \"none\" }}
initial = {{ kind = \"state\", theta0_deg = 0.0 }}
[analysis.diagram]
intervals = 20
degree = 4
max_step = 0.5
"
    )
}

/// A 2 × 3 threshold map across the bistable range (relative speeds), short horizons.
const SWEEP_THRESHOLD: &str = "\
name = \"threshold_map\"
[[axes]]
parameter = \"speed_mps\"
min = { in_bistable = 0.3 }
max = { in_bistable = 0.7 }
points = 2
[[axes]]
parameter = \"theta0_deg\"
min = 1.0
max = 9.0
points = 3
[base]
horizon_s = 6.0
action_s = 0.0
speed = { kind = \"constant\", speed_mps = 33.0 }
controller = { kind = \"none\" }
initial = { kind = \"state\", theta0_deg = 2.0 }
[base.solver]
rtol = 1e-5
atol = 1e-7
[threshold]
horizon_s = 6.0
tolerance_deg = 1.0
max_doublings = 0
compare_cycles = false
";

/// Runs `task` with config text `toml` for the vehicle file `vehicle` into `dir`; its
/// `summary.json`.
fn run(task: &str, toml: &str, vehicle: &Path, dir: &Path) -> Result<Value, String> {
    let file = dir.join(format!("{task}-{}.toml", toml.len()));
    std::fs::write(&file, toml).map_err(|e| e.to_string())?;
    let results = dir.join("results");
    let ctx = TaskContext::new(vehicle, &configs_dir(), &results, &NoProgress)
        .map_err(|e| e.to_string())?;
    let t = tasks::registry()
        .into_iter()
        .find(|t| t.name == task)
        .expect("task in the registry");
    let (prepared, _plan) =
        tasks::prepare_checked(&t, &ctx, &file).map_err(|e| format!("{task}: {e}"))?;
    let report = prepared.run(&ctx).map_err(|e| format!("{task}: {e}"))?;
    let text = std::fs::read_to_string(report.output_dir.join("summary.json"))
        .map_err(|e| e.to_string())?;
    serde_json::from_str(&text).map_err(|e| e.to_string())
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// The first value of the first grid row of a sweep's `sweep.csv` in column `col`.
fn csv_value(dir: &Path, name: &str, col: &str) -> Result<Option<f64>, String> {
    let text = std::fs::read_to_string(dir.join("results").join(name).join("sweep.csv"))
        .map_err(|e| e.to_string())?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let row: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let i = header
        .iter()
        .position(|h| *h == col)
        .ok_or_else(|| format!("{name}: no column {col} in {header:?}"))?;
    Ok(row.get(i).and_then(|c| c.parse().ok()))
}

/// Everything checked for one vehicle; `Err` lists what failed.
fn check(name: &str, params: &VehicleParams) -> Result<bool, Vec<String>> {
    let err = |e: String| vec![format!("{name}: {e}")];
    let tmp = tempfile::tempdir().map_err(|e| err(e.to_string()))?;
    let dir = tmp.path();
    let vehicle = dir.join(format!("{name}.toml"));
    std::fs::write(
        &vehicle,
        toml::to_string(params).map_err(|e| err(e.to_string()))?,
    )
    .map_err(|e| err(e.to_string()))?;
    let mut failures = Vec::new();
    let linear = run("linear", LINEAR, &vehicle, dir).map_err(err)?;
    let v_crit = linear["v_crit_mps"].as_f64();
    let m2 = params.trailer.mass;
    let configs = [
        ("fig3b", fig3b()),
        ("fig4c", fig4c()),
        ("simulate", simulate()),
        ("mitigation", mitigation()),
        ("loading", LOADING.to_string()),
        ("sweep", sweep_linear(m2)),
        ("sweep", sweep_hopf(m2)),
        ("sweep", SWEEP_THRESHOLD.to_string()),
    ];
    for (task, toml) in &configs {
        let started = std::time::Instant::now();
        let result = run(task, toml, &vehicle, dir);
        println!("{name}: {task} {:.2} s", started.elapsed().as_secs_f64());
        let s = match result {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{name}: {e}"));
                continue;
            }
        };
        // nothing to show must come with its reason; with a V_crit the V_crit-relative
        // scenarios have something to show
        let nothing = s.get("unresolved_key").is_some()
            || (*task == "mitigation" && s.get("optimum").is_none());
        if nothing && !s["reason"].is_string() {
            failures.push(format!(
                "{name}: {task} has nothing to show without a reason"
            ));
        }
        // (mitigation settles only 10 s here: near V_crit the sway may not have grown yet)
        if nothing && v_crit.is_some() && !toml.contains("in_bistable") && *task != "mitigation" {
            // except where the start above V_crit has no stable sway cycle (a subcritical
            // Hopf point with nothing stable above it): reference, the vehicle's diagram
            let reason = s["reason"].as_str().unwrap_or("");
            match no_cycle_speed(reason) {
                Some(v) => match stable_cycle_at(params, v) {
                    Ok(false) => {}
                    other => failures.push(format!(
                        "{name}: {task} finds no sway cycle at {v} m/s, its diagram: {other:?}"
                    )),
                },
                None => failures.push(format!(
                    "{name}: {task} has nothing to show although V_crit = {v_crit:?}: {reason}"
                )),
            }
        }
        if v_crit.is_none() && !nothing && *task != "loading" && !toml.contains("kind = ") {
            failures.push(format!(
                "{name}: {task} shows something for a vehicle stable up to the maximum speed"
            ));
        }
        // the resolved speeds are the factors times linear's V_crit
        if let (Some(vc), Some(list)) = (v_crit, s["resolved_speeds"].as_array()) {
            for r in list {
                let (Some(f), Some(v)) = (r["spec"]["of_v_crit"].as_f64(), r["speed_mps"].as_f64())
                else {
                    continue;
                };
                if rel(v, f * vc) > 1e-12 {
                    failures.push(format!(
                        "{name}: {task} {} resolved to {v}, not {f}·{vc}",
                        r["key"]
                    ));
                }
            }
        }
    }
    // V_crit of the sweep kinds against linear's
    let sweep_linear = csv_value(dir, "v_crit_point", "v_crit_mps").map_err(err)?;
    let sweep_hopf = csv_value(dir, "hopf_point", "hopf_v_mps").map_err(err)?;
    match (v_crit, sweep_linear, sweep_hopf) {
        (Some(a), Some(b), Some(c)) => {
            if rel(b, a) > 1e-8 || rel(c, a) > 1e-8 {
                failures.push(format!(
                    "{name}: V_crit linear {a}, sweep linear kind {b}, sweep Hopf kind {c} (tolerance 1e-8 rel.)"
                ));
            }
        }
        (None, None, None) => {}
        other => failures.push(format!(
            "{name}: linear and the sweep kinds disagree on whether there is a V_crit: {other:?}"
        )),
    }
    if failures.is_empty() {
        Ok(v_crit.is_some())
    } else {
        Err(failures)
    }
}

/// The speed of a "no sway cycle to start from at V = … m/s" reason.
fn no_cycle_speed(reason: &str) -> Option<f64> {
    let rest = reason.split("no sway cycle to start from at V = ").nth(1)?;
    rest.split(" m/s").next()?.parse().ok()
}

/// Whether the open loop of `params` has a stable cycle at `v` \[m/s\] on its
/// bifurcation diagram (collocation with Floquet multipliers).
fn stable_cycle_at(params: &VehicleParams, v: f64) -> Result<bool, String> {
    use sway::bifurcation::{CycleExtent, DiagramOutcome, DiagramSettings, LoopLaw};
    let model = trailer_model::Model::new(*params).map_err(|e| e.to_string())?;
    let outcome = sway::bifurcation::vehicle_diagram(
        &model,
        LoopLaw::OPEN_LOOP,
        &DiagramSettings::default(),
        &sway::ranging::SpeedLimits::default(),
        CycleExtent::WholeRange,
    )
    .map_err(|e| e.to_string())?;
    let DiagramOutcome::Computed(d) = outcome else {
        return Ok(false);
    };
    let cycles = d.cycles_at(&model, v).map_err(|e| e.to_string())?;
    Ok(cycles.iter().any(|c| c.stable))
}

#[test]
fn scenario_tasks_and_sweep_kinds_run_on_every_generated_vehicle() {
    let fleet = vehicles::fleet(20_261_202, 6);
    assert!(fleet.len() >= 12);
    let results: Vec<(String, Result<bool, Vec<String>>)> = fleet
        .par_iter()
        .map(|(n, p)| (n.clone(), check(n, p)))
        .collect();
    let mut failures = Vec::new();
    let mut critical = 0;
    for (n, r) in &results {
        match r {
            Ok(true) => critical += 1,
            Ok(false) => {}
            Err(f) => failures.extend(f.iter().cloned()),
        }
        println!("{n}: {r:?}");
    }
    assert!(failures.is_empty(), "{failures:#?}");
    // both outcomes are covered: most combinations sway somewhere, one is stable
    assert!(critical >= 10, "{critical} vehicles with a V_crit");
    assert!(
        results
            .iter()
            .any(|(n, r)| n == "stable_to_max_speed" && *r == Ok(false)),
        "the named stable vehicle is stable up to the maximum speed"
    );
}

/// A small simulation sweep: θ(0) × trailer mass at an absolute speed, with `{ of_v_crit }`
/// as the base speed so that the variant's own V_crit is resolved.
const SWEEP_VARIANT: &str = "\
name = \"variant_sweep\"
[[axes]]
parameter = \"theta0_deg\"
min = 2.0
max = 8.0
points = 2
[[axes]]
parameter = \"trailer.mass\"
min = 1400.0
max = 1500.0
points = 2
[base]
horizon_s = 4.0
speed = { kind = \"constant\", speed_mps = { of_v_crit = 0.95 } }
controller = { kind = \"none\" }
initial = { kind = \"state\", theta0_deg = 2.0 }
[base.solver]
rtol = 1e-6
atol = 1e-8
";

#[test]
fn simulation_tasks_run_on_each_model_variant_file() {
    // each example vehicle (relaxation, Magic Formula, tandem, hitch friction)
    // through simulate, fig3b, fig4c and a sweep: every run ends with its metrics; the
    // relative speeds refer to the variant's own V_crit (reference:
    // trailer_model::Plant::critical_speed of the vehicle's plant, 1e-6 relative: both
    // scan and bisect the spectral abscissa to 1e-11 m/s)
    let dir = tempfile::tempdir().expect("tempdir");
    let vehicles_dir = configs_dir().join("vehicles");
    for file in [
        "relaxation.toml",
        "magic_formula.toml",
        "tandem.toml",
        "hitch_friction.toml",
    ] {
        let vehicle = vehicles_dir.join(file);
        let ctx = TaskContext::new(&vehicle, &configs_dir(), &dir.path().join("r"), &NoProgress)
            .expect("vehicle loads");
        assert!(ctx.variant_key.is_some(), "{file}");
        let v_crit = trailer_model::with_plant!(&ctx.plant, m => {
            trailer_model::Plant::critical_speed(m, &Default::default())
        })
        .expect("V_crit")
        .v_crit_mps;
        for (task, toml) in [
            ("simulate", simulate()),
            ("fig3b", fig3b()),
            ("fig4c", fig4c()),
        ] {
            let s =
                run(task, &toml, &vehicle, dir.path()).unwrap_or_else(|e| panic!("{file}: {e}"));
            let speeds = s["resolved_speeds"].as_array().expect("resolved speeds");
            let first = &speeds[0];
            let factor = first["spec"]["of_v_crit"].as_f64().expect("of_v_crit");
            let v = first["speed_mps"].as_f64().expect("speed");
            assert!(
                rel(v, factor * v_crit) < 1e-6,
                "{file} {task}: {v} vs {factor}·{v_crit}"
            );
            let text = s.to_string();
            assert!(text.contains("\"class\""), "{file} {task}: {text}");
        }
        let s = run("sweep", SWEEP_VARIANT, &vehicle, dir.path())
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(s["points_failed"].as_u64(), Some(0), "{file}: {s}");
    }
}

/// `variants` at a small resolution: few gains, a short threshold horizon, a 3-point σ grid.
fn variants_config() -> String {
    let mf = configs_dir().join("vehicles/magic_formula.toml");
    format!(
        "relaxation_lengths_m = [0.0, 0.3, 0.6]
vehicle_files = [{mf:?}]
curve_relaxation_lengths_m = {{ min = 0.0, max = 0.6, points = 3 }}
[headline]
delay_s = 0.2
theta0_deg = [1.0, 20.0, 3.0]
[headline.gain_search]
gain_samples = 6
speed_samples = 40
speed_tolerance_mps = 1e-6
gain_tolerance_s = 1e-4
[headline.threshold]
horizon_s = 8.0
tolerance_deg = 1.0
max_doublings = 0
compare_cycles = false
"
    )
}

#[test]
fn variants_task_moves_the_headline_numbers_with_relaxation() {
    // References: the paper's model's V_crit 34.7479 m/s (`linear`,
    // rounded to 1e-4: 5e-5); independent linear analyses of Table I with σ on every axle:
    // 32.5777 m/s at σ = 0.3 m (rounded to 1e-4: 5e-5) and ≈ 30.3 m/s at σ = 0.6 m (given
    // to 0.1 m/s: 0.05); a Magic Formula tyre with the brush tyre's cornering stiffness has
    // the same linearisation, so the same V_crit (1e-9 relative: both bisect the same
    // spectral abscissa to 1e-11 m/s), but another force curve, so another fold of cycles
    // (the Table I fold at 31.52 m/s moves by more than 0.1 m/s)
    let dir = tempfile::tempdir().expect("tempdir");
    let vehicle = configs_dir().join("vehicle.toml");
    let s = run("variants", &variants_config(), &vehicle, dir.path()).expect("variants runs");
    let rows = s["variants"].as_array().expect("variants");
    assert_eq!(rows.len(), 4, "{s}");
    let num = |r: &Value, k: &str| r[k].as_f64().unwrap_or_else(|| panic!("{k}: {r}"));
    let v_crit: Vec<f64> = rows.iter().map(|r| num(r, "v_crit_mps")).collect();
    assert!((v_crit[0] - 34.7479).abs() < 5e-5, "{}", v_crit[0]);
    assert!((v_crit[1] - 32.5777).abs() < 5e-5, "{}", v_crit[1]);
    assert!((v_crit[2] - 30.3).abs() < 0.05, "{}", v_crit[2]);
    // the fold at σ = 0.3 m: 29.757448 m/s on a mesh of L = 80 (29.757452 at L = 20: the
    // mesh error is < 1e-5 m/s), so 1e-4
    assert!(
        (num(&rows[1], "v_fold_mps") - 29.757448).abs() < 1e-4,
        "{}",
        rows[1]
    );
    assert_eq!(rows[0]["states"].as_u64(), Some(4));
    assert_eq!(rows[1]["states"].as_u64(), Some(7));
    // the σ curve of the figure falls, and its fold stays below V_crit
    let curve = s["relaxation_curve"].as_array().expect("curve");
    assert_eq!(curve.len(), 3);
    for w in curve.windows(2) {
        assert!(num(&w[1], "v_crit_mps") < num(&w[0], "v_crit_mps"), "{s}");
    }
    for p in curve {
        assert!(num(p, "v_fold_mps") < num(p, "v_crit_mps"), "{p}");
    }
    // the curve's σ = 0.3 m point is the table's row (the same computation)
    assert_eq!(num(&curve[1], "v_crit_mps"), v_crit[1]);
    assert_eq!(curve[1]["v_fold_mps"], rows[1]["v_fold_mps"]);
    // Magic Formula: the brush tyre's V_crit, another fold
    let (brush, mf) = (&rows[0], &rows[3]);
    assert!(
        (v_crit[3] - v_crit[0]).abs() < 1e-9 * v_crit[0],
        "{} vs {}",
        v_crit[3],
        v_crit[0]
    );
    let (f0, f3) = (num(brush, "v_fold_mps"), num(mf, "v_fold_mps"));
    assert!((f3 - f0).abs() > 0.1, "MF fold {f3} vs brush {f0}");
    // every row has D* (below V_crit(D*)) and the bistable width V_crit − V_fold
    for r in rows {
        assert!(num(r, "v_crit_at_d_opt_mps") > num(r, "v_crit_mps"), "{r}");
        let w = num(r, "bistable_width_mps");
        assert!(
            (w - (num(r, "v_crit_mps") - num(r, "v_fold_mps"))).abs() < 1e-12,
            "{r}"
        );
    }
    for f in [
        "variants.csv",
        "v_crit_v_fold_vs_sigma.png",
        "v_crit_v_fold_vs_sigma.svg",
    ] {
        assert!(dir.path().join("results/variants").join(f).exists(), "{f}");
    }
}

/// `chart_nonlinear` at a small resolution: one delay, a coarse mesh and shading grid.
const CHART_SMALL: &str = "\
delays_s = [0.2]
[chart]
hopf_max_points = 60
fold_max_points = 40
criticality_samples = 2
[chart.cycles]
intervals = 12
[regions]
speed_cells = 12
gain_cells = 8
";

#[test]
fn chart_nonlinear_runs_on_a_model_variant_and_keeps_the_papers_numbers() {
    // a vehicle with tyre relaxation: its chart is computed on its own plant (7 states); its
    // Hopf speed at D = 0 is its own open-loop V_crit (reference: Plant::critical_speed,
    // 1e-6 relative: the Hopf curve is corrected on its defining system to 1e-10, the
    // linear search bisects to 1e-11 m/s). The paper's vehicle through the task (dispatched
    // to AnyVehicleModel::Paper) gives the summary of the library's computation on the
    // paper's Model (compared after the run info, which names files and times).
    let dir = tempfile::tempdir().expect("tempdir");
    let variant = configs_dir().join("vehicles/relaxation.toml");
    let s = run("chart_nonlinear", CHART_SMALL, &variant, dir.path()).expect("variant chart");
    let ctx = TaskContext::new(&variant, &configs_dir(), &dir.path().join("r"), &NoProgress)
        .expect("vehicle loads");
    let v_crit = trailer_model::with_plant!(&ctx.plant, m => {
        trailer_model::Plant::critical_speed(m, &Default::default())
    })
    .expect("V_crit")
    .v_crit_mps;
    let curves = s["per_tau"][0]["curves"].as_array().expect("curves");
    let at0 = curves
        .iter()
        .find(|c| c["d_s"].as_f64() == Some(0.0))
        .expect("D = 0 among the summary gains");
    let v0 = at0["v_hopf_mps"].as_f64().expect("Hopf speed at D = 0");
    assert!(rel(v0, v_crit) < 1e-6, "{v0} vs {v_crit}");

    let paper = configs_dir().join("vehicle.toml");
    let a = run("chart_nonlinear", CHART_SMALL, &paper, dir.path()).expect("paper chart");
    let cfg: sway_studies::chart::ChartNonlinearConfig =
        toml::from_str(CHART_SMALL).expect("config");
    let model = trailer_model::Model::new(VehicleParams::default()).expect("Table I");
    let study = sway_studies::chart::compute(
        &model,
        &cfg,
        &sway::charts::auto_range::SpeedBounds::from(&sway::ranging::SpeedLimits::default()),
        &NoProgress,
    )
    .expect("library chart");
    let d = &study.delays[0];
    let task_curves = a["per_tau"][0]["curves"].as_array().expect("curves");
    assert_eq!(task_curves.len(), d.curves.len());
    for (t, c) in task_curves.iter().zip(&d.curves) {
        assert_eq!(t["v_hopf_mps"].as_f64(), c.v_hopf_mps);
        assert_eq!(t["v_fold_mps"].as_f64(), c.v_fold_mps);
    }
    assert_eq!(
        a["per_tau"][0]["bistable_width_mps"].as_f64(),
        d.bistable_width_mps
    );
}

#[test]
fn fleet_takes_a_vehicle_file_with_model_variants() {
    // configs/vehicles/relaxation.toml (Table I, σ = 0.3 m on every axle) as a fleet file:
    // its own V_crit 32.5777 m/s and fold 29.757448 m/s (references and tolerances as in
    // `variants_task_moves_the_headline_numbers_with_relaxation`)
    let dir = tempfile::tempdir().expect("tempdir");
    let relaxation = configs_dir().join("vehicles/relaxation.toml");
    let toml = variants_config()
        .replace("relaxation_lengths_m = [0.0, 0.3, 0.6]\n", "")
        .replace(
            "curve_relaxation_lengths_m = { min = 0.0, max = 0.6, points = 3 }\n",
            "",
        )
        .replace("vehicle_files = [", "files = [")
        .replace(
            &format!("{:?}", configs_dir().join("vehicles/magic_formula.toml")),
            &format!("{relaxation:?}"),
        );
    let vehicle = configs_dir().join("vehicle.toml");
    let s = run("fleet", &toml, &vehicle, dir.path()).expect("fleet runs");
    let r = &s["vehicles"][0];
    let v = r["v_crit_mps"].as_f64().expect("V_crit");
    let f = r["v_fold_mps"].as_f64().expect("V_fold");
    assert!((v - 32.5777).abs() < 5e-5, "{v}");
    assert!((f - 29.757448).abs() < 1e-4, "{f}");
}

#[test]
fn loading_maps_a_model_variant_on_its_own_plant() {
    // the map of a vehicle with tyre relaxation: V_crit at its own loading is its own
    // V_crit (reference: Plant::critical_speed of its plant; the map bisects to 1e-6 m/s,
    // so 1e-5) and the relative end of the range refers to it (1e-8: both searches bisect
    // the spectral abscissa to 1e-11 m/s); the same for a tandem trailer axle (its l is the
    // mean position of the two axles)
    let dir = tempfile::tempdir().expect("tempdir");
    for file in ["relaxation.toml", "tandem.toml"] {
        let vehicle = configs_dir().join("vehicles").join(file);
        let ctx = TaskContext::new(&vehicle, &configs_dir(), &dir.path().join("r"), &NoProgress)
            .expect("vehicle loads");
        let v_crit = trailer_model::with_plant!(&ctx.plant, m => {
            trailer_model::Plant::critical_speed(m, &Default::default())
        })
        .expect("V_crit")
        .v_crit_mps;
        let s =
            run("loading", LOADING, &vehicle, dir.path()).unwrap_or_else(|e| panic!("{file}: {e}"));
        let v = s["v_crit_table_i_mps"].as_f64().expect("V_crit");
        assert!((v - v_crit).abs() < 1e-5, "{file}: {v} vs {v_crit}");
        let top = s["v_range_mps"][1].as_f64().expect("range");
        assert!(rel(top, 3.453443785619 * v_crit) < 1e-8, "{file}: {top}");
    }
}
