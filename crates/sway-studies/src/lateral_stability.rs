//! The computation of `lateral_stability`: the lateral stability test of car–trailer
//! combinations as test engineers run it (ISO 9815, pulse steer), on the model and on
//! recordings of real runs.
//!
//! At each test speed the combination runs straight, gets one steering impulse
//! ([`SteeringInput::Pulse`], its size a steering angle or the car's target peak lateral
//! acceleration) and the wheel is then held straight (with a controller from the config
//! in the loop if it names one); the damping ratio D = δ/√(4π² + δ²) is read from the
//! logarithmic decrement δ of successive peaks of the chosen signal ([`DecaySignal`]: the
//! hitch angle θ, the trailer's or the car's yaw rate; [`sway::sim::decay`]). The test's
//! critical speed is where a fit of D(V) over the runs that decay reaches D = 0 — what an
//! engineer extrapolates — beside the true V_crit (the Hopf point) and V_fold (the fold of
//! cycles) of the bifurcation diagram.
//!
//! The test's blind spot: in the bistable range V_fold < V < V_crit a small impulse decays
//! (D > 0) while a large one triggers sway. The local damping over one period against the
//! amplitude, D(A), over a family of impulses crosses zero at the amplitude of the
//! unstable sway cycle; [`compute`] reports that amplitude beside the cycle's max |θ| from
//! continuation, and the smallest impulse of the family that triggers sway. Above V_crit
//! D < 0 at small amplitudes and, where the family reaches it, D(A) crosses back to
//! positive at the stable sway cycle (for a supercritical Hopf point the cycle that grows
//! from V_crit).
//!
//! ```
//! use sway_studies::lateral_stability::{LateralStabilityConfig, fit_damping, DampingFit};
//! // an engineer's straight line through three decaying runs reaches D = 0 at 40 m/s
//! let runs = [(20.0, 0.2), (25.0, 0.15), (30.0, 0.1)];
//! let fit = fit_damping(&runs, DampingFit::Line).unwrap();
//! assert!((fit.zero_speed_mps.unwrap() - 40.0).abs() < 1e-9);
//! assert_eq!(LateralStabilityConfig::default().periods, 3);
//! ```

use serde::{Deserialize, Serialize};
use sway::SwayError;
use sway::bifurcation::{CycleKind, Diagram, DiagramSettings};
use sway::parallel::{Split, try_map};
use sway::progress::Progress;
use sway::ranging::{RelativeSpeed, SpeedLimits, SpeedReferences, SpeedSpec, corrected_diagram};
use sway::sim::decay::{Decay, Peak, decay, local_damping, peaks};
use sway::sim::{
    ControllerTable, LoopLaw, Outcome, PulseShape, Recording, RunSettings, SimResult, SimSpec,
    SimulateOwn, SpeedProfile, SteeringInput, SwayClass,
};
use sway_model::vehicle::Vehicle;
use trailer_model::{AnyVehicleModel, HITCH_ANGLE, Model, State4, with_plant};

/// The signal whose peaks the test reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DecaySignal {
    /// the articulation (hitch) angle θ (ISO 9815's usual choice)
    #[default]
    HitchAngle,
    /// the trailer's yaw rate ψ̇ + θ̇
    TrailerYawRate,
    /// the towing car's yaw rate ψ̇ (what the car's own sensors see)
    CarYawRate,
    /// the rearmost articulation angle θ_n (a chain of n towed units; the hitch angle of
    /// a two-unit vehicle): the heavy-vehicle standards' yaw damping
    RearmostArticulationAngle,
}

impl DecaySignal {
    /// Every signal, in the order of preference when a recording has several.
    pub const ALL: [DecaySignal; 4] = [
        DecaySignal::HitchAngle,
        DecaySignal::TrailerYawRate,
        DecaySignal::CarYawRate,
        DecaySignal::RearmostArticulationAngle,
    ];

    /// The config's (and a recording's column) name.
    pub fn as_str(&self) -> &'static str {
        match self {
            DecaySignal::HitchAngle => "hitch_angle",
            DecaySignal::TrailerYawRate => "trailer_yaw_rate",
            DecaySignal::CarYawRate => "car_yaw_rate",
            DecaySignal::RearmostArticulationAngle => "rearmost_articulation_angle",
        }
    }

    /// The unit the test reports it in: `deg` or `deg/s`.
    pub fn unit(&self) -> &'static str {
        match self {
            DecaySignal::HitchAngle | DecaySignal::RearmostArticulationAngle => "deg",
            DecaySignal::TrailerYawRate | DecaySignal::CarYawRate => "deg/s",
        }
    }

    /// Its value \[rad or rad/s\] at the paper-layout state `x` of `model` (eq. 5: the
    /// car's yaw rate ψ̇, the hitch-angle rate θ̇; the trailer's heading is ψ + θ). The
    /// paper layout has the first articulation only: the rearmost one of a chain is read
    /// from the plant's own states (the model's runs carry it), here it is the hitch angle.
    pub fn of(&self, model: &Model, x: &State4) -> f64 {
        match self {
            DecaySignal::HitchAngle | DecaySignal::RearmostArticulationAngle => x[HITCH_ANGLE],
            DecaySignal::TrailerYawRate => model.yaw_rate(x) + model.hitch_angle_rate(x),
            DecaySignal::CarYawRate => model.yaw_rate(x),
        }
    }
}

/// The steering impulse of the test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PulseConfig {
    /// `half_sine`, `triangle` or `rectangle`
    pub shape: PulseShape,
    /// when the impulse starts \[s\] (straight running before)
    pub start_s: f64,
    /// its duration \[s\]
    pub duration_s: f64,
    /// the impulse's peak front-wheel steering angle \[deg\] (small by default: its damping
    /// is the linear one); the first guess when `peak_lateral_acceleration_mps2` is given
    pub amplitude_deg: f64,
    /// the size of the impulse as the car's peak lateral acceleration \[m/s²\] instead of a
    /// steering angle: the angle is then found per speed (the car's lateral acceleration
    /// at its centre of gravity, highest during the impulse and as long again after it)
    pub peak_lateral_acceleration_mps2: Option<f64>,
}

impl Default for PulseConfig {
    fn default() -> Self {
        Self {
            shape: PulseShape::HalfSine,
            start_s: 0.5,
            duration_s: 0.4,
            amplitude_deg: 0.05,
            peak_lateral_acceleration_mps2: None,
        }
    }
}

impl PulseConfig {
    /// The steering input of an impulse of `amplitude_deg` \[deg\] of this shape and timing.
    pub fn input(&self, amplitude_deg: f64) -> SteeringInput {
        SteeringInput::Pulse {
            shape: self.shape,
            start_s: self.start_s,
            duration_s: self.duration_s,
            amplitude_rad: amplitude_deg.to_radians(),
        }
    }

    /// When the impulse ends \[s\].
    pub fn end_s(&self) -> f64 {
        self.start_s + self.duration_s
    }
}

/// The fit of D(V) an engineer extrapolates to D = 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DampingFit {
    /// the least-squares straight line D = a + b·V
    #[default]
    Line,
    /// the least-squares parabola D = a + b·V + c·V² (three runs at least)
    Quadratic,
}

/// How a recording is read ([`analyse_recording`]); the settings of the task's
/// `[recording]` table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordingSettings {
    /// the impulse starts where |steering| first exceeds this fraction of its largest
    /// value and ends where it falls back below \[-\]
    pub impulse_fraction: f64,
    /// cut-off of the zero-phase low-pass applied to the read signal \[Hz\] (well above
    /// the sway frequency of ≈ 0.5–1 Hz, well below sensor noise)
    pub low_pass_hz: f64,
    /// the prominence a peak needs, as a fraction of the largest |signal| after the
    /// impulse \[-\]
    pub prominence_fraction: f64,
}

impl Default for RecordingSettings {
    fn default() -> Self {
        Self {
            impulse_fraction: 0.05,
            low_pass_hz: 3.0,
            prominence_fraction: 0.05,
        }
    }
}

/// The test (the task's config without the vehicle).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LateralStabilityConfig {
    /// the test speeds, in m/s or relative to the vehicle (`{ of_v_crit = f }`,
    /// `{ in_bistable = f }`); the default runs from V_crit/2 to above V_crit with four
    /// speeds inside the bistable range
    pub speeds: Vec<SpeedSpec>,
    /// the impulse
    pub pulse: PulseConfig,
    /// the signal whose peaks give the damping
    pub signal: DecaySignal,
    /// peaks skipped after the impulse before the decrement is read (the fast mode dies
    /// out meanwhile)
    pub skip_peaks: usize,
    /// periods averaged (each between a peak and the next of the same sign)
    pub periods: usize,
    /// the fit of D(V) over the decaying runs
    pub fit: DampingFit,
    /// the family of impulse amplitudes for D(A) \[deg of front-wheel angle\]
    pub amplitudes_deg: Vec<f64>,
    /// simulated time per run \[s\]
    pub horizon_s: f64,
    /// sampling of the runs \[s\]
    pub sample_step_s: f64,
    /// a controller in the loop during the whole test (`kind = "none"`: the open loop);
    /// V_crit, V_fold and the cycles are then the closed loop's
    pub controller: ControllerTable,
    /// the bifurcation diagram (V_crit, V_fold, the cycles); its range derived from the
    /// vehicle where it gives none
    pub diagram: DiagramSettings,
    /// how recordings are read (`--recording`)
    pub recording: RecordingSettings,
}

impl Default for LateralStabilityConfig {
    fn default() -> Self {
        let of_v_crit = |f| SpeedSpec::Relative(RelativeSpeed::OfVCrit(f));
        let in_bistable = |f| SpeedSpec::Relative(RelativeSpeed::InBistable(f));
        Self {
            speeds: vec![
                of_v_crit(0.5),
                of_v_crit(0.6),
                of_v_crit(0.7),
                of_v_crit(0.8),
                in_bistable(0.2),
                in_bistable(0.4),
                in_bistable(0.6),
                in_bistable(0.8),
                of_v_crit(1.02),
                of_v_crit(1.05),
            ],
            pulse: PulseConfig::default(),
            signal: DecaySignal::HitchAngle,
            skip_peaks: 2,
            periods: 3,
            fit: DampingFit::Line,
            amplitudes_deg: vec![0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0, 8.0],
            horizon_s: 40.0,
            sample_step_s: 0.005,
            controller: ControllerTable::None,
            diagram: DiagramSettings::default(),
            recording: RecordingSettings::default(),
        }
    }
}

/// One test speed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpeedRow {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// the impulse's peak front-wheel angle \[deg\] (the config's, or the one found for
    /// its target lateral acceleration)
    pub steering_amplitude_deg: f64,
    /// the car's peak lateral acceleration during the impulse \[m/s²\] (None: the runs
    /// failed)
    pub peak_lateral_acceleration_mps2: Option<f64>,
    /// D of the impulse \[-\] (None: too few peaks, with `reason`)
    pub damping_ratio: Option<f64>,
    /// the frequency of the sway \[Hz\]
    pub frequency_hz: Option<f64>,
    /// the peaks the decrement read (two more than the periods averaged)
    pub peaks_used: usize,
    /// where the family's local damping D(A) crosses zero \[deg of θ\]: from positive to
    /// negative (the unstable cycle) in the bistable range, from negative to positive (the
    /// stable cycle) above V_crit
    pub zero_damping_amplitude_deg: Option<f64>,
    /// the unstable sway cycle's max |θ| from continuation \[deg\] (bistable range)
    pub unstable_cycle_amplitude_deg: Option<f64>,
    /// the stable sway cycle's max |θ| from continuation \[deg\] (above V_crit)
    pub stable_cycle_amplitude_deg: Option<f64>,
    /// the smallest impulse of the family that ends in sustained sway or loss of control
    /// \[deg of steering\]
    pub triggering_impulse_deg: Option<f64>,
    /// why a value is None
    pub reason: Option<String>,
    /// the local damping points (amplitude \[deg of θ\], D) of the family, for the figure
    #[serde(skip)]
    pub local_damping: Vec<(f64, f64)>,
}

/// A run's trace for the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// the signal read
    pub signal: DecaySignal,
    /// (t \[s\], the signal \[deg or deg/s\])
    pub values: Vec<(f64, f64)>,
    /// (t \[s\], δ \[deg\])
    pub steering_deg: Vec<(f64, f64)>,
    /// the peaks the decrement used (t \[s\], value \[deg or deg/s\])
    pub peaks_used: Vec<(f64, f64)>,
}

/// A fit of D(V) and where it reaches zero.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitResult {
    /// the kind of fit
    pub kind: DampingFit,
    /// its coefficients, constant first: D = Σ cₖ·Vᵏ
    pub coefficients: Vec<f64>,
    /// the lowest speed above the slowest run where it reaches D = 0 while falling \[m/s\]
    /// (None: it does not)
    pub zero_speed_mps: Option<f64>,
}

/// What the test gives.
#[derive(Debug, Clone, PartialEq)]
pub struct LateralStability {
    /// per test speed
    pub speeds: Vec<SpeedRow>,
    /// the speeds the config gives that the vehicle does not have, with the reason
    pub unresolved: Vec<(String, String)>,
    /// the fit of D(V) over the runs that decay (D > 0)
    pub fit: Option<FitResult>,
    /// where it reaches D = 0 \[m/s\] (None: fewer runs than the fit needs, or D does not
    /// fall to 0)
    pub test_critical_speed_mps: Option<f64>,
    /// V_crit (Hopf point) of the loop tested \[m/s\]
    pub v_crit_mps: Option<f64>,
    /// the fold of cycles \[m/s\]
    pub v_fold_mps: Option<f64>,
    /// why V_crit or V_fold is None (stable at every speed up to the limit, a supercritical
    /// Hopf point, …)
    pub reference_reason: Option<String>,
    /// without V_crit: straight running is stable up to this speed \[m/s\] (the searched
    /// range's top)
    pub stable_up_to_mps: Option<f64>,
    /// by how much the test's critical speed exceeds the lowest speed at which a kick can
    /// trigger sway (V_fold, else V_crit) \[m/s\]; negative: the test is conservative
    pub overestimate_mps: Option<f64>,
    /// one run of the impulse (the test speed nearest V_crit below it)
    pub trace: Option<Trace>,
}
/// The loop a test runs in: the vehicle, the paper form of its kinematics (for the
/// signals) and the controller (None: open loop).
struct TestLoop<'a> {
    vehicle: &'a AnyVehicleModel,
    paper: Model,
    law: Option<LoopLaw>,
}

/// One impulse's run, sampled.
struct ImpulseRun {
    /// t \[s\]
    t: Vec<f64>,
    /// the paper-layout states
    x: Vec<State4>,
    /// δ \[rad\]
    steering: Vec<f64>,
    /// the rearmost articulation angle θ_n \[rad\] (the hitch angle of two units)
    rearmost: Vec<f64>,
    /// sustained sway or loss of control
    sways: bool,
}

impl ImpulseRun {
    /// The samples of a run in a plant's own layout (the paper layout's four states first),
    /// its rearmost articulation angle state `rearmost`.
    fn of<const M: usize>(r: &SimResult<M>, rearmost: usize) -> Self {
        let tr = &r.trajectory;
        ImpulseRun {
            t: tr.iter().map(|s| s.t).collect(),
            x: tr
                .iter()
                .map(|s| State4::new(s.x[0], s.x[1], s.x[2], s.x[3]))
                .collect(),
            steering: tr.iter().map(|s| s.steering_angle).collect(),
            rearmost: tr.iter().map(|s| s.x[rearmost]).collect(),
            sways: r.metrics.outcome != Outcome::Ok || r.metrics.class == SwayClass::SustainedSway,
        }
    }

    /// The samples of `signal` \[rad or rad/s\].
    fn signal(&self, paper: &Model, signal: DecaySignal) -> Vec<f64> {
        match signal {
            DecaySignal::RearmostArticulationAngle => self.rearmost.clone(),
            s => self.x.iter().map(|x| s.of(paper, x)).collect(),
        }
    }

    /// The car's largest |lateral acceleration| at its centre of gravity \[m/s²\] from
    /// `from_s` to `to_s`: a = d/dt(σ1 + d·ψ̇) + V·ψ̇ (the lateral velocity of the centre
    /// of gravity, d ahead of the hitch, and the turning of the body frame), the derivative
    /// by central differences of the samples (relative error ≈ (hω)²/6, 3e-4 at h = 5 ms
    /// and the impulse's ω ≈ 8 rad/s).
    fn peak_lateral_acceleration(&self, paper: &Model, speed: f64, from_s: f64, to_s: f64) -> f64 {
        let d = paper.params().tractor.cog;
        let v_lat: Vec<f64> = self
            .x
            .iter()
            .map(|x| x[0] + d * paper.yaw_rate(x))
            .collect();
        (1..self.t.len().saturating_sub(1))
            .filter(|&i| self.t[i] >= from_s && self.t[i] <= to_s)
            .map(|i| {
                let dv = (v_lat[i + 1] - v_lat[i - 1]) / (self.t[i + 1] - self.t[i - 1]);
                (dv + speed * paper.yaw_rate(&self.x[i])).abs()
            })
            .fold(0.0, f64::max)
    }
}

impl TestLoop<'_> {
    /// Runs one impulse of `amplitude_deg` \[deg\] at `speed`.
    fn run(
        &self,
        cfg: &LateralStabilityConfig,
        speed: f64,
        amplitude_deg: f64,
    ) -> Result<ImpulseRun, SwayError> {
        let spec = SimSpec {
            early_stop: sway::sim::EarlyStop::Never,
            steering: cfg.pulse.input(amplitude_deg),
            profile: SpeedProfile::Constant { speed_mps: speed },
            controller: self.law,
            horizon_s: cfg.horizon_s,
            action_s: cfg.pulse.start_s,
            settings: RunSettings::default(),
        };
        // the plant in its own layout: its first four states are the paper layout's, and a
        // chain's rearmost articulation angle θ_n is state 2n + 1
        let rearmost = 2 * self.vehicle.towed_units() + 1;
        let recording = Recording::Every {
            step_s: cfg.sample_step_s,
        };
        with_plant!(self.vehicle, m => {
            let x0 = m.initial_state(&State4::zeros(), speed);
            m.simulate_own(&spec, x0, recording).map(|r| ImpulseRun::of(&r, rearmost))
        })
    }

    /// The impulse of the test at `speed`: the config's angle, or the angle whose run
    /// reaches the target peak lateral acceleration (secant iteration from the config's
    /// angle, to 0.1 %; the response is linear in the angle for small impulses, so one
    /// step usually lands), with its run and the peak reached.
    fn test_impulse(
        &self,
        cfg: &LateralStabilityConfig,
        speed: f64,
    ) -> Result<(f64, ImpulseRun, f64), SwayError> {
        let p = &cfg.pulse;
        let window = (p.start_s, p.end_s() + p.duration_s);
        let peak = |r: &ImpulseRun| self.paper_peak(r, speed, window);
        let mut a0 = p.amplitude_deg;
        let mut r0 = self.run(cfg, speed, a0)?;
        let mut y0 = peak(&r0);
        let Some(target) = p.peak_lateral_acceleration_mps2 else {
            return Ok((a0, r0, y0));
        };
        // the first step scales the angle (a linear response), then secants
        let mut a1 = if y0 > 0.0 { a0 * target / y0 } else { 2.0 * a0 };
        for _ in 0..8 {
            if (y0 - target).abs() <= 1e-3 * target {
                break;
            }
            let r1 = self.run(cfg, speed, a1)?;
            let y1 = peak(&r1);
            let next = if y1 != y0 {
                a1 - (y1 - target) * (a1 - a0) / (y1 - y0)
            } else {
                a1
            };
            (a0, r0, y0) = (a1, r1, y1);
            a1 = next.clamp(0.1 * a0, 10.0 * a0).min(29.0);
        }
        Ok((a0, r0, y0))
    }

    fn paper_peak(&self, r: &ImpulseRun, speed: f64, window: (f64, f64)) -> f64 {
        r.peak_lateral_acceleration(&self.paper, speed, window.0, window.1)
    }

    /// The impulse's decay at `speed`, its trace, and the impulse.
    fn decay_at(
        &self,
        cfg: &LateralStabilityConfig,
        speed: f64,
    ) -> Result<(Option<Decay>, Trace, f64, f64), SwayError> {
        let (amplitude_deg, run, peak_acceleration) = self.test_impulse(cfg, speed)?;
        let y = run.signal(&self.paper, cfg.signal);
        let p = prominent_peaks(&run.t, &y, cfg.pulse.end_s());
        let d = decay(&p, cfg.skip_peaks, cfg.periods);
        let used = p
            .iter()
            .skip(cfg.skip_peaks)
            .take(cfg.periods + 2)
            .map(|q| (q.t, q.value.to_degrees()))
            .collect();
        let deg = |ys: &[f64]| {
            run.t
                .iter()
                .zip(ys)
                .map(|(&a, &b)| (a, b.to_degrees()))
                .collect()
        };
        let trace = Trace {
            speed_mps: speed,
            signal: cfg.signal,
            values: deg(&y),
            steering_deg: deg(&run.steering),
            peaks_used: used,
        };
        Ok((d, trace, amplitude_deg, peak_acceleration))
    }

    /// Runs the family of impulses at `speed`.
    fn family(&self, cfg: &LateralStabilityConfig, speed: f64) -> Result<Family, SwayError> {
        let runs = try_map(&cfg.amplitudes_deg, Split::OnePerTask, &|_, &a| {
            self.run(cfg, speed, a)
        })?;
        let mut points = Vec::new();
        let mut triggering = None;
        for (&a, r) in cfg.amplitudes_deg.iter().zip(&runs) {
            let theta = r.signal(&self.paper, DecaySignal::HitchAngle);
            let p = prominent_peaks(&r.t, &theta, cfg.pulse.end_s());
            // from the first peak after the fast mode has died out
            let tail = p.get(cfg.skip_peaks..).unwrap_or(&[]);
            points.extend(
                local_damping(tail)
                    .into_iter()
                    .map(|(amp, d)| (amp.to_degrees(), d)),
            );
            if r.sways && triggering.is_none_or(|b: f64| a < b) {
                triggering = Some(a);
            }
        }
        points.sort_by(|x, y| x.0.total_cmp(&y.0));
        Ok(Family {
            points,
            triggering_deg: triggering,
        })
    }
}

/// The peaks of a signal after the impulse (prominence: 1e-6 of its largest |value|: a
/// simulated run has no noise).
fn prominent_peaks(t: &[f64], y: &[f64], after_s: f64) -> Vec<Peak> {
    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    peaks(t, y, after_s, 1e-6 * scale)
}

/// The family of impulses at one speed: the local damping points (amplitude \[deg\], D)
/// of all runs, sorted by amplitude, and the smallest impulse that triggers sway.
struct Family {
    points: Vec<(f64, f64)>,
    triggering_deg: Option<f64>,
}

/// Which way D(A) crosses zero.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Crossing {
    /// positive below, negative above: an unstable cycle
    Falling,
    /// negative below, positive above: a stable cycle
    Rising,
}

/// The amplitude where D(A) first changes sign the `way` asked, interpolated linearly
/// between the two points around it; None without one.
fn zero_damping_amplitude(points: &[(f64, f64)], way: Crossing) -> Option<f64> {
    points.windows(2).find_map(|w| {
        let ((a0, d0), (a1, d1)) = (w[0], w[1]);
        let crosses = match way {
            Crossing::Falling => d0 > 0.0 && d1 <= 0.0,
            Crossing::Rising => d0 < 0.0 && d1 >= 0.0,
        };
        (crosses && a1 > a0).then(|| a0 + d0 * (a1 - a0) / (d0 - d1))
    })
}

/// The least-squares fit of D(V) through `runs` (speed \[m/s\], D) and where it reaches
/// zero while falling (the lowest such speed above the slowest run). None with fewer runs
/// than the fit has coefficients or when the speeds do not determine it.
pub fn fit_damping(runs: &[(f64, f64)], kind: DampingFit) -> Option<FitResult> {
    let terms = match kind {
        DampingFit::Line => 2,
        DampingFit::Quadratic => 3,
    };
    if runs.len() < terms {
        return None;
    }
    // normal equations in the speed centred and scaled on the runs (well conditioned)
    let n = runs.len() as f64;
    let mean = runs.iter().map(|r| r.0).sum::<f64>() / n;
    let scale = runs.iter().map(|r| (r.0 - mean).abs()).fold(0.0, f64::max);
    if scale == 0.0 {
        return None;
    }
    let mut m = [[0.0; 4]; 3];
    for &(v, d) in runs {
        let s = (v - mean) / scale;
        let basis = [1.0, s, s * s];
        for i in 0..terms {
            for j in 0..terms {
                m[i][j] += basis[i] * basis[j];
            }
            m[i][3] += basis[i] * d;
        }
    }
    let c = solve(&mut m, terms)?;
    // back to D = Σ cₖ Vᵏ
    let (a, b, q) = (
        c[0],
        c[1] / scale,
        c.get(2).map_or(0.0, |c2| c2 / (scale * scale)),
    );
    let coefficients = match kind {
        DampingFit::Line => vec![a - b * mean, b],
        DampingFit::Quadratic => vec![a - b * mean + q * mean * mean, b - 2.0 * q * mean, q],
    };
    let slowest = runs.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
    let zero_speed_mps = falling_zero(&coefficients, slowest);
    Some(FitResult {
        kind,
        coefficients,
        zero_speed_mps,
    })
}

/// Gaussian elimination with partial pivoting of the `n`×`n` system in `m` (right-hand
/// side in column 3); None when singular.
fn solve(m: &mut [[f64; 4]; 3], n: usize) -> Option<Vec<f64>> {
    for col in 0..n {
        let pivot = (col..n).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[pivot][col].abs() < 1e-12 {
            return None;
        }
        m.swap(col, pivot);
        for row in col + 1..n {
            let f = m[row][col] / m[col][col];
            for k in col..4 {
                m[row][k] -= f * m[col][k];
            }
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| m[row][k] * x[k]).sum();
        x[row] = (m[row][3] - s) / m[row][row];
    }
    Some(x)
}

/// The lowest V > `above` where the polynomial (constant first, degree ≤ 2) is zero with a
/// negative slope.
fn falling_zero(c: &[f64], above: f64) -> Option<f64> {
    let slope = |v: f64| c[1] + 2.0 * c.get(2).copied().unwrap_or(0.0) * v;
    let linear = |a: f64, b: f64| if b != 0.0 { vec![-a / b] } else { vec![] };
    let roots: Vec<f64> = match c {
        [a, b] => linear(*a, *b),
        [a, b, q] if *q == 0.0 => linear(*a, *b),
        [a, b, q] => {
            let disc = b * b - 4.0 * q * a;
            if disc < 0.0 {
                vec![]
            } else {
                let r = disc.sqrt();
                vec![(-b - r) / (2.0 * q), (-b + r) / (2.0 * q)]
            }
        }
        _ => vec![],
    };
    roots
        .into_iter()
        .filter(|&v| v > above && slope(v) < 0.0)
        .min_by(f64::total_cmp)
}

/// The loop's diagram and its corrected V_crit and V_fold ([`corrected_diagram`]); without
/// a Hopf point the speed up to which straight running is stable.
fn diagram_on<P: Vehicle<N>, const N: usize>(
    model: &P,
    law: LoopLaw,
    settings: &DiagramSettings,
    limits: &SpeedLimits,
) -> Result<(Option<Diagram>, SpeedReferences, Option<f64>), SwayError> {
    Ok(match corrected_diagram(model, law, settings, limits)? {
        Ok(c) => (Some(*c.diagram), c.references, None),
        Err(n) => (
            None,
            SpeedReferences {
                v_crit_mps: None,
                v_fold_mps: None,
                reason: Some(n.reason),
            },
            n.stable_up_to_mps,
        ),
    })
}

/// The max |θ| of the cycle of `kind` at `speed` \[deg\] ([`Diagram::cycle_at`]: the
/// smallest unstable one, the largest stable one).
fn cycle_amplitude<P: Vehicle<N>, const N: usize>(
    model: &P,
    d: &Diagram,
    speed: f64,
    kind: CycleKind,
) -> Result<Option<f64>, SwayError> {
    Ok(d.cycle_at(model, speed, kind)?
        .cycle
        .map(|c| c.amplitude_deg))
}

/// Where a test speed lies relative to the loop's V_fold and V_crit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Range {
    /// below V_fold (or V_crit without a fold): every impulse decays
    Stable,
    /// V_fold < V < V_crit: small impulses decay, large ones trigger sway
    Bistable,
    /// above V_crit: straight running is unstable
    Unstable,
}

fn range_of(v: f64, refs: &SpeedReferences) -> Range {
    match (refs.v_fold_mps, refs.v_crit_mps) {
        (_, Some(c)) if v >= c => Range::Unstable,
        (Some(f), Some(_)) if v > f => Range::Bistable,
        _ => Range::Stable,
    }
}

/// The family's zero-damping amplitude at one speed beside the cycle continuation gives
/// there, and why either is missing.
struct ZeroDamping {
    zero_deg: Option<f64>,
    unstable_deg: Option<f64>,
    stable_deg: Option<f64>,
    reason: Option<String>,
}

fn zero_damping_at(
    vehicle: &AnyVehicleModel,
    diagram: Option<&Diagram>,
    range: Range,
    refs_fold: bool,
    speed: f64,
    points: &[(f64, f64)],
) -> Result<ZeroDamping, SwayError> {
    let cycle = |kind| match diagram {
        Some(d) => trailer_model::with_plant!(vehicle, m => cycle_amplitude(m, d, speed, kind)),
        None => Ok(None),
    };
    let none = |why: &str| ZeroDamping {
        zero_deg: None,
        unstable_deg: None,
        stable_deg: None,
        reason: Some(why.to_string()),
    };
    Ok(match range {
        Range::Stable if refs_fold => {
            none("below V_fold: every impulse decays, no sway cycle to cross")
        }
        Range::Stable => none(
            "below V_crit without a fold of cycles: every impulse decays, no sway cycle to cross",
        ),
        Range::Bistable => {
            let zero = zero_damping_amplitude(points, Crossing::Falling);
            ZeroDamping {
                zero_deg: zero,
                unstable_deg: cycle(CycleKind::Unstable)?,
                stable_deg: None,
                reason: zero.is_none().then(|| {
                    "the family's local damping does not fall through zero (its impulses stay below the unstable cycle or all trigger sway)".to_string()
                }),
            }
        }
        Range::Unstable => {
            let zero = zero_damping_amplitude(points, Crossing::Rising);
            ZeroDamping {
                zero_deg: zero,
                unstable_deg: None,
                stable_deg: cycle(CycleKind::Stable)?,
                reason: Some(match zero {
                    Some(_) => "above V_crit: no unstable sway cycle; D(A) rises through zero at the stable cycle".to_string(),
                    None => "above V_crit: no unstable sway cycle; D < 0 at every amplitude of the family (its impulses stay below the stable cycle, or the run loses control)".to_string(),
                }),
            }
        }
    })
}

/// What a test speed's row needs besides the runs.
struct SpeedContext<'a> {
    vehicle: &'a AnyVehicleModel,
    diagram: Option<&'a Diagram>,
    range: Range,
    has_fold: bool,
}

/// The test at one speed: the impulse's decay, the family's D(A) and the cycles there.
fn speed_row(
    test: &TestLoop<'_>,
    cfg: &LateralStabilityConfig,
    v: f64,
    c: &SpeedContext<'_>,
) -> Result<(SpeedRow, Trace), SwayError> {
    let (small, run_trace, steering_deg, peak_acceleration) = test.decay_at(cfg, v)?;
    let Family {
        points,
        triggering_deg,
    } = test.family(cfg, v)?;
    let z = zero_damping_at(c.vehicle, c.diagram, c.range, c.has_fold, v, &points)?;
    let reason = match small {
        None => Some("too few peaks after the impulse".to_string()),
        Some(_) => z.reason,
    };
    let row = SpeedRow {
        speed_mps: v,
        steering_amplitude_deg: steering_deg,
        peak_lateral_acceleration_mps2: Some(peak_acceleration),
        damping_ratio: small.map(|d| d.damping_ratio),
        frequency_hz: small.map(|d| d.frequency_hz),
        peaks_used: small.map_or(0, |d| d.periods_used + 2),
        zero_damping_amplitude_deg: z.zero_deg,
        unstable_cycle_amplitude_deg: z.unstable_deg,
        stable_cycle_amplitude_deg: z.stable_deg,
        triggering_impulse_deg: triggering_deg,
        reason,
        local_damping: points,
    };
    Ok((row, run_trace))
}

impl SpeedRow {
    /// The row of a speed whose runs failed, with the error as its reason.
    fn failed(speed_mps: f64, steering_amplitude_deg: f64, e: &SwayError) -> Self {
        Self {
            speed_mps,
            steering_amplitude_deg,
            peak_lateral_acceleration_mps2: None,
            damping_ratio: None,
            frequency_hz: None,
            peaks_used: 0,
            zero_damping_amplitude_deg: None,
            unstable_cycle_amplitude_deg: None,
            stable_cycle_amplitude_deg: None,
            triggering_impulse_deg: None,
            reason: Some(format!("the test's runs failed at this speed: {e}")),
            local_damping: Vec::new(),
        }
    }
}

/// Runs the test on `vehicle` (any model variant; the config's controller in the loop, if
/// any); `progress` advances by one per test speed.
///
/// # Errors
/// [`SwayError::Numerical`] when the diagram or a run fails, or when the config's
/// predictor names a `prediction_vehicle` that was not loaded.
pub fn compute(
    cfg: &LateralStabilityConfig,
    vehicle: &AnyVehicleModel,
    limits: &SpeedLimits,
    progress: &dyn Progress,
) -> Result<LateralStability, SwayError> {
    let law = cfg
        .controller
        .law()
        .map_err(|e| SwayError::numerical("the lateral stability test's controller", e))?;
    let paper = trailer_model::with_plant!(vehicle, m => m.paper_model().clone());
    let test = TestLoop {
        vehicle,
        paper,
        law,
    };
    let loop_law = law.unwrap_or(LoopLaw::OPEN_LOOP);
    let (diagram, refs, stable_up_to_mps) = trailer_model::with_plant!(
        vehicle,
        m => diagram_on(m, loop_law, &cfg.diagram, limits)
    )?;
    let mut unresolved = Vec::new();
    let mut speeds: Vec<f64> = Vec::new();
    for spec in &cfg.speeds {
        match spec.resolve(&refs) {
            Ok(v) => speeds.push(v),
            Err(e) => unresolved.push((spec.to_string(), e.reason)),
        }
    }
    speeds.sort_by(f64::total_cmp);
    let mut rows = Vec::with_capacity(speeds.len());
    let mut trace: Option<Trace> = None;
    for &v in &speeds {
        let range = range_of(v, &refs);
        let context = SpeedContext {
            vehicle,
            diagram: diagram.as_ref(),
            range,
            has_fold: refs.v_fold_mps.is_some(),
        };
        // a run that fails (a stiff variant beyond the solver's step budget) is this
        // speed's result, with the reason; the other speeds go on
        match speed_row(&test, cfg, v, &context) {
            Ok((row, run_trace)) => {
                if range != Range::Unstable {
                    trace = Some(run_trace);
                }
                rows.push(row);
            }
            Err(e) => rows.push(SpeedRow::failed(v, cfg.pulse.amplitude_deg, &e)),
        }
        progress.advance(1);
    }
    let decaying = decaying_runs(rows.iter().map(|r| (r.speed_mps, r.damping_ratio)));
    let fit = fit_damping(&decaying, cfg.fit);
    let test_v = fit.as_ref().and_then(|f| f.zero_speed_mps);
    let lowest_unsafe = refs.v_fold_mps.or(refs.v_crit_mps);
    Ok(LateralStability {
        speeds: rows,
        unresolved,
        fit,
        test_critical_speed_mps: test_v,
        v_crit_mps: refs.v_crit_mps,
        v_fold_mps: refs.v_fold_mps,
        reference_reason: refs.reason,
        stable_up_to_mps,
        overestimate_mps: test_v.zip(lowest_unsafe).map(|(t, l)| t - l),
        trace,
    })
}

/// The runs an engineer fits: those whose sway decays (D > 0); beyond them the test stops.
pub fn decaying_runs(runs: impl Iterator<Item = (f64, Option<f64>)>) -> Vec<(f64, f64)> {
    runs.filter_map(|(v, d)| d.filter(|d| *d > 0.0).map(|d| (v, d)))
        .collect()
}

/// How a recording is read ([`analyse_recording`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordingAnalysis {
    /// impulse detection, filter and prominence
    pub settings: RecordingSettings,
    /// peaks skipped after the impulse ends
    pub skip_peaks: usize,
    /// periods averaged
    pub periods: usize,
}

impl Default for RecordingAnalysis {
    fn default() -> Self {
        Self::from(&LateralStabilityConfig::default())
    }
}

impl From<&LateralStabilityConfig> for RecordingAnalysis {
    fn from(cfg: &LateralStabilityConfig) -> Self {
        Self {
            settings: cfg.recording,
            skip_peaks: cfg.skip_peaks,
            periods: cfg.periods,
        }
    }
}

/// What one recording shows.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedDecay {
    /// when the impulse started and ended \[s\]
    pub impulse_s: (f64, f64),
    /// the damping read from the filtered signal's peaks
    pub decay: Decay,
    /// the peaks used (t \[s\], value of the filtered signal)
    pub peaks_used: Vec<(f64, f64)>,
    /// the signal after the zero-phase low-pass (same samples as the input)
    pub filtered: Vec<f64>,
}

/// Why a recording cannot be read; rows count from 0 (the first sample).
#[derive(Debug, Clone, PartialEq)]
pub enum RecordingProblem {
    /// fewer than 10 samples, or columns of different lengths
    TooShort {
        /// samples of time, steering and signal
        lengths: [usize; 3],
    },
    /// time does not increase
    TimeNotIncreasing {
        /// the sample
        row: usize,
        /// its time and the one before \[s\]
        t: f64,
        /// the time before \[s\]
        previous: f64,
    },
    /// a sample is NaN or infinite
    NotFinite {
        /// `time`, `steering` or `signal`
        column: &'static str,
        /// the sample
        row: usize,
    },
    /// the sampling is coarser than 20 Hz
    TooCoarse {
        /// the median step \[s\]
        step_s: f64,
    },
    /// the steering angle is zero throughout
    NoImpulse,
    /// the steering does not come back after the impulse
    ImpulseDoesNotEnd {
        /// when the impulse started \[s\]
        start_s: f64,
    },
    /// too few peaks after the impulse for the decrement
    TooFewPeaks {
        /// peaks found
        found: usize,
        /// peaks needed
        needed: usize,
    },
}

impl std::fmt::Display for RecordingProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RecordingProblem::TooShort { lengths: [t, s, y] } => write!(
                f,
                "expected at least 10 samples of time, steering and signal of equal length, got {t}, {s} and {y}"
            ),
            RecordingProblem::TimeNotIncreasing { row, t, previous } => write!(
                f,
                "row {row}: time does not increase ({t} s after {previous} s)"
            ),
            RecordingProblem::NotFinite { column, row } => {
                write!(f, "row {row}: {column} is not a finite number")
            }
            RecordingProblem::TooCoarse { step_s } => write!(
                f,
                "sampled every {step_s} s (median): the test needs 20 Hz or more"
            ),
            RecordingProblem::NoImpulse => {
                write!(
                    f,
                    "no steering impulse found (the steering angle is zero throughout)"
                )
            }
            RecordingProblem::ImpulseDoesNotEnd { start_s } => write!(
                f,
                "the steering impulse from {start_s} s does not end within the recording (the wheel must come back to straight)"
            ),
            RecordingProblem::TooFewPeaks { found, needed } => write!(
                f,
                "too few peaks after the impulse: {found} found, {needed} needed (record longer, or lower skip_peaks or periods)"
            ),
        }
    }
}

impl std::error::Error for RecordingProblem {}

/// Checks the samples of a recording: equal lengths, finite, time increasing, ≥ 20 Hz.
fn check_samples(t: &[f64], steering: &[f64], signal: &[f64]) -> Result<(), RecordingProblem> {
    let n = t.len();
    if n < 10 || steering.len() != n || signal.len() != n {
        return Err(RecordingProblem::TooShort {
            lengths: [n, steering.len(), signal.len()],
        });
    }
    for (column, v) in [("time", t), ("steering", steering), ("signal", signal)] {
        if let Some(row) = v.iter().position(|x| !x.is_finite()) {
            return Err(RecordingProblem::NotFinite { column, row });
        }
    }
    if let Some(row) = (1..n).find(|&i| t[i] <= t[i - 1]) {
        return Err(RecordingProblem::TimeNotIncreasing {
            row,
            t: t[row],
            previous: t[row - 1],
        });
    }
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let step_s = steps[steps.len() / 2];
    if step_s > 0.05 {
        return Err(RecordingProblem::TooCoarse { step_s });
    }
    Ok(())
}

/// Reads the damping of one recorded pulse-steer run: `t` \[s\] increasing, `steering`
/// (any unit) and the read `signal` (θ or a yaw rate, any unit) sampled at `t`. The impulse
/// is where |steering| first exceeds `impulse_fraction` of its largest value until it
/// falls back below; the signal is low-passed forwards and backwards (zero phase, so the
/// peaks keep their times) and its peaks after the impulse of sufficient prominence give
/// the decrement.
///
/// # Errors
/// [`RecordingProblem`]: too few samples, a non-finite sample, non-increasing time,
/// sampling below 20 Hz, no impulse, too few peaks.
pub fn analyse_recording(
    t: &[f64],
    steering: &[f64],
    signal: &[f64],
    how: &RecordingAnalysis,
) -> Result<RecordedDecay, RecordingProblem> {
    check_samples(t, steering, signal)?;
    let s = &how.settings;
    let peak = steering.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let threshold = s.impulse_fraction * peak;
    let start = steering
        .iter()
        .position(|v| v.abs() > threshold && peak > 0.0)
        .ok_or(RecordingProblem::NoImpulse)?;
    let end = (start..t.len())
        .find(|&i| steering[i].abs() <= threshold)
        .ok_or(RecordingProblem::ImpulseDoesNotEnd { start_s: t[start] })?;
    let filtered = sway::sim::decay::low_pass(t, signal, s.low_pass_hz);
    let scale = filtered[end..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let p = peaks(t, &filtered, t[end], s.prominence_fraction * scale);
    let d = decay(&p, how.skip_peaks, how.periods).ok_or(RecordingProblem::TooFewPeaks {
        found: p.len(),
        needed: how.skip_peaks + how.periods + 2,
    })?;
    Ok(RecordedDecay {
        impulse_s: (t[start], t[end]),
        decay: d,
        peaks_used: p
            .iter()
            .skip(how.skip_peaks)
            .take(how.periods + 2)
            .map(|q| (q.t, q.value))
            .collect(),
        filtered,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_and_a_parabola_through_exact_points_are_recovered() {
        // reference: points on D = 0.5 − 0.01·V and on D = 0.6 − 0.01·V − 1e-4·V²
        // (zeros 50 m/s and (−100 + √(1e4 + 2.4e4))/2 = 42.195…); exact up to rounding
        let line: Vec<(f64, f64)> = [20.0, 25.0, 30.0].map(|v| (v, 0.5 - 0.01 * v)).to_vec();
        let f = fit_damping(&line, DampingFit::Line).unwrap();
        assert!((f.zero_speed_mps.unwrap() - 50.0).abs() < 1e-9, "{f:?}");
        let par: Vec<(f64, f64)> = [15.0, 20.0, 25.0, 30.0]
            .map(|v| (v, 0.6 - 0.01 * v - 1e-4 * v * v))
            .to_vec();
        let f = fit_damping(&par, DampingFit::Quadratic).unwrap();
        let exact = (-100.0 + (1e4f64 + 2.4e4).sqrt()) / 2.0;
        assert!(
            (f.zero_speed_mps.unwrap() - exact).abs() < 1e-8,
            "{f:?} vs {exact}"
        );
        assert!((f.coefficients[2] + 1e-4).abs() < 1e-12);
        // a rising line never reaches zero while falling
        let rising: Vec<(f64, f64)> = [20.0, 30.0].map(|v| (v, 0.01 * v)).to_vec();
        assert_eq!(
            fit_damping(&rising, DampingFit::Line)
                .unwrap()
                .zero_speed_mps,
            None
        );
        assert!(fit_damping(&line[..1], DampingFit::Line).is_none());
    }

    #[test]
    fn zero_damping_crossings_are_told_apart_by_their_direction() {
        // reference: D(A) = 0.1 − A/10 falls through zero at A = 1 (an unstable cycle);
        // D(A) = A/10 − 0.3 rises through zero at A = 3 (a stable one)
        let falling: Vec<(f64, f64)> = (0..20)
            .map(|k| (k as f64 * 0.25, 0.1 - k as f64 * 0.025))
            .collect();
        let a = zero_damping_amplitude(&falling, Crossing::Falling).unwrap();
        assert!((a - 1.0).abs() < 1e-12);
        assert_eq!(zero_damping_amplitude(&falling, Crossing::Rising), None);
        let rising: Vec<(f64, f64)> = (0..20)
            .map(|k| (k as f64 * 0.25, k as f64 * 0.025 - 0.3))
            .collect();
        let a = zero_damping_amplitude(&rising, Crossing::Rising).unwrap();
        assert!((a - 3.0).abs() < 1e-12);
    }

    #[test]
    fn bad_recordings_name_the_row_or_the_problem() {
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.02).collect();
        let z = vec![0.0; 100];
        let how = RecordingAnalysis::default();
        assert_eq!(
            analyse_recording(&t, &z, &z, &how),
            Err(RecordingProblem::NoImpulse)
        );
        let mut bad = t.clone();
        bad[17] = bad[16];
        assert!(matches!(
            analyse_recording(&bad, &z, &z, &how),
            Err(RecordingProblem::TimeNotIncreasing { row: 17, .. })
        ));
        let mut nan = z.clone();
        nan[5] = f64::NAN;
        assert!(matches!(
            analyse_recording(&t, &z, &nan, &how),
            Err(RecordingProblem::NotFinite {
                column: "signal",
                row: 5
            })
        ));
        let coarse: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
        assert!(matches!(
            analyse_recording(&coarse, &z, &z, &how),
            Err(RecordingProblem::TooCoarse { .. })
        ));
        let held: Vec<f64> = (0..100).map(|k| if k > 10 { 1.0 } else { 0.0 }).collect();
        assert!(matches!(
            analyse_recording(&t, &held, &z, &how),
            Err(RecordingProblem::ImpulseDoesNotEnd { .. })
        ));
    }
}
