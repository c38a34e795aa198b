//! Issue 23 performance (release, medians): the closed-loop bifurcation diagram at
//! τ = 0.2 s, D = 0.1 s (fig4b's settings, `DiagramOptions::closed_loop`) on L = 40 and
//! L = 120 mesh intervals (target: L = 120 at most 3× L = 40), with the cycle branch's
//! branch-point test on (the default: the determinant from the block-forward solver's dense
//! Schur complement) and off (GMRES on the Schur complement where the border is large).
//!
//! Measured (criterion medians, load 3–4 from a parallel build): with the branch-point test
//! 1.25 s at L = 40 and 3.42 s at L = 120 (2.7×); without 1.36 / 3.11 s (2.3×). Before the
//! block-forward solver and the Arnoldi multipliers: 3.9 s / 36.6 s;
//! with the block-forward solver but the dense monodromy eigenvalues: 1.28 / 5.76 s (4.5×,
//! the O(L³) eigenvalue problem of the monodromy matrix was 26 % of the L = 120 profile).
//!
//! Re-measured idle on 2026-12-05 (db2b6ac): 0.727 s at L = 40 and 2.733 s at L = 120
//! (3.76×: the target is not met any more — L = 40 got 1.7× faster since, L = 120 1.25×);
//! without the branch-point test 0.651 / 2.488 s (3.8×). The L = 120 profile: the dense
//! Schur complement (Z = A⁻¹C, one forward solve per border column, and its K × K LU: K
//! grows with L) ≈ 27 %, and faer's sparse LU (simplicial, ≈ 7 %) of the branch-point
//! test's bordered determinant, now factorised as the corrector does: 0.695 / 2.576 s
//! (3.70×). What is left superlinear is the dense Schur complement, formed at every point
//! for the branch-point test's determinant and for the Floquet multipliers.
//!
//! Stop 41 (2026-12-05): from K = 40 border unknowns on the Schur complement is not formed
//! — the determinant by Arnoldi on E = S + I (its Krylov space invariant after 10–24
//! products at L = 120), solves by GMRES —, the one-right-hand-side forward solves sweep
//! by columns, monodromy operators from size 40 by Arnoldi, and a diverging kink-resolved
//! correction stops early (one at L = 120 had gone on for 12 iterations, its Jacobians
//! reading ahead, K ≈ 950, each factorised densely). Criterion medians, idle: 0.635 /
//! 1.732 s (2.73×) and, in a slower spell an hour later, 0.657 / 1.833 s (2.79×); without
//! the branch-point test 0.597 / 1.632 s (2.73×). Target met.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sway::bifurcation::{BranchPointTest, DiagramOptions, LoopLaw, bifurcation_diagram};
use trailer_model::{Model, VehicleParams};

fn diagrams(c: &mut Criterion) {
    let model = Model::new(VehicleParams::default()).expect("Table I model");
    let feedback = LoopLaw::paper(0.1, 0.2);
    let mut g = c.benchmark_group("closed_loop_mesh");
    g.sample_size(10);
    for (test, name) in [
        (BranchPointTest::Watch, "diagram"),
        (BranchPointTest::Ignore, "diagram_no_branch_points"),
    ] {
        for l in [40usize, 120] {
            let options = DiagramOptions {
                intervals: l,
                cycle_branch_points: test,
                ..DiagramOptions::closed_loop()
            };
            g.bench_with_input(BenchmarkId::new(name, l), &l, |b, _| {
                b.iter(|| black_box(bifurcation_diagram(&model, feedback, &options).unwrap()))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, diagrams);
criterion_main!(benches);
