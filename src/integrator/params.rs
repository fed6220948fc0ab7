//! Every setting of a step's solve: what is integrated, Newton's and CG's tolerances, the
//! definiteness strategy, the linear-solver strategy, and the failure policy.

use super::scheme::Integrator;
use crate::linear::LinearSolverParams;
use crate::linear::PreconditionerKind;
use crate::linear::amg::AmgParams;
use crate::linear::cg::CgParams;
use crate::linear::sparse::Precision;
use crate::material::{DampingStiffness, Definiteness};

/// How the assembled strategies (AMG, Cholesky) store Newton's matrix A (scene key
/// `matrix_precision`). f32 halves the bytes CG's product and the multigrid smoother read
/// (measured in docs/performance.md, "Why the defaults"); but A's rounding, about 6e-8 of each entry, limits how exactly a Newton step solves
/// A·d = −g to about 6e-8 times the condition of A scaled by its diagonal: harmless with a
/// dynamic step's mass term (M/h² bounds it), not with the stiffness alone, whose condition
/// grows with the mesh and with near-incompressibility, nor with contact barriers (see
/// [`crate::linear::System::needs_f64`]), nor on a body collapsed onto a line (see
/// [`crate::linear::multigrid::Multigrid`]'s solve).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MatrixPrecision {
    /// f32 for dynamic steps with the AMG, else f64 (quasistatic steps, the Cholesky
    /// preconditioner).
    #[default]
    Auto,
    /// f32 always.
    F32,
    /// f64 always.
    F64,
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

/// How Newton's matrix accounts for the damping force's dependence on x through K(x) (the
/// force itself, −γ·K_d(x)·v, is the same either way: this changes iteration counts, not
/// answers).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DampingTangent {
    /// `shifted`: the consistent tangent to first order. The exact Jacobian of the damping
    /// force is `γ/h·K(x) + γ·(∂K/∂x)[·]v`, and `(∂K/∂x)[·]v = (∂K/∂x)[v]·` (third derivatives
    /// of E are symmetric), so `(1 + γ/h)·K(x) + γ·(∂K/∂x)[v] = (1 + γ/h)·K(x + θ·v) + O(θ²)`
    /// with `θ = γh/(h + γ)`: Newton's tangents are taken at x + θ·v. It is the same kind of
    /// matrix as before (symmetric, projected per element by the definiteness strategy, so
    /// positive semi-definite), at the price of a second SVD per tet and evaluation.
    #[default]
    Shifted,
    /// `frozen`: K at x, the damping's ∂K/∂x dropped (SPEC §4's modified Newton): one SVD per
    /// tet, but Newton converges only linearly where K changes along v.
    Frozen,
}

impl DampingTangent {
    /// The scene name.
    pub fn name(self) -> &'static str {
        match self {
            DampingTangent::Shifted => "shifted",
            DampingTangent::Frozen => "frozen",
        }
    }
}

/// Every solver setting, with its unit and default (built by the scene from `[solver]`).
#[derive(Clone, Debug, PartialEq)]
pub struct SolverParams {
    /// The time scheme (default backward Euler) or quasistatic.
    pub integrator: Integrator,
    /// Seconds per frame (dynamic schemes). Default 1/30 s.
    pub dt: f64,
    /// Frames (dynamic) or load steps (quasistatic). Default 60.
    pub frames: usize,
    /// Time steps (load increments) per frame. Default 1.
    pub substeps: usize,
    /// Rayleigh stiffness damping γ, seconds: f_d = −γK(x)v. Default 0.
    pub rayleigh_stiffness: f64,
    /// Rayleigh mass damping α, 1/s: f_d = −αMv. Default 0.
    pub rayleigh_mass: f64,
    /// Which K the stiffness damping force −γK(x)v uses: physics, the same under every
    /// `definiteness`. Default Projected (see [`DampingStiffness`]).
    pub damping_stiffness: DampingStiffness,
    /// How Newton linearizes the damping force. Default Shifted (see [`DampingTangent`]).
    pub damping_tangent: DampingTangent,
    /// Newton stops at ‖rhs‖ ≤ this × the step's first ‖rhs‖. Default 1e-6.
    pub newton_tolerance: f64,
    /// Newton iteration cap per step. Default 20.
    pub newton_max_iterations: usize,
    /// CG tolerance (relative to ‖rhs‖) and cap. Defaults 1e-6 and 2000.
    pub cg: CgParams,
    /// Definiteness treatment of K. Default Adaptive: Teran's projection, with the exact tangent
    /// once projected Newton stalls (see [`Definiteness::Adaptive`]).
    pub definiteness: Definiteness,
    /// Preconditioner. Default AMG on the assembled system (why, against Jacobi, block Jacobi
    /// and the sparse Cholesky: docs/performance.md, "Why the defaults").
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
    /// Default false.
    pub f32_matrix: bool,
    /// How the assembled strategies store A (see [`MatrixPrecision`]). Default auto.
    pub matrix_precision: MatrixPrecision,
    /// With the Cholesky preconditioner: keep the factor across Newton iterations and frames and
    /// refactor when CG needs more than `CHOLESKY_REFACTOR_RATE` (see `linear::cholesky`) iterations per decade (or the
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
            damping_stiffness: DampingStiffness::Projected,
            damping_tangent: DampingTangent::Shifted,
            newton_tolerance: 1e-6,
            newton_max_iterations: 20,
            cg: CgParams::default(),
            definiteness: Definiteness::Adaptive,
            preconditioner: PreconditionerKind::Amg,
            amg: AmgParams::default(),
            line_search: true,
            inexact_newton: true,
            f32_matrix: false,
            matrix_precision: MatrixPrecision::Auto,
            cholesky_reuse: true,
            on_failure: OnFailure::Retry,
            max_step_cuts: 4,
        }
    }
}

impl SolverParams {
    /// The linear-solver strategy's settings.
    pub fn linear(&self) -> LinearSolverParams {
        LinearSolverParams {
            kind: self.preconditioner,
            amg: self.amg.clone(),
            f32_matrix: self.f32_matrix,
            matrix_precision: match self.matrix_precision {
                MatrixPrecision::F32 => Precision::F32,
                MatrixPrecision::F64 => Precision::F64,
                // A direct factor gains little from f32 and loses definiteness to its rounding.
                MatrixPrecision::Auto
                    if self.integrator.is_dynamic()
                        && self.preconditioner == PreconditionerKind::Amg =>
                {
                    Precision::F32
                }
                MatrixPrecision::Auto => Precision::F64,
            },
            cholesky_reuse: self.cholesky_reuse,
        }
    }
}
