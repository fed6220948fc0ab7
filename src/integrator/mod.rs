//! One time step (or load step) as Newton's method on the SPEC §4 system.
//!
//! **Backward Euler** with Rayleigh damping `f_d = −αMv − γK_d(x)v`, from (xⁿ, vⁿ) over h:
//! starting from `x₀ = xⁿ + h·vⁿ` (constrained components at their prescribed values) and keeping
//! `v_k = (x_k − xⁿ)/h`, each iterate solves
//!
//! ```text
//! [ K_n(x̃_k) + (γ/h)·K_d(x̃_k) + (1/h² + α/h)·M ] dx = (1/h)·M(vⁿ − v_k) + f_el(x_k) − γ·K_d(x_k)·v_k − α·M·v_k + f_ext
//! ```
//!
//! on the free degrees of freedom, then `x_{k+1} = x_k + dx`. The right-hand side is the physics:
//! K_d, the damping stiffness, is the scene's choice ([`crate::material::DampingStiffness`]:
//! Teran's projected K by default, or the exact one) and no solver setting changes it, so the
//! damped trajectory is the same under every `definiteness`. The matrix is Newton's business:
//! K_n is the elastic tangent the definiteness strategy and [`policy`] pick, and both are taken at
//! `x̃_k = x_k + θ·v_k` with `θ = γh/(h + γ)` ([`DampingTangent::Shifted`], the default), which
//! adds the damping force's `γ·(∂K/∂x)[·]v` to first order; `θ = 0`
//! ([`DampingTangent::Frozen`]) drops it (SPEC §4's modified Newton). At convergence either is
//! the exact backward-Euler step.
//!
//! **Quasistatic** (no inertia): `K(x_k)·dx = f_el(x_k) + f_ext`, loads ramped over load steps.
//!
//! Convergence: `‖rhs‖ ≤ newton_tolerance·‖rhs₀‖` over free DOFs (relative to the step's first
//! residual), or below an absolute floor of 1e-12 of the body's characteristic force E·ℓ²·√n,
//! so that a body at rest takes zero iterations.
//!
//! **Incremental potential.** When γ = 0 the system is the gradient of
//! `Φ(x) = ½‖x − xⁿ − h·vⁿ‖²_M / h² + α‖x − xⁿ‖²_M / (2h) + E(x) − f_ext·x` (just `E − f_ext·x`
//! when quasistatic), a list of [`terms`] that contact and friction join.
//!
//! Files: [`params`] (settings), [`problem`] (the step's context and the potential as the linear
//! solvers' system), [`terms`], [`newton`] (the loop, inexact-Newton forcing), [`line_search`],
//! [`policy`] (which tangent), [`stats`] (what a solve and a frame did).

use rayon::prelude::*;

use crate::math::Vec3;

pub mod line_search;
pub mod newton;
pub mod params;
pub mod policy;
pub mod problem;
pub mod scheme;
pub mod stats;
pub mod terms;

pub use crate::linear::PreconditionerKind;
pub use line_search::MAX_LINE_SEARCH_CUTS;
pub use newton::Newton;
pub use params::{DampingTangent, MatrixPrecision, OnFailure, SolverParams};
pub use problem::{IncrementalPotential, StepContext, StepKind};
pub use scheme::{BackwardEulerStep, Inertial, Integrator};
pub use stats::{NewtonInfo, StepStats, Timings};
pub use terms::{HessianShape, StepStart, Term};

/// Vertices per parallel chunk in the vector updates; fixed so sums are deterministic.
pub(crate) const CHUNK: usize = 2048;

/// `x = x0 + alpha·dx`.
pub(crate) fn set_axpy(x: &mut [Vec3], x0: &[Vec3], alpha: f64, dx: &[Vec3]) {
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
