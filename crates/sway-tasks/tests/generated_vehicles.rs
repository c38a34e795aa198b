//! A curve that cannot go on is a result, not a failed task: 30 generated car–trailer
//! combinations with random variant mixes (`sway_model::generator`: tyre relaxation, Magic
//! Formula tyres, tandem trailer axles, hitch damping and friction, each with probability ½)
//! through every task that takes the vehicle, at CI size, with the code path of
//! `cargo xtask study_generated` (`study_generated::run_all`), each task exactly as
//! `cargo xtask <task> --vehicle FILE` runs it.
//!
//! Checked, per vehicle and task:
//! - every run exits 0 with its `summary.json` (no error, no panic);
//! - a curve that ended early says how (`curves_ended_early` entries carry an `end` with a
//!   known `reason`);
//! - every variant is in the mix (each in at least 5 of the 30 vehicles, and at least 5
//!   vehicles with three variants or more).
//!
//! The configs are the shipped ones with the continuation and simulation tasks at small
//! resolutions (mesh L = 20, degree 4, short curves and horizons, coarse grids).

use std::path::{Path, PathBuf};

use sway_model::generator::generate;
use sway_tasks::tasks::study_generated::{Run, VEHICLE_TASKS, run_all, summarise};

/// The seed of the generator and the number of vehicles.
const SEED: u64 = 52;
const COUNT: usize = 30;

fn configs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}

/// The CI-sized configs: (file name, text). The others are the shipped ones.
const SMALL: [(&str, &str); 14] = [
    (
        "fig3a.toml",
        "[panels]\nspeed_mps = { of_v_crit = 0.9 }\ntheta0_deg = [2.0]\nhorizon_s = 2.0\noutput_step_s = 0.05\n\
         [diagram]\nstable_speeds_mps = [{ of_v_crit = 1.05 }]\nunstable_speeds_mps = [{ in_bistable = 0.5 }]\n\
         [diagram.continuation]\nintervals = 20\ndegree = 4\nmax_step = 0.5\n",
    ),
    (
        "fig4a.toml",
        "speed = { cells = 30 }\ngain = { cells = 20 }\ndelays_s = [0.0, 0.2]\n",
    ),
    (
        "fig4b.toml",
        "[[pairs]]\ndelay_s = 0.0\ngain_s = 0.0\n[[pairs]]\ndelay_s = 0.2\ngain_s = 0.1\n\
         [continuation]\nintervals = 20\ndegree = 4\n",
    ),
    (
        "chart_nonlinear.toml",
        "delays_s = [0.0, 0.2]\n[chart]\nhopf_max_step = 4.0\nhopf_max_points = 12\nfold_max_step = 4.0\n\
         fold_max_points = 6\ncriticality_samples = 2\ncriticality_cycle_points = 2\n\
         [chart.cycles]\nintervals = 20\ndegree = 4\nmax_step = 2.0\n[regions]\nspeed_cells = 8\ngain_cells = 6\n",
    ),
    (
        "gain_design.toml",
        "delays_s = { min = 0.0, max = 0.2, points = 2 }\nheadline_delays_s = [0.2]\n\
         [search]\ngain_samples = 5\nspeed_samples = 25\ngain_tolerance_s = 1e-3\n\
         [nonlinear]\nevery = 1\n[chart]\nfold_max_step = 4.0\nfold_max_points = 6\n\
         [chart.cycles]\nintervals = 20\ndegree = 4\nmax_step = 2.0\n",
    ),
    (
        "corners.toml",
        "delays_s = [0.2]\n[chart]\nhopf_max_step = 4.0\nhopf_max_points = 12\nfold_max_points = 4\n\
         criticality_samples = 2\ncriticality_cycle_points = 2\n[chart.cycles]\nintervals = 20\ndegree = 4\n\
         [corners]\nv_samples = 21\nzoom_curve_samples = 11\nzoom_cells = 6\nprobe_radii = [0.5]\n\
         [corners.simulation]\ntransient_s = 10.0\nwindow_s = 20.0\nsample_step_s = 0.05\nkicks_deg = [5.0]\n\
         [corners.torus_scan]\nspeed_offsets_mps = [0.0]\nd_samples = 2\ntolerance_s = 1e-2\n\
         [corners.torus_curves]\nmax_points = 0\n",
    ),
    (
        "control_design.toml",
        "structures = [\"yaw_rate\"]\nactuators = [\"steering\"]\ndelays_s = { min = 0.0, max = 0.4, points = 2 }\n\
         [search]\ngain_samples = 9\n[search.speed]\nv_min_mps = 1.0\nv_max_mps = 100.0\nsamples = 30\ntolerance_mps = 1e-6\n\
         [robustness]\ndelays_s = [0.4]\n[robustness.uncertainty.vehicle]\nmethod = \"latin_hypercube\"\nsamples = 4\nseed = 1\n\
         [[robustness.uncertainty.vehicle.fields]]\nkey = \"trailer.cog\"\nabout = \"offset\"\ndistribution = \"uniform\"\nmin = -0.05\nmax = 0.05\n",
    ),
    (
        "loading.toml",
        "trailer_mass_kg = { min = 500.0, max = 1800.0, points = 3 }\n\
         trailer_cog_of_axle = { min = 0.8571428571428572, max = 1.0714285714285714, points = 3 }\n\
         v_range_mps = [1.0, { of_v_crit = 3.453443785619 }]\n",
    ),
    (
        "fig3b.toml",
        "brake_start_s = 1.0\nspeed_change_mps = { of_v_crit = -0.2877869821349167 }\nbrake_durations_s = [2.0]\n\
         horizon_s = 4.0\noutput_step_s = 0.1\n[start]\nspeed_mps = { of_v_crit = 1.0072544374722083 }\n\
         settle_s = 5.0\ntheta0_rad = 0.1\n[solver]\nrtol = 1e-6\natol = 1e-8\n",
    ),
    (
        "fig4c.toml",
        "action_s = 1.0\nhorizon_s = 4.0\noutput_step_s = 0.1\n[start]\nspeed_mps = { of_v_crit = 1.0072544374722083 }\n\
         settle_s = 5.0\ntheta0_rad = 0.1\n[steering]\ngain_s = 0.1\ndelay_s = 0.2\n\
         [braking]\nspeed_change_mps = { of_v_crit = -0.2877869821349167 }\nduration_s = 2.0\n[solver]\nrtol = 1e-6\natol = 1e-8\n",
    ),
    (
        "sweep_threshold.toml",
        "name = \"hopf_point\"\nkind = \"hopf_fold_speeds\"\n[[axes]]\nparameter = \"speed_mps\"\nmin = 30.0\nmax = 30.0\npoints = 1\n\
         [base]\nspeed = { kind = \"constant\", speed_mps = 30.0 }\ncontroller = { kind = \"none\" }\n\
         initial = { kind = \"state\", theta0_deg = 0.0 }\n[analysis.diagram]\nintervals = 20\ndegree = 4\nmax_step = 0.5\n",
    ),
    (
        "sweep_brake_timing.toml",
        "name = \"sweep_brake_timing\"\n[[axes]]\nparameter = \"brake_start_s\"\nmin = 2.0\nmax = 3.0\npoints = 2\n\
         [[axes]]\nparameter = \"ramp_duration_s\"\nmin = 2.0\nmax = 4.0\npoints = 2\n[base]\nhorizon_s = 6.0\n\
         speed = { kind = \"ramp\", initial_mps = { of_v_crit = 1.0072544374722083 }, change_mps = { of_v_crit = -0.2877869821349167 }, start_s = 2.0, duration_s = 5.0 }\n\
         controller = { kind = \"none\" }\n\
         initial = { kind = \"sway_cycle\", speed_mps = { of_v_crit = 1.0072544374722083 }, settle_s = 5.0, theta0_rad = 0.1 }\n\
         guard = \"stop\"\n[base.solver]\nrtol = 1e-6\natol = 1e-8\n",
    ),
    (
        "study_uncertainty.toml",
        "name = \"study_uncertainty\"\nkind = \"linear_critical_speed\"\n[sampling]\nmethod = \"latin_hypercube\"\nsamples = 20\nseed = 2026\n\
         [[sampling.fields]]\nkey = \"trailer.cog\"\nabout = \"offset\"\ndistribution = \"uniform\"\nmin = -0.05\nmax = 0.05\n\
         [base]\nspeed = { kind = \"constant\", speed_mps = 30.0 }\ncontroller = { kind = \"none\" }\n\
         initial = { kind = \"state\", theta0_deg = 0.0 }\n",
    ),
    (
        "lateral_stability.toml",
        "speeds = [{ of_v_crit = 0.7 }, { in_bistable = 0.5 }]\nskip_peaks = 2\nperiods = 3\namplitudes_deg = [1.0, 5.0]\n\
         horizon_s = 20.0\nsample_step_s = 0.01\n[pulse]\nshape = \"half_sine\"\nstart_s = 0.5\nduration_s = 0.4\namplitude_deg = 0.05\n",
    ),
];

/// The shipped configs with [`SMALL`] in place, in `dir`.
fn small_configs(dir: &Path) {
    for entry in std::fs::read_dir(configs_dir()).expect("configs/") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "toml") {
            std::fs::copy(&path, dir.join(path.file_name().expect("name"))).expect("copy");
        }
    }
    for (name, text) in SMALL {
        std::fs::write(dir.join(name), text).expect("write config");
    }
}

/// The reasons an `end` may give (`sway::bifurcation::chart::CurveEnd`, snake case).
const REASONS: [&str; 6] = [
    "left_box",
    "budget",
    "singular_point",
    "step_underflow",
    "corrector_failure",
    "failure",
];

#[test]
fn generated_vehicles_with_variants_get_an_outcome_from_every_task() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let configs = tmp.path().join("configs");
    std::fs::create_dir_all(&configs).expect("configs dir");
    small_configs(&configs);
    let vehicles = generate(SEED, COUNT);
    // every variant is present in the mix, and so are vehicles with several at once
    let names: Vec<Vec<&str>> = vehicles.iter().map(|v| v.variants.names()).collect();
    for variant in [
        "relaxation",
        "magic_formula",
        "tandem",
        "hitch_damping",
        "hitch_friction",
    ] {
        assert!(
            names.iter().filter(|n| n.contains(&variant)).count() >= 5,
            "{variant} in fewer than 5 of {COUNT} vehicles"
        );
    }
    assert!(names.iter().filter(|n| n.len() >= 3).count() >= 5);
    let tasks: Vec<String> = VEHICLE_TASKS.iter().map(|s| s.to_string()).collect();
    let t0 = std::time::Instant::now();
    let runs = run_all(
        &vehicles,
        &tasks,
        &configs,
        &tmp.path().join("scratch"),
        sway::ranging::SpeedLimits::default(),
        &|| {},
    )
    .expect("vehicle files written");
    let summary = summarise(&vehicles, &tasks, &runs);
    println!(
        "{} runs in {:.1} s: {} failed, curves ended early {:?}",
        summary.runs,
        t0.elapsed().as_secs_f64(),
        summary.failures,
        summary.curves_ended_early_by_reason
    );
    assert_eq!(summary.runs, COUNT * VEHICLE_TASKS.len());
    let failed: Vec<&Run> = runs.iter().filter(|r| r.error.is_some()).collect();
    assert!(
        failed.is_empty(),
        "{} of {} runs failed:\n{}",
        failed.len(),
        runs.len(),
        failed
            .iter()
            .map(|r| format!(
                "{} ({}) {}: {}",
                r.vehicle,
                r.variants,
                r.task,
                r.error.as_deref().unwrap_or("")
            ))
            .collect::<Vec<_>>()
            .join("\n")
    );
    for r in &runs {
        for e in &r.ended_early {
            assert!(
                REASONS.contains(&e.reason.as_str()),
                "{} {}: unknown end reason {:?} of {}",
                r.vehicle,
                r.task,
                e.reason,
                e.curve
            );
        }
    }
}
