//! What the monitors read off the state: probe displacements and constraint reactions.

use super::*;

impl Simulation {
    /// Each probe's displacement in the current state, m (in [`Simulation::monitors`] order).
    pub fn probe_displacements(&self) -> Vec<Vec3> {
        self.monitors
            .probes
            .iter()
            .map(|p| p.displacement(&self.body, &self.state.x))
            .collect()
    }

    /// The reaction force on every vertex, N: what the constraints exert on the body's
    /// constrained components (zero on free ones). After a frame: minus the total force of the
    /// step's equation there at the converged state (see [`crate::monitor`]); before the first
    /// (or when not recorded), the static value −(f_el + f_ext), which holds for constraints at
    /// rest.
    pub fn vertex_reactions(&self) -> Vec<Vec3> {
        let n = self.body.vertex_count();
        let recorded = self.newton.potential().constrained_forces();
        if self.frame > 0 && recorded.len() == n {
            return recorded.iter().map(|f| -f).collect();
        }
        let mut f = vec![Vec3::zeros(); n];
        self.boundary
            .external_forces(&self.clock_at(self.state.t), self.body.masses(), &mut f);
        self.body.add_forces(&self.state.x, &mut f);
        f.iter()
            .zip(&self.free)
            .map(|(f, m)| -f.component_mul(&(Vec3::repeat(1.0) - m)))
            .collect()
    }

    /// The total reaction force of each named constraint, N (in [`Simulation::monitors`]
    /// order): the sum of [`Simulation::vertex_reactions`] over its vertices and components.
    pub fn reaction_forces(&self) -> Vec<Vec3> {
        if self.monitors.reactions.is_empty() {
            return Vec::new();
        }
        let reactions = self.vertex_reactions();
        self.monitors
            .reactions
            .iter()
            .map(|group| {
                let c = &self.boundary.constraints[group.constraint];
                let mask = Vec3::from(c.components.map(|on| if on { 1.0 } else { 0.0 }));
                c.vertices.iter().fold(Vec3::zeros(), |sum, &v| {
                    sum + reactions[v].component_mul(&mask)
                })
            })
            .collect()
    }
}
