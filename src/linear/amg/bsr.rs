//! Block compressed sparse rows with R×C blocks of compile-time size: the operators of the AMG
//! hierarchy (A with 3×3 or 6×6 blocks, P with 3×6 or 6×6, Pᵀ), their products, and the
//! deterministic vector kernels the cycle uses.
//!
//! Every kernel is parallel over rows and computes each output row on its own in a fixed order,
//! so the bits do not depend on the thread count; the only reductions (dot products) sum fixed
//! chunks in order.

use nalgebra::{SMatrix, SVector};
use rayon::prelude::*;

use crate::linear::sparse::{BlockCsr, BlockPattern, for_each_row};

/// Rows per parallel task. Results never depend on it (rows are independent); it only sets the
/// grain of the work split.
pub(crate) const ROW_CHUNK: usize = 512;

/// Vector entries per chunk of a dot product: fixed, so sums are the same for any thread count.
const DOT_CHUNK: usize = 2048;

/// A block vector entry.
pub(crate) type Vector<const B: usize> = SVector<f64, B>;
/// A block.
pub(crate) type Block<const R: usize, const C: usize> = SMatrix<f64, R, C>;

/// A sparse matrix of R×C blocks in compressed rows, columns sorted within a row.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bsr<const R: usize, const C: usize> {
    /// Rows and sorted block columns (the same structure as the assembled system's).
    pub pattern: BlockPattern,
    /// The blocks.
    pub values: Vec<Block<R, C>>,
    /// Number of block columns.
    pub ncols: usize,
}

impl<const R: usize, const C: usize> Bsr<R, C> {
    /// Zero blocks on the pattern given by sorted column lists per row.
    pub fn from_rows(rows: &[Vec<u32>], ncols: usize) -> Self {
        debug_assert!(rows.iter().all(|r| r.windows(2).all(|w| w[0] < w[1])));
        let pattern = BlockPattern::from_rows(rows);
        let values = vec![Block::<R, C>::zeros(); pattern.blocks()];
        Bsr {
            pattern,
            values,
            ncols,
        }
    }

    /// Bytes held: blocks and pattern.
    pub fn heap_bytes(&self) -> usize {
        use crate::memory::vec_bytes;
        vec_bytes(&self.values) + vec_bytes(&self.pattern.row_start) + vec_bytes(&self.pattern.cols)
    }

    /// Number of stored blocks.
    pub fn blocks(&self) -> usize {
        self.pattern.blocks()
    }

    /// Run `f(i, columns of row i, blocks of row i)` for every row, in parallel over row chunks.
    pub fn for_each_row_mut(&mut self, f: impl Fn(usize, &[u32], &mut [Block<R, C>]) + Sync) {
        for_each_row(&self.pattern, &mut self.values, ROW_CHUNK, f);
    }

    /// The transpose's pattern (no blocks) and, for each of its blocks, the index of the block
    /// of `self` it mirrors.
    pub fn transpose_pattern(&self) -> (Bsr<C, R>, Vec<u32>) {
        let mut counts = vec![0u32; self.ncols + 1];
        for &j in &self.pattern.cols {
            counts[j as usize + 1] += 1;
        }
        for j in 0..self.ncols {
            counts[j + 1] += counts[j];
        }
        let mut fill = counts.clone();
        let mut cols = vec![0u32; self.blocks()];
        let mut map = vec![0u32; self.blocks()];
        // Rows in increasing order, so every transposed row comes out sorted.
        for i in 0..self.rows() {
            for k in self.row(i) {
                let j = self.pattern.cols[k] as usize;
                let at = fill[j] as usize;
                cols[at] = i as u32;
                map[at] = k as u32;
                fill[j] += 1;
            }
        }
        let t = Bsr {
            values: Vec::new(),
            pattern: BlockPattern {
                row_start: counts,
                cols,
            },
            ncols: self.rows(),
        };
        (t, map)
    }

    /// Fill `t` (from [`Bsr::transpose_pattern`]) with the transposed blocks.
    #[cfg(test)]
    pub fn transpose_into(&self, t: &mut Bsr<C, R>, map: &[u32]) {
        t.values
            .par_iter_mut()
            .zip(map.par_iter())
            .with_min_len(4 * ROW_CHUNK)
            .for_each(|(v, &k)| *v = self.values[k as usize].transpose());
    }
}

/// Read access to a matrix of R×C blocks in compressed rows: an owned [`Bsr`], or the assembled
/// system's [`BlockCsr`] itself, which the finest level smooths with instead of a copy (see
/// [`super::Amg::new_shared`]). The products compute each row on its own, in the pattern's order.
pub(crate) trait BlockRows<const R: usize, const C: usize>: Sync {
    /// Rows and sorted block columns.
    fn pattern(&self) -> &BlockPattern;
    /// Block k (in pattern order), as f64.
    fn block(&self, k: usize) -> Block<R, C>;

    /// Number of block rows.
    fn rows(&self) -> usize {
        self.pattern().rows()
    }

    /// Block range of row i.
    #[inline]
    fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.pattern().row(i)
    }

    /// Index of block (i, j), if stored.
    fn find(&self, i: usize, j: usize) -> Option<usize> {
        self.pattern().find(i, j)
    }

    /// `(M·x)ᵢ`.
    #[inline]
    fn row_product(&self, i: usize, x: &[Vector<C>]) -> Vector<R> {
        let pattern = self.pattern();
        let mut sum = Vector::<R>::zeros();
        for k in pattern.row(i) {
            sum += self.block(k) * x[pattern.cols[k] as usize];
        }
        sum
    }

    /// `y = M·x`.
    fn multiply(&self, x: &[Vector<C>], y: &mut [Vector<R>]) {
        debug_assert_eq!(y.len(), self.rows());
        y.par_iter_mut()
            .enumerate()
            .with_min_len(ROW_CHUNK)
            .for_each(|(i, yi)| *yi = self.row_product(i, x));
    }

    /// `r = b − M·x`.
    fn residual(&self, b: &[Vector<R>], x: &[Vector<C>], r: &mut [Vector<R>]) {
        r.par_iter_mut()
            .zip(b.par_iter())
            .enumerate()
            .with_min_len(ROW_CHUNK)
            .for_each(|(i, (ri, bi))| *ri = bi - self.row_product(i, x));
    }
}

impl<const R: usize, const C: usize> BlockRows<R, C> for Bsr<R, C> {
    fn pattern(&self) -> &BlockPattern {
        &self.pattern
    }
    #[inline]
    fn block(&self, k: usize) -> Block<R, C> {
        self.values[k]
    }
}

/// The system's A, f64 or f32 (see [`crate::linear::sparse::Precision`]): its row products
/// choose the storage once per row, not per block.
impl BlockRows<3, 3> for BlockCsr {
    fn pattern(&self) -> &BlockPattern {
        &self.pattern
    }
    #[inline]
    fn block(&self, k: usize) -> Block<3, 3> {
        BlockCsr::block(self, k)
    }
    #[inline]
    fn row_product(&self, i: usize, x: &[Vector<3>]) -> Vector<3> {
        BlockCsr::row_product(self, i, x)
    }
}

/// A block stored in f32: the transfer operators T and P keep their blocks so (half the bytes;
/// their entries are O(1) and a preconditioner needs no more digits), converted to f64 as they
/// are read.
pub(crate) type Block32<const R: usize, const C: usize> = SMatrix<f32, R, C>;

/// `y += M·x` for M on `pattern` with f32 blocks.
pub(crate) fn multiply_add_f32<const R: usize, const C: usize>(
    pattern: &BlockPattern,
    values: &[Block32<R, C>],
    x: &[Vector<C>],
    y: &mut [Vector<R>],
) {
    y.par_iter_mut()
        .enumerate()
        .with_min_len(ROW_CHUNK)
        .for_each(|(i, yi)| {
            let mut sum = Vector::<R>::zeros();
            for k in pattern.row(i) {
                sum += values[k].cast::<f64>() * x[pattern.cols[k] as usize];
            }
            *yi += sum;
        });
}

/// `y = Mᵀ·x` for M with f32 blocks `values`, read through the transpose's pattern and map (from
/// [`Bsr::transpose_pattern`]): the bits of a product with the stored transpose, without it.
/// (The cycle restricts in P's own order instead, see `restrict.rs`; this is its reference.)
#[cfg(test)]
pub(crate) fn multiply_transposed_f32<const R: usize, const C: usize>(
    values: &[Block32<R, C>],
    pattern: &BlockPattern,
    map: &[u32],
    x: &[Vector<R>],
    y: &mut [Vector<C>],
) {
    debug_assert_eq!(y.len(), pattern.rows());
    y.par_iter_mut()
        .enumerate()
        .with_min_len(ROW_CHUNK)
        .for_each(|(i, yi)| {
            let mut sum = Vector::<C>::zeros();
            for k in pattern.row(i) {
                sum +=
                    values[map[k] as usize].cast::<f64>().transpose() * x[pattern.cols[k] as usize];
            }
            *yi = sum;
        });
}

/// The pattern of `a·b`, without blocks (a caller that needs them allocates them: a set-up's
/// freed temporaries stay resident). Built in one flat array, not a list per row, for the same
/// reason.
pub(crate) fn product_pattern<const R: usize, const K: usize, const C: usize>(
    a: &impl BlockRows<R, K>,
    b: &Bsr<K, C>,
) -> Bsr<R, C> {
    let mut marker = vec![u32::MAX; b.ncols];
    let mut row_start = Vec::with_capacity(a.rows() + 1);
    row_start.push(0u32);
    let mut cols: Vec<u32> = Vec::new();
    for i in 0..a.rows() {
        let begin = cols.len();
        for ka in a.row(i) {
            let k = a.pattern().cols[ka] as usize;
            for kb in b.row(k) {
                let j = b.pattern.cols[kb];
                if marker[j as usize] != i as u32 {
                    marker[j as usize] = i as u32;
                    cols.push(j);
                }
            }
        }
        cols[begin..].sort_unstable();
        row_start.push(cols.len() as u32);
    }
    cols.shrink_to_fit();
    Bsr {
        pattern: BlockPattern { row_start, cols },
        values: Vec::new(),
        ncols: b.ncols,
    }
}

/// `out = a·b` on `out`'s pattern (from [`product_pattern`]). With `upper`, only the blocks with
/// column ≥ row are computed (the others are left alone), for symmetric products.
#[cfg(test)]
pub(crate) fn product_into<const R: usize, const K: usize, const C: usize>(
    a: &impl BlockRows<R, K>,
    b: &Bsr<K, C>,
    out: &mut Bsr<R, C>,
    upper: bool,
) {
    product_with_into(
        a.pattern(),
        |k| a.block(k),
        &b.pattern,
        |k| b.values[k],
        out,
        upper,
    );
}

/// [`product_into`] with a's and b's blocks given by functions of their index on `a_pattern` and
/// `b_pattern` (a transpose read through its map, f32 blocks converted, say;
/// transpose read through its map, say).
pub(crate) fn product_with_into<const R: usize, const K: usize, const C: usize>(
    a_pattern: &BlockPattern,
    a_block: impl Fn(usize) -> Block<R, K> + Sync,
    b_pattern: &BlockPattern,
    b_block: impl Fn(usize) -> Block<K, C> + Sync,
    out: &mut Bsr<R, C>,
    upper: bool,
) {
    out.for_each_row_mut(|i, cols, row| {
        let first = if upper {
            cols.partition_point(|&j| (j as usize) < i)
        } else {
            0
        };
        row[first..].iter_mut().for_each(|v| *v = Block::zeros());
        let cols = &cols[first..];
        let row = &mut row[first..];
        for ka in a_pattern.row(i) {
            let k = a_pattern.cols[ka] as usize;
            let block = a_block(ka);
            let range = b_pattern.row(k);
            // Columns below the first wanted one are skipped without a search.
            let bcols = &b_pattern.cols[range.clone()];
            let skip = if upper {
                bcols.partition_point(|&j| (j as usize) < i)
            } else {
                0
            };
            let mut at = 0;
            for (kb, &j) in range.clone().zip(bcols).skip(skip) {
                // Both column lists are sorted: advance instead of searching.
                while cols[at] != j {
                    at += 1;
                }
                row[at] += block * b_block(kb);
            }
        }
    });
}

/// For a symmetric pattern, the pairs (lower block, its mirror upper block): block (i, j) with
/// j < i and the index of (j, i).
pub(crate) fn mirror_pairs<const B: usize>(m: &Bsr<B, B>) -> Vec<(u32, u32)> {
    let mut pairs = Vec::new();
    for i in 0..m.rows() {
        for k in m.row(i) {
            let j = m.pattern.cols[k] as usize;
            if j < i {
                pairs.push((k as u32, m.find(j, i).expect("symmetric pattern") as u32));
            }
        }
    }
    pairs
}

/// Copy the upper blocks (column > row) into the lower ones, transposed: exact symmetry. A
/// sequential copy: it moves each lower block once, a small cost next to the products.
pub(crate) fn mirror_lower<const B: usize>(m: &mut Bsr<B, B>, pairs: &[(u32, u32)]) {
    for &(lower, upper) in pairs {
        m.values[lower as usize] = m.values[upper as usize].transpose();
    }
}

/// Deterministic parallel `Σ aᵢ·bᵢ`: fixed chunks, partial sums added in order.
pub(crate) fn dot<const B: usize>(
    a: &[Vector<B>],
    b: &[Vector<B>],
    partials: &mut Vec<f64>,
) -> f64 {
    let chunks = a.len().div_ceil(DOT_CHUNK);
    partials.resize(chunks.max(1), 0.0);
    a.par_chunks(DOT_CHUNK)
        .zip(b.par_chunks(DOT_CHUNK))
        .zip(partials.par_iter_mut())
        .for_each(|((a, b), s)| *s = a.iter().zip(b).map(|(x, y)| x.dot(y)).sum());
    partials[..chunks].iter().sum()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn dense<const R: usize, const C: usize>(m: &Bsr<R, C>) -> nalgebra::DMatrix<f64> {
        let mut d = nalgebra::DMatrix::zeros(R * m.rows(), C * m.ncols);
        for i in 0..m.rows() {
            for k in m.row(i) {
                let j = m.pattern.cols[k] as usize;
                d.view_mut((R * i, C * j), (R, C)).copy_from(&m.values[k]);
            }
        }
        d
    }

    /// A small deterministic generator of test numbers (an LCG's high bits).
    pub(crate) fn lcg(seed: u64) -> impl FnMut() -> usize {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as usize
        }
    }

    fn sample<const R: usize, const C: usize>(rows: usize, ncols: usize, seed: u64) -> Bsr<R, C> {
        let mut next = lcg(seed);
        let pattern: Vec<Vec<u32>> = (0..rows)
            .map(|_| {
                let mut r: Vec<u32> = (0..3).map(|_| (next() % ncols) as u32).collect();
                r.sort_unstable();
                r.dedup();
                r
            })
            .collect();
        let mut m = Bsr::<R, C>::from_rows(&pattern, ncols);
        for v in &mut m.values {
            *v = Block::<R, C>::from_fn(|_, _| (next() % 1000) as f64 / 500.0 - 1.0);
        }
        m
    }

    #[test]
    fn products_and_transposes_match_dense() {
        let a = sample::<3, 6>(40, 9, 1);
        let b = sample::<6, 6>(9, 7, 2);
        let mut c = product_pattern(&a, &b);
        c.values = vec![Block::zeros(); c.blocks()];
        product_into(&a, &b, &mut c, false);
        assert!((dense(&c) - dense(&a) * dense(&b)).norm() < 1e-12);
        let (mut t, map) = a.transpose_pattern();
        t.values = vec![Block::zeros(); t.blocks()];
        a.transpose_into(&mut t, &map);
        assert_eq!(dense(&t), dense(&a).transpose());
        // Symmetric product, upper half computed and mirrored.
        let mut s = product_pattern(&t, &a);
        s.values = vec![Block::zeros(); s.blocks()];
        product_into(&t, &a, &mut s, true);
        let pairs = mirror_pairs(&s);
        mirror_lower(&mut s, &pairs);
        let exact = dense(&a).transpose() * dense(&a);
        assert!((dense(&s) - &exact).norm() < 1e-12 * exact.norm());
        assert_eq!(dense(&s), dense(&s).transpose());
    }
}
