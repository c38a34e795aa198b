//! The closed loop of eq. (8) as a [`continuation::Problem`] with parameters p = [V, D, τ],
//! any of which may be free: the right-hand side and all its derivatives (Jacobian, ∂f/∂p,
//! second derivatives along two directions, ∂J/∂p·a) exact by dual numbers.
//!
//! f(x, x_τ; V, D, τ) = F(x, δ; V) with δ = −D·c·x_τ (eq. 8; c·x = ψ̇ of eq. 5, linear in x)
//! and F the reduced model of eq. (5)–(6). The delay τ enters only through the argument
//! x_τ = x(t − τ) (reported by [`Problem::delay_dp`]); f itself does not depend on it.

use continuation::Problem;
use nalgebra::SVector;
use num_dual::{Dual64, DualNum, DualSVec64, HyperDual64, jacobian};
use serde::{Deserialize, Serialize};
use trailer_model::{Inputs, Model, State4};

use crate::sim::LossOfControl;

/// index of the speed V \[m/s\] in the parameter vector
pub const SPEED: usize = 0;
/// index of the feedback gain D \[s\] in the parameter vector
pub const GAIN: usize = 1;
/// index of the feedback delay τ \[s\] in the parameter vector
pub const DELAY: usize = 2;

/// The steering feedback δ(t) = −D·ψ̇(t − τ) of eq. (8).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Feedback {
    /// gain D \[s\]
    pub gain_d_s: f64,
    /// delay τ \[s\]
    pub delay_s: f64,
}

impl Feedback {
    /// no steering control (δ ≡ 0)
    pub const OPEN_LOOP: Feedback = Feedback {
        gain_d_s: 0.0,
        delay_s: 0.0,
    };

    /// The closed loop is a delay equation: τ > 0 (for every gain D, also D = 0, so that
    /// the structure does not change when D is continued through 0).
    pub fn is_delayed(&self) -> bool {
        self.delay_s > 0.0
    }
}

/// The closed loop as a continuation problem, parameters p = [V, D, τ] (indices [`SPEED`],
/// [`GAIN`], [`DELAY`]); any of them may be the free parameter. The gain and the delay are
/// read from p; the [`Feedback`] it was built with only fixes the structure (a DDE with one
/// delay p\[τ\] if τ > 0, an ODE with instantaneous feedback otherwise) and the default
/// parameter vector ([`ClosedLoop::parameters`]).
#[derive(Debug, Clone, Copy)]
pub struct ClosedLoop<'a> {
    model: &'a Model,
    feedback: Feedback,
    delayed: bool,
    /// gradient c of the yaw rate ψ̇ = c·x (linear in x, eq. 5)
    yaw_gradient: [f64; 4],
}

impl<'a> ClosedLoop<'a> {
    /// The closed loop of `model` with `feedback`.
    pub fn new(model: &'a Model, feedback: Feedback) -> Self {
        let e = |i: usize| State4::from_fn(|k, _| if k == i { 1.0 } else { 0.0 });
        let yaw_gradient = [0, 1, 2, 3].map(|i| model.yaw_rate(&e(i)));
        Self {
            model,
            feedback,
            delayed: feedback.is_delayed(),
            yaw_gradient,
        }
    }

    /// The model.
    pub fn model(&self) -> &'a Model {
        self.model
    }

    /// The feedback it was built with.
    pub fn feedback(&self) -> Feedback {
        self.feedback
    }

    /// parameter vector [V, D, τ] with the built-in feedback
    pub fn parameters(&self, speed: f64) -> Vec<f64> {
        vec![speed, self.feedback.gain_d_s, self.feedback.delay_s]
    }

    /// offset of the fed-back state in the stacked arguments (x(t − τ) or x(t))
    fn feedback_offset(&self) -> usize {
        if self.delayed { 4 } else { 0 }
    }

    /// number of stacked arguments, 4·(k + 1)
    fn n_args(&self) -> usize {
        4 + self.feedback_offset()
    }

    /// yaw rate c·v of the fed-back part of stacked arguments `v`
    fn fed_back_yaw(&self, v: &[f64]) -> f64 {
        let o = self.feedback_offset();
        (0..4).map(|k| self.yaw_gradient[k] * v[o + k]).sum()
    }

    fn state(x: &[f64]) -> State4 {
        State4::new(x[0], x[1], x[2], x[3])
    }

    /// F(x, δ; V) of eq. (5)–(6) at constant speed, for any number type
    fn model_rhs<T: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<T>,
        steering: T,
        speed: T,
    ) -> State4<T> {
        let u = Inputs {
            steering_angle: steering,
            speed,
            acceleration: T::from(0.0),
        };
        self.model.rhs4(x, &u)
    }

    /// inputs at real arguments (for the switching functions)
    fn inputs(&self, args: &[f64], p: &[f64]) -> Inputs {
        Inputs {
            steering_angle: -p[GAIN] * self.fed_back_yaw(args),
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
        let x = Self::state(args);
        let (tan_front, tan_rear) = self.model.axle_slip_tangents(&x, &u);
        let (cr_front, cr_rear) = self.model.critical_slip_tangents();
        let front_wheel_speed = {
            let lateral_front =
                x[0] + self.model.yaw_rate(&x) * self.model.params().tractor.front_axle;
            let (sd, cd) = u.steering_angle.sin_cos();
            u.speed * cd + lateral_front * sd
        };
        if tan_front > cr_front {
            Some(LossOfControl::FrontAxleSliding)
        } else if tan_rear > cr_rear {
            Some(LossOfControl::RearAxleSliding)
        } else if front_wheel_speed <= 0.0 {
            Some(LossOfControl::FrontWheelStopped)
        } else if u.speed <= 0.0 {
            Some(LossOfControl::RearWheelStopped)
        } else if self.model.trailer_wheel_speed(&x, u.speed) <= 0.0 {
            Some(LossOfControl::TrailerWheelStopped)
        } else {
            None
        }
    }

    /// state x + ε1·a + ε2·b as hyper-dual numbers
    fn hyper_state(x: &[f64], a: &[f64], b: &[f64]) -> State4<HyperDual64> {
        State4::from_fn(|k, _| HyperDual64::new(x[k], a[k], b[k], 0.0))
    }
}

impl Problem for ClosedLoop<'_> {
    fn dim(&self) -> usize {
        4
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
        let steering = -p[GAIN] * self.fed_back_yaw(args);
        let r = self.model_rhs(&Self::state(args), steering, p[SPEED]);
        f[..4].copy_from_slice(r.as_slice());
    }
    /// exact: ∂F/∂(x, δ) by a 5-component dual vector, then the chain rule through the
    /// linear δ = −D·c·x_τ
    fn jacobian(&self, args: &[f64], p: &[f64], jac: &mut [f64]) {
        let (gain, speed) = (p[GAIN], p[SPEED]);
        let delta = -gain * self.fed_back_yaw(args);
        let z = SVector::<f64, 5>::new(args[0], args[1], args[2], args[3], delta);
        let (_, j) = jacobian(
            |z: SVector<DualSVec64<5>, 5>| {
                let x = State4::new(z[0], z[1], z[2], z[3]);
                self.model_rhs(&x, z[4], DualSVec64::<5>::from(speed))
            },
            &z,
        );
        let (nc, off) = (self.n_args(), self.feedback_offset());
        jac[..4 * nc].iter_mut().for_each(|v| *v = 0.0);
        for i in 0..4 {
            for k in 0..4 {
                jac[i * nc + k] = j[(i, k)];
            }
            for k in 0..4 {
                jac[i * nc + off + k] += j[(i, 4)] * (-gain * self.yaw_gradient[k]);
            }
        }
    }
    /// exact (dual numbers); ∂f/∂τ = 0: the delay acts only through x(t − τ)
    fn dfdp(&self, args: &[f64], p: &[f64], ip: usize, out: &mut [f64]) {
        let yaw = self.fed_back_yaw(args);
        let (steering, speed) = match ip {
            SPEED => (Dual64::from(-p[GAIN] * yaw), Dual64::new(p[SPEED], 1.0)),
            GAIN => (Dual64::new(-p[GAIN] * yaw, -yaw), Dual64::from(p[SPEED])),
            _ => {
                out[..4].iter_mut().for_each(|v| *v = 0.0);
                return;
            }
        };
        let x = Self::state(args).map(Dual64::from);
        let r = self.model_rhs(&x, steering, speed);
        for i in 0..4 {
            out[i] = r[i].eps;
        }
    }
    /// exact: one evaluation with hyper-dual numbers along (a, b); δ is linear in the
    /// arguments, so its directions are −D·c·a_τ and −D·c·b_τ
    fn second_derivative(
        &self,
        args: &[f64],
        p: &[f64],
        a: &[f64],
        b: &[f64],
        out: &mut [f64],
    ) -> continuation::Result<()> {
        let gain = p[GAIN];
        let x = Self::hyper_state(args, a, b);
        let steering = HyperDual64::new(
            -gain * self.fed_back_yaw(args),
            -gain * self.fed_back_yaw(a),
            -gain * self.fed_back_yaw(b),
            0.0,
        );
        let r = self.model_rhs(&x, steering, HyperDual64::from(p[SPEED]));
        for i in 0..4 {
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
        let (gain, yaw, yaw_a) = (p[GAIN], self.fed_back_yaw(args), self.fed_back_yaw(a));
        let (steering, speed) = match ip {
            SPEED => (
                HyperDual64::new(-gain * yaw, -gain * yaw_a, 0.0, 0.0),
                HyperDual64::new(p[SPEED], 0.0, 1.0, 0.0),
            ),
            // δ = −(D + ε2)·(y + ε1·y_a)
            GAIN => (
                HyperDual64::new(-gain * yaw, -gain * yaw_a, -yaw, -yaw_a),
                HyperDual64::from(p[SPEED]),
            ),
            _ => {
                out[..4].iter_mut().for_each(|v| *v = 0.0);
                return Ok(());
            }
        };
        let x = Self::hyper_state(args, a, &[0.0; 4]);
        let r = self.model_rhs(&x, steering, speed);
        for i in 0..4 {
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
        6
    }
    /// slip angles α_F, α_R, α_T (the brush tire is only C¹ at α = 0) and |α| − α_cr
    /// (sliding starts, the force curve's second derivative jumps)
    fn switching(&self, args: &[f64], p: &[f64], g: &mut [f64]) {
        let u = self.inputs(args, p);
        let a = self.model.slip_angles(&Self::state(args), &u);
        let cr = self.model.critical_slip_angles();
        g[0] = a.front;
        g[1] = a.rear;
        g[2] = a.trailer;
        g[3] = a.front.abs() - cr.front;
        g[4] = a.rear.abs() - cr.rear;
        g[5] = a.trailer.abs() - cr.trailer;
    }
}

#[cfg(test)]
mod tests;
