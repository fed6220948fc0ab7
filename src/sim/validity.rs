//! What a converged step must also satisfy with contact: the end of every step is checked from
//! outside the solver, so that no frame says `converged` with a vertex inside anything.

use rayon::prelude::*;

use super::*;

impl Simulation {
    /// Why the step that took `xn` to the current state may not count as converged, or None:
    /// a vertex (interior ones too) inside or behind an obstacle, a body passing through another
    /// or itself at the end or on the straight way there (see
    /// [`crate::contact::term::ContactTerm::step_violation`]), or a tet inverted by the step
    /// (not inverted at its start, and not tangled). Only with contact: without it bodies may
    /// pass through anything, and a step that inverts tets under a prescribed motion is the
    /// scene's business.
    pub(super) fn step_violation(&self) -> Option<String> {
        let contact = self.newton.potential().contact.as_ref()?;
        let mut newly = 0;
        if self.newton.ranks().is_none() {
            if let Some(message) = contact.step_violation(&self.xn, &self.state.x) {
                return Some(message);
            }
            let (body, x, xn) = (&self.body, &self.state.x, &self.xn);
            newly = (0..body.tet_count())
                .into_par_iter()
                .filter(|&t| {
                    !body.is_tangled_tet(t)
                        && body.deformation_gradient(x, t).determinant() <= 0.0
                        && body.deformation_gradient(xn, t).determinant() > 0.0
                })
                .count();
        }
        (newly > 0).then(|| {
            format!(
                "the step inverted {newly} tet(s) that were not inverted at its start (crushed or \
                 driven through themselves faster than they could deform)"
            )
        })
    }
}
