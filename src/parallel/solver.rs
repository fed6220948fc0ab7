//! Newton's linear systems on PETSc: a [`LinearSolver`] whose matrix is the distributed BAIJ
//! matrix the ranks' element blocks were added into ([`Shared`], the parts' [`ElementSink`]),
//! solved by a KSP (CG + GAMG unless the options database says otherwise), the solution
//! gathered whole to every rank.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::elastic::ElementSink;
use super::petsc::{Ksp, Matrix, Petsc, ToAll, Vector};
use super::setup::record;
use crate::linear::cg::{CgError, CgInfo, CgParams};
use crate::linear::sparse::BlockCsr;
use crate::linear::{LinearSolver, SolverReport, System};
use crate::math::Vec3;

/// The matrix the elasticity parts add into and the solver solves with.
pub struct Shared {
    /// The distributed matrix.
    pub matrix: Matrix,
    /// Each vertex's block row in the matrix.
    position: Vec<usize>,
    /// The first PETSc error met while adding (reported by the next solve).
    error: Option<super::petsc::PetscError>,
}

impl Shared {
    /// `matrix` with block row `position[v]` for vertex v.
    pub fn new(matrix: Matrix, position: Vec<usize>) -> Self {
        Shared {
            matrix,
            position,
            error: None,
        }
    }
}

impl ElementSink for Shared {
    fn begin(&mut self) {
        if let Err(e) = self.matrix.zero() {
            self.error.get_or_insert(e);
        }
    }

    fn add_element(&mut self, vertices: [usize; 4], values: &[f64; 144]) {
        let rows = vertices.map(|v| self.position[v] as i32);
        if let Err(e) = self.matrix.add_blocks(&rows, &rows, values) {
            self.error.get_or_insert(e);
        }
    }
}

/// The PETSc strategy.
pub struct PetscSolver {
    petsc: Petsc,
    shared: Arc<Mutex<Shared>>,
    ksp: Ksp,
    b: Vector,
    x: Vector,
    to_all: ToAll,
    /// This rank's vertices, in block-row order.
    owned: Vec<usize>,
    /// The first block row of this rank.
    offset: usize,
    /// Each vertex's block row.
    position: Vec<usize>,
    /// The lumped diagonal (inertia) the system assembles beside the parts' blocks.
    diagonal: Option<(BlockCsr, u64)>,
    report: SolverReport,
}

impl PetscSolver {
    /// A solver on `shared`'s matrix with `ksp` and vectors (b, x, scatter to all) laid out
    /// like it; `owned` are this rank's vertices, the first at block row `offset`.
    pub fn new(
        petsc: Petsc,
        shared: Arc<Mutex<Shared>>,
        ksp: Ksp,
        (b, x, to_all): (Vector, Vector, ToAll),
        owned: Vec<usize>,
        offset: usize,
        position: Vec<usize>,
    ) -> Self {
        PetscSolver {
            petsc,
            shared,
            ksp,
            b,
            x,
            to_all,
            owned,
            offset,
            position,
            diagonal: None,
            report: SolverReport {
                name: "petsc",
                ..Default::default()
            },
        }
    }

    fn fail(&self, what: &str, e: super::petsc::PetscError) -> ! {
        // A PETSc failure on one rank leaves the others waiting in a collective call: abort
        // the whole job with the reason rather than hang.
        eprintln!("error: {what}: {e}");
        std::process::abort();
    }

    /// Write `v` (whole-mesh) into this rank's part of `b`.
    fn set_b(&mut self, v: &[Vec3]) {
        let owned = &self.owned;
        if let Err(e) = self.b.with_local(|b| {
            for (k, &i) in owned.iter().enumerate() {
                b[3 * k..3 * k + 3].copy_from_slice(v[i].as_slice());
            }
        }) {
            self.fail("writing the right-hand side", e);
        }
    }

    /// Gather x whole into `out` (whole-mesh order) on every rank.
    fn get_x(&mut self, out: &mut [Vec3]) {
        let position = &self.position;
        if let Err(e) = self.to_all.gather(&self.x, |all| {
            for (o, &p) in out.iter_mut().zip(position) {
                *o = Vec3::new(all[3 * p], all[3 * p + 1], all[3 * p + 2]);
            }
        }) {
            self.fail("gathering the solution", e);
        }
    }
}

impl LinearSolver for PetscSolver {
    fn prepare(&mut self, system: &mut dyn System, free: &[Vec3]) {
        let started = Instant::now();
        let sent = self.petsc.bytes_sent();
        let pattern = system.pattern();
        if self.diagonal.as_ref().map(|d| d.1) != Some(pattern.generation) {
            self.diagonal = Some((BlockCsr::zeros(pattern.pattern.clone()), pattern.generation));
        }
        let (diagonal, _) = self.diagonal.as_mut().expect("made above");
        // The elasticity parts add their element blocks into the shared matrix here; the
        // system's own matrix is then the lumped diagonal alone.
        system.assemble(diagonal);
        let mut shared = self.shared.lock().expect("the matrix is not poisoned");
        if let Some(e) = shared.error.take() {
            self.fail("adding element matrices", e);
        }
        for (k, &v) in self.owned.iter().enumerate() {
            let d = diagonal.diagonal(v);
            let mut values = [0.0; 9];
            for i in 0..3 {
                for j in 0..3 {
                    values[3 * i + j] = free[v][i] * free[v][j] * d[(i, j)];
                }
                if free[v][i] == 0.0 {
                    values[4 * i] = 1.0;
                }
            }
            let row = [(self.offset + k) as i32];
            if let Err(e) = shared.matrix.add_blocks(&row, &row, &values) {
                self.fail("adding the diagonal", e);
            }
        }
        if let Err(e) = shared
            .matrix
            .assemble()
            .and_then(|()| self.ksp.set_operator(&shared.matrix))
        {
            self.fail("assembling the matrix", e);
        }
        self.report.builds += 1;
        let bytes = self.petsc.bytes_sent() - sent;
        let seconds = started.elapsed().as_secs_f64();
        record(|s| {
            s.petsc_setup_bytes += bytes;
            s.setup_seconds += seconds;
        });
    }

    fn solve(
        &mut self,
        _system: &mut dyn System,
        b: &[Vec3],
        x: &mut [Vec3],
        free: &[Vec3],
        params: &CgParams,
    ) -> Result<CgInfo, CgError> {
        let started = Instant::now();
        let sent = self.petsc.bytes_sent();
        self.set_b(b);
        let outcome = match self.ksp.solve(
            &self.b,
            &mut self.x,
            params.tolerance,
            params.max_iterations,
        ) {
            Ok(o) => o,
            Err(e) => self.fail("KSPSolve", e),
        };
        self.get_x(x);
        // GAMG's coarse spaces couple the constrained DOFs back in: keep them still.
        crate::linear::cg::project(x, free);
        // The serial CG's measure: ‖r‖/‖b‖ over the free DOFs (b is masked: the same norm).
        let norm: f64 = b
            .iter()
            .zip(free)
            .map(|(b, m)| b.component_mul(m).norm_squared())
            .sum::<f64>()
            .sqrt();
        let info = CgInfo {
            iterations: outcome.iterations,
            relative_residual: if norm > 0.0 {
                outcome.residual / norm
            } else {
                0.0
            },
            converged: outcome.reason > 0,
        };
        let bytes = self.petsc.bytes_sent() - sent;
        let seconds = started.elapsed().as_secs_f64();
        record(|s| {
            s.solves += 1;
            s.cg_iterations += outcome.iterations;
            s.petsc_solve_bytes += bytes;
            s.solve_seconds += seconds;
        });
        match outcome.reason {
            // Breakdown, indefinite preconditioner or matrix: what the serial CG calls pᵀAp ≤ 0.
            -5 | -8 | -10 => Err(CgError::NotPositiveDefinite {
                iteration: outcome.iterations,
                curvature: f64::NAN,
                info,
            }),
            -9 => Err(CgError::NonFinite {
                iteration: outcome.iterations,
                info,
            }),
            _ => Ok(info),
        }
    }

    fn precondition(&mut self, r: &[Vec3], z: &mut [Vec3]) {
        self.set_b(r);
        if let Err(e) = self.ksp.precondition(&self.b, &mut self.x) {
            self.fail("PCApply", e);
        }
        self.get_x(z);
    }

    fn bytes_per_iteration(&self, matrix_free_bytes: f64) -> f64 {
        // PETSc's memory traffic is its own; its sends are in `Stats`.
        matrix_free_bytes
    }

    fn report(&self) -> SolverReport {
        self.report.clone()
    }
}
