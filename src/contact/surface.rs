//! The contact surface of a tet mesh (or of any triangle surface): its vertices, edges and
//! faces, by the mesh's own vertex ids, so that contact forces land directly on mesh dofs.
//!
//! Only the boundary can touch anything, so contact works on boundary faces (outward, from
//! [`TetMesh::boundary_faces_with_tets`]), their edges (each once, as [a, b] with a < b, sorted)
//! and their vertices (sorted). Interior vertices never take part.

use super::broad::Primitives;
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// Boundary vertices, edges and faces, all as vertex ids of the underlying mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ContactSurface {
    /// Vertices used by a boundary face, sorted, unique.
    pub vertices: Vec<usize>,
    /// Edges of the boundary faces, each [a, b] with a < b, sorted, unique.
    pub edges: Vec<[usize; 2]>,
    /// Boundary faces with outward normals (right-hand rule), in the mesh's deterministic order.
    pub faces: Vec<[usize; 3]>,
    /// The tet each face belongs to (empty for a surface built from bare triangles).
    pub face_tets: Vec<usize>,
}

impl ContactSurface {
    /// The boundary of a tet mesh. Tets with out-of-range vertex ids are skipped (as by
    /// `boundary_faces_with_tets`), so this never panics on an unvalidated mesh.
    pub fn from_mesh(mesh: &TetMesh) -> Self {
        let (faces, face_tets) = mesh.boundary_faces_with_tets().into_iter().unzip();
        let mut surface = ContactSurface::from_triangles(faces);
        surface.face_tets = face_tets;
        surface
    }

    /// The vertices and edges of a triangle surface (open or closed; orientation kept).
    pub fn from_triangles(faces: Vec<[usize; 3]>) -> Self {
        let mut edges: Vec<[usize; 2]> = faces
            .iter()
            .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
            .filter(|[a, b]| a != b)
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let mut vertices: Vec<usize> = faces.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        ContactSurface {
            vertices,
            edges,
            faces,
            face_tets: Vec::new(),
        }
    }

    /// Position of mesh vertex `v` in [`ContactSurface::vertices`], if it is on the surface.
    pub fn vertex_index(&self, v: usize) -> Option<usize> {
        self.vertices.binary_search(&v).ok()
    }

    /// The primitives for the broad phase, over positions at the start and end of a step.
    pub fn primitives<'a>(&'a self, start: &'a [Vec3], end: &'a [Vec3]) -> Primitives<'a> {
        Primitives {
            start,
            end,
            vertices: &self.vertices,
            edges: &self.edges,
            faces: &self.faces,
        }
    }

    /// Σ over edges of ‖x_a − x_b‖ / count: the mean surface edge length (m), 0 without edges.
    pub fn mean_edge_length(&self, x: &[Vec3]) -> f64 {
        if self.edges.is_empty() {
            return 0.0;
        }
        let sum: f64 = self.edges.iter().map(|&[a, b]| (x[a] - x[b]).norm()).sum();
        sum / self.edges.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    #[test]
    fn closed_boundary_has_euler_characteristic_two_and_outward_faces() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [3, 2, 2]);
        let s = ContactSurface::from_mesh(&mesh);
        // V − E + F = 2 for a closed genus-0 surface; every edge is on two faces.
        let (v, e, f) = (s.vertices.len(), s.edges.len(), s.faces.len());
        assert_eq!(v as i64 - e as i64 + f as i64, 2);
        assert_eq!(2 * e, 3 * f);
        assert_eq!(s.face_tets.len(), f);
        // Interior vertex (1, 0.5, 0.5) is not there; corners are.
        assert!(s.vertices.iter().all(|&i| {
            let p = mesh.positions[i];
            p.x == 0.0 || p.x == 2.0 || p.y == 0.0 || p.y == 1.0 || p.z == 0.0 || p.z == 1.0
        }));
        // Outward: the normal points away from the centroid, and the volume is positive.
        let c = Vec3::new(1.0, 0.5, 0.5);
        let x = &mesh.positions;
        let mut volume = 0.0;
        for &[a, b, cc] in &s.faces {
            let n = (x[b] - x[a]).cross(&(x[cc] - x[a]));
            assert!(n.dot(&(x[a] - c)) > 0.0);
            volume += x[a].dot(&x[b].cross(&x[cc])) / 6.0;
        }
        assert!((volume - 2.0).abs() < 1e-12);
        assert!(s.edges.windows(2).all(|w| w[0] < w[1]));
        assert!(s.edges.iter().all(|e| e[0] < e[1]));
        assert_eq!(s.vertex_index(s.vertices[3]), Some(3));
    }

    #[test]
    fn a_bad_mesh_does_not_panic() {
        let mesh = TetMesh::new(vec![Vec3::zeros(); 3], vec![[0, 1, 2, 7]]);
        assert_eq!(ContactSurface::from_mesh(&mesh), ContactSurface::default());
    }
}
