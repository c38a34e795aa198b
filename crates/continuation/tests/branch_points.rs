//! Branch points (pitchfork, transcritical) on equilibrium branches, branch switching,
//! singular points met on Hopf curves (zero-Hopf points of symmetric systems), and
//! observers of the continuation.
use continuation::*;
use continuation_textbook::{Neuron, Pitchfork};

/// The delayed pair of the nonlinear chart's tests:
/// x1' = −x1/2 − tanh x1(t−1.5) + tanh x2(t−0.2),
/// x2' = −x2/2 − tanh x2(t−1.5) + a·tanh x1(t−0.2), p = [a].
#[derive(Debug)]
struct TanhPair;

fn sech2(x: f64) -> f64 {
    1.0 - x.tanh().powi(2)
}

impl Problem for TanhPair {
    fn dim(&self) -> usize {
        2
    }
    fn n_delays(&self) -> usize {
        2
    }
    fn delay(&self, j: usize, _p: &[f64]) -> f64 {
        [1.5, 0.2][j]
    }
    // args = [x(t), x(t − 1.5), x(t − 0.2)]
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        f[0] = -x[0] / 2.0 - x[2].tanh() + x[5].tanh();
        f[1] = -x[1] / 2.0 - x[3].tanh() + p[0] * x[4].tanh();
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        j.iter_mut().for_each(|v| *v = 0.0);
        j[0] = -0.5;
        j[2] = -sech2(x[2]);
        j[5] = sech2(x[5]);
        j[6 + 1] = -0.5;
        j[6 + 3] = -sech2(x[3]);
        j[6 + 4] = p[0] * sech2(x[4]);
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
        out[0] = 0.0;
        out[1] = x[4].tanh();
    }
}

/// x' = p·x − x²: transcritical bifurcation at (x, p) = (0, 0), branches x = 0 and x = p.
#[derive(Debug)]
struct Transcritical;

impl Problem for Transcritical {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, x: &[f64], p: &[f64], f: &mut [f64]) {
        f[0] = p[0] * x[0] - x[0] * x[0];
    }
    fn jacobian(&self, x: &[f64], p: &[f64], j: &mut [f64]) {
        j[0] = p[0] - 2.0 * x[0];
    }
    fn dfdp(&self, x: &[f64], _p: &[f64], _ip: usize, out: &mut [f64]) {
        out[0] = x[0];
    }
}

fn cont(step: f64, max_step: f64, range: (f64, f64)) -> Continuation {
    Continuation::new(ContinuationOptions {
        initial_step: step,
        max_step,
        parameter_range: range,
        ..Default::default()
    })
}

/// the equilibrium system of `problem` in its one parameter and the branch started with `c`
/// at the unknowns `u0` (x, then the parameter), towards larger values
fn started<'a, P: Problem>(
    c: &Continuation,
    problem: &'a P,
    u0: &[f64],
) -> (EquilibriumSystem<'a, P, ChebyshevRoots>, Branch) {
    let p = vec![u0[u0.len() - 1]];
    let mut eq = EquilibriumSystem::new(problem, p, 0, ChebyshevRoots::default()).expect("system");
    let dir = eq.parameter_direction();
    let br = c.start(&mut eq, u0, &dir).expect("start");
    (eq, br)
}

/// the trivial branch x = 0 of the tanh pair from a = 0.5, 40 steps of up to 0.25 towards
/// a = 3 (through the branch point): the continuation, the system, the branch and why it
/// stopped
fn tanh_pair_from_zero() -> (
    Continuation,
    EquilibriumSystem<'static, TanhPair, ChebyshevRoots>,
    Branch,
    Stop,
) {
    let c = cont(0.1, 0.25, (0.0, 3.0));
    let (mut eq, mut br) = started(&c, &TanhPair, &[0.0, 0.0, 0.5]);
    let stop = c
        .extend(&mut eq, &mut br, 40)
        .expect("the engine passes the branch point");
    (c, eq, br, stop)
}

#[test]
fn tanh_pair_branch_point_at_a_9_over_4_is_located_and_passed() {
    // reference: at x = 0 the characteristic matrix at λ = 0 is
    // Δ(0) = −A0 − A1 − A2 = [[1/2 + 1, −1], [−a, 1/2 + 1]], det Δ(0) = 9/4 − a, so a zero
    // root appears at a = 2.25 exactly (and x = 0 stays an equilibrium: a branch point).
    // Location tolerance 1e-10 on the parameter; required 1e-8.
    let (_, _, br, stop) = tanh_pair_from_zero();
    assert_eq!(stop, Stop::ParameterRange);
    let (i, bp) = br.first(SpecialKind::BranchPoint).expect("branch point");
    assert_eq!(bp.location, Location::Located);
    assert!(
        (bp.parameter - 2.25).abs() < 1e-8,
        "branch point at a = {}",
        bp.parameter
    );
    // the zero root is there (polished characteristic roots, 1e-6: the point is 1e-10 off)
    let critical = bp.critical.expect("critical root");
    assert!(critical.norm() < 1e-6, "critical root {critical}");
    // the branch goes on past it, still on x = 0
    assert!(br.points[i + 1..].iter().any(|p| p.parameter > 2.5));
    assert!(
        br.points
            .iter()
            .all(|p| p.u[0].abs() < 1e-12 && p.u[1].abs() < 1e-12)
    );
    assert_eq!(
        br.special_points()
            .filter(|(_, s)| s.kind == SpecialKind::BranchPoint)
            .count(),
        1
    );
}

/// the nontrivial equilibria of the tanh pair parametrised by x1 (closed form):
/// tanh x2 = x1/2 + tanh x1, a = (x2/2 + tanh x2)/tanh x1
fn tanh_pair_branch(x1: f64) -> (f64, f64) {
    let x2 = (x1 / 2.0 + x1.tanh()).atanh();
    (x2, (x2 / 2.0 + x2.tanh()) / x1.tanh())
}

#[test]
fn switching_at_the_tanh_pair_branch_point_follows_the_pitchfork() {
    // reference: the closed-form nontrivial branch (tanh_pair_branch), a → 9/4 as x1 → 0;
    // Newton tolerance 1e-10, required 1e-9
    let (c, mut eq, br, _) = tanh_pair_from_zero();
    let (i, _) = br.first(SpecialKind::BranchPoint).expect("branch point");
    let phi = c
        .branch_direction(&mut eq, &br.points[i])
        .expect("direction");
    // null vector of [[−3/2, 1], [9/4, −3/2]]: (2, 3)/√13, no parameter component
    let s13 = 13f64.sqrt();
    assert!((phi[0] - 2.0 / s13).abs() < 1e-6 && (phi[1] - 3.0 / s13).abs() < 1e-6);
    assert!(phi[2].abs() < 1e-6, "{phi:?}");
    for side in [1.0, -1.0] {
        let c = cont(0.05, 0.1, (0.0, 2.6));
        let mut other = c
            .switch_branch(&mut eq, &br.points[i], side * 0.05)
            .expect("switch");
        c.extend(&mut eq, &mut other, 10)
            .expect("extend the new branch");
        assert!(other.points.len() > 5);
        for p in &other.points {
            assert!(p.u[0] * side > 0.0, "on the side chosen");
            let (x2, a) = tanh_pair_branch(p.u[0]);
            assert!((p.u[1] - x2).abs() < 1e-9, "x2 {} vs {x2}", p.u[1]);
            assert!((p.parameter - a).abs() < 1e-9, "a {} vs {a}", p.parameter);
        }
    }
}

#[test]
fn transcritical_branch_point_and_switch_onto_x_equals_p() {
    // reference: x' = p x − x² has the branches x = 0 and x = p crossing at p = 0;
    // location tolerance 1e-10 (required 1e-8), Newton tolerance 1e-10 (required 1e-9)
    let c = cont(0.1, 0.2, (-1.0, 1.0));
    let (mut eq, mut br) = started(&c, &Transcritical, &[0.0, -1.0]);
    let stop = c.extend(&mut eq, &mut br, 30).expect("extend");
    assert_eq!(stop, Stop::ParameterRange);
    let (i, bp) = br.first(SpecialKind::BranchPoint).expect("branch point");
    assert!(
        bp.parameter.abs() < 1e-8,
        "branch point at p = {}: {bp:?} {:?}",
        bp.parameter,
        br.points.iter().map(|p| p.parameter).collect::<Vec<_>>()
    );
    // stable before (eigenvalue p < 0), unstable after
    assert_eq!(br.points[i - 1].is_stable(), Some(true));
    assert_eq!(br.points[i + 1].is_stable(), Some(false));
    let mut other = c
        .switch_branch(&mut eq, &br.points[i], -0.1)
        .expect("switch");
    c.extend(&mut eq, &mut other, 20).expect("extend");
    assert!(other.points.last().expect("points").parameter < -0.5);
    for p in &other.points {
        assert!(
            (p.u[0] - p.parameter).abs() < 1e-9,
            "x = {} at p = {}",
            p.u[0],
            p.parameter
        );
    }
}

#[test]
fn observer_sees_every_point_and_can_stop_the_run() {
    // reference: counting (one call per added point), the stop rule's threshold, and the
    // checkpoint being the branch itself
    let c = cont(0.1, 0.2, (-1.0, 1.0));
    let (mut eq, start) = started(&c, &Transcritical, &[0.0, -1.0]);

    // progress: one call per added point, the new point last
    let mut br = start.clone();
    let mut seen = Vec::new();
    let mut progress = |b: &Branch| {
        seen.push((b.points.len(), b.points.last().map(|p| p.parameter)));
        Decision::Continue
    };
    let stop = c
        .extend_observed(&mut eq, &mut br, 8, &mut progress)
        .expect("extend");
    assert_eq!(stop, Stop::MaxPoints);
    assert_eq!(seen.len(), br.points.len() - 1);
    for (k, (len, p)) in seen.iter().enumerate() {
        assert_eq!(*len, k + 2);
        assert_eq!(*p, Some(br.points[k + 1].parameter));
    }
    // without an observer: the same branch
    let mut plain = start.clone();
    c.extend(&mut eq, &mut plain, 8).expect("extend");
    assert_eq!(plain, br);

    // user stop rule with a checkpoint: stop past p = 0.3
    let mut br = start.clone();
    let mut checkpoint = String::new();
    let mut rule = |b: &Branch| {
        checkpoint = serde_json::to_string(b).expect("serialise");
        if b.points.last().is_some_and(|p| p.parameter > 0.3) {
            Decision::Stop
        } else {
            Decision::Continue
        }
    };
    let stop = c
        .extend_observed(&mut eq, &mut br, 100, &mut rule)
        .expect("extend");
    assert_eq!(stop, Stop::Observer);
    let n = br.points.len();
    assert!(br.points[n - 1].parameter > 0.3 && br.points[n - 2].parameter <= 0.3);
    let restored: Branch = serde_json::from_str(&checkpoint).expect("deserialise");
    assert_eq!(restored, br);
}

#[test]
fn newton_step_is_the_bordered_newton_update() {
    // reference: for x' = p x − x² at (x, p) with the border (0, 1) (p fixed), the Newton
    // update is Δx = −(p x − x²)/(p − 2x), Δp = 0 (exact arithmetic, 1e-15)
    let mut eq = EquilibriumSystem::new(&Transcritical, vec![0.5], 0, ChebyshevRoots::default())
        .expect("system");
    let (x, p) = (0.3, 0.5);
    let du = newton_step(&mut eq, &[x, p], &[0.0, 1.0]).expect("step");
    let expected = -(p * x - x * x) / (p - 2.0 * x);
    assert!(
        (du[0] - expected).abs() < 1e-15 && du[1].abs() < 1e-15,
        "{du:?}"
    );
}

#[test]
fn options_saved_before_branch_points_existed_still_load() {
    // reference: serde default — a serialised ContinuationOptions without the
    // `branch_points` field loads with the test switched on (the default)
    // (a finite range: JSON has no infinities)
    let options = ContinuationOptions {
        parameter_range: (-1.0, 1.0),
        ..Default::default()
    };
    let mut json: serde_json::Value = serde_json::to_value(&options).expect("serialise");
    json.as_object_mut()
        .expect("object")
        .remove("branch_points");
    let o: ContinuationOptions = serde_json::from_value(json).expect("deserialise");
    assert!(o.branch_points);
    assert_eq!(o, options);
}

#[test]
fn pitchfork_of_the_symmetric_cubic_is_named_and_switched_onto_both_halves() {
    // reference: x' = μx − x³ (textbook::Pitchfork): the trivial branch x = 0 has a branch
    // point at μ = 0 exactly (the system is odd in x) and the crossing branches are
    // x = ±√μ. Location tolerance 1e-10 (required 1e-8); Newton tolerance 1e-10 (required
    // 1e-9 on the closed form).
    let c = cont(0.1, 0.2, (-0.5, 0.5));
    let (mut eq, mut br) = started(&c, &Pitchfork, &[0.0, -0.5]);
    let stop = c
        .extend(&mut eq, &mut br, 30)
        .expect("the branch passes the pitchfork");
    assert_eq!(stop, Stop::ParameterRange);
    let (i, bp) = br
        .first(SpecialKind::BranchPoint)
        .expect("branch point named");
    assert_eq!(bp.location, Location::Located);
    assert!(
        bp.parameter.abs() < 1e-8,
        "branch point at μ = {}",
        bp.parameter
    );
    assert_eq!(br.points[i - 1].is_stable(), Some(true));
    assert_eq!(br.points[i + 1].is_stable(), Some(false));
    assert!(
        br.points.iter().all(|p| p.u[0] == 0.0),
        "the trivial branch stays x = 0"
    );
    for side in [1.0, -1.0] {
        let mut half = c
            .switch_branch(&mut eq, &br.points[i], side * 0.05)
            .expect("switch");
        c.extend(&mut eq, &mut half, 15).expect("extend");
        assert!(half.points.last().expect("points").parameter > 0.2);
        for p in &half.points {
            assert!(p.u[0] * side > 0.0, "on the side chosen");
            assert!(
                (p.u[0].abs() - p.parameter.sqrt()).abs() < 1e-9,
                "x = {} at μ = {}",
                p.u[0],
                p.parameter
            );
            // the nontrivial equilibria are stable (eigenvalue μ − 3x² = −2μ)
            assert_eq!(p.is_stable(), Some(true));
        }
    }
}

#[test]
fn neuron_hopf_curve_stops_at_the_bogdanov_takens_point_on_a21_9_over_4() {
    // Issue 23, item 4: DDE-Biftool's neuron demo, p = [κ, β, a12, a21, τ1, τ2, τs] =
    // [0.5, −1, 1, ·, 0.2, 0.2, ·], the Hopf curve of x = 0 in (a21, τs) from a21 = 0.807,
    // τs = 1.5 towards larger a21. At x = 0, Δ(0) = [[κ − β, −a12], [−a21, κ − β]], so
    // det Δ(0) = 9/4 − a21: a zero root at a21 = 2.25 for every τs (a pitchfork line of the
    // symmetric system, ∂f/∂p = 0 at x = 0). The Hopf curve meets that line where its
    // frequency ω reaches 0: a (symmetric, Hopf-pitchfork) Bogdanov–Takens point, at which
    // the curve's defining system is exactly singular. The curve used to stop there with
    // `SingularSystem`; now the point is located and named (tolerance 1e-8 on a21: the
    // location stops within 1e-10, the last regular iterate before the singular point) and
    // the curve goes on as the same curve with −ω (it turns back at a BT point).
    let p0 = vec![0.5, -1.0, 1.0, 0.5, 0.2, 0.2, 1.5];
    let mut eq =
        EquilibriumSystem::new(&Neuron, p0.clone(), 3, ChebyshevRoots::default()).expect("system");
    let c = cont(0.05, 0.1, (0.0, 3.0));
    let dir = eq.parameter_direction();
    let mut br = c.start(&mut eq, &[0.0, 0.0, 0.5], &dir).expect("start");
    c.extend_observed(&mut eq, &mut br, 30, &mut |b: &Branch| {
        if b.first(SpecialKind::Hopf).is_some() {
            Decision::Stop
        } else {
            Decision::Continue
        }
    })
    .expect("equilibria");
    let (i, sp) = br.first(SpecialKind::Hopf).expect("Hopf point");
    let hopf = eq
        .hopf_point(&br.points[i].u, sp.transversality.expect("located"))
        .expect("Hopf data");
    assert!(
        (hopf.parameter - 0.807).abs() < 1e-3,
        "a21 = {}",
        hopf.parameter
    );
    let mut p = p0;
    p[3] = hopf.parameter;
    let mut hc =
        HopfCurveSystem::new(&Neuron, p, [3, 6], ChebyshevRoots::default()).expect("curve system");
    let (guess, _) = hc.start_at_hopf(&hopf, 3).expect("start data");
    // towards larger a21: the direction of a21 (unknown 3n + 1 = 7)
    let mut dir = vec![0.0; guess.len()];
    dir[7] = 1.0;
    let cc = cont(0.1, 0.5, (0.0, 3.0));
    let mut curve = cc.start(&mut hc, &guess, &dir).expect("start the curve");
    cc.extend(&mut hc, &mut curve, 40)
        .expect("no error at a21 = 2.25");
    let bt = single_codim2(hc.codim2_points(&curve), SpecialKind::BogdanovTakens);
    assert!((bt.p1 - 2.25).abs() < 1e-8, "{bt:?}");
    let k = bt.index;
    assert!(
        hc.omega(&curve.points[k].u).abs() < 1e-4,
        "ω at the BT point"
    );
    // the curve goes on past it (retracing with −ω), x = 0 throughout
    assert!(curve.points.len() > k + 5);
    assert!(
        curve.points[k + 1..]
            .iter()
            .all(|p| hc.omega(&p.u) < 0.0 && p.parameter <= 2.25)
    );
    assert!(
        curve
            .points
            .iter()
            .all(|p| hc.state(&p.u).iter().all(|x| x.abs() < 1e-12))
    );
}

/// the one codimension-two point of kind `kind` among `points`
fn single_codim2(points: Vec<Codim2Point>, kind: SpecialKind) -> Codim2Point {
    let mut of_kind: Vec<_> = points.into_iter().filter(|c| c.kind == kind).collect();
    assert_eq!(of_kind.len(), 1, "{of_kind:?}");
    of_kind.remove(0)
}
