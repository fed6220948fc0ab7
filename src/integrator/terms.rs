//! The terms of the incremental potential Newton minimises, behind one [`Term`] trait.
//!
//! A dynamic step from (xⁿ, vⁿ) over h (backward Euler here; every scheme of [`super::scheme`]
//! has the same form with its own x̃, x_still and times) finds a stationary point of
//!
//! ```text
//! Φ(x) = ½‖x − xⁿ − h·vⁿ‖²_M / h² + α‖x − xⁿ‖²_M / (2h)     inertia and mass damping
//!      + E(x)                                               elasticity (stiffness damping: force only)
//!      − f_ext·x                                            gravity and dead loads
//!      + …                                                  contact, friction (as they come)
//! ```
//!
//! (a quasistatic step drops the first line). Each term gives its energy, adds its force
//! `−∇Φ_term` (plus non-conservative parts, like the damping force `−γ·K·v`), and describes its
//! Hessian: none (linear terms), a lumped diagonal (inertia), or blocks (elasticity, contact)
//! with a product, diagonal blocks, a block pattern and an assembly. Hessians are the
//! definiteness-projected ones unless [`Term::use_exact`] says otherwise.
//!
//! **Order.** Forces are added in list order (inertia, elasticity, loads, then the rest), from
//! zero; Hessians are added block terms first, then the lumped diagonals (they are folded into
//! the last pass). Both orders are fixed, so sums are the same bits for any thread count.

use rayon::prelude::*;

use super::params::DampingTangent;
use super::problem::{StepContext, StepKind};
use super::{CHUNK, ordered_sum};
use crate::elastic::{AssemblyWork, Damping, ElasticBody, Linearization};
use crate::linear::sparse::{BlockCsr, BlockPattern};
use crate::material::Definiteness;
use crate::math::{Mat3, Vec3};

/// How a step starts, for [`Term::begin_step`].
pub struct StepStart<'a> {
    /// Positions at the step's start.
    pub xn: &'a [Vec3],
    /// The step's length, s (1 for a load step).
    pub h: f64,
    /// The ramp factor of a motion of the given duration (None: the whole run) at the step's
    /// start.
    pub ramp_start: &'a dyn Fn(Option<f64>) -> f64,
    /// The same at the step's end.
    pub ramp_end: &'a dyn Fn(Option<f64>) -> f64,
    /// 0/1 mask of the free DOFs.
    pub free: &'a [Vec3],
}

/// How a term's Hessian looks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HessianShape {
    /// Zero: the term is linear in x (dead loads).
    Zero,
    /// A diagonal with the same weight on a vertex's three DOFs (lumped masses): see
    /// [`Term::add_lumped_diagonal`].
    LumpedDiagonal,
    /// 3×3 blocks between vertices: see [`Term::add_hessian_product`] and the others.
    Blocks,
}

/// One term of the incremental potential. See the module docs for the sign and order rules.
pub trait Term: Send {
    /// A short name for reports and `tetsim check` ("inertia", "elasticity", ...).
    fn name(&self) -> &'static str;

    /// Evaluate at positions x (v: the velocities x implies in a dynamic step; zero when
    /// static): return the term's energy (J; 0 for terms without one) and add its force into
    /// `force`. Terms with blocks linearize here, once per iterate (prepare once, apply many).
    fn evaluate(
        &mut self,
        ctx: &StepContext<'_>,
        x: &[Vec3],
        v: &[Vec3],
        force: &mut [Vec3],
        partials: &mut [f64],
    ) -> f64;

    /// Make whatever Hessian data [`Term::evaluate`] at the same (x, v) left for later (a
    /// damped elasticity's shifted tangents): called before the Hessian is first used at an
    /// iterate, never for an iterate Newton stops at. Default: nothing.
    fn linearize(&mut self, _ctx: &StepContext<'_>, _x: &[Vec3], _v: &[Vec3]) {}

    /// The shape of the Hessian at the last evaluation.
    fn hessian_shape(&self, ctx: &StepContext<'_>) -> HessianShape;

    /// `d[i] += w_i` for a [`HessianShape::LumpedDiagonal`] term (the Hessian is diag(w)⊗I₃).
    fn add_lumped_diagonal(&self, _ctx: &StepContext<'_>, _d: &mut [f64]) {}

    /// `out += H·p` for a [`HessianShape::Blocks`] term.
    fn add_hessian_product(&mut self, _ctx: &StepContext<'_>, _p: &[Vec3], _out: &mut [Vec3]) {}

    /// `out[i] += H_ii` (3×3 diagonal blocks) for a [`HessianShape::Blocks`] term.
    fn add_diagonal_blocks(&mut self, _ctx: &StepContext<'_>, _out: &mut [Mat3]) {}

    /// The blocks (i, j) this term's Hessian may fill beyond the mesh's vertex adjacency, in any
    /// order (contact pairs); changes between iterates are noticed through
    /// [`Term::pattern_generation`].
    fn extra_blocks(&self, _out: &mut Vec<(u32, u32)>) {}

    /// A number that changes whenever [`Term::extra_blocks`] does.
    fn pattern_generation(&self) -> u64 {
        0
    }

    /// `a += H` for a [`HessianShape::Blocks`] term (`a`'s pattern holds the term's blocks).
    fn add_to_matrix(&mut self, _ctx: &StepContext<'_>, _a: &mut BlockCsr) {}

    /// Use the exact (true) Hessian instead of the definiteness-projected one, or back.
    fn use_exact(&mut self, _exact: bool) {}

    /// The largest fraction of the move from x to x + dx this term allows (contact: what
    /// continuous collision detection finds free); the line search starts there. Default 1.
    fn max_step(&mut self, _ctx: &StepContext<'_>, _x: &[Vec3], _dx: &[Vec3]) -> f64 {
        1.0
    }

    /// Called once before a step's solve, with Newton's first guess, which the term may change
    /// (contact: moving obstacles placed for the step, the guess cut back to what continuous
    /// collision detection finds free). Default: nothing.
    fn begin_step(&mut self, _start: &StepStart<'_>, _guess: &mut [Vec3]) {}

    /// After a converged solve of the step at x: `Ok(false)` when the term is done with the
    /// step, `Ok(true)` when it moved itself on and the step must be solved again (contact:
    /// moving obstacles pushing the body), `Err(why)` when it cannot go on. Default `Ok(false)`.
    fn continue_step(&mut self, _x: &[Vec3]) -> Result<bool, String> {
        Ok(false)
    }

    /// Add what this term did in the step just solved to its statistics (contact: steps.csv's
    /// contacts, min_distance, contact_energy and friction_dissipation). Default: nothing.
    fn add_stats(&self, _stats: &mut super::stats::StepStats) {}

    /// A residual (N) below which this term's forces cannot be resolved, so that Newton's
    /// absolute floor is raised to it (contact: the tolerance times the loads, a stiff barrier's
    /// rounding being far above a fraction of a small first residual). Default 0.
    fn residual_floor(&mut self, _ctx: &StepContext<'_>) -> f64 {
        0.0
    }

    /// Called once a step after the first evaluation, with the total force there: return true
    /// when the term changed itself and the iterate must be evaluated again (contact: IPC's
    /// balanced barrier stiffness). Default: nothing.
    fn after_first_evaluation(&mut self, _ctx: &StepContext<'_>, _force: &[Vec3]) -> bool {
        false
    }

    /// Whether the Newton step dx is already too small to matter for this term, near
    /// convergence (contact: IPC's rule, a step below 1e-5 bounding-box diagonals per second):
    /// Newton then stops. Default false.
    fn step_converged(&self, _ctx: &StepContext<'_>, _dx: &[Vec3]) -> bool {
        false
    }
}

/// Inertia and mass damping of a dynamic step (see [`super::scheme`]):
/// `½‖x − x̃‖²_M / (τ_v·τ_a) + α‖x − x_still‖²_M / (2τ_v)`, force `M·((ṽ − v)/τ_a − α·v)`,
/// Hessian `(1/(τ_v·τ_a) + α/τ_v)·M` (backward Euler: x̃ = xⁿ + h·vⁿ, x_still = xⁿ, ṽ = vⁿ,
/// τ_v = τ_a = h). Absent (zero) in a quasistatic step.
#[derive(Debug, Default)]
pub struct Inertia;

impl Term for Inertia {
    fn name(&self) -> &'static str {
        "inertia"
    }

    fn evaluate(
        &mut self,
        ctx: &StepContext<'_>,
        x: &[Vec3],
        v: &[Vec3],
        force: &mut [Vec3],
        partials: &mut [f64],
    ) -> f64 {
        let StepKind::Dynamic(step) = ctx.kind else {
            return 0.0;
        };
        let alpha = ctx.params.rayleigh_mass;
        let masses = ctx.body.masses();
        let (base, tau_a) = (step.base_velocity, step.inertia_time);
        force
            .par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(i, f)| *f += masses[i] * ((base[i] - v[i]) / tau_a - alpha * v[i]));
        let (predicted, still) = (step.predicted, step.still);
        let (denominator, tau_v) = (step.inertia_denominator, step.velocity_time);
        ordered_sum(partials, x.len(), |i| {
            let m = masses[i];
            0.5 * m * (x[i] - predicted[i]).norm_squared() / denominator
                + 0.5 * alpha * m * (x[i] - still[i]).norm_squared() / tau_v
        })
    }

    fn hessian_shape(&self, ctx: &StepContext<'_>) -> HessianShape {
        match ctx.kind {
            StepKind::Dynamic(_) => HessianShape::LumpedDiagonal,
            StepKind::Static => HessianShape::Zero,
        }
    }

    fn add_lumped_diagonal(&self, ctx: &StepContext<'_>, d: &mut [f64]) {
        if let StepKind::Dynamic(step) = ctx.kind {
            let scale =
                1.0 / step.inertia_denominator + ctx.params.rayleigh_mass / step.velocity_time;
            for (d, m) in d.iter_mut().zip(ctx.body.masses()) {
                *d += scale * m;
            }
        }
    }
}

/// Elasticity E(x) with Rayleigh stiffness damping: force `f_el(x) − γ·K_d(x)·v` (dynamic
/// steps; K_d the scene's [`crate::material::DampingStiffness`], whatever the definiteness
/// strategy), Hessian `K_n(x̃) + (γ/h)·K_d(x̃)` with `x̃ = x + θ·v` (see
/// [`super::DampingTangent`]; K_n by the strategy). In a damped step with a shift the forces come
/// from [`Term::evaluate`] and the tangents (a second SVD per tet) from [`Term::linearize`], so
/// that iterates Newton stops at never pay for them.
pub struct Elasticity {
    lin: Linearization,
    f_el: Vec<Vec3>,
    kv: Vec<Vec3>,
    scratch: Vec<Vec3>,
    blocks: Vec<Mat3>,
    pattern: BlockPattern,
    work: AssemblyWork,
    energy: f64,
    /// Under MPI (the body is then one rank's part): the forces' completion over the ranks
    /// and the distributed matrix (see [`crate::parallel`]).
    ghosts: Option<crate::parallel::elastic::Ghosts>,
}

impl Elasticity {
    /// Buffers for `body` with tangents made by `definiteness` (`adaptive` keeps the exact
    /// pieces beside the projected ones, see [`Term::use_exact`]).
    pub fn new(body: &ElasticBody, definiteness: Definiteness) -> Self {
        let n = body.vertex_count();
        Elasticity {
            lin: Linearization::new(body, definiteness),
            f_el: vec![Vec3::zeros(); n],
            kv: vec![Vec3::zeros(); n],
            scratch: vec![Vec3::zeros(); n],
            blocks: Vec::new(),
            pattern: body.stiffness_pattern(),
            work: AssemblyWork::default(),
            energy: 0.0,
            ghosts: None,
        }
    }

    /// The elasticity of one rank's part of a distributed body (see [`crate::parallel`]):
    /// forces completed over the ranks, the matrix sent to the ghosts' sink; the Hessian's
    /// pattern the solvers see is the diagonal only.
    pub fn partitioned(
        body: &ElasticBody,
        definiteness: Definiteness,
        ghosts: crate::parallel::elastic::Ghosts,
    ) -> Self {
        let n = body.vertex_count();
        let mut e = Self::new(body, definiteness);
        let diagonal: Vec<Vec<u32>> = (0..n as u32).map(|i| vec![i]).collect();
        e.pattern = BlockPattern::from_rows(&diagonal);
        e.ghosts = Some(ghosts);
        e
    }

    /// The linearization at the last evaluation.
    pub fn linearization(&self) -> &Linearization {
        &self.lin
    }

    /// Its buffers, into a memory inventory.
    pub fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        use crate::memory::vec_bytes;
        self.lin.add_memory(inventory);
        inventory.add(
            "elasticity: per-vertex forces, K·v, scratch, diagonal blocks",
            vec_bytes(&self.f_el)
                + vec_bytes(&self.kv)
                + vec_bytes(&self.scratch)
                + vec_bytes(&self.blocks),
        );
        inventory.add(
            "elasticity: the mesh's block pattern",
            vec_bytes(&self.pattern.row_start) + vec_bytes(&self.pattern.cols),
        );
        inventory.add(
            "assembly: the tets of each chunk of rows",
            self.work.heap_bytes(),
        );
    }

    /// The elastic forces f_el at the last evaluation, N.
    pub fn forces(&self) -> &[Vec3] {
        &self.f_el
    }

    /// K·v at the last evaluation of a dynamic step with γ > 0; stale otherwise.
    pub fn stiffness_velocity(&self) -> &[Vec3] {
        &self.kv
    }

    /// E at the last evaluation, J.
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The mesh's vertex adjacency: the pattern of K.
    pub fn pattern(&self) -> &BlockPattern {
        &self.pattern
    }

    /// `a = (1 + γ/h)·K`: every block of `a` set (see [`ElasticBody::write_stiffness`]).
    pub fn write_matrix(&mut self, ctx: &StepContext<'_>, a: &mut BlockCsr) {
        if let Some(ghosts) = &self.ghosts {
            ghosts.write_matrix(ctx.body, &self.lin, 1.0, ctx.free);
            a.blocks_mut().fill_zero();
            return;
        }
        ctx.body
            .write_stiffness(&self.lin, 1.0, a, &mut self.work, true);
    }

    /// The damping of a dynamic step with γ > 0 at velocities v: the scene's damping stiffness,
    /// and Newton's tangent shifted to x + θ·v with θ = γh/(h + γ) (see [`DampingTangent`]).
    fn damping<'v>(ctx: &StepContext<'_>, v: &'v [Vec3]) -> Damping<'v> {
        let gamma = ctx.stiffness_damping();
        let shift = match (ctx.kind, ctx.params.damping_tangent) {
            (StepKind::Dynamic(step), DampingTangent::Shifted) => step.damping_shift(gamma),
            _ => 0.0,
        };
        let weight = match ctx.kind {
            StepKind::Dynamic(step) => step.damping_weight(gamma),
            StepKind::Static => 0.0,
        };
        Damping {
            velocities: v,
            stiffness: ctx.params.damping_stiffness,
            shift,
            weight,
        }
    }
}

impl Term for Elasticity {
    fn name(&self) -> &'static str {
        "elasticity"
    }

    fn evaluate(
        &mut self,
        ctx: &StepContext<'_>,
        x: &[Vec3],
        v: &[Vec3],
        force: &mut [Vec3],
        _partials: &mut [f64],
    ) -> f64 {
        let body = ctx.body;
        let gamma = ctx.stiffness_damping();
        self.energy = if gamma != 0.0 {
            let damping = Self::damping(ctx, v);
            body.damped_forces_into(x, &damping, &mut self.lin, &mut self.f_el, &mut self.kv)
        } else {
            body.linearize_into(x, &mut self.lin, &mut self.f_el)
        };
        // Distributed: this rank's energy stays its share (Newton sums the shares).
        if let Some(ghosts) = &mut self.ghosts {
            ghosts.complete(&mut self.f_el);
            if gamma != 0.0 {
                ghosts.complete(&mut self.kv);
            }
            if !self.lin.tangents_pending() {
                ghosts.count(&mut self.lin);
            }
        }
        let f_el = &self.f_el;
        if gamma != 0.0 {
            let kv = &self.kv;
            force
                .par_iter_mut()
                .enumerate()
                .with_min_len(CHUNK)
                .for_each(|(i, f)| *f = *f + f_el[i] - gamma * kv[i]);
        } else {
            force
                .par_iter_mut()
                .zip(f_el.par_iter())
                .with_min_len(CHUNK)
                .for_each(|(f, fe)| *f += fe);
        }
        self.energy
    }

    fn linearize(&mut self, ctx: &StepContext<'_>, x: &[Vec3], v: &[Vec3]) {
        if ctx.stiffness_damping() != 0.0 {
            ctx.body
                .damped_tangents_into(x, &Self::damping(ctx, v), &mut self.lin);
            if let Some(ghosts) = &self.ghosts {
                ghosts.count(&mut self.lin);
            }
        }
    }

    fn hessian_shape(&self, _ctx: &StepContext<'_>) -> HessianShape {
        HessianShape::Blocks
    }

    fn add_hessian_product(&mut self, ctx: &StepContext<'_>, p: &[Vec3], out: &mut [Vec3]) {
        ctx.body
            .apply_stiffness(&mut self.lin, p, &mut self.scratch);
        if let Some(ghosts) = &mut self.ghosts {
            ghosts.complete(&mut self.scratch);
        }
        out.par_iter_mut()
            .zip(self.scratch.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(o, s)| *o += s);
    }

    fn add_diagonal_blocks(&mut self, ctx: &StepContext<'_>, out: &mut [Mat3]) {
        self.blocks.resize(out.len(), Mat3::zeros());
        ctx.body
            .stiffness_diagonal_blocks(&self.lin, &mut self.blocks);
        if let Some(ghosts) = &mut self.ghosts {
            ghosts.complete_blocks(&mut self.blocks);
        }
        out.par_iter_mut()
            .zip(self.blocks.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(o, b)| *o += b);
    }

    fn add_to_matrix(&mut self, ctx: &StepContext<'_>, a: &mut BlockCsr) {
        ctx.body.add_stiffness(&self.lin, 1.0, a, &mut self.work);
    }

    fn use_exact(&mut self, exact: bool) {
        self.lin.use_exact(exact);
    }
}

/// Gravity and dead loads, ramped by the boundary's clock: energy `−f_ext·x`, force f_ext.
#[derive(Debug, Default)]
pub struct ExternalForces;

impl Term for ExternalForces {
    fn name(&self) -> &'static str {
        "loads"
    }

    fn evaluate(
        &mut self,
        ctx: &StepContext<'_>,
        x: &[Vec3],
        _v: &[Vec3],
        force: &mut [Vec3],
        partials: &mut [f64],
    ) -> f64 {
        let f_ext = ctx.f_ext;
        force
            .par_iter_mut()
            .zip(f_ext.par_iter())
            .with_min_len(CHUNK)
            .for_each(|(f, fe)| *f += fe);
        -ordered_sum(partials, x.len(), |i| f_ext[i].dot(&x[i]))
    }

    fn hessian_shape(&self, _ctx: &StepContext<'_>) -> HessianShape {
        HessianShape::Zero
    }
}
