//! Design on the roots: the gains of a controller structure that maximise the linear
//! critical speed at a delay τ, the band of near-optimal gains, whether the optimum sits on
//! a double-Hopf corner, the delay budget and the critical speed a design guarantees under
//! vehicle uncertainty.
//!
//! The objective V_crit(gains) — the lowest speed at which straight running is unstable,
//! from exact unstable-root counts ([`super::critical_speed`]) — is continuous but not
//! smooth: it has kinks where two Hopf curves cross (double-Hopf points) and plateaus where
//! a design is stable up to the top of the speed range. So
//!
//! - a structure with one gain (`yaw_rate`, `predictor`) is optimised as `gain_design`
//!   does: a coarse scan of the gain range, Brent's method in the bracket of the best sample
//!   (golden sections where the parabola fails, as at a kink), the band within 1 % by
//!   bisection — for `yaw_rate` with steering this is `gain_design`'s computation;
//! - a structure with several gains (`yaw_rate_hitch`) by Nelder–Mead, a derivative-free
//!   method that copes with kinks, with restarts: from the best one-gain design (D\*, 0, 0),
//!   from the optimum of the previous delay of a τ grid, and from seeded random points of
//!   the gain box ([`sway_model::optimise::minimise`]); the bands are bisected along
//!   each gain with the others at the optimum.

use crate::parallel::{Split, map_indices};
use serde::{Deserialize, Serialize};
use trailer_model::{Model, PARAMETERS, VehicleParams};

use super::LoopModel;

use super::{Actuator, GainName, Gains, LinearLoop, LoopLaw, SpeedSearch, Structure};
use crate::SwayError;
use crate::gain_design::{GainSearch, band_end, refine_sampled};
use crate::sampling::{About, Sampler, Sampling, Statistics};
use sway_model::optimise::{Bound, MixedProblem, OptimiserSettings, minimise};
use sway_model::speeds::CappedSpeed;
use sway_model::vehicle::VehicleDescription;

/// Bounds of the gains, in steering units (D, D_θ in s, K_θ in rad/rad); for differential
/// braking they are multiplied by [`Actuator::scale`] (N m per rad of equivalent steering).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GainBounds {
    /// D on the yaw rate \[s\]
    pub yaw_rate: Bound,
    /// K_θ on the hitch angle \[rad/rad\]
    pub hitch_angle: Bound,
    /// D_θ on the hitch-angle rate \[s\]
    pub hitch_rate: Bound,
}

impl Default for GainBounds {
    fn default() -> Self {
        Self {
            yaw_rate: Bound::new(0.0, 0.5),
            hitch_angle: Bound::new(-1.0, 1.0),
            hitch_rate: Bound::new(-0.5, 0.5),
        }
    }
}

impl GainBounds {
    /// The bound of one gain, in the actuator's units (`scale` from [`Actuator::scale`]).
    pub fn get(&self, name: GainName, scale: f64) -> Bound {
        let b = match name {
            GainName::YawRate => self.yaw_rate,
            GainName::HitchAngle => self.hitch_angle,
            GainName::HitchRate => self.hitch_rate,
        };
        Bound::new(b.lo * scale, b.hi * scale)
    }
}

/// The physical limit of the yaw-rate gain D: the linear design holds only while the
/// actuator is not saturated, so the command D·ψ̇ at the largest tractor yaw-rate amplitude
/// ψ̇_ref the controller must handle linearly stays within the actuator's limit u_max:
/// D ≤ u_max/ψ̇_ref. u_max is the steering authority δ_max \[rad\] for steering and the
/// yaw moment of braking one side of the tractor to the friction limit,
/// μ0·(F_zF + F_zR)·w/4 \[N m\] ([`Actuator::limit`]), for differential braking.
///
/// Without it the critical speed of some loops keeps rising with D (the delay-free loop,
/// so the perfectly predicted `predictor` at every τ, and `yaw_rate` at τ ≲ 0.1 s), and the
/// optimum is whatever end of the range was configured.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandLimits {
    /// ψ̇_ref: the tractor yaw-rate amplitude up to which the command must stay within the
    /// actuator's limit \[rad/s\]
    pub yaw_rate_amplitude_rad_s: f64,
    /// δ_max: the steering authority of the controller at the road wheels \[rad\]
    pub steering_rad: f64,
    /// the tow vehicle's track width w \[m\] of the braking limit (set by the task from its
    /// `track_width_m`)
    #[serde(skip, default = "default_track_width")]
    pub track_width_m: f64,
}

fn default_track_width() -> f64 {
    1.6
}

impl CommandLimits {
    /// u_max: the largest command of `actuator` (steering: rad; braking: N m).
    pub fn max_command(&self, actuator: Actuator, model: &Model) -> f64 {
        match actuator {
            Actuator::Steering => self.steering_rad,
            Actuator::DifferentialBraking => actuator
                .limit(model, self.track_width_m)
                .unwrap_or(f64::INFINITY),
        }
    }

    /// The largest yaw-rate gain, u_max/ψ̇_ref (steering: s; braking: N m s/rad).
    pub fn max_yaw_rate_gain(&self, actuator: Actuator, model: &Model) -> f64 {
        self.max_command(actuator, model) / self.yaw_rate_amplitude_rad_s
    }
}

/// Settings of the design search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DesignSearch {
    /// the critical-speed search (range, scan, final tolerance)
    pub speed: SpeedSearch,
    /// bisection tolerance of the critical speeds inside the Nelder–Mead runs \[m/s\] (the
    /// optimum is re-evaluated at `speed.tolerance_mps`)
    pub search_tolerance_mps: f64,
    /// the gain ranges (steering units)
    pub bounds: GainBounds,
    /// the physical limit of the yaw-rate gain: where given, it replaces the upper end of
    /// `bounds.yaw_rate` by u_max/ψ̇_ref in the actuator's units
    pub limits: Option<CommandLimits>,
    /// gains of the coarse scan of one-gain structures (≥ 3)
    pub gain_samples: usize,
    /// tolerance of an optimal gain and of the band ends (steering units: s)
    pub gain_tolerance: f64,
    /// the band: gains whose critical speed is within this fraction of the maximum
    pub band_fraction: f64,
    /// most Brent iterations of a one-gain refinement
    pub max_iterations: u64,
    /// the Nelder–Mead runs of several-gain structures
    pub optimiser: OptimiserSettings,
    /// |Re λ| \[1/s\] below which a second root pair at the optimum's critical speed counts
    /// as critical too: the optimum sits on a double-Hopf corner
    pub double_hopf_tolerance_per_s: f64,
}

impl Default for DesignSearch {
    fn default() -> Self {
        Self {
            speed: SpeedSearch::default(),
            search_tolerance_mps: 1e-6,
            bounds: GainBounds::default(),
            limits: None,
            gain_samples: 101,
            gain_tolerance: 1e-6,
            band_fraction: 0.01,
            max_iterations: 200,
            optimiser: OptimiserSettings {
                seed: 22,
                random_starts: 1,
                max_iters: 100,
                sd_tolerance: 1e-6,
                initial_step: 0.3,
            },
            double_hopf_tolerance_per_s: 1e-3,
        }
    }
}

impl DesignSearch {
    /// The search range of one gain with `actuator` in its units: `bounds` × the actuator's
    /// scale, the yaw-rate gain's upper end from `limits` where given.
    pub fn gain_bound(&self, name: GainName, actuator: Actuator, model: &Model) -> Bound {
        let b = self.bounds.get(name, actuator.scale(model));
        match (name, self.limits) {
            (GainName::YawRate, Some(l)) => Bound::new(b.lo, l.max_yaw_rate_gain(actuator, model)),
            _ => b,
        }
    }
}

/// The gains within `band_fraction` of the optimum along one gain, the others at the
/// optimum (an end equal to a bound where the band reaches it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GainBand {
    /// which gain
    pub gain: GainName,
    /// lower end (actuator units)
    pub lo: f64,
    /// upper end
    pub hi: f64,
}

/// The best gains of one structure and actuator at one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Design {
    /// the controller structure
    pub structure: Structure,
    /// the actuator
    pub actuator: Actuator,
    /// the loop delay τ \[s\]
    pub tau_s: f64,
    /// the optimal gains (actuator units)
    pub gains: Gains,
    /// the maximal linear critical speed \[m/s\] (the top of the speed range if capped: the
    /// optimiser's objective; a summary reports [`Design::v_crit`])
    pub v_crit_mps: f64,
    /// the scan's critical speed where a narrower window of instability was found below it
    /// ([`super::verified_critical_speed`]; `v_crit_mps` is the window's start) \[m/s\]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub v_crit_scan_mps: Option<f64>,
    /// stable up to the top of the speed range: the true critical speed is higher
    pub speed_capped: bool,
    /// the near-optimal band of each gain of the structure
    pub bands: Vec<GainBand>,
    /// a second root pair of another frequency is critical at the optimum too (within
    /// `double_hopf_tolerance_per_s`): the optimum is a double-Hopf corner
    pub at_double_hopf: bool,
    /// the real part \[1/s\] and frequency \[rad/s\] of the rightmost root pair other than the
    /// critical one at V_crit (None where capped or no other pair was found)
    pub second_pair: Option<[f64; 2]>,
    /// why `second_pair` is None, where it is
    pub second_pair_note: Option<String>,
    /// critical speeds evaluated
    pub evaluations: usize,
}

impl Design {
    /// The designed law: the structure and actuator with the optimal gains at delay τ.
    pub fn law(&self) -> LoopLaw {
        LoopLaw::new(self.structure, self.actuator, self.gains, self.tau_s)
    }

    /// The maximal linear critical speed as a summary reports it: found, or straight
    /// running stable up to the top of the speed range (`speed_capped`: `v_crit_mps` is
    /// that top, not a measured speed).
    pub fn v_crit(&self) -> CappedSpeed {
        if self.speed_capped {
            CappedSpeed::StableUpTo(self.v_crit_mps)
        } else {
            CappedSpeed::Found(self.v_crit_mps)
        }
    }
}

/// The critical speed of a controller, the top of the range where stable on all of it.
fn v_crit<M: LoopModel + ?Sized>(
    model: &M,
    c: &LoopLaw,
    prediction: Option<&dyn LoopModel>,
    search: &SpeedSearch,
) -> Result<f64, SwayError> {
    Ok(super::critical_speed(model, c, prediction, search)?.unwrap_or(search.v_max_mps))
}

/// Whether `e` is a root count that found no frequency bound for the crossings
/// ([`stability::StabilityError::UnboundedCrossings`]).
fn unbounded_crossings(e: &SwayError) -> bool {
    match e {
        SwayError::Numerical { cause, .. } => matches!(
            cause.downcast_ref::<stability::StabilityError>(),
            Some(stability::StabilityError::UnboundedCrossings { .. })
        ),
        _ => false,
    }
}

/// What a design starts from beside its own search: a previous optimum `warm` (the design
/// at the neighbouring delay), and for a several-gain structure (`yaw_rate_hitch`) the
/// `yaw_rate` design of the same actuator at the same delay (which [`design`] otherwise
/// computes first: the same result without computing that design twice).
#[derive(Debug, Clone, Copy, Default)]
pub struct DesignStart<'a> {
    /// a previous optimum to start from (several-gain structures)
    pub warm: Option<&'a Gains>,
    /// the `yaw_rate` design of the same actuator and delay (several-gain structures)
    pub yaw_rate: Option<&'a Design>,
}

/// The best gains of `law`'s structure with its actuator at its delay τ (its gains are
/// what the design sets; see the module docs), started from `start`.
///
/// # Errors
/// [`SwayError::Numerical`] if a critical speed cannot be computed.
pub fn design<M: LoopModel + ?Sized>(
    model: &M,
    law: &LoopLaw,
    prediction: Option<&dyn LoopModel>,
    start: DesignStart<'_>,
    o: &DesignSearch,
) -> Result<Design, SwayError> {
    debug_assert!(start.yaw_rate.is_none_or(|d| {
        d.structure == Structure::YawRate && d.actuator == law.actuator && d.tau_s == law.delay_s
    }));
    let target = Target {
        model,
        law: *law,
        prediction,
        o,
    };
    target.design(
        start.warm,
        start.yaw_rate.map(|d| (&d.gains, d.evaluations)),
    )
}

/// One design's target: the loop of a structure with an actuator at one delay τ on `model`
/// (`law`'s gains are what the search sets), the predictor's model and the search options.
struct Target<'a, M: LoopModel + ?Sized> {
    model: &'a M,
    law: LoopLaw,
    prediction: Option<&'a dyn LoopModel>,
    o: &'a DesignSearch,
}

impl<M: LoopModel + ?Sized> Target<'_, M> {
    /// The critical speed of the loop with `gains` on the search's speed range. A gain set
    /// whose crossings cannot be bounded in frequency at a speed of the scan (the loop
    /// keeps its gain to beyond 10⁶ times its roots' frequencies: `UnboundedCrossings`) is
    /// not certified stable there: the search counts it as unstable from the bottom of
    /// the range, so that it never wins (a design reports only certified speeds).
    fn v_crit(&self, gains: Gains, search: &SpeedSearch) -> Result<f64, SwayError> {
        match v_crit(
            self.model,
            &self.law.with_gains(gains),
            self.prediction,
            search,
        ) {
            Err(e) if unbounded_crossings(&e) => Ok(search.v_min_mps),
            r => r,
        }
    }

    /// The command per radian of equivalent steering of the actuator.
    fn scale(&self) -> f64 {
        self.law.actuator.scale(self.model.paper_model())
    }

    /// [`design`], the `yaw_rate_hitch` search started from `start` (the `yaw_rate`
    /// optimum's gains and its evaluations) when given, else from that optimum computed
    /// here.
    fn design(
        &self,
        warm: Option<&Gains>,
        start: Option<(&Gains, usize)>,
    ) -> Result<Design, SwayError> {
        let found = match self.law.structure {
            Structure::YawRate | Structure::Predictor => self.one_gain()?,
            Structure::YawRateHitch => {
                let computed;
                let (start_gains, start_evaluations) = match start {
                    Some(s) => s,
                    None => {
                        let yaw_rate = Target {
                            law: LoopLaw {
                                structure: Structure::YawRate,
                                ..self.law
                            },
                            prediction: None,
                            ..*self
                        };
                        computed = yaw_rate.one_gain()?;
                        (&computed.0, computed.3)
                    }
                };
                let (g, v, b, n) = self.several_gains(start_gains, warm)?;
                (g, v, b, n + start_evaluations)
            }
        };
        self.finish(found)
    }

    /// The design from the optimum found: the double-Hopf check at V_crit.
    fn finish(&self, (gains, v, bands, evaluations): Found) -> Result<Design, SwayError> {
        let (model, prediction, o) = (self.model, self.prediction, self.o);
        let LoopLaw {
            structure,
            actuator,
            delay_s: tau,
            ..
        } = self.law;
        let c = self.law.with_gains(gains);
        // the several-gain search can push a pair to graze the axis between the scan's
        // samples: its optimum's V_crit is checked for such a window below it
        let scan_v_crit = v;
        let v = if structure == Structure::YawRateHitch {
            let scan = (v < o.speed.v_max_mps).then_some(v);
            super::verified_critical_speed(model, &c, prediction, &o.speed, scan)?.unwrap_or(v)
        } else {
            v
        };
        let speed_capped = v >= o.speed.v_max_mps;
        // the rightmost roots at V_crit: a second critical pair marks a double-Hopf corner; where
        // the roots cannot be confirmed (the predictor's cleared quasi-polynomial of degree 2n is
        // ill-conditioned for the spectral seeds) the design stands, with the reason
        let (second_pair, second_pair_note) = if speed_capped {
            (
                None,
                Some("stable up to the top of the speed range".to_string()),
            )
        } else {
            match second_pair(model, &c, prediction, v) {
                Ok(Some(p)) => (Some(p), None),
                Ok(None) => (
                    None,
                    Some("no second root pair among the six rightmost".into()),
                ),
                Err(e) => (None, Some(format!("rightmost roots not confirmed: {e}"))),
            }
        };
        Ok(Design {
            structure,
            actuator,
            tau_s: tau,
            gains,
            v_crit_mps: v,
            v_crit_scan_mps: (v != scan_v_crit).then_some(scan_v_crit),
            speed_capped,
            bands,
            at_double_hopf: second_pair
                .is_some_and(|[re, _]| re.abs() <= o.double_hopf_tolerance_per_s),
            second_pair,
            second_pair_note,
            evaluations,
        })
    }

    /// One gain (D): `gain_design`'s scan, Brent refinement and band, on this structure's loop.
    fn one_gain(&self) -> Result<Found, SwayError> {
        let (model, o, scale) = (self.model, self.o, self.scale());
        let bound = o.gain_bound(GainName::YawRate, self.law.actuator, model.paper_model());
        let g = GainSearch {
            d_min_s: bound.lo,
            d_max_s: bound.hi,
            gain_samples: o.gain_samples,
            v_min_mps: o.speed.v_min_mps,
            v_max_mps: o.speed.v_max_mps,
            speed_samples: o.speed.samples,
            speed_tolerance_mps: o.speed.tolerance_mps,
            gain_tolerance_s: o.gain_tolerance * scale,
            band_fraction: o.band_fraction,
            max_iterations: o.max_iterations,
        };
        let f = |d: f64| self.v_crit(Gains::yaw_rate(d), &o.speed);
        let gains = g.gains();
        let speeds = gains.iter().map(|&d| f(d)).collect::<Result<Vec<_>, _>>()?;
        let (d, v, band, n) = refine_sampled(&f, &gains, &speeds, &g)?;
        let band = GainBand {
            gain: GainName::YawRate,
            lo: band[0],
            hi: band[1],
        };
        Ok((Gains::yaw_rate(d), v, vec![band], gains.len() + n))
    }

    /// Several gains: −V_crit minimised by Nelder–Mead from the `yaw_rate` optimum and
    /// `warm`, then the band of each gain.
    fn several_gains(
        &self,
        one_gain_optimum: &Gains,
        warm: Option<&Gains>,
    ) -> Result<Found, SwayError> {
        let (model, o, scale) = (self.model, self.o, self.scale());
        let names = self.law.structure.gain_names();
        let problem = CriticalSpeedProblem {
            target: self,
            names,
            bounds: names
                .iter()
                .map(|&n| o.gain_bound(n, self.law.actuator, model.paper_model()))
                .collect(),
            search: SpeedSearch {
                tolerance_mps: o.search_tolerance_mps,
                ..o.speed
            },
        };
        let as_point = |g: &Gains| names.iter().map(|&n| g.get(n)).collect::<Vec<f64>>();
        let mut starts = vec![as_point(one_gain_optimum)];
        if let Some(w) = warm {
            starts.push(as_point(w));
        }
        let best = minimise(&problem, &starts, &o.optimiser)?;
        let gains = problem.gains(&best.x);
        let v = self.v_crit(gains, &o.speed)?;
        let mut n = best.evaluations + 1;
        let mut bands = Vec::with_capacity(names.len());
        for (i, &name) in names.iter().enumerate() {
            let b = problem.bounds[i];
            let along = |x: f64| self.v_crit(gains.with(name, x), &o.speed);
            let thr = (1.0 - o.band_fraction) * v;
            let tol = o.gain_tolerance * scale.max(1.0);
            let at = gains.get(name);
            let mut end = |toward: f64| -> Result<f64, SwayError> {
                n += 1;
                if along(toward)? >= thr {
                    return Ok(toward);
                }
                let (e, m) = band_end(&along, at, toward, thr, tol)?;
                n += m;
                Ok(e)
            };
            let (lo, hi) = (end(b.lo)?, end(b.hi)?);
            bands.push(GainBand { gain: name, lo, hi });
        }
        Ok((gains, v, bands, n))
    }
}

/// The designs of the perfectly predicted `predictor` (its model the vehicle itself) at
/// every delay of `taus`: its loop is the delay-free one whatever τ (finite spectrum
/// assignment, [`super::predictor`]; [`LinearLoop`] builds it without τ), so the design at
/// the first delay is the design at every delay, computed once.
///
/// # Errors
/// As [`design`].
pub fn perfect_predictor_designs<M: LoopModel + ?Sized>(
    model: &M,
    actuator: Actuator,
    taus: &[f64],
    o: &DesignSearch,
) -> Result<Vec<Design>, SwayError> {
    let Some(&first) = taus.first() else {
        return Ok(Vec::new());
    };
    let d = design(
        model,
        &LoopLaw::new(Structure::Predictor, actuator, Gains::default(), first),
        None,
        DesignStart::default(),
        o,
    )?;
    Ok(taus
        .iter()
        .map(|&tau| Design {
            tau_s: tau,
            ..d.clone()
        })
        .collect())
}

type Found = (Gains, f64, Vec<GainBand>, usize);

/// Several gains: −V_crit minimised by Nelder–Mead from the given starts.
struct CriticalSpeedProblem<'a, M: LoopModel + ?Sized> {
    target: &'a Target<'a, M>,
    names: &'static [GainName],
    bounds: Vec<Bound>,
    search: SpeedSearch,
}

impl<M: LoopModel + ?Sized> CriticalSpeedProblem<'_, M> {
    fn gains(&self, x: &[f64]) -> Gains {
        self.names
            .iter()
            .zip(x)
            .fold(Gains::default(), |g, (&n, &v)| g.with(n, v))
    }
}

impl<M: LoopModel + ?Sized> MixedProblem for CriticalSpeedProblem<'_, M> {
    fn bounds(&self) -> &[Bound] {
        &self.bounds
    }

    fn choices(&self) -> usize {
        1
    }

    fn cost(&self, _choice: usize, x: &[f64]) -> Result<f64, SwayError> {
        Ok(-self.target.v_crit(self.gains(x), &self.search)?)
    }
}

/// The rightmost root pair at V \[m/s\] whose frequency differs from the critical pair's
/// (by more than 1 %): its real part and frequency, or None if there is none among the
/// six rightmost roots.
fn second_pair<M: LoopModel + ?Sized>(
    model: &M,
    c: &LoopLaw,
    prediction: Option<&dyn LoopModel>,
    v: f64,
) -> Result<Option<[f64; 2]>, SwayError> {
    let tau = c.delay_s;
    let l = LinearLoop::new(model, c, v, prediction)?;
    let roots = l.rightmost_roots(6).map_err(|e| {
        SwayError::numerical(format!("rightmost roots at V = {v} m/s, τ = {tau} s"), e)
    })?;
    let Some(first) = roots.first() else {
        return Ok(None);
    };
    let w1 = first.im.abs();
    Ok(roots
        .iter()
        .find(|z| (z.im.abs() - w1).abs() > 0.01 * w1.max(1e-3))
        .map(|z| [z.re, z.im.abs()]))
}

/// [`design`] at every delay of an increasing grid, each warm-started from the previous
/// delay's optimum (sequential: the result depends only on the inputs).
///
/// # Errors
/// The first failing delay's error.
pub fn designs_over_delays<M: LoopModel + ?Sized>(
    model: &M,
    structure: Structure,
    actuator: Actuator,
    taus: &[f64],
    prediction: Option<&dyn LoopModel>,
    o: &DesignSearch,
) -> Result<Vec<Design>, SwayError> {
    let mut out: Vec<Design> = Vec::with_capacity(taus.len());
    for &tau in taus {
        let warm = out.last().map(|d| d.gains);
        out.push(design(
            model,
            &LoopLaw::new(structure, actuator, Gains::default(), tau),
            prediction,
            DesignStart {
                warm: warm.as_ref(),
                yaw_rate: None,
            },
            o,
        )?);
    }
    Ok(out)
}

/// The delay budget of one structure and actuator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DelayBudget {
    /// the largest delay at which the best gains still raise the critical speed by
    /// `gain_fraction` over the open loop \[s\] (None: not even at the first delay)
    pub tau_s: Option<f64>,
    /// the required rise: V_crit,max ≥ (1 + fraction)·V_crit,open
    pub gain_fraction: f64,
    /// the open-loop critical speed \[m/s\]
    pub open_loop_v_crit_mps: f64,
    /// the budget is the last delay of the grid (the true budget may be larger)
    pub at_grid_end: bool,
    /// grid delays beyond the budget at which the rise is reached again (delays near a
    /// multiple of the sway period put the delayed feedback back in phase) \[s\]
    pub later_windows_s: Vec<f64>,
}

/// The delay budget from the designs of an increasing τ grid: the last grid delay of the
/// run from the first one whose optima all reach (1 + `fraction`)·`v_open`, refined by bisection in τ (a [`design`] per
/// step, warm-started from that grid delay's gains) to `tau_tolerance` \[s\].
///
/// # Errors
/// [`SwayError::Numerical`] from a [`design`].
pub fn delay_budget<M: LoopModel + ?Sized>(
    model: &M,
    designs: &[Design],
    v_open: f64,
    fraction: f64,
    tau_tolerance: f64,
    prediction: Option<&dyn LoopModel>,
    o: &DesignSearch,
) -> Result<DelayBudget, SwayError> {
    let thr = (1.0 + fraction) * v_open;
    let mut budget = DelayBudget {
        tau_s: None,
        gain_fraction: fraction,
        open_loop_v_crit_mps: v_open,
        at_grid_end: false,
        later_windows_s: Vec::new(),
    };
    let ok = |d: &Design| d.v_crit_mps >= thr;
    // the budget is connected to τ = 0: beyond the first delay that fails, a delay near a
    // multiple of the sway period can work again (the delayed feedback is back in phase);
    // those grid delays are listed, not counted
    budget.later_windows_s = match designs.iter().position(|d| !ok(d)) {
        Some(f) => designs[f..]
            .iter()
            .filter(|d| ok(d))
            .map(|d| d.tau_s)
            .collect(),
        None => Vec::new(),
    };
    let j = match designs.iter().position(|d| !ok(d)) {
        Some(0) => return Ok(budget),
        Some(f) => f - 1,
        None => designs.len() - 1,
    };
    if j + 1 == designs.len() {
        budget.tau_s = Some(designs[j].tau_s);
        budget.at_grid_end = true;
        return Ok(budget);
    }
    let base = &designs[j];
    let g = |tau: f64| {
        design(
            model,
            &LoopLaw::new(base.structure, base.actuator, Gains::default(), tau),
            prediction,
            DesignStart {
                warm: Some(&base.gains),
                yaw_rate: None,
            },
            o,
        )
        .map(|d| d.v_crit_mps)
    };
    let (tau, _) = band_end(&g, base.tau_s, designs[j + 1].tau_s, thr, tau_tolerance)?;
    budget.tau_s = Some(tau);
    Ok(budget)
}

/// The vehicle uncertainty a design is judged under: the vehicle's fields sampled as in
/// `study_uncertainty` (by key path; each field's [`About`] says whether the draws are
/// values, offsets or factors of the nominal vehicle's), and for the predictor its model's
/// fields off by sampled errors (`prediction_model`, e.g. factors 0.9 … 1.1 on
/// `trailer.mass` with `about = "factor"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleUncertainty {
    /// the vehicle's sampled fields
    pub vehicle: Sampling,
    /// the predictor model's sampled errors (usually factors on the nominal values);
    /// sample s of it goes with sample s of `vehicle` (so its `samples` must be equal)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prediction_model: Option<Sampling>,
}

/// The critical speeds of a design over the uncertainty samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Robustness {
    /// statistics of the critical speed over the samples (finite ones)
    pub v_crit: Option<Statistics>,
    /// the 5 % quantile of the critical speed \[m/s\]: what the design guarantees
    pub v_crit_p05_mps: Option<f64>,
    /// samples whose vehicle was not valid or whose critical speed failed
    pub failed_samples: usize,
}

/// The index of a vehicle field by key path, e.g. `trailer.cog`.
fn field_index(key: &str) -> Result<usize, SwayError> {
    PARAMETERS
        .iter()
        .position(|(k, _, _)| *k == key)
        .ok_or_else(|| {
            SwayError::numerical(
                format!("uncertainty field `{key}`"),
                std::io::Error::other("not a vehicle field (see trailer_model::PARAMETERS)"),
            )
        })
}

fn sampler(s: &Sampling) -> Result<(Sampler, Vec<(usize, About)>), SwayError> {
    let sampler = Sampler::new(s).map_err(|(key, problem)| {
        SwayError::numerical(
            format!("uncertainty sampling `{key}`"),
            std::io::Error::other(problem),
        )
    })?;
    let idx = s
        .fields
        .iter()
        .map(|f| field_index(&f.key).map(|i| (i, f.about)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((sampler, idx))
}

/// The critical speed of `controller` at delay τ over the samples of `uncertainty` (in
/// parallel, reduced in sample order: the same on any number of threads). `nominal` is the
/// paper's [`VehicleParams`] or a vehicle file of any form
/// ([`trailer_model::VehicleSpec`]: tyre relaxation, axle lists, …); each sample sets the
/// sampled fields of the paper's keys on it ([`VehicleDescription::with_paper_value`],
/// about the nominal values of those keys). The predictor predicts with `prediction` (`nominal` when `None`), perturbed by the
/// uncertainty's `prediction_model` errors where given. A sample whose vehicle is invalid or
/// whose search fails is counted, not fatal.
///
/// # Errors
/// [`SwayError::Numerical`] for an invalid sampling or an unknown field; the nominal
/// vehicle's or prediction model's errors.
pub fn robust_critical_speed<D: VehicleDescription>(
    nominal: &D,
    prediction: Option<&D>,
    controller: &LoopLaw,
    uncertainty: &VehicleUncertainty,
    search: &SpeedSearch,
) -> Result<Robustness, SwayError> {
    let (vehicle, vehicle_idx) = sampler(&uncertainty.vehicle)?;
    let model_errors = match (&uncertainty.prediction_model, controller.structure) {
        (Some(s), Structure::Predictor) => Some(sampler(s)?),
        _ => None,
    };
    let predicted = prediction.unwrap_or(nominal);
    let nominal_values = nominal.paper_values()?;
    let predicted_values = predicted.paper_values()?;
    let prediction_model = predicted.model()?;
    let perturbed = |base: &D,
                     values: &VehicleParams,
                     draws: &[f64],
                     idx: &[(usize, About)]|
     -> Option<D::Model> {
        let mut description = base.clone();
        for (&v, &(i, about)) in draws.iter().zip(idx) {
            description = description
                .with_paper_value(i, about.apply(values.get(i), v))
                .ok()?;
        }
        description.model().ok()
    };
    let one = |s: usize| -> Option<f64> {
        let model = perturbed(nominal, &nominal_values, &vehicle.sample(s), &vehicle_idx)?;
        let sampled_prediction = match &model_errors {
            Some((errors, idx)) => Some(perturbed(
                predicted,
                &predicted_values,
                &errors.sample(s % errors.len()),
                idx,
            )?),
            None => None,
        };
        let prediction = match controller.structure {
            Structure::Predictor => {
                Some(sampled_prediction.as_ref().unwrap_or(&prediction_model) as &dyn LoopModel)
            }
            _ => None,
        };
        v_crit(&model, controller, prediction, search).ok()
    };
    let values: Vec<Option<f64>> = map_indices(vehicle.len(), Split::Adaptive, &one);
    let failed_samples = values.iter().filter(|v| v.is_none()).count();
    let stats = Statistics::of(values.into_iter().flatten());
    Ok(Robustness {
        v_crit_p05_mps: stats.as_ref().map(|s| s.quantiles.q05),
        v_crit: stats,
        failed_samples,
    })
}
