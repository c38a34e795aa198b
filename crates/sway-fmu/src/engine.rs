//! The simulation behind the FMU: the vehicle with its law as the `sway` simulation
//! problem ([`SimProblem`], with the master's inputs as [`HeldInputs`]), integrated by the
//! `dde` solvers one communication step at a time. The state of an engine (the solver with
//! its delay history, the held inputs, the guard's verdict) is data: cloned for
//! `fmi2GetFMUstate`, serialised as CBOR for `fmi2SerializeFMUstate`.
//!
//! The state counts are type parameters (the plant's M reduced states, N = M + 3 kinematic
//! + the law's own states); [`build`] picks them at run time, as the simulations do.

use nalgebra::SVector;
use sway::sim::cosim::CoSimulation;
pub use sway::sim::cosim::StepEnd;
use sway::sim::{HeldInputs, SimProblem, SolverSettings, SpeedProfile};
use sway_model::law::LoopLaw;
use sway_model::vehicle::{LossOfControl, Vehicle};
use trailer_model::{AnyVehicleModel, Model, State4, VehicleModel};

use crate::FmuError;
use crate::variables::Output;

/// Everything an engine is built from.
#[derive(Debug, Clone)]
pub struct EngineSpec {
    /// the vehicle's plant
    pub plant: AnyVehicleModel,
    /// the feedback law (None: open loop)
    pub law: Option<LoopLaw>,
    /// the paper's 7 initial states
    pub initial: [f64; 7],
    /// the speed at the start \[m/s\] (the predictor's model is linearised there)
    pub speed_mps: f64,
    /// the start time \[s\]
    pub start_s: f64,
    /// the solver's settings
    pub solver: SolverSettings,
}

/// One simulation run by the FMU (object-safe: the state counts are hidden).
pub trait Engine: Send + std::fmt::Debug {
    /// The engine's time \[s\].
    fn time(&self) -> f64;
    /// Integrates to `t_end` with `held` applied from now (a change is a jump of the
    /// right-hand side).
    ///
    /// # Errors
    /// [`FmuError::Step`] if the solver fails.
    fn step(&mut self, held: HeldInputs, t_end: f64) -> Result<StepEnd, FmuError>;
    /// The outputs at the current time, in [`Output::ALL`] order (booleans and integers as
    /// 0/1 and their value).
    fn outputs(&mut self, held: HeldInputs) -> [f64; Output::ALL.len()];
    /// The engine's state as bytes (the delay history included).
    ///
    /// # Errors
    /// [`FmuError::State`] if it does not serialise.
    fn save(&self) -> Result<Vec<u8>, FmuError>;
    /// Restores a state made by [`Engine::save`] of an engine with the same states.
    ///
    /// # Errors
    /// [`FmuError::State`] if the bytes are not such a state.
    fn restore(&mut self, bytes: &[u8]) -> Result<(), FmuError>;
}

/// The engine of a plant `P` with M reduced states and N states in all.
struct SimEngine<P: Vehicle<M> + 'static, const M: usize, const N: usize> {
    /// the problem, owning its plant and speed profile ([`SimProblem::new_owned`])
    problem: SimProblem<'static, P, M, N>,
    law: Option<LoopLaw>,
    progress: CoSimulation<N>,
}

impl<P: Vehicle<M> + 'static, const M: usize, const N: usize> std::fmt::Debug
    for SimEngine<P, M, N>
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimEngine")
            .field("reduced_states", &M)
            .field("states", &N)
            .field("law", &self.law)
            .field("t", &self.progress.time())
            .finish_non_exhaustive()
    }
}

impl<P: Vehicle<M> + Send + Sync + 'static, const M: usize, const N: usize> SimEngine<P, M, N> {
    fn new(plant: P, spec: &EngineSpec) -> Result<Self, FmuError> {
        let x4 = State4::new(
            spec.initial[0],
            spec.initial[1],
            spec.initial[2],
            spec.initial[3],
        );
        let xr = plant.initial_state(&x4, spec.speed_mps);
        let x0 = SVector::<f64, N>::from_fn(|i, _| match i {
            i if i < M => xr[i],
            i if i < M + 3 => spec.initial[4 + i - M],
            _ => 0.0,
        });
        let profile = SpeedProfile::Constant {
            speed_mps: spec.speed_mps,
        };
        let problem =
            SimProblem::<P, M, N>::new_owned(plant, profile, spec.law, x0).map_err(|source| {
                FmuError::Step {
                    t: spec.start_s,
                    t_end: spec.start_s,
                    source,
                }
            })?;
        let progress =
            CoSimulation::start(&problem, spec.start_s, x0, &spec.solver).map_err(|source| {
                FmuError::Step {
                    t: spec.start_s,
                    t_end: spec.start_s,
                    source,
                }
            })?;
        Ok(Self {
            problem,
            law: spec.law,
            progress,
        })
    }
}

impl<P: Vehicle<M> + Send + Sync + 'static, const M: usize, const N: usize> Engine
    for SimEngine<P, M, N>
{
    fn time(&self) -> f64 {
        self.progress.time()
    }

    fn step(&mut self, held: HeldInputs, t_end: f64) -> Result<StepEnd, FmuError> {
        let t = self.time();
        self.progress
            .step(&mut self.problem, held, t_end)
            .map_err(|source| FmuError::Step { t, t_end, source })
    }

    fn outputs(&mut self, held: HeldInputs) -> [f64; Output::ALL.len()] {
        self.problem.set_held_inputs(held);
        let problem: &SimProblem<'static, P, M, N> = &self.problem;
        let t = self.time();
        let x = *self.progress.state();
        let xd = self.progress.delayed();
        let plant = problem.plant();
        let xr = sway::sim::reduced_state::<M, N>(&x);
        let u = problem.inputs(t, &x, xd);
        let yaw_rate = plant.yaw_rate(&xr);
        let hitch_rate = plant.hitch_angle_rate(&xr);
        let model: &Model = plant.paper_model();
        // a_y of C1 in the car's frame: d/dt(σ1 + d ψ̇) + V ψ̇
        let lateral_acceleration = self.progress.lateral_acceleration(problem);
        let x4 = State4::new(x[0], x[1], x[2], x[3]);
        let slips = model.slip_angles(&x4, &u);
        let forces = model.tire_forces(&x4, &u);
        let (lost, reason) = match self.progress.lost() {
            Some((_, why)) => {
                let k = LossOfControl::ALL
                    .iter()
                    .position(|l| *l == why)
                    .unwrap_or(0);
                (1.0, (k + 1) as f64)
            }
            None => (0.0, 0.0),
        };
        [
            x[0],
            x[1],
            x[2],
            x[3],
            x[M],
            x[M + 1],
            x[M + 2],
            hitch_rate,
            yaw_rate,
            yaw_rate + hitch_rate,
            lateral_acceleration,
            u.steering_angle,
            slips.front,
            slips.rear,
            slips.trailer,
            forces.front,
            forces.rear,
            forces.trailer,
            lost,
            reason,
        ]
    }

    fn save(&self) -> Result<Vec<u8>, FmuError> {
        let mut bytes = Vec::new();
        ciborium::into_writer(&self.progress, &mut bytes)
            .map_err(|e| FmuError::State(format!("serialising: {e}")))?;
        Ok(bytes)
    }

    fn restore(&mut self, bytes: &[u8]) -> Result<(), FmuError> {
        let progress: CoSimulation<N> = ciborium::from_reader(bytes)
            .map_err(|e| FmuError::State(format!("not a state of this FMU ({e})")))?;
        self.progress
            .replace_with(progress)
            .map_err(FmuError::State)
    }
}

fn boxed<P: Vehicle<M> + Send + Sync + 'static, const M: usize, const N: usize>(
    plant: P,
    spec: &EngineSpec,
) -> Result<Box<dyn Engine>, FmuError> {
    Ok(Box::new(SimEngine::<P, M, N>::new(plant, spec)?))
}

/// `plant` with N = M + 3 + the law's own states (0, 1 for a rate-limited steering, 4 for
/// the predictor): the three N of each M as literals.
fn by_law<
    P: Vehicle<M> + Send + Sync + 'static,
    const M: usize,
    const N0: usize,
    const N1: usize,
    const N4: usize,
>(
    plant: P,
    spec: &EngineSpec,
) -> Result<Box<dyn Engine>, FmuError> {
    match spec.law.map_or(0, |l| l.extra_states()) {
        0 => boxed::<P, M, N0>(plant, spec),
        1 => boxed::<P, M, N1>(plant, spec),
        _ => boxed::<P, M, N4>(plant, spec),
    }
}

/// The engine of `spec`.
///
/// # Errors
/// [`FmuError::Step`] if the problem or its solver cannot start (a predictor's model that
/// is not a vehicle, a non-finite initial state).
pub fn build(spec: &EngineSpec) -> Result<Box<dyn Engine>, FmuError> {
    let at = |e: FmuError| match e {
        FmuError::Step { source, .. } => FmuError::Step {
            t: spec.start_s,
            t_end: spec.start_s,
            source,
        },
        other => other,
    };
    match spec.plant.clone() {
        AnyVehicleModel::Paper(m) => by_law::<Model, 4, 7, 8, 11>(m, spec),
        AnyVehicleModel::N4(m) => by_law::<VehicleModel<4>, 4, 7, 8, 11>(m, spec),
        AnyVehicleModel::N5(m) => by_law::<VehicleModel<5>, 5, 8, 9, 12>(m, spec),
        AnyVehicleModel::N6(m) => by_law::<VehicleModel<6>, 6, 9, 10, 13>(m, spec),
        AnyVehicleModel::N7(m) => by_law::<VehicleModel<7>, 7, 10, 11, 14>(m, spec),
        AnyVehicleModel::N8(m) => by_law::<VehicleModel<8>, 8, 11, 12, 15>(m, spec),
        AnyVehicleModel::N9(m) => by_law::<VehicleModel<9>, 9, 12, 13, 16>(m, spec),
        AnyVehicleModel::N10(m) => by_law::<VehicleModel<10>, 10, 13, 14, 17>(m, spec),
    }
    .map_err(at)
}
