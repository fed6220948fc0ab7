//! Newton's method on one step's incremental potential (see [`super`] for the equations).
//!
//! Each iterate evaluates every term at x (forces, energies, linearizations), stops when
//! `‖rhs‖ ≤ newton_tolerance·‖rhs₀‖` over the free DOFs or below an absolute floor, else asks the
//! linear solver for `dx = A⁻¹·rhs` (inexact: the CG tolerance follows Newton's progress), lets
//! the definiteness policy pick the tangent, and searches along dx ([`super::line_search`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::CHUNK;
use super::params::SolverParams;
use super::policy::{ADAPTIVE_STALL_RATIO, TangentPolicy};
use super::problem::{IncrementalPotential, Problem, StepContext, StepKind};
use super::stats::{NewtonInfo, Timings};
use crate::elastic::{ElasticBody, Linearization};
use crate::linear::cg::{self, CgError, CgParams};
use crate::linear::{LinearSolver, SolverReport, make_solver};
use crate::material::Definiteness;
use crate::math::{Mat3, Vec3};

/// Newton's method with its preallocated workspace (one per simulation).
pub struct Newton {
    pub(super) potential: IncrementalPotential,
    solver: Box<dyn LinearSolver>,
    pub(super) rhs: Vec<Vec3>,
    pub(super) dx: Vec<Vec3>,
    pub(super) x_start: Vec<Vec3>,
    pub(super) partials: Vec<f64>,
    timings: Timings,
    policy: TangentPolicy,
    /// Whether a failed ‖rhs‖ line search may fall back on the potential (see
    /// [`Newton::set_last_resort`]).
    pub(super) last_resort: bool,
    /// Whether continuous collision detection shortened the last line search's first trial
    /// (contact only): such a step says nothing about the tangent's quality.
    pub(super) collision_limited: bool,
    /// Under MPI: the whole body's sums over the ranks (see [`crate::parallel`]); this rank's
    /// vectors then hold its own vertices and a ghost layer that no sum counts.
    ranks: Option<std::sync::Arc<dyn crate::parallel::Ranks>>,
    /// Set from outside (a signal handler) to stop the step at the next iteration.
    interrupt: Option<Arc<AtomicBool>>,
}

/// Merit and residual of one evaluated iterate.
#[derive(Clone, Copy, Debug)]
pub(super) struct Evaluation {
    /// Elastic energy, J.
    pub energy: f64,
    /// The incremental potential Φ, J.
    pub potential: f64,
    /// ‖rhs‖ over the free DOFs, N.
    pub residual: f64,
}

impl Newton {
    /// Workspace for `body`.
    pub fn new(body: &ElasticBody, params: &SolverParams) -> Self {
        let n = body.vertex_count();
        Newton {
            potential: IncrementalPotential::new(body, params),
            solver: make_solver(&params.linear(), n),
            rhs: vec![Vec3::zeros(); n],
            dx: vec![Vec3::zeros(); n],
            x_start: vec![Vec3::zeros(); n],
            partials: vec![0.0; n.div_ceil(CHUNK).max(1)],
            timings: Timings::default(),
            policy: TangentPolicy::new(params.definiteness),
            last_resort: true,
            collision_limited: false,
            ranks: None,
            interrupt: None,
        }
    }

    /// A flag that, once set, ends the step being solved at its next iteration, unconverged
    /// (see [`Newton::interrupted`]).
    pub fn set_interrupt(&mut self, flag: Option<Arc<AtomicBool>>) {
        self.interrupt = flag;
    }

    /// Whether the interrupt flag is set. Never under MPI: a rank that left the step alone would
    /// leave the others waiting in a collective (mpirun stops the job on a signal instead).
    pub fn interrupted(&self) -> bool {
        self.ranks.is_none()
            && self
                .interrupt
                .as_ref()
                .is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// The incremental potential's terms (add contact or friction terms to `extra`).
    pub fn potential_mut(&mut self) -> &mut IncrementalPotential {
        &mut self.potential
    }

    /// The incremental potential's terms.
    pub fn potential(&self) -> &IncrementalPotential {
        &self.potential
    }

    /// The linearization at the last evaluated iterate (for diagnostics).
    pub fn linearization(&self) -> &Linearization {
        self.potential.elasticity.linearization()
    }

    /// Bytes one CG iteration's operator and preconditioner move (a traffic model for roofline
    /// figures; see each [`LinearSolver`]). On the assembled paths known after the first solve.
    pub fn bytes_per_cg_iteration(&self, body: &ElasticBody) -> f64 {
        self.solver
            .bytes_per_iteration(body.matrix_free_bytes_per_product())
    }

    /// Newton's buffers, the potential's and the linear solver's, into a memory inventory.
    pub fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        use crate::memory::vec_bytes;
        inventory.add(
            "Newton: right-hand side, step, start",
            vec_bytes(&self.rhs) + vec_bytes(&self.dx) + vec_bytes(&self.x_start),
        );
        self.potential.add_memory(inventory);
        self.solver.add_memory(inventory);
    }

    /// Replace the linear solver (under MPI: PETSc's, see [`crate::parallel`]).
    #[cfg(feature = "mpi")]
    pub fn set_linear_solver(&mut self, solver: Box<dyn LinearSolver>) {
        self.solver = solver;
    }

    /// Make every sum Newton decides on a sum over the MPI ranks (see [`crate::parallel`]).
    pub fn set_ranks(&mut self, ranks: std::sync::Arc<dyn crate::parallel::Ranks>) {
        self.ranks = Some(ranks);
    }

    /// The ranks' sums, when distributed.
    pub fn ranks(&self) -> Option<&std::sync::Arc<dyn crate::parallel::Ranks>> {
        self.ranks.as_ref()
    }

    /// Add `values` over the ranks (nothing when not distributed).
    fn sum_over_ranks(&self, values: &mut [f64]) {
        if let Some(r) = &self.ranks {
            r.sum(values);
        }
    }

    /// `rhs·dx` over the whole body.
    pub(super) fn rhs_dot_dx(&mut self) -> f64 {
        let mut d = [cg::dot(&self.rhs, &self.dx, &mut self.partials)];
        self.sum_over_ranks(&mut d);
        d[0]
    }

    /// What the linear solver did so far.
    pub fn solver_report(&self) -> SolverReport {
        self.solver.report()
    }

    /// The linear solver's state between iterates (for a checkpoint).
    pub fn solver_state(&self) -> crate::linear::state::SolverState {
        self.solver.save_state()
    }

    /// Take up a saved linear-solver state (`rest`: the body's rest positions).
    pub fn restore_solver_state(
        &mut self,
        saved: &crate::linear::state::SolverState,
        rest: &[Vec3],
    ) -> Result<(), String> {
        self.solver.restore_state(saved, rest)
    }

    /// The sparse Cholesky's costs and counts, when it is the preconditioner.
    #[cfg(feature = "direct")]
    pub fn cholesky_info(&self) -> Option<&crate::linear::direct::CholeskyInfo> {
        self.solver.cholesky_info()
    }

    /// The elastic forces f_el at the last evaluated iterate (the step's result after
    /// [`Newton::solve`]), N.
    pub fn elastic_forces(&self) -> &[Vec3] {
        self.potential.elasticity.forces()
    }

    /// K·v at the last evaluated iterate of a dynamic step with γ > 0 (the damping force is
    /// −γ·K·v); stale otherwise.
    pub fn stiffness_velocity(&self) -> &[Vec3] {
        self.potential.elasticity.stiffness_velocity()
    }

    /// The right-hand side at the last evaluated iterate, zero on constrained components: what
    /// is left of the step's equation, N.
    pub fn residual(&self) -> &[Vec3] {
        &self.rhs
    }

    /// Whether the coming solves are a last attempt (no retry with smaller steps follows; the
    /// default). Only then may a first line search on ‖rhs‖ (γ > 0) that finds nothing accept a
    /// step on which the incremental potential without the damping term falls by Armijo's rule.
    pub fn set_last_resort(&mut self, last: bool) {
        self.last_resort = last;
    }

    /// Solve one step. On entry `x` holds the initial guess with its constrained components at
    /// their prescribed values; on exit `x` (and `v`, for dynamic steps) hold the result.
    pub fn solve(&mut self, ctx: &StepContext<'_>, x: &mut [Vec3], v: &mut [Vec3]) -> NewtonInfo {
        let params = ctx.params;
        let mut info = NewtonInfo {
            // One allocation per step, none per iteration.
            history: Vec::with_capacity(params.newton_max_iterations + 1),
            ..Default::default()
        };
        self.timings = Timings::default();
        self.collision_limited = false;
        // A term may raise the floor to what its forces can resolve (see `Term::residual_floor`).
        let mut floor = absolute_floor(ctx, x, self.ranks.as_deref());
        let drive = self.drive(ctx);
        floor = floor.max(self.potential.residual_floor(ctx));
        // Before any iteration the floor may not exceed the tolerance on what drives the step
        // (loads, momentum): a stiffness-scaled floor (λ + 2μ grows without bound as ν → ½)
        // would otherwise swallow an unbalanced load and declare the unmoved body converged.
        let first_floor = if drive > 0.0 {
            floor.min(params.newton_tolerance * drive)
        } else {
            floor
        };
        self.policy.begin_step(ctx);
        let mut eval = self.evaluate(ctx, x, v);
        // A term that adjusts itself to the first iterate (contact's barrier stiffness).
        if self.potential.after_first_evaluation(ctx, &self.rhs) {
            eval = self.evaluate(ctx, x, v);
        }
        let first = eval.residual;
        let mut eta = FORCING_MAX;
        // Counts of the first iterate's tangents, unless they are left for later (a damped step
        // with a shift: the loop reads them once made).
        if !self.linearization().tangents_pending() {
            info.clamped_tets = self.linearization().clamped_tets();
            info.strongly_clamped_tets = self.linearization().strongly_clamped_tets();
        }
        loop {
            info.history.push(eval.residual);
            info.residual = eval.residual;
            info.elastic_energy = eval.energy;
            info.relative_residual = if first > floor {
                eval.residual / first
            } else {
                0.0
            };
            if !eval.residual.is_finite() {
                info.failure = Some("the residual became non-finite".into());
                break;
            }
            let floor_now = if info.iterations == 0 {
                first_floor
            } else {
                floor
            };
            if eval.residual <= floor_now || eval.residual <= params.newton_tolerance * first {
                info.converged = true;
                break;
            }
            if self.interrupted() {
                info.failure = Some("interrupted".into());
                break;
            }
            if info.iterations == params.newton_max_iterations {
                info.failure = Some(format!(
                    "Newton reached its cap of {} iterations at relative residual {:.2e} (tolerance {:.0e})",
                    params.newton_max_iterations, info.relative_residual, params.newton_tolerance
                ));
                break;
            }
            info.iterations += 1;
            let (cg_before, cuts_before) = (info.cg_iterations, info.line_search_cuts);
            self.linearize(ctx, x, v);
            info.clamped_tets = info.clamped_tets.max(self.linearization().clamped_tets());
            info.strongly_clamped_tets = info
                .strongly_clamped_tets
                .max(self.linearization().strongly_clamped_tets());
            let mut exact = !self.collision_limited
                && self
                    .policy
                    .wants_exact(&info.history, self.potential.elasticity.linearization());
            // The first solve of a damped step on the exact tangent is made tighter: Newton
            // then converges fast enough for the first direction's accuracy to carry through.
            let consistent = exact || params.definiteness == Definiteness::Exact;
            let first_eta = if consistent && ctx.stiffness_damping() > 0.0 {
                FORCING_FIRST_EXACT
            } else {
                FORCING_MAX
            };
            eta = forcing_term(params, &info.history, eta, first, floor, first_eta);
            let cg_params = CgParams {
                tolerance: eta,
                max_iterations: params.cg.max_iterations,
            };
            self.potential.use_exact(exact);
            let breakdowns = info.cg_breakdowns;
            self.solve_linear(ctx, &cg_params, &mut info);
            if exact && (info.cg_breakdowns > breakdowns || !self.is_descent(ctx)) {
                log::debug!(
                    "Newton {}: exact tangent gave no descent; projected",
                    info.iterations
                );
                info.cg_breakdowns = breakdowns;
                info.projected_fallbacks += 1;
                self.policy.exact_failed();
                exact = false;
                self.potential.use_exact(false);
                self.solve_linear(ctx, &cg_params, &mut info);
            }
            // A term may find the step already too small to matter (contact's IPC rule), but
            // only near convergence: a state pressed deep into a barrier also asks for a tiny
            // step (its Hessian is huge), with forces far from balanced.
            let close = eval.residual <= 1e3 * params.newton_tolerance * first;
            if close && self.potential.step_converged(ctx, &self.dx) {
                info.converged = true;
                break;
            }
            let mut searched = self.line_search(ctx, x, v, eval, &mut info);
            if searched.is_none() && exact {
                // The line search re-evaluated x: its linearization is projected again.
                log::debug!(
                    "Newton {}: line search failed on the exact tangent; projected",
                    info.iterations
                );
                info.projected_fallbacks += 1;
                self.policy.exact_failed();
                self.linearize(ctx, x, v);
                self.solve_linear(ctx, &cg_params, &mut info);
                searched = self.line_search(ctx, x, v, eval, &mut info);
            } else if exact
                && searched.is_some_and(|next| next.residual > ADAPTIVE_STALL_RATIO * eval.residual)
            {
                log::debug!(
                    "Newton {}: the exact tangent stalls; projected first for the rest of the step",
                    info.iterations
                );
                self.policy.exact_failed();
            }
            match searched {
                Some(next) => {
                    log::debug!(
                        "Newton {}: residual {:.3e} N → {:.3e} N, {} CG, {} line-search cuts",
                        info.iterations,
                        eval.residual,
                        next.residual,
                        info.cg_iterations - cg_before,
                        info.line_search_cuts - cuts_before
                    );
                    eval = next
                }
                None => {
                    info.failure = Some(
                        "the line search found no step that reduces the merit (the Newton direction is not a descent direction)".into(),
                    );
                    break;
                }
            }
            info.clamped_tets = info.clamped_tets.max(self.linearization().clamped_tets());
            info.strongly_clamped_tets = info
                .strongly_clamped_tets
                .max(self.linearization().strongly_clamped_tets());
        }
        info.timings = self.timings;
        info
    }

    /// Make the Hessian data the last evaluation left for later (timed as evaluation).
    fn linearize(&mut self, ctx: &StepContext<'_>, x: &[Vec3], v: &[Vec3]) {
        let started = Instant::now();
        self.potential.linearize(ctx, x, v);
        self.timings.evaluate += started.elapsed().as_secs_f64();
    }

    /// dx = A⁻¹·rhs by the linear solver (A from the current linearizations).
    fn solve_linear(&mut self, ctx: &StepContext<'_>, cg_params: &CgParams, info: &mut NewtonInfo) {
        let started = Instant::now();
        let mut problem = Problem::new(&mut self.potential, ctx);
        self.solver.prepare(&mut problem, ctx.free);
        self.dx.iter_mut().for_each(|d| *d = Vec3::zeros());
        let cg_started = Instant::now();
        self.timings.preconditioner += cg_started.duration_since(started).as_secs_f64();
        let result = self
            .solver
            .solve(&mut problem, &self.rhs, &mut self.dx, ctx.free, cg_params);
        self.timings.cg += cg_started.elapsed().as_secs_f64();
        match result {
            Ok(cg_info) => {
                info.cg_iterations += cg_info.iterations;
                info.cg_capped += (!cg_info.converged) as usize;
            }
            Err(CgError::NotPositiveDefinite { info: cg_info, .. })
            | Err(CgError::NonFinite { info: cg_info, .. }) => {
                info.cg_iterations += cg_info.iterations;
                info.cg_breakdowns += 1;
                log::debug!("CG broke down after {} iterations", cg_info.iterations);
                // The iterate so far minimises the quadratic model over the Krylov space built
                // before the breakdown; with none, fall back to the preconditioned residual.
                let mut useless = [(self.dx.iter().all(|d| *d == Vec3::zeros())
                    || self.dx.iter().any(|d| !d.iter().all(|c| c.is_finite())))
                    as u8 as f64];
                // Every rank must agree (the fallback is collective under MPI).
                if let Some(r) = &self.ranks {
                    r.max(&mut useless);
                }
                let useless = useless[0] > 0.0;
                if useless {
                    self.solver.precondition(&self.rhs, &mut self.dx);
                    cg::project(&mut self.dx, ctx.free);
                }
            }
        }
    }

    /// Whether dx points downhill: for the incremental potential (γ = 0 or quasistatic) its
    /// slope ∇Φ·dx = −rhs·dx must be negative. With γ > 0 there is no potential and the line
    /// search on ‖rhs‖ is the judge.
    fn is_descent(&mut self, ctx: &StepContext<'_>) -> bool {
        if !ctx.has_potential() {
            return true;
        }
        self.rhs_dot_dx() > 0.0
    }

    /// What drives the step, N: ‖f_ext‖ and, for a dynamic step, ‖M·vⁿ/h‖ over the free DOFs
    /// (the scale against which "balanced at the start" is judged).
    fn drive(&mut self, ctx: &StepContext<'_>) -> f64 {
        let masses = ctx.body.masses();
        let mut sum = 0.0;
        for (i, (f, free)) in ctx.f_ext.iter().zip(ctx.free).enumerate() {
            let mut d = f.component_mul(free).norm_squared();
            if let StepKind::Dynamic(step) = ctx.kind {
                d += (masses[i] / step.inertia_time * step.base_velocity[i])
                    .component_mul(free)
                    .norm_squared();
            }
            sum += d;
        }
        let mut sum = [sum];
        self.sum_over_ranks(&mut sum);
        sum[0].sqrt()
    }

    /// Evaluate every term at x (linearizing), fill `self.rhs` (masked) and `v` (dynamic), and
    /// return the merits.
    pub(super) fn evaluate(
        &mut self,
        ctx: &StepContext<'_>,
        x: &[Vec3],
        v: &mut [Vec3],
    ) -> Evaluation {
        let started = Instant::now();
        if let StepKind::Dynamic(step) = ctx.kind {
            let tau = step.velocity_time;
            v.par_iter_mut()
                .zip(x.par_iter().zip(step.still.par_iter()))
                .with_min_len(CHUNK)
                .for_each(|(v, (x, still))| *v = (x - still) / tau);
        }
        let potential = self
            .potential
            .evaluate(ctx, x, v, &mut self.rhs, &mut self.partials);
        let squared = cg::dot(&self.rhs, &self.rhs, &mut self.partials);
        // One reduction over the ranks for the three numbers an iterate is judged by.
        let mut sums = [potential, self.potential.elasticity.energy(), squared];
        self.sum_over_ranks(&mut sums);
        self.timings.evaluate += started.elapsed().as_secs_f64();
        Evaluation {
            energy: sums[1],
            potential: sums[0],
            residual: sums[2].sqrt(),
        }
    }
}

/// CG tolerance η for the next Newton iterate (inexact Newton; Eisenstat & Walker 1996,
/// choice 2 with γ = 0.9, α = 2): η = 0.9·(‖rₖ‖/‖rₖ₋₁‖)², kept from falling faster than
/// 0.9·η_prev² once that exceeds 0.1, capped at [`FORCING_MAX`]; never tighter than half of
/// what would reach the Newton target in this step (no oversolving at the end), nor than
/// `cg.tolerance`. With `inexact_newton` off, η = `cg.tolerance`.
fn forcing_term(
    params: &SolverParams,
    history: &[f64],
    previous: f64,
    first: f64,
    floor: f64,
    first_eta: f64,
) -> f64 {
    if !params.inexact_newton {
        return params.cg.tolerance;
    }
    let r = *history.last().unwrap_or(&first);
    let mut eta = match history {
        [.., before, last] => {
            let ratio = last / before.max(f64::MIN_POSITIVE);
            let eta = 0.9 * ratio * ratio;
            let safeguard = 0.9 * previous * previous;
            if safeguard > 0.1 {
                eta.max(safeguard)
            } else {
                eta
            }
        }
        _ => first_eta,
    };
    eta = eta.min(FORCING_MAX);
    let target = (params.newton_tolerance * first).max(floor);
    eta = eta.max(0.5 * target / r.max(f64::MIN_POSITIVE));
    eta.clamp(params.cg.tolerance, FORCING_MAX.max(params.cg.tolerance))
}

/// The loosest CG tolerance inexact Newton uses, and the first one in general.
const FORCING_MAX: f64 = 0.1;

/// The first CG tolerance of a damped step that starts on the exact tangent (see
/// [`super::policy`]): the first residual reduction then carries (measured in
/// docs/performance.md, "Why the defaults").
const FORCING_FIRST_EXACT: f64 = 0.01;

/// Absolute residual floor: 1e-12 of the characteristic force E·ℓ²·√n (E from the material at
/// rest), so that a body at rest is converged before any iteration; raised where rounding of
/// the positions themselves is larger (a body far from the origin, e.g. moving at 1e4 m/s):
/// an error of ε·|x| in the coordinates makes an elastic force error of about E·ℓ·ε·|x| per
/// vertex and an inertia error of about m·ε·|x|/h².
/// Under MPI the mesh's figures are the whole body's (`ranks`).
fn absolute_floor(
    ctx: &StepContext<'_>,
    x: &[Vec3],
    ranks: Option<&dyn crate::parallel::Ranks>,
) -> f64 {
    use crate::material::Material;
    let body = ctx.body;
    // The rest tangent's ∂P₁₁/∂F₁₁ = λ + 2μ stands in for E: a scale, not a measurement.
    let mut df = Mat3::zeros();
    df[(0, 0)] = 1.0;
    let stiffness = body.model.stress_differential(&Mat3::identity(), &df)[(0, 0)].abs();
    let mut maxima = [
        x.iter().map(|p| p.amax()).fold(0.0, f64::max),
        body.masses().iter().copied().fold(0.0, f64::max),
    ];
    let (edge, vertices) = match ranks {
        Some(r) => {
            r.max(&mut maxima);
            (r.mean_edge_length(), r.vertex_count())
        }
        None => (body.mesh.mean_edge_length(), body.vertex_count()),
    };
    let [reach, mass] = maxima;
    let roots = (vertices as f64).sqrt();
    let mut floor =
        stiffness * edge * edge * roots * 1e-12_f64.max(POSITION_ROUNDING * reach / edge);
    if let StepKind::Dynamic(step) = ctx.kind {
        floor = floor.max(POSITION_ROUNDING * mass * reach / step.inertia_denominator * roots);
    }
    floor
}

/// Coordinates carry a relative rounding of ε; the floor allows a hundred times that.
const POSITION_ROUNDING: f64 = 100.0 * f64::EPSILON;
