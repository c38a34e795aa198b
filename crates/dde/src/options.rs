//! Solver options.

use crate::Error;

/// How the step size is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepController {
    /// Proportional-integral control (Hairer–Nørsett–Wanner, *Solving ODEs I*, §IV.2 and the
    /// DOPRI5 code): `h_new = h · safety · err^(−α) · err_prev^β` with `α = 1/5 − 0.75 β`.
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

/// What the solver keeps of the trajectory.
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

/// Options of the Dormand–Prince integrator. All fields have sensible defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
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
    /// to `b + k1·τ1 + … + km·τm` for `k1 + … + km ≤ breakpoint_order`. The default 5 is the
    /// order of the method: beyond it, a jump in a higher derivative no longer spoils the
    /// local error.
    pub breakpoint_order: usize,
    /// absolute tolerance of event location in t
    pub event_tol: f64,
    /// what to keep of the trajectory
    pub dense_output: DenseOutput,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            rtol: 1e-6,
            atol: 1e-9,
            h_initial: None,
            h_max: f64::INFINITY,
            max_steps: 1_000_000,
            controller: StepController::default(),
            safety: 0.9,
            fac_min: 0.2,
            fac_max: 10.0,
            breakpoint_order: 5,
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
