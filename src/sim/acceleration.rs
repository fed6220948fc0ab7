//! The acceleration a scheme that keeps one (Newmark) starts from: the forces at the state over
//! the masses.

use super::Simulation;
use crate::boundary::Clock;
use crate::math::Vec3;

impl Simulation {
    /// `M⁻¹·(f_el(xⁿ) + f_ext(tⁿ) − α·M·vⁿ)` on free components, zero on constrained ones, at the
    /// start of the step of h ending at `clock`. The stiffness-damping and contact forces at the
    /// start are left out: zero for a body at rest and out of contact, which is how scenes start.
    pub(super) fn start_acceleration(&self, clock: &Clock, h: f64) -> Vec<Vec3> {
        let n = self.xn.len();
        let start = match *clock {
            Clock::Time { time, run_duration } => Clock::Time {
                time: time - h,
                run_duration,
            },
            other => other,
        };
        let mut forces = vec![Vec3::zeros(); n];
        self.body.add_forces(&self.xn, &mut forces);
        let mut loads = vec![Vec3::zeros(); n];
        self.boundary
            .external_forces(&start, self.body.masses(), &mut loads);
        let alpha = self.params.rayleigh_mass;
        let masses = self.body.masses();
        for i in 0..n {
            forces[i] += loads[i] - alpha * masses[i] * self.vn[i];
        }
        // Distributed: the owners add up the ranks' shares (a ghost has no mass) and hand the
        // acceleration back to the ghosts, so that every copy of a vertex steps alike.
        let ranks = self.newton.ranks();
        if let Some(ranks) = ranks {
            crate::parallel::complete_vectors(&**ranks, &mut forces);
        }
        let mut a: Vec<Vec3> = (0..n)
            .map(|i| {
                if masses[i] > 0.0 {
                    (forces[i] / masses[i]).component_mul(&self.free[i])
                } else {
                    Vec3::zeros()
                }
            })
            .collect();
        if let Some(ranks) = ranks {
            let mut flat: Vec<f64> = a.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
            ranks.share(&mut flat, 3);
            for (v, f) in a.iter_mut().zip(flat.chunks_exact(3)) {
                *v = Vec3::new(f[0], f[1], f[2]);
            }
        }
        a
    }
}
