//! The mitigation pipeline on the sway cycle at 35 m/s: the period of the
//! cycle, the mirror symmetry behind the half-period phase placement, the lead-in history,
//! the penalty's ordering.

mod common;

use sway::mitigation::{
    Intervention, PhaseStarts, Setting, SwayCycle, cycle_state, evaluate, evaluate_unless_above,
    phase_cost, settled, sway_cycle,
};
use sway::sim::{
    ActuatorLimits, EarlyStop, Metrics, Outcome, RampShape, Recording, RunSettings, SimulateOwn,
    SolverSettings,
};
use sway_model::optimise::Bounded;
use trailer_model::Model;

fn cycle(model: &Model) -> SwayCycle {
    sway_cycle(model, 35.0, 0.1, 200.0, 20.0, &SolverSettings::default()).unwrap()
}

fn setting() -> Setting {
    Setting {
        speed_mps: 35.0,
        delay_s: 0.2,
        actuator: ActuatorLimits::NONE,
        horizon_s: 40.0,
        peak_limit_deg: 45.0,
        settings: RunSettings::default(),
    }
}

fn combined() -> Intervention {
    Intervention {
        speed_change_mps: -10.0,
        duration_s: 5.0,
        shape: RampShape::Linear,
        gain_s: 0.1,
        on_s: 0.0,
        off_s: None,
    }
}

#[test]
fn the_period_closes_the_cycle() {
    // reference: periodicity — one period after the anchor the state returns to it. The
    // crossing times are located to ≈ 1e-10 s and the cycle is attracting, so the residual
    // is at the solver's tolerance: < 1e-6 in every component (states of order 1)
    let model = common::model();
    let c = cycle(&model);
    let x = cycle_state(&model, &c, c.period_s, &SolverSettings::default()).unwrap();
    let err = (x - c.anchor).amax();
    assert!(err < 1e-6, "residual {err:e}, period {} s", c.period_s);
    // the anchor is an upward zero crossing of θ, and the sway is large
    assert!(c.anchor[3].abs() < 1e-9);
    assert!(
        c.amplitude_deg > 20.0 && c.amplitude_deg < 35.0,
        "{}",
        c.amplitude_deg
    );
}

#[test]
fn phases_half_a_period_apart_are_mirror_images() {
    // reference: the odd symmetry of the model, (σ, θ, δ) → −(σ, θ, δ). The run from
    // φ + ½ must have the settle time and peak of the run from φ, up to the solver's
    // tolerance: 1e-5 s and 1e-5 deg (measured ≈ 1e-6)
    let model = common::model();
    let c = cycle(&model);
    let starts = PhaseStarts::new(&model, &c, 6, 1.0, 0.2, &SolverSettings::default()).unwrap();
    let s = setting();
    let e = evaluate(&model, &s, &starts, &combined()).unwrap();
    for k in 0..3 {
        let (a, b) = (&e.phases[k], &e.phases[k + 3]);
        let (sa, sb) = (settled(a, &s).unwrap(), settled(b, &s).unwrap());
        assert!((sa - sb).abs() < 1e-5, "phase {k}: {sa} vs {sb}");
        let (pa, pb) = (
            a.peak_theta_deg_after_action.unwrap(),
            b.peak_theta_deg_after_action.unwrap(),
        );
        assert!((pa - pb).abs() < 1e-5, "phase {k}: {pa} vs {pb}");
        // and the start states are mirror images
        assert!((starts.states[k] + starts.states[k + 3]).amax() < 1e-6);
    }
}

#[test]
fn the_lead_in_runs_on_the_cycle() {
    // reference: the cycle itself — during the lead-in (controller off, constant V0) the
    // run must follow the open-loop cycle: at the intervention start its state equals the
    // cycle state at φ·P, computed independently from the anchor, to 1e-6
    let model = common::model();
    let c = cycle(&model);
    let solver = SolverSettings::default();
    let starts = PhaseStarts::new(&model, &c, 4, 1.0, 0.2, &solver).unwrap();
    let s = setting();
    let k = 1;
    let r = s
        .run(
            &model,
            &combined(),
            starts.states[k],
            starts.lead_in_s,
            Recording::Every { step_s: 0.1 },
        )
        .unwrap();
    let at_start = r
        .trajectory
        .iter()
        .find(|q| (q.t - 0.2).abs() < 1e-9)
        .unwrap();
    let expected = cycle_state(&model, &c, starts.phases[k] * c.period_s, &solver).unwrap();
    let got =
        trailer_model::State4::new(at_start.x[0], at_start.x[1], at_start.x[2], at_start.x[3]);
    assert!((got - expected).amax() < 1e-6, "{got} vs {expected}");
}

fn metrics(outcome: Outcome, settle: Option<f64>, final_amp: Option<f64>, peak: f64) -> Metrics {
    Metrics {
        peak_theta_deg_after_action: Some(peak),
        final_amplitude_deg: final_amp,
        settle_time_s: settle,
        outcome,
        loss_of_control_time_s: (outcome == Outcome::LossOfControl).then_some(10.2),
        loss_of_control_condition: None,
        class: match outcome {
            Outcome::LossOfControl => sway::sim::SwayClass::LossOfControl,
            Outcome::Ok if settle.is_some() => sway::sim::SwayClass::Settled,
            Outcome::Ok => sway::sim::SwayClass::SustainedSway,
        },
        decay_rate_per_s: None,
    }
}

#[test]
fn every_infeasible_phase_costs_more_than_every_feasible_one() {
    // reference: the penalty's definition (module docs), H = 40 s, lead-in 0.2 s
    let s = setting();
    let feasible = phase_cost(&metrics(Outcome::Ok, Some(39.0), Some(0.5), 30.0), 0.2, &s);
    assert_eq!(feasible, 39.0);
    // "settled" at the horizon's end but swaying in the final window: not settled
    let brief = metrics(Outcome::Ok, Some(39.9), Some(27.9), 27.9);
    assert_eq!(settled(&brief, &s), None);
    assert_eq!(phase_cost(&brief, 0.2, &s), 40.0 + 27.9);
    let peak = phase_cost(&metrics(Outcome::Ok, Some(10.0), Some(0.5), 46.0), 0.2, &s);
    assert_eq!(peak, 41.0);
    let lost = phase_cost(&metrics(Outcome::LossOfControl, None, None, 60.0), 0.2, &s);
    assert!((lost - (80.0 + 30.0 + 15.0)).abs() < 1e-12, "{lost}");
}

#[test]
fn evaluations_cut_short_agree_with_the_full_ones() {
    // reference: the full evaluation ([`evaluate`]) — below or at its cost the answer is
    // that cost bit for bit, above it `Above`; a run stopped early by a settle-time bound
    // settles later than the bound (or never) in its full run, a run not stopped has the
    // full run's metrics. Designs: the paper's combined strategy (settles after ≈ 13 s) and
    // no action at all (sways on, cost above the horizon).
    let model = common::model();
    let c = cycle(&model);
    let solver = SolverSettings::default();
    let starts = PhaseStarts::new(&model, &c, 4, 0.5, 0.2, &solver).unwrap();
    let s = setting();
    let idle = Intervention {
        speed_change_mps: 0.0,
        gain_s: 0.0,
        ..combined()
    };
    for iv in [combined(), idle] {
        let full = evaluate(&model, &s, &starts, &iv).unwrap();
        let e = full.cost;
        for cutoff in [e - 5.0, e - 0.5, e, e + 1.0, 1.5 * s.horizon_s] {
            let got = evaluate_unless_above(&model, &s, &starts, &iv, cutoff).unwrap();
            let expected = if e > cutoff {
                Bounded::Above
            } else {
                Bounded::Exact(e)
            };
            assert_eq!(got, expected, "cost {e}, cutoff {cutoff}");
        }
        // below the worst phase's settle time (or the horizon) its run stops; above the
        // cost none does
        for bound in [e.min(s.horizon_s) - 3.0, e + 1.0] {
            let mut stopped = Vec::new();
            for (k, x0) in starts.states.iter().enumerate() {
                let mut spec = s.spec(&iv, starts.lead_in_s);
                spec.early_stop = EarlyStop::SettleTimeAbove(bound);
                let r = model.simulate_own(&spec, *x0, Recording::None).unwrap();
                let settle = settled(&full.phases[k], &s);
                if r.stopped_early {
                    stopped.push(k);
                    assert!(r.t_end < spec.horizon_s);
                    assert!(settle.is_none_or(|t| t > bound), "phase {k}: {settle:?}");
                } else {
                    assert_eq!(r.metrics, full.phases[k], "phase {k}");
                }
            }
            if bound < e {
                assert!(stopped.contains(&full.worst_phase), "{stopped:?}");
            } else {
                assert!(stopped.is_empty(), "{stopped:?}");
            }
        }
    }
}
