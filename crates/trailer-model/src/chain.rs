//! The single-track model of a towing unit and a chain of n ≥ 1 towed units
//! ([`ChainSpec`]), with the towing unit's longitudinal speed V(t) prescribed.
//!
//! # Coordinates
//!
//! Unit 0 is the towing unit, units 1…n the towed units front to back. ψ_i \[rad\] is the
//! heading of unit i, θ_i = ψ_i − ψ_{i−1} \[rad\] the articulation angle at coupling i (the
//! coupling H_i in front of unit i; H_1 is the towing unit's rear coupling, the paper's
//! hitch H). E1_i, E2_i are the unit vectors along and to the left of unit i. Each unit has a
//! longitudinal coordinate x \[m\] along E1_i from its reference point, ahead positive: the
//! towing unit's reference point is H_1 (its file positions as given), a towed unit's is its
//! front coupling H_i (file positions negated: centre of gravity x = −h_i, axle x = −ℓ, rear
//! coupling H_{i+1} at x = −ρ_i).
//!
//! Generalised speeds (n + 2) u = (v, r, θ̇_1, …, θ̇_n): v \[m/s\] the lateral velocity of
//! H_1 along E2_0, r = ψ̇_0 \[rad/s\] the towing unit's yaw rate, θ̇_i \[rad/s\]. The angular
//! velocity of unit i is Ω_i = r + θ̇_1 + … + θ̇_i. The velocity along E1_0 is not a
//! generalised speed: the constraint (eq. 3 of the paper)
//!
//! ```text
//! v_H1 · E1_0 = V(t)                                        (C)
//! ```
//!
//! prescribes it. Its ideal constraint force λ E1_0 acts along the towing unit's axis; its
//! virtual power λ E1_0·δv vanishes for every variation of u (all partial velocities of the
//! points on that axis are along E2_0), so it drops out of Kane's equations.
//!
//! **Reduced state** (N = 2(n + 1) + relaxing axles):
//! `[v, r, θ̇_1, θ_1, θ̇_2, θ_2, …, θ̇_n, θ_n, α′…]` (lagged slips α′ \[rad\] of the relaxing
//! axles in axle order: towing unit first, each unit in file order). θ_1 sits at index 3 =
//! [`crate::HITCH_ANGLE`], as in every [`Plant`]; but indices 1, 2 are r and θ̇_1, not the
//! Appellian pseudovelocities σ2, σ3 of the paper's [`crate::Model`]. With one towed unit
//! (σ1 = v, ψ̇ = r, θ = θ_1):
//!
//! ```text
//! σ1 = v,  σ2 = r + (m1 d / I1) v,  σ3 = r + θ̇ − (m2 h / I2) v cos θ     (eq. 4)
//! v = σ1,  r = σ2 − (m1 d / I1) σ1, θ̇ = σ3 − σ2 + σ1 (m1 d / I1 + (m2 h / I2) cos θ)
//! ```
//!
//! # Kinematics of the coupling points
//!
//! In the towing unit's frame (so that ψ_0 drops out; E1_i = (cos φ_i, sin φ_i) with
//! φ_i = θ_1 + … + θ_i), a point at x on unit i with reference point P_i has
//!
//! ```text
//! velocity      v_P = v_{P_i} + x Ω_i E2_i
//! acceleration  a_P = a_{P_i} + x Ω̇_i E2_i − x Ω_i² E1_i
//! ```
//!
//! from v_{H1} = V E1_0 + v E2_0, a_{H1} = (V̇ − v r) E1_0 + (v̇ + V r) E2_0, and P_{i+1} = the
//! point x = x_rear,i (= −ρ_i; 0 on the towing unit) of unit i. Every velocity is
//! V E1_0 + Σ_k W_k u_k, every acceleration Σ_k W_k u̇_k + A (partial velocities W_k \[m\] or
//! \[1\], velocity-product and V, V̇ terms A \[m/s²\]); the recursion above carries W_k and A
//! from coupling to coupling. The partial angular velocities β_{i,k} = ∂Ω_i/∂u_k are 0 for v,
//! 1 for r, 1 for θ̇_j with j ≤ i.
//!
//! # Equations (Kane)
//!
//! ```text
//! Σ_l M_kl u̇_l = Q_k − Σ_i m_i W^C_{i,k} · A^C_i,   M_kl = Σ_i m_i W^C_{i,k}·W^C_{i,l} + J_i β_{i,k} β_{i,l}
//! ```
//!
//! (C_i the centre of gravity of unit i, m_i \[kg\], J_i \[kg m²\] about C_i). The generalised
//! forces Q_k \[N or N m\] are the axle forces F n at their wheel centres (n = E2_i, on a
//! steered axle E2_0 turned by δ), Q_k += F n·W^axle_k; the yaw moment M_z \[N m\] on the towing
//! unit, Q_r += M_z; and per coupling i the torque T_i \[N m\] (+T_i on unit i−1, −T_i on unit
//! i) T_i = c_h θ̇_i + M_c sat(θ̇_i/ω_c) + k_i θ_i, which enters only Q_{θ̇_i} −= T_i (the
//! spring k_i \[N m/rad\] is zero unless set by [`ChainModel::with_coupling_stiffness`]). M is
//! symmetric positive definite; it is factored (LDLᵀ) at each evaluation on fixed-size
//! arrays: the right-hand side allocates nothing and is generic over the scalar, so
//! Jacobians are exact (forward-mode AD).
//!
//! # Axle forces
//!
//! As in [`crate::VehicleModel`]: the slip angle of a wheel centre with velocity v_P is
//! α = δ_axle − atan(v_P·E2_i / v_P·E1_i) (eq. 2 in body-frame form; on the towing unit
//! v_P·E1_0 = V), its force F = law(α) ([`tires::TireLaw`], built with the static load of
//! [`ChainSpec::static_loads`]); an axle with relaxation length σ > 0 has the lagged slip
//! α′ with σ α̇′ = v_x (α − α′), v_x = v_P·E1_i, and the force law(α′).
//!
//! # As a [`Plant`]
//!
//! [`ChainModel<N>`] is a `Plant<N>`: the right-hand sides (with a yaw moment on the towing
//! unit), exact Jacobians, the linearisation about straight running, the open-loop spectrum
//! and V_crit come from the trait. What the trait calls "the hitch" is the FIRST coupling
//! H_1: [`Plant::hitch_angle_rate`] is θ̇_1, [`crate::HITCH_ANGLE`] indexes θ_1,
//! [`Plant::trailer_longitudinal_speed`] is the first towed unit's, [`Plant::params`] the
//! towing unit with the first towed unit ([`ChainSpec::first_pair_params`]), and the full
//! state of [`Plant::rhs_full`] appends ψ_0 and the position of H_1. The validity guard
//! ([`Plant::guard_values`]) watches every towed unit's axles.
//!
//! A vehicle file with `[[trailers]]` ([`crate::VehicleSpec`]) builds a
//! [`crate::VehicleModel`] with this model behind it, its state mapped to the layout of every
//! plant (the first four states \[σ1, σ2, σ3, θ\] of eq. 4 for the first articulation, the
//! rest as here): that is the model the engines run.
//!
//! ```
//! use trailer_model::{
//!     ChainModel, ChainSpec, CriticalSpeedOptions, Plant, TowedUnitSpec, VehicleParams,
//! };
//!
//! // Table I with a second, lighter caravan 4 m behind the first one's hitch
//! let mut spec = ChainSpec::from(VehicleParams::default());
//! let mut first = spec.trailer.take().unwrap();
//! first.rear_coupling = Some(4.0);
//! let second = TowedUnitSpec {
//!     mass: 600.0,
//!     yaw_inertia: 700.0,
//!     cog: 2.0,
//!     axle: Some(2.3),
//!     cornering_stiffness: Some(40e3),
//!     rear_coupling: None,
//!     ..first.clone()
//! };
//! spec.trailers = vec![first, second];
//! let model = ChainModel::<6>::new(&spec).unwrap(); // 2 states per unit
//! let vc = model.critical_speed(&CriticalSpeedOptions::default()).unwrap();
//! assert!(vc.v_crit_mps > 10.0 && vc.v_crit_mps < 60.0);
//! ```

use nalgebra::SVector;
use num_dual::DualNum;
use tires::{TireLaw, TireModel};

use crate::chain_spec::{MAX_CHAIN_AXLES, MAX_TOWED_UNITS};
use crate::model::is_plain_zero;
use crate::{ChainSpec, Inputs, Model, ModelError, Plant, SwitchingKind, VehicleParams};

mod motion;
pub use motion::{AsChain, Pose, UnitMotion};

/// Most units (towing unit included).
const MAX_UNITS: usize = MAX_TOWED_UNITS + 1;
/// Most generalised speeds.
const MAX_DOF: usize = MAX_UNITS + 1;

/// One axle of a [`ChainModel`], resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainAxle {
    /// unit index (0: the towing unit)
    pub unit: usize,
    /// position as in the file \[m\]: ahead of the rear coupling on the towing unit, behind
    /// the front coupling on a towed unit
    pub position_m: f64,
    /// turns with δ (towing unit only)
    pub steered: bool,
    /// tyre law, built with the static load
    pub tire: TireLaw,
    /// static vertical load \[N\]
    pub vertical_load: f64,
    /// relaxation length σ \[m\]
    pub relaxation_length_m: f64,
    /// index of α′ in the reduced state (σ > 0)
    pub state: Option<usize>,
    /// key path in the vehicle file
    pub key: String,
    /// x on its unit, ahead of the reference point positive \[m\]
    x: f64,
    /// 1/σ \[1/m\] (0 without relaxation)
    inv_sigma: f64,
    /// tan α_cr (+∞ without a sliding limit)
    tan_critical: f64,
    /// tan α_sat (+∞ without saturation)
    tan_saturation: f64,
}

/// Constants of one unit.
#[derive(Debug, Clone, Copy, Default)]
struct UnitConst {
    /// m \[kg\]
    mass: f64,
    /// J about the centre of gravity \[kg m²\]
    inertia: f64,
    /// x of the centre of gravity \[m\]
    x_cog: f64,
    /// x of the rear coupling \[m\] (0 on the towing unit; unused on the last unit)
    x_rear: f64,
    /// the unit's axles are `axles[first_axle..end_axle]`
    first_axle: usize,
    end_axle: usize,
}

/// The torque law of one coupling.
#[derive(Debug, Clone, Copy, Default)]
struct CouplingLaw {
    /// c_h \[N m s/rad\]
    damping: f64,
    /// M_c \[N m\]
    friction: f64,
    /// ω_c \[rad/s\]
    regularisation: f64,
    /// k \[N m/rad\]
    stiffness: f64,
}

/// Orientation, angular velocity and reference-point velocity of one unit in the towing
/// unit's frame.
#[derive(Debug, Clone, Copy)]
struct Frame<D> {
    /// cos φ_i, sin φ_i
    cos: D,
    sin: D,
    /// Ω_i \[rad/s\]
    omega: D,
    /// velocity of the reference point \[m/s\] (components in the towing unit's frame)
    vel: [D; 2],
}

/// Kane's equations of one evaluation while they are assembled unit by unit
/// ([`ChainModel::add_unit`]).
///
/// U ≥ the number of units and DOF = U + 1 size its arrays: exactly, for the unit counts
/// that have their own code (the arrays then live in registers), or the most a chain has.
struct Kane<D, const N: usize, const U: usize, const DOF: usize> {
    /// every unit's frame
    frames: [Frame<D>; U],
    /// (sin δ, cos δ), and whether δ is a plain zero (then (0, 1))
    steering: (D, D),
    plain_delta: bool,
    /// M (lower triangle) and the right-hand side of M u̇ = …
    mass: [[D; DOF]; DOF],
    rhs: [D; DOF],
    /// partial velocities W_k and bias acceleration A of the current reference point
    w: [[D; 2]; DOF],
    acc: [D; 2],
    /// the rates (the lagged slips' so far)
    dx: SVector<D, N>,
}

impl<D: DualNum<Primitive = f64> + Copy, const N: usize, const U: usize, const DOF: usize>
    Kane<D, N, U, DOF>
{
    /// Nothing assembled yet: the frames of the `nu` units, W and A at H_1.
    #[inline(always)]
    fn new(
        x: &SVector<D, N>,
        u: &Inputs<D>,
        first: (D, D),
        nu: usize,
        model: &ChainModel<N>,
    ) -> Self {
        let zero = D::from(0.0);
        let (v, r) = (x[0], x[1]);
        let plain_delta = is_plain_zero(u.steering_angle);
        let mut w = [[zero; 2]; DOF];
        w[0] = [zero, D::from(1.0)];
        Self {
            frames: model.frames_of::<D, U>(x, u.speed, first, nu),
            steering: if plain_delta {
                (zero, D::from(1.0))
            } else {
                u.steering_angle.sin_cos()
            },
            plain_delta,
            mass: [[zero; DOF]; DOF],
            rhs: [zero; DOF],
            w,
            acc: [u.acceleration - v * r, u.speed * r],
            dx: SVector::<D, N>::from_element(zero),
        }
    }
}

/// The chain model with N reduced states (module docs).
#[derive(Debug, Clone)]
pub struct ChainModel<const N: usize> {
    spec: ChainSpec,
    params: VehicleParams,
    units: usize,
    unit: [UnitConst; MAX_UNITS],
    /// coupling i (1-based) at index i − 1
    coupling: [CouplingLaw; MAX_TOWED_UNITS],
    axles: Vec<ChainAxle>,
    tyre_forces: bool,
    switching: Vec<SwitchingKind>,
    /// m1 d / I1 and m2 h / I2 \[1/m\] of the first pair (eq. 4): the paper layout's map
    paper_ratios: (f64, f64),
}

#[inline]
fn dot<D: DualNum<Primitive = f64> + Copy>(a: [D; 2], b: [D; 2]) -> D {
    a[0] * b[0] + a[1] * b[1]
}

/// Solves M z = b for a symmetric positive definite M (lower triangle given) of size n by
/// LDLᵀ, in place (z in b): the factorisation and the two triangular solves. Inlined where n
/// is a constant, so that its loops have known lengths.
#[inline(always)]
fn ldlt_in_place<D: DualNum<Primitive = f64> + Copy, const M: usize>(
    a: &mut [[D; M]; M],
    b: &mut [D; M],
    n: usize,
) {
    // a[j][j] ends as 1/D_j (one division per pivot), a[i][j] (i > j) as L_ij
    let mut d = [D::from(0.0); M];
    for j in 0..n {
        let mut dj = a[j][j];
        for k in 0..j {
            dj -= a[j][k] * a[j][k] * d[k];
        }
        d[j] = dj;
        let inv = dj.recip();
        a[j][j] = inv;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k] * d[k];
            }
            a[i][j] = s * inv;
        }
    }
    for i in 0..n {
        for k in 0..i {
            let t = a[i][k] * b[k];
            b[i] -= t;
        }
    }
    for i in 0..n {
        b[i] *= a[i][i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            let t = a[k][i] * b[k];
            b[i] -= t;
        }
    }
}

impl<const N: usize> ChainModel<N> {
    /// Builds the model of a chain with N = 2·(units) + (axles with σ > 0) states.
    ///
    /// # Errors
    /// [`ChainSpec::check_physics`]'s errors; [`ModelError::StateCount`] when N does not fit.
    pub fn new(spec: &ChainSpec) -> Result<Self, ModelError> {
        let laws = spec.check_physics()?;
        let resolved = spec.resolved_axles()?;
        let relaxed = spec.relaxed_axles()?;
        let units = spec.units();
        if N != 2 * units + relaxed {
            return Err(ModelError::StateCount {
                relaxed,
                expected: 2 * units + relaxed,
                requested: N,
                hint: " (a chain has 2 states per unit plus one per relaxing axle)",
            });
        }
        debug_assert!(resolved.len() <= MAX_CHAIN_AXLES);
        let (loads, _) = spec.static_loads()?;
        let mut unit = [UnitConst::default(); MAX_UNITS];
        unit[0] = UnitConst {
            mass: spec.tractor.mass,
            inertia: spec.tractor.yaw_inertia,
            x_cog: spec.tractor.cog,
            x_rear: 0.0,
            first_axle: 0,
            end_axle: 0,
        };
        let mut coupling = [CouplingLaw::default(); MAX_TOWED_UNITS];
        for (i, t) in spec.towed_units().iter().enumerate() {
            unit[i + 1] = UnitConst {
                mass: t.mass,
                inertia: t.yaw_inertia,
                x_cog: -t.cog,
                x_rear: -t.rear_coupling.unwrap_or(0.0),
                first_axle: 0,
                end_axle: 0,
            };
            let (h, _) = spec.coupling(i);
            coupling[i] = CouplingLaw {
                damping: h.yaw_damping_nms,
                friction: h.friction_torque_nm,
                regularisation: h.friction_regularisation_rad_s,
                stiffness: 0.0,
            };
        }
        let mut next_state = 2 * units;
        let mut axles = Vec::with_capacity(resolved.len());
        for ((a, law), fz) in resolved.iter().zip(laws).zip(loads) {
            let sigma = a.spec.relaxation_length_m;
            let state = (sigma > 0.0).then(|| {
                next_state += 1;
                next_state - 1
            });
            let tan_of = |angle: f64| {
                if angle < std::f64::consts::FRAC_PI_2 {
                    angle.tan()
                } else {
                    f64::INFINITY
                }
            };
            axles.push(ChainAxle {
                unit: a.unit,
                position_m: a.spec.position_m,
                steered: a.spec.steered,
                tire: law,
                vertical_load: fz,
                relaxation_length_m: sigma,
                state,
                key: a.key.clone(),
                x: if a.unit == 0 {
                    a.spec.position_m
                } else {
                    -a.spec.position_m
                },
                inv_sigma: if sigma > 0.0 { 1.0 / sigma } else { 0.0 },
                tan_critical: tan_of(law.critical_slip_angle().unwrap_or(f64::INFINITY)),
                tan_saturation: tan_of(law.saturation_slip_angle()),
            });
        }
        // resolved axles come unit by unit
        for (k, a) in axles.iter().enumerate() {
            let u = &mut unit[a.unit];
            if u.end_axle == 0 {
                u.first_axle = k;
            }
            u.end_axle = k + 1;
        }
        let mut switching = Vec::new();
        for (i, a) in axles.iter().enumerate() {
            if a.tire.kinks().at_zero {
                switching.push(SwitchingKind::SlipSign { axle: i });
            }
        }
        for (i, a) in axles.iter().enumerate() {
            if a.tire.kinks().sliding_limit.is_some() {
                switching.push(SwitchingKind::SlidingOnset { axle: i });
            }
        }
        for c in coupling.iter().take(units - 1) {
            if c.friction > 0.0 {
                switching.push(SwitchingKind::HitchFriction);
            }
        }
        let params = spec.first_pair_params()?;
        let (t, r) = (&params.tractor, &params.trailer);
        let i1 = t.yaw_inertia + t.mass * t.cog * t.cog;
        let i2 = r.yaw_inertia + r.mass * r.cog * r.cog;
        Ok(Self {
            spec: spec.clone(),
            params,
            paper_ratios: (t.mass * t.cog / i1, r.mass * r.cog / i2),
            units,
            unit,
            coupling,
            axles,
            tyre_forces: true,
            switching,
        })
    }

    /// The vehicle file it was built from.
    pub fn spec(&self) -> &ChainSpec {
        &self.spec
    }

    /// Number of units (towing unit + towed units).
    pub fn units(&self) -> usize {
        self.units
    }

    /// The axles, towing unit first, each unit in file order.
    pub fn axles(&self) -> &[ChainAxle] {
        &self.axles
    }

    /// Index of θ_i (coupling i = 1…n) in the reduced state.
    pub fn articulation_angle_index(coupling: usize) -> usize {
        2 * coupling + 1
    }

    /// Index of θ̇_i (coupling i = 1…n) in the reduced state.
    pub fn articulation_rate_index(coupling: usize) -> usize {
        2 * coupling
    }

    /// A copy with a torsional spring k \[N m/rad\] at coupling i (1…n): T_i gains k θ_i. Not
    /// part of the vehicle file: a locked or stiff coupling (e.g. the rigid-lock check of the
    /// tests: k → ∞ makes the two units one body).
    ///
    /// # Panics
    /// If `coupling` is not in 1…n.
    pub fn with_coupling_stiffness(mut self, coupling: usize, k_nm_per_rad: f64) -> Self {
        assert!(
            (1..self.units).contains(&coupling),
            "coupling {coupling} not in 1..={}",
            self.units - 1
        );
        self.coupling[coupling - 1].stiffness = k_nm_per_rad;
        self
    }

    /// A copy without any tyre force (the axles still exist and their lagged slips still
    /// evolve): the mechanics of the free chain alone, for checks such as conservation of
    /// its kinetic energy.
    pub fn without_tyre_forces(mut self) -> Self {
        self.tyre_forces = false;
        self
    }

    /// The torque T_i \[N m\] at coupling i (1…n) at articulation angle θ_i \[rad\] and rate θ̇_i
    /// \[rad/s\]: c_h θ̇ + M_c sat(θ̇/ω_c) + k θ (on unit i − 1; −T_i on unit i).
    pub fn coupling_torque<D: DualNum<Primitive = f64> + Copy>(
        &self,
        coupling: usize,
        angle: D,
        rate: D,
    ) -> D {
        let c = &self.coupling[coupling - 1];
        let mut t = D::from(0.0);
        if c.damping != 0.0 {
            t += rate * c.damping;
        }
        if c.friction != 0.0 {
            let w = rate.re();
            t += if w > c.regularisation {
                D::from(c.friction)
            } else if w < -c.regularisation {
                D::from(-c.friction)
            } else {
                rate * (c.friction / c.regularisation)
            };
        }
        if c.stiffness != 0.0 {
            t += angle * c.stiffness;
        }
        t
    }

    /// Orientation, angular velocity and reference-point velocity of every unit.
    #[inline]
    fn frames<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        speed: D,
    ) -> [Frame<D>; MAX_UNITS] {
        self.frames_of::<D, MAX_UNITS>(x, speed, x[3].sin_cos(), self.units)
    }

    /// [`Self::frames`] of the first `nu` units, with (sin θ_1, cos θ_1) given.
    #[inline(always)]
    fn frames_of<D: DualNum<Primitive = f64> + Copy, const U: usize>(
        &self,
        x: &SVector<D, N>,
        speed: D,
        first: (D, D),
        nu: usize,
    ) -> [Frame<D>; U] {
        let zero = D::from(0.0);
        let mut f = [Frame {
            cos: D::from(1.0),
            sin: zero,
            omega: x[1],
            vel: [speed, x[0]],
        }; U];
        for i in 1..nu {
            let p = f[i - 1];
            let xr = self.unit[i - 1].x_rear;
            let vel = if i == 1 {
                p.vel
            } else {
                // v_P = v_ref + x Ω E2 with E2 = (−sin φ, cos φ)
                [
                    p.vel[0] - p.sin * p.omega * xr,
                    p.vel[1] + p.cos * p.omega * xr,
                ]
            };
            let (s, c) = if i == 1 {
                first
            } else {
                x[2 * i + 1].sin_cos()
            };
            let (cos, sin) = if i == 1 {
                (c, s)
            } else {
                (p.cos * c - p.sin * s, p.sin * c + p.cos * s)
            };
            f[i] = Frame {
                cos,
                sin,
                omega: p.omega + x[2 * i],
                vel,
            };
        }
        f
    }

    /// tan α and the longitudinal wheel-centre speed v_x \[m/s\] of an unsteered axle, or the
    /// ratio r = v_lat/V (α = δ − atan r) of a steered one, from its unit's frame.
    #[inline]
    fn axle_kinematics<D: DualNum<Primitive = f64> + Copy>(
        a: &ChainAxle,
        f: &Frame<D>,
        speed: D,
    ) -> (D, D) {
        if a.unit == 0 {
            // the towing unit's frame is the reference frame: v_P = (V, v + x r)
            let lat = f.vel[1] + f.omega * a.x;
            if a.steered {
                (lat / speed, speed)
            } else {
                (-(lat / speed), speed)
            }
        } else {
            let vx = f.vel[0] * f.cos + f.vel[1] * f.sin;
            let vy = -f.vel[0] * f.sin + f.vel[1] * f.cos + f.omega * a.x;
            (-(vy / vx), vx)
        }
    }

    /// F of a steered axle from r = (v + a r)/V, as [`crate::VehicleModel`] computes it.
    #[inline]
    fn steered_force<D: DualNum<Primitive = f64> + Copy>(tire: &TireLaw, delta: D, r: D) -> D {
        if is_plain_zero(delta) {
            return tire.lateral_force_from_tan(-r);
        }
        let tan_delta = delta.tan();
        let den = D::from(1.0) + r * tan_delta;
        if den.re() > 0.0 {
            tire.lateral_force_from_tan((tan_delta - r) / den)
        } else {
            tire.lateral_force(delta - r.atan())
        }
    }

    /// Slip angle α \[rad\] of every axle (the instantaneous slip, which relaxing axles lag
    /// behind), in axle order, into `out`.
    pub fn slip_angles<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        out: &mut [D],
    ) {
        let frames = self.frames(x, u.speed);
        for (o, a) in out.iter_mut().zip(&self.axles) {
            let (t, _) = Self::axle_kinematics(a, &frames[a.unit], u.speed);
            *o = if a.steered {
                u.steering_angle - t.atan()
            } else {
                t.atan()
            };
        }
    }

    /// The right-hand side with an optional yaw moment M_z \[N m\] on the towing unit.
    fn rhs_actuated<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: Option<D>,
    ) -> SVector<D, N> {
        self.rhs_actuated_with(x, u, yaw_moment, x[3].sin_cos())
    }

    /// [`Self::rhs_actuated`] with (sin θ_1, cos θ_1) given.
    pub(crate) fn rhs_actuated_with<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: Option<D>,
        first: (D, D),
    ) -> SVector<D, N> {
        // the common unit counts with arrays of their own size (as the factorisation's size
        // in [`ldlt_in_place`]), longer chains in arrays of the most units
        match self.units {
            2 => self.equations_of_motion::<D, 2, 3>(x, u, yaw_moment, first, 2),
            3 => self.equations_of_motion::<D, 3, 4>(x, u, yaw_moment, first, 3),
            nu => self.equations_of_motion::<D, MAX_UNITS, MAX_DOF>(x, u, yaw_moment, first, nu),
        }
    }

    /// Kane's equations of a chain of `nu` ≤ U units (module docs), solved for the rates;
    /// DOF = U + 1.
    #[inline(always)]
    fn equations_of_motion<D: DualNum<Primitive = f64> + Copy, const U: usize, const DOF: usize>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: Option<D>,
        first: (D, D),
        nu: usize,
    ) -> SVector<D, N> {
        let mut kane = Kane::<D, N, U, DOF>::new(x, u, first, nu, self);
        // with U = nu the loop has a known length and each unit's index is a constant in its
        // inlined step; the same operations in the same order for every U
        for i in 0..nu {
            self.add_unit(&mut kane, x, u, i, nu);
        }
        let Kane {
            mut mass,
            mut rhs,
            mut dx,
            ..
        } = kane;
        if let Some(m) = yaw_moment {
            rhs[1] += m;
        }
        for i in 1..nu {
            let c = &self.coupling[i - 1];
            if c.damping != 0.0 || c.friction != 0.0 || c.stiffness != 0.0 {
                rhs[1 + i] -= self.coupling_torque(i, x[2 * i + 1], x[2 * i]);
            }
        }
        ldlt_in_place(&mut mass, &mut rhs, nu + 1);
        dx[0] = rhs[0];
        dx[1] = rhs[1];
        for i in 1..nu {
            dx[2 * i] = rhs[1 + i];
            dx[2 * i + 1] = x[2 * i];
        }
        dx
    }

    /// Adds unit i's terms to Kane's equations (module docs): its inertia to M and to the
    /// right-hand side, its axle forces to the generalised forces, the lagged slips' rates of
    /// its relaxing axles to `dx`; then carries the partial velocities and the bias
    /// acceleration on to its rear coupling.
    #[inline(always)]
    fn add_unit<D: DualNum<Primitive = f64> + Copy, const U: usize, const DOF: usize>(
        &self,
        kane: &mut Kane<D, N, U, DOF>,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        i: usize,
        nu: usize,
    ) {
        let zero = D::from(0.0);
        let (speed, delta) = (u.speed, u.steering_angle);
        let (sin_delta, cos_delta) = kane.steering;
        let f = &kane.frames[i];
        let uc = &self.unit[i];
        let e1 = [f.cos, f.sin];
        let e2 = [-f.sin, f.cos];
        let omega2 = f.omega * f.omega;
        // β_{i,k}: 0 for v, 1 for r and θ̇_j (j ≤ i), 0 beyond; the speeds beyond θ̇_i
        // (k > i + 1) move neither unit i nor the units in front of it: W_k = 0 there
        let beta = |k: usize| k >= 1;
        let dofs = i + 2;
        // centre of gravity: W^C_k, A^C
        let mut wc = kane.w;
        for (k, wk) in wc.iter_mut().enumerate().take(dofs) {
            if beta(k) {
                wk[0] += e2[0] * uc.x_cog;
                wk[1] += e2[1] * uc.x_cog;
            }
        }
        let ac = [
            kane.acc[0] - e1[0] * omega2 * uc.x_cog,
            kane.acc[1] - e1[1] * omega2 * uc.x_cog,
        ];
        for k in 0..dofs {
            for l in 0..=k {
                let mut m_kl = dot(wc[k], wc[l]) * uc.mass;
                if beta(k) && beta(l) {
                    m_kl += D::from(uc.inertia);
                }
                kane.mass[k][l] += m_kl;
            }
            kane.rhs[k] -= dot(wc[k], ac) * uc.mass;
        }
        // axle forces: resultant R (towing unit's frame) and moment about the reference
        // point
        let mut res = [zero; 2];
        let mut moment = zero;
        for a in &self.axles[uc.first_axle..uc.end_axle] {
            let (t, vx) = Self::axle_kinematics(a, f, speed);
            if let Some(j) = a.state {
                let alpha = if a.steered {
                    delta - t.atan()
                } else {
                    t.atan()
                };
                kane.dx[j] = (alpha - x[j]) * vx * a.inv_sigma;
            }
            if !self.tyre_forces {
                continue;
            }
            let force = match a.state {
                None if a.steered => Self::steered_force(&a.tire, delta, t),
                None => a.tire.lateral_force_from_tan(t),
                Some(j) => a.tire.lateral_force(x[j]),
            };
            if a.steered && !kane.plain_delta {
                // n = E2_0 turned by δ = (−sin δ, cos δ); n·E2_0 = cos δ
                res[0] -= force * sin_delta;
                res[1] += force * cos_delta;
                moment += force * cos_delta * a.x;
            } else {
                res[0] += force * e2[0];
                res[1] += force * e2[1];
                moment += force * a.x;
            }
        }
        for k in 0..dofs {
            let mut q = dot(res, kane.w[k]);
            if beta(k) {
                q += moment;
            }
            kane.rhs[k] += q;
        }
        // on to the next coupling point
        if i + 1 < nu {
            let xr = uc.x_rear;
            if xr != 0.0 {
                for (k, wk) in kane.w.iter_mut().enumerate().take(dofs) {
                    if beta(k) {
                        wk[0] += e2[0] * xr;
                        wk[1] += e2[1] * xr;
                    }
                }
                kane.acc = [
                    kane.acc[0] - e1[0] * omega2 * xr,
                    kane.acc[1] - e1[1] * omega2 * xr,
                ];
            }
        }
    }

    /// Per axle: its slip for the switching functions and the guard (tan α of an
    /// instantaneous axle, tan α_F of [`Model::front_slip_tangent`] for a steered one, α′ of a
    /// relaxing one; `is_angle` tells which) and its longitudinal speed v_x \[m/s\].
    fn axle_slips(&self, x: &SVector<f64, N>, u: &Inputs) -> [(f64, bool, f64); MAX_CHAIN_AXLES] {
        let frames = self.frames(x, u.speed);
        let mut out = [(0.0, false, 0.0); MAX_CHAIN_AXLES];
        for (o, a) in out.iter_mut().zip(&self.axles) {
            let (t, vx) = Self::axle_kinematics(a, &frames[a.unit], u.speed);
            *o = match a.state {
                Some(j) => (x[j], true, vx),
                None if a.steered => match Model::front_slip_tangent(u.steering_angle, t) {
                    Some(tan) => (tan, false, vx),
                    None => (u.steering_angle - t.atan(), true, vx),
                },
                None => (t, false, vx),
            };
        }
        out
    }
}

impl<const N: usize> Plant<N> for ChainModel<N> {
    #[inline]
    fn rhs<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
    ) -> SVector<D, N> {
        self.rhs_actuated(x, u, None)
    }

    fn rhs_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> SVector<D, N> {
        self.rhs_actuated(x, u, Some(yaw_moment))
    }

    /// r = ψ̇_0 = x\[1\].
    #[inline]
    fn yaw_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        x[1]
    }

    /// θ̇_1 = x\[2\], the FIRST articulation (the hitch of the towing unit).
    fn hitch_angle_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D {
        x[2]
    }

    /// The towing unit and the first towed unit in the paper's form
    /// ([`ChainSpec::first_pair_params`]).
    fn params(&self) -> &VehicleParams {
        &self.params
    }

    fn switching_kinds(&self) -> &[SwitchingKind] {
        &self.switching
    }

    /// SlipSign: tan α of an instantaneous axle (tan α_F for a steered one), α′ of a relaxing
    /// one; SlidingOnset: tan²α − tan²α_cr, or α′² − α_cr²; HitchFriction (one per coupling
    /// with M_c > 0, front to back): θ̇_i² − ω_c².
    fn switching_functions(&self, x: &SVector<f64, N>, u: &Inputs, g: &mut [f64]) {
        let slips = self.axle_slips(x, u);
        let mut couplings = (1..self.units).filter(|&i| self.coupling[i - 1].friction > 0.0);
        for (g, kind) in g.iter_mut().zip(&self.switching) {
            *g = match *kind {
                SwitchingKind::SlipSign { axle } => slips[axle].0,
                SwitchingKind::SlidingOnset { axle } => {
                    let (s, is_angle, _) = slips[axle];
                    let a = &self.axles[axle];
                    let cr = if is_angle {
                        a.tire.critical_slip_angle().unwrap_or(f64::INFINITY)
                    } else {
                        a.tan_critical
                    };
                    s * s - cr * cr
                }
                SwitchingKind::HitchFriction => {
                    let i = couplings.next().unwrap_or(1);
                    let wc = self.coupling[i - 1].regularisation;
                    let w = x[2 * i];
                    w * w - wc * wc
                }
            };
        }
    }

    /// As [`crate::VehicleModel`]'s, over the towing unit's axles; the last entry is the
    /// largest −v_x over the towed units' axles (any towed unit stops).
    fn guard_values(&self, x: &SVector<f64, N>, u: &Inputs) -> [f64; 5] {
        let slips = self.axle_slips(x, u);
        let mut out = [f64::NEG_INFINITY; 5];
        let (sd, cd) = if u.steering_angle == 0.0 {
            (0.0, 1.0)
        } else {
            u.steering_angle.sin_cos()
        };
        for (a, &(s, is_angle, vx)) in self.axles.iter().zip(&slips) {
            if a.unit != 0 {
                out[4] = out[4].max(-vx);
                continue;
            }
            let tan_abs = if !is_angle {
                s.abs()
            } else if s.abs() < std::f64::consts::FRAC_PI_2 {
                s.abs().tan()
            } else {
                f64::INFINITY
            };
            let k = usize::from(!a.steered);
            if a.tan_saturation.is_finite() {
                out[k] = out[k].max(tan_abs - a.tan_saturation);
            }
            if a.steered {
                let lateral = x[0] + x[1] * a.x;
                let speed = if u.steering_angle == 0.0 {
                    u.speed
                } else {
                    u.speed * cd + lateral * sd
                };
                out[2] = out[2].max(-speed);
            }
        }
        out[3] = -u.speed;
        out
    }
}
