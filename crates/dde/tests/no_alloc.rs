//! The stepping loop allocates nothing per step: a counting global allocator shows that the
//! number of allocations does not grow with the number of steps (ODE path and DDE path).
//! Single test in its own binary so that no other test thread allocates meanwhile.

use std::alloc::System;

use dde::{DdeProblem, DdeSolver, NoObserver, OdeProblem, OdeSolver, Options};
use nalgebra::SVector;
use stats_alloc::{INSTRUMENTED_SYSTEM, Region, StatsAlloc};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

struct VanDerPol;
impl OdeProblem<2> for VanDerPol {
    fn rhs(&self, _t: f64, x: &SVector<f64, 2>, dx: &mut SVector<f64, 2>) {
        dx[0] = x[1];
        dx[1] = (1.0 - x[0] * x[0]) * x[1] - x[0];
    }
}

struct DelayedLogistic;
impl DdeProblem<1> for DelayedLogistic {
    fn delays(&self) -> &[f64] {
        &[1.0]
    }
    fn history(&self, _t: f64) -> SVector<f64, 1> {
        SVector::from([0.5])
    }
    fn rhs(&self, _t: f64, x: &SVector<f64, 1>, xd: &[SVector<f64, 1>], dx: &mut SVector<f64, 1>) {
        dx[0] = 1.4 * x[0] * (1.0 - xd[0][0]);
    }
}

fn count(f: impl FnOnce()) -> usize {
    let region = Region::new(GLOBAL);
    f();
    let c = region.change();
    c.allocations + c.reallocations
}

#[test]
fn allocation_count_does_not_grow_with_the_number_of_steps() {
    let opts = Options::with_tolerances(1e-8, 1e-10);
    let x0 = SVector::from([2.0, 0.0]);
    let mut s = OdeSolver::new(&VanDerPol, 0.0, x0, opts.clone()).unwrap();
    // a first call may allocate (event bookkeeping is empty here, so nothing at all)
    s.integrate(&VanDerPol, 1.0, &[], &mut NoObserver).unwrap();
    let steps0 = s.stats().accepted;
    let n = count(|| {
        s.integrate(&VanDerPol, 200.0, &[], &mut NoObserver)
            .unwrap();
    });
    assert!(s.stats().accepted - steps0 > 1000);
    assert_eq!(n, 0, "ODE path allocated {n} times");

    // DDE: the pruned past reaches its steady size within the first delay intervals;
    // after that, integrating 24× longer allocates nothing more
    let mut d = DdeSolver::new(&DelayedLogistic, 0.0, opts).unwrap();
    d.integrate(&DelayedLogistic, 20.0, &[], &mut NoObserver)
        .unwrap();
    let steps0 = d.stats().accepted;
    let n = count(|| {
        d.integrate(&DelayedLogistic, 500.0, &[], &mut NoObserver)
            .unwrap();
    });
    assert!(
        d.stats().accepted - steps0 > 300,
        "{} steps",
        d.stats().accepted - steps0
    );
    assert_eq!(n, 0, "DDE path allocated {n} times");
}
