//! What a chain's state says about each unit: the paper layout it is run in
//! ([`ChainModel::from_paper_layout`]), each unit's yaw rate and the lateral acceleration
//! of its centre of gravity ([`ChainModel::unit_motions`], what heavy-vehicle standards
//! compare between the towing and the rearmost unit), and where a point of a unit is on the
//! road ([`ChainModel::point_position`]).

use nalgebra::SVector;
use num_dual::DualNum;

use super::ChainModel;
use crate::{ChainSpec, Inputs, Model, ModelError, Plant};

/// The motion of one unit at a state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct UnitMotion {
    /// heading relative to the towing unit φ_i = θ_1 + … + θ_i \[rad\] (0 on the towing unit)
    pub relative_heading_rad: f64,
    /// yaw rate Ω_i = r + θ̇_1 + … + θ̇_i \[rad/s\]
    pub yaw_rate_rad_s: f64,
    /// acceleration of its centre of gravity along E2_i, to the unit's left \[m/s²\]
    pub lateral_acceleration_mps2: f64,
}

/// Where the towing unit is on the road: its heading ψ_0 \[rad\] and the position of its rear
/// coupling H_1 \[m\] (the kinematic states \[ψ, x_H, y_H\] of the paper's full state, eq. 5).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pose {
    /// ψ_0 \[rad\]
    pub heading_rad: f64,
    /// x_H \[m\]
    pub x_m: f64,
    /// y_H \[m\]
    pub y_m: f64,
}

impl<const N: usize> ChainModel<N> {
    /// The chain's state \[v, r, θ̇1, θ1, …\] of a state in the layout every
    /// [`Plant`] of a vehicle file runs in (\[σ1, σ2, σ3, θ\] of eq. 4 for the first
    /// articulation, the rest as the chain's): r = σ2 − (m1 d/I1) σ1,
    /// θ̇1 = σ3 − σ2 + σ1 (m1 d/I1 + (m2 h/I2) cos θ).
    pub fn from_paper_layout<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
    ) -> SVector<D, N> {
        let (k1, k2) = self.paper_ratios();
        let mut y = *x;
        y[1] = x[1] - x[0] * k1;
        y[2] = x[2] - x[1] + x[0] * (x[3].cos() * k2 + k1);
        y
    }

    /// The paper layout's rates from the chain's state `y` and its rates `dy` (the inverse
    /// map of [`Self::from_paper_layout`], differentiated): σ̇1 = v̇, σ̇2 = ṙ + (m1 d/I1) v̇,
    /// σ̇3 = ṙ + θ̈1 − (m2 h/I2)(v̇ cos θ1 − v θ̇1 sin θ1).
    pub fn paper_layout_rate<D: DualNum<Primitive = f64> + Copy>(
        &self,
        y: &SVector<D, N>,
        dy: &SVector<D, N>,
    ) -> SVector<D, N> {
        let (k1, k2) = self.paper_ratios();
        let mut dx = *dy;
        let (s, c) = y[3].sin_cos();
        dx[1] = dy[1] + dy[0] * k1;
        dx[2] = dy[1] + dy[2] - (dy[0] * c - y[0] * y[2] * s) * k2;
        dx
    }

    /// The right-hand side in the paper layout (the map of [`Self::from_paper_layout`], the
    /// chain's equations, the rates mapped back by [`Self::paper_layout_rate`]), with an
    /// optional yaw moment M_z \[N m\] on the towing unit; sin θ1 and cos θ1 are computed once
    /// for the three.
    pub fn rhs_in_paper_layout<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: Option<D>,
    ) -> SVector<D, N> {
        let (k1, k2) = self.paper_ratios();
        let (s, c) = x[3].sin_cos();
        let mut y = *x;
        y[1] = x[1] - x[0] * k1;
        y[2] = x[2] - x[1] + x[0] * (c * k2 + k1);
        let dy = self.rhs_actuated_with(&y, u, yaw_moment, (s, c));
        let mut dx = dy;
        dx[1] = dy[1] + dy[0] * k1;
        dx[2] = dy[1] + dy[2] - (dy[0] * c - y[0] * y[2] * s) * k2;
        dx
    }

    /// (m1 d/I1, m2 h/I2) of the first pair (eq. 4).
    fn paper_ratios(&self) -> (f64, f64) {
        self.paper_ratios
    }

    /// The motion of every unit at the chain's state `x` (its own layout) and inputs `u`,
    /// into `out` (towing unit first; `out` shorter than [`Self::units`] gets the first
    /// ones). The accelerations follow from the generalised accelerations u̇ of the
    /// right-hand side by the kinematics of the module docs of [`ChainModel`]:
    /// a_{H1} = (V̇ − v r) E1_0 + (v̇ + V r) E2_0, and along each unit
    /// a_P = a_{P_i} + x Ω̇_i E2_i − x Ω_i² E1_i with Ω̇_i = ṙ + θ̈_1 + … + θ̈_i.
    pub fn unit_motions(&self, x: &SVector<f64, N>, u: &Inputs, out: &mut [UnitMotion]) {
        let du = self.rhs(x, u);
        let frames = self.frames(x, u.speed);
        let (v, r) = (x[0], x[1]);
        // acceleration of the current reference point, in the towing unit's frame
        let mut acc = [u.acceleration - v * r, du[0] + u.speed * r];
        let mut omega_dot = du[1];
        let mut heading = 0.0;
        for i in 0..self.units.min(out.len()) {
            let f = &frames[i];
            if i >= 1 {
                omega_dot += du[2 * i];
                heading += x[2 * i + 1];
            }
            let (e1, e2) = ([f.cos, f.sin], [-f.sin, f.cos]);
            let at = |acc: [f64; 2], xp: f64| {
                let w2 = f.omega * f.omega;
                [
                    acc[0] + xp * (omega_dot * e2[0] - w2 * e1[0]),
                    acc[1] + xp * (omega_dot * e2[1] - w2 * e1[1]),
                ]
            };
            let ac = at(acc, self.unit[i].x_cog);
            out[i] = UnitMotion {
                relative_heading_rad: heading,
                yaw_rate_rad_s: f.omega,
                lateral_acceleration_mps2: ac[0] * e2[0] + ac[1] * e2[1],
            };
            acc = at(acc, self.unit[i].x_rear);
        }
    }

    /// The position on the road \[m\] of the point at `x_local` \[m\] on unit `unit` (its
    /// longitudinal coordinate, ahead of the unit's reference point positive: the rear
    /// coupling on the towing unit, the front coupling on a towed one; [`super::ChainAxle`]'s
    /// positions are behind positive on towed units) at the chain's state `x` with the
    /// towing unit at `pose`: H_{i+1} = H_i + x_rear,i E1_i.
    ///
    /// # Panics
    /// If `unit` is not below [`Self::units`].
    pub fn point_position(
        &self,
        x: &SVector<f64, N>,
        pose: &Pose,
        unit: usize,
        x_local: f64,
    ) -> [f64; 2] {
        assert!(unit < self.units, "unit {unit} of {}", self.units);
        let mut p = [pose.x_m, pose.y_m];
        let mut heading = pose.heading_rad;
        for i in 0..=unit {
            if i >= 1 {
                heading += x[2 * i + 1];
            }
            let xp = if i == unit {
                x_local
            } else {
                self.unit[i].x_rear
            };
            let (s, c) = heading.sin_cos();
            p = [p[0] + xp * c, p[1] + xp * s];
        }
        p
    }

    /// The longitudinal coordinate on its unit \[m\] (ahead of the unit's reference point
    /// positive) of axle `k` ([`Self::axles`]).
    pub fn axle_coordinate(&self, k: usize) -> f64 {
        self.axles[k].x
    }
}

/// A model of a vehicle seen as the chain of its units: its equations in the chain's own
/// layout ([`ChainModel`]), for what needs every unit (their motions, where their axles
/// run). The paper's [`Model`] and every [`crate::VehicleModel`] are one: a two-unit vehicle is the
/// chain of two units (the same dynamics to rounding, `tests/chain.rs`).
pub trait AsChain<const N: usize>: Plant<N> {
    /// The chain model of the vehicle.
    ///
    /// # Errors
    /// [`ChainModel::new`]'s (a vehicle that built as a plant builds as a chain).
    fn as_chain(&self) -> Result<ChainModel<N>, ModelError>;
}

impl AsChain<4> for Model {
    fn as_chain(&self) -> Result<ChainModel<4>, ModelError> {
        ChainModel::new(&ChainSpec::from(*Plant::params(self)))
    }
}
