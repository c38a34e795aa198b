//! Uncertainty sampling: Monte-Carlo or Latin-hypercube samples of vehicle
//! fields from declared distributions, seeded and reproducible, and the statistics of the
//! results (quantiles, mean, standard deviation, histogram counts).
//!
//! Sample `s` is a pure function of (seed, s): its random numbers come from the ChaCha8
//! stream number `s` of the seed, so a sample does not depend on which other samples are
//! drawn, in which order, or on how many threads draw them. A Latin hypercube also needs
//! one permutation of the strata per field; those are drawn once from their own streams
//! (numbered from the top of the stream space) when the [`Sampler`] is built.
//!
//! ```
//! use sway_model::sampling::{Distribution, Field, Method, Sampler, Sampling};
//! let s = Sampling {
//!     method: Method::LatinHypercube,
//!     samples: 100,
//!     seed: 7,
//!     fields: vec![Field {
//!         key: "trailer.cog".into(),
//!         about: Default::default(),
//!         distribution: Distribution::Uniform,
//!         min: 2.85,
//!         max: 2.95,
//!         mean: None,
//!         sd: None,
//!     }],
//! };
//! let sampler = Sampler::new(&s).unwrap();
//! let x = sampler.sample(3);
//! assert!(x[0] >= 2.85 && x[0] <= 2.95);
//! assert_eq!(x, sampler.sample(3)); // reproducible
//! ```

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// How the samples are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// independent draws
    MonteCarlo,
    /// one draw per stratum of each field's probability (equal-probability strata), the
    /// strata of the fields paired by random permutations
    LatinHypercube,
}

/// The distribution of a field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Distribution {
    /// uniform on \[min, max\]
    Uniform,
    /// normal (mean, sd) truncated to \[min, max\]
    Normal,
}

/// What the drawn numbers of a field are: the field's value, or a change of the vehicle's
/// own value (so that one config serves any vehicle file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum About {
    /// the value itself (min, max and mean in the field's unit)
    #[default]
    Absolute,
    /// added to the vehicle's value: value = vehicle's + draw (e.g. h ± 0.05 m)
    Offset,
    /// multiplies the vehicle's value: value = vehicle's × draw (e.g. m2 ± 10 %: 0.9 … 1.1)
    Factor,
}

impl About {
    /// The field's value for a draw `x` when the vehicle's own value is `vehicle`.
    pub fn apply(self, vehicle: f64, x: f64) -> f64 {
        match self {
            About::Absolute => x,
            About::Offset => vehicle + x,
            About::Factor => vehicle * x,
        }
    }
}

/// One sampled field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Field {
    /// key path of the vehicle field, e.g. `trailer.cog`
    pub key: String,
    /// what the draws are: the value (`"absolute"`, the default), an `"offset"` added to
    /// the vehicle's value, or a `"factor"` on it
    #[serde(default, skip_serializing_if = "is_absolute")]
    pub about: About,
    /// the distribution
    pub distribution: Distribution,
    /// lower bound (the uniform's start; the normal is truncated here)
    pub min: f64,
    /// upper bound
    pub max: f64,
    /// the normal's mean (normal only)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean: Option<f64>,
    /// the normal's standard deviation (normal only)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sd: Option<f64>,
}

/// The `[sampling]` table of a sweep file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sampling {
    /// "monte_carlo" or "latin_hypercube"
    pub method: Method,
    /// number of samples
    pub samples: usize,
    /// the seed of the ChaCha8 generator
    pub seed: u64,
    /// the sampled fields (`[[sampling.fields]]`)
    pub fields: Vec<Field>,
}

fn is_absolute(a: &About) -> bool {
    *a == About::Absolute
}

/// Most samples of one study (memory of the Latin-hypercube permutations: 8 bytes per
/// sample and field).
pub const MAX_SAMPLES: usize = 10_000_000;

impl Field {
    /// Checks the bounds and parameters; the error says which key (relative to the field's
    /// table) and what was expected.
    ///
    /// # Errors
    /// `(key, problem)`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(self.min.is_finite() && self.max.is_finite() && self.min <= self.max) {
            return Err((
                "min",
                format!(
                    "expected finite min <= max, got {} and {}",
                    self.min, self.max
                ),
            ));
        }
        match self.distribution {
            Distribution::Uniform => {
                if self.mean.is_some() || self.sd.is_some() {
                    return Err(("mean", "a uniform distribution takes no mean or sd".into()));
                }
            }
            Distribution::Normal => {
                let mean = self
                    .mean
                    .ok_or(("mean", "a normal distribution needs a mean".into()))?;
                let sd = self
                    .sd
                    .ok_or(("sd", "a normal distribution needs an sd".into()))?;
                if !(sd.is_finite() && sd > 0.0) {
                    return Err(("sd", format!("expected a finite sd > 0, got {sd}")));
                }
                if !mean.is_finite() {
                    return Err(("mean", format!("expected a finite mean, got {mean}")));
                }
                let (a, b) = self.normal_cdf_bounds(mean, sd);
                if b - a <= 1e-12 || b.is_nan() || a.is_nan() {
                    return Err((
                        "min",
                        format!(
                            "[min, max] = [{}, {}] holds almost no probability of the normal ({mean}, {sd})",
                            self.min, self.max
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    fn normal_cdf_bounds(&self, mean: f64, sd: f64) -> (f64, f64) {
        (
            normal_cdf((self.min - mean) / sd),
            normal_cdf((self.max - mean) / sd),
        )
    }

    /// The value at probability `u` in \[0, 1\] (the inverse distribution function).
    pub fn quantile(&self, u: f64) -> f64 {
        let x = match (self.distribution, self.mean, self.sd) {
            (Distribution::Normal, Some(mean), Some(sd)) => {
                let (a, b) = self.normal_cdf_bounds(mean, sd);
                mean + sd * normal_quantile(a + u * (b - a))
            }
            _ => self.min + u * (self.max - self.min),
        };
        x.clamp(self.min, self.max)
    }

    /// The exact mean of the (truncated) distribution.
    pub fn exact_mean(&self) -> f64 {
        match (self.distribution, self.mean, self.sd) {
            (Distribution::Normal, Some(m), Some(s)) => {
                let (al, be) = ((self.min - m) / s, (self.max - m) / s);
                let z = normal_cdf(be) - normal_cdf(al);
                m + s * (normal_pdf(al) - normal_pdf(be)) / z
            }
            _ => 0.5 * (self.min + self.max),
        }
    }
}

/// Draws the samples of a [`Sampling`].
#[derive(Debug, Clone, PartialEq)]
pub struct Sampler {
    sampling: Sampling,
    /// per field, the stratum of each sample (Latin hypercube only)
    strata: Vec<Vec<u32>>,
}

/// Stream of the permutation of field `j` (the sample streams count up from 0).
fn permutation_stream(j: usize) -> u64 {
    u64::MAX - j as u64
}

impl Sampler {
    /// Checks the sampling and draws the Latin-hypercube permutations.
    ///
    /// # Errors
    /// `(key, problem)` with the key relative to the `[sampling]` table, e.g.
    /// `fields[1].sd`.
    pub fn new(sampling: &Sampling) -> Result<Self, (String, String)> {
        sampling.validate()?;
        let strata = match sampling.method {
            Method::MonteCarlo => Vec::new(),
            Method::LatinHypercube => (0..sampling.fields.len())
                .map(|j| {
                    let mut rng = ChaCha8Rng::seed_from_u64(sampling.seed);
                    rng.set_stream(permutation_stream(j));
                    let mut p: Vec<u32> = (0..sampling.samples as u32).collect();
                    p.shuffle(&mut rng);
                    p
                })
                .collect(),
        };
        Ok(Self {
            sampling: sampling.clone(),
            strata,
        })
    }

    /// The number of samples.
    pub fn len(&self) -> usize {
        self.sampling.samples
    }
}

impl Sampling {
    /// Checks the counts and every field (cheap: draws nothing).
    ///
    /// # Errors
    /// `(key, problem)` with the key relative to the `[sampling]` table, e.g.
    /// `fields[1].sd`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let sampling = self;
        // the wording of every count limit (`crate::config::ensure_count`)
        if let Err(crate::SwayError::Config { problem, .. }) = crate::config::ensure_count(
            sampling.samples,
            (1, MAX_SAMPLES),
            std::path::Path::new(""),
            "samples",
            "sample",
            || "one vehicle drawn and analysed per sample".into(),
        ) {
            return Err(("samples".into(), problem));
        }
        if sampling.fields.is_empty() {
            return Err((
                "fields".into(),
                "expected at least one sampled field".into(),
            ));
        }
        for (i, f) in sampling.fields.iter().enumerate() {
            f.validate()
                .map_err(|(k, p)| (format!("fields[{i}].{k}"), p))?;
        }
        Ok(())
    }
}

impl Sampler {
    /// True without samples (never: [`Sampler::new`] refuses 0).
    pub fn is_empty(&self) -> bool {
        self.sampling.samples == 0
    }

    /// The fields.
    pub fn fields(&self) -> &[Field] {
        &self.sampling.fields
    }

    /// The field values of sample `s` (in field order); a pure function of (seed, s).
    pub fn sample(&self, s: usize) -> Vec<f64> {
        let mut out = vec![0.0; self.sampling.fields.len()];
        self.sample_into(s, &mut out);
        out
    }

    /// [`Sampler::sample`] into `out` (one value per field), without allocating.
    pub fn sample_into(&self, s: usize, out: &mut [f64]) {
        let mut rng = ChaCha8Rng::seed_from_u64(self.sampling.seed);
        rng.set_stream(s as u64);
        let n = self.sampling.samples as f64;
        for (j, (f, o)) in self.sampling.fields.iter().zip(out.iter_mut()).enumerate() {
            let jitter: f64 = rng.random();
            let u = match self.strata.get(j) {
                Some(p) => (f64::from(p[s]) + jitter) / n,
                None => jitter,
            };
            *o = f.quantile(u);
        }
    }
}

/// Φ(x), the standard normal distribution function (via erfc: accurate in both tails).
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// φ(x), the standard normal density.
pub fn normal_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Φ⁻¹(p) for p in \[0, 1\] (±∞ at the ends): Acklam's rational approximation (relative
/// error 1.2e-9) polished by two Newton steps on Φ.
pub fn normal_quantile(p: f64) -> f64 {
    if p <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if p >= 1.0 {
        return f64::INFINITY;
    }
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    let mut x = if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    };
    for _ in 0..2 {
        let d = normal_pdf(x);
        if d > 0.0 {
            x -= (normal_cdf(x) - p) / d;
        }
    }
    x
}

/// The statistics of a sample of a result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Statistics {
    /// values used (finite ones)
    pub count: usize,
    /// arithmetic mean
    pub mean: f64,
    /// sample standard deviation (n − 1)
    pub sd: f64,
    /// smallest value
    pub min: f64,
    /// largest value
    pub max: f64,
    /// the 5, 25, 50, 75 and 95 % quantiles (linear interpolation between order
    /// statistics, "type 7")
    pub quantiles: Quantiles,
}

/// The quantiles reported by [`Statistics`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quantiles {
    /// 5 %
    pub q05: f64,
    /// 25 %
    pub q25: f64,
    /// 50 % (median)
    pub q50: f64,
    /// 75 %
    pub q75: f64,
    /// 95 %
    pub q95: f64,
}

/// The `p`-quantile of sorted values (type 7: linear between order statistics).
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let h = (n - 1) as f64 * p.clamp(0.0, 1.0);
    let (lo, frac) = (h.floor() as usize, h - h.floor());
    let hi = (lo + 1).min(n - 1);
    sorted[lo] + frac * (sorted[hi] - sorted[lo])
}

impl Statistics {
    /// The statistics of the finite values of `values` (None if there are none). The sum
    /// runs in the given order, so the result depends only on the values and their order.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Self> {
        let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = if v.len() > 1 {
            v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0)
        } else {
            0.0
        };
        v.sort_by(f64::total_cmp);
        let q = |p| quantile_sorted(&v, p);
        Some(Self {
            count: v.len(),
            mean,
            sd: var.sqrt(),
            min: v[0],
            max: v[v.len() - 1],
            quantiles: Quantiles {
                q05: q(0.05),
                q25: q(0.25),
                q50: q(0.5),
                q75: q(0.75),
                q95: q(0.95),
            },
        })
    }
}

/// Histogram counts of `values` over `bins` equal bins spanning \[lo, hi\] (the last bin
/// includes hi); values outside are not counted.
pub fn histogram(values: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<usize> {
    let mut counts = vec![0; bins.max(1)];
    let width = (hi - lo) / counts.len() as f64;
    for &x in values {
        if !(x >= lo && x <= hi) {
            continue;
        }
        let k = if width > 0.0 {
            (((x - lo) / width) as usize).min(counts.len() - 1)
        } else {
            0
        };
        counts[k] += 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uniform(key: &str, min: f64, max: f64) -> Field {
        Field {
            key: key.into(),
            about: About::Absolute,
            distribution: Distribution::Uniform,
            min,
            max,
            mean: None,
            sd: None,
        }
    }

    fn sampling(method: Method, samples: usize) -> Sampling {
        Sampling {
            method,
            samples,
            seed: 2026,
            fields: vec![
                uniform("trailer.cog", 2.85, 2.95),
                Field {
                    key: "trailer.axle".into(),
                    about: About::Absolute,
                    distribution: Distribution::Normal,
                    min: 2.75,
                    max: 2.85,
                    mean: Some(2.8),
                    sd: Some(0.025),
                },
            ],
        }
    }

    #[test]
    fn same_seed_same_samples_on_one_and_two_threads() {
        use rayon::prelude::*;
        let s = Sampler::new(&sampling(Method::LatinHypercube, 1000)).unwrap();
        let draw = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    (0..1000)
                        .into_par_iter()
                        .map(|k| s.sample(k))
                        .collect::<Vec<_>>()
                })
        };
        let (one, two) = (draw(1), draw(2));
        assert_eq!(one, two); // bit for bit
        // and a sampler built again from the same seed draws the same values
        let again = Sampler::new(&sampling(Method::LatinHypercube, 1000)).unwrap();
        assert_eq!(again.sample(417), one[417]);
        // another seed draws others
        let other = Sampler::new(&Sampling {
            seed: 2027,
            ..sampling(Method::LatinHypercube, 1000)
        })
        .unwrap();
        assert_ne!(other.sample(417), one[417]);
    }

    #[test]
    fn uniform_mean_and_spread_match_exact_values() {
        // exact: mean (a + b)/2 = 2.9, sd (b − a)/√12 = 0.028868; Monte Carlo with n = 20000
        // has a standard error of sd/√n = 2.0e-4 on the mean: tolerance 4 standard errors.
        // The sd's standard error is about sd/√(2n)·√(4/5) (uniform kurtosis): 1.3e-4.
        let (a, b) = (2.85, 2.95);
        let exact_sd = (b - a) / 12f64.sqrt();
        let n = 20_000;
        let s = Sampler::new(&sampling(Method::MonteCarlo, n)).unwrap();
        let st = Statistics::of((0..n).map(|k| s.sample(k)[0])).unwrap();
        let se = exact_sd / (n as f64).sqrt();
        assert!((st.mean - 2.9).abs() < 4.0 * se, "mean {}", st.mean);
        assert!((st.sd - exact_sd).abs() < 4.0 * 1.3e-4, "sd {}", st.sd);
        // a Latin hypercube puts exactly one sample in each of the n strata: its mean is
        // within (b − a)/(2n)·... of the exact one; bound: (b − a)/n
        let l = Sampler::new(&sampling(Method::LatinHypercube, n)).unwrap();
        let xs: Vec<f64> = (0..n).map(|k| l.sample(k)[0]).collect();
        let st = Statistics::of(xs.iter().copied()).unwrap();
        assert!(
            (st.mean - 2.9).abs() < (b - a) / n as f64,
            "LHS mean {}",
            st.mean
        );
        assert!((st.sd - exact_sd).abs() < 1e-5, "LHS sd {}", st.sd);
        assert_eq!(histogram(&xs, a, b, 100), vec![n / 100; 100]);
    }

    #[test]
    fn truncated_normal_is_inside_its_bounds_with_the_exact_mean() {
        // the truncated normal (2.8, 0.025) on [2.75, 2.85] is symmetric: exact mean 2.8
        let f = &sampling(Method::LatinHypercube, 1).fields[1];
        assert!((f.exact_mean() - 2.8).abs() < 1e-15);
        let n = 10_000;
        let l = Sampler::new(&sampling(Method::LatinHypercube, n)).unwrap();
        let xs: Vec<f64> = (0..n).map(|k| l.sample(k)[1]).collect();
        assert!(xs.iter().all(|&x| (2.75..=2.85).contains(&x)));
        let st = Statistics::of(xs).unwrap();
        assert!((st.mean - 2.8).abs() < 1e-5, "mean {}", st.mean);
        // reference: the truncated normal's median is the mean (symmetric)
        assert!((st.quantiles.q50 - 2.8).abs() < 1e-4);
    }

    #[test]
    fn normal_quantile_inverts_the_cdf() {
        // reference: Φ(Φ⁻¹(p)) = p, and the tabulated Φ⁻¹(0.975) = 1.959963984540054
        for p in [1e-10, 1e-3, 0.02, 0.3, 0.5, 0.9, 0.999, 1.0 - 1e-9] {
            let x = normal_quantile(p);
            assert!((normal_cdf(x) - p).abs() < 1e-14 * p.max(1e-3), "p {p}");
        }
        assert!((normal_quantile(0.975) - 1.959963984540054).abs() < 1e-12);
    }

    #[test]
    fn bad_fields_are_named() {
        let mut s = sampling(Method::MonteCarlo, 10);
        s.fields[1].sd = Some(-1.0);
        assert_eq!(Sampler::new(&s).unwrap_err().0, "fields[1].sd");
        s.fields[1].sd = None;
        assert_eq!(Sampler::new(&s).unwrap_err().0, "fields[1].sd");
        s = sampling(Method::MonteCarlo, 0);
        assert_eq!(Sampler::new(&s).unwrap_err().0, "samples");
    }

    #[test]
    fn quantiles_of_a_known_sample() {
        // type-7 quantiles of 1..=101 are 1 + 100 p exactly
        let st = Statistics::of((1..=101).map(f64::from)).unwrap();
        assert_eq!(st.quantiles.q05, 6.0);
        assert_eq!(st.quantiles.q50, 51.0);
        assert_eq!(st.quantiles.q95, 96.0);
        assert_eq!(st.mean, 51.0);
    }
}
