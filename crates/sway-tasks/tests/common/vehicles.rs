//! A seeded generator of plausible car–trailer combinations, for tests that
//! must hold for any valid vehicle file, not only Table I.
//!
//! The draws are `sway_model::generator::Draw`'s; its ranges (ours; typical passenger car +
//! single-axle trailer, the single-track model):
//!
//! | quantity | range |
//! |---|---|
//! | tractor mass m1 | 1200–3000 kg |
//! | wheelbase f − c | 2.5–3.9 m |
//! | rear overhang to the hitch c | 0.9–1.4 m |
//! | centre of gravity d − c | 40–60 % of the wheelbase ahead of the rear axle |
//! | yaw inertia J1 | m1 · (0.18–0.28) · (f − c)² |
//! | trailer mass m2 | 400–2000 kg |
//! | hitch → trailer axle l | 2.0–4.5 m |
//! | tongue load 1 − h/l | −3 % … +15 % of the trailer weight (h = l·(1 − t)) |
//! | yaw inertia J2 | m2 · (0.12–0.25) · l² |
//! | cornering stiffness per axle | (8–20, 12–25, 5–15) /rad × static axle load (front, rear, trailer) |
//! | friction μ0, μ | 0.9, 0.6 (the paper's) |
//!
//! Besides the random draws, [`named`] gives the combinations the issue asks to cover by
//! name: nose-heavy and tail-heavy trailers, a heavy trailer behind a light car, a very
//! light trailer, a long trailer and one stable up to the maximum speed.

#![allow(dead_code)]

pub use sway_model::generator::Draw;
use trailer_model::VehicleParams;

/// `count` random combinations from seed `seed` (ChaCha8: the same on every machine).
pub fn random(seed: u64, count: usize) -> Vec<(String, VehicleParams)> {
    sway_model::generator::random_paper_form(seed, count)
}

/// The combinations the issue names, each a variation of [`Draw::typical`].
pub fn named() -> Vec<(String, VehicleParams)> {
    let t = Draw::typical();
    let cases = [
        (
            "nose_heavy",
            Draw {
                tongue_load: 0.12,
                ..t
            },
        ),
        (
            "tail_heavy",
            Draw {
                tongue_load: -0.03,
                ..t
            },
        ),
        (
            "heavy_trailer_light_car",
            Draw {
                tractor_mass: 1200.0,
                wheelbase: 2.5,
                trailer_mass: 2000.0,
                tongue_load: 0.02,
                ..t
            },
        ),
        (
            "very_light_trailer",
            Draw {
                trailer_mass: 400.0,
                ..t
            },
        ),
        (
            "long_trailer",
            Draw {
                trailer_axle: 4.5,
                ..t
            },
        ),
        (
            "stable_to_max_speed",
            Draw {
                tractor_mass: 3000.0,
                trailer_mass: 500.0,
                tongue_load: 0.15,
                cornering_coefficients: [14.0, 25.0, 15.0],
                ..t
            },
        ),
    ];
    cases
        .into_iter()
        .map(|(n, d)| (n.to_string(), d.vehicle()))
        .collect()
}

/// The named combinations, then `random_count` random ones from `seed`.
pub fn fleet(seed: u64, random_count: usize) -> Vec<(String, VehicleParams)> {
    let mut v = named();
    v.extend(random(seed, random_count));
    v
}
