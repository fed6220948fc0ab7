//! PETSc through a small hand-kept FFI: with [`super::metis`] (one METIS call), the only
//! `unsafe` of the `mpi` feature lives here.
//!
//! Against Debian's `libpetsc-real-dev` 3.18 (PetscInt = 32-bit `int`, PetscScalar = PetscReal
//! = `double`, PetscErrorCode = `int`, every object an opaque pointer). The declarations copy
//! the prototypes of petscsys.h, petscvec.h, petscmat.h and petscksp.h by hand (a dozen
//! functions: no bindgen run, no build script); the enum values are the headers'.
//!
//! **Safety.** Every wrapper owns its PETSc object and destroys it on drop; no pointer leaves
//! this file. Every call's error code is checked ([`check`]). The objects are collective on the
//! communicator they were made on, so every rank must make the same calls in the same order:
//! the callers guarantee that by running the same control flow on every rank, its decisions
//! made on sums over the ranks (see [`super`]). PETSc is initialised once ([`Petsc::init`], after MPI) and finalised when the
//! last [`Petsc`] handle is dropped; the wrappers keep a handle, so they are destroyed first.

use std::ffi::{CString, c_char, c_int, c_void};
use std::sync::Arc;

use mpi::ffi::MPI_Comm;

type PetscErrorCode = c_int;
type PetscInt = c_int;
type PetscScalar = f64;
type PetscReal = f64;
type Object = *mut c_void;

const ADD_VALUES: c_int = 2;
const MAT_FINAL_ASSEMBLY: c_int = 0;
const KSP_NORM_UNPRECONDITIONED: c_int = 2;
/// PETSC_DEFAULT: keep PETSc's value of a tolerance.
const PETSC_DEFAULT: PetscReal = -2.0;

#[link(name = "petsc_real")]
unsafe extern "C" {
    fn PetscInitializeNoArguments() -> PetscErrorCode;
    fn PetscInitialized(initialized: *mut c_int) -> PetscErrorCode;
    fn PetscFinalize() -> PetscErrorCode;
    fn PetscOptionsInsertString(options: Object, text: *const c_char) -> PetscErrorCode;
    fn PetscMemoryGetCurrentUsage(bytes: *mut f64) -> PetscErrorCode;

    fn VecCreateMPI(comm: MPI_Comm, n: PetscInt, big_n: PetscInt, v: *mut Object)
    -> PetscErrorCode;
    fn VecSetBlockSize(v: Object, bs: PetscInt) -> PetscErrorCode;
    fn VecGetArray(v: Object, a: *mut *mut PetscScalar) -> PetscErrorCode;
    fn VecRestoreArray(v: Object, a: *mut *mut PetscScalar) -> PetscErrorCode;
    fn VecGetLocalSize(v: Object, n: *mut PetscInt) -> PetscErrorCode;
    fn VecDestroy(v: *mut Object) -> PetscErrorCode;

    fn MatCreate(comm: MPI_Comm, a: *mut Object) -> PetscErrorCode;
    fn MatSetSizes(
        a: Object,
        m: PetscInt,
        n: PetscInt,
        big_m: PetscInt,
        big_n: PetscInt,
    ) -> PetscErrorCode;
    fn MatSetBlockSize(a: Object, bs: PetscInt) -> PetscErrorCode;
    fn MatSetType(a: Object, kind: *const c_char) -> PetscErrorCode;
    fn MatSetFromOptions(a: Object) -> PetscErrorCode;
    fn MatXAIJSetPreallocation(
        a: Object,
        bs: PetscInt,
        dnnz: *const PetscInt,
        onnz: *const PetscInt,
        dnnzu: *const PetscInt,
        onnzu: *const PetscInt,
    ) -> PetscErrorCode;
    fn MatSetValuesBlocked(
        a: Object,
        m: PetscInt,
        rows: *const PetscInt,
        n: PetscInt,
        cols: *const PetscInt,
        v: *const PetscScalar,
        mode: c_int,
    ) -> PetscErrorCode;
    fn MatAssemblyBegin(a: Object, kind: c_int) -> PetscErrorCode;
    fn MatAssemblyEnd(a: Object, kind: c_int) -> PetscErrorCode;
    fn MatZeroEntries(a: Object) -> PetscErrorCode;
    fn MatSetNearNullSpace(a: Object, space: Object) -> PetscErrorCode;
    fn MatNullSpaceCreateRigidBody(coords: Object, space: *mut Object) -> PetscErrorCode;
    fn MatNullSpaceDestroy(space: *mut Object) -> PetscErrorCode;
    fn MatDestroy(a: *mut Object) -> PetscErrorCode;

    fn KSPCreate(comm: MPI_Comm, ksp: *mut Object) -> PetscErrorCode;
    fn KSPSetType(ksp: Object, kind: *const c_char) -> PetscErrorCode;
    fn KSPGetPC(ksp: Object, pc: *mut Object) -> PetscErrorCode;
    fn PCSetType(pc: Object, kind: *const c_char) -> PetscErrorCode;
    fn PCApply(pc: Object, x: Object, y: Object) -> PetscErrorCode;
    fn KSPSetNormType(ksp: Object, kind: c_int) -> PetscErrorCode;
    fn KSPSetFromOptions(ksp: Object) -> PetscErrorCode;
    fn KSPSetOperators(ksp: Object, a: Object, p: Object) -> PetscErrorCode;
    fn KSPSetTolerances(
        ksp: Object,
        rtol: PetscReal,
        abstol: PetscReal,
        dtol: PetscReal,
        maxits: PetscInt,
    ) -> PetscErrorCode;
    fn KSPSetUp(ksp: Object) -> PetscErrorCode;
    fn KSPSolve(ksp: Object, b: Object, x: Object) -> PetscErrorCode;
    fn KSPGetIterationNumber(ksp: Object, its: *mut PetscInt) -> PetscErrorCode;
    fn KSPGetConvergedReason(ksp: Object, reason: *mut c_int) -> PetscErrorCode;
    fn KSPGetResidualNorm(ksp: Object, norm: *mut PetscReal) -> PetscErrorCode;
    fn KSPDestroy(ksp: *mut Object) -> PetscErrorCode;

    /// Bytes PETSc's own point-to-point sends moved so far (petsclog.h's counters).
    static petsc_send_len: f64;
    static petsc_isend_len: f64;
}

/// A PETSc call failed: its error code (PETSc has printed its own trace on stderr).
#[derive(Debug, thiserror::Error)]
#[error("PETSc error {code} in {call}")]
pub struct PetscError {
    /// PETSc's error code.
    pub code: i32,
    /// The call.
    pub call: &'static str,
}

/// Result of a PETSc call.
pub type Result<T> = std::result::Result<T, PetscError>;

fn check(code: PetscErrorCode, call: &'static str) -> Result<()> {
    if code == 0 {
        Ok(())
    } else {
        Err(PetscError { code, call })
    }
}

/// Convert an index or count to PetscInt (32-bit in Debian's build).
fn int(i: usize) -> PetscInt {
    PetscInt::try_from(i).expect("an index below 2³¹ (Debian's PETSc has 32-bit indices)")
}

struct Session;

impl Drop for Session {
    fn drop(&mut self) {
        // SAFETY: the last handle: every object (which holds a handle) is gone.
        unsafe {
            PetscFinalize();
        }
    }
}

/// PETSc, initialised: a handle every PETSc object keeps, so PetscFinalize runs after them.
#[derive(Clone)]
pub struct Petsc {
    _session: Arc<Session>,
}

// SAFETY: PETSc objects are used by one thread of each rank at a time (the Newton loop); the
// handles only move between threads with the values that own them, never concurrently.
unsafe impl Send for Petsc {}
unsafe impl Sync for Petsc {}

impl Petsc {
    /// Initialise PETSc (MPI must be initialised: PETSc then leaves MPI_Finalize to it). Reads
    /// the PETSC_OPTIONS environment variable; then `options` (PETSc's command-line syntax,
    /// `-ksp_rtol 1e-8 -pc_type hypre`) are inserted and take precedence.
    pub fn init(options: &str) -> Result<Self> {
        let text = CString::new(options).map_err(|_| PetscError {
            code: -1,
            call: "petsc_options (holds a NUL byte)",
        })?;
        // SAFETY: plain calls with valid C strings; initialising twice is refused below.
        unsafe {
            let mut done = 0;
            check(PetscInitialized(&mut done), "PetscInitialized")?;
            assert!(done == 0, "PETSc initialised twice");
            check(PetscInitializeNoArguments(), "PetscInitializeNoArguments")?;
            check(
                PetscOptionsInsertString(std::ptr::null_mut(), text.as_ptr()),
                "PetscOptionsInsertString",
            )?;
        }
        Ok(Petsc {
            _session: Arc::new(Session),
        })
    }

    /// This process's resident memory as PETSc measures it, bytes.
    pub fn memory_bytes(&self) -> f64 {
        let mut bytes = 0.0;
        // SAFETY: writes one double.
        unsafe { PetscMemoryGetCurrentUsage(&mut bytes) };
        bytes
    }

    /// Bytes PETSc has sent from this rank so far (its logged sends; 0 without logging).
    pub fn bytes_sent(&self) -> f64 {
        // SAFETY: reads two doubles PETSc only writes from this thread.
        unsafe { petsc_send_len + petsc_isend_len }
    }
}

/// A distributed vector of `3·owned` entries per rank (block size 3).
pub struct Vector {
    v: Object,
    _petsc: Petsc,
}

impl Vector {
    /// A vector with `owned` blocks on this rank and `total` blocks on all.
    pub fn new(petsc: &Petsc, comm: MPI_Comm, owned: usize, total: usize) -> Result<Self> {
        let mut v = std::ptr::null_mut();
        // SAFETY: collective creation; `v` is written by PETSc.
        unsafe {
            check(
                VecCreateMPI(comm, int(3 * owned), int(3 * total), &mut v),
                "VecCreateMPI",
            )?;
            let vector = Vector {
                v,
                _petsc: petsc.clone(),
            };
            check(VecSetBlockSize(v, 3), "VecSetBlockSize")?;
            Ok(vector)
        }
    }

    /// Read or write this rank's entries.
    pub fn with_local<T>(&mut self, f: impl FnOnce(&mut [f64]) -> T) -> Result<T> {
        // SAFETY: the array PETSc lends is valid for its local size until VecRestoreArray.
        unsafe {
            let mut n = 0;
            check(VecGetLocalSize(self.v, &mut n), "VecGetLocalSize")?;
            let mut a = std::ptr::null_mut();
            check(VecGetArray(self.v, &mut a), "VecGetArray")?;
            let out = f(std::slice::from_raw_parts_mut(a, n as usize));
            check(VecRestoreArray(self.v, &mut a), "VecRestoreArray")?;
            Ok(out)
        }
    }
}

impl Drop for Vector {
    fn drop(&mut self) {
        // SAFETY: owned object, destroyed once.
        unsafe { VecDestroy(&mut self.v) };
    }
}

/// A distributed matrix of 3×3 blocks: AIJ with block size 3 by default (GAMG in PETSc 3.18
/// builds its graph from AIJ only: "No method creategraph for Mat of type mpibaij"), BAIJ with
/// `-mat_type baij` for preconditioners that take it; filled by blocks either way.
pub struct Matrix {
    a: Object,
    null_space: Object,
    _petsc: Petsc,
}

// SAFETY: see `Petsc`: one thread at a time, shared between the elasticity term that adds
// element blocks and the solver behind a mutex.
unsafe impl Send for Matrix {}

impl Matrix {
    /// `owned` block rows on this rank of `total`, preallocated with `diagonal[i]` blocks of
    /// row i in this rank's columns and `off[i]` in other ranks'.
    pub fn new(
        petsc: &Petsc,
        comm: MPI_Comm,
        total: usize,
        diagonal: &[usize],
        off: &[usize],
    ) -> Result<Self> {
        let owned = diagonal.len();
        let d: Vec<PetscInt> = diagonal.iter().map(|&k| int(k)).collect();
        let o: Vec<PetscInt> = off.iter().map(|&k| int(k)).collect();
        let mut a = std::ptr::null_mut();
        // SAFETY: collective; the count arrays have one entry per owned block row; the
        // matrix is owned by `out` as soon as it exists, so an error below still destroys it.
        unsafe {
            check(MatCreate(comm, &mut a), "MatCreate")?;
            let out = Matrix {
                a,
                null_space: std::ptr::null_mut(),
                _petsc: petsc.clone(),
            };
            let (m, big_m) = (int(3 * owned), int(3 * total));
            check(MatSetSizes(a, m, m, big_m, big_m), "MatSetSizes")?;
            check(MatSetBlockSize(a, 3), "MatSetBlockSize")?;
            check(MatSetType(a, c"aij".as_ptr()), "MatSetType")?;
            check(MatSetFromOptions(a), "MatSetFromOptions")?;
            check(
                MatXAIJSetPreallocation(
                    a,
                    3,
                    d.as_ptr(),
                    o.as_ptr(),
                    std::ptr::null(),
                    std::ptr::null(),
                ),
                "MatXAIJSetPreallocation",
            )?;
            Ok(out)
        }
    }
    /// Tell the multigrid the six rigid-body modes, from this rank's rest coordinates (x, y, z
    /// of each owned vertex in PETSc order), laid out like `like`.
    pub fn set_rigid_body_modes(&mut self, coords: &mut Vector, local: &[f64]) -> Result<()> {
        coords.with_local(|c| c.copy_from_slice(local))?;
        // SAFETY: collective; the null space is owned here (the matrix keeps its own reference).
        unsafe {
            check(
                MatNullSpaceCreateRigidBody(coords.v, &mut self.null_space),
                "MatNullSpaceCreateRigidBody",
            )?;
            check(
                MatSetNearNullSpace(self.a, self.null_space),
                "MatSetNearNullSpace",
            )
        }
    }

    /// Zero every entry, keeping the pattern.
    pub fn zero(&mut self) -> Result<()> {
        // SAFETY: plain call on an owned matrix.
        unsafe { check(MatZeroEntries(self.a), "MatZeroEntries") }
    }

    /// `A[rows, cols] += values` (blocks; `values` row-major, (3·rows)×(3·cols)); rows owned by
    /// other ranks are sent to them at [`Matrix::assemble`].
    pub fn add_blocks(&mut self, rows: &[i32], cols: &[i32], values: &[f64]) -> Result<()> {
        assert_eq!(values.len(), 9 * rows.len() * cols.len());
        // SAFETY: the slices have the lengths PETSc reads.
        unsafe {
            check(
                MatSetValuesBlocked(
                    self.a,
                    int(rows.len()),
                    rows.as_ptr(),
                    int(cols.len()),
                    cols.as_ptr(),
                    values.as_ptr(),
                    ADD_VALUES,
                ),
                "MatSetValuesBlocked",
            )
        }
    }

    /// Finish the additions (collective: exchanges the blocks of other ranks' rows).
    pub fn assemble(&mut self) -> Result<()> {
        // SAFETY: plain collective calls.
        unsafe {
            check(
                MatAssemblyBegin(self.a, MAT_FINAL_ASSEMBLY),
                "MatAssemblyBegin",
            )?;
            check(MatAssemblyEnd(self.a, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd")
        }
    }
}

impl Drop for Matrix {
    fn drop(&mut self) {
        // SAFETY: owned objects, destroyed once.
        unsafe {
            if !self.null_space.is_null() {
                MatNullSpaceDestroy(&mut self.null_space);
            }
            MatDestroy(&mut self.a);
        }
    }
}

/// How a Krylov solve ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KspOutcome {
    /// Iterations.
    pub iterations: usize,
    /// KSPConvergedReason: > 0 converged, < 0 diverged (−3 iteration cap, −5 breakdown, −8/−10
    /// indefinite preconditioner/matrix, −9 NaN or Inf).
    pub reason: i32,
    /// The final (unpreconditioned) residual norm.
    pub residual: f64,
}

/// A Krylov solver (KSP) with its preconditioner (PC).
pub struct Ksp {
    ksp: Object,
    _petsc: Petsc,
}

// SAFETY: see `Petsc`.
unsafe impl Send for Ksp {}

impl Ksp {
    /// CG with the true residual norm and `pc` (PETSc's name: "gamg"), then the options
    /// database (PETSC_OPTIONS, `[solver] petsc_options`) may override both.
    pub fn new(petsc: &Petsc, comm: MPI_Comm, pc: &str) -> Result<Self> {
        let (cg, pc) = (c"cg", CString::new(pc).expect("a PC name without NUL"));
        let mut ksp = std::ptr::null_mut();
        // SAFETY: collective creation; valid C strings.
        unsafe {
            check(KSPCreate(comm, &mut ksp), "KSPCreate")?;
            let out = Ksp {
                ksp,
                _petsc: petsc.clone(),
            };
            check(KSPSetType(ksp, cg.as_ptr()), "KSPSetType")?;
            let mut pcobj = std::ptr::null_mut();
            check(KSPGetPC(ksp, &mut pcobj), "KSPGetPC")?;
            check(PCSetType(pcobj, pc.as_ptr()), "PCSetType")?;
            check(
                KSPSetNormType(ksp, KSP_NORM_UNPRECONDITIONED),
                "KSPSetNormType",
            )?;
            check(KSPSetFromOptions(ksp), "KSPSetFromOptions")?;
            Ok(out)
        }
    }

    /// Use `a` as operator and preconditioner matrix and build the preconditioner now (so that
    /// its cost is not counted in the solve's).
    pub fn set_operator(&mut self, a: &Matrix) -> Result<()> {
        // SAFETY: the KSP takes its own reference to the matrix.
        unsafe {
            check(KSPSetOperators(self.ksp, a.a, a.a), "KSPSetOperators")?;
            check(KSPSetUp(self.ksp), "KSPSetUp")
        }
    }

    /// Solve `A·x = b` from x = 0 to `rtol` (relative to ‖b‖) in at most `max_iterations`.
    pub fn solve(
        &mut self,
        b: &Vector,
        x: &mut Vector,
        rtol: f64,
        max_iterations: usize,
    ) -> Result<KspOutcome> {
        // SAFETY: plain collective calls on owned objects; outputs written by PETSc.
        unsafe {
            check(
                KSPSetTolerances(
                    self.ksp,
                    rtol,
                    PETSC_DEFAULT,
                    PETSC_DEFAULT,
                    int(max_iterations),
                ),
                "KSPSetTolerances",
            )?;
            check(KSPSolve(self.ksp, b.v, x.v), "KSPSolve")?;
            let (mut its, mut reason, mut residual) = (0, 0, 0.0);
            check(
                KSPGetIterationNumber(self.ksp, &mut its),
                "KSPGetIterationNumber",
            )?;
            check(
                KSPGetConvergedReason(self.ksp, &mut reason),
                "KSPGetConvergedReason",
            )?;
            check(
                KSPGetResidualNorm(self.ksp, &mut residual),
                "KSPGetResidualNorm",
            )?;
            Ok(KspOutcome {
                iterations: its.max(0) as usize,
                reason,
                residual,
            })
        }
    }

    /// `z = M⁻¹·r` with the preconditioner of the last solve.
    pub fn precondition(&mut self, r: &Vector, z: &mut Vector) -> Result<()> {
        // SAFETY: the PC belongs to the KSP; vectors of the matrix's layout.
        unsafe {
            let mut pc = std::ptr::null_mut();
            check(KSPGetPC(self.ksp, &mut pc), "KSPGetPC")?;
            check(PCApply(pc, r.v, z.v), "PCApply")
        }
    }
}

impl Drop for Ksp {
    fn drop(&mut self) {
        // SAFETY: owned object, destroyed once.
        unsafe { KSPDestroy(&mut self.ksp) };
    }
}

/// The MPI communicator the ranks' all-gathers run on (an rsmpi communicator, made `Send`).
pub struct Comm(pub mpi::topology::SimpleCommunicator);

// SAFETY: an MPI communicator is a handle; each rank uses it from one thread at a time (the
// Newton loop), and MPI is initialised with at least MPI_THREAD_SINGLE semantics respected.
unsafe impl Send for Comm {}
// SAFETY: as above: the reductions and halo exchanges that share it run on the Newton loop's
// thread, one at a time.
unsafe impl Sync for Comm {}

// SAFETY: see `Petsc`: owned by the solver, used from one thread at a time.
unsafe impl Send for Vector {}
