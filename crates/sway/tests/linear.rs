//! The sensitivities of V_crit against dimensional analysis.

use sway::linear::sensitivities;
use trailer_model::{CriticalSpeedOptions, Model, VehicleParams};

#[test]
fn sensitivities_satisfy_euler_relations_of_dimensional_analysis() {
    // Reference: V_crit [m/s] is a function of the parameters homogeneous under unit
    // changes. With elasticities e_i = (p_i/V) ∂V/∂p_i, Euler's theorem gives for mass
    // (m, J, C scale with M): Σ e = 0; for length (J ~ L², lengths and C ~ L): Σ b_i e_i = 1;
    // for time (C ~ T⁻², V ~ T⁻¹): −2 Σ_C e = −1. Central differences with step 1e-4 and
    // V_crit to 1e-11 m/s make each elasticity accurate to ~1e-8: tolerance 1e-6.
    let p = VehicleParams::default();
    let model = Model::new(p).expect("valid");
    let vc = model
        .critical_speed(&CriticalSpeedOptions::default())
        .expect("V_crit")
        .v_crit_mps;
    let s = sensitivities(&p, vc, &Default::default(), 1e-11).expect("sensitivities");
    let e = |sym: &str| {
        s.iter()
            .find(|x| x.symbol == sym)
            .map(|x| x.elasticity)
            .expect("known symbol")
    };
    let mass: f64 = ["m1", "J1", "C_F", "C_R", "m2", "J2", "C_T"]
        .iter()
        .map(|k| e(k))
        .sum();
    let length: f64 = 2.0 * (e("J1") + e("J2"))
        + ["f", "d", "c", "h", "l", "C_F", "C_R", "C_T"]
            .iter()
            .map(|k| e(k))
            .sum::<f64>();
    let time: f64 = -2.0 * (e("C_F") + e("C_R") + e("C_T"));
    assert!(mass.abs() < 1e-6, "mass relation {mass}");
    assert!((length - 1.0).abs() < 1e-6, "length relation {length}");
    assert!((time + 1.0).abs() < 1e-6, "time relation {time}");
    // loads, friction and g do not enter the linearisation: exactly zero
    for k in ["mu0", "mu", "g"] {
        assert_eq!(e(k), 0.0, "{k}");
    }
}
