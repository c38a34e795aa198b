//! Parallel sweeps: a grid over scenario quantities (V, θ(0), D, τ, braking
//! time and start), vehicle fields by key path and vehicle files (a fleet), optionally times
//! uncertainty samples of vehicle fields; every point evaluates one [`PointKind`]: a
//! simulation (classified, see [`sway::sim::classify`]), the linear critical speed, or the
//! Hopf and fold-of-cycles speeds.
//!
//! Every piece of work is a point with an index `k` in `0..len()` and
//! [`Sweep::run_point`] is a pure function of (vehicles, config, k), so the points can be
//! computed in any order, on any number of threads or machines, and give the same numbers.
//! The index space: first the grid points (first axis fastest, the sample index outermost),
//! then, with a `[threshold]` table, one θ(0)-threshold bisection per value of axis 1
//! ([`threshold`]), then the reference cycle amplitudes of the bifurcation diagram at
//! those speeds. A failing point is reported in its result and the sweep goes on.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sway::with_run_fields;
use trailer_model::{AnyVehicleModel, Model, State4, VehicleParams, VehicleSpec};

use sway::SwayError;
use sway::config::{MAX_GRID_POINTS, Positive, ensure, ensure_count};
use sway::progress::Progress;
use sway::ranging::SpeedLimits;
use sway::sampling::{About, Sampler, Sampling};
use sway::sim::speeds::{ResolveSpeeds, Resolver, SpeedValue, UnresolvedSpeed};
use sway::sim::{ControllerTable, LoopLaw, Recording, SpeedProfile};
use sway::sim::{
    InitialCondition, default_action_time, ensure_name, validate_parts, validate_spec_parts,
};
use sway::sim::{Metrics, RunSettings, SimSpec, VehicleForm, simulate_in_paper_layout};

mod analysis;
mod axis;
pub mod threshold;

pub use analysis::{
    AnalysisOptions, HopfFoldSpeeds, LinearCriticalSpeed, diagram_hopf_fold_speeds,
    hopf_fold_speeds, linear_critical_speed, open_loop_critical_speed,
};
pub use axis::{Axis, AxisParameter, SweepParameter, VEHICLE_FILE, VehicleField};
pub use threshold::{CycleReference, Theta0Threshold, ThresholdSearch, theta0_threshold};

fn default_horizon() -> Positive {
    Positive::literal(60.0)
}

with_run_fields! {
    /// The scenario every grid point starts from.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct BaseScenario {
        /// end time \[s\]
        #[serde(default = "default_horizon")]
        pub horizon_s: Positive,
    }
}

/// What a sweep point evaluates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointKind {
    /// a simulation of the base scenario: metrics and class
    #[default]
    Simulation,
    /// the linear critical speed and Hopf frequency of straight running (open loop, or the
    /// base controller's delayed feedback)
    LinearCriticalSpeed,
    /// the Hopf and fold-of-cycles speeds (bifurcation diagram corrected on the
    /// two-parameter defining systems; open loop or the base controller's feedback)
    HopfFoldSpeeds,
}

impl PointKind {
    fn is_simulation(&self) -> bool {
        *self == PointKind::Simulation
    }

    /// The snake_case name used in config files and summaries.
    pub fn as_str(&self) -> &'static str {
        match self {
            PointKind::Simulation => "simulation",
            PointKind::LinearCriticalSpeed => "linear_critical_speed",
            PointKind::HopfFoldSpeeds => "hopf_fold_speeds",
        }
    }
}

/// A sweep file (see `configs/sweep_threshold.toml`). `S`: the type of the speeds (base
/// scenario and `speed_mps` axes), [`sway::ranging::SpeedSpec`] as written, `f64` when run
/// (see [`sway::sim::speeds`]; relative speeds resolve once per run against the sweep's
/// vehicle, not per point).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(serialize = "S: Serialize", deserialize = "S: Deserialize<'de>"))]
pub struct SweepConfig<S = f64> {
    /// results go to `results/<name>/`
    pub name: String,
    /// what each point evaluates (default: a simulation)
    #[serde(default, skip_serializing_if = "is_simulation")]
    pub kind: PointKind,
    /// the grid axes (the first two span the heat map); may be empty with `[sampling]`
    #[serde(default = "Vec::new")]
    pub axes: Vec<Axis<S>>,
    /// the scenario that is varied
    pub base: BaseScenario<S>,
    /// uncertainty samples of vehicle fields (every grid point is evaluated per sample)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampling: Option<Sampling>,
    /// the θ(0) threshold per value of axis 1, bisected between its grid cells
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threshold: Option<ThresholdSearch>,
    /// settings of the linear and bifurcation kinds
    #[serde(default, skip_serializing_if = "AnalysisOptions::is_default")]
    pub analysis: AnalysisOptions,
}

fn is_simulation(k: &PointKind) -> bool {
    k.is_simulation()
}

/// What one point computed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointOutput {
    /// a simulation's metrics (with its class)
    Simulation(Metrics),
    /// V_crit and the Hopf frequency
    LinearCriticalSpeed(LinearCriticalSpeed),
    /// the Hopf and fold-of-cycles speeds
    HopfFoldSpeeds(HopfFoldSpeeds),
    /// the θ(0) threshold at one value of axis 1
    Theta0Threshold(Theta0Threshold),
    /// the cycle amplitudes of the bifurcation diagram at the values of axis 1
    CycleReference(CycleReference),
}

/// Result of one point (grid point, sampled point, threshold or reference point).
/// Serialises to JSON and back exactly (every number is a finite f64 or null).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointResult {
    /// the inputs of this point: the axis values in axis order (a fleet axis: the file
    /// index), then the sampled field values; a threshold point: its value of axis 1
    pub values: Vec<f64>,
    /// what was computed, or the error message of a failed point
    pub output: Result<PointOutput, String>,
    /// accepted solver steps (0 when not a simulation or on failure)
    pub steps: usize,
}

impl PointResult {
    /// The simulation metrics of a grid point (None for other kinds or a failed point).
    pub fn metrics(&self) -> Option<&Metrics> {
        match &self.output {
            Ok(PointOutput::Simulation(m)) => Some(m),
            _ => None,
        }
    }
}

impl<S: SpeedValue> ResolveSpeeds for BaseScenario<S> {
    type Resolved = BaseScenario;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<BaseScenario, UnresolvedSpeed> {
        Ok(BaseScenario {
            horizon_s: self.horizon_s,
            action_s: self.action_s,
            speed: self.speed.resolve_speeds("base.speed", r)?,
            controller: self.controller.clone(),
            initial: self.initial.resolve_speeds("base.initial", r)?,
            settings: self.settings,
        })
    }
}

impl<S: SpeedValue> ResolveSpeeds for SweepConfig<S> {
    type Resolved = SweepConfig;
    fn resolve_speeds(&self, r: &mut Resolver<'_>) -> Result<SweepConfig, UnresolvedSpeed> {
        let axes = self
            .axes
            .iter()
            .enumerate()
            .map(|(i, a)| a.resolve_speeds(&format!("axes[{i}]"), r))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SweepConfig {
            name: self.name.clone(),
            kind: self.kind,
            axes,
            base: self.base.resolve_speeds(r)?,
            sampling: self.sampling.clone(),
            threshold: self.threshold.clone(),
            analysis: self.analysis.clone(),
        })
    }
}

impl<S: SpeedValue> SweepConfig<S> {
    /// The vehicle fields the sweep varies, each with the config key that names it
    /// (`axes[i].parameter`, `sampling.fields[i].key`); keys that do not name a field are
    /// left out (the config check refuses them).
    pub fn vehicle_fields(&self) -> Vec<(String, VehicleField)> {
        let axes = self
            .axes
            .iter()
            .enumerate()
            .filter_map(|(i, a)| match a.parameter {
                AxisParameter::Vehicle(f) => Some((format!("axes[{i}].parameter"), f)),
                _ => None,
            });
        let sampled = self.sampling.iter().flat_map(|s| {
            s.fields.iter().enumerate().filter_map(|(i, f)| {
                VehicleField::from_key(&f.key)
                    .ok()
                    .map(|v| (format!("sampling.fields[{i}].key"), v))
            })
        });
        axes.chain(sampled).collect()
    }

    /// Checks every key that can be checked before the speeds are resolved: only
    /// `speed_mps` axes may be relative, not with a fleet (a relative speed needs one
    /// vehicle); a sweep whose speeds are all numbers is checked completely
    /// ([`SweepConfig::validate`]); one with relative speeds is checked completely once
    /// they are resolved.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate_spec(&self, file: &Path) -> Result<(), SwayError> {
        validate_spec_parts(file, "base", &self.base.speed)?;
        for (i, a) in self.axes.iter().enumerate() {
            let speed = a.parameter == AxisParameter::Scenario(SweepParameter::SpeedMps);
            ensure(
                speed || !a.is_relative(),
                file,
                &format!("axes[{i}]"),
                || {
                    format!(
                        "only a speed_mps axis may give min and max relative to the vehicle; {} takes numbers",
                        a.parameter.as_str()
                    )
                },
            )?;
        }
        let relative = self.needs().reference().is_some();
        ensure(
            !relative || self.fleet_files().is_empty(),
            file,
            "axes",
            || {
                "relative speeds ({ of_v_crit = … }, { in_bistable = … }) refer to one vehicle; with a vehicle_file axis give the speeds in m/s".into()
            },
        )?;
        match self.all_numbers() {
            Some(c) => c.validate(file),
            None => Ok(()),
        }
    }

    /// The number of grid points (product of the axis lengths, times the samples;
    /// saturating: a config whose product overflows is refused by the task's plan).
    pub fn grid_len(&self) -> usize {
        let samples = self.sampling.as_ref().map_or(1, |s| s.samples.max(1));
        self.axes
            .iter()
            .map(Axis::len)
            .fold(samples, usize::saturating_mul)
    }

    /// The fleet's vehicle files as written in the config (relative to the sweep file's
    /// directory), empty without a `vehicle_file` axis.
    pub fn fleet_files(&self) -> Vec<PathBuf> {
        self.axes
            .iter()
            .find(|a| a.parameter == AxisParameter::VehicleFile)
            .map(|a| a.files.clone())
            .unwrap_or_default()
    }
}

impl SweepConfig {
    /// Checks every key, including that each axis can act on the base scenario (or, for
    /// a vehicle field, that both its ends give a valid vehicle with `vehicle`).
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path) -> Result<(), SwayError> {
        ensure_name(file, &self.name, "a name of letters, digits, '_' or '-'")?;
        ensure(
            !self.axes.is_empty() || self.sampling.is_some(),
            file,
            "axes",
            || "expected at least one axis (or a [sampling] table)".into(),
        )?;
        let b = &self.base;
        validate_parts(
            file,
            "base",
            &b.speed,
            &b.controller,
            &b.initial,
            &b.settings,
        )?;
        for (i, a) in self.axes.iter().enumerate() {
            self.validate_axis(file, i, a)?;
        }
        if let Some(a) = b.action_s {
            ensure(
                a.is_finite() && a >= 0.0 && a <= b.horizon_s.get(),
                file,
                "base.action_s",
                || format!("expected 0 <= action_s <= horizon_s, got {a}"),
            )?;
        }
        if let Some(s) = &self.sampling {
            let sampler = Sampler::new(s)
                .map_err(|(k, p)| SwayError::config(file, format!("sampling.{k}"), p))?;
            for (i, f) in sampler.fields().iter().enumerate() {
                let key = format!("sampling.fields[{i}].key");
                let field =
                    VehicleField::from_key(&f.key).map_err(|m| SwayError::config(file, &key, m))?;
                if self
                    .axes
                    .iter()
                    .any(|a| a.parameter == AxisParameter::Vehicle(field))
                    || sampler.fields()[..i].iter().any(|g| g.key == f.key)
                {
                    return Err(SwayError::config(
                        file,
                        key,
                        "each vehicle field may be varied once",
                    ));
                }
            }
        }
        self.analysis.validate(file, self.kind)?;
        if let Some(t) = &self.threshold {
            t.validate(file, self)?;
        }
        Ok(())
    }

    fn validate_axis(&self, file: &Path, i: usize, a: &Axis) -> Result<(), SwayError> {
        let key = format!("axes[{i}]");
        if self.axes[..i].iter().any(|o| o.parameter == a.parameter) {
            return Err(SwayError::config(
                file,
                format!("{key}.parameter"),
                "each parameter may be swept once",
            ));
        }
        if a.parameter == AxisParameter::VehicleFile {
            ensure(
                !a.files.is_empty() && a.min.is_none() && a.max.is_none() && a.points.is_none(),
                file,
                &format!("{key}.files"),
                || {
                    "a vehicle_file axis lists its vehicle files in `files` (and has no min, max or points)".into()
                },
            )?;
            return Ok(());
        }
        ensure(a.files.is_empty(), file, &format!("{key}.files"), || {
            format!("only a `{VEHICLE_FILE}` axis lists files")
        })?;
        let (Some(min), Some(max), Some(points)) = (a.min, a.max, a.points) else {
            return Err(SwayError::config(
                file,
                &key,
                "expected `min`, `max` and `points`",
            ));
        };
        ensure(
            min.is_finite() && max.is_finite() && min <= max,
            file,
            &key,
            || format!("expected finite min <= max, got {min} and {max}"),
        )?;
        ensure_count(
            points,
            (1, MAX_GRID_POINTS),
            file,
            &format!("{key}.points"),
            "point",
            || format!("{points} points on this axis alone"),
        )?;
        if let AxisParameter::Scenario(p) = a.parameter {
            if !self.kind.is_simulation()
                && !matches!(p, SweepParameter::GainS | SweepParameter::DelayS)
            {
                return Err(SwayError::config(
                    file,
                    format!("{key}.parameter"),
                    format!(
                        "a {} sweep varies only gain_s, delay_s and vehicle fields, not {}",
                        self.kind.as_str(),
                        p.as_str()
                    ),
                ));
            }
            // apply both ends to the base and validate the result
            for v in [min, max] {
                let s = apply(&self.base, p, v)
                    .map_err(|m| SwayError::config(file, format!("{key}.parameter"), m))?;
                validate_parts(file, &key, &s.speed, &s.controller, &s.initial, &s.settings)?;
            }
        }
        Ok(())
    }

    /// Checks that every vehicle the sweep can build is valid: each of `vehicles` (the
    /// `--vehicle` file or the fleet) with every vehicle-field axis at both ends and every
    /// sampled field at both bounds (one at a time); the error names the axis or field and
    /// the vehicle key that fails.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming `file` and the key.
    pub fn validate_vehicles(
        &self,
        file: &Path,
        vehicles: &[VehicleParams],
    ) -> Result<(), SwayError> {
        let mut ends: Vec<(String, VehicleField, About, f64)> = Vec::new();
        for (i, a) in self.axes.iter().enumerate() {
            if let AxisParameter::Vehicle(f) = a.parameter {
                for v in [a.min, a.max].into_iter().flatten() {
                    ends.push((format!("axes[{i}]"), f, About::Absolute, v));
                }
            }
        }
        for (i, f) in self
            .sampling
            .iter()
            .flat_map(|s| s.fields.iter())
            .enumerate()
        {
            if let Ok(field) = VehicleField::from_key(&f.key) {
                for v in [f.min, f.max] {
                    ends.push((format!("sampling.fields[{i}]"), field, f.about, v));
                }
            }
        }
        for (j, base) in vehicles.iter().enumerate() {
            for (key, f, about, v) in &ends {
                let value = about.apply(f.get(base), *v);
                Model::new(f.set(base, value)).map_err(|e| {
                    SwayError::config(
                        file,
                        key,
                        format!(
                            "{} = {value} gives an invalid vehicle (vehicle {j}): {e}",
                            f.key()
                        ),
                    )
                })?;
            }
        }
        Ok(())
    }
}

/// The base scenario with one scenario quantity set.
fn apply(base: &BaseScenario, p: SweepParameter, v: f64) -> Result<BaseScenario, String> {
    let mut s = base.clone();
    set_scenario(&mut s, p, v)?;
    Ok(s)
}

#[doc(hidden)] // pub for tests/unit
pub fn set_scenario(s: &mut BaseScenario, p: SweepParameter, v: f64) -> Result<(), String> {
    match p {
        SweepParameter::SpeedMps => {
            match &mut s.speed {
                SpeedProfile::Constant { speed_mps } => *speed_mps = v,
                SpeedProfile::Ramp { initial_mps, .. } => *initial_mps = v,
                SpeedProfile::Table { .. } => {
                    return Err(
                        "speed_mps needs a constant or ramp speed profile in [base.speed]".into(),
                    );
                }
            }
            if let InitialCondition::SwayCycle { speed_mps, .. } = &mut s.initial {
                *speed_mps = v;
            }
        }
        SweepParameter::Theta0Deg => match &mut s.initial {
            InitialCondition::State { theta0_deg, .. } => *theta0_deg = v,
            InitialCondition::SwayCycle { theta0_rad, .. } => *theta0_rad = v.to_radians(),
        },
        SweepParameter::GainS | SweepParameter::DelayS => match &mut s.controller {
            ControllerTable::YawRateFeedback {
                gain_s, delay_s, ..
            } => {
                if p == SweepParameter::GainS {
                    *gain_s = v;
                } else {
                    *delay_s = v;
                }
            }
            ControllerTable::YawRateHitch { gains, delay_s, .. }
            | ControllerTable::Predictor { gains, delay_s, .. } => {
                if p == SweepParameter::GainS {
                    gains.yaw_rate = v;
                } else {
                    *delay_s = v;
                }
            }
            ControllerTable::None => {
                return Err(format!(
                    "{} needs a yaw_rate_feedback, yaw_rate_hitch or predictor controller in [base.controller]",
                    p.as_str()
                ));
            }
        },
        SweepParameter::RampDurationS => match &mut s.speed {
            SpeedProfile::Ramp { duration_s, .. } => *duration_s = v,
            _ => return Err("ramp_duration_s needs a ramp speed profile in [base.speed]".into()),
        },
        SweepParameter::BrakeStartS => match &mut s.speed {
            SpeedProfile::Ramp { start_s, .. } => *start_s = v,
            _ => return Err("brake_start_s needs a ramp speed profile in [base.speed]".into()),
        },
    }
    Ok(())
}

/// The model of one point: the paper's (borrowed when no vehicle field varies), or the plant
/// of a vehicle with model variants.
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)] // one per point, on the stack of its run
pub(crate) enum PointModel<'a> {
    /// the paper's model
    Paper(Cow<'a, Model>),
    /// a vehicle with model variants ([`Sweep::with_vehicle_spec`])
    Variant(Cow<'a, AnyVehicleModel>),
}

impl<'a> From<&'a PointModel<'_>> for VehicleForm<'a> {
    fn from(model: &'a PointModel<'_>) -> Self {
        match model {
            PointModel::Paper(m) => VehicleForm::Paper(m),
            PointModel::Variant(v) => VehicleForm::from(v.as_ref()),
        }
    }
}

impl<'a> From<VehicleForm<'a>> for PointModel<'a> {
    fn from(vehicle: VehicleForm<'a>) -> Self {
        match vehicle {
            VehicleForm::Paper(m) => PointModel::Paper(Cow::Borrowed(m)),
            VehicleForm::Variants(v) => PointModel::Variant(Cow::Borrowed(v)),
        }
    }
}

/// The model and the scenario of one point.
/// The model and scenario of a grid point, and the fleet index of its vehicle when that is
/// the sweep's own vehicle unchanged (None: an axis or a sample changed it).
type PointSetup<'a> = (PointModel<'a>, BaseScenario, Option<usize>);

/// A sweep ready to run: the config, its vehicles and models, the axis values and the
/// sampler, built once; [`Sweep::run_point`] then needs nothing else.
#[derive(Debug)]
pub struct Sweep {
    cfg: SweepConfig,
    /// the vehicle of each fleet entry (or the one vehicle)
    vehicles: Vec<VehicleParams>,
    /// their models
    models: Vec<Model>,
    /// the values of each axis
    axis_values: Vec<Vec<f64>>,
    sampler: Option<Sampler>,
    /// sampled fields, in the sampler's order, with what their draws are
    sampled_fields: Vec<(VehicleField, About)>,
    /// points of one sample (product of the axis lengths)
    per_sample: usize,
    grid: usize,
    thresholds: usize,
    references: usize,
    /// the limits of the ranges derived from the vehicle (`--max-speed`)
    pub(crate) limits: SpeedLimits,
    /// the vehicle file and its plant when it has model variants (no fleet axis)
    variant: Option<(VehicleSpec, AnyVehicleModel)>,
    /// the start of the base scenario on each unchanged vehicle, resolved once (settling
    /// on the sway cycle costs as much as a run, and every point over scenario quantities
    /// starts there)
    base_starts: Vec<OnceLock<Result<State4, String>>>,
}

impl Sweep {
    /// Builds the sweep of `cfg` (already validated with [`SweepConfig::validate`]) for
    /// `vehicle` (the `--vehicle` file) or, with a `vehicle_file` axis, for `fleet` (the
    /// params of its files, in the order of [`SweepConfig::fleet_files`]).
    ///
    /// # Errors
    /// [`SwayError::Model`] for an invalid vehicle, [`SwayError::Config`] (file `<sweep>`)
    /// when the fleet does not match the axis or the sampling is invalid.
    pub fn new(
        vehicle: &VehicleParams,
        fleet: &[VehicleParams],
        cfg: &SweepConfig,
    ) -> Result<Self, SwayError> {
        let sweep_file = Path::new("<sweep>");
        let n_files = cfg.fleet_files().len();
        if fleet.len() != n_files {
            return Err(SwayError::config(
                sweep_file,
                "axes",
                format!("{} fleet vehicles given for {n_files} files", fleet.len()),
            ));
        }
        let vehicles: Vec<VehicleParams> = if n_files > 0 {
            fleet.to_vec()
        } else {
            vec![*vehicle]
        };
        let models = vehicles
            .iter()
            .map(|v| Model::new(*v))
            .collect::<Result<Vec<_>, _>>()?;
        let n_vehicles = vehicles.len();
        let sampler = match &cfg.sampling {
            Some(s) => Some(
                Sampler::new(s)
                    .map_err(|(k, p)| SwayError::config(sweep_file, format!("sampling.{k}"), p))?,
            ),
            None => None,
        };
        let sampled_fields = sampler
            .iter()
            .flat_map(|s| s.fields())
            .map(|f| VehicleField::from_key(&f.key).map(|v| (v, f.about)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|m| SwayError::config(sweep_file, "sampling.fields", m))?;
        let thresholds = cfg
            .threshold
            .as_ref()
            .map_or(0, |_| cfg.axes.first().map_or(0, Axis::len));
        let references = usize::from(cfg.threshold.as_ref().is_some_and(|t| t.compare_cycles));
        Ok(Self {
            per_sample: cfg
                .axes
                .iter()
                .map(Axis::len)
                .fold(1, usize::saturating_mul),
            grid: cfg.grid_len(),
            axis_values: cfg.axes.iter().map(Axis::values).collect(),
            cfg: cfg.clone(),
            vehicles,
            models,
            sampler,
            sampled_fields,
            thresholds,
            references,
            limits: SpeedLimits::default(),
            variant: None,
            base_starts: (0..n_vehicles).map(|_| OnceLock::new()).collect(),
        })
    }

    /// The same sweep on the vehicle file `spec` itself when it has model variants (tyre
    /// relaxation, axle lists, tyre laws, hitch torque): simulations run on its plant
    /// ([`simulate_in_paper_layout`]), vehicle fields and samples change it by
    /// [`VehicleSpec::with_parameter`]. A vehicle of the paper's form (or a sweep with a
    /// fleet axis) is left on the paper's model.
    ///
    /// # Errors
    /// [`SwayError::Model`] for an invalid vehicle.
    pub fn with_vehicle_spec(self, spec: &VehicleSpec) -> Result<Self, SwayError> {
        if !self.cfg.fleet_files().is_empty() || !spec.has_variants()? {
            return Ok(self);
        }
        let plant = AnyVehicleModel::new(spec)?;
        Ok(Self {
            variant: Some((spec.clone(), plant)),
            ..self
        })
    }

    /// Whether the sweep runs on a vehicle with model variants.
    pub fn has_variants(&self) -> bool {
        self.variant.is_some()
    }

    /// The plant of the vehicle with model variants the sweep runs on (None: the paper's
    /// model, [`Sweep::base_model`]).
    pub(crate) fn variant_plant(&self) -> Option<&AnyVehicleModel> {
        self.variant.as_ref().map(|(_, plant)| plant)
    }

    /// The same sweep with other [`SpeedLimits`] (`--max-speed`): the ranges of the
    /// linear and bifurcation kinds and of the threshold map's reference diagram that the
    /// config omits are derived within them.
    #[must_use]
    pub fn with_limits(self, limits: SpeedLimits) -> Self {
        Self { limits, ..self }
    }

    /// The config.
    pub fn config(&self) -> &SweepConfig {
        &self.cfg
    }

    /// The total number of points: grid (× samples), then thresholds, then references.
    pub fn len(&self) -> usize {
        self.grid + self.thresholds + self.references
    }

    /// True for a sweep without points (never after validation).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The number of grid points (× samples); points from here on are thresholds and
    /// references.
    pub fn grid_len(&self) -> usize {
        self.grid
    }

    /// The axis values of grid point `k` (first axis fastest) and its sample index.
    pub fn grid_point(&self, k: usize) -> (Vec<f64>, usize) {
        let mut r = k % self.per_sample.max(1);
        let values = self
            .axis_values
            .iter()
            .map(|vals| {
                let v = vals[r % vals.len()];
                r /= vals.len();
                v
            })
            .collect();
        (values, k / self.per_sample.max(1))
    }

    /// Computes point `k` (in `0..len()`); a pure function of (vehicles, config, k).
    pub fn run_point(&self, k: usize) -> PointResult {
        if k < self.grid {
            self.run_grid_point(k)
        } else if k < self.grid + self.thresholds {
            threshold::run_threshold_point(self, k - self.grid)
        } else {
            threshold::run_reference_point(self)
        }
    }

    /// The model and scenario of grid point `k`, and its input values.
    fn setup(&self, k: usize) -> (Vec<f64>, Result<PointSetup<'_>, String>) {
        let (mut values, s) = self.grid_point(k);
        let mut fleet = 0;
        let mut params: Option<VehicleParams> = None;
        let mut scenario = self.cfg.base.clone();
        let mut err = None;
        for (a, &v) in self.cfg.axes.iter().zip(&values) {
            match a.parameter {
                AxisParameter::VehicleFile => fleet = v as usize,
                AxisParameter::Vehicle(_) => {}
                AxisParameter::Scenario(p) => {
                    if let Err(e) = set_scenario(&mut scenario, p, v) {
                        err = Some(e);
                    }
                }
            }
        }
        for (a, &v) in self.cfg.axes.iter().zip(&values) {
            if let AxisParameter::Vehicle(f) = a.parameter {
                let base = params.unwrap_or(self.vehicles[fleet]);
                params = Some(f.set(&base, v));
            }
        }
        if let Some(sampler) = &self.sampler {
            let start = values.len();
            values.resize(start + self.sampled_fields.len(), 0.0);
            sampler.sample_into(s, &mut values[start..]);
            let mut p = params.unwrap_or(self.vehicles[fleet]);
            // the recorded value is the field's value (the draw applied to the vehicle's)
            for ((f, about), v) in self.sampled_fields.iter().zip(&mut values[start..]) {
                *v = about.apply(f.get(&p), *v);
                p = f.set(&p, *v);
            }
            params = Some(p);
        }
        if let Some(e) = err {
            return (values, Err(e));
        }
        if let Some((spec, plant)) = &self.variant {
            let model = variant_point(spec, plant, &self.cfg.axes, &values, &self.sampled_fields);
            return (
                values,
                model.map(|m| {
                    let unchanged = matches!(&m, PointModel::Variant(Cow::Borrowed(_)));
                    (m, scenario, unchanged.then_some(0))
                }),
            );
        }
        let unchanged = params.is_none().then_some(fleet);
        let model = match params {
            None => Ok(Cow::Borrowed(&self.models[fleet])),
            Some(p) => Model::new(p)
                .map(Cow::Owned)
                .map_err(|e| format!("vehicle: {e}")),
        };
        (
            values,
            model.map(|m| (PointModel::Paper(m), scenario, unchanged)),
        )
    }

    /// The start of a simulated grid point: on an unchanged vehicle (`base_vehicle`) from
    /// the base scenario's initial condition, resolved once per vehicle; else resolved here.
    fn start_of(
        &self,
        model: &PointModel<'_>,
        s: &BaseScenario,
        base_vehicle: Option<usize>,
    ) -> Result<State4, String> {
        let resolve = || {
            s.initial
                .resolve(model, &s.settings.solver)
                .map(|(x0, _psi0)| x0)
                .map_err(|e| e.to_string())
        };
        let base = &self.cfg.base;
        match base_vehicle {
            Some(i) if s.initial == base.initial && s.settings.solver == base.settings.solver => {
                self.base_starts[i].get_or_init(resolve).clone()
            }
            _ => resolve(),
        }
    }

    fn run_grid_point(&self, k: usize) -> PointResult {
        let (values, setup) = self.setup(k);
        let result = setup.and_then(|(model, s, base_vehicle)| match (self.cfg.kind, &model) {
            (PointKind::Simulation, _) => self
                .start_of(&model, &s, base_vehicle)
                .and_then(|x0| simulate_from(&model, &s, s.horizon_s.get(), x0))
                .map(|(m, steps)| (PointOutput::Simulation(m), steps)),
            (PointKind::LinearCriticalSpeed, _) => law_of(&s)
                .and_then(|law| {
                    analysis::linear_critical_speed(
                        &model,
                        law.as_ref(),
                        &self.cfg.analysis,
                        &self.limits,
                    )
                })
                .map(|r| (PointOutput::LinearCriticalSpeed(r), 0)),
            (PointKind::HopfFoldSpeeds, PointModel::Paper(model)) => law_of(&s)
                .and_then(|law| {
                    analysis::hopf_fold_speeds(
                        model,
                        law.as_ref(),
                        &self.cfg.analysis,
                        &self.limits,
                    )
                })
                .map(|r| (PointOutput::HopfFoldSpeeds(r), 0)),
            (PointKind::HopfFoldSpeeds, PointModel::Variant(plant)) => law_of(&s)
                .and_then(|law| {
                    trailer_model::with_plant!(plant.as_ref(), m => analysis::diagram_hopf_fold_speeds(
                        m,
                        law.as_ref(),
                        &self.cfg.analysis,
                        &self.limits,
                    ))
                })
                .map(|r| (PointOutput::HopfFoldSpeeds(r), 0)),
        });
        match result {
            Ok((output, steps)) => PointResult {
                values,
                output: Ok(output),
                steps,
            },
            Err(e) => PointResult {
                values,
                output: Err(e),
                steps: 0,
            },
        }
    }

    /// The model of the base vehicle (the first of a fleet).
    pub(crate) fn base_model(&self) -> &Model {
        &self.models[0]
    }
}

/// The plant of a point of a sweep over a vehicle with model variants: the vehicle fields of
/// the axes and the sampled fields set by [`VehicleSpec::with_parameter`] (a sampled draw is
/// applied to the field's value in the equivalent paper-form vehicle); the base plant
/// borrowed when nothing changes.
fn variant_point<'a>(
    spec: &VehicleSpec,
    plant: &'a AnyVehicleModel,
    axes: &[Axis],
    values: &[f64],
    sampled: &[(VehicleField, About)],
) -> Result<PointModel<'a>, String> {
    let vehicle_err = |e: trailer_model::ModelError| format!("vehicle: {e}");
    let mut changed: Option<VehicleSpec> = None;
    for (a, &v) in axes.iter().zip(values) {
        if let AxisParameter::Vehicle(f) = a.parameter {
            let base = changed.as_ref().unwrap_or(spec);
            changed = Some(base.with_parameter(f.index(), v).map_err(vehicle_err)?);
        }
    }
    for ((f, _), &v) in sampled.iter().zip(&values[axes.len().min(values.len())..]) {
        let base = changed.as_ref().unwrap_or(spec);
        changed = Some(base.with_parameter(f.index(), v).map_err(vehicle_err)?);
    }
    Ok(match changed {
        None => PointModel::Variant(Cow::Borrowed(plant)),
        Some(s) => PointModel::Variant(Cow::Owned(AnyVehicleModel::new(&s).map_err(vehicle_err)?)),
    })
}

/// Simulates scenario `s` on `vehicle` in the paper's 4-state layout (θ and the guard do
/// not depend on ψ, x_H, y_H; [`simulate_in_paper_layout`]) to `horizon_s`: its metrics and
/// accepted steps.
#[doc(hidden)] // pub for tests/unit
pub fn simulate_point<'a>(
    vehicle: impl Into<VehicleForm<'a>>,
    s: &BaseScenario,
    horizon_s: f64,
) -> Result<(Metrics, usize), String> {
    let vehicle = vehicle.into();
    let (x0, _psi0) = s
        .initial
        .resolve(vehicle, &s.settings.solver)
        .map_err(|e| e.to_string())?;
    simulate_from(vehicle, s, horizon_s, x0)
}

/// [`simulate_point`] from the resolved start `x0` of its initial condition.
fn simulate_from<'a>(
    vehicle: impl Into<VehicleForm<'a>>,
    s: &BaseScenario,
    horizon_s: f64,
    x0: State4,
) -> Result<(Metrics, usize), String> {
    let vehicle = vehicle.into();
    let spec = SimSpec {
        early_stop: sway::sim::EarlyStop::Never,
        steering: Default::default(),
        action_s: s
            .action_s
            .unwrap_or_else(|| default_action_time(&s.speed, &s.controller)),
        profile: s.speed.clone(),
        controller: law_of(s)?,
        horizon_s,
        settings: s.settings,
    };
    let r = simulate_in_paper_layout::<4>(vehicle, &spec, x0, Recording::None)
        .map_err(|e| e.to_string())?;
    Ok((r.metrics, r.stats.accepted))
}

/// The law of a point's controller table (a predictor's `prediction_vehicle` loaded).
fn law_of(s: &BaseScenario) -> Result<Option<LoopLaw>, String> {
    s.controller.law().map_err(|e| e.to_string())
}

/// Runs every point in parallel on the current rayon pool; results in index order,
/// identical whatever the number of threads.
pub fn run_sweep(sweep: &Sweep, progress: &dyn Progress) -> Vec<PointResult> {
    let n = sweep.len();
    progress.start(&format!("sweep {}", sweep.cfg.name), n as u64);
    let out: Vec<PointResult> = (0..n)
        .into_par_iter()
        .map(|k| {
            let r = sweep.run_point(k);
            progress.advance(1);
            r
        })
        .collect();
    progress.finish();
    out
}
