//! What a caller may change between frames, for control and optimisation loops (and the Python
//! module): positions, velocities, and where the fixed vertices go. Each value is checked the way
//! the scene file checks the same value (finite, within the cap of its unit, a rotation about a
//! non-zero axis), and refused with an [`Error`] naming it before anything changes.
//!
//! Vertex arrays here are in the *input* numbering: the mesh file's, which is also the output
//! frames'. The simulation may number vertices differently inside, for memory locality
//! ([`crate::mesh::ordering`]); [`Simulation::to_input_order`] and
//! [`Simulation::from_input_order`] convert.

use crate::boundary::Motion;
use crate::error::{Error, Result};
use crate::integrator::Integrator;
use crate::math::Vec3;
use crate::scene::beyond_limit;
use crate::sim::Simulation;

/// The first of `points` (a row number and why) that is not finite or is beyond the cap of
/// `unit`: `what 3 is not finite`, `what 3: 1e300 is beyond any physical value: …`.
fn bad_point(points: &[Vec3], unit: &str, what: &str) -> Option<String> {
    points.iter().enumerate().find_map(|(i, p)| {
        if !p.iter().all(|c| c.is_finite()) {
            Some(format!("{what} {i} is not finite"))
        } else {
            p.iter()
                .find_map(|&c| beyond_limit(c, unit))
                .map(|why| format!("{what} {i}: {why}"))
        }
    })
}

impl Simulation {
    /// Per-vertex values in the simulation's numbering (`state.x`, `body.mesh.positions`, …),
    /// reordered into the input's.
    pub fn to_input_order<T: Copy>(&self, values: &[T]) -> Vec<T> {
        match &self.renumbering {
            Some(r) => r.vertices_to_old(values),
            None => values.to_vec(),
        }
    }

    /// Per-vertex values in the input's numbering, reordered into the simulation's.
    pub fn from_input_order<T: Copy>(&self, values: &[T]) -> Vec<T> {
        match &self.renumbering {
            Some(r) => r.to_new(values),
            None => values.to_vec(),
        }
    }

    /// The tets in the input's order, with the input's vertex numbers.
    pub fn input_tets(&self) -> Vec<[usize; 4]> {
        match &self.renumbering {
            Some(r) => r.tets_to_old_mesh(&self.body.mesh.tets),
            None => self.body.mesh.tets.clone(),
        }
    }

    /// The ten nodes of each quadratic tet in input numbering and order (corners, then the
    /// nodes on edges 01, 12, 02, 03, 13, 23); None for linear tets.
    pub fn input_quadratic_tets(&self) -> Option<Vec<[usize; 10]>> {
        let mesh = &self.body.mesh;
        if !mesh.is_quadratic() {
            return None;
        }
        let mut tets = vec![[0; 10]; mesh.tets.len()];
        for t in 0..mesh.tets.len() {
            let nodes = mesh.quadratic_nodes(t);
            match &self.renumbering {
                Some(r) => tets[r.tet_old[t]] = nodes.map(|v| r.vertex_old[v]),
                None => tets[t] = nodes,
            }
        }
        Some(tets)
    }

    /// Move every vertex to `x` (input numbering), as `[initial] positions` would: one finite
    /// position per vertex, and none inside an obstacle when contact is on. The next step
    /// starts from here; constrained components are set by their constraint again at that
    /// step. The positions at frame 0, which prescribed motions move, stay as they were.
    pub fn set_positions(&mut self, x: &[Vec3]) -> Result<()> {
        let n = self.body.vertex_count();
        if x.len() != n {
            return Err(Error::parameter(
                "positions",
                format!(
                    "{} positions for a mesh of {n} vertices (same count and order needed)",
                    x.len()
                ),
            ));
        }
        if let Some(why) = bad_point(x, "m", "position") {
            return Err(Error::parameter("positions", why));
        }
        let x = self.from_input_order(x);
        if let Some(message) = self.contact().and_then(|c| c.intersection(&x)) {
            return Err(Error::parameter("positions", message));
        }
        self.state.x = x;
        Ok(())
    }

    /// Set every vertex's velocity to `v` (input numbering), as `[initial] velocity` would:
    /// finite, and zero on constrained components (values given there are dropped: the
    /// constraint's motion sets them). Quasistatic runs have no velocities: only zeros are
    /// accepted there.
    pub fn set_velocities(&mut self, v: &[Vec3]) -> Result<()> {
        let n = self.body.vertex_count();
        if v.len() != n {
            return Err(Error::parameter(
                "velocities",
                format!(
                    "{} velocities for a mesh of {n} vertices (same count and order needed)",
                    v.len()
                ),
            ));
        }
        if let Some(why) = bad_point(v, "m/s", "velocity") {
            return Err(Error::parameter("velocities", why));
        }
        if self.params.integrator == Integrator::Quasistatic
            && v.iter().any(|p| *p != Vec3::zeros())
        {
            return Err(Error::parameter(
                "velocities",
                "a quasistatic simulation has no velocities (only zeros can be set)",
            ));
        }
        let v = self.from_input_order(v);
        for ((state, given), free) in self.state.v.iter_mut().zip(&v).zip(&self.free) {
            *state = given.component_mul(free);
        }
        Ok(())
    }

    /// The vertices of `[[fixed]]` entry `index` (0-based: `[[fixed]] #1` is 0), in the input
    /// numbering, sorted: the order [`Simulation::set_fixed_targets`] takes targets in.
    pub fn fixed_vertices(&self, index: usize) -> Result<Vec<usize>> {
        self.constraint(index)?;
        Ok(self
            .fixed_input_order(index)
            .into_iter()
            .map(|(v, _)| v)
            .collect())
    }

    /// Give `[[fixed]]` entry `index` a new rigid motion of its frame-0 positions, ramped over
    /// `duration` seconds from the start of the run (None: the whole run; 0: at once), checked
    /// like the scene's `motion` and `duration` keys. It takes effect at the next step and
    /// replaces targets set by [`Simulation::set_fixed_targets`].
    pub fn set_fixed_motion(
        &mut self,
        index: usize,
        motion: Motion,
        duration: Option<f64>,
    ) -> Result<()> {
        let key = self.constraint(index)?;
        let text = |v: Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
        let finite3 = |name: &str, v: Vec3, unit: &str| {
            let why = if v.iter().all(|c| c.is_finite()) {
                v.iter().find_map(|&c| beyond_limit(c, unit))
            } else {
                Some(format!("must be finite ({unit}), got {}", text(v)))
            };
            match why {
                Some(why) => Err(Error::parameter(format!("{key} motion.{name}"), why)),
                None => Ok(()),
            }
        };
        finite3("translate", motion.translate, "m")?;
        let angle = motion.rotate_degrees;
        let why = if angle.is_finite() {
            beyond_limit(angle, "degrees")
        } else {
            Some(format!("must be finite (degrees), got {angle}"))
        };
        if let Some(why) = why {
            return Err(Error::parameter(
                format!("{key} motion.rotate_degrees"),
                why,
            ));
        }
        finite3("axis", motion.axis, "a direction")?;
        // A norm that is zero (or underflows to zero) would leave the rotation out silently.
        if angle != 0.0 && motion.axis.norm() == 0.0 {
            return Err(Error::parameter(
                format!("{key} motion.axis"),
                format!(
                    "a rotation of {angle} degrees needs a non-zero axis, got {}",
                    text(motion.axis)
                ),
            ));
        }
        finite3("center", motion.center, "m")?;
        if let Some(d) = duration {
            let why = if d >= 0.0 && d.is_finite() {
                beyond_limit(d, "s")
            } else {
                Some(format!("must be zero or positive and finite (s), got {d}"))
            };
            if let Some(why) = why {
                return Err(Error::parameter(format!("{key} duration"), why));
            }
        }
        let c = &mut self.boundary.constraints[index];
        c.motion = motion;
        c.duration = duration;
        c.targets = None;
        Ok(())
    }

    /// Hold the vertices of `[[fixed]]` entry `index` at `targets` (m, one finite position per
    /// vertex of [`Simulation::fixed_vertices`], in its order) from the next step on, in place of
    /// its motion. Only the entry's constrained components follow their targets.
    pub fn set_fixed_targets(&mut self, index: usize, targets: &[Vec3]) -> Result<()> {
        let key = self.constraint(index)?;
        let order = self.fixed_input_order(index);
        if targets.len() != order.len() {
            return Err(Error::parameter(
                format!("{key} targets"),
                format!(
                    "{} targets for {} fixed vertices (one per vertex of fixed_vertices({index}))",
                    targets.len(),
                    order.len()
                ),
            ));
        }
        if let Some(why) = bad_point(targets, "m", "target") {
            return Err(Error::parameter(format!("{key} targets"), why));
        }
        let mut inside = vec![Vec3::zeros(); targets.len()];
        for ((_, k), target) in order.iter().zip(targets) {
            inside[*k] = *target;
        }
        self.boundary.constraints[index].targets = Some(inside);
        Ok(())
    }

    /// `[[fixed]] #index+1` as messages name it, or an error when there is no such entry.
    fn constraint(&self, index: usize) -> Result<String> {
        let n = self.boundary.constraints.len();
        if index >= n {
            return Err(Error::parameter(
                "fixed",
                format!("there is no fixed entry {index} (the scene has {n}, numbered from 0)"),
            ));
        }
        Ok(format!("[[fixed]] #{}", index + 1))
    }

    /// (input vertex, position in the constraint's own list) of entry `index`, by input vertex.
    fn fixed_input_order(&self, index: usize) -> Vec<(usize, usize)> {
        let vertices = &self.boundary.constraints[index].vertices;
        let mut order: Vec<(usize, usize)> = vertices
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                let input = self.renumbering.as_ref().map_or(v, |r| r.vertex_old[v]);
                (input, k)
            })
            .collect();
        order.sort_unstable();
        order
    }
}
