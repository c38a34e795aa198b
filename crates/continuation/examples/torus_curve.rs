//! Torus curves at a double-Hopf point of two delay-coupled oscillators
//! (`textbook::TorusTestBed`, τ = 2.5): the double-Hopf point located on a Hopf curve,
//! both torus curves started there and compared with their closed forms.
//!
//! Run with `cargo run --release -p continuation --example torus_curve`.
use continuation::*;
use continuation_textbook::TorusTestBed;

fn main() -> Result<()> {
    let bed = TorusTestBed::delayed();
    let tau = 2.5;
    let (omega, d) = bed.second_hopf(tau);
    let cont = Continuation::new(ContinuationOptions {
        initial_step: 0.02,
        max_step: 0.05,
        ..Default::default()
    });

    // the Hopf point of z1 (μ = 0) at ν = D − 0.3, then its Hopf curve in (ν, μ)
    let p = vec![-0.3, d - 0.3, tau];
    let mut eq = EquilibriumSystem::new(&bed, p.clone(), 0, ChebyshevRoots::default())?;
    let dir = eq.parameter_direction();
    let mut branch = cont.start(&mut eq, &[0.0, 0.0, 0.0, 0.0, -0.3], &dir)?;
    cont.extend(&mut eq, &mut branch, 40)?;
    let (i, sp) = branch.first(SpecialKind::Hopf).ok_or(Error::EmptyBranch)?;
    let hopf = eq.hopf_point(&branch.points[i].u, sp.transversality.unwrap_or(1.0))?;
    let mut hc = HopfCurveSystem::new(&bed, p, [1, 0], ChebyshevRoots::default())?;
    let (guess, dir) = hc.start_at_hopf(&hopf, 0)?;
    let mut curve = cont.start(&mut hc, &guess, &dir)?;
    cont.extend(&mut hc, &mut curve, 40)?;
    let c2 = hc
        .codim2_points(&curve)
        .into_iter()
        .find(|c| c.kind == SpecialKind::DoubleHopf)
        .ok_or(Error::EmptyBranch)?;
    let hh = DoubleHopfPoint::from_hopf_curve(&bed, &hc, &curve, &c2)?;
    println!(
        "double Hopf at (μ, ν) = ({:.3e}, {:.10}), ω = {:.10}, {:.10}; closed form (0, {d:.10}), ω = 1, {omega:.10}",
        c2.p2, c2.p1, hh.omegas[0], hh.omegas[1]
    );

    // both torus curves from there (family 0: cycles of z1, family 1: cycles of z2)
    let colloc = CollocationOptions {
        intervals: 10,
        ..Default::default()
    };
    for family in [0, 1] {
        let options = TorusCurveOptions::default();
        let (mut torus, guess, dir) = TorusCurveSystem::from_double_hopf(
            &bed,
            &hh,
            [0, 1],
            family,
            0.1,
            colloc.clone(),
            options,
        )?;
        let mut t = cont.start(&mut torus, &guess, &dir)?;
        let stop = torus.extend_curve(&cont, &mut t, 20)?;
        println!(
            "torus curve T{}: {} points, stop {stop:?}",
            family + 1,
            t.points.len()
        );
        println!("      μ          ν      ν(closed form)  rotation number  amplitude");
        for pt in t.points.iter().step_by(4) {
            let cp = torus.curve_point(&pt.u);
            let [mu, nu] = cp.parameters;
            let exact = if family == 0 {
                -bed.c * mu + d
            } else {
                d - mu / bed.e
            };
            println!(
                "{mu:10.6} {nu:10.6} {exact:10.6}      {:8.6}       {:8.5}",
                cp.rotation_number, cp.amplitude
            );
        }
    }
    Ok(())
}
