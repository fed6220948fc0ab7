//! A box mesh with the full symmetry of the cube in every cell: each cube is cut into 24 tets
//! (its centre, each face's centre and each face's edges). The generator's Kuhn tets prefer the
//! (1,1,1) diagonal, so bending along y + z and y − z differ (a square cantilever's bending
//! "pair" comes out 7-17 % apart); this mesh is invariant under the 90° rotation about the
//! beam's axis, so the pair is exactly degenerate.

use tetsim::{TetMesh, Vec3};

/// `[0, size] ` split into `cells` cubes (cuboids) of 24 positively oriented tets each.
pub fn box_mesh_24(size: Vec3, cells: [usize; 3]) -> TetMesh {
    let [nx, ny, nz] = cells;
    let h = size.component_div(&Vec3::new(nx as f64, ny as f64, nz as f64));
    let mut positions: Vec<Vec3> = Vec::new();
    let mut index = std::collections::BTreeMap::<[usize; 3], usize>::new();
    // Points on the half-cell lattice: corners (even, even, even), face centres (two odd),
    // cell centres (all odd).
    let mut point = |twice: [usize; 3]| -> usize {
        *index.entry(twice).or_insert_with(|| {
            positions.push(Vec3::new(
                twice[0] as f64 * h.x / 2.0,
                twice[1] as f64 * h.y / 2.0,
                twice[2] as f64 * h.z / 2.0,
            ));
            positions.len() - 1
        })
    };
    let mut tets: Vec<[usize; 4]> = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let base = [2 * i, 2 * j, 2 * k];
                let at = |d: [usize; 3]| [base[0] + d[0], base[1] + d[1], base[2] + d[2]];
                let centre = point(at([1, 1, 1]));
                for axis in 0..3 {
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    for side in [0, 2] {
                        let mut f = [1, 1, 1];
                        f[axis] = side;
                        let face = point(at(f));
                        // The face's four corners in order around it.
                        let mut corner = |a: usize, b: usize| {
                            let mut c = [0; 3];
                            c[axis] = side;
                            c[u] = a;
                            c[v] = b;
                            point(at(c))
                        };
                        let ring = [corner(0, 0), corner(2, 0), corner(2, 2), corner(0, 2)];
                        for e in 0..4 {
                            tets.push([centre, face, ring[e], ring[(e + 1) % 4]]);
                        }
                    }
                }
            }
        }
    }
    for tet in &mut tets {
        let x = tet.map(|v| positions[v]);
        if (x[1] - x[0]).cross(&(x[2] - x[0])).dot(&(x[3] - x[0])) < 0.0 {
            tet.swap(2, 3);
        }
    }
    TetMesh::new(positions, tets)
}
