//! Past one machine (SPEC §15): the same scene on many MPI ranks, with PETSc solving Newton's
//! linear systems.
//!
//! **What is distributed.** The tets are split over the ranks ([`partition`]: recursive
//! coordinate bisection; each vertex owned by one rank, the other vertices of a rank's tets its
//! ghost layer). Each rank evaluates only its own tets with the serial material code
//! ([`elastic::PartitionedElasticity`] on [`crate::elastic::ElasticBody::part`]), keeps only
//! their tangents, and adds only their element matrices into a distributed PETSc block matrix
//! (BAIJ, block size 3) whose block rows are owned by the vertices' ranks; PETSc's Krylov
//! solver (CG with GAMG by default) solves Newton's systems on it ([`solver`]).
//!
//! **What is replicated.** The vertex state (positions, velocities, loads, Newton's vectors)
//! and the mesh are on every rank, and Newton (its line search, definiteness policy, loads,
//! constraints, the energy audit) runs the serial code on every rank on the same bits: the
//! whole-body sums of the parts are made by an all-gather summed in rank order, the solution
//! is gathered whole to every rank. This keeps Newton exactly the serial one and the output
//! (written by rank 0) the serial file set, at the price of O(vertices) memory and traffic
//! per rank; docs/scaling.md measures and projects it, and says what a ghosted state changes.
//!
//! Files: [`partition`] and [`elastic`] are plain Rust (tested without MPI); with the feature
//! `mpi`, [`petsc`] (the FFI, all the `unsafe`) and [`solver`] (the [`crate::linear::LinearSolver`]
//! on PETSc), and [`distribute`], which puts both into a [`crate::Simulation`].

pub mod elastic;
pub mod partition;
#[cfg(feature = "mpi")]
#[allow(unsafe_code)]
pub mod petsc;
#[cfg(feature = "mpi")]
pub mod solver;

#[cfg(feature = "mpi")]
pub use setup::{Stats, distribute, stats};

#[cfg(feature = "mpi")]
pub(crate) mod setup {
    use std::sync::{Arc, Mutex};

    use mpi::datatype::PartitionMut;
    use mpi::raw::AsRaw;
    use mpi::topology::SimpleCommunicator;
    use mpi::traits::*;

    use super::elastic::{Gather, PartitionedElasticity};
    use super::partition::{Part, Partition};
    use super::petsc::{Comm, Ksp, Matrix, Petsc, PetscError, ToAll, Vector};
    use super::solver::{PetscSolver, Shared};
    use crate::Simulation;
    use crate::integrator::terms::Elasticity;
    use crate::linear::sparse::BlockPattern;

    /// What one rank did, for `TETSIM_MPI_STATS` and docs/scaling.md.
    #[derive(Clone, Debug, Default, PartialEq)]
    pub struct Stats {
        /// This rank and the number of ranks.
        pub rank: usize,
        /// Number of ranks.
        pub ranks: usize,
        /// Tets this rank evaluates.
        pub tets: usize,
        /// Vertices it owns (matrix block rows).
        pub owned: usize,
        /// Its ghost vertices.
        pub ghosts: usize,
        /// Linear solves, CG iterations and seconds in them.
        pub solves: usize,
        /// CG iterations over all solves.
        pub cg_iterations: usize,
        /// Seconds in PETSc's KSPSolve.
        pub solve_seconds: f64,
        /// Seconds assembling the PETSc matrix and setting up its preconditioner.
        pub setup_seconds: f64,
        /// Bytes PETSc sent from this rank inside KSPSolve (matrix products, V-cycles,
        /// reductions: PETSc's logged sends).
        pub petsc_solve_bytes: f64,
        /// Bytes PETSc sent assembling the matrix (other ranks' rows of this rank's tets) and
        /// setting up the preconditioner (GAMG's coarsening and Galerkin products).
        pub petsc_setup_bytes: f64,
        /// Bytes this rank sent in the elasticity all-gathers (forces, K·v, energy).
        pub exchange_bytes: f64,
        /// Elasticity evaluations (one per Newton iterate and line-search trial).
        pub evaluations: usize,
    }

    static STATS: Mutex<Option<Stats>> = Mutex::new(None);

    /// Update this rank's statistics.
    pub(crate) fn record(f: impl FnOnce(&mut Stats)) {
        if let Some(s) = STATS.lock().expect("stats lock").as_mut() {
            f(s)
        }
    }

    /// This rank's statistics so far (None before [`distribute`]).
    pub fn stats() -> Option<Stats> {
        STATS.lock().expect("stats lock").clone()
    }

    /// Rank-ordered all-gather over MPI.
    struct MpiGather(Comm);

    impl Gather for MpiGather {
        fn rank(&self) -> usize {
            self.0.0.rank() as usize
        }
        fn size(&self) -> usize {
            self.0.0.size() as usize
        }
        fn all_gather(&mut self, local: &[f64], counts: &[usize], out: &mut [f64]) {
            let counts: Vec<i32> = counts.iter().map(|&c| c as i32).collect();
            let displs: Vec<i32> = counts
                .iter()
                .scan(0, |at, &c| {
                    let d = *at;
                    *at += c;
                    Some(d)
                })
                .collect();
            let mut partition = PartitionMut::new(out, &counts[..], &displs[..]);
            self.0.0.all_gather_varcount_into(local, &mut partition);
            let bytes = (8 * local.len() * (counts.len() - 1)) as f64;
            record(|s| s.exchange_bytes += bytes);
        }
    }

    /// Put `sim` on the ranks of `world`: partition its mesh, give Newton this rank's part of
    /// the elasticity and a PETSc solver (KSP with preconditioner `pc`, then the options
    /// database). Every rank must call it with the same simulation.
    pub fn distribute(
        sim: &mut Simulation,
        world: SimpleCommunicator,
        petsc: &Petsc,
        pc: &str,
    ) -> Result<(), PetscError> {
        let rank = world.rank() as usize;
        let size = world.size() as usize;
        let mesh = &sim.body.mesh;
        let partition = Partition::new(mesh, size);
        let parts: Vec<Part> = (0..size).map(|r| partition.part(mesh, r)).collect();
        let (order, position) = partition.global_order();
        let counts = partition.owned_counts();
        let offset: usize = counts[..rank].iter().sum();
        let owned: Vec<usize> = order[offset..offset + counts[rank]].to_vec();
        // Preallocation from the mesh's vertex adjacency: blocks in this rank's columns and
        // in others', per owned row.
        let pattern = BlockPattern::from_tets(mesh.positions.len(), &mesh.tets);
        let (mut diagonal, mut off) = (Vec::new(), Vec::new());
        for &v in &owned {
            let row = pattern.row(v);
            let cols = &pattern.cols[row];
            let mine = cols
                .iter()
                .filter(|&&c| partition.vertex_owner[c as usize] as usize == rank)
                .count();
            diagonal.push(mine);
            off.push(cols.len() - mine);
        }
        drop(pattern);
        let comm = world.as_raw();
        let matrix = Matrix::new(petsc, comm, order.len(), &diagonal, &off)?;
        let mut coords = Vector::new(petsc, comm, owned.len(), order.len())?;
        let rest: Vec<f64> = owned
            .iter()
            .flat_map(|&v| {
                let p = mesh.positions[v];
                [p.x, p.y, p.z]
            })
            .collect();
        let shared = Arc::new(Mutex::new(Shared::new(matrix, position.clone())));
        shared
            .lock()
            .expect("fresh")
            .matrix
            .set_rigid_body_modes(&mut coords, &rest)?;
        let ksp = Ksp::new(petsc, comm, pc)?;
        let b = Vector::new(petsc, comm, owned.len(), order.len())?;
        let x = Vector::new(petsc, comm, owned.len(), order.len())?;
        let to_all = ToAll::new(&x)?;
        *STATS.lock().expect("stats lock") = Some(Stats {
            rank,
            ranks: size,
            tets: parts[rank].tets.len(),
            owned: owned.len(),
            ghosts: parts[rank].ghosts().len(),
            ..Default::default()
        });
        let solver = PetscSolver::new(
            petsc.clone(),
            shared.clone(),
            ksp,
            (b, x, to_all),
            owned,
            offset,
            position,
        );
        let pe =
            PartitionedElasticity::new(&sim.body, parts, Box::new(MpiGather(Comm(world))), shared);
        let elasticity = Elasticity::partitioned(&sim.body, sim.params.definiteness, pe);
        let newton = sim.newton_mut();
        newton.potential_mut().elasticity = elasticity;
        newton.set_linear_solver(Box::new(solver));
        Ok(())
    }
}
