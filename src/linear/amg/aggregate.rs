//! Coarsening: strength of connection between block nodes, greedy aggregation (Vaněk, Mandel and
//! Brezina 1996) and the tentative prolongator fitted to the near-nullspace by a QR per aggregate.
//! All sequential and deterministic (fixed node order).

use nalgebra::DMatrix;

use super::bsr::{Block, BlockRows, Bsr};

/// Coarse DOFs per aggregate: the six rigid-body modes.
pub(crate) const MODES: usize = 6;

/// Marks a node that belongs to no aggregate.
pub(crate) const NONE: u32 = u32::MAX;

/// Nodes grouped into aggregates.
#[derive(Clone, Debug)]
pub(crate) struct Aggregates {
    /// Aggregate of each node, or [`NONE`].
    pub of: Vec<u32>,
    /// Number of aggregates.
    pub count: usize,
}

/// The strong neighbours of every node: j ≠ i with `‖A_ij‖_F > θ·√(‖A_ii‖_F·‖A_jj‖_F)` and
/// `A_ij ≠ 0` (a symmetric test, so the graph is undirected).
pub(crate) fn strong_neighbours<const B: usize>(
    a: &impl BlockRows<B, B>,
    theta: f64,
) -> Vec<Vec<u32>> {
    let n = a.rows();
    let diagonal: Vec<f64> = (0..n)
        .map(|i| a.find(i, i).map_or(0.0, |k| a.block(k).norm()))
        .collect();
    (0..n)
        .map(|i| {
            a.row(i)
                .filter_map(|k| {
                    let j = a.pattern().cols[k] as usize;
                    let norm = a.block(k).norm();
                    let strong =
                        j != i && norm > 0.0 && norm > theta * (diagonal[i] * diagonal[j]).sqrt();
                    strong.then_some(j as u32)
                })
                .collect()
        })
        .collect()
}

/// Greedy aggregation over the strength graph. Nodes with `active[i] = false` (fully constrained,
/// or carrying no near-nullspace) and nodes with no strong neighbour stay out of every aggregate:
/// the smoother alone handles them.
///
/// 1. Each node whose strong neighbours are all free starts an aggregate with them (roots).
/// 2. Each node left joins the aggregate it is most strongly connected to (by neighbour count).
/// 3. Any node still left starts an aggregate with its unaggregated strong neighbours.
pub(crate) fn aggregate(strong: &[Vec<u32>], active: &[bool]) -> Aggregates {
    let n = strong.len();
    let mut of = vec![NONE; n];
    let mut count = 0u32;
    let eligible = |i: usize| active[i] && !strong[i].is_empty();
    for i in 0..n {
        if !eligible(i) || of[i] != NONE {
            continue;
        }
        if strong[i].iter().all(|&j| of[j as usize] == NONE) {
            of[i] = count;
            for &j in &strong[i] {
                if active[j as usize] {
                    of[j as usize] = count;
                }
            }
            count += 1;
        }
    }
    // Phase 2 reads the phase-1 assignment only, so the order of joining does not cascade.
    let phase1 = of.clone();
    for i in 0..n {
        if !eligible(i) || of[i] != NONE {
            continue;
        }
        // The aggregate with the most strong neighbours of i; ties go to the lowest number.
        let mut best: Option<(usize, u32)> = None;
        for &j in &strong[i] {
            let g = phase1[j as usize];
            if g == NONE {
                continue;
            }
            let links = strong[i]
                .iter()
                .filter(|&&k| phase1[k as usize] == g)
                .count();
            if best.is_none_or(|(l, b)| links > l || (links == l && g < b)) {
                best = Some((links, g));
            }
        }
        if let Some((_, g)) = best {
            of[i] = g;
        }
    }
    for i in 0..n {
        if !eligible(i) || of[i] != NONE {
            continue;
        }
        of[i] = count;
        for &j in &strong[i] {
            if active[j as usize] && of[j as usize] == NONE {
                of[j as usize] = count;
            }
        }
        count += 1;
    }
    Aggregates {
        of,
        count: count as usize,
    }
}

/// The tentative prolongator T (one B×6 block per aggregated node, in column `aggregate`) and the
/// coarse near-nullspace: per aggregate, the QR `N_agg = Q·R` of its stacked near-nullspace rows
/// gives T's blocks (Q's rows) and the coarse node's 6×6 near-nullspace block (R), so that
/// `T·N_c = N` on aggregated nodes and Tᵀ·T = I on the kept columns. Columns that are linearly
/// dependent within an aggregate (two nodes cannot carry the rotation about their axis) are
/// dropped: zero in Q and in R. Returns T, the coarse near-nullspace and, per coarse DOF,
/// whether its column was kept.
pub(crate) fn tentative<const B: usize>(
    aggregates: &Aggregates,
    nullspace: &[Block<B, MODES>],
) -> (Bsr<B, MODES>, Vec<Block<MODES, MODES>>, Vec<[bool; MODES]>) {
    let n = aggregates.of.len();
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); aggregates.count];
    for (i, &g) in aggregates.of.iter().enumerate() {
        if g != NONE {
            members[g as usize].push(i);
        }
    }
    let rows: Vec<Vec<u32>> = aggregates
        .of
        .iter()
        .map(|&g| if g == NONE { vec![] } else { vec![g] })
        .collect();
    let mut t = Bsr::<B, MODES>::from_rows(&rows, aggregates.count);
    let mut coarse = vec![Block::<MODES, MODES>::zeros(); aggregates.count];
    let mut kept = vec![[false; MODES]; aggregates.count];
    for (g, nodes) in members.iter().enumerate() {
        let mut m = DMatrix::<f64>::zeros(B * nodes.len(), MODES);
        for (a, &i) in nodes.iter().enumerate() {
            m.view_mut((B * a, 0), (B, MODES)).copy_from(&nullspace[i]);
        }
        let (q, r, k) = gram_schmidt(m);
        for (a, &i) in nodes.iter().enumerate() {
            let at = t.row(i).start;
            t.values[at] = q.fixed_view::<B, MODES>(B * a, 0).into_owned();
        }
        coarse[g] = r;
        kept[g] = k;
    }
    debug_assert_eq!(t.rows(), n);
    (t, coarse, kept)
}

/// Thin QR `m = Q·R` by classical Gram-Schmidt with one re-orthogonalisation pass (CGS2, as
/// accurate as Householder for so few columns). A column whose remainder after projection is
/// below 1e-10 of its norm is dependent on the previous ones: its Q column and R row are zero.
fn gram_schmidt(mut q: DMatrix<f64>) -> (DMatrix<f64>, Block<MODES, MODES>, [bool; MODES]) {
    let mut r = Block::<MODES, MODES>::zeros();
    let mut kept = [false; MODES];
    for c in 0..MODES {
        let original = q.column(c).norm();
        for _pass in 0..2 {
            for p in 0..c {
                if !kept[p] {
                    continue;
                }
                let proj = q.column(p).dot(&q.column(c));
                r[(p, c)] += proj;
                let qp = q.column(p).clone_owned();
                q.column_mut(c).axpy(-proj, &qp, 1.0);
            }
        }
        let norm = q.column(c).norm();
        if original > 0.0 && norm > 1e-10 * original {
            q.column_mut(c).scale_mut(1.0 / norm);
            r[(c, c)] = norm;
            kept[c] = true;
        } else {
            q.column_mut(c).fill(0.0);
        }
    }
    (q, r, kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qr_reproduces_the_columns_and_drops_dependent_ones() {
        // Two 3-DOF nodes on the x axis: the rotation about x vanishes on both (column 3).
        let mut m = DMatrix::<f64>::zeros(6, MODES);
        for (a, x) in [(0usize, 1.0f64), (1, 2.0)] {
            for d in 0..3 {
                m[(3 * a + d, d)] = 1.0;
            }
            // Rotations e_k × (x, 0, 0).
            m[(3 * a + 2, 4)] = -x;
            m[(3 * a + 1, 5)] = x;
        }
        let (q, r, kept) = gram_schmidt(m.clone());
        assert_eq!(kept, [true, true, true, false, true, true]);
        let r = DMatrix::from_fn(MODES, MODES, |i, j| r[(i, j)]);
        assert!((&q * r - &m).norm() < 1e-12);
        let qtq = q.transpose() * &q;
        for i in 0..MODES {
            for j in 0..MODES {
                let expected = if i == j && kept[i] { 1.0 } else { 0.0 };
                assert!((qtq[(i, j)] - expected).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn aggregation_covers_a_path_graph() {
        // 0 - 1 - 2 - ... - 9, node 5 inactive.
        let strong: Vec<Vec<u32>> = (0..10u32)
            .map(|i| {
                let mut v = vec![];
                if i > 0 {
                    v.push(i - 1);
                }
                if i < 9 {
                    v.push(i + 1);
                }
                v
            })
            .collect();
        let mut active = vec![true; 10];
        active[5] = false;
        let agg = aggregate(&strong, &active);
        assert_eq!(agg.of[5], NONE);
        assert!(agg.of.iter().enumerate().all(|(i, &g)| i == 5 || g != NONE));
        assert!(agg.count >= 3 && agg.count <= 4, "{:?}", agg.of);
    }
}
