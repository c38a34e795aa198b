//! A seeded generator of plausible car–trailer combinations with random mixes of the model
//! variants (issue 52): the vehicles that tests and the `study_generated` task run through
//! every task, so that "every valid vehicle file gets a physical outcome" is checked beyond
//! Table I and the paper's form.
//!
//! The paper form of a draw ([`Draw`]; ranges ours, a typical passenger car and a
//! single-axle trailer in the single-track model):
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
//! The variant mix ([`VariantMix`]), each variant drawn independently with probability ½:
//!
//! | variant | range |
//! |---|---|
//! | tyre relaxation σ on every axle | 0.15–0.6 m |
//! | Magic Formula on every axle | C 1.15–1.4, E −1.5…0, μ_p 0.6–0.95 (B from the axle's C_α) |
//! | tandem trailer axle | the axle split at ±(0.3–0.5) m, half the stiffness each |
//! | viscous hitch damping c_h | 100–1000 N m s/rad |
//! | Coulomb hitch friction M_c | 50–300 N m (ω_c = 0.02 rad/s) |

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use tires::TireLawSpec;
use trailer_model::{
    AxleSpec, FrictionParams, HitchSpec, TractorParams, TrailerParams, VehicleParams, VehicleSpec,
};

/// The geometry and masses of one combination before the stiffnesses are set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
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

/// A uniform draw in [lo, hi).
fn uniform(rng: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
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
        let mut u = |lo: f64, hi: f64| uniform(rng, lo, hi);
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

    /// The vehicle of the paper's form of this draw: the static axle loads of Fig. 2's
    /// statics give the cornering stiffnesses.
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

/// The Magic Formula of every axle of a generated vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MagicFormula {
    /// shape factor C \[-\]
    pub shape_factor: f64,
    /// curvature factor E \[-\]
    pub curvature_factor: f64,
    /// peak friction μ_p \[-\] (D = μ_p·F_z)
    pub peak_friction: f64,
}

/// Which model variants a generated vehicle has (None / 0: the paper's model there).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct VariantMix {
    /// relaxation length σ \[m\] of every axle
    pub relaxation_length_m: Option<f64>,
    /// Magic Formula tyres on every axle
    pub magic_formula: Option<MagicFormula>,
    /// half the spacing \[m\] of a tandem trailer axle (split about l)
    pub tandem_half_spacing_m: Option<f64>,
    /// viscous hitch damping c_h \[N m s/rad\]
    pub hitch_damping_nms: Option<f64>,
    /// Coulomb hitch friction M_c \[N m\]
    pub hitch_friction_nm: Option<f64>,
}

impl VariantMix {
    /// The paper's model (no variant).
    pub const NONE: Self = Self {
        relaxation_length_m: None,
        magic_formula: None,
        tandem_half_spacing_m: None,
        hitch_damping_nms: None,
        hitch_friction_nm: None,
    };

    /// Each variant with probability ½, from the ranges of the module docs.
    pub fn random(rng: &mut impl Rng) -> Self {
        let mut maybe = |lo: f64, hi: f64| {
            let on = rng.random::<bool>();
            let x = uniform(rng, lo, hi);
            on.then_some(x)
        };
        let relaxation_length_m = maybe(0.15, 0.6);
        let shape_factor = maybe(1.15, 1.4);
        let curvature_factor = maybe(-1.5, 0.0).unwrap_or(-1.24);
        let peak_friction = maybe(0.6, 0.95).unwrap_or(0.648);
        let tandem_half_spacing_m = maybe(0.3, 0.5);
        let hitch_damping_nms = maybe(100.0, 1000.0);
        let hitch_friction_nm = maybe(50.0, 300.0);
        Self {
            relaxation_length_m,
            magic_formula: shape_factor.map(|c| MagicFormula {
                shape_factor: c,
                curvature_factor,
                peak_friction,
            }),
            tandem_half_spacing_m,
            hitch_damping_nms,
            hitch_friction_nm,
        }
    }

    /// The names of the variants present (`relaxation`, `magic_formula`, `tandem`,
    /// `hitch_damping`, `hitch_friction`), `paper` for none.
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        let present = [
            (self.relaxation_length_m.is_some(), "relaxation"),
            (self.magic_formula.is_some(), "magic_formula"),
            (self.tandem_half_spacing_m.is_some(), "tandem"),
            (self.hitch_damping_nms.is_some(), "hitch_damping"),
            (self.hitch_friction_nm.is_some(), "hitch_friction"),
        ];
        v.extend(present.iter().filter(|(on, _)| *on).map(|(_, n)| *n));
        if v.is_empty() {
            v.push("paper");
        }
        v
    }

    /// The vehicle file of the paper-form vehicle `p` with these variants.
    pub fn apply(&self, p: VehicleParams) -> VehicleSpec {
        let mut s = VehicleSpec::from(p);
        let tire = self.magic_formula.map(|m| TireLawSpec::MagicFormula {
            shape_factor: m.shape_factor,
            curvature_factor: m.curvature_factor,
            peak_friction: Some(m.peak_friction),
            peak_force: None,
            stiffness_factor: None,
        });
        let sigma = self.relaxation_length_m;
        s.tractor.front_tire = tire;
        s.tractor.rear_tire = tire;
        s.tractor.front_relaxation_length_m = sigma;
        s.tractor.rear_relaxation_length_m = sigma;
        // (the paper form's vehicle file always has its `[trailer]`)
        if let Some(trailer) = s.trailer.as_mut() {
            if let Some(a) = self.tandem_half_spacing_m {
                let axle = |position_m: f64| AxleSpec {
                    position_m,
                    cornering_stiffness: p.trailer.cornering_stiffness / 2.0,
                    steered: false,
                    tire: tire.unwrap_or_default(),
                    relaxation_length_m: sigma.unwrap_or(0.0),
                };
                trailer.axle = None;
                trailer.cornering_stiffness = None;
                trailer.axles = Some(vec![axle(p.trailer.axle - a), axle(p.trailer.axle + a)]);
            } else {
                trailer.tire = tire;
                trailer.relaxation_length_m = sigma;
            }
        }
        s.hitch = HitchSpec {
            yaw_damping_nms: self.hitch_damping_nms.unwrap_or(0.0),
            friction_torque_nm: self.hitch_friction_nm.unwrap_or(0.0),
            ..HitchSpec::default()
        };
        s
    }
}

/// One generated vehicle: its name, draw, variants and vehicle file.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedVehicle {
    /// `generated-<index>`
    pub name: String,
    /// the paper form's draw
    pub draw: Draw,
    /// the variants
    pub variants: VariantMix,
    /// the vehicle file
    pub spec: VehicleSpec,
}

/// `count` generated vehicles with variant mixes from `seed` (ChaCha8: the same on every
/// machine; the first `k` of a larger count are the same `k`).
pub fn generate(seed: u64, count: usize) -> Vec<GeneratedVehicle> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|i| {
            let draw = Draw::random(&mut rng);
            let variants = VariantMix::random(&mut rng);
            GeneratedVehicle {
                name: format!("generated-{i}"),
                draw,
                variants,
                spec: variants.apply(draw.vehicle()),
            }
        })
        .collect()
}

/// `count` random paper-form combinations from `seed`, named `random-<index>`.
pub fn random_paper_form(seed: u64, count: usize) -> Vec<(String, VehicleParams)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|i| (format!("random-{i}"), Draw::random(&mut rng).vehicle()))
        .collect()
}
