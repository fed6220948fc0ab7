//! Quadratic (10-node) tets: the six mid-edge nodes of each tet, and elevating a linear mesh.
//!
//! A quadratic mesh keeps its four corners per tet in [`TetMesh::tets`] (so everything that
//! reasons about a tet's shape, its volume or its faces reads the same arrays as for a linear
//! mesh) and adds [`TetMesh::edge_nodes`]: the node on each of the six edges, in VTK's order
//! ([`EDGES`]). Node positions live with the corners in [`TetMesh::positions`]; a mid-edge node
//! need not sit at its edge's midpoint (curved elements from Gmsh are isoparametric).

use std::collections::HashMap;

use super::{Group, TetMesh};

/// The corners of each edge of a tet, in the order of the mid-edge nodes (VTK's
/// `VTK_QUADRATIC_TETRA`: nodes 4–9 on edges 01, 12, 02, 03, 13, 23).
pub const EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]];

/// How the edge slots move when a tet's corners 2 and 3 are swapped (see
/// [`TetMesh::reorient`]): new slot k holds old slot `SWAP_23[k]`.
pub const SWAP_23: [usize; 6] = [0, 4, 3, 2, 1, 5];

impl TetMesh {
    /// Whether the tets are quadratic (ten nodes each).
    pub fn is_quadratic(&self) -> bool {
        !self.edge_nodes.is_empty()
    }

    /// Nodes per tet: 4 or 10.
    pub fn nodes_per_tet(&self) -> usize {
        if self.is_quadratic() { 10 } else { 4 }
    }

    /// The ten nodes of quadratic tet `t`: its corners, then its mid-edge nodes ([`EDGES`]).
    #[inline]
    pub fn quadratic_nodes(&self, t: usize) -> [usize; 10] {
        let (c, e) = (&self.tets[t], &self.edge_nodes[t]);
        [c[0], c[1], c[2], c[3], e[0], e[1], e[2], e[3], e[4], e[5]]
    }

    /// The nodes of tet `t` (4 or 10), as a vector (for set-up code, not kernels).
    pub fn element_nodes(&self, t: usize) -> Vec<usize> {
        if self.is_quadratic() {
            self.quadratic_nodes(t).to_vec()
        } else {
            self.tets[t].to_vec()
        }
    }

    /// The node on the edge between corners `a` and `b` (local indices) of tet `t`.
    pub fn edge_node(&self, t: usize, a: usize, b: usize) -> usize {
        let k = EDGES
            .iter()
            .position(|e| (e[0] == a && e[1] == b) || (e[0] == b && e[1] == a))
            .expect("two distinct corners");
        self.edge_nodes[t][k]
    }

    /// Every tet as its node list (corners, then mid-edge nodes when quadratic).
    pub fn elements(&self) -> Vec<Vec<usize>> {
        (0..self.tets.len())
            .map(|t| self.element_nodes(t))
            .collect()
    }
}

/// The mesh with quadratic tets: a node at the midpoint of every edge (shared by the tets
/// around it), numbered after the existing vertices in the order tets and their edges are
/// met. Groups keep their meaning: a face group gains the nodes on its faces' edges, a volume
/// group those of its tets, a point or line group the nodes of edges with both ends in it.
/// A mesh that is already quadratic is returned unchanged.
pub fn elevate(mesh: &TetMesh) -> TetMesh {
    if mesh.is_quadratic() {
        return mesh.clone();
    }
    let mut positions = mesh.positions.clone();
    let mut on_edge: HashMap<(usize, usize), usize> = HashMap::new();
    let mut edge_nodes = Vec::with_capacity(mesh.tets.len());
    let mut edge_of = |a: usize, b: usize, positions: &mut Vec<_>| {
        let key = (a.min(b), a.max(b));
        *on_edge.entry(key).or_insert_with(|| {
            positions.push(0.5 * (mesh.positions[a] + mesh.positions[b]));
            positions.len() - 1
        })
    };
    for tet in &mesh.tets {
        edge_nodes.push(EDGES.map(|[i, j]| edge_of(tet[i], tet[j], &mut positions)));
    }
    let added = positions.len() - mesh.positions.len();
    let vertex_ids = mesh.vertex_ids.as_ref().map(|ids| {
        // New nodes get ids after the file's largest, so messages never confuse two nodes.
        let next = ids.iter().copied().max().map_or(0, |m| m + 1);
        let mut ids = ids.clone();
        ids.extend((0..added as u64).map(|k| next + k));
        ids
    });
    let mid = |a: usize, b: usize| on_edge.get(&(a.min(b), a.max(b))).copied();
    let surface = if mesh.groups.iter().any(|g| g.dim == 2 && g.faces.is_empty()) {
        mesh.boundary_faces()
    } else {
        Vec::new()
    };
    let groups = mesh
        .groups
        .iter()
        .map(|g| elevate_group(g, mesh, &surface, &edge_nodes, &mid))
        .collect();
    TetMesh {
        positions,
        tets: mesh.tets.clone(),
        edge_nodes,
        groups,
        tet_ids: mesh.tet_ids.clone(),
        vertex_ids,
    }
}

/// `surface`: the mesh's boundary triangles, for face groups given by their vertices only.
fn elevate_group(
    g: &Group,
    mesh: &TetMesh,
    surface: &[[usize; 3]],
    edge_nodes: &[[usize; 6]],
    mid: &impl Fn(usize, usize) -> Option<usize>,
) -> Group {
    let mut g = g.clone();
    let mut added = Vec::new();
    match g.dim {
        3 => {
            for &t in &g.tets {
                added.extend_from_slice(&edge_nodes[t]);
            }
        }
        2 if !g.faces.is_empty() => {
            for f in &g.faces {
                added.extend((0..3).filter_map(|k| mid(f[k], f[(k + 1) % 3])));
            }
        }
        2 => {
            // Surface edges with both ends in the group (an edge through the inside between
            // two of its vertices is not on the face).
            let inside: std::collections::HashSet<usize> = g.vertices.iter().copied().collect();
            for f in surface {
                for k in 0..3 {
                    let (a, b) = (f[k], f[(k + 1) % 3]);
                    if inside.contains(&a) && inside.contains(&b) {
                        added.extend(mid(a, b));
                    }
                }
            }
        }
        _ => {
            let inside: std::collections::HashSet<usize> = g.vertices.iter().copied().collect();
            for tet in &mesh.tets {
                for [i, j] in EDGES {
                    if inside.contains(&tet[i]) && inside.contains(&tet[j]) {
                        added.extend(mid(tet[i], tet[j]));
                    }
                }
            }
        }
    }
    g.vertices.extend(added);
    g.vertices.sort_unstable();
    g.vertices.dedup();
    g
}

/// The four triangles a quadratic face is drawn and checked as: corner `p` with the nodes on
/// its two edges, likewise for `q` and `r`, and the middle one; all oriented like `[p, q, r]`.
pub fn split_face(corners: [usize; 3], mids: [usize; 3]) -> [[usize; 3]; 4] {
    let [p, q, r] = corners;
    // mids: on pq, qr, rp.
    let [pq, qr, rp] = mids;
    [[p, pq, rp], [pq, q, qr], [rp, qr, r], [pq, qr, rp]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::generate::box_mesh;

    #[test]
    fn elevation_shares_edge_nodes_and_keeps_the_boundary_closed() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.0), [2, 1, 1]);
        let q = elevate(&mesh);
        // Vertices + unique edges of the lattice's tets.
        let mut edges = std::collections::HashSet::new();
        for t in &mesh.tets {
            for [i, j] in EDGES {
                edges.insert((t[i].min(t[j]), t[i].max(t[j])));
            }
        }
        assert_eq!(q.positions.len(), mesh.positions.len() + edges.len());
        for t in 0..q.tets.len() {
            for (k, [i, j]) in EDGES.iter().enumerate() {
                let n = q.edge_nodes[t][k];
                let m = 0.5 * (q.positions[q.tets[t][*i]] + q.positions[q.tets[t][*j]]);
                assert!((q.positions[n] - m).norm() < 1e-15);
            }
        }
        // Each boundary triangle becomes four; each edge of the split surface is shared by two.
        let faces = q.boundary_faces();
        assert_eq!(faces.len(), 4 * mesh.boundary_faces().len());
        let mut count: HashMap<(usize, usize), i32> = HashMap::new();
        for f in &faces {
            for k in 0..3 {
                *count.entry((f[k], f[(k + 1) % 3])).or_default() += 1;
                *count.entry((f[(k + 1) % 3], f[k])).or_default() -= 1;
            }
        }
        assert!(count.values().all(|&c| c == 0), "split surface not closed");
        // Face groups gain the nodes on their edges: the x = 0 face of the box.
        for g in &q.groups {
            let before = mesh.groups.iter().find(|h| h.name == g.name).unwrap();
            assert!(g.vertices.len() > before.vertices.len(), "{}", g.name);
            if g.dim == 2 {
                let axis_value = |v: usize| q.positions[v];
                let first = axis_value(before.vertices[0]);
                let plane: Vec<usize> = (0..3)
                    .filter(|&a| {
                        before
                            .vertices
                            .iter()
                            .all(|&v| axis_value(v)[a] == first[a])
                    })
                    .collect();
                for &v in &g.vertices {
                    for &a in &plane {
                        assert_eq!(q.positions[v][a], first[a], "{}", g.name);
                    }
                }
            }
        }
    }

    #[test]
    fn reorienting_a_quadratic_tet_moves_its_edge_nodes_with_its_corners() {
        let mut q = elevate(&box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [1, 1, 1]));
        let before = q.clone();
        for t in 0..q.tets.len() {
            q.tets[t].swap(2, 3);
            q.edge_nodes[t] = SWAP_23.map(|k| q.edge_nodes[t][k]);
        }
        let flipped = q.reorient();
        assert_eq!(flipped, q.tets.len());
        assert_eq!(q, before);
    }
}
