use sway::mitigation::*;
use sway::sim::*;
use trailer_model::{Model, VehicleParams};
fn main() {
    let model = Model::new(VehicleParams::default()).unwrap();
    let solver = SolverSettings::default();
    let cycle = sway_cycle(&model, 35.0, 0.1, 200.0, 20.0, &solver).unwrap();
    println!("{cycle:?}");
    let starts = PhaseStarts::new(&model, &cycle, 16, 0.2, &solver).unwrap();
    let setting = Setting { speed_mps: 35.0, delay_s: 0.2, actuator: ActuatorLimits::NONE, horizon_s: 40.0, peak_limit_deg: 45.0, settings: RunSettings::default() };
    for (name, dv, d) in [("none", 0.0, 0.0), ("steering", 0.0, 0.1), ("braking", -10.0, 0.0), ("combined", -10.0, 0.1)] {
        let iv = Intervention { speed_change_mps: dv, duration_s: 5.0, shape: RampShape::Linear, gain_s: d, on_s: 0.0, off_s: None };
        let t = std::time::Instant::now();
        let e = evaluate(&model, &setting, &starts, &iv).unwrap();
        let _ = name;
        println!("{name}: {:?} worst {:?} peak {:.1} lost {:?} costs {:?} ({:?})", e.cost, e.worst_settle_time_s, e.worst_peak_deg, e.lost_phases, e.costs.iter().map(|c| (c*10.0).round()/10.0).collect::<Vec<_>>(), t.elapsed());
    }
    let bounds = DecisionBounds { speed_change_mps: optimise::Bound::new(-10.0, 0.0), duration_s: optimise::Bound::new(0.5, 15.0), gain_s: optimise::Bound::new(0.0, 0.5), on_s: optimise::Bound::new(0.0, 5.0), on_duration_s: optimise::Bound::new(2.0, 40.0) };
    let mut setting2 = setting;
    setting2.settings.solver = SolverSettings { rtol: 1e-6, atol: 1e-8, ..solver };
    let problem = MitigationProblem { model: &model, setting: setting2, starts: &starts, bounds: bounds.to_array() };
    let comb = Intervention { speed_change_mps: -10.0, duration_s: 5.0, shape: RampShape::Linear, gain_s: 0.1, on_s: 0.0, off_s: None };
    let t = std::time::Instant::now();
    let o = optimise(&problem, &[comb], &optimise::OptimiserSettings::default()).unwrap();
    println!("{:?} evals {} in {:?}", o.intervention, o.minimum.evaluations, t.elapsed());
    for r in &o.minimum.runs { println!("  {} {} {:.3} {:?} {}", r.choice, r.start, r.cost, r.x.iter().map(|v| (v*1000.0).round()/1000.0).collect::<Vec<_>>(), r.evaluations); }
    let e = evaluate(&model, &setting, &starts, &o.intervention).unwrap();
    println!("verified: {:?} peak {}", e.worst_settle_time_s, e.worst_peak_deg);
}
#[allow(dead_code)]
fn unused() {}
