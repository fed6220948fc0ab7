//! Incremental Potential Contact (Li et al. 2020): the geometry and math of contact, as plain
//! functions the integrator assembles into an energy term.
//!
//! Contact is an energy. For every close pair of surface primitives k (point–triangle,
//! edge–edge, and point/edge against rigid obstacles) with squared distance dₖ(x),
//!
//! ```text
//! B(x) = κ Σₖ mₖ(x) b(dₖ(x)),   b(d) = −(d − d̂)² ln(d / d̂) for 0 < d < d̂, 0 beyond,
//! ```
//!
//! where d̂ is the activation distance squared, κ the barrier stiffness and mₖ the edge–edge
//! mollifier (1 for other pairs). Newton adds B to the incremental potential; the line search is
//! limited by continuous collision detection so that no iterate ever has dₖ ≤ 0; friction is the
//! lagged smoothed Coulomb potential D(x) = Σₖ μ λₖ f₀(‖uₖ(x)‖).
//!
//! The pieces, each testable alone:
//! - [`distance`]: squared distances point–point, point–edge, point–triangle, edge–edge with
//!   the closest-feature classification, their gradients and Hessians (fixed-size nalgebra);
//!   point–plane and sphere–face distances for analytic obstacles.
//! - [`barrier`]: b(d) and its derivatives, the edge–edge mollifier, the barrier stiffness κ
//!   (initial, minimum, adaptive update).
//! - [`ccd`]: conservative time of impact for linear trajectories (additive CCD, Li, Kaufman &
//!   Jiang 2021) for every pair type, plus planes and spheres.
//! - [`broad`]: a bounding volume hierarchy giving candidate pairs, deterministic and parallel.
//! - [`surface`]: the contact surface (vertices, edges, faces) of a tet mesh.
//! - [`obstacle`]: rigid obstacles (plane, box, sphere, triangle mesh) with scripted motion.
//! - [`display`]: the obstacles as triangles for the output files and the pictures.
//! - [`friction`]: tangent bases, relative tangential displacement, the smoothed friction
//!   potential with its gradient and PSD Hessian.
//!
//! Conventions: positions are `Vec3` in metres; a pair's dofs are its vertices' coordinates
//! stacked in the order the function takes them (point first, then the triangle's or edges'
//! vertices), so a gradient over 12 dofs is `[∂/∂p; ∂/∂t₀; ∂/∂t₁; ∂/∂t₂]`. Distances are
//! *squared* throughout, as in the IPC paper (d̂ is a squared distance too), except where a name
//! says `gap` (an unsquared, possibly signed, distance).

pub mod barrier;
pub mod broad;
pub mod ccd;
pub mod display;
pub mod distance;
pub mod friction;
pub mod obstacle;
pub mod setup;
pub mod surface;
pub mod term;

pub use setup::{ContactParams, ContactSetup, ObstacleSpec};

#[cfg(test)]
pub(crate) mod testutil;
