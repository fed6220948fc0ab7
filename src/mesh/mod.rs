//! Topology and rest geometry of a tetrahedral mesh, and its validation.
//!
//! A [`TetMesh`] is what every reader and generator produces and what the elastic body is built
//! on. Validation (finite coordinates, indices in range, no degenerate tets) happens here, once,
//! so the physics never sees a NaN or a zero-volume tet.

pub mod bodies;
pub mod doctor;
pub mod embed;
pub mod generate;
pub mod ordering;
pub mod overlap;
pub mod quadratic;
pub mod stuff;

use crate::error::MeshProblem;
use crate::math::{Mat3, Vec3};

/// Tets are "degenerate" when their volume is below this fraction of the cube of their longest
/// edge. A regular tet has V ≈ 0.118 ℓ³; a tet flatter than 1e-10 of that cannot carry a
/// meaningful Bm = Dm⁻¹ (its condition number exceeds 1e10). Scale-free, so the same mesh in mm
/// and in km is judged the same.
pub const DEGENERATE_RELATIVE_VOLUME: f64 = 1e-11;

/// A tet is also degenerate when its volume is negligible against the mesh's mean edge length
/// cubed: this catches tiny tets whose four vertices (nearly) coincide.
pub const DEGENERATE_MESH_VOLUME: f64 = 1e-15;

/// A named subset of a mesh, as Gmsh physical groups provide (also built by generators).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Group {
    /// The group's name (may be empty when the file gives only a tag).
    pub name: String,
    /// The group's numeric tag in the file (0 when it has none).
    pub tag: i64,
    /// Dimension of the entities that define it: 0 points, 1 lines, 2 faces, 3 volumes.
    pub dim: usize,
    /// Every vertex touched by the group, sorted and unique.
    pub vertices: Vec<usize>,
    /// Triangles of the group (dimension 2), as vertex indices.
    pub faces: Vec<[usize; 3]>,
    /// Tets of the group (dimension 3), as tet indices.
    pub tets: Vec<usize>,
}

/// A linear tetrahedral mesh: rest positions and tets (four vertex indices each).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetMesh {
    /// Rest positions in metres.
    pub positions: Vec<Vec3>,
    /// Tets as four 0-based vertex indices (their corners). Either orientation is accepted.
    pub tets: Vec<[usize; 4]>,
    /// Quadratic tets only (empty otherwise): each tet's six mid-edge nodes, in the order of
    /// [`quadratic::EDGES`].
    pub edge_nodes: Vec<[usize; 6]>,
    /// Named groups (Gmsh physical groups, generator faces).
    pub groups: Vec<Group>,
    /// Id of each tet in the source file, for error messages (None: the 0-based index).
    pub tet_ids: Option<Vec<u64>>,
    /// Id of each vertex in the source file, for error messages (None: the 0-based index).
    pub vertex_ids: Option<Vec<u64>>,
}

impl TetMesh {
    /// A mesh from positions and tets, with no groups and no file ids.
    pub fn new(positions: Vec<Vec3>, tets: Vec<[usize; 4]>) -> Self {
        TetMesh {
            positions,
            tets,
            ..Default::default()
        }
    }

    /// The id of tet `t` in the source file (or `t`).
    pub fn tet_id(&self, t: usize) -> u64 {
        self.tet_ids.as_ref().map_or(t as u64, |ids| ids[t])
    }

    /// The id of vertex `v` in the source file (or `v`).
    pub fn vertex_id(&self, v: usize) -> u64 {
        self.vertex_ids.as_ref().map_or(v as u64, |ids| ids[v])
    }

    /// `Dm = [X₁−X₀, X₂−X₀, X₃−X₀]` of tet `t` at positions `x`.
    pub fn edge_matrix(x: &[Vec3], tet: &[usize; 4]) -> Mat3 {
        let x0 = x[tet[0]];
        Mat3::from_columns(&[x[tet[1]] - x0, x[tet[2]] - x0, x[tet[3]] - x0])
    }

    /// Signed volume of tet `t` in the rest configuration (negative: inverted ordering).
    pub fn signed_volume(&self, t: usize) -> f64 {
        Self::edge_matrix(&self.positions, &self.tets[t]).determinant() / 6.0
    }

    /// Mean length of the tets' edges (each tet's six edges, shared edges counted per tet).
    pub fn mean_edge_length(&self) -> f64 {
        if self.tets.is_empty() {
            return 0.0;
        }
        let total: f64 = self
            .tets
            .iter()
            .map(|t| tet_edges(&self.positions, t).iter().sum::<f64>())
            .sum();
        total / (6 * self.tets.len()) as f64
    }

    /// Check that the mesh can be simulated: it has tets, indices are in range, coordinates are
    /// finite and no tet is degenerate. Every degenerate tet is listed, not just the first.
    pub fn validate(&self) -> Result<(), MeshProblem> {
        if self.tets.is_empty() {
            return Err(MeshProblem::NoTetrahedra);
        }
        for (t, tet) in self.tets.iter().enumerate() {
            let edge_nodes = self.edge_nodes.get(t).map_or(&[][..], |e| &e[..]);
            if let Some(&v) = tet
                .iter()
                .chain(edge_nodes)
                .find(|&&v| v >= self.positions.len())
            {
                // Readers map file ids to indices and report unknown ids themselves; here the
                // index is all there is.
                return Err(MeshProblem::IndexOutOfRange {
                    tet: self.tet_id(t),
                    vertex: v as u64,
                });
            }
        }
        if let Some(v) = self
            .positions
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(MeshProblem::NonFinite {
                vertex: self.vertex_id(v),
            });
        }
        let degenerate = self.degenerate_tets();
        if !degenerate.is_empty() {
            return Err(MeshProblem::Degenerate {
                tets: degenerate.into_iter().map(|t| self.tet_id(t)).collect(),
            });
        }
        Ok(())
    }

    /// Indices of tets with zero or near-zero volume (see [`DEGENERATE_RELATIVE_VOLUME`]).
    pub fn degenerate_tets(&self) -> Vec<usize> {
        let mesh_scale = self.mean_edge_length().powi(3);
        (0..self.tets.len())
            .filter(|&t| {
                let tet = &self.tets[t];
                let volume = self.signed_volume(t).abs();
                let longest = tet_edges(&self.positions, tet)
                    .into_iter()
                    .fold(0.0, f64::max);
                let distinct = (0..4).all(|i| (i + 1..4).all(|j| tet[i] != tet[j]));
                // Written so that a NaN volume also counts as degenerate.
                let sound = volume > DEGENERATE_RELATIVE_VOLUME * longest.powi(3)
                    && volume > DEGENERATE_MESH_VOLUME * mesh_scale;
                !distinct || !sound
            })
            .collect()
    }

    /// Boundary triangles (faces used by exactly one tet), oriented with outward normals, in a
    /// deterministic order (sorted by their vertex sets).
    pub fn boundary_faces(&self) -> Vec<[usize; 3]> {
        self.boundary_faces_with_tets()
            .into_iter()
            .map(|(f, _)| f)
            .collect()
    }

    /// [`TetMesh::boundary_faces`] with the tet each face belongs to. Tets with out-of-range
    /// vertex indices are skipped (so this is safe on unvalidated meshes).
    pub fn boundary_faces_with_tets(&self) -> Vec<([usize; 3], usize)> {
        let n = self.positions.len();
        let mut faces: Vec<([usize; 3], [usize; 3], usize)> =
            Vec::with_capacity(4 * self.tets.len());
        for (t, tet) in self.tets.iter().enumerate() {
            let edge_nodes = self.edge_nodes.get(t).map_or(&[][..], |e| &e[..]);
            if tet.iter().chain(edge_nodes).any(|&v| v >= n) {
                continue;
            }
            let [a, b, c, d] = *tet;
            // Outward for a positively oriented tet; flipped for a negatively oriented one.
            let flip = self.signed_volume(t) < 0.0;
            for face in [[b, c, d], [a, d, c], [a, b, d], [a, c, b]] {
                let oriented = if flip {
                    [face[0], face[2], face[1]]
                } else {
                    face
                };
                let mut key = face;
                key.sort_unstable();
                faces.push((key, oriented, t));
            }
        }
        faces.sort_unstable_by_key(|f| (f.0, f.2));
        let mut boundary = Vec::new();
        let mut i = 0;
        while i < faces.len() {
            let mut j = i + 1;
            while j < faces.len() && faces[j].0 == faces[i].0 {
                j += 1;
            }
            if j - i == 1 {
                let (face, t) = (faces[i].1, faces[i].2);
                if self.is_quadratic() {
                    let mid = |a: usize, b: usize| {
                        let local = |v: usize| self.tets[t].iter().position(|&c| c == v).unwrap();
                        self.edge_node(t, local(a), local(b))
                    };
                    let [p, q, r] = face;
                    let mids = [mid(p, q), mid(q, r), mid(r, p)];
                    for sub in quadratic::split_face(face, mids) {
                        boundary.push((sub, t));
                    }
                } else {
                    boundary.push((face, t));
                }
            }
            i = j;
        }
        boundary
    }

    /// Swap the last two vertices of every negatively oriented tet, so that all have positive
    /// signed volume (readers do this on load). Returns how many were reoriented.
    pub fn reorient(&mut self) -> usize {
        let mut count = 0;
        for t in 0..self.tets.len() {
            if self.signed_volume(t) < 0.0 {
                self.tets[t].swap(2, 3);
                if let Some(e) = self.edge_nodes.get_mut(t) {
                    *e = quadratic::SWAP_23.map(|k| e[k]);
                }
                count += 1;
            }
        }
        count
    }

    /// Drop the vertices that no tet uses and renumber the others in their order, updating the
    /// groups (dropping group faces that lose a vertex) and `vertex_ids`. Returns the file ids
    /// (see [`TetMesh::vertex_id`]) of the dropped vertices. Does nothing when a tet index is out
    /// of range (see [`TetMesh::validate`]).
    pub fn drop_unreferenced_vertices(&mut self) -> Vec<u64> {
        let n = self.positions.len();
        if self
            .tets
            .iter()
            .flatten()
            .chain(self.edge_nodes.iter().flatten())
            .any(|&v| v >= n)
        {
            // Not a mesh to renumber: `validate` reports the bad index.
            return Vec::new();
        }
        let mut used = vec![false; n];
        for &v in self
            .tets
            .iter()
            .flatten()
            .chain(self.edge_nodes.iter().flatten())
        {
            used[v] = true;
        }
        if used.iter().all(|&u| u) {
            return Vec::new();
        }
        let mut new_index = vec![usize::MAX; n];
        let mut dropped = Vec::new();
        let mut next = 0;
        for v in 0..n {
            if used[v] {
                new_index[v] = next;
                next += 1;
            } else {
                dropped.push(self.vertex_id(v));
            }
        }
        let keep = |v: &usize| used[*v];
        self.positions = (0..n).filter(keep).map(|v| self.positions[v]).collect();
        let ids: Vec<u64> = (0..n).filter(keep).map(|v| self.vertex_id(v)).collect();
        self.vertex_ids = Some(ids);
        for tet in &mut self.tets {
            *tet = tet.map(|v| new_index[v]);
        }
        for e in &mut self.edge_nodes {
            *e = e.map(|v| new_index[v]);
        }
        for g in &mut self.groups {
            g.vertices = g
                .vertices
                .iter()
                .filter(|&&v| v < n && used[v])
                .map(|&v| new_index[v])
                .collect();
            g.faces = g
                .faces
                .iter()
                .filter(|f| f.iter().all(|&v| v < n && used[v]))
                .map(|f| f.map(|v| new_index[v]))
                .collect();
        }
        dropped
    }

    /// The group with this name, if any.
    pub fn group(&self, name: &str) -> Option<&Group> {
        self.groups.iter().find(|g| g.name == name)
    }

    /// Axis-aligned bounding box of the rest positions (min, max).
    pub fn bounding_box(&self) -> (Vec3, Vec3) {
        bounding_box(&self.positions)
    }
}

/// Axis-aligned bounding box of a point set (min, max); zeros when empty.
pub fn bounding_box(points: &[Vec3]) -> (Vec3, Vec3) {
    if points.is_empty() {
        return (Vec3::zeros(), Vec3::zeros());
    }
    points.iter().fold(
        (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    )
}

/// The six edge lengths of a tet.
fn tet_edges(x: &[Vec3], tet: &[usize; 4]) -> [f64; 6] {
    let e = |i: usize, j: usize| (x[tet[i]] - x[tet[j]]).norm();
    [e(0, 1), e(0, 2), e(0, 3), e(1, 2), e(1, 3), e(2, 3)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_tet() -> TetMesh {
        TetMesh::new(
            vec![Vec3::zeros(), Vec3::x(), Vec3::y(), Vec3::z()],
            vec![[0, 1, 2, 3]],
        )
    }

    #[test]
    fn single_tet_boundary_is_outward() {
        let mesh = unit_tet();
        let faces = mesh.boundary_faces();
        assert_eq!(faces.len(), 4);
        let centroid = Vec3::repeat(0.25);
        for f in faces {
            let [a, b, c] = f.map(|v| mesh.positions[v]);
            let n = (b - a).cross(&(c - a));
            assert!(n.dot(&(a - centroid)) > 0.0);
        }
    }

    #[test]
    fn flat_tet_is_degenerate_and_named() {
        let mut mesh = unit_tet();
        mesh.positions.push(Vec3::new(1.0, 1.0, 0.0));
        mesh.tets.push([0, 1, 2, 4]);
        mesh.tet_ids = Some(vec![1, 2]);
        assert_eq!(
            mesh.validate(),
            Err(MeshProblem::Degenerate { tets: vec![2] })
        );
    }

    #[test]
    fn reorient_and_drop_unused_vertices_renumber_in_order() {
        let mut mesh = unit_tet();
        mesh.positions.insert(0, Vec3::new(9.0, 9.0, 9.0));
        mesh.tets[0] = [1, 3, 2, 4];
        mesh.vertex_ids = Some(vec![10, 11, 12, 13, 14]);
        mesh.groups.push(Group {
            vertices: vec![0, 2],
            faces: vec![[0, 1, 2], [1, 2, 3]],
            ..Default::default()
        });
        assert_eq!(mesh.drop_unreferenced_vertices(), vec![10]);
        assert_eq!(mesh.tets, vec![[0, 2, 1, 3]]);
        assert_eq!(mesh.vertex_id(0), 11);
        assert_eq!(mesh.groups[0].vertices, vec![1]);
        assert_eq!(mesh.groups[0].faces, vec![[0, 1, 2]]);
        assert_eq!(mesh.reorient(), 1);
        assert!(mesh.signed_volume(0) > 0.0);
        assert_eq!(mesh.reorient(), 0);
    }

    #[test]
    fn reversed_tet_is_accepted() {
        let mut mesh = unit_tet();
        mesh.tets[0] = [0, 2, 1, 3];
        assert!(mesh.validate().is_ok());
        assert!(mesh.signed_volume(0) < 0.0);
    }
}
