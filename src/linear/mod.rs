//! Solving Newton's linear systems `A·dx = rhs`, knowing nothing of FEM.
//!
//! A is whatever a [`System`] says it is: its product with a vector, its 3×3 diagonal blocks and
//! its assembly into a block-sparse matrix over a pattern that may change between calls (contact
//! adds and removes blocks). A [`LinearSolver`] is one strategy for solving with it, prepared
//! once per Newton iterate and then applied:
//!
//! | scene value | strategy | file |
//! | --- | --- | --- |
//! | `none`, `jacobi`, `block-jacobi` | matrix-free CG product, diagonal preconditioners | [`matrix_free`] |
//! | `amg` (default) | assembled A, smoothed-aggregation multigrid V-cycle | [`multigrid`] |
//! | `cholesky` (feature `direct`) | assembled A, sparse Cholesky kept across iterates | `cholesky` |
//!
//! A new preconditioner is one new file implementing [`LinearSolver`] plus one
//! [`PreconditionerKind`] value (and its scene name). The building blocks live beside them:
//! [`cg`] (preconditioned conjugate gradient on any [`cg::LinearOperator`]), [`sparse`] (block
//! matrices and patterns), [`amg`] (the multigrid hierarchy) and `direct` (faer's Cholesky).
//! [`lobpcg`] finds the lowest eigenpairs of such systems (the vibration modes, [`crate::modes`]).
//!
//! **Changing patterns.** Every assembled strategy compares [`SystemPattern::generation`] with
//! the one it prepared for: a new generation rebuilds the matrix storage and what depends on the
//! pattern (AMG aggregates, Cholesky's symbolic analysis); the same generation reuses them.

pub mod amg;
pub mod cg;
#[cfg(feature = "direct")]
pub mod cholesky;
#[cfg(feature = "direct")]
pub mod direct;
pub mod lobpcg;
pub mod matrix_free;
pub mod multigrid;
pub mod sparse;
pub mod state;

use crate::math::{Mat3, Vec3};
use cg::{CgError, CgInfo, CgParams};
use sparse::{BlockCsr, BlockPattern};

/// The pattern a [`System`] assembles into, and a number that changes whenever it does.
#[derive(Clone, Copy, Debug)]
pub struct SystemPattern<'a> {
    /// The block pattern (symmetric, diagonal included).
    pub pattern: &'a BlockPattern,
    /// Equal generations mean equal patterns.
    pub generation: u64,
}

/// A symmetric system matrix A on vertex vectors (3 DOFs per vertex), as Newton's terms make it.
/// Constrained DOFs are the solver's business (the 0/1 `free` mask), not the system's.
pub trait System {
    /// Number of vertices.
    fn len(&self) -> usize;
    /// True when the system has no vertices.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// `out = A·p` (matrix-free).
    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]);
    /// The 3×3 diagonal blocks of A, one per vertex (overwritten).
    fn diagonal_blocks(&mut self, out: &mut [Mat3]);
    /// The pattern of A's blocks.
    fn pattern(&self) -> SystemPattern<'_>;
    /// Write A into `a`, whose pattern is [`System::pattern`]'s (overwritten).
    fn assemble(&mut self, a: &mut BlockCsr);
    /// Rest positions of the vertices (multigrid builds its rigid-body modes from them).
    fn rest_positions(&self) -> &[Vec3];
    /// False while A holds an exact, possibly indefinite tangent (`adaptive` trying it): a
    /// preconditioner must not be built from such an A (see [`multigrid`]).
    fn is_projected(&self) -> bool;
    /// Write the projected A into `a` like [`System::assemble`], whatever tangent the system
    /// holds now, and leave the system as it was: what a preconditioner is built from while
    /// [`System::is_projected`] is false. Default: [`System::assemble`].
    fn assemble_projected(&mut self, a: &mut BlockCsr) {
        self.assemble(a);
    }
    /// Whether a preconditioner that grew stale while A holds the exact tangent should be
    /// refreshed from [`System::assemble_projected`] (an extra assembly) rather than wait for a
    /// projected A: true where the exact tangent is the rule, not a short trial. Default false.
    fn refresh_while_exact(&self) -> bool {
        false
    }
    /// Whether A now holds couplings far stiffer than the rest (contact barriers, up to 1e7
    /// times the elastic blocks where a gap closes), which an f32 A rounds away: the smallest
    /// eigenvalues of A scaled by its diagonal move by about 6e-8 times that ratio. An
    /// assembled strategy then stores A in f64 (see [`sparse::Precision`]). Default false.
    fn needs_f64(&self) -> bool {
        false
    }
    /// Whether [`System::needs_f64`] may become true during the run (a contact term exists,
    /// with or without pairs yet). The multigrid hierarchy then keeps its coarse matrices in
    /// f64 throughout: a hierarchy made before the first pairs is used into the impact, and
    /// rounding its coarse levels changed the jelly drop's impact frame (36 capped CG solves
    /// against 6). Default false.
    fn may_need_f64(&self) -> bool {
        false
    }
}

/// What a strategy has done so far, for `tetsim bench` and the run summary.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SolverReport {
    /// The scene name of the strategy.
    pub name: &'static str,
    /// Preconditioner builds from scratch (hierarchies, symbolic analyses with a factor).
    pub builds: usize,
    /// Numeric refreshes on a kept structure (AMG refresh, Cholesky refactorization).
    pub refreshes: usize,
    /// Times the system's pattern changed and the structure was rebuilt for it.
    pub pattern_changes: usize,
}

/// One way of solving `A·x = b`: prepared for the system at a Newton iterate, then asked to
/// solve (possibly several times: `adaptive` may retry with another tangent).
pub trait LinearSolver: Send {
    /// Get ready for solves with the system as it is now (assemble it, build or refresh a
    /// preconditioner by the strategy's own rules). `free` is the 0/1 DOF mask.
    fn prepare(&mut self, system: &mut dyn System, free: &[Vec3]);
    /// `x ≈ A⁻¹·b` on the free DOFs by preconditioned CG from `x` (the caller zeroes it).
    fn solve(
        &mut self,
        system: &mut dyn System,
        b: &[Vec3],
        x: &mut [Vec3],
        free: &[Vec3],
        params: &CgParams,
    ) -> Result<CgInfo, CgError>;
    /// `z = M⁻¹·r` with the prepared preconditioner (a fallback direction when CG breaks down).
    fn precondition(&mut self, r: &[Vec3], z: &mut [Vec3]);
    /// Bytes one CG iteration moves (operator and preconditioner; a traffic model for roofline
    /// figures), for a system of `vertices` vertices whose matrix-free product moves
    /// `matrix_free_bytes`.
    fn bytes_per_iteration(&self, matrix_free_bytes: f64) -> f64;
    /// Counts so far.
    fn report(&self) -> SolverReport;
    /// Its buffers, into a memory inventory. Default: nothing counted.
    fn add_memory(&self, _inventory: &mut crate::memory::Inventory) {}
    /// What shapes the coming solves, for a checkpoint ([`state::SolverState`]). Default: nothing.
    fn save_state(&self) -> state::SolverState {
        state::SolverState::Fresh
    }
    /// Take up a saved state (`rest`: the vertices' rest positions), as if the solves that made
    /// it had happened here. Default: only [`state::SolverState::Fresh`] is accepted.
    fn restore_state(&mut self, saved: &state::SolverState, rest: &[Vec3]) -> Result<(), String> {
        let _ = rest;
        match saved {
            state::SolverState::Fresh => Ok(()),
            _ => {
                Err("the checkpoint's linear-solver state belongs to another preconditioner".into())
            }
        }
    }
    /// The sparse Cholesky's costs, when this strategy uses it.
    #[cfg(feature = "direct")]
    fn cholesky_info(&self) -> Option<&direct::CholeskyInfo> {
        None
    }
}

/// The preconditioner (and with it the linear-solver strategy) of the Newton systems.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PreconditionerKind {
    /// None (plain CG), for experiments.
    Identity,
    /// Diagonal of A.
    Jacobi,
    /// Inverse of each vertex's 3×3 diagonal block of A.
    BlockJacobi,
    /// Smoothed-aggregation algebraic multigrid ([`amg`]) on the assembled A, one V-cycle
    /// per CG iteration; CG then multiplies with the assembled A too.
    #[default]
    Amg,
    /// Sparse Cholesky of the assembled A (`direct`, feature `direct`), kept across
    /// Newton iterations while CG converges fast (see `cholesky_reuse`).
    #[cfg(feature = "direct")]
    Cholesky,
}

/// Settings every strategy may read (each reads its own).
#[derive(Clone, Debug, PartialEq)]
pub struct LinearSolverParams {
    /// Which strategy.
    pub kind: PreconditionerKind,
    /// Multigrid settings.
    pub amg: amg::AmgParams,
    /// Assembled strategies: CG multiplies with an f32 upper triangle of A.
    pub f32_matrix: bool,
    /// How the assembled A is stored.
    pub matrix_precision: sparse::Precision,
    /// Cholesky: keep the factor across iterates while CG converges fast.
    pub cholesky_reuse: bool,
}

/// The strategy for `params`, for systems of `vertices` vertices.
pub fn make_solver(params: &LinearSolverParams, vertices: usize) -> Box<dyn LinearSolver> {
    match params.kind {
        PreconditionerKind::Identity
        | PreconditionerKind::Jacobi
        | PreconditionerKind::BlockJacobi => {
            Box::new(matrix_free::MatrixFree::new(params.kind, vertices))
        }
        PreconditionerKind::Amg => Box::new(multigrid::Multigrid::new(params, vertices)),
        #[cfg(feature = "direct")]
        PreconditionerKind::Cholesky => Box::new(cholesky::SparseCholesky::new(params, vertices)),
    }
}

/// The assembled matrix of an assembled strategy, rebuilt when the system's pattern changes.
#[derive(Debug, Default)]
pub(crate) struct AssembledMatrix {
    /// A, constrained.
    pub a: Option<BlockCsr>,
    /// How `a` is stored.
    precision: sparse::Precision,
    /// The f32 upper triangle CG multiplies with, when asked for.
    pub upper: Option<sparse::UpperF32>,
    /// The pattern generation `a` was made for.
    generation: Option<u64>,
    /// After a resume: the pattern the checkpoint's generation stood for. A resumed run numbers
    /// its first pattern with the stored generation, so the first assembly compares the
    /// patterns themselves (a resumed coil once refreshed its restored hierarchy on a pattern
    /// the contact pairs had changed since).
    restored: Option<BlockPattern>,
}

impl AssembledMatrix {
    pub fn new(f32_matrix: bool, precision: sparse::Precision) -> Self {
        AssembledMatrix {
            a: None,
            precision,
            upper: f32_matrix.then(sparse::UpperF32::default),
            generation: None,
            restored: None,
        }
    }

    /// Store A in f64 from the next assembly on, whatever [`System::needs_f64`] says (a new
    /// storage on the same pattern: not a pattern change).
    pub fn use_f64(&mut self) {
        self.precision = sparse::Precision::F64;
        self.a = None;
    }

    /// Assemble and constrain A; true when the pattern changed since the last call (the first
    /// call included). An f32 A is stored in f64 while [`System::needs_f64`] (a new storage on
    /// the same pattern: not a change; a shared hierarchy reads either).
    pub fn assemble(&mut self, system: &mut dyn System, free: &[Vec3]) -> bool {
        let precision = match self.precision {
            sparse::Precision::F32 if system.needs_f64() => sparse::Precision::F64,
            p => p,
        };
        let pattern = system.pattern();
        let mut changed = self.generation != Some(pattern.generation);
        if let Some(restored) = self.restored.take() {
            changed |= restored != *pattern.pattern;
        }
        if changed || self.a.is_none() {
            self.a = Some(BlockCsr::zeros_in(pattern.pattern.clone(), precision));
            self.generation = Some(pattern.generation);
        } else if let Some(a) = self.a.as_mut().filter(|a| a.precision() != precision) {
            *a = BlockCsr::zeros_in(std::mem::take(&mut a.pattern), precision);
        }
        let a = self.a.as_mut().expect("made above");
        system.assemble(a);
        a.constrain(free);
        if let Some(upper) = &mut self.upper {
            upper.fill_from(a);
        }
        changed
    }

    /// Assemble and constrain the projected A (see [`System::assemble_projected`]) into the
    /// storage of the last [`AssembledMatrix::assemble`], whose pattern it must have; the f32
    /// copy is left alone (the next `assemble` refills both).
    pub fn assemble_projected(&mut self, system: &mut dyn System, free: &[Vec3]) {
        let a = self.a.as_mut().expect("assembled before");
        system.assemble_projected(a);
        a.constrain(free);
    }

    /// The pattern generation and pattern, for a checkpoint.
    pub fn saved(&self) -> (Option<u64>, Option<state::StoredPattern>) {
        let pattern = self
            .a
            .as_ref()
            .map(|a| (a.pattern.row_start.clone(), a.pattern.cols.clone()));
        (self.generation, pattern)
    }

    /// Take up a saved generation and pattern (see [`AssembledMatrix::saved`]): the next
    /// assembly with that generation reuses the storage instead of counting a new pattern.
    /// `pattern` is the one `generation` stood for, when stored.
    pub fn restore(&mut self, generation: Option<u64>, pattern: Option<BlockPattern>) {
        self.generation = generation;
        self.a = None;
        self.restored = pattern;
    }

    /// CG with the assembled A (f64 or its f32 upper triangle).
    #[cfg(feature = "direct")]
    pub fn solve(
        &mut self,
        m: &mut dyn cg::Preconditioner,
        b: &[Vec3],
        x: &mut [Vec3],
        free: &[Vec3],
        params: &CgParams,
        ws: &mut cg::CgWorkspace,
    ) -> Result<CgInfo, CgError> {
        let a = self.a.as_ref().expect("solve before prepare");
        solve_assembled(a, self.upper.as_mut(), m, b, x, free, params, ws)
    }

    /// Its matrices, into a memory inventory.
    pub fn add_memory(&self, inventory: &mut crate::memory::Inventory) {
        use crate::memory::vec_bytes;
        if let Some(a) = &self.a {
            let precision = match a.precision() {
                sparse::Precision::F64 => "f64",
                sparse::Precision::F32 => "f32",
            };
            inventory.add(
                format!("assembled A ({precision} blocks, both triangles)"),
                a.block_bytes(),
            );
            inventory.add(
                "assembled A's pattern",
                vec_bytes(&a.pattern.row_start) + vec_bytes(&a.pattern.cols),
            );
        }
        if let Some(upper) = &self.upper {
            inventory.add("assembled A's f32 upper triangle", upper.heap_bytes());
        }
    }

    /// Bytes of the matrix one product reads (72- or 36-byte blocks plus a 4-byte column index,
    /// or the f32 upper triangle).
    pub fn bytes(&self) -> f64 {
        match (&self.upper, &self.a) {
            (Some(upper), _) => upper.matrix_bytes() as f64,
            (None, Some(a)) => a.product_bytes() as f64,
            (None, None) => 0.0,
        }
    }
}

/// CG with the assembled A, or with its f32 upper triangle when there is one (a function of
/// the parts, so that a preconditioner may borrow A meanwhile).
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_assembled(
    a: &BlockCsr,
    upper: Option<&mut sparse::UpperF32>,
    m: &mut dyn cg::Preconditioner,
    b: &[Vec3],
    x: &mut [Vec3],
    free: &[Vec3],
    params: &CgParams,
    ws: &mut cg::CgWorkspace,
) -> Result<CgInfo, CgError> {
    match upper {
        Some(upper) => cg::conjugate_gradient(&mut UpperOperator(upper), m, b, x, free, params, ws),
        None => cg::conjugate_gradient(&mut CsrOperator(a), m, b, x, free, params, ws),
    }
}

/// The assembled A as a CG operator.
struct CsrOperator<'a>(&'a BlockCsr);

impl cg::LinearOperator for CsrOperator<'_> {
    fn len(&self) -> usize {
        self.0.rows()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.0.multiply(p, out);
    }
}

/// The f32 upper triangle of A as a CG operator.
struct UpperOperator<'a>(&'a mut sparse::UpperF32);

impl cg::LinearOperator for UpperOperator<'_> {
    fn len(&self) -> usize {
        self.0.rows()
    }

    fn apply(&mut self, p: &[Vec3], out: &mut [Vec3]) {
        self.0.multiply(p, out);
    }
}

/// CG iterations per decade of residual reduction of a solve: the measure the refresh rules use
/// (inexact Newton asks for a loose 0.1 early in a step and a tight tolerance at its end, so raw
/// counts say nothing about the preconditioner's quality).
pub(crate) fn iterations_per_decade(info: &CgInfo) -> f64 {
    let decades = (-info.relative_residual.max(1e-300).log10()).max(0.25);
    info.iterations as f64 / decades
}

/// The [`CgInfo`] of a solve, finished or broken down.
pub(crate) fn info_of(result: &Result<CgInfo, CgError>) -> &CgInfo {
    match result {
        Ok(i) => i,
        Err(CgError::NotPositiveDefinite { info, .. } | CgError::NonFinite { info, .. }) => info,
    }
}

#[cfg(test)]
mod tests;
