//! Tests of the corner analysis on the vehicle model.

use std::sync::OnceLock;
use sway::bifurcation::LoopLaw;
use sway::bifurcation::corners::motion::MotionClass;
use sway::bifurcation::corners::*;
use sway::charts::rightmost_roots;
use trailer_model::{Model, VehicleParams};

fn model() -> &'static Model {
    static M: OnceLock<Model> = OnceLock::new();
    M.get_or_init(|| Model::new(VehicleParams::default()).expect("Table I model"))
}

/// the nonlinear chart's box (configs/chart_nonlinear.toml)
const V_RANGE: (f64, f64) = (5.0, 70.0);
const D_RANGE: (f64, f64) = (-0.1, 0.3);

fn points(tau: f64) -> &'static [DoubleHopfPoint] {
    static P02: OnceLock<Vec<DoubleHopfPoint>> = OnceLock::new();
    static P04: OnceLock<Vec<DoubleHopfPoint>> = OnceLock::new();
    let cell = if tau == 0.2 { &P02 } else { &P04 };
    cell.get_or_init(|| double_hopf_points(model(), tau, V_RANGE, D_RANGE, 131).unwrap())
}

#[test]
fn double_hopf_point_lies_on_the_fig4a_dynamic_boundary() {
    // reference: sway::charts::critical_speed_at_gain, the fig4a computation (exact counts
    // of unstable roots on a 0.5 m/s scan, bisection to 1e-11 m/s) at the point's gain:
    // the corner of the stable region, required to 1e-8 m/s (the tolerance)
    let p = points(0.2);
    assert_eq!(p.len(), 1, "{p:?}");
    let p = p[0];
    assert_eq!(p.other_unstable_roots, 0, "{p:?}");
    let b =
        sway::charts::critical_speed_at_gain(model(), 0.2, p.d_s, V_RANGE.0, V_RANGE.1, 131, 1e-11)
            .unwrap()
            .expect("unstable somewhere");
    assert!((b - p.v_mps).abs() < 1e-8, "{} vs fig4a {b}", p.v_mps);
    // reference: the rightmost-root finder (Chebyshev seeds, Newton on eq. 13): both
    // pairs on the imaginary axis to 1e-8
    assert!(p.critical_real_part < 1e-8, "{p:?}");
}

#[test]
fn double_hopf_point_agrees_with_the_hopf_curve_continuation() {
    // reference: the double-Hopf point the chart's Hopf-curve continuation located with its
    // test function (chart_nonlinear at τ = 0.2 s: D = 0.26349469435275547 s,
    // V = 63.45977414572072 m/s, ω = 3.9402025147492745 / 9.270505224283449 rad/s), an
    // independent formulation (extended system on the DDE, Chebyshev roots); required
    // 1e-6 relative (the continuation's Newton tolerance)
    let p = points(0.2)[0];
    let close = |a: f64, b: f64| (a - b).abs() < 1e-6 * b.abs();
    assert!(close(p.d_s, 0.26349469435275547), "{p:?}");
    assert!(close(p.v_mps, 63.45977414572072), "{p:?}");
    assert!(close(p.omega1_rad_s, 3.9402025147492745), "{p:?}");
    assert!(close(p.omega2_rad_s, 9.270505224283449), "{p:?}");
    assert!((p.ratio - p.omega2_rad_s / p.omega1_rad_s).abs() < 1e-15);
}

#[test]
fn no_double_hopf_point_in_the_chart_range_at_tau_0_4() {
    // reference: the rightmost roots at the tip of the τ = 0.4 s Hopf curve (D ≈ 0.148 s,
    // V ≈ 60.15 m/s, where the boundary turns back): a single critical pair there, i.e.
    // the sharp tip is a turning Hopf curve and not a crossing of two curves; the points
    // beyond the range (D < −0.1 s, where fig4a's τ = 0.4 s panel shows crossing
    // boundaries) are genuine double-Hopf points (both pairs on the axis to 1e-8)
    assert!(points(0.4).is_empty(), "{:?}", points(0.4));
    let roots = rightmost_roots(model(), 60.1487, 0.14843, 0.4, 8).unwrap();
    let near_axis = roots
        .iter()
        .filter(|r| r.im > 0.0 && r.re.abs() < 0.05)
        .count();
    assert_eq!(near_axis, 1, "{roots:?}");
    let beyond = double_hopf_points(model(), 0.4, V_RANGE, (-0.5, 0.5), 131).unwrap();
    assert!(!beyond.is_empty());
    for p in &beyond {
        assert!(p.d_s < D_RANGE.0 || p.d_s > D_RANGE.1, "{p:?}");
        assert!(p.critical_real_part < 1e-8, "{p:?}");
    }
}

#[test]
fn probe_points_lie_one_in_each_region() {
    // reference: the linear chart's region of each probe (exact unstable-root count at the
    // point): the four sectors around the corner are the four combinations of the two
    // modes' stability, so the probes at one radius see 0, 1, 1 and 2 unstable pairs
    let p = points(0.2)[0];
    let o = CornerOptions {
        probe_radii: vec![0.3],
        ..CornerOptions::default()
    };
    let probes = probe_points(&p, &o);
    assert_eq!(probes.len(), 4);
    let mut counts: Vec<usize> = probes
        .iter()
        .map(|&(v, d)| unstable_modes(model(), 0.2, v, d).unwrap().len())
        .collect();
    counts.sort_unstable();
    assert_eq!(counts, vec![0, 1, 1, 2], "{probes:?}");
}

#[test]
fn quasi_periodic_classification_agrees_with_the_torus_curve() {
    // reference: the torus curve T2 of the ω2 ≈ 9.27 rad/s cycles continued from the
    // double-Hopf point at τ = 0.2 s (continuation::TorusCurveSystem; L = 30 and L = 60
    // meshes agree to 1.1e-5 s in D over the zoom window, here L = 16 for speed), taken
    // ≈ 6 m/s below V_HH where the band between the ω2 Hopf curve and T2 is wide. Below
    // T2 the cycle is attracting (no multiplier outside the unit circle besides the
    // critical pair, checked), above it the ω1 ≈ 3.8 rad/s mode grows on it.
    // δ: the classifier sees a transverse mode decay or grow only if its amplitude
    // changes by the factor decay_ratio = 0.8 / growth_ratio = 1.25 between the window
    // halves (100 s apart): |σ| > ln(1.25)/100 s = 2.2e-3 1/s; the rate measured in long
    // simulations at V = 57.46 m/s is |σ| ≈ 1.06 1/s² · |D − D_T2| (0.0453° → 0.0048° in
    // 400 s at 0.0053 s below T2), so |D − D_T2| > 2.1e-3 s is needed; δ = 4e-3 s is twice
    // that and ≫ the curve's mesh error (≤ 1e-4 s at L = 16). Tolerance: the class itself.
    let p = points(0.2)[0];
    let fb = LoopLaw::paper(p.d_s, p.tau_s);
    let problem = sway::bifurcation::ClosedLoop::new(model(), fb);
    let o = TorusContinuation {
        intervals: 16,
        max_step: 2.0,
        max_points: 40,
        back_points: 0,
        ..TorusContinuation::default()
    };
    let window = [p.v_mps - 6.0, p.v_mps + 1.0, p.d_s - 0.1, p.d_s + 0.1];
    let t2 = torus_curve(&problem, &p, 1, window, &o).expect("T2 continued");
    let q = *t2.points.last().expect("points");
    assert!(q.v_mps < p.v_mps - 5.0, "{:?}", t2.stop);
    assert_eq!(q.other_unstable_multipliers, Some(0), "{q:?}");
    let delta = 4e-3;
    let opts = CornerOptions::default();
    let class = |d: f64| {
        let mut o = opts.clone();
        o.simulation.kicks_deg = vec![0.0];
        let r = run_from(model(), p.tau_s, q.v_mps, d, q.cycle_state, &o).expect("simulation");
        (r.evidence.class, r.evidence)
    };
    let (outside, e_out) = class(q.d_s - delta);
    let (inside, e_in) = class(q.d_s + delta);
    assert_eq!(
        outside,
        MotionClass::Periodic,
        "D = {} s: {e_out:?}",
        q.d_s - delta
    );
    assert_eq!(
        inside,
        MotionClass::QuasiPeriodic,
        "D = {} s: {e_in:?}",
        q.d_s + delta
    );
}
