//! Tests of the corner analysis on the vehicle model.

use super::*;
use std::sync::OnceLock;
use trailer_model::VehicleParams;

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
    // reference: crate::charts::critical_speed_at_gain, the fig4a computation (exact counts
    // of unstable roots on a 0.5 m/s scan, bisection to 1e-11 m/s) at the point's gain:
    // the corner of the stable region, required to 1e-8 m/s (the tolerance)
    let p = points(0.2);
    assert_eq!(p.len(), 1, "{p:?}");
    let p = p[0];
    assert_eq!(p.other_unstable_roots, 0, "{p:?}");
    let b = crate::charts::critical_speed_at_gain(
        model(),
        0.2,
        p.d_s,
        V_RANGE.0,
        V_RANGE.1,
        131,
        1e-11,
    )
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
