//! The sway modes of straight running: every oscillatory eigenvalue pair of the open loop
//! along the speed, followed from speed to speed, with its frequency, damping ratio and
//! shape (which unit swings hardest), and the speeds where it crosses the imaginary axis.
//!
//! The eigenvalues are those of A(V) = ∂f/∂y at straight running in the chain's own layout
//! ([`ChainModel`]: y = \[v, r, θ̇1, θ1, …\]); the paper layout's A is similar to it (the
//! map between the layouts is linear at y = 0), so the spectrum is the engines' one. An
//! eigenvector y of λ gives each unit's heading amplitude ψ_i = r/λ + θ_1 + … + θ_i (the
//! towing unit's heading ψ_0 = r/λ); the shape is |ψ_i| over the largest, and the unit of
//! the largest leads the mode.

use nalgebra::{Complex, DMatrix};
use serde::Serialize;
use trailer_model::{ChainModel, Plant};

/// An eigenvalue counts as oscillatory when Im λ exceeds this fraction of max(|λ|, 1 1/s)
/// (a real eigenvalue's imaginary part is exactly 0 from the Schur form; a pair just split
/// off the real axis is kept).
const OSCILLATORY: f64 = 1e-9;

/// Bisection of a crossing stops at this bracket width \[m/s\].
pub const CROSSING_TOLERANCE_MPS: f64 = 1e-9;

/// One mode at one speed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModePoint {
    /// V \[m/s\]
    pub speed_mps: f64,
    /// Re λ \[1/s\]
    pub real_per_s: f64,
    /// Im λ = ω \[rad/s\] (> 0)
    pub omega_rad_s: f64,
    /// ω / 2π \[Hz\]
    pub frequency_hz: f64,
    /// ζ = −Re λ / |λ| \[-\] (negative: the mode grows)
    pub damping_ratio: f64,
    /// the unit with the largest heading amplitude (0: the towing unit, i: the i-th towed
    /// unit from the front)
    pub leading_unit: usize,
    /// |ψ_i| / max_j |ψ_j| of every unit, towing unit first \[-\]
    pub heading_amplitudes: Vec<f64>,
    /// the phase of every unit's heading against the leading unit's \[deg\], in (−180, 180]
    pub heading_phases_deg: Vec<f64>,
}

impl ModePoint {
    fn new<const N: usize>(
        chain: &ChainModel<N>,
        a: &DMatrix<f64>,
        speed: f64,
        l: Complex<f64>,
    ) -> Self {
        let y = eigenvector(a, l);
        let units = chain.units();
        let mut psi = Vec::with_capacity(units);
        let mut heading = y[1] / l;
        psi.push(heading);
        for i in 1..units {
            heading += y[ChainModel::<N>::articulation_angle_index(i)];
            psi.push(heading);
        }
        let (leading_unit, largest) =
            psi.iter().enumerate().fold((0, 0.0_f64), |(k, m), (i, p)| {
                if p.norm() > m { (i, p.norm()) } else { (k, m) }
            });
        let reference = psi[leading_unit];
        Self {
            speed_mps: speed,
            real_per_s: l.re,
            omega_rad_s: l.im,
            frequency_hz: l.im / std::f64::consts::TAU,
            damping_ratio: -l.re / l.norm(),
            leading_unit,
            heading_amplitudes: psi.iter().map(|p| p.norm() / largest).collect(),
            heading_phases_deg: psi
                .iter()
                .map(|p| (p / reference).arg().to_degrees())
                .collect(),
        }
    }

    fn eigenvalue(&self) -> Complex<f64> {
        Complex::new(self.real_per_s, self.omega_rad_s)
    }
}

/// Where a mode crosses the imaginary axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeCrossing {
    /// the direction with rising speed
    pub direction: CrossingDirection,
    /// the mode there (Re λ = 0 to [`CROSSING_TOLERANCE_MPS`] in V)
    pub at: ModePoint,
}

/// Whether a mode loses or regains stability with rising speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossingDirection {
    /// Re λ rises through 0: a Hopf point of straight running, sway of this mode starts
    LosesStability,
    /// Re λ falls through 0
    RegainsStability,
}

/// One oscillatory mode followed along the speed grid.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SwayMode {
    /// the mode at every grid speed where it is oscillatory (a pair may turn into two real
    /// eigenvalues: the mode then ends)
    pub points: Vec<ModePoint>,
    /// its crossings of the imaginary axis, by rising speed
    pub crossings: Vec<ModeCrossing>,
}

impl SwayMode {
    /// The first speed where it loses stability, if it does on the grid.
    pub fn loses_stability(&self) -> Option<&ModePoint> {
        self.crossings
            .iter()
            .find(|c| c.direction == CrossingDirection::LosesStability)
            .map(|c| &c.at)
    }

    /// The mode at grid speed `speed_mps` (exactly a grid speed), if it is oscillatory there.
    pub fn at(&self, speed_mps: f64) -> Option<&ModePoint> {
        self.points.iter().find(|p| p.speed_mps == speed_mps)
    }

    /// The point that names the mode: where it first loses stability, else at
    /// `reference_mps` when it exists there, else in the middle of its speeds.
    pub fn characteristic(&self, reference_mps: Option<f64>) -> &ModePoint {
        self.loses_stability()
            .or_else(|| reference_mps.and_then(|v| self.at(v)))
            .unwrap_or(&self.points[self.points.len() / 2])
    }
}

/// The oscillatory eigenvalues (Im λ > 0) of A at `speed`, with A.
fn upper_spectrum<const N: usize>(
    chain: &ChainModel<N>,
    speed: f64,
) -> (DMatrix<f64>, Vec<Complex<f64>>) {
    let a = chain.plant_linearization(speed).a;
    let ev = trailer_model::sorted_spectrum(&a);
    let upper = ev
        .into_iter()
        .filter(|l| l.im > OSCILLATORY * l.norm().max(1.0))
        .collect();
    (DMatrix::from_column_slice(N, N, a.as_slice()), upper)
}

/// The eigenvector of the simple eigenvalue `l` of `a`: the right singular vector of the
/// smallest singular value of A − λI.
fn eigenvector(a: &DMatrix<f64>, l: Complex<f64>) -> Vec<Complex<f64>> {
    let n = a.nrows();
    let m = DMatrix::<Complex<f64>>::from_fn(n, n, |i, j| {
        Complex::new(a[(i, j)], 0.0) - if i == j { l } else { Complex::new(0.0, 0.0) }
    });
    let svd = m.svd(false, true);
    let k = svd
        .singular_values
        .iter()
        .enumerate()
        .fold(
            (0, f64::INFINITY),
            |(k, s), (i, &v)| if v < s { (i, v) } else { (k, s) },
        )
        .0;
    let v_t = svd.v_t.expect("requested");
    (0..n).map(|j| v_t[(k, j)].conj()).collect()
}

/// The modes of `chain` along the increasing speeds `speeds` \[m/s\]: the oscillatory
/// eigenvalues at consecutive speeds are paired closest first (a pair farther apart than
/// half the larger modulus starts a new mode), and every change of sign of Re λ along a
/// mode is bisected to [`CROSSING_TOLERANCE_MPS`], following the eigenvalue nearest to the
/// straight line between the bracket's ends.
pub fn sway_modes<const N: usize>(chain: &ChainModel<N>, speeds: &[f64]) -> Vec<SwayMode> {
    let mut modes: Vec<SwayMode> = Vec::new();
    // modes still followed: index into `modes`
    let mut open: Vec<usize> = Vec::new();
    for &v in speeds {
        let (a, upper) = upper_spectrum(chain, v);
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (oi, &m) in open.iter().enumerate() {
            let last = modes[m]
                .points
                .last()
                .expect("a mode has a point")
                .eigenvalue();
            for (ui, l) in upper.iter().enumerate() {
                let d = (l - last).norm();
                if d <= 0.5 * l.norm().max(last.norm()) {
                    pairs.push((d, oi, ui));
                }
            }
        }
        pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
        let (mut used_open, mut used_upper) = (vec![false; open.len()], vec![false; upper.len()]);
        let mut next_open = Vec::new();
        for (_, oi, ui) in pairs {
            if used_open[oi] || used_upper[ui] {
                continue;
            }
            used_open[oi] = true;
            used_upper[ui] = true;
            modes[open[oi]]
                .points
                .push(ModePoint::new(chain, &a, v, upper[ui]));
            next_open.push(open[oi]);
        }
        for (ui, l) in upper.iter().enumerate() {
            if !used_upper[ui] {
                modes.push(SwayMode {
                    points: vec![ModePoint::new(chain, &a, v, *l)],
                    crossings: Vec::new(),
                });
                next_open.push(modes.len() - 1);
            }
        }
        open = next_open;
    }
    for mode in &mut modes {
        mode.crossings = crossings(chain, &mode.points);
    }
    modes
}

/// The sign changes of Re λ between consecutive points, bisected.
fn crossings<const N: usize>(chain: &ChainModel<N>, points: &[ModePoint]) -> Vec<ModeCrossing> {
    let mut out = Vec::new();
    for w in points.windows(2) {
        let (p, q) = (&w[0], &w[1]);
        if (p.real_per_s < 0.0) == (q.real_per_s < 0.0) {
            continue;
        }
        let direction = if q.real_per_s >= 0.0 {
            CrossingDirection::LosesStability
        } else {
            CrossingDirection::RegainsStability
        };
        let (lp, lq) = (p.eigenvalue(), q.eigenvalue());
        let near = |v: f64| {
            let s = (v - p.speed_mps) / (q.speed_mps - p.speed_mps);
            let guess = lp + (lq - lp) * s;
            let (a, upper) = upper_spectrum(chain, v);
            upper
                .into_iter()
                .min_by(|x, y| (x - guess).norm().total_cmp(&(y - guess).norm()))
                .map(|l| (a, l))
        };
        let (mut lo, mut hi) = (p.speed_mps, q.speed_mps);
        let below = p.real_per_s < 0.0;
        while hi - lo > CROSSING_TOLERANCE_MPS {
            let mid = 0.5 * (lo + hi);
            let Some((_, l)) = near(mid) else { break };
            if (l.re < 0.0) == below {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let v = 0.5 * (lo + hi);
        if let Some((a, l)) = near(v) {
            out.push(ModeCrossing {
                direction,
                at: ModePoint::new(chain, &a, v, l),
            });
        }
    }
    out
}
