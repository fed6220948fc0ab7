//! Splitting a tet mesh over ranks: each rank owns some tets (it evaluates them) and some
//! vertices (it owns their rows of the matrix); the vertices of its tets that other ranks own
//! are its ghost layer.
//!
//! The partitioner is recursive coordinate bisection of the tet centroids: cut the longest side
//! of the bounding box at the weighted median, recurse with part counts split in proportion
//! (any rank count, not only powers of two). It is deterministic (ties broken by tet index),
//! needs no library and, on the compact meshes FEM makes, cuts within a small factor of a graph
//! partitioner (Debian's PETSc ships PT-Scotch, not METIS; see docs/scaling.md). A vertex
//! belongs to the lowest rank among its tets'.

use crate::math::Vec3;
use crate::mesh::TetMesh;

/// Which rank owns each tet and each vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct Partition {
    /// Number of ranks.
    pub parts: usize,
    /// Rank of each tet.
    pub tet_part: Vec<u32>,
    /// Rank of each vertex (the lowest among its tets').
    pub vertex_owner: Vec<u32>,
}

/// What one rank holds: its tets and the vertices they touch.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// The rank's tets (mesh indices, increasing).
    pub tets: Vec<usize>,
    /// The vertices of those tets: the rank's own first, then its ghosts, each increasing.
    pub vertices: Vec<usize>,
    /// How many of `vertices` the rank owns.
    pub owned: usize,
}

impl Part {
    /// The ghost layer: vertices of this rank's tets that other ranks own.
    pub fn ghosts(&self) -> &[usize] {
        &self.vertices[self.owned..]
    }
}

impl Partition {
    /// Split `mesh` into `parts` by recursive coordinate bisection of its tet centroids.
    pub fn new(mesh: &TetMesh, parts: usize) -> Self {
        assert!(parts >= 1, "at least one part");
        let centroids: Vec<Vec3> = mesh
            .tets
            .iter()
            .map(|t| t.iter().map(|&v| mesh.positions[v]).sum::<Vec3>() / 4.0)
            .collect();
        let mut tet_part = vec![0u32; mesh.tets.len()];
        let mut order: Vec<usize> = (0..mesh.tets.len()).collect();
        bisect(&centroids, &mut order, 0, parts, &mut tet_part);
        Self::from_tet_parts(mesh, parts, tet_part)
    }

    /// The partition that gives tet t to rank `tet_part[t]` (a graph partitioner's answer);
    /// each vertex goes to the lowest rank among its tets'.
    pub fn from_tet_parts(mesh: &TetMesh, parts: usize, tet_part: Vec<u32>) -> Self {
        assert!(tet_part.iter().all(|&p| (p as usize) < parts));
        let mut vertex_owner = vec![u32::MAX; mesh.positions.len()];
        for (t, tet) in mesh.tets.iter().enumerate() {
            for &v in tet {
                vertex_owner[v] = vertex_owner[v].min(tet_part[t]);
            }
        }
        // A vertex in no tet (the mesh doctor refuses those, but --force lets them through)
        // belongs to rank 0.
        vertex_owner
            .iter_mut()
            .filter(|o| **o == u32::MAX)
            .for_each(|o| *o = 0);
        Partition {
            parts,
            tet_part,
            vertex_owner,
        }
    }

    /// What rank `rank` holds. Rank 0 also holds the vertices in no tet.
    pub fn part(&self, mesh: &TetMesh, rank: usize) -> Part {
        let tets: Vec<usize> = (0..mesh.tets.len())
            .filter(|&t| self.tet_part[t] as usize == rank)
            .collect();
        let mut touched = vec![false; mesh.positions.len()];
        for &t in &tets {
            for &v in &mesh.tets[t] {
                touched[v] = true;
            }
        }
        let mine = |v: usize| self.vertex_owner[v] as usize == rank;
        let mut vertices: Vec<usize> = (0..touched.len())
            .filter(|&v| mine(v) && (touched[v] || rank == 0))
            .collect();
        let owned = vertices.len();
        vertices.extend((0..touched.len()).filter(|&v| touched[v] && !mine(v)));
        Part {
            tets,
            vertices,
            owned,
        }
    }

    /// Every rank's part, in one pass over the mesh (the same as [`Partition::part`] of each).
    pub fn parts(&self, mesh: &TetMesh) -> Vec<Part> {
        let mut tets = vec![Vec::new(); self.parts];
        for (t, &p) in self.tet_part.iter().enumerate() {
            tets[p as usize].push(t);
        }
        let mut owned = vec![Vec::new(); self.parts];
        for (v, &o) in self.vertex_owner.iter().enumerate() {
            owned[o as usize].push(v);
        }
        // Rank 0 keeps the vertices in no tet; other ranks own only vertices of their tets
        // (the lowest rank among a vertex's tets owns it).
        tets.into_iter()
            .zip(owned)
            .enumerate()
            .map(|(rank, (tets, owned))| {
                let mut ghosts: Vec<usize> = tets
                    .iter()
                    .flat_map(|&t| mesh.tets[t])
                    .filter(|&v| self.vertex_owner[v] as usize != rank)
                    .collect();
                ghosts.sort_unstable();
                ghosts.dedup();
                let count = owned.len();
                let mut vertices = owned;
                vertices.extend(ghosts);
                Part {
                    tets,
                    vertices,
                    owned: count,
                }
            })
            .collect()
    }

    /// How every rank's vertices map to the matrix rows and to the other ranks' vertices.
    pub fn layouts(&self, parts: &[Part]) -> Vec<Layout> {
        let (_, position) = self.global_order();
        let counts = self.owned_counts();
        let offsets: Vec<usize> = counts
            .iter()
            .scan(0, |at, &c| {
                let o = *at;
                *at += c;
                Some(o)
            })
            .collect();
        let mut layouts: Vec<Layout> = parts
            .iter()
            .enumerate()
            .map(|(r, part)| Layout {
                rows: part.vertices.iter().map(|&v| position[v]).collect(),
                first_row: offsets[r],
                neighbours: Vec::new(),
            })
            .collect();
        for (r, part) in parts.iter().enumerate() {
            for (k, &g) in part.vertices.iter().enumerate().skip(part.owned) {
                let p = self.vertex_owner[g] as usize;
                let local_at_owner = position[g] - offsets[p];
                neighbour(&mut layouts[r], p).ghosts.push(k);
                neighbour(&mut layouts[p], r).shared.push(local_at_owner);
            }
        }
        for l in &mut layouts {
            l.neighbours.sort_by_key(|n| n.rank);
        }
        layouts
    }

    /// Ghost vertices over all ranks: the halo a force completion sends (what a partitioner
    /// should keep small).
    pub fn ghost_count(&self, mesh: &TetMesh) -> usize {
        self.parts(mesh).iter().map(|p| p.ghosts().len()).sum()
    }

    /// The owned vertices of every rank, in rank order then increasing index: the order of the
    /// distributed matrix's block rows. Returns (that order, each vertex's position in it).
    pub fn global_order(&self) -> (Vec<usize>, Vec<usize>) {
        let mut order: Vec<usize> = (0..self.vertex_owner.len()).collect();
        order.sort_by_key(|&v| (self.vertex_owner[v], v));
        let mut position = vec![0; order.len()];
        for (k, &v) in order.iter().enumerate() {
            position[v] = k;
        }
        (order, position)
    }

    /// Vertices owned by each rank.
    pub fn owned_counts(&self) -> Vec<usize> {
        let mut counts = vec![0; self.parts];
        for &o in &self.vertex_owner {
            counts[o as usize] += 1;
        }
        counts
    }
}

/// How one rank's vertices (owned, then ghosts) map to the distributed matrix's block rows and
/// to the other ranks' vertices: what the halo exchanges send and receive.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// The block row of each of the rank's vertices.
    pub rows: Vec<usize>,
    /// The first row the rank owns (its owned vertices are the rows from there on).
    pub first_row: usize,
    /// The ranks it shares vertices with, in rank order.
    pub neighbours: Vec<Neighbour>,
}

/// The vertices two ranks share, each list in increasing whole-body index (so both ranks list
/// them in the same order).
#[derive(Clone, Debug, PartialEq)]
pub struct Neighbour {
    /// The other rank.
    pub rank: usize,
    /// This rank's ghosts that the other rank owns (local indices).
    pub ghosts: Vec<usize>,
    /// This rank's owned vertices that are ghosts on the other rank (local indices).
    pub shared: Vec<usize>,
}

fn neighbour(layout: &mut Layout, rank: usize) -> &mut Neighbour {
    match layout.neighbours.iter().position(|n| n.rank == rank) {
        Some(i) => &mut layout.neighbours[i],
        None => {
            layout.neighbours.push(Neighbour {
                rank,
                ghosts: Vec::new(),
                shared: Vec::new(),
            });
            layout.neighbours.last_mut().expect("just pushed")
        }
    }
}

/// Assign `order`'s tets to parts `first..first + parts`, cutting the longest side of their
/// centroids' box so that the two halves' sizes are in the ratio of their part counts.
fn bisect(c: &[Vec3], order: &mut [usize], first: usize, parts: usize, out: &mut [u32]) {
    if parts == 1 || order.len() <= 1 {
        order.iter().for_each(|&t| out[t] = first as u32);
        return;
    }
    let (mut lo, mut hi) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
    for &t in order.iter() {
        lo = lo.inf(&c[t]);
        hi = hi.sup(&c[t]);
    }
    let axis = (hi - lo).imax();
    order.sort_by(|&a, &b| c[a][axis].total_cmp(&c[b][axis]).then(a.cmp(&b)));
    let left = parts / 2;
    let cut = order.len() * left / parts;
    let (a, b) = order.split_at_mut(cut);
    bisect(c, a, first, left, out);
    bisect(c, b, first + left, parts - left, out);
}

/// Sum every rank's per-vertex contributions in rank order: `out[vertices_r[k]] += values_r[k]`
/// for r = 0, 1, …, each of `width` numbers. `values` holds the ranks' contributions one after
/// another (as an all-gather returns them); the same bits on every rank.
pub fn sum_in_rank_order(parts: &[Part], values: &[f64], width: usize, out: &mut [f64]) {
    out.iter_mut().for_each(|o| *o = 0.0);
    let mut at = 0;
    for part in parts {
        for &v in &part.vertices {
            for c in 0..width {
                out[width * v + c] += values[at + c];
            }
            at += width;
        }
    }
    debug_assert_eq!(at, values.len());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elastic::ElasticBody;
    use crate::material::{Definiteness, Lame, Model, ModelKind};

    fn block(n: usize) -> TetMesh {
        crate::mesh::generate::box_mesh(Vec3::zeros(), Vec3::new(3.0, 1.0, 1.0), [3 * n, n, n])
    }

    #[test]
    fn parts_cover_the_mesh_once_and_are_balanced() {
        let mesh = block(4);
        for parts in [1, 2, 3, 4, 7] {
            let p = Partition::new(&mesh, parts);
            let counts: Vec<usize> = (0..parts)
                .map(|r| p.tet_part.iter().filter(|&&q| q as usize == r).count())
                .collect();
            let (min, max) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
            assert!(max - min <= 1, "{parts}: {counts:?}");
            let all: Vec<Part> = (0..parts).map(|r| p.part(&mesh, r)).collect();
            // Every vertex owned exactly once; every ghost owned by another rank.
            let owned: usize = all.iter().map(|q| q.owned).sum();
            assert_eq!(owned, mesh.positions.len());
            for (r, q) in all.iter().enumerate() {
                assert!(q.ghosts().iter().all(|&v| p.vertex_owner[v] as usize != r));
                assert_eq!(q.tets.len(), counts[r]);
            }
            if (2..=4).contains(&parts) {
                // A cut through a box: ghosts are a thin layer, not a copy of the mesh (with 7
                // parts of this small box most vertices are near a cut).
                let ghosts: usize = all.iter().map(|q| q.ghosts().len()).sum();
                assert!(
                    ghosts * 4 < mesh.positions.len(),
                    "{parts}: {ghosts} ghosts"
                );
            }
            let (order, position) = p.global_order();
            assert!(order.iter().enumerate().all(|(k, &v)| position[v] == k));
            assert_eq!(
                p.parts(&mesh),
                all,
                "{parts}: one pass gives the same parts"
            );
            // The halo lists: rank r's ghosts owned by q are q's shared vertices with r, in
            // the same order; rows are the global order.
            let layouts = p.layouts(&all);
            for (r, l) in layouts.iter().enumerate() {
                for (k, &v) in all[r].vertices.iter().enumerate() {
                    assert_eq!(l.rows[k], position[v]);
                }
                for nb in &l.neighbours {
                    let back = layouts[nb.rank]
                        .neighbours
                        .iter()
                        .find(|m| m.rank == r)
                        .expect("neighbours both ways");
                    let mine: Vec<usize> = nb.ghosts.iter().map(|&k| all[r].vertices[k]).collect();
                    let theirs: Vec<usize> = back
                        .shared
                        .iter()
                        .map(|&k| all[nb.rank].vertices[k])
                        .collect();
                    assert_eq!(mine, theirs, "{parts}: ranks {r} and {}", nb.rank);
                }
            }
        }
    }

    #[test]
    fn the_parts_forces_summed_in_rank_order_are_the_bodys() {
        let mesh = block(3);
        let mut x = mesh.positions.clone();
        for (i, p) in x.iter_mut().enumerate() {
            *p += 0.01 * Vec3::new((i % 5) as f64, (i % 3) as f64, -((i % 7) as f64));
        }
        let body = ElasticBody::new(
            mesh,
            Model::new(ModelKind::NeoHookean, Lame::from_young_poisson(1e5, 0.3)),
            1000.0,
        )
        .unwrap();
        let mut serial = vec![Vec3::zeros(); body.vertex_count()];
        body.add_forces(&x, &mut serial);
        let full_energy = body.energy(&x);
        for parts in [2, 3, 4] {
            let p = Partition::new(&body.mesh, parts);
            let all: Vec<Part> = (0..parts).map(|r| p.part(&body.mesh, r)).collect();
            let mut gathered = Vec::new();
            let mut energy = 0.0;
            for q in &all {
                let sub = body.part(&q.tets, &q.vertices);
                let xl: Vec<Vec3> = q.vertices.iter().map(|&v| x[v]).collect();
                let mut lin = crate::elastic::Linearization::new(&sub, Definiteness::Projected);
                let mut f = vec![Vec3::zeros(); q.vertices.len()];
                energy += sub.linearize_into(&xl, &mut lin, &mut f);
                gathered.extend(f.iter().flat_map(|v| [v.x, v.y, v.z]));
            }
            let mut flat = vec![0.0; 3 * body.vertex_count()];
            sum_in_rank_order(&all, &gathered, 3, &mut flat);
            let scale = serial.iter().map(|f| f.norm()).fold(0.0, f64::max);
            for (v, f) in serial.iter().enumerate() {
                let g = Vec3::new(flat[3 * v], flat[3 * v + 1], flat[3 * v + 2]);
                assert!((g - f).norm() <= 1e-12 * scale, "{parts} parts, vertex {v}");
            }
            assert!((energy - full_energy).abs() <= 1e-12 * full_energy.abs());
        }
    }
}
