//! The shared core of the two-parameter curves of cycles with extra equations (folds of
//! cycles, torus points, period doublings): a [`PeriodicOrbitSystem`] in the primary
//! parameter p1 with a second free parameter p2, and the extra blocks built on it.
//!
//! Every such system has the unknowns u = [x, T, p1, p2, extra…] (x the n·L·m profile
//! values, T the period) and the equations [cycle (collocation + phase), extra rows]. This
//! module holds what they all need:
//!
//! - [`CycleCurveSystem`]: the one type of the three systems, generic over the part in
//!   which they differ ([`CycleExtension`]: options, the mode of the last accepted point,
//!   scratch), with their shared constructors and getters (the cycle, its period,
//!   parameters and amplitude, its periodic-orbit system and Floquet multipliers);
//! - [`CycleCurve`]: the cycle system and p2 (validation, parameters of a point, the cycle's
//!   rows of the residual and the Jacobian, weights, the node-interleaved column order, the
//!   mesh structure, the extrapolation of a curve's end to zero amplitude), and the curve
//!   loop with stop rules;
//! - the one [`ContinuationSystem`] implementation of the three systems: the cycle's part
//!   written once, the extra equations from each system's [`CycleRows`];
//! - the rows of a *real* mode v on the cycle's mesh, y'(s) = T Σ_j J_j(s) y(s − τ_j/T),
//!   either periodic with a period component v_T (the null vector of the linearised
//!   periodic problem: folds of cycles) or antiperiodic, v(s + 1) = −v(s) (the Floquet mode
//!   of the multiplier −1: period doubling), with their exact Jacobian
//!   ([`CycleCurve::real_mode_rows`]);
//! - inverse iteration for a mode (a bordered sparse solve repeated).

use crate::collocation::{MAX_DEGREE, lagrange_d2};
use crate::engine::{Branch, Continuation, ContinuationSystem, Stop};
use crate::error::{Error, Result};
use crate::linalg::{Entry, MeshStructure};
use crate::linear_solver::{Factorisation, LinearSolver, SparseLu};
use crate::periodic::{Loc, PeriodicOrbitSystem};
use crate::problem::Problem;
use crate::stability::{SpecialKind, Stability};
use crate::{BranchPoint, CollocationOptions};
use num_complex::Complex64;

/// The cycle of a two-parameter curve: the periodic-orbit system in p1 and the index of p2.
#[derive(Debug)]
pub(crate) struct CycleCurve<'a, P: Problem> {
    pub(crate) po: PeriodicOrbitSystem<'a, P>,
    pub(crate) ip2: usize,
}

/// the uniform mesh of `l` intervals (at least one)
pub(crate) fn uniform_mesh(l: usize) -> Vec<f64> {
    let l = l.max(1);
    (0..=l).map(|i| i as f64 / l as f64).collect()
}

impl<'a, P: Problem> CycleCurve<'a, P> {
    /// the cycle system on `mesh` with free parameters (ip1, ip2) (validated)
    pub(crate) fn new(
        problem: &'a P,
        params: Vec<f64>,
        (ip1, ip2): (usize, usize),
        mesh: Vec<f64>,
        collocation: CollocationOptions,
    ) -> Result<Self> {
        if ip2 >= params.len() || ip2 == ip1 {
            return Err(Error::InvalidInput(format!(
                "secondary parameter index {ip2} must differ from the primary {ip1} and be below {}",
                params.len()
            )));
        }
        let po = PeriodicOrbitSystem::with_mesh(problem, params, ip1, mesh, collocation)?;
        Ok(Self { po, ip2 })
    }

    /// the same cycle system (problem, mesh, collocation) as `po`, with p1 at the branch
    /// point's value and `ip2` as the second parameter; checks the point's length
    pub(crate) fn from_branch_point(
        po: &PeriodicOrbitSystem<'a, P>,
        point: &BranchPoint,
        ip2: usize,
        what: &str,
    ) -> Result<Self> {
        let np = po.period_index();
        if point.u.len() != np + 2 {
            return Err(Error::InvalidInput(format!(
                "{what}: the point has {} unknowns, the periodic-orbit system {}",
                point.u.len(),
                np + 2
            )));
        }
        let mut params = po.params.clone();
        params[po.ip] = point.parameter;
        let mut curve = Self::new(
            po.problem,
            params,
            (po.ip, ip2),
            po.mesh.clone(),
            po.options.clone(),
        )?;
        curve.po.linear_solver = po.linear_solver;
        Ok(curve)
    }

    /// n·L·m: number of profile unknowns
    pub(crate) fn np(&self) -> usize {
        self.po.period_index()
    }

    /// the parameters of the cycle system set from u (p1 and p2)
    pub(crate) fn sync(&mut self, u: &[f64]) {
        let np = self.np();
        self.po.params[self.ip2] = u[np + 2];
        self.po.set_params(&u[..np + 2]);
    }

    /// the cycle's rows (collocation and phase) of the residual `r` at u, p1 and p2 set
    /// from u first; the rest of `r`, the extra rows
    pub(crate) fn cycle_residual<'r>(
        &mut self,
        u: &[f64],
        r: &'r mut [f64],
    ) -> Result<&'r mut [f64]> {
        let np = self.np();
        self.sync(u);
        let (r_cycle, rest) = r.split_at_mut(np + 1);
        self.po.residual(&u[..np + 2], r_cycle)?;
        Ok(rest)
    }

    /// the Jacobian entries of the cycle's rows in the columns (x, T, p1) at u, p1 and p2
    /// set from u first
    pub(crate) fn cycle_jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let np = self.np();
        self.sync(u);
        self.po.jacobian(&u[..np + 2], entries)
    }

    /// the accepted point u: p1 and p2 set from it, its cycle the phase reference
    pub(crate) fn accept(&mut self, u: &[f64]) {
        let np = self.np();
        self.sync(u);
        self.po.set_reference(&u[..np + 2]);
    }

    /// Ok if the extra rows (or their Jacobian entries) at u are `finite`, else the error
    /// at u's p1
    pub(crate) fn finite(&self, u: &[f64], finite: bool) -> Result<()> {
        if finite {
            Ok(())
        } else {
            Err(Error::NonFinite {
                parameter: u[self.np() + 1],
            })
        }
    }

    /// ⟨a, b⟩ = Σ a_i b_i /(L·m) on profile-sized vectors
    pub(crate) fn mean_dot(&self, a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>() / self.po.n_nodes() as f64
    }

    /// the direction +p2 in a system of `len` unknowns: the start direction of a curve
    /// from a point of a cycle branch, along which the corrector keeps p2 fixed
    pub(crate) fn p2_direction(&self, len: usize) -> Vec<f64> {
        let mut direction = vec![0.0; len];
        direction[self.np() + 2] = 1.0;
        direction
    }

    /// the periodic-orbit unknowns [x, T, p1] of the point's cycle
    pub(crate) fn orbit<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        &u[..self.np() + 2]
    }

    /// all parameters at the point u
    pub(crate) fn parameters(&self, u: &[f64]) -> Vec<f64> {
        let np = self.np();
        let mut p = self.po.params.clone();
        p[self.po.ip] = u[np + 1];
        p[self.ip2] = u[np + 2];
        p
    }

    /// the periodic-orbit system of the point's cycle (free parameter p1, same mesh, phase
    /// reference set to the cycle)
    pub(crate) fn periodic_system(&self, u: &[f64]) -> Result<PeriodicOrbitSystem<'a, P>> {
        self.po.at(self.parameters(u), self.orbit(u))
    }

    /// Floquet multipliers of the point's cycle
    pub(crate) fn multipliers(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        self.sync(u);
        let np = self.np();
        self.po.floquet_multipliers(&u[..np + 2])
    }

    /// weights of `total` unknowns: the cycle's, p2 weighted like p1, the rest not at all
    pub(crate) fn weights(&self, total: usize) -> Vec<f64> {
        let np = self.np();
        let w = self.po.weights();
        let mut v = vec![0.0; total];
        v[..np + 2].copy_from_slice(&w);
        v[np + 2] = w[np + 1];
        v
    }

    /// the cycle and `modes` profile-sized blocks after p2 (the rows after the cycle's)
    /// on the mesh (see [`LinearSolver::Krylov`])
    pub(crate) fn mesh_structure(&self, modes: usize) -> Option<MeshStructure> {
        let np = self.np();
        let columns = std::iter::once(0).chain((0..modes).map(|k| np + 3 + k * np));
        let rows = std::iter::once(0).chain((0..modes).map(|k| np + 1 + k * np));
        self.po.structure(columns.collect(), rows.collect())
    }

    /// column order with the cycle and the extra profile-sized blocks starting at
    /// `blocks` interleaved node by node (each node's state of x, then of each block), the
    /// `border` columns last: the Jacobian is then banded like the cycle's
    pub(crate) fn interleaved_order(&self, blocks: &[usize], border: &[usize]) -> Vec<usize> {
        let np = self.np();
        let n = self.po.dim();
        let mut order = Vec::with_capacity((1 + blocks.len()) * np + border.len());
        for g in 0..np / n {
            order.extend(g * n..(g + 1) * n);
            for &b in blocks {
                order.extend(b + g * n..b + (g + 1) * n);
            }
        }
        order.extend_from_slice(border);
        order
    }

    /// The values `values(point)` of a curve extrapolated from its last two points to zero
    /// amplitude, linearly in amplitude² (exact for the normal forms' leading order), and
    /// the last point's amplitude
    pub(crate) fn extrapolate_to_zero_amplitude<const N: usize>(
        &self,
        branch: &Branch,
        values: impl Fn(&BranchPoint) -> [f64; N],
    ) -> ([f64; N], f64) {
        let last = branch.points.len() - 1;
        let b = &branch.points[last];
        let rho_b = self.po.amplitude(&b.u).powi(2);
        let vb = values(b);
        let est = match last.checked_sub(1).map(|i| &branch.points[i]) {
            Some(a) => {
                let rho_a = self.po.amplitude(&a.u).powi(2);
                let va = values(a);
                if rho_a > rho_b {
                    let t = rho_b / (rho_a - rho_b);
                    std::array::from_fn(|i| vb[i] - t * (va[i] - vb[i]))
                } else {
                    vb
                }
            }
            None => vb,
        };
        (est, rho_b.sqrt())
    }
}

/// The part in which the two-parameter cycle systems differ: the options of their extra
/// equations, the mode of the last accepted point and scratch (see [`CycleCurveSystem`]).
pub trait CycleExtension {
    /// the options of the curve
    type Options;
    /// the part of a system whose cycle has `n` components, `delays` delays and `np`
    /// profile unknowns
    fn new(options: Self::Options, n: usize, delays: usize, np: usize) -> Self;
}

/// A curve of cycles in two free parameters with the extra equations `E`: the type of
/// [`crate::FoldOfCyclesSystem`], [`crate::PeriodDoublingCurveSystem`] and
/// [`crate::TorusCurveSystem`], whose documentation gives their equations. The unknowns
/// are u = [x, T, p1, p2, extra…] (x the n·L·m profile values, T the period); the
/// constructors, the getters of the cycle and the [`ContinuationSystem`] implementation
/// (p1, p2, the cycle's rows first, then the extra equations of `E`) are those of all three.
#[derive(Debug)]
pub struct CycleCurveSystem<'a, P: Problem, E> {
    pub(crate) base: CycleCurve<'a, P>,
    pub(crate) ext: E,
}

impl<'a, P: Problem, E: CycleExtension> CycleCurveSystem<'a, P, E> {
    /// New system on the mesh `mesh` (0 = s_0 < … < s_L = 1); `params`: all parameters,
    /// `free` = (p1, p2) the primary and secondary free parameter. Set the references with
    /// [`ContinuationSystem::accept`] before correcting a guess (or start from the special
    /// point of a cycle branch, as each system's documentation says).
    pub fn with_mesh(
        problem: &'a P,
        params: Vec<f64>,
        free: (usize, usize),
        mesh: Vec<f64>,
        collocation: CollocationOptions,
        options: E::Options,
    ) -> Result<Self> {
        Ok(Self::on(
            CycleCurve::new(problem, params, free, mesh, collocation)?,
            options,
        ))
    }

    /// New system on a uniform mesh of `collocation.intervals` intervals.
    pub fn new(
        problem: &'a P,
        params: Vec<f64>,
        free: (usize, usize),
        collocation: CollocationOptions,
        options: E::Options,
    ) -> Result<Self> {
        let mesh = uniform_mesh(collocation.intervals);
        Self::with_mesh(problem, params, free, mesh, collocation, options)
    }

    /// the system on the cycle `base`
    pub(crate) fn on(base: CycleCurve<'a, P>, options: E::Options) -> Self {
        let problem = base.po.problem;
        let ext = E::new(options, problem.dim(), problem.n_delays(), base.np());
        Self { base, ext }
    }

    /// the system on the cycle system of `po` at the branch point `point`, with `ip2` as
    /// the second parameter (see [`CycleCurve::from_branch_point`])
    pub(crate) fn at_branch_point(
        po: &PeriodicOrbitSystem<'a, P>,
        point: &BranchPoint,
        ip2: usize,
        options: E::Options,
        what: &str,
    ) -> Result<Self> {
        let base = CycleCurve::from_branch_point(po, point, ip2, what)?;
        Ok(Self::on(base, options))
    }
}

impl<'a, P: Problem, E> CycleCurveSystem<'a, P, E> {
    /// n·L·m: number of profile unknowns
    pub(crate) fn np(&self) -> usize {
        self.base.np()
    }

    /// the periodic-orbit unknowns [x, T, p1] of the point's cycle
    pub fn orbit<'u>(&self, u: &'u [f64]) -> &'u [f64] {
        self.base.orbit(u)
    }

    /// the period T of the point's cycle [time units]
    pub fn period(&self, u: &[f64]) -> f64 {
        u[self.np()]
    }

    /// all parameters at the point u
    pub fn parameters(&self, u: &[f64]) -> Vec<f64> {
        self.base.parameters(u)
    }

    /// amplitude of the point's cycle: half the peak-to-peak range of the node values,
    /// largest over the components [state units]
    pub fn amplitude(&self, u: &[f64]) -> f64 {
        self.base.po.amplitude(u)
    }

    /// The periodic-orbit system of the point's cycle at the parameters of u (free
    /// parameter p1, same mesh, phase reference set to the cycle): continue the cycle
    /// branch from here, or evaluate the cycle with [`PeriodicOrbitSystem::eval`].
    pub fn periodic_system(&self, u: &[f64]) -> Result<PeriodicOrbitSystem<'a, P>> {
        self.base.periodic_system(u)
    }

    /// How the bordered Newton systems are solved (default: that of the cycle system the
    /// curve was started from, [`LinearSolver::Auto`] unless set there).
    pub fn set_linear_solver(&mut self, solver: LinearSolver) {
        self.base.po.set_linear_solver(solver);
    }

    /// Floquet multipliers of the point's cycle, sorted by decreasing modulus: the trivial
    /// multiplier 1 and the critical ones of the curve among them (≈ 1 at a fold of
    /// cycles, −1 at a period doubling, e^{±iθ} at a torus point)
    pub fn multipliers(&mut self, u: &[f64]) -> Result<Vec<Complex64>> {
        self.base.multipliers(u)
    }

    /// The stability of the point (if `wanted`): the cycle's multipliers with the one
    /// nearest to each of `critical` removed, so that a change of the number outside the
    /// unit circle marks a codimension-two point of the curve.
    pub(crate) fn stability_without(
        &mut self,
        u: &[f64],
        wanted: bool,
        critical: &[Complex64],
    ) -> Result<Option<Stability>> {
        if !wanted {
            return Ok(None);
        }
        let mut mu = self.multipliers(u)?;
        for z in critical {
            let nearest = mu
                .iter()
                .enumerate()
                .min_by(|a, b| (a.1 - z).norm().total_cmp(&(b.1 - z).norm()))
                .map(|(i, _)| i);
            if let Some(i) = nearest {
                mu.remove(i);
            }
        }
        Ok(Some(Stability::from_multipliers(mu)))
    }
}

/// The extra equations of a two-parameter cycle system, what each extension adds to the one
/// [`ContinuationSystem`] implementation of [`CycleCurveSystem`]. That implementation holds
/// what the three systems share: p1 and p2 at u\[np + 1\] and u\[np + 2\], the cycle's rows
/// first and their Jacobian, the finiteness checks of the extra rows, the weights, the mesh
/// structure, the node-interleaved column order and the cycle as the phase reference of an
/// accepted point. The functions take the whole system: the extra rows read the cycle.
pub(crate) trait CycleRows: CycleExtension + Sized {
    /// the number of unknowns, [x, T, p1, p2] and the extra ones, with `np` profile unknowns
    fn n_unknowns(np: usize) -> usize;

    /// the first columns of the extra unknowns' profile-sized blocks (interleaved with the
    /// cycle node by node, and the blocks of the mesh structure) and the border columns,
    /// eliminated last (see [`CycleCurve::interleaved_order`])
    fn column_blocks(np: usize) -> (Vec<usize>, Vec<usize>);

    /// the extra rows `rows` of the residual at u (p1 and p2 already set from u)
    fn residual_rows<P: Problem>(
        sys: &mut CycleCurveSystem<'_, P, Self>,
        u: &[f64],
        rows: &mut [f64],
    ) -> Result<()>;

    /// entries of the extra rows copied from the cycle's Jacobian `entries[cycle..]`,
    /// appended; like the cycle's own entries they are not checked finite (default: none)
    fn repeat_cycle_entries(_np: usize, _entries: &mut Vec<Entry>, _cycle: usize) {}

    /// the Jacobian entries of the extra rows at u (and of the cycle's rows in the extra
    /// columns, such as p2's), appended
    fn jacobian_rows<P: Problem>(
        sys: &mut CycleCurveSystem<'_, P, Self>,
        u: &[f64],
        entries: &mut Vec<Entry>,
    ) -> Result<()>;

    /// the references of the accepted point u other than its cycle (set already)
    fn set_reference<P: Problem>(sys: &mut CycleCurveSystem<'_, P, Self>, u: &[f64]);

    /// the stability of the point u (see [`CycleCurveSystem::stability_without`])
    fn stability<P: Problem>(
        sys: &mut CycleCurveSystem<'_, P, Self>,
        u: &[f64],
    ) -> Result<Option<Stability>>;

    /// which special point, if any, lies between two stabilities (default: none)
    fn classify(_a: &Stability, _b: &Stability) -> Option<SpecialKind> {
        None
    }
}

/// The continuation system of every two-parameter cycle curve: p1 at u\[np + 1\], p2 at
/// u\[np + 2\], the cycle's rows (collocation and phase) first, then the rows of the extra
/// equations, each system's own (see the type's documentation).
impl<P: Problem, E: CycleRows> ContinuationSystem for CycleCurveSystem<'_, P, E> {
    fn n_unknowns(&self) -> usize {
        E::n_unknowns(self.np())
    }
    fn parameter_index(&self) -> usize {
        self.np() + 1
    }
    fn secondary_parameter_index(&self) -> Option<usize> {
        Some(self.np() + 2)
    }

    fn residual(&mut self, u: &[f64], r: &mut [f64]) -> Result<()> {
        let rows = self.base.cycle_residual(u, r)?;
        E::residual_rows(self, u, rows)?;
        self.base.finite(u, rows.iter().all(|x| x.is_finite()))
    }

    fn jacobian(&mut self, u: &[f64], entries: &mut Vec<Entry>) -> Result<()> {
        let cycle = entries.len();
        self.base.cycle_jacobian(u, entries)?;
        E::repeat_cycle_entries(self.np(), entries, cycle);
        let start = entries.len();
        E::jacobian_rows(self, u, entries)?;
        self.base
            .finite(u, entries[start..].iter().all(|e| e.val.is_finite()))
    }

    /// the cycle and the extra profile-sized blocks interleaved node by node (each node's
    /// state of the cycle, then of each block), the border columns (T, p1, p2 and the extra
    /// scalars) last: the Jacobian is then banded like the cycle's
    fn column_order(&self) -> Option<Vec<usize>> {
        let (blocks, border) = E::column_blocks(self.np());
        Some(self.base.interleaved_order(&blocks, &border))
    }

    /// the cycle's weights ([`PeriodicOrbitSystem`]), p2 weighted like p1, the extra
    /// unknowns not at all
    fn weights(&self) -> Vec<f64> {
        self.base.weights(self.n_unknowns())
    }

    /// the cycle and the extra profile-sized blocks on the mesh (see
    /// [`LinearSolver::Krylov`])
    fn mesh_structure(&self) -> Option<MeshStructure> {
        let (blocks, _) = E::column_blocks(self.np());
        self.base.mesh_structure(blocks.len())
    }

    fn accept(&mut self, u: &[f64]) {
        self.base.accept(u);
        E::set_reference(self, u);
    }

    fn stability(&mut self, u: &[f64]) -> Result<Option<Stability>> {
        E::stability(self, u)
    }

    fn classify(&self, a: &Stability, b: &Stability) -> Option<SpecialKind> {
        E::classify(a, b)
    }
}

/// Continue `branch` of `sys` by up to `max_points` points one engine step at a time,
/// asking `check(sys, branch, first_new_index)` after each step whether the curve ends
/// there (its own stop, returned as `Err`); otherwise the engine's stop is returned as
/// `Ok` once it is not [`Stop::MaxPoints`].
pub(crate) fn extend_checked<S: ContinuationSystem, E>(
    sys: &mut S,
    cont: &Continuation,
    branch: &mut Branch,
    max_points: usize,
    mut check: impl FnMut(&mut S, &mut Branch, usize) -> Result<Option<E>>,
) -> Result<std::result::Result<Stop, E>> {
    let mut added = 0;
    while added < max_points {
        let before = branch.points.len();
        let stop = cont.extend(sys, branch, 1)?;
        added += branch.points.len() - before;
        if branch.points.is_empty() {
            return Err(Error::EmptyBranch);
        }
        if let Some(end) = check(sys, branch, before)? {
            return Ok(Err(end));
        }
        if stop != Stop::MaxPoints {
            return Ok(Ok(stop));
        }
    }
    Ok(Ok(Stop::MaxPoints))
}

/// B = f_XX[dir, ·] (n × nc, row-major) column by column at the arguments `args`
/// (`unit`, `col`: scratch of lengths nc and n)
pub(crate) fn second_derivative_matrix<P: Problem>(
    problem: &P,
    args: &[f64],
    params: &[f64],
    dir: &[f64],
    unit: &mut [f64],
    col: &mut [f64],
    b: &mut [f64],
) -> Result<()> {
    let n = problem.dim();
    let nc = unit.len();
    for c in 0..nc {
        unit.iter_mut().for_each(|e| *e = 0.0);
        unit[c] = 1.0;
        problem.second_derivative(args, params, dir, unit, col)?;
        for r in 0..n {
            b[r * nc + c] = col[r];
        }
    }
    Ok(())
}

/// The reference mode of an accepted point: `reference` = `mode` / `norm` where `norm` is
/// positive and finite (else the reference is kept).
pub(crate) fn set_reference_mode(reference: &mut [f64], mode: &[f64], norm: f64) {
    if norm > 0.0 && norm.is_finite() {
        reference
            .iter_mut()
            .zip(mode)
            .for_each(|(r, x)| *r = x / norm);
    }
}

/// Entry i of the fixed, generic start of inverse iteration (the same numbers on every
/// run)
pub(crate) fn generic_start(i: usize) -> f64 {
    1.0 + 0.5 * ((i as f64) * 0.754_877_666_246_692_7).fract()
}

/// A mode found by inverse iteration on the square block of `size` rows from `r0` and
/// columns from `c0` of the Jacobian `entries` (nearly singular at the special point):
/// four solves from the start `z`, each normalised to max-norm 1.
pub(crate) fn inverse_iteration(
    entries: Vec<Entry>,
    (r0, c0, size): (usize, usize, usize),
    z: &mut [f64],
    what: &str,
) -> Result<()> {
    let block: Vec<Entry> = entries
        .into_iter()
        .filter(|e| (r0..r0 + size).contains(&e.row) && (c0..c0 + size).contains(&e.col))
        .map(|e| Entry::new(e.row - r0, e.col - c0, e.val))
        .collect();
    let lu = SparseLu::new(size, &block, Factorisation::Fast(None), what)?;
    for _ in 0..4 {
        lu.solve(z, what)?;
        let norm = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(Error::SingularSystem {
                size,
                what: format!("{what}: inverse iteration gave a zero or non-finite vector"),
            });
        }
        z.iter_mut().for_each(|v| *v /= norm);
    }
    Ok(())
}

/// Which real mode v (node values like the profile, at u\[np + 3..\]) the rows describe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RealMode {
    /// periodic, v(s + 1) = v(s), with the period component v_T at u\[2·np + 3\]: the rows
    /// are ∂R/∂(x, T)·(v, v_T) (the null vector of a fold of cycles)
    Periodic,
    /// antiperiodic, v(s + 1) = −v(s) (no period component): the rows are the collocated
    /// variational equation v' = T Σ_j J_j v(s − τ_j/T) with the antiperiodic extension
    /// (the Floquet mode of the multiplier −1)
    Antiperiodic,
}

/// Per-collocation-point scratch of the real-mode rows (allocated once).
#[derive(Debug)]
pub(crate) struct ModeScratch {
    f: Vec<f64>,
    jac: Vec<f64>,
    /// B = f_XX[Xv, ·] (n × n(k+1), row-major)
    b: Vec<f64>,
    /// Xv: the stacked arguments' derivative along the mode
    xv: Vec<f64>,
    unit: Vec<f64>,
    col: Vec<f64>,
    fp1: Vec<f64>,
    fp2: Vec<f64>,
    fxp1: Vec<f64>,
    fxp2: Vec<f64>,
    /// v_s and x_ss at the delayed points (n per delay)
    vs: Vec<f64>,
    xss: Vec<f64>,
    locs: Vec<Loc>,
    /// sign of the antiperiodic extension at the delayed points ((−1)^wraps; 1 if periodic)
    signs: Vec<f64>,
}

impl ModeScratch {
    pub(crate) fn new(n: usize, k: usize) -> Self {
        let nc = n * (k + 1);
        Self {
            f: vec![0.0; n],
            jac: vec![0.0; n * nc],
            b: vec![0.0; n * nc],
            xv: vec![0.0; nc],
            unit: vec![0.0; nc],
            col: vec![0.0; n],
            fp1: vec![0.0; n],
            fp2: vec![0.0; n],
            fxp1: vec![0.0; n],
            fxp2: vec![0.0; n],
            vs: vec![0.0; n * k],
            xss: vec![0.0; n * k],
            locs: vec![Loc::ZERO; k],
            signs: vec![1.0; k],
        }
    }
}

/// where the rows of a mode go (the real mode's here, the complex torus mode's in
/// the torus system)
pub(crate) enum Out<'b> {
    /// the mode's rows of the residual
    Residual(&'b mut [f64]),
    /// their Jacobian entries and the p2 column of R (real mode: the second-order terms, for
    /// an antiperiodic mode also the mode's own columns)
    Jacobian(&'b mut Vec<Entry>),
}

/// where the second-order terms of one collocation point are assembled
struct Point<'d> {
    i: usize,
    c: usize,
    row0: usize,
    period: f64,
    vt: f64,
    delays: &'d [f64],
    dtau: [&'d [f64]; 2],
}

impl<P: Problem> CycleCurve<'_, P> {
    /// sign of node j of interval `base` in the antiperiodic extension (the end node of
    /// the last interval is node 0 one period on)
    fn end_sign(&self, kind: RealMode, base: usize, j: usize) -> f64 {
        if kind == RealMode::Antiperiodic
            && base + 1 == self.po.intervals()
            && j == self.po.degree()
        {
            -1.0
        } else {
            1.0
        }
    }

    /// The rows of the real mode `kind` (residual), or their derivative with respect to
    /// (x, T, p1, p2) together with the p2 column of R (Jacobian), collocation point by
    /// collocation point. Periodic: A·(v, v_T) = v' − v_T f − T J·Xv with Xv the stacked
    /// v at s and v(s_d) + x_s(s_d)(τ_d/T²)v_T at the delayed points s_d = s − τ_d/T (their
    /// motion with T); antiperiodic: v' − T J·Xv with the sign (−1)^wraps at the s_d.
    pub(crate) fn real_mode_rows(
        &mut self,
        u: &[f64],
        kind: RealMode,
        s: &mut ModeScratch,
        mut out: Out<'_>,
    ) -> Result<()> {
        let n = self.po.dim();
        let m = self.po.degree();
        let problem = self.po.problem;
        let k = problem.n_delays();
        let nc = n * (k + 1);
        let np = self.np();
        let period = u[np];
        let (ip1, ip2) = (self.po.ip, self.ip2);
        let delays = self.po.delays();
        let dtau1: Vec<f64> = (0..k)
            .map(|d| problem.delay_dp(d, &self.po.params, ip1))
            .collect();
        let dtau2: Vec<f64> = (0..k)
            .map(|d| problem.delay_dp(d, &self.po.params, ip2))
            .collect();
        let vt = match kind {
            RealMode::Periodic => u[2 * np + 3],
            RealMode::Antiperiodic => 0.0,
        };
        let (mut l, mut dl, mut ddl) = (
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
        );
        let v = &u[np + 3..];
        for i in 0..self.po.intervals() {
            let h = self.po.mesh[i + 1] - self.po.mesh[i];
            let s_c0 = self.po.mesh[i];
            for c in 0..m {
                self.po
                    .fill_args(&u[..np + 2], i, c, period, &delays, &mut s.locs);
                let params = &self.po.params;
                let args = &self.po.args;
                problem.rhs(args, params, &mut s.f);
                problem.jacobian(args, params, &mut s.jac);
                let sc = s_c0 + h * self.po.basis.xi[c];
                for kk in 0..n {
                    s.xv[kk] = (0..=m)
                        .map(|j| {
                            self.po.basis.val[c * (m + 1) + j]
                                * self.end_sign(kind, i, j)
                                * v[self.po.node(i, j) * n + kk]
                        })
                        .sum();
                }
                for (d, &tau) in delays.iter().enumerate() {
                    let loc = s.locs[d];
                    let hd = self.po.mesh[loc.base + 1] - self.po.mesh[loc.base];
                    s.signs[d] = match kind {
                        RealMode::Periodic => 1.0,
                        RealMode::Antiperiodic => {
                            if ((sc - tau / period).floor() as i64).rem_euclid(2) == 0 {
                                1.0
                            } else {
                                -1.0
                            }
                        }
                    };
                    lagrange_d2(m, loc.xi, &mut l, &mut dl, &mut ddl);
                    for kk in 0..n {
                        let (mut vd, mut vs, mut xss) = (0.0, 0.0, 0.0);
                        for j in 0..=m {
                            let g = self.po.node(loc.base, j) * n + kk;
                            let sg = s.signs[d] * self.end_sign(kind, loc.base, j);
                            vd += l[j] * sg * v[g];
                            vs += dl[j] * sg * v[g] / hd;
                            xss += ddl[j] * u[g] / (hd * hd);
                        }
                        let xs = self.po.dx[d * n + kk];
                        s.xv[(d + 1) * n + kk] = vd + xs * tau / (period * period) * vt;
                        s.vs[d * n + kk] = vs;
                        s.xss[d * n + kk] = xss;
                    }
                }
                let row0 = (i * m + c) * n;
                match &mut out {
                    Out::Residual(r) => {
                        for rr in 0..n {
                            let dv: f64 = (0..=m)
                                .map(|j| {
                                    self.po.basis.der[c * (m + 1) + j]
                                        * self.end_sign(kind, i, j)
                                        * v[self.po.node(i, j) * n + rr]
                                })
                                .sum();
                            let jxv: f64 =
                                (0..nc).map(|col| s.jac[rr * nc + col] * s.xv[col]).sum();
                            r[row0 + rr] = dv / h - vt * s.f[rr] - period * jxv;
                        }
                    }
                    Out::Jacobian(entries) => {
                        let at = Point {
                            i,
                            c,
                            row0,
                            period,
                            vt,
                            delays: &delays,
                            dtau: [&dtau1, &dtau2],
                        };
                        self.push_second_order(&at, s, entries)?;
                        if kind == RealMode::Antiperiodic {
                            self.push_mode_columns(&at, h, s, entries);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// the antiperiodic mode's own columns at one collocation point: (ℓ'_j/h − T J_0 ℓ_j)
    /// at s_c and −T J_d ℓ_j at the delayed points, with the extension's signs
    fn push_mode_columns(&self, at: &Point<'_>, h: f64, s: &ModeScratch, entries: &mut Vec<Entry>) {
        let n = self.po.dim();
        let m = self.po.degree();
        let nc = s.xv.len();
        let np = self.np();
        let row_a = np + 1 + at.row0;
        let basis = &self.po.basis;
        let kind = RealMode::Antiperiodic;
        for j in 0..=m {
            let g = np + 3 + self.po.node(at.i, j) * n;
            let sg = self.end_sign(kind, at.i, j);
            let lv = basis.val[at.c * (m + 1) + j];
            let dv = basis.der[at.c * (m + 1) + j] / h;
            for r in 0..n {
                for kk in 0..n {
                    let mut v = -at.period * s.jac[r * nc + kk] * lv;
                    if r == kk {
                        v += dv;
                    }
                    entries.push(Entry::new(row_a + r, g + kk, sg * v));
                }
            }
        }
        let (mut l, mut dl, mut ddl) = (
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
            [0.0; MAX_DEGREE + 1],
        );
        for d in 0..at.delays.len() {
            let loc = s.locs[d];
            lagrange_d2(m, loc.xi, &mut l, &mut dl, &mut ddl);
            for (j, &lj) in l.iter().enumerate().take(m + 1) {
                let g = np + 3 + self.po.node(loc.base, j) * n;
                let sg = s.signs[d] * self.end_sign(kind, loc.base, j);
                for r in 0..n {
                    for kk in 0..n {
                        let v = -at.period * s.jac[r * nc + (d + 1) * n + kk] * lj;
                        entries.push(Entry::new(row_a + r, g + kk, sg * v));
                    }
                }
            }
        }
    }

    /// Jacobian entries of the second-order terms of one collocation point (the scratch
    /// holds f, J, Xv, v_s and x_ss and `po` the arguments, x_s and the delayed locations)
    fn push_second_order(
        &self,
        at: &Point<'_>,
        s: &mut ModeScratch,
        entries: &mut Vec<Entry>,
    ) -> Result<()> {
        let n = self.po.dim();
        let m = self.po.degree();
        let problem = self.po.problem;
        let nc = s.xv.len();
        let np = self.np();
        let (ip1, ip2) = (self.po.ip, self.ip2);
        let (t, vt) = (at.period, at.vt);
        let params = &self.po.params;
        let args = &self.po.args;
        second_derivative_matrix(
            problem,
            args,
            params,
            &s.xv,
            &mut s.unit,
            &mut s.col,
            &mut s.b,
        )?;
        problem.dfdp(args, params, ip1, &mut s.fp1);
        problem.dfdp(args, params, ip2, &mut s.fp2);
        problem.jacobian_dp(args, params, ip1, &s.xv, &mut s.fxp1)?;
        problem.jacobian_dp(args, params, ip2, &s.xv, &mut s.fxp2)?;
        let xs = &self.po.dx;
        let dot = |mat: &[f64], r: usize, d: usize, vec: &[f64]| -> f64 {
            (0..n)
                .map(|kk| mat[r * nc + (d + 1) * n + kk] * vec[d * n + kk])
                .sum::<f64>()
        };
        let row_a = np + 1 + at.row0;
        for r in 0..n {
            // R's column of p2: −T f_p2 + Σ_d J_d x_s(s_d) ∂τ_d/∂p2
            let mut c_r2 = -t * s.fp2[r];
            // the mode rows differentiated by T, p1, p2
            let jxv: f64 = (0..nc).map(|col| s.jac[r * nc + col] * s.xv[col]).sum();
            let mut c_t = -jxv;
            let mut c_p = [
                -vt * s.fp1[r] - t * s.fxp1[r],
                -vt * s.fp2[r] - t * s.fxp2[r],
            ];
            for (d, &tau) in at.delays.iter().enumerate() {
                let jx = dot(&s.jac, r, d, xs);
                let bx = dot(&s.b, r, d, xs);
                let jvs = dot(&s.jac, r, d, &s.vs);
                let jxss = dot(&s.jac, r, d, &s.xss);
                let st = tau / (t * t);
                let dst_dt = -2.0 * tau / (t * t * t);
                c_t -= vt * jx * st
                    + t * bx * st
                    + t * (jvs * st + vt * (jxss * st * st + jx * dst_dt));
                c_r2 += jx * at.dtau[1][d];
                for (cp, dtau) in c_p.iter_mut().zip(at.dtau) {
                    let sp = -dtau[d] / t;
                    let dst_dp = dtau[d] / (t * t);
                    *cp -= vt * jx * sp
                        + t * bx * sp
                        + t * (jvs * sp + vt * (jxss * st * sp + jx * dst_dp));
                }
            }
            entries.push(Entry::new(at.row0 + r, np + 2, c_r2));
            entries.push(Entry::new(row_a + r, np, c_t));
            entries.push(Entry::new(row_a + r, np + 1, c_p[0]));
            entries.push(Entry::new(row_a + r, np + 2, c_p[1]));
        }
        // profile columns at s_c: −v_T J_0 − T B_0
        let basis = &self.po.basis;
        for j in 0..=m {
            let g = self.po.node(at.i, j);
            let lv = basis.val[at.c * (m + 1) + j];
            for r in 0..n {
                for kk in 0..n {
                    let v = (-vt * s.jac[r * nc + kk] - t * s.b[r * nc + kk]) * lv;
                    entries.push(Entry::new(row_a + r, g * n + kk, v));
                }
            }
        }
        // profile columns at the delayed points: (−v_T J_d − T B_d) ℓ_j − T v_T (τ_d/T²) J_d ℓ'_j
        let (mut l, mut dl) = ([0.0; MAX_DEGREE + 1], [0.0; MAX_DEGREE + 1]);
        let mut ddl = [0.0; MAX_DEGREE + 1];
        for (d, &tau) in at.delays.iter().enumerate() {
            let loc = s.locs[d];
            let hd = self.po.mesh[loc.base + 1] - self.po.mesh[loc.base];
            lagrange_d2(m, loc.xi, &mut l, &mut dl, &mut ddl);
            let st = tau / (t * t);
            for j in 0..=m {
                let g = self.po.node(loc.base, j);
                for r in 0..n {
                    for kk in 0..n {
                        let q = r * nc + (d + 1) * n + kk;
                        let v = (-vt * s.jac[q] - t * s.b[q]) * l[j]
                            - t * vt * st * s.jac[q] * dl[j] / hd;
                        entries.push(Entry::new(row_a + r, g * n + kk, v));
                    }
                }
            }
        }
        Ok(())
    }
}
