//! Built-in mesh generators, so that scenes and benchmarks need no mesh file.

use super::{Group, TetMesh};
use crate::math::Vec3;

/// The six tets of the Kuhn (Freudenthal) subdivision of the unit cube along its (0,0,0)–(1,1,1)
/// diagonal, as corner ids (bit 0 = x, bit 1 = y, bit 2 = z). Each tet walks from corner 0 to
/// corner 7 along one permutation of the axes; the tets of odd permutations have their middle two
/// vertices swapped so that all six are positively oriented.
fn kuhn_tets() -> [[usize; 4]; 6] {
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut tets = [[0; 4]; 6];
    for (t, p) in perms.iter().enumerate() {
        let a = 1 << p[0];
        let b = a | (1 << p[1]);
        // Odd permutations are the ones with an odd number of inversions.
        let inversions = (p[0] > p[1]) as usize + (p[0] > p[2]) as usize + (p[1] > p[2]) as usize;
        tets[t] = if inversions.is_multiple_of(2) {
            [0, a, b, 7]
        } else {
            [0, b, a, 7]
        };
    }
    tets
}

/// A box `[min, max]` split into `cells` cubes (cuboids), each into the six positively oriented
/// tets of the Kuhn subdivision. Vertices are numbered x-fastest, then y, then z. Six groups name
/// the faces of the box: `xmin`, `xmax`, `ymin`, `ymax`, `zmin`, `zmax`.
pub fn box_mesh(min: Vec3, max: Vec3, cells: [usize; 3]) -> TetMesh {
    let [nx, ny, nz] = cells;
    let (vx, vy) = (nx + 1, ny + 1);
    let vertex = |i: usize, j: usize, k: usize| i + vx * (j + vy * k);
    let step = (max - min).component_div(&Vec3::new(nx as f64, ny as f64, nz as f64));
    let mut positions = Vec::with_capacity(vx * vy * (nz + 1));
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                let ijk = Vec3::new(i as f64, j as f64, k as f64);
                positions.push(min + step.component_mul(&ijk));
            }
        }
    }
    let corners = kuhn_tets();
    let mut tets = Vec::with_capacity(6 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let corner = |c: usize| vertex(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                tets.extend(corners.iter().map(|t| t.map(corner)));
            }
        }
    }
    let mut mesh = TetMesh::new(positions, tets);
    let dims = [nx, ny, nz];
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        for (side, suffix) in [(0, "min"), (dims[axis], "max")] {
            let vertices = (0..mesh.positions.len())
                .filter(|&v| {
                    let ijk = [v % vx, (v / vx) % vy, v / (vx * vy)];
                    ijk[axis] == side
                })
                .collect();
            mesh.groups.push(Group {
                name: format!("{name}{suffix}"),
                dim: 2,
                vertices,
                ..Default::default()
            });
        }
    }
    mesh
}

/// A unit icosahedron subdivided `levels` times (each triangle into 4, new vertices pushed onto
/// the sphere), outward triangles.
pub fn icosphere(levels: usize) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut points: Vec<Vec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        // Midpoints shared between the two triangles of an edge, found in a sorted list (no
        // hash order reaches the output).
        let mut midpoints: Vec<((usize, usize), usize)> = Vec::new();
        let mut midpoint = |a: usize, b: usize, points: &mut Vec<Vec3>| {
            let key = (a.min(b), a.max(b));
            match midpoints.binary_search_by_key(&key, |e| e.0) {
                Ok(i) => midpoints[i].1,
                Err(i) => {
                    points.push((0.5 * (points[a] + points[b])).normalize());
                    midpoints.insert(i, (key, points.len() - 1));
                    points.len() - 1
                }
            }
        };
        let mut finer = Vec::with_capacity(4 * triangles.len());
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut points);
            let bc = midpoint(b, c, &mut points);
            let ca = midpoint(c, a, &mut points);
            finer.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = finer;
    }
    (points, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kuhn_box_is_positive_and_fills_the_box() {
        let mesh = box_mesh(Vec3::zeros(), Vec3::new(4.0, 1.0, 2.0), [4, 2, 3]);
        assert_eq!(mesh.tets.len(), 6 * 24);
        assert_eq!(mesh.positions.len(), 5 * 3 * 4);
        let mut total = 0.0;
        for t in 0..mesh.tets.len() {
            let v = mesh.signed_volume(t);
            assert!(v > 0.0, "tet {t} negatively oriented");
            total += v;
        }
        assert!((total - 8.0).abs() < 1e-12);
        assert!(mesh.validate().is_ok());
        // Closed surface: 2 triangles per boundary square.
        assert_eq!(mesh.boundary_faces().len(), 2 * 2 * (4 * 2 + 4 * 3 + 2 * 3));
        assert_eq!(mesh.group("xmin").unwrap().vertices.len(), 3 * 4);
    }
}
