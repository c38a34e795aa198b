//! The Dormand–Prince 5(4) stepping loop shared by the ODE and the DDE solver.

use std::collections::VecDeque;

use nalgebra::SVector;

use crate::Error;
use crate::dense::{Segment, Solution};
use crate::events::{Event, EventAction, EventHit, locate_root};
use crate::options::{DenseOutput, Options, StepController};
use crate::problem::{DdeProblem, OdeProblem};
use crate::tableau::*;

type SV<const N: usize> = SVector<f64, N>;

/// Whether the integration goes on after an observer call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// go on
    Continue,
    /// stop after this step
    Stop,
}

/// How an `integrate` call ended (errors aside).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Status<const N: usize> {
    /// the requested end time was reached
    Reached,
    /// a terminal event stopped the integration at `hit.t`
    Event(EventHit<N>),
    /// the observer returned [`Flow::Stop`]
    ObserverStopped,
}

/// Work counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// accepted steps
    pub accepted: usize,
    /// rejected steps
    pub rejected: usize,
    /// right-hand side evaluations
    pub rhs_evals: usize,
}

/// What an observer sees of an accepted step.
pub struct StepView<'a, const N: usize> {
    segment: &'a Segment<N>,
    x: &'a SV<N>,
    past: &'a dyn PastEval<N>,
}

impl<const N: usize> std::fmt::Debug for StepView<'_, N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StepView")
            .field("segment", self.segment)
            .finish_non_exhaustive()
    }
}

impl<const N: usize> StepView<'_, N> {
    /// start of the step
    pub fn t_start(&self) -> f64 {
        self.segment.t_start
    }
    /// end of the step
    pub fn t_end(&self) -> f64 {
        self.segment.t_end
    }
    /// state at the end of the step
    pub fn x(&self) -> &SV<N> {
        self.x
    }
    /// the continuous extension of this step
    pub fn segment(&self) -> &Segment<N> {
        self.segment
    }
    /// the solution at `t` in `[t_start, t_end]` from the continuous extension
    pub fn eval(&self, t: f64) -> SV<N> {
        self.segment.eval(t)
    }
    /// DDE: the solution at an earlier time `t ≥ t_start − max delay` (history for `t ≤ t0`);
    /// ODE: only within this step. `None` outside what is stored.
    pub fn eval_past(&self, t: f64) -> Option<SV<N>> {
        if t >= self.segment.t_start && t <= self.segment.t_end {
            Some(self.segment.eval(t))
        } else if t < self.segment.t_start {
            self.past.eval_past(t)
        } else {
            None
        }
    }
}

/// Receives every accepted step and every event. Closures `FnMut(&StepView) -> Flow` are
/// observers.
pub trait Observer<const N: usize> {
    /// called after each accepted step (cut at a terminal event's time)
    fn on_step(&mut self, _step: &StepView<'_, N>) -> Flow {
        Flow::Continue
    }
    /// called for each event, in time order, after the `on_step` of its step
    fn on_event(&mut self, _hit: &EventHit<N>) {}
}

/// An observer that does nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoObserver;

impl<const N: usize> Observer<N> for NoObserver {}

impl<const N: usize, F: FnMut(&StepView<'_, N>) -> Flow> Observer<N> for F {
    fn on_step(&mut self, step: &StepView<'_, N>) -> Flow {
        self(step)
    }
}

/// Evaluation of the stored past (DDE) for observers.
pub(crate) trait PastEval<const N: usize> {
    fn eval_past(&self, t: f64) -> Option<SV<N>>;
}

/// The right-hand side as the stepping loop sees it.
trait Rhs<const N: usize>: PastEval<N> {
    fn eval(&mut self, t: f64, x: &SV<N>, dx: &mut SV<N>);
    fn push(&mut self, seg: &Segment<N>);
    fn truncate(&mut self, t_end: f64);
    /// largest step that keeps every delayed argument in the computed past
    fn h_cap(&self) -> f64;
    /// number of delays
    fn n_delays(&self) -> usize;
    /// `out[j] = x(t − τⱼ)` from the stored past (the current step included)
    fn delayed_states(&self, t: f64, x: &SV<N>, out: &mut [SV<N>]);
}

struct OdeRhs<'a, P>(&'a P);

impl<const N: usize, P: OdeProblem<N>> PastEval<N> for OdeRhs<'_, P> {
    fn eval_past(&self, _t: f64) -> Option<SV<N>> {
        None
    }
}

impl<const N: usize, P: OdeProblem<N>> Rhs<N> for OdeRhs<'_, P> {
    #[inline]
    fn eval(&mut self, t: f64, x: &SV<N>, dx: &mut SV<N>) {
        self.0.rhs(t, x, dx);
    }
    #[inline]
    fn push(&mut self, _seg: &Segment<N>) {}
    fn truncate(&mut self, _t_end: f64) {}
    fn h_cap(&self) -> f64 {
        f64::INFINITY
    }
    fn n_delays(&self) -> usize {
        0
    }
    fn delayed_states(&self, _t: f64, _x: &SV<N>, _out: &mut [SV<N>]) {}
}

/// The computed past of a DDE, pruned to the longest delay.
#[derive(Debug, Clone)]
struct Past<const N: usize> {
    segs: VecDeque<Segment<N>>,
    span: f64,
}

impl<const N: usize> Past<N> {
    fn push(&mut self, seg: &Segment<N>) {
        self.segs.push_back(*seg);
        // queries (stages and observers) reach back to t_start - span at most
        let keep_from = seg.t_start - self.span;
        while self.segs.len() > 1 && self.segs[0].t_end < keep_from {
            self.segs.pop_front();
        }
    }

    #[inline]
    fn lookup(&self, t: f64) -> Option<SV<N>> {
        let n = self.segs.len();
        if n == 0 {
            return None;
        }
        let i = self.segs.partition_point(|s| s.t_end < t).min(n - 1);
        Some(self.segs[i].eval(t))
    }
}

struct DdeRhs<'a, const N: usize, P> {
    p: &'a P,
    t0: f64,
    past: &'a mut Past<N>,
    delayed: &'a mut Vec<SV<N>>,
    h_cap: f64,
}

impl<const N: usize, P: DdeProblem<N>> DdeRhs<'_, N, P> {
    #[inline]
    fn at(&self, s: f64) -> SV<N> {
        if s <= self.t0 {
            self.p.history(s)
        } else {
            // with h <= min delay every stage's s lies in the computed past
            self.past
                .lookup(s)
                .unwrap_or_else(|| self.p.history(self.t0))
        }
    }
}

impl<const N: usize, P: DdeProblem<N>> PastEval<N> for DdeRhs<'_, N, P> {
    fn eval_past(&self, t: f64) -> Option<SV<N>> {
        if t <= self.t0 {
            return Some(self.p.history(t));
        }
        let first = self.past.segs.front()?;
        if t < first.t_start {
            None
        } else {
            self.past.lookup(t)
        }
    }
}

impl<const N: usize, P: DdeProblem<N>> Rhs<N> for DdeRhs<'_, N, P> {
    #[inline]
    fn eval(&mut self, t: f64, x: &SV<N>, dx: &mut SV<N>) {
        let delays = self.p.delays();
        for (j, &tau) in delays.iter().enumerate() {
            let v = if tau == 0.0 { *x } else { self.at(t - tau) };
            self.delayed[j] = v;
        }
        self.p.rhs(t, x, &self.delayed[..delays.len()], dx);
    }
    fn push(&mut self, seg: &Segment<N>) {
        self.past.push(seg);
    }
    fn truncate(&mut self, t_end: f64) {
        if let Some(s) = self.past.segs.back_mut() {
            s.t_end = t_end;
        }
    }
    fn h_cap(&self) -> f64 {
        self.h_cap
    }
    fn n_delays(&self) -> usize {
        self.p.delays().len()
    }
    fn delayed_states(&self, t: f64, x: &SV<N>, out: &mut [SV<N>]) {
        for (o, &tau) in out.iter_mut().zip(self.p.delays()) {
            *o = if tau == 0.0 { *x } else { self.at(t - tau) };
        }
    }
}

/// Integration state shared by both solvers (cloneable: save and restore it freely).
#[derive(Debug, Clone)]
struct Core<const N: usize> {
    opts: Options,
    t: f64,
    x: SV<N>,
    /// f(t, x) (FSAL); invalid after a breakpoint or a terminal event
    k1: SV<N>,
    k1_valid: bool,
    /// proposed next step (0: not chosen yet)
    h: f64,
    /// ln of the previous accepted step's error (at least 1e-4), for the PI controller
    ln_err_old: f64,
    rejected_last: bool,
    stats: Stats,
    breakpoints: Vec<f64>,
    bp_next: usize,
    solution: Option<Solution<N>>,
}

#[inline]
fn is_finite<const N: usize>(v: &SV<N>) -> bool {
    v.iter().all(|c| c.is_finite())
}

impl<const N: usize> Core<N> {
    fn new(t0: f64, x0: SV<N>, opts: Options, mut breakpoints: Vec<f64>) -> Result<Self, Error> {
        opts.validate()?;
        if !t0.is_finite() {
            return Err(Error::InvalidProblem {
                what: "t0",
                value: t0,
                expected: "a finite initial time",
            });
        }
        if !is_finite(&x0) {
            return Err(Error::NonFiniteInitialState { t0 });
        }
        for &b in &breakpoints {
            if b.is_nan() {
                return Err(Error::InvalidProblem {
                    what: "breakpoint",
                    value: b,
                    expected: "finite breakpoint times",
                });
            }
        }
        breakpoints.retain(|&b| b > t0 && b.is_finite());
        breakpoints.sort_by(f64::total_cmp);
        // merge breakpoints closer than a few ulps (e.g. 2τ₁ vs τ₂ = 2τ₁ up to rounding)
        breakpoints.dedup_by(|b, a| (*b - *a).abs() <= 64.0 * f64::EPSILON * a.abs().max(1.0));
        let solution = match opts.dense_output {
            DenseOutput::Keep => Some(Solution::default()),
            DenseOutput::Discard => None,
        };
        Ok(Core {
            opts,
            t: t0,
            x: x0,
            k1: SV::<N>::zeros(),
            k1_valid: false,
            h: 0.0,
            ln_err_old: 1e-4_f64.ln(),
            rejected_last: false,
            stats: Stats::default(),
            breakpoints,
            bp_next: 0,
            solution,
        })
    }

    fn err_norm(&self, x: &SV<N>, x_new: &SV<N>, e: &SV<N>) -> f64 {
        let (rtol, atol) = (self.opts.rtol, self.opts.atol);
        let mut s = 0.0;
        for i in 0..N {
            let sk = atol + rtol * x[i].abs().max(x_new[i].abs());
            let q = e[i] / sk;
            s += q * q;
        }
        (s / N as f64).sqrt()
    }

    /// Hairer's starting step (*Solving ODEs I*, §II.4).
    fn initial_step<R: Rhs<N>>(&mut self, rhs: &mut R, h_cap: f64, t_end: f64) -> f64 {
        let (rtol, atol) = (self.opts.rtol, self.opts.atol);
        let norm = |v: &SV<N>, x: &SV<N>| {
            let mut s = 0.0;
            for i in 0..N {
                let q = v[i] / (atol + rtol * x[i].abs());
                s += q * q;
            }
            (s / N as f64).sqrt()
        };
        let d0 = norm(&self.x, &self.x);
        let d1 = norm(&self.k1, &self.x);
        let mut h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        };
        h0 = h0.min(h_cap).min(t_end - self.t);
        let x1 = self.x + self.k1 * h0;
        let mut f1 = SV::<N>::zeros();
        rhs.eval(self.t + h0, &x1, &mut f1);
        self.stats.rhs_evals += 1;
        let d2 = norm(&(f1 - self.k1), &self.x) / h0;
        let dm = d1.max(d2);
        let h1 = if dm <= 1e-15 || !dm.is_finite() {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / dm).powf(0.2)
        };
        (100.0 * h0).min(h1).min(h_cap)
    }

    /// Integrates to `t_end`: attempt, judge, accept, record, detect events, advance and
    /// report, one Dormand–Prince step after the other.
    fn run<R: Rhs<N>, O: Observer<N>>(
        &mut self,
        rhs: &mut R,
        t_end: f64,
        events: &[Event<'_, N>],
        obs: &mut O,
    ) -> Result<Status<N>, Error> {
        if !t_end.is_finite() || t_end < self.t {
            return Err(Error::InvalidInterval { t: self.t, t_end });
        }
        if t_end == self.t {
            return Ok(Status::Reached);
        }
        self.ensure_fsal(rhs)?;
        let ctl = self.control(rhs, t_end);
        let mut scratch = EventScratch::new(&*rhs, events, self.t, &self.x);
        let mut attempts = 0usize;
        loop {
            self.pass_reached_breakpoints();
            if self.t >= t_end {
                return Ok(Status::Reached);
            }
            if attempts >= self.opts.max_steps {
                return Err(Error::TooManySteps {
                    t: self.t,
                    max_steps: self.opts.max_steps,
                });
            }
            attempts += 1;

            let plan = self.plan_step(&ctl, t_end)?;
            let stages = Stages::compute(rhs, &plan);
            self.stats.rhs_evals += 6;
            let Some(err) = self.judge(&ctl, &plan, &stages)? else {
                continue;
            };
            let h_next = self.accept(&ctl, &plan, err);
            let seg = self.record(rhs, &plan, &stages);
            let stop_at = scratch.detect(&*rhs, events, &seg, &plan, &stages, self.opts.event_tol);
            let seg_obs = match stop_at {
                Some(k) => self.stop_at_event(rhs, &seg, scratch.hits[k], h_next),
                None => {
                    self.advance(rhs, &plan, &stages, h_next)?;
                    seg
                }
            };
            if let Some(status) = self.report(rhs, obs, &seg_obs, &scratch.hits, stop_at) {
                return Ok(status);
            }
        }
    }

    /// Makes `k1 = f(t, x)` valid (after construction, a breakpoint or a terminal event).
    fn ensure_fsal<R: Rhs<N>>(&mut self, rhs: &mut R) -> Result<(), Error> {
        if !self.k1_valid {
            self.evaluate_k1(rhs)?;
            self.k1_valid = true;
        }
        Ok(())
    }

    /// `k1 = f(t, x)` evaluated afresh at the current point (counted, checked finite).
    fn evaluate_k1<R: Rhs<N>>(&mut self, rhs: &mut R) -> Result<(), Error> {
        let mut k1 = SV::<N>::zeros();
        rhs.eval(self.t, &self.x, &mut k1);
        self.stats.rhs_evals += 1;
        if !is_finite(&k1) {
            return Err(Error::NonFiniteState { t: self.t });
        }
        self.k1 = k1;
        Ok(())
    }

    /// Reads the step-size settings of this call and picks the first step if none is set.
    fn control<R: Rhs<N>>(&mut self, rhs: &mut R, t_end: f64) -> Control {
        let h_cap = self.opts.h_max.min(rhs.h_cap());
        let fixed = match self.opts.controller {
            StepController::Fixed { h } => Some(h),
            StepController::Pi { .. } => None,
        };
        let beta = match self.opts.controller {
            StepController::Pi { beta } => beta,
            StepController::Fixed { .. } => 0.0,
        };
        if self.h == 0.0 {
            self.h = match (fixed, self.opts.h_initial) {
                (Some(h), _) | (None, Some(h)) => h,
                (None, None) => self.initial_step(rhs, h_cap, t_end),
            };
        }
        Control {
            h_cap,
            fixed,
            beta,
            expo1: 0.2 - 0.75 * beta,
            safety: self.opts.safety,
            fac_min: self.opts.fac_min,
            fac_max: self.opts.fac_max,
        }
    }

    /// Passes the breakpoints already reached (or too close to resolve).
    fn pass_reached_breakpoints(&mut self) {
        while self.bp_next < self.breakpoints.len()
            && self.breakpoints[self.bp_next] - self.t <= 16.0 * f64::EPSILON * self.t.abs()
        {
            self.bp_next += 1;
        }
    }

    /// The next step: the proposed size, shortened to land on the next breakpoint or on
    /// `t_end` (and stretched by up to 1 % to land instead of leaving a sliver).
    fn plan_step(&self, ctl: &Control, t_end: f64) -> Result<Plan<N>, Error> {
        let t = self.t;
        let (target, at_bp) = match self.breakpoints.get(self.bp_next) {
            Some(&b) if b < t_end => (b, true),
            _ => (t_end, false),
        };
        let h_prop = ctl.fixed.unwrap_or(self.h).min(ctl.h_cap);
        let dist = target - t;
        let (h, land) = if h_prop >= dist || (dist <= 1.01 * h_prop && dist <= ctl.h_cap) {
            (dist, true)
        } else {
            (h_prop, false)
        };
        if h <= 16.0 * f64::EPSILON * t.abs() || h <= 0.0 {
            return Err(Error::StepSizeUnderflow { t, h });
        }
        let t_new = if land { target } else { t + h };
        let at_bp = land && at_bp;
        // at a breakpoint the right-hand side is evaluated as its left limit
        let t_last = if at_bp { target.next_down() } else { t_new };
        Ok(Plan {
            t,
            x: self.x,
            k1: self.k1,
            h,
            h_prop,
            land,
            at_bp,
            t_new,
            t_last,
        })
    }

    /// The scaled error of the step (0 with fixed steps), or `None` after a rejection (the
    /// step size is then reduced); an error once the step cannot shrink any further.
    fn judge(&mut self, ctl: &Control, p: &Plan<N>, s: &Stages<N>) -> Result<Option<f64>, Error> {
        let err = if ctl.fixed.is_some() {
            if is_finite(&s.x_new) && is_finite(&s.k[6]) {
                0.0
            } else {
                f64::NAN
            }
        } else {
            self.err_norm(&p.x, &s.x_new, &s.error_estimate(p.h))
        };
        if !err.is_finite() || !is_finite(&s.x_new) || !is_finite(&s.k[6]) {
            // try again with a much smaller step; give up once it cannot shrink further
            self.stats.rejected += 1;
            self.rejected_last = true;
            if ctl.fixed.is_some()
                || p.h * ctl.fac_min <= 16.0 * f64::EPSILON * p.t.abs().max(1e-300)
            {
                return Err(Error::NonFiniteState { t: p.t });
            }
            self.h = p.h * ctl.fac_min;
            return Ok(None);
        }
        if err > 1.0 {
            self.stats.rejected += 1;
            let fac11 = err.powf(ctl.expo1);
            self.h = p.h / (1.0 / ctl.fac_min).min(fac11 / ctl.safety);
            self.rejected_last = true;
            return Ok(None);
        }
        Ok(Some(err))
    }

    /// Counts the accepted step and returns the next step size (PI control).
    fn accept(&mut self, ctl: &Control, p: &Plan<N>, err: f64) -> f64 {
        self.stats.accepted += 1;
        let h_next = if ctl.fixed.is_some() {
            p.h_prop
        } else {
            // err^α / err_old^β as one exp of logs (err = 0 gives 0, as the powers do)
            let ln_err = err.ln();
            let fac = ((ctl.expo1 * ln_err - ctl.beta * self.ln_err_old).exp() / ctl.safety)
                .clamp(1.0 / ctl.fac_max, 1.0 / ctl.fac_min);
            let mut hn = p.h / fac;
            if self.rejected_last {
                hn = hn.min(p.h);
            }
            if p.land {
                // a step cut short to land does not say the next one must be short
                hn = hn.max(p.h_prop.min(hn * ctl.fac_max));
            }
            self.ln_err_old = ln_err.max(1e-4_f64.ln());
            hn
        };
        self.rejected_last = false;
        h_next
    }

    /// The continuous extension of the accepted step, stored in the past (DDE) and in the
    /// kept dense output.
    fn record<R: Rhs<N>>(&mut self, rhs: &mut R, p: &Plan<N>, s: &Stages<N>) -> Segment<N> {
        let seg = s.segment(p);
        rhs.push(&seg);
        if let Some(sol) = self.solution.as_mut() {
            sol.push(seg);
        }
        seg
    }

    /// Ends the step at a terminal event: the past, the dense output and the state are cut
    /// at its time, and `k1` is invalid. Returns the step as the observer sees it.
    fn stop_at_event<R: Rhs<N>>(
        &mut self,
        rhs: &mut R,
        seg: &Segment<N>,
        hit: EventHit<N>,
        h_next: f64,
    ) -> Segment<N> {
        let mut seg_obs = *seg;
        seg_obs.t_end = hit.t;
        rhs.truncate(hit.t);
        if let Some(sol) = self.solution.as_mut() {
            sol.truncate_last(hit.t);
        }
        self.t = hit.t;
        self.x = hit.x;
        self.k1_valid = false;
        self.h = h_next;
        seg_obs
    }

    /// Moves to the end of the step; at a breakpoint `k1` becomes the right limit of `f`.
    fn advance<R: Rhs<N>>(
        &mut self,
        rhs: &mut R,
        p: &Plan<N>,
        s: &Stages<N>,
        h_next: f64,
    ) -> Result<(), Error> {
        self.t = p.t_new;
        self.x = s.x_new;
        self.h = h_next;
        if p.at_bp {
            self.bp_next += 1;
            // right limit of f after the jump
            self.evaluate_k1(rhs)?;
        } else {
            self.k1 = s.k[6];
        }
        Ok(())
    }

    /// Shows the step and its events to the observer; the final status if the integration
    /// ends here (a terminal event, or the observer's stop).
    fn report<R: Rhs<N>, O: Observer<N>>(
        &mut self,
        rhs: &mut R,
        obs: &mut O,
        seg_obs: &Segment<N>,
        hits: &[EventHit<N>],
        stop_at: Option<usize>,
    ) -> Option<Status<N>> {
        let view = StepView {
            segment: seg_obs,
            x: &self.x,
            past: &*rhs,
        };
        let flow = obs.on_step(&view);
        for hit in hits {
            obs.on_event(hit);
        }
        if let Some(k) = stop_at {
            if !self.k1_valid {
                let mut k1n = SV::<N>::zeros();
                rhs.eval(self.t, &self.x, &mut k1n);
                self.stats.rhs_evals += 1;
                self.k1 = k1n;
                self.k1_valid = is_finite(&k1n);
            }
            return Some(Status::Event(hits[k]));
        }
        (flow == Flow::Stop).then_some(Status::ObserverStopped)
    }
}

/// Step-size settings of one `integrate` call, read once from the options.
#[derive(Debug, Clone, Copy)]
struct Control {
    /// largest step (h_max, and the smallest delay for DDEs)
    h_cap: f64,
    /// the fixed step size, if the controller is fixed
    fixed: Option<f64>,
    /// PI weight of the previous error
    beta: f64,
    /// exponent of the current error, 1/5 − 0.75 β
    expo1: f64,
    safety: f64,
    fac_min: f64,
    fac_max: f64,
}

/// The step about to be attempted from `(t, x)` with `k1 = f(t, x)`.
#[derive(Debug, Clone, Copy)]
struct Plan<const N: usize> {
    t: f64,
    x: SV<N>,
    k1: SV<N>,
    /// the step size
    h: f64,
    /// the size the controller proposed (before landing)
    h_prop: f64,
    /// whether the step lands on a breakpoint or on `t_end`
    land: bool,
    /// whether it lands on a breakpoint
    at_bp: bool,
    /// end of the step
    t_new: f64,
    /// where the last stages are evaluated: the left limit at a breakpoint
    t_last: f64,
}

/// The seven stages `k[0] = k1 … k[6] = k7` of one Dormand–Prince step and its result.
#[derive(Debug, Clone, Copy)]
struct Stages<const N: usize> {
    k: [SV<N>; 7],
    x_new: SV<N>,
}

impl<const N: usize> Stages<N> {
    /// One Dormand–Prince 5(4) step (six new right-hand side evaluations, FSAL).
    fn compute<R: Rhs<N>>(rhs: &mut R, p: &Plan<N>) -> Self {
        let (t, x, k1, h) = (p.t, p.x, p.k1, p.h);
        let mut k2 = SV::<N>::zeros();
        let mut k3 = SV::<N>::zeros();
        let mut k4 = SV::<N>::zeros();
        let mut k5 = SV::<N>::zeros();
        let mut k6 = SV::<N>::zeros();
        let mut k7 = SV::<N>::zeros();
        rhs.eval(t + C2 * h, &(x + k1 * (h * A21)), &mut k2);
        rhs.eval(t + C3 * h, &(x + (k1 * A31 + k2 * A32) * h), &mut k3);
        rhs.eval(
            t + C4 * h,
            &(x + (k1 * A41 + k2 * A42 + k3 * A43) * h),
            &mut k4,
        );
        rhs.eval(
            t + C5 * h,
            &(x + (k1 * A51 + k2 * A52 + k3 * A53 + k4 * A54) * h),
            &mut k5,
        );
        let t6 = if p.at_bp { p.t_last } else { t + h };
        rhs.eval(
            t6,
            &(x + (k1 * A61 + k2 * A62 + k3 * A63 + k4 * A64 + k5 * A65) * h),
            &mut k6,
        );
        let x_new = x + (k1 * A71 + k3 * A73 + k4 * A74 + k5 * A75 + k6 * A76) * h;
        rhs.eval(p.t_last, &x_new, &mut k7);
        Stages {
            k: [k1, k2, k3, k4, k5, k6, k7],
            x_new,
        }
    }

    /// The embedded error estimate (5th minus 4th order solution).
    fn error_estimate(&self, h: f64) -> SV<N> {
        let [k1, _, k3, k4, k5, k6, k7] = self.k;
        (k1 * E1 + k3 * E3 + k4 * E4 + k5 * E5 + k6 * E6 + k7 * E7) * h
    }

    /// The continuous extension of order 4 on `[t, t_new]` (Hairer's DOPRI5 coefficients).
    fn segment(&self, p: &Plan<N>) -> Segment<N> {
        let [k1, _, k3, k4, k5, k6, k7] = self.k;
        let (x, h) = (p.x, p.h);
        let ydiff = self.x_new - x;
        let bspl = k1 * h - ydiff;
        Segment {
            t_start: p.t,
            t_end: p.t_new,
            h,
            r: [
                x,
                ydiff,
                bspl,
                ydiff - k7 * h - bspl,
                (k1 * D1 + k3 * D3 + k4 * D4 + k5 * D5 + k6 * D6 + k7 * D7) * h,
            ],
        }
    }
}

/// Event bookkeeping of one `integrate` call (allocated per call, only when there are
/// events): the delayed states for `g`, the last value of each `g`, the hits of a step.
struct EventScratch<const N: usize> {
    xd: Vec<SV<N>>,
    g_prev: Vec<f64>,
    hits: Vec<EventHit<N>>,
}

impl<const N: usize> EventScratch<N> {
    fn new<R: Rhs<N>>(rhs: &R, events: &[Event<'_, N>], t: f64, x: &SV<N>) -> Self {
        let mut xd: Vec<SV<N>> = if events.is_empty() {
            Vec::new()
        } else {
            vec![SV::<N>::zeros(); rhs.n_delays()]
        };
        rhs.delayed_states(t, x, &mut xd);
        let g_prev: Vec<f64> = events.iter().map(|e| e.g(t, x, &xd)).collect();
        EventScratch {
            xd,
            g_prev,
            hits: Vec::with_capacity(events.len()),
        }
    }

    /// Finds the events of the accepted step `seg`, sorted in time; the index (into
    /// `self.hits`) of the first terminal one, where the hits are cut off.
    fn detect<R: Rhs<N>>(
        &mut self,
        rhs: &R,
        events: &[Event<'_, N>],
        seg: &Segment<N>,
        p: &Plan<N>,
        s: &Stages<N>,
        event_tol: f64,
    ) -> Option<usize> {
        let (t, t_new, x_new) = (p.t, p.t_new, s.x_new);
        self.hits.clear();
        for (i, ev) in events.iter().enumerate() {
            rhs.delayed_states(t_new, &x_new, &mut self.xd);
            let g1 = ev.g(t_new, &x_new, &self.xd);
            // (recomputed per event: the root search below overwrites the buffer)
            if let Some(dir) = ev.triggers(self.g_prev[i], g1) {
                let xd_buf = &mut self.xd;
                let g = |s: f64| {
                    let xs = seg.eval(s);
                    rhs.delayed_states(s, &xs, xd_buf);
                    ev.g(s, &xs, xd_buf)
                };
                let ts = locate_root(g, t, self.g_prev[i], t_new, g1, event_tol);
                self.hits.push(EventHit {
                    index: i,
                    t: ts,
                    x: seg.eval(ts),
                    direction: dir,
                });
            }
            self.g_prev[i] = g1;
        }
        if self.hits.is_empty() {
            return None;
        }
        self.hits
            .sort_by(|a, b| a.t.total_cmp(&b.t).then(a.index.cmp(&b.index)));
        let k = self
            .hits
            .iter()
            .position(|h| events[h.index].action == EventAction::Stop)?;
        self.hits.truncate(k + 1);
        Some(k)
    }
}

fn check_delays(delays: &[f64]) -> Result<(), Error> {
    for &tau in delays {
        if !(tau.is_finite() && tau >= 0.0) {
            return Err(Error::InvalidProblem {
                what: "delay",
                value: tau,
                expected: "a finite delay >= 0",
            });
        }
    }
    Ok(())
}

/// `b + k₁τ₁ + … + kₘτₘ` for `k_min ≤ Σk ≤ order` (positive delays only).
fn propagate(base: f64, k_min: usize, delays: &[f64], order: usize, out: &mut Vec<f64>) {
    fn rec(
        t: f64,
        used: usize,
        k_min: usize,
        start: usize,
        d: &[f64],
        order: usize,
        out: &mut Vec<f64>,
    ) {
        if used >= k_min {
            out.push(t);
        }
        if used == order {
            return;
        }
        for j in start..d.len() {
            rec(t + d[j], used + 1, k_min, j, d, order, out);
        }
    }
    rec(base, 0, k_min, 0, delays, order, out);
}

// ---------------------------------------------------------------------------------------

/// The read accessors both solvers share: time, state, counters, dense output and options
/// of the common stepping core.
macro_rules! core_accessors {
    () => {
        /// current time
        pub fn t(&self) -> f64 {
            self.core.t
        }
        /// current state
        pub fn state(&self) -> &SV<N> {
            &self.core.x
        }
        /// work counters since construction
        pub fn stats(&self) -> Stats {
            self.core.stats
        }
        /// the kept dense output ([`DenseOutput::Keep`])
        pub fn solution(&self) -> Option<&Solution<N>> {
            self.core.solution.as_ref()
        }
        /// the options in use
        pub fn options(&self) -> &Options {
            &self.core.opts
        }
    };
}

/// Integration state of an ODE (cloneable: save and restore it freely). The problem is
/// passed to every call; the solver never owns it.
#[derive(Debug, Clone)]
pub struct OdeSolver<const N: usize> {
    core: Core<N>,
}

impl<const N: usize> OdeSolver<N> {
    /// Starts at `(t0, x0)`; the problem's breakpoints are read here.
    pub fn new<P: OdeProblem<N>>(p: &P, t0: f64, x0: SV<N>, opts: Options) -> Result<Self, Error> {
        Ok(OdeSolver {
            core: Core::new(t0, x0, opts, p.breakpoints().to_vec())?,
        })
    }

    /// Integrates to `t_end` (or to the first terminal event / observer stop).
    pub fn integrate<P: OdeProblem<N>, O: Observer<N>>(
        &mut self,
        p: &P,
        t_end: f64,
        events: &[Event<'_, N>],
        observer: &mut O,
    ) -> Result<Status<N>, Error> {
        self.core.run(&mut OdeRhs(p), t_end, events, observer)
    }

    core_accessors!();
}

/// Integration state of a DDE with constant delays: current state, the computed past
/// (pruned to the longest delay) and the breakpoint schedule. Cloneable; the problem is passed
/// to every call.
#[derive(Debug, Clone)]
pub struct DdeSolver<const N: usize> {
    core: Core<N>,
    t0: f64,
    delays: Vec<f64>,
    past: Past<N>,
    delayed: Vec<SV<N>>,
}

impl<const N: usize> DdeSolver<N> {
    /// Starts at `t0` with `x(t0) = history(t0)`. Breakpoints: `t0 + Σkⱼτⱼ` for
    /// `1 ≤ Σkⱼ ≤ breakpoint_order` (the jump of the derivative at t0 travelling along the
    /// delays) and every user breakpoint `b + Σkⱼτⱼ`, `0 ≤ Σkⱼ ≤ breakpoint_order`.
    pub fn new<P: DdeProblem<N>>(p: &P, t0: f64, opts: Options) -> Result<Self, Error> {
        let delays = p.delays().to_vec();
        check_delays(&delays)?;
        let mut pos: Vec<f64> = delays.iter().copied().filter(|&d| d > 0.0).collect();
        pos.sort_by(f64::total_cmp);
        pos.dedup();
        let order = opts.breakpoint_order;
        let mut bps = Vec::new();
        propagate(t0, 1, &pos, order, &mut bps);
        for &b in p.breakpoints() {
            propagate(b, 0, &pos, order, &mut bps);
        }
        let x0 = p.history(t0);
        let core = Core::new(t0, x0, opts, bps)?;
        let span = pos.last().copied().unwrap_or(0.0);
        Ok(DdeSolver {
            core,
            t0,
            past: Past {
                segs: VecDeque::with_capacity(64),
                span,
            },
            delayed: vec![SV::<N>::zeros(); delays.len()],
            delays,
        })
    }

    /// Integrates to `t_end` (or to the first terminal event / observer stop). The problem
    /// must have the delays it had at construction.
    pub fn integrate<P: DdeProblem<N>, O: Observer<N>>(
        &mut self,
        p: &P,
        t_end: f64,
        events: &[Event<'_, N>],
        observer: &mut O,
    ) -> Result<Status<N>, Error> {
        if p.delays() != self.delays.as_slice() {
            return Err(Error::InvalidProblem {
                what: "number or values of delays",
                value: p.delays().len() as f64,
                expected: "the delays the solver was constructed with (build a new DdeSolver)",
            });
        }
        let h_cap = self
            .delays
            .iter()
            .copied()
            .filter(|&d| d > 0.0)
            .fold(f64::INFINITY, f64::min);
        let mut rhs = DdeRhs {
            p,
            t0: self.t0,
            past: &mut self.past,
            delayed: &mut self.delayed,
            h_cap,
        };
        self.core.run(&mut rhs, t_end, events, observer)
    }

    core_accessors!();
    /// the breakpoint schedule (sorted, after t0)
    pub fn breakpoints(&self) -> &[f64] {
        &self.core.breakpoints
    }
}

/// Solves an ODE on `[t0, t_end]` and returns the dense solution (forces
/// [`DenseOutput::Keep`]).
pub fn solve_ode<const N: usize, P: OdeProblem<N>>(
    p: &P,
    t0: f64,
    x0: SV<N>,
    t_end: f64,
    opts: Options,
) -> Result<Solution<N>, Error> {
    let mut s = OdeSolver::new(p, t0, x0, opts.keep_dense_output())?;
    s.integrate(p, t_end, &[], &mut NoObserver)?;
    Ok(s.core.solution.take().unwrap_or_default())
}

/// Solves a DDE on `[t0, t_end]` and returns the dense solution on `[t0, t_end]` (forces
/// [`DenseOutput::Keep`]; for `t < t0` use the problem's history).
pub fn solve_dde<const N: usize, P: DdeProblem<N>>(
    p: &P,
    t0: f64,
    t_end: f64,
    opts: Options,
) -> Result<Solution<N>, Error> {
    let mut s = DdeSolver::new(p, t0, opts.keep_dense_output())?;
    s.integrate(p, t_end, &[], &mut NoObserver)?;
    Ok(s.core.solution.take().unwrap_or_default())
}
