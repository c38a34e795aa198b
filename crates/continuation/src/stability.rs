//! Stability information and special points recorded on branches.

use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// What the spectrum of a branch point means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SpectrumKind {
    /// eigenvalues / characteristic roots λ of an equilibrium: stable iff all Re λ < 0
    Eigenvalues,
    /// Floquet multipliers μ of a periodic orbit: stable iff all nontrivial |μ| < 1
    FloquetMultipliers,
}

/// Stability of one branch point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stability {
    /// eigenvalues or multipliers
    pub kind: SpectrumKind,
    /// eigenvalues sorted by decreasing real part, or multipliers by decreasing modulus
    /// (for delay equations only the leading part of the infinite spectrum)
    pub values: Vec<Complex64>,
    /// index in `values` of the trivial Floquet multiplier (the one closest to 1)
    pub trivial: Option<usize>,
    /// number of nontrivial values in the unstable region
    pub unstable: usize,
}

impl Stability {
    /// Build from eigenvalues (sorts them by decreasing real part).
    pub fn from_eigenvalues(mut values: Vec<Complex64>) -> Self {
        values.sort_by(|a, b| b.re.total_cmp(&a.re).then(b.im.total_cmp(&a.im)));
        let unstable = values.iter().filter(|z| z.re > 0.0).count();
        Self {
            kind: SpectrumKind::Eigenvalues,
            values,
            trivial: None,
            unstable,
        }
    }

    /// Build from Floquet multipliers; the one closest to 1 is taken as the trivial one.
    pub fn from_multipliers(mut values: Vec<Complex64>) -> Self {
        values.sort_by(|a, b| b.norm().total_cmp(&a.norm()).then(b.im.total_cmp(&a.im)));
        let trivial = values
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - 1.0).norm().total_cmp(&(b.1 - 1.0).norm()))
            .map(|(i, _)| i);
        let unstable = values
            .iter()
            .enumerate()
            .filter(|(i, z)| Some(*i) != trivial && z.norm() > 1.0)
            .count();
        Self {
            kind: SpectrumKind::FloquetMultipliers,
            values,
            trivial,
            unstable,
        }
    }

    /// The bifurcation of a cycle between the multiplier spectra `a` and `b` with different
    /// numbers of unstable multipliers, from the multiplier that crossed (the smallest one
    /// outside the unit circle on the unstable side): a complex pair is a torus
    /// (Neimark–Sacker) point, a real negative one a period doubling, a real positive one a
    /// fold. `None` when the counts agree.
    pub fn multiplier_crossing(a: &Stability, b: &Stability) -> Option<SpecialKind> {
        if a.unstable == b.unstable {
            return None;
        }
        let outside = if b.unstable > a.unstable { b } else { a };
        let z = outside
            .nontrivial()
            .filter(|z| z.norm() > 1.0)
            .min_by(|x, y| x.norm().total_cmp(&y.norm()))?;
        Some(if z.im.abs() > 1e-6 {
            SpecialKind::Torus
        } else if z.re < 0.0 {
            SpecialKind::PeriodDoubling
        } else {
            SpecialKind::Fold
        })
    }

    /// linearly stable (no nontrivial value in the unstable region)
    pub fn is_stable(&self) -> bool {
        self.unstable == 0
    }

    /// the trivial Floquet multiplier, if any
    pub fn trivial_multiplier(&self) -> Option<Complex64> {
        self.trivial.map(|i| self.values[i])
    }

    /// nontrivial values (all values but the trivial multiplier)
    pub fn nontrivial(&self) -> impl Iterator<Item = Complex64> + '_ {
        self.values
            .iter()
            .enumerate()
            .filter(move |(i, _)| Some(*i) != self.trivial)
            .map(|(_, z)| *z)
    }

    /// the value most likely responsible for a special point of this kind
    pub fn critical(&self, kind: SpecialKind) -> Option<Complex64> {
        let pick = |f: &dyn Fn(&Complex64) -> f64, keep: &dyn Fn(&Complex64) -> bool| {
            self.nontrivial()
                .filter(|z| keep(z))
                .min_by(|a, b| f(a).total_cmp(&f(b)))
        };
        match (self.kind, kind) {
            // on a Hopf curve the values are the remaining spectrum: the second pair
            (SpectrumKind::Eigenvalues, SpecialKind::Hopf | SpecialKind::DoubleHopf) => {
                pick(&|z| z.re.abs(), &|z| z.im > 1e-9)
            }
            (SpectrumKind::Eigenvalues, _) => pick(&|z| z.norm(), &|z| z.im.abs() <= 1e-9),
            (SpectrumKind::FloquetMultipliers, SpecialKind::PeriodDoubling) => {
                pick(&|z| (z + 1.0).norm(), &|_| true)
            }
            (SpectrumKind::FloquetMultipliers, SpecialKind::Torus) => {
                pick(&|z| (z.norm() - 1.0).abs(), &|z| z.im > 1e-9)
            }
            (SpectrumKind::FloquetMultipliers, _) => pick(&|z| (z - 1.0).norm(), &|_| true),
        }
    }
}

/// Kinds of special points on a branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SpecialKind {
    /// Hopf bifurcation of an equilibrium (complex pair crosses the imaginary axis)
    Hopf,
    /// turning point in the parameter (fold / saddle-node; for cycles: multiplier through +1)
    Fold,
    /// real eigenvalue through 0 without a parameter turning point (branch point)
    RealCrossing,
    /// Floquet multiplier through −1
    PeriodDoubling,
    /// complex pair of Floquet multipliers through the unit circle (Neimark–Sacker)
    Torus,
    /// branch point of an equilibrium branch (pitchfork / transcritical: the bordered
    /// Jacobian of the branch is singular; another branch crosses here)
    BranchPoint,
    /// codimension two, on a Hopf curve: a second complex pair on the imaginary axis
    DoubleHopf,
    /// codimension two, on a Hopf or fold curve: a real eigenvalue 0 and a pair ±iω
    ZeroHopf,
    /// codimension two, on a Hopf or fold curve: a double zero eigenvalue (ω → 0)
    BogdanovTakens,
    /// codimension two, on a fold curve of equilibria: the fold curve has a cusp
    Cusp,
    /// codimension two, on a Hopf curve: the Hopf point changes criticality (generalised
    /// Hopf / Bautin point; a fold-of-cycles curve ends here)
    CriticalityChange,
    /// codimension two, on a fold-of-cycles curve: two folds of cycles meet (cusp of cycles)
    CuspOfCycles,
}

impl std::fmt::Display for SpecialKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self {
            SpecialKind::Hopf => "Hopf point",
            SpecialKind::Fold => "fold",
            SpecialKind::RealCrossing => "real eigenvalue crossing",
            SpecialKind::PeriodDoubling => "period-doubling point",
            SpecialKind::Torus => "torus (Neimark-Sacker) point",
            SpecialKind::BranchPoint => "branch point",
            SpecialKind::DoubleHopf => "double-Hopf point",
            SpecialKind::ZeroHopf => "zero-Hopf point",
            SpecialKind::BogdanovTakens => "Bogdanov-Takens point",
            SpecialKind::Cusp => "cusp point",
            SpecialKind::CriticalityChange => "criticality change (generalised Hopf point)",
            SpecialKind::CuspOfCycles => "cusp of cycles",
        };
        f.write_str(s)
    }
}

/// Whether a special point was located (solved for) or only detected between two points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Location {
    /// the point sits on the special point to the location tolerance
    Located,
    /// the special point lies between this point and the previous one
    Detected,
}

/// A special point recorded on a branch point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpecialPoint {
    /// what it is
    pub kind: SpecialKind,
    /// located or only detected
    pub location: Location,
    /// parameter value
    pub parameter: f64,
    /// the critical eigenvalue / multiplier (for a Hopf point ≈ iω)
    pub critical: Option<Complex64>,
    /// d(test function)/d(parameter) across the point (for a Hopf point: d Re λ / dp)
    pub transversality: Option<f64>,
}

/// Criticality of a Hopf bifurcation, decided from the computed cycle branch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Criticality {
    /// cycles born on the side where the equilibrium is stable (they are unstable)
    Subcritical,
    /// cycles born on the side where the equilibrium is unstable
    Supercritical,
}

impl std::fmt::Display for Criticality {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Criticality::Subcritical => "subcritical",
            Criticality::Supercritical => "supercritical",
        })
    }
}
