//! The matrix of a level below the finest (a Galerkin product), stored in f64 or in f32.
//!
//! Why f32: at 1.1M tets the second level's matrix (8,112 rows of 43 6×6 blocks) held 100 MB
//! in f64, nearly as much as the f32 system matrix, and the cycle reads it four times (pre- and
//! post-smoothing, residual). A preconditioner needs no more digits than the f32 A it is built
//! from, so a hierarchy built on an f32 A stores its coarse matrices rounded, and one built on
//! an f64 A (quasistatic steps, analyses, contact, the f64 fallback after a breakdown: see
//! [`crate::linear::sparse::Precision`]) keeps them in f64; a refresh follows the A it is
//! given (contact holds A in f64 while pairs are present, on the same pattern, and its
//! barriers are what f32 rounding hurts: the jelly drop's impact frames took 31 % more CG
//! iterations with the coarse levels left in f32). The Galerkin product is computed
//! in f64 and rounded once per entry (blocks mirrored before rounding, so exactly symmetric);
//! everything below reads the rounded blocks, so a refresh and a fresh build agree bit for bit.

use super::MODES;
use super::bsr::{Block, Block32, BlockRows, Bsr, Vector};
use crate::linear::sparse::BlockPattern;

/// A coarse level's matrix (see the module docs).
#[derive(Clone, Debug)]
pub(super) struct CoarseMatrix {
    pattern: BlockPattern,
    ncols: usize,
    values: Values,
}

#[derive(Clone, Debug)]
enum Values {
    F64(Vec<Block<MODES, MODES>>),
    F32(Vec<Block32<MODES, MODES>>),
}

impl CoarseMatrix {
    /// `a`, rounded to f32 when `f32`.
    pub fn new(a: Bsr<MODES, MODES>, f32: bool) -> Self {
        let values = if f32 {
            Values::F32(a.values.iter().map(|b| b.cast::<f32>()).collect())
        } else {
            Values::F64(a.values)
        };
        CoarseMatrix {
            pattern: a.pattern,
            ncols: a.ncols,
            values,
        }
    }

    /// An f64 matrix on this pattern for a refresh's Galerkin product to fill (its blocks are
    /// all overwritten); the pattern is lent to it until [`CoarseMatrix::store`].
    pub fn lend(&mut self) -> Bsr<MODES, MODES> {
        let values = match &mut self.values {
            Values::F64(v) => std::mem::take(v),
            Values::F32(v) => vec![Block::zeros(); v.len()],
        };
        Bsr {
            pattern: std::mem::take(&mut self.pattern),
            values,
            ncols: self.ncols,
        }
    }

    /// Take back what [`CoarseMatrix::lend`] lent, filled (rounded if stored in f32).
    pub fn store(&mut self, a: Bsr<MODES, MODES>) {
        self.pattern = a.pattern;
        match &mut self.values {
            Values::F64(v) => *v = a.values,
            Values::F32(v) => {
                for (out, b) in v.iter_mut().zip(&a.values) {
                    *out = b.cast::<f32>();
                }
            }
        }
    }

    /// Store the blocks in f32 (`f32`) or f64 from now on, converting what is held (a refresh
    /// then overwrites them); nothing to do when they already are.
    pub fn set_precision(&mut self, f32: bool) {
        self.values = match (&self.values, f32) {
            (Values::F64(v), true) => Values::F32(v.iter().map(|b| b.cast::<f32>()).collect()),
            (Values::F32(v), false) => Values::F64(v.iter().map(|b| b.cast::<f64>()).collect()),
            _ => return,
        };
    }

    /// Whether the blocks are stored in f32.
    pub fn is_f32(&self) -> bool {
        matches!(self.values, Values::F32(_))
    }

    /// Number of stored blocks.
    pub fn blocks(&self) -> usize {
        self.pattern.blocks()
    }

    /// The blocks, column-major, 36 numbers each (a checkpoint stores them).
    pub fn column_major(&self) -> Vec<f64> {
        (0..self.blocks())
            .flat_map(|k| {
                let b = self.block(k);
                (0..MODES * MODES).map(move |e| b[e])
            })
            .collect()
    }

    /// Set the blocks from [`CoarseMatrix::column_major`]'s numbers (rounded if stored in f32:
    /// numbers that came from f32 come back with the same bits).
    pub fn set_column_major(&mut self, stored: &[f64]) {
        debug_assert_eq!(stored.len(), MODES * MODES * self.blocks());
        let blocks = stored.chunks(MODES * MODES).map(Block::from_column_slice);
        match &mut self.values {
            Values::F64(v) => v.iter_mut().zip(blocks).for_each(|(out, b)| *out = b),
            Values::F32(v) => v
                .iter_mut()
                .zip(blocks)
                .for_each(|(out, b)| *out = b.cast::<f32>()),
        }
    }

    /// Bytes held: blocks and pattern.
    pub fn heap_bytes(&self) -> usize {
        use crate::memory::vec_bytes;
        let values = match &self.values {
            Values::F64(v) => vec_bytes(v),
            Values::F32(v) => vec_bytes(v),
        };
        values + vec_bytes(&self.pattern.row_start) + vec_bytes(&self.pattern.cols)
    }
}

impl BlockRows<MODES, MODES> for CoarseMatrix {
    fn pattern(&self) -> &BlockPattern {
        &self.pattern
    }

    #[inline]
    fn block(&self, k: usize) -> Block<MODES, MODES> {
        match &self.values {
            Values::F64(v) => v[k],
            Values::F32(v) => v[k].cast::<f64>(),
        }
    }

    /// The storage is chosen once per row, not per block (the smoother's hot loop).
    #[inline]
    fn row_product(&self, i: usize, x: &[Vector<MODES>]) -> Vector<MODES> {
        let p = &self.pattern;
        let mut sum = Vector::<MODES>::zeros();
        match &self.values {
            Values::F64(v) => {
                for k in p.row(i) {
                    sum += v[k] * x[p.cols[k] as usize];
                }
            }
            Values::F32(v) => {
                for k in p.row(i) {
                    sum += v[k].cast::<f64>() * x[p.cols[k] as usize];
                }
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Bsr<MODES, MODES> {
        let rows = vec![vec![0u32, 1], vec![0, 1, 2], vec![1, 2]];
        let mut a = Bsr::<MODES, MODES>::from_rows(&rows, 3);
        for (k, b) in a.values.iter_mut().enumerate() {
            *b = Block::from_fn(|i, j| 1.0 / (1.0 + (i + 2 * j + 3 * k) as f64));
        }
        a
    }

    #[test]
    fn f32_storage_rounds_once_and_reads_like_f64() {
        let a = sample();
        let x: Vec<Vector<MODES>> = (0..3)
            .map(|i| Vector::<MODES>::from_fn(|c, _| 0.3 * (i + c) as f64 - 1.0))
            .collect();
        let wide = CoarseMatrix::new(a.clone(), false);
        let mut narrow = CoarseMatrix::new(a.clone(), true);
        assert!(narrow.heap_bytes() < wide.heap_bytes());
        for k in 0..a.blocks() {
            assert_eq!(wide.block(k), a.values[k]);
            assert_eq!(narrow.block(k), a.values[k].cast::<f32>().cast::<f64>());
        }
        for i in 0..3 {
            let expected: Vector<MODES> = a
                .row(i)
                .map(|k| narrow.block(k) * x[a.pattern.cols[k] as usize])
                .sum();
            assert_eq!(narrow.row_product(i, &x), expected);
        }
        // A checkpoint's numbers come back with the same bits, and lend/store round-trips.
        let numbers = narrow.column_major();
        let mut restored = CoarseMatrix::new(a.clone(), true);
        restored.set_column_major(&numbers);
        assert_eq!(restored.column_major(), numbers);
        let mut lent = narrow.lend();
        lent.values.clone_from(&a.values);
        narrow.store(lent);
        assert_eq!(narrow.column_major(), numbers);
    }
}
