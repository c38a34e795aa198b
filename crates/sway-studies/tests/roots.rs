//! The rightmost characteristic roots up to the documented limit of 200.

use sway_studies::roots::{RootsConfig, compute};
use trailer_model::{AnyVehicleModel, VehicleParams, VehicleSpec};

#[test]
fn two_hundred_roots_begin_with_the_first_ten() {
    // reference: the 10 rightmost roots computed alone (a coarser collocation); the first
    // 10 of 200 agree to 1e-10 relative (both Newton-polished to ~1e-14), and every root
    // satisfies the ordering by decreasing real part
    let vehicle = AnyVehicleModel::new(&VehicleSpec::from(VehicleParams::default())).unwrap();
    let few = compute(&vehicle, &RootsConfig::paper(35.0, 0.1, 0.2, 10), None).unwrap();
    let many = compute(&vehicle, &RootsConfig::paper(35.0, 0.1, 0.2, 200), None).unwrap();
    assert!(many.len() >= 200, "{} roots", many.len());
    for (a, b) in few.iter().zip(&many) {
        assert!((a - b).norm() <= 1e-10 * a.norm().max(1.0), "{a} vs {b}");
    }
    assert!(many.windows(2).all(|w| w[0].re >= w[1].re - 1e-9));
}
