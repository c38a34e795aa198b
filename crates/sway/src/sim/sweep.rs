//! Parallel sweeps: a grid of simulations over any of V, θ(0), D, τ and the braking time T,
//! run with rayon. Each point is independent; results are collected in grid order, so the
//! numbers do not depend on the number of threads. A failing point is reported in its row
//! and the sweep goes on.

use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use trailer_model::{Model, State4};

use super::run::{Metrics, Recording, RunSettings, SimSpec, simulate};
use super::scenario::{
    InitialCondition, default_action_time, ensure_name, validate_parts, with_run_fields,
};
use super::{Controller, SpeedProfile};
use crate::SwayError;
use crate::config::{Positive, ensure};
use crate::progress::Progress;

/// A swept quantity.
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

/// One axis of the grid: `points` uniformly spaced values from `min` to `max`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// what is swept
    pub parameter: SweepParameter,
    /// first value
    pub min: f64,
    /// last value
    pub max: f64,
    /// number of values (≥ 1; 1 gives `min`)
    pub points: usize,
}

impl Axis {
    /// The values.
    pub fn values(&self) -> Vec<f64> {
        if self.points <= 1 {
            return vec![self.min];
        }
        (0..self.points)
            .map(|i| {
                if i + 1 == self.points {
                    self.max
                } else {
                    self.min + (self.max - self.min) * i as f64 / (self.points - 1) as f64
                }
            })
            .collect()
    }
}

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

/// A sweep file (see `configs/sweep_threshold.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepConfig {
    /// results go to `results/<name>/`
    pub name: String,
    /// the grid axes (1 or more; the first two span the heat map)
    pub axes: Vec<Axis>,
    /// the scenario that is varied
    pub base: BaseScenario,
}

/// Result of one grid point (serialisable: shards carry it, exactly, through JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointResult {
    /// the axis values of this point, in axis order
    pub values: Vec<f64>,
    /// metrics, or the error message of a failed run
    pub metrics: Result<Metrics, String>,
    /// accepted steps of the run (0 on failure)
    pub steps: usize,
}

impl SweepConfig {
    /// Checks every key, including that each axis can act on the base scenario.
    ///
    /// # Errors
    /// [`SwayError::Config`] naming the file and key.
    pub fn validate(&self, file: &Path) -> Result<(), SwayError> {
        ensure_name(file, &self.name, "a name of letters, digits, '_' or '-'")?;
        ensure(!self.axes.is_empty(), file, "axes", || {
            "expected at least one axis".into()
        })?;
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
            let key = format!("axes[{i}]");
            ensure(
                a.min.is_finite() && a.max.is_finite() && a.min <= a.max,
                file,
                &key,
                || format!("expected finite min <= max, got {} and {}", a.min, a.max),
            )?;
            ensure(
                a.points >= 1 && a.points <= 1_000_000,
                file,
                &format!("{key}.points"),
                || format!("expected 1 to 1e6 points, got {}", a.points),
            )?;
            if self.axes[..i].iter().any(|o| o.parameter == a.parameter) {
                return Err(SwayError::config(
                    file,
                    format!("{key}.parameter"),
                    "each parameter may be swept once",
                ));
            }
            // apply both ends to the base and validate the result
            for v in [a.min, a.max] {
                let p = apply(b, a.parameter, v)
                    .map_err(|m| SwayError::config(file, format!("{key}.parameter"), m))?;
                validate_parts(file, &key, &p.speed, &p.controller, &p.initial, &p.settings)?;
            }
        }
        if let Some(a) = b.action_s {
            ensure(
                a.is_finite() && a >= 0.0 && a <= b.horizon_s.get(),
                file,
                "base.action_s",
                || format!("expected 0 <= action_s <= horizon_s, got {a}"),
            )?;
        }
        Ok(())
    }

    /// The number of grid points.
    pub fn len(&self) -> usize {
        self.axes.iter().map(|a| a.points.max(1)).product()
    }

    /// True for a grid without points (never after validation).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The axis values of point `k` (first axis fastest).
    pub fn point(&self, mut k: usize) -> Vec<f64> {
        self.axes
            .iter()
            .map(|a| {
                let n = a.points.max(1);
                let v = a.values()[k % n];
                k /= n;
                v
            })
            .collect()
    }
}

/// The base scenario with one parameter set.
fn apply(base: &BaseScenario, p: SweepParameter, v: f64) -> Result<BaseScenario, String> {
    let mut s = base.clone();
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
            Controller::YawRateFeedback {
                gain_s, delay_s, ..
            } => {
                if p == SweepParameter::GainS {
                    *gain_s = v;
                } else {
                    *delay_s = v;
                }
            }
            Controller::None => {
                return Err(format!(
                    "{} needs a yaw_rate_feedback controller in [base.controller]",
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
    Ok(s)
}

/// Runs one grid point (4-state model: θ and the guard do not depend on ψ, x_H, y_H).
pub fn run_point(model: &Model, cfg: &SweepConfig, k: usize) -> PointResult {
    let values = cfg.point(k);
    let run = || -> Result<(Metrics, usize), String> {
        let mut s = cfg.base.clone();
        for (a, &v) in cfg.axes.iter().zip(&values) {
            s = apply(&s, a.parameter, v)?;
        }
        let (x0, _psi0) = s
            .initial
            .resolve(model, &s.settings.solver)
            .map_err(|e| e.to_string())?;
        let spec = SimSpec {
            action_s: s
                .action_s
                .unwrap_or_else(|| default_action_time(&s.speed, &s.controller)),
            profile: s.speed,
            controller: s.controller,
            horizon_s: s.horizon_s.get(),
            settings: s.settings,
        };
        let r = simulate::<4>(model, &spec, State4::from(x0), Recording::None)
            .map_err(|e| e.to_string())?;
        Ok((r.metrics, r.stats.accepted))
    };
    match run() {
        Ok((m, steps)) => PointResult {
            values,
            metrics: Ok(m),
            steps,
        },
        Err(e) => PointResult {
            values,
            metrics: Err(e),
            steps: 0,
        },
    }
}

/// Runs the whole grid in parallel on the current rayon pool; results in grid order
/// (first axis fastest), identical whatever the number of threads.
pub fn run_sweep(model: &Model, cfg: &SweepConfig, progress: &dyn Progress) -> Vec<PointResult> {
    let n = cfg.len();
    progress.start(&format!("sweep {}", cfg.name), n as u64);
    let out: Vec<PointResult> = (0..n)
        .into_par_iter()
        .map(|k| {
            let r = run_point(model, cfg, k);
            progress.advance(1);
            r
        })
        .collect();
    progress.finish();
    out
}
