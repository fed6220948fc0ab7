//! Past one machine (SPEC §15): the same scene on many MPI ranks, with PETSc solving Newton's
//! linear systems.
//!
//! **What each rank holds.** The tets are split over the ranks ([`partition`]); each vertex is
//! owned by one rank, and the other vertices of a rank's tets are its ghost layer. Rank 0 reads
//! the scene and the mesh, partitions it and sends every rank only its part ([`wire`]): its
//! tets with their rest data, its vertices (owned first, then ghosts) with the whole body's
//! masses of the owned ones, its share of the constraints and loads, and how its vertices map
//! to the rows of the distributed matrix and to the other ranks' vertices. Each rank then runs
//! an ordinary [`crate::Simulation`] of its part: the same Newton, line search, definiteness
//! policy, loads, constraints and energy audit as a serial run, on vectors of its own and ghost
//! vertices only (O(part) memory, nothing of size O(whole) on ranks other than 0).
//!
//! **The design: ghosts that no sum counts.** Ghost entries carry positions and velocities
//! equal to their owners' (the local tets need them), and zero in everything that is summed:
//! mass, loads, elastic forces, K·v, hence the right-hand side. Every sum the serial code makes
//! over a rank's vectors is then a sum over the vertices it owns, and the serial code stays as
//! it is with a handful of hooks: the sums Newton and the simulation decide on (residual,
//! potential, slopes, the absolute floor, kinetic energy, min J, the audit) go through
//! [`Ranks::sum`] and [`Ranks::max`], which add the ranks' partial sums in rank order (an
//! all-gather of a few numbers, then the same additions on every rank: the same bits on every
//! rank and on every run with the same rank count), so every rank takes the same decisions and
//! makes the same collective calls. Two halo exchanges do the rest ([`Ranks::complete`]: the
//! ghosts' element forces are added to their owners, in rank order, then zeroed; and
//! [`Ranks::share`]: the owners' solution is copied to their ghosts). The alternative, an
//! abstraction over every vector operation of Newton (a distributed vector type), would have
//! rewritten Newton, the line search and the audit; this one adds reductions at the dozen
//! places that compute a number, and each of them is a no-op in a serial run (bit-identical).
//!
//! **Linear solves.** Each rank adds only its tets' element matrices into a distributed PETSc
//! matrix (AIJ with block size 3; rows owned by the vertices' ranks) and PETSc's Krylov solver
//! (CG with GAMG by default) solves Newton's systems ([`solver`]); the solution is copied to
//! the ghosts.
//!
//! **Output.** Rank 0 keeps the whole mesh and gathers the owned positions and velocities of
//! every rank at each frame ([`Driver`]), and writes the serial run's file set from them. That
//! makes rank 0 O(whole) in memory (the mesh read, the serial set-up, the file writer); the
//! other ranks are O(part). docs/scaling.md measures both.
//!
//! Files: [`partition`] (who owns what; plain Rust), [`elastic`] (the elasticity term's halo and
//! matrix hooks), [`wire`] (rank 0's set-up of each rank's part, plain Rust, tested without
//! MPI); with the feature `mpi`, [`petsc`] (the FFI, all the `unsafe`), [`solver`] (the
//! [`crate::linear::LinearSolver`] on PETSc) and `setup` ([`distribute`]: MPI's side of it).

pub mod elastic;
#[cfg(feature = "mpi")]
#[allow(unsafe_code)]
pub mod metis;
pub mod partition;
#[cfg(feature = "mpi")]
#[allow(unsafe_code)]
pub mod petsc;
#[cfg(feature = "mpi")]
pub(crate) mod setup;
#[cfg(feature = "mpi")]
pub mod solver;
pub mod wire;

#[cfg(feature = "mpi")]
pub use setup::{Stats, distribute, stats};

use crate::integrator::StepStats;
use crate::math::Vec3;
use crate::sim::State;

/// The collective operations one rank's part needs (MPI's in a distributed run). Every rank
/// must call them in the same order.
pub trait Ranks: Send + Sync {
    /// Add each of `values` over the ranks: the ranks' numbers are gathered and added in rank
    /// order, so every rank gets the same bits.
    fn sum(&self, values: &mut [f64]);
    /// The largest of each of `values` over the ranks.
    fn max(&self, values: &mut [f64]);
    /// Vertices of the whole body.
    fn vertex_count(&self) -> usize;
    /// The whole mesh's mean edge length, m.
    fn mean_edge_length(&self) -> f64;
    /// Per-vertex numbers (`width` per vertex, this rank's vertices: owned, then ghosts): add
    /// the ghosts' values to their owners' (the owner's own first, then the other ranks' in
    /// rank order), then zero the ghosts.
    fn complete(&self, values: &mut [f64], width: usize);
    /// Per-vertex numbers: copy the owners' values to their ghosts.
    fn share(&self, values: &mut [f64], width: usize);
}

/// [`Ranks::complete`] on vectors.
pub fn complete_vectors(ranks: &dyn Ranks, values: &mut [Vec3]) {
    let mut flat: Vec<f64> = values.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
    ranks.complete(&mut flat, 3);
    for (v, f) in values.iter_mut().zip(flat.chunks_exact(3)) {
        *v = Vec3::new(f[0], f[1], f[2]);
    }
}

/// [`Ranks::share`] on vectors.
pub fn share_vectors(ranks: &dyn Ranks, values: &mut [Vec3]) {
    let mut flat: Vec<f64> = values.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
    ranks.share(&mut flat, 3);
    for (v, f) in values.iter_mut().zip(flat.chunks_exact(3)) {
        *v = Vec3::new(f[0], f[1], f[2]);
    }
}

/// What steps a distributed simulation: advances every rank's part by one frame and, on rank
/// 0, gathers the whole state into `whole`.
pub trait Driver: Send {
    /// One frame.
    fn step(&mut self, whole: &mut State) -> crate::error::Result<StepStats>;
}
