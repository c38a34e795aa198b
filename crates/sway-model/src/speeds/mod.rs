//! Speeds derived from the vehicle: the vehicle-independent [`SpeedLimits`] every automatic
//! range respects, the one open-loop critical-speed search ([`open_loop_critical_speed`]),
//! speeds given relative to the vehicle ([`SpeedSpec`]) and their resolution in a config
//! ([`resolve`]).
//!
//! A config that omits a range lets the pipelines size it from the vehicle; a number in a
//! config always wins. What the limits cut off is an outcome with a reason (straight
//! running stable up to the maximum speed), not an error.

use serde::{Deserialize, Serialize};

pub mod resolve;

use trailer_model::{CriticalSpeed, CriticalSpeedOptions, ModelError, Plant};

use crate::SwayError;

/// The limits of every automatic range: vehicle-independent settings (`--max-speed`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpeedLimits {
    /// the highest speed any automatic range reaches \[m/s\]: straight running stable up to
    /// here is reported as "stable up to" this speed
    pub max_speed_mps: f64,
    /// the lowest speed of the critical-speed scan \[m/s\] (V > 0: slip angles divide by V)
    pub min_speed_mps: f64,
    /// scan step of the critical-speed search \[m/s\]
    pub scan_step_mps: f64,
    /// bracket width at which the critical speed is accepted \[m/s\]
    pub tolerance_mps: f64,
}

impl Default for SpeedLimits {
    fn default() -> Self {
        Self {
            max_speed_mps: 100.0,
            min_speed_mps: 1.0,
            scan_step_mps: 0.5,
            tolerance_mps: 1e-11,
        }
    }
}

impl SpeedLimits {
    /// The options of the open-loop critical-speed scan over \[min, max\] speed.
    pub fn critical_speed_options(&self) -> CriticalSpeedOptions {
        CriticalSpeedOptions {
            v_min: self.min_speed_mps,
            v_max: self.max_speed_mps,
            scan_step: self.scan_step_mps,
            tolerance: self.tolerance_mps,
        }
    }

    /// The reason said when straight running is stable on the whole scanned range.
    pub fn stable_reason(&self) -> String {
        stable_up_to_reason("straight running", self.max_speed_mps, MAX_SPEED)
    }
}

/// The name of the cap of [`SpeedLimits`] in a reason: `--max-speed`.
pub const MAX_SPEED: &str = "the maximum speed, --max-speed";

/// The one wording of a speed that a search's cap cut off: "`subject` is stable at every
/// speed up to `cap` m/s (`cap_name`)", e.g. "straight running is stable at every speed up
/// to 100 m/s (the maximum speed, --max-speed)". Every summary's `reason` beside a null
/// speed with `stable_up_to_mps`, and every printed line and label of one, says it so.
pub fn stable_up_to_reason(subject: &str, cap: f64, cap_name: &str) -> String {
    format!("{subject} is stable at every speed up to {cap} m/s ({cap_name})")
}

/// A speed searched for on a range that ends at a cap (`--max-speed`, a search's
/// `v_max_mps`): found below the cap, or none there — straight running is stable up to
/// the cap, and the cap is not a measured speed. A summary writes it as the open loop's
/// V_crit is written ([`CriticalSpeedSummary`]): the speed, or null with
/// `stable_up_to_mps` = the cap and a `reason` ([`CappedSpeed::reason`]); a CSV cell of it
/// is empty then, and a plot marks the cap as "stable up to".
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CappedSpeed {
    /// the speed found below the cap \[m/s\]
    Found(f64),
    /// none below the cap: stable up to it \[m/s\]
    StableUpTo(f64),
}

impl CappedSpeed {
    /// A search's answer: `Some(v)` found, `None` stable up to `cap` \[m/s\].
    pub fn of(found: Option<f64>, cap: f64) -> Self {
        found.map_or(Self::StableUpTo(cap), Self::Found)
    }

    /// A speed `v` \[m/s\] of an engine that reports the cap where it found nothing below
    /// it (an optimiser's objective: the maximal critical speed of a gain design): `v ≥ cap`
    /// is stable up to the cap, not a measured speed.
    pub fn from_bounded(v: f64, cap: f64) -> Self {
        if v >= cap {
            Self::StableUpTo(cap)
        } else {
            Self::Found(v)
        }
    }

    /// The speed found below the cap \[m/s\] (None: stable up to it).
    pub fn found(self) -> Option<f64> {
        match self {
            Self::Found(v) => Some(v),
            Self::StableUpTo(_) => None,
        }
    }

    /// The cap up to which straight running is stable \[m/s\] (None: a speed was found).
    pub fn stable_up_to(self) -> Option<f64> {
        match self {
            Self::Found(_) => None,
            Self::StableUpTo(cap) => Some(cap),
        }
    }

    /// The speed found, or the cap: a lower bound of the true speed \[m/s\] (what an
    /// optimiser compares and a plot places a "stable up to" marker at).
    pub fn lower_bound(self) -> f64 {
        match self {
            Self::Found(v) | Self::StableUpTo(v) => v,
        }
    }

    /// Why the speed is null ([`stable_up_to_reason`] of `subject` and the cap named
    /// `cap_name`); None where a speed was found.
    pub fn reason(self, subject: &str, cap_name: &str) -> Option<String> {
        self.stable_up_to()
            .map(|cap| stable_up_to_reason(subject, cap, cap_name))
    }

    /// The speed named `symbol` for a printed line or a label: "`symbol` = `v` m/s" with
    /// `decimals` decimals, or "`symbol`: stable up to `cap` m/s (the speed cap)".
    pub fn label(self, symbol: &str, decimals: usize) -> String {
        match self {
            Self::Found(v) => format!("{symbol} = {v:.decimals$} m/s"),
            Self::StableUpTo(cap) => format!("{symbol}: stable up to {cap} m/s (the speed cap)"),
        }
    }
}

/// Whether, and where, straight running of the open loop loses stability.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "outcome")]
pub enum OpenLoopStability {
    /// The spectral abscissa of Ã(V) (eq. 9–11) changes sign at V_crit: a Hopf point, or a
    /// static divergence when the rightmost eigenvalue is real (`hopf_omega_rad_s` = 0).
    Critical {
        /// V_crit \[m/s\]
        v_crit_mps: f64,
        /// the frequency of the critical pair at V_crit \[rad/s\]
        hopf_omega_rad_s: f64,
    },
    /// Stable at every speed of \[min, max\] of the [`SpeedLimits`].
    StableUpTo {
        /// the maximum speed scanned \[m/s\]
        stable_up_to_mps: f64,
    },
}

impl OpenLoopStability {
    /// Whether straight running loses stability through a real eigenvalue (ω = 0: a
    /// static divergence, no Hopf point, no sway cycles) rather than a complex pair.
    pub fn is_divergence(&self) -> bool {
        matches!(*self, Self::Critical { hopf_omega_rad_s, .. } if hopf_omega_rad_s == 0.0)
    }

    /// V_crit, if straight running loses stability below the maximum speed.
    pub fn v_crit(&self) -> Option<f64> {
        match *self {
            Self::Critical { v_crit_mps, .. } => Some(v_crit_mps),
            Self::StableUpTo { .. } => None,
        }
    }

    /// The fields every summary reports for it: nulls come with a reason.
    pub fn summary(&self) -> CriticalSpeedSummary {
        match *self {
            Self::Critical {
                v_crit_mps,
                hopf_omega_rad_s,
            } => CriticalSpeedSummary {
                v_crit_mps: Some(v_crit_mps),
                hopf_omega_rad_s: Some(hopf_omega_rad_s),
                hopf_frequency_hz: Some(hopf_omega_rad_s / (2.0 * std::f64::consts::PI)),
                stable_up_to_mps: None,
                reason: None,
            },
            Self::StableUpTo { stable_up_to_mps } => CriticalSpeedSummary {
                v_crit_mps: None,
                hopf_omega_rad_s: None,
                hopf_frequency_hz: None,
                stable_up_to_mps: Some(stable_up_to_mps),
                reason: Some(stable_up_to_reason(
                    "straight running",
                    stable_up_to_mps,
                    MAX_SPEED,
                )),
            },
        }
    }
}

/// The critical-speed fields of a summary: V_crit and the Hopf frequency, or null with
/// `stable_up_to_mps` and the `reason`.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct CriticalSpeedSummary {
    /// V_crit \[m/s\], null when stable up to the maximum speed
    pub v_crit_mps: Option<f64>,
    /// ω of the critical pair \[rad/s\]
    pub hopf_omega_rad_s: Option<f64>,
    /// ω / 2π \[Hz\]
    pub hopf_frequency_hz: Option<f64>,
    /// the maximum speed up to which straight running is stable \[m/s\] (when no V_crit)
    pub stable_up_to_mps: Option<f64>,
    /// why a value is null
    pub reason: Option<String>,
}

/// The open-loop critical speed: the one search every task and sweep uses (a scan of the
/// spectral abscissa of Ã(V) from `min_speed_mps` in `scan_step_mps`, then bisection of
/// the bracket to `tolerance_mps`, [`Plant::critical_speed_search`]; for the paper's
/// [`trailer_model::Model`] its own search, so its numbers do not move). Any plant.
///
/// # Errors
/// [`SwayError::Model`] when straight running is already unstable at the lowest speed or
/// the eigenvalues are not finite (a vehicle outside the model's range).
pub fn open_loop_critical_speed<P: Plant<N>, const N: usize>(
    model: &P,
    limits: &SpeedLimits,
) -> Result<OpenLoopStability, SwayError> {
    open_loop_stability_by(limits, |o| model.critical_speed_search(o))
}

/// [`open_loop_critical_speed`] with the search given: `search` answers the options of
/// `limits` ([`SpeedLimits::critical_speed_options`]) as [`Plant::critical_speed_search`]
/// does (a vehicle's, or
/// [`LoopModel::critical_speed_search`](crate::vehicle::LoopModel::critical_speed_search) of
/// any plant).
///
/// # Errors
/// [`SwayError::Model`] from the search.
pub fn open_loop_stability_by(
    limits: &SpeedLimits,
    search: impl FnOnce(&CriticalSpeedOptions) -> Result<Option<CriticalSpeed>, ModelError>,
) -> Result<OpenLoopStability, SwayError> {
    Ok(match search(&limits.critical_speed_options())? {
        Some(c) => OpenLoopStability::Critical {
            v_crit_mps: c.v_crit_mps,
            hopf_omega_rad_s: c.hopf_omega_rad_s,
        },
        None => OpenLoopStability::StableUpTo {
            stable_up_to_mps: limits.max_speed_mps,
        },
    })
}

/// A speed in a config: a number in m/s (absolute, used as given) or relative to the
/// vehicle's open loop.
///
/// ```toml
/// speed_mps = 33.0                       # m/s
/// speed_mps = { of_v_crit = 1.0073 }     # 1.0073·V_crit
/// change_mps = { of_v_crit = -0.2878 }   # a speed change ΔV = −0.2878·V_crit
/// speed_mps = { in_bistable = 0.458 }    # V_fold + 0.458·(V_crit − V_fold)
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(untagged)]
pub enum SpeedSpec {
    /// a speed \[m/s\]
    Absolute(f64),
    /// a speed relative to the open loop's V_crit or its bistable range
    Relative(RelativeSpeed),
}

impl std::fmt::Display for SpeedSpec {
    /// As the config writes it: `33 m/s`, `{ of_v_crit = 0.5 }`, `{ in_bistable = 0.4 }`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SpeedSpec::Absolute(v) => write!(f, "{v} m/s"),
            SpeedSpec::Relative(RelativeSpeed::OfVCrit(x)) => write!(f, "{{ of_v_crit = {x} }}"),
            SpeedSpec::Relative(RelativeSpeed::InBistable(x)) => {
                write!(f, "{{ in_bistable = {x} }}")
            }
        }
    }
}

/// A speed relative to the open loop of the vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RelativeSpeed {
    /// f·V_crit
    OfVCrit(f64),
    /// V_fold + f·(V_crit − V_fold): 0 at the fold of cycles, 1 at V_crit
    InBistable(f64),
}

/// Which reference speeds a spec needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Reference {
    /// none (an absolute speed)
    None,
    /// the open-loop V_crit
    VCrit,
    /// V_crit and the open-loop fold of cycles V_fold
    Fold,
}

/// The reference speeds of a vehicle's open loop, with the reason where one is missing.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct SpeedReferences {
    /// the open-loop V_crit \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// the open-loop fold of cycles V_fold \[m/s\] (computed only when a spec needs it)
    pub v_fold_mps: Option<f64>,
    /// why a reference is missing
    pub reason: Option<String>,
}

/// A relative speed with nothing to refer to (a stable vehicle, no bistable range).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{reason}")]
pub struct Unresolved {
    /// why
    pub reason: String,
}

impl SpeedSpec {
    /// The reference speeds this spec needs.
    pub fn needs(&self) -> Reference {
        match self {
            Self::Absolute(_) => Reference::None,
            Self::Relative(RelativeSpeed::OfVCrit(_)) => Reference::VCrit,
            Self::Relative(RelativeSpeed::InBistable(_)) => Reference::Fold,
        }
    }

    /// The speed \[m/s\] for a vehicle with these references.
    ///
    /// # Errors
    /// [`Unresolved`] with the reason when the reference does not exist, or when an
    /// `in_bistable` factor below the fold reaches to 0 m/s or below on this vehicle.
    pub fn resolve(&self, refs: &SpeedReferences) -> Result<f64, Unresolved> {
        let missing = |what: &str| Unresolved {
            reason: refs
                .reason
                .clone()
                .unwrap_or_else(|| format!("the vehicle has no {what}")),
        };
        match *self {
            Self::Absolute(v) => Ok(v),
            Self::Relative(RelativeSpeed::OfVCrit(f)) => {
                Ok(f * refs.v_crit_mps.ok_or_else(|| missing("critical speed"))?)
            }
            Self::Relative(RelativeSpeed::InBistable(f)) => {
                let vc = refs.v_crit_mps.ok_or_else(|| missing("critical speed"))?;
                let vf = refs
                    .v_fold_mps
                    .ok_or_else(|| missing("bistable range (no fold of cycles)"))?;
                let v = vf + f * (vc - vf);
                if v > 0.0 {
                    Ok(v)
                } else {
                    // a factor below the fold reaches past 0 on a wide bistable range
                    Err(Unresolved {
                        reason: format!(
                            "{{ in_bistable = {f} }} = V_fold + {f}·(V_crit − V_fold) = {v:.3} m/s for this vehicle (V_fold = {vf:.3}, V_crit = {vc:.3} m/s): not a speed; its bistable range is wider than the factor allows for (give the speed in m/s)"
                        ),
                    })
                }
            }
        }
    }
}

impl From<f64> for SpeedSpec {
    fn from(v: f64) -> Self {
        Self::Absolute(v)
    }
}

impl<'de> Deserialize<'de> for SpeedSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        const EXPECTED: &str = "a speed in m/s, or a table `{ of_v_crit = f }` (f·V_crit) or `{ in_bistable = f }` (V_fold + f·(V_crit − V_fold))";
        fn finite<E: serde::de::Error>(x: f64, what: &str) -> Result<f64, E> {
            if x.is_finite() {
                Ok(x)
            } else {
                Err(E::custom(format!("{x} is invalid: {what} must be finite")))
            }
        }
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = SpeedSpec;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(EXPECTED)
            }
            // any finite number: a speed *change* (a braking ramp's ΔV) is negative; a
            // speed ≤ 0 is refused by the check of the config that uses it, naming its key
            fn visit_f64<E: serde::de::Error>(self, x: f64) -> Result<SpeedSpec, E> {
                if x.is_finite() {
                    Ok(SpeedSpec::Absolute(x))
                } else {
                    Err(E::custom(format!(
                        "{x} is invalid: expected a speed in m/s (a finite number)"
                    )))
                }
            }
            fn visit_i64<E: serde::de::Error>(self, x: i64) -> Result<SpeedSpec, E> {
                self.visit_f64(x as f64)
            }
            fn visit_u64<E: serde::de::Error>(self, x: u64) -> Result<SpeedSpec, E> {
                self.visit_f64(x as f64)
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<SpeedSpec, A::Error> {
                use serde::de::Error;
                let mut out = None;
                while let Some(key) = map.next_key::<String>()? {
                    if out.is_some() {
                        return Err(A::Error::custom(format!(
                            "`{key}`: give one of `of_v_crit`, `in_bistable`, not both"
                        )));
                    }
                    let f: f64 = map.next_value()?;
                    out = Some(match key.as_str() {
                        // any finite factor: a speed *change* (a braking ramp's ΔV) is
                        // negative; a speed that resolves to ≤ 0 is refused by the check
                        // of the resolved config, naming its key
                        "of_v_crit" => {
                            RelativeSpeed::OfVCrit(finite::<A::Error>(f, "the factor of V_crit")?)
                        }
                        "in_bistable" => RelativeSpeed::InBistable(finite::<A::Error>(
                            f,
                            "the fraction of the bistable range",
                        )?),
                        other => {
                            return Err(A::Error::custom(format!(
                                "unknown key `{other}`: expected {EXPECTED}"
                            )));
                        }
                    });
                }
                out.map(SpeedSpec::Relative)
                    .ok_or_else(|| A::Error::custom(format!("empty table: expected {EXPECTED}")))
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use trailer_model::{Model, VehicleParams};

    #[derive(Debug, Deserialize)]
    struct Holder {
        speed_mps: SpeedSpec,
    }

    fn parse(text: &str) -> Result<SpeedSpec, String> {
        toml::from_str::<Holder>(text)
            .map(|h| h.speed_mps)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn a_speed_is_a_number_or_a_relative_table() {
        assert_eq!(parse("speed_mps = 33.0"), Ok(SpeedSpec::Absolute(33.0)));
        assert_eq!(parse("speed_mps = 33"), Ok(SpeedSpec::Absolute(33.0)));
        assert_eq!(
            parse("speed_mps = { of_v_crit = 0.95 }"),
            Ok(SpeedSpec::Relative(RelativeSpeed::OfVCrit(0.95)))
        );
        assert_eq!(
            parse("speed_mps = { in_bistable = 0.5 }"),
            Ok(SpeedSpec::Relative(RelativeSpeed::InBistable(0.5)))
        );
        let unknown = parse("speed_mps = { of_vcrit = 0.95 }").unwrap_err();
        assert!(unknown.contains("unknown key `of_vcrit`"), "{unknown}");
        let both = parse("speed_mps = { of_v_crit = 0.95, in_bistable = 0.5 }").unwrap_err();
        assert!(both.contains("not both"), "{both}");
        // a negative number is a speed change (ΔV in m/s); a speed ≤ 0 is refused where the
        // config is checked
        assert_eq!(parse("speed_mps = -3.0"), Ok(SpeedSpec::Absolute(-3.0)));
        assert!(
            parse("speed_mps = inf")
                .unwrap_err()
                .contains("finite number")
        );
        // a negative factor is a speed change (ΔV = f·V_crit); a speed ≤ 0 is refused
        // when the resolved config is checked
        assert_eq!(
            parse("speed_mps = { of_v_crit = -0.25 }"),
            Ok(SpeedSpec::Relative(RelativeSpeed::OfVCrit(-0.25)))
        );
        assert!(
            parse("speed_mps = { of_v_crit = nan }")
                .unwrap_err()
                .contains("must be finite")
        );
        assert!(parse("speed_mps = {}").unwrap_err().contains("empty table"));
    }

    #[test]
    fn an_in_bistable_speed_past_zero_is_unresolved_with_the_numbers() {
        // reference: V_fold + f·(V_crit − V_fold) by hand. Table I's threshold map goes
        // from in_bistable = −1.09 (28 m/s); a vehicle with V_fold = 30, V_crit = 70 m/s
        // would put it at 30 − 1.09·40 = −13.6 m/s: no speed
        let refs = |vc: f64, vf: f64| SpeedReferences {
            v_crit_mps: Some(vc),
            v_fold_mps: Some(vf),
            reason: None,
        };
        let spec = SpeedSpec::Relative(RelativeSpeed::InBistable(-1.09));
        let v = spec.resolve(&refs(34.75, 31.52)).unwrap();
        assert!((v - (31.52 - 1.09 * (34.75 - 31.52))).abs() < 1e-12, "{v}");
        let e = spec.resolve(&refs(70.0, 30.0)).unwrap_err();
        assert!(e.reason.contains("-13.600 m/s"), "{}", e.reason);
        assert!(e.reason.contains("give the speed in m/s"), "{}", e.reason);
    }

    #[test]
    fn table_i_critical_speed_is_the_models_search() {
        // reference: Model::critical_speed with the same scan (the `linear` task's value)
        let model = Model::new(VehicleParams::default()).unwrap();
        let reference = model
            .critical_speed(&CriticalSpeedOptions::default())
            .unwrap();
        let got = open_loop_critical_speed(&model, &SpeedLimits::default()).unwrap();
        assert_eq!(got.v_crit(), Some(reference.v_crit_mps));
        let s = got.summary();
        assert_eq!(s.hopf_omega_rad_s, Some(reference.hopf_omega_rad_s));
        assert!(s.reason.is_none() && s.stable_up_to_mps.is_none());
    }

    #[test]
    fn a_capped_speed_is_null_with_the_cap_and_the_reason() {
        // reference: the README's convention (`v_crit_mps: null` with `stable_up_to_mps`
        // and a `reason`) and the open loop's wording of it (OpenLoopStability::summary)
        let capped = CappedSpeed::from_bounded(100.0, 100.0);
        assert_eq!(capped, CappedSpeed::of(None, 100.0));
        assert_eq!((capped.found(), capped.stable_up_to()), (None, Some(100.0)));
        let open = OpenLoopStability::StableUpTo {
            stable_up_to_mps: 100.0,
        }
        .summary();
        assert_eq!(capped.reason("straight running", MAX_SPEED), open.reason);
        assert_eq!(
            capped.label("V_crit", 2),
            "V_crit: stable up to 100 m/s (the speed cap)"
        );
        let found = CappedSpeed::from_bounded(60.5, 100.0);
        assert_eq!((found.found(), found.stable_up_to()), (Some(60.5), None));
        assert_eq!(found.reason("straight running", MAX_SPEED), None);
        assert_eq!(found.label("V_crit", 2), "V_crit = 60.50 m/s");
        assert_eq!(found.lower_bound(), 60.5);
    }

    #[test]
    fn relative_speeds_resolve_against_the_references() {
        let refs = SpeedReferences {
            v_crit_mps: Some(40.0),
            v_fold_mps: Some(30.0),
            reason: None,
        };
        let r = |s: SpeedSpec| s.resolve(&refs).unwrap();
        assert_eq!(r(SpeedSpec::Absolute(12.5)), 12.5);
        assert_eq!(r(SpeedSpec::Relative(RelativeSpeed::OfVCrit(0.5))), 20.0);
        assert_eq!(
            r(SpeedSpec::Relative(RelativeSpeed::InBistable(0.25))),
            32.5
        );
        let no_fold = SpeedReferences {
            v_fold_mps: None,
            ..refs
        };
        assert!(
            SpeedSpec::Relative(RelativeSpeed::InBistable(0.5))
                .resolve(&no_fold)
                .unwrap_err()
                .reason
                .contains("bistable")
        );
    }
}
