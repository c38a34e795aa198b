//! Linear stability of the delayed yaw-rate feedback δ(t) = −D·ψ̇(t − τ) (paper §IV-B):
//! the model's linearisation (eq. 9–11) wired into the general-purpose [`stability`] crate,
//! the (V, D) charts of Fig. 4(a), their headline numbers and their figure.
//!
//! The closed loop is eq. (12) on the 4 states (σ1, σ2, σ3, θ): x' = Ã x − B̃ D C̃ x(t − τ);
//! its characteristic function (13) is the quasi-polynomial p(λ) + D e^{−λτ} q(λ) with
//! p = det(λI − Ã), q = C̃ adj(λI − Ã) B̃ ([`stability::RankOneFeedback`]).

use serde::{Deserialize, Serialize};

use crate::SwayError;
use stability::{
    Axis, ChartOptions, Complex64, RankOneFeedback, RootOptions, StabilityChart, StabilityError,
    first_unstable_parameter, stability_charts,
};
use sway_model::law::{Actuator, Gains, LoopLaw, LoopLinearization, Structure, loop_output_row};
use sway_model::vehicle::LoopModel;

pub mod auto_range;

/// The closed loop at speed V \[m/s\] in quasi-polynomial form (Ã, B̃, C̃ of eq. 11) of any
/// plant ([`LoopModel`]: the paper's `Model`, a `VehicleModel<N>`, an `AnyVehicleModel`):
/// p = det(λI − A) of degree n, q = C adj(λI − A) B.
///
/// # Errors
/// [`StabilityError`] if the linearisation is not finite (e.g. V = 0).
pub fn closed_loop<M: LoopModel + ?Sized>(
    model: &M,
    speed: f64,
) -> Result<RankOneFeedback, StabilityError> {
    let lin = model.loop_linearization(speed);
    RankOneFeedback::from_state_space(&lin.a, &lin.b, &lin.c)
}

/// The controller table of a (V, D) chart (`controller` of `fig4a`): the file form of the
/// [`LoopLaw`] whose gain D is the chart's gain axis ([`ChartControllerTable::law`]). For the chart to stay the D-subdivision of one quasi-polynomial
/// p(λ) + D·e^{−λτ}·q(λ), every gain is proportional to D: with `yaw_rate_hitch` the loop is
/// u = −D·(ψ̇ + k_θ·θ + d_θ·θ̇)(t − τ), k_θ = `hitch_angle_per_d`, d_θ = `hitch_rate_per_d`.
/// The default is the paper's yaw-rate steering (numbers unchanged). The predictor is not
/// linear in D (its cleared function has D in both terms): charts refuse it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ChartControllerTable {
    /// `yaw_rate` (default) or `yaw_rate_hitch`
    pub structure: Structure,
    /// `steering` (default; D in s) or `differential_braking` (D in N m s/rad)
    pub actuator: Actuator,
    /// K_θ / D \[rad/rad per unit of D\] (`yaw_rate_hitch` only)
    pub hitch_angle_per_d: f64,
    /// D_θ / D \[s per unit of D\] (`yaw_rate_hitch` only)
    pub hitch_rate_per_d: f64,
}

impl Default for ChartControllerTable {
    fn default() -> Self {
        Self {
            structure: Structure::YawRate,
            actuator: Actuator::Steering,
            hitch_angle_per_d: 0.0,
            hitch_rate_per_d: 0.0,
        }
    }
}

impl ChartControllerTable {
    /// The paper's controller δ = −D·ψ̇(t − τ).
    pub fn is_paper(&self) -> bool {
        *self == Self::default()
    }

    /// Checks that the chart can be drawn for this controller.
    ///
    /// # Errors
    /// A message for the predictor (not linear in D) and for non-finite ratios.
    pub fn check(&self) -> Result<(), String> {
        if self.structure == Structure::Predictor {
            return Err(
                "the predictor is not linear in D (its cleared characteristic function \
                 has D in both terms): a (V, D) chart takes `yaw_rate` or `yaw_rate_hitch`"
                    .into(),
            );
        }
        if !(self.hitch_angle_per_d.is_finite() && self.hitch_rate_per_d.is_finite()) {
            return Err("expected finite hitch_angle_per_d and hitch_rate_per_d".into());
        }
        Ok(())
    }

    /// The law per unit of D: gains (1, k_θ, d_θ) of the structure and actuator, τ = 0
    /// (the chart's axes give D and τ).
    pub fn law(&self) -> LoopLaw {
        let gains = Gains {
            yaw_rate: 1.0,
            hitch_angle: self.hitch_angle_per_d,
            hitch_rate: self.hitch_rate_per_d,
        };
        LoopLaw::new(self.structure, self.actuator, gains, 0.0)
    }
}

/// A plant seen through a law per unit of D ([`ChartControllerTable::law`]): its
/// linearisation with B the actuator's column and C the law's output row, so that every chart function
/// ([`closed_loop`], [`fig4a_charts`], [`critical_speed_at_gain`], [`auto_range`]) draws the
/// chart of that controller with D as its gain. The paper's controller passes the plant's
/// own B̃, C̃ through.
#[derive(Debug, Clone, Copy)]
pub struct Controlled<'a, M: LoopModel + ?Sized> {
    /// the plant
    pub model: &'a M,
    /// the law, its gains per unit of D (the chart's gain axis scales them)
    pub law: LoopLaw,
}

impl<M: LoopModel + ?Sized> LoopModel for Controlled<'_, M> {
    fn loop_linearization(&self, speed: f64) -> LoopLinearization {
        let mut lin = self.model.loop_linearization(speed);
        let law = &self.law;
        if law.is_paper_structure() {
            return lin;
        }
        let row = loop_output_row(&lin, law.structure, &law.gains);
        lin.b = law.actuator.loop_input_column(&lin).clone();
        lin.c = row;
        lin
    }

    fn open_loop_spectrum(&self, speed: f64) -> Vec<Complex64> {
        self.model.open_loop_spectrum(speed)
    }

    fn critical_speed_search(
        &self,
        opts: &trailer_model::CriticalSpeedOptions,
    ) -> Result<Option<trailer_model::CriticalSpeed>, trailer_model::ModelError> {
        self.model.critical_speed_search(opts)
    }

    fn paper_model(&self) -> &trailer_model::Model {
        self.model.paper_model()
    }

    fn states(&self) -> usize {
        self.model.states()
    }
}

/// The open-loop critical speed of any plant: [`sway_model::speeds::open_loop_critical_speed`]
/// (the one search every task uses, [`sway_model::speeds::open_loop_stability_by`]) through
/// [`LoopModel::critical_speed_search`]; for the paper's `Model` the same call, so the same
/// numbers.
///
/// # Errors
/// [`SwayError::Model`] when straight running is already unstable at the lowest speed or
/// the eigenvalues are not finite.
pub fn open_loop_stability<M: LoopModel + ?Sized>(
    model: &M,
    limits: &sway_model::speeds::SpeedLimits,
) -> Result<sway_model::speeds::OpenLoopStability, SwayError> {
    sway_model::speeds::open_loop_stability_by(limits, |o| model.critical_speed_search(o))
}

fn numerical(context: String) -> impl FnOnce(StabilityError) -> SwayError {
    move |e| SwayError::numerical(context, e)
}

/// The `count` rightmost characteristic roots of eq. (13) at speed V \[m/s\], gain D \[s\] and
/// delay τ \[s\], sorted by decreasing real part, conjugates listed separately, Newton-polished
/// (relative accuracy ~1e-14).
///
/// # Errors
/// [`SwayError::Numerical`] if the roots cannot be confirmed.
pub fn rightmost_roots<M: LoopModel + ?Sized>(
    model: &M,
    speed: f64,
    gain: f64,
    delay: f64,
    count: usize,
) -> Result<Vec<Complex64>, SwayError> {
    let ctx = format!("rightmost roots at V = {speed} m/s, D = {gain} s, τ = {delay} s");
    let sys = closed_loop(model, speed).map_err(numerical(ctx.clone()))?;
    sys.rightmost_roots(gain, delay, count, &RootOptions::for_count(count))
        .map_err(numerical(ctx))
}

/// Number of characteristic roots with Re λ > 0 at (V, D, τ), exact by D-subdivision.
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn unstable_root_count<M: LoopModel + ?Sized>(
    model: &M,
    speed: f64,
    gain: f64,
    delay: f64,
) -> Result<usize, SwayError> {
    let ctx = format!("unstable roots at V = {speed} m/s, D = {gain} s, τ = {delay} s");
    let sys = closed_loop(model, speed).map_err(numerical(ctx.clone()))?;
    sys.unstable_root_count(gain, delay).map_err(numerical(ctx))
}

/// Stability charts of Fig. 4(a): one per delay, over cell-centred V \[m/s\] × D \[s\] axes.
///
/// # Errors
/// [`SwayError::Numerical`] for an invalid grid or a failed linearisation.
pub fn fig4a_charts<M: LoopModel + ?Sized>(
    model: &M,
    delays: &[f64],
    speed: Axis,
    gain: Axis,
    options: &ChartOptions,
) -> Result<Vec<StabilityChart>, SwayError> {
    stability_charts(|v| closed_loop(model, v), delays, speed, gain, options)
        .map_err(numerical("stability charts of Fig. 4(a)".into()))
}

/// The lowest speed in \[v_min, v_max\] at which gain D leaves straight running unstable
/// (`None` if stable on the whole range): scan of the exact unstable-root count at `samples`
/// speeds, then bisection to `tolerance` \[m/s\] — the crossing of the boundary curves.
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn critical_speed_at_gain<M: LoopModel + ?Sized>(
    model: &M,
    delay: f64,
    gain: f64,
    v_min: f64,
    v_max: f64,
    samples: usize,
    tolerance: f64,
) -> Result<Option<f64>, SwayError> {
    first_unstable_parameter(
        |v| closed_loop(model, v),
        delay,
        gain,
        v_min,
        v_max,
        samples,
        tolerance,
    )
    .map_err(numerical(format!(
        "critical speed at D = {gain} s, τ = {delay} s"
    )))
}

/// Intervals \[D_min, D_max\] of stabilising gains at speed V within \[d_min, d_max\]; the end
/// points are exact boundary crossings (or the range ends).
///
/// # Errors
/// [`SwayError::Numerical`].
pub fn stable_gain_intervals<M: LoopModel + ?Sized>(
    model: &M,
    delay: f64,
    speed: f64,
    d_min: f64,
    d_max: f64,
) -> Result<Vec<(f64, f64)>, SwayError> {
    let ctx = format!("stable gains at V = {speed} m/s, τ = {delay} s");
    let sys = closed_loop(model, speed).map_err(numerical(ctx.clone()))?;
    sys.stable_gain_intervals(delay, d_min, d_max)
        .map_err(numerical(ctx))
}
