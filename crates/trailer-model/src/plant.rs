//! The plant abstraction: what every task needs from a car–trailer model, generic over the
//! number N of states of its reduced (ψ-free) system.
//!
//! A plant's reduced state starts with the four states of eq. (5)–(6), [σ1, σ2, σ3, θ]
//! (indices 0…3, [`crate::HITCH_ANGLE`] = 3), followed by the model's own states (the lagged
//! slip angles α′ of relaxing axles, …). The dynamics of the reduced state do not depend on
//! ψ, x_H, y_H; the full state appends them: [reduced (N), ψ, x_H, y_H] (N + 3 states,
//! [`Plant::rhs_full`]). For the paper's [`Model`] that is the order of eq. (10).
//!
//! Exact derivatives come from evaluating [`Plant::rhs`] on dual numbers (num-dual): the
//! right-hand side is generic over the scalar.

use nalgebra::{Complex, DMatrix, RowSVector, SMatrix, SVector};
use num_dual::{DualNum, DualSVec64, DualVec, jacobian};

use crate::linear::critical_speed_scan;
use crate::{
    CriticalSpeed, CriticalSpeedOptions, HITCH_ANGLE, Inputs, Model, ModelError, State4,
    VehicleParams,
};

/// What a switching function of a plant marks (a kink of the right-hand side, where an
/// integrator should land), so that a caller can treat each kind (e.g. a floor on tiny slips).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SwitchingKind {
    /// sign of the slip of axle `axle` (tan α, or the lagged α′ of a relaxing axle): the brush
    /// law's tan α·|tan α| is only C¹ there
    SlipSign {
        /// index of the axle (file order, tractor first)
        axle: usize,
    },
    /// onset of full sliding of axle `axle`: tan²α − tan²α_cr (α′² − α_cr² when relaxing)
    SlidingOnset {
        /// index of the axle
        axle: usize,
    },
    /// the regularised Coulomb friction at the hitch leaves its linear band: θ̇² − ω_c²
    HitchFriction,
}

/// The linearisation of a plant's reduced system about straight running at speed V:
/// x' = A x + B δ + B_M M_z, y = C x with y = ψ̇ (eq. 9–11 for the paper's model).
#[derive(Debug, Clone, PartialEq)]
pub struct PlantLinearization<const N: usize> {
    /// speed V \[m/s\]
    pub speed: f64,
    /// A = ∂f/∂x (N×N)
    pub a: SMatrix<f64, N, N>,
    /// B = ∂f/∂δ (steering angle)
    pub b: SVector<f64, N>,
    /// B_M = ∂f/∂M_z (yaw moment on the tractor)
    pub b_yaw_moment: SVector<f64, N>,
    /// C: ψ̇ = C x
    pub c: RowSVector<f64, N>,
}

/// A car–trailer model with N reduced states (see the module docs for the state order).
///
/// Required: the right-hand side (with and without a yaw moment on the tractor), the yaw
/// and hitch-angle rates, the equivalent parameters and the switching functions. Provided:
/// the full (N + 3)-state right-hand side, exact Jacobians, the linearisation, the open-loop
/// spectrum and the critical speed (the paper's [`Model`] overrides them with its own,
/// byte-identical to what it gave before the trait existed).
pub trait Plant<const N: usize> {
    /// Right-hand side of the reduced system at state `x` and inputs `u`.
    fn rhs<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
    ) -> SVector<D, N>;

    /// [`Plant::rhs`] with a yaw moment M_z \[N m\] on the tractor (positive in the sense of ψ).
    fn rhs_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> SVector<D, N>;

    /// Tractor yaw rate ψ̇ \[rad/s\] (the measured output of eq. 10); linear in x.
    fn yaw_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D;

    /// Hitch-angle rate θ̇ \[rad/s\].
    fn hitch_angle_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &SVector<D, N>) -> D;

    /// Parameters of the paper's form (for a vehicle with axle lists: the equivalent
    /// single-axle vehicle, [`crate::VehicleSpec::equivalent_params`]).
    fn params(&self) -> &VehicleParams;

    /// What each switching function marks; its length is the number of functions.
    fn switching_kinds(&self) -> &[SwitchingKind];

    /// The switching functions at (x, u) into `g` (length [`Plant::switching_kinds`]): their
    /// sign changes are the kinks of the right-hand side.
    fn switching_functions(&self, x: &SVector<f64, N>, u: &Inputs, g: &mut [f64]);

    /// The conditions of the simulations' validity guard at (x, u), each tripped when > 0, in
    /// this order: a steered tractor axle saturates (|tan α| − tan α_sat, the largest over the
    /// steered axles), an unsteered tractor axle saturates (likewise), a steered wheel stops
    /// (−(V cos δ + (σ1 + a ψ̇) sin δ)), the tractor stops (−V), the trailer stops
    /// (−(V cos θ + σ1 sin θ)). α_sat is the tyre's [`tires::TireLaw::saturation_slip_angle`]
    /// (α_cr of the brush tyre, eq. 15); a relaxing axle compares its lagged slip α′. A
    /// condition that cannot trip is −∞.
    fn guard_values(&self, x: &SVector<f64, N>, u: &Inputs) -> [f64; 5];

    /// Longitudinal speed of the trailer at its axles, V cos θ + σ1 sin θ \[m/s\]: the model is
    /// meaningful only while it is positive.
    fn trailer_longitudinal_speed<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &SVector<D, N>,
        speed: D,
    ) -> D {
        let (s, c) = x[HITCH_ANGLE].sin_cos();
        speed * c + x[0] * s
    }

    /// Right-hand side of the full system [reduced (N), ψ, x_H, y_H] (M = N + 3, checked at
    /// compile time): ψ̇ = yaw rate, ẋ_H = V cos ψ − σ1 sin ψ, ẏ_H = V sin ψ + σ1 cos ψ (eq. 5).
    fn rhs_full<D: DualNum<Primitive = f64> + Copy, const M: usize>(
        &self,
        x: &SVector<D, M>,
        u: &Inputs<D>,
    ) -> SVector<D, M> {
        const {
            assert!(
                M == N + 3,
                "the full state is the reduced state plus ψ, x_H, y_H"
            )
        };
        let xr = SVector::<D, N>::from_fn(|i, _| x[i]);
        let r = self.rhs(&xr, u);
        let (sp, cp) = x[N].sin_cos();
        let s1 = x[0];
        let kinematics = [
            self.yaw_rate(&xr),
            u.speed * cp - s1 * sp,
            u.speed * sp + s1 * cp,
        ];
        SVector::<D, M>::from_fn(|i, _| if i < N { r[i] } else { kinematics[i - N] })
    }

    /// Exact Jacobian ∂f/∂x (N×N) of the reduced system and ∂f/∂δ (forward-mode AD).
    fn jacobian(&self, x: &SVector<f64, N>, u: &Inputs) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
        let (_, a) = jacobian(
            |z: SVector<DualSVec64<N>, N>| {
                let ud = Inputs {
                    steering_angle: DualVec::from(u.steering_angle),
                    speed: DualVec::from(u.speed),
                    acceleration: DualVec::from(u.acceleration),
                };
                self.rhs(&z, &ud)
            },
            x,
        );
        let (b, _) = input_columns(self, x, u);
        (a, b)
    }

    /// Linearisation of the reduced system about straight running at constant speed V
    /// (x = 0, δ = 0, V̇ = 0), exact.
    fn plant_linearization(&self, speed: f64) -> PlantLinearization<N> {
        let x = SVector::<f64, N>::zeros();
        let u = Inputs::constant_speed(speed);
        let (a, b) = self.jacobian(&x, &u);
        let (_, b_yaw_moment) = input_columns(self, &x, &u);
        let mut c = RowSVector::<f64, N>::zeros();
        // ψ̇ is linear in x: its gradient is exact from N unit vectors
        for k in 0..N {
            let mut e = SVector::<f64, N>::zeros();
            e[k] = 1.0;
            c[k] = self.yaw_rate(&e);
        }
        PlantLinearization {
            speed,
            a,
            b,
            b_yaw_moment,
            c,
        }
    }

    /// Eigenvalues of A(V), sorted by decreasing real part, ties by decreasing imaginary part.
    fn open_loop_spectrum(&self, speed: f64) -> Vec<Complex<f64>> {
        sorted_spectrum(&self.plant_linearization(speed).a)
    }

    /// Spectral abscissa max Re λ(A(V)) \[1/s\].
    fn spectral_abscissa(&self, speed: f64) -> f64 {
        self.open_loop_spectrum(speed)[0].re
    }

    /// [`Model::critical_speed_search`] for this plant: scan and bisection on the spectral
    /// abscissa; `Ok(None)` when stable up to `v_max`.
    ///
    /// # Errors
    /// [`ModelError::NoCriticalSpeed`] as for the paper's model.
    fn critical_speed_search(
        &self,
        opts: &CriticalSpeedOptions,
    ) -> Result<Option<CriticalSpeed>, ModelError> {
        critical_speed_scan(
            opts,
            |v| self.spectral_abscissa(v),
            |v| self.open_loop_spectrum(v)[0],
        )
    }

    /// The open-loop critical speed.
    ///
    /// # Errors
    /// [`ModelError::NoCriticalSpeed`] when there is none in the range.
    fn critical_speed(&self, opts: &CriticalSpeedOptions) -> Result<CriticalSpeed, ModelError> {
        self.critical_speed_search(opts)?
            .ok_or(ModelError::NoCriticalSpeed {
                v_min: opts.v_min,
                v_max: opts.v_max,
                detail: "straight running stays stable up to v_max",
            })
    }
}

/// ∂f/∂δ and ∂f/∂M_z at (x, u), exact (two dual directions).
fn input_columns<P: Plant<N> + ?Sized, const N: usize>(
    plant: &P,
    x: &SVector<f64, N>,
    u: &Inputs,
) -> (SVector<f64, N>, SVector<f64, N>) {
    type D2 = DualSVec64<2>;
    let lift = |v: f64| D2::from(v);
    let xd: SVector<D2, N> = x.map(lift);
    let mut delta = lift(u.steering_angle);
    delta.eps = num_dual::Derivative::some(nalgebra::SVector::<f64, 2>::new(1.0, 0.0));
    let mut m = lift(0.0);
    m.eps = num_dual::Derivative::some(nalgebra::SVector::<f64, 2>::new(0.0, 1.0));
    let ud = Inputs {
        steering_angle: delta,
        speed: lift(u.speed),
        acceleration: lift(u.acceleration),
    };
    let r = plant.rhs_with_yaw_moment(&xd, &ud, m);
    let col = |k: usize| {
        SVector::<f64, N>::from_fn(|i, _| {
            r[i].eps
                .unwrap_generic(nalgebra::Const::<2>, nalgebra::Const::<1>)[k]
        })
    };
    (col(0), col(1))
}

/// Eigenvalues of a real N×N matrix, sorted by decreasing real part, ties by decreasing
/// imaginary part (a conjugate pair appears as (a + ib, a − ib)). A matrix with a non-finite
/// entry, or one whose Schur iteration does not converge within 10 000 iterations,
/// has N NaN eigenvalues (nalgebra's `complex_eigenvalues` iterates without a bound and
/// never returns on such a matrix).
pub fn sorted_spectrum<const N: usize>(a: &SMatrix<f64, N, N>) -> Vec<Complex<f64>> {
    let nan = || vec![Complex::new(f64::NAN, f64::NAN); N];
    if !a.iter().all(|v| v.is_finite()) {
        return nan();
    }
    let m = DMatrix::from_column_slice(N, N, a.as_slice());
    let Some(schur) = nalgebra::Schur::try_new(m, f64::EPSILON, SCHUR_MAX_ITERATIONS) else {
        return nan();
    };
    let mut out: Vec<Complex<f64>> = schur.complex_eigenvalues().iter().copied().collect();
    out.sort_by(by_decreasing_real_part);
    out
}

/// Most iterations of the Schur decomposition in [`sorted_spectrum`] (a handful per
/// eigenvalue converge; this bound only ends a matrix on which the QR iteration cycles).
pub const SCHUR_MAX_ITERATIONS: usize = 10_000;

/// The order of [`sorted_spectrum`] (a `fn` item, not a closure: the sort is compiled once,
/// not once per N).
fn by_decreasing_real_part(x: &Complex<f64>, y: &Complex<f64>) -> std::cmp::Ordering {
    y.re.total_cmp(&x.re).then(y.im.total_cmp(&x.im))
}

/// The paper's model is the plant with N = 4; every method gives exactly what the inherent
/// method of [`Model`] gives.
impl Plant<4> for Model {
    #[inline]
    fn rhs<D: DualNum<Primitive = f64> + Copy>(&self, x: &State4<D>, u: &Inputs<D>) -> State4<D> {
        self.rhs4(x, u)
    }

    #[inline]
    fn rhs_with_yaw_moment<D: DualNum<Primitive = f64> + Copy>(
        &self,
        x: &State4<D>,
        u: &Inputs<D>,
        yaw_moment: D,
    ) -> State4<D> {
        self.rhs4_with_yaw_moment(x, u, yaw_moment)
    }

    #[inline]
    fn yaw_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &State4<D>) -> D {
        Model::yaw_rate(self, x)
    }

    fn hitch_angle_rate<D: DualNum<Primitive = f64> + Copy>(&self, x: &State4<D>) -> D {
        Model::hitch_angle_rate(self, x)
    }

    fn params(&self) -> &VehicleParams {
        Model::params(self)
    }

    fn switching_kinds(&self) -> &[SwitchingKind] {
        &PAPER_SWITCHING
    }

    /// tan α of the front, rear and trailer axles, then tan²α − tan²α_cr of each.
    fn switching_functions(&self, x: &State4, u: &Inputs, g: &mut [f64]) {
        let t = self.slip_angle_tangents(x, u);
        let cr = self.critical_slip_angles();
        let tans = [t.front, t.rear, t.trailer];
        let crs = [cr.front, cr.rear, cr.trailer].map(|a| a.tan());
        for k in 0..3 {
            g[k] = tans[k];
            g[3 + k] = tans[k] * tans[k] - crs[k] * crs[k];
        }
    }

    /// As `sway::sim`'s guard computes it for the paper's model (|tan α| against tan α_cr,
    /// the front wheel's speed V at δ = 0 without trigonometry).
    fn guard_values(&self, x: &State4, u: &Inputs) -> [f64; 5] {
        let (tan_cr_front, tan_cr_rear) = self.critical_tangents;
        let (tan_front, tan_rear) = self.axle_slip_tangents(x, u);
        let front_wheel_speed = if u.steering_angle == 0.0 {
            u.speed
        } else {
            let lateral_front = x[0] + Model::yaw_rate(self, x) * self.f;
            let (sd, cd) = u.steering_angle.sin_cos();
            u.speed * cd + lateral_front * sd
        };
        [
            tan_front - tan_cr_front,
            tan_rear - tan_cr_rear,
            -front_wheel_speed,
            -u.speed,
            -self.trailer_wheel_speed(x, u.speed),
        ]
    }

    fn jacobian(&self, x: &State4, u: &Inputs) -> (SMatrix<f64, 4, 4>, SVector<f64, 4>) {
        self.jacobian4(x, u)
    }

    fn plant_linearization(&self, speed: f64) -> PlantLinearization<4> {
        let lin = self.linearize(speed);
        PlantLinearization {
            speed,
            a: lin.a4,
            b: lin.b4,
            b_yaw_moment: lin.b4_yaw_moment,
            c: lin.c4,
        }
    }

    fn open_loop_spectrum(&self, speed: f64) -> Vec<Complex<f64>> {
        self.open_loop_eigenvalues(speed).to_vec()
    }

    fn spectral_abscissa(&self, speed: f64) -> f64 {
        Model::spectral_abscissa(self, speed)
    }

    fn critical_speed_search(
        &self,
        opts: &CriticalSpeedOptions,
    ) -> Result<Option<CriticalSpeed>, ModelError> {
        Model::critical_speed_search(self, opts)
    }
}

const PAPER_SWITCHING: [SwitchingKind; 6] = [
    SwitchingKind::SlipSign { axle: 0 },
    SwitchingKind::SlipSign { axle: 1 },
    SwitchingKind::SlipSign { axle: 2 },
    SwitchingKind::SlidingOnset { axle: 0 },
    SwitchingKind::SlidingOnset { axle: 1 },
    SwitchingKind::SlidingOnset { axle: 2 },
];
