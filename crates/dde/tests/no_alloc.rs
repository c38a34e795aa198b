//! The stepping loop allocates nothing per step: a counting global allocator shows that the
//! number of allocations does not grow with the number of steps (ODE path and DDE path).
//! A binary without the test harness (`harness = false` in Cargo.toml): the counter is
//! global, and the harness's own thread (its output, its timers) could allocate while the
//! solver is counted.
mod common;

use std::alloc::System;

use common::{DelayedLogistic, VanDerPol};
use dde::{DdeSolver, Method, NoObserver, OdeSolver, Options};
use nalgebra::SVector;
use stats_alloc::{INSTRUMENTED_SYSTEM, Region, StatsAlloc};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn count(f: impl FnOnce()) -> usize {
    let region = Region::new(GLOBAL);
    f();
    let c = region.change();
    c.allocations + c.reallocations
}

fn main() {
    // both pairs, one after the other, on this (the only) thread
    for method in [Method::Dopri5, Method::Dop853] {
        check(Options::with_tolerances(1e-8, 1e-10).with_method(method));
    }
    println!("allocation_count_does_not_grow_with_the_number_of_steps ... ok");
}

fn check(opts: Options) {
    let method = opts.method;
    let (vdp, dl) = (VanDerPol { mu: 1.0 }, DelayedLogistic { r: 1.4 });
    let x0 = SVector::from([2.0, 0.0]);
    let mut s = OdeSolver::new(&vdp, 0.0, x0, opts.clone()).unwrap();
    // a first call may allocate (event bookkeeping is empty here, so nothing at all)
    s.integrate(&vdp, 1.0, &[], &mut NoObserver).unwrap();
    let steps0 = s.stats().accepted;
    let n = count(|| {
        s.integrate(&vdp, 200.0, &[], &mut NoObserver).unwrap();
    });
    assert!(s.stats().accepted - steps0 > 300, "{method:?}");
    assert_eq!(n, 0, "{method:?}: ODE path allocated {n} times");

    // DDE: the pruned past reaches its steady size within the first delay intervals;
    // after that, integrating 24× longer allocates nothing more
    let mut d = DdeSolver::new(&dl, 0.0, opts).unwrap();
    d.integrate(&dl, 20.0, &[], &mut NoObserver).unwrap();
    let steps0 = d.stats().accepted;
    let n = count(|| {
        d.integrate(&dl, 500.0, &[], &mut NoObserver).unwrap();
    });
    assert!(
        d.stats().accepted - steps0 > 100,
        "{method:?}: {} steps",
        d.stats().accepted - steps0
    );
    assert_eq!(n, 0, "{method:?}: DDE path allocated {n} times");
}
