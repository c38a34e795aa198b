//! Scenario speeds that mean the same for every vehicle: a speed in a scenario
//! or sweep config is a [`SpeedSpec`] — a number (m/s, absolute: wins, as always) or a
//! table relative to the vehicle, `{ of_v_crit = f }` (f·V_crit of the open loop) or
//! `{ in_bistable = f }` (V_fold + f·(V_crit − V_fold); f = 0 at the fold of cycles, 1 at
//! V_crit). A speed *change* (a braking ramp's ΔV) takes a number or `{ of_v_crit = f }`
//! (ΔV = f·V_crit, so that V0 + ΔV keeps its place relative to V_crit).
//!
//! The config types are generic over the speed type `S`: `S = SpeedSpec` is what a file
//! says, `S = f64` (the default) is what the pipelines run. A config is resolved once per
//! run (`sway::ranging::resolve_speeds`): the references it needs are computed once
//! (`sway::ranging::open_loop_references`; the fold only when an `in_bistable` speed
//! asks for it, nothing at all when every speed is a number), then every speed is
//! replaced by its value ([`resolve_against`]). A spec that cannot resolve (a vehicle stable at every speed up
//! to the maximum has no V_crit; a supercritical Hopf point has no bistable range) is an
//! outcome with a reason ([`UnresolvedSpeed`]), not an error.

use std::fmt::Debug;

use serde::Serialize;
use serde::de::DeserializeOwned;

use super::{Reference, RelativeSpeed, SpeedReferences, SpeedSpec};

/// A speed as a config type holds it: `f64` (resolved, m/s) or [`SpeedSpec`] (as written).
pub trait SpeedValue:
    Copy + Debug + PartialEq + Serialize + DeserializeOwned + Send + Sync + 'static
{
    /// The value \[m/s\] of this speed at config key `key` (recorded in `r`).
    ///
    /// # Errors
    /// [`UnresolvedSpeed`] when the vehicle has no reference for it.
    fn resolve_speed(&self, key: &str, r: &mut Resolver<'_>) -> Result<f64, UnresolvedSpeed>;

    /// The value of this speed *change* \[m/s\] (a number or `{ of_v_crit = f }`).
    ///
    /// # Errors
    /// As [`SpeedValue::resolve_speed`].
    fn resolve_change(&self, key: &str, r: &mut Resolver<'_>) -> Result<f64, UnresolvedSpeed> {
        self.resolve_speed(key, r)
    }

    /// The number, if this is one (m/s).
    fn absolute(&self) -> Option<f64>;

    /// The factor f of `{ in_bistable = f }` (a change refuses it).
    fn is_in_bistable(&self) -> bool {
        false
    }
}

impl SpeedValue for f64 {
    fn resolve_speed(&self, _key: &str, _r: &mut Resolver<'_>) -> Result<f64, UnresolvedSpeed> {
        Ok(*self)
    }
    fn absolute(&self) -> Option<f64> {
        Some(*self)
    }
}

impl SpeedValue for SpeedSpec {
    fn resolve_speed(&self, key: &str, r: &mut Resolver<'_>) -> Result<f64, UnresolvedSpeed> {
        r.resolve(key, self)
    }
    fn absolute(&self) -> Option<f64> {
        match *self {
            SpeedSpec::Absolute(v) => Some(v),
            SpeedSpec::Relative(_) => None,
        }
    }
    fn is_in_bistable(&self) -> bool {
        matches!(self, SpeedSpec::Relative(RelativeSpeed::InBistable(_)))
    }
}

/// A relative speed of the config and what it resolved to (for `summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResolvedSpeed {
    /// the config key
    pub key: String,
    /// as written
    pub spec: SpeedSpec,
    /// its value for this vehicle \[m/s\]
    pub speed_mps: f64,
}

/// Why a config's speeds do not resolve for this vehicle: the task has nothing to show.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnresolvedSpeed {
    /// the config key of the first speed that does not resolve
    pub key: String,
    /// as written
    pub spec: SpeedSpec,
    /// why (e.g. "straight running is stable at every speed up to 100 m/s …")
    pub reason: String,
}

/// The references a config's relative speeds need.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Needs {
    /// some speed is relative (V_crit is needed)
    pub v_crit: bool,
    /// some speed is `in_bistable` (the fold of cycles is needed)
    pub fold: bool,
}

impl Needs {
    /// The reference to compute (`sway::ranging::open_loop_references`), None when every speed is a number.
    pub fn reference(&self) -> Option<Reference> {
        match (self.v_crit, self.fold) {
            (_, true) => Some(Reference::Fold),
            (true, false) => Some(Reference::VCrit),
            (false, false) => None,
        }
    }
}

/// Walks a config's speeds: either probing what they need, or resolving them against
/// references (recording each relative one).
#[derive(Debug)]
pub struct Resolver<'a> {
    refs: Option<&'a SpeedReferences>,
    needs: Needs,
    speeds: Vec<ResolvedSpeed>,
}

impl<'a> Resolver<'a> {
    /// A resolver that only records what is needed (every relative speed gives NaN).
    pub fn probe() -> Self {
        Self {
            refs: None,
            needs: Needs::default(),
            speeds: Vec::new(),
        }
    }

    /// A resolver against these references.
    pub fn against(refs: &'a SpeedReferences) -> Self {
        Self {
            refs: Some(refs),
            needs: Needs::default(),
            speeds: Vec::new(),
        }
    }

    /// What the walked speeds need.
    pub fn needs(&self) -> Needs {
        self.needs
    }

    /// The relative speeds resolved so far.
    pub fn speeds(&self) -> &[ResolvedSpeed] {
        &self.speeds
    }

    fn resolve(&mut self, key: &str, spec: &SpeedSpec) -> Result<f64, UnresolvedSpeed> {
        if let SpeedSpec::Relative(rel) = spec {
            self.needs.v_crit = true;
            if matches!(rel, RelativeSpeed::InBistable(_)) {
                self.needs.fold = true;
            }
        } else if let SpeedSpec::Absolute(v) = spec {
            return Ok(*v);
        }
        let Some(refs) = self.refs else {
            return Ok(f64::NAN);
        };
        match spec.resolve(refs) {
            Ok(v) => {
                self.speeds.push(ResolvedSpeed {
                    key: key.to_string(),
                    spec: *spec,
                    speed_mps: v,
                });
                Ok(v)
            }
            Err(u) => Err(UnresolvedSpeed {
                key: key.to_string(),
                spec: *spec,
                reason: format!("`{key}` = {}: {}", describe(spec), u.reason),
            }),
        }
    }
}

/// `{ of_v_crit = 1.007 }` as written in a config.
pub fn describe(spec: &SpeedSpec) -> String {
    match spec {
        SpeedSpec::Absolute(v) => format!("{v}"),
        SpeedSpec::Relative(RelativeSpeed::OfVCrit(f)) => format!("{{ of_v_crit = {f} }}"),
        SpeedSpec::Relative(RelativeSpeed::InBistable(f)) => format!("{{ in_bistable = {f} }}"),
    }
}

/// A config whose speeds can be resolved: `Self` with `S = SpeedSpec` → `Resolved` with
/// `S = f64`.
pub trait ResolveSpeeds {
    /// the config with every speed a number
    type Resolved;
    /// Resolves every speed through `r` (config keys as in the file).
    ///
    /// # Errors
    /// The first speed that does not resolve.
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<Self::Resolved, UnresolvedSpeed>;

    /// What the config's speeds need.
    fn needs(&self) -> Needs {
        let mut r = Resolver::probe();
        // a probe resolves every speed (relative ones to NaN)
        let _ = self.resolve_speeds(&mut r);
        r.needs()
    }

    /// The config with every speed a number, if it has no relative speed.
    fn all_numbers(&self) -> Option<Self::Resolved> {
        if self.needs().reference().is_some() {
            return None;
        }
        self.resolve_speeds(&mut Resolver::probe()).ok()
    }
}

/// A config resolved for one vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolution<T> {
    /// the config with numbers, or why it has none for this vehicle
    pub outcome: Result<T, UnresolvedSpeed>,
    /// the references used (both null when every speed was a number)
    pub references: SpeedReferences,
    /// the relative speeds and their values
    pub speeds: Vec<ResolvedSpeed>,
}

/// Resolves `cfg` against references already known (e.g. a diagram's fold).
pub fn resolve_against<C: ResolveSpeeds>(
    refs: &SpeedReferences,
    cfg: &C,
) -> Resolution<C::Resolved> {
    let mut r = Resolver::against(refs);
    let outcome = cfg.resolve_speeds(&mut r);
    Resolution {
        outcome,
        references: refs.clone(),
        speeds: r.speeds,
    }
}

/// Resolves a speed change (ΔV): a number or `{ of_v_crit = f }`.
///
/// # Errors
/// As [`SpeedValue::resolve_speed`].
pub fn change<S: SpeedValue>(
    s: &S,
    key: &str,
    r: &mut Resolver<'_>,
) -> Result<f64, UnresolvedSpeed> {
    s.resolve_change(key, r)
}

/// Checks that a speed change is not `in_bistable` (an affine reference makes no sense for
/// a difference): `Err((key, problem))`.
pub fn check_change<S: SpeedValue>(s: &S, key: &str) -> Result<(), (String, String)> {
    if s.is_in_bistable() {
        return Err((
            key.to_string(),
            "a speed change is a number [m/s] or { of_v_crit = f } (ΔV = f·V_crit), not in_bistable"
                .into(),
        ));
    }
    Ok(())
}
