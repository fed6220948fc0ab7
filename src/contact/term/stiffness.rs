//! The barrier stiffness κ: matched to the bodies' material, and balanced against the step's other forces (IPC's initial κ).

use super::*;

impl ContactTerm {
    /// Raise κ_min (and κ, κ_max = 100 κ_min) to the stiffness that matches the bodies' own:
    /// `youngs_modulus` (Pa, the softest body's) times the mean edge length `edge` (m) is the
    /// stiffness of a surface vertex, and the barrier is made as stiff across a gap of d̂/2
    /// ([`stiffness_matched_barrier_stiffness`]). Never lowers κ_min. Call before the first step.
    pub fn match_material_stiffness(&mut self, youngs_modulus: f64, edge: f64) {
        let matched = stiffness_matched_barrier_stiffness(self.dhat, youngs_modulus * edge);
        if matched.is_finite() && matched > self.kappa_min {
            self.kappa_min = matched;
            self.kappa_max = 100.0 * matched;
            self.kappa = self.kappa.max(matched);
        }
    }

    /// IPC's initial stiffness, at the first evaluation of a step ([`initial_barrier_stiffness`]):
    /// κ raised to the value whose barrier forces best balance the other forces of the step
    /// (least squares over the free components), within [κ_min, 100 κ_min]; never lowered.
    /// `total` is the evaluation's force (every term, masked to the free components, N).
    /// Returns whether κ changed (the caller evaluates again).
    ///
    /// Without it a body that starts its step inside d̂ under a load (the beam resting on the
    /// ground) meets a barrier too soft to carry it where it is: Newton asks its bottom to
    /// pass through the ground, CCD cuts the whole step to a few per cent, and the frame takes
    /// many iterations to walk the gap down to where the weak barrier holds (16 Newton
    /// iterations against 7 with the balanced κ in `tetsim bench --contact`'s first frame).
    pub fn balance_stiffness(&mut self, total: &[Vec3], free: &[Vec3]) -> bool {
        if self.balanced {
            return false;
        }
        self.balanced = true;
        if self.barrier_pairs == 0 {
            return false;
        }
        // The barrier's own forces (friction's belong with the rest), unscaled: −∇B.
        let mut barrier = vec![Vec3::zeros(); total.len()];
        for p in &self.pairs[..self.barrier_pairs] {
            for k in 0..p.count {
                barrier[p.vertices[k]] -= p.gradient.fixed_rows::<3>(3 * k) / self.kappa;
            }
        }
        let grad_barrier: Vec<Vec3> = barrier
            .iter()
            .zip(free)
            .map(|(b, m)| -b.component_mul(m))
            .collect();
        // ∇E = −(total − contact), the contact forces being κ·(−∇B) plus friction's.
        let grad_energy: Vec<Vec3> = total
            .iter()
            .zip(&barrier)
            .zip(free)
            .map(|((t, b), m)| -(t - self.kappa * b).component_mul(m))
            .collect();
        let (kappa, _) = initial_barrier_stiffness(self.kappa_min, &grad_energy, &grad_barrier);
        if kappa > self.kappa {
            log::debug!(
                "contact: barrier stiffness {:.3e} → {kappa:.3e} (balanced against the step's other forces)",
                self.kappa
            );
            self.kappa = kappa;
            return true;
        }
        false
    }
}
