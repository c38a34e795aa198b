//! The loading map (beyond the paper) against the linear analysis and statics.

use approx::assert_relative_eq;
use sway::loading::{InertiaScaling, loaded, tongue_load_fraction, v_crit_map, v_crit_of};
use trailer_model::{AxleLoads, CriticalSpeedOptions, Model, VehicleParams, VehicleSpec};

fn opts() -> CriticalSpeedOptions {
    CriticalSpeedOptions {
        v_min: 1.0,
        v_max: 120.0,
        scan_step: 0.5,
        tolerance: 1e-9,
    }
}

#[test]
fn tongue_load_is_the_static_hitch_force() {
    // Reference: statics (AxleLoads): the trailer's vertical hitch force is
    // H = m2 g − F_z,T = m2 g (1 − h/l); tongue load fraction = H / (m2 g).
    let p = VehicleParams::default();
    let loads = AxleLoads::from_params(&p);
    let w = p.trailer.mass * p.gravity;
    assert_relative_eq!(
        tongue_load_fraction(&p),
        loads.hitch / w,
        max_relative = 1e-12
    );
    assert_relative_eq!(
        tongue_load_fraction(&p),
        1.0 - 2.9 / 2.8,
        max_relative = 1e-15
    );
}

#[test]
fn map_reproduces_the_linear_critical_speed_at_the_base_vehicle() {
    // Reference: Model::critical_speed of the unmodified Table I vehicle; the map cell
    // at (m2, h) of Table I is the same computation: equal to the bisection tolerance.
    let p = VehicleParams::default();
    let direct = Model::new(p)
        .expect("valid")
        .critical_speed(&opts())
        .expect("V_crit")
        .v_crit_mps;
    let map = v_crit_map(
        &VehicleSpec::from(p),
        &[985.0],
        &[2.9],
        InertiaScaling::ScaleWithMass,
        &opts(),
        &|| {},
    );
    assert!((map[0][0] - direct).abs() < 1e-8);
    // a cell without a stability change in the range is NaN, not an error
    let narrow = CriticalSpeedOptions {
        v_min: 1.0,
        v_max: 20.0,
        ..opts()
    };
    assert!(v_crit_of(&p, &narrow).is_nan());
}

#[test]
fn more_tongue_load_raises_the_critical_speed() {
    // The physical claim the loading figure makes (and the trailer-towing rule of thumb):
    // moving the load forward (smaller h, larger tongue load) raises V_crit, here
    // monotonically over −7 % … +14 % tongue load at the Table I mass.
    let p = VehicleParams::default();
    let mut last = 0.0;
    for k in 0..=20 {
        let h = 3.0 - 0.03 * k as f64;
        let v = v_crit_of(
            &loaded(&p, p.trailer.mass, h, InertiaScaling::ScaleWithMass),
            &opts(),
        );
        assert!(v > last, "h = {h}: {v} after {last}");
        last = v;
    }
}

#[test]
fn map_is_independent_of_the_thread_count() {
    let p = VehicleParams::default();
    let masses = [600.0, 900.0, 1200.0, 1500.0];
    let cogs = [2.5, 2.7, 2.9];
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| {
                v_crit_map(
                    &VehicleSpec::from(p),
                    &masses,
                    &cogs,
                    InertiaScaling::Fixed,
                    &opts(),
                    &|| {},
                )
            })
    };
    let one = run(1);
    let two = run(2);
    for (a, b) in one.iter().flatten().zip(two.iter().flatten()) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
}
