//! Co-simulation stepping: a [`SimProblem`] integrated one communication interval at a
//! time with inputs held between two calls ([`HeldInputs`]), as the FMU's engine
//! (`sway-fmu`) and the sway assist (the `assist` module above) step it. The state of a stepping
//! ([`CoSimulation`]: the solver with its delay history, the inputs the last step held,
//! x(t − τ), the guard's verdict) is data: cloneable and serialisable.
//!
//! A change of the held inputs between two steps is a jump of the right-hand side: the
//! solver is told of it ([`dde::OdeSolver::input_jump`]), so stepping with the same inputs
//! throughout integrates exactly as one call over the whole interval would, up to the
//! landing on the interval ends.

use dde::{DdeProblem, DdeSolver, Flow, Observer, OdeProblem, OdeSolver, Status, StepView};
use nalgebra::SVector;
use serde::{Deserialize, Serialize};
use sway_model::vehicle::{LossOfControl, Vehicle};

use super::plant::{HeldInputs, SimProblem, reduced_state};
use super::run::{SolverSettings, guard_event, tripped};
use crate::SwayError;

/// The integrator: an ODE in open loop (as the simulations), a DDE with a delay.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum Integrator<const N: usize> {
    /// open loop
    Ode(OdeSolver<N>),
    /// closed loop with a delay
    Dde(DdeSolver<N>),
}

/// [`HeldInputs`] as data (compared to tell the solver of a jump of the inputs). The
/// fields added after the first FMU release default to 0 when a saved state lacks them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HeldSnapshot {
    speed_mps: Option<f64>,
    steering_angle_rad: f64,
    yaw_moment_nm: f64,
    trailer_lateral_force_n: f64,
    #[serde(default)]
    acceleration_mps2: f64,
    #[serde(default)]
    speed_from_s: f64,
}

impl From<HeldInputs> for HeldSnapshot {
    fn from(h: HeldInputs) -> Self {
        Self {
            speed_mps: h.speed_mps,
            steering_angle_rad: h.steering_angle_rad,
            yaw_moment_nm: h.yaw_moment_nm,
            trailer_lateral_force_n: h.trailer_lateral_force_n,
            acceleration_mps2: h.acceleration_mps2,
            speed_from_s: h.speed_from_s,
        }
    }
}

/// What a step ended with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepEnd {
    /// the step's end was reached
    Reached,
    /// the validity guard tripped at t \[s\]: the state stays there
    LostControl(f64, LossOfControl),
}

/// The part of a co-simulation that changes with time (the problem itself is the
/// caller's): the solver, the inputs the last step held, x(t − τ) at the current time
/// (closed loop), and where and why the guard tripped.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CoSimulation<const N: usize> {
    solver: Integrator<N>,
    held: Option<HeldSnapshot>,
    delayed: Option<SVector<f64, N>>,
    lost: Option<(f64, usize)>,
}

/// Keeps x(t_end − τ) of the last accepted step.
struct Delayed<const N: usize> {
    delay_s: Option<f64>,
    x0: SVector<f64, N>,
    at_end: Option<SVector<f64, N>>,
}

impl<const N: usize> Observer<N> for Delayed<N> {
    fn on_step(&mut self, step: &StepView<'_, N>) -> Flow {
        if let Some(tau) = self.delay_s {
            self.at_end = Some(step.eval_past(step.t_end() - tau).unwrap_or(self.x0));
        }
        Flow::Continue
    }
}

impl<const N: usize> CoSimulation<N> {
    /// A co-simulation of `problem` from its initial state `x0` at `t0` \[s\] (an ODE solver
    /// in open loop, a DDE solver with the problem's controller).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if the solver does not start (bad settings, a non-finite
    /// state).
    pub fn start<P: Vehicle<M>, const M: usize>(
        problem: &SimProblem<'_, P, M, N>,
        t0: f64,
        x0: SVector<f64, N>,
        settings: &SolverSettings,
    ) -> Result<Self, SwayError> {
        let law = problem.controller().copied();
        let opts = settings.options(law.as_ref());
        let solver = if law.is_some() {
            DdeSolver::new(problem, t0, opts)
                .map(Integrator::Dde)
                .map_err(|e| SwayError::numerical("starting the DDE solver", e))?
        } else {
            OdeSolver::new(problem, t0, x0, opts)
                .map(Integrator::Ode)
                .map_err(|e| SwayError::numerical("starting the ODE solver", e))?
        };
        Ok(Self {
            solver,
            held: None,
            delayed: law.map(|_| x0),
            lost: None,
        })
    }

    /// The time \[s\].
    pub fn time(&self) -> f64 {
        match &self.solver {
            Integrator::Ode(s) => s.t(),
            Integrator::Dde(s) => s.t(),
        }
    }

    /// The state at [`CoSimulation::time`].
    pub fn state(&self) -> &SVector<f64, N> {
        match &self.solver {
            Integrator::Ode(s) => s.state(),
            Integrator::Dde(s) => s.state(),
        }
    }

    /// x(t − τ) at the current time (closed loop; empty in open loop): the delayed states a
    /// right-hand side evaluation needs.
    pub fn delayed(&self) -> &[SVector<f64, N>] {
        match &self.delayed {
            Some(d) => std::slice::from_ref(d),
            None => &[],
        }
    }

    /// Where and why the guard tripped (None while the model is valid).
    pub fn lost(&self) -> Option<(f64, LossOfControl)> {
        self.lost.map(|(t, k)| (t, LossOfControl::ALL[k]))
    }

    /// Whether the integrator is an ODE solver (open loop) or a DDE solver.
    pub fn is_delayed(&self) -> bool {
        matches!(self.solver, Integrator::Dde(_))
    }

    /// Integrates `problem` to `t_end` \[s\] with `held` applied from now (a change from the
    /// last step's inputs is a jump of the right-hand side), stopping where the validity
    /// guard trips (then every later step returns the same [`StepEnd::LostControl`]).
    ///
    /// # Errors
    /// [`SwayError::Numerical`] if the solver fails.
    pub fn step<P: Vehicle<M>, const M: usize>(
        &mut self,
        problem: &mut SimProblem<'_, P, M, N>,
        held: HeldInputs,
        t_end: f64,
    ) -> Result<StepEnd, SwayError> {
        if let Some((t_lost, why)) = self.lost() {
            return Ok(StepEnd::LostControl(t_lost, why));
        }
        let snapshot = HeldSnapshot::from(held);
        if self.held.is_some_and(|h| h != snapshot) {
            match &mut self.solver {
                Integrator::Ode(s) => s.input_jump(),
                Integrator::Dde(s) => s.input_jump(),
            }
        }
        self.held = Some(snapshot);
        problem.set_held_inputs(held);
        let problem: &SimProblem<'_, P, M, N> = problem;
        let events = [guard_event(problem)];
        let mut observer = Delayed {
            delay_s: problem.controller().map(|l| l.delay_s),
            // before the start: the constant history x(t) = x(0)
            x0: DdeProblem::history(problem, 0.0),
            at_end: None,
        };
        let status = match &mut self.solver {
            Integrator::Ode(s) => s.integrate(problem, t_end, &events, &mut observer),
            Integrator::Dde(s) => s.integrate(problem, t_end, &events, &mut observer),
        }
        .map_err(|e| {
            SwayError::numerical(format!("a co-simulation step with inputs {held:?}"), e)
        })?;
        if let Some(d) = observer.at_end {
            self.delayed = Some(d);
        }
        match status {
            Status::Event(hit) => {
                let v = problem.guard_values(hit.t, &hit.x, self.delayed());
                let why = tripped(v);
                let k = LossOfControl::ALL
                    .iter()
                    .position(|l| *l == why)
                    .unwrap_or(0);
                self.lost = Some((hit.t, k));
                Ok(StepEnd::LostControl(hit.t, why))
            }
            _ => Ok(StepEnd::Reached),
        }
    }

    /// The right-hand side ẋ at the current time with the inputs `problem` holds.
    pub fn derivative<P: Vehicle<M>, const M: usize>(
        &self,
        problem: &SimProblem<'_, P, M, N>,
    ) -> SVector<f64, N> {
        let (t, x) = (self.time(), *self.state());
        let mut dx = SVector::<f64, N>::zeros();
        if self.is_delayed() {
            DdeProblem::rhs(problem, t, &x, self.delayed(), &mut dx);
        } else {
            OdeProblem::rhs(problem, t, &x, &mut dx);
        }
        dx
    }

    /// The car's lateral acceleration at its centre of gravity C1 \[m/s²\] at the current
    /// time, in the car's frame: d/dt(σ1 + d·ψ̇) + V·ψ̇ (σ1 the lateral velocity of the
    /// hitch, d the hitch-to-C1 distance; the derivatives from the right-hand side, so
    /// exact), with the inputs `problem` holds.
    pub fn lateral_acceleration<P: Vehicle<M>, const M: usize>(
        &self,
        problem: &SimProblem<'_, P, M, N>,
    ) -> f64 {
        let x = *self.state();
        let dx = self.derivative(problem);
        let plant = problem.plant();
        let d = plant.paper_model().params().tractor.cog;
        let u = problem.inputs(self.time(), &x, self.delayed());
        dx[0]
            + d * plant.yaw_rate(&reduced_state::<M, N>(&dx))
            + u.speed * plant.yaw_rate(&reduced_state::<M, N>(&x))
    }

    /// Restores the time-dependent part saved from a co-simulation of the same problem;
    /// `Err` when `other` used another kind of integrator (open against closed loop).
    ///
    /// # Errors
    /// A message saying so.
    pub fn replace_with(&mut self, other: CoSimulation<N>) -> Result<(), String> {
        if other.is_delayed() != self.is_delayed() {
            return Err("saved with another controller (open against closed loop)".into());
        }
        *self = other;
        Ok(())
    }
}
