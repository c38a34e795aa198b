//! A seeded generator of plausible car–trailer combinations, for tests that
//! must hold for any valid vehicle file, not only Table I.
//!
//! Ranges (ours; typical passenger car + single-axle trailer, the single-track model):
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

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use trailer_model::{FrictionParams, TractorParams, TrailerParams, VehicleParams};

/// The geometry and masses of one combination before the stiffnesses are set.
#[derive(Debug, Clone, Copy)]
pub struct Draw {
    /// m1 \[kg\]
    pub tractor_mass: f64,
    /// f − c \[m\]
    pub wheelbase: f64,
    /// c \[m\]
    pub rear_overhang: f64,
    /// (d − c)/(f − c)
    pub cog_fraction: f64,
    /// J1 / (m1 (f − c)²)
    pub tractor_inertia_factor: f64,
    /// m2 \[kg\]
    pub trailer_mass: f64,
    /// l \[m\]
    pub trailer_axle: f64,
    /// 1 − h/l
    pub tongue_load: f64,
    /// J2 / (m2 l²)
    pub trailer_inertia_factor: f64,
    /// C / F_z of the front, rear and trailer axle \[1/rad\]
    pub cornering_coefficients: [f64; 3],
}

impl Draw {
    /// A draw in the middle of every range.
    pub fn typical() -> Self {
        Self {
            tractor_mass: 1800.0,
            wheelbase: 2.8,
            rear_overhang: 1.1,
            cog_fraction: 0.55,
            tractor_inertia_factor: 0.23,
            trailer_mass: 1000.0,
            trailer_axle: 3.2,
            tongue_load: 0.06,
            trailer_inertia_factor: 0.18,
            cornering_coefficients: [14.0, 18.0, 10.0],
        }
    }

    /// A random draw from the ranges of the module docs.
    pub fn random(rng: &mut impl Rng) -> Self {
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
        Self {
            tractor_mass: u(1200.0, 3000.0),
            wheelbase: u(2.5, 3.9),
            rear_overhang: u(0.9, 1.4),
            cog_fraction: u(0.4, 0.6),
            tractor_inertia_factor: u(0.18, 0.28),
            trailer_mass: u(400.0, 2000.0),
            trailer_axle: u(2.0, 4.5),
            tongue_load: u(-0.03, 0.15),
            trailer_inertia_factor: u(0.12, 0.25),
            cornering_coefficients: [u(8.0, 20.0), u(12.0, 25.0), u(5.0, 15.0)],
        }
    }

    /// The vehicle file of this draw: the static axle loads of Fig. 2's statics give the
    /// cornering stiffnesses.
    pub fn vehicle(&self) -> VehicleParams {
        let g = 9.81;
        let c = self.rear_overhang;
        let f = c + self.wheelbase;
        let d = c + self.cog_fraction * self.wheelbase;
        let l = self.trailer_axle;
        let h = l * (1.0 - self.tongue_load);
        let (m1, m2) = (self.tractor_mass, self.trailer_mass);
        // statics: trailer axle load, hitch force on the trailer, tractor axle loads
        let fz_t = m2 * g * h / l;
        let hitch = m2 * g - fz_t;
        let fz_f = (m1 * g * (d - c) - hitch * c) / (f - c);
        let fz_r = m1 * g + hitch - fz_f;
        let [kf, kr, kt] = self.cornering_coefficients;
        VehicleParams {
            tractor: TractorParams {
                mass: m1,
                yaw_inertia: m1 * self.tractor_inertia_factor * self.wheelbase.powi(2),
                front_axle: f,
                cog: d,
                rear_axle: c,
                front_cornering_stiffness: kf * fz_f,
                rear_cornering_stiffness: kr * fz_r,
            },
            trailer: TrailerParams {
                mass: m2,
                yaw_inertia: m2 * self.trailer_inertia_factor * l * l,
                cog: h,
                axle: l,
                cornering_stiffness: kt * fz_t,
            },
            friction: FrictionParams {
                mu_static: 0.9,
                mu_dynamic: 0.6,
            },
            gravity: g,
        }
    }
}

/// `count` random combinations from seed `seed` (ChaCha8: the same on every machine).
pub fn random(seed: u64, count: usize) -> Vec<(String, VehicleParams)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|i| (format!("random-{i}"), Draw::random(&mut rng).vehicle()))
        .collect()
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
