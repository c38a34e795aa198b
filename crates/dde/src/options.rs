//! Solver options.

use crate::Error;

/// How the step size is chosen.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepController {
    /// Proportional-integral control (Hairer–Nørsett–Wanner, *Solving ODEs I*, §IV.2 and the
    /// DOPRI5 and DOP853 codes): `h_new = h · safety · err^(−α) · err_prev^β` with
    /// `α = 1/5 − 0.75 β` (Dormand–Prince 5(4)) or `α = 1/8 − 0.2 β` (DOP853).
    /// `beta = 0.04` is the value recommended for DOPRI5; `beta = 0` gives the standard
    /// (integral-only) controller.
    Pi {
        /// weight of the previous error, typically 0.04 (0 → standard control)
        beta: f64,
    },
    /// Fixed step size `h` (no error control). Steps are still shortened to land on
    /// breakpoints and on the end time. Meant for convergence studies.
    Fixed {
        /// the step size \[same unit as t\]
        h: f64,
    },
}

impl Default for StepController {
    fn default() -> Self {
        StepController::Pi { beta: 0.04 }
    }
}

/// The Runge–Kutta pair.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Dormand–Prince 5(4) (the DOPRI5 code): six right-hand sides per step, a continuous
    /// extension of order 4 for free. The economical choice at moderate tolerances
    /// (rtol ≳ 1e-7).
    #[default]
    Dopri5,
    /// Dormand–Prince 8(5,3) (the DOP853 code): twelve right-hand sides per step, far fewer
    /// steps at tight tolerances (rtol ≲ 1e-7), and a continuous extension of order 7 that
    /// costs three more right-hand sides — spent only on the steps that need it: every step
    /// of a DDE (its past) or with [`DenseOutput::Keep`], and otherwise only the steps where
    /// an event fires or an observer interpolates.
    Dop853,
}

/// How a step lands on a kink: a root of a switching function
/// ([`crate::OdeProblem::switching`]). In both rules the solver looks ahead after every
/// accepted step: where a switching function heads for zero within the next step, the
/// step's continuous extension carried over the next one locates the root and the next
/// step lands there; a kink the look-ahead misses is found by the step that crosses it
/// (which is then repeated, up to the root located on its own extension).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KinkLanding {
    /// On the root, to [`Options::event_tol`]: a landing that overshoots the root is
    /// repeated up to the root located again on its own extension (which the kink spoils
    /// only over the overshoot), one that falls short is followed by a short step. The
    /// global error stays at tolerance level even where the kinks dominate it.
    #[default]
    Exact,
    /// Once, on the root estimate; the small remainder it misses is straddled by the
    /// neighbouring step and left to its error test (Hairer–Nørsett–Wanner, *Solving ODEs I*,
    /// §II.6). Fewer steps. Where `f` stays C¹ across the kink (an `s·|s|` term) the
    /// straddled remainder δ costs O(δ²) and this is as accurate as [`KinkLanding::Exact`];
    /// across a C⁰ kink (`|s|`, a clamp) it costs O(δ), which the error test underestimates.
    Once,
}

/// What the solver keeps of the trajectory.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DenseOutput {
    /// Keep nothing beyond what the delays need (ODE: nothing at all). Use an observer to
    /// compute quantities on the fly.
    #[default]
    Discard,
    /// Keep the continuous extension of every accepted step, so that the solution can be
    /// evaluated at any t of the integrated range afterwards ([`crate::Solution`]).
    Keep,
}

/// Options of the Runge–Kutta integrator. All fields have sensible defaults.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// the Runge–Kutta pair
    pub method: Method,
    /// relative tolerance (per component)
    pub rtol: f64,
    /// absolute tolerance (per component)
    pub atol: f64,
    /// first step size; `None` picks one automatically (Hairer's starting-step algorithm)
    pub h_initial: Option<f64>,
    /// largest step size allowed
    pub h_max: f64,
    /// maximum number of accepted + rejected steps per `integrate` call
    pub max_steps: usize,
    /// step-size control
    pub controller: StepController,
    /// safety factor of the step-size controller
    pub safety: f64,
    /// smallest factor by which a step may shrink (default 0.2)
    pub fac_min: f64,
    /// largest factor by which a step may grow (default 10)
    pub fac_max: f64,
    /// DDE only: the initial discontinuity at t0 and every user breakpoint b are propagated
    /// to `b + k1·τ1 + … + km·τm` for `k1 + … + km ≤ breakpoint_order`. `None` (the
    /// default) takes the order of the method (5 or 8, [`Method::order`]): beyond it, a jump
    /// in a higher derivative no longer spoils the local error.
    pub breakpoint_order: Option<usize>,
    /// DDE only: a kink landed on (a root of a switching function, [`crate::DdeProblem::switching`])
    /// at `t*` is carried along the delays to `t* + k₁τ₁ + … + kₘτₘ` for
    /// `1 ≤ k₁ + … + kₘ ≤ kink_propagation`, and steps land there too. Where `f` reads the
    /// kink back through a delayed argument the solution is one derivative smoother each
    /// time, but a jump in a derivative below the method's order still spoils the local
    /// error, and the error estimate then misjudges the step. `None` (the default) takes the
    /// method's order − 2 (3 or 6): a switch where `f` stays continuous makes the solution's
    /// second derivative jump.
    pub kink_propagation: Option<usize>,
    /// how steps land on the kinks of switching functions
    pub kink_landing: KinkLanding,
    /// absolute tolerance of event location in t
    pub event_tol: f64,
    /// what to keep of the trajectory
    pub dense_output: DenseOutput,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            method: Method::default(),
            rtol: 1e-6,
            atol: 1e-9,
            h_initial: None,
            h_max: f64::INFINITY,
            max_steps: 1_000_000,
            controller: StepController::default(),
            safety: 0.9,
            fac_min: 0.2,
            fac_max: 10.0,
            breakpoint_order: None,
            kink_propagation: None,
            kink_landing: KinkLanding::default(),
            event_tol: 1e-12,
            dense_output: DenseOutput::Discard,
        }
    }
}

impl Options {
    /// Options with the given tolerances and everything else default.
    pub fn with_tolerances(rtol: f64, atol: f64) -> Self {
        Options {
            rtol,
            atol,
            ..Options::default()
        }
    }

    /// Builder-style: the Runge–Kutta pair.
    pub fn with_method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// The order up to which DDE breakpoints are tracked (see [`Options::breakpoint_order`]).
    pub fn breakpoint_order(&self) -> usize {
        self.breakpoint_order.unwrap_or(self.method.order())
    }

    /// How far DDE kinks are carried along the delays (see [`Options::kink_propagation`]).
    pub fn kink_propagation(&self) -> usize {
        self.kink_propagation
            .unwrap_or(self.method.order().saturating_sub(2))
    }

    /// Builder-style: keep the dense output of every step.
    pub fn keep_dense_output(mut self) -> Self {
        self.dense_output = DenseOutput::Keep;
        self
    }

    /// Checks every field; returns the first offending one.
    pub fn validate(&self) -> Result<(), Error> {
        let bad = |field, value, expected| {
            Err(Error::InvalidOptions {
                field,
                value,
                expected,
            })
        };
        if !(self.rtol.is_finite() && self.rtol >= 0.0) {
            return bad("rtol", self.rtol, "a finite number >= 0 (e.g. 1e-6)");
        }
        if !(self.atol.is_finite() && self.atol >= 0.0) {
            return bad("atol", self.atol, "a finite number >= 0 (e.g. 1e-9)");
        }
        if self.rtol == 0.0 && self.atol == 0.0 {
            return bad("rtol", 0.0, "rtol and atol must not both be 0");
        }
        if self.rtol > 0.0 && self.rtol < 1e3 * f64::EPSILON && self.atol == 0.0 {
            return bad(
                "rtol",
                self.rtol,
                "rtol >= 2.2e-13 (below that round-off dominates)",
            );
        }
        if let Some(h) = self.h_initial
            && !(h.is_finite() && h > 0.0)
        {
            return bad(
                "h_initial",
                h,
                "a finite step size > 0, or None for automatic",
            );
        }
        if self.h_max.is_nan() || self.h_max <= 0.0 {
            return bad(
                "h_max",
                self.h_max,
                "a step size > 0 (f64::INFINITY for no limit)",
            );
        }
        if self.max_steps == 0 {
            return bad("max_steps", 0.0, "at least 1");
        }
        match self.controller {
            StepController::Pi { beta } if !(0.0..=0.2).contains(&beta) => {
                return bad(
                    "controller.beta",
                    beta,
                    "0 <= beta <= 0.2 (0.04 recommended)",
                );
            }
            StepController::Fixed { h } if !(h.is_finite() && h > 0.0) => {
                return bad("controller.h", h, "a finite fixed step size > 0");
            }
            _ => {}
        }
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return bad("safety", self.safety, "0 < safety <= 1 (0.9 is usual)");
        }
        if !(self.fac_min > 0.0 && self.fac_min < 1.0) {
            return bad("fac_min", self.fac_min, "0 < fac_min < 1 (0.2 is usual)");
        }
        if !(self.fac_max > 1.0 && self.fac_max.is_finite()) {
            return bad(
                "fac_max",
                self.fac_max,
                "a finite fac_max > 1 (10 is usual)",
            );
        }
        if !(self.event_tol.is_finite() && self.event_tol > 0.0) {
            return bad(
                "event_tol",
                self.event_tol,
                "a finite tolerance > 0 (e.g. 1e-12)",
            );
        }
        Ok(())
    }
}
