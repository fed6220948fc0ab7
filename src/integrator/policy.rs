//! Which tangent Newton solves with: the definiteness-projected one, or, under the `adaptive`
//! strategy, the exact one: from the first iterate in a damped step, else once projected Newton
//! stalls.
//!
//! The per-element projection itself is the material layer's ([`Definiteness`] in
//! `material::isotropic`); keeping the exact pieces beside the projected ones so that switching
//! costs no SVD is the elastic layer's ([`Linearization::use_exact`]). When to switch is this
//! policy's, and only this policy's.
//!
//! **Exact first in damped steps.** With Rayleigh stiffness damping γ > 0, Newton's matrix
//! holds `(γ/h)·K_d` (the damping stiffness, positive semi-definite by default) beside the
//! elastic tangent, and its consistent part along v (see [`super::DampingTangent`]): the exact
//! elastic tangent then rarely meets negative curvature, and it converges where the projected
//! one only creeps (the projection drops the geometric stiffness of compressed fibres, which a
//! bending beam lives on). Measured with `tetsim compare SCENE --definiteness adaptive,teran`
//! (Newton iterations in all, `teran` being the earlier `adaptive` on these scenes): default
//! 258 → 124, cantilever 389 → 234, twist 744 → 450, gmsh_beam 225 → 179, squash_recover
//! 195 → 184, squash_release 448 → 323, tangle_recover 2327 → 2247; the bench beam (41,472
//! tets) 3.67 → 2.13 per frame. A damped step starts on the exact tangent and falls back to the
//! projected one for the rest of the step as soon as it fails (no descent, CG breakdown, failed
//! line search), stalls (a reduction by less than [`ADAPTIVE_STALL_RATIO`]) or meets an
//! inverted tet. Undamped steps keep the earlier rule below, unchanged.

use super::problem::StepContext;
use crate::elastic::Linearization;
use crate::material::Definiteness;

/// `adaptive` definiteness tries the exact tangent once an iterate with the projected one
/// reduced the residual by less than this factor: projection makes Newton linear, and a rate
/// this slow means it is stalling. 0.6 leaves every sample scene exactly as `teran` runs it
/// (their projected iterates contract faster) while the ν = 0.49 cantilever at dt = 1 s converges
/// in 19 Newton iterations instead of failing after 243; 0.1 and 0.3 used the exact tangent on
/// the squash scenes too, where it took up to 46 % more Newton iterations (compression makes the
/// exact Hessian a poor model there).
pub const ADAPTIVE_STALL_RATIO: f64 = 0.6;

/// Newton's choice of tangent at each iterate.
#[derive(Clone, Copy, Debug)]
pub struct TangentPolicy {
    adaptive: bool,
    /// This step tries the exact tangent from its first iterate (and it has not failed yet).
    exact_first: bool,
}

impl TangentPolicy {
    /// The policy of a definiteness strategy.
    pub fn new(definiteness: Definiteness) -> Self {
        TangentPolicy {
            adaptive: definiteness == Definiteness::Adaptive,
            exact_first: false,
        }
    }

    /// A new step: under `adaptive`, a damped step starts on the exact tangent. Nothing is
    /// carried from one step to the next (a resumed run takes the same decisions).
    pub fn begin_step(&mut self, ctx: &StepContext<'_>) {
        self.exact_first = self.adaptive && ctx.stiffness_damping() > 0.0;
    }

    /// The exact tangent failed or stalled: projected first for the rest of the step (the stall
    /// rule of [`TangentPolicy::wants_exact`] still applies).
    pub fn exact_failed(&mut self) {
        self.exact_first = false;
    }

    /// Whether the next direction should use the exact tangent: under `adaptive`, once the last
    /// iterate reduced the residual by less than [`ADAPTIVE_STALL_RATIO`], while the projection
    /// clamped some tet and none is inverted (from tangled starts the exact Hessian leads to
    /// folded minima, 2–2.6 edge lengths from rest where `teran` recovers). Newton asks only
    /// after a full step: a step that continuous collision detection shortened is slow because
    /// an obstacle is in the way, not because of the projection (the 41,472-tet beam landing on
    /// the ground switched to the exact tangent at its second iterate, whose kept multigrid then
    /// needed 3 → 97 CG iterations per solve: 0.361 s per frame against 0.229 s staying projected).
    /// In a damped step, from the first iterate until [`TangentPolicy::exact_failed`] or an
    /// iterate with an inverted tet (the rest of that step is projected first: through
    /// inversion the exact Newton found other stationary points than the projected one, and on
    /// `scenes/squash_release.toml` one of them gave energy back), under the same conditions on
    /// the tets.
    pub fn wants_exact(&mut self, history: &[f64], lin: &Linearization) -> bool {
        let slow = match history {
            [.., before, last] => *last > ADAPTIVE_STALL_RATIO * before,
            _ => false,
        };
        if lin.inverted_tets() > 0 {
            self.exact_first = false;
        }
        self.adaptive
            && lin.clamped_tets() > 0
            && lin.inverted_tets() == 0
            && (slow || self.exact_first)
    }
}
