//! The sway assist's evaluation on Table I: the default (small) config's sets, the
//! metrics' bookkeeping, and the same numbers on one thread and on two.

use sway::assist::Disturbance;
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
    // every detector (the counter, the damping estimator, the observer), then every
    // detector behind the gate
    assert_eq!(r.detectors.len(), 6);
    assert_eq!(r.detectors[2].name, "model_observer");
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
    // the observer after 90 s of the false-alarm set's slaloms and lane changes (up to
    // 4 m/s²) at 0.7 V_crit with the default sensor noise. Reference: Table I's V_crit
    // 34.7479 m/s; issue 48's goal is within 5 % after at most 60 s. Measured with the
    // observer's brush tyres: 35.44 m/s (2.0 % high; trailer 1004 kg against 985 kg),
    // within 5 % from 12.9 s on.
    let o = &r.observer[0];
    eprintln!(
        "V̂_crit {:?} ± {:?}, V̂_fold {:?}, converged after {:?}, trailer {:?}",
        o.v_crit_estimate_mps,
        o.v_crit_sd_mps,
        o.v_fold_estimate_mps,
        o.converged_after_s,
        o.trailer_estimate
    );
    let v = o.v_crit_estimate_mps.unwrap();
    let err = (v - 34.7479).abs() / 34.7479;
    assert!(err < 0.05, "V̂_crit = {v} m/s, error {err}");
    assert!(o.converged_after_s.is_some_and(|t| t <= 60.0));
    assert!(o.v_fold_estimate_mps.is_some());
    assert!(o.manoeuvres >= 10);
    let track = o.track.as_ref().unwrap();
    assert_eq!(track.t.len(), track.v_crit_mps.len());
}

#[test]
fn the_observer_converges_in_moderate_driving() {
    // ordinary driving only (no scenario): the false-alarm set's slaloms and lane changes
    // at 1 m/s² of lateral acceleration, where the tyres are nearly linear
    let mut cfg = SwayAssistConfig {
        sway_speeds: Vec::new(),
        false_alarm_speeds: Vec::new(),
        ..SwayAssistConfig::default()
    };
    for d in &mut cfg.false_alarm_disturbances {
        match d {
            Disturbance::Slalom {
                lateral_acceleration_mps2,
                ..
            }
            | Disturbance::SingleLaneChange {
                lateral_acceleration_mps2,
                ..
            }
            | Disturbance::DoubleLaneChange {
                lateral_acceleration_mps2,
                ..
            } => *lateral_acceleration_mps2 = lateral_acceleration_mps2.min(1.0),
            _ => {}
        }
    }
    let one = on_threads(1, || {
        compute(&cfg, &table_i(), &SpeedLimits::default()).unwrap()
    });
    let two = on_threads(2, || {
        compute(&cfg, &table_i(), &SpeedLimits::default()).unwrap()
    });
    assert_eq!(one.observer, two.observer);
    let o = &one.observer[0];
    eprintln!(
        "V̂_crit {:?} ± {:?}, V̂_fold {:?}, converged after {:?}, trailer {:?}",
        o.v_crit_estimate_mps,
        o.v_crit_sd_mps,
        o.v_fold_estimate_mps,
        o.converged_after_s,
        o.trailer_estimate
    );
    // reference: Table I's V_crit 34.7479 m/s; measured 1.6 % high, within 5 % from 43 s
    // on, V_fold 2.5 % high
    let v = o.v_crit_estimate_mps.unwrap();
    assert!((v - 34.7479).abs() / 34.7479 < 0.05, "V̂_crit = {v} m/s");
    assert!(o.converged_after_s.is_some_and(|t| t <= 60.0));
    assert!(o.v_fold_error_rel.is_some_and(|e| e < 0.05));
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

#[test]
fn ordinary_driving_leaves_out_a_manoeuvre_that_alone_loses_control() {
    // reference: the full evaluation's false-alarm runs on Table I at 0.7 V_crit — alone,
    // the 0.4 Hz slalom at 4 m/s² (near the sway frequency) loses control within 5 s, the
    // 0.6 Hz slalom at 1 m/s² swings the trailer by a few degrees and decays. Ordinary
    // driving keeps only the second, names the first, and does not lose control
    let slalom = |f, a| Disturbance::Slalom {
        frequency_hz: f,
        lateral_acceleration_mps2: a,
        periods: 4.0,
    };
    let cfg = SwayAssistConfig {
        sway_speeds: Vec::new(),
        false_alarm_speeds: Vec::new(),
        false_alarm_disturbances: vec![slalom(0.4, 4.0), slalom(0.6, 1.0)],
        ordinary_driving_s: 30.0,
        ..SwayAssistConfig::default()
    };
    let r = compute(&cfg, &table_i(), &SpeedLimits::default()).unwrap();
    let o = &r.observer[0];
    assert_eq!(o.left_out, ["slalom 0.4 Hz 4 m/s²"], "{o:?}");
    assert!(o.manoeuvres >= 3, "{o:?}");
    let reason = o.reason.as_deref().unwrap_or("");
    assert!(reason.contains("left out of ordinary driving"), "{reason}");
    assert!(!reason.contains("lost control"), "{reason}");
    assert!(o.v_crit_estimate_mps.is_some(), "{o:?}");
}
