//! Tests of the nonlinear chart on the vehicle model.

use super::*;
use std::sync::OnceLock;
use trailer_model::VehicleParams;

fn model() -> &'static Model {
    static M: OnceLock<Model> = OnceLock::new();
    M.get_or_init(|| Model::new(VehicleParams::default()).expect("Table I model"))
}

#[test]
#[ignore = "exploration"]
fn explore() {
    let tau: f64 = std::env::var("TAU")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.2);
    let o = ChartOptions::default();
    let t0 = std::time::Instant::now();
    let c = nonlinear_chart(model(), tau, &o).unwrap();
    eprintln!("τ = {tau}: {:.2} s", t0.elapsed().as_secs_f64());
    for h in &c.hopf_curves {
        eprintln!(
            "Hopf curve seed {} : {} points ({} + {}), D {:?} .. {:?}",
            h.seed_d_s,
            h.points.len(),
            h.branches[0].points.len(),
            h.branches[1].points.len(),
            h.points.first(),
            h.points.last()
        );
        for b in &h.branches {
            let v: Vec<String> = b
                .points
                .iter()
                .step_by(8)
                .map(|p| {
                    format!(
                        "({:.4},{:.2},{:.2})",
                        p.u[HOPF_D], p.u[HOPF_V], p.u[HOPF_OMEGA]
                    )
                })
                .collect();
            eprintln!("  {}", v.join(" "));
        }
        for s in &h.criticality {
            eprintln!("   {:?}", s);
        }
    }
    for f in &c.fold_curves {
        eprintln!(
            "fold curve: {} points, {:?} .. {:?}",
            f.points.len(),
            f.points.first(),
            f.points.last()
        );
    }
    for p in &c.codim2_points {
        eprintln!("{p:?}");
    }
    for n in &c.notes {
        eprintln!("note: {n}");
    }
    for d in [0.0, 0.05, 0.1, 0.15, 0.2, 0.25] {
        eprintln!(
            "D = {d}: hopf {:?} fold {:?}",
            c.hopf_speed_at(model(), d).unwrap(),
            c.fold_speed_at(model(), d).unwrap()
        );
    }
    eprintln!("total {:.2} s", t0.elapsed().as_secs_f64());
}
