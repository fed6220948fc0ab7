//! One time step (or load step) as Newton's method on the SPEC §4 system.
//!
//! **Backward Euler** with Rayleigh damping `f_d = −αMv − γK(x)v`, from (xⁿ, vⁿ) over h: starting
//! from `x₀ = xⁿ + h·vⁿ` (constrained components at their prescribed values) and keeping
//! `v_k = (x_k − xⁿ)/h`, each iterate solves
//!
//! ```text
//! [ (1 + γ/h)·K(x_k) + (1/h² + α/h)·M ] dx = (1/h)·M(vⁿ − v_k) + f_el(x_k) − γ·K(x_k)·v_k − α·M·v_k + f_ext
//! ```
//!
//! on the free degrees of freedom, then `x_{k+1} = x_k + dx`. K(x_k) in the damping term makes it
//! a modified Newton method; at convergence it is the exact backward-Euler step.
//!
//! **Quasistatic** (no inertia): `K(x_k)·dx = f_el(x_k) + f_ext`, loads ramped over load steps.
//!
//! Convergence: `‖rhs‖ ≤ newton_tolerance·‖rhs₀‖` over free DOFs (relative to the step's first
//! residual), or below an absolute floor of 1e-12 of the body's characteristic force E·ℓ²·√n,
//! so that a body at rest takes zero iterations.
//!
//! **Line search.** When γ = 0 the system is the gradient of the incremental potential
//! `Φ(x) = ½‖x − xⁿ − h·vⁿ‖²_M / h² + α‖x − xⁿ‖²_M / (2h) + E(x) − f_ext·x` (just `E − f_ext·x`
//! when quasistatic), and a step is accepted when Φ falls (Armijo, c = 1e-4) or the residual at
//! least halves (Φ's differences drown in rounding near convergence). With γ > 0 there is no
//! potential and the merit is ‖rhs‖. Rejected steps are halved up to [`MAX_LINE_SEARCH_CUTS`]
//! times.

use std::time::Instant;

use rayon::prelude::*;

use crate::amg::{Amg, AmgParams};
use crate::cg::{
    self, BlockJacobi, CgError, CgInfo, CgParams, CgWorkspace, Jacobi, LinearOperator,
    Preconditioner, conjugate_gradient,
};
use crate::elastic::{AssemblyWork, ElasticBody, Linearization};
use crate::material::Definiteness;
use crate::math::{Mat3, Vec3};
use crate::sparse::{BlockCsr, UpperF32};

/// Step halvings the line search tries before giving up on a Newton direction.
pub const MAX_LINE_SEARCH_CUTS: usize = 8;

/// Vertices per parallel chunk in the vector updates; fixed so sums are deterministic.
const CHUNK: usize = 2048;

/// What is integrated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// Backward (implicit) Euler in time, SPEC §4.
    #[default]
    BackwardEuler,
    /// Static equilibrium under loads ramped over load steps.
    Quasistatic,
}

/// What to do when a step does not converge (SPEC §9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OnFailure {
    /// Keep the unconverged (but finite) result, flag it in steps.csv and go on.
    Continue,
    /// Redo the frame with twice the substeps (load increments), up to `max_step_cuts` times;
    /// if it still fails, continue as above with the best finite result.
    #[default]
    Retry,
    /// Stop the run with an error (non-zero exit); frames written so far stay valid.
    Stop,
}

/// The preconditioner of the linear solves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PreconditionerKind {
    /// None (plain CG), for experiments.
    Identity,
    /// Diagonal of A.
    Jacobi,
    /// Inverse of each vertex's 3×3 diagonal block of A.
    BlockJacobi,
    /// Smoothed-aggregation algebraic multigrid ([`crate::amg`]) on the assembled A, one V-cycle
    /// per CG iteration; CG then multiplies with the assembled A too.
    #[default]
    Amg,
    /// Sparse Cholesky of the assembled A ([`crate::direct`], feature `direct`), kept across
    /// Newton iterations while CG converges fast (see `cholesky_reuse`).
    #[cfg(feature = "direct")]
    Cholesky,
}

/// Every solver setting, with its unit and default (built by the scene from `[solver]`).
#[derive(Clone, Debug, PartialEq)]
pub struct SolverParams {
    /// Backward Euler (default) or quasistatic.
    pub integrator: Integrator,
    /// Seconds per frame (backward Euler). Default 1/30 s.
    pub dt: f64,
    /// Frames (backward Euler) or load steps (quasistatic). Default 60.
    pub frames: usize,
    /// Time steps (load increments) per frame. Default 1.
    pub substeps: usize,
    /// Rayleigh stiffness damping γ, seconds: f_d = −γK(x)v. Default 0.
    pub rayleigh_stiffness: f64,
    /// Rayleigh mass damping α, 1/s: f_d = −αMv. Default 0.
    pub rayleigh_mass: f64,
    /// Newton stops at ‖rhs‖ ≤ this × the step's first ‖rhs‖. Default 1e-6.
    pub newton_tolerance: f64,
    /// Newton iteration cap per step. Default 20.
    pub newton_max_iterations: usize,
    /// CG tolerance (relative to ‖rhs‖) and cap. Defaults 1e-6 and 2000.
    pub cg: CgParams,
    /// Definiteness treatment of K. Default Adaptive: Teran's projection, with the exact tangent
    /// once projected Newton stalls (see [`Definiteness::Adaptive`]).
    pub definiteness: Definiteness,
    /// Preconditioner. Default AMG on the assembled system: on the default cantilever (3,000
    /// tets, 60 frames) 1,055 CG iterations in all against Jacobi's 8,725 and 1.4 s against 2.7 s
    /// of CPU; 7–10× faster per frame than Jacobi at 41,472 and 192,000 tets (see the README).
    /// Among the matrix-free ones Jacobi beats block Jacobi (122 against 129 CG iterations per
    /// Newton iteration on the default beam, 272 against 303 at 41,472 tets). The sparse Cholesky
    /// (feature `direct`, factor kept) ran the bench beam in 0.054 s/frame against AMG's 0.085
    /// at 5,184 tets but 1.71 against 0.82 at 41,472 tets: AMG stays the default.
    pub preconditioner: PreconditionerKind,
    /// Settings of the AMG preconditioner (used when `preconditioner` is `Amg`).
    pub amg: AmgParams,
    /// Backtracking line search on (default) or off.
    pub line_search: bool,
    /// Inexact Newton: each CG solve only as tight as Newton's progress warrants (Eisenstat-
    /// Walker forcing terms between 0.1 and `cg.tolerance`). Default on.
    pub inexact_newton: bool,
    /// With the AMG preconditioner, CG multiplies with the upper triangle of A stored in f32
    /// (f64 vectors and sums) instead of the full f64 matrix: a third of the bytes per product.
    /// Newton and CG iteration counts are unchanged on the issue-8 beams. Default false (see
    /// the README's speed section for the measurement).
    pub f32_matrix: bool,
    /// With the Cholesky preconditioner: keep the factor across Newton iterations and frames and
    /// refactor when CG needs more than [`CHOLESKY_REFACTOR_RATE`] iterations per decade (or the
    /// factorization failed, or the constrained DOFs changed); false factors at every Newton
    /// iterate. Default true.
    pub cholesky_reuse: bool,
    /// Failure policy. Default Retry.
    pub on_failure: OnFailure,
    /// How many times Retry may halve the step. Default 4 (16× substeps).
    pub max_step_cuts: usize,
}

impl Default for SolverParams {
    fn default() -> Self {
        SolverParams {
            integrator: Integrator::BackwardEuler,
            dt: 1.0 / 30.0,
            frames: 60,
            substeps: 1,
            rayleigh_stiffness: 0.0,
            rayleigh_mass: 0.0,
            newton_tolerance: 1e-6,
            newton_max_iterations: 20,
            cg: CgParams::default(),
            definiteness: Definiteness::Adaptive,
            preconditioner: PreconditionerKind::Amg,
            amg: AmgParams::default(),
            line_search: true,
            inexact_newton: true,
            f32_matrix: false,
            cholesky_reuse: true,
            on_failure: OnFailure::Retry,
            max_step_cuts: 4,
        }
    }
}

/// The problem one Newton solve works on.
#[derive(Clone, Copy, Debug)]
pub enum StepKind<'a> {
    /// Backward Euler from (xⁿ, vⁿ) over h seconds.
    Dynamic {
        /// Positions at the start of the step.
        xn: &'a [Vec3],
        /// Velocities at the start of the step.
        vn: &'a [Vec3],
        /// Step length, s.
        h: f64,
    },
    /// Static equilibrium.
    Static,
}

/// What one Newton solve did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NewtonInfo {
    /// Newton iterations (linear solves).
    pub iterations: usize,
    /// CG iterations summed over the solves.
    pub cg_iterations: usize,
    /// Final ‖rhs‖ over free DOFs, N.
    pub residual: f64,
    /// Final ‖rhs‖ / first ‖rhs‖ (0 when the first was already below the floor).
    pub relative_residual: f64,
    /// Whether the tolerance was met.
    pub converged: bool,
    /// Line-search halvings taken.
    pub line_search_cuts: usize,
    /// CG solves that broke down (pᵀAp ≤ 0): the step then used the iterate so far.
    pub cg_breakdowns: usize,
    /// CG solves that hit their iteration cap.
    pub cg_capped: usize,
    /// Most tets with a clamped tangent at any iterate.
    pub clamped_tets: usize,
    /// `adaptive` definiteness: Newton iterates whose exact-tangent direction was given up for
    /// the projected one (CG met negative curvature, no descent, or the line search failed).
    pub projected_fallbacks: usize,
    /// Elastic energy at the final iterate, J.
    pub elastic_energy: f64,
    /// Why it stopped without converging, in words.
    pub failure: Option<String>,
    /// ‖rhs‖ at every iterate, first to last (for convergence studies).
    pub history: Vec<f64>,
    /// Where the time went.
    pub timings: Timings,
}

/// Wall-clock seconds by phase, for `tetsim bench` and tuning.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    /// Forces, energy and tangents (one SVD per tet per evaluation, line-search trials included).
    pub evaluate: f64,
    /// Preconditioner setup (and matrix assembly, on assembled paths).
    pub preconditioner: f64,
    /// Conjugate gradient.
    pub cg: f64,
}

impl Timings {
    /// Add another's times.
    pub fn add(&mut self, other: &Timings) {
        self.evaluate += other.evaluate;
        self.preconditioner += other.preconditioner;
        self.cg += other.cg;
    }
}

/// `A = k·K + m·M` over a linearization: the Newton system as a CG operator.
struct SystemMatrix<'a> {
    body: &'a ElasticBody,
    lin: &'a mut Linearization,
    k_scale: f64,
    m_scale: f64,
}

impl LinearOperator for SystemMatrix<'_> {
    fn len(&self) -> usize {
        self.body.vertex_count()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.body.apply_stiffness(self.lin, p, out);
        let (k, m) = (self.k_scale, self.m_scale);
        let masses = self.body.masses();
        out.par_iter_mut()
            .zip(p.par_iter().zip(masses.par_iter()))
            .with_min_len(CHUNK)
            .for_each(|(o, (p, &mass))| *o = k * *o + (m * mass) * p);
    }
}

/// The assembled A as a CG operator.
struct AssembledMatrix<'a>(&'a BlockCsr);

impl LinearOperator for AssembledMatrix<'_> {
    fn len(&self) -> usize {
        self.0.rows()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.0.multiply(p, out);
    }
}

struct UpperMatrix<'a>(&'a mut UpperF32);

impl LinearOperator for UpperMatrix<'_> {
    fn len(&self) -> usize {
        self.0.rows()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.0.multiply(p, out);
    }
}

/// The AMG hierarchy is refreshed (numbers recomputed on the kept aggregates) when CG needed more
/// than this factor times the iterations per decade of residual reduction of the first solve
/// after the last refresh. Iterations per decade, not per solve: inexact Newton asks for a
/// loose 0.1 early in a step and a tight tolerance at its end, so raw counts say nothing about
/// the preconditioner's quality. With fixed tolerances, refreshing on 1.5× growth took 0.41 s
/// per frame on the 41,472-tet cantilever against 0.46 s refreshing at every Newton iterate and
/// 0.76 s never refreshing: a refresh costs about two solves' worth of CG iterations.
const AMG_REFRESH_GROWTH: f64 = 1.5;

/// A kept Cholesky factor is refreshed once CG needed more than this many iterations per decade
/// of residual reduction (a fresh factor takes one iteration for the whole solve). Measured on
/// the bench cantilever (s/frame, 30 frames) for thresholds 1, 2, 4, 8: 0.071, 0.058, 0.065,
/// 0.070 at 5,184 tets and 1.48, 1.04, 1.18, 1.71 at 41,472 tets (0.8, 0.27, 0.13, 0.07
/// factorizations per frame); never refactoring leaves CG at 8.7 iterations per Newton iteration
/// and 0.098 s/frame at 5,184 tets. Unlike AMG's rule this one is absolute: a fresh factor's rate
/// (≈ 0.1) is no baseline to grow from.
#[cfg(feature = "direct")]
pub const CHOLESKY_REFACTOR_RATE: f64 = 2.0;

/// The preconditioner of the assembled path.
enum OnAssembled {
    /// Built at the first solve, refreshed on the AMG rule.
    Amg(Option<Box<Amg>>),
    /// Factored at the first solve, refactored on the Cholesky rule.
    #[cfg(feature = "direct")]
    Cholesky {
        factor: Box<crate::direct::Cholesky>,
        reuse: bool,
        /// The free mask the factor was made with.
        free: Vec<Vec3>,
    },
}

impl OnAssembled {
    /// The preconditioner prepared last.
    fn as_dyn(&mut self) -> &mut dyn Preconditioner {
        match self {
            OnAssembled::Amg(amg) => &mut **amg.as_mut().expect("prepared before use"),
            #[cfg(feature = "direct")]
            OnAssembled::Cholesky { factor, .. } => &mut **factor,
        }
    }
}

/// The assembled path: `A = k·K + m·M` as a block matrix (constrained), the AMG hierarchy or the
/// Cholesky factor on it, and when to refresh them. CG multiplies with the assembled f64 matrix: on
/// the 5,184-tet cantilever it ran the frame in 0.057 s against 0.103 s with the matrix-free
/// product (same CG iterations).
struct Assembled {
    a: BlockCsr,
    /// The f32 upper triangle CG multiplies with when `cg_f32` is set.
    upper: Option<UpperF32>,
    work: AssemblyWork,
    precond: OnAssembled,
    params: AmgParams,
    /// CG iterations per decade of residual reduction: of the first solve after the last build
    /// or refresh, and of the last solve.
    baseline_rate: Option<f64>,
    last_rate: f64,
    /// Whether the last CG solve stopped at its iteration cap.
    last_capped: bool,
}

impl Assembled {
    fn new(body: &ElasticBody, params: &SolverParams) -> Self {
        let precond = match params.preconditioner {
            #[cfg(feature = "direct")]
            PreconditionerKind::Cholesky => OnAssembled::Cholesky {
                factor: Box::default(),
                reuse: params.cholesky_reuse,
                free: Vec::new(),
            },
            _ => OnAssembled::Amg(None),
        };
        Assembled {
            a: BlockCsr::zeros(body.stiffness_pattern()),
            upper: params.f32_matrix.then(UpperF32::default),
            work: AssemblyWork::default(),
            precond,
            params: params.amg.clone(),
            baseline_rate: None,
            last_rate: 0.0,
            last_capped: false,
        }
    }

    /// Assemble and constrain A at the current linearization, then build the AMG (first call;
    /// near-nullspace from the rest positions) or refresh it (when CG iterations grew), or
    /// (re)factor A.
    fn prepare(
        &mut self,
        body: &ElasticBody,
        lin: &Linearization,
        k_scale: f64,
        m_scale: f64,
        free: &[Vec3],
    ) {
        let started = Instant::now();
        body.assemble_system(lin, k_scale, m_scale, &mut self.a, &mut self.work);
        self.a.constrain(free);
        if let Some(upper) = &mut self.upper {
            upper.fill_from(&self.a);
        }
        let assembled = Instant::now();
        // One iteration of slack per decade, so that 2 → 4 iterations does not count as growth.
        let stale = self
            .baseline_rate
            .is_some_and(|b| self.last_rate > AMG_REFRESH_GROWTH * b + 1.0);
        // The hierarchy's numbers only ever come from a projected (positive semi-definite) A:
        // built or refreshed on the exact tangent of `adaptive`, which may be indefinite, its
        // Chebyshev smoothers and coarse factor stop being positive definite, and CG on the
        // projected A that follows broke down at every Newton iterate (a tangled ball, frame 43:
        // 147 breakdowns and no convergence, against none with the hierarchy kept). The exact A
        // is preconditioned with the hierarchy of the projected one.
        let exact = lin.exact_in_use();
        match &mut self.precond {
            OnAssembled::Amg(amg @ None) => {
                *amg = Some(Box::new(Amg::new(
                    &self.a,
                    &body.mesh.positions,
                    free,
                    &self.params,
                )))
            }
            // A solve that ran into the CG cap says the hierarchy no longer fits A at all, not
            // that it aged: a body started collapsed onto a line builds its aggregates from
            // that degenerate A, and the growth rule never fires when the first solve is
            // already capped (a 3,560-tet ball: 2,000 CG iterations at every Newton iterate,
            // minutes per frame). Aggregates and numbers are rebuilt from the current A.
            OnAssembled::Amg(Some(amg)) if self.last_capped && !exact => {
                **amg = Amg::new(&self.a, &body.mesh.positions, free, &self.params);
                self.baseline_rate = None;
                self.last_capped = false;
            }
            OnAssembled::Amg(Some(amg)) if stale && !exact => {
                amg.refresh(&self.a);
                self.baseline_rate = None;
            }
            OnAssembled::Amg(Some(_)) => {}
            #[cfg(feature = "direct")]
            OnAssembled::Cholesky {
                factor,
                reuse,
                free: factored_free,
            } => {
                if !*reuse
                    || !factor.is_factored()
                    || self.last_rate > CHOLESKY_REFACTOR_RATE
                    || factored_free.as_slice() != free
                {
                    factored_free.clear();
                    factored_free.extend_from_slice(free);
                    self.last_rate = 0.0;
                    if let Err(e) = factor.factorize(&self.a) {
                        log::debug!("{e}; block Jacobi for this solve");
                    }
                }
            }
        }
        log::debug!(
            "assembly {:.4} s, preconditioner {:.4} s",
            assembled.duration_since(started).as_secs_f64(),
            assembled.elapsed().as_secs_f64()
        );
    }

    /// Note a CG solve's iterations per decade of reduction (for the refresh rules).
    fn record(&mut self, info: &CgInfo) {
        let decades = (-info.relative_residual.max(1e-300).log10()).max(0.25);
        self.last_rate = info.iterations as f64 / decades;
        self.last_capped = !info.converged;
        self.baseline_rate.get_or_insert(self.last_rate);
    }
}

/// The active preconditioner, refilled each Newton iterate.
enum Precond {
    Identity(cg::Identity),
    Jacobi(Jacobi),
    BlockJacobi(BlockJacobi),
    /// AMG or Cholesky on the assembled A.
    Assembled(Box<Assembled>),
}

impl Precond {
    fn as_dyn(&mut self) -> &mut dyn Preconditioner {
        match self {
            Precond::Identity(p) => p,
            Precond::Jacobi(p) => p,
            Precond::BlockJacobi(p) => p,
            Precond::Assembled(p) => p.precond.as_dyn(),
        }
    }
}

/// `adaptive` definiteness tries the exact tangent once an iterate with the projected one
/// reduced the residual by less than this factor: projection makes Newton linear, and a rate
/// this slow means it is stalling. 0.6 leaves every sample scene exactly as `teran` runs it
/// (their projected iterates contract faster) while the ν = 0.49 cantilever at dt = 1 s converges
/// in 19 Newton iterations instead of failing after 243; 0.1 and 0.3 used the exact tangent on
/// the squash scenes too, where it took up to 46 % more Newton iterations (compression makes the
/// exact Hessian a poor model there).
const ADAPTIVE_STALL_RATIO: f64 = 0.6;

/// Newton's method with its preallocated workspace (one per simulation).
pub struct Newton {
    lin: Linearization,
    f_el: Vec<Vec3>,
    rhs: Vec<Vec3>,
    dx: Vec<Vec3>,
    kv: Vec<Vec3>,
    x_start: Vec<Vec3>,
    blocks: Vec<Mat3>,
    precond: Precond,
    cg: CgWorkspace,
    partials: Vec<f64>,
    timings: Timings,
    /// Whether a failed ‖rhs‖ line search may fall back on the potential (see
    /// [`Newton::set_last_resort`]).
    last_resort: bool,
}

/// Merit and residual of one evaluated iterate.
#[derive(Clone, Copy, Debug)]
struct Evaluation {
    energy: f64,
    potential: f64,
    residual: f64,
}

impl Newton {
    /// Workspace for `body`.
    pub fn new(body: &ElasticBody, params: &SolverParams) -> Self {
        let n = body.vertex_count();
        let precond = match params.preconditioner {
            PreconditionerKind::Identity => Precond::Identity(cg::Identity),
            PreconditionerKind::Jacobi => Precond::Jacobi(Jacobi::default()),
            PreconditionerKind::BlockJacobi => Precond::BlockJacobi(BlockJacobi::default()),
            PreconditionerKind::Amg => Precond::Assembled(Box::new(Assembled::new(body, params))),
            #[cfg(feature = "direct")]
            PreconditionerKind::Cholesky => {
                Precond::Assembled(Box::new(Assembled::new(body, params)))
            }
        };
        Newton {
            lin: Linearization::new(body, params.definiteness),
            f_el: vec![Vec3::zeros(); n],
            rhs: vec![Vec3::zeros(); n],
            dx: vec![Vec3::zeros(); n],
            kv: vec![Vec3::zeros(); n],
            x_start: vec![Vec3::zeros(); n],
            blocks: vec![Mat3::zeros(); n],
            precond,
            cg: CgWorkspace::new(n),
            partials: vec![0.0; n.div_ceil(CHUNK).max(1)],
            timings: Timings::default(),
            last_resort: true,
        }
    }

    /// The linearization at the last evaluated iterate (for diagnostics).
    pub fn linearization(&self) -> &Linearization {
        &self.lin
    }

    /// Bytes one CG iteration's operator and preconditioner move (a traffic model for roofline
    /// figures): the matrix-free product's data, or on the assembled path the block matrix
    /// (72-byte blocks plus a 4-byte column index) and the V-cycle's matrices — each level read
    /// 2·degree + 1 times (Chebyshev pre- and post-smoothing and the residual), 8 bytes per
    /// stored entry plus its index share.
    pub fn bytes_per_cg_iteration(&self, body: &ElasticBody) -> f64 {
        match &self.precond {
            Precond::Assembled(assembled) => {
                let a = &assembled.a;
                let matrix = match &assembled.upper {
                    Some(upper) => upper.matrix_bytes() as f64,
                    None => (a.pattern.blocks() * (72 + 4) + 4 * (a.rows() + 1)) as f64,
                };
                let preconditioner = match &assembled.precond {
                    OnAssembled::Amg(amg) => amg.as_ref().map_or(0.0, |amg| {
                        let reads = (2 * assembled.params.smoother_degree + 1) as f64;
                        amg.info()
                            .levels
                            .iter()
                            .map(|l| {
                                reads
                                    * l.nonzeros as f64
                                    * (8.0 + 4.0 / (l.block_size * l.block_size) as f64)
                            })
                            .sum::<f64>()
                    }),
                    // L read twice (forward and backward), 8 bytes an entry; its supernodal
                    // row indices are a small share and left out.
                    #[cfg(feature = "direct")]
                    OnAssembled::Cholesky { factor, .. } => 16.0 * factor.info().l_nonzeros as f64,
                };
                matrix + preconditioner
            }
            _ => body.matrix_free_bytes_per_product(),
        }
    }

    /// The sparse Cholesky's costs and counts, when it is the preconditioner.
    #[cfg(feature = "direct")]
    pub fn cholesky_info(&self) -> Option<&crate::direct::CholeskyInfo> {
        match &self.precond {
            Precond::Assembled(assembled) => match &assembled.precond {
                OnAssembled::Cholesky { factor, .. } => Some(factor.info()),
                _ => None,
            },
            _ => None,
        }
    }

    /// The elastic forces f_el at the last evaluated iterate (the step's result after
    /// [`Newton::solve`]), N.
    pub fn elastic_forces(&self) -> &[Vec3] {
        &self.f_el
    }

    /// K·v at the last evaluated iterate of a dynamic step with γ > 0 (the damping force is
    /// −γ·K·v); stale otherwise.
    pub fn stiffness_velocity(&self) -> &[Vec3] {
        &self.kv
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
    /// `f_ext` are the external forces at the end of the step, `free` the 0/1 DOF mask.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        body: &ElasticBody,
        kind: StepKind<'_>,
        f_ext: &[Vec3],
        free: &[Vec3],
        params: &SolverParams,
        x: &mut [Vec3],
        v: &mut [Vec3],
    ) -> NewtonInfo {
        let mut info = NewtonInfo {
            // One allocation per step, none per iteration.
            history: Vec::with_capacity(params.newton_max_iterations + 1),
            ..Default::default()
        };
        self.timings = Timings::default();
        let floor = absolute_floor(body);
        let (k_scale, m_scale) = match kind {
            StepKind::Dynamic { h, .. } => (
                1.0 + params.rayleigh_stiffness / h,
                1.0 / (h * h) + params.rayleigh_mass / h,
            ),
            StepKind::Static => (1.0, 0.0),
        };
        let mut eval = self.evaluate(body, kind, f_ext, free, params, x, v);
        let first = eval.residual;
        let mut eta = FORCING_MAX;
        info.clamped_tets = self.lin.clamped_tets();
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
            if eval.residual <= floor || eval.residual <= params.newton_tolerance * first {
                info.converged = true;
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
            eta = forcing_term(params, &info.history, eta, first, floor);
            let cg_params = CgParams {
                tolerance: eta,
                max_iterations: params.cg.max_iterations,
            };
            // `adaptive`: the exact tangent once the projected one converges slowly.
            let slow = match info.history.as_slice() {
                [.., before, last] => *last > ADAPTIVE_STALL_RATIO * before,
                _ => false,
            };
            // Never while a tet is inverted: from tangled starts the exact Hessian leads to
            // folded minima (2–2.6 edge lengths from rest where `teran` recovers).
            let mut exact = self.lin.definiteness() == Definiteness::Adaptive
                && self.lin.clamped_tets() > 0
                && self.lin.inverted_tets() == 0
                && slow;
            self.lin.use_exact(exact);
            let breakdowns = info.cg_breakdowns;
            self.solve_linear(body, k_scale, m_scale, free, &cg_params, &mut info);
            if exact && (info.cg_breakdowns > breakdowns || !self.is_descent(kind, params)) {
                log::debug!(
                    "Newton {}: exact tangent gave no descent; projected",
                    info.iterations
                );
                info.cg_breakdowns = breakdowns;
                info.projected_fallbacks += 1;
                exact = false;
                self.lin.use_exact(false);
                self.solve_linear(body, k_scale, m_scale, free, &cg_params, &mut info);
            }
            let mut searched =
                self.line_search(body, kind, f_ext, free, params, x, v, eval, &mut info);
            if searched.is_none() && exact {
                // The line search re-evaluated x: its linearization is projected again.
                log::debug!(
                    "Newton {}: line search failed on the exact tangent; projected",
                    info.iterations
                );
                info.projected_fallbacks += 1;
                self.solve_linear(body, k_scale, m_scale, free, &cg_params, &mut info);
                searched = self.line_search(body, kind, f_ext, free, params, x, v, eval, &mut info);
            }
            match searched {
                Some(next) => {
                    log::debug!(
                        "Newton {}: residual {:.3e} → {:.3e}, {} CG, {} line-search cuts",
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
            info.clamped_tets = info.clamped_tets.max(self.lin.clamped_tets());
        }
        info.timings = self.timings;
        info
    }

    /// dx = A⁻¹·rhs by preconditioned CG (A from the current linearization).
    fn solve_linear(
        &mut self,
        body: &ElasticBody,
        k_scale: f64,
        m_scale: f64,
        free: &[Vec3],
        cg_params: &CgParams,
        info: &mut NewtonInfo,
    ) {
        let started = Instant::now();
        if matches!(self.precond, Precond::Jacobi(_) | Precond::BlockJacobi(_)) {
            body.stiffness_diagonal_blocks(&self.lin, &mut self.blocks);
            let masses = body.masses();
            self.blocks
                .par_iter_mut()
                .zip(masses.par_iter())
                .with_min_len(CHUNK)
                .for_each(|(b, &m)| *b = k_scale * *b + Mat3::from_diagonal_element(m_scale * m));
        }
        match &mut self.precond {
            Precond::Identity(_) => {}
            Precond::Jacobi(p) => p.set_from_blocks(&self.blocks),
            Precond::BlockJacobi(p) => p.set_from_blocks(&self.blocks),
            Precond::Assembled(assembled) => {
                assembled.prepare(body, &self.lin, k_scale, m_scale, free)
            }
        }
        self.dx.iter_mut().for_each(|d| *d = Vec3::zeros());
        let cg_started = Instant::now();
        self.timings.preconditioner += cg_started.duration_since(started).as_secs_f64();
        let result = match &mut self.precond {
            Precond::Assembled(assembled) => {
                let Assembled {
                    a, precond, upper, ..
                } = &mut **assembled;
                let m = precond.as_dyn();
                match upper {
                    Some(upper) => conjugate_gradient(
                        &mut UpperMatrix(upper),
                        m,
                        &self.rhs,
                        &mut self.dx,
                        free,
                        cg_params,
                        &mut self.cg,
                    ),
                    None => conjugate_gradient(
                        &mut AssembledMatrix(a),
                        m,
                        &self.rhs,
                        &mut self.dx,
                        free,
                        cg_params,
                        &mut self.cg,
                    ),
                }
            }
            precond => conjugate_gradient(
                &mut SystemMatrix {
                    body,
                    lin: &mut self.lin,
                    k_scale,
                    m_scale,
                },
                precond.as_dyn(),
                &self.rhs,
                &mut self.dx,
                free,
                cg_params,
                &mut self.cg,
            ),
        };
        self.timings.cg += cg_started.elapsed().as_secs_f64();
        if let Precond::Assembled(assembled) = &mut self.precond {
            assembled.record(match &result {
                Ok(i) => i,
                Err(
                    CgError::NotPositiveDefinite { info, .. } | CgError::NonFinite { info, .. },
                ) => info,
            });
        }
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
                let useless = self.dx.iter().all(|d| *d == Vec3::zeros())
                    || self.dx.iter().any(|d| !d.iter().all(|c| c.is_finite()));
                if useless {
                    self.precond.as_dyn().apply(&self.rhs, &mut self.dx);
                    cg::project(&mut self.dx, free);
                }
            }
        }
    }

    /// Whether dx points downhill: for the incremental potential (γ = 0 or quasistatic) its
    /// slope ∇Φ·dx = −rhs·dx must be negative. With γ > 0 there is no potential and the line
    /// search on ‖rhs‖ is the judge.
    fn is_descent(&mut self, kind: StepKind<'_>, params: &SolverParams) -> bool {
        let potential_merit = params.rayleigh_stiffness == 0.0 || matches!(kind, StepKind::Static);
        !potential_merit || cg::dot(&self.rhs, &self.dx, &mut self.partials) > 0.0
    }

    /// Backtracking along dx from x; evaluates (and so re-linearizes at) each trial point.
    #[allow(clippy::too_many_arguments)]
    fn line_search(
        &mut self,
        body: &ElasticBody,
        kind: StepKind<'_>,
        f_ext: &[Vec3],
        free: &[Vec3],
        params: &SolverParams,
        x: &mut [Vec3],
        v: &mut [Vec3],
        current: Evaluation,
        info: &mut NewtonInfo,
    ) -> Option<Evaluation> {
        self.x_start.copy_from_slice(x);
        let slope = -cg::dot(&self.rhs, &self.dx, &mut self.partials); // ∇Φ·dx
        let potential_merit = params.rayleigh_stiffness == 0.0 || matches!(kind, StepKind::Static);
        let mut alpha = 1.0;
        let mut best: Option<(f64, f64)> = None; // (merit, alpha)
        // With γ > 0, the largest step on which the undamped incremental potential met Armijo.
        let mut downhill: Option<(usize, f64)> = None; // (cut, alpha)
        for cut in 0..=MAX_LINE_SEARCH_CUTS {
            set_axpy(x, &self.x_start, alpha, &self.dx);
            let trial = self.evaluate(body, kind, f_ext, free, params, x, v);
            let finite = trial.residual.is_finite() && trial.potential.is_finite();
            let accepted = finite
                && if !params.line_search {
                    true
                } else if potential_merit {
                    let scale = 1e-12 * (current.potential.abs() + current.energy.abs());
                    trial.potential <= current.potential + 1e-4 * alpha * slope + scale
                        || trial.residual <= 0.5 * current.residual
                } else {
                    trial.residual <= (1.0 - 1e-4 * alpha) * current.residual
                };
            if accepted {
                info.line_search_cuts += cut;
                return Some(trial);
            }
            let merit = if potential_merit {
                trial.potential
            } else {
                trial.residual
            };
            if finite && best.is_none_or(|(m, _)| merit < m) {
                best = Some((merit, alpha));
            }
            if finite
                && !potential_merit
                && self.last_resort
                && info.iterations == 1
                && downhill.is_none()
                && slope < 0.0
                && trial.potential <= current.potential + 1e-4 * alpha * slope
            {
                downhill = Some((cut, alpha));
            }
            alpha *= 0.5;
        }
        if let Some((cut, alpha)) = downhill {
            // ‖rhs‖ cannot fall where the forces jump: at a collapsed tet (F = 0, every vertex
            // of a body on one point) the energy is a cone and any step changes the forces by a
            // finite amount. The potential without the damping term still falls along dx (it
            // is the energy the damping only dissipates), so the step is taken on its word. Only
            // where the step would otherwise not move at all (first iterate, last attempt): a
            // frozen state fails the same way at every later frame, while elsewhere a smaller
            // step is the better cure (taking this step at every failed search sent a corotated
            // beam from a jittered line into a folded minimum, 2.9 edges from rest).
            info.line_search_cuts += cut;
            set_axpy(x, &self.x_start, alpha, &self.dx);
            return Some(self.evaluate(body, kind, f_ext, free, params, x, v));
        }
        info.line_search_cuts += MAX_LINE_SEARCH_CUTS;
        // Nothing acceptable: take the best finite trial if it improved at all, else give up.
        let current_merit = if potential_merit {
            current.potential
        } else {
            current.residual
        };
        match best {
            Some((merit, alpha)) if merit < current_merit => {
                set_axpy(x, &self.x_start, alpha, &self.dx);
                Some(self.evaluate(body, kind, f_ext, free, params, x, v))
            }
            _ => {
                x.copy_from_slice(&self.x_start);
                self.evaluate(body, kind, f_ext, free, params, x, v);
                None
            }
        }
    }

    /// Linearize at x, fill `self.rhs` (masked) and `v` (dynamic), and return the merits.
    #[allow(clippy::too_many_arguments)]
    fn evaluate(
        &mut self,
        body: &ElasticBody,
        kind: StepKind<'_>,
        f_ext: &[Vec3],
        free: &[Vec3],
        params: &SolverParams,
        x: &[Vec3],
        v: &mut [Vec3],
    ) -> Evaluation {
        let started = Instant::now();
        let energy = body.linearize_into(x, &mut self.lin, &mut self.f_el);
        let masses = body.masses();
        let work = ordered_sum(&mut self.partials, x.len(), |i| f_ext[i].dot(&x[i]));
        let mut potential = energy - work;
        match kind {
            StepKind::Dynamic { xn, vn, h } => {
                let (gamma, alpha) = (params.rayleigh_stiffness, params.rayleigh_mass);
                v.par_iter_mut()
                    .zip(x.par_iter().zip(xn.par_iter()))
                    .with_min_len(CHUNK)
                    .for_each(|(v, (x, xn))| *v = (x - xn) / h);
                if gamma != 0.0 {
                    body.apply_stiffness(&mut self.lin, v, &mut self.kv);
                }
                let kv = &self.kv;
                let f_el = &self.f_el;
                self.rhs
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(CHUNK)
                    .for_each(|(i, r)| {
                        let damping = if gamma != 0.0 {
                            gamma * kv[i]
                        } else {
                            Vec3::zeros()
                        };
                        let inertia = masses[i] * ((vn[i] - v[i]) / h - alpha * v[i]);
                        *r = (inertia + f_el[i] - damping + f_ext[i]).component_mul(&free[i]);
                    });
                potential += ordered_sum(&mut self.partials, x.len(), |i| {
                    let xhat = xn[i] + h * vn[i];
                    let m = masses[i];
                    0.5 * m * (x[i] - xhat).norm_squared() / (h * h)
                        + 0.5 * alpha * m * (x[i] - xn[i]).norm_squared() / h
                });
            }
            StepKind::Static => {
                let f_el = &self.f_el;
                self.rhs
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(CHUNK)
                    .for_each(|(i, r)| *r = (f_el[i] + f_ext[i]).component_mul(&free[i]));
            }
        }
        let residual = cg::dot(&self.rhs, &self.rhs, &mut self.partials).sqrt();
        self.timings.evaluate += started.elapsed().as_secs_f64();
        Evaluation {
            energy,
            potential,
            residual,
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
        _ => FORCING_MAX,
    };
    eta = eta.min(FORCING_MAX);
    let target = (params.newton_tolerance * first).max(floor);
    eta = eta.max(0.5 * target / r.max(f64::MIN_POSITIVE));
    eta.clamp(params.cg.tolerance, FORCING_MAX.max(params.cg.tolerance))
}

/// The loosest CG tolerance inexact Newton uses.
const FORCING_MAX: f64 = 0.1;

/// Absolute residual floor: 1e-12 of the characteristic force E·ℓ²·√n (E from the material at
/// rest), so that a body at rest is converged before any iteration.
fn absolute_floor(body: &ElasticBody) -> f64 {
    use crate::material::Material;
    // The rest tangent's ∂P₁₁/∂F₁₁ = λ + 2μ stands in for E: a scale, not a measurement.
    let mut df = Mat3::zeros();
    df[(0, 0)] = 1.0;
    let stiffness = body.model.stress_differential(&Mat3::identity(), &df)[(0, 0)].abs();
    let edge = body.mesh.mean_edge_length();
    1e-12 * stiffness * edge * edge * (body.vertex_count() as f64).sqrt()
}

/// `x = x0 + alpha·dx`.
fn set_axpy(x: &mut [Vec3], x0: &[Vec3], alpha: f64, dx: &[Vec3]) {
    x.par_iter_mut()
        .zip(x0.par_iter().zip(dx.par_iter()))
        .with_min_len(CHUNK)
        .for_each(|(x, (x0, dx))| *x = x0 + alpha * dx);
}

/// Deterministic parallel Σ f(i) for i < n: fixed chunks, partials summed in order.
pub fn ordered_sum(partials: &mut [f64], n: usize, f: impl Fn(usize) -> f64 + Sync) -> f64 {
    let chunks = n.div_ceil(CHUNK);
    partials[..chunks]
        .par_iter_mut()
        .enumerate()
        .for_each(|(c, s)| {
            *s = (c * CHUNK..((c + 1) * CHUNK).min(n)).map(&f).sum();
        });
    partials[..chunks].iter().sum()
}

/// Per-frame statistics: one row of steps.csv.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Frame number (1-based; frame 0 is the initial state).
    pub frame: usize,
    /// Time at the end of the frame, s (quasistatic: the load factor).
    pub time: f64,
    /// Newton iterations over the frame's substeps.
    pub newton_iterations: usize,
    /// CG iterations over the frame's substeps.
    pub cg_iterations: usize,
    /// Largest final ‖rhs‖ over the substeps, N.
    pub residual: f64,
    /// Largest final relative residual over the substeps.
    pub relative_residual: f64,
    /// Whether every substep converged.
    pub converged: bool,
    /// Elastic energy at the end of the frame, J.
    pub elastic_energy: f64,
    /// Kinetic energy at the end of the frame, J.
    pub kinetic_energy: f64,
    /// Smallest det F at the end of the frame.
    pub min_j: f64,
    /// Tets with det F ≤ 0 at the end of the frame.
    pub inverted_elements: usize,
    /// Wall-clock seconds spent on the frame (retries included).
    pub wall_seconds: f64,
    /// Substeps used (more than asked when the step was cut).
    pub substeps: usize,
    /// Line-search halvings over the frame.
    pub line_search_cuts: usize,
    /// CG solves that broke down.
    pub cg_breakdowns: usize,
    /// CG solves that hit their cap.
    pub cg_capped: usize,
    /// Most tets with a clamped tangent at any iterate.
    pub clamped_tets: usize,
    /// Why the frame did not converge, in words.
    pub failure: Option<String>,
    /// The frame's energy audit (see [`crate::audit`]).
    pub energy: crate::audit::EnergyAudit,
    /// Time by phase over the frame (not written to steps.csv: it is not deterministic).
    pub timings: Timings,
}

impl StepStats {
    /// Fold one substep's Newton result in.
    pub fn absorb(&mut self, info: &NewtonInfo) {
        self.newton_iterations += info.iterations;
        self.cg_iterations += info.cg_iterations;
        self.residual = self.residual.max(info.residual);
        self.relative_residual = self.relative_residual.max(info.relative_residual);
        self.converged &= info.converged;
        self.line_search_cuts += info.line_search_cuts;
        self.cg_breakdowns += info.cg_breakdowns;
        self.cg_capped += info.cg_capped;
        self.clamped_tets = self.clamped_tets.max(info.clamped_tets);
        self.elastic_energy = info.elastic_energy;
        self.timings.add(&info.timings);
        if self.failure.is_none() {
            self.failure.clone_from(&info.failure);
        }
    }
}
