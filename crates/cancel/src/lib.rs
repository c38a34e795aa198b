//! Cooperative cancellation of long computations.
//!
//! A caller that may want to stop a computation (Ctrl-C in Python, a front end's "stop"
//! button) creates a [`CancelToken`] and runs the computation through [`run`]. Long loops
//! anywhere below call [`checkpoint`]: the stepping loop of the DDE solver, the
//! continuation engine between points, the parallel maps between items, the chart grids
//! between rows. Once the token is cancelled, the next checkpoint unwinds the stack with
//! the [`Cancelled`] payload, and [`run`] turns that unwind back into `Err(Cancelled)`.
//!
//! Why unwinding and not a `Result` in every signature: a computation crosses a dozen
//! crates and hundreds of functions, most of which cannot fail for any other reason, and
//! the numerical crates (solver, continuation, charts) know nothing of who calls them.
//! Unwinding also guarantees that no half-finished value escapes: whatever a cancelled
//! computation built is dropped on the way up. (rust-analyzer cancels its queries the same
//! way.) The unwind does not run the panic hook, so nothing is printed, and rayon carries
//! it from its workers to the thread that waits for them.
//!
//! The token is found through the current thread: [`run`] installs it for the duration of
//! its closure, and the computation's parallel parts see it when they run in a rayon pool
//! made by [`pool_builder`] (whose threads carry the token; rayon's global pool does
//! not). Where no token is installed, [`checkpoint`] costs one thread-local read and never
//! unwinds.
//!
//! A code path that catches unwinds itself (to survive a panicking point of a sweep, say)
//! must let a cancellation through: [`is_cancellation`] tells it apart, and
//! [`resume_if_cancelled`] passes it on.
//!
//! ```
//! use cancel::{CancelToken, Cancelled, checkpoint, pool_builder, run};
//!
//! let token = CancelToken::new();
//! // not cancelled: the computation's value
//! assert_eq!(run(&token, || (0..1000).sum::<u64>()), Ok(499_500));
//!
//! // cancelled half-way: the error, and nothing after the checkpoint ran
//! let mut steps = 0;
//! let got = run(&token, || {
//!     for k in 0.. {
//!         if k == 10 {
//!             token.cancel();
//!         }
//!         checkpoint();
//!         steps += 1;
//!     }
//! });
//! assert_eq!(got, Err(Cancelled));
//! assert_eq!(steps, 10);
//!
//! // a parallel computation: its pool's threads carry the token
//! let token = CancelToken::new();
//! let pool = pool_builder(&token).num_threads(2).build().unwrap();
//! let got = run(&token, || {
//!     pool.install(|| {
//!         rayon::join(|| token.cancel(), || loop { checkpoint() });
//!     })
//! });
//! assert_eq!(got, Err(Cancelled));
//! ```

use std::any::Any;
use std::cell::RefCell;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A shared flag that asks every computation it was given to stop at its next checkpoint.
/// Clones share the flag.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token that is not cancelled.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks the computations that run with this token to stop (from any thread; a signal
    /// handler may call it).
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`CancelToken::cancel`] was called.
    #[must_use]
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// The error of a computation that stopped because its token was cancelled (and the
/// payload of the unwind that carries it there).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cancelled;

impl std::fmt::Display for Cancelled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the computation was cancelled")
    }
}

impl std::error::Error for Cancelled {}

thread_local! {
    /// The token of the computation running on this thread.
    static CURRENT: RefCell<Option<CancelToken>> = const { RefCell::new(None) };
}

/// Stops the computation (unwinding to [`run`]) if the token installed on this thread is
/// cancelled; otherwise returns at once. Call it in every loop whose iterations may add up
/// to more than a few milliseconds.
pub fn checkpoint() {
    if is_cancelled() {
        resume_unwind(Box::new(Cancelled));
    }
}

/// Whether the token installed on this thread is cancelled (false without a token), for a
/// loop that prefers to stop on its own and return early.
#[must_use]
pub fn is_cancelled() -> bool {
    CURRENT.with(|c| c.borrow().as_ref().is_some_and(CancelToken::is_cancelled))
}

/// Installs `token` on this thread for good (until the next [`install`]): for the threads
/// of a pool that runs a cancellable computation's parallel parts.
pub fn install(token: &CancelToken) {
    CURRENT.with(|c| *c.borrow_mut() = Some(token.clone()));
}

/// A rayon pool builder whose threads carry `token` (set the thread count and build): the
/// pool for the parallel parts of a computation run with [`run`] and `token`.
#[must_use]
pub fn pool_builder(token: &CancelToken) -> rayon::ThreadPoolBuilder {
    let token = token.clone();
    rayon::ThreadPoolBuilder::new().start_handler(move |_| install(&token))
}

/// Runs `f` with `token` installed on this thread (the previous one is restored after);
/// `Err(Cancelled)` if a checkpoint inside `f` saw the token cancelled. Any other panic
/// goes on unwinding.
///
/// # Errors
/// [`Cancelled`] when the token was cancelled while `f` ran (and a checkpoint saw it).
pub fn run<T>(token: &CancelToken, f: impl FnOnce() -> T) -> Result<T, Cancelled> {
    let _scope = Scope::enter(token);
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(value) => Ok(value),
        Err(payload) if is_cancellation(payload.as_ref()) => Err(Cancelled),
        Err(payload) => resume_unwind(payload),
    }
}

/// Whether a caught unwind's payload is a cancellation (to be passed on, not reported as a
/// failure).
#[must_use]
pub fn is_cancellation(payload: &(dyn Any + Send)) -> bool {
    payload.is::<Cancelled>()
}

/// For code that catches unwinds: a cancellation goes on unwinding; any other payload is
/// handed back.
pub fn resume_if_cancelled(payload: Box<dyn Any + Send>) -> Box<dyn Any + Send> {
    if is_cancellation(payload.as_ref()) {
        resume_unwind(payload);
    }
    payload
}

/// The token installed for the duration of a [`run`], the previous one restored on drop
/// (also when unwinding).
struct Scope {
    previous: Option<CancelToken>,
}

impl Scope {
    fn enter(token: &CancelToken) -> Self {
        let previous = CURRENT.with(|c| c.borrow_mut().replace(token.clone()));
        Self { previous }
    }
}

impl Drop for Scope {
    fn drop(&mut self) {
        let previous = self.previous.take();
        CURRENT.with(|c| *c.borrow_mut() = previous);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without a token, checkpoints never stop anything.
    #[test]
    fn without_a_token_a_checkpoint_is_a_no_op() {
        for _ in 0..10 {
            checkpoint();
        }
        assert!(!is_cancelled());
    }

    /// A nested run restores the outer token; an inner cancellation does not leak out.
    #[test]
    fn nested_runs_restore_the_outer_token() {
        let outer = CancelToken::new();
        let inner = CancelToken::new();
        let got = run(&outer, || {
            let r = run(&inner, || {
                inner.cancel();
                checkpoint();
            });
            assert_eq!(r, Err(Cancelled));
            checkpoint(); // the outer token is not cancelled
            7
        });
        assert_eq!(got, Ok(7));
        assert!(!is_cancelled());
    }

    /// Other panics are not swallowed.
    #[test]
    fn other_panics_keep_unwinding() {
        let token = CancelToken::new();
        let caught = catch_unwind(|| run(&token, || panic!("a real bug")));
        assert!(caught.is_err());
    }

    /// Reference: the unwind crosses rayon's workers of a pool whose threads carry the
    /// token, and stops the remaining items (far fewer than all of them run).
    #[test]
    fn cancellation_crosses_a_rayon_pool() {
        use rayon::prelude::*;
        use std::sync::atomic::AtomicUsize;
        let token = CancelToken::new();
        let pool = pool_builder(&token).num_threads(3).build().unwrap();
        let done = AtomicUsize::new(0);
        let got = run(&token, || {
            pool.install(|| {
                (0..100_000).into_par_iter().for_each(|k| {
                    if k == 500 {
                        token.cancel();
                    }
                    checkpoint();
                    done.fetch_add(1, Ordering::Relaxed);
                });
            });
        });
        assert_eq!(got, Err(Cancelled));
        assert!(done.load(Ordering::Relaxed) < 100_000);
    }
}
