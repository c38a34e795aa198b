//! Vehicle files with a chain of towed units (`[[trailers]]`, `configs/combinations/`) load
//! through the same path as two-unit files, and the two-unit files still give the numbers
//! they gave before chains existed (the committed `results/` of `fleet` and `variants`).

use std::path::{Path, PathBuf};

use sway_model::speeds::{OpenLoopStability, SpeedLimits, open_loop_critical_speed};
use sway_tasks::config_file::{load_vehicle_spec, vehicle_from_spec};
use trailer_model::{
    AnyVehicleModel, Inputs, Model, Plant, VehicleParams, VehicleSpec, with_plant,
};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn v_crit(plant: &AnyVehicleModel) -> Option<f64> {
    match with_plant!(plant, m => open_loop_critical_speed(m, &SpeedLimits::default()))
        .expect("a critical-speed search")
    {
        OpenLoopStability::Critical { v_crit_mps, .. } => Some(v_crit_mps),
        OpenLoopStability::StableUpTo { .. } => None,
    }
}

/// Column 0 and column `col` of a committed CSV: name → V_crit (None where empty).
fn committed(file: &str, col: usize) -> Vec<(String, Option<f64>)> {
    let text = std::fs::read_to_string(root().join(file)).expect("a committed result");
    text.lines()
        .skip(1)
        .map(|line| {
            let mut cols = line.split(',');
            let name = cols.next().unwrap_or_default().to_string();
            (name, cols.nth(col - 1).and_then(|v| v.parse().ok()))
        })
        .collect()
}

#[test]
fn every_example_combination_loads_and_builds_its_model() {
    let dir = root().join("configs/combinations");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("configs/combinations")
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 4, "{files:?}");
    for file in files {
        let loaded = load_vehicle_spec(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        assert!(loaded.spec.is_chain(), "{}", file.display());
        assert_eq!(loaded.variant_key.as_deref(), Some("trailers"));
        // 2 states per unit, no relaxation in the examples
        let units = 1 + loaded.spec.towed_units();
        assert_eq!(loaded.plant.states(), 2 * units, "{}", file.display());
        // straight running is an equilibrium, and the rhs is finite near it
        let x = with_plant!(&loaded.plant, m => {
            let mut x = nalgebra::SVector::<f64, _>::zeros();
            x[trailer_model::HITCH_ANGLE] = 0.02;
            let at_rest = m.rhs(&nalgebra::SVector::zeros(), &Inputs::constant_speed(20.0));
            assert!(at_rest.iter().all(|v| *v == 0.0), "{}", file.display());
            m.rhs(&x, &Inputs::constant_speed(20.0)).iter().all(|v| v.is_finite())
        });
        assert!(x, "{}", file.display());
        // the paper form of a chain is its towing unit with the first towed unit
        assert_eq!(loaded.params.tractor.mass, loaded.spec.tractor.mass);
        assert_eq!(loaded.params.trailer.mass, loaded.spec.trailers[0].mass);
        // a V_crit, or stable up to the cap
        if let Some(v) = v_crit(&loaded.plant) {
            assert!(v > 5.0 && v < 100.0, "{}: V_crit = {v}", file.display());
        }
    }
}

#[test]
fn two_unit_files_give_the_committed_critical_speeds_bit_for_bit() {
    for (name, expected) in committed("results/fleet/fleet.csv", 1) {
        let loaded = load_vehicle_spec(&root().join("configs").join(&name))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!loaded.spec.is_chain());
        assert_eq!(v_crit(&loaded.plant), expected, "{name}");
    }
    let variants = committed("results/variants/variants.csv", 2);
    for (file, row) in [
        ("vehicle.toml", "Table I (paper's model)"),
        ("vehicles/magic_formula.toml", "magic_formula"),
        ("vehicles/tandem.toml", "tandem"),
        ("vehicles/hitch_friction.toml", "hitch_friction"),
    ] {
        let loaded = load_vehicle_spec(&root().join("configs").join(file)).expect(file);
        let expected = variants.iter().find(|(n, _)| n == row).expect(row).1;
        assert_eq!(v_crit(&loaded.plant), expected, "{file}");
    }
}

#[test]
fn paper_form_files_are_the_papers_model_bit_for_bit() {
    let mut files = vec![root().join("configs/vehicle.toml")];
    for e in std::fs::read_dir(root().join("configs/fleet")).expect("configs/fleet") {
        files.push(e.expect("an entry").path());
    }
    for file in files {
        let text = std::fs::read_to_string(&file).expect("a vehicle file");
        let params: VehicleParams = toml::from_str(&text).expect("the paper's form");
        let old = Model::new(params).expect("a valid vehicle");
        let loaded = load_vehicle_spec(&file).expect("a valid vehicle");
        let AnyVehicleModel::Paper(new) = &loaded.plant else {
            panic!("{}: not the paper's model", file.display());
        };
        let x = trailer_model::State4::new(0.3_f64, -0.05, 0.12, 0.08);
        let u: Inputs<f64> = Inputs {
            steering_angle: 0.01,
            speed: 27.0,
            acceleration: -0.5,
        };
        let (a, b): (trailer_model::State4, trailer_model::State4) =
            (old.rhs4(&x, &u), new.rhs4(&x, &u));
        for k in 0..4 {
            assert_eq!(a[k].to_bits(), b[k].to_bits(), "{}", file.display());
        }
    }
}

fn spec(text: &str) -> VehicleSpec {
    toml::from_str(text).expect("a vehicle file's form")
}

fn error_of(text: &str) -> String {
    match vehicle_from_spec(spec(text), Path::new("bad.toml")) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

const TRACTOR: &str = "[tractor]\nmass = 2400.0\nyaw_inertia = 7647.0\nfront_axle = 5.15\ncog = 3.25\nrear_axle = 1.35\nfront_cornering_stiffness = 137e3\nrear_cornering_stiffness = 256e3\n[friction]\nmu_static = 0.9\nmu_dynamic = 0.6\n";
const UNIT: &str =
    "mass = 985.0\nyaw_inertia = 1416.0\ncog = 2.6\naxle = 2.8\ncornering_stiffness = 50e3\n";

#[test]
fn bad_chain_files_are_errors_naming_the_key() {
    // both forms
    let both = format!("{TRACTOR}[trailer]\n{UNIT}[[trailers]]\n{UNIT}");
    assert!(
        error_of(&both).contains("`trailers`"),
        "{}",
        error_of(&both)
    );
    // neither
    let e = error_of(TRACTOR);
    assert!(e.contains("`trailer`"), "{e}");
    // a rear coupling missing on the first of two units
    let e = error_of(&format!(
        "{TRACTOR}[[trailers]]\n{UNIT}[[trailers]]\n{UNIT}"
    ));
    assert!(e.contains("trailers[0].rear_coupling"), "{e}");
    // a rear coupling on the last unit
    let e = error_of(&format!(
        "{TRACTOR}[[trailers]]\n{UNIT}rear_coupling = 5.0\n[[trailers]]\n{UNIT}rear_coupling = 4.0\n"
    ));
    assert!(e.contains("trailers[1].rear_coupling"), "{e}");
    // a top-level [hitch] with [[trailers]]
    let e = error_of(&format!(
        "{TRACTOR}[hitch]\nyaw_damping_nms = 100.0\n[[trailers]]\n{UNIT}"
    ));
    assert!(e.contains("`hitch`"), "{e}");
    // a negative mass of the second unit
    let e = error_of(&format!(
        "{TRACTOR}[[trailers]]\n{UNIT}rear_coupling = 5.0\n[[trailers]]\n{}",
        UNIT.replace("985.0", "-1.0")
    ));
    assert!(e.contains("trailers[1].mass"), "{e}");
    // a steered towed axle
    let e = error_of(&format!(
        "{TRACTOR}[[trailers]]\nmass = 985.0\nyaw_inertia = 1416.0\ncog = 2.6\n[[trailers.axles]]\nposition_m = 2.8\ncornering_stiffness = 50e3\nsteered = true\n"
    ));
    assert!(e.contains("trailers[0].axles[0].steered"), "{e}");
    // an unknown key of a towed unit
    let text = format!("{TRACTOR}[[trailers]]\n{UNIT}coupling = 1.0\n");
    assert!(toml::from_str::<VehicleSpec>(&text).is_err());
}

#[test]
fn two_unit_notions_of_a_chain_are_errors_naming_the_key() {
    let chain = spec(&format!(
        "{TRACTOR}[[trailers]]\n{UNIT}rear_coupling = 5.2\n[[trailers]]\n{}",
        UNIT.replace("985.0", "600.0")
    ));
    let key_of = |e: trailer_model::ModelError| match e {
        trailer_model::ModelError::InvalidSpec { key, .. } => key,
        other => panic!("{other}"),
    };
    assert_eq!(key_of(chain.equivalent_params().unwrap_err()), "trailers");
    assert_eq!(key_of(chain.axle_loads().unwrap_err()), "trailers");
    assert_eq!(key_of(chain.resolved_axles().unwrap_err()), "trailers");
    assert_eq!(
        key_of(chain.with_parameter(7, 1000.0).unwrap_err()),
        "trailer.mass"
    );
    assert_eq!(
        key_of(chain.with_parameter(10, 3.0).unwrap_err()),
        "trailer.axle"
    );
    // the towing unit's keys still vary
    let heavier = chain.with_parameter(0, 2600.0).expect("tractor.mass");
    assert_eq!(heavier.tractor.mass, 2600.0);
    let e = sway::loading::loaded_vehicle(&chain, 900.0, 2.5, sway::loading::InertiaScaling::Fixed)
        .unwrap_err();
    assert_eq!(key_of(e), "trailers");
    assert!(
        chain
            .two_unit_trailer("x")
            .unwrap_err()
            .to_string()
            .contains("2 towed units")
    );
}

#[test]
fn the_shipped_vehicle_files_still_parse() {
    for dir in [
        "configs",
        "configs/fleet",
        "configs/vehicles",
        "configs/combinations",
    ] {
        for e in std::fs::read_dir(root().join(dir)).expect(dir) {
            let path = e.expect("an entry").path();
            if path.extension().is_none_or(|x| x != "toml") {
                continue;
            }
            let text = std::fs::read_to_string(&path).expect("a file");
            if !text.contains("[tractor]") {
                continue; // a task's config
            }
            load_vehicle_spec(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
    }
}

/// Runs the shipped config of `task` on the vehicle file `vehicle` into `results` and
/// returns its `summary.json` and printed lines.
fn run_shipped(task: &str, vehicle: &Path, results: &Path) -> (serde_json::Value, Vec<String>) {
    use sway_tasks::tasks::{self, TaskContext};
    let configs = root().join("configs");
    let ctx = TaskContext::new(vehicle, &configs, results, &sway::progress::NoProgress)
        .expect("the vehicle loads");
    let t = tasks::registry()
        .into_iter()
        .find(|t| t.name == task)
        .expect("task in the registry");
    let (prepared, _) =
        tasks::prepare_checked(&t, &ctx, &configs.join(t.config)).expect("the config loads");
    let report = prepared
        .run(&ctx)
        .unwrap_or_else(|e| panic!("{task} fails on a chain: {e}"));
    let text = std::fs::read_to_string(report.output_dir.join("summary.json")).expect("summary");
    (serde_json::from_str(&text).expect("JSON"), report.lines)
}

#[test]
fn two_unit_notions_of_a_task_are_results_saying_so_for_a_chain() {
    // the shipped configs on a car with two caravans: the loading map (of the one trailer),
    // the uncertainty study (which samples `trailer.cog` and `trailer.axle`) and the
    // rounding of h and l in `linear` have no meaning for a chain; each says so by key
    // and reason, and the run succeeds with nothing else in its result
    let vehicle = root().join("configs/combinations/car_two_caravans.toml");
    let dir = tempfile::tempdir().expect("temp dir");
    let (loading, lines) = run_shipped("loading", &vehicle, dir.path());
    assert_eq!(loading["not_applicable"]["key"], "trailers", "{loading}");
    assert!(lines[0].contains("not applicable"), "{lines:?}");
    let files: Vec<_> = std::fs::read_dir(dir.path().join("loading"))
        .expect("results/loading")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(files, ["summary.json"], "nothing of a half-run map is kept");

    let (study, _) = run_shipped("study_uncertainty", &vehicle, dir.path());
    assert_eq!(
        study["not_applicable"]["key"], "sampling.fields[0].key",
        "{study}"
    );
    let reason = study["not_applicable"]["reason"].as_str().expect("reason");
    assert!(reason.contains("trailer.cog"), "{reason}");

    let (linear, lines) = run_shipped("linear", &vehicle, dir.path());
    assert!(linear["v_crit_mps"].as_f64().is_some(), "{linear}");
    assert!(linear["dv_crit_dh_mps_per_m"].is_null());
    let why = linear["v_crit_rounding_reason"].as_str().expect("a reason");
    assert!(why.contains("2 towed units"), "{why}");
    assert!(lines.iter().all(|l| !l.contains("NaN")), "{lines:?}");
}

/// Every shipped combination's first mode to lose stability does so at the V_crit of the
/// one search every task uses (the spectral abscissa's sign change, bisected to 1e-11 m/s;
/// the mode's crossing is bisected to 1e-9 m/s on its own eigenvalue): agreement to 1e-8
/// m/s, or no crossing where straight running is stable to the maximum speed.
#[test]
fn each_combinations_first_mode_crossing_is_its_v_crit() {
    use sway_studies::modes::modes_of;
    for f in COMBINATIONS {
        let loaded = load_vehicle_spec(&root().join(f)).expect("a combination");
        let speeds: Vec<f64> = (2..=200).map(|k| 0.5 * f64::from(k)).collect();
        let modes = modes_of(&loaded.plant, &speeds, 22.0).expect("modes");
        let first = modes
            .summaries
            .iter()
            .filter_map(|m| m.crossing_speed_mps)
            .fold(None, |a: Option<f64>, v| Some(a.map_or(v, |a| a.min(v))));
        match (v_crit(&loaded.plant), first) {
            (Some(vc), Some(c)) => assert!((vc - c).abs() < 1e-8, "{f}: {vc} vs {c}"),
            (None, None) => {}
            other => panic!("{f}: V_crit and the modes disagree: {other:?}"),
        }
        assert_eq!(
            modes.summaries.len(),
            loaded.spec.towed_units().max(1) + usize::from(f.contains("two_caravans")),
            "{f}: {:#?}",
            modes.summaries
        );
    }
}

const COMBINATIONS: [&str; 4] = [
    "configs/combinations/car_two_caravans.toml",
    "configs/combinations/truck_centre_axle_trailer.toml",
    "configs/combinations/tractor_semitrailer.toml",
    "configs/combinations/truck_dolly_semitrailer.toml",
];

/// `combination` on the shipped combinations: every number or its reason. Where straight
/// running is stable, the yaw damping read from the rearmost articulation's decaying peaks
/// after a pulse (a simulation) is the damping ratio of the least damped mode of the
/// linearisation at the test speed (an eigenvalue problem) to 3 %: the two are independent
/// readings of the same decay, which differ by the faster modes' remains and the tyres'
/// nonlinearity at a 0.5° pulse.
#[test]
fn the_combination_task_reports_the_heavy_vehicle_metrics() {
    let dir = tempfile::tempdir().expect("temp dir");
    let vehicle = root().join("configs/vehicle.toml");
    let (s, lines) = run_shipped("combination", &vehicle, dir.path());
    let rows = s["combinations"].as_array().expect("combinations");
    assert_eq!(rows.len(), 4, "{s}");
    assert_eq!(lines.len(), 4);
    for r in rows {
        let file = r["vehicle_file"].as_str().expect("file");
        let least = r["modes"]
            .as_array()
            .expect("modes")
            .iter()
            .filter_map(|m| m["damping_ratio"].as_f64())
            .fold(f64::INFINITY, f64::min);
        let read = r["yaw_damping_ratio"].as_f64().expect("a yaw damping");
        if file.contains("two_caravans") {
            // growing sway: the growth quickens with the amplitude (a subcritical Hopf
            // point, V_fold < V_crit), so the reading is only of the same sign
            assert!(least < 0.0, "{file}: {least}");
            // unstable at 80 km/h: the lane change is not run, and says why
            assert!(r["rearward_amplification"].is_null());
            assert!(read < 0.0);
            let reasons = r["reasons"].to_string();
            assert!(reasons.contains("unstable"), "{reasons}");
            assert!(
                r["v_fold_mps"]
                    .as_f64()
                    .is_some_and(|f| f < r["v_crit_mps"].as_f64().unwrap())
            );
        } else {
            assert!(
                (read / least - 1.0).abs() < 3e-2,
                "{file}: {read} vs {least}"
            );
            let ra = r["rearward_amplification"].as_f64().expect("RA");
            let hsto = r["high_speed_transient_offtracking_m"]
                .as_f64()
                .expect("HSTO");
            assert!(
                ra > 0.5 && ra < 3.0 && hsto > 0.0 && hsto < 2.0,
                "{file}: {ra} {hsto}"
            );
            assert!(r["v_crit_mps"].is_null() && r["stable_up_to_mps"].as_f64().is_some());
        }
    }
    for f in [
        "combination.csv",
        "combination.md",
        "modes.csv",
        "lane_change.csv",
        "lane_change.png",
        "modes.png",
    ] {
        assert!(dir.path().join("combination").join(f).exists(), "{f}");
    }
}

/// `sway_assist` on a chain: its observer is the two-unit model's, so the task says so.
#[test]
fn sway_assist_is_not_applicable_to_a_chain() {
    let dir = tempfile::tempdir().expect("temp dir");
    let vehicle = root().join("configs/combinations/car_two_caravans.toml");
    let (s, _) = run_shipped("sway_assist", &vehicle, dir.path());
    assert_eq!(s["not_applicable"]["key"], "trailers", "{s}");
    // the summary's vehicle is the chain's file, not its first pair
    let (linear, _) = run_shipped("linear", &vehicle, dir.path());
    assert_eq!(
        linear["vehicle"]["trailers"].as_array().map(Vec::len),
        Some(2),
        "{linear}"
    );
    assert!(
        linear["modes"].as_array().is_some_and(|m| m.len() == 3),
        "{linear}"
    );
}

/// `lateral_stability` reads the rearmost articulation of a chain when its config asks for
/// it: on the truck–dolly–semitrailer at 80 km/h its damping is that of the least damped
/// mode of the linearisation (3 %, as for `combination`'s pulse), while the first
/// coupling's (the dolly's drawbar, a mix of both modes) reads otherwise.
#[test]
fn lateral_stability_reads_the_rearmost_articulation_of_a_chain() {
    use sway_tasks::tasks::{self, TaskContext};
    let dir = tempfile::tempdir().expect("temp dir");
    let configs = root().join("configs");
    let vehicle = root().join("configs/combinations/truck_dolly_semitrailer.toml");
    let ctx = TaskContext::new(&vehicle, &configs, dir.path(), &sway::progress::NoProgress)
        .expect("the vehicle loads");
    let t = tasks::registry()
        .into_iter()
        .find(|t| t.name == "lateral_stability")
        .expect("task in the registry");
    let read = |signal: &str| {
        let file = dir.path().join(format!("{signal}.toml"));
        std::fs::write(
            &file,
            format!(
                "speeds = [22.222222222222]\nsignal = \"{signal}\"\nskip_peaks = 1\nperiods = 3\namplitudes_deg = []\n[pulse]\namplitude_deg = 0.5\n"
            ),
        )
        .expect("config");
        let (prepared, _) = tasks::prepare_checked(&t, &ctx, &file).expect("the config loads");
        let report = prepared
            .run(&ctx)
            .expect("lateral_stability runs on a chain");
        let text =
            std::fs::read_to_string(report.output_dir.join("summary.json")).expect("summary");
        let s: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        s["speeds"][0]["damping_ratio"]
            .as_f64()
            .unwrap_or_else(|| panic!("a damping: {s}"))
    };
    let rearmost = read("rearmost_articulation_angle");
    let first = read("hitch_angle");
    let loaded = load_vehicle_spec(&vehicle).expect("the A-double");
    let modes = sway_studies::modes::modes_of(&loaded.plant, &[22.222222222222], 22.222222222222)
        .expect("modes");
    let least = modes
        .summaries
        .iter()
        .filter_map(|m| m.damping_ratio)
        .fold(f64::INFINITY, f64::min);
    assert!(
        (rearmost / least - 1.0).abs() < 3e-2,
        "{rearmost} vs {least}"
    );
    assert!((first - rearmost).abs() > 0.03, "{first} vs {rearmost}");
}
