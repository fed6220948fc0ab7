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
        if let Some(ranks) = self.newton.ranks() {
            crate::parallel::complete_vectors(&**ranks, &mut forces);
        }
        let mut loads = vec![Vec3::zeros(); n];
        self.boundary
            .external_forces(&start, self.body.masses(), &mut loads);
        let alpha = self.params.rayleigh_mass;
        (0..n)
            .map(|i| {
                let m = self.body.masses()[i];
                ((forces[i] + loads[i]) / m - alpha * self.vn[i]).component_mul(&self.free[i])
            })
            .collect()
    }
}
