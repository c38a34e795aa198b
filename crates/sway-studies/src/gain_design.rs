//! The computation of `gain_design`: the linear optima of a τ grid, the
//! nonlinear part at every few delays, the delay budget, with the gain range, the speed
//! range and the fold-of-cycles chart's box and seed derived from the vehicle where
//! `configs/gain_design.toml` omits them ([`sway::charts::auto_range`]); the physical
//! outcomes (stable up to the maximum speed, no gain that helps, no budget) carry reasons.

use serde::{Deserialize, Serialize};
use sway::parallel::{Split, join, map, try_map};
use trailer_model::Model;

use sway::control::LoopModel;

use crate::chart::ChartConfig;
use sway::SwayError;
use sway::bifurcation::DiagramOptions;
use sway::bifurcation::chart::ChartOptions;
use sway::charts::auto_range::{
    BoxKeys, Derivation, SpeedBounds, design_gains, middle, nonlinear_box, vehicle_scale,
};
use sway::config::Grid;
use sway::gain_design::{
    DelayBudget, FoldResult, GainSearch, LinearOptimum, critical_speed, delay_budget, fold_optimum,
    linear_optimum, open_loop_fold_speed,
};
use sway::ranging::{MAX_SPEED, stable_up_to_reason};

/// The search's keys: [`GainSearch`] with the gain and speed ranges optional.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GainSearchConfig {
    /// lower end of the gain range \[s\] (omitted: 0)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub d_min_s: Option<f64>,
    /// upper end \[s\] (omitted: 5·D₁)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub d_max_s: Option<f64>,
    /// see [`GainSearch::gain_samples`]
    pub gain_samples: usize,
    /// lower end of the speed range \[m/s\] (omitted: the minimum speed)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_min_mps: Option<f64>,
    /// upper end \[m/s\] (omitted: the maximum speed, `--max-speed`)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v_max_mps: Option<f64>,
    /// see [`GainSearch::speed_samples`]
    pub speed_samples: usize,
    /// see [`GainSearch::speed_tolerance_mps`]
    pub speed_tolerance_mps: f64,
    /// see [`GainSearch::gain_tolerance_s`]
    pub gain_tolerance_s: f64,
    /// see [`GainSearch::band_fraction`]
    pub band_fraction: f64,
    /// see [`GainSearch::max_iterations`]
    pub max_iterations: u64,
}

impl Default for GainSearchConfig {
    fn default() -> Self {
        let o = GainSearch::default();
        Self {
            d_min_s: None,
            d_max_s: None,
            gain_samples: o.gain_samples,
            v_min_mps: None,
            v_max_mps: None,
            speed_samples: o.speed_samples,
            speed_tolerance_mps: o.speed_tolerance_mps,
            gain_tolerance_s: o.gain_tolerance_s,
            band_fraction: o.band_fraction,
            max_iterations: o.max_iterations,
        }
    }
}

/// The delay budget's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BudgetConfig {
    /// the required rise of the critical speed over the open loop (0.1: 10 %)
    pub rise_fraction: f64,
    /// bisection tolerance in τ \[s\]
    pub tau_tolerance_s: f64,
}

impl Default for BudgetConfig {
    fn default() -> Self {
        Self {
            rise_fraction: 0.1,
            tau_tolerance_s: 1e-5,
        }
    }
}

/// The nonlinear part's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NonlinearConfig {
    /// the fold-of-cycles optimum at every `every`-th delay of the grid, the first one
    /// included (0: none)
    pub every: usize,
    /// the fold-of-cycles curve: its speed range (omitted: that of `chart_nonlinear`'s
    /// derived box at the nonlinear delays), seed gain (the first of `seed_gains_s`;
    /// omitted: the middle of that box's gains, D₁), steps and cycle mesh; its gain range
    /// is the search's
    pub chart: ChartConfig,
}

/// The chart settings of the gain design: those of `chart_nonlinear` with a coarser cycle
/// mesh (L = 20: fold speeds within 0.01 m/s of L = 40 at τ = 0.2 s, 3× faster) and longer
/// fold steps; box and seed derived.
pub fn default_chart() -> ChartConfig {
    let o = ChartOptions {
        fold_max_step: 4.0,
        cycles: DiagramOptions {
            intervals: 20,
            max_step: 0.5,
            ..DiagramOptions::default()
        },
        ..ChartOptions::default()
    };
    ChartConfig::from_options(&o, false)
}

impl Default for NonlinearConfig {
    fn default() -> Self {
        Self {
            every: 10,
            chart: default_chart(),
        }
    }
}

fn default_delays() -> Grid {
    Grid {
        min: 0.0,
        max: 0.5,
        points: 51,
    }
}

fn default_headline_delays() -> Vec<f64> {
    vec![0.1, 0.2, 0.4]
}

/// `configs/gain_design.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainDesignConfig {
    /// the delays τ \[s\]
    #[serde(default = "default_delays")]
    pub delays_s: Grid,
    /// delays whose optimum is printed as a headline line \[s\] (the nearest grid delay)
    #[serde(default = "default_headline_delays")]
    pub headline_delays_s: Vec<f64>,
    /// the search for the best gain at one delay
    #[serde(default)]
    pub search: GainSearchConfig,
    /// the delay budget
    #[serde(default)]
    pub budget: BudgetConfig,
    /// the fold-of-cycles optimum
    #[serde(default)]
    pub nonlinear: NonlinearConfig,
}

impl GainDesignConfig {
    /// The delays of the grid \[s\].
    pub fn delays(&self) -> Vec<f64> {
        self.delays_s.values()
    }

    /// Whether the nonlinear part runs at grid index `i`.
    pub fn is_nonlinear(&self, i: usize) -> bool {
        self.nonlinear.every > 0 && i.is_multiple_of(self.nonlinear.every)
    }

    /// The cap of the critical-speed search as a reason names it: `search.v_max_mps` where
    /// the config gives it, else the maximum speed (`--max-speed`) it is derived from.
    pub fn cap_name(&self) -> &'static str {
        match self.search.v_max_mps {
            Some(_) => "the speed cap, search.v_max_mps",
            None => MAX_SPEED,
        }
    }

    /// The settings with the omitted keys derived from the vehicle.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] from the derivation.
    pub fn resolve<M: LoopModel + ?Sized>(
        &self,
        model: &M,
        b: &SpeedBounds,
    ) -> Result<ResolvedDesign, SwayError> {
        let s = &self.search;
        let mut der = Derivation::default();
        if s.d_min_s.is_none() || s.d_max_s.is_none() {
            der.scale = Some(vehicle_scale(model, b)?);
        }
        let gains = der.scale.map(|sc| design_gains(&sc));
        let mut take = |given: Option<f64>, key: &str, derived: Option<f64>| match given {
            Some(x) => x,
            None => {
                der.derived_keys.push(format!("search.{key}"));
                derived.unwrap_or(f64::NAN)
            }
        };
        let search = GainSearch {
            d_min_s: take(s.d_min_s, "d_min_s", gains.map(|g| g.0)),
            d_max_s: take(s.d_max_s, "d_max_s", gains.map(|g| g.1)),
            gain_samples: s.gain_samples,
            v_min_mps: take(s.v_min_mps, "v_min_mps", Some(b.min_mps)),
            v_max_mps: take(s.v_max_mps, "v_max_mps", Some(b.max_mps)),
            speed_samples: s.speed_samples,
            speed_tolerance_mps: s.speed_tolerance_mps,
            gain_tolerance_s: s.gain_tolerance_s,
            band_fraction: s.band_fraction,
            max_iterations: s.max_iterations,
        };
        let c = &self.nonlinear.chart;
        let delays = self.nonlinear_delays();
        let chart = if delays.is_empty() {
            c.options(
                &sway::charts::auto_range::SpeedGainBox {
                    v_min_mps: c.v_min_mps.unwrap_or(b.min_mps),
                    v_max_mps: c.v_max_mps.unwrap_or(b.max_mps),
                    d_min_s: search.d_min_s,
                    d_max_s: search.d_max_s,
                },
                c.seed_gains_s
                    .clone()
                    .unwrap_or_else(|| vec![middle((search.d_min_s, search.d_max_s))]),
            )
        } else {
            // the speed range of chart_nonlinear's box at the nonlinear delays; the gain range
            // is replaced by the search's ([`sway::gain_design::fold_chart_options`])
            let keys = BoxKeys {
                v_min_mps: c.v_min_mps,
                v_max_mps: c.v_max_mps,
                d_min_s: None,
                d_max_s: None,
            };
            let (bx, d2) = nonlinear_box(model, &keys, &delays, b, "nonlinear.chart.")?;
            der.derived_keys
                .extend(d2.derived_keys.into_iter().filter(|k| k.contains("v_m")));
            der.scale = der.scale.or(d2.scale);
            der.extent = d2.extent;
            let seeds = match &c.seed_gains_s {
                Some(s) => s.clone(),
                None => {
                    der.derived_keys.push("nonlinear.chart.seed_gains_s".into());
                    vec![middle((bx.d_min_s, bx.d_max_s))]
                }
            };
            c.options(&bx, seeds)
        };
        Ok(ResolvedDesign {
            search,
            chart,
            derivation: der,
        })
    }

    /// The delays of the nonlinear part \[s\].
    pub fn nonlinear_delays(&self) -> Vec<f64> {
        let d = self.delays();
        (0..d.len())
            .filter(|&i| self.is_nonlinear(i))
            .map(|i| d[i])
            .collect()
    }
}

/// The settings in use.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResolvedDesign {
    /// the search (gain and speed ranges resolved)
    pub search: GainSearch,
    /// the fold-of-cycles chart (box and seed resolved)
    pub chart: ChartOptions,
    /// which keys were derived, and from what
    pub derivation: Derivation,
}

/// Everything computed (no I/O).
#[derive(Debug, Clone)]
pub struct GainDesign {
    /// the settings in use
    pub resolved: ResolvedDesign,
    /// the delays \[s\]
    pub delays_s: Vec<f64>,
    /// the linear optimum of each delay
    pub linear: Vec<LinearOptimum>,
    /// why the optimum of each delay is special (stable up to the maximum speed; no gain
    /// raises the critical speed) — None: nothing to say
    pub linear_reasons: Vec<Option<String>>,
    /// the nonlinear part of each delay (None where it was not computed)
    pub fold: Vec<Option<FoldResult>>,
    /// the delay budget
    pub budget: DelayBudget,
    /// why there is no delay budget (None: there is one)
    pub budget_reason: Option<String>,
    /// the open loop is stable up to the top of the speed range (its V_crit is then that top)
    pub open_loop_stable: bool,
    /// V_fold(D = 0) \[m/s\] (None: no fold in the speed range, or the nonlinear part is off)
    pub open_loop_v_fold_mps: Option<f64>,
    /// why the nonlinear part was left out although the config asks for it (None: it ran
    /// where asked)
    pub nonlinear_reason: Option<String>,
}

/// The reason of one linear optimum: stable up to the speed range's top (`cap_name`), or
/// no gain above the open loop.
fn linear_reason(l: &LinearOptimum, v_open: f64, o: &GainSearch, cap_name: &str) -> Option<String> {
    if let Some(cap) = l.v_crit_max().stable_up_to() {
        let subject = format!("straight running with D = {:.4} s", l.d_opt_s);
        return Some(format!(
            "{}: the critical speed is higher",
            stable_up_to_reason(&subject, cap, cap_name)
        ));
    }
    let no_rise = l.v_crit_max_mps <= v_open * (1.0 + 1e-9);
    no_rise.then(|| {
        format!(
            "no gain in [{}, {}] s raises the critical speed above the open loop's {:.4} m/s at τ = {} s",
            o.d_min_s, o.d_max_s, v_open, l.tau_s
        )
    })
}

/// The whole computation (no I/O): the settings resolved, the linear optima of all delays
/// and the nonlinear part of the selected ones side by side on the thread pool (each delay
/// deterministic, results in grid order), then the delay budget. The linear part (optima,
/// bands, budget, the derived ranges) runs on `model`'s own linearisation ([`LoopModel`]:
/// the paper's model or any plant); the nonlinear part (the fold-of-cycles optimum,
/// V_fold(D = 0)) on `nonlinear_model`, the paper's model of the same vehicle, and is left
/// out (every `fold` None, [`GainDesign::nonlinear_reason`] says why) when it is `None`.
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn compute<M: LoopModel + ?Sized>(
    model: &M,
    nonlinear_model: Option<&Model>,
    cfg: &GainDesignConfig,
    b: &SpeedBounds,
    progress: &dyn sway::progress::Progress,
) -> Result<GainDesign, SwayError> {
    let resolved = cfg.resolve(model, b)?;
    let delays = cfg.delays();
    let o = &resolved.search;
    let chart = &resolved.chart;
    let nonlinear: Vec<usize> = match nonlinear_model {
        Some(_) => (0..delays.len()).filter(|&i| cfg.is_nonlinear(i)).collect(),
        None => Vec::new(),
    };
    let nonlinear_reason = match nonlinear_model {
        None if (0..delays.len()).any(|i| cfg.is_nonlinear(i)) => Some(
            "the fold-of-cycles optimum is computed for the paper's model only: this vehicle \
             has model variants, whose nonlinear chart is not wired into gain_design yet"
                .to_string(),
        ),
        _ => None,
    };
    let (linear, (fold, v_fold_open)) = join(
        &|| {
            try_map(&delays, Split::Adaptive, &|_, &tau| {
                let r = linear_optimum(model, tau, o);
                progress.advance(1);
                r
            })
        },
        &|| {
            let r: Vec<Result<FoldResult, SwayError>> =
                map(&nonlinear, Split::Adaptive, &|_, &i| {
                    let r = match nonlinear_model {
                        Some(m) => fold_optimum(m, delays[i], o, chart),
                        None => unreachable_fold(),
                    };
                    progress.advance(1);
                    r
                });
            let open = match nonlinear_model {
                Some(m) if !nonlinear.is_empty() => open_loop_fold_speed(m, chart).or_else(|e| {
                    // no Hopf point of the open loop in the chart's speed range: no fold
                    if e.to_string().contains("no Hopf point") {
                        Ok(None)
                    } else {
                        Err(e)
                    }
                }),
                _ => Ok(None),
            };
            (r, open)
        },
    );
    let linear = linear?;
    let mut folds: Vec<Option<FoldResult>> = vec![None; delays.len()];
    for (&i, r) in nonlinear.iter().zip(fold) {
        folds[i] = Some(r?);
    }
    let v_open = critical_speed(model, 0.0, 0.0, o)?;
    let open_loop_stable = v_open >= o.v_max_mps;
    let cap_name = cfg.cap_name();
    let bc = &cfg.budget;
    let budget = delay_budget(
        model,
        &linear,
        v_open,
        bc.rise_fraction,
        bc.tau_tolerance_s,
        o,
    )?;
    let rise = format!("by {} %", bc.rise_fraction * 100.0);
    let budget_reason = match (budget.tau_s, budget.at_grid_end) {
        (Some(_), false) => None,
        (Some(tau), true) => Some(format!(
            "the best gain raises the critical speed {rise} over the open loop's {v_open:.4} m/s at every delay of the grid up to its end, τ = {tau} s (delays_s.max): the delay budget is at least that"
        )),
        (None, _) if open_loop_stable => Some(format!(
            "{}: no critical speed to raise",
            stable_up_to_reason("straight running without feedback", o.v_max_mps, cap_name)
        )),
        // a capped optimum is a lower bound: above the cap no rise can be told
        (None, _) if (1.0 + bc.rise_fraction) * v_open > o.v_max_mps => Some(format!(
            "the rise {rise} over the open loop's {v_open:.4} m/s asks for a critical speed above the top of the speed range, {} m/s ({cap_name}): no delay budget can be told",
            o.v_max_mps
        )),
        (None, _) => Some(format!(
            "no delay of the grid has a gain that raises the critical speed {rise} over the open loop's {v_open:.4} m/s"
        )),
    };
    let linear_reasons = linear
        .iter()
        .map(|l| linear_reason(l, v_open, o, cap_name))
        .collect();
    progress.advance(1);
    Ok(GainDesign {
        resolved,
        delays_s: delays,
        linear,
        linear_reasons,
        fold: folds,
        budget,
        budget_reason,
        open_loop_stable,
        open_loop_v_fold_mps: v_fold_open?,
        nonlinear_reason,
    })
}

/// The nonlinear part is never asked for without a nonlinear model (`nonlinear` is empty).
fn unreachable_fold() -> Result<FoldResult, SwayError> {
    Err(SwayError::numerical(
        "the fold-of-cycles optimum",
        std::io::Error::other("no nonlinear model of this plant"),
    ))
}
