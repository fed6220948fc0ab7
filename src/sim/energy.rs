//! The energy audit of each substep (see [`crate::audit`]): what the step's record holds, the
//! ledger it carries on, and the Simpson refinement of a flagged step.

use super::Simulation;
use crate::audit::{EnergyAudit, StepRecord, audit_finish, audit_refined, audit_sums};
use crate::math::Vec3;

impl Simulation {
    /// The audit of the substep just solved (from `xn`, `vn` to the state), updating the ledger:
    /// `elastic` is the solve's elastic energy, `gravity` the step's, `dynamic` whether it was a
    /// time step (the scheme's, as planned in the history), `rayleigh` (γ, α).
    pub(super) fn audit_substep(
        &mut self,
        elastic: f64,
        gravity: Vec3,
        dynamic: bool,
        (gamma, alpha): (f64, f64),
    ) -> EnergyAudit {
        let account = self
            .newton
            .potential_mut()
            .contact
            .as_mut()
            .map(|c| c.account(&self.xn, &self.state.x));
        let record = StepRecord {
            body: &self.body,
            free: &self.free,
            gravity,
            f_ext: &self.f_ext,
            xn: &self.xn,
            vn: &self.vn,
            x: &self.state.x,
            v: &self.state.v,
            f_el: self.newton.elastic_forces(),
            kv: self.newton.stiffness_velocity(),
            residual: self.newton.residual(),
            // Under MPI each rank's own share, summed over the ranks with the audit's sums.
            elastic: match self.newton.ranks() {
                Some(_) => self.newton.potential().elasticity.energy(),
                None => elastic,
            },
            added: self.newton.potential().added_energy(),
            dynamic: dynamic.then(|| (self.history.inertial(&self.xn, &self.vn), gamma, alpha)),
            contact: self
                .newton
                .potential()
                .contact
                .as_ref()
                .zip(account)
                .map(|(c, a)| (c.forces(), a)),
        };
        // The elastic forces' work over the step at its start and end (what the audit's
        // trapezoid estimate of the Bregman term is made of), for a refinement below.
        let ends_work = (self.newton.ranks().is_none()
            && self.ledger.forces.len() == self.xn.len())
        .then(|| {
            (
                work_over_step(&self.ledger.forces, &self.state.x, &self.xn),
                work_over_step(self.newton.elastic_forces(), &self.state.x, &self.xn),
            )
        });
        let mut sums = audit_sums(&record, &mut self.ledger);
        if let Some(ranks) = self.newton.ranks() {
            ranks.sum(&mut sums);
        }
        let mut audit = audit_finish(&sums);
        if audit.injected() > 0.0
            && let Some((start, end)) = ends_work
        {
            // A flagged step is audited again with the Bregman term by Simpson's rule (the
            // elastic forces at the step's midpoint too): the trapezoid's own error is third
            // order, and a bar twisted past buckling outgrew its allowance.
            let mid: Vec<Vec3> = self
                .xn
                .iter()
                .zip(&self.state.x)
                .map(|(a, b)| 0.5 * (a + b))
                .collect();
            let mut f_mid = vec![Vec3::zeros(); mid.len()];
            self.body.add_forces(&mid, &mut f_mid);
            let middle = work_over_step(&f_mid, &self.state.x, &self.xn);
            audit = audit_refined(&sums, start, middle, end);
        }
        audit
    }
}

/// Σ f·(x − xn): the work of the forces f over the step.
fn work_over_step(f: &[Vec3], x: &[Vec3], xn: &[Vec3]) -> f64 {
    f.iter()
        .zip(x.iter().zip(xn))
        .map(|(f, (x, xn))| f.dot(&(x - xn)))
        .sum()
}
