//! The computation of `fig4a` (paper Fig. 4(a)): the stability charts of the delayed
//! yaw-rate feedback in the (V, D) plane for several delays, their headline numbers, and the
//! axes derived from the vehicle where `configs/fig4a.toml` omits them
//! ([`sway::charts::auto_range`]).

use serde::{Deserialize, Serialize};
use stability::{Axis, ChartOptions, StabilityChart};
use sway::control::LoopModel;

use sway::SwayError;
use sway::charts::auto_range::{
    Derivation, SpeedBounds, VehicleScale, chart_gains, critical_speed_extent, speed_top,
    summary_speed, vehicle_scale,
};
use sway::charts::{critical_speed_at_gain, fig4a_charts, stable_gain_intervals};

/// Speed axis \[m/s\]; an omitted end is derived from the vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedAxis {
    /// lower edge \[m/s\] (omitted: 0)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_mps: Option<f64>,
    /// upper edge \[m/s\] (omitted: the largest critical speed over the chart's gains and
    /// delays + 5 %, rounded up to 5 m/s, at most the maximum speed)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_mps: Option<f64>,
    /// number of cells
    pub cells: usize,
}

/// Gain axis \[s\]; an omitted end is derived from the vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainAxis {
    /// lower edge \[s\] (omitted: −5·D₁)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_s: Option<f64>,
    /// upper edge \[s\] (omitted: 5·D₁)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_s: Option<f64>,
    /// number of cells
    pub cells: usize,
}

/// Where the headline numbers are taken.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SummaryConfig {
    /// gain of `v_crit_at_d_<D>_mps` \[s\] (omitted: D₁)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gain_for_critical_speed_s: Option<f64>,
    /// speed of `stable_d_interval_at_v_<V>` \[m/s\] (omitted: the first whole m/s above
    /// the open-loop V_crit)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_for_gain_interval_mps: Option<f64>,
    /// bisection tolerance of the critical speed \[m/s\]
    pub speed_tolerance_mps: f64,
}

impl Default for SummaryConfig {
    fn default() -> Self {
        Self {
            gain_for_critical_speed_s: None,
            speed_for_gain_interval_mps: None,
            speed_tolerance_mps: 1e-9,
        }
    }
}

/// Numerical settings of the charts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NumericsConfig {
    /// fresh spectral seed every this many cells along D
    pub reseed_interval: usize,
    /// rightmost roots followed from cell to cell
    pub tracked_roots: usize,
}

impl Default for NumericsConfig {
    fn default() -> Self {
        let o = ChartOptions::default();
        Self {
            reseed_interval: o.reseed_interval,
            tracked_roots: o.tracked_roots,
        }
    }
}

/// `configs/fig4a.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fig4aConfig {
    /// speed axis
    pub speed: SpeedAxis,
    /// gain axis
    pub gain: GainAxis,
    /// delays τ \[s\], one panel each
    pub delays_s: Vec<f64>,
    /// headline numbers
    #[serde(default)]
    pub summary: SummaryConfig,
    /// numerics
    #[serde(default)]
    pub numerics: NumericsConfig,
    /// the controller whose gain D is the chart's axis (omitted: the paper's yaw-rate
    /// steering, [`sway::charts::ChartControllerTable`])
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller: Option<sway::charts::ChartControllerTable>,
}

impl Fig4aConfig {
    /// Chart options.
    pub fn chart_options(&self) -> ChartOptions {
        ChartOptions {
            reseed_interval: self.numerics.reseed_interval,
            tracked_roots: self.numerics.tracked_roots,
            ..ChartOptions::default()
        }
    }
}

/// A resolved axis (the config's numbers or the derived ones).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisRange {
    /// lower edge
    pub min: f64,
    /// upper edge
    pub max: f64,
    /// cells
    pub cells: usize,
}

impl AxisRange {
    /// As the [`stability`] crate's axis.
    pub fn axis(&self) -> Axis {
        Axis {
            min: self.min,
            max: self.max,
            count: self.cells,
        }
    }
}

/// The axes and summary settings in use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fig4aRanges {
    /// speed axis \[m/s\]
    pub speed_mps: AxisRange,
    /// gain axis \[s\]
    pub gain_s: AxisRange,
    /// the gain of `v_crit_at_d_<D>_mps` \[s\]
    pub gain_for_critical_speed_s: f64,
    /// the speed of `stable_d_interval_at_v_<V>` \[m/s\]
    pub speed_for_gain_interval_mps: f64,
    /// which keys were derived, and from what
    pub derivation: Derivation,
}

/// The config's axes and summary settings with the omitted ones derived from the vehicle
/// ([`sway::charts::auto_range`]).
///
/// # Errors
/// [`SwayError::Numerical`] from the derivation.
pub fn resolve<M: LoopModel + ?Sized>(
    model: &M,
    cfg: &Fig4aConfig,
    b: &SpeedBounds,
) -> Result<Fig4aRanges, SwayError> {
    let mut der = Derivation::default();
    let needs_scale = cfg.gain.min_s.is_none()
        || cfg.gain.max_s.is_none()
        || cfg.summary.gain_for_critical_speed_s.is_none()
        || cfg.summary.speed_for_gain_interval_mps.is_none();
    let scale: Option<VehicleScale> = if needs_scale {
        Some(vehicle_scale(model, b)?)
    } else {
        None
    };
    der.scale = scale;
    let mut pick = |given: Option<f64>, key: &str, derived: &dyn Fn(&VehicleScale) -> f64| match (
        given, scale,
    ) {
        (Some(x), _) => x,
        (None, Some(s)) => {
            der.derived_keys.push(key.into());
            derived(&s)
        }
        // unreachable: the scale is computed whenever a key is missing
        (None, None) => f64::NAN,
    };
    let g = cfg.gain;
    let gain = AxisRange {
        min: pick(g.min_s, "gain.min_s", &|s| chart_gains(s).0),
        max: pick(g.max_s, "gain.max_s", &|s| chart_gains(s).1),
        cells: g.cells,
    };
    let d_summary = pick(
        cfg.summary.gain_for_critical_speed_s,
        "summary.gain_for_critical_speed_s",
        &|s| s.reference_gain_s,
    );
    let v_summary = pick(
        cfg.summary.speed_for_gain_interval_mps,
        "summary.speed_for_gain_interval_mps",
        &|s| summary_speed(s, b),
    );
    let v_min = cfg.speed.min_mps.unwrap_or_else(|| {
        der.derived_keys.push("speed.min_mps".into());
        0.0
    });
    let v_max = match cfg.speed.max_mps {
        Some(v) => v,
        None => {
            der.derived_keys.push("speed.max_mps".into());
            let e = critical_speed_extent(model, &cfg.delays_s, (gain.min, gain.max), b)?;
            der.extent = Some(e);
            speed_top(&e, b, v_min)
        }
    };
    Ok(Fig4aRanges {
        speed_mps: AxisRange {
            min: v_min,
            max: v_max,
            cells: cfg.speed.cells,
        },
        gain_s: gain,
        gain_for_critical_speed_s: d_summary,
        speed_for_gain_interval_mps: v_summary,
        derivation: der,
    })
}

/// Headline numbers of one chart.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChartSummary {
    /// delay \[s\]
    pub delay_s: f64,
    /// lowest speed at which the summary gain is unstable \[m/s\] (None: stable on the
    /// whole speed axis, see `reason`)
    pub v_crit_at_gain_mps: Option<f64>,
    /// stable gain intervals at the summary speed \[s\]
    pub stable_gain_intervals: Vec<(f64, f64)>,
    /// why a number is missing or what the chart shows as a whole (None: nothing to say)
    pub reason: Option<String>,
}

/// Everything `fig4a` computes.
#[derive(Debug, Clone)]
pub struct Fig4a {
    /// the axes and summary settings used
    pub ranges: Fig4aRanges,
    /// one chart per delay, in the config's order
    pub charts: Vec<StabilityChart>,
    /// their headline numbers
    pub summaries: Vec<ChartSummary>,
}

/// The reason line of one chart: stable at the summary gain up to the axis top, no
/// stabilising gain at the summary speed, a chart without unstable cells.
fn chart_reason(
    ch: &StabilityChart,
    s: &ChartSummary,
    r: &Fig4aRanges,
    b: &SpeedBounds,
) -> Option<String> {
    let mut parts = Vec::new();
    let top = r.speed_mps.max;
    let limit = if top >= b.max_mps {
        " (the maximum speed, --max-speed)"
    } else {
        " (the top of the speed axis)"
    };
    if ch.cells.iter().all(|c| c.is_stable()) {
        parts.push(format!(
            "straight running is stable in every cell of the chart (V up to {top} m/s{limit}, D in [{}, {}] s): all safe",
            r.gain_s.min, r.gain_s.max
        ));
    } else if s.v_crit_at_gain_mps.is_none() {
        parts.push(format!(
            "D = {} s keeps straight running stable at every speed up to {top} m/s{limit}",
            r.gain_for_critical_speed_s
        ));
    }
    if s.stable_gain_intervals.is_empty() {
        parts.push(format!(
            "no gain in [{}, {}] s stabilises straight running at V = {} m/s",
            r.gain_s.min, r.gain_s.max, r.speed_for_gain_interval_mps
        ));
    }
    (!parts.is_empty()).then(|| parts.join("; "))
}

/// Computes the charts and the headline numbers (no I/O): the whole Fig. 4(a)
/// computation, also used by the benchmark.
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn compute<M: LoopModel + ?Sized>(
    model: &M,
    cfg: &Fig4aConfig,
    b: &SpeedBounds,
) -> Result<Fig4a, SwayError> {
    match cfg.controller {
        Some(c) if !c.is_paper() => {
            c.check().map_err(|m| {
                SwayError::numerical(
                    "the controller of the chart",
                    continuation::Error::InvalidInput(m),
                )
            })?;
            compute_loop(
                &sway::charts::Controlled {
                    model,
                    law: c.law(),
                },
                cfg,
                b,
            )
        }
        _ => compute_loop(model, cfg, b),
    }
}

fn compute_loop<M: LoopModel + ?Sized>(
    model: &M,
    cfg: &Fig4aConfig,
    b: &SpeedBounds,
) -> Result<Fig4a, SwayError> {
    let ranges = resolve(model, cfg, b)?;
    let (sa, ga) = (ranges.speed_mps.axis(), ranges.gain_s.axis());
    let charts = fig4a_charts(model, &cfg.delays_s, sa, ga, &cfg.chart_options())?;
    let v_lo = sa.values()[0];
    let mut summaries = Vec::new();
    for (&tau, ch) in cfg.delays_s.iter().zip(&charts) {
        let v_crit = critical_speed_at_gain(
            model,
            tau,
            ranges.gain_for_critical_speed_s,
            v_lo,
            sa.max,
            sa.count,
            cfg.summary.speed_tolerance_mps,
        )?;
        let intervals = stable_gain_intervals(
            model,
            tau,
            ranges.speed_for_gain_interval_mps,
            ga.min,
            ga.max,
        )?;
        let mut s = ChartSummary {
            delay_s: tau,
            v_crit_at_gain_mps: v_crit,
            stable_gain_intervals: intervals,
            reason: None,
        };
        s.reason = chart_reason(ch, &s, &ranges, b);
        summaries.push(s);
    }
    Ok(Fig4a {
        ranges,
        charts,
        summaries,
    })
}
