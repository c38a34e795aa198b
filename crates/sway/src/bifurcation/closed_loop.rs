//! The closed loop of eq. (8) as a [`continuation::Problem`] with parameters p = [V, D, τ],
//! any of which may be free: the right-hand side and all its derivatives (Jacobian, ∂f/∂p,
//! second derivatives along two directions, ∂J/∂p·a) exact by dual numbers.
//!
//! f(x, x_τ; V, D, τ) = F(x, u; V) with the command u = −D·c·x_τ (eq. 8; c·x = ψ̇ of eq. 5,
//! linear in x) and F the plant's reduced right-hand side ([`trailer_model::Plant::rhs`], eq. (5)–(6) for
//! the paper's [`Model`]). The delay τ enters only through the argument x_τ = x(t − τ)
//! (reported by [`Problem::delay_dp`]); f itself does not depend on it.
//!
//! **Any plant.** The loop is generic over the plant `P: `[`Vehicle<N>`] (N reduced
//! states): the paper's [`Model`] keeps its own switching functions (slip angles) and guard,
//! as its pipelines have always computed them; every [`trailer_model::VehicleModel`] gets
//! them from [`trailer_model::Plant::switching_functions`] and
//! [`trailer_model::Plant::guard_values`].
//!
//! **Controller structures** (the [`LoopLaw`]'s): the command may also feed back the
//! hitch angle and its rate, u = −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ) (`yaw_rate_hitch`, θ̇ the
//! plant's nonlinear hitch-angle rate, as the simulations measure it), and drive either the
//! steering angle δ \[rad\] or a yaw moment M_z \[N m\] on the tractor
//! ([`trailer_model::Plant::rhs_with_yaw_moment`], differential braking). The braking limit
//! ([`sway_model::law::Actuator::limit`]) is **not** modelled in continuation (the moment is
//! unsaturated); the `predictor` structure (a distributed delay) is not a problem of this
//! module.

use continuation::Problem;
use nalgebra::SVector;
use num_dual::{Dual64, DualNum, DualSVec64, HyperDual64, jacobian};
use trailer_model::{Inputs, Model};

use sway_model::law::{Actuator, LoopLaw};
use sway_model::vehicle::{LossOfControl, Vehicle, actuated_rhs, input_jacobian};

/// index of the speed V \[m/s\] in the parameter vector
pub const SPEED: usize = 0;
/// index of the feedback gain D \[s\] in the parameter vector
pub const GAIN: usize = 1;
/// index of the feedback delay τ \[s\] in the parameter vector
pub const DELAY: usize = 2;

/// The closed loop as a continuation problem, parameters p = [V, D, τ] (indices [`SPEED`],
/// [`GAIN`], [`DELAY`]); any of them may be free. The gain D and the delay τ are read from
/// p; the [`LoopLaw`] it was built with fixes the structure (a DDE with one delay p\[τ\] if
/// its τ > 0, an ODE with instantaneous feedback otherwise), the default parameter vector
/// ([`ClosedLoop::parameters`]), the actuator and the hitch gains (K_θ, D_θ).
/// Generic over the plant `P` with `N` reduced states (default: the paper's [`Model`]).
#[derive(Debug, Clone, Copy)]
pub struct ClosedLoop<'a, P = Model, const N: usize = 4> {
    model: &'a P,
    law: LoopLaw,
    /// (K_θ, D_θ) fed back ([`LoopLaw::hitch_gains`])
    hitch: (f64, f64),
    delayed: bool,
    /// gradient c of the yaw rate ψ̇ = c·x (linear in x, eq. 5)
    yaw_gradient: [f64; N],
}

impl<'a, P: Vehicle<N>, const N: usize> ClosedLoop<'a, P, N> {
    /// The closed loop of `model` with the command u = −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ) of
    /// `law` on its actuator (the paper's δ = −D·ψ̇(t − τ) for [`LoopLaw::paper`]). The
    /// predictor's structure is not a problem of this module: its command is that of
    /// `yaw_rate` here (callers refuse it first).
    pub fn new(model: &'a P, law: LoopLaw) -> Self {
        let e = |i: usize| SVector::<f64, N>::from_fn(|k, _| if k == i { 1.0 } else { 0.0 });
        let yaw_gradient = std::array::from_fn(|i| model.yaw_rate(&e(i)));
        Self {
            model,
            law,
            hitch: law.hitch_gains(),
            delayed: law.is_delayed(),
            yaw_gradient,
        }
    }

    /// The model.
    pub fn model(&self) -> &'a P {
        self.model
    }

    /// The law it was built with.
    pub fn law(&self) -> LoopLaw {
        self.law
    }

    /// parameter vector [V, D, τ] with the built-in feedback
    pub fn parameters(&self, speed: f64) -> Vec<f64> {
        vec![speed, self.law.gains.yaw_rate, self.law.delay_s]
    }

    /// offset of the fed-back state in the stacked arguments (x(t − τ) or x(t))
    fn feedback_offset(&self) -> usize {
        if self.delayed { N } else { 0 }
    }

    /// number of stacked arguments, N·(k + 1)
    #[doc(hidden)] // pub for tests/unit
    pub fn n_args(&self) -> usize {
        N + self.feedback_offset()
    }

    /// yaw rate c·v of the fed-back part of stacked arguments `v`
    fn fed_back_yaw(&self, v: &[f64]) -> f64 {
        let o = self.feedback_offset();
        (0..N).map(|k| self.yaw_gradient[k] * v[o + k]).sum()
    }

    /// Only the yaw rate is fed back (the command is linear in the state).
    #[inline]
    fn yaw_rate_only(&self) -> bool {
        self.hitch == (0.0, 0.0)
    }

    /// the fed-back state of stacked arguments `v` with its directions a and b (hyper-dual;
    /// b = None: 0)
    fn fed_back_hyper(&self, v: &[f64], a: &[f64], b: Option<&[f64]>) -> SVector<HyperDual64, N> {
        let o = self.feedback_offset();
        SVector::from_fn(|k, _| {
            HyperDual64::new(v[o + k], a[o + k], b.map_or(0.0, |b| b[o + k]), 0.0)
        })
    }

    /// K_θ·θ + D_θ·θ̇ of the fed-back state, for any number type
    /// ([`LoopLaw::output_beyond_yaw_rate`])
    fn hitch_term<T: DualNum<Primitive = f64> + Copy>(&self, xf: &SVector<T, N>) -> T {
        self.law.output_beyond_yaw_rate(self.model, xf)
    }

    /// K_θ·θ + D_θ·θ̇ of the fed-back part of stacked arguments `v`
    fn hitch_value(&self, v: &[f64]) -> f64 {
        let o = self.feedback_offset();
        self.hitch_term(&SVector::<f64, N>::from_fn(|k, _| v[o + k]))
    }

    /// the command u at stacked arguments `v` with gain D
    fn command(&self, v: &[f64], gain: f64) -> f64 {
        if self.yaw_rate_only() {
            -gain * self.fed_back_yaw(v)
        } else {
            -(gain * self.fed_back_yaw(v) + self.hitch_value(v))
        }
    }

    /// the command along args + ε1·a + ε2·b (b = None: 0) with gain D
    fn command_hyper(&self, args: &[f64], a: &[f64], b: Option<&[f64]>, gain: f64) -> HyperDual64 {
        if self.yaw_rate_only() {
            HyperDual64::new(
                -gain * self.fed_back_yaw(args),
                -gain * self.fed_back_yaw(a),
                b.map_or(0.0, |b| -gain * self.fed_back_yaw(b)),
                0.0,
            )
        } else {
            let y = HyperDual64::new(
                self.fed_back_yaw(args),
                self.fed_back_yaw(a),
                b.map_or(0.0, |b| self.fed_back_yaw(b)),
                0.0,
            );
            -(y * gain + self.hitch_term(&self.fed_back_hyper(args, a, b)))
        }
    }

    fn state(x: &[f64]) -> SVector<f64, N> {
        SVector::<f64, N>::from_fn(|k, _| x[k])
    }

    /// F(x, u; V) at constant speed, for any number type
    #[inline]
    fn model_rhs<T: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<T, N>,
        command: T,
        speed: T,
    ) -> SVector<T, N> {
        actuated_rhs(self.model, x, command, speed, self.law.actuator)
    }

    /// inputs at real arguments (for the switching functions and the guard; a yaw moment
    /// does not enter the slip angles)
    fn inputs(&self, args: &[f64], p: &[f64]) -> Inputs {
        Inputs {
            steering_angle: match self.law.actuator {
                Actuator::Steering => self.command(args, p[GAIN]),
                Actuator::DifferentialBraking => 0.0,
            },
            speed: p[SPEED],
            acceleration: 0.0,
        }
    }

    /// The simulations' validity guard ([`crate::sim::ValidityGuard`]) at one point of a
    /// solution: `args` the stacked arguments (x(t), and x(t − τ) if delayed), `p` = [V, D, τ].
    /// The first tripped condition (in [`LossOfControl`]'s order), None while the model is
    /// valid: a tractor axle sliding fully (|α| > α_cr, eq. 15) or a wheel's longitudinal
    /// velocity at or below 0.
    pub fn loss_of_control(&self, args: &[f64], p: &[f64]) -> Option<LossOfControl> {
        let u = self.inputs(args, p);
        self.model.loop_loss_of_control(&Self::state(args), &u)
    }

    /// The command u(t) \[rad or N m\] at stacked arguments `args`, `p` = [V, D, τ].
    pub fn command_at(&self, args: &[f64], p: &[f64]) -> f64 {
        self.command(args, p[GAIN])
    }

    /// state x + ε1·a + ε2·b as hyper-dual numbers
    fn hyper_state(x: &[f64], a: &[f64], b: &[f64]) -> SVector<HyperDual64, N> {
        SVector::from_fn(|k, _| HyperDual64::new(x[k], a[k], b[k], 0.0))
    }
}

impl<P: Vehicle<N>, const N: usize> Problem for ClosedLoop<'_, P, N> {
    fn dim(&self) -> usize {
        N
    }
    fn n_delays(&self) -> usize {
        usize::from(self.delayed)
    }
    fn delay(&self, _j: usize, p: &[f64]) -> f64 {
        p[DELAY]
    }
    /// ∂τ/∂p: 1 for the delay parameter itself, 0 for V and D
    fn delay_dp(&self, _j: usize, _p: &[f64], ip: usize) -> f64 {
        if ip == DELAY { 1.0 } else { 0.0 }
    }
    fn rhs(&self, args: &[f64], p: &[f64], f: &mut [f64]) {
        let command = self.command(args, p[GAIN]);
        let r = self.model_rhs(&Self::state(args), command, p[SPEED]);
        f[..N].copy_from_slice(r.as_slice());
    }
    /// exact: ∂F/∂(x, u) by dual numbers, then the chain rule through the command
    /// u = −(D·c·x_τ + K_θ·θ_τ + D_θ·θ̇(x_τ)) (the last term by an N-component dual pass)
    fn jacobian(&self, args: &[f64], p: &[f64], jac: &mut [f64]) {
        let (gain, speed) = (p[GAIN], p[SPEED]);
        let command = self.command(args, gain);
        let x = Self::state(args);
        let (jx, ju) = match self.law.actuator {
            Actuator::Steering => self.model.steering_jacobian(&x, command, speed),
            a => input_jacobian(self.model, &x, command, speed, a),
        };
        // ∂u/∂x_τ
        let mut row = [0.0; N];
        if self.yaw_rate_only() {
            for (k, r) in row.iter_mut().enumerate() {
                *r = -gain * self.yaw_gradient[k];
            }
        } else {
            let o = self.feedback_offset();
            let xf = SVector::<f64, N>::from_fn(|k, _| args[o + k]);
            let (_, gh) = jacobian(
                |z: SVector<DualSVec64<N>, N>| {
                    SVector::<DualSVec64<N>, 1>::new(self.hitch_term(&z))
                },
                &xf,
            );
            for (k, r) in row.iter_mut().enumerate() {
                *r = -(gain * self.yaw_gradient[k] + gh[(0, k)]);
            }
        }
        let (nc, off) = (self.n_args(), self.feedback_offset());
        jac[..N * nc].iter_mut().for_each(|v| *v = 0.0);
        for i in 0..N {
            for k in 0..N {
                jac[i * nc + k] = jx[(i, k)];
            }
            for k in 0..N {
                jac[i * nc + off + k] += ju[i] * row[k];
            }
        }
    }
    /// exact (dual numbers); ∂f/∂τ = 0: the delay acts only through x(t − τ)
    fn dfdp(&self, args: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
        let command = self.command(args, p[GAIN]);
        let (command, speed) = match ip {
            SPEED => (Dual64::from(command), Dual64::new(p[SPEED], 1.0)),
            GAIN => (
                Dual64::new(command, -self.fed_back_yaw(args)),
                Dual64::from(p[SPEED]),
            ),
            _ => {
                out[..N].iter_mut().for_each(|v| *v = 0.0);
                return;
            }
        };
        let x = Self::state(args).map(Dual64::from);
        let r = self.model_rhs(&x, command, speed);
        for i in 0..N {
            out[i] = r[i].eps;
        }
    }
    /// exact: one evaluation with hyper-dual numbers along (a, b), the command along them too
    fn second_derivative(
        &self,
        args: &[f64],
        p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> continuation::Result<()> {
        let x = Self::hyper_state(args, a, b);
        let command = self.command_hyper(args, a, Some(b), p[GAIN]);
        let r = self.model_rhs(&x, command, HyperDual64::from(p[SPEED]));
        for i in 0..N {
            out[i] = r[i].eps1eps2;
        }
        Ok(())
    }
    /// exact: hyper-dual numbers with ε1 along `a` and ε2 along p_ip; 0 for the delay
    /// (f does not depend on τ explicitly)
    fn jacobian_dp(
        &self,
        args: &[f64],
        p: &[f64],
        ip: usize,
        a: &[f64],
        out: &mut [f64],
    ) -> continuation::Result<()> {
        let zeros = [0.0; N];
        let gain = p[GAIN];
        let (command, speed) = match ip {
            SPEED => {
                let c = self.command_hyper(args, a, None, gain);
                (c, HyperDual64::new(p[SPEED], 0.0, 1.0, 0.0))
            }
            // u = −((D + ε2)·(y + ε1·y_a) + h(x_τ + ε1·a_τ))
            GAIN => {
                let c = self.command_hyper(args, a, None, gain);
                let (yaw, yaw_a) = (self.fed_back_yaw(args), self.fed_back_yaw(a));
                (
                    HyperDual64::new(c.re, c.eps1, -yaw, -yaw_a),
                    HyperDual64::from(p[SPEED]),
                )
            }
            _ => {
                out[..N].iter_mut().for_each(|v| *v = 0.0);
                return Ok(());
            }
        };
        let x = Self::hyper_state(args, a, &zeros);
        let r = self.model_rhs(&x, command, speed);
        for i in 0..N {
            out[i] = r[i].eps1eps2;
        }
        Ok(())
    }
    /// the brush tire is only C¹ at zero slip, where the straight-running equilibrium sits:
    /// no normal form there (criticality comes from the cycles)
    fn smoothness(&self) -> continuation::Smoothness {
        continuation::Smoothness::C1AtKinks
    }
    fn n_switching(&self) -> usize {
        self.model.loop_switching_count()
    }
    /// the plant's switching functions at x(t) with the command of the loop
    /// ([`Vehicle::loop_switching`]; for the paper's model the slip angles α_F, α_R, α_T
    /// and |α| − α_cr)
    fn switching(&self, args: &[f64], p: &[f64], g: &mut [f64]) {
        let u = self.inputs(args, p);
        self.model.loop_switching(&Self::state(args), &u, g);
    }
}
