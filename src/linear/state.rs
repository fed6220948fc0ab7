//! What a linear solver carries from one Newton iterate to the next, in a form a checkpoint can
//! store (see [`crate::checkpoint`]), so that a resumed run solves exactly as one never stopped.
//!
//! A multigrid hierarchy is several times the size of A and full of derived arrays, but it is a
//! pure function of its aggregates (found from the A it was built on) and the A of its last
//! build or refresh (a refresh gives the bits of a fresh build on the kept aggregates: see
//! [`super::amg`]). The solver's hierarchy does not keep that A (its finest level smooths with
//! the current one), so what is stored is the aggregates and the numbers a rebuild would compute
//! from that A: the finest level's D⁻¹, Chebyshev interval and prolongator, and the second
//! level's matrix, from which the levels below follow (a hierarchy of one level keeps its A, and
//! that is stored instead). With the mask of constrained DOFs at the build and the reuse rule's
//! counters, the hierarchy is rebuilt from them on resume, bit for bit.

use serde::{Deserialize, Serialize};

use super::sparse::{BlockCsr, BlockPattern};
use crate::math::{Mat3, Vec3};

/// A linear solver's state between iterates.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum SolverState {
    /// Nothing that shapes later solves (matrix-free strategies, or before the first solve).
    #[default]
    Fresh,
    /// The multigrid strategy's hierarchy and reuse counters.
    Multigrid(MultigridState),
    /// State that is not stored (the sparse Cholesky's factor): a resumed run starts it afresh,
    /// so its later solves differ within the solver tolerances, not in bits.
    NotStored,
}

/// A block pattern as stored: row starts and columns.
pub type StoredPattern = (Vec<u32>, Vec<u32>);

/// See [`SolverState::Multigrid`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MultigridState {
    /// The system pattern generation the assembled matrix was made for.
    pub generation: Option<u64>,
    /// The pattern of A (row starts, columns), when assembled.
    pub pattern: Option<StoredPattern>,
    /// The hierarchy, when built.
    pub hierarchy: Option<Box<HierarchyState>>,
    /// CG iterations per decade of the first solve after the last build or refresh.
    pub baseline_rate: Option<f64>,
    /// CG iterations per decade of the last solve.
    pub last_rate: f64,
    /// Whether the last solve ran into the CG cap.
    pub last_capped: bool,
    /// Builds, refreshes and pattern changes so far.
    pub counts: [usize; 3],
    /// Whether A went from f32 to f64 after a CG breakdown (see
    /// [`super::multigrid::Multigrid`]'s solve).
    pub f64_fallback: bool,
}

/// What a multigrid hierarchy was made from.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HierarchyState {
    /// The 0/1 mask of free DOFs at the build.
    pub free: Vec<[f64; 3]>,
    /// Each level's aggregates, finest first: the aggregate of each row (`u32::MAX`: none) and
    /// the number of aggregates.
    pub aggregates: Vec<(Vec<u32>, usize)>,
    /// A's blocks at the last build or refresh (column-major 3×3), for a hierarchy of one level
    /// (which keeps them); empty otherwise.
    pub values: Vec<[f64; 9]>,
    /// A hierarchy of several levels: the finest level's D⁻¹ blocks (column-major 3×3), its
    /// Chebyshev interval, its prolongator blocks (18 numbers each) and the second level's
    /// matrix blocks (36 numbers each), all as of the last build or refresh (see
    /// [`crate::linear::amg::FineNumbers`]).
    pub dinv: Vec<[f64; 9]>,
    /// See [`HierarchyState::dinv`].
    pub bounds: (f64, f64),
    /// See [`HierarchyState::dinv`].
    pub prolongator: Vec<f64>,
    /// See [`HierarchyState::dinv`].
    pub second: Vec<f64>,
    /// Whether the coarse matrices were stored in f32 (`second` then holds f32 values).
    pub coarse_f32: bool,
}

/// Blocks as plain arrays (column-major), bit for bit.
pub(crate) fn blocks_out(blocks: &[Mat3]) -> Vec<[f64; 9]> {
    blocks
        .iter()
        .map(|m| std::array::from_fn(|k| m.as_slice()[k]))
        .collect()
}

/// See [`blocks_out`].
pub(crate) fn blocks_in(blocks: &[[f64; 9]]) -> Vec<Mat3> {
    blocks.iter().map(|b| Mat3::from_column_slice(b)).collect()
}

/// Vectors as plain arrays.
pub(crate) fn vectors_out(v: &[Vec3]) -> Vec<[f64; 3]> {
    v.iter().map(|v| [v.x, v.y, v.z]).collect()
}

/// See [`vectors_out`].
pub(crate) fn vectors_in(v: &[[f64; 3]]) -> Vec<Vec3> {
    v.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect()
}

/// A matrix from a checked pattern ([`pattern_in`]) and stored blocks, checked for consistency.
pub(crate) fn matrix_in(pattern: BlockPattern, blocks: &[[f64; 9]]) -> Result<BlockCsr, String> {
    if blocks.len() != pattern.cols.len() {
        return Err(format!(
            "the stored solver matrix does not fit a system of {} vertices",
            pattern.rows()
        ));
    }
    Ok(BlockCsr::from_blocks(pattern, blocks_in(blocks)))
}

/// A stored pattern, checked for consistency.
pub(crate) fn pattern_in(pattern: &StoredPattern, rows: usize) -> Result<BlockPattern, String> {
    let pattern = BlockPattern {
        row_start: pattern.0.clone(),
        cols: pattern.1.clone(),
    };
    if pattern.row_start.len() != rows + 1
        || pattern.row_start.last().copied() != Some(pattern.cols.len() as u32)
        || pattern.row_start.windows(2).any(|w| w[0] > w[1])
        || pattern.cols.iter().any(|&c| c as usize >= rows)
    {
        return Err(format!(
            "the stored solver matrix does not fit a system of {rows} vertices"
        ));
    }
    Ok(pattern)
}
