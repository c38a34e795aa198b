//! The axes of a sweep: a scenario quantity, a vehicle field by its key path, or a list of
//! vehicle files (a fleet).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use trailer_model::{PARAMETERS, VehicleParams};

use sway::sim::speeds::{Resolver, SpeedValue, UnresolvedSpeed};

/// A swept scenario quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepParameter {
    /// V \[m/s\]: the constant speed, the ramp's initial speed, and the settling speed of a
    /// sway-cycle start
    SpeedMps,
    /// θ(0) \[deg\]: the initial hitch angle (a state start) or the perturbation that
    /// starts the settling (sway-cycle start)
    Theta0Deg,
    /// D \[s\]: gain of the yaw-rate feedback
    GainS,
    /// τ \[s\]: delay of the yaw-rate feedback
    DelayS,
    /// T \[s\]: duration of the braking ramp
    RampDurationS,
    /// t_b \[s\]: when the braking ramp starts (with a sway-cycle start: the sway phase at
    /// which braking begins)
    BrakeStartS,
}

impl SweepParameter {
    /// Every scenario quantity.
    pub const ALL: [SweepParameter; 6] = [
        SweepParameter::SpeedMps,
        SweepParameter::Theta0Deg,
        SweepParameter::GainS,
        SweepParameter::DelayS,
        SweepParameter::RampDurationS,
        SweepParameter::BrakeStartS,
    ];

    /// The column name.
    pub fn as_str(&self) -> &'static str {
        match self {
            SweepParameter::SpeedMps => "speed_mps",
            SweepParameter::Theta0Deg => "theta0_deg",
            SweepParameter::GainS => "gain_s",
            SweepParameter::DelayS => "delay_s",
            SweepParameter::RampDurationS => "ramp_duration_s",
            SweepParameter::BrakeStartS => "brake_start_s",
        }
    }

    /// Axis label with unit.
    pub fn label(&self) -> &'static str {
        match self {
            SweepParameter::SpeedMps => "V [m/s]",
            SweepParameter::Theta0Deg => "θ(0) [deg]",
            SweepParameter::GainS => "D [s]",
            SweepParameter::DelayS => "τ [s]",
            SweepParameter::RampDurationS => "braking time T [s]",
            SweepParameter::BrakeStartS => "braking start t_b [s]",
        }
    }
}

/// A field of the vehicle file, by its key path (`trailer.mass`, …: the keys of
/// [`trailer_model::PARAMETERS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VehicleField(usize);

impl VehicleField {
    /// The field with key path `key`.
    ///
    /// # Errors
    /// A message naming the key and listing the valid ones.
    pub fn from_key(key: &str) -> Result<Self, String> {
        PARAMETERS
            .iter()
            .position(|(k, _, _)| *k == key)
            .map(Self)
            .ok_or_else(|| {
                let keys: Vec<&str> = PARAMETERS.iter().map(|p| p.0).collect();
                format!(
                    "`{key}` is not a field of the vehicle file; expected one of {}",
                    keys.join(", ")
                )
            })
    }

    /// The index of the field in [`PARAMETERS`] (as [`trailer_model::VehicleSpec::with_parameter`]
    /// takes it).
    pub fn index(&self) -> usize {
        self.0
    }

    /// The key path.
    pub fn key(&self) -> &'static str {
        PARAMETERS[self.0].0
    }

    /// Axis label: key path, paper symbol and unit.
    pub fn label(&self) -> String {
        let (k, sym, unit) = PARAMETERS[self.0];
        format!("{k} ({sym}) [{unit}]")
    }

    /// `params` with this field set to `value` (not validated: [`trailer_model::Model::new`]
    /// validates, as it does a vehicle file).
    pub fn set(&self, params: &VehicleParams, value: f64) -> VehicleParams {
        params.with(self.0, value)
    }

    /// The field's value in `params`.
    pub fn get(&self, params: &VehicleParams) -> f64 {
        params.get(self.0)
    }
}

/// What an axis sweeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum AxisParameter {
    /// a scenario quantity (`speed_mps`, `theta0_deg`, …)
    Scenario(SweepParameter),
    /// a field of the vehicle file by key path (`trailer.mass`, …)
    Vehicle(VehicleField),
    /// `vehicle_file`: the vehicle files listed in the axis's `files` (a fleet)
    VehicleFile,
}

/// The name of the fleet axis.
pub const VEHICLE_FILE: &str = "vehicle_file";

impl TryFrom<String> for AxisParameter {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        if let Some(p) = SweepParameter::ALL.iter().find(|p| p.as_str() == s) {
            return Ok(AxisParameter::Scenario(*p));
        }
        if s == VEHICLE_FILE {
            return Ok(AxisParameter::VehicleFile);
        }
        VehicleField::from_key(&s).map(AxisParameter::Vehicle).map_err(|e| {
            let names: Vec<&str> = SweepParameter::ALL.iter().map(|p| p.as_str()).collect();
            format!(
                "unknown parameter: expected a scenario quantity ({}), `{VEHICLE_FILE}`, or a vehicle key path: {e}",
                names.join(", ")
            )
        })
    }
}

impl From<AxisParameter> for String {
    fn from(p: AxisParameter) -> String {
        p.as_str().to_string()
    }
}

impl AxisParameter {
    /// The column name (the key path for a vehicle field).
    pub fn as_str(&self) -> &'static str {
        match self {
            AxisParameter::Scenario(p) => p.as_str(),
            AxisParameter::Vehicle(f) => f.key(),
            AxisParameter::VehicleFile => VEHICLE_FILE,
        }
    }

    /// Axis label with unit.
    pub fn label(&self) -> String {
        match self {
            AxisParameter::Scenario(p) => p.label().to_string(),
            AxisParameter::Vehicle(f) => f.label(),
            AxisParameter::VehicleFile => "vehicle file (index in the fleet)".into(),
        }
    }
}

/// One axis of the grid: `points` uniformly spaced values from `min` to `max`, or for
/// `parameter = "vehicle_file"` the vehicle files `files` (paths relative to the sweep
/// file's directory). `S`: the type of `min` and `max` (a `speed_mps` axis may give them
/// relative to the vehicle, see [`sway::sim::speeds`]; every other axis gives numbers).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct Axis<S = f64> {
    /// what is swept
    pub parameter: AxisParameter,
    /// first value
    #[serde(default = "none", skip_serializing_if = "Option::is_none")]
    pub min: Option<S>,
    /// last value
    #[serde(default = "none", skip_serializing_if = "Option::is_none")]
    pub max: Option<S>,
    /// number of values (≥ 1; 1 gives `min`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points: Option<usize>,
    /// the vehicle files of a fleet axis
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<PathBuf>,
}

fn none<S>() -> Option<S> {
    None
}

impl<S: SpeedValue> Axis<S> {
    /// The axis with numbers for `min` and `max` (config keys under `key`).
    ///
    /// # Errors
    /// An end does not resolve for this vehicle.
    pub fn resolve_speeds(&self, key: &str, r: &mut Resolver<'_>) -> Result<Axis, UnresolvedSpeed> {
        let end = |v: &Option<S>, k: &str, r: &mut Resolver<'_>| {
            v.as_ref()
                .map(|v| v.resolve_speed(&format!("{key}.{k}"), r))
                .transpose()
        };
        Ok(Axis {
            parameter: self.parameter,
            min: end(&self.min, "min", r)?,
            max: end(&self.max, "max", r)?,
            points: self.points,
            files: self.files.clone(),
        })
    }

    /// Whether `min` or `max` is given relative to the vehicle.
    pub fn is_relative(&self) -> bool {
        [self.min, self.max]
            .iter()
            .flatten()
            .any(|v| v.absolute().is_none())
    }

    /// The number of values (the number of files of a fleet axis).
    pub fn len(&self) -> usize {
        match self.parameter {
            AxisParameter::VehicleFile => self.files.len().max(1),
            _ => self.points.unwrap_or(1).max(1),
        }
    }

    /// True for an axis without values (never: an axis has at least one).
    pub fn is_empty(&self) -> bool {
        false
    }
}

impl Axis {
    /// A range axis.
    pub fn range(parameter: AxisParameter, min: f64, max: f64, points: usize) -> Self {
        Self {
            parameter,
            min: Some(min),
            max: Some(max),
            points: Some(points),
            files: Vec::new(),
        }
    }

    /// The values (a fleet axis: the file indices 0, 1, …).
    pub fn values(&self) -> Vec<f64> {
        let n = self.len();
        if self.parameter == AxisParameter::VehicleFile {
            return (0..n).map(|i| i as f64).collect();
        }
        let (min, max) = (self.min.unwrap_or(0.0), self.max.unwrap_or(0.0));
        if n <= 1 {
            return vec![min];
        }
        (0..n)
            .map(|i| {
                if i + 1 == n {
                    max
                } else {
                    min + (max - min) * i as f64 / (n - 1) as f64
                }
            })
            .collect()
    }
}
