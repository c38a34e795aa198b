//! The Runge–Kutta stepping loop shared by the ODE and the DDE solver and by both pairs
//! ([`crate::Method`]): attempt, judge, accept, record, detect events, advance, report.

use std::cell::{Cell, OnceCell, RefCell};
use std::collections::VecDeque;

use nalgebra::SVector;

use crate::Error;
use crate::dense::{Segment, Solution};
use crate::events::{Event, EventAction, EventHit, locate_root};
use crate::options::{DenseOutput, KinkLanding, Options, StepController};
use crate::problem::{DdeProblem, OdeProblem};
use crate::scheme::Pair;
use crate::step::{PastEval, Plan, Rhs, Tolerances};

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
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// accepted steps
    pub accepted: usize,
    /// rejected steps
    pub rejected: usize,
    /// right-hand side evaluations
    pub rhs_evals: usize,
    /// steps landed on a root of a switching function (a kink of `f`)
    pub switches: usize,
}

/// What an observer sees of an accepted step. The continuous extension is built when first
/// asked for (with DOP853 on an ODE that costs three right-hand sides; an observer that
/// only reads [`StepView::x`] costs nothing).
pub struct StepView<'a, const N: usize> {
    t_start: f64,
    t_end: f64,
    x: &'a SV<N>,
    source: &'a dyn StepSource<N>,
}

impl<const N: usize> std::fmt::Debug for StepView<'_, N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StepView")
            .field("t_start", &self.t_start)
            .field("t_end", &self.t_end)
            .field("x", self.x)
            .finish_non_exhaustive()
    }
}

impl<const N: usize> StepView<'_, N> {
    /// start of the step
    pub fn t_start(&self) -> f64 {
        self.t_start
    }
    /// end of the step
    pub fn t_end(&self) -> f64 {
        self.t_end
    }
    /// state at the end of the step
    pub fn x(&self) -> &SV<N> {
        self.x
    }
    /// the continuous extension of this step
    pub fn segment(&self) -> &Segment<N> {
        self.source.segment()
    }
    /// the solution at `t` in `[t_start, t_end]` from the continuous extension
    pub fn eval(&self, t: f64) -> SV<N> {
        self.segment().eval(t)
    }
    /// DDE: the solution at an earlier time `t ≥ t_start − max delay` (history for `t ≤ t0`);
    /// ODE: only within this step. `None` outside what is stored.
    pub fn eval_past(&self, t: f64) -> Option<SV<N>> {
        if t >= self.t_start && t <= self.t_end {
            Some(self.eval(t))
        } else if t < self.t_start {
            self.source.eval_past(t)
        } else {
            None
        }
    }
}

/// What a [`StepView`] reads: the step's continuous extension (built on demand) and the
/// stored past.
trait StepSource<const N: usize> {
    fn segment(&self) -> &Segment<N>;
    fn eval_past(&self, t: f64) -> Option<SV<N>>;
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

/// The problem behind a `&dyn`: the stepping loop, its controller and the event machinery
/// are compiled once per state count N, not once per problem type (one indirect call per
/// stage is nothing beside a right-hand side).
struct OdeRhs<'a, const N: usize>(&'a dyn OdeProblem<N>);

impl<const N: usize> PastEval<N> for OdeRhs<'_, N> {
    fn eval_past(&self, _t: f64) -> Option<SV<N>> {
        None
    }
}

impl<const N: usize> Rhs<N> for OdeRhs<'_, N> {
    #[inline]
    fn eval(&self, t: f64, x: &SV<N>, dx: &mut SV<N>) {
        self.0.rhs(t, x, dx);
    }
    fn keeps_past(&self) -> bool {
        false
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
    fn switching(&self, t: f64, x: &SV<N>, g: &mut [f64]) {
        self.0.switching(t, x, g);
    }
}

/// The computed past of a DDE, pruned to the longest delay.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone)]
struct Past<const N: usize> {
    segs: VecDeque<Segment<N>>,
    span: f64,
    /// the segment of the last lookup: the stages of consecutive steps query t − τ in
    /// increasing order, so the next answer is almost always this one or the next
    cursor: Cell<usize>,
}

impl<const N: usize> Past<N> {
    fn new(span: f64) -> Self {
        Self {
            segs: VecDeque::with_capacity(64),
            span,
            cursor: Cell::new(0),
        }
    }

    fn push(&mut self, seg: &Segment<N>) {
        self.segs.push_back(*seg);
        // queries (stages and observers) reach back to t_start - span at most
        let keep_from = seg.t_start - self.span;
        while self.segs.len() > 1 && self.segs[0].t_end < keep_from {
            self.segs.pop_front();
            self.cursor.set(self.cursor.get().saturating_sub(1));
        }
    }

    /// The first segment ending at or after `t` (the last one if none does): checked at
    /// the cursor and the segment after it, else found by bisection.
    #[inline]
    fn index(&self, t: f64) -> usize {
        let n = self.segs.len();
        let ends_before = |i: usize| self.segs[i].t_end < t;
        let is_answer =
            |i: usize| (i == n - 1 || !ends_before(i)) && (i == 0 || ends_before(i - 1));
        let c = self.cursor.get().min(n - 1);
        let i = if is_answer(c) {
            c
        } else if c + 1 < n && is_answer(c + 1) {
            c + 1
        } else {
            self.segs.partition_point(|s| s.t_end < t).min(n - 1)
        };
        self.cursor.set(i);
        i
    }

    #[inline]
    fn lookup(&self, t: f64) -> Option<SV<N>> {
        if self.segs.is_empty() {
            return None;
        }
        Some(self.segs[self.index(t)].eval(t))
    }
}

struct DdeRhs<'a, const N: usize> {
    /// the problem behind a `&dyn` (see [`OdeRhs`])
    p: &'a dyn DdeProblem<N>,
    t0: f64,
    past: &'a mut Past<N>,
    /// scratch for `x(t − τⱼ)` (a cell: evaluation goes through a shared reference)
    delayed: &'a RefCell<Vec<SV<N>>>,
    h_cap: f64,
}

impl<const N: usize> DdeRhs<'_, N> {
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

impl<const N: usize> PastEval<N> for DdeRhs<'_, N> {
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

impl<const N: usize> Rhs<N> for DdeRhs<'_, N> {
    #[inline]
    fn eval(&self, t: f64, x: &SV<N>, dx: &mut SV<N>) {
        let delays = self.p.delays();
        let mut delayed = self.delayed.borrow_mut();
        for (j, &tau) in delays.iter().enumerate() {
            let v = if tau == 0.0 { *x } else { self.at(t - tau) };
            delayed[j] = v;
        }
        self.p.rhs(t, x, &delayed[..delays.len()], dx);
    }
    fn keeps_past(&self) -> bool {
        true
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
    fn switching(&self, t: f64, x: &SV<N>, g: &mut [f64]) {
        let mut delayed = self.delayed.borrow_mut();
        let n = self.p.delays().len();
        self.delayed_states(t, x, &mut delayed[..n]);
        self.p.switching(t, x, &delayed[..n], g);
    }
}

/// Integration state shared by both solvers (cloneable: save and restore it freely).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
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
    switches: Switches,
    solution: Option<Solution<N>>,
}

#[inline]
fn is_finite<const N: usize>(v: &SV<N>) -> bool {
    v.iter().all(|c| c.is_finite())
}

impl<const N: usize> Core<N> {
    fn new(
        t0: f64,
        x0: SV<N>,
        opts: Options,
        mut breakpoints: Vec<f64>,
        switching_count: usize,
    ) -> Result<Self, Error> {
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
        let switches = Switches::new(switching_count, opts.kink_landing);
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
            switches,
            solution,
        })
    }

    /// Hairer's starting step (*Solving ODEs I*, §II.4) for a method of order `order`.
    fn initial_step<R: Rhs<N>>(&mut self, rhs: &R, h_cap: f64, t_end: f64, order: usize) -> f64 {
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
            (0.01 / dm).powf(1.0 / order as f64)
        };
        (100.0 * h0).min(h1).min(h_cap)
    }

    /// Integrates to `t_end`: attempt, judge, accept, record, detect events, advance and
    /// report, one step of the options' pair after the other. The pair is a value
    /// ([`Pair`]), not a type parameter: one stepping loop is compiled per problem, not one
    /// per problem and pair (the loop, the events and the kink location are most of the
    /// solver's code; the per-pair stage arithmetic sits behind one `match` per call).
    fn run<R: Rhs<N>>(
        &mut self,
        rhs: &mut R,
        t_end: f64,
        events: &[Event<'_, N>],
        obs: &mut dyn Observer<N>,
    ) -> Result<Status<N>, Error> {
        if !t_end.is_finite() || t_end < self.t {
            return Err(Error::InvalidInterval { t: self.t, t_end });
        }
        if t_end == self.t {
            return Ok(Status::Reached);
        }
        self.ensure_fsal(rhs)?;
        let method = self.opts.method;
        let ctl = self.control(rhs, t_end);
        let mut scratch = EventScratch::new(&*rhs, events, self.t, &self.x);
        let mut attempts = 0usize;
        let mut previous: Option<Previous<N>> = None;
        loop {
            // a cancelled computation stops here (`cancel::run` catches it)
            cancel::checkpoint();
            self.pass_reached_breakpoints();
            // reached, or closer than the resolution of t (a kink landed a few ulps before
            // t_end: the sliver left is no step)
            if self.t >= t_end || t_end - self.t <= 16.0 * f64::EPSILON * self.t.abs() {
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
            let stages = Pair::attempt(method, &*rhs, &plan);
            self.stats.rhs_evals += method.evals();
            let err = self.estimate(&ctl, &plan, &stages);
            if self.switches.crossing(
                &*rhs,
                &plan,
                &stages,
                previous.as_ref(),
                self.opts.event_tol,
                &mut self.stats,
            ) {
                // a kink of f inside the step: land on it instead; an attempt that also
                // failed its error test leaves the size the rejection would have
                if err > 1.0 || err.is_nan() {
                    self.h = self.h.min(self.rejected_size(&ctl, &plan, err));
                }
                continue;
            }
            let Some(err) = self.judge(&ctl, &plan, err)? else {
                continue;
            };
            let h_next = self.accept(&ctl, &plan, err);
            self.switches.accepted(&plan, &mut self.stats);
            let mut dense = StepDense::new(&plan, &stages);
            self.record(rhs, &dense);
            let stop_at = scratch.detect(&*rhs, events, &dense, self.opts.event_tol);
            match stop_at {
                Some(k) => self.stop_at_event(rhs, &mut dense, scratch.hits[k], h_next),
                None => self.advance(rhs, &plan, &stages, h_next)?,
            }
            let status = self.report(&*rhs, obs, &dense, &scratch.hits, stop_at);
            // the extension stays valid past the step's end unless f jumps there (a
            // breakpoint) or the state was reset (a terminal event)
            let carries = !plan.at_bp && stop_at.is_none();
            if status.is_none() && carries {
                let h = ctl.fixed.unwrap_or(self.h).min(ctl.h_cap);
                self.switches
                    .look_ahead(&*rhs, &dense, h, self.opts.event_tol);
            }
            self.stats.rhs_evals += dense.extra_evals.get();
            if let Some(status) = status {
                return Ok(status);
            }
            // exact landing relocates a crossed kink on this extension: keep the step (with
            // its extension if it was built)
            let built = dense.segment.get().copied();
            previous = (carries && self.switches.landing == KinkLanding::Exact).then(|| Previous {
                plan,
                stages,
                segment: built.map_or_else(OnceCell::new, OnceCell::from),
            });
        }
    }

    /// The right-hand side jumps at the current time (an input changed between two calls):
    /// `k1` becomes invalid (the next call evaluates the right limit), the switching
    /// functions start afresh, and `later` (the jump carried along the delays) joins the
    /// breakpoint schedule; the breakpoints already passed are dropped.
    fn input_jump(&mut self, later: &[f64]) {
        self.k1_valid = false;
        self.switches.restart();
        self.breakpoints.drain(..self.bp_next);
        self.bp_next = 0;
        let t = self.t;
        self.breakpoints
            .extend(later.iter().copied().filter(|&b| b > t));
        self.breakpoints.sort_by(f64::total_cmp);
        self.breakpoints
            .dedup_by(|b, a| (*b - *a).abs() <= 64.0 * f64::EPSILON * a.abs().max(1.0));
    }

    /// Makes `k1 = f(t, x)` valid (after construction, a breakpoint or a terminal event).
    fn ensure_fsal<R: Rhs<N>>(&mut self, rhs: &R) -> Result<(), Error> {
        if !self.k1_valid {
            self.evaluate_k1(rhs)?;
            self.k1_valid = true;
        }
        Ok(())
    }

    /// `k1 = f(t, x)` evaluated afresh at the current point (counted, checked finite).
    fn evaluate_k1<R: Rhs<N>>(&mut self, rhs: &R) -> Result<(), Error> {
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
    fn control<R: Rhs<N>>(&mut self, rhs: &R, t_end: f64) -> Control {
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
                (None, None) => self.initial_step(rhs, h_cap, t_end, self.opts.method.order()),
            };
        }
        Control {
            h_cap,
            fixed,
            beta,
            expo1: self.opts.method.exponent() - self.opts.method.beta_weight() * beta,
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
        let (mut target, mut at_bp) = match self.breakpoints.get(self.bp_next) {
            Some(&b) if b < t_end => (b, true),
            _ => (t_end, false),
        };
        if let Some(kink) = self.switches.kink
            && kink.t < target
        {
            (target, at_bp) = (kink.t, false);
        }
        if let Some(&echo) = self.switches.echoes.front()
            && echo < target
        {
            (target, at_bp) = (echo, false);
        }
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

    /// The scaled error of the attempt (0 with fixed steps; NaN where the attempt is not
    /// finite).
    fn estimate(&self, ctl: &Control, p: &Plan<N>, s: &Pair<N>) -> f64 {
        if !(is_finite(s.x_new()) && is_finite(s.f_new())) {
            return f64::NAN;
        }
        if ctl.fixed.is_some() {
            return 0.0;
        }
        s.error(
            p,
            Tolerances {
                rtol: self.opts.rtol,
                atol: self.opts.atol,
            },
        )
    }

    /// The size to try after rejecting an attempt of scaled error `err` > 1 (or not
    /// finite: a much smaller one).
    ///
    /// An attempt cut short at a kink it crossed is not judged, but its size must not
    /// come back after the landing when it failed the error test: a size far too large
    /// (grown over a stretch where nothing moved, before a pulse of the input, say)
    /// diverges, its extension shows a spurious root just ahead, and without the cut the
    /// run creeps on by landings of picoseconds until the step budget is spent.
    fn rejected_size(&self, ctl: &Control, p: &Plan<N>, err: f64) -> f64 {
        if err.is_finite() {
            p.h / (1.0 / ctl.fac_min).min(err.powf(ctl.expo1) / ctl.safety)
        } else {
            p.h * ctl.fac_min
        }
    }

    /// The attempt's scaled error `err` ([`Core::estimate`]) if it passes, or `None` after
    /// a rejection (the step size is then reduced); an error once the step cannot shrink
    /// any further.
    fn judge(&mut self, ctl: &Control, p: &Plan<N>, err: f64) -> Result<Option<f64>, Error> {
        if !err.is_finite() {
            // try again with a much smaller step; give up once it cannot shrink further
            self.stats.rejected += 1;
            self.rejected_last = true;
            if ctl.fixed.is_some()
                || p.h * ctl.fac_min <= 16.0 * f64::EPSILON * p.t.abs().max(1e-300)
            {
                return Err(Error::NonFiniteState { t: p.t });
            }
            self.h = self.rejected_size(ctl, p, err);
            return Ok(None);
        }
        if err > 1.0 {
            self.stats.rejected += 1;
            self.h = self.rejected_size(ctl, p, err);
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
                // a step cut short to land (on a breakpoint, a kink, the end) says nothing
                // about the next one: the controller's proposal before the cut stands
                hn = hn.max(p.h_prop);
            }
            self.ln_err_old = ln_err.max(1e-4_f64.ln());
            hn
        };
        self.rejected_last = false;
        h_next
    }

    /// Stores the continuous extension of the accepted step where it must be kept: in the
    /// past (DDE) and in the kept dense output. (Otherwise it is built only if asked for.)
    fn record<R: Rhs<N>>(&mut self, rhs: &mut R, dense: &StepDense<'_, N>) {
        if !rhs.keeps_past() && self.solution.is_none() {
            return;
        }
        let seg = *dense.get(&*rhs);
        rhs.push(&seg);
        if let Some(sol) = self.solution.as_mut() {
            sol.push(seg);
        }
    }

    /// Ends the step at a terminal event: the past, the dense output and the state are cut
    /// at its time, and `k1` is invalid.
    fn stop_at_event<R: Rhs<N>>(
        &mut self,
        rhs: &mut R,
        dense: &mut StepDense<'_, N>,
        hit: EventHit<N>,
        h_next: f64,
    ) {
        dense.cut(hit.t);
        rhs.truncate(hit.t);
        if let Some(sol) = self.solution.as_mut() {
            sol.truncate_last(hit.t);
        }
        self.t = hit.t;
        self.x = hit.x;
        self.k1_valid = false;
        self.h = h_next;
        self.switches.restart();
    }

    /// Moves to the end of the step; at a breakpoint `k1` becomes the right limit of `f`.
    fn advance<R: Rhs<N>>(
        &mut self,
        rhs: &R,
        p: &Plan<N>,
        s: &Pair<N>,
        h_next: f64,
    ) -> Result<(), Error> {
        self.t = p.t_new;
        self.x = *s.x_new();
        self.h = h_next;
        if p.at_bp {
            self.bp_next += 1;
            // right limit of f after the jump (and of the switching functions)
            self.evaluate_k1(rhs)?;
            self.switches.restart();
        } else {
            self.k1 = *s.f_new();
        }
        Ok(())
    }

    /// Shows the step and its events to the observer; the final status if the integration
    /// ends here (a terminal event, or the observer's stop).
    fn report<R: Rhs<N>>(
        &mut self,
        rhs: &R,
        obs: &mut dyn Observer<N>,
        dense: &StepDense<'_, N>,
        hits: &[EventHit<N>],
        stop_at: Option<usize>,
    ) -> Option<Status<N>> {
        let source = Shown { rhs, dense };
        let view = StepView {
            t_start: dense.plan.t,
            t_end: dense.t_end,
            x: &self.x,
            source: &source,
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

/// The continuous extension of an accepted step, built at most once and only when
/// something needs it (the DDE past, the kept output, an event that fires, an observer);
/// counts the extra right-hand sides that took.
struct StepDense<'s, const N: usize> {
    plan: &'s Plan<N>,
    stages: &'s Pair<N>,
    /// end of the step as reported (cut at a terminal event)
    t_end: f64,
    segment: OnceCell<Segment<N>>,
    extra_evals: Cell<usize>,
}

impl<'s, const N: usize> StepDense<'s, N> {
    fn new(plan: &'s Plan<N>, stages: &'s Pair<N>) -> Self {
        StepDense {
            plan,
            stages,
            t_end: plan.t_new,
            segment: OnceCell::new(),
            extra_evals: Cell::new(0),
        }
    }

    fn get<R: Rhs<N>>(&self, rhs: &R) -> &Segment<N> {
        self.segment.get_or_init(|| {
            let (mut seg, evals) = self.stages.dense(rhs, self.plan);
            seg.t_end = self.t_end;
            self.extra_evals.set(self.extra_evals.get() + evals);
            seg
        })
    }

    /// Ends the step at `t` (a terminal event).
    fn cut(&mut self, t: f64) {
        self.t_end = t;
        if let Some(seg) = self.segment.get_mut() {
            seg.t_end = t;
        }
    }
}

/// The last accepted step, kept for locating the next kink on its continuous extension
/// (built at most once: reused if the step already built it).
struct Previous<const N: usize> {
    plan: Plan<N>,
    stages: Pair<N>,
    segment: OnceCell<Segment<N>>,
}

impl<const N: usize> Previous<N> {
    /// The step's continuous extension; extra right-hand sides counted in `stats`.
    fn extension<R: Rhs<N>>(&self, rhs: &R, stats: &mut Stats) -> &Segment<N> {
        self.segment.get_or_init(|| {
            let (seg, extra) = self.stages.dense(rhs, &self.plan);
            stats.rhs_evals += extra;
            seg
        })
    }
}

/// The step as an observer's [`StepView`] reads it.
struct Shown<'a, 's, const N: usize, R> {
    rhs: &'a R,
    dense: &'a StepDense<'s, N>,
}

impl<const N: usize, R: Rhs<N>> StepSource<N> for Shown<'_, '_, N, R> {
    fn segment(&self) -> &Segment<N> {
        self.dense.get(self.rhs)
    }
    fn eval_past(&self, t: f64) -> Option<SV<N>> {
        self.rhs.eval_past(t)
    }
}

/// The switching functions of the problem ([`OdeProblem::switching`]): their values at the
/// current point and at the end of the attempted step, and the located kink ahead.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone)]
struct Switches {
    /// gⱼ at the current point; exactly 0 for a switch whose root the step just landed on
    /// (either sign then counts as its far side)
    at_t: Vec<f64>,
    /// whether `at_t` belongs to the current point
    at_t_valid: bool,
    /// gⱼ at the end of the attempted step
    at_new: Vec<f64>,
    /// scratch for evaluating all gⱼ during root location
    scratch: Vec<f64>,
    /// gⱼ at the start of the last accepted step (for the look-ahead)
    at_previous: Vec<f64>,
    /// the earliest located root ahead
    kink: Option<Kink>,
    /// how steps land on kinks
    landing: KinkLanding,
    /// the last landing
    last_landing: Option<Kink>,
    /// DDE: landed kinks carried along the delays, where steps land too (sorted)
    echoes: VecDeque<f64>,
    /// DDE: the distinct positive delays
    echo_delays: Vec<f64>,
    /// DDE: how many delays a kink is carried along ([`Options::kink_propagation`])
    echo_depth: usize,
}

/// A located root of a switching function.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone, Copy)]
struct Kink {
    t: f64,
    index: usize,
}

impl Switches {
    fn new(count: usize, landing: KinkLanding) -> Self {
        Switches {
            landing,
            at_t: vec![0.0; count],
            at_t_valid: false,
            at_new: vec![0.0; count],
            scratch: vec![0.0; count],
            at_previous: vec![0.0; count],
            kink: None,
            last_landing: None,
            echoes: VecDeque::new(),
            echo_delays: Vec::new(),
            echo_depth: 0,
        }
    }

    /// DDE: carry every landed kink along the positive `delays` up to `depth` of them.
    fn with_echoes(mut self, delays: &[f64], depth: usize) -> Self {
        if !self.at_t.is_empty() && !delays.is_empty() && depth > 0 {
            self.echo_delays = delays.to_vec();
            self.echo_depth = depth;
            self.echoes.reserve(64);
        }
        self
    }

    /// The state was set anew (a terminal event, a breakpoint's right limit): the values at
    /// the current point are recomputed before the next step, and a kink ahead is located
    /// again if it is still there.
    fn restart(&mut self) {
        self.at_t_valid = false;
        self.kink = None;
    }

    /// Whether the attempted step crosses a switch that it does not end on. Then the
    /// earliest crossing is located and becomes the target of the next attempt. Where the
    /// roots are sought: on the previous step's continuous extension carried over this step
    /// (smooth up to the kink: extrapolated over one step it places the root far more
    /// accurately than the attempt's own extension, which the kink spoils), or, for the
    /// attempt that lands on a kink but overshoots it, on its own extension (spoiled only
    /// over the overshoot). Extra right-hand sides are counted.
    fn crossing<const N: usize, R: Rhs<N>>(
        &mut self,
        rhs: &R,
        p: &Plan<N>,
        s: &Pair<N>,
        previous: Option<&Previous<N>>,
        tol: f64,
        stats: &mut Stats,
    ) -> bool {
        if self.at_t.is_empty() {
            return false;
        }
        if !self.at_t_valid {
            rhs.switching(p.t, &p.x, &mut self.at_t);
            self.at_t_valid = true;
        }
        rhs.switching(p.t_last, s.x_new(), &mut self.at_new);
        let crosses = |g0: f64, g1: f64| g0 != 0.0 && g1 != 0.0 && (g0 < 0.0) != (g1 < 0.0);
        if !self
            .at_t
            .iter()
            .zip(&self.at_new)
            .any(|(&g0, &g1)| crosses(g0, g1))
        {
            return false;
        }
        let landing = self.kink.filter(|k| k.t == p.t_new);
        if self.landing == KinkLanding::Once
            && let Some(k) = landing
        {
            // landing once: the step ends on its kink, whatever the sign there says
            self.at_new[k.index] = 0.0;
        }
        let exact = self.landing == KinkLanding::Exact;
        let carried = match previous {
            Some(prev) if exact && landing.is_none() && prev.plan.t_new == p.t => {
                Some(*prev.extension(rhs, stats))
            }
            _ => None,
        };
        let own = OnceCell::new();
        let mut first: Option<Kink> = None;
        for j in 0..self.at_t.len() {
            let (g0, g1) = (self.at_t[j], self.at_new[j]);
            if !crosses(g0, g1) {
                continue;
            }
            let scratch = &mut self.scratch;
            let mut g_on = |seg: &Segment<N>, t: f64| {
                rhs.switching(t, &seg.eval(t), scratch);
                scratch[j]
            };
            // the carried extension if it brackets the root, else the attempt's own
            let bracket = carried
                .as_ref()
                .map(|seg| (seg, g_on(seg, p.t_new)))
                .filter(|&(_, g1c)| crosses(g0, g1c));
            let t_root = match bracket {
                Some((seg, g1c)) => locate_root(|t| g_on(seg, t), p.t, g0, p.t_new, g1c, tol),
                None => {
                    let seg = own.get_or_init(|| {
                        let (seg, extra) = s.dense(rhs, p);
                        stats.rhs_evals += extra;
                        seg
                    });
                    locate_root(|t| g_on(seg, t), p.t, g0, p.t_new, g1, tol)
                }
            };
            if first.is_none_or(|k| t_root < k.t) {
                first = Some(Kink {
                    t: t_root,
                    index: j,
                });
            }
        }
        let Some(kink) = first else {
            return false;
        };
        let resolution = tol.max(16.0 * f64::EPSILON * p.t_new.abs());
        if kink.t - p.t <= resolution {
            // the switch flipped at the step's start (within the location tolerance): the
            // step lies on its far side already
            self.at_t[kink.index] = 0.0;
            return self.crossing(rhs, p, s, previous, tol, stats);
        }
        if p.t_new - kink.t <= resolution {
            // the step ends on the root: it lands on the kink
            self.kink = Some(Kink { t: p.t_new, ..kink });
            return false;
        }
        // a root inside: land on it instead
        self.kink = Some(kink);
        true
    }

    /// Looks ahead before the next step of size `h` from the end of the accepted `step`:
    /// where the straight line through gⱼ at that step's ends crosses zero within 1.5 h, the
    /// step's continuous extension carried over the next step (smooth up to the kink, and
    /// far more accurate there than the extension of a step that crossed it) locates the
    /// root, and the next step lands on it — instead of crossing it first and being repeated.
    /// A missed or misplaced prediction is caught by [`Switches::crossing`] as before.
    fn look_ahead<const N: usize, R: Rhs<N>>(
        &mut self,
        rhs: &R,
        step: &StepDense<'_, N>,
        h: f64,
        tol: f64,
    ) {
        if self.at_t.is_empty() || self.kink.is_some() || !self.at_t_valid {
            return;
        }
        let (t0, t1) = (step.plan.t, step.plan.t_new);
        let soon = |g0: f64, g1: f64| {
            let g_ahead = g1 + (g1 - g0) / (t1 - t0) * 1.5 * h;
            g0 != 0.0 && g1 != 0.0 && (g1 < 0.0) != (g_ahead < 0.0)
        };
        if !self
            .at_previous
            .iter()
            .zip(&self.at_t)
            .any(|(&g0, &g1)| soon(g0, g1))
        {
            return;
        }
        let seg = step.get(rhs);
        let t_ahead = t1 + h;
        let mut first: Option<Kink> = None;
        for j in 0..self.at_t.len() {
            let g1 = self.at_t[j];
            if !soon(self.at_previous[j], g1) {
                continue;
            }
            let scratch = &mut self.scratch;
            let mut g = |t: f64| {
                rhs.switching(t, &seg.eval(t), scratch);
                scratch[j]
            };
            let g_ahead = g(t_ahead);
            if g_ahead == 0.0 || (g1 < 0.0) == (g_ahead < 0.0) {
                continue;
            }
            let t_root = locate_root(g, t1, g1, t_ahead, g_ahead, tol);
            if t_root - t1 > tol.max(16.0 * f64::EPSILON * t1.abs())
                && first.is_none_or(|k| t_root < k.t)
            {
                first = Some(Kink {
                    t: t_root,
                    index: j,
                });
            }
        }
        self.kink = first;
    }

    /// The attempted step was accepted: its end values become the current ones; on landing
    /// on the kink, that switch counts as crossed.
    fn accepted<const N: usize>(&mut self, p: &Plan<N>, stats: &mut Stats) {
        if self.at_t.is_empty() {
            return;
        }
        self.at_previous.copy_from_slice(&self.at_t);
        std::mem::swap(&mut self.at_t, &mut self.at_new);
        while self.echoes.front().is_some_and(|&e| e <= p.t_new) {
            self.echoes.pop_front();
        }
        if let Some(k) = self.kink
            && k.t == p.t_new
        {
            if self.landing == KinkLanding::Once {
                // either side of the landing point counts as the far side
                self.at_t[k.index] = 0.0;
            }
            self.kink = None;
            stats.switches += 1;
            let echoes = &mut self.echoes;
            if let Some(last) = self.last_landing
                && last.index == k.index
                && last.t == p.t
            {
                // a second landing on the same kink (the first fell short of its root):
                // its echoes replace the first one's
                propagate(last.t, 1, &self.echo_delays, self.echo_depth, &mut |e| {
                    let i = echoes.partition_point(|&x| x < e);
                    if echoes.get(i) == Some(&e) {
                        echoes.remove(i);
                    }
                });
            }
            propagate(k.t, 1, &self.echo_delays, self.echo_depth, &mut |e| {
                let i = echoes.partition_point(|&x| x < e);
                // one echo for times a few ulps apart (t + 2τ₁ vs t + τ₂ with τ₂ = 2τ₁
                // up to rounding): landing on both would need a step of an ulp
                let near = |x: &f64| (x - e).abs() <= 64.0 * f64::EPSILON * e.abs().max(1.0);
                let duplicate = echoes.get(i).is_some_and(near)
                    || i.checked_sub(1)
                        .and_then(|j| echoes.get(j))
                        .is_some_and(near);
                if !duplicate {
                    echoes.insert(i, e);
                }
            });
            self.last_landing = Some(k);
        }
    }
}

/// Event bookkeeping of one `integrate` call (allocated per call, only when there are
/// events): the delayed states for `g`, the values of each `g` at the last and the new step
/// end, the hits of a step.
struct EventScratch<const N: usize> {
    xd: Vec<SV<N>>,
    g_prev: Vec<f64>,
    g_new: Vec<f64>,
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
            g_new: g_prev.clone(),
            g_prev,
            hits: Vec::with_capacity(events.len()),
        }
    }

    /// Finds the events of the accepted step, sorted in time; the index (into `self.hits`)
    /// of the first terminal one, where the hits are cut off. The sign of every `g` is read
    /// at the step's end first; the continuous extension is needed (and built) only if one
    /// changed.
    fn detect<R: Rhs<N>>(
        &mut self,
        rhs: &R,
        events: &[Event<'_, N>],
        dense: &StepDense<'_, N>,
        event_tol: f64,
    ) -> Option<usize> {
        self.hits.clear();
        if events.is_empty() {
            return None;
        }
        let (t, t_new, x_new) = (dense.plan.t, dense.plan.t_new, dense.stages.x_new());
        rhs.delayed_states(t_new, x_new, &mut self.xd);
        for (g1, ev) in self.g_new.iter_mut().zip(events) {
            *g1 = ev.g(t_new, x_new, &self.xd);
        }
        for (i, ev) in events.iter().enumerate() {
            let (g0, g1) = (self.g_prev[i], self.g_new[i]);
            if let Some(dir) = ev.triggers(g0, g1) {
                let seg = dense.get(rhs);
                let xd_buf = &mut self.xd;
                let g = |s: f64| {
                    let xs = seg.eval(s);
                    rhs.delayed_states(s, &xs, xd_buf);
                    ev.g(s, &xs, xd_buf)
                };
                let ts = locate_root(g, t, g0, t_new, g1, event_tol);
                self.hits.push(EventHit {
                    index: i,
                    t: ts,
                    x: seg.eval(ts),
                    direction: dir,
                });
            }
        }
        std::mem::swap(&mut self.g_prev, &mut self.g_new);
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

/// `b + k₁τ₁ + … + kₘτₘ` for `k_min ≤ Σk ≤ order` (positive delays only), each passed to
/// `out`.
fn propagate(base: f64, k_min: usize, delays: &[f64], order: usize, out: &mut impl FnMut(f64)) {
    fn rec(
        t: f64,
        used: usize,
        k_min: usize,
        start: usize,
        d: &[f64],
        order: usize,
        out: &mut impl FnMut(f64),
    ) {
        if used >= k_min {
            out(t);
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
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone)]
pub struct OdeSolver<const N: usize> {
    core: Core<N>,
}

impl<const N: usize> OdeSolver<N> {
    /// Starts at `(t0, x0)`; the problem's breakpoints are read here.
    pub fn new<P: OdeProblem<N>>(p: &P, t0: f64, x0: SV<N>, opts: Options) -> Result<Self, Error> {
        Ok(OdeSolver {
            core: Core::new(t0, x0, opts, p.breakpoints().to_vec(), p.switching_count())?,
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

    /// Tells the solver that the right-hand side jumps at the current time, as when an input
    /// held between two [`OdeSolver::integrate`] calls changes (a co-simulation master's
    /// communication point): the next call starts from the right limit instead of the
    /// derivative carried over (first same as last).
    pub fn input_jump(&mut self) {
        self.core.input_jump(&[]);
    }

    core_accessors!();
}

/// Integration state of a DDE with constant delays: current state, the computed past
/// (pruned to the longest delay) and the breakpoint schedule. Cloneable; the problem is passed
/// to every call.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug, Clone)]
pub struct DdeSolver<const N: usize> {
    core: Core<N>,
    t0: f64,
    delays: Vec<f64>,
    past: Past<N>,
    delayed: RefCell<Vec<SV<N>>>,
}

impl<const N: usize> DdeSolver<N> {
    /// Starts at `t0` with `x(t0) = history(t0)`. Breakpoints: `t0 + Σkⱼτⱼ` for
    /// `1 ≤ Σkⱼ ≤ breakpoint_order` (the jump of the derivative at t0 travelling along the
    /// delays) and every user breakpoint `b + Σkⱼτⱼ`, `0 ≤ Σkⱼ ≤ breakpoint_order`.
    pub fn new<P: DdeProblem<N>>(p: &P, t0: f64, opts: Options) -> Result<Self, Error> {
        Self::start(p, t0, opts)
    }

    /// [`DdeSolver::new`] behind a `&dyn` (compiled once per N, see [`OdeRhs`]).
    fn start(p: &dyn DdeProblem<N>, t0: f64, opts: Options) -> Result<Self, Error> {
        let delays = p.delays().to_vec();
        check_delays(&delays)?;
        let mut pos: Vec<f64> = delays.iter().copied().filter(|&d| d > 0.0).collect();
        pos.sort_by(f64::total_cmp);
        pos.dedup();
        let order = opts.breakpoint_order();
        let mut bps = Vec::new();
        propagate(t0, 1, &pos, order, &mut |b| bps.push(b));
        for &b in p.breakpoints() {
            propagate(b, 0, &pos, order, &mut |b| bps.push(b));
        }
        let x0 = p.history(t0);
        let depth = opts.kink_propagation();
        let mut core = Core::new(t0, x0, opts, bps, p.switching_count())?;
        core.switches = core.switches.with_echoes(&pos, depth);
        let span = pos.last().copied().unwrap_or(0.0);
        Ok(DdeSolver {
            core,
            t0,
            past: Past::new(span),
            delayed: RefCell::new(vec![SV::<N>::zeros(); delays.len()]),
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
        self.integrate_dyn(p, t_end, events, observer)
    }

    /// [`DdeSolver::integrate`] behind a `&dyn` (compiled once per N, see [`OdeRhs`]).
    fn integrate_dyn(
        &mut self,
        p: &dyn DdeProblem<N>,
        t_end: f64,
        events: &[Event<'_, N>],
        observer: &mut dyn Observer<N>,
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
            delayed: &self.delayed,
            h_cap,
        };
        self.core.run(&mut rhs, t_end, events, observer)
    }

    /// Tells the solver that the right-hand side jumps at the current time t, as when an
    /// input held between two [`DdeSolver::integrate`] calls changes: the next call starts
    /// from the right limit, and t + Σkⱼτⱼ (`1 ≤ Σkⱼ ≤ breakpoint_order`, the jump read back
    /// through the delays) join the breakpoint schedule, as the problem's own breakpoints do.
    pub fn input_jump(&mut self) {
        let mut pos: Vec<f64> = self.delays.iter().copied().filter(|&d| d > 0.0).collect();
        pos.sort_by(f64::total_cmp);
        pos.dedup();
        let mut later = Vec::new();
        propagate(
            self.core.t,
            1,
            &pos,
            self.core.opts.breakpoint_order(),
            &mut |b| later.push(b),
        );
        self.core.input_jump(&later);
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
