//! The vehicle file of a combination with more than one articulation: a towing unit and a
//! chain of towed units (car + two caravans, truck + centre-axle trailer, tractor–semitrailer,
//! truck–dolly–semitrailer), as serde data with validation. The model is
//! [`crate::ChainModel`].
//!
//! ```toml
//! [tractor]              # as in a two-unit file; positions measured from its REAR
//! mass = 7000.0          #   COUPLING, ahead positive (a fifth wheel ahead of the rear
//! yaw_inertia = 2.6e4    #   axle gives rear_axle < 0)
//! front_axle = 3.2
//! cog = 1.9
//! rear_axle = -0.5
//! front_cornering_stiffness = 3.0e5
//! rear_cornering_stiffness = 6.0e5
//!
//! [[trailers]]           # the towed units, front to back
//! mass = 800.0           # [kg]
//! yaw_inertia = 600.0    # [kg m²] about its centre of gravity
//! cog = 0.9              # its own coupling → its centre of gravity, behind positive [m]
//! axle = 1.0             # its coupling → its axle [m] (or [[trailers.axles]] as today)
//! cornering_stiffness = 2.0e5   # [N/rad]
//! rear_coupling = 1.0    # its coupling → the next unit's coupling [m] (all but the last)
//! [trailers.hitch]       # optional: torque at the coupling at its FRONT (as today's [hitch])
//! yaw_damping_nms = 0.0
//!
//! [[trailers]]
//! mass = 2.0e4
//! yaw_inertia = 3.0e5
//! cog = 6.0
//! [[trailers.axles]]
//! position_m = 9.0
//! cornering_stiffness = 4.0e5
//! [[trailers.axles]]
//! position_m = 10.3
//! cornering_stiffness = 4.0e5
//!
//! [friction]
//! mu_static = 0.9
//! mu_dynamic = 0.6
//! ```
//!
//! The one-trailer form of today's files (`[trailer]` with an optional top-level `[hitch]`)
//! stays valid: it is the chain with one towed unit ([`From<&VehicleSpec>`]).
//!
//! **Static loads.** From the last unit forward: towed unit i, loaded at its rear coupling
//! (ρ_i behind its front coupling) by the vertical force P_{i+1} \[N\] of the unit behind it,
//! carries on its axles (as a group at their mean position ℓ̄_i, shared equally, as in
//! [`VehicleSpec`]) F_i = (m_i g h_i + P_{i+1} ρ_i)/ℓ̄_i and puts P_i = m_i g + P_{i+1} − F_i on
//! the unit in front. The towing unit's steered group (mean position f̄) and unsteered group
//! (c̄) carry F_F = (m₀ g (d − c̄) − P₁ c̄)/(f̄ − c̄) and F_R = m₀ g + P₁ − F_F: with one towed
//! unit these are [`crate::AxleLoads`] exactly.

use serde::{Deserialize, Serialize};
use tires::{TireLaw, TireLawSpec};

use crate::spec::{AxleView, build_tires, check_axle_spacing, invalid};
use crate::{
    AxleSpec, FrictionParams, HitchSpec, ModelError, TractorParams, TractorSpec, TrailerParams,
    TrailerSpec, VehicleParams, VehicleSpec,
};

/// Most towed units a [`ChainSpec`] may have (the fixed size of the model's work arrays).
pub const MAX_TOWED_UNITS: usize = 5;

/// Most axles of a chain (all units together).
pub const MAX_CHAIN_AXLES: usize = 16;

/// One towed unit of a chain (`[[trailers]]`, or the one-trailer form's `[trailer]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TowedUnitSpec {
    /// mass m_i \[kg\]
    pub mass: f64,
    /// yaw moment of inertia J_i about its centre of gravity \[kg m²\]
    pub yaw_inertia: f64,
    /// h_i \[m\]: its own (front) coupling → its centre of gravity, behind positive
    pub cog: f64,
    /// ℓ_i \[m\]: its coupling → its axle, behind positive (single-axle form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axle: Option<f64>,
    /// cornering stiffness of that axle \[N/rad\] (single-axle form)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cornering_stiffness: Option<f64>,
    /// tyre law of that axle (single-axle form; default brush)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tire: Option<TireLawSpec>,
    /// relaxation length σ \[m\] of that axle (single-axle form; default 0)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relaxation_length_m: Option<f64>,
    /// the axles as a list, positions behind its coupling (instead of the keys above)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axles: Option<Vec<AxleSpec>>,
    /// ρ_i \[m\]: its coupling → the next unit's coupling, behind positive (every unit but the
    /// last)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rear_coupling: Option<f64>,
    /// torque at the coupling at its front (default: a free coupling)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hitch: Option<HitchSpec>,
}

impl From<&TrailerSpec> for TowedUnitSpec {
    fn from(t: &TrailerSpec) -> Self {
        Self {
            mass: t.mass,
            yaw_inertia: t.yaw_inertia,
            cog: t.cog,
            axle: t.axle,
            cornering_stiffness: t.cornering_stiffness,
            tire: t.tire,
            relaxation_length_m: t.relaxation_length_m,
            axles: t.axles.clone(),
            rear_coupling: None,
            hitch: None,
        }
    }
}

fn default_gravity() -> f64 {
    9.81
}

/// A vehicle file of a towing unit and n ≥ 1 towed units (see the module docs for the form).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainSpec {
    /// the towing unit; its positions are measured from its rear coupling, ahead positive
    pub tractor: TractorSpec,
    /// the one-trailer form (exclusive with `trailers`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trailer: Option<TowedUnitSpec>,
    /// the towed units, front to back
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trailers: Vec<TowedUnitSpec>,
    /// tyre–road friction of the brush tyres (eq. 15)
    pub friction: FrictionParams,
    /// g \[m/s²\]
    #[serde(default = "default_gravity")]
    pub gravity: f64,
    /// the one-trailer form's torque at the hitch (with `trailers`: `trailers[0].hitch`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hitch: Option<HitchSpec>,
}

/// One axle of a chain, resolved: its unit (0 = towing unit, i = i-th towed unit), its spec
/// (position as in the file: ahead of the rear coupling on the towing unit, behind the front
/// coupling on a towed unit) and its key path.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainAxleSpec {
    /// unit index (0: towing unit)
    pub unit: usize,
    /// the axle's spec
    pub spec: AxleSpec,
    /// key path of the axle (`trailers[1].axles[0]`, `tractor.front_axle` …)
    pub key: String,
    /// key of its position
    pub position_key: String,
    /// key prefix of its stiffness, tyre and relaxation (`tractor.front_`, `trailers[0].`)
    pub prefix: String,
}

impl ChainAxleSpec {
    /// The axles as the file's checks see them.
    fn views(axles: &[ChainAxleSpec]) -> Vec<AxleView<'_, usize>> {
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

impl From<&VehicleSpec> for ChainSpec {
    /// A vehicle file as a chain: today's two-unit file is the chain with one towed unit
    /// (`[trailer]`, `[hitch]`); a file with `[[trailers]]` is its list.
    fn from(s: &VehicleSpec) -> Self {
        Self {
            tractor: s.tractor.clone(),
            trailer: s.trailer.as_ref().map(TowedUnitSpec::from),
            trailers: s.trailers.clone(),
            friction: s.friction,
            gravity: s.gravity,
            hitch: (s.hitch != HitchSpec::default()).then_some(s.hitch),
        }
    }
}

impl From<VehicleParams> for ChainSpec {
    /// The paper's vehicle (Table I for the default) as a one-trailer chain.
    fn from(p: VehicleParams) -> Self {
        Self::from(&VehicleSpec::from(p))
    }
}

impl ChainSpec {
    /// The towed units, front to back (the `[trailer]` form gives one).
    pub fn towed_units(&self) -> &[TowedUnitSpec] {
        match &self.trailer {
            Some(t) => std::slice::from_ref(t),
            None => &self.trailers,
        }
    }

    /// Number of units (towing unit + towed units).
    pub fn units(&self) -> usize {
        1 + self.towed_units().len()
    }

    /// Key path of towed unit `i` (0-based): `trailer` in the one-trailer form, else
    /// `trailers[i]`.
    pub fn towed_unit_key(&self, i: usize) -> String {
        if self.trailer.is_some() {
            "trailer".into()
        } else {
            format!("trailers[{i}]")
        }
    }

    /// The torque law at the coupling in front of towed unit `i` (0-based), with the key
    /// path of its table.
    ///
    /// # Panics
    /// If there is no towed unit `i`.
    pub fn coupling(&self, i: usize) -> (HitchSpec, String) {
        let unit = &self.towed_units()[i];
        match (unit.hitch, self.hitch, i) {
            (Some(h), _, _) => (h, format!("{}.hitch", self.towed_unit_key(i))),
            (None, Some(h), 0) => (h, "hitch".into()),
            _ => (
                HitchSpec::default(),
                format!("{}.hitch", self.towed_unit_key(i)),
            ),
        }
    }

    /// The form's structural checks: exactly one of `trailer` / `trailers`, at most
    /// [`MAX_TOWED_UNITS`], `rear_coupling` on every towed unit but the last and not on the
    /// last, a top-level `hitch` only in the one-trailer form and not with `trailer.hitch`.
    fn check_form(&self) -> Result<(), ModelError> {
        match (&self.trailer, self.trailers.is_empty()) {
            (Some(_), false) => {
                return Err(invalid(
                    "trailers",
                    self.trailers.len() as f64,
                    "either `[trailer]` (one towed unit) or `[[trailers]]`, not both",
                ));
            }
            (None, true) => {
                return Err(invalid(
                    "trailers",
                    0.0,
                    "at least one towed unit (`[[trailers]]` or `[trailer]`)",
                ));
            }
            _ => {}
        }
        let units = self.towed_units();
        if units.len() > MAX_TOWED_UNITS {
            return Err(invalid(
                "trailers",
                units.len() as f64,
                format!("at most {MAX_TOWED_UNITS} towed units"),
            ));
        }
        if let Some(h) = self.hitch {
            if self.trailer.is_none() {
                return Err(invalid(
                    "hitch",
                    h.yaw_damping_nms,
                    "no top-level `[hitch]` with `[[trailers]]`: give `[trailers.hitch]` on the unit behind the coupling",
                ));
            }
            if units[0].hitch.is_some() {
                return Err(invalid(
                    "trailer.hitch",
                    f64::NAN,
                    "either `[hitch]` or `[trailer.hitch]`, not both",
                ));
            }
        }
        let last = units.len() - 1;
        for (i, u) in units.iter().enumerate() {
            let key = format!("{}.rear_coupling", self.towed_unit_key(i));
            match (u.rear_coupling, i == last) {
                (Some(r), true) => {
                    return Err(invalid(
                        key,
                        r,
                        "no rear coupling on the last unit (nothing is coupled to it)",
                    ));
                }
                (None, false) => {
                    return Err(invalid(
                        key,
                        f64::NAN,
                        "the distance [m] from this unit's coupling to the next unit's, behind positive",
                    ));
                }
                (Some(r), false) if !(r.is_finite() && r > 0.0) => {
                    return Err(invalid(
                        key,
                        r,
                        "a positive distance [m] behind the unit's own coupling",
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// The axles of all units in the list form, towing unit first, each unit in file order.
    ///
    /// # Errors
    /// [`ModelError::InvalidSpec`] when a unit mixes the single-axle keys with `axles`, gives
    /// neither completely, marks a towed axle `steered`, or the form is wrong (see the
    /// module docs).
    pub fn resolved_axles(&self) -> Result<Vec<ChainAxleSpec>, ModelError> {
        self.check_form()?;
        // the towing unit's keys are those of a two-unit file
        let mut out: Vec<ChainAxleSpec> = VehicleSpec::resolved_tractor_axles(&self.tractor)?
            .into_iter()
            .map(|a| ChainAxleSpec {
                unit: 0,
                spec: a.spec,
                key: a.key,
                position_key: a.position_key,
                prefix: a.prefix,
            })
            .collect();
        for (i, u) in self.towed_units().iter().enumerate() {
            let uk = self.towed_unit_key(i);
            match &u.axles {
                Some(list) => {
                    for (key, given) in [
                        ("axle", u.axle.is_some()),
                        ("cornering_stiffness", u.cornering_stiffness.is_some()),
                        ("tire", u.tire.is_some()),
                        ("relaxation_length_m", u.relaxation_length_m.is_some()),
                    ] {
                        if given {
                            return Err(invalid(
                                format!("{uk}.{key}"),
                                f64::NAN,
                                format!("either the single-axle keys or `{uk}.axles`, not both"),
                            ));
                        }
                    }
                    if list.is_empty() {
                        return Err(invalid(format!("{uk}.axles"), 0.0, "at least one axle"));
                    }
                    for (j, a) in list.iter().enumerate() {
                        if a.steered {
                            return Err(invalid(
                                format!("{uk}.axles[{j}].steered"),
                                1.0,
                                "false: only the towing unit's axles are steered",
                            ));
                        }
                        out.push(ChainAxleSpec {
                            unit: i + 1,
                            spec: *a,
                            key: format!("{uk}.axles[{j}]"),
                            position_key: format!("{uk}.axles[{j}].position_m"),
                            prefix: format!("{uk}.axles[{j}]."),
                        });
                    }
                }
                None => {
                    let need = |key: &str, v: Option<f64>| {
                        v.ok_or_else(|| {
                            invalid(
                                format!("{uk}.{key}"),
                                f64::NAN,
                                format!("a value (or the list `{uk}.axles`)"),
                            )
                        })
                    };
                    let l = need("axle", u.axle)?;
                    let c = need("cornering_stiffness", u.cornering_stiffness)?;
                    out.push(ChainAxleSpec {
                        unit: i + 1,
                        spec: AxleSpec {
                            position_m: l,
                            cornering_stiffness: c,
                            steered: false,
                            tire: u.tire.unwrap_or_default(),
                            relaxation_length_m: u.relaxation_length_m.unwrap_or(0.0),
                        },
                        key: format!("{uk}.axle"),
                        position_key: format!("{uk}.axle"),
                        prefix: format!("{uk}."),
                    });
                }
            }
        }
        Ok(out)
    }

    /// Mean position \[m\] of the axles of `unit` with steering `steered` (None: all), NaN
    /// for an empty group.
    fn group_mean(axles: &[ChainAxleSpec], unit: usize, steered: Option<bool>) -> f64 {
        let (mut sum, mut n) = (0.0, 0usize);
        for a in axles
            .iter()
            .filter(|a| a.unit == unit && steered.is_none_or(|s| a.spec.steered == s))
        {
            sum += a.spec.position_m;
            n += 1;
        }
        if n == 0 { f64::NAN } else { sum / n as f64 }
    }

    /// Static vertical load \[N\] of each axle of [`Self::resolved_axles`] (module docs), and
    /// the vertical coupling loads P_i \[N\] (on the unit in front, downward positive), front to
    /// back.
    ///
    /// # Errors
    /// As [`Self::resolved_axles`]; [`ModelError::InvalidSpec`] for a towing unit without a
    /// steered or an unsteered axle.
    pub fn static_loads(&self) -> Result<(Vec<f64>, Vec<f64>), ModelError> {
        let axles = self.resolved_axles()?;
        let g = self.gravity;
        let units = self.towed_units();
        let count = |unit: usize, steered: Option<bool>| {
            axles
                .iter()
                .filter(|a| a.unit == unit && steered.is_none_or(|s| a.spec.steered == s))
                .count() as f64
        };
        if count(0, Some(true)) == 0.0 {
            return Err(invalid(
                "tractor.axles",
                f64::NAN,
                "at least one steered axle (`steered = true`)",
            ));
        }
        if count(0, Some(false)) == 0.0 {
            return Err(invalid(
                "tractor.axles",
                f64::NAN,
                "at least one unsteered axle",
            ));
        }
        // from the back: the group load of each towed unit and its coupling load
        let mut group = vec![0.0; units.len() + 1];
        let mut coupling = vec![0.0; units.len()];
        let mut behind = 0.0; // P_{i+1}
        for i in (0..units.len()).rev() {
            let u = &units[i];
            let l = Self::group_mean(&axles, i + 1, None);
            let rho = u.rear_coupling.unwrap_or(0.0);
            let f = (u.mass * g * u.cog + behind * rho) / l;
            group[i + 1] = f;
            coupling[i] = u.mass * g + behind - f;
            behind = coupling[i];
        }
        let t = &self.tractor;
        let (f, c) = (
            Self::group_mean(&axles, 0, Some(true)),
            Self::group_mean(&axles, 0, Some(false)),
        );
        let front = (t.mass * g * (t.cog - c) - behind * c) / (f - c);
        let rear = t.mass * g + behind - front;
        let loads = axles
            .iter()
            .map(|a| match (a.unit, a.spec.steered) {
                (0, true) => front / count(0, Some(true)),
                (0, false) => rear / count(0, Some(false)),
                (u, _) => group[u] / count(u, None),
            })
            .collect();
        Ok((loads, coupling))
    }

    /// The physical checks a model needs: masses, inertias > 0; the towing unit's steered
    /// group ahead of its unsteered group (f̄ > c̄) with its centre of gravity d finite; each
    /// towed unit's h > 0 and its axles behind its coupling (position > 0); stiffnesses > 0,
    /// σ ≥ 0, at most [`MAX_CHAIN_AXLES`] axles; 0 < μ ≤ μ0, g > 0; each coupling's c_h ≥ 0,
    /// M_c ≥ 0, ω_c > 0; every static axle load > 0 (naming the axle's position); each tyre
    /// law buildable with its static load. Returns the tyre laws in axle order.
    ///
    /// # Errors
    /// [`ModelError::InvalidSpec`] naming the key; [`ModelError::TireSpec`] for a tyre law.
    pub fn check_physics(&self) -> Result<Vec<TireLaw>, ModelError> {
        let axles = self.resolved_axles()?;
        if axles.len() > MAX_CHAIN_AXLES {
            return Err(invalid(
                "axles",
                axles.len() as f64,
                format!("at most {MAX_CHAIN_AXLES} axles in all"),
            ));
        }
        let positive = |key: String, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(invalid(key, v, "a positive finite number"))
            }
        };
        positive("tractor.mass".into(), self.tractor.mass)?;
        positive("tractor.yaw_inertia".into(), self.tractor.yaw_inertia)?;
        if !self.tractor.cog.is_finite() {
            return Err(invalid(
                "tractor.cog",
                self.tractor.cog,
                "a finite distance [m]",
            ));
        }
        for (i, u) in self.towed_units().iter().enumerate() {
            let uk = self.towed_unit_key(i);
            positive(format!("{uk}.mass"), u.mass)?;
            positive(format!("{uk}.yaw_inertia"), u.yaw_inertia)?;
            positive(format!("{uk}.cog"), u.cog)?;
        }
        positive("gravity".into(), self.gravity)?;
        positive("friction.mu_static".into(), self.friction.mu_static)?;
        positive("friction.mu_dynamic".into(), self.friction.mu_dynamic)?;
        if self.friction.mu_dynamic > self.friction.mu_static {
            return Err(invalid(
                "friction.mu_dynamic",
                self.friction.mu_dynamic,
                "0 < mu_dynamic <= mu_static",
            ));
        }
        for a in &axles {
            let p = a.spec.position_m;
            if a.unit == 0 {
                if !p.is_finite() {
                    return Err(invalid(
                        a.position_key.clone(),
                        p,
                        "a finite distance [m] ahead of the rear coupling",
                    ));
                }
            } else if !(p.is_finite() && p > 0.0) {
                return Err(invalid(
                    a.position_key.clone(),
                    p,
                    "a positive distance [m] behind the unit's coupling",
                ));
            }
            positive(
                format!("{}cornering_stiffness", a.prefix),
                a.spec.cornering_stiffness,
            )?;
            let s = a.spec.relaxation_length_m;
            if !(s.is_finite() && s >= 0.0) {
                return Err(invalid(
                    format!("{}relaxation_length_m", a.prefix),
                    s,
                    "a relaxation length σ ≥ 0 m",
                ));
            }
        }
        let (f, c) = (
            Self::group_mean(&axles, 0, Some(true)),
            Self::group_mean(&axles, 0, Some(false)),
        );
        if f <= c {
            let key = if self.tractor.axles.is_some() {
                "tractor.axles"
            } else {
                "tractor.rear_axle"
            };
            return Err(invalid(
                key,
                c,
                format!("the unsteered axles behind the steered ones (mean {f} m)"),
            ));
        }
        for i in 0..self.towed_units().len() {
            let (h, key) = self.coupling(i);
            for (name, v) in [
                ("yaw_damping_nms", h.yaw_damping_nms),
                ("friction_torque_nm", h.friction_torque_nm),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(invalid(format!("{key}.{name}"), v, "a finite value ≥ 0"));
                }
            }
            let w = h.friction_regularisation_rad_s;
            if !(w.is_finite() && w > 0.0) {
                return Err(invalid(
                    format!("{key}.friction_regularisation_rad_s"),
                    w,
                    "a positive regularisation ω_c [rad/s]",
                ));
            }
        }
        let (loads, _) = self.static_loads()?;
        for (a, &fz) in axles.iter().zip(&loads) {
            if !(fz.is_finite() && fz > 0.0) {
                return Err(invalid(
                    a.position_key.clone(),
                    a.spec.position_m,
                    format!(
                        "a position with a positive static load (it is {fz:.1} N): check the centres of gravity and couplings of this unit and the units behind it"
                    ),
                ));
            }
        }
        build_tires(&ChainAxleSpec::views(&axles), &loads, &self.friction)
    }

    /// The checks of a vehicle file: [`Self::check_physics`] and no two axles of a unit
    /// closer than [`MIN_AXLE_SPACING_M`](crate::MIN_AXLE_SPACING_M).
    ///
    /// # Errors
    /// As [`Self::check_physics`]; [`ModelError::InvalidSpec`] naming the second axle.
    pub fn validate(&self) -> Result<(), ModelError> {
        self.check_physics()?;
        check_axle_spacing(&ChainAxleSpec::views(&self.resolved_axles()?))
    }

    /// Number of axles with σ > 0.
    ///
    /// # Errors
    /// As [`Self::resolved_axles`].
    pub fn relaxed_axles(&self) -> Result<usize, ModelError> {
        Ok(self
            .resolved_axles()?
            .iter()
            .filter(|a| a.spec.relaxation_length_m > 0.0)
            .count())
    }

    /// Number of reduced states of [`crate::ChainModel`]: 2 per unit (towing unit: lateral
    /// velocity and yaw rate; towed unit: articulation angle and its rate) plus one lagged
    /// slip per relaxing axle.
    ///
    /// # Errors
    /// As [`Self::resolved_axles`].
    pub fn states(&self) -> Result<usize, ModelError> {
        Ok(2 * self.units() + self.relaxed_axles()?)
    }

    /// The two-unit vehicle of the paper's form made of the towing unit and the FIRST towed
    /// unit (groups of axles at their mean positions with summed stiffnesses; the units
    /// further back are not represented). Not validated: a towing unit with a fifth wheel
    /// ahead of its rear axle has c < 0, which [`VehicleParams::validate`] rejects.
    ///
    /// # Errors
    /// As [`Self::resolved_axles`].
    pub fn first_pair_params(&self) -> Result<VehicleParams, ModelError> {
        let axles = self.resolved_axles()?;
        let stiff = |unit: usize, steered: Option<bool>| {
            axles
                .iter()
                .filter(|a| a.unit == unit && steered.is_none_or(|s| a.spec.steered == s))
                .fold(0.0, |acc, a| acc + a.spec.cornering_stiffness)
        };
        let t = &self.tractor;
        let r = &self.towed_units()[0];
        Ok(VehicleParams {
            tractor: TractorParams {
                mass: t.mass,
                yaw_inertia: t.yaw_inertia,
                front_axle: Self::group_mean(&axles, 0, Some(true)),
                cog: t.cog,
                rear_axle: Self::group_mean(&axles, 0, Some(false)),
                front_cornering_stiffness: stiff(0, Some(true)),
                rear_cornering_stiffness: stiff(0, Some(false)),
            },
            trailer: TrailerParams {
                mass: r.mass,
                yaw_inertia: r.yaw_inertia,
                cog: r.cog,
                axle: Self::group_mean(&axles, 1, None),
                cornering_stiffness: stiff(1, None),
            },
            friction: self.friction,
            gravity: self.gravity,
        })
    }
}
