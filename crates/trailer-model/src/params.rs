//! Vehicle parameters (paper Table I) and their physical validation.

use serde::{Deserialize, Serialize};

use crate::ModelError;

/// Tractor (towing car) parameters. Distances are measured forward from the hitch H.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TractorParams {
    /// mass m1 \[kg\] (with occupants)
    pub mass: f64,
    /// yaw moment of inertia J1 about the centre of gravity C1 \[kg m²\]
    pub yaw_inertia: f64,
    /// f \[m\]: hitch H → front axle F
    pub front_axle: f64,
    /// d \[m\]: hitch H → centre of gravity C1
    pub cog: f64,
    /// c \[m\]: hitch H → rear axle R
    pub rear_axle: f64,
    /// C_F \[N/rad\]: cornering stiffness of the front axle
    pub front_cornering_stiffness: f64,
    /// C_R \[N/rad\]: cornering stiffness of the rear axle
    pub rear_cornering_stiffness: f64,
}

/// Trailer parameters. Distances are measured backward from the hitch H.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrailerParams {
    /// mass m2 \[kg\] (with load)
    pub mass: f64,
    /// yaw moment of inertia J2 about the centre of gravity C2 \[kg m²\]
    pub yaw_inertia: f64,
    /// h \[m\]: hitch H → centre of gravity C2
    pub cog: f64,
    /// l \[m\]: hitch H → trailer axle T
    pub axle: f64,
    /// C_T \[N/rad\]: cornering stiffness of the trailer axle
    pub cornering_stiffness: f64,
}

/// Tire–road friction of the brush model (eq. 15).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionParams {
    /// static friction coefficient μ0 \[-\]
    pub mu_static: f64,
    /// dynamic (sliding) friction coefficient μ \[-\]
    pub mu_dynamic: f64,
}

/// All physical parameters of the car–trailer combination.
///
/// [`Default`] is Table I of the paper with μ0 = 0.9, μ = 0.6 (appendix) and g = 9.81 m/s².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleParams {
    /// the towing car
    pub tractor: TractorParams,
    /// the trailer
    pub trailer: TrailerParams,
    /// tire–road friction
    pub friction: FrictionParams,
    /// gravitational acceleration g \[m/s²\] (not given in the paper)
    #[serde(default = "default_gravity")]
    pub gravity: f64,
}

fn default_gravity() -> f64 {
    9.81
}

impl Default for VehicleParams {
    fn default() -> Self {
        Self {
            tractor: TractorParams {
                mass: 2400.0,
                yaw_inertia: 7647.0,
                front_axle: 5.15,
                cog: 3.25,
                rear_axle: 1.35,
                front_cornering_stiffness: 137e3,
                rear_cornering_stiffness: 256e3,
            },
            trailer: TrailerParams {
                mass: 985.0,
                yaw_inertia: 1416.0,
                cog: 2.9,
                axle: 2.8,
                cornering_stiffness: 50e3,
            },
            friction: FrictionParams {
                mu_static: 0.9,
                mu_dynamic: 0.6,
            },
            gravity: 9.81,
        }
    }
}

/// Names of the scalar parameters: (key path in the config, paper symbol, unit).
pub const PARAMETERS: [(&str, &str, &str); 15] = [
    ("tractor.mass", "m1", "kg"),
    ("tractor.yaw_inertia", "J1", "kg m^2"),
    ("tractor.front_axle", "f", "m"),
    ("tractor.cog", "d", "m"),
    ("tractor.rear_axle", "c", "m"),
    ("tractor.front_cornering_stiffness", "C_F", "N/rad"),
    ("tractor.rear_cornering_stiffness", "C_R", "N/rad"),
    ("trailer.mass", "m2", "kg"),
    ("trailer.yaw_inertia", "J2", "kg m^2"),
    ("trailer.cog", "h", "m"),
    ("trailer.axle", "l", "m"),
    ("trailer.cornering_stiffness", "C_T", "N/rad"),
    ("friction.mu_static", "mu0", "-"),
    ("friction.mu_dynamic", "mu", "-"),
    ("gravity", "g", "m/s^2"),
];

impl VehicleParams {
    /// True for the paper's vehicle, Table I (with the appendix's friction and g = 9.81 m/s²),
    /// exactly as [`Default`] gives it: the only vehicle whose results may be compared with
    /// the paper's published numbers (34.1 m/s and the like).
    pub fn is_table_i(&self) -> bool {
        *self == Self::default()
    }

    fn slot(&mut self, index: usize) -> &mut f64 {
        match index {
            0 => &mut self.tractor.mass,
            1 => &mut self.tractor.yaw_inertia,
            2 => &mut self.tractor.front_axle,
            3 => &mut self.tractor.cog,
            4 => &mut self.tractor.rear_axle,
            5 => &mut self.tractor.front_cornering_stiffness,
            6 => &mut self.tractor.rear_cornering_stiffness,
            7 => &mut self.trailer.mass,
            8 => &mut self.trailer.yaw_inertia,
            9 => &mut self.trailer.cog,
            10 => &mut self.trailer.axle,
            11 => &mut self.trailer.cornering_stiffness,
            12 => &mut self.friction.mu_static,
            13 => &mut self.friction.mu_dynamic,
            _ => &mut self.gravity,
        }
    }

    /// Value of the parameter with index `i` of [`PARAMETERS`].
    pub fn get(&self, index: usize) -> f64 {
        let mut copy = *self;
        *copy.slot(index)
    }

    /// A copy with parameter `i` of [`PARAMETERS`] set to `value` (not validated).
    pub fn with(&self, index: usize, value: f64) -> Self {
        let mut copy = *self;
        *copy.slot(index) = value;
        copy
    }

    /// Checks the physical constraints: positive masses, inertias and stiffnesses,
    /// 0 < c < f, 0 < d < f, h > 0, l > 0, 0 < μ ≤ μ0, g > 0.
    ///
    /// # Errors
    /// [`ModelError::InvalidParameter`] naming the key path, the value and what was expected.
    pub fn validate(&self) -> Result<(), ModelError> {
        for (i, (key, _, _)) in PARAMETERS.iter().enumerate() {
            let value = self.get(i);
            if !(value.is_finite() && value > 0.0) {
                return Err(ModelError::InvalidParameter {
                    key,
                    value,
                    expected: "a positive finite number",
                });
            }
        }
        let t = &self.tractor;
        if t.rear_axle >= t.front_axle {
            return Err(ModelError::InvalidParameter {
                key: "tractor.rear_axle",
                value: t.rear_axle,
                expected: "0 < c < f (rear axle between hitch and front axle)",
            });
        }
        if t.cog >= t.front_axle {
            return Err(ModelError::InvalidParameter {
                key: "tractor.cog",
                value: t.cog,
                expected: "0 < d < f (centre of gravity behind the front axle)",
            });
        }
        if self.friction.mu_dynamic > self.friction.mu_static {
            return Err(ModelError::InvalidParameter {
                key: "friction.mu_dynamic",
                value: self.friction.mu_dynamic,
                expected: "0 < mu_dynamic <= mu_static",
            });
        }
        Ok(())
    }
}

/// Static vertical axle loads \[N\] from the statics of Fig. 2: trailer axle m2·g·h/l, the
/// hitch force m2·g − F_z,T, the tractor's axles from its moment balance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxleLoads {
    /// front axle load F_z,F \[N\]
    pub front: f64,
    /// rear axle load F_z,R \[N\]
    pub rear: f64,
    /// trailer axle load F_z,T \[N\]
    pub trailer: f64,
    /// vertical hitch force on the trailer H \[N\] (negative: the trailer lifts the hitch)
    pub hitch: f64,
}

impl AxleLoads {
    /// Statics: trailer moments about H give F_z,T = m2 g h / l, the trailer's vertical
    /// balance gives the hitch force H = m2 g − F_z,T, the tractor's moment and force
    /// balances give F_z,F = (m1 g (d − c) − H c)/(f − c) and F_z,R = m1 g + H − F_z,F.
    pub fn from_params(p: &VehicleParams) -> Self {
        let g = p.gravity;
        let (t, r) = (&p.tractor, &p.trailer);
        let trailer = r.mass * g * r.cog / r.axle;
        let hitch = r.mass * g - trailer;
        let front = (t.mass * g * (t.cog - t.rear_axle) - hitch * t.rear_axle)
            / (t.front_axle - t.rear_axle);
        let rear = t.mass * g + hitch - front;
        Self {
            front,
            rear,
            trailer,
            hitch,
        }
    }
}
