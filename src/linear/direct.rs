//! Sparse Cholesky of the assembled system (cargo feature `direct`): faer's supernodal `LLᵀ` of
//! the constrained `A = k·K + m·M`, applied as CG's preconditioner `z = (LLᵀ)⁻¹·r`.
//!
//! Why a preconditioner and not a solver: with a fresh factor CG stops after one iteration (the
//! preconditioned residual is the exact answer), and with a factor kept from an earlier iterate
//! CG corrects what changed since. So the caller may keep a factor across Newton iterations and
//! frames and refactor only when CG slows down, and a solve never depends on the factor being
//! current.
//!
//! Work is split as faer splits it, prepare once and apply many:
//! - [`Cholesky::factorize`] runs the symbolic analysis on its first call only (faer's AMD
//!   fill-reducing ordering, elimination tree, supernodes: the pattern of A is fixed for a
//!   simulation), then the numeric factorization into preallocated values and scratch;
//! - [`Preconditioner::apply`] does the two triangular solves in a preallocated buffer: no
//!   allocation per CG iteration.
//!
//! A is fed to faer as the upper triangle of its scalar (3 DOFs per vertex) matrix, by columns,
//! read straight from the block rows of [`BlockCsr`] (symmetric, so block row J holds column J).
//!
//! **Failure.** A numeric factorization fails on a non-positive pivot: A is not positive definite
//! (the exact tangent of `definiteness = "none"`, or `adaptive` trying it). That is data, not a
//! bug: [`Cholesky::factorize`] returns the error and the preconditioner turns into block Jacobi
//! on A's diagonal blocks until the next factorization succeeds, so the caller's CG still runs
//! (and its breakdown on negative curvature is what `adaptive` listens for).
//!
//! **Determinism.** faer's supernodal factorization visits supernodes in a fixed order, but with
//! `Par::rayon` its dense kernels split work by thread count: a 40×10×10 cantilever's frames
//! came out with different bits on 1 and 2 threads (and different from `Par::Seq`), and at
//! 41,472 tets the parallel factorization was not faster on this 2-core machine (0.92–1.23 s
//! against 0.67–0.95 s). So faer runs with `Par::Seq` (and is built without its `rayon`
//! feature): the same bits for any thread count.

use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, Spec};

use crate::linear::cg::{BlockJacobi, Preconditioner};
use crate::linear::sparse::BlockCsr;
use crate::math::{Mat3, Vec3};

/// What the factorizations cost and found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CholeskyInfo {
    /// Scalar unknowns (3 per vertex, constrained ones included).
    pub dofs: usize,
    /// Stored entries of A's upper triangle.
    pub a_nonzeros: usize,
    /// Entries of L: the lower trapezoids of its supernodes (zeros that supernode amalgamation
    /// stores explicitly included).
    pub l_nonzeros: usize,
    /// Whether faer chose its supernodal (rather than simplicial) factorization.
    pub supernodal: bool,
    /// Seconds of the symbolic analysis (ordering, elimination tree, supernodes).
    pub symbolic_seconds: f64,
    /// Numeric factorizations attempted.
    pub factorizations: usize,
    /// Numeric factorizations that failed (A not positive definite).
    pub failures: usize,
    /// Seconds of numeric factorization, summed.
    pub factor_seconds: f64,
}

/// Why a factorization failed; the preconditioner is block Jacobi until the next success.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CholeskyError {
    /// A pivot was not positive: A is not positive definite.
    #[error("sparse Cholesky: A is not positive definite (pivot {pivot} of {dofs} ≤ 0)")]
    NotPositiveDefinite {
        /// The failing pivot in faer's (permuted) elimination order.
        pivot: usize,
        /// Scalar unknowns.
        dofs: usize,
    },
    /// The symbolic analysis or its workspace failed (out of memory, index overflow).
    #[error("sparse Cholesky analysis failed: {0}")]
    Analysis(String),
}

/// The symbolic factorization and every buffer the numeric one and the solves reuse.
struct Analysis {
    symbolic: SymbolicCholesky<usize>,
    /// Upper triangle of the scalar A by columns: pattern fixed, values refilled.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// Factor values (faer's supernodal layout).
    l_values: Vec<f64>,
    factor_scratch: MemBuffer,
    solve_scratch: MemBuffer,
    /// The right-hand side, solved in place.
    rhs: Vec<f64>,
}

/// Which operator [`Preconditioner::apply`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Active {
    /// Nothing factored yet: identity.
    None,
    /// The factor.
    Factor,
    /// Block Jacobi, after a failed factorization.
    Fallback,
}

/// The sparse Cholesky preconditioner (see the module docs).
pub struct Cholesky {
    analysis: Option<Result<Analysis, CholeskyError>>,
    fallback: BlockJacobi,
    diagonal: Vec<Mat3>,
    active: Active,
    info: CholeskyInfo,
}

impl Default for Cholesky {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for Cholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cholesky")
            .field("active", &self.active)
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

/// Sequential: see the module docs on determinism.
const PAR: Par = Par::Seq;

impl Cholesky {
    /// Empty: the first [`Cholesky::factorize`] analyses the pattern.
    pub fn new() -> Self {
        Cholesky {
            analysis: None,
            fallback: BlockJacobi::default(),
            diagonal: Vec::new(),
            active: Active::None,
            info: CholeskyInfo::default(),
        }
    }

    /// Costs and counts so far.
    pub fn info(&self) -> &CholeskyInfo {
        &self.info
    }

    /// Whether [`Preconditioner::apply`] uses a factor (false before the first factorization
    /// and after a failed one).
    pub fn is_factored(&self) -> bool {
        self.active == Active::Factor
    }

    /// Forget the symbolic analysis: the next [`Cholesky::factorize`] analyses the pattern it is
    /// given anew (call it when the pattern of A changed; the counts in [`CholeskyInfo`] stay).
    pub fn forget_pattern(&mut self) {
        self.analysis = None;
        self.active = Active::None;
    }

    /// Factor `a` (symmetric, SPD for success; its pattern must be the one analysed first, see
    /// [`Cholesky::forget_pattern`]). On failure the preconditioner becomes block Jacobi on `a`'s
    /// diagonal blocks.
    pub fn factorize(&mut self, a: &BlockCsr) -> Result<(), CholeskyError> {
        let analysis = self.analysis.get_or_insert_with(|| {
            let started = Instant::now();
            let analysis = analyse(a);
            self.info.symbolic_seconds = started.elapsed().as_secs_f64();
            if let Ok(an) = &analysis {
                self.info.dofs = an.rhs.len();
                self.info.a_nonzeros = an.values.len();
                (self.info.l_nonzeros, self.info.supernodal) = factor_nonzeros(&an.symbolic);
            }
            analysis
        });
        let result = match analysis {
            Ok(an) => {
                let started = Instant::now();
                self.info.factorizations += 1;
                an.fill(a);
                let result = an.factor();
                self.info.factor_seconds += started.elapsed().as_secs_f64();
                result
            }
            Err(e) => Err(e.clone()),
        };
        if result.is_ok() {
            self.active = Active::Factor;
        } else {
            self.info.failures += 1;
            self.diagonal.clear();
            self.diagonal.extend((0..a.rows()).map(|i| a.diagonal(i)));
            self.fallback.set_from_blocks(&self.diagonal);
            self.active = Active::Fallback;
        }
        result
    }
}

impl Preconditioner for Cholesky {
    fn apply(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        match (self.active, &mut self.analysis) {
            (Active::Factor, Some(Ok(an))) => {
                for (chunk, v) in an.rhs.chunks_exact_mut(3).zip(r) {
                    chunk.copy_from_slice(v.as_slice());
                }
                let n = an.rhs.len();
                LltRef::new(&an.symbolic, &an.l_values).solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(&mut an.rhs, n, 1),
                    PAR,
                    MemStack::new(&mut an.solve_scratch),
                );
                for (v, chunk) in z.iter_mut().zip(an.rhs.chunks_exact(3)) {
                    *v = Vec3::new(chunk[0], chunk[1], chunk[2]);
                }
            }
            (Active::Fallback, _) => self.fallback.apply(r, z),
            _ => z.copy_from_slice(r),
        }
    }
}

/// Symbolic analysis of `a`'s pattern and the buffers for the numeric phase.
fn analyse(a: &BlockCsr) -> Result<Analysis, CholeskyError> {
    let (col_ptr, row_idx) = upper_pattern(a);
    let dofs = 3 * a.rows();
    let pattern = SymbolicSparseColMatRef::new_checked(dofs, dofs, &col_ptr, None, &row_idx);
    let symbolic = factorize_symbolic_cholesky(
        pattern,
        Side::Upper,
        SymmetricOrdering::Amd,
        CholeskySymbolicParams {
            // faer's default flop ratio picks the supernodal factorization for any 3D mesh
            // past a few hundred vertices and the simplicial one below, where it is faster.
            supernodal_flop_ratio_threshold: SupernodalThreshold::AUTO,
            ..Default::default()
        },
    )
    .map_err(|e| CholeskyError::Analysis(format!("{e:?}")))?;
    let buffer = |req| {
        MemBuffer::try_new(req).map_err(|e| CholeskyError::Analysis(format!("scratch: {e:?}")))
    };
    let factor_scratch =
        buffer(symbolic.factorize_numeric_llt_scratch::<f64>(PAR, Spec::default()))?;
    let solve_scratch = buffer(symbolic.solve_in_place_scratch::<f64>(1, PAR))?;
    let l_values = vec![0.0; symbolic.len_val()];
    let values = vec![0.0; row_idx.len()];
    Ok(Analysis {
        symbolic,
        col_ptr,
        row_idx,
        values,
        l_values,
        factor_scratch,
        solve_scratch,
        rhs: vec![0.0; dofs],
    })
}

/// The scalar upper triangle's pattern by columns: column 3J + r holds rows 3I + c for the blocks
/// (J, I) of block row J with I < J, and c ≤ r of the diagonal block; sorted within a column.
fn upper_pattern(a: &BlockCsr) -> (Vec<usize>, Vec<usize>) {
    let p = &a.pattern;
    let mut col_ptr = Vec::with_capacity(3 * p.rows() + 1);
    let mut row_idx = Vec::new();
    col_ptr.push(0);
    for j in 0..p.rows() {
        for r in 0..3 {
            for k in p.row(j) {
                let i = p.cols[k] as usize;
                if i > j {
                    break;
                }
                let last = if i == j { r } else { 2 };
                row_idx.extend((0..=last).map(|c| 3 * i + c));
            }
            col_ptr.push(row_idx.len());
        }
    }
    (col_ptr, row_idx)
}

/// Entries of L (supernode lower trapezoids) and whether the factorization is supernodal.
fn factor_nonzeros(symbolic: &SymbolicCholesky<usize>) -> (usize, bool) {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(s) => {
            let (begin, end, val) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
            let nonzeros = (0..s.n_supernodes())
                .map(|k| {
                    let cols = end[k] - begin[k];
                    val[k + 1] - val[k] - cols * (cols - 1) / 2
                })
                .sum();
            (nonzeros, true)
        }
        SymbolicCholeskyRaw::Simplicial(s) => (s.len_val(), false),
    }
}

impl Analysis {
    /// Copy `a`'s upper triangle into the CSC values, in [`upper_pattern`]'s order.
    fn fill(&mut self, a: &BlockCsr) {
        let p = &a.pattern;
        let mut out = 0;
        for j in 0..p.rows() {
            for r in 0..3 {
                for k in p.row(j) {
                    let i = p.cols[k] as usize;
                    if i > j {
                        break;
                    }
                    let last = if i == j { r } else { 2 };
                    // Block (J, I) row r is column r of block (I, J) = A[3I + c, 3J + r].
                    let block = a.block(k);
                    for c in 0..=last {
                        self.values[out] = block[(r, c)];
                        out += 1;
                    }
                }
            }
        }
        debug_assert_eq!(out, self.values.len());
    }

    /// Numeric factorization of the filled values.
    fn factor(&mut self) -> Result<(), CholeskyError> {
        let dofs = self.rhs.len();
        let pattern =
            SymbolicSparseColMatRef::new_checked(dofs, dofs, &self.col_ptr, None, &self.row_idx);
        self.symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                SparseColMatRef::new(pattern, &self.values),
                Side::Upper,
                LltRegularization::default(),
                PAR,
                MemStack::new(&mut self.factor_scratch),
                Spec::default(),
            )
            .map(|_| ())
            .map_err(|e| match e {
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                    CholeskyError::NotPositiveDefinite { pivot: index, dofs }
                }
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::sparse::BlockPattern;
    use crate::mesh::generate::box_mesh;

    /// A symmetric, diagonally dominant (so SPD) block matrix on a small beam's pattern; `shift`
    /// is added to the diagonal (negative makes it indefinite).
    fn beam_matrix(cells: usize, shift: f64) -> BlockCsr {
        let mesh = box_mesh(
            Vec3::zeros(),
            Vec3::new(3.0, 1.0, 1.0),
            [3 * cells, cells, cells],
        );
        let mut a = BlockCsr::zeros(BlockPattern::from_tets(mesh.positions.len(), &mesh.tets));
        let mut seed = 11u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for i in 0..a.rows() {
            for k in a.pattern.row(i) {
                let j = a.pattern.cols[k] as usize;
                if j > i {
                    let m = Mat3::from_fn(|_, _| next());
                    a.blocks_mut().set(k, &m);
                    let kt = a.pattern.find(j, i).unwrap();
                    a.blocks_mut().set(kt, &m.transpose());
                }
            }
        }
        for i in 0..a.rows() {
            let k = a.pattern.find(i, i).unwrap();
            let m = Mat3::from_fn(|_, _| next());
            a.blocks_mut()
                .set(k, &(m + m.transpose() + Mat3::identity() * (60.0 + shift)));
        }
        a
    }

    fn sample(n: usize) -> Vec<Vec3> {
        (0..n)
            .map(|i| Vec3::new((i as f64).sin(), 1.0, (0.3 * i as f64).cos()))
            .collect()
    }

    #[test]
    fn factor_solves_the_assembled_system() {
        let a = beam_matrix(3, 0.0);
        let mut chol = Cholesky::new();
        chol.factorize(&a).unwrap();
        assert!(chol.is_factored());
        let b = sample(a.rows());
        let mut x = vec![Vec3::zeros(); a.rows()];
        chol.apply(&b, &mut x);
        let mut ax = vec![Vec3::zeros(); a.rows()];
        a.multiply(&x, &mut ax);
        let error = ax
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        assert!(error < 1e-12, "‖Ax − b‖∞ = {error}");
        let info = chol.info();
        assert_eq!(info.dofs, 3 * a.rows());
        assert_eq!(info.factorizations, 1);
        assert!(info.l_nonzeros >= info.a_nonzeros, "{info:?}");
    }

    #[test]
    fn refactoring_follows_new_values_on_the_same_pattern() {
        let mut a = beam_matrix(2, 0.0);
        let mut chol = Cholesky::new();
        chol.factorize(&a).unwrap();
        a.for_each_row_mut(|_, _, mut row| {
            for k in 0..row.len() {
                row.set(k, &(row.get(k) * 3.0));
            }
        });
        chol.factorize(&a).unwrap();
        let b = sample(a.rows());
        let mut x = vec![Vec3::zeros(); a.rows()];
        chol.apply(&b, &mut x);
        let mut ax = vec![Vec3::zeros(); a.rows()];
        a.multiply(&x, &mut ax);
        let error = ax
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        assert!(error < 1e-12, "‖Ax − b‖∞ = {error}");
        assert_eq!(chol.info().factorizations, 2);
    }

    #[test]
    fn indefinite_matrix_falls_back_to_block_jacobi() {
        let a = beam_matrix(2, -200.0);
        let mut chol = Cholesky::new();
        let err = chol.factorize(&a).unwrap_err();
        assert!(
            matches!(err, CholeskyError::NotPositiveDefinite { .. }),
            "{err}"
        );
        assert!(!chol.is_factored());
        assert_eq!(chol.info().failures, 1);
        let b = sample(a.rows());
        let mut z = vec![Vec3::zeros(); a.rows()];
        chol.apply(&b, &mut z);
        for (i, (z, b)) in z.iter().zip(&b).enumerate() {
            let expected = a.diagonal(i).try_inverse().unwrap() * b;
            assert!((z - expected).norm() < 1e-12, "vertex {i}");
        }
        // A positive definite matrix on the same pattern factors again.
        chol.factorize(&beam_matrix(2, 0.0)).unwrap();
        assert!(chol.is_factored());
    }

    #[test]
    fn same_factor_bits_on_one_and_two_threads() {
        let a = beam_matrix(4, 0.0);
        let b = sample(a.rows());
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let mut chol = Cholesky::new();
                    chol.factorize(&a).unwrap();
                    let mut x = vec![Vec3::zeros(); a.rows()];
                    chol.apply(&b, &mut x);
                    x
                })
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn upper_pattern_is_sorted_and_upper() {
        let a = beam_matrix(1, 0.0);
        let (col_ptr, row_idx) = upper_pattern(&a);
        for c in 0..3 * a.rows() {
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            assert!(rows.windows(2).all(|w| w[0] < w[1]), "column {c}");
            assert_eq!(rows.last(), Some(&c), "column {c} ends at its diagonal");
        }
    }
}
