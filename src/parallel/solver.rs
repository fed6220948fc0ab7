//! Newton's linear systems on PETSc: a [`LinearSolver`] whose matrix is the distributed BAIJ
//! matrix the ranks' element blocks were added into ([`Shared`], the parts' [`ElementSink`]),
//! solved by a KSP (CG + GAMG unless the options database says otherwise) on this rank's owned
//! vertices, the solution then copied to the ghosts ([`super::Ranks::share`]).

use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::Ranks;
use super::elastic::ElementSink;
use super::petsc::{Ksp, Matrix, Petsc, Vector};
use super::setup::record;
use crate::linear::cg::{CgError, CgInfo, CgParams};
use crate::linear::sparse::BlockCsr;
use crate::linear::{LinearSolver, SolverReport, System};
use crate::math::Vec3;

/// The matrix the elasticity parts add into and the solver solves with.
pub struct Shared {
    /// The distributed matrix.
    pub matrix: Matrix,
    /// The first PETSc error met while adding (reported by the next solve).
    error: Option<super::petsc::PetscError>,
}

impl Shared {
    /// Elements are added into `matrix`.
    pub fn new(matrix: Matrix) -> Self {
        Shared {
            matrix,
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

    fn add_element(&mut self, rows: [usize; 4], values: &[f64; 144]) {
        let rows = rows.map(|r| r as i32);
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
    /// This rank's owned vertices (the first ones of its vectors; rows `offset..`).
    owned: usize,
    /// The first block row of this rank.
    offset: usize,
    ranks: Arc<dyn Ranks>,
    flat: Vec<f64>,
    /// The lumped diagonal (inertia) the system assembles beside the parts' blocks.
    diagonal: Option<(BlockCsr, u64)>,
    report: SolverReport,
}

impl PetscSolver {
    /// A solver on `shared`'s matrix with `ksp` and vectors (b, x) laid out like it; this
    /// rank owns the first `owned` vertices of its vectors, at block rows from `offset`.
    pub fn new(
        petsc: Petsc,
        shared: Arc<Mutex<Shared>>,
        ksp: Ksp,
        (b, x): (Vector, Vector),
        owned: usize,
        offset: usize,
        ranks: Arc<dyn Ranks>,
    ) -> Self {
        PetscSolver {
            petsc,
            shared,
            ksp,
            b,
            x,
            owned,
            offset,
            ranks,
            flat: Vec::new(),
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

    /// Write the owned entries of `v` into `b`.
    fn set_b(&mut self, v: &[Vec3]) {
        let owned = self.owned;
        if let Err(e) = self.b.with_local(|b| {
            for (k, v) in v[..owned].iter().enumerate() {
                b[3 * k..3 * k + 3].copy_from_slice(v.as_slice());
            }
        }) {
            self.fail("writing the right-hand side", e);
        }
    }

    /// x into `out`: the owned entries from PETSc, the ghosts from their owners.
    fn get_x(&mut self, out: &mut [Vec3]) {
        let mut flat = std::mem::take(&mut self.flat);
        flat.clear();
        flat.resize(3 * out.len(), 0.0);
        let owned = self.owned;
        if let Err(e) = self
            .x
            .with_local(|x| flat[..3 * owned].copy_from_slice(&x[..3 * owned]))
        {
            self.fail("reading the solution", e);
        }
        self.ranks.share(&mut flat, 3);
        for (o, f) in out.iter_mut().zip(flat.chunks_exact(3)) {
            *o = Vec3::new(f[0], f[1], f[2]);
        }
        self.flat = flat;
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
        for (v, m) in free[..self.owned].iter().enumerate() {
            let d = diagonal.diagonal(v);
            let mut values = [0.0; 9];
            for i in 0..3 {
                for j in 0..3 {
                    values[3 * i + j] = m[i] * m[j] * d[(i, j)];
                }
                if m[i] == 0.0 {
                    values[4 * i] = 1.0;
                }
            }
            let row = [(self.offset + v) as i32];
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
        // The serial CG's measure: ‖r‖/‖b‖ over the free DOFs (b is masked: the same norm; the
        // ghosts' entries are zero).
        let mut norm = [b
            .iter()
            .zip(free)
            .map(|(b, m)| b.component_mul(m).norm_squared())
            .sum::<f64>()];
        self.ranks.sum(&mut norm);
        let norm = norm[0].sqrt();
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
