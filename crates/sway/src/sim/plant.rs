//! The car–trailer model with a speed profile and a steering controller, as an ODE/DDE
//! problem for the [`dde`] solver: 4 states \[σ1, σ2, σ3, θ\] or all 7 \[σ1, σ2, σ3, θ, ψ, x_H, y_H\],
//! plus the steering angle δ as a last state (5 or 8 states) when the controller has a
//! rate-limited actuator (see [`crate::sim::ActuatorLimits`]), or the predictor's integral
//! z as the last four states (8 or 11 states, see [`Controller::Predictor`]).

use dde::{DdeProblem, OdeProblem};
use nalgebra::{Matrix4, RowVector4, SVector, Vector4};
use trailer_model::{Inputs, Model, SlipAngles, State4};

use super::controller::LoopLaw;
use super::{Controller, SpeedProfile};
use crate::SwayError;
use crate::control::{Actuator, Structure};

/// What a `yaw_rate_hitch` or `predictor` controller needs at run time.
#[derive(Debug, Clone)]
struct LoopCommand {
    law: LoopLaw,
    /// M_max \[N m\] of braking (none for steering)
    limit: Option<f64>,
    /// the predictor's Â, B̂, K e^{Âτ}, K = D·Ĉ and e^{Âτ}B̂ (zeros for `yaw_rate_hitch`)
    a_hat: Matrix4<f64>,
    b_hat: Vector4<f64>,
    k_e: RowVector4<f64>,
    k: RowVector4<f64>,
    e_b: Vector4<f64>,
}

/// The closed (or open) loop: paper eq. (5)–(7) with V(t), V̇(t) from a [`SpeedProfile`] and
/// δ(t) from a [`Controller`] (eq. 8). Implements [`OdeProblem`] (δ ≡ 0) and
/// [`DdeProblem`] (δ = −D·ψ̇(t − τ)) for `N = 4` and `N = 7`, and with a rate-limited
/// actuator (δ the last state) for `N = 5` and `N = 8`.
#[derive(Debug, Clone)]
pub struct Plant<'a, const N: usize> {
    model: &'a Model,
    profile: &'a SpeedProfile,
    controller: Controller,
    /// x\[N − 1\] is the steering angle δ (rate-limited actuator)
    actuator_state: bool,
    /// the kinematic states ψ, x_H, y_H are x\[4..7\]
    kinematics: bool,
    delays: Vec<f64>,
    breakpoints: Vec<f64>,
    /// the constant initial function x(t) = x0 for t ≤ 0
    history: SVector<f64, N>,
    /// tan α_cr of the front, rear and trailer tyres (+∞ without a sliding limit)
    tan_critical: [f64; 3],
    /// `yaw_rate_hitch` and `predictor`
    loop_command: Option<LoopCommand>,
}

/// |tan α| below which a slip counts as zero for the switching functions (a kink of that size
/// changes the brush force by φ₂·tan²α ≈ 1e-18 of its scale).
pub const SLIP_TANGENT_FLOOR: f64 = 1e-9;

/// Number of switching functions of a [`Plant`] (see [`Plant::switching_functions`]).
pub const SWITCHING_FUNCTIONS: usize = 8;

/// The reduced state \[σ1, σ2, σ3, θ\] of a 4- or 7-state vector.
#[inline]
pub fn reduced<const N: usize>(x: &SVector<f64, N>) -> State4 {
    State4::new(x[0], x[1], x[2], x[3])
}

impl<'a, const N: usize> Plant<'a, N> {
    /// A plant starting from `x0` (also the history for t ≤ 0). With a rate-limited
    /// controller ([`Controller::has_actuator_state`]) `N` must be 5 or 8 and `x0[N − 1]` is
    /// δ(0); with a predictor `N` is 8 or 11 and `x0[N − 4..]` is z(0); otherwise `N` is 4
    /// or 7.
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if a predictor's model (the vehicle with its
    /// [`crate::sim::ModelError`]) is not a valid vehicle or its linearisation is not finite.
    pub fn new(
        model: &'a Model,
        profile: &'a SpeedProfile,
        controller: Controller,
        x0: SVector<f64, N>,
    ) -> Result<Self, SwayError> {
        let loop_command = match controller.loop_law() {
            Some(law) => Some(loop_command(model, profile, law)?),
            None => None,
        };
        let mut breakpoints = profile.breakpoints();
        breakpoints.extend(controller.breakpoints());
        breakpoints.retain(|&b| b > 0.0);
        breakpoints.sort_by(f64::total_cmp);
        breakpoints.dedup();
        let actuator_state = controller.has_actuator_state();
        let delays = match (controller.delay(), &loop_command) {
            // u(t − τ) in ż needs x(t − 2τ)
            (Some(tau), Some(c)) if c.law.structure == Structure::Predictor => vec![tau, 2.0 * tau],
            (d, _) => d.into_iter().collect(),
        };
        Ok(Self {
            model,
            profile,
            controller,
            actuator_state,
            kinematics: N - controller.extra_states() == 7,
            delays,
            breakpoints,
            history: x0,
            tan_critical: {
                let a = model.critical_slip_angles();
                [a.front, a.rear, a.trailer].map(|a| {
                    if a < std::f64::consts::FRAC_PI_2 {
                        a.tan()
                    } else {
                        f64::INFINITY
                    }
                })
            },
            loop_command,
        })
    }

    /// The model.
    pub fn model(&self) -> &Model {
        self.model
    }

    /// The controller.
    pub fn controller(&self) -> &Controller {
        &self.controller
    }

    /// The speed profile.
    pub fn profile(&self) -> &SpeedProfile {
        self.profile
    }

    /// Whether the steering angle δ is the last state (rate-limited actuator).
    pub fn has_actuator_state(&self) -> bool {
        self.actuator_state
    }

    /// The command of a `yaw_rate_hitch` or `predictor` loop at time t before saturation
    /// \[rad or N m\], from x(t − τ) (`delayed`) and, for the predictor, z(t) (`current`):
    /// −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ), or −(K e^{Âτ} x(t − τ) + K z(t)); 0 while off.
    #[inline]
    fn loop_raw(
        &self,
        c: &LoopCommand,
        t: f64,
        current: &SVector<f64, N>,
        delayed: &SVector<f64, N>,
    ) -> f64 {
        if !c.law.is_on(t) {
            return 0.0;
        }
        let xd = reduced(delayed);
        match c.law.structure {
            Structure::Predictor => {
                let z = Vector4::from_fn(|i, _| current[N - 4 + i]);
                -((c.k_e * xd)[(0, 0)] + (c.k * z)[(0, 0)])
            }
            _ => {
                let g = &c.law.gains;
                -(g.yaw_rate * self.model.yaw_rate(&xd)
                    + g.hitch_angle * xd[trailer_model::HITCH_ANGLE]
                    + g.hitch_rate * self.model.hitch_angle_rate(&xd))
            }
        }
    }

    /// The command u(t) applied by a loop \[rad or N m\] (saturated for braking) and its
    /// raw value.
    #[inline]
    fn loop_command(
        &self,
        c: &LoopCommand,
        t: f64,
        current: &SVector<f64, N>,
        delayed: &SVector<f64, N>,
    ) -> (f64, f64) {
        let raw = self.loop_raw(c, t, current, delayed);
        let applied = match c.limit {
            Some(m) => raw.clamp(-m, m),
            None => raw,
        };
        (applied, raw)
    }

    /// The loop's applied command at t (0 without delayed states) and the braking yaw
    /// moment it makes (0 for steering).
    #[inline]
    fn loop_inputs(&self, t: f64, x: &SVector<f64, N>, x_delayed: &[SVector<f64, N>]) -> f64 {
        match (&self.loop_command, x_delayed.first()) {
            (Some(c), Some(xd)) => self.loop_command(c, t, x, xd).0,
            _ => 0.0,
        }
    }

    /// The braking yaw moment M_z(t) \[N m\] of a loop with differential braking (0
    /// otherwise), given the delayed states.
    #[inline]
    pub fn yaw_moment(&self, t: f64, x: &SVector<f64, N>, x_delayed: &[SVector<f64, N>]) -> f64 {
        match &self.loop_command {
            Some(c) if c.law.actuator == Actuator::DifferentialBraking => {
                self.loop_inputs(t, x, x_delayed)
            }
            _ => 0.0,
        }
    }

    /// The steering command δ_c(t) \[rad\] given the delayed states (eq. 8 with saturation).
    #[inline]
    fn command(&self, t: f64, x_delayed: &[SVector<f64, N>]) -> f64 {
        match x_delayed.first() {
            Some(xd) => self
                .controller
                .steering_angle(t, self.model.yaw_rate(&reduced(xd))),
            None => 0.0,
        }
    }

    /// Inputs at time t given the state x(t) and the delayed states (`x_delayed[0] = x(t − τ)`,
    /// empty in open loop): δ is the actuator state when there is one, else the command.
    #[inline]
    pub fn inputs(&self, t: f64, x: &SVector<f64, N>, x_delayed: &[SVector<f64, N>]) -> Inputs {
        let steering_angle = if self.actuator_state {
            x[N - 1]
        } else if let Some(c) = &self.loop_command {
            if c.law.actuator == Actuator::Steering {
                self.loop_inputs(t, x, x_delayed)
            } else {
                0.0
            }
        } else {
            self.command(t, x_delayed)
        };
        Inputs {
            steering_angle,
            speed: self.profile.speed(t),
            acceleration: self.profile.acceleration(t),
        }
    }

    /// Slip angles at (t, x) with the delayed states for δ.
    pub fn slip_angles(
        &self,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
    ) -> SlipAngles {
        self.model
            .slip_angles(&reduced(x), &self.inputs(t, x, x_delayed))
    }

    /// The places where the right-hand side is continuous but not smooth, as the sign
    /// changes of eight functions: tan α of each axle (the brush law's tan α·|tan α|, eq. 14),
    /// tan²α − tan²α_cr of each axle (the onset of full sliding), and with actuator limits
    /// δ_raw² − δ_max² (saturation) and r² − δ̇_max² (rate limit); for a braking
    /// `yaw_rate_hitch` or `predictor` loop the last two are u_raw(t)² − M_max² and (the
    /// predictor's ż uses u(t − τ)) u_raw(t − τ)² − M_max². A function that cannot change
    /// sign (no sliding limit, no actuator limit) is −1.
    pub fn switching_functions(
        &self,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
    ) -> [f64; SWITCHING_FUNCTIONS] {
        let u = self.inputs(t, x, x_delayed);
        let tan = self.model.slip_angle_tangents(&reduced(x), &u);
        // below the floor a slip has no sign: near straight running all three hover at
        // round-off level, where sign flips are noise and landing on them would never end
        let signed = |t: f64| {
            if t.abs() <= SLIP_TANGENT_FLOOR {
                0.0
            } else {
                t
            }
        };
        let tans = [tan.front, tan.rear, tan.trailer];
        let sliding = |k: usize| {
            let cr = self.tan_critical[k];
            if cr.is_finite() {
                tans[k] * tans[k] - cr * cr
            } else {
                -1.0
            }
        };
        let (saturation, rate) = if let Some(c) = &self.loop_command {
            self.loop_switches(c, t, x, x_delayed)
        } else {
            let actuator = self.controller.actuator();
            let delayed_yaw_rate = x_delayed
                .first()
                .map_or(0.0, |xd| self.model.yaw_rate(&reduced(xd)));
            let raw = self.controller.raw_steering_angle(t, delayed_yaw_rate);
            let rate = if self.actuator_state {
                actuator.rate_switch(self.command(t, x_delayed), x[N - 1])
            } else {
                -1.0
            };
            (actuator.saturation_switch(raw), rate)
        };
        [
            signed(tans[0]),
            signed(tans[1]),
            signed(tans[2]),
            sliding(0),
            sliding(1),
            sliding(2),
            saturation,
            rate,
        ]
    }

    /// The braking limit's switching functions of a loop: u_raw(t)² − M_max² and (predictor)
    /// u_raw(t − τ)² − M_max²; −1 where there is no limit.
    fn loop_switches(
        &self,
        c: &LoopCommand,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
    ) -> (f64, f64) {
        let Some(m) = c.limit else {
            return (-1.0, -1.0);
        };
        let now = x_delayed
            .first()
            .map_or(-1.0, |xd| self.loop_raw(c, t, x, xd).powi(2) - m * m);
        let before = match (c.law.structure, x_delayed) {
            (Structure::Predictor, [xd1, xd2, ..]) => {
                self.loop_raw(c, t - c.law.delay_s, xd1, xd2).powi(2) - m * m
            }
            _ => -1.0,
        };
        (now, before)
    }

    #[inline]
    fn eval(&self, u: &Inputs, yaw_moment: f64, x: &SVector<f64, N>, dx: &mut SVector<f64, N>) {
        let x4 = reduced(x);
        let r = if yaw_moment == 0.0 {
            self.model.rhs4(&x4, u)
        } else {
            self.model.rhs4_with_yaw_moment(&x4, u, yaw_moment)
        };
        dx[0] = r[0];
        dx[1] = r[1];
        dx[2] = r[2];
        dx[3] = r[3];
        if self.kinematics {
            // ψ̇, ẋ_H = V cos ψ − σ1 sin ψ, ẏ_H = V sin ψ + σ1 cos ψ (eq. 5)
            let (sp, cp) = x[4].sin_cos();
            dx[4] = self.model.yaw_rate(&x4);
            dx[5] = u.speed * cp - x[0] * sp;
            dx[6] = u.speed * sp + x[0] * cp;
        }
    }
}

impl<const N: usize> OdeProblem<N> for Plant<'_, N> {
    #[inline]
    fn rhs(&self, t: f64, x: &SVector<f64, N>, dx: &mut SVector<f64, N>) {
        let u = self.inputs(t, x, &[]);
        self.eval(&u, 0.0, x, dx);
        if self.loop_command.is_some() && self.controller.extra_states() == 4 {
            // no delayed states: u ≡ 0, ż = Â z
            let z = Vector4::from_fn(|i, _| x[N - 4 + i]);
            if let Some(c) = &self.loop_command {
                let dz = c.a_hat * z;
                for i in 0..4 {
                    dx[N - 4 + i] = dz[i];
                }
            }
        }
        if self.actuator_state {
            dx[N - 1] = self.controller.actuator().rate(0.0, x[N - 1]);
        }
    }
    fn breakpoints(&self) -> &[f64] {
        &self.breakpoints
    }
    fn switching_count(&self) -> usize {
        SWITCHING_FUNCTIONS
    }
    fn switching(&self, t: f64, x: &SVector<f64, N>, g: &mut [f64]) {
        g.copy_from_slice(&self.switching_functions(t, x, &[]));
    }
}

impl<const N: usize> DdeProblem<N> for Plant<'_, N> {
    fn delays(&self) -> &[f64] {
        &self.delays
    }
    fn history(&self, _t: f64) -> SVector<f64, N> {
        self.history
    }
    #[inline]
    fn rhs(
        &self,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
        dx: &mut SVector<f64, N>,
    ) {
        let u = self.inputs(t, x, x_delayed);
        let yaw_moment = self.yaw_moment(t, x, x_delayed);
        self.eval(&u, yaw_moment, x, dx);
        if let Some(c) = &self.loop_command
            && c.law.structure == Structure::Predictor
        {
            // ż = Â z + B̂ u(t) − e^{Âτ} B̂ u(t − τ)
            let now = self.loop_inputs(t, x, x_delayed);
            let before = match x_delayed {
                [xd1, xd2, ..] => self.loop_command(c, t - c.law.delay_s, xd1, xd2).0,
                _ => 0.0,
            };
            let z = Vector4::from_fn(|i, _| x[N - 4 + i]);
            let dz = c.a_hat * z + c.b_hat * now - c.e_b * before;
            for i in 0..4 {
                dx[N - 4 + i] = dz[i];
            }
        }
        if self.actuator_state {
            let command = self.command(t, x_delayed);
            dx[N - 1] = self.controller.actuator().rate(command, x[N - 1]);
        }
    }
    fn breakpoints(&self) -> &[f64] {
        &self.breakpoints
    }
    fn switching_count(&self) -> usize {
        SWITCHING_FUNCTIONS
    }
    fn switching(&self, t: f64, x: &SVector<f64, N>, x_delayed: &[SVector<f64, N>], g: &mut [f64]) {
        g.copy_from_slice(&self.switching_functions(t, x, x_delayed));
    }
}

/// The run-time data of a loop: the braking limit and, for the predictor, its model's
/// matrices linearised at V(0).
fn loop_command(
    model: &Model,
    profile: &SpeedProfile,
    law: LoopLaw,
) -> Result<LoopCommand, SwayError> {
    let limit = law.limit.max_command(law.actuator, model);
    let mut c = LoopCommand {
        law,
        limit,
        a_hat: Matrix4::zeros(),
        b_hat: Vector4::zeros(),
        k_e: RowVector4::zeros(),
        k: RowVector4::zeros(),
        e_b: Vector4::zeros(),
    };
    if law.structure == Structure::Predictor {
        let speed = profile.speed(0.0);
        let context = || format!("the predictor's model at V = {speed} m/s");
        let prediction = Model::new(law.model_error.apply(model.params()))
            .map_err(|e| SwayError::numerical(context(), e))?;
        let lin = prediction.linearize(speed);
        let e = (lin.a4 * law.delay_s).exp();
        c.a_hat = lin.a4;
        c.b_hat = law.actuator.input_column(&lin);
        c.k = lin.c4 * law.gains.yaw_rate;
        c.k_e = c.k * e;
        c.e_b = e * c.b_hat;
        let finite = c
            .a_hat
            .iter()
            .chain(c.b_hat.iter())
            .chain(c.k_e.iter())
            .chain(c.e_b.iter())
            .all(|v| v.is_finite());
        if !finite {
            return Err(SwayError::numerical(
                context(),
                std::io::Error::other("the linearisation or e^{Âτ} is not finite"),
            ));
        }
    }
    Ok(c)
}
