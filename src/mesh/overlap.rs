//! Whether a deformed tet mesh overlaps itself: a vertex strictly inside a tet it is not a
//! vertex of. A mesh whose tets are all positively oriented and that has no such vertex is
//! *untangled*; folded and everted meshes (the local minima a tangled start can settle in, every
//! tet positive but the mesh lying over itself) have one.
//!
//! A uniform grid of cells about a mean tet's size holds every tet's bounding box; each vertex
//! then tests the tets of its own cell: O(n) for a mesh of reasonable shape, parallel over the
//! vertices, and the answer (the first such vertex) is the same on any thread count.

use rayon::prelude::*;

use crate::math::Vec3;

/// A point counts as inside a tet when each of its four barycentric coordinates exceeds this
/// share of one: a vertex on a neighbour's face, or within rounding of it, is not inside.
const INSIDE_MARGIN: f64 = 1e-9;

/// At most this many grid cells per tet (a bound on memory when a few tets are huge).
const CELLS_PER_TET: usize = 8;

/// The first vertex (lowest index) strictly inside a tet it is not a vertex of, with that tet;
/// None when there is none. Either orientation counts (a rest mesh may hold both).
pub fn first_vertex_inside(x: &[Vec3], tets: &[[usize; 4]]) -> Option<(usize, usize)> {
    if tets.is_empty() || x.is_empty() {
        return None;
    }
    let grid = Grid::new(x, tets);
    (0..x.len()).into_par_iter().find_map_first(|v| {
        let p = x[v];
        grid.tets_near(&p)
            .iter()
            .map(|&t| t as usize)
            .find(|&t| !tets[t].contains(&v) && strictly_inside(&p, x, &tets[t]))
            .map(|t| (v, t))
    })
}

/// The first of `points` (lowest index) inside a tet of the mesh at `x` or on its boundary (a
/// point on a face shared by two tets is inside the body), with that tet.
pub fn first_point_inside(
    x: &[Vec3],
    tets: &[[usize; 4]],
    points: &[Vec3],
) -> Option<(usize, usize)> {
    if tets.is_empty() || points.is_empty() {
        return None;
    }
    let grid = Grid::new(x, tets);
    let (lo, hi) = super::bounding_box(x);
    (0..points.len()).into_par_iter().find_map_first(|k| {
        let p = points[k];
        if (0..3).any(|i| p[i] < lo[i] || p[i] > hi[i]) {
            return None;
        }
        grid.tets_near(&p)
            .iter()
            .map(|&t| t as usize)
            .find(|&t| inside_or_on(&p, x, &tets[t]))
            .map(|t| (k, t))
    })
}

/// Whether p is inside the tet or on its boundary (within rounding), either orientation.
fn inside_or_on(p: &Vec3, x: &[Vec3], tet: &[usize; 4]) -> bool {
    depth_inside(p, x, tet).is_some_and(|d| d >= -INSIDE_MARGIN)
}

/// Whether p is strictly inside the tet, of either orientation (see [`INSIDE_MARGIN`]).
fn strictly_inside(p: &Vec3, x: &[Vec3], tet: &[usize; 4]) -> bool {
    depth_inside(p, x, tet).is_some_and(|d| d > INSIDE_MARGIN)
}

/// The smallest barycentric coordinate of p in the tet (negative outside), whatever the tet's
/// orientation; None for a flat or non-finite tet.
fn depth_inside(p: &Vec3, x: &[Vec3], tet: &[usize; 4]) -> Option<f64> {
    let [a, b, c, d] = tet.map(|v| x[v]);
    let volume = (b - a).cross(&(c - a)).dot(&(d - a));
    if volume == 0.0 || !volume.is_finite() {
        return None;
    }
    // Each signed volume below has the tet's own sign when p is inside.
    let w = barycentric_volumes(p, &[a, b, c, d]);
    Some(w.iter().map(|&w| w / volume).fold(f64::INFINITY, f64::min))
}

/// Six times the signed volumes of the tets with p in place of each vertex in turn.
fn barycentric_volumes(p: &Vec3, [a, b, c, d]: &[Vec3; 4]) -> [f64; 4] {
    let orient =
        |q0: &Vec3, q1: &Vec3, q2: &Vec3, q3: &Vec3| (q1 - q0).cross(&(q2 - q0)).dot(&(q3 - q0));
    [
        orient(p, b, c, d),
        orient(a, p, c, d),
        orient(a, b, p, d),
        orient(a, b, c, p),
    ]
}

/// Tets binned by the grid cells their bounding boxes touch (compressed rows).
struct Grid {
    origin: Vec3,
    cell: f64,
    dims: [usize; 3],
    starts: Vec<u32>,
    tets: Vec<u32>,
}

impl Grid {
    fn new(x: &[Vec3], tets: &[[usize; 4]]) -> Self {
        let (lo, hi) = super::bounding_box(x);
        let extent = hi - lo;
        let mean_size = tets
            .iter()
            .map(|t| {
                let (a, b) = bounds(x, t);
                (b - a).max()
            })
            .sum::<f64>()
            / tets.len() as f64;
        // Cells about a mean tet across, but never more than CELLS_PER_TET per tet in all.
        let budget = (CELLS_PER_TET * tets.len()).max(1) as f64;
        let volume_cell =
            (extent.x.max(1e-300) * extent.y.max(1e-300) * extent.z.max(1e-300) / budget).cbrt();
        let cell = mean_size.max(volume_cell).max(extent.max() / 1024.0);
        let cell = if cell > 0.0 && cell.is_finite() {
            cell
        } else {
            1.0
        };
        let dims = [0, 1, 2].map(|k| ((extent[k] / cell) as usize + 1).min(1024));
        let grid =
            |p: &Vec3| [0, 1, 2].map(|k| (((p[k] - lo[k]) / cell) as usize).min(dims[k] - 1));
        let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        let ncells = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0u32; ncells + 1];
        let cells_of = |t: &[usize; 4], f: &mut dyn FnMut(usize)| {
            let (a, b) = bounds(x, t);
            let (ca, cb) = (grid(&a), grid(&b));
            for k in ca[2]..=cb[2] {
                for j in ca[1]..=cb[1] {
                    for i in ca[0]..=cb[0] {
                        f(index([i, j, k]));
                    }
                }
            }
        };
        for t in tets {
            cells_of(t, &mut |c| counts[c + 1] += 1);
        }
        for c in 0..ncells {
            counts[c + 1] += counts[c];
        }
        let mut fill = counts.clone();
        let mut binned = vec![0u32; counts[ncells] as usize];
        for (n, t) in tets.iter().enumerate() {
            cells_of(t, &mut |c| {
                binned[fill[c] as usize] = n as u32;
                fill[c] += 1;
            });
        }
        Grid {
            origin: lo,
            cell,
            dims,
            starts: counts,
            tets: binned,
        }
    }

    /// The tets whose bounding boxes touch the cell of p.
    fn tets_near(&self, p: &Vec3) -> &[u32] {
        let c = [0, 1, 2].map(|k| {
            (((p[k] - self.origin[k]) / self.cell).max(0.0) as usize).min(self.dims[k] - 1)
        });
        let i = (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0];
        &self.tets[self.starts[i] as usize..self.starts[i + 1] as usize]
    }
}

/// The bounding box of one tet.
fn bounds(x: &[Vec3], tet: &[usize; 4]) -> (Vec3, Vec3) {
    let mut lo = x[tet[0]];
    let mut hi = lo;
    for &v in &tet[1..] {
        lo = lo.inf(&x[v]);
        hi = hi.sup(&x[v]);
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    #[test]
    fn a_mesh_at_rest_does_not_overlap_itself() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(3.0, 1.0, 1.0), [6, 2, 2]);
        assert_eq!(first_vertex_inside(&mesh.positions, &mesh.tets), None);
    }

    #[test]
    fn a_vertex_pushed_into_another_tet_is_found() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(3.0, 1.0, 1.0), [6, 2, 2]);
        let mut x = mesh.positions.clone();
        // The last vertex (a corner at the far end) moved to the centroid of the first tet.
        let target = mesh.tets[0];
        let v = x.len() - 1;
        assert!(!target.contains(&v));
        x[v] = target.iter().map(|&k| x[k]).sum::<Vec3>() / 4.0;
        // The moved vertex, or one that its stretched tets now cover (the lowest index wins).
        let (found, t) = first_vertex_inside(&x, &mesh.tets).expect("an overlap");
        assert!(!mesh.tets[t].contains(&found));
        assert!(strictly_inside(&x[found], &x, &mesh.tets[t]));
        assert!(
            mesh.tets
                .iter()
                .any(|tet| !tet.contains(&v) && strictly_inside(&x[v], &x, tet))
        );
    }

    #[test]
    fn a_vertex_on_a_face_is_not_inside() {
        let x = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.25, 0.25, 0.0),
        ];
        assert!(!strictly_inside(&x[4], &x, &[0, 1, 2, 3]));
        let inside = Vec3::new(0.1, 0.1, 0.1);
        assert!(strictly_inside(&inside, &x, &[0, 1, 2, 3]));
    }
}
