//! One triangle (j ≥ i) of a symmetric [`BlockCsr`] in f32, for the CG product where bytes
//! moved per iteration are the cost: about a quarter of the full f64 matrix. Its product is
//! deterministic for any thread count: rows are cut into fixed chunks, each chunk adds the
//! transposed part that falls outside itself into a private spill buffer, and spills are summed
//! in chunk order.

use rayon::prelude::*;

use super::{BlockCsr, BlockPattern, ROW_CHUNK};
use crate::math::Vec3;

/// One triangle (j ≥ i) of a symmetric block matrix in f32, with a deterministic parallel
/// product (see the module docs). Refilled in place with a fixed pattern.
#[derive(Clone, Debug, Default)]
pub struct UpperF32 {
    row_start: Vec<u32>,
    cols: Vec<u32>,
    values: Vec<[f32; 9]>,
    /// Per chunk: first row past the chunk, and how many rows past it its transposed part
    /// reaches (its spill buffer's length).
    spill: Vec<(usize, usize)>,
    spill_offset: Vec<usize>,
    spill_buffer: Vec<Vec3>,
}

impl UpperF32 {
    /// Pattern and values from the upper triangle of a full matrix.
    pub fn fill_from(&mut self, a: &BlockCsr) {
        let p = &a.pattern;
        if self.row_start.len() != p.rows() + 1 {
            self.build_pattern(p);
        }
        let mut k_out = 0;
        for i in 0..p.rows() {
            for k in p.row(i) {
                if p.cols[k] as usize >= i {
                    let m = a.block(k);
                    // Column-major, as nalgebra stores it.
                    self.values[k_out] = std::array::from_fn(|e| m[e] as f32);
                    k_out += 1;
                }
            }
        }
    }

    fn build_pattern(&mut self, p: &BlockPattern) {
        let n = p.rows();
        self.row_start = Vec::with_capacity(n + 1);
        self.cols.clear();
        self.row_start.push(0);
        for i in 0..n {
            for k in p.row(i) {
                if p.cols[k] as usize >= i {
                    self.cols.push(p.cols[k]);
                }
            }
            self.row_start.push(self.cols.len() as u32);
        }
        self.values = vec![[0.0; 9]; self.cols.len()];
        self.spill.clear();
        self.spill_offset.clear();
        let mut offset = 0;
        for start in (0..n).step_by(ROW_CHUNK) {
            let end = (start + ROW_CHUNK).min(n);
            let reach = (start..end)
                .flat_map(|i| {
                    self.cols[self.row_start[i] as usize..self.row_start[i + 1] as usize].iter()
                })
                .map(|&j| j as usize + 1)
                .max()
                .unwrap_or(end)
                .max(end);
            self.spill.push((end, reach - end));
            self.spill_offset.push(offset);
            offset += reach - end;
        }
        self.spill_buffer = vec![Vec3::zeros(); offset];
    }

    /// Block rows.
    pub fn rows(&self) -> usize {
        self.row_start.len().saturating_sub(1)
    }

    /// Bytes held: values, indices, spill buffers.
    pub fn heap_bytes(&self) -> usize {
        use crate::memory::vec_bytes;
        vec_bytes(&self.row_start)
            + vec_bytes(&self.cols)
            + vec_bytes(&self.values)
            + vec_bytes(&self.spill_buffer)
    }

    /// Bytes of the stored matrix: values and column indices, row starts.
    pub fn matrix_bytes(&self) -> usize {
        self.values.len() * (36 + 4) + 4 * self.row_start.len()
    }

    /// Bytes the product reads and writes per call (matrix, indices, vectors), for roofline
    /// figures.
    pub fn bytes_per_product(&self) -> usize {
        let n = self.row_start.len().saturating_sub(1);
        self.values.len() * (36 + 4) + 4 * (n + 1) + 3 * 24 * n + 2 * 24 * self.spill_buffer.len()
    }

    /// `y = A·x`, deterministic for any thread count.
    pub fn multiply(&mut self, x: &[Vec3], y: &mut [Vec3]) {
        let (row_start, cols, values) = (&self.row_start, &self.cols, &self.values);
        let chunks: Vec<(usize, &mut [Vec3])> = {
            let mut out = Vec::with_capacity(self.spill.len());
            let mut rest: &mut [Vec3] = &mut self.spill_buffer;
            for &(_, len) in &self.spill {
                let (head, tail) = rest.split_at_mut(len);
                out.push((len, head));
                rest = tail;
            }
            out
        };
        y.par_chunks_mut(ROW_CHUNK)
            .zip(chunks.into_par_iter())
            .enumerate()
            .for_each(|(c, (y, (_, spill)))| {
                let start = c * ROW_CHUNK;
                let end = start + y.len();
                y.iter_mut().for_each(|v| *v = Vec3::zeros());
                spill.iter_mut().for_each(|v| *v = Vec3::zeros());
                for i in start..end {
                    let xi = x[i];
                    let mut sum = Vec3::zeros();
                    for k in row_start[i] as usize..row_start[i + 1] as usize {
                        let j = cols[k] as usize;
                        let m = &values[k];
                        let xj = x[j];
                        // Row part: block (i, j)·xⱼ.
                        sum.x += m[0] as f64 * xj.x + m[3] as f64 * xj.y + m[6] as f64 * xj.z;
                        sum.y += m[1] as f64 * xj.x + m[4] as f64 * xj.y + m[7] as f64 * xj.z;
                        sum.z += m[2] as f64 * xj.x + m[5] as f64 * xj.y + m[8] as f64 * xj.z;
                        if j != i {
                            // Transposed part: block (i, j)ᵀ·xᵢ into row j.
                            let t = Vec3::new(
                                m[0] as f64 * xi.x + m[1] as f64 * xi.y + m[2] as f64 * xi.z,
                                m[3] as f64 * xi.x + m[4] as f64 * xi.y + m[5] as f64 * xi.z,
                                m[6] as f64 * xi.x + m[7] as f64 * xi.y + m[8] as f64 * xi.z,
                            );
                            if j < end {
                                y[j - start] += t;
                            } else {
                                spill[j - end] += t;
                            }
                        }
                    }
                    y[i - start] += sum;
                }
            });
        // Spills, added in chunk order.
        let (spill, offsets, buffer) = (&self.spill, &self.spill_offset, &self.spill_buffer);
        y.par_chunks_mut(ROW_CHUNK).enumerate().for_each(|(c, y)| {
            let start = c * ROW_CHUNK;
            let end = start + y.len();
            for (d, &(first, len)) in spill.iter().enumerate().take(c) {
                let (lo, hi) = (first.max(start), (first + len).min(end));
                for j in lo..hi {
                    y[j - start] += buffer[offsets[d] + j - first];
                }
            }
        });
    }
}
