//! Hopf point and cycle branch of a delay equation, with Floquet multipliers.
//!
//! The delayed Stuart–Landau oscillator (z = x0 + i·x1)
//!
//! z'(t) = (μ + i) z − |z|² z + κ (z(t − τ) − e^{−iτ} z(t))
//!
//! keeps the cycles z = √μ e^{it} (period 2π) of the undelayed oscillator for every κ, τ, so
//! the table can be checked by eye: the amplitude column must equal √μ and the period 2π.
//! The problem is [`continuation_textbook::DelayedStuartLandau`], with its Jacobian supplied
//! exactly. Run with
//!
//! ```text
//! cargo run --example delayed_hopf -p continuation
//! ```

use continuation::*;
use continuation_textbook::DelayedStuartLandau;
use std::f64::consts::PI;

fn main() -> Result<()> {
    let (kappa, tau) = (0.2, 1.0);
    let problem = DelayedStuartLandau;
    let cont = Continuation::new(ContinuationOptions {
        initial_step: 0.05,
        max_step: 0.1,
        parameter_range: (-1.0, 0.6),
        ..Default::default()
    });

    // 1. equilibrium z = 0 from μ = −0.3 upwards: the Hopf point is located at μ = 0, ω = 1
    let mut eq = EquilibriumSystem::new(
        &problem,
        vec![-0.3, kappa, tau],
        0,
        ChebyshevRoots::default(),
    )?;
    let dir = eq.parameter_direction();
    let mut equilibria = cont.start(&mut eq, &[0.0, 0.0, -0.3], &dir)?;
    cont.extend(&mut eq, &mut equilibria, 12)?;
    let (i, sp) = equilibria
        .first(SpecialKind::Hopf)
        .ok_or_else(|| Error::InvalidInput("no Hopf point on the equilibrium branch".into()))?;
    let transversality = sp.transversality.unwrap_or(1.0);
    let hopf = eq.hopf_point(&equilibria.points[i].u, transversality)?;
    println!(
        "Hopf point: mu = {:.3e} (exact 0), omega = {:.12} (exact 1)",
        hopf.parameter, hopf.omega
    );

    // 2. the cycles born there (collocation, 30 intervals), with a progress observer
    let mut po = PeriodicOrbitSystem::new(
        &problem,
        vec![0.0, kappa, tau],
        0,
        CollocationOptions {
            intervals: 30,
            ..Default::default()
        },
    )?;
    let (guess, dir) = po.hopf_guess(&hopf, 0.05);
    let mut cycles = cont.start(&mut po, &guess, &dir)?;
    let mut progress = |b: &Branch| {
        eprint!("\r{} cycles", b.points.len());
        Decision::Continue
    };
    cont.extend_observed(&mut po, &mut cycles, 12, &mut progress)?;
    eprintln!();
    println!(
        "criticality: {}",
        criticality(&hopf, &cycles).map_or("undecided".into(), |c| c.to_string())
    );

    // 3. the table: amplitude and period against the closed form, leading multipliers
    println!(
        "{:>8} {:>10} {:>10} {:>10} {:>24} {:>7}",
        "mu", "amplitude", "sqrt(mu)", "period/2pi", "leading multiplier", "stable"
    );
    for p in cycles.points.iter().filter(|p| p.parameter > 0.0) {
        let st = p.stability.as_ref();
        let lead = st.and_then(|s| s.nontrivial().max_by(|a, b| a.norm().total_cmp(&b.norm())));
        println!(
            "{:>8.4} {:>10.6} {:>10.6} {:>10.6} {:>24} {:>7}",
            p.parameter,
            po.max_abs(&p.u, 0),
            p.parameter.sqrt(),
            po.period(&p.u) / (2.0 * PI),
            lead.map_or("-".into(), |m| format!("{:+.6}{:+.6}i", m.re, m.im)),
            p.is_stable().map_or("-", |s| if s { "yes" } else { "no" }),
        );
    }
    Ok(())
}
