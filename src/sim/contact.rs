//! Contact as the simulation sees it: turning it on (with the start checks and the contact
//! distance checked against the body's own gaps) and reading its term back.

use super::Simulation;
use crate::error::{Error, Result};
use crate::math::Vec3;

impl Simulation {
    /// Turn contact on: rigid obstacles, the bodies and the `[contact]` settings (SPEC §11).
    /// Refused when the initial state passes through an obstacle (the message names it and a
    /// vertex), two bodies overlap, or a body through itself (the message names both bodies and
    /// an element of each).
    pub fn with_contact(mut self, mut setup: crate::contact::ContactSetup) -> Result<Self> {
        use crate::contact::term::ContactTerm;
        let mut term = ContactTerm::new(setup.clone(), &self.body.mesh, self.body.masses());
        // Self-contact must see the rest shape as free: parts of one body's surface closer than
        // d̂ at rest would be pushed apart from the first step (a 0.5 m distance on a 0.2 m cube
        // inflated it with 17 kJ). An explicit distance is refused, a default one shrunk.
        if let Some(gap) = term.rest_self_gap() {
            let dhat = term.activation_distance();
            let safe = 0.5 * gap;
            if safe <= 1e-12 * term.bounding_box_diagonal() {
                // No distance fits: the surface touches itself at rest.
                return Err(Error::parameter(
                    "contact",
                    format!(
                        "parts of a body's own surface not sharing a vertex touch at rest (gap \
                         {gap:.3e} m): self-contact cannot start there. Repair the mesh, or set \
                         `self = false` in [contact]"
                    ),
                ));
            }
            if setup.params.distance.is_some() {
                return Err(Error::parameter(
                    "contact.distance",
                    format!(
                        "{dhat} m is more than the gap between parts of a body's own surface at \
                         rest ({gap:.3e} m): self-contact would push the rest shape apart. Use a \
                         distance below that gap ({safe:.2e} m, half of it, leaves room), or \
                         `self = false` in [contact]"
                    ),
                ));
            }
            log::warn!(
                "the default contact distance {dhat:.3e} m is more than the gap between parts of \
                 a body's own surface at rest ({gap:.3e} m); using {safe:.3e} m"
            );
            setup.params.distance = Some(safe);
            term = ContactTerm::new(setup, &self.body.mesh, self.body.masses());
        }
        term.match_material_stiffness(
            self.body.softest_youngs_modulus(),
            self.body.mesh.mean_edge_length(),
        );
        // Where the obstacles stand at the start: a motion with duration 0 has already moved.
        let start = self.clock_at(self.state.t);
        term.place_obstacles(|duration| start.ramp(duration));
        let inside = (0..setup_obstacles(&term)).find_map(|o| {
            crate::mesh::overlap::first_point_inside(
                &self.state.x,
                &self.body.mesh.tets,
                &term.obstacle_points(o),
            )
            .map(|(_, t)| {
                let name = &term.setup().obstacles[o].name;
                (
                    Some(o),
                    format!(
                        "the initial state passes through {name}: it lies inside element {} of \
                         the body",
                        self.body.mesh.tet_id(t)
                    ),
                )
            })
        });
        if let Some((obstacle, message)) =
            inside.or_else(|| term.located_intersection(&self.state.x))
        {
            // "invalid contact: the initial state …": obstacles and bodies alike; an obstacle's
            // index rides in the key, for the scene to point at its `[[obstacle]]` table.
            let key = obstacle.map_or("contact".to_string(), |o| format!("obstacle.{o}"));
            return Err(Error::parameter(key, message));
        }
        self.newton.potential_mut().contact = Some(term);
        Ok(self)
    }

    /// The contact term, when contact is on: its pairs, gaps, energy, forces and costs.
    pub fn contact(&self) -> Option<&crate::contact::term::ContactTerm> {
        self.newton.potential().contact.as_ref()
    }

    /// The contact setup, when contact is on.
    pub fn contact_setup(&self) -> Option<&crate::contact::ContactSetup> {
        self.contact().map(|c| c.setup())
    }

    /// Contact forces on the vertices at the last evaluation (the end of the last frame), N
    /// (empty without contact).
    pub fn contact_forces(&self) -> &[Vec3] {
        self.contact().map_or(&[], |c| c.forces())
    }
}

/// How many obstacles a contact term has.
fn setup_obstacles(term: &crate::contact::term::ContactTerm) -> usize {
    term.setup().obstacles.len()
}
