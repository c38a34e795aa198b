//! The control-design study of `cargo xtask control_design`: for every structure ×
//! actuator, the best gains on a grid of delays, the delay budget, and at chosen delays the
//! robust (5 %) critical speed under vehicle uncertainty; for every optimum of the
//! output-feedback structures (`yaw_rate`, `yaw_rate_hitch`, either actuator) the
//! fold-of-cycles speed of its loop ([`sway::bifurcation::ClosedLoop`] with the
//! [`sway::bifurcation::LoopLaw`] of the design) and, where the optimum sits on a double-Hopf
//! corner, the gain a little away from it that maximises the fold speed instead
//! ([`AwayFromCorner`]). The `predictor` has no fold: its distributed delay is not a continuation problem
//! here.

use serde::{Deserialize, Serialize};
use sway::parallel::{Split, map};
use trailer_model::{AnyVehicleModel, Model, State4, VehicleParams, VehicleSpec};

use sway::SwayError;
use sway::bifurcation::chart::ChartOptions;
use sway::control::{
    Actuator, DelayBudget, Design, DesignSearch, GainName, Gains, LoopLaw, LoopModel, Robustness,
    SpeedSearch, Structure, VehicleUncertainty, delay_budget, designs_over_delays,
    robust_critical_speed,
};
use sway::control::{DesignStart, design, perfect_predictor_designs};
use sway::control::{fold_speed, hopf_and_fold};
use sway::progress::Progress;
use sway::ranging::CappedSpeed;
use sway::sim::{
    PredictionVehicle, Recording, RunSettings, SimSpec, SpeedProfile, SwayClass, simulate,
};

/// What the study computes (plain data; the task reads it from its config).
#[derive(Debug, Clone, PartialEq)]
pub struct StudySettings {
    /// the delays τ of the grid \[s\] (increasing)
    pub delays_s: Vec<f64>,
    /// the structures
    pub structures: Vec<Structure>,
    /// the actuators
    pub actuators: Vec<Actuator>,
    /// the design search
    pub search: DesignSearch,
    /// the delay budget: required rise over the open loop (0.1: 10 %)
    pub budget_rise_fraction: f64,
    /// the budget's bisection tolerance in τ \[s\]
    pub budget_tau_tolerance_s: f64,
    /// delays at which the robustness (and the fold of cycles) of the optima is computed;
    /// each is snapped to the nearest grid delay
    pub checked_delays_s: Vec<f64>,
    /// the uncertainty the optima are judged under
    pub uncertainty: VehicleUncertainty,
    /// the critical-speed search of the uncertainty samples
    pub robustness_speed: SpeedSearch,
    /// the fold-of-cycles computation (speed range, mesh) of every design
    pub fold: ChartOptions,
    /// gains tried on each side of a double-Hopf optimum, evenly in its near-optimal band of
    /// D (0: the search away from the corner is skipped)
    pub away_from_corner_samples: usize,
}

/// The fold of cycles of one optimum (one entry of [`Combination::designs`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignFold {
    /// the grid delay \[s\]
    pub tau_s: f64,
    /// the fold-of-cycles speed of the optimum \[m/s\] (no kick triggers sway below it)
    pub v_fold_mps: Option<f64>,
    /// why `v_fold_mps` is null, where it is
    pub v_fold_reason: Option<String>,
    /// the Hopf point of straight running the cycle branch starts from \[m/s\] (located on
    /// the spectrum; the first one the straight-running continuation meets, which can lie
    /// past a window of instability below it: compare the design's V_crit)
    #[serde(default)]
    pub hopf_v_mps: Option<f64>,
    /// where the optimum is a double-Hopf corner: the gains a little away from it with the
    /// largest fold speed
    pub away_from_corner: Option<AwayFromCorner>,
}

/// The gains near a double-Hopf optimum that maximise the fold-of-cycles speed: D varied over its near-optimal band ([`sway::control::GainBand`], the gains whose
/// linear critical speed is within the band fraction of the best), `samples` evenly on each
/// side of the corner, the other gains kept at the optimum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AwayFromCorner {
    /// the gains (actuator units)
    pub gains: Gains,
    /// their fold-of-cycles speed \[m/s\]
    pub v_fold_mps: f64,
    /// their linear critical speed \[m/s\] (null: stable up to the search's cap, see
    /// `stable_up_to_mps` and `reason`)
    pub v_crit_mps: Option<f64>,
    /// straight running with these gains is stable up to this speed \[m/s\], the top of the
    /// search range (absent: `v_crit_mps` was found below it)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stable_up_to_mps: Option<f64>,
    /// why `v_crit_mps` is null (absent: it is not)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// the gains tried (with a fold)
    pub tried: usize,
}

/// The cap of a design's critical-speed search, as a reason names it.
pub const SEARCH_CAP: &str = "the speed cap, search.speed.v_max_mps";

/// The cap of the uncertainty samples' critical-speed search, as a reason names it.
pub const ROBUSTNESS_CAP: &str = "the speed cap, robustness.speed.v_max_mps";

/// The checks of one optimum at one delay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckedDesign {
    /// the grid delay \[s\]
    pub tau_s: f64,
    /// the critical speed under the uncertainty
    pub robustness: Robustness,
    /// the fold-of-cycles speed of the optimum \[m/s\] (no kick triggers sway below it)
    pub v_fold_mps: Option<f64>,
    /// why `v_fold_mps` is null, where it is
    pub v_fold_reason: Option<String>,
}

/// The open-loop critical speed \[m/s\] of the study's linear side (the reference of the
/// budgets); None: straight running is stable up to the search's top speed without
/// control, and there is nothing to design for.
///
/// # Errors
/// [`SwayError::Numerical`] if the search fails.
pub fn open_loop_critical_speed(
    vehicle: StudyVehicle<'_>,
    s: &StudySettings,
) -> Result<Option<f64>, SwayError> {
    let model: &dyn LoopModel = match vehicle.paper {
        Some((m, _)) => m,
        None => vehicle.plant,
    };
    sway::control::critical_speed(model, &LoopLaw::OPEN_LOOP, None, &s.search.speed)
}

/// The results of one structure × actuator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Combination {
    /// the structure
    pub structure: Structure,
    /// the actuator
    pub actuator: Actuator,
    /// the optimum at each grid delay
    pub designs: Vec<Design>,
    /// the delay budget
    pub budget: DelayBudget,
    /// the checks at the checked delays
    pub checked: Vec<CheckedDesign>,
    /// the fold of cycles of each optimum, in the order of `designs`
    pub folds: Vec<DesignFold>,
}

/// The whole study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControlStudy {
    /// the open-loop critical speed \[m/s\] (the reference of the budgets)
    pub open_loop_v_crit_mps: f64,
    /// structure × actuator, structure-major in the settings' order
    pub combinations: Vec<Combination>,
}

/// The vehicle of a study: its plant (the linear side) and, for a vehicle file of the
/// paper's form, the paper's model, on which the fold of cycles is computed and whose
/// parameters the uncertainty samples perturb.
#[derive(Debug, Clone, Copy)]
pub struct StudyVehicle<'a> {
    /// the vehicle file as written (axle lists, tyre laws, relaxation, hitch torque)
    pub spec: &'a VehicleSpec,
    /// its plant ([`AnyVehicleModel::Paper`] for a vehicle of the paper's form)
    pub plant: &'a AnyVehicleModel,
    /// the paper's model and its parameters, for a vehicle of the paper's form (None for a
    /// vehicle with model variants: the folds of cycles are then left out with the reason)
    pub paper: Option<(&'a Model, &'a VehicleParams)>,
    /// the predictor's model of the vehicle: a separate vehicle file (None: the vehicle
    /// itself, a perfect prediction model)
    pub prediction: Option<&'a VehicleSpec>,
}

impl<'a> StudyVehicle<'a> {
    /// A vehicle of the paper's form, predicted with itself.
    pub fn paper(
        model: &'a Model,
        params: &'a VehicleParams,
        spec: &'a VehicleSpec,
        plant: &'a AnyVehicleModel,
    ) -> Self {
        Self {
            spec,
            plant,
            paper: Some((model, params)),
            prediction: None,
        }
    }
}

/// What the study runs after the designs: one job each, all in one parallel pass.
enum Job {
    /// the delay budget of combination `c`
    Budget { c: usize },
    /// the fold of cycles of the designs (combination, index) of one loop (identical loops
    /// share one continuation)
    Fold { designs: Vec<(usize, usize)> },
    /// the robust critical speed of combination `c`'s design `d`
    Robust { c: usize, d: usize },
}

/// A job's result.
enum Done {
    Budget(DelayBudget),
    Fold(DesignFold),
    Robust(Robustness),
}

/// Runs the study (see the module docs) on `vehicle`.
///
/// The work is scheduled for the thread pool without changing any number: the designs of
/// each actuator form one chain (the `yaw_rate` optima at every delay, then the
/// `yaw_rate_hitch` ones, which start from them and from the previous delay's optimum,
/// their Nelder–Mead runs side by side), the chains and the `predictor` in parallel; the
/// perfectly predicted `predictor`'s loop is the delay-free one at every τ, so its design
/// is computed once; then the delay
/// budgets, the folds of cycles (one continuation per distinct loop: a design without
/// feedback is the open loop whatever its actuator) and the robust critical speeds all in
/// one parallel pass. Every job is a pure function of its inputs and the results are
/// gathered in the settings' order: the same on any number of threads. One progress step
/// per combination.
///
/// # Errors
/// [`SwayError::Numerical`], also when the open loop has no critical speed in the search range
/// (then nothing is to be raised: [`open_loop_critical_speed`] says so beforehand).
pub fn control_study(
    vehicle: StudyVehicle<'_>,
    s: &StudySettings,
    progress: &dyn Progress,
) -> Result<ControlStudy, SwayError> {
    // the linear side on the paper's model itself where the vehicle has its form (the same
    // numbers as before the plants), else on the plant
    let model: &dyn LoopModel = match vehicle.paper {
        Some((m, _)) => m,
        None => vehicle.plant,
    };
    let prediction_model = vehicle
        .prediction
        .map(AnyVehicleModel::new)
        .transpose()
        .map_err(|e| SwayError::numerical("the predictor's prediction vehicle", e))?;
    let prediction = prediction_model.as_ref().map(|m| m as &dyn LoopModel);
    let open = open_loop_critical_speed(vehicle, s)?.ok_or_else(|| {
        SwayError::numerical(
            "the open-loop critical speed of the control study",
            std::io::Error::other(format!(
                "straight running is stable up to {} m/s without control: nothing to design for \
                 (raise search.speed.v_max_mps)",
                s.search.speed.v_max_mps
            )),
        )
    })?;
    let pairs: Vec<(Structure, Actuator)> = s
        .structures
        .iter()
        .flat_map(|&st| s.actuators.iter().map(move |&a| (st, a)))
        .collect();
    let designs = all_designs(model, prediction, &pairs, s)?;
    // the jobs after the designs
    let mut jobs: Vec<Job> = (0..pairs.len()).map(|c| Job::Budget { c }).collect();
    let mut folds: Vec<(FoldKey, Vec<(usize, usize)>)> = Vec::new();
    for (c, ds) in designs.iter().enumerate() {
        for (d, design) in ds.iter().enumerate() {
            let key = FoldKey::of(design);
            match folds.iter_mut().find(|(k, _)| *k == key) {
                Some((_, list)) => list.push((c, d)),
                None => folds.push((key, vec![(c, d)])),
            }
        }
    }
    jobs.extend(
        folds
            .into_iter()
            .map(|(_, list)| Job::Fold { designs: list }),
    );
    let checked: Vec<Vec<usize>> = designs
        .iter()
        .map(|ds| checked_designs(ds, &s.checked_delays_s))
        .collect();
    for (c, list) in checked.iter().enumerate() {
        jobs.extend(list.iter().map(|&d| Job::Robust { c, d }));
    }
    let done: Vec<Result<Done, SwayError>> = map(&jobs, Split::OnePerTask, &|_, job| match *job {
        Job::Budget { c } => {
            let (structure, _) = pairs[c];
            let p = (structure == Structure::Predictor)
                .then_some(prediction)
                .flatten();
            delay_budget(
                model,
                &designs[c],
                open,
                s.budget_rise_fraction,
                s.budget_tau_tolerance_s,
                p,
                &s.search,
            )
            .map(Done::Budget)
        }
        Job::Fold { designs: ref list } => {
            let (c, d) = list[0];
            design_fold(vehicle.paper.map(|(m, _)| m), &designs[c][d], s).map(Done::Fold)
        }
        Job::Robust { c, d } => {
            let design = &designs[c][d];
            let controller = design.law();
            match (vehicle.paper, vehicle.prediction) {
                (Some((_, params)), None) => robust_critical_speed(
                    params,
                    None,
                    &controller,
                    &s.uncertainty,
                    &s.robustness_speed,
                ),
                _ => robust_critical_speed(
                    vehicle.spec,
                    vehicle.prediction,
                    &controller,
                    &s.uncertainty,
                    &s.robustness_speed,
                ),
            }
            .map(Done::Robust)
        }
    });
    // gather in the order of the jobs
    let mut budgets: Vec<Option<DelayBudget>> = vec![None; pairs.len()];
    let mut fold_of: Vec<Vec<Option<DesignFold>>> =
        designs.iter().map(|ds| vec![None; ds.len()]).collect();
    let mut robust_of: Vec<Vec<Option<Robustness>>> =
        designs.iter().map(|ds| vec![None; ds.len()]).collect();
    for (job, r) in jobs.iter().zip(done) {
        match (job, r?) {
            (Job::Budget { c }, Done::Budget(b)) => budgets[*c] = Some(b),
            (Job::Fold { designs: list }, Done::Fold(f)) => {
                for &(c, d) in list {
                    fold_of[c][d] = Some(DesignFold {
                        tau_s: designs[c][d].tau_s,
                        ..f.clone()
                    });
                }
            }
            (Job::Robust { c, d }, Done::Robust(r)) => robust_of[*c][*d] = Some(r),
            _ => unreachable!("a job's result is of its kind"),
        }
    }
    let mut combinations = Vec::with_capacity(pairs.len());
    for (c, (&(structure, actuator), designs)) in pairs.iter().zip(designs).enumerate() {
        let folds: Vec<DesignFold> = fold_of[c]
            .iter_mut()
            .map(|f| f.take().expect("every design has its fold job"))
            .collect();
        let budget = budgets[c].take().expect("a budget job per combination");
        let checked = checked[c]
            .iter()
            .map(|&d| CheckedDesign {
                tau_s: designs[d].tau_s,
                robustness: robust_of[c][d]
                    .take()
                    .expect("a robust job per checked design"),
                v_fold_mps: folds[d].v_fold_mps,
                v_fold_reason: folds[d].v_fold_reason.clone(),
            })
            .collect();
        combinations.push(Combination {
            structure,
            actuator,
            designs,
            budget,
            checked,
            folds,
        });
        progress.advance(1);
    }
    Ok(ControlStudy {
        open_loop_v_crit_mps: open,
        combinations,
    })
}

/// The indices of the designs checked at `delays` (each snapped to the nearest grid delay),
/// in the order of `delays` (repeats kept, as the table lists them).
fn checked_designs(designs: &[Design], delays: &[f64]) -> Vec<usize> {
    delays
        .iter()
        .filter_map(|&tau| {
            designs
                .iter()
                .enumerate()
                .min_by(|(_, a), (_, b)| (a.tau_s - tau).abs().total_cmp(&(b.tau_s - tau).abs()))
                .map(|(i, _)| i)
        })
        .collect()
}

/// Which continuation a design's fold of cycles is: designs with the same key have the
/// same loop. Without feedback (every gain 0) the loop is the open loop whatever the
/// structure, actuator and delay (u ≡ 0): its fold is computed once, at the delay of the
/// first such design (the delayed form of the same loop, whose fold agrees with the
/// undelayed one's to ~1e-14 m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
enum FoldKey {
    /// no feedback
    OpenLoop,
    /// a design of its own
    Own {
        structure: Structure,
        actuator: Actuator,
        gains: [u64; 3],
        tau_bits: u64,
    },
}

impl FoldKey {
    fn of(d: &Design) -> Self {
        let g = d.gains;
        if d.structure != Structure::Predictor && g == Gains::default() {
            return Self::OpenLoop;
        }
        Self::Own {
            structure: d.structure,
            actuator: d.actuator,
            gains: [
                g.yaw_rate.to_bits(),
                g.hitch_angle.to_bits(),
                g.hitch_rate.to_bits(),
            ],
            tau_bits: d.tau_s.to_bits(),
        }
    }
}

/// The designs of every combination, in the order of `pairs`: one chain per actuator
/// (`yaw_rate` at every delay, then `yaw_rate_hitch` from those optima), the predictor's
/// designs beside them.
fn all_designs(
    model: &dyn LoopModel,
    prediction: Option<&dyn LoopModel>,
    pairs: &[(Structure, Actuator)],
    s: &StudySettings,
) -> Result<Vec<Vec<Design>>, SwayError> {
    let mut actuators: Vec<Actuator> = Vec::new();
    for &(st, a) in pairs {
        if st != Structure::Predictor && !actuators.contains(&a) {
            actuators.push(a);
        }
    }
    enum Chain {
        Output(Actuator),
        Predictor(Actuator),
    }
    let mut chains: Vec<Chain> = actuators.iter().map(|&a| Chain::Output(a)).collect();
    chains.extend(
        pairs
            .iter()
            .filter(|(st, _)| *st == Structure::Predictor)
            .map(|&(_, a)| Chain::Predictor(a)),
    );
    type ChainResult = Vec<((Structure, Actuator), Vec<Design>)>;
    let computed: Vec<Result<ChainResult, SwayError>> =
        map(&chains, Split::OnePerTask, &|_, chain| match *chain {
            Chain::Output(a) => {
                let yaw = designs_over_delays(
                    model,
                    Structure::YawRate,
                    a,
                    &s.delays_s,
                    None,
                    &s.search,
                )?;
                let mut out = vec![((Structure::YawRate, a), yaw)];
                if pairs.contains(&(Structure::YawRateHitch, a)) {
                    let mut hitch: Vec<Design> = Vec::with_capacity(s.delays_s.len());
                    for (i, &tau) in s.delays_s.iter().enumerate() {
                        let warm = hitch.last().map(|d| d.gains);
                        hitch.push(design(
                            model,
                            &LoopLaw::new(Structure::YawRateHitch, a, Gains::default(), tau),
                            None,
                            DesignStart {
                                warm: warm.as_ref(),
                                yaw_rate: Some(&out[0].1[i]),
                            },
                            &s.search,
                        )?);
                    }
                    out.push(((Structure::YawRateHitch, a), hitch));
                }
                Ok(out)
            }
            Chain::Predictor(a) => {
                let ds = match prediction {
                    None => perfect_predictor_designs(model, a, &s.delays_s, &s.search)?,
                    Some(p) => designs_over_delays(
                        model,
                        Structure::Predictor,
                        a,
                        &s.delays_s,
                        Some(p),
                        &s.search,
                    )?,
                };
                Ok(vec![((Structure::Predictor, a), ds)])
            }
        });
    let mut by_pair: Vec<((Structure, Actuator), Vec<Design>)> = Vec::new();
    for r in computed {
        by_pair.extend(r?);
    }
    Ok(pairs
        .iter()
        .map(|p| {
            let i = by_pair
                .iter()
                .position(|(q, _)| q == p)
                .expect("every pair has a chain");
            by_pair[i].1.clone()
        })
        .collect())
}

/// The fold of one optimum and, at a double-Hopf corner, the best gains away from it; for
/// a vehicle with model variants (no paper `model`) none, with the reason.
fn design_fold(
    model: Option<&Model>,
    d: &Design,
    s: &StudySettings,
) -> Result<DesignFold, SwayError> {
    let Some(model) = model else {
        return Ok(DesignFold {
            tau_s: d.tau_s,
            v_fold_mps: None,
            v_fold_reason: Some(
                "the fold of cycles is computed for the paper's model only: this vehicle has \
                 model variants, whose nonlinear chart is not wired into control_design yet"
                    .into(),
            ),
            hopf_v_mps: None,
            away_from_corner: None,
        });
    };
    let r = hopf_and_fold(model, &d.law(), &s.fold, &s.robustness_speed)?;
    let v_fold_mps = r.fold.map(|f| f.v_mps);
    let away_from_corner = match (d.at_double_hopf, v_fold_mps) {
        (true, Some(_)) if s.away_from_corner_samples > 0 => away_from_corner(model, d, s)?,
        _ => None,
    };
    Ok(DesignFold {
        tau_s: d.tau_s,
        v_fold_mps,
        v_fold_reason: r.reason,
        hopf_v_mps: r.hopf.map(|h| h.0),
        away_from_corner,
    })
}

/// [`AwayFromCorner`] of a double-Hopf optimum `d`: None when no gain of the band has a fold.
fn away_from_corner(
    model: &Model,
    d: &Design,
    s: &StudySettings,
) -> Result<Option<AwayFromCorner>, SwayError> {
    let Some(band) = d.bands.iter().find(|b| b.gain == GainName::YawRate) else {
        return Ok(None);
    };
    let d0 = d.gains.yaw_rate;
    let n = s.away_from_corner_samples;
    // the gains in the order they are judged (nearest the corner first, below then above);
    // their folds side by side, the best picked in that order (the first on ties)
    let gains: Vec<Gains> = (1..=n)
        .flat_map(|k| {
            let f = k as f64 / n as f64;
            [d0 - f * (d0 - band.lo), d0 + f * (band.hi - d0)]
        })
        .filter(|&g| g != d0)
        .map(|g| d.gains.with(GainName::YawRate, g))
        .collect();
    let folds: Vec<Result<Option<f64>, SwayError>> =
        map(&gains, Split::OnePerTask, &|_, &gains| {
            let law = d.law().with_gains(gains);
            fold_speed(model, &law, &s.fold, &s.robustness_speed).map(|(v, _)| v)
        });
    let mut best: Option<(Gains, f64)> = None;
    let mut tried = 0;
    for (&gains, v) in gains.iter().zip(folds) {
        let Some(v) = v? else {
            continue;
        };
        tried += 1;
        if best.is_none_or(|(_, b)| v > b) {
            best = Some((gains, v));
        }
    }
    let best = match best {
        Some((gains, v_fold_mps)) => {
            let law = d.law().with_gains(gains);
            let v_crit = CappedSpeed::of(
                sway::control::critical_speed(model, &law, None, &s.search.speed)?,
                s.search.speed.v_max_mps,
            );
            Some(AwayFromCorner {
                gains,
                v_fold_mps,
                v_crit_mps: v_crit.found(),
                stable_up_to_mps: v_crit.stable_up_to(),
                reason: v_crit.reason("straight running with these gains", SEARCH_CAP),
                tried: 0,
            })
        }
        None => None,
    };
    Ok(best.map(|b| AwayFromCorner { tried, ..b }))
}

/// The simulation check: at `speed_fraction`·V_crit (open loop) and constant speed, the
/// smallest of `kicks_deg` (a hitch-angle kick θ(0), the other states 0) that makes the
/// open loop sway (class "sustained_sway" at the horizon) is applied to the loop closed by
/// each structure's design at τ = `delay_s` (the study's optimum there, with
/// `actuator`); a design passes when its run settles (|θ| below the settle threshold over
/// the final window).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimulationCheck {
    /// τ \[s\]: must be one of the grid's delays
    pub delay_s: f64,
    /// V / V_crit of the open loop \[-\]
    pub speed_fraction: f64,
    /// candidate kicks θ(0) \[deg\], tried in increasing order on the open loop
    pub kicks_deg: Vec<f64>,
    /// simulated time \[s\]
    pub horizon_s: f64,
    /// the actuator of the checked designs
    pub actuator: Actuator,
}

impl Default for SimulationCheck {
    fn default() -> Self {
        Self {
            delay_s: 0.6,
            speed_fraction: 0.95,
            kicks_deg: vec![2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 15.0],
            horizon_s: 60.0,
            actuator: Actuator::Steering,
        }
    }
}

/// The outcome of the simulation check ([`simulation_check`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimulationOutcome {
    pub delay_s: f64,
    pub speed_mps: f64,
    /// the kick θ(0) \[deg\] (the smallest candidate that makes the open loop sway)
    pub kick_deg: f64,
    pub open_loop_sways: bool,
    pub open_loop_final_amplitude_deg: Option<f64>,
    pub designs: Vec<SimulatedDesign>,
}

/// One design's run in the simulation check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimulatedDesign {
    pub structure: &'static str,
    pub actuator: &'static str,
    pub gains: Gains,
    /// the run settled (|θ| below the settle threshold over the final window)
    pub decays: bool,
    /// max |θ| over the final window \[deg\]
    pub final_amplitude_deg: Option<f64>,
    /// the run's class (`settled`, `sustained_sway`, …)
    pub class: SwayClass,
}

/// A labelled θ(t) curve: (label, [(t \[s\], θ \[deg\])]).
pub type Curve = (String, Vec<(f64, f64)>);

/// Runs the simulation check `sc` of the study `r` on `model`: the outcome and the θ(t)
/// curves (open loop first); the predictor predicts with `prediction` (the vehicle itself
/// when `None`).
///
/// # Errors
/// [`SwayError::Config`] without kicks; [`SwayError::Numerical`] when a run fails.
pub fn simulation_check(
    model: &trailer_model::Model,
    r: &ControlStudy,
    sc: &SimulationCheck,
    prediction: Option<&PredictionVehicle>,
) -> Result<(SimulationOutcome, Vec<Curve>), SwayError> {
    let speed = sc.speed_fraction * r.open_loop_v_crit_mps;
    let run = |controller: Option<LoopLaw>, kick_deg: f64| {
        let spec = SimSpec {
            early_stop: sway::sim::EarlyStop::Never,
            steering: Default::default(),
            profile: SpeedProfile::Constant { speed_mps: speed },
            controller,
            horizon_s: sc.horizon_s,
            action_s: 0.0,
            settings: RunSettings::default(),
        };
        let x0 = State4::new(0.0, 0.0, 0.0, kick_deg.to_radians());
        simulate(model, &spec, x0, Recording::Every { step_s: 0.02 })
    };
    let curve = |label: String, res: &sway::sim::SimResult<4>| -> Curve {
        (
            label,
            res.trajectory
                .iter()
                .map(|s| (s.t, s.x[trailer_model::HITCH_ANGLE].to_degrees()))
                .collect(),
        )
    };
    let mut kicks = sc.kicks_deg.clone();
    kicks.sort_by(f64::total_cmp);
    let mut open = None;
    for &k in &kicks {
        let res = run(None, k)?;
        let sways = res.metrics.class == SwayClass::SustainedSway;
        open = Some((k, res, sways));
        if sways {
            break;
        }
    }
    let Some((kick_deg, open_run, open_loop_sways)) = open else {
        return Err(SwayError::config(
            std::path::Path::new("control_design.toml"),
            "simulation_check.kicks_deg",
            "expected at least one kick",
        ));
    };
    let mut curves = vec![curve("open loop".into(), &open_run)];
    let mut designs = Vec::new();
    for c in r.combinations.iter().filter(|c| c.actuator == sc.actuator) {
        let Some(d) = c
            .designs
            .iter()
            .find(|d| (d.tau_s - sc.delay_s).abs() < 1e-9)
        else {
            continue;
        };
        let law = LoopLaw {
            prediction_vehicle: prediction.and_then(|p| p.params),
            ..d.law()
        };
        let res = run(Some(law), kick_deg)?;
        curves.push(curve(
            format!("{} + {}", c.structure.as_str(), c.actuator.as_str()),
            &res,
        ));
        designs.push(SimulatedDesign {
            structure: c.structure.as_str(),
            actuator: c.actuator.as_str(),
            gains: d.gains,
            decays: res.metrics.class == SwayClass::Settled,
            final_amplitude_deg: res.metrics.final_amplitude_deg,
            class: res.metrics.class,
        });
    }
    Ok((
        SimulationOutcome {
            delay_s: sc.delay_s,
            speed_mps: speed,
            kick_deg,
            open_loop_sways,
            open_loop_final_amplitude_deg: open_run.metrics.final_amplitude_deg,
            designs,
        },
        curves,
    ))
}
