//! Block-sparse symmetric matrices with 3×3 blocks (one block per pair of vertices that share a
//! tet), for the assembled path of the linear solve and for preconditioners that need entries.
//!
//! [`BlockCsr`] stores the full pattern (both triangles) in f64 or f32 (see [`Precision`]): easy
//! to read by rows, used to build preconditioners. Its upper triangle alone, for the CG product
//! of `f32_matrix`, is [`UpperF32`] (in `upper_f32.rs`).

use nalgebra::Matrix3;
use rayon::prelude::*;

use crate::math::{Mat3, Vec3};

/// Rows per chunk of the parallel kernels; fixed so results do not depend on the thread count.
const ROW_CHUNK: usize = 1024;

mod upper_f32;
pub use upper_f32::UpperF32;

/// A symmetric block pattern: for each row (vertex), the sorted columns (vertices) it couples
/// to, the diagonal included.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlockPattern {
    /// Row i's blocks are `row_start[i]..row_start[i + 1]`.
    pub row_start: Vec<u32>,
    /// Column (vertex) of each block, sorted within a row.
    pub cols: Vec<u32>,
}

impl BlockPattern {
    /// The vertex-adjacency pattern of a tet mesh: i and j couple when a tet holds both.
    pub fn from_tets<const N: usize>(vertex_count: usize, tets: &[[usize; N]]) -> Self {
        let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); vertex_count];
        for tet in tets {
            for &a in tet {
                for &b in tet {
                    neighbours[a].push(b as u32);
                }
            }
        }
        for (i, n) in neighbours.iter_mut().enumerate() {
            n.push(i as u32);
            n.sort_unstable();
            n.dedup();
        }
        Self::from_rows(&neighbours)
    }

    /// From sorted, unique column lists per row.
    pub fn from_rows(rows: &[Vec<u32>]) -> Self {
        let mut row_start = Vec::with_capacity(rows.len() + 1);
        row_start.push(0u32);
        let mut cols = Vec::with_capacity(rows.iter().map(Vec::len).sum());
        for r in rows {
            cols.extend_from_slice(r);
            row_start.push(cols.len() as u32);
        }
        BlockPattern { row_start, cols }
    }

    /// This pattern with the blocks (i, j) and (j, i) of every pair added (contact couplings).
    pub fn with_blocks(&self, pairs: &[(u32, u32)]) -> Self {
        let mut rows: Vec<Vec<u32>> = (0..self.rows())
            .map(|i| self.cols[self.row(i)].to_vec())
            .collect();
        for &(i, j) in pairs {
            rows[i as usize].push(j);
            rows[j as usize].push(i);
        }
        for row in &mut rows {
            row.sort_unstable();
            row.dedup();
        }
        Self::from_rows(&rows)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.row_start.len() - 1
    }

    /// Number of stored blocks.
    pub fn blocks(&self) -> usize {
        self.cols.len()
    }

    /// Block range of row i.
    #[inline]
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.row_start[i] as usize..self.row_start[i + 1] as usize
    }

    /// Index of block (i, j), if stored.
    pub fn find(&self, i: usize, j: usize) -> Option<usize> {
        let range = self.row(i);
        self.cols[range.clone()]
            .binary_search(&(j as u32))
            .ok()
            .map(|k| range.start + k)
    }
}

/// Run `f(c, rows, entries of those rows)` for the chunks c of `chunk_rows` consecutive rows of
/// `pattern`, in parallel. The chunks' disjoint slices of `values` are handed out by halving the
/// chunk range with `rayon::join`, without allocating a list of them (this runs once per Newton
/// iterate).
pub(crate) fn for_each_row_chunk<T: Send>(
    pattern: &BlockPattern,
    values: &mut [T],
    chunk_rows: usize,
    f: impl Fn(usize, std::ops::Range<usize>, &mut [T]) + Sync,
) {
    let chunk_rows = chunk_rows.max(1);
    let chunks = pattern.rows().div_ceil(chunk_rows);
    split_row_chunks(pattern, chunk_rows, 0..chunks, values, &f);
}

/// Run `f(i, columns of row i, entries of row i)` for every row of `pattern`, in parallel over
/// chunks of `chunk_rows` rows (rows are disjoint slices of `values`).
pub(crate) fn for_each_row<T: Send>(
    pattern: &BlockPattern,
    values: &mut [T],
    chunk_rows: usize,
    f: impl Fn(usize, &[u32], &mut [T]) + Sync,
) {
    for_each_row_chunk(pattern, values, chunk_rows, |_, rows, values| {
        let mut values = values;
        for i in rows {
            let range = pattern.row(i);
            let (row, rest) = values.split_at_mut(range.len());
            f(i, &pattern.cols[range], row);
            values = rest;
        }
    });
}

/// [`for_each_row_chunk`] on the chunks in `chunks`, whose entries are `values`.
fn split_row_chunks<T: Send>(
    p: &BlockPattern,
    chunk_rows: usize,
    chunks: std::ops::Range<usize>,
    values: &mut [T],
    f: &(impl Fn(usize, std::ops::Range<usize>, &mut [T]) + Sync),
) {
    let n = p.rows();
    let first_row = |chunk: usize| (chunk * chunk_rows).min(n);
    if chunks.len() > 1 {
        let mid = chunks.start + chunks.len() / 2;
        let split = (p.row_start[first_row(mid)] - p.row_start[first_row(chunks.start)]) as usize;
        let (head, tail) = values.split_at_mut(split);
        rayon::join(
            || split_row_chunks(p, chunk_rows, chunks.start..mid, head, f),
            || split_row_chunks(p, chunk_rows, mid..chunks.end, tail, f),
        );
    } else if chunks.len() == 1 {
        let c = chunks.start;
        f(c, first_row(c)..first_row(c + 1), values);
    }
}

/// How a [`BlockCsr`] stores its numbers. A dynamic step's system matrix is [`Precision::F32`]
/// by default (see [`crate::integrator::MatrixPrecision`]): CG's product and the multigrid
/// smoother read it about six times per CG iteration, so its bytes are most of an iteration's
/// memory traffic, and Newton measures its residual with the f64 forces, not with A. Matrices
/// compared with finite differences, or nearly singular ones (a quasistatic K, an analysis's),
/// are [`Precision::F64`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    /// f64 blocks (72 bytes each).
    #[default]
    F64,
    /// f32 blocks (36 bytes each); every addition is done in f64 and rounded once.
    F32,
}

/// A 3×3 block in f32.
pub type Mat3f = Matrix3<f32>;

/// The blocks of a [`BlockCsr`], in its [`Precision`].
#[derive(Clone, Debug, PartialEq)]
enum Blocks {
    F64(Vec<Mat3>),
    F32(Vec<Mat3f>),
}

impl Default for Blocks {
    fn default() -> Self {
        Blocks::F64(Vec::new())
    }
}

/// Mutable access to a run of a [`BlockCsr`]'s blocks (a row or a chunk of rows), whatever its
/// precision: read as f64, added to in f64.
pub enum BlocksMut<'a> {
    /// Blocks of an f64 matrix.
    F64(&'a mut [Mat3]),
    /// Blocks of an f32 matrix.
    F32(&'a mut [Mat3f]),
}

impl BlocksMut<'_> {
    /// Block k of the run.
    #[inline]
    pub fn get(&self, k: usize) -> Mat3 {
        match self {
            BlocksMut::F64(b) => b[k],
            BlocksMut::F32(b) => b[k].cast(),
        }
    }

    /// Block k = m.
    #[inline]
    pub fn set(&mut self, k: usize, m: &Mat3) {
        match self {
            BlocksMut::F64(b) => b[k] = *m,
            BlocksMut::F32(b) => b[k] = m.cast(),
        }
    }

    /// Block k += m (in f64, rounded once).
    #[inline]
    pub fn add(&mut self, k: usize, m: &Mat3) {
        match self {
            BlocksMut::F64(b) => b[k] += m,
            BlocksMut::F32(b) => b[k] = (b[k].cast::<f64>() + m).cast(),
        }
    }

    /// Every block of the run = 0.
    pub fn fill_zero(&mut self) {
        match self {
            BlocksMut::F64(b) => b.fill(Mat3::zeros()),
            BlocksMut::F32(b) => b.fill(Mat3f::zeros()),
        }
    }

    /// Blocks in the run.
    pub fn len(&self) -> usize {
        match self {
            BlocksMut::F64(b) => b.len(),
            BlocksMut::F32(b) => b.len(),
        }
    }

    /// Whether the run is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A symmetric matrix of 3×3 blocks on a [`BlockPattern`], full pattern (both triangles), in
/// f64 or f32 (see [`Precision`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlockCsr {
    /// The pattern.
    pub pattern: BlockPattern,
    /// One block per pattern entry.
    blocks: Blocks,
}

impl BlockCsr {
    /// Zero f64 matrix on a pattern.
    pub fn zeros(pattern: BlockPattern) -> Self {
        Self::zeros_in(pattern, Precision::F64)
    }

    /// Zero matrix on a pattern, stored in `precision`.
    pub fn zeros_in(pattern: BlockPattern, precision: Precision) -> Self {
        let n = pattern.blocks();
        let blocks = match precision {
            Precision::F64 => Blocks::F64(vec![Mat3::zeros(); n]),
            Precision::F32 => Blocks::F32(vec![Mat3f::zeros(); n]),
        };
        BlockCsr { pattern, blocks }
    }

    /// An f64 matrix from its blocks, one per pattern entry.
    pub fn from_blocks(pattern: BlockPattern, blocks: Vec<Mat3>) -> Self {
        assert_eq!(blocks.len(), pattern.blocks());
        BlockCsr {
            pattern,
            blocks: Blocks::F64(blocks),
        }
    }

    /// How the blocks are stored.
    pub fn precision(&self) -> Precision {
        match self.blocks {
            Blocks::F64(_) => Precision::F64,
            Blocks::F32(_) => Precision::F32,
        }
    }

    /// Number of block rows.
    pub fn rows(&self) -> usize {
        self.pattern.rows()
    }

    /// Block k (in pattern order), as f64.
    #[inline]
    pub fn block(&self, k: usize) -> Mat3 {
        match &self.blocks {
            Blocks::F64(b) => b[k],
            Blocks::F32(b) => b[k].cast(),
        }
    }

    /// Every block, as f64 (a copy).
    pub fn blocks_f64(&self) -> Vec<Mat3> {
        match &self.blocks {
            Blocks::F64(b) => b.clone(),
            Blocks::F32(b) => b.iter().map(|m| m.cast()).collect(),
        }
    }

    /// All blocks, for writing.
    pub fn blocks_mut(&mut self) -> BlocksMut<'_> {
        match &mut self.blocks {
            Blocks::F64(b) => BlocksMut::F64(b),
            Blocks::F32(b) => BlocksMut::F32(b),
        }
    }

    /// Bytes of the blocks.
    pub fn block_bytes(&self) -> usize {
        use crate::memory::vec_bytes;
        match &self.blocks {
            Blocks::F64(b) => vec_bytes(b),
            Blocks::F32(b) => vec_bytes(b),
        }
    }

    /// Bytes one stored block takes (72 in f64, 36 in f32).
    pub fn bytes_per_block(&self) -> usize {
        match self.precision() {
            Precision::F64 => 72,
            Precision::F32 => 36,
        }
    }

    /// Bytes one product reads of the matrix: blocks, column indices, row starts.
    pub fn product_bytes(&self) -> usize {
        self.pattern.blocks() * (self.bytes_per_block() + 4) + 4 * (self.rows() + 1)
    }

    /// The diagonal block of row i.
    pub fn diagonal(&self, i: usize) -> Mat3 {
        let k = self
            .pattern
            .find(i, i)
            .expect("the pattern holds the diagonal");
        self.block(k)
    }

    /// `(A·x)ᵢ`, summed in the pattern's order.
    #[inline]
    pub fn row_product(&self, i: usize, x: &[Vec3]) -> Vec3 {
        match &self.blocks {
            Blocks::F64(b) => row_product(&self.pattern, b, i, x),
            Blocks::F32(b) => row_product(&self.pattern, b, i, x),
        }
    }

    /// `y = A·x` (full pattern; parallel over rows, deterministic).
    pub fn multiply(&self, x: &[Vec3], y: &mut [Vec3]) {
        fn run<S: StoredReal>(p: &BlockPattern, b: &[Matrix3<S>], x: &[Vec3], y: &mut [Vec3]) {
            y.par_iter_mut()
                .enumerate()
                .with_min_len(ROW_CHUNK)
                .for_each(|(i, yi)| *yi = row_product(p, b, i, x));
        }
        match &self.blocks {
            Blocks::F64(b) => run(&self.pattern, b, x, y),
            Blocks::F32(b) => run(&self.pattern, b, x, y),
        }
    }

    /// Run `f(i, columns of row i, blocks of row i)` for every row, in parallel over fixed row
    /// chunks (rows are disjoint slices of the values, so no synchronisation is needed).
    pub fn for_each_row_mut(&mut self, f: impl Fn(usize, &[u32], BlocksMut<'_>) + Sync) {
        let p = &self.pattern;
        match &mut self.blocks {
            Blocks::F64(b) => for_each_row(p, b, ROW_CHUNK, |i, c, r| f(i, c, BlocksMut::F64(r))),
            Blocks::F32(b) => for_each_row(p, b, ROW_CHUNK, |i, c, r| f(i, c, BlocksMut::F32(r))),
        }
    }

    /// Run `f(c, rows, the pattern, blocks of those rows)` for the chunks c of `chunk_rows`
    /// consecutive rows, in parallel (the chunks' blocks are disjoint slices; handed out by
    /// halving with `rayon::join`, without allocating: this runs once per Newton iterate).
    pub fn for_each_row_chunk_mut(
        &mut self,
        chunk_rows: usize,
        f: impl Fn(usize, std::ops::Range<usize>, &BlockPattern, BlocksMut<'_>) + Sync,
    ) {
        let p = &self.pattern;
        match &mut self.blocks {
            Blocks::F64(b) => for_each_row_chunk(p, b, chunk_rows, |c, rows, b| {
                f(c, rows, p, BlocksMut::F64(b))
            }),
            Blocks::F32(b) => for_each_row_chunk(p, b, chunk_rows, |c, rows, b| {
                f(c, rows, p, BlocksMut::F32(b))
            }),
        }
    }

    /// Add `d[i]·I` to every diagonal block (a lumped mass).
    pub fn add_diagonal(&mut self, d: &[f64]) {
        assert_eq!(d.len(), self.rows());
        self.for_each_row_mut(|i, cols, mut row| {
            let k = cols
                .binary_search(&(i as u32))
                .expect("the pattern holds the diagonal");
            row.add(k, &Mat3::from_diagonal_element(d[i]));
        });
    }

    /// Project out constrained DOFs: for every component with `free = 0`, zero its row and
    /// column and put the original diagonal entry (1 if it is not positive) back, so the matrix
    /// stays SPD with the constrained DOFs decoupled.
    pub fn constrain(&mut self, free: &[Vec3]) {
        self.for_each_row_mut(|i, cols, mut row| {
            for (k, &j) in cols.iter().enumerate() {
                let j = j as usize;
                let fixed = |v: &Vec3| v.iter().any(|&c| c == 0.0);
                if !fixed(&free[i]) && !fixed(&free[j]) {
                    continue;
                }
                let diagonal = row.get(k);
                let mut block = diagonal;
                for r in 0..3 {
                    for c in 0..3 {
                        if free[i][r] == 0.0 || free[j][c] == 0.0 {
                            block[(r, c)] = 0.0;
                        }
                    }
                }
                if i == j {
                    for r in 0..3 {
                        if free[i][r] == 0.0 {
                            block[(r, r)] = if diagonal[(r, r)] > 0.0 {
                                diagonal[(r, r)]
                            } else {
                                1.0
                            };
                        }
                    }
                }
                row.set(k, &block);
            }
        });
    }

    /// The upper triangle in f32 for fast products.
    pub fn upper_f32(&self, out: &mut UpperF32) {
        out.fill_from(self);
    }
}

/// The number types a [`BlockCsr`] stores, for kernels written once for both.
trait StoredReal: nalgebra::Scalar + Copy + Send + Sync {
    fn load(m: &Matrix3<Self>) -> Mat3;
}

impl StoredReal for f64 {
    #[inline]
    fn load(m: &Mat3) -> Mat3 {
        *m
    }
}

impl StoredReal for f32 {
    #[inline]
    fn load(m: &Mat3f) -> Mat3 {
        m.cast()
    }
}

/// `(A·x)ᵢ` for blocks `b` on `p`, in the pattern's order.
#[inline]
fn row_product<S: StoredReal>(p: &BlockPattern, b: &[Matrix3<S>], i: usize, x: &[Vec3]) -> Vec3 {
    let mut sum = Vec3::zeros();
    for k in p.row(i) {
        sum += S::load(&b[k]) * x[p.cols[k] as usize];
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    fn random_symmetric(n_cells: usize) -> BlockCsr {
        let mesh = box_mesh(
            Vec3::zeros(),
            Vec3::new(3.0, 1.0, 1.0),
            [3 * n_cells, n_cells, n_cells],
        );
        let pattern = BlockPattern::from_tets(mesh.positions.len(), &mesh.tets);
        let mut a = BlockCsr::zeros(pattern);
        let mut seed = 7u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for i in 0..a.rows() {
            for k in a.pattern.row(i) {
                let j = a.pattern.cols[k] as usize;
                if j >= i {
                    let m = Mat3::from_fn(|_, _| next())
                        + if i == j {
                            Mat3::identity() * 20.0
                        } else {
                            Mat3::zeros()
                        };
                    let m = if i == j { m + m.transpose() } else { m };
                    a.blocks_mut().set(k, &m);
                    let kt = a.pattern.find(j, i).unwrap();
                    a.blocks_mut().set(kt, &m.transpose());
                }
            }
        }
        a
    }

    #[test]
    fn upper_f32_product_matches_full_and_is_thread_independent() {
        let a = random_symmetric(8);
        let n = a.rows();
        assert!(n > 3 * ROW_CHUNK / 2, "test several chunks: {n}");
        let x: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new((i as f64).sin(), 1.0, (i as f64 * 0.3).cos()))
            .collect();
        let mut full = vec![Vec3::zeros(); n];
        a.multiply(&x, &mut full);
        let mut upper = UpperF32::default();
        a.upper_f32(&mut upper);
        let run = |threads: usize, upper: &mut UpperF32| {
            let mut y = vec![Vec3::zeros(); n];
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| upper.multiply(&x, &mut y));
            y
        };
        let y1 = run(1, &mut upper);
        let y2 = run(2, &mut upper);
        assert_eq!(y1, y2);
        for i in 0..n {
            assert!(
                (y1[i] - full[i]).norm() <= 1e-5 * (1.0 + full[i].norm()),
                "row {i}: {} vs {}",
                y1[i],
                full[i]
            );
        }
    }

    #[test]
    fn f32_storage_rounds_each_sum_once_and_multiplies_like_the_f64_matrix() {
        let a = random_symmetric(4);
        let n = a.rows();
        // The same blocks added in two parts into an f32 matrix: each addition is done in f64
        // and rounded once (on these numbers the result is the rounded f64 block).
        let mut b = BlockCsr::zeros_in(a.pattern.clone(), Precision::F32);
        assert_eq!(b.precision(), Precision::F32);
        b.for_each_row_mut(|i, _, mut row| {
            let start = a.pattern.row(i).start;
            for k in 0..row.len() {
                row.add(k, &(0.25 * a.block(start + k)));
                row.add(k, &(0.75 * a.block(start + k)));
            }
        });
        for k in 0..a.pattern.blocks() {
            let (exact, stored) = (a.block(k), b.block(k));
            assert_eq!(stored, exact.cast::<f32>().cast::<f64>(), "block {k}");
            let kt = a
                .pattern
                .find(a.pattern.cols[k] as usize, row_of(&a.pattern, k))
                .unwrap();
            assert_eq!(stored, b.block(kt).transpose(), "block {k}: symmetric bits");
        }
        assert_eq!(2 * b.block_bytes(), a.block_bytes());
        let x: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new((i as f64).cos(), -1.0, (i as f64 * 0.7).sin()))
            .collect();
        let (mut full, mut rounded) = (vec![Vec3::zeros(); n], vec![Vec3::zeros(); n]);
        a.multiply(&x, &mut full);
        b.multiply(&x, &mut rounded);
        for i in 0..n {
            assert!(
                (full[i] - rounded[i]).norm() <= 1e-6 * (1.0 + full[i].norm()),
                "row {i}"
            );
            assert_eq!(rounded[i], b.row_product(i, &x));
        }
    }

    fn row_of(p: &BlockPattern, k: usize) -> usize {
        p.row_start.partition_point(|&s| s as usize <= k) - 1
    }

    /// `a`'s blocks added into a zero matrix stored in `precision`.
    fn stored_in(a: &BlockCsr, precision: Precision) -> BlockCsr {
        let mut out = BlockCsr::zeros_in(a.pattern.clone(), precision);
        let mut blocks = out.blocks_mut();
        for k in 0..a.pattern.blocks() {
            blocks.add(k, &a.block(k));
        }
        out
    }

    #[test]
    fn constrained_matrix_decouples_fixed_dofs() {
        for precision in [Precision::F64, Precision::F32] {
            constrained_matrix_decouples_fixed_dofs_in(precision);
        }
    }

    fn constrained_matrix_decouples_fixed_dofs_in(precision: Precision) {
        let mut a = stored_in(&random_symmetric(2), precision);
        let n = a.rows();
        let mut free = vec![Vec3::repeat(1.0); n];
        free[3] = Vec3::new(0.0, 1.0, 0.0);
        let d = a.diagonal(3);
        a.constrain(&free);
        let mut e = vec![Vec3::zeros(); n];
        e[3] = Vec3::x();
        let mut y = vec![Vec3::zeros(); n];
        a.multiply(&e, &mut y);
        for (i, v) in y.iter().enumerate() {
            let expected = if i == 3 {
                Vec3::new(d[(0, 0)], 0.0, 0.0)
            } else {
                Vec3::zeros()
            };
            assert!((v - expected).norm() < 1e-14, "{i}: {v}");
        }
    }
}
