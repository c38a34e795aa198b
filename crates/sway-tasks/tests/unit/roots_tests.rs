use stability::Complex64;
use sway::control::{LoopLaw, LoopModel};
use sway_tasks::tasks::roots::*;
use trailer_model::{Model, VehicleParams};

#[test]
fn roots_are_sorted_conjugate_and_satisfy_the_characteristic_equation() {
    // reference: the residual of det(λI − Ã + B̃ D C̃ e^{−λτ}) (eq. 13) evaluated directly
    // with complex 4×4 determinants; tolerance relative to the size of its terms
    let m = Model::new(VehicleParams::default()).unwrap();
    let (v, d, tau) = (35.0, 0.1, 0.2);
    // the 6th root is complex here, so its conjugate is listed as a 7th
    let r = roots(&m, v, d, tau, 6).unwrap();
    assert_eq!(r.len(), 7);
    for w in r.windows(2) {
        assert!(w[0].re >= w[1].re);
    }
    for l in &r {
        assert!(r.iter().any(|k| *k == l.conj()), "conjugate of {l} missing");
    }
    assert_eq!(
        roots(&m, v, d, tau, 5).unwrap().len(),
        5,
        "5th root is real"
    );
    let lin = m.linearize(v);
    for l in &r {
        let e = (-l * tau).exp() * d;
        let mat = nalgebra::Matrix4::from_fn(|i, j| {
            let bdc = lin.b4[i] * lin.c4[j];
            let base = Complex64::new(-lin.a4[(i, j)], 0.0) + e * bdc;
            if i == j { base + l } else { base }
        });
        let det = mat.determinant();
        let scale = mat.norm().powi(4);
        assert!(
            det.norm() < 1e-13 * scale,
            "root {l}: residual {det} (scale {scale})"
        );
    }
    let text = format_roots(&r);
    assert_eq!(text.lines().count(), 7);
    let back: f64 = text
        .lines()
        .next()
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(back, r[0].re);
}

#[test]
fn controller_roots_of_a_relaxed_vehicle_satisfy_the_loop_equation() {
    // reference: det(λI − A + B K e^{−λτ}) of the 7-state relaxed plant evaluated
    // directly (complex LU), for the hitch-sensor structure with differential braking;
    // the paper's controller gives the numbers of `charts::rightmost_roots` (the same
    // quasi-polynomial and root finder: equal to the bit)
    use sway::control::{Actuator, Gains, Structure, loop_output_row};
    let m = Model::new(VehicleParams::default()).unwrap();
    let paper = roots(&m, 35.0, 0.1, 0.2, 6).unwrap();
    assert_eq!(
        paper,
        sway::charts::rightmost_roots(&m, 35.0, 0.1, 0.2, 7).unwrap()
    );
    let plant = trailer_model::AnyVehicleModel::new(
        &trailer_model::VehicleSpec::table_i_with_relaxation(0.3),
    )
    .unwrap();
    let scale = Actuator::DifferentialBraking.scale(&m);
    let (v, tau) = (40.0, 0.4);
    let gains = Gains {
        yaw_rate: 0.1 * scale,
        hitch_angle: 0.05 * scale,
        hitch_rate: 0.03 * scale,
    };
    let c = LoopLaw::new(
        Structure::YawRateHitch,
        Actuator::DifferentialBraking,
        gains,
        tau,
    );
    let point = RootsConfig {
        speed_mps: v,
        count: 4,
        law: c,
    };
    let r = run(&plant, &point, None).unwrap();
    let lin = plant.loop_linearization(v);
    let k = loop_output_row(&lin, c.structure, &c.gains);
    let bk = &lin.b_yaw_moment * &k;
    for l in &r {
        let e = (-l * tau).exp();
        let mat = nalgebra::DMatrix::from_fn(7, 7, |i, j| {
            let base = Complex64::new(-lin.a[(i, j)], 0.0) + e * bk[(i, j)];
            if i == j { base + l } else { base }
        });
        let scale = mat.norm().powi(7);
        let det = mat.lu().determinant();
        assert!(det.norm() < 1e-12 * scale, "root {l}: residual {det}");
    }
}

#[test]
fn bad_arguments_are_named() {
    let m = Model::new(VehicleParams::default()).unwrap();
    let e = roots(&m, 0.0, 0.1, 0.2, 6).unwrap_err().to_string();
    assert!(e.contains("--speed"), "{e}");
    let e = roots(&m, 30.0, 0.1, -0.2, 6).unwrap_err().to_string();
    assert!(e.contains("--delay"), "{e}");
}
