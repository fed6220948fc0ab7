//! Backtracking line search along Newton's direction.
//!
//! When the step has a potential (γ = 0 or quasistatic) a step is accepted when Φ falls
//! (Armijo, c = 1e-4) or the residual at least halves (Φ's differences drown in rounding near
//! convergence). With γ > 0 there is no potential and the merit is ‖rhs‖. Rejected steps are
//! halved up to [`MAX_LINE_SEARCH_CUTS`] times.

use super::newton::{Evaluation, Newton};
use super::problem::StepContext;
use super::set_axpy;
use super::stats::NewtonInfo;
use crate::math::Vec3;

/// Step halvings the line search tries before giving up on a Newton direction.
pub const MAX_LINE_SEARCH_CUTS: usize = 8;

impl Newton {
    /// Backtracking along dx from x; evaluates (and so re-linearizes at) each trial point.
    pub(super) fn line_search(
        &mut self,
        ctx: &StepContext<'_>,
        x: &mut [Vec3],
        v: &mut [Vec3],
        current: Evaluation,
        info: &mut NewtonInfo,
    ) -> Option<Evaluation> {
        self.x_start.copy_from_slice(x);
        let slope = -self.rhs_dot_dx(); // ∇Φ·dx
        let potential_merit = ctx.has_potential();
        // Never past what continuous collision detection finds free (1 without contact).
        let mut alpha = self.potential.max_step(ctx, x, &self.dx);
        self.collision_limited = alpha < 1.0;
        if self.collision_limited {
            log::trace!("CCD limits the step to {alpha:.3e}");
        }

        let mut best: Option<(f64, f64)> = None; // (merit, alpha)
        // With γ > 0, the largest step on which the undamped incremental potential met Armijo.
        let mut downhill: Option<(usize, f64)> = None; // (cut, alpha)
        for cut in 0..=MAX_LINE_SEARCH_CUTS {
            set_axpy(x, &self.x_start, alpha, &self.dx);
            let trial = self.evaluate(ctx, x, v);
            let finite = trial.residual.is_finite() && trial.potential.is_finite();
            let accepted = finite
                && if !ctx.params.line_search {
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
            return Some(self.evaluate(ctx, x, v));
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
                Some(self.evaluate(ctx, x, v))
            }
            _ => {
                x.copy_from_slice(&self.x_start);
                self.evaluate(ctx, x, v);
                None
            }
        }
    }
}
