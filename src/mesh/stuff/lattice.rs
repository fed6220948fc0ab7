//! The body-centred cubic (BCC) lattice of isosurface stuffing: black vertices at the corners of
//! a cubic grid of spacing h, red vertices at the cube centres. Its tets (each the hull of a red
//! edge crossing a cube face and one black edge of that face) are all congruent, with dihedral
//! angles of 60° and 90°, which is what the stencils' quality bound starts from.
//!
//! Vertices live in doubled integer coordinates: black at (2i, 2j, 2k), red at (2i+1, 2j+1, 2k+1).
//! Every lattice edge is owned by one endpoint and named by one of seven "positive" directions
//! from it, so an edge has one id (vertex · 7 + direction) without a hash map.

use crate::math::Vec3;

/// The seven directions (in doubled coordinates) an edge leaves its owner by: three axis edges
/// (black–black or red–red, length h) and four diagonal edges (black–red, length h·√3/2).
pub const DIRECTIONS: [[i64; 3]; 7] = [
    [2, 0, 0],
    [0, 2, 0],
    [0, 0, 2],
    [1, 1, 1],
    [1, 1, -1],
    [1, -1, 1],
    [1, -1, -1],
];

/// Whether direction `d` is an axis (long) edge.
pub fn is_axis(d: usize) -> bool {
    d < 3
}

/// A BCC lattice covering a box with at least one cell of margin on every side.
#[derive(Clone, Debug)]
pub struct Lattice {
    /// Position of black vertex (0, 0, 0).
    pub origin: Vec3,
    /// Cube edge length h.
    pub spacing: f64,
    /// Cells along x, y, z (black vertices: cells + 1).
    pub cells: [usize; 3],
}

impl Lattice {
    /// The lattice of spacing `h` over the box `min..max`, centred on it, with one cell of margin
    /// so that the outermost vertices lie outside the box.
    pub fn covering(min: &Vec3, max: &Vec3, h: f64) -> Lattice {
        let extent = max - min;
        let cells = [0, 1, 2].map(|k| (extent[k] / h).ceil().max(1.0) as usize + 2);
        let centre = 0.5 * (min + max);
        let half = Vec3::new(cells[0] as f64, cells[1] as f64, cells[2] as f64) * (0.5 * h);
        Lattice {
            origin: centre - half,
            spacing: h,
            cells,
        }
    }

    fn black_count(&self) -> usize {
        let [x, y, z] = self.cells;
        (x + 1) * (y + 1) * (z + 1)
    }

    /// Number of vertices, black then red.
    pub fn vertex_count(&self) -> usize {
        let [x, y, z] = self.cells;
        self.black_count() + x * y * z
    }

    /// The id of the vertex at doubled coordinates `c`, or None outside the lattice (or at a
    /// point that is neither black nor red).
    pub fn id(&self, c: [i64; 3]) -> Option<usize> {
        let [nx, ny, nz] = self.cells.map(|n| n as i64);
        let parity = c[0].rem_euclid(2);
        if c.iter().any(|&v| v.rem_euclid(2) != parity) {
            return None;
        }
        if parity == 0 {
            let [i, j, k] = c.map(|v| v / 2);
            let inside = (0..=nx).contains(&i) && (0..=ny).contains(&j) && (0..=nz).contains(&k);
            inside.then(|| (i + (nx + 1) * (j + (ny + 1) * k)) as usize)
        } else {
            let [i, j, k] = c.map(|v| (v - 1).div_euclid(2));
            let inside = (0..nx).contains(&i) && (0..ny).contains(&j) && (0..nz).contains(&k);
            inside.then(|| self.black_count() + (i + nx * (j + ny * k)) as usize)
        }
    }

    /// Doubled coordinates of vertex `v`.
    pub fn coords(&self, v: usize) -> [i64; 3] {
        let [nx, ny, _] = self.cells;
        let black = self.black_count();
        if v < black {
            let (i, rest) = (v % (nx + 1), v / (nx + 1));
            let (j, k) = (rest % (ny + 1), rest / (ny + 1));
            [i, j, k].map(|c| 2 * c as i64)
        } else {
            let r = v - black;
            let (i, rest) = (r % nx, r / nx);
            let (j, k) = (rest % ny, rest / ny);
            [i, j, k].map(|c| 2 * c as i64 + 1)
        }
    }

    /// Position of the point at doubled coordinates `c`.
    pub fn position_of(&self, c: [i64; 3]) -> Vec3 {
        self.origin + Vec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * (0.5 * self.spacing)
    }

    /// Position of vertex `v`.
    pub fn position(&self, v: usize) -> Vec3 {
        self.position_of(self.coords(v))
    }

    /// The other end of the edge leaving `v` in direction `d`, if it is in the lattice.
    pub fn neighbour(&self, v: usize, d: usize) -> Option<usize> {
        let c = self.coords(v);
        let o = DIRECTIONS[d];
        self.id([c[0] + o[0], c[1] + o[1], c[2] + o[2]])
    }

    /// The edge id (owner · 7 + direction) of the edge between `a` and `b`, if they are
    /// lattice neighbours.
    pub fn edge_id(&self, a: usize, b: usize) -> Option<usize> {
        let (ca, cb) = (self.coords(a), self.coords(b));
        let delta = [cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]];
        let neg = delta.map(|x| -x);
        DIRECTIONS.iter().position(|&d| d == delta).map_or_else(
            || DIRECTIONS.iter().position(|&d| d == neg).map(|d| b * 7 + d),
            |d| Some(a * 7 + d),
        )
    }

    /// Number of cube faces that separate two cells (each carries four lattice tets).
    pub fn interior_face_count(&self) -> usize {
        let [x, y, z] = self.cells;
        x.saturating_sub(1) * y * z + x * y.saturating_sub(1) * z + x * y * (z.saturating_sub(1))
    }

    /// The four lattice tets of interior face `f` (faces normal to x, then y, then z), as
    /// vertex ids: two reds (the cells on either side) and two blacks (an edge of the face).
    pub fn face_tets(&self, f: usize) -> [[usize; 4]; 4] {
        let [x, y, z] = self.cells;
        let per_axis = [
            (x.saturating_sub(1)) * y * z,
            x * (y.saturating_sub(1)) * z,
            x * y * (z.saturating_sub(1)),
        ];
        let (mut axis, mut r) = (0, f);
        while r >= per_axis[axis] {
            r -= per_axis[axis];
            axis += 1;
        }
        // Cells along this axis on the face's "low" side: the face sits at cell index c[axis]+1.
        let mut dims = self.cells;
        dims[axis] -= 1;
        let i = r % dims[0];
        let j = (r / dims[0]) % dims[1];
        let k = r / (dims[0] * dims[1]);
        let cell = [i as i64, j as i64, k as i64];
        let red_low = cell.map(|c| 2 * c + 1);
        let mut red_high = red_low;
        red_high[axis] += 2;
        // The face's corners, in cyclic order, in the plane doubled-coordinate 2·(cell+1).
        let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
        let corner = |du: i64, dw: i64| {
            let mut c = [0i64; 3];
            c[axis] = 2 * (cell[axis] + 1);
            c[u] = 2 * (cell[u] + du);
            c[w] = 2 * (cell[w] + dw);
            self.id(c).unwrap_or(usize::MAX)
        };
        let ring = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
        let (lo, hi) = (
            self.id(red_low).unwrap_or(usize::MAX),
            self.id(red_high).unwrap_or(usize::MAX),
        );
        std::array::from_fn(|m| [lo, hi, ring[m], ring[(m + 1) % 4]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_and_coordinates_round_trip() {
        let l = Lattice::covering(&Vec3::zeros(), &Vec3::new(1.0, 2.0, 3.0), 0.5);
        for v in 0..l.vertex_count() {
            assert_eq!(l.id(l.coords(v)), Some(v));
        }
    }

    #[test]
    fn face_tets_fill_the_interior_with_equal_volumes() {
        let l = Lattice::covering(&Vec3::zeros(), &Vec3::new(1.0, 1.0, 1.0), 0.5);
        let h = l.spacing;
        let mut total = 0.0;
        for f in 0..l.interior_face_count() {
            for t in l.face_tets(f) {
                assert!(t.iter().all(|&v| v != usize::MAX));
                let p = t.map(|v| l.position(v));
                let vol = (p[1] - p[0])
                    .cross(&(p[2] - p[0]))
                    .dot(&(p[3] - p[0]))
                    .abs()
                    / 6.0;
                assert!((vol - h * h * h / 12.0).abs() < 1e-12);
                total += vol;
                // Every pair of a tet's vertices is a lattice edge.
                for a in 0..4 {
                    for b in a + 1..4 {
                        assert!(l.edge_id(t[a], t[b]).is_some());
                    }
                }
            }
        }
        // Interior faces cover the box between the outermost cell centres.
        let [x, y, z] = l.cells.map(|c| (c - 1) as f64 * h);
        let core = x * y * z;
        assert!(total > core, "{total} vs {core}");
    }
}
