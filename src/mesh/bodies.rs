//! Several deformable bodies in one mesh (SPEC §11 `[[body]]`).
//!
//! The bodies of a scene are concatenated into one [`TetMesh`], body after body: one elastic
//! body, one Newton solve, one linear system, and contact between bodies is the same barrier as a
//! body's contact with itself. [`Bodies`] remembers which vertices and tets came from which
//! body, in that input order (output is written in it, so frames list body after body).

use crate::math::{Mat3, Vec3};
use crate::mesh::{Group, TetMesh};

/// Where each body's vertices and tets sit in the merged mesh (input order).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Bodies {
    /// Body names, body 0 first.
    pub names: Vec<String>,
    /// Vertex ranges: body b owns vertices `vertex_start[b]..vertex_start[b + 1]`.
    pub vertex_start: Vec<usize>,
    /// Tet ranges: body b owns tets `tet_start[b]..tet_start[b + 1]`.
    pub tet_start: Vec<usize>,
}

impl Bodies {
    /// One body named `name` holding the whole of `mesh`.
    pub fn single(name: impl Into<String>, mesh: &TetMesh) -> Self {
        Bodies {
            names: vec![name.into()],
            vertex_start: vec![0, mesh.positions.len()],
            tet_start: vec![0, mesh.tets.len()],
        }
    }

    /// Concatenate named meshes into one: vertices and tets body after body, groups of the same
    /// name and dimension merged (a region naming a group selects it in every body), file ids
    /// dropped (each part is validated with its own ids before merging).
    pub fn merge(parts: Vec<(String, TetMesh)>) -> (TetMesh, Bodies) {
        let mut merged = TetMesh::default();
        let mut bodies = Bodies {
            names: Vec::with_capacity(parts.len()),
            vertex_start: vec![0],
            tet_start: vec![0],
        };
        for (name, mesh) in parts {
            let (v0, t0) = (merged.positions.len(), merged.tets.len());
            merged.positions.extend(&mesh.positions);
            merged
                .tets
                .extend(mesh.tets.iter().map(|t| t.map(|v| v + v0)));
            merged
                .edge_nodes
                .extend(mesh.edge_nodes.iter().map(|e| e.map(|v| v + v0)));
            for g in mesh.groups {
                let shifted = Group {
                    vertices: g.vertices.iter().map(|v| v + v0).collect(),
                    faces: g.faces.iter().map(|f| f.map(|v| v + v0)).collect(),
                    tets: g.tets.iter().map(|t| t + t0).collect(),
                    ..g
                };
                match merged
                    .groups
                    .iter_mut()
                    .find(|h| h.name == shifted.name && h.dim == shifted.dim)
                {
                    Some(h) => {
                        h.vertices.extend(shifted.vertices);
                        h.faces.extend(shifted.faces);
                        h.tets.extend(shifted.tets);
                    }
                    None => merged.groups.push(shifted),
                }
            }
            bodies.names.push(name);
            bodies.vertex_start.push(merged.positions.len());
            bodies.tet_start.push(merged.tets.len());
        }
        (merged, bodies)
    }

    /// How many bodies.
    pub fn count(&self) -> usize {
        self.names.len()
    }

    /// The index of the body named `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// The vertex range of body `b`.
    pub fn vertices(&self, b: usize) -> std::ops::Range<usize> {
        self.vertex_start[b]..self.vertex_start[b + 1]
    }

    /// The tet range of body `b`.
    pub fn tets(&self, b: usize) -> std::ops::Range<usize> {
        self.tet_start[b]..self.tet_start[b + 1]
    }

    /// The body of every vertex, in input order.
    pub fn vertex_body(&self) -> Vec<u32> {
        spread(&self.vertex_start)
    }

    /// The body of every tet, in input order.
    pub fn tet_body(&self) -> Vec<u32> {
        spread(&self.tet_start)
    }
}

fn spread(start: &[usize]) -> Vec<u32> {
    let mut out = Vec::with_capacity(start.last().copied().unwrap_or(0));
    for (b, w) in start.windows(2).enumerate() {
        out.extend(std::iter::repeat_n(b as u32, w[1] - w[0]));
    }
    out
}

/// Where a body's rest mesh goes: scaled about the origin (a change of units), then rotated by
/// `rotate_degrees` about `axis` through its centroid (the mean of its vertices, after scaling),
/// then translated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Scale factor (> 0).
    pub scale: f64,
    /// Rotation angle, degrees (right-hand rule about `axis`).
    pub rotate_degrees: f64,
    /// Rotation axis (need not be unit; nonzero when the angle is).
    pub axis: Vec3,
    /// Translation, m.
    pub translate: Vec3,
}

impl Default for Placement {
    fn default() -> Self {
        Placement {
            scale: 1.0,
            rotate_degrees: 0.0,
            axis: Vec3::z(),
            translate: Vec3::zeros(),
        }
    }
}

impl Placement {
    /// Move `mesh`'s rest positions. The identity placement leaves every bit as it was.
    pub fn apply(&self, mesh: &mut TetMesh) {
        if *self == Placement::default() {
            return;
        }
        let centroid = self.pivot(&mesh.positions);
        for p in &mut mesh.positions {
            *p = self.map(*p, centroid);
        }
    }

    /// The centroid the rotation turns about: the mean of `positions` after scaling.
    pub fn pivot(&self, positions: &[Vec3]) -> Vec3 {
        let n = positions.len().max(1) as f64;
        positions.iter().map(|p| p * self.scale).sum::<Vec3>() / n
    }

    /// Where the placement takes the point `p`, rotating about `pivot` (see [`Placement::pivot`]):
    /// so that a surface embedded in a mesh moves with it.
    pub fn map(&self, p: Vec3, pivot: Vec3) -> Vec3 {
        if *self == Placement::default() {
            return p;
        }
        pivot + rotation(self.axis, self.rotate_degrees) * (p * self.scale - pivot) + self.translate
    }
}

/// The rotation by `degrees` about `axis` (identity for a zero angle or axis).
fn rotation(axis: Vec3, degrees: f64) -> Mat3 {
    match nalgebra::Unit::try_new(axis, 0.0) {
        Some(axis) if degrees != 0.0 => {
            *nalgebra::Rotation3::from_axis_angle(&axis, degrees.to_radians()).matrix()
        }
        _ => Mat3::identity(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    #[test]
    fn merged_bodies_keep_their_ranges_and_groups() {
        let a = box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [1, 1, 1]);
        let b = box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [2, 1, 1]);
        let (na, ta) = (a.positions.len(), a.tets.len());
        let (merged, bodies) = Bodies::merge(vec![("a".into(), a.clone()), ("b".into(), b)]);
        assert_eq!(bodies.count(), 2);
        assert_eq!(bodies.vertices(1).start, na);
        assert_eq!(bodies.tets(1).start, ta);
        assert_eq!(bodies.vertex_body().len(), merged.positions.len());
        assert_eq!(bodies.tet_body()[ta], 1);
        assert_eq!(bodies.index("b"), Some(1));
        // Body 1's tets point at body 1's vertices.
        assert!(
            merged.tets[ta..]
                .iter()
                .flatten()
                .all(|&v| bodies.vertices(1).contains(&v))
        );
        // "xmin" holds both bodies' faces.
        let xmin = merged.group("xmin").unwrap();
        let in_a = a.group("xmin").unwrap().vertices.len();
        assert!(xmin.vertices.len() > in_a);
        assert!(xmin.vertices.iter().any(|&v| v >= na));
    }

    #[test]
    fn placement_scales_rotates_about_the_centroid_then_translates() {
        let mut mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [2, 1, 1]);
        let placement = Placement {
            scale: 0.5,
            rotate_degrees: 90.0,
            axis: Vec3::new(0.0, 0.0, 2.0),
            translate: Vec3::new(10.0, 0.0, 0.0),
        };
        placement.apply(&mut mesh);
        let (lo, hi) = mesh.bounding_box();
        // Scaled to 1 × 0.5 × 0.5 (centroid 0.5, 0.25, 0.25), turned a quarter about z: 0.5 along x
        // and 1 along y, about the same centroid, then moved 10 along x.
        assert!((lo - Vec3::new(10.25, -0.25, 0.0)).norm() < 1e-12, "{lo}");
        assert!((hi - Vec3::new(10.75, 0.75, 0.5)).norm() < 1e-12, "{hi}");
        // The identity placement keeps the bits.
        let before = box_mesh(Vec3::zeros(), Vec3::new(0.3, 0.7, 0.1), [1, 2, 1]);
        let mut after = before.clone();
        Placement::default().apply(&mut after);
        assert_eq!(before, after);
    }
}
