//! The elasticity term's side of a distributed run: after a rank evaluates its own tets with
//! the serial code, [`Ghosts`] completes the forces over the ranks (ghost contributions added
//! to their owners, ghosts zeroed: see [`super`]), makes the tet counts the whole body's, and
//! sends the element matrices to an [`ElementSink`] (the distributed PETSc matrix) at the rows
//! of the whole body's numbering.

use std::sync::{Arc, Mutex};

use super::Ranks;
use crate::elastic::{ElasticBody, Linearization, element_stiffness};
use crate::math::{Mat3, Vec3};

/// Where the element stiffness matrices go.
pub trait ElementSink: Send {
    /// Start a new matrix (zero it).
    fn begin(&mut self);
    /// Add one tet's 12×12 matrix (row-major, rows and columns in corner order, x y z per
    /// corner) at the given block rows and columns (the whole body's matrix rows).
    fn add_element(&mut self, rows: [usize; 4], values: &[f64; 144]);
}

/// One rank's elasticity hooks.
pub struct Ghosts {
    ranks: Arc<dyn Ranks>,
    sink: Arc<Mutex<dyn ElementSink>>,
    /// The matrix block row of each of this rank's vertices.
    rows: Vec<usize>,
    flat: Vec<f64>,
}

impl Ghosts {
    /// Hooks over `ranks`, adding into `sink` at `rows` (one per local vertex).
    pub fn new(ranks: Arc<dyn Ranks>, sink: Arc<Mutex<dyn ElementSink>>, rows: Vec<usize>) -> Self {
        Ghosts {
            ranks,
            sink,
            rows,
            flat: Vec::new(),
        }
    }

    /// Forces (or K·v) of this rank's tets → the whole body's on owned vertices, zero on ghosts.
    pub fn complete(&mut self, values: &mut [Vec3]) {
        self.flat.clear();
        self.flat
            .extend(values.iter().flat_map(|v| [v.x, v.y, v.z]));
        self.ranks.complete(&mut self.flat, 3);
        for (v, f) in values.iter_mut().zip(self.flat.chunks_exact(3)) {
            *v = Vec3::new(f[0], f[1], f[2]);
        }
    }

    /// 3×3 blocks per vertex, completed like [`Ghosts::complete`].
    pub fn complete_blocks(&mut self, values: &mut [Mat3]) {
        self.flat.clear();
        self.flat
            .extend(values.iter().flat_map(|b| b.iter().copied()));
        self.ranks.complete(&mut self.flat, 9);
        for (b, f) in values.iter_mut().zip(self.flat.chunks_exact(9)) {
            *b = Mat3::from_column_slice(f);
        }
    }

    /// Make `lin`'s tet counts the whole body's.
    pub fn count(&self, lin: &mut Linearization) {
        let mut counts = [
            lin.clamped_tets() as f64,
            lin.strongly_clamped_tets() as f64,
            lin.inverted_tets() as f64,
        ];
        self.ranks.sum(&mut counts);
        lin.set_counts(counts[0] as usize, counts[1] as usize, counts[2] as usize);
    }

    /// Send `scale·K_e` of this rank's tets (`body`, with tangents `lin`), with the rows and
    /// columns of constrained DOFs (`free` = 0) zeroed, to the sink.
    pub fn write_matrix(&self, body: &ElasticBody, lin: &Linearization, scale: f64, free: &[Vec3]) {
        let mut sink = self.sink.lock().expect("the matrix is not poisoned");
        sink.begin();
        let mut values = [0.0; 144];
        for (t, tet) in body.mesh.tets.iter().enumerate() {
            let k = element_stiffness(
                &lin.tangents()[t],
                &body.rest_inverses()[t],
                body.volumes()[t],
            );
            for a in 0..4 {
                for b in 0..4 {
                    let block = if a <= b {
                        k[upper(a, b)]
                    } else {
                        k[upper(b, a)].transpose()
                    };
                    for i in 0..3 {
                        for j in 0..3 {
                            let mask = free[tet[a]][i] * free[tet[b]][j];
                            values[(3 * a + i) * 12 + 3 * b + j] = scale * mask * block[(i, j)];
                        }
                    }
                }
            }
            sink.add_element(tet.map(|v| self.rows[v]), &values);
        }
    }
}

/// Index of block (a, b), a ≤ b, in [`element_stiffness`]'s upper triangle.
fn upper(a: usize, b: usize) -> usize {
    [0, 4, 7, 9][a] + b - a
}
