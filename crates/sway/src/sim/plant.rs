//! The car–trailer model with a speed profile and a steering controller, as an ODE/DDE
//! problem for the [`dde`] solver: 4 states \[σ1, σ2, σ3, θ\] or all 7 \[σ1, σ2, σ3, θ, ψ, x_H, y_H\],
//! plus the steering angle δ as a last state (5 or 8 states) when the controller has a
//! rate-limited actuator (see [`crate::sim::ActuatorLimits`]).

use dde::{DdeProblem, OdeProblem};
use nalgebra::SVector;
use trailer_model::{Inputs, Model, SlipAngles, State4};

use super::{Controller, SpeedProfile};

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
    /// δ(0); otherwise `N` is 4 or 7.
    pub fn new(
        model: &'a Model,
        profile: &'a SpeedProfile,
        controller: Controller,
        x0: SVector<f64, N>,
    ) -> Self {
        let mut breakpoints = profile.breakpoints();
        breakpoints.extend(controller.breakpoints());
        breakpoints.retain(|&b| b > 0.0);
        breakpoints.sort_by(f64::total_cmp);
        breakpoints.dedup();
        let actuator_state = controller.has_actuator_state();
        Self {
            model,
            profile,
            controller,
            actuator_state,
            kinematics: N - usize::from(actuator_state) == 7,
            delays: controller.delay().into_iter().collect(),
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
        }
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
    /// δ_raw² − δ_max² (saturation) and r² − δ̇_max² (rate limit). A function that cannot
    /// change sign (no sliding limit, no actuator limit) is −1.
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
        [
            signed(tans[0]),
            signed(tans[1]),
            signed(tans[2]),
            sliding(0),
            sliding(1),
            sliding(2),
            actuator.saturation_switch(raw),
            rate,
        ]
    }

    #[inline]
    fn eval(&self, u: &Inputs, x: &SVector<f64, N>, dx: &mut SVector<f64, N>) {
        let x4 = reduced(x);
        let r = self.model.rhs4(&x4, u);
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
        self.eval(&u, x, dx);
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
        self.eval(&u, x, dx);
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
