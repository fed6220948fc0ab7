//! Terms a library user adds to the potential, and their energy for the audit's ledger.

use super::*;

impl Simulation {
    /// Add a term to the incremental potential every step minimises, after the built-in ones
    /// and contact: a spring, a pressure, an energy of the caller's own (see
    /// [`crate::integrator::Term`] for what a term gives: its energy, forces and Hessian). Its
    /// energy counts as stored energy in the energy audit. Not under MPI: the ranks' parts would
    /// not have it.
    pub fn add_term(&mut self, term: Box<dyn crate::integrator::Term>) -> Result<()> {
        if self.driver.is_some() || self.newton.ranks().is_some() {
            return Err(Error::parameter(
                "add_term",
                "a distributed simulation takes no added terms",
            ));
        }
        self.newton.potential_mut().extra.push(term);
        self.ledger.added = self.added_energy_now();
        self.saved_ledger.added = self.ledger.added;
        Ok(())
    }

    /// The added terms' energy at the current state (for the audit's ledger), J.
    pub(super) fn added_energy_now(&mut self) -> f64 {
        let potential = self.newton.potential_mut();
        if potential.extra.is_empty() {
            return 0.0;
        }
        let n = self.body.vertex_count();
        let ctx = StepContext {
            body: &self.body,
            kind: StepKind::Static,
            f_ext: &self.f_ext,
            free: &self.free,
            params: &self.params,
        };
        let mut scratch = vec![Vec3::zeros(); n];
        let mut partials = vec![0.0; n.div_ceil(crate::integrator::CHUNK).max(1)];
        potential
            .extra
            .iter_mut()
            .map(|t| {
                t.evaluate(
                    &ctx,
                    &self.state.x,
                    &self.state.v,
                    &mut scratch,
                    &mut partials,
                )
            })
            .sum()
    }
}
