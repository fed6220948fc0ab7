//! A detailed surface carried by a coarser tet mesh: each of its points bound once to the rest
//! tet that holds it, then moved every frame with that tet's deformation.
//!
//! **Binding.** A point inside the mesh gets the tet whose smallest barycentric coordinate is
//! largest (ties: the lower tet index), found through a uniform grid over the tets' bounding
//! boxes; a point exactly on a tet corner gets that corner's weight exactly (1, 0, 0, 0), so it
//! follows the corner bit for bit. A point outside the mesh (a smooth surface over a faceted
//! mesh bulges out a little) gets the nearest tet, searched ring by ring in the grid, and that
//! tet's barycentric coordinates extrapolated (some negative): the affine map of the nearest tet
//! carries it. Points farther out than the tolerance are refused, naming the first one and its
//! distance. Each point is bound on its own (rayon), so the result does not depend on threads.
//!
//! **Moving.** x(p) = Σ λᵢ xᵢ over the four corners of a linear tet (exact for any affine
//! deformation of the tet); over the ten nodes of a quadratic tet with its shape functions
//! Nₖ(λ) (corners λᵢ(2λᵢ − 1), edges 4λᵢλⱼ), the same interpolation the element computes with.

use rayon::prelude::*;

use crate::elastic::quadratic::shape_values;
use crate::math::{Mat3, Vec3};
use crate::mesh::TetMesh;

/// The default tolerance for points outside the mesh, as a fraction of the diagonal of the
/// body's bounding box: a smooth surface over a coarse faceted mesh stays well inside it, a
/// surface in the wrong unit or at the wrong place does not.
pub const OUTSIDE_FRACTION: f64 = 0.05;

/// Why a surface could not be bound.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EmbedError {
    /// No tet to bind to.
    #[error("the body has no tets to embed the surface in")]
    NoTets,
    /// Points farther from every tet than the tolerance; `vertex` is the first (1-based, as in
    /// the OBJ file).
    #[error(
        "vertex {vertex} of the surface, at ({:.4}, {:.4}, {:.4}), is {distance:.3e} m from the nearest tet, \
         beyond the tolerance of {tolerance:.3e} m ({count} vertices are); check the surface's \
         unit and placement against the mesh",
        point[0], point[1], point[2]
    )]
    Outside {
        /// 1-based index of the first vertex too far out.
        vertex: usize,
        /// Its position, m.
        point: [f64; 3],
        /// Its distance to the nearest tet, m.
        distance: f64,
        /// The tolerance, m.
        tolerance: f64,
        /// How many vertices are too far out.
        count: usize,
    },
}

/// Each point's tet and barycentric coordinates in it (rest shape).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Embedding {
    /// The tet of each point (the mesh's numbering).
    pub tet: Vec<u32>,
    /// The barycentric coordinates of each point in its tet: sum 1, all ≥ 0 inside, some
    /// negative for a point outside the mesh.
    pub weights: Vec<[f64; 4]>,
    /// How many points lie outside the mesh (bound to their nearest tet).
    pub outside: usize,
    /// The largest distance of an outside point to its tet, m.
    pub max_distance: f64,
}

/// A bound point: its tet, weights and distance to the tet (0 inside).
type Bound = (u32, [f64; 4], f64);

/// A point counts as inside when its smallest barycentric coordinate is at least this: points
/// on a face, up to rounding, are inside.
const INSIDE: f64 = -1e-12;

impl Embedding {
    /// Bind `points` to the tets of `mesh` listed in `candidates` (rest positions); points
    /// farther than `tolerance` (m) from every candidate are refused.
    pub fn bind(
        mesh: &TetMesh,
        candidates: &[usize],
        points: &[Vec3],
        tolerance: f64,
    ) -> Result<Embedding, EmbedError> {
        if candidates.is_empty() {
            return Err(EmbedError::NoTets);
        }
        let grid = Grid::new(mesh, candidates, tolerance);
        let found: Vec<Result<Bound, ()>> = points
            .par_iter()
            .with_min_len(256)
            .map(|p| grid.bind(mesh, p, tolerance))
            .collect();
        let mut out = Embedding {
            tet: Vec::with_capacity(points.len()),
            weights: Vec::with_capacity(points.len()),
            outside: 0,
            max_distance: 0.0,
        };
        let far = found.iter().filter(|f| f.is_err()).count();
        if let Some(first) = found.iter().position(|f| f.is_err()) {
            // The exact distance of the first one, by brute force (it is reported, not bound).
            let p = points[first];
            let distance = candidates
                .iter()
                .map(|&t| grid.distance(mesh, t, &p))
                .fold(f64::INFINITY, f64::min);
            return Err(EmbedError::Outside {
                vertex: first + 1,
                point: [p.x, p.y, p.z],
                distance,
                tolerance,
                count: far,
            });
        }
        for (tet, weights, distance) in found.into_iter().flatten() {
            out.tet.push(tet);
            out.weights.push(weights);
            if distance > 0.0 {
                out.outside += 1;
                out.max_distance = out.max_distance.max(distance);
            }
        }
        Ok(out)
    }

    /// The points moved with the tets: `x` holds the mesh's current node positions.
    pub fn positions(&self, mesh: &TetMesh, x: &[Vec3]) -> Vec<Vec3> {
        let quadratic = mesh.is_quadratic();
        self.tet
            .par_iter()
            .zip(self.weights.par_iter())
            .with_min_len(1024)
            .map(|(&t, &w)| {
                let t = t as usize;
                if quadratic {
                    let n = shape_values(w);
                    mesh.quadratic_nodes(t)
                        .iter()
                        .zip(n)
                        .fold(Vec3::zeros(), |p, (&v, n)| p + n * x[v])
                } else {
                    let c = mesh.tets[t];
                    w[0] * x[c[0]] + w[1] * x[c[1]] + w[2] * x[c[2]] + w[3] * x[c[3]]
                }
            })
            .collect()
    }
}

/// The candidate tets in a uniform grid of cells over their bounding boxes (CSR lists, tets
/// in increasing index order in each cell), with each tet's rest inverse edge matrix.
struct Grid {
    lo: Vec3,
    h: f64,
    dims: [usize; 3],
    start: Vec<usize>,
    tets: Vec<u32>,
    /// Bm = Dm⁻¹ of every tet of the mesh that is a candidate (identity for the others).
    bm: Vec<Mat3>,
}

impl Grid {
    fn new(mesh: &TetMesh, candidates: &[usize], margin: f64) -> Grid {
        let x = &mesh.positions;
        let mut bm = vec![Mat3::identity(); mesh.tets.len()];
        let inverses: Vec<Mat3> = candidates
            .par_iter()
            .map(|&t| {
                TetMesh::edge_matrix(x, &mesh.tets[t])
                    .try_inverse()
                    .unwrap_or_else(Mat3::zeros)
            })
            .collect();
        for (&t, b) in candidates.iter().zip(inverses) {
            bm[t] = b;
        }
        let boxes: Vec<(Vec3, Vec3)> = candidates
            .iter()
            .map(|&t| {
                let c = mesh.tets[t].map(|v| x[v]);
                let lo = c.iter().fold(c[0], |a, b| a.inf(b));
                let hi = c.iter().fold(c[0], |a, b| a.sup(b));
                (lo, hi)
            })
            .collect();
        let mut lo = boxes[0].0;
        let mut hi = boxes[0].1;
        let mut extent = 0.0;
        for (a, b) in &boxes {
            lo = lo.inf(a);
            hi = hi.sup(b);
            extent += (b - a).max();
        }
        let margin = Vec3::repeat(margin.max(0.0));
        let (lo, hi) = (lo - margin, hi + margin);
        // Cells about the size of a tet, at most a few per tet (memory stays linear).
        let size = hi - lo;
        let mut h = (extent / boxes.len() as f64).max(1e-300);
        let cap = 4.0 * boxes.len() as f64 + 64.0;
        while (size / h).map(|s| s.ceil().max(1.0)).product() > cap {
            h *= 1.25;
        }
        let dims = [0, 1, 2].map(|k| ((size[k] / h).ceil() as usize).max(1));
        let cell_of = |p: &Vec3| -> [usize; 3] {
            [0, 1, 2].map(|k| (((p[k] - lo[k]) / h).floor().max(0.0) as usize).min(dims[k] - 1))
        };
        let index = |c: [usize; 3]| c[0] + dims[0] * (c[1] + dims[1] * c[2]);
        let mut count = vec![0usize; dims[0] * dims[1] * dims[2] + 1];
        let cells = |(a, b): &(Vec3, Vec3)| {
            let (ca, cb) = (cell_of(a), cell_of(b));
            (ca[2]..=cb[2]).flat_map(move |k| {
                (ca[1]..=cb[1]).flat_map(move |j| (ca[0]..=cb[0]).map(move |i| [i, j, k]))
            })
        };
        for b in &boxes {
            for c in cells(b) {
                count[index(c) + 1] += 1;
            }
        }
        for i in 1..count.len() {
            count[i] += count[i - 1];
        }
        let start = count.clone();
        let mut tets = vec![0u32; *count.last().unwrap_or(&0)];
        for (b, &t) in boxes.iter().zip(candidates) {
            for c in cells(b) {
                let slot = &mut count[index(c)];
                tets[*slot] = t as u32;
                *slot += 1;
            }
        }
        Grid {
            lo,
            h,
            dims,
            start,
            tets,
            bm,
        }
    }

    fn weights(&self, mesh: &TetMesh, t: usize, p: &Vec3) -> [f64; 4] {
        let c = mesh.tets[t];
        // A point on a corner takes that corner whole: it follows the node exactly.
        if let Some(k) = c.iter().position(|&v| mesh.positions[v] == *p) {
            let mut w = [0.0; 4];
            w[k] = 1.0;
            return w;
        }
        let l = self.bm[t] * (p - mesh.positions[c[0]]);
        [1.0 - l[0] - l[1] - l[2], l[0], l[1], l[2]]
    }

    /// Distance from `p` to tet `t` (0 inside).
    fn distance(&self, mesh: &TetMesh, t: usize, p: &Vec3) -> f64 {
        let w = self.weights(mesh, t, p);
        if w.iter().all(|&w| w >= 0.0) {
            return 0.0;
        }
        let c = mesh.tets[t].map(|v| mesh.positions[v]);
        [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]
            .iter()
            .map(|f| {
                crate::contact::distance::point_triangle_distance(p, &c[f[0]], &c[f[1]], &c[f[2]])
            })
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    fn cell(&self, p: &Vec3) -> Option<[usize; 3]> {
        let mut c = [0; 3];
        for k in 0..3 {
            let f = ((p[k] - self.lo[k]) / self.h).floor();
            if !(f >= 0.0 && f < self.dims[k] as f64) {
                return None;
            }
            c[k] = f as usize;
        }
        Some(c)
    }

    fn cell_tets(&self, c: [usize; 3]) -> &[u32] {
        let i = c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2]);
        &self.tets[self.start[i]..self.start[i + 1]]
    }

    /// The tet, weights and distance (0 inside) of `p`; Err when farther than `tolerance`.
    fn bind(&self, mesh: &TetMesh, p: &Vec3, tolerance: f64) -> Result<Bound, ()> {
        // The grid reaches `tolerance` beyond every tet: a point outside it is too far.
        let c = self.cell(p).ok_or(())?;
        let mut best: Option<(f64, u32)> = None;
        for &t in self.cell_tets(c) {
            let w = self.weights(mesh, t as usize, p);
            let worst = w.iter().copied().fold(f64::INFINITY, f64::min);
            if best.is_none_or(|(b, bt)| worst > b || (worst == b && t < bt)) {
                best = Some((worst, t));
            }
        }
        if let Some((worst, t)) = best
            && worst >= INSIDE
        {
            return Ok((t, self.weights(mesh, t as usize, p), 0.0));
        }
        // Outside: the nearest tet, ring by ring. After rings 0..=r every tet nearer than r·h
        // has been seen (a point at distance d lies in a cell at most ⌈d/h⌉ away).
        let mut nearest: Option<(f64, u32)> = None;
        let reach = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=reach {
            for cell in shell(c, r, self.dims) {
                for &t in self.cell_tets(cell) {
                    let d = self.distance(mesh, t as usize, p);
                    if nearest.is_none_or(|(b, bt)| d < b || (d == b && t < bt)) {
                        nearest = Some((d, t));
                    }
                }
            }
            let seen = r as f64 * self.h;
            if nearest.is_some_and(|(d, _)| d <= seen) || seen > tolerance {
                break;
            }
        }
        match nearest {
            Some((d, t)) if d <= tolerance => Ok((t, self.weights(mesh, t as usize, p), d)),
            _ => Err(()),
        }
    }
}

/// The cells at Chebyshev distance exactly `r` from `c`, inside the grid, in a fixed order.
fn shell(c: [usize; 3], r: usize, dims: [usize; 3]) -> impl Iterator<Item = [usize; 3]> {
    let range = move |k: usize| {
        let lo = c[k].saturating_sub(r);
        let hi = (c[k] + r).min(dims[k] - 1);
        lo..=hi
    };
    range(2).flat_map(move |z| {
        range(1).flat_map(move |y| {
            range(0).filter_map(move |x| {
                let d = [x, y, z]
                    .iter()
                    .zip(c)
                    .map(|(&a, b)| a.abs_diff(b))
                    .max()
                    .unwrap_or(0);
                (d == r).then_some([x, y, z])
            })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    fn cube() -> TetMesh {
        box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 1.0), [3, 3, 3])
    }

    #[test]
    fn a_vertex_on_a_corner_moves_with_that_corner_exactly() {
        let mesh = cube();
        let all: Vec<usize> = (0..mesh.tets.len()).collect();
        let e = Embedding::bind(&mesh, &all, &mesh.positions, 0.01).unwrap();
        // Any deformation at all: the nodes' new positions come back bit for bit.
        let x: Vec<Vec3> = mesh
            .positions
            .iter()
            .map(|p| Vec3::new(p.x.sin() + p.y * p.z, p.y.exp(), p.z * p.z - p.x))
            .collect();
        assert_eq!(e.positions(&mesh, &x), x);
    }

    #[test]
    fn inside_points_move_affinely_under_an_affine_deformation() {
        let mesh = cube();
        let all: Vec<usize> = (0..mesh.tets.len()).collect();
        let points: Vec<Vec3> = (0..500)
            .map(|i| {
                let f = i as f64;
                Vec3::new(
                    (f * 0.618).fract(),
                    (f * 0.414).fract(),
                    (f * 0.732).fract(),
                )
            })
            .collect();
        let e = Embedding::bind(&mesh, &all, &points, 0.01).unwrap();
        assert_eq!(e.outside, 0);
        let a = Mat3::new(1.2, 0.3, -0.1, 0.0, 0.8, 0.2, 0.1, -0.4, 1.1);
        let b = Vec3::new(0.5, -2.0, 3.0);
        let x: Vec<Vec3> = mesh.positions.iter().map(|p| a * p + b).collect();
        for (p, q) in points.iter().zip(e.positions(&mesh, &x)) {
            assert!((a * p + b - q).norm() < 1e-14, "{p}: {q}");
        }
    }

    #[test]
    fn points_slightly_outside_follow_their_nearest_tet_and_far_ones_are_refused() {
        let mesh = cube();
        let all: Vec<usize> = (0..mesh.tets.len()).collect();
        let near = [Vec3::new(0.5, 0.5, 1.01), Vec3::new(-0.02, 0.3, 0.4)];
        let e = Embedding::bind(&mesh, &all, &near, 0.05).unwrap();
        assert_eq!(e.outside, 2);
        assert!((e.max_distance - 0.02).abs() < 1e-12, "{}", e.max_distance);
        // Extrapolated weights still reproduce a translation exactly.
        let x: Vec<Vec3> = mesh.positions.iter().map(|p| p + Vec3::x()).collect();
        let moved = e.positions(&mesh, &x);
        assert!((moved[0] - near[0] - Vec3::x()).norm() < 1e-14);
        let far = [Vec3::new(0.5, 0.5, 0.5), Vec3::new(0.5, 0.5, 1.3)];
        match Embedding::bind(&mesh, &all, &far, 0.05) {
            Err(EmbedError::Outside {
                vertex, distance, ..
            }) => {
                assert_eq!(vertex, 2);
                assert!((distance - 0.3).abs() < 1e-12, "{distance}");
            }
            other => panic!("{other:?}"),
        }
    }
}
