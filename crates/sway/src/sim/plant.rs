//! The car–trailer model with a speed profile and a steering controller, as an ODE/DDE
//! problem for the [`dde`] solver ([`SimProblem`]), for any plant
//! ([`trailer_model::Plant<M>`] with M reduced states, through [`Vehicle`]). The state of
//! the problem is, in this order: the M reduced states (\[σ1, σ2, σ3, θ\] and the plant's own,
//! e.g. the lagged slips α′ of relaxing axles), the kinematic states \[ψ, x_H, y_H\] when the
//! path is wanted, the steering angle δ when the controller has a rate-limited actuator (see
//! [`crate::sim::ActuatorLimits`]), or the predictor's integral z as the last four states (see
//! [`sway_model::law::table::ControllerTable::Predictor`]). For the paper's [`Model`] (M = 4) that is 4 or 7 states, 5 or 8
//! with a rate-limited actuator, 8 or 11 with a predictor.

use dde::{DdeProblem, OdeProblem};
use nalgebra::{Matrix4, RowVector4, SVector, Vector4};
use sway_model::vehicle::Vehicle;
use trailer_model::{HITCH_ANGLE, Inputs, Model, SlipAngles, State4};

use super::{SpeedProfile, SteeringInput};
use crate::SwayError;
use sway_model::law::{Actuator, ActuatorLimits, LoopLaw, Structure};

/// The plant or the speed profile of a [`SimProblem`]: borrowed from the caller (the
/// simulations, which keep their own for the run) or owned ([`SimProblem::new_owned`]: a
/// problem that lives on its own, as the FMU's engine between two calls of the importer).
#[derive(Debug, Clone)]
enum Kept<'a, T> {
    Borrowed(&'a T),
    Owned(T),
}

impl<T> std::ops::Deref for Kept<'_, T> {
    type Target = T;
    #[inline]
    fn deref(&self) -> &T {
        match self {
            Kept::Borrowed(t) => t,
            Kept::Owned(t) => t,
        }
    }
}

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

/// The closed (or open) loop: the plant `P` (M reduced states; the paper's eq. 5–7 for
/// [`Model`]) with V(t), V̇(t) from a [`SpeedProfile`] and the command from a [`LoopLaw`]
/// (eq. 8; none in open loop), as an `N`-state problem (the layout in the module docs). Implements
/// [`OdeProblem`] (δ ≡ 0) and [`DdeProblem`] (δ = −D·ψ̇(t − τ)).
#[derive(Debug, Clone)]
pub struct SimProblem<'a, P, const M: usize, const N: usize> {
    plant: Kept<'a, P>,
    profile: Kept<'a, SpeedProfile>,
    controller: Option<LoopLaw>,
    /// x\[N − 1\] is the steering angle δ (rate-limited actuator)
    actuator_state: bool,
    /// the kinematic states ψ, x_H, y_H are x\[M..M + 3\]
    kinematics: bool,
    /// number of the plant's switching functions (the controller's two follow)
    plant_switching: usize,
    delays: Vec<f64>,
    breakpoints: Vec<f64>,
    /// the constant initial function x(t) = x0 for t ≤ 0
    history: SVector<f64, N>,
    /// `yaw_rate_hitch` and `predictor`
    loop_command: Option<LoopCommand>,
    /// a steering input added to the law's command (none by default)
    steering: SteeringInput,
    /// inputs held by a co-simulation master (none by default)
    held: HeldInputs,
}

/// Inputs that a co-simulation master holds constant between two communication points (the
/// FMU's inputs, `sway-fmu`), applied on top of the run's own speed profile, law and
/// steering input. All zero (none) by default; a change between two integration calls is a
/// jump of the right-hand side, which the solver must be told of
/// ([`dde::OdeSolver::input_jump`], [`dde::DdeSolver::input_jump`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HeldInputs {
    /// the forward speed V \[m/s\] in place of the profile's, at the time `speed_from_s`,
    /// changing at `acceleration_mps2` while held; `None`: the profile's V(t) and V̇(t)
    pub speed_mps: Option<f64>,
    /// V̇ \[m/s²\] while the speed is held: V(t) = `speed_mps` + V̇·(t − `speed_from_s`),
    /// and V̇ enters the equations of motion (eq. 6) as the profile's does. 0 (the default):
    /// V held constant, as an FMU's master holds it; negative when braking (the sway
    /// assist)
    pub acceleration_mps2: f64,
    /// the time \[s\] at which the held speed is `speed_mps` (only read when
    /// `acceleration_mps2` is not 0)
    pub speed_from_s: f64,
    /// a steering angle δ \[rad\] added to the law's command and the steering input
    pub steering_angle_rad: f64,
    /// a yaw moment M_z \[N m\] on the tractor (differential braking), added to a braking
    /// loop's
    pub yaw_moment_nm: f64,
    /// a lateral force \[N\] on the trailer at its centre of gravity, positive to its left
    /// (crosswind; [`trailer_model::Model::trailer_force_response`])
    pub trailer_lateral_force_n: f64,
}

/// The paper's model as a simulation problem (the name of [`SimProblem`] before it took any
/// plant).
#[deprecated(note = "use `SimProblem<'a, Model, 4, N>`")]
pub type Plant<'a, const N: usize> = SimProblem<'a, Model, 4, N>;

/// Number of switching functions of a [`SimProblem`] of the paper's model (see
/// [`SimProblem::switching_functions`]).
pub const SWITCHING_FUNCTIONS: usize = 8;

/// The reduced state \[σ1, σ2, σ3, θ\] of the paper's model: the first four states.
#[inline]
pub fn reduced<const N: usize>(x: &SVector<f64, N>) -> State4 {
    State4::new(x[0], x[1], x[2], x[3])
}

/// The first M states of an N-state vector (the reduced state of an M-state plant).
#[inline]
pub fn reduced_state<const M: usize, const N: usize>(x: &SVector<f64, N>) -> SVector<f64, M> {
    SVector::<f64, M>::from_fn(|i, _| x[i])
}

impl<'a, P: Vehicle<M>, const M: usize, const N: usize> SimProblem<'a, P, M, N> {
    /// A problem starting from `x0` (also the history for t ≤ 0). `N` is M (+ 3 for the
    /// kinematic states) + the controller's states ([`LoopLaw::extra_states`]): with a
    /// rate-limited controller ([`LoopLaw::has_actuator_state`]) `x0[N − 1]` is δ(0), with a
    /// predictor `x0[N − 4..]` is z(0).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if `N` fits neither layout, or if a predictor's model (the
    /// vehicle with its [`crate::sim::ModelError`]) is not a valid vehicle or its
    /// linearisation is not finite.
    pub fn new(
        plant: &'a P,
        profile: &'a SpeedProfile,
        controller: Option<LoopLaw>,
        x0: SVector<f64, N>,
    ) -> Result<Self, SwayError> {
        Self::kept(
            Kept::Borrowed(plant),
            Kept::Borrowed(profile),
            controller,
            x0,
        )
    }

    /// A problem of its own plant and profile ([`SimProblem::new`] otherwise): one that
    /// outlives the code that made it, as the FMU's engine does between two calls of the
    /// importer.
    ///
    /// # Errors
    /// As [`SimProblem::new`].
    pub fn new_owned(
        plant: P,
        profile: SpeedProfile,
        controller: Option<LoopLaw>,
        x0: SVector<f64, N>,
    ) -> Result<SimProblem<'static, P, M, N>, SwayError>
    where
        P: 'static,
    {
        SimProblem::kept(Kept::Owned(plant), Kept::Owned(profile), controller, x0)
    }

    fn kept(
        plant: Kept<'a, P>,
        profile: Kept<'a, SpeedProfile>,
        controller: Option<LoopLaw>,
        x0: SVector<f64, N>,
    ) -> Result<Self, SwayError> {
        let extra = controller.map_or(0, |l| l.extra_states());
        let kinematics = match N.checked_sub(extra) {
            Some(s) if s == M => false,
            Some(s) if s == M + 3 => true,
            _ => {
                return Err(SwayError::numerical(
                    format!(
                        "simulation problem with {N} states for a {M}-state plant and \
                         {extra} controller states"
                    ),
                    std::io::Error::other(format!(
                        "expected {} or {} states",
                        M + extra,
                        M + 3 + extra
                    )),
                ));
            }
        };
        let loop_command = match controller {
            Some(law) if !law.is_paper_structure() => {
                Some(loop_command(plant.paper_model(), &profile, law)?)
            }
            _ => None,
        };
        let mut breakpoints = profile.breakpoints();
        breakpoints.extend(controller.iter().flat_map(LoopLaw::breakpoints));
        breakpoints.retain(|&b| b > 0.0);
        breakpoints.sort_by(f64::total_cmp);
        breakpoints.dedup();
        let actuator_state = controller.is_some_and(|l| l.has_actuator_state());
        let plant_switching = plant.switching_count();
        let delays = match (controller.map(|l| l.delay_s), &loop_command) {
            // u(t − τ) in ż needs x(t − 2τ)
            (Some(tau), Some(c)) if c.law.structure == Structure::Predictor => vec![tau, 2.0 * tau],
            (d, _) => d.into_iter().collect(),
        };
        Ok(Self {
            plant,
            profile,
            controller,
            actuator_state,
            kinematics,
            plant_switching,
            delays,
            breakpoints,
            history: x0,
            loop_command,
            steering: SteeringInput::None,
            held: HeldInputs::default(),
        })
    }

    /// This problem with the steering input `steering` added to the law's command (its
    /// jumps and kinks become breakpoints).
    #[must_use]
    pub fn with_steering(mut self, steering: SteeringInput) -> Self {
        self.breakpoints.extend(steering.breakpoints());
        self.breakpoints.retain(|&b| b > 0.0);
        self.breakpoints.sort_by(f64::total_cmp);
        self.breakpoints.dedup();
        self.steering = steering;
        self
    }

    /// Holds `held` from now on (see [`HeldInputs`]).
    pub fn set_held_inputs(&mut self, held: HeldInputs) {
        self.held = held;
    }

    /// The inputs held by a co-simulation master.
    pub fn held_inputs(&self) -> &HeldInputs {
        &self.held
    }

    /// The plant.
    pub fn plant(&self) -> &P {
        &self.plant
    }

    /// The controller.
    pub fn controller(&self) -> Option<&LoopLaw> {
        self.controller.as_ref()
    }

    /// The steering limits of the paper's loop (none without a controller).
    #[inline]
    fn steering_limits(&self) -> ActuatorLimits {
        self.controller
            .as_ref()
            .map_or(ActuatorLimits::NONE, |l| l.steering_limits)
    }

    /// The speed profile.
    pub fn profile(&self) -> &SpeedProfile {
        &self.profile
    }

    /// Whether the steering angle δ is the last state (rate-limited actuator).
    pub fn has_actuator_state(&self) -> bool {
        self.actuator_state
    }

    /// Whether the kinematic states ψ, x_H, y_H are x\[M..M + 3\].
    pub fn has_kinematics(&self) -> bool {
        self.kinematics
    }

    /// The plant's reduced state of x.
    #[inline]
    fn xr(x: &SVector<f64, N>) -> SVector<f64, M> {
        reduced_state::<M, N>(x)
    }

    /// The command of a `yaw_rate_hitch` or `predictor` loop at time t before saturation
    /// \[rad or N m\], from x(t − τ) (`delayed`) and, for the predictor, z(t) (`current`):
    /// −(D·ψ̇ + K_θ·θ + D_θ·θ̇)(t − τ), or −(K e^{Âτ} x(t − τ) + K z(t)); 0 while off. The
    /// predictor's model is the paper's model of the vehicle: it reads the first four states.
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
        match c.law.structure {
            Structure::Predictor => {
                let xd = reduced(delayed);
                let z = Vector4::from_fn(|i, _| current[N - 4 + i]);
                -((c.k_e * xd)[(0, 0)] + (c.k * z)[(0, 0)])
            }
            _ => -c.law.measured_output(&*self.plant, &Self::xr(delayed)),
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
        let held = self.held.yaw_moment_nm;
        match &self.loop_command {
            Some(c) if c.law.actuator == Actuator::DifferentialBraking => {
                let m = self.loop_inputs(t, x, x_delayed);
                if held == 0.0 { m } else { m + held }
            }
            _ => held,
        }
    }

    /// The steering command δ_c(t) \[rad\] given the delayed states (eq. 8 with saturation).
    #[inline]
    fn command(&self, t: f64, x_delayed: &[SVector<f64, N>]) -> f64 {
        match (&self.controller, x_delayed.first()) {
            (Some(law), Some(xd)) => law.steering_angle(t, self.plant.yaw_rate(&Self::xr(xd))),
            _ => 0.0,
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
        let steering_angle = if self.steering.is_none() {
            steering_angle
        } else {
            steering_angle + self.steering.angle(t)
        };
        let held = &self.held;
        let steering_angle = if held.steering_angle_rad == 0.0 {
            steering_angle
        } else {
            steering_angle + held.steering_angle_rad
        };
        let (speed, acceleration) = match held.speed_mps {
            Some(v) if held.acceleration_mps2 == 0.0 => (v, 0.0),
            Some(v) => (
                v + held.acceleration_mps2 * (t - held.speed_from_s),
                held.acceleration_mps2,
            ),
            None => (self.profile.speed(t), self.profile.acceleration(t)),
        };
        Inputs {
            steering_angle,
            speed,
            acceleration,
        }
    }

    /// The places where the right-hand side is continuous but not smooth, as the sign
    /// changes of the plant's switching functions ([`Vehicle::sim_switching`]; for the
    /// paper's model tan α of each axle, the brush law's tan α·|tan α| of eq. 14, and
    /// tan²α − tan²α_cr of each axle, the onset of full sliding) followed by two of the
    /// controller: with actuator limits δ_raw² − δ_max² (saturation) and r² − δ̇_max² (rate
    /// limit); for a braking `yaw_rate_hitch` or `predictor` loop u_raw(t)² − M_max² and (the
    /// predictor's ż uses u(t − τ)) u_raw(t − τ)² − M_max². A function that cannot change
    /// sign (no sliding limit, no actuator limit) is −1. `g` has
    /// [`SimProblem::switching_count`] entries.
    pub fn switching_functions(
        &self,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
        g: &mut [f64],
    ) {
        let u = self.inputs(t, x, x_delayed);
        let k = self.plant_switching;
        self.plant.sim_switching(&Self::xr(x), &u, &mut g[..k]);
        let (saturation, rate) = if let Some(c) = &self.loop_command {
            self.loop_switches(c, t, x, x_delayed)
        } else {
            let actuator = self.steering_limits();
            let delayed_yaw_rate = x_delayed
                .first()
                .map_or(0.0, |xd| self.plant.yaw_rate(&Self::xr(xd)));
            let raw = self
                .controller
                .as_ref()
                .map_or(0.0, |l| l.raw_steering_angle(t, delayed_yaw_rate));
            let rate = if self.actuator_state {
                actuator.rate_switch(self.command(t, x_delayed), x[N - 1])
            } else {
                -1.0
            };
            (actuator.saturation_switch(raw), rate)
        };
        g[k] = saturation;
        g[k + 1] = rate;
    }

    /// Number of switching functions: the plant's and two of the controller
    /// ([`SWITCHING_FUNCTIONS`] for the paper's model).
    pub fn switching_count(&self) -> usize {
        self.plant_switching + 2
    }

    /// The validity guard's conditions at (t, x) ([`trailer_model::Plant::guard_values`]), each
    /// tripped when > 0.
    #[inline]
    pub fn guard_values(
        &self,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
    ) -> [f64; 5] {
        let u = self.inputs(t, x, x_delayed);
        self.plant.guard_values(&Self::xr(x), &u)
    }

    /// The hitch-angle rate θ̇ \[rad/s\] at x.
    #[inline]
    pub fn hitch_angle_rate(&self, x: &SVector<f64, N>) -> f64 {
        self.plant.hitch_angle_rate(&Self::xr(x))
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
        let xr = Self::xr(x);
        let r = if yaw_moment == 0.0 {
            self.plant.rhs(&xr, u)
        } else {
            self.plant.rhs_with_yaw_moment(&xr, u, yaw_moment)
        };
        for i in 0..M {
            dx[i] = r[i];
        }
        let force = self.held.trailer_lateral_force_n;
        if force != 0.0 {
            let extra = self
                .plant
                .paper_model()
                .trailer_force_response(x[HITCH_ANGLE], force);
            dx[0] += extra[0];
            dx[2] += extra[2];
        }
        if self.kinematics {
            // ψ̇, ẋ_H = V cos ψ − σ1 sin ψ, ẏ_H = V sin ψ + σ1 cos ψ (eq. 5)
            let (sp, cp) = x[M].sin_cos();
            dx[M] = self.plant.yaw_rate(&xr);
            dx[M + 1] = u.speed * cp - x[0] * sp;
            dx[M + 2] = u.speed * sp + x[0] * cp;
        }
    }
}

impl<const N: usize> SimProblem<'_, Model, 4, N> {
    /// The model.
    pub fn model(&self) -> &Model {
        &self.plant
    }

    /// Slip angles at (t, x) with the delayed states for δ.
    pub fn slip_angles(
        &self,
        t: f64,
        x: &SVector<f64, N>,
        x_delayed: &[SVector<f64, N>],
    ) -> SlipAngles {
        self.plant
            .slip_angles(&reduced(x), &self.inputs(t, x, x_delayed))
    }
}

impl<P: Vehicle<M>, const M: usize, const N: usize> OdeProblem<N> for SimProblem<'_, P, M, N> {
    #[inline]
    fn rhs(&self, t: f64, x: &SVector<f64, N>, dx: &mut SVector<f64, N>) {
        let u = self.inputs(t, x, &[]);
        self.eval(&u, self.held.yaw_moment_nm, x, dx);
        if self.loop_command.is_some()
            && self
                .controller
                .as_ref()
                .is_some_and(|l| l.extra_states() == 4)
        {
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
            dx[N - 1] = self.steering_limits().rate(0.0, x[N - 1]);
        }
    }
    fn breakpoints(&self) -> &[f64] {
        &self.breakpoints
    }
    fn switching_count(&self) -> usize {
        SimProblem::switching_count(self)
    }
    fn switching(&self, t: f64, x: &SVector<f64, N>, g: &mut [f64]) {
        self.switching_functions(t, x, &[], g);
    }
}

impl<P: Vehicle<M>, const M: usize, const N: usize> DdeProblem<N> for SimProblem<'_, P, M, N> {
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
            dx[N - 1] = self.steering_limits().rate(command, x[N - 1]);
        }
    }
    fn breakpoints(&self) -> &[f64] {
        &self.breakpoints
    }
    fn switching_count(&self) -> usize {
        SimProblem::switching_count(self)
    }
    fn switching(&self, t: f64, x: &SVector<f64, N>, x_delayed: &[SVector<f64, N>], g: &mut [f64]) {
        self.switching_functions(t, x, x_delayed, g);
    }
}

/// The run-time data of a loop: the braking limit and, for the predictor, its model's
/// matrices linearised at V(0).
fn loop_command(
    model: &Model,
    profile: &SpeedProfile,
    law: LoopLaw,
) -> Result<LoopCommand, SwayError> {
    let limit = law.max_command(model);
    let mut c = LoopCommand {
        law,
        limit,
        a_hat: Matrix4::zeros(),
        b_hat: Vector4::zeros(),
        k_e: RowVector4::zeros(),
        k: RowVector4::zeros(),
        e_b: Vector4::zeros(),
    };
    let law = &c.law;
    if law.structure == Structure::Predictor {
        let speed = profile.speed(0.0);
        let context = || format!("the predictor's model at V = {speed} m/s");
        let params = law.prediction_params(model.params());
        let prediction = Model::new(params).map_err(|e| SwayError::numerical(context(), e))?;
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
