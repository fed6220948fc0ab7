//! The small dense pieces of LOBPCG: Rayleigh-Ritz on the projected pencil, Gram matrices of blocks (plain and mass-weighted, in a fixed order), and linear combinations of blocks.

use super::*;

/// The m smallest Ritz pairs of `H·c = θ·G·c` (G symmetric positive definite), ascending, with
/// `Cᵀ·G·C = I`; None when G does not factor or a value is not finite.
pub(super) fn rayleigh_ritz(
    h: &DMatrix<f64>,
    g: &DMatrix<f64>,
    m: usize,
) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let l = g.clone().cholesky()?.l();
    let l_inv = l.try_inverse()?;
    let reduced = &l_inv * h * l_inv.transpose();
    let reduced = (&reduced + reduced.transpose()) * 0.5;
    if reduced.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let eigen = SymmetricEigen::new(reduced);
    let mut order: Vec<usize> = (0..eigen.eigenvalues.len()).collect();
    order.sort_by(|&i, &j| eigen.eigenvalues[i].total_cmp(&eigen.eigenvalues[j]));
    order.truncate(m);
    let values = order.iter().map(|&i| eigen.eigenvalues[i]).collect();
    let v = DMatrix::from_fn(h.nrows(), order.len(), |r, c| {
        eigen.eigenvectors[(r, order[c])]
    });
    Some((values, l_inv.transpose() * v))
}

/// `AᵀB` for two blocks whose product is symmetric in exact arithmetic (upper half computed and
/// mirrored).
pub(super) fn gram_sym(a: &Block, b: &Block) -> DMatrix<f64> {
    let a: Vec<&[Vec3]> = a.iter().map(Vec::as_slice).collect();
    let b: Vec<&[Vec3]> = b.iter().map(Vec::as_slice).collect();
    gram_sym_slices(&a, &b, None)
}

/// `XᵀBX`.
pub(super) fn gram_sym_mass(x: &Block, mass: &[f64]) -> DMatrix<f64> {
    let xs: Vec<&[Vec3]> = x.iter().map(Vec::as_slice).collect();
    gram_sym_slices(&xs, &xs, Some(mass))
}

/// [`gram_slices`] for a symmetric result: the upper half, mirrored.
pub(super) fn gram_sym_slices(
    a: &[&[Vec3]],
    b: &[&[Vec3]],
    weight: Option<&[f64]>,
) -> DMatrix<f64> {
    gram_with(a, b, weight, true)
}

/// `G[i][j] = Σ_v w_v·a_i[v]·b_j[v]` (w = 1 without weights), summed over fixed vertex chunks
/// in order.
pub(super) fn gram_slices(a: &[&[Vec3]], b: &[&[Vec3]], weight: Option<&[f64]>) -> DMatrix<f64> {
    gram_with(a, b, weight, false)
}

pub(super) fn gram_with(
    a: &[&[Vec3]],
    b: &[&[Vec3]],
    weight: Option<&[f64]>,
    symmetric: bool,
) -> DMatrix<f64> {
    let (ka, kb) = (a.len(), b.len());
    let n = a.first().map_or(0, |v| v.len());
    let chunks = n.div_ceil(CHUNK);
    let partials: Vec<DMatrix<f64>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let range = c * CHUNK..((c + 1) * CHUNK).min(n);
            let mut g = DMatrix::zeros(ka, kb);
            let mut weighted = Vec::with_capacity(range.len());
            for i in 0..ka {
                let mut ai = &a[i][range.clone()];
                if let Some(w) = weight {
                    weighted.clear();
                    weighted.extend(ai.iter().zip(&w[range.clone()]).map(|(x, w)| x * *w));
                    ai = &weighted;
                }
                let first = if symmetric { i } else { 0 };
                for j in first..kb {
                    g[(i, j)] = dot(ai, &b[j][range.clone()]);
                }
            }
            g
        })
        .collect();
    let mut g = partials
        .into_iter()
        .fold(DMatrix::zeros(ka, kb), |acc, p| acc + p);
    if symmetric {
        for i in 0..ka.min(kb) {
            for j in 0..i {
                g[(i, j)] = g[(j, i)];
            }
        }
    }
    g
}

/// `Σ a·b` with four independent accumulators, so the loop is not bound by the latency of one
/// running sum; the order is fixed, so the result is too.
fn dot(a: &[Vec3], b: &[Vec3]) -> f64 {
    let mut lanes = [Vec3::zeros(); 4];
    let (head_a, head_b) = (a.chunks_exact(4), b.chunks_exact(4));
    let (tail_a, tail_b) = (head_a.remainder(), head_b.remainder());
    for (x, y) in head_a.zip(head_b) {
        for k in 0..4 {
            lanes[k] += x[k].component_mul(&y[k]);
        }
    }
    let mut tail = Vec3::zeros();
    for (x, y) in tail_a.iter().zip(tail_b) {
        tail += x.component_mul(y);
    }
    ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail).sum()
}

/// `S·C` for a block given as several pieces (their columns concatenated).
pub(super) fn combine(pieces: &[&Block], c: &DMatrix<f64>) -> Block {
    let s: Vec<&[Vec3]> = pieces
        .iter()
        .flat_map(|b| b.iter().map(Vec::as_slice))
        .collect();
    combine_slices(&s, c)
}

/// `out_j = Σ_i C[i][j]·s_i`, parallel over fixed vertex chunks.
pub(super) fn combine_slices(s: &[&[Vec3]], c: &DMatrix<f64>) -> Block {
    assert_eq!(s.len(), c.nrows());
    let n = s.first().map_or(0, |v| v.len());
    let k = c.ncols();
    let mut out: Block = vec![vec![Vec3::zeros(); n]; k];
    let chunks = n.div_ceil(CHUNK);
    let mut per_chunk: Vec<Vec<&mut [Vec3]>> = (0..chunks).map(|_| Vec::with_capacity(k)).collect();
    for column in out.iter_mut() {
        for (chunk, slice) in column.chunks_mut(CHUNK).enumerate() {
            per_chunk[chunk].push(slice);
        }
    }
    per_chunk
        .into_par_iter()
        .enumerate()
        .for_each(|(chunk, mut outputs)| {
            let start = chunk * CHUNK;
            for (j, o) in outputs.iter_mut().enumerate() {
                for (i, si) in s.iter().enumerate() {
                    let w = c[(i, j)];
                    if w == 0.0 {
                        continue;
                    }
                    let si = &si[start..start + o.len()];
                    o.iter_mut().zip(si).for_each(|(o, s)| *o += s * w);
                }
            }
        });
    out
}
