//! The acceleration a scheme that keeps one (Newmark, BDF2's first step) starts from: the
//! forces of every term at the state, over the masses.

use super::Simulation;
use crate::boundary::Clock;
use crate::integrator::{StepContext, StepKind};
use crate::math::Vec3;

impl Simulation {
    /// `M⁻¹·(f(xⁿ) − α·M·vⁿ)` on free components, zero on constrained ones, at the start of the
    /// step, whose clock is `start`: f the force of every term of the potential but inertia
    /// (elasticity, the loads at tⁿ, contact, added terms). The stiffness-damping force at the
    /// start is left out: zero for a body at rest, which is how scenes start.
    pub(super) fn start_acceleration(&mut self, start: &Clock) -> Vec<Vec3> {
        let n = self.xn.len();
        let mut loads = vec![Vec3::zeros(); n];
        self.boundary
            .external_forces(start, self.body.masses(), &mut loads);
        let ctx = StepContext {
            body: &self.body,
            kind: StepKind::Static,
            f_ext: &loads,
            free: &self.free,
            params: &self.params,
        };
        let mut forces = vec![Vec3::zeros(); n];
        let mut partials = vec![0.0; n.div_ceil(crate::integrator::CHUNK).max(1)];
        // Distributed, the elastic forces come completed on the owners (zero on the ghosts,
        // which have no mass) and the loads are on the owners only.
        self.newton
            .potential_mut()
            .evaluate(&ctx, &self.xn, &self.vn, &mut forces, &mut partials);
        let alpha = self.params.rayleigh_mass;
        let masses = self.body.masses();
        let mut a: Vec<Vec3> = (0..n)
            .map(|i| {
                if masses[i] > 0.0 {
                    (forces[i] / masses[i] - alpha * self.vn[i]).component_mul(&self.free[i])
                } else {
                    Vec3::zeros()
                }
            })
            .collect();
        // Every copy of a vertex steps alike: the owners hand the acceleration to the ghosts.
        if let Some(ranks) = self.newton.ranks() {
            let mut flat: Vec<f64> = a.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
            ranks.share(&mut flat, 3);
            for (v, f) in a.iter_mut().zip(flat.chunks_exact(3)) {
                *v = Vec3::new(f[0], f[1], f[2]);
            }
        }
        a
    }
}
