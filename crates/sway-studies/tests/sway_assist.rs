//! The sway assist's evaluation on Table I: the default (small) config's sets, the
//! metrics' bookkeeping, and the same numbers on one thread and on two.

use sway::ranging::SpeedLimits;
use sway_studies::sway_assist::{ScenarioSet, SwayAssistConfig, compute, roc};
use trailer_model::{AnyVehicleModel, Model, VehicleParams};

fn table_i() -> Vec<(String, AnyVehicleModel)> {
    let m = Model::new(VehicleParams::default()).unwrap();
    vec![("Table I".to_string(), AnyVehicleModel::Paper(m))]
}

fn on_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn the_default_evaluation_on_table_i() {
    let cfg = SwayAssistConfig::default();
    let one = on_threads(1, || {
        compute(&cfg, &table_i(), &SpeedLimits::default()).unwrap()
    });
    let two = on_threads(2, || {
        compute(&cfg, &table_i(), &SpeedLimits::default()).unwrap()
    });
    assert_eq!(one, two);
    let r = one;
    let refs = &r.vehicles[0].references;
    // Table I: V_crit 34.75 m/s, and a bistable range below it
    assert!((refs.v_crit_mps.unwrap() - 34.75).abs() < 0.05);
    assert!(refs.v_fold_mps.unwrap() < refs.v_crit_mps.unwrap());
    let n_sway = cfg.sway_speeds.len() * cfg.sway_disturbances.len();
    let n_quiet = cfg.false_alarm_speeds.len() * cfg.false_alarm_disturbances.len();
    assert_eq!(r.scenarios.len(), n_sway + n_quiet);
    assert_eq!(r.assist.runs, n_sway + n_quiet);
    assert_eq!(r.assist.failed, 0);
    assert!(
        r.scenarios[..n_sway]
            .iter()
            .all(|s| s.set == ScenarioSet::Sway)
    );
    // above V_crit every disturbance sways without the assist
    let above = &r.scenarios[2 * cfg.sway_disturbances.len()..n_sway];
    assert!(above.iter().all(|s| s.without.as_ref().unwrap().sways));
    // the assist prevents losses of control
    assert!(r.assist.loss_of_control_with <= r.assist.loss_of_control_without);
    // every detector, then every detector behind the gate
    assert_eq!(r.detectors.len(), 4);
    for d in &r.detectors {
        let roc = &d.roc;
        assert_eq!(
            (roc[0].false_positive_rate, roc[0].true_positive_rate),
            (0.0, 0.0)
        );
        let last = roc.last().unwrap();
        assert_eq!(
            (last.false_positive_rate, last.true_positive_rate),
            (1.0, 1.0)
        );
        eprintln!("{d:?}");
    }
    eprintln!("{:?}", r.assist);
    assert!(r.sway_trace.is_some() && r.slalom_trace.is_some());
}

#[test]
fn roc_counts_runs_at_each_threshold() {
    // reference: by hand; two sway runs (0.5, 0.2), two quiet runs (0.3, never scored)
    let c = roc(&[Some(0.5), Some(0.2)], &[Some(0.3), None]);
    let points: Vec<(f64, f64)> = c
        .iter()
        .map(|p| (p.false_positive_rate, p.true_positive_rate))
        .collect();
    assert_eq!(
        points,
        vec![(0.0, 0.0), (0.0, 0.5), (0.5, 0.5), (0.5, 1.0), (1.0, 1.0)]
    );
}
