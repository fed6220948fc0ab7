//! Vertex and tet orderings that keep memory accesses local.
//!
//! Every per-tet kernel gathers four vertices and every row of the assembled matrix reads the
//! vertices it couples to; when neighbours in the mesh are neighbours in memory those reads hit
//! the cache. Mesh files rarely promise that (TetGen numbers vertices in insertion order, Gmsh
//! by geometric entity, a converted or merged mesh anyhow), so a simulation renumbers its mesh
//! once at load time and maps back to the file's numbering whenever it writes (see
//! [`Renumbering`]): frames keep the vertex and tet order of the input mesh.
//!
//! Orderings, chosen with `[mesh] reorder` (`tetsim bench --reorder` measures them):
//! - [`VertexOrder::Auto`] (the default): a generator's own order (its lattice order is already
//!   local) and reverse Cuthill–McKee for mesh files (measured in docs/performance.md, "Why the
//!   defaults").
//! - [`VertexOrder::Rcm`], reverse Cuthill–McKee: breadth-first from a
//!   pseudo-peripheral vertex, neighbours by increasing degree, reversed. It minimises the
//!   matrix bandwidth, so the rows a CG product touches lie in a narrow band of x.
//! - [`VertexOrder::Morton`]: vertices sorted along a Z-order curve of their rest positions (21
//!   bits per axis in the bounding box), which keeps 3D neighbourhoods together.
//! - [`VertexOrder::None`]: the file's order.
//! - [`VertexOrder::Random`]: a seeded shuffle, the worst case, for benchmarks.
//!
//! Tets follow their vertices: they are sorted by their smallest new vertex index (ties by their
//! old index), so the tet loop walks the vertex array forward.

use serde::{Deserialize, Serialize};

use super::TetMesh;
use crate::math::Vec3;

/// How a simulation numbers the vertices of its mesh internally.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum VertexOrder {
    /// A generator's order, RCM for files (resolved by the scene; [`Renumbering::new`] treats it
    /// as RCM).
    #[default]
    Auto,
    /// The file's order.
    None,
    /// Reverse Cuthill–McKee on the vertex adjacency graph.
    Rcm,
    /// Z-order (Morton) curve through the rest positions.
    Morton,
    /// A seeded random shuffle: the worst case, for benchmarks.
    Random,
}

impl VertexOrder {
    /// The scene name.
    pub fn name(self) -> &'static str {
        match self {
            VertexOrder::Auto => "auto",
            VertexOrder::None => "none",
            VertexOrder::Rcm => "rcm",
            VertexOrder::Morton => "morton",
            VertexOrder::Random => "random",
        }
    }

    /// From a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        [
            Self::Auto,
            Self::None,
            Self::Rcm,
            Self::Morton,
            Self::Random,
        ]
        .into_iter()
        .find(|o| o.name() == name)
    }
}

/// A permutation of a mesh's vertices and tets, with the maps both ways.
#[derive(Clone, Debug, PartialEq)]
pub struct Renumbering {
    /// For each new vertex index, its index in the original mesh.
    pub vertex_old: Vec<usize>,
    /// For each original vertex index, its new index.
    pub vertex_new: Vec<usize>,
    /// For each new tet index, its index in the original mesh.
    pub tet_old: Vec<usize>,
}

impl Renumbering {
    /// The renumbering `order` gives `mesh` (None for [`VertexOrder::None`]).
    pub fn new(mesh: &TetMesh, order: VertexOrder) -> Option<Self> {
        let vertex_old = match order {
            VertexOrder::None => return None,
            VertexOrder::Auto | VertexOrder::Rcm if mesh.is_quadratic() => {
                reverse_cuthill_mckee(mesh.positions.len(), &mesh.elements())
            }
            VertexOrder::Auto | VertexOrder::Rcm => {
                reverse_cuthill_mckee(mesh.positions.len(), &mesh.tets)
            }
            VertexOrder::Morton => morton_order(&mesh.positions),
            VertexOrder::Random => shuffled(mesh.positions.len(), 0x007e_7513),
        };
        Some(Self::from_vertex_order(mesh, vertex_old))
    }

    /// The renumbering that puts vertex `vertex_old[i]` at i, with tets sorted by their smallest
    /// new vertex index (ties by old index).
    pub fn from_vertex_order(mesh: &TetMesh, vertex_old: Vec<usize>) -> Self {
        let mut vertex_new = vec![usize::MAX; vertex_old.len()];
        for (new, &old) in vertex_old.iter().enumerate() {
            vertex_new[old] = new;
        }
        let key = |t: usize| mesh.tets[t].iter().map(|&v| vertex_new[v]).min();
        let mut tet_old: Vec<usize> = (0..mesh.tets.len()).collect();
        tet_old.sort_by_key(|&t| (key(t), t));
        Renumbering {
            vertex_old,
            vertex_new,
            tet_old,
        }
    }

    /// The mesh renumbered: positions, tets, groups, and the file ids that messages name (so an
    /// error about a tet still names it as the file does).
    pub fn apply(&self, mesh: &TetMesh) -> TetMesh {
        let mut tet_new = vec![0; self.tet_old.len()];
        for (new, &old) in self.tet_old.iter().enumerate() {
            tet_new[old] = new;
        }
        let groups = mesh
            .groups
            .iter()
            .map(|g| {
                let mut g = g.clone();
                g.vertices.iter_mut().for_each(|v| *v = self.vertex_new[*v]);
                g.vertices.sort_unstable();
                g.faces
                    .iter_mut()
                    .for_each(|f| *f = f.map(|v| self.vertex_new[v]));
                g.tets.iter_mut().for_each(|t| *t = tet_new[*t]);
                g.tets.sort_unstable();
                g
            })
            .collect();
        TetMesh {
            positions: self.to_new(&mesh.positions),
            tets: self
                .tet_old
                .iter()
                .map(|&t| mesh.tets[t].map(|v| self.vertex_new[v]))
                .collect(),
            groups,
            edge_nodes: if mesh.is_quadratic() {
                self.tet_old
                    .iter()
                    .map(|&t| mesh.edge_nodes[t].map(|v| self.vertex_new[v]))
                    .collect()
            } else {
                Vec::new()
            },
            tet_ids: Some(self.tet_old.iter().map(|&t| mesh.tet_id(t)).collect()),
            vertex_ids: Some(self.vertex_old.iter().map(|&v| mesh.vertex_id(v)).collect()),
        }
    }

    /// Per-vertex data in the original order, from data in the new order.
    pub fn vertices_to_old<T: Copy>(&self, new: &[T]) -> Vec<T> {
        self.vertex_new.iter().map(|&n| new[n]).collect()
    }

    /// Per-vertex data in the new order, from data in the original order.
    pub fn to_new<T: Copy>(&self, old: &[T]) -> Vec<T> {
        self.vertex_old.iter().map(|&o| old[o]).collect()
    }

    /// Per-tet data in the original order, from data in the new order.
    pub fn tets_to_old<T: Copy + Default>(&self, new: &[T]) -> Vec<T> {
        let mut old = vec![T::default(); new.len()];
        for (n, &o) in self.tet_old.iter().enumerate() {
            old[o] = new[n];
        }
        old
    }

    /// The original mesh's tets (original vertex indices, original order) from the new mesh's.
    /// Any per-tet node list renumbers the same way: corners (`N = 4`), mid-edge nodes
    /// ([`TetMesh::edge_nodes`], `N = 6`) or all ten nodes.
    pub fn tets_to_old_mesh<const N: usize>(&self, new_tets: &[[usize; N]]) -> Vec<[usize; N]> {
        let mut old = vec![[0; N]; new_tets.len()];
        for (n, &o) in self.tet_old.iter().enumerate() {
            old[o] = new_tets[n].map(|v| self.vertex_old[v]);
        }
        old
    }

    /// Faces given by new vertex indices, renamed to original ones.
    pub fn faces_to_old(&self, faces: &[[usize; 3]]) -> Vec<[usize; 3]> {
        faces
            .iter()
            .map(|f| f.map(|v| self.vertex_old[v]))
            .collect()
    }
}

/// The largest distance between the indices of two vertices that share a tet: the half
/// bandwidth of the assembled matrix, in block rows.
pub fn bandwidth(tets: &[[usize; 4]]) -> usize {
    tets.iter()
        .map(|t| t.iter().max().unwrap() - t.iter().min().unwrap())
        .max()
        .unwrap_or(0)
}

/// Vertex adjacency (vertices sharing a tet) in compressed rows, each row sorted and unique.
fn adjacency<T: AsRef<[usize]>>(n: usize, tets: &[T]) -> (Vec<usize>, Vec<usize>) {
    let mut rows: Vec<Vec<usize>> = vec![Vec::new(); n];
    for t in tets {
        let t = t.as_ref();
        for &a in t {
            rows[a].extend(t.iter().copied().filter(|&b| b != a));
        }
    }
    let mut start = Vec::with_capacity(n + 1);
    let mut cols = Vec::new();
    start.push(0);
    for mut r in rows {
        r.sort_unstable();
        r.dedup();
        cols.extend(r);
        start.push(cols.len());
    }
    (start, cols)
}

/// Reverse Cuthill–McKee order (new → old) of the vertices of `tets`, component by component
/// (lowest old index first), each started from a pseudo-peripheral vertex (George and Liu's
/// repeated breadth-first search for the vertex of greatest eccentricity). Deterministic: ties
/// are broken by old index.
pub fn reverse_cuthill_mckee<T: AsRef<[usize]>>(n: usize, tets: &[T]) -> Vec<usize> {
    let (start, cols) = adjacency(n, tets);
    let neighbours = |v: usize| &cols[start[v]..start[v + 1]];
    let degree = |v: usize| start[v + 1] - start[v];
    let mut placed = vec![false; n];
    let mut order = Vec::with_capacity(n);
    // Scratch for the breadth-first searches that look for a peripheral vertex.
    let mut level = vec![usize::MAX; n];
    let mut queue = Vec::new();
    for seed in 0..n {
        if placed[seed] {
            continue;
        }
        // Pseudo-peripheral start: from the current root, search to the last level and restart
        // from its lowest-degree vertex while the eccentricity grows.
        let mut root = seed;
        let mut eccentricity = 0;
        for _ in 0..8 {
            let (depth, last) = bfs_levels(root, &neighbours, &mut level, &mut queue);
            let candidate = last
                .iter()
                .copied()
                .min_by_key(|&v| (degree(v), v))
                .unwrap_or(root);
            for &v in &queue {
                level[v] = usize::MAX;
            }
            if depth <= eccentricity {
                break;
            }
            eccentricity = depth;
            root = candidate;
        }
        // Cuthill–McKee from root: visit neighbours by increasing degree.
        let first = order.len();
        order.push(root);
        placed[root] = true;
        let mut head = first;
        let mut next = Vec::new();
        while head < order.len() {
            let v = order[head];
            head += 1;
            next.clear();
            next.extend(neighbours(v).iter().copied().filter(|&w| !placed[w]));
            next.sort_unstable_by_key(|&w| (degree(w), w));
            for &w in &next {
                placed[w] = true;
                order.push(w);
            }
        }
        order[first..].reverse();
    }
    order
}

/// Breadth-first levels from `root`: returns the depth of the deepest level and its vertices.
/// Leaves `level` set for every vertex in `queue` (the caller resets them).
fn bfs_levels<'a>(
    root: usize,
    neighbours: &impl Fn(usize) -> &'a [usize],
    level: &mut [usize],
    queue: &mut Vec<usize>,
) -> (usize, Vec<usize>) {
    queue.clear();
    queue.push(root);
    level[root] = 0;
    let mut head = 0;
    while head < queue.len() {
        let v = queue[head];
        head += 1;
        for &w in neighbours(v) {
            if level[w] == usize::MAX {
                level[w] = level[v] + 1;
                queue.push(w);
            }
        }
    }
    let depth = queue.last().map_or(0, |&v| level[v]);
    let last = queue
        .iter()
        .rev()
        .take_while(|&&v| level[v] == depth)
        .copied()
        .collect();
    (depth, last)
}

/// Vertices (new → old) sorted along a Z-order curve through their positions: each coordinate
/// scaled to 21 bits of the bounding box and the bits interleaved; ties by old index.
pub fn morton_order(positions: &[Vec3]) -> Vec<usize> {
    let (lo, hi) = super::bounding_box(positions);
    let extent = (hi - lo).map(|e| if e > 0.0 { e } else { 1.0 });
    let scale = ((1u64 << 21) - 1) as f64;
    let spread = |mut x: u64| {
        // Put the 21 bits of x three apart.
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let code = |p: &Vec3| {
        let q = (p - lo).component_div(&extent) * scale;
        let c = |i: usize| q[i].clamp(0.0, scale) as u64;
        spread(c(0)) | spread(c(1)) << 1 | spread(c(2)) << 2
    };
    let mut order: Vec<(u64, usize)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| (code(p), i))
        .collect();
    order.sort_unstable();
    order.into_iter().map(|(_, i)| i).collect()
}

/// A seeded shuffle of 0..n (Fisher–Yates with SplitMix64).
pub fn shuffled(n: usize, seed: u64) -> Vec<usize> {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let mut order: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        order.swap(i, j);
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    fn beam() -> TetMesh {
        box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 1.0), [16, 4, 4])
    }

    fn is_permutation(p: &[usize]) -> bool {
        let mut seen = vec![false; p.len()];
        p.iter()
            .all(|&i| i < p.len() && !std::mem::replace(&mut seen[i], true))
    }

    #[test]
    fn every_order_is_a_permutation() {
        let mesh = beam();
        for order in [VertexOrder::Rcm, VertexOrder::Morton, VertexOrder::Random] {
            let r = Renumbering::new(&mesh, order).unwrap();
            assert!(is_permutation(&r.vertex_old), "{order:?}");
            assert!(is_permutation(&r.tet_old), "{order:?}");
            assert!(
                r.vertex_old
                    .iter()
                    .enumerate()
                    .all(|(n, &o)| r.vertex_new[o] == n)
            );
        }
        assert!(Renumbering::new(&mesh, VertexOrder::None).is_none());
    }

    #[test]
    fn rcm_narrows_the_band_of_a_shuffled_beam() {
        let mesh = beam();
        let shuffled = Renumbering::new(&mesh, VertexOrder::Random)
            .unwrap()
            .apply(&mesh);
        let rcm = Renumbering::new(&shuffled, VertexOrder::Rcm)
            .unwrap()
            .apply(&shuffled);
        let (b_file, b_random, b_rcm) = (
            bandwidth(&mesh.tets),
            bandwidth(&shuffled.tets),
            bandwidth(&rcm.tets),
        );
        // The beam's natural x-fastest order couples vertices one (nx+1)(ny+1) layer apart; RCM
        // sweeps along the long axis, about one 5×5 cross-section.
        assert!(b_random > 10 * b_rcm, "{b_random} vs {b_rcm}");
        assert!(b_rcm < b_file, "{b_rcm} vs {b_file}");
        assert!(b_rcm <= 2 * 25 + 5, "{b_rcm}");
    }

    #[test]
    fn renumbered_mesh_is_the_same_mesh() {
        let mesh = beam();
        for order in [VertexOrder::Rcm, VertexOrder::Morton, VertexOrder::Random] {
            let r = Renumbering::new(&mesh, order).unwrap();
            let new = r.apply(&mesh);
            // Geometry, tets and groups map back exactly.
            assert_eq!(r.vertices_to_old(&new.positions), mesh.positions);
            assert_eq!(r.tets_to_old_mesh(&new.tets), mesh.tets);
            let volumes: Vec<f64> = (0..new.tets.len()).map(|t| new.signed_volume(t)).collect();
            let old_volumes: Vec<f64> = (0..mesh.tets.len())
                .map(|t| mesh.signed_volume(t))
                .collect();
            assert_eq!(r.tets_to_old(&volumes), old_volumes);
            for (g_new, g_old) in new.groups.iter().zip(&mesh.groups) {
                let mut back: Vec<usize> =
                    g_new.vertices.iter().map(|&v| r.vertex_old[v]).collect();
                back.sort_unstable();
                assert_eq!(back, g_old.vertices, "{order:?} group {}", g_old.name);
            }
            // Messages still name the file's ids.
            assert!((0..new.tets.len()).all(|t| new.tet_id(t) == r.tet_old[t] as u64));
            assert!((0..new.positions.len()).all(|v| new.vertex_id(v) == r.vertex_old[v] as u64));
            // Tets walk the vertex array forward.
            let firsts: Vec<usize> = new.tets.iter().map(|t| *t.iter().min().unwrap()).collect();
            assert!(firsts.windows(2).all(|w| w[0] <= w[1]), "{order:?}");
        }
    }

    #[test]
    fn disconnected_components_are_all_ordered() {
        let mut mesh = box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [2, 2, 2]);
        let other = box_mesh(
            Vec3::new(5.0, 0.0, 0.0),
            Vec3::new(6.0, 1.0, 1.0),
            [2, 2, 2],
        );
        let offset = mesh.positions.len();
        mesh.positions.extend(other.positions);
        mesh.tets
            .extend(other.tets.iter().map(|t| t.map(|v| v + offset)));
        let order = reverse_cuthill_mckee(mesh.positions.len(), &mesh.tets);
        assert!(is_permutation(&order));
        // Each component is contiguous.
        let first_component = order.iter().take(offset).all(|&v| v < offset);
        assert!(first_component);
    }
}
