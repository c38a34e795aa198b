//! The vehicle file with the model variants: per-axle tyre laws, tyre
//! relaxation, axle lists (tandems) and hitch damping, as serde data with validation.
//!
//! Every key of today's `configs/vehicle.toml` ([`VehicleParams`]) keeps its meaning; the new
//! keys are optional and default to the paper's model:
//!
//! ```toml
//! [tractor]                       # as in configs/vehicle.toml, plus optionally
//! front_relaxation_length_m = 0.3 # σ [m] of the front axle (default 0: no lag)
//! rear_relaxation_length_m = 0.3
//! front_tire = { law = "magic_formula", shape_factor = 1.536, peak_friction = 0.9 }
//! rear_tire = { law = "linear" }  # default { law = "brush" } with [friction]
//!
//! [trailer]                       # either `axle` + `cornering_stiffness` (+ `tire`,
//! mass = 985.0                    #   `relaxation_length_m`) or a list of axles:
//! yaw_inertia = 1416.0
//! cog = 2.9
//! [[trailer.axles]]
//! position_m = 2.4                # behind the hitch (tractor: in front of it) [m]
//! cornering_stiffness = 25e3      # [N/rad]
//! [[trailer.axles]]
//! position_m = 3.2
//! cornering_stiffness = 25e3
//! relaxation_length_m = 0.3       # optional, as `tire` = { law = … }
//!
//! [hitch]                         # optional: a friction sway-control device
//! yaw_damping_nms = 0.0           # c_h [N m s/rad], viscous
//! friction_torque_nm = 400.0      # M_c [N m], Coulomb
//! friction_regularisation_rad_s = 0.02   # ω_c [rad/s] (default 0.02)
//! ```
//!
//! **Chains.** A file may give a chain of towed units instead of `[trailer]`: `[[trailers]]`
//! ([`crate::ChainSpec`]'s form, each with `rear_coupling` but the last and an optional
//! `[trailers.hitch]`; no top-level `[hitch]`). Such a vehicle builds a
//! [`crate::VehicleModel`] with the chain's equations ([`crate::ChainModel`]); what only a
//! two-unit vehicle has — [`VehicleSpec::resolved_axles`], [`VehicleSpec::equivalent_params`],
//! [`VehicleSpec::axle_loads`] and the trailer's keys of [`VehicleSpec::with_parameter`] —
//! is an error naming `trailers` and the reason.
//!
//! A tractor axle list marks its steered axles with `steered = true` (at least one steered and
//! one unsteered axle). Static loads of a group of axles (the tractor's steered axles, its
//! unsteered axles, the trailer's axles) follow from the statics of Fig. 2 with the group at
//! the mean position of its axles, shared **equally** by the axles of the group (the
//! load-equalising suspension of a tandem). For the trailer this is exact statics: equal
//! loads F at l₁, l₂ balance the moment m2·g·h about the hitch iff F·(l₁ + l₂) = m2·g·h, the
//! load of one axle at (l₁ + l₂)/2.

use serde::{Deserialize, Serialize};
use tires::{TireLaw, TireLawSpec};

use crate::{
    AxleLoads, ChainSpec, FrictionParams, ModelError, TowedUnitSpec, TractorParams, TrailerParams,
    VehicleParams,
};

/// Axles of one unit closer than this \[m\] overlap (less than a small trailer wheel's
/// diameter): an error in a vehicle file ([`VehicleSpec::validate`]), usually a duplicated
/// entry. The model itself accepts coincident axles.
pub const MIN_AXLE_SPACING_M: f64 = 0.3;

/// Default ω_c \[rad/s\] of the regularised Coulomb friction at the hitch.
pub const DEFAULT_FRICTION_REGULARISATION_RAD_S: f64 = 0.02;

/// Most axles a vehicle may have (both units together).
pub const MAX_AXLES: usize = 8;

/// One axle of a unit in the list form.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxleSpec {
    /// distance \[m\] from the hitch: forward on the tractor, backward on the trailer (> 0)
    pub position_m: f64,
    /// cornering stiffness C_α of the axle (all its tyres) \[N/rad\]
    pub cornering_stiffness: f64,
    /// whether the axle turns with the steering angle δ (tractor only)
    #[serde(default)]
    pub steered: bool,
    /// the tyre law (default: brush with the vehicle's friction)
    #[serde(default)]
    pub tire: TireLawSpec,
    /// relaxation length σ \[m\] of the first-order slip lag (0: instantaneous)
    #[serde(default)]
    pub relaxation_length_m: f64,
}

/// The towing car: Table I's keys (the axle keys optional when `axles` is given) plus the
/// per-axle tyre law and relaxation length of the paper's two axles. The fields are in the
/// order of [`TractorParams`], so a file of the paper's form serialises as it does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TractorSpec {
    /// m1 \[kg\]
    pub mass: f64,
    /// J1 \[kg m²\] about C1
    pub yaw_inertia: f64,
    /// f \[m\]: hitch → front (steered) axle (paper form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub front_axle: Option<f64>,
    /// d \[m\]: hitch → centre of gravity C1
    pub cog: f64,
    /// c \[m\]: hitch → rear axle (paper form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rear_axle: Option<f64>,
    /// C_F \[N/rad\] (paper form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub front_cornering_stiffness: Option<f64>,
    /// C_R \[N/rad\] (paper form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rear_cornering_stiffness: Option<f64>,
    /// tyre law of the front axle (paper form; default brush)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub front_tire: Option<TireLawSpec>,
    /// tyre law of the rear axle (paper form; default brush)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rear_tire: Option<TireLawSpec>,
    /// σ \[m\] of the front axle (paper form; default 0)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub front_relaxation_length_m: Option<f64>,
    /// σ \[m\] of the rear axle (paper form; default 0)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rear_relaxation_length_m: Option<f64>,
    /// the axles as a list (instead of the paper form's keys)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axles: Option<Vec<AxleSpec>>,
}

/// The trailer: Table I's keys (the axle keys optional when `axles` is given) plus the tyre
/// law and relaxation length of its axle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrailerSpec {
    /// m2 \[kg\]
    pub mass: f64,
    /// J2 \[kg m²\] about C2
    pub yaw_inertia: f64,
    /// h \[m\]: hitch → centre of gravity C2
    pub cog: f64,
    /// l \[m\]: hitch → axle (paper form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axle: Option<f64>,
    /// C_T \[N/rad\] (paper form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cornering_stiffness: Option<f64>,
    /// tyre law of the axle (paper form; default brush)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tire: Option<TireLawSpec>,
    /// σ \[m\] of the axle (paper form; default 0)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relaxation_length_m: Option<f64>,
    /// the axles as a list (instead of the paper form's keys)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axles: Option<Vec<AxleSpec>>,
}

/// Yaw damping at the hitch (a friction sway-control device): the torque on the trailer
/// about the hitch is −T_h with T_h = c_h·θ̇ + M_c·sat(θ̇/ω_c), and +T_h on the tractor.
///
/// The Coulomb torque M_c·sgn θ̇ is regularised as a saturation: linear (a viscous damping
/// M_c/ω_c) for |θ̇| < ω_c, exactly M_c·sgn θ̇ beyond. Its kinks at |θ̇| = ω_c are declared as
/// the switching function θ̇² − ω_c² ([`crate::SwitchingKind::HitchFriction`]). The
/// linearisation about straight running sees the damping c_h + M_c/ω_c.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HitchSpec {
    /// viscous yaw damping c_h \[N m s/rad\] (default 0)
    #[serde(default)]
    pub yaw_damping_nms: f64,
    /// Coulomb friction torque M_c \[N m\] (default 0)
    #[serde(default)]
    pub friction_torque_nm: f64,
    /// regularisation ω_c \[rad/s\] of the Coulomb torque (default 0.02 rad/s)
    #[serde(default = "default_regularisation")]
    pub friction_regularisation_rad_s: f64,
}

fn default_regularisation() -> f64 {
    DEFAULT_FRICTION_REGULARISATION_RAD_S
}

impl Default for HitchSpec {
    fn default() -> Self {
        Self {
            yaw_damping_nms: 0.0,
            friction_torque_nm: 0.0,
            friction_regularisation_rad_s: DEFAULT_FRICTION_REGULARISATION_RAD_S,
        }
    }
}

impl HitchSpec {
    /// No torque at the hitch (the paper's frictionless hitch).
    pub fn is_free(&self) -> bool {
        self.yaw_damping_nms == 0.0 && self.friction_torque_nm == 0.0
    }
}

fn is_default_hitch(h: &HitchSpec) -> bool {
    *h == HitchSpec::default()
}

fn default_gravity() -> f64 {
    9.81
}

/// A vehicle file: [`VehicleParams`]' keys with the optional variants, or a chain of towed
/// units (`trailers`, exclusive with `trailer`). [`From<VehicleParams>`] gives the paper's
/// model; [`VehicleSpec::equivalent_params`] the single-axle vehicle of the paper's form
/// (identical to the file's keys when it has that form; an error for a chain).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleSpec {
    /// the towing car
    pub tractor: TractorSpec,
    /// the trailer of a two-unit vehicle (exclusive with `trailers`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trailer: Option<TrailerSpec>,
    /// the towed units of a chain, front to back (exclusive with `trailer`; positions as in
    /// [`crate::ChainSpec`])
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trailers: Vec<TowedUnitSpec>,
    /// tyre–road friction of the brush tyres (eq. 15)
    pub friction: FrictionParams,
    /// g \[m/s²\]
    #[serde(default = "default_gravity")]
    pub gravity: f64,
    /// torque at the hitch of a two-unit vehicle (default: none; a chain gives
    /// `trailers[i].hitch` per coupling instead)
    #[serde(default, skip_serializing_if = "is_default_hitch")]
    pub hitch: HitchSpec,
}

/// Which body an axle belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Unit {
    /// the towing car (positions forward of the hitch)
    Tractor,
    /// the trailer (positions behind the hitch)
    Trailer,
}

/// One axle, resolved: the list form of either unit's axles, with its key path in the file.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedAxle {
    /// unit
    pub unit: Unit,
    /// the axle's spec
    pub spec: AxleSpec,
    /// key path of the axle in the file (`tractor.axles[1]`, or `tractor.front_axle` …)
    pub key: String,
    /// key of its position, for error messages
    pub position_key: String,
    /// key prefix of its tyre and relaxation (`tractor.front_` / `trailer.axles[0].`)
    pub prefix: String,
}

impl ResolvedAxle {
    /// The axles as the file's checks see them.
    fn views(axles: &[ResolvedAxle]) -> Vec<AxleView<'_, Unit>> {
        axles
            .iter()
            .map(|a| AxleView {
                unit: a.unit,
                spec: &a.spec,
                key: &a.key,
                position_key: &a.position_key,
                prefix: &a.prefix,
            })
            .collect()
    }
}

impl From<VehicleParams> for VehicleSpec {
    fn from(p: VehicleParams) -> Self {
        Self {
            tractor: TractorSpec {
                mass: p.tractor.mass,
                yaw_inertia: p.tractor.yaw_inertia,
                cog: p.tractor.cog,
                front_axle: Some(p.tractor.front_axle),
                rear_axle: Some(p.tractor.rear_axle),
                front_cornering_stiffness: Some(p.tractor.front_cornering_stiffness),
                rear_cornering_stiffness: Some(p.tractor.rear_cornering_stiffness),
                front_tire: None,
                rear_tire: None,
                front_relaxation_length_m: None,
                rear_relaxation_length_m: None,
                axles: None,
            },
            trailer: Some(TrailerSpec {
                mass: p.trailer.mass,
                yaw_inertia: p.trailer.yaw_inertia,
                cog: p.trailer.cog,
                axle: Some(p.trailer.axle),
                cornering_stiffness: Some(p.trailer.cornering_stiffness),
                tire: None,
                relaxation_length_m: None,
                axles: None,
            }),
            trailers: Vec::new(),
            friction: p.friction,
            gravity: p.gravity,
            hitch: HitchSpec::default(),
        }
    }
}

pub(crate) fn invalid(
    key: impl Into<String>,
    value: f64,
    expected: impl Into<String>,
) -> ModelError {
    ModelError::InvalidSpec {
        key: key.into(),
        value,
        expected: expected.into(),
    }
}

/// An axle as a vehicle file's checks see it, whatever form resolved it (two units:
/// [`ResolvedAxle`]; a chain: [`crate::ChainAxleSpec`]).
pub(crate) struct AxleView<'a, U> {
    /// its unit
    pub unit: U,
    /// its spec
    pub spec: &'a AxleSpec,
    /// its key path
    pub key: &'a str,
    /// the key of its position
    pub position_key: &'a str,
    /// the key prefix of its tyre
    pub prefix: &'a str,
}

/// The tyre law of every axle on its static load `loads[i]` \[N\] with `friction`.
///
/// # Errors
/// [`ModelError::TireSpec`] naming the axle's tyre key.
pub(crate) fn build_tires<U>(
    axles: &[AxleView<'_, U>],
    loads: &[f64],
    friction: &FrictionParams,
) -> Result<Vec<TireLaw>, ModelError> {
    axles
        .iter()
        .zip(loads)
        .map(|(a, &fz)| {
            a.spec
                .tire
                .build(
                    a.spec.cornering_stiffness,
                    fz,
                    friction.mu_static,
                    friction.mu_dynamic,
                )
                .map_err(|source| ModelError::TireSpec {
                    key: format!("{}tire", a.prefix),
                    source,
                })
        })
        .collect()
}

/// No two axles of a unit closer than [`MIN_AXLE_SPACING_M`].
///
/// # Errors
/// [`ModelError::InvalidSpec`] naming the second axle's position.
pub(crate) fn check_axle_spacing<U: PartialEq>(
    axles: &[AxleView<'_, U>],
) -> Result<(), ModelError> {
    for (i, a) in axles.iter().enumerate() {
        for b in &axles[..i] {
            let gap = (a.spec.position_m - b.spec.position_m).abs();
            if a.unit == b.unit && gap < MIN_AXLE_SPACING_M {
                return Err(invalid(
                    a.position_key,
                    a.spec.position_m,
                    format!(
                        "at least {MIN_AXLE_SPACING_M} m from `{}` ({} m): the axles overlap",
                        b.key, b.spec.position_m
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for x in xs {
        sum += x;
        n += 1;
    }
    sum / n as f64
}

impl VehicleSpec {
    /// Table I with every axle given relaxation length σ \[m\] .
    pub fn table_i_with_relaxation(sigma_m: f64) -> Self {
        let mut s = Self::from(VehicleParams::default());
        s.tractor.front_relaxation_length_m = Some(sigma_m);
        s.tractor.rear_relaxation_length_m = Some(sigma_m);
        if let Some(t) = s.trailer.as_mut() {
            t.relaxation_length_m = Some(sigma_m);
        }
        s
    }

    /// Whether the file gives a chain of towed units (`[[trailers]]`) rather than one
    /// `[trailer]`.
    pub fn is_chain(&self) -> bool {
        !self.trailers.is_empty()
    }

    /// Number of towed units (1 for a two-unit vehicle).
    pub fn towed_units(&self) -> usize {
        if self.is_chain() {
            self.trailers.len()
        } else {
            1
        }
    }

    /// The vehicle as a chain of towed units (a two-unit vehicle: the chain with one).
    pub fn chain_spec(&self) -> ChainSpec {
        ChainSpec::from(self)
    }

    /// The trailer of a two-unit vehicle, for `what` (a two-unit notion, said in the error).
    ///
    /// # Errors
    /// [`ModelError::InvalidSpec`] naming `trailers` when both `trailer` and `trailers` are
    /// given, or the vehicle is a chain (with `what` as the reason), and naming `trailer`
    /// when neither is.
    pub fn two_unit_trailer(&self, what: &str) -> Result<&TrailerSpec, ModelError> {
        match (&self.trailer, self.trailers.len()) {
            (Some(t), 0) => Ok(t),
            (Some(_), n) => Err(invalid(
                "trailers",
                n as f64,
                "either `[trailer]` (one towed unit) or `[[trailers]]` (a chain), not both",
            )),
            (None, 0) => Err(invalid(
                "trailer",
                f64::NAN,
                "a `[trailer]` table (or a chain of towed units, `[[trailers]]`)",
            )),
            (None, n) => Err(invalid(
                "trailers",
                n as f64,
                format!(
                    "one towed unit: a chain of {n} towed units has no {what} (the paper's model has one trailer)"
                ),
            )),
        }
    }

    /// [`Self::two_unit_trailer`], mutable.
    ///
    /// # Errors
    /// As [`Self::two_unit_trailer`].
    pub fn two_unit_trailer_mut(&mut self, what: &str) -> Result<&mut TrailerSpec, ModelError> {
        self.two_unit_trailer(what)?;
        self.trailer
            .as_mut()
            .ok_or_else(|| invalid("trailer", f64::NAN, "a `[trailer]` table"))
    }

    /// A chain's form checks (exactly one of `trailer` / `trailers`; see
    /// [`crate::ChainSpec`]): Ok(true) for a well-formed chain, Ok(false) for a two-unit
    /// vehicle.
    fn chain_form(&self) -> Result<bool, ModelError> {
        if self.trailers.is_empty() {
            self.two_unit_trailer("")?;
            return Ok(false);
        }
        if self.trailer.is_some() {
            self.two_unit_trailer("")?;
        }
        self.chain_spec().resolved_axles()?;
        Ok(true)
    }

    /// The axles of both units in the list form, tractor first, each in file order.
    ///
    /// # Errors
    /// [`ModelError::InvalidSpec`] when a unit mixes the paper form's axle keys with
    /// `axles`, or gives neither completely; naming `trailers` for a chain of towed units
    /// ([`Self::two_unit_trailer`]; its axles: [`ChainSpec::resolved_axles`]).
    pub fn resolved_axles(&self) -> Result<Vec<ResolvedAxle>, ModelError> {
        let r =
            self.two_unit_trailer("axle list of two units (use `ChainSpec::resolved_axles`)")?;
        let mut out = Self::resolved_tractor_axles(&self.tractor)?;
        match &r.axles {
            Some(list) => {
                for (key, given) in [
                    ("trailer.axle", r.axle.is_some()),
                    (
                        "trailer.cornering_stiffness",
                        r.cornering_stiffness.is_some(),
                    ),
                    ("trailer.tire", r.tire.is_some()),
                    (
                        "trailer.relaxation_length_m",
                        r.relaxation_length_m.is_some(),
                    ),
                ] {
                    if given {
                        return Err(invalid(
                            key,
                            f64::NAN,
                            "either the paper form's axle keys or `trailer.axles`, not both",
                        ));
                    }
                }
                for (i, a) in list.iter().enumerate() {
                    if a.steered {
                        return Err(invalid(
                            format!("trailer.axles[{i}].steered"),
                            1.0,
                            "false: only the tractor's axles are steered",
                        ));
                    }
                    out.push(ResolvedAxle {
                        unit: Unit::Trailer,
                        spec: *a,
                        key: format!("trailer.axles[{i}]"),
                        position_key: format!("trailer.axles[{i}].position_m"),
                        prefix: format!("trailer.axles[{i}]."),
                    });
                }
            }
            None => {
                let l = r.axle.ok_or_else(|| {
                    invalid(
                        "trailer.axle",
                        f64::NAN,
                        "a value (or the list `trailer.axles`)",
                    )
                })?;
                let ct = r.cornering_stiffness.ok_or_else(|| {
                    invalid(
                        "trailer.cornering_stiffness",
                        f64::NAN,
                        "a value (or the list `trailer.axles`)",
                    )
                })?;
                out.push(ResolvedAxle {
                    unit: Unit::Trailer,
                    spec: AxleSpec {
                        position_m: l,
                        cornering_stiffness: ct,
                        steered: false,
                        tire: r.tire.unwrap_or_default(),
                        relaxation_length_m: r.relaxation_length_m.unwrap_or(0.0),
                    },
                    key: "trailer.axle".into(),
                    position_key: "trailer.axle".into(),
                    prefix: "trailer.".into(),
                });
            }
        }
        Ok(out)
    }

    /// The towing unit's axles in the list form, in file order (as in a two-unit file; a
    /// chain's towing unit has the same keys).
    ///
    /// # Errors
    /// [`ModelError::InvalidSpec`] when it mixes the paper form's axle keys with
    /// `tractor.axles`, or gives neither completely.
    pub(crate) fn resolved_tractor_axles(t: &TractorSpec) -> Result<Vec<ResolvedAxle>, ModelError> {
        let mut out = Vec::new();
        let paper_keys = [
            ("tractor.front_axle", t.front_axle.is_some()),
            ("tractor.rear_axle", t.rear_axle.is_some()),
            (
                "tractor.front_cornering_stiffness",
                t.front_cornering_stiffness.is_some(),
            ),
            (
                "tractor.rear_cornering_stiffness",
                t.rear_cornering_stiffness.is_some(),
            ),
            ("tractor.front_tire", t.front_tire.is_some()),
            ("tractor.rear_tire", t.rear_tire.is_some()),
            (
                "tractor.front_relaxation_length_m",
                t.front_relaxation_length_m.is_some(),
            ),
            (
                "tractor.rear_relaxation_length_m",
                t.rear_relaxation_length_m.is_some(),
            ),
        ];
        match &t.axles {
            Some(list) => {
                if let Some((key, _)) = paper_keys.iter().find(|(_, given)| *given) {
                    return Err(invalid(
                        *key,
                        f64::NAN,
                        "either the paper form's axle keys or `tractor.axles`, not both",
                    ));
                }
                for (i, a) in list.iter().enumerate() {
                    out.push(ResolvedAxle {
                        unit: Unit::Tractor,
                        spec: *a,
                        key: format!("tractor.axles[{i}]"),
                        position_key: format!("tractor.axles[{i}].position_m"),
                        prefix: format!("tractor.axles[{i}]."),
                    });
                }
            }
            None => {
                let need = |key: &str, v: Option<f64>| {
                    v.ok_or_else(|| invalid(key, f64::NAN, "a value (or the list `tractor.axles`)"))
                };
                let f = need("tractor.front_axle", t.front_axle)?;
                let c = need("tractor.rear_axle", t.rear_axle)?;
                let cf = need(
                    "tractor.front_cornering_stiffness",
                    t.front_cornering_stiffness,
                )?;
                let cr = need(
                    "tractor.rear_cornering_stiffness",
                    t.rear_cornering_stiffness,
                )?;
                out.push(ResolvedAxle {
                    unit: Unit::Tractor,
                    spec: AxleSpec {
                        position_m: f,
                        cornering_stiffness: cf,
                        steered: true,
                        tire: t.front_tire.unwrap_or_default(),
                        relaxation_length_m: t.front_relaxation_length_m.unwrap_or(0.0),
                    },
                    key: "tractor.front_axle".into(),
                    position_key: "tractor.front_axle".into(),
                    prefix: "tractor.front_".into(),
                });
                out.push(ResolvedAxle {
                    unit: Unit::Tractor,
                    spec: AxleSpec {
                        position_m: c,
                        cornering_stiffness: cr,
                        steered: false,
                        tire: t.rear_tire.unwrap_or_default(),
                        relaxation_length_m: t.rear_relaxation_length_m.unwrap_or(0.0),
                    },
                    key: "tractor.rear_axle".into(),
                    position_key: "tractor.rear_axle".into(),
                    prefix: "tractor.rear_".into(),
                });
            }
        }
        Ok(out)
    }

    /// The single-axle vehicle of the paper's form: each group of axles (steered, unsteered,
    /// trailer) at the mean position of its axles with the sum of their cornering
    /// stiffnesses. For a file in the paper's form these are its keys, exactly. Its static
    /// loads are the group loads of the equal-load assumption (module docs).
    ///
    /// # Errors
    /// As [`Self::resolved_axles`] (a chain of towed units has no paper-form equivalent: an
    /// error naming `trailers`), and [`ModelError::InvalidSpec`] for a tractor without a
    /// steered or an unsteered axle, or a trailer without axles.
    pub fn equivalent_params(&self) -> Result<VehicleParams, ModelError> {
        let trailer = self.two_unit_trailer("paper-form equivalent (`VehicleParams`)")?;
        let axles = self.resolved_axles()?;
        let group = |unit: Unit, steered: bool| {
            axles
                .iter()
                .filter(move |a| a.unit == unit && a.spec.steered == steered)
        };
        let need = |unit: Unit, steered: bool, key: &str, what: &str| {
            if group(unit, steered).next().is_none() {
                Err(invalid(key, f64::NAN, what))
            } else {
                Ok(())
            }
        };
        need(
            Unit::Tractor,
            true,
            "tractor.axles",
            "at least one steered axle (`steered = true`)",
        )?;
        need(
            Unit::Tractor,
            false,
            "tractor.axles",
            "at least one unsteered axle",
        )?;
        need(Unit::Trailer, false, "trailer.axles", "at least one axle")?;
        let pos = |u, s| mean(group(u, s).map(|a| a.spec.position_m));
        let stiff = |u, s| {
            group(u, s)
                .map(|a| a.spec.cornering_stiffness)
                .fold(0.0, |acc, c| acc + c)
        };
        Ok(VehicleParams {
            tractor: TractorParams {
                mass: self.tractor.mass,
                yaw_inertia: self.tractor.yaw_inertia,
                front_axle: pos(Unit::Tractor, true),
                cog: self.tractor.cog,
                rear_axle: pos(Unit::Tractor, false),
                front_cornering_stiffness: stiff(Unit::Tractor, true),
                rear_cornering_stiffness: stiff(Unit::Tractor, false),
            },
            trailer: TrailerParams {
                mass: trailer.mass,
                yaw_inertia: trailer.yaw_inertia,
                cog: trailer.cog,
                axle: pos(Unit::Trailer, false),
                cornering_stiffness: stiff(Unit::Trailer, false),
            },
            friction: self.friction,
            gravity: self.gravity,
        })
    }

    /// Static vertical load \[N\] of each axle of [`Self::resolved_axles`]: the group load of
    /// the equivalent vehicle ([`AxleLoads`]) shared equally within the group.
    ///
    /// # Errors
    /// As [`Self::equivalent_params`] (naming `trailers` for a chain:
    /// [`ChainSpec::static_loads`] has its loads).
    pub fn axle_loads(&self) -> Result<Vec<f64>, ModelError> {
        self.two_unit_trailer("two-unit static loads (use `ChainSpec::static_loads`)")?;
        let axles = self.resolved_axles()?;
        let loads = AxleLoads::from_params(&self.equivalent_params()?);
        let count = |unit: Unit, steered: bool| {
            axles
                .iter()
                .filter(|a| a.unit == unit && a.spec.steered == steered)
                .count() as f64
        };
        let (nf, nr, nt) = (
            count(Unit::Tractor, true),
            count(Unit::Tractor, false),
            count(Unit::Trailer, false),
        );
        Ok(axles
            .iter()
            .map(|a| match (a.unit, a.spec.steered) {
                (Unit::Tractor, true) => loads.front / nf,
                (Unit::Tractor, false) => loads.rear / nr,
                (Unit::Trailer, _) => loads.trailer / nt,
            })
            .collect())
    }

    /// The physical checks a model needs: the equivalent vehicle's ([`VehicleParams::validate`]),
    /// every axle off the hitch (position > 0), positive stiffnesses, σ ≥ 0, at most
    /// [`MAX_AXLES`] axles, the hitch's c_h ≥ 0, M_c ≥ 0, ω_c > 0, and each tyre law buildable.
    /// Coincident axles are accepted (see [`Self::validate`]).
    ///
    /// # Errors
    /// [`ModelError::InvalidSpec`] / [`ModelError::InvalidParameter`] naming the key;
    /// [`ModelError::TireSpec`] for a tyre law.
    pub fn check_physics(&self) -> Result<Vec<TireLaw>, ModelError> {
        if self.chain_form()? {
            return self.chain_spec().check_physics();
        }
        let axles = self.resolved_axles()?;
        if axles.len() > MAX_AXLES {
            return Err(invalid(
                "axles",
                axles.len() as f64,
                format!("at most {MAX_AXLES} axles in all"),
            ));
        }
        for a in &axles {
            let p = a.spec.position_m;
            if !(p.is_finite() && p > 0.0) {
                let side = match a.unit {
                    Unit::Tractor => "in front of the hitch",
                    Unit::Trailer => "behind the hitch",
                };
                return Err(invalid(
                    a.position_key.clone(),
                    p,
                    format!(
                        "a positive distance {side} (an axle on the hitch or on the wrong side is not a vehicle)"
                    ),
                ));
            }
            let c = a.spec.cornering_stiffness;
            if !(c.is_finite() && c > 0.0) {
                return Err(invalid(
                    format!("{}cornering_stiffness", a.prefix),
                    c,
                    "a positive finite cornering stiffness [N/rad]",
                ));
            }
            let s = a.spec.relaxation_length_m;
            if !(s.is_finite() && s >= 0.0) {
                return Err(invalid(
                    format!("{}relaxation_length_m", a.prefix),
                    s,
                    "a relaxation length σ ≥ 0 m",
                ));
            }
        }
        let params = self.equivalent_params()?;
        params.validate()?;
        let h = &self.hitch;
        for (key, v) in [
            ("hitch.yaw_damping_nms", h.yaw_damping_nms),
            ("hitch.friction_torque_nm", h.friction_torque_nm),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(key, v, "a finite value ≥ 0"));
            }
        }
        let w = h.friction_regularisation_rad_s;
        if !(w.is_finite() && w > 0.0) {
            return Err(invalid(
                "hitch.friction_regularisation_rad_s",
                w,
                "a positive regularisation ω_c [rad/s]",
            ));
        }
        let loads = self.axle_loads()?;
        build_tires(&ResolvedAxle::views(&axles), &loads, &self.friction)
    }

    /// The checks of a vehicle file: [`Self::check_physics`] and no two axles of a unit
    /// closer than [`MIN_AXLE_SPACING_M`] (overlapping axles, usually a duplicated entry).
    ///
    /// # Errors
    /// As [`Self::check_physics`]; [`ModelError::InvalidSpec`] naming the second axle.
    pub fn validate(&self) -> Result<(), ModelError> {
        if self.chain_form()? {
            return self.chain_spec().validate();
        }
        self.check_physics()?;
        check_axle_spacing(&ResolvedAxle::views(&self.resolved_axles()?))
    }

    /// Whether the vehicle differs from the paper's model: more than one axle in a group
    /// (steered, unsteered, trailer), a tyre law other than the brush tyre with the vehicle's
    /// friction, σ > 0 on an axle, or a torque at the hitch. Without variants the model is
    /// the paper's [`crate::Model`] of [`Self::equivalent_params`].
    ///
    /// # Errors
    /// As [`Self::resolved_axles`].
    pub fn has_variants(&self) -> Result<bool, ModelError> {
        Ok(self.first_variant_key()?.is_some())
    }

    /// The first key that makes the vehicle differ from the paper's model (see
    /// [`Self::has_variants`]): `tractor.axles` / `trailer.axles` for a group of more than one
    /// axle, an axle's `…tire` or `…relaxation_length_m`, `hitch.yaw_damping_nms` or
    /// `hitch.friction_torque_nm`; None for a vehicle of the paper's form. For messages
    /// ("this task takes the paper's model only: `…` is a variant").
    ///
    /// # Errors
    /// As [`Self::resolved_axles`].
    pub fn first_variant_key(&self) -> Result<Option<String>, ModelError> {
        if self.chain_form()? {
            return Ok(Some("trailers".to_string()));
        }
        let axles = self.resolved_axles()?;
        let group = |unit: Unit, steered: bool| {
            axles
                .iter()
                .filter(move |a| a.unit == unit && a.spec.steered == steered)
        };
        for (unit, steered, key) in [
            (Unit::Tractor, true, "tractor.axles"),
            (Unit::Tractor, false, "tractor.axles"),
            (Unit::Trailer, false, "trailer.axles"),
        ] {
            if group(unit, steered).count() != 1 {
                return Ok(Some(key.to_string()));
            }
        }
        for a in &axles {
            if a.spec.tire != TireLawSpec::default() {
                return Ok(Some(format!("{}tire", a.prefix)));
            }
            if a.spec.relaxation_length_m != 0.0 {
                return Ok(Some(format!("{}relaxation_length_m", a.prefix)));
            }
        }
        Ok(if self.hitch.yaw_damping_nms != 0.0 {
            Some("hitch.yaw_damping_nms".to_string())
        } else if self.hitch.friction_torque_nm != 0.0 {
            Some("hitch.friction_torque_nm".to_string())
        } else {
            None
        })
    }

    /// A copy with parameter `index` of [`crate::PARAMETERS`] set to `value` (not validated),
    /// for sweeps and sensitivities over the paper's keys on a vehicle with variants.
    ///
    /// An axle key (f, c, C_F, C_R, l, C_T) of a unit given as a list of axles sets the
    /// group's value of the equivalent paper-form vehicle ([`Self::equivalent_params`]):
    /// a position moves the whole group (every axle shifted by the same amount, so their
    /// mean is `value`), a cornering stiffness scales the group's stiffnesses (so their sum
    /// is `value`). A tandem's `l` is then where its axle pair sits, and dV_crit/dl the
    /// effect of moving the pair.
    ///
    /// A chain of towed units has no `[trailer]`: its trailer keys (`trailer.mass` …
    /// `trailer.cornering_stiffness`) are errors naming that key; the towing unit's keys,
    /// friction and g are set as in a two-unit file.
    ///
    /// # Errors
    /// As [`Self::equivalent_params`], for an axle key of a unit given as a list;
    /// [`ModelError::InvalidSpec`] naming the key for a trailer key of a chain.
    pub fn with_parameter(&self, index: usize, value: f64) -> Result<Self, ModelError> {
        if (7..=11).contains(&index) && self.is_chain() {
            return Err(invalid(
                crate::PARAMETERS[index].0,
                value,
                format!(
                    "a key of a two-unit vehicle: a chain of {} towed units has no `[trailer]` (vary `trailers[i]` in its file)",
                    self.trailers.len()
                ),
            ));
        }
        let mut s = self.clone();
        let t = &mut s.tractor;
        let r = &mut s.trailer;
        let slot: Option<&mut f64> = match index {
            0 => Some(&mut t.mass),
            1 => Some(&mut t.yaw_inertia),
            2 => t.front_axle.as_mut(),
            3 => Some(&mut t.cog),
            4 => t.rear_axle.as_mut(),
            5 => t.front_cornering_stiffness.as_mut(),
            6 => t.rear_cornering_stiffness.as_mut(),
            7 => r.as_mut().map(|r| &mut r.mass),
            8 => r.as_mut().map(|r| &mut r.yaw_inertia),
            9 => r.as_mut().map(|r| &mut r.cog),
            10 => r.as_mut().and_then(|r| r.axle.as_mut()),
            11 => r.as_mut().and_then(|r| r.cornering_stiffness.as_mut()),
            12 => Some(&mut s.friction.mu_static),
            13 => Some(&mut s.friction.mu_dynamic),
            _ => Some(&mut s.gravity),
        };
        match slot {
            Some(v) => {
                *v = value;
                Ok(s)
            }
            None => self.with_axle_group(index, value),
        }
    }

    /// [`Self::with_parameter`] of an axle key whose unit is a list of axles.
    fn with_axle_group(&self, index: usize, value: f64) -> Result<Self, ModelError> {
        let equivalent = crate::VehicleParams::get(&self.equivalent_params()?, index);
        let mut s = self.clone();
        // (the unit's list, the steered group of a tractor list, position or stiffness)
        let (axles, steered, position) = match index {
            2 => (s.tractor.axles.as_mut(), Some(true), true),
            4 => (s.tractor.axles.as_mut(), Some(false), true),
            5 => (s.tractor.axles.as_mut(), Some(true), false),
            6 => (s.tractor.axles.as_mut(), Some(false), false),
            10 => (
                s.trailer.as_mut().and_then(|r| r.axles.as_mut()),
                None,
                true,
            ),
            _ => (
                s.trailer.as_mut().and_then(|r| r.axles.as_mut()),
                None,
                false,
            ),
        };
        let Some(axles) = axles else {
            return Err(invalid(
                crate::PARAMETERS[index.min(crate::PARAMETERS.len() - 1)].0,
                value,
                "an axle key of the paper's form or an axle list",
            ));
        };
        for a in axles
            .iter_mut()
            .filter(|a| steered.is_none_or(|st| a.steered == st))
        {
            if position {
                a.position_m += value - equivalent;
            } else {
                a.cornering_stiffness *= value / equivalent;
            }
        }
        Ok(s)
    }

    /// Number of axles with σ > 0: the relaxation states the model adds to the 4 of eq. (5)–(6).
    ///
    /// # Errors
    /// As [`Self::resolved_axles`].
    pub fn relaxed_axles(&self) -> Result<usize, ModelError> {
        if self.chain_form()? {
            return self.chain_spec().relaxed_axles();
        }
        Ok(self
            .resolved_axles()?
            .iter()
            .filter(|a| a.spec.relaxation_length_m > 0.0)
            .count())
    }
}
