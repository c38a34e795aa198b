//! Rightmost characteristic roots: spectral seeds confirmed and polished by Newton's method.

use num_complex::Complex64;

use crate::dde::{LinearDde, NewtonOptions, sort_rightmost};
use crate::error::{Result, StabilityError};
use crate::spectral::ChebyshevCollocation;

/// Collocation eigenvalues are trusted as seeds only for |λ|·τ_max ≤ RESOLVED·N (about π
/// collocation points per wavelength of e^{λθ} over the delay interval, Chebyshev's minimum);
/// inaccurate seeds inside that range are caught by the seed-to-root distance check.
const RESOLVED: f64 = 1.0;

/// Options of [`rightmost_roots`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootOptions {
    /// first Chebyshev degree N tried for the seeds
    pub initial_degree: usize,
    /// the degree is raised by half until the seeds are confirmed, up to this one
    pub max_degree: usize,
    /// a seed is confirmed when Newton moves it by less than this (relative to max(1, |λ|))
    pub seed_tolerance: f64,
    /// Newton polishing
    pub newton: NewtonOptions,
}

impl RootOptions {
    /// The default options with the degree cap raised to what `count` roots need: the
    /// k-th conjugate pair of a delayed system lies near |Im λ|·τ ≈ 2πk, so `count` roots
    /// reach |λ|·τ ≈ π·count, which the collocation resolves at N ≥ |λ|·τ / RESOLVED
    /// (with a margin of 1.2).
    pub fn for_count(count: usize) -> Self {
        let needed = (1.2 * std::f64::consts::PI * count as f64 / RESOLVED).ceil() as usize;
        let defaults = Self::default();
        Self {
            max_degree: defaults.max_degree.max(needed),
            ..defaults
        }
    }
}

impl Default for RootOptions {
    fn default() -> Self {
        Self {
            initial_degree: 16,
            max_degree: 256,
            seed_tolerance: 1e-4,
            newton: NewtonOptions::default(),
        }
    }
}

/// Rightmost `count` characteristic roots of `dde` (conjugates listed separately), sorted by
/// decreasing real part, each polished by Newton's method on `det Δ(λ)` to relative accuracy
/// ~1e-14 (simple roots; ~1e-8, the round-off floor, for a double root).
///
/// Seeds are the rightmost eigenvalues of the Chebyshev collocation ([`ChebyshevCollocation`]);
/// the degree is raised by half until every polished root lies within `seed_tolerance` of its
/// seed. Only eigenvalues with |λ|·τ_max ≤ N are used as seeds (higher ones are not resolved; the degree is raised if fewer than `count` are left).
/// A root beyond that frequency yet among the `count` rightmost would be missed; for retarded
/// DDEs the roots of high frequency lie far to the left, and [`crate::RankOneFeedback`] checks
/// the right-half-plane count exactly by D-subdivision.
pub fn rightmost_roots(
    dde: &LinearDde,
    count: usize,
    options: &RootOptions,
) -> Result<Vec<Complex64>> {
    let newton = options.newton;
    confirmed_rightmost(dde, count, options, |s| dde.polish_root(s, &newton)).map(|(r, _)| r)
}

/// Shared driver: returns the roots and the Chebyshev degree that confirmed them.
pub(crate) fn confirmed_rightmost<P>(
    dde: &LinearDde,
    count: usize,
    options: &RootOptions,
    polish: P,
) -> Result<(Vec<Complex64>, usize)>
where
    P: Fn(Complex64) -> Result<Complex64>,
{
    let mut degree = options.initial_degree.max(2);
    loop {
        let seeds = ChebyshevCollocation { degree }.seed_eigenvalues(dde)?;
        // eigenvalues with |λ|·τ_max beyond RESOLVED·N are not resolved by the collocation
        // (spurious high-frequency modes): they are not used as seeds
        let limit = RESOLVED * degree as f64;
        let tau = dde.max_delay();
        let resolved = |s: &&Complex64| s.norm() * tau <= limit;
        let unresolved_exist = seeds.iter().any(|s| !resolved(&s));
        let mut upper: Vec<Complex64> = Vec::new();
        let mut worst = 0.0_f64;
        let mut listed = 0;
        for s in seeds.iter().filter(|s| s.im >= 0.0).filter(resolved) {
            if listed >= count {
                break;
            }
            let mut r = match polish(*s) {
                Ok(r) => r,
                Err(_) => {
                    worst = f64::INFINITY;
                    break;
                }
            };
            // a seed that converged to another root moves far from it: that is what forces a
            // finer discretisation (two close seeds polished to one point are a double root)
            worst = worst.max((r - s).norm() / s.norm().max(1.0));
            r.im = if r.im.abs() <= 1e-12 * r.norm().max(1.0) {
                0.0
            } else {
                r.im.abs()
            };
            listed += if r.im > 0.0 { 2 } else { 1 };
            upper.push(r);
        }
        if listed < count && unresolved_exist {
            // not enough resolved roots: refine
            worst = f64::INFINITY;
        }
        if worst <= options.seed_tolerance {
            let mut all: Vec<Complex64> = Vec::with_capacity(2 * upper.len());
            for r in upper {
                all.push(r);
                if r.im > 0.0 {
                    all.push(r.conj());
                }
            }
            sort_rightmost(&mut all);
            all.truncate(count);
            return Ok((all, degree));
        }
        if degree >= options.max_degree || dde.delayed_terms().is_empty() {
            return Err(StabilityError::Unconfirmed {
                degree,
                mismatch: worst,
            });
        }
        degree = (degree * 3 / 2).min(options.max_degree);
    }
}

/// Spectral abscissa `max Re λ` over the characteristic roots, from [`rightmost_roots`]
/// (accuracy: that of the polished rightmost root, ~1e-12 relative).
pub fn spectral_abscissa(dde: &LinearDde, options: &RootOptions) -> Result<f64> {
    let r = rightmost_roots(dde, 1, options)?;
    Ok(r.first().map_or(f64::NEG_INFINITY, |l| l.re))
}

/// Number of characteristic roots with `Re λ > 0` (conjugates counted separately), found by
/// listing rightmost roots until one with `Re λ ≤ 0` appears. Exact whenever no root lies within
/// ~1e-10 of the imaginary axis.
pub fn unstable_root_count(dde: &LinearDde, options: &RootOptions) -> Result<usize> {
    let mut want = 4;
    loop {
        let r = rightmost_roots(dde, want, options)?;
        let k = r.iter().filter(|l| l.re > 0.0).count();
        if k < r.len() || r.len() < want {
            return Ok(k);
        }
        want *= 2;
    }
}

/// Largest distance `|polished − seed| / (1 + |seed|)` for which [`collocation_roots`] accepts
/// a polished root; farther, Newton went to another root and the seed is kept.
const MAX_POLISH_MOVE: f64 = 0.1;

/// Rightmost `count` characteristic roots at one fixed Chebyshev degree, without the adaptive
/// confirmation of [`rightmost_roots`] (for callers that choose the resolution themselves,
/// e.g. along a continuation branch, where a root count must never fail).
///
/// The `2·count` rightmost eigenvalues of [`ChebyshevCollocation`] of degree `degree` (≥ 2)
/// are each polished by Newton's method on `det Δ(λ)` when `newton` is given (a polished root
/// that moved farther than 0.1·(1 + |seed|), or a failed polish, keeps the seed), duplicates
/// within 1e-8·(1 + |λ|) are merged, and the `count` rightmost are returned sorted as
/// [`sort_rightmost`] does. For an ODE (no delayed terms) all eigenvalues of `A0` are returned.
/// Accuracy: that of [`LinearDde::polish_root`] (~1e-14 relative for simple roots) when
/// polishing, otherwise the collocation's (spectral in the degree).
pub fn collocation_roots(
    dde: &LinearDde,
    degree: usize,
    count: usize,
    newton: Option<&NewtonOptions>,
) -> Result<Vec<Complex64>> {
    let collocation = ChebyshevCollocation {
        degree: degree.max(2),
    };
    let eigenvalues = collocation.eigenvalues(dde)?;
    if dde.delayed_terms().is_empty() {
        return Ok(eigenvalues);
    }
    let mut out: Vec<Complex64> = Vec::with_capacity(2 * count);
    for z in eigenvalues.into_iter().take(2 * count) {
        let r = newton
            .and_then(|o| dde.polish_root(z, o).ok())
            .filter(|r| (r - z).norm() < MAX_POLISH_MOVE * (1.0 + z.norm()))
            .unwrap_or(z);
        if !out.iter().any(|o| (o - r).norm() < 1e-8 * (1.0 + r.norm())) {
            out.push(r);
        }
    }
    sort_rightmost(&mut out);
    out.truncate(count);
    Ok(out)
}
