//! V_crit of Table I with first-order tyre relaxation σ on every axle.
//!
//! `cargo run -p trailer-model --example relaxation`

use trailer_model::{AnyVehicleModel, CriticalSpeedOptions, Plant, VehicleSpec, with_plant};

fn main() -> Result<(), trailer_model::ModelError> {
    for sigma in [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6] {
        let any = AnyVehicleModel::new(&VehicleSpec::table_i_with_relaxation(sigma))?;
        let vc = with_plant!(&any, m => m.critical_speed(&CriticalSpeedOptions::default()))?;
        println!(
            "sigma = {sigma:.1} m: N = {}, V_crit = {:.6} m/s, f = {:.4} Hz",
            any.states(),
            vc.v_crit_mps,
            vc.hopf_frequency_hz
        );
    }
    Ok(())
}
