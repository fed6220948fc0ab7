//! What contact adds to one step's energy balance (see [`crate::audit`]): the barrier is a
//! potential B(x, o) of the body's positions x and the obstacles' placement o, friction a force
//! that does work, and a moving obstacle does work on the body through both.
//!
//! The barrier's level changes by `ΔB = B(xⁿ⁺¹, oⁿ⁺¹) − B(xⁿ, oⁿ)` over a step, both ends
//! states the step passed through (free of intersection). A moving obstacle's work is taken as
//! backward Euler takes every force, at the end of the step: each obstacle pair's reaction
//! (minus the force on its body vertices) times the displacement of the obstacle's point at
//! those vertices. Against still obstacles the balance is then exact up to the barrier's
//! Bregman term, which joins backward Euler's numerical dissipation like the elastic one, with
//! its trapezoid estimate `½(f_c(xⁿ) − f_c(xⁿ⁺¹))·Δx` for the allowance on a non-convex barrier.
//! Friction's work is its force on the body times the body's displacement. All at the step's κ.

use super::ContactTerm;
use crate::math::Vec3;

/// Contact's share of one step's energy audit, J.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactAccount {
    /// B(xⁿ⁺¹, oⁿ⁺¹): the barrier at the end.
    pub barrier_end: f64,
    /// B(xⁿ, oⁿ): the barrier at the start.
    pub barrier_start: f64,
    /// B(xⁿ, oⁿ⁺¹) − B(xⁿ, oⁿ): the work of the obstacles' motion (0 when none moves).
    pub obstacle_work: f64,
    /// f_friction·Δx: friction's work on the body (≤ 0 against still obstacles).
    pub friction_work: f64,
    /// ½(f_c(xⁿ, oⁿ⁺¹) − f_c(xⁿ⁺¹, oⁿ⁺¹))·Δx: the trapezoid estimate of the barrier's Bregman term.
    pub curvature: f64,
}

impl ContactTerm {
    /// Contact's share of the audit of the step from `xn` to `x`, the obstacles where the step
    /// ends and the last evaluation at `x` (its friction pairs are the step's).
    pub fn account(&mut self, xn: &[Vec3], x: &[Vec3]) -> ContactAccount {
        let mut friction_work = 0.0;
        for p in &self.pairs[self.barrier_pairs..] {
            for k in 0..p.count {
                let v = p.vertices[k];
                friction_work -= p.gradient.fixed_rows::<3>(3 * k).dot(&(x[v] - xn[v]));
            }
        }
        let (barrier_end, forces_end, obstacle_work) = self.barrier_at(x, true);
        let (barrier_start, forces_start) = if self.ramp_start == self.ramp_now {
            let (energy, forces, _) = self.barrier_at(xn, false);
            (energy, forces)
        } else {
            let end = self.ramp_now.clone();
            self.place_at(&self.ramp_start.clone());
            let (energy, forces, _) = self.barrier_at(xn, false);
            self.place_at(&end);
            (energy, forces)
        };
        let curvature = forces_start
            .iter()
            .zip(&forces_end)
            .zip(x.iter().zip(xn))
            .map(|((fs, fe), (x, xn))| 0.5 * (fs - fe).dot(&(x - xn)))
            .sum();
        ContactAccount {
            barrier_end,
            barrier_start,
            obstacle_work,
            friction_work,
            curvature,
        }
    }

    /// The barrier's energy (κ applied) and forces at `x`, the obstacles where they are, and
    /// (when `with_work`) the work of the obstacles' motion since the step's start against
    /// these forces.
    fn barrier_at(&self, x: &[Vec3], with_work: bool) -> (f64, Vec<Vec3>, f64) {
        let mut body = None;
        let (pairs, ..) = self.collect_pairs(x, &mut body);
        let mut forces = vec![Vec3::zeros(); x.len()];
        let (mut energy, mut work) = (0.0, 0.0);
        for p in &pairs {
            energy += p.energy;
            for k in 0..p.count {
                let v = p.vertices[k];
                let f = -self.kappa * p.gradient.fixed_rows::<3>(3 * k);
                forces[v] += f;
                if let (true, Some(o)) = (with_work, p.obstacle) {
                    // The obstacle's point now at the vertex came from `back` at the start; the
                    // obstacle pushes it with the reaction of what it takes, −(−f).
                    let (s0, s1) = (self.ramp_start[o], self.ramp_now[o]);
                    if s0 != s1 {
                        let motion = &self.setup.obstacles[o].obstacle.motion;
                        let back = motion.apply(s0, &motion.unapply(s1, &x[v]));
                        work += f.dot(&(x[v] - back));
                    }
                }
            }
        }
        (self.kappa * energy, forces, work)
    }
}
