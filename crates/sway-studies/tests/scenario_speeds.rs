//! Scenario speeds relative to the vehicle: parsing of a speed in a
//! scenario, sweep and mitigation config, its resolution for Table I (the shipped factors
//! give the paper's speeds), the outcome for a vehicle without a reference, and a scenario
//! that resolves to a nose-heavy trailer's own speeds.

use std::path::Path;

use sway::ranging::{SpeedLimits, SpeedReferences, SpeedSpec, resolve_speeds};
use sway::sim::speeds::{ResolveSpeeds, resolve_against};
use sway::sim::{
    InitialCondition, Outcome, Recording, ScenarioConfig, SimSpec, SpeedProfile, simulate,
};
use sway_studies::mitigation::MitigationConfig;
use sway_studies::sweep::SweepConfig;
use trailer_model::{CriticalSpeedOptions, Model, State4, VehicleParams};

/// Table I's open-loop critical speed as committed in results/linear/summary.json.
const TABLE1_V_CRIT: f64 = 34.747923362676374;

fn configs() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs")
}

fn scenario(speed: &str) -> Result<ScenarioConfig<SpeedSpec>, toml::de::Error> {
    toml::from_str(&format!(
        "name = \"t\"\nspeed = {speed}\ninitial = {{ kind = \"state\", theta0_deg = 1.0 }}\n"
    ))
}

#[test]
fn a_speed_is_a_number_or_a_table_relative_to_the_vehicle() {
    // reference: the three forms of the plan (a number wins; of_v_crit; in_bistable)
    let c = scenario("{ kind = \"constant\", speed_mps = 33.0 }").unwrap();
    assert_eq!(
        c.speed,
        SpeedProfile::Constant {
            speed_mps: SpeedSpec::Absolute(33.0)
        }
    );
    let refs = SpeedReferences {
        v_crit_mps: Some(40.0),
        v_fold_mps: Some(30.0),
        reason: None,
    };
    for (text, expected) in [
        ("{ kind = \"constant\", speed_mps = 33.0 }", 33.0),
        (
            "{ kind = \"constant\", speed_mps = { of_v_crit = 0.5 } }",
            20.0,
        ),
        (
            "{ kind = \"constant\", speed_mps = { in_bistable = 0.25 } }",
            32.5,
        ),
    ] {
        let c = scenario(text).unwrap();
        let r = resolve_against(&refs, &c).outcome.unwrap();
        assert_eq!(r.speed.initial_speed(), expected, "{text}");
    }
    // an unknown key of the table is an error that names it
    let e = scenario("{ kind = \"constant\", speed_mps = { of_vcrit = 0.5 } }")
        .unwrap_err()
        .to_string();
    assert!(e.contains("of_vcrit"), "{e}");
}

#[test]
fn shipped_relative_speeds_are_the_papers_speeds_for_table1() {
    // reference: the paper's speeds (Fig. 3b, 4c: V0 = 35 m/s, ΔV = −10 m/s; mitigation:
    // floor 25 m/s), tolerance 1e-12 relative (the factors are written so that f·V_crit
    // rounds to them)
    let model = Model::new(VehicleParams::default()).unwrap();
    let limits = SpeedLimits::default();
    let text = std::fs::read_to_string(configs().join("mitigation.toml")).unwrap();
    let cfg: MitigationConfig<SpeedSpec> = toml::from_str(&text).unwrap();
    let r = resolve_speeds(&model, &limits, &cfg).unwrap();
    assert_eq!(r.references.v_crit_mps, Some(TABLE1_V_CRIT));
    let m = r.outcome.unwrap();
    for (got, want) in [
        (m.start.speed_mps, 35.0),
        (m.min_final_speed_mps, 25.0),
        (m.paper.speed_change_mps, -10.0),
    ] {
        assert!((got - want).abs() <= 1e-12 * want.abs(), "{got} vs {want}");
    }
    let text = std::fs::read_to_string(configs().join("scenario_example.toml")).unwrap();
    let cfg: ScenarioConfig<SpeedSpec> = toml::from_str(&text).unwrap();
    let s = resolve_speeds(&model, &limits, &cfg)
        .unwrap()
        .outcome
        .unwrap();
    assert!((s.speed.initial_speed() - 35.0).abs() < 35e-12);
    match s.initial {
        InitialCondition::SwayCycle { speed_mps, .. } => {
            assert!((speed_mps - 35.0).abs() < 35e-12)
        }
        other => panic!("{other:?}"),
    }
    // the brake-timing map: from the sway cycle at 35 m/s, ΔV = −10 m/s
    let text = std::fs::read_to_string(configs().join("sweep_brake_timing.toml")).unwrap();
    let cfg: SweepConfig<SpeedSpec> = toml::from_str(&text).unwrap();
    let s = resolve_speeds(&model, &limits, &cfg)
        .unwrap()
        .outcome
        .unwrap();
    assert!((s.base.speed.initial_speed() - 35.0).abs() < 35e-12);
    assert!((s.base.speed.min_speed(40.0) - 25.0).abs() < 25e-12);
}

#[test]
fn in_bistable_is_affine_between_the_fold_and_v_crit() {
    // reference: Table I's V_crit and fold (results/linear, results/fig3a); f = 0 at the
    // fold, 1 at V_crit, (33 − V_fold)/(V_crit − V_fold) at 33 m/s; 1e-12 relative
    let (vc, vf) = (TABLE1_V_CRIT, 31.52274092031792);
    let refs = SpeedReferences {
        v_crit_mps: Some(vc),
        v_fold_mps: Some(vf),
        reason: None,
    };
    let f = (33.0 - vf) / (vc - vf);
    for (factor, want) in [(0.0, vf), (1.0, vc), (f, 33.0)] {
        let c = scenario(&format!(
            "{{ kind = \"constant\", speed_mps = {{ in_bistable = {factor:?} }} }}"
        ))
        .unwrap();
        let v = resolve_against(&refs, &c)
            .outcome
            .unwrap()
            .speed
            .initial_speed();
        assert!((v - want).abs() <= 1e-12 * want, "{factor}: {v} vs {want}");
    }
}

/// Table I with a trailer whose centre of gravity is ahead of its axle by 1.6 m (h = 1.2 m,
/// l = 2.8 m): straight running is stable at every speed up to 100 m/s.
fn stable_vehicle() -> VehicleParams {
    let mut p = VehicleParams::default();
    p.trailer.cog = 1.2;
    p
}

#[test]
fn a_vehicle_without_v_crit_is_an_outcome_with_a_reason() {
    // reference: the eigenvalue scan of trailer_model (no sign change up to 100 m/s)
    let model = Model::new(stable_vehicle()).unwrap();
    assert!(
        model
            .critical_speed(&CriticalSpeedOptions::default())
            .is_err()
    );
    let c = scenario("{ kind = \"constant\", speed_mps = { of_v_crit = 1.0 } }").unwrap();
    let r = resolve_speeds(&model, &SpeedLimits::default(), &c).unwrap();
    assert_eq!(r.references.v_crit_mps, None);
    let u = r.outcome.unwrap_err();
    assert_eq!(u.key, "speed.speed_mps");
    assert!(u.reason.contains("speed.speed_mps"), "{}", u.reason);
    // a number still resolves, without computing a reference
    let c = scenario("{ kind = \"constant\", speed_mps = 30.0 }").unwrap();
    let r = resolve_speeds(&model, &SpeedLimits::default(), &c).unwrap();
    assert_eq!(r.references, SpeedReferences::default());
    assert_eq!(r.outcome.unwrap().speed.initial_speed(), 30.0);
}

#[test]
fn a_nose_heavy_trailer_resolves_to_its_own_speeds_and_runs() {
    // reference: the nose-heavy trailer's own V_crit from trailer_model's scan (1e-12
    // relative), and the linear stability it implies: 0.9·V_crit decays from θ(0) = 1°,
    // 1.1·V_crit grows
    let mut p = VehicleParams::default();
    p.trailer.cog = 2.5;
    let model = Model::new(p).unwrap();
    let vc = model
        .critical_speed(&CriticalSpeedOptions::default())
        .unwrap()
        .v_crit_mps;
    assert!(vc > TABLE1_V_CRIT + 5.0, "{vc}");
    let limits = SpeedLimits::default();
    for (factor, grows) in [(0.9, false), (1.1, true)] {
        let c = scenario(&format!(
            "{{ kind = \"constant\", speed_mps = {{ of_v_crit = {factor} }} }}"
        ))
        .unwrap();
        let s = resolve_speeds(&model, &limits, &c)
            .unwrap()
            .outcome
            .unwrap();
        let v = s.speed.initial_speed();
        assert!(
            (v - factor * vc).abs() <= 1e-12 * v,
            "{v} vs {}",
            factor * vc
        );
        let spec = SimSpec {
            early_stop: sway::sim::EarlyStop::Never,
            steering: Default::default(),
            profile: s.speed.clone(),
            controller: None,
            horizon_s: 20.0,
            action_s: 0.0,
            settings: s.settings,
        };
        let x0 = State4::new(0.0, 0.0, 0.0, 1f64.to_radians());
        let r = simulate(&model, &spec, x0, Recording::None).unwrap();
        let peak_late = r.metrics.final_amplitude_deg.unwrap_or(f64::INFINITY);
        if grows {
            assert!(
                r.metrics.outcome == Outcome::LossOfControl || peak_late > 1.0,
                "{factor}: {:?}",
                r.metrics
            );
        } else {
            assert!(peak_late < 1.0, "{factor}: {:?}", r.metrics);
        }
    }
}

#[test]
fn only_speed_axes_are_relative_and_not_with_a_fleet() {
    // reference: the sweep file's rules (validate_spec), errors naming the key
    let file = Path::new("sweep.toml");
    let base = "[base]\nspeed = { kind = \"constant\", speed_mps = 30.0 }\ninitial = { kind = \"state\" }\n";
    let cfg: SweepConfig<SpeedSpec> = toml::from_str(&format!(
        "name = \"s\"\n[[axes]]\nparameter = \"gain_s\"\nmin = {{ of_v_crit = 0.1 }}\nmax = 0.2\npoints = 3\n{base}"
    ))
    .unwrap();
    let e = cfg.validate_spec(file).unwrap_err().to_string();
    assert!(e.contains("`axes[0]`"), "{e}");
    let cfg: SweepConfig<SpeedSpec> = toml::from_str(&format!(
        "name = \"s\"\n[[axes]]\nparameter = \"speed_mps\"\nmin = {{ of_v_crit = 0.75 }}\nmax = {{ of_v_crit = 1.25 }}\npoints = 3\n{base}"
    ))
    .unwrap();
    cfg.validate_spec(file).unwrap();
    assert!(cfg.all_numbers().is_none());
    let refs = SpeedReferences {
        v_crit_mps: Some(40.0),
        v_fold_mps: None,
        reason: None,
    };
    let r = resolve_against(&refs, &cfg).outcome.unwrap();
    assert_eq!(r.axes[0].values(), vec![30.0, 40.0, 50.0]);
    r.validate(file).unwrap();
}
