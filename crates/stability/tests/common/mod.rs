//! The synthetic test system shared by the tests and the benchmarks.
#![allow(dead_code)]

use nalgebra::{Matrix4, RowVector4, Vector4};
use stability::{RankOneFeedback, StabilityError};

/// A 4-state test loop: two coupled oscillators, the first with parameter-dependent damping
/// (unstable for v > 4), single input into the first, output a mix of velocities.
pub fn test_system(v: f64) -> (Matrix4<f64>, Vector4<f64>, RowVector4<f64>) {
    #[rustfmt::skip]
    let a = Matrix4::new(
        0.0, 1.0,            0.0,  0.0,
        -4.0, 0.2 - 0.05 * v, 1.0,  0.0,
        0.0, 0.0,            0.0,  1.0,
        1.5, 0.0,           -9.0, -0.6,
    );
    let b = Vector4::new(0.0, 1.0, 0.0, 0.5);
    let c = RowVector4::new(0.3, 1.0, 0.0, -0.4);
    (a, b, c)
}

/// [`test_system`] as a rank-one feedback loop.
pub fn test_loop(v: f64) -> Result<RankOneFeedback, StabilityError> {
    let (a, b, c) = test_system(v);
    RankOneFeedback::from_state_space(&a, &b, &c)
}
