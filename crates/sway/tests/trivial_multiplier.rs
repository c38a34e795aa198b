//! The trivial Floquet multiplier of the sway cycles: every cycle of an
//! autonomous system has the multiplier 1 exactly; the collocation's approximation of it
//! measures the accuracy of the Floquet computation of the C¹ (kinked) trailer model.

use continuation::BranchPoint;
use sway::bifurcation::{DiagramOptions, LoopLaw, bifurcation_diagram};
use trailer_model::{Model, VehicleParams};

/// max |μ_trivial − 1| over the points of `points` at least `gap` m/s from `fold` (the
/// second multiplier near 1 there makes the trivial one ambiguous), and the number of
/// points checked
fn worst_trivial(points: &[BranchPoint], fold: Option<f64>, gap: f64) -> (f64, f64, usize) {
    let mut worst = (0.0f64, f64::NAN);
    let mut checked = 0;
    for p in points {
        if fold.is_some_and(|f| (p.parameter - f).abs() < gap) {
            continue;
        }
        let s = p
            .stability
            .as_ref()
            .expect("multipliers on every cycle point");
        let mu = s.trivial_multiplier().expect("a trivial multiplier");
        let d = (mu - 1.0).norm();
        if d > worst.0 {
            worst = (d, p.parameter);
        }
        checked += 1;
    }
    (worst.0, worst.1, checked)
}

fn check(feedback: LoopLaw, options: DiagramOptions) {
    let model = Model::new(VehicleParams::default()).expect("Table I model");
    let d = bifurcation_diagram(&model, feedback, &options).expect("diagram");
    let fold = d.fold.map(|f| f.speed_mps);
    // the first points next to the Hopf point have a second multiplier within ~1e-3 of 1
    // too; the branch is checked from 0.05 m/s off the Hopf speed and the fold
    let points: Vec<BranchPoint> = d
        .cycles
        .points
        .iter()
        .filter(|p| (p.parameter - d.hopf.parameter).abs() > 0.05)
        .cloned()
        .collect();
    let (worst, at, checked) = worst_trivial(&points, fold, 0.05);
    assert!(checked >= 10, "only {checked} cycles checked");
    assert!(
        worst <= 1e-6,
        "|mu_trivial - 1| = {worst:e} at V = {at} m/s"
    );
}

#[test]
fn trivial_multiplier_of_open_loop_sway_cycles_is_one() {
    // reference: exactly 1 (autonomous system); tolerance 1e-6, on the
    // fig3a branch with a coarser mesh (L = 20; fig3a uses 60): measured 7.3e-8
    check(
        LoopLaw::OPEN_LOOP,
        DiagramOptions {
            intervals: 20,
            max_cycle_points: 80,
            ..DiagramOptions::default()
        },
    );
}

#[test]
fn trivial_multiplier_of_delayed_closed_loop_sway_cycles_is_one() {
    // reference: exactly 1; tolerance 1e-6, on fig4b's delayed pair τ = 0.2 s, D = 0.1 s
    // with fig4b's mesh L = 40 (measured 1.6e-7; 3.6e-6 on L = 20, 2.5e-4 there with mesh
    // points at the switching times only, not at the kinks carried along the delay)
    check(
        LoopLaw::paper(0.1, 0.2),
        DiagramOptions {
            intervals: 40,
            max_cycle_points: 80,
            ..DiagramOptions::closed_loop()
        },
    );
}
