//! Assembled A with a sparse Cholesky factor as CG's preconditioner (feature `direct`; the
//! factorization itself is [`super::direct`]).
//!
//! The factor is kept across Newton iterations and frames and refactored when CG needs more than
//! [`CHOLESKY_REFACTOR_RATE`] iterations per decade, after a failed factorization, when the
//! constrained DOFs changed, or (`cholesky_reuse = false`) at every iterate. A new pattern of A
//! (contact) is analysed anew.
//!
//! Measured on the bench beam (30 frames): 0.054 s/frame against multigrid's 0.085 at 5,184
//! tets, 1.71 against 0.82 at 41,472: multigrid stays the default.

use super::cg::{CgError, CgInfo, CgParams, CgWorkspace};
use super::direct::{Cholesky, CholeskyInfo};
use super::{AssembledMatrix, LinearSolver, LinearSolverParams, SolverReport, System};
use crate::math::Vec3;

/// A kept factor is refactored once CG needed more than this many iterations per decade of
/// residual reduction (a fresh factor takes one iteration for the whole solve). Measured on the
/// bench cantilever (s/frame, 30 frames) for thresholds 1, 2, 4, 8: 0.071, 0.058, 0.065, 0.070 at
/// 5,184 tets and 1.48, 1.04, 1.18, 1.71 at 41,472 tets (0.8, 0.27, 0.13, 0.07 factorizations per
/// frame); never refactoring leaves CG at 8.7 iterations per Newton iteration and 0.098 s/frame
/// at 5,184 tets. Unlike multigrid's rule this one is absolute: a fresh factor's rate (≈ 0.1) is
/// no baseline to grow from.
pub const CHOLESKY_REFACTOR_RATE: f64 = 2.0;

/// Assembled A with a sparse Cholesky preconditioner.
pub struct SparseCholesky {
    matrix: AssembledMatrix,
    factor: Box<Cholesky>,
    reuse: bool,
    /// The free mask the factor was made with.
    factored_free: Vec<Vec3>,
    last_rate: f64,
    cg: CgWorkspace,
    report: SolverReport,
}

impl SparseCholesky {
    /// For systems of `vertices` vertices.
    pub fn new(params: &LinearSolverParams, vertices: usize) -> Self {
        SparseCholesky {
            matrix: AssembledMatrix::new(params.f32_matrix, params.matrix_precision),
            factor: Box::default(),
            reuse: params.cholesky_reuse,
            factored_free: Vec::new(),
            last_rate: 0.0,
            cg: CgWorkspace::new(vertices),
            report: SolverReport {
                name: "cholesky",
                ..Default::default()
            },
        }
    }
}

impl LinearSolver for SparseCholesky {
    fn prepare(&mut self, system: &mut dyn System, free: &[Vec3]) {
        let new_pattern = self.matrix.assemble(system, free);
        if new_pattern && self.factor.is_factored() {
            self.factor.forget_pattern();
            self.report.pattern_changes += 1;
        }
        if !self.reuse
            || !self.factor.is_factored()
            || self.last_rate > CHOLESKY_REFACTOR_RATE
            || self.factored_free.as_slice() != free
        {
            self.factored_free.clear();
            self.factored_free.extend_from_slice(free);
            self.last_rate = 0.0;
            let a = self.matrix.a.as_ref().expect("assembled");
            if let Err(e) = self.factor.factorize(a) {
                log::debug!("{e}; block Jacobi for this solve");
            }
            self.report.refreshes += 1;
        }
    }

    fn solve(
        &mut self,
        _system: &mut dyn System,
        b: &[Vec3],
        x: &mut [Vec3],
        free: &[Vec3],
        params: &CgParams,
    ) -> Result<CgInfo, CgError> {
        let result = self
            .matrix
            .solve(&mut *self.factor, b, x, free, params, &mut self.cg);
        self.last_rate = super::iterations_per_decade(super::info_of(&result));
        result
    }

    fn precondition(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        use super::cg::Preconditioner;
        self.factor.apply(r, z);
    }

    /// The block matrix, and L read twice (forward and backward), 8 bytes an entry; its
    /// supernodal row indices are a small share and left out.
    fn bytes_per_iteration(&self, _matrix_free_bytes: f64) -> f64 {
        self.matrix.bytes() + 16.0 * self.factor.info().l_nonzeros as f64
    }

    fn report(&self) -> SolverReport {
        let mut report = self.report.clone();
        report.builds = self.factor.info().factorizations;
        report
    }

    /// The factor is not stored: a resumed run factors afresh at its first solve.
    fn save_state(&self) -> super::state::SolverState {
        super::state::SolverState::NotStored
    }

    fn restore_state(
        &mut self,
        saved: &super::state::SolverState,
        _rest: &[Vec3],
    ) -> Result<(), String> {
        match saved {
            super::state::SolverState::Multigrid(_) => {
                Err("the checkpoint's linear-solver state belongs to another preconditioner".into())
            }
            _ => Ok(()),
        }
    }

    fn cholesky_info(&self) -> Option<&CholeskyInfo> {
        Some(self.factor.info())
    }
}
