//! The computation of `corners`: [`sway::bifurcation::corners::corner_study`] for every delay of
//! `configs/corners.toml`, with the nonlinear chart's box and seeds and the
//! `beyond_gain_s` scan derived from the vehicle where the config omits them
//! ([`sway::charts::auto_range`]); a delay without a double-Hopf point in the box is an
//! outcome with its reason, not an error.

use serde::{Deserialize, Serialize};
use sway::parallel::{Split, try_map};

use crate::chart::ChartConfig;
use sway::SwayError;
use sway::bifurcation::chart::ChartOptions;
use sway::bifurcation::corners::{CornerOptions, CornerStudy, corner_study};
use sway::charts::auto_range::{Derivation, SpeedBounds, chart_gains, vehicle_scale};
use sway::control::LoopModel;
use sway::sim::SimulateOwn;

fn default_delays() -> Vec<f64> {
    vec![0.2, 0.4]
}

/// `configs/corners.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CornersConfig {
    /// the delays τ \[s\]
    #[serde(default = "default_delays")]
    pub delays_s: Vec<f64>,
    /// the nonlinear chart: its (V, D) box is the range searched for double-Hopf points
    #[serde(default)]
    pub chart: ChartConfig,
    /// the corner analysis: scan, zoom window, probes, simulations, classifier
    #[serde(default)]
    pub corners: CornerOptions,
}

/// The settings in use.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResolvedCorners {
    /// the nonlinear chart (box, seeds)
    pub chart: ChartOptions,
    /// the corner analysis (with `beyond_gain_s` resolved)
    pub corners: CornerOptions,
    /// which keys were derived, and from what
    pub derivation: Derivation,
}

/// What one delay gave.
#[derive(Debug, Clone)]
pub struct DelayCorners {
    /// the study
    pub study: CornerStudy,
    /// why there is nothing near a corner (None: at least one double-Hopf point)
    pub reason: Option<String>,
}

/// Everything `corners` computes.
#[derive(Debug, Clone)]
pub struct Corners {
    /// the settings in use
    pub resolved: ResolvedCorners,
    /// one entry per delay, in the config's order
    pub delays: Vec<DelayCorners>,
}

impl CornersConfig {
    /// The settings with the omitted keys derived from the vehicle.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] from the derivation.
    pub fn resolve<L: LoopModel + ?Sized>(
        &self,
        model: &L,
        b: &SpeedBounds,
    ) -> Result<ResolvedCorners, SwayError> {
        let (chart, mut der) = self.chart.resolve(model, &self.delays_s, b, "chart.")?;
        let mut corners = self.corners.clone();
        if corners.beyond_gain_s.is_none() {
            let s = match der.scale {
                Some(s) => s,
                None => vehicle_scale(model, b)?,
            };
            der.scale = Some(s);
            der.derived_keys.push("corners.beyond_gain_s".into());
            corners.beyond_gain_s = Some(chart_gains(&s).1);
        }
        Ok(ResolvedCorners {
            chart,
            corners,
            derivation: der,
        })
    }
}

/// All delays (in parallel, results in config order; each delay is deterministic), for any
/// plant (the paper's model or a vehicle with model variants).
///
/// # Errors
/// The first failing delay's error.
pub fn compute<P: SimulateOwn<N> + LoopModel, const N: usize>(
    model: &P,
    cfg: &CornersConfig,
    b: &SpeedBounds,
) -> Result<Corners, SwayError> {
    let resolved = cfg.resolve(model, b)?;
    let (c, o) = (&resolved.chart, &resolved.corners);
    let delays = try_map(&cfg.delays_s, Split::Adaptive, &|_, &tau| {
        let study = corner_study(model, tau, c, o)?;
        let reason = study.corners.is_empty().then(|| {
            format!(
                "no double-Hopf corner in the box (V in [{}, {}] m/s, D in [{}, {}] s) at τ = {tau} s: no zoom, probes or torus curves",
                c.v_min_mps, c.v_max_mps, c.d_min_s, c.d_max_s
            )
        });
        Ok::<_, SwayError>(DelayCorners { study, reason })
    })?;
    Ok(Corners { resolved, delays })
}
