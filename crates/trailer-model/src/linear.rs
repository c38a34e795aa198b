//! Linearisation about straight running (eq. 9–11) and open-loop linear stability.

use nalgebra::{Complex, Matrix4, RowSVector, RowVector4, SMatrix, SVector, Vector4};
use num_dual::{DualSVec64, DualVec, jacobian};
use serde::Serialize;

use crate::{Inputs, Model, ModelError, State4, State7};

/// The matrices of eq. (9)–(11) at speed V: x' = A x + B u, y = C x with
/// x = [σ1, σ2, σ3, θ, ψ, x̃_H, y_H], u = δ, y = ψ̇, and their 4×4 blocks Ã, B̃, C̃.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    /// speed V \[m/s\] the linearisation is taken at
    pub speed: f64,
    /// A (7×7), with the zero pattern of eq. (11)
    pub a: SMatrix<f64, 7, 7>,
    /// B (7×1)
    pub b: SVector<f64, 7>,
    /// C (1×7) = [−m1 d / I1, 1, 0, …]
    pub c: RowSVector<f64, 7>,
    /// Ã: upper-left 4×4 block of A
    pub a4: Matrix4<f64>,
    /// B̃: first 4 entries of B
    pub b4: Vector4<f64>,
    /// C̃: first 4 entries of C
    pub c4: RowVector4<f64>,
    /// B_M (7×1): the input column of a yaw moment M_z \[N m\] on the tractor
    /// ([`Model::rhs4_with_yaw_moment`], differential braking)
    pub b_yaw_moment: SVector<f64, 7>,
    /// B̃_M: first 4 entries of B_M
    pub b4_yaw_moment: Vector4<f64>,
}

impl Model {
    /// Jacobian ∂f/∂x (4×4) of the reduced right-hand side and ∂f/∂δ (4×1), exact
    /// (forward-mode automatic differentiation, no finite-difference bias at the
    /// C¹ kink of the brush tire).
    pub fn jacobian4(&self, x: &State4, u: &Inputs) -> (Matrix4<f64>, Vector4<f64>) {
        let z = SVector::<f64, 5>::new(x[0], x[1], x[2], x[3], u.steering_angle);
        let (_, j) = jacobian(
            |z: SVector<DualSVec64<5>, 5>| {
                let xd = State4::new(z[0], z[1], z[2], z[3]);
                let ud = Inputs {
                    steering_angle: z[4],
                    speed: DualVec::from(u.speed),
                    acceleration: DualVec::from(u.acceleration),
                };
                self.rhs4(&xd, &ud)
            },
            &z,
        );
        (
            j.fixed_view::<4, 4>(0, 0).into_owned(),
            j.column(4).into_owned(),
        )
    }

    /// Linearisation (eq. 9–11) about straight running at constant speed V:
    /// all states zero except x_H = V t, δ = 0, V̇ = 0. Exact derivatives.
    pub fn linearize(&self, speed: f64) -> Linearization {
        let z = SVector::<f64, 9>::zeros();
        let (_, j) = jacobian(
            |z: SVector<DualSVec64<9>, 9>| {
                let xd = State7::from_fn(|i, _| z[i]);
                let ud = Inputs {
                    steering_angle: z[7],
                    speed: DualVec::from(speed),
                    acceleration: DualVec::from(0.0),
                };
                self.rhs7_with_yaw_moment(&xd, &ud, z[8])
            },
            &z,
        );
        let a: SMatrix<f64, 7, 7> = j.fixed_view::<7, 7>(0, 0).into_owned();
        let b: SVector<f64, 7> = j.column(7).into_owned();
        let b_yaw_moment: SVector<f64, 7> = j.column(8).into_owned();
        let mut c = RowSVector::<f64, 7>::zeros();
        c[0] = -self.params().tractor.mass * self.params().tractor.cog / self.i1();
        c[1] = 1.0;
        Linearization {
            speed,
            a4: a.fixed_view::<4, 4>(0, 0).into_owned(),
            b4: b.fixed_rows::<4>(0).into_owned(),
            c4: c.fixed_columns::<4>(0).into_owned(),
            b4_yaw_moment: b_yaw_moment.fixed_rows::<4>(0).into_owned(),
            b_yaw_moment,
            a,
            b,
            c,
        }
    }

    /// Eigenvalues of Ã at speed V, sorted by decreasing real part (then by imaginary part).
    pub fn open_loop_eigenvalues(&self, speed: f64) -> [Complex<f64>; 4] {
        sorted_eigenvalues(&self.linearize(speed).a4)
    }

    /// Spectral abscissa max Re λ(Ã(V)) \[1/s\] of the open loop.
    pub fn spectral_abscissa(&self, speed: f64) -> f64 {
        self.open_loop_eigenvalues(speed)[0].re
    }
}

/// Eigenvalues of a real 4×4 matrix, sorted by decreasing real part, ties by decreasing
/// imaginary part (so a conjugate pair appears as (a + ib, a − ib)).
pub fn sorted_eigenvalues(a: &Matrix4<f64>) -> [Complex<f64>; 4] {
    let ev = a.complex_eigenvalues();
    let mut out = [ev[0], ev[1], ev[2], ev[3]];
    out.sort_by(|x, y| y.re.total_cmp(&x.re).then(y.im.total_cmp(&x.im)));
    out
}

/// Where straight running loses stability: the open-loop critical speed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CriticalSpeed {
    /// V_crit \[m/s\]: the spectral abscissa of Ã changes sign
    pub v_crit_mps: f64,
    /// frequency of the critical pair Im λ / 2π \[Hz\] at V_crit
    pub hopf_frequency_hz: f64,
    /// angular frequency ω \[rad/s\] at V_crit
    pub hopf_omega_rad_s: f64,
    /// d(max Re λ)/dV at V_crit \[1/m\]: the transversality of the crossing
    pub crossing_speed: f64,
}

/// Options of the V_crit search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalSpeedOptions {
    /// lowest speed scanned \[m/s\]
    pub v_min: f64,
    /// highest speed scanned \[m/s\]
    pub v_max: f64,
    /// scan step for the sign change \[m/s\]
    pub scan_step: f64,
    /// bracket width at which bisection stops \[m/s\]
    pub tolerance: f64,
}

impl Default for CriticalSpeedOptions {
    fn default() -> Self {
        Self {
            v_min: 1.0,
            v_max: 100.0,
            scan_step: 0.5,
            tolerance: 1e-11,
        }
    }
}

impl Model {
    /// Finds the lowest speed at which the spectral abscissa of Ã crosses zero, by a
    /// scan followed by bisection on the bracket (the abscissa is continuous in V).
    ///
    /// # Errors
    /// [`ModelError::NoCriticalSpeed`] if straight running is stable (or unstable)
    /// on the whole scanned range.
    pub fn critical_speed(&self, opts: &CriticalSpeedOptions) -> Result<CriticalSpeed, ModelError> {
        self.critical_speed_search(opts)?
            .ok_or(ModelError::NoCriticalSpeed {
                v_min: opts.v_min,
                v_max: opts.v_max,
                detail: "straight running stays stable up to v_max",
            })
    }

    /// [`critical_speed`](Self::critical_speed) with "stable on the whole range" as an
    /// answer: `Ok(None)` when the spectral abscissa stays negative up to `v_max`.
    ///
    /// # Errors
    /// [`ModelError::NoCriticalSpeed`] if straight running is already unstable at `v_min`,
    /// the eigenvalues are not finite, or the scan cannot advance.
    pub fn critical_speed_search(
        &self,
        opts: &CriticalSpeedOptions,
    ) -> Result<Option<CriticalSpeed>, ModelError> {
        critical_speed_scan(
            opts,
            |v| self.spectral_abscissa(v),
            |v| self.open_loop_eigenvalues(v)[0],
        )
    }
}

/// The scan and bisection of [`Model::critical_speed_search`] on any spectral abscissa
/// `abscissa(V)` whose rightmost eigenvalue is `leading(V)` (shared by every
/// [`crate::Plant`]).
pub(crate) fn critical_speed_scan(
    opts: &CriticalSpeedOptions,
    spectral_abscissa: impl Fn(f64) -> f64,
    leading: impl Fn(f64) -> Complex<f64>,
) -> Result<Option<CriticalSpeed>, ModelError> {
    let no_crossing = |detail| ModelError::NoCriticalSpeed {
        v_min: opts.v_min,
        v_max: opts.v_max,
        detail,
    };
    let abscissa = |v: f64| {
        let a = spectral_abscissa(v);
        if a.is_finite() {
            Ok(a)
        } else {
            Err(no_crossing(
                "the eigenvalues are not finite on the scanned range (speed beyond the model's range)",
            ))
        }
    };
    let mut lo = opts.v_min;
    if abscissa(lo)? >= 0.0 {
        return Err(no_crossing("straight running is already unstable at v_min"));
    }
    let mut hi = lo;
    loop {
        let next = (hi + opts.scan_step).min(opts.v_max);
        if next <= hi {
            // a step below the round-off of the speed would never reach v_max
            return Err(no_crossing(
                "the scan step is below the round-off of the speed (the scan cannot advance)",
            ));
        }
        hi = next;
        if abscissa(hi)? >= 0.0 {
            break;
        }
        if hi >= opts.v_max {
            return Ok(None);
        }
        lo = hi;
    }
    // bisection down to the tolerance or to adjacent floating-point numbers (a
    // tolerance below the round-off of the speed ends there instead of looping)
    while hi - lo > opts.tolerance {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if abscissa(mid)? < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let v = 0.5 * (lo + hi);
    let ev = leading(v);
    let dv = 1e-4;
    let slope = (spectral_abscissa(v + dv) - spectral_abscissa(v - dv)) / (2.0 * dv);
    Ok(Some(CriticalSpeed {
        v_crit_mps: v,
        hopf_omega_rad_s: ev.im.abs(),
        hopf_frequency_hz: ev.im.abs() / (2.0 * std::f64::consts::PI),
        crossing_speed: slope,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::VehicleParams;

    #[test]
    fn a_tolerance_or_scan_step_below_round_off_ends_instead_of_looping() {
        // reference: the default search; a tolerance of 1e-300 m/s (below the spacing of
        // floats near 35 m/s) ends at adjacent floats, within 1e-11 of it
        let m = Model::new(VehicleParams::default()).expect("Table I");
        let v = m
            .critical_speed(&CriticalSpeedOptions::default())
            .expect("default")
            .v_crit_mps;
        let tiny = CriticalSpeedOptions {
            tolerance: 1e-300,
            ..CriticalSpeedOptions::default()
        };
        let w = m.critical_speed(&tiny).expect("tiny tolerance").v_crit_mps;
        assert!((v - w).abs() < 1e-11, "{v} vs {w}");
        // speeds where a 1 m/s step cannot move the speed: an error, never an endless loop
        let stuck = CriticalSpeedOptions {
            v_min: 1e17,
            v_max: 2e17,
            scan_step: 1.0,
            ..CriticalSpeedOptions::default()
        };
        assert!(m.critical_speed(&stuck).is_err());
    }
}
