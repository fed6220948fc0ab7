//! Which degrees of freedom are prescribed and how they move; which loads apply.
//!
//! Motions and loads ramp linearly from zero to their full value: over the load steps in
//! quasistatic mode, over `duration` seconds (default: the whole run) in backward Euler
//! (SPEC §10). Gravity is a body force: constant in backward Euler, ramped with the load steps in
//! quasistatic mode (so static equilibrium under gravity is reached gradually).

use crate::math::{Mat3, Vec3};
use crate::mesh::TetMesh;

/// A set of vertices picked by geometry, by list or by a named mesh group. Selection happens on
/// the rest positions.
#[derive(Clone, Debug, PartialEq)]
pub enum Region {
    /// Vertices inside the axis-aligned box [min, max] (inclusive).
    Box {
        /// Lower corner, m.
        min: Vec3,
        /// Upper corner, m.
        max: Vec3,
    },
    /// Vertices on the plane or on the side its normal points to: (X − point)·n ≥ −tolerance,
    /// with a tolerance of 1e-9 of the mesh's bounding-box diagonal.
    Plane {
        /// A point on the plane, m.
        point: Vec3,
        /// The plane's normal (any length).
        normal: Vec3,
    },
    /// Explicit 0-based vertex indices.
    Vertices(Vec<usize>),
    /// A named group of the mesh (a Gmsh physical group; the box generator names its faces
    /// `xmin`, `xmax`, `ymin`, `ymax`, `zmin`, `zmax`).
    Physical(String),
}

impl Region {
    /// The selected vertices, sorted and unique. An empty selection or an unknown vertex or group
    /// is an error (a misplaced box is the most common scene mistake).
    pub fn select(&self, mesh: &TetMesh) -> Result<Vec<usize>, String> {
        let x = &mesh.positions;
        let mut picked: Vec<usize> = match self {
            Region::Box { min, max } => (0..x.len())
                .filter(|&v| (0..3).all(|k| x[v][k] >= min[k] && x[v][k] <= max[k]))
                .collect(),
            Region::Plane { point, normal } => {
                let n = normal
                    .try_normalize(0.0)
                    .ok_or("the plane's normal is zero")?;
                let (lo, hi) = mesh.bounding_box();
                let tolerance = 1e-9 * (hi - lo).norm();
                (0..x.len())
                    .filter(|&v| (x[v] - point).dot(&n) >= -tolerance)
                    .collect()
            }
            Region::Vertices(list) => {
                if let Some(&bad) = list.iter().find(|&&v| v >= x.len()) {
                    return Err(format!(
                        "vertex {bad} does not exist (the mesh has {} vertices)",
                        x.len()
                    ));
                }
                list.clone()
            }
            Region::Physical(name) => match mesh.group(name) {
                Some(group) => group.vertices.clone(),
                None => {
                    let known: Vec<String> = mesh
                        .groups
                        .iter()
                        .map(|g| crate::error::clip(&g.name))
                        .collect();
                    return Err(format!(
                        "the mesh has no group named \"{}\" (it has: {})",
                        crate::error::clip(name),
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ));
                }
            },
        };
        picked.sort_unstable();
        picked.dedup();
        if picked.is_empty() {
            return Err(format!("the region selects no vertices: {self:?}"));
        }
        Ok(picked)
    }
}

/// A rigid motion reached at full ramp: rotation by `rotate_degrees` about `axis` through
/// `center`, then translation by `translate`. Intermediate ramps interpolate both linearly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Translation at full ramp, m.
    pub translate: Vec3,
    /// Rotation angle at full ramp, degrees.
    pub rotate_degrees: f64,
    /// Rotation axis (any length; ignored when the angle is zero).
    pub axis: Vec3,
    /// A point on the rotation axis, m.
    pub center: Vec3,
}

impl Default for Motion {
    fn default() -> Self {
        Motion {
            translate: Vec3::zeros(),
            rotate_degrees: 0.0,
            axis: Vec3::x(),
            center: Vec3::zeros(),
        }
    }
}

impl Motion {
    /// Where a point that started at `x0` is at ramp `s` ∈ [0, 1].
    pub fn apply(&self, s: f64, x0: &Vec3) -> Vec3 {
        let rotation = self.rotation(s);
        self.center + rotation * (x0 - self.center) + s * self.translate
    }

    /// The point that [`Motion::apply`] takes to `x` at ramp `s` (its inverse).
    pub fn unapply(&self, s: f64, x: &Vec3) -> Vec3 {
        let rotation = self.rotation(s);
        self.center + rotation.transpose() * (x - s * self.translate - self.center)
    }

    fn rotation(&self, s: f64) -> Mat3 {
        match nalgebra::Unit::try_new(self.axis, 0.0) {
            Some(axis) if self.rotate_degrees != 0.0 => {
                nalgebra::Rotation3::from_axis_angle(&axis, s * self.rotate_degrees.to_radians())
                    .into_inner()
            }
            _ => Mat3::identity(),
        }
    }
}

/// Dirichlet condition: selected components of selected vertices follow a prescribed motion of
/// their initial positions.
#[derive(Clone, Debug, PartialEq)]
pub struct Constraint {
    /// The constrained vertices.
    pub vertices: Vec<usize>,
    /// Which of x, y, z are constrained.
    pub components: [bool; 3],
    /// The motion (identity: held in place).
    pub motion: Motion,
    /// Ramp duration in seconds (backward Euler); None: the whole run.
    pub duration: Option<f64>,
    /// Release: after this time (s; quasistatic: load factor) the vertices are free again, with
    /// the velocity they had. None: held for the whole run.
    pub until: Option<f64>,
    /// Explicit target positions (m) of `vertices`, one per vertex in the same order, set by a
    /// caller between frames (`Simulation::set_fixed_targets`, for control loops): when Some,
    /// they replace the motion and its ramp, and hold from the next step on.
    pub targets: Option<Vec<Vec3>>,
}

impl Constraint {
    /// Whether the constraint holds at `clock` (it is released strictly after `until`).
    pub fn active(&self, clock: &Clock) -> bool {
        self.until.is_none_or(|until| clock.position() <= until)
    }
}

/// A dead load: nodal forces at full value, ramped.
#[derive(Clone, Debug, PartialEq)]
pub struct Load {
    /// (vertex, force in N) at full ramp.
    pub nodal: Vec<(usize, Vec3)>,
    /// Ramp duration in seconds (backward Euler); None: the whole run; 0: applied at once.
    pub duration: Option<f64>,
}

impl Load {
    /// Traction t (N/m² of rest area) on the boundary faces whose three vertices are all in
    /// `vertices`: each face gives area·t/3 to each of its vertices. Errors when no boundary face
    /// lies in the region.
    pub fn traction(mesh: &TetMesh, vertices: &[usize], traction: Vec3) -> Result<Self, String> {
        let faces = region_faces(mesh, vertices);
        if faces.is_empty() {
            return Err("the region contains no boundary face to carry a traction".into());
        }
        let mut nodal = Vec::with_capacity(3 * faces.len());
        for (face, area) in faces {
            for v in face {
                nodal.push((v, traction * (area / 3.0)));
            }
        }
        Ok(Load::merged(nodal))
    }

    /// A total force (N) spread over the region's boundary faces by area, or equally over its
    /// vertices when it contains no boundary face (a point load).
    pub fn total_force(mesh: &TetMesh, vertices: &[usize], force: Vec3) -> Self {
        let faces = region_faces(mesh, vertices);
        let area: f64 = faces.iter().map(|f| f.1).sum();
        if faces.is_empty() || area <= 0.0 {
            let share = force / vertices.len() as f64;
            return Load::merged(vertices.iter().map(|&v| (v, share)).collect());
        }
        let mut nodal = Vec::with_capacity(3 * faces.len());
        for (face, a) in faces {
            for v in face {
                nodal.push((v, force * (a / area / 3.0)));
            }
        }
        Load::merged(nodal)
    }

    /// The same force (N) on every selected vertex.
    pub fn point_force(vertices: &[usize], force: Vec3) -> Self {
        Load::merged(vertices.iter().map(|&v| (v, force)).collect())
    }

    /// Sum contributions per vertex (sorted by vertex, deterministic).
    fn merged(mut nodal: Vec<(usize, Vec3)>) -> Self {
        nodal.sort_by_key(|n| n.0);
        let mut out: Vec<(usize, Vec3)> = Vec::with_capacity(nodal.len());
        for (v, f) in nodal {
            match out.last_mut() {
                Some(last) if last.0 == v => last.1 += f,
                _ => out.push((v, f)),
            }
        }
        Load {
            nodal: out,
            duration: None,
        }
    }

    /// The resultant force at full ramp, N.
    pub fn resultant(&self) -> Vec3 {
        self.nodal.iter().map(|n| n.1).sum()
    }
}

/// Boundary faces with all three vertices in the (sorted) set, with their rest areas.
fn region_faces(mesh: &TetMesh, sorted_vertices: &[usize]) -> Vec<([usize; 3], f64)> {
    let inside = |v: &usize| sorted_vertices.binary_search(v).is_ok();
    mesh.boundary_faces()
        .into_iter()
        .filter(|f| f.iter().all(inside))
        .map(|f| {
            let [a, b, c] = f.map(|v| mesh.positions[v]);
            (f, 0.5 * (b - a).cross(&(c - a)).norm())
        })
        .collect()
}

/// How far along its ramp everything is at one moment of the run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clock {
    /// Backward Euler at `time` seconds of a run lasting `run_duration` seconds.
    Time {
        /// Seconds since the start.
        time: f64,
        /// Length of the whole run, the default ramp duration.
        run_duration: f64,
    },
    /// Quasistatic load factor in [0, 1]; gravity ramps too.
    LoadFactor(f64),
}

impl Clock {
    /// Ramp value in [0, 1] for something with the given duration.
    pub fn ramp(&self, duration: Option<f64>) -> f64 {
        match *self {
            Clock::Time { time, run_duration } => {
                let d = duration.unwrap_or(run_duration);
                if d <= 0.0 {
                    1.0
                } else {
                    (time / d).clamp(0.0, 1.0)
                }
            }
            Clock::LoadFactor(s) => s.clamp(0.0, 1.0),
        }
    }

    /// Seconds since the start (backward Euler) or the load factor (quasistatic).
    pub fn position(&self) -> f64 {
        match *self {
            Clock::Time { time, .. } => time,
            Clock::LoadFactor(s) => s,
        }
    }

    /// Scale of gravity: 1 in backward Euler, the load factor in quasistatic mode.
    pub fn gravity_scale(&self) -> f64 {
        match *self {
            Clock::Time { .. } => 1.0,
            Clock::LoadFactor(s) => s,
        }
    }
}

/// The free mask (1 free, 0 held, per vertex and component) that holds every vertex at whose
/// position `held` is true: a clamp given by a predicate, as tests and examples make one.
pub fn mask_holding(positions: &[Vec3], held: impl Fn(&Vec3) -> bool) -> Vec<Vec3> {
    positions
        .iter()
        .map(|p| {
            if held(p) {
                Vec3::zeros()
            } else {
                Vec3::repeat(1.0)
            }
        })
        .collect()
}

/// Everything at the boundary of the problem: Dirichlet constraints, loads and gravity.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Boundary {
    /// Dirichlet constraints, applied in order (a later one wins on shared components).
    pub constraints: Vec<Constraint>,
    /// Dead loads.
    pub loads: Vec<Load>,
    /// Gravitational acceleration, m/s².
    pub gravity: Vec3,
}

impl Boundary {
    /// 1 for free, 0 for constrained, per vertex and component (every constraint, released or
    /// not).
    pub fn free_mask(&self, vertex_count: usize) -> Vec<Vec3> {
        let mut free = vec![Vec3::repeat(1.0); vertex_count];
        self.fill_free_mask(None, &mut free);
        free
    }

    /// Whether some constraint is released during the run (the free mask changes).
    pub fn has_releases(&self) -> bool {
        self.constraints.iter().any(|c| c.until.is_some())
    }

    /// The free mask at `clock`: constraints released by then count as free.
    pub fn fill_free_mask(&self, clock: Option<&Clock>, free: &mut [Vec3]) {
        free.iter_mut().for_each(|f| *f = Vec3::repeat(1.0));
        for c in &self.constraints {
            if clock.is_some_and(|clock| !c.active(clock)) {
                continue;
            }
            for &v in &c.vertices {
                for (k, &constrained) in c.components.iter().enumerate() {
                    if constrained {
                        free[v][k] = 0.0;
                    }
                }
            }
        }
    }

    /// Number of constrained components.
    pub fn constrained_dofs(&self, vertex_count: usize) -> usize {
        self.free_mask(vertex_count)
            .iter()
            .map(|m| 3 - m.sum() as usize)
            .sum()
    }

    /// Set the constrained components of `x` to their prescribed values at `clock`, moving the
    /// initial positions `x0`.
    pub fn prescribe(&self, clock: &Clock, x0: &[Vec3], x: &mut [Vec3]) {
        for c in self.constraints.iter().filter(|c| c.active(clock)) {
            let s = clock.ramp(c.duration);
            for (i, &v) in c.vertices.iter().enumerate() {
                let target = match &c.targets {
                    Some(targets) => targets[i],
                    None => c.motion.apply(s, &x0[v]),
                };
                for k in 0..3 {
                    if c.components[k] {
                        x[v][k] = target[k];
                    }
                }
            }
        }
    }

    /// `f = m·g·(gravity scale) + Σ ramped loads` (overwrites f).
    pub fn external_forces(&self, clock: &Clock, masses: &[f64], f: &mut [Vec3]) {
        let g = self.gravity * clock.gravity_scale();
        for (f, &m) in f.iter_mut().zip(masses) {
            *f = m * g;
        }
        for load in &self.loads {
            let s = clock.ramp(load.duration);
            for &(v, force) in &load.nodal {
                f[v] += s * force;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    #[test]
    fn traction_sums_to_force_times_area() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 2.0), [4, 2, 2]);
        let tip = Region::Box {
            min: Vec3::new(3.99, -1.0, -1.0),
            max: Vec3::new(4.01, 2.0, 3.0),
        }
        .select(&mesh)
        .unwrap();
        let load = Load::traction(&mesh, &tip, Vec3::new(0.0, -100.0, 0.0)).unwrap();
        assert!((load.resultant() - Vec3::new(0.0, -200.0, 0.0)).norm() < 1e-10);
        let total = Load::total_force(&mesh, &tip, Vec3::new(5.0, 0.0, 0.0));
        assert!((total.resultant() - Vec3::new(5.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn plane_selects_on_and_behind() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [2, 1, 1]);
        let picked = Region::Plane {
            point: Vec3::zeros(),
            normal: -Vec3::x(),
        }
        .select(&mesh)
        .unwrap();
        assert_eq!(picked.len(), 4);
        assert!(picked.iter().all(|&v| mesh.positions[v].x == 0.0));
        let err = Region::Physical("nope".into()).select(&mesh).unwrap_err();
        assert!(err.contains("xmin"), "{err}");
    }

    #[test]
    fn motion_rotates_about_center_and_ramps() {
        let m = Motion {
            translate: Vec3::new(0.0, 0.0, 1.0),
            rotate_degrees: 90.0,
            axis: Vec3::x(),
            center: Vec3::new(0.0, 0.5, 0.5),
        };
        let p = m.apply(1.0, &Vec3::new(1.0, 1.0, 0.5));
        assert!((p - Vec3::new(1.0, 0.5, 2.0)).norm() < 1e-12, "{p}");
        assert_eq!(
            m.apply(0.0, &Vec3::new(1.0, 1.0, 0.5)),
            Vec3::new(1.0, 1.0, 0.5)
        );
        let clock = Clock::Time {
            time: 0.5,
            run_duration: 2.0,
        };
        assert_eq!(clock.ramp(None), 0.25);
        assert_eq!(clock.ramp(Some(0.0)), 1.0);
    }
}
