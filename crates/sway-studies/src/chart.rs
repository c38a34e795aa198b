//! The computation of `chart_nonlinear`: the nonlinear chart of every delay of
//! `configs/chart_nonlinear.toml`, the linear chart behind its shading, the speeds of the
//! curves at the summary gains and the bistable width; the box, the seeds and the summary
//! gains derived from the vehicle where the config omits them
//! ([`sway::charts::auto_range`]). Also the `[chart]` table that `corners` and
//! `gain_design` share ([`ChartConfig`], the config form of
//! [`sway::bifurcation::chart::ChartOptions`]).

use serde::{Deserialize, Serialize};
use stability::{Axis, StabilityChart};
use sway::control::LoopModel;
use sway::parallel::{Split, join, map};
use sway_model::vehicle::Vehicle;

use sway::SwayError;
pub use sway::bifurcation::chart::ChartConfig;
use sway::bifurcation::chart::{
    ChartOptions, CurveEnd, EndedCurve, NonlinearChart, nonlinear_chart,
};
use sway::charts::auto_range::{Derivation, SpeedBounds, middle, summary_gains};
use sway::charts::fig4a_charts;

/// The shading grid (cells of the linear stability chart, exact unstable-root counts).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionGrid {
    /// cells along V
    pub speed_cells: usize,
    /// cells along D
    pub gain_cells: usize,
}

impl Default for RegionGrid {
    fn default() -> Self {
        Self {
            speed_cells: 140,
            gain_cells: 80,
        }
    }
}

fn default_delays() -> Vec<f64> {
    vec![0.0, 0.1, 0.2, 0.4]
}

/// `configs/chart_nonlinear.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChartNonlinearConfig {
    /// the delays τ \[s\], one panel each
    #[serde(default = "default_delays")]
    pub delays_s: Vec<f64>,
    /// gains of the `"curves"` entries of the summary \[s\] (omitted: 0, h, 2h, … below
    /// the box's top, h = (D_max − D_min)/8)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub summary_gains_s: Option<Vec<f64>>,
    /// gain of `"bistable_width_mps"` \[s\] (omitted: the middle of the box's gains)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bistable_gain_s: Option<f64>,
    /// the curves: box, seeds, steps, cycle mesh
    #[serde(default)]
    pub chart: ChartConfig,
    /// the shading grid
    #[serde(default)]
    pub regions: RegionGrid,
}

impl Default for ChartNonlinearConfig {
    fn default() -> Self {
        Self {
            delays_s: default_delays(),
            summary_gains_s: None,
            bistable_gain_s: None,
            chart: ChartConfig::default(),
            regions: RegionGrid::default(),
        }
    }
}

/// The settings in use: the chart options and the summary gains.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResolvedChart {
    /// the chart options (box, seeds, numerics)
    pub options: ChartOptions,
    /// the gains of `"curves"` \[s\]
    pub summary_gains_s: Vec<f64>,
    /// the gain of `"bistable_width_mps"` \[s\]
    pub bistable_gain_s: f64,
    /// the shading grid
    pub regions: RegionGrid,
    /// which keys were derived, and from what
    pub derivation: Derivation,
}

impl ChartNonlinearConfig {
    /// The settings with the omitted keys derived from the vehicle.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] from the derivation.
    pub fn resolve<M: LoopModel + ?Sized>(
        &self,
        model: &M,
        b: &SpeedBounds,
    ) -> Result<ResolvedChart, SwayError> {
        let (options, mut der) = self.chart.resolve(model, &self.delays_s, b, "chart.")?;
        let gains = (options.d_min_s, options.d_max_s);
        let summary_gains_s = self.summary_gains_s.clone().unwrap_or_else(|| {
            der.derived_keys.push("summary_gains_s".into());
            summary_gains(gains)
        });
        let bistable_gain_s = self.bistable_gain_s.unwrap_or_else(|| {
            der.derived_keys.push("bistable_gain_s".into());
            middle(gains)
        });
        Ok(ResolvedChart {
            options,
            summary_gains_s,
            bistable_gain_s,
            regions: self.regions,
            derivation: der,
        })
    }
}

/// The summary row of one gain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CurvesAtGain {
    /// gain D \[s\]
    pub d_s: f64,
    /// lowest Hopf speed \[m/s\]
    pub v_hopf_mps: Option<f64>,
    /// lowest fold-of-cycles speed \[m/s\]
    pub v_fold_mps: Option<f64>,
    /// why a speed is null (None: both found)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// Everything computed for one delay.
#[derive(Debug, Clone)]
pub struct DelayResult {
    /// the curves and codimension-two points
    pub chart: NonlinearChart,
    /// the linear stability chart of the shading grid (static boundary, regions)
    pub linear: StabilityChart,
    /// the speeds at the summary gains
    pub curves: Vec<CurvesAtGain>,
    /// V_hopf − V_fold at the bistable gain \[m/s\]
    pub bistable_width_mps: Option<f64>,
    /// why there is no bistable width (None: there is one)
    pub bistable_reason: Option<String>,
    /// the chart is all safe: straight running stable in every shading cell (None: not)
    pub safe_reason: Option<String>,
    /// the curves that ended early and the speeds that could not be read off them
    pub curves_ended_early: Vec<EndedCurve>,
}

/// The shading grid's axes: V from 0 to the box's top, D over the box.
pub fn grid_axes(r: &ResolvedChart) -> (Axis, Axis) {
    let c = &r.options;
    (
        Axis {
            min: 0.0,
            max: c.v_max_mps,
            count: r.regions.speed_cells,
        },
        Axis {
            min: c.d_min_s,
            max: c.d_max_s,
            count: r.regions.gain_cells,
        },
    )
}

/// The speeds of the curves at gain `d`, and the read-offs that failed (a speed that
/// cannot be corrected on its curve is null with the failure as its reason).
fn speeds_at<P: Vehicle<N>, const N: usize>(
    model: &P,
    chart: &NonlinearChart,
    d: f64,
) -> (CurvesAtGain, Vec<EndedCurve>) {
    let o = &chart.options;
    let mut failed = Vec::new();
    let mut why = Vec::new();
    let mut read = |what: &str, r: Result<Option<f64>, SwayError>| match r {
        Ok(v) => (v, true),
        Err(e) => {
            let end = CurveEnd::from_error(None, &e);
            why.push(format!(
                "the {what} at D = {d} s could not be corrected: {}",
                end.describe()
            ));
            failed.push(EndedCurve {
                curve: format!("{what} read off at D = {d} s"),
                end,
            });
            (None, false)
        }
    };
    let (v_hopf_mps, hopf_read) = read("Hopf speed", chart.hopf_speed_at(model, d));
    let (v_fold_mps, fold_read) = read("fold-of-cycles speed", chart.fold_speed_at(model, d));
    let range = format!("[{}, {}] m/s", o.v_min_mps, o.v_max_mps);
    if v_hopf_mps.is_none() && hopf_read {
        why.push(format!(
            "no Hopf curve crosses D = {d} s in {range} (straight running stable there up to the box's top)"
        ));
    }
    if v_fold_mps.is_none() && fold_read {
        why.push(match &chart.fold_reason {
            Some(r) => r.clone(),
            None if chart.fold_incomplete => format!(
                "the fold-of-cycles curve ended early and does not reach D = {d} s: unknown there"
            ),
            None => format!("the fold-of-cycles curve does not cross D = {d} s in {range}"),
        });
    }
    let at = CurvesAtGain {
        d_s: d,
        v_hopf_mps,
        v_fold_mps,
        reason: (!why.is_empty()).then(|| why.join("; ")),
    };
    (at, failed)
}

/// The whole computation of one delay (no I/O), on any plant (the paper's
/// [`trailer_model::Model`] or a model variant: the curves on its own closed loop, the
/// shading on its own linearisation).
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn compute_delay<P: Vehicle<N> + LoopModel, const N: usize>(
    model: &P,
    r: &ResolvedChart,
    tau: f64,
) -> Result<DelayResult, SwayError> {
    // the curves and the linear chart side by side, then the speeds at every summary gain
    // and at the bistable gain (the last entry) in parallel; each piece is deterministic
    let (chart, linear) = join(&|| nonlinear_chart(model, tau, &r.options), &|| {
        linear_chart(model, r, tau)
    });
    // a chart that cannot be computed is a result (no curves, its cells unknown)
    let (chart, linear) = (
        chart.unwrap_or_else(|e| NonlinearChart::not_computed(tau, &r.options, &e)),
        linear?,
    );
    let gains: Vec<f64> = r
        .summary_gains_s
        .iter()
        .chain([&r.bistable_gain_s])
        .copied()
        .collect();
    let read = map(&gains, Split::Adaptive, &|_, &d| {
        speeds_at(model, &chart, d)
    });
    let mut curves_ended_early = chart.curves_ended_early.clone();
    let mut curves = Vec::with_capacity(read.len());
    for (at, failed) in read {
        curves.push(at);
        curves_ended_early.extend(failed);
    }
    let at = curves.pop().ok_or_else(|| {
        SwayError::numerical(
            format!("speeds at D = {} s, τ = {tau} s", r.bistable_gain_s),
            continuation::Error::InvalidInput("no speeds returned".into()),
        )
    })?;
    let bistable_width_mps = match (at.v_hopf_mps, at.v_fold_mps) {
        (Some(h), Some(f)) => Some(h - f),
        _ => None,
    };
    let bistable_reason = bistable_width_mps.is_none().then(|| {
        format!(
            "no bistable band at D = {} s: {}",
            r.bistable_gain_s,
            at.reason.clone().unwrap_or_default()
        )
    });
    let safe_reason = linear.cells.iter().all(|c| c.is_stable()).then(|| {
        format!(
            "straight running is stable in every cell of the chart (V up to {} m/s, D in [{}, {}] s): no self-excited sway",
            r.options.v_max_mps, r.options.d_min_s, r.options.d_max_s
        )
    });
    Ok(DelayResult {
        chart,
        linear,
        curves,
        bistable_width_mps,
        bistable_reason,
        safe_reason,
        curves_ended_early,
    })
}

/// fig4a's linear chart of delay τ on the shading grid (exact counts of unstable roots).
fn linear_chart<M: LoopModel + ?Sized>(
    model: &M,
    r: &ResolvedChart,
    tau: f64,
) -> Result<StabilityChart, SwayError> {
    let (sa, ga) = grid_axes(r);
    fig4a_charts(model, &[tau], sa, ga, &stability::ChartOptions::default())?
        .into_iter()
        .next()
        .ok_or_else(|| {
            SwayError::numerical(
                format!("linear chart τ = {tau} s"),
                continuation::Error::InvalidInput("no chart returned".into()),
            )
        })
}

/// The settings and every delay's result.
#[derive(Debug, Clone)]
pub struct ChartStudy {
    /// the settings in use
    pub resolved: ResolvedChart,
    /// one result per delay, in the config's order
    pub delays: Vec<DelayResult>,
}

/// All delays of the config, in its order (parallel over delays; each is deterministic),
/// after resolving the settings ([`ChartNonlinearConfig::resolve`]).
///
/// # Errors
/// The first failing delay's error (in config order).
pub fn compute<P: Vehicle<N> + LoopModel, const N: usize>(
    model: &P,
    cfg: &ChartNonlinearConfig,
    b: &SpeedBounds,
    progress: &dyn sway::progress::Progress,
) -> Result<ChartStudy, SwayError> {
    let resolved = cfg.resolve(model, b)?;
    let delays = compute_resolved(model, &resolved, &cfg.delays_s, progress)?;
    Ok(ChartStudy { resolved, delays })
}

/// [`compute_delay`] for every delay of `delays` \[s\] (parallel, results in its order).
///
/// # Errors
/// The first failing delay's error.
pub fn compute_resolved<P: Vehicle<N> + LoopModel, const N: usize>(
    model: &P,
    r: &ResolvedChart,
    delays: &[f64],
    progress: &dyn sway::progress::Progress,
) -> Result<Vec<DelayResult>, SwayError> {
    // the longest delays first (their collocation factors fill most, so they cost most):
    // rayon then starts them on separate threads instead of last; results in config order
    let order = longest_first(delays);
    let mut results: Vec<(usize, Result<DelayResult, SwayError>)> =
        map(&order, Split::Adaptive, &|_, &i| {
            let res = compute_delay(model, r, delays[i]);
            progress.advance(1);
            (i, res)
        });
    // a `fn` item, not a closure: the sort is compiled once, not once per plant
    fn config_index(r: &(usize, Result<DelayResult, SwayError>)) -> usize {
        r.0
    }
    results.sort_by_key(config_index);
    results.into_iter().map(|(_, res)| res).collect()
}

/// The indices of `delays`, longest delay first (ties in config order).
fn longest_first(delays: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..delays.len()).collect();
    order.sort_by(|&a, &b| delays[b].total_cmp(&delays[a]));
    order
}
