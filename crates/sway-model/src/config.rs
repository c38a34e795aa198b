//! Typed configs as plain data: validation helpers whose errors name the file, the key
//! path and the problem, the validated
//! value types [`Positive`], [`NonNegative`] and [`Grid`] (they check themselves when
//! deserialised, so the reader reports the key path). Reading files is the task layer's job
//! (`sway-tasks`); here configs are values.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::SwayError;

/// Returns a [`SwayError::Config`] for `key` unless `ok` holds.
pub fn ensure(
    ok: bool,
    file: &Path,
    key: &str,
    problem: impl FnOnce() -> String,
) -> Result<(), SwayError> {
    if ok {
        Ok(())
    } else {
        Err(SwayError::config(file, key, problem()))
    }
}

/// A count in `min ..= limit`, with the wording of every limit of the task layer's checks
/// (`sway_tasks::limits::bound`): below, `expected at least {min} {unit}, got {value}`;
/// above, `{value} exceeds the limit {limit} ({cost}); reduce it`.
///
/// # Errors
/// [`SwayError::Config`] naming `key`.
pub fn ensure_count(
    value: usize,
    (min, limit): (usize, usize),
    file: &Path,
    key: &str,
    unit: &str,
    cost: impl FnOnce() -> String,
) -> Result<(), SwayError> {
    ensure(value >= min, file, key, || {
        format!("expected at least {min} {unit}, got {value}")
    })?;
    ensure(value <= limit, file, key, || {
        format!("{value} exceeds the limit {limit} ({}); reduce it", cost())
    })
}

/// `value` must be finite and > 0 (`what` names the unit or meaning, e.g. "a horizon > 0 s").
///
/// # Errors
/// [`SwayError::Config`] naming `key`.
pub fn ensure_positive(value: f64, file: &Path, key: &str, what: &str) -> Result<(), SwayError> {
    ensure(value.is_finite() && value > 0.0, file, key, || {
        format!("expected {what}, got {value}")
    })
}

/// A simulated time span: `horizon` > 0 s and an output step in (0, horizon]; keys are
/// `<prefix>horizon_s` and `<prefix>output_step_s`.
///
/// # Errors
/// [`SwayError::Config`] naming the key.
pub fn ensure_time_span(
    horizon: f64,
    output_step: f64,
    file: &Path,
    prefix: &str,
) -> Result<(), SwayError> {
    ensure_positive(
        horizon,
        file,
        &format!("{prefix}horizon_s"),
        "a horizon > 0 s",
    )?;
    ensure(
        output_step > 0.0 && output_step <= horizon,
        file,
        &format!("{prefix}output_step_s"),
        || format!("expected 0 < output_step_s <= horizon_s, got {output_step}"),
    )
}

/// A config value that a table may omit, so that one struct serves both with its numbers
/// given and with them optional (`#[serde(skip_serializing_if = "Omittable::is_omitted")]`):
/// an `Option` is omitted when None, `()` (a key the struct does not take) always, a given
/// value never.
pub trait Omittable {
    /// Whether the key is left out of the serialised table.
    fn is_omitted(&self) -> bool;
}

impl<T> Omittable for Option<T> {
    fn is_omitted(&self) -> bool {
        self.is_none()
    }
}

/// The value of a key that a table of this kind does not have (the derived end
/// `beyond_hopf` of a diagram whose range is given): never serialised, and a config that
/// gives it is refused at the key with the reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Absent;

impl<'de> Deserialize<'de> for Absent {
    fn deserialize<D: serde::Deserializer<'de>>(_: D) -> Result<Self, D::Error> {
        Err(serde::de::Error::custom(
            "not a key of this table (it belongs to a table whose range is derived from the vehicle)",
        ))
    }
}

impl Omittable for Absent {
    fn is_omitted(&self) -> bool {
        true
    }
}

impl Omittable for f64 {
    fn is_omitted(&self) -> bool {
        false
    }
}

impl<T> Omittable for Vec<T> {
    fn is_omitted(&self) -> bool {
        false
    }
}

/// A finite number > 0. It validates itself when deserialised, so a bad value in a config
/// file is reported at its key path (`metrics.final_window_s`) with no validation code in
/// the config that holds it.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(try_from = "f64", into = "f64")]
pub struct Positive(f64);

impl Positive {
    /// `x` if it is finite and > 0.
    ///
    /// # Errors
    /// What was expected and the value given.
    pub fn new(x: f64) -> Result<Self, String> {
        if x.is_finite() && x > 0.0 {
            Ok(Self(x))
        } else {
            Err(format!("expected a finite number > 0, got {x}"))
        }
    }

    /// A positive literal, for defaults in code (`Positive::literal(5.0)`); a literal that
    /// is not finite and > 0 is a programming error and panics (at compile time in a
    /// `const`).
    pub const fn literal(x: f64) -> Self {
        assert!(
            x.is_finite() && x > 0.0,
            "Positive::literal needs a finite x > 0"
        );
        Self(x)
    }
}

/// The rest of a checked number type `$t(f64)` with a checking `$t::new`: `get`, and the
/// conversions from and to `f64` through which serde reads (checking) and writes it.
macro_rules! checked_number {
    ($t:ident) => {
        impl $t {
            /// The value.
            pub fn get(self) -> f64 {
                self.0
            }
        }

        impl TryFrom<f64> for $t {
            type Error = String;
            fn try_from(x: f64) -> Result<Self, String> {
                Self::new(x)
            }
        }

        impl From<$t> for f64 {
            fn from(p: $t) -> f64 {
                p.0
            }
        }
    };
}

checked_number!(Positive);

/// A finite number ≥ 0, validated when deserialised (see [`Positive`]).
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(try_from = "f64", into = "f64")]
pub struct NonNegative(f64);

impl NonNegative {
    /// `x` if it is finite and ≥ 0.
    ///
    /// # Errors
    /// What was expected and the value given.
    pub fn new(x: f64) -> Result<Self, String> {
        if x.is_finite() && x >= 0.0 {
            Ok(Self(x))
        } else {
            Err(format!("expected a finite number >= 0, got {x}"))
        }
    }
}

checked_number!(NonNegative);

/// Most points of a [`Grid`]: 100 000. The default grids have at most 591 points; a grid
/// is evaluated point by point and its rows kept (≈ 500 bytes each), so 100 000 points
/// stay below 50 MB however expensive a point is, and a typo (`points = 3000000`) is
/// refused when the file is read.
pub const MAX_GRID_POINTS: usize = 100_000;

/// A uniform grid `[min, max]` with `points` points, as written in task configs; validated
/// when deserialised (finite min < max, 2 ≤ points ≤ [`MAX_GRID_POINTS`]), so the error
/// names the grid's key path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "GridKeys")]
pub struct Grid {
    /// first value
    pub min: f64,
    /// last value
    pub max: f64,
    /// number of points (2 ≤ points ≤ [`MAX_GRID_POINTS`])
    pub points: usize,
}

/// The keys of a [`Grid`] before validation.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GridKeys {
    min: f64,
    max: f64,
    points: usize,
}

impl TryFrom<GridKeys> for Grid {
    type Error = String;
    fn try_from(g: GridKeys) -> Result<Self, String> {
        if !(g.min.is_finite() && g.max.is_finite() && g.min < g.max) {
            return Err(format!(
                "expected finite min < max, got min = {}, max = {}",
                g.min, g.max
            ));
        }
        if g.points < 2 {
            return Err(format!("expected at least 2 points, got {}", g.points));
        }
        if g.points > MAX_GRID_POINTS {
            return Err(format!(
                "points = {} exceeds the limit {MAX_GRID_POINTS} (≈ {} MB of rows); reduce it",
                g.points,
                g.points / 2000
            ));
        }
        Ok(Self {
            min: g.min,
            max: g.max,
            points: g.points,
        })
    }
}

impl Grid {
    /// The grid values (the last one is exactly `max`).
    pub fn values(&self) -> Vec<f64> {
        let n = self.points.max(2);
        (0..n)
            .map(|i| {
                if i + 1 == n {
                    self.max
                } else {
                    self.min + (self.max - self.min) * i as f64 / (n - 1) as f64
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_a_table_does_not_have_is_refused_with_the_reason() {
        #[derive(Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Table {
            #[serde(default)]
            #[allow(dead_code)]
            beyond_hopf: Absent,
        }
        assert!(toml::from_str::<Table>("").is_ok());
        let e = toml::from_str::<Table>("beyond_hopf = 0.3")
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a key of this table"), "{e}");
    }

    #[derive(Debug, Deserialize)]
    struct Holder {
        #[allow(dead_code)]
        x: Positive,
        #[allow(dead_code)]
        g: Grid,
    }

    #[test]
    fn validated_types_reject_bad_values_on_deserialisation() {
        let ok: Holder =
            toml::from_str("x = 2.5\ng = { min = 0.0, max = 1.0, points = 3 }").expect("valid");
        assert_eq!(ok.x.get(), 2.5);
        assert_eq!(ok.g.values(), vec![0.0, 0.5, 1.0]);
        for (text, problem) in [
            ("x = -1.0\ng = { min = 0.0, max = 1.0, points = 3 }", "> 0"),
            (
                "x = 1.0\ng = { min = 1.0, max = 0.0, points = 3 }",
                "min < max",
            ),
            (
                "x = 1.0\ng = { min = 0.0, max = 1.0, points = 1 }",
                "2 points",
            ),
            (
                "x = 1.0\ng = { min = 0.0, max = 1.0, points = 3, step = 1 }",
                "step",
            ),
            (
                "x = 1.0\ng = { min = 0.0, max = 1.0, points = 100000000 }",
                "limit 100000",
            ),
        ] {
            let e = toml::from_str::<Holder>(text).expect_err(text).to_string();
            assert!(e.contains(problem), "{text}: {e}");
        }
        assert!(NonNegative::new(0.0).is_ok() && NonNegative::new(-1e-300).is_err());
    }
}
