//! The restriction `y = Pᵀ·x` of the V-cycle, read in P's row order.
//!
//! Why: a product with Pᵀ row by row (coarse row i summing the blocks of P's column i) gathers
//! P's blocks from all over the array, one cache miss each; at 1.1M tets it took 5× as long as
//! the prolongation `P·x`, which streams the same blocks (16.6 against 3.5 ms a cycle, the
//! largest item of the finest level). Here P is read in its own order instead: the fine rows
//! are cut into fixed chunks of `rows / 16` rows, each chunk adds its rows' terms into
//! partial sums of the coarse rows it reaches (a short list, hot in cache), and each coarse row
//! then sums its chunks' partials in chunk order. The chunks are fixed, so the bits do not
//! depend on the thread count; they differ from the row-by-row transpose's only in where the
//! sums are split (rounding).

use rayon::prelude::*;

use super::bsr::{Block32, Bsr, ROW_CHUNK, Vector};
use crate::linear::sparse::{BlockPattern, for_each_row};

/// The fine rows are cut into this many chunks (fewer for small P: at least [`MIN_CHUNK`] rows
/// each). Each chunk is one parallel task with partial sums over the coarse rows its rows
/// reach; results depend on the split, so it depends on P's size only, never on the threads.
const CHUNKS: usize = 16;
const MIN_CHUNK: usize = 1024;

/// The chunks' partial sums and where they go, for one P's pattern (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Restriction<const C: usize> {
    /// Fine rows per chunk.
    chunk: usize,
    /// Row c: the coarse rows chunk c reaches, sorted; its entries are chunk c's partial sums.
    touched: BlockPattern,
    /// For each block of P: its coarse row's slot within its chunk's row of `touched`.
    slot: Vec<u32>,
    /// Row i: the chunks reaching coarse row i, in order (columns), and `partials` index of each.
    gather: BlockPattern,
    gather_map: Vec<u32>,
    partials: Vec<Vector<C>>,
}

impl<const C: usize> Restriction<C> {
    /// For P with pattern `p` and `ncols` block columns.
    pub fn new(p: &BlockPattern, ncols: usize) -> Self {
        let chunk = p.rows().div_ceil(CHUNKS).max(MIN_CHUNK);
        let chunks = p.rows().div_ceil(chunk);
        let mut rows: Vec<Vec<u32>> = Vec::with_capacity(chunks);
        let mut slot = vec![0u32; p.blocks()];
        for c in 0..chunks {
            let fine = c * chunk..((c + 1) * chunk).min(p.rows());
            let blocks = p.row(fine.start).start..p.row(fine.end - 1).end;
            let mut cols = p.cols[blocks.clone()].to_vec();
            cols.sort_unstable();
            cols.dedup();
            for k in blocks {
                slot[k] = cols.binary_search(&p.cols[k]).expect("reached") as u32;
            }
            rows.push(cols);
        }
        let touched = Bsr::<1, 1> {
            pattern: BlockPattern::from_rows(&rows),
            values: Vec::new(),
            ncols,
        };
        let (gather, gather_map) = touched.transpose_pattern();
        Restriction {
            chunk,
            partials: vec![Vector::zeros(); touched.blocks()],
            touched: touched.pattern,
            slot,
            gather: gather.pattern,
            gather_map,
        }
    }

    /// `y = Pᵀ·x` for P on `p` (the pattern this was made for) with f32 blocks `values`.
    pub fn apply<const R: usize>(
        &mut self,
        p: &BlockPattern,
        values: &[Block32<R, C>],
        x: &[Vector<R>],
        y: &mut [Vector<C>],
    ) {
        debug_assert_eq!(p.blocks(), self.slot.len());
        debug_assert_eq!(y.len(), self.gather.rows());
        let (slot, chunk) = (&self.slot, self.chunk);
        for_each_row(&self.touched, &mut self.partials, 1, |c, _, sums| {
            sums.iter_mut().for_each(|s| *s = Vector::zeros());
            let fine = c * chunk..((c + 1) * chunk).min(p.rows());
            for (j, xj) in fine.clone().zip(&x[fine]) {
                for k in p.row(j) {
                    sums[slot[k] as usize] += values[k].cast::<f64>().transpose() * xj;
                }
            }
        });
        let (gather, map, partials) = (&self.gather, &self.gather_map, &self.partials);
        y.par_iter_mut()
            .enumerate()
            .with_min_len(ROW_CHUNK)
            .for_each(|(i, yi)| {
                let mut sum = Vector::<C>::zeros();
                for k in gather.row(i) {
                    sum += partials[map[k] as usize];
                }
                *yi = sum;
            });
    }

    /// Bytes held.
    pub fn heap_bytes(&self) -> usize {
        use crate::memory::vec_bytes;
        vec_bytes(&self.touched.row_start)
            + vec_bytes(&self.touched.cols)
            + vec_bytes(&self.slot)
            + vec_bytes(&self.gather.row_start)
            + vec_bytes(&self.gather.cols)
            + vec_bytes(&self.gather_map)
            + vec_bytes(&self.partials)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::amg::bsr::multiply_transposed_f32;
    use crate::linear::amg::bsr::tests::lcg;

    /// A P of `rows` fine rows over `ncols` coarse ones, reaching near and far columns.
    fn random_p(rows: usize, ncols: usize) -> (Bsr<3, 6>, Vec<Block32<3, 6>>) {
        let mut next = lcg(11);
        let lists: Vec<Vec<u32>> = (0..rows)
            .map(|i| {
                // Empty rows too (constrained DOFs), and columns far from the row's own.
                let mut cols: Vec<u32> = (0..next() % 5)
                    .map(|_| {
                        let near = i * ncols / rows;
                        if next().is_multiple_of(7) {
                            next() % ncols
                        } else {
                            (near + next() % 3).min(ncols - 1)
                        }
                    } as u32)
                    .collect();
                cols.sort_unstable();
                cols.dedup();
                cols
            })
            .collect();
        let p = Bsr::<3, 6>::from_rows(&lists, ncols);
        let values = (0..p.blocks())
            .map(|_| Block32::from_fn(|_, _| (next() % 1000) as f32 / 250.0 - 2.0))
            .collect();
        (p, values)
    }

    #[test]
    fn restriction_is_the_transposed_product_in_any_thread_count() {
        let (rows, ncols) = (40 * MIN_CHUNK + 123, 2000);
        let (p, values) = random_p(rows, ncols);
        let x: Vec<Vector<3>> = (0..rows)
            .map(|i| Vector::<3>::new(i as f64 * 1e-3, 1.0 - i as f64 * 1e-4, (i % 17) as f64))
            .collect();
        let (pt, map) = p.transpose_pattern();
        let mut reference = vec![Vector::<6>::zeros(); ncols];
        multiply_transposed_f32(&values, &pt.pattern, &map, &x, &mut reference);
        let mut restriction = Restriction::<6>::new(&p.pattern, ncols);
        let mut run = |threads: usize| {
            let mut y = vec![Vector::<6>::repeat(f64::NAN); ncols];
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| restriction.apply(&p.pattern, &values, &x, &mut y));
            y
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(one, two, "the bits depend on the thread count");
        for (a, b) in one.iter().zip(&reference) {
            assert!(
                (a - b).amax() <= 1e-12 * (1.0 + b.amax()),
                "{a} against {b}"
            );
        }
        // A second application starts from zero again.
        assert_eq!(run(2), one);
    }
}
