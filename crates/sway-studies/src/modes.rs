//! The sway modes of a vehicle as `linear` and `combination` report them: every oscillatory
//! mode of straight running followed along the speed ([`sway::combination::modes`]), with
//! the speed where it loses stability, its frequency and damping at a reference speed, and
//! the unit that leads its shape, named by its key in the vehicle file.

use serde::Serialize;
use sway::combination::modes::{SwayMode, sway_modes};
use trailer_model::{AnyVehicleModel, AsChain, ChainSpec, with_plant};

use sway::SwayError;

/// One mode in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeSummary {
    /// 1, 2, …: the modes that lose stability first, by that speed, then the others by
    /// their damping at the reference speed
    pub mode: usize,
    /// the unit with the largest heading amplitude (0: the towing unit, i: the i-th towed
    /// unit from the front), where the mode loses stability, else at the reference speed
    pub leading_unit: usize,
    /// its key in the vehicle file (`tractor`, `trailer` or `trailers[i]`)
    pub leading_unit_key: String,
    /// where the mode loses stability (its Hopf point of straight running) \[m/s\]; null
    /// when it does not on the speeds followed (`reason`)
    pub crossing_speed_mps: Option<f64>,
    /// its frequency there \[Hz\]
    pub crossing_frequency_hz: Option<f64>,
    /// where it regains stability above its crossing \[m/s\], if it does
    #[serde(skip_serializing_if = "Option::is_none")]
    pub regains_stability_at_mps: Option<f64>,
    /// why `crossing_speed_mps` is null
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// the reference speed of the next three fields \[m/s\]
    pub reference_speed_mps: f64,
    /// its frequency at the reference speed \[Hz\] (null where it is not oscillatory there)
    pub frequency_hz: Option<f64>,
    /// its damping ratio ζ = −Re λ/|λ| at the reference speed \[-\]
    pub damping_ratio: Option<f64>,
    /// |ψ_i| over the largest, every unit, towing unit first, at the point of
    /// `leading_unit` \[-\]
    pub heading_amplitudes: Vec<f64>,
}

/// One row of `modes.csv`: a mode at one speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ModeRow {
    /// the mode's number in the summary
    pub mode: usize,
    /// V \[m/s\]
    pub speed_mps: f64,
    /// Re λ \[1/s\]
    pub real_per_s: f64,
    /// Im λ / 2π \[Hz\]
    pub frequency_hz: f64,
    /// ζ \[-\]
    pub damping_ratio: f64,
    /// the leading unit there
    pub leading_unit: usize,
}

/// The modes of a vehicle with their summaries (in the same order).
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// the modes, in the summaries' order
    pub modes: Vec<SwayMode>,
    /// their summaries
    pub summaries: Vec<ModeSummary>,
}

impl Modes {
    /// Every mode at every speed, for `modes.csv`.
    pub fn rows(&self) -> Vec<ModeRow> {
        self.modes
            .iter()
            .zip(&self.summaries)
            .flat_map(|(m, s)| {
                m.points.iter().map(|p| ModeRow {
                    mode: s.mode,
                    speed_mps: p.speed_mps,
                    real_per_s: p.real_per_s,
                    frequency_hz: p.frequency_hz,
                    damping_ratio: p.damping_ratio,
                    leading_unit: p.leading_unit,
                })
            })
            .collect()
    }
}

/// The key of unit `i` of `chain` in its file.
pub fn unit_key(chain: &ChainSpec, i: usize) -> String {
    if i == 0 {
        "tractor".into()
    } else {
        chain.towed_unit_key(i - 1)
    }
}

/// The modes of `plant` along `speeds` (increasing) with `reference_mps` added, summarised.
///
/// # Errors
/// [`SwayError::Model`] when the vehicle does not build as a chain.
pub fn modes_of(
    plant: &AnyVehicleModel,
    speeds: &[f64],
    reference_mps: f64,
) -> Result<Modes, SwayError> {
    let mut grid: Vec<f64> = speeds.to_vec();
    if let Err(k) = grid.binary_search_by(|v| v.total_cmp(&reference_mps)) {
        grid.insert(k, reference_mps);
    }
    let (modes, chain) = with_plant!(plant, m => {
        let chain = m.as_chain()?;
        (sway_modes(&chain, &grid), chain.spec().clone())
    });
    let (lo, hi) = (grid[0], grid[grid.len() - 1]);
    let mut keyed: Vec<(SwayMode, ModeSummary)> = modes
        .into_iter()
        .map(|m| {
            let s = summary(&m, &chain, reference_mps, (lo, hi));
            (m, s)
        })
        .collect();
    keyed.sort_by(|(_, a), (_, b)| {
        let key = |s: &ModeSummary| {
            (
                s.crossing_speed_mps.unwrap_or(f64::INFINITY),
                s.damping_ratio.unwrap_or(f64::INFINITY),
            )
        };
        let (ka, kb) = (key(a), key(b));
        ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    let (modes, mut summaries): (Vec<_>, Vec<_>) = keyed.into_iter().unzip();
    for (k, s) in summaries.iter_mut().enumerate() {
        s.mode = k + 1;
    }
    Ok(Modes { modes, summaries })
}

fn summary(
    m: &SwayMode,
    chain: &ChainSpec,
    reference_mps: f64,
    (lo, hi): (f64, f64),
) -> ModeSummary {
    let lead = m.characteristic(Some(reference_mps));
    let at_reference = m.at(reference_mps);
    let crossing = m.loses_stability();
    let regains = crossing.and_then(|c| {
        m.crossings
            .iter()
            .find(|r| {
                r.at.speed_mps > c.speed_mps
                    && r.direction != sway::combination::modes::CrossingDirection::LosesStability
            })
            .map(|r| r.at.speed_mps)
    });
    let (first, last) = (
        m.points[0].speed_mps,
        m.points[m.points.len() - 1].speed_mps,
    );
    let reason = crossing.is_none().then(|| {
        let unstable = m.points[0].real_per_s >= 0.0;
        let span = if first > lo || last < hi {
            format!(" (it is oscillatory from {first} to {last} m/s of the speeds {lo}–{hi} m/s followed)")
        } else {
            format!(" ({lo}–{hi} m/s followed)")
        };
        if unstable {
            format!("the mode is unstable from the lowest speed on{span}")
        } else {
            format!("the mode stays damped at every speed{span}")
        }
    });
    ModeSummary {
        mode: 0,
        leading_unit: lead.leading_unit,
        leading_unit_key: unit_key(chain, lead.leading_unit),
        crossing_speed_mps: crossing.map(|c| c.speed_mps),
        crossing_frequency_hz: crossing.map(|c| c.frequency_hz),
        regains_stability_at_mps: regains,
        reason,
        reference_speed_mps: reference_mps,
        frequency_hz: at_reference.map(|p| p.frequency_hz),
        damping_ratio: at_reference.map(|p| p.damping_ratio),
        heading_amplitudes: lead.heading_amplitudes.clone(),
    }
}
