//! Assembly of the stiffness straight into the block matrix, by chunks of rows, in tet order (the same bits for any thread count).

use super::*;

/// The assembled path's split of the work: the tets each chunk of rows needs.
///
/// Each tet adds its element matrix straight into the blocks of the matrix (no per-tet element
/// buffer). The rows are cut into chunks, each owning its rows' blocks; a chunk goes through the
/// tets that touch its rows in tet order and adds their blocks in its rows (found by a binary
/// search in the row), so a tet whose vertices fall in several chunks is computed once in each
/// (a few percent of the tets on a well-numbered mesh). Every block so sums its tets in tet
/// order, as a gather by rows does: the same bits for any thread count and any chunking.
#[derive(Clone, Debug, Default)]
pub struct AssemblyWork {
    /// Rows per chunk.
    chunk_rows: usize,
    /// The number of rows and tets the lists were made for.
    made_for: (usize, usize),
    /// Chunk c's tets are `tets[tet_start[c]..tet_start[c + 1]]`, in increasing order.
    tet_start: Vec<u32>,
    tets: Vec<u32>,
}

impl AssemblyWork {
    /// Bytes held (a memory inventory for `tetsim bench`).
    pub fn heap_bytes(&self) -> usize {
        use crate::memory::vec_bytes;
        vec_bytes(&self.tet_start) + vec_bytes(&self.tets)
    }

    /// Lay out the work for `tets` on `rows` rows.
    fn prepare<const N: usize>(&mut self, tets: &[[usize; N]], rows: usize) {
        // Two chunks per thread, at least 256 rows each: few chunks keep the tets computed
        // twice few (a tet straddles chunks only near their borders: on the bench beam's
        // lattice order, 19 % of the tets at n = 20 with four chunks, 37 % with eight), two
        // per thread let work stealing even out some load. The result does not depend on it.
        self.chunk_rows = rows
            .div_ceil(2 * rayon::current_num_threads().max(1))
            .max(256);
        let chunk_rows = self.chunk_rows;
        let chunks = rows.div_ceil(chunk_rows).max(1);
        let mut count = vec![0u32; chunks + 1];
        let mut seen = vec![u32::MAX; chunks];
        let chunks_of = |t: usize, tet: &[usize; N], seen: &mut [u32], f: &mut dyn FnMut(usize)| {
            for &v in tet {
                let c = v / chunk_rows;
                if seen[c] != t as u32 {
                    seen[c] = t as u32;
                    f(c);
                }
            }
        };
        for (t, tet) in tets.iter().enumerate() {
            chunks_of(t, tet, &mut seen, &mut |c| count[c + 1] += 1);
        }
        for c in 0..chunks {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut list = vec![0u32; count[chunks] as usize];
        seen.fill(u32::MAX);
        for (t, tet) in tets.iter().enumerate() {
            chunks_of(t, tet, &mut seen, &mut |c| {
                list[fill[c] as usize] = t as u32;
                fill[c] += 1;
            });
        }
        log::debug!(
            "assembly: {chunks} chunks of {chunk_rows} rows, {} tet computations for {} tets",
            list.len(),
            tets.len()
        );
        self.tet_start = count;
        self.tets = list;
        self.made_for = (rows, tets.len());
    }
}

impl ElasticBody {
    /// The pattern of the assembled stiffness (vertex adjacency).
    pub fn stiffness_pattern(&self) -> BlockPattern {
        if let Some(q) = self.quadratic() {
            return BlockPattern::from_tets(self.vertex_count(), &q.nodes);
        }
        BlockPattern::from_tets(self.vertex_count(), &self.mesh.tets)
    }

    /// Assemble `A = k_scale·K + m_scale·M` (K from the tangents in `lin`, M the lumped mass)
    /// into `a` (overwritten), whose pattern must hold [`ElasticBody::stiffness_pattern`].
    pub fn assemble_system(
        &self,
        lin: &Linearization,
        k_scale: f64,
        m_scale: f64,
        a: &mut BlockCsr,
        work: &mut AssemblyWork,
    ) {
        self.write_stiffness(lin, k_scale, a, work, true);
        let diagonal: Vec<f64> = self.mass.iter().map(|m| m_scale * m).collect();
        a.add_diagonal(&diagonal);
    }

    /// `a += scale·K` (K from the tangents in `lin`); `a`'s pattern must hold
    /// [`ElasticBody::stiffness_pattern`] (it may hold more blocks). Element matrices are
    /// added straight into the blocks, chunks of rows in parallel (see [`AssemblyWork`]): the
    /// same bits for any thread count.
    pub fn add_stiffness(
        &self,
        lin: &Linearization,
        scale: f64,
        a: &mut BlockCsr,
        work: &mut AssemblyWork,
    ) {
        self.write_stiffness(lin, scale, a, work, false);
    }

    /// `a = scale·K` (`overwrite`: every block of `a` is set, zero where K has none) or
    /// `a += scale·K`. Overwriting zeroes each chunk of rows in the pass that fills it.
    pub fn write_stiffness(
        &self,
        lin: &Linearization,
        scale: f64,
        a: &mut BlockCsr,
        work: &mut AssemblyWork,
        overwrite: bool,
    ) {
        assert_eq!(a.rows(), self.vertex_count());
        if let Some(q) = self.quadratic() {
            return self.quadratic_write_stiffness(q, lin, scale, a, work, overwrite);
        }
        let element = |t: usize| element_stiffness(&lin.tangents[t], &self.bm[t], self.volume[t]);
        write_elements(
            &self.mesh.tets,
            element,
            upper_index,
            scale,
            a,
            work,
            overwrite,
        );
    }
}

/// `a (+)= scale·Σ K_e` over elements of N nodes (see [`ElasticBody::write_stiffness`]):
/// `element(t)` gives element t's upper blocks, block (i, j), i ≤ j, at `upper(i, j)`.
/// Chunks of rows in parallel, each adding its rows' blocks in element order: the same bits for
/// any thread count.
pub(super) fn write_elements<const N: usize, const B: usize>(
    elements: &[[usize; N]],
    element: impl Fn(usize) -> [Mat3; B] + Sync,
    upper: fn(usize, usize) -> usize,
    scale: f64,
    a: &mut BlockCsr,
    work: &mut AssemblyWork,
    overwrite: bool,
) {
    if work.made_for != (a.rows(), elements.len()) {
        work.prepare(elements, a.rows());
    }
    let work = &*work;
    a.for_each_row_chunk_mut(work.chunk_rows, |c, rows, pattern, mut blocks| {
        if overwrite {
            blocks.fill_zero();
        }
        let first = pattern.row_start[rows.start] as usize;
        let list = &work.tets[work.tet_start[c] as usize..work.tet_start[c + 1] as usize];
        for &t in list {
            let t = t as usize;
            let e = element(t);
            let nodes = &elements[t];
            for i in 0..N {
                if !rows.contains(&nodes[i]) {
                    continue;
                }
                let range = pattern.row(nodes[i]);
                let cols = &pattern.cols[range.clone()];
                let start = range.start - first;
                for j in 0..N {
                    let block = if i <= j {
                        e[upper(i, j)]
                    } else {
                        e[upper(j, i)].transpose()
                    };
                    let k = cols
                        .binary_search(&(nodes[j] as u32))
                        .expect("the pattern holds the mesh's");
                    blocks.add(start + k, &(block * scale));
                }
            }
        }
    });
}
