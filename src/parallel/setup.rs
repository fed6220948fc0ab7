//! MPI's side of a distributed run: the [`Ranks`] over a communicator ([`MpiRanks`]), the set-up
//! that sends every rank its part and gives its simulation PETSc's solver ([`distribute`]), and
//! the [`Driver`] that steps the parts and gathers the whole state on rank 0.

use std::sync::{Arc, Mutex};

use mpi::datatype::{Partition as Parted, PartitionMut};
use mpi::raw::AsRaw;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

use super::elastic::Ghosts;
use super::partition::Partition;
use super::petsc::{Comm, Ksp, Matrix, Petsc, Vector};
use super::solver::{PetscSolver, Shared};
use super::wire::{self, RankSetup, Whole};
use super::{Driver, Ranks};
use crate::integrator::terms::Elasticity;
use crate::integrator::{SolverParams, StepStats};
use crate::math::Vec3;
use crate::sim::{Simulation, State};

/// What one rank did, for `TETSIM_MPI_STATS` and docs/scaling.md.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// This rank.
    pub rank: usize,
    /// Number of ranks.
    pub ranks: usize,
    /// Tets this rank evaluates.
    pub tets: usize,
    /// Vertices it owns (matrix block rows).
    pub owned: usize,
    /// Its ghost vertices.
    pub ghosts: usize,
    /// Bytes of the set-up it received from rank 0 (rank 0: sent to all).
    pub setup_bytes: usize,
    /// Linear solves.
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
    /// Bytes PETSc sent assembling the matrix and setting up the preconditioner.
    pub petsc_setup_bytes: f64,
    /// Bytes this rank sent in halo exchanges (forces completed, solutions shared).
    pub halo_bytes: f64,
    /// Halo exchanges.
    pub halo_exchanges: usize,
    /// Bytes this rank sent in the reductions (sums and maxima of a few numbers).
    pub reduction_bytes: f64,
    /// Reductions.
    pub reductions: usize,
    /// Bytes this rank sent to rank 0 in the per-frame gathers of the state.
    pub gather_bytes: f64,
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

fn displacements(counts: &[i32]) -> Vec<i32> {
    counts
        .iter()
        .scan(0, |at, &c| {
            let d = *at;
            *at += c;
            Some(d)
        })
        .collect()
}

/// The ranks of a communicator, with this rank's halo.
pub struct MpiRanks {
    comm: Comm,
    size: usize,
    owned: usize,
    vertices: usize,
    mean_edge: f64,
    /// (rank, local ghosts it owns, local owned vertices that are its ghosts).
    neighbours: Vec<(usize, Vec<usize>, Vec<usize>)>,
}

impl MpiRanks {
    fn gather(&self, values: &[f64]) -> Vec<f64> {
        let mut all = vec![0.0; values.len() * self.size];
        self.comm.0.all_gather_into(values, &mut all[..]);
        let bytes = (8 * values.len() * (self.size - 1)) as f64;
        record(|s| {
            s.reduction_bytes += bytes;
            s.reductions += 1;
        });
        all
    }

    /// Send `width` numbers of the `send` vertices to each neighbour, receive theirs for the
    /// `recv` vertices (MPI_Alltoallv; nothing to or from the other ranks).
    fn exchange(
        &self,
        values: &[f64],
        width: usize,
        send_list: impl Fn(&(usize, Vec<usize>, Vec<usize>)) -> &Vec<usize>,
        recv_list: impl Fn(&(usize, Vec<usize>, Vec<usize>)) -> &Vec<usize>,
    ) -> Vec<f64> {
        let (mut scounts, mut rcounts) = (vec![0i32; self.size], vec![0i32; self.size]);
        let mut send = Vec::new();
        for nb in &self.neighbours {
            let list = send_list(nb);
            scounts[nb.0] = (width * list.len()) as i32;
            rcounts[nb.0] = (width * recv_list(nb).len()) as i32;
            for &k in list {
                send.extend_from_slice(&values[width * k..width * (k + 1)]);
            }
        }
        let mut recv = vec![0.0; rcounts.iter().sum::<i32>() as usize];
        let (sd, rd) = (displacements(&scounts), displacements(&rcounts));
        {
            let sp = Parted::new(&send[..], &scounts[..], &sd[..]);
            let mut rp = PartitionMut::new(&mut recv[..], &rcounts[..], &rd[..]);
            self.comm.0.all_to_all_varcount_into(&sp, &mut rp);
        }
        let bytes = (8 * send.len()) as f64;
        record(|s| {
            s.halo_bytes += bytes;
            s.halo_exchanges += 1;
        });
        recv
    }
}

impl Ranks for MpiRanks {
    fn sum(&self, values: &mut [f64]) {
        let all = self.gather(values);
        values.iter_mut().for_each(|v| *v = 0.0);
        for chunk in all.chunks_exact(values.len().max(1)) {
            for (v, c) in values.iter_mut().zip(chunk) {
                *v += c;
            }
        }
    }

    fn max(&self, values: &mut [f64]) {
        let all = self.gather(values);
        for chunk in all.chunks_exact(values.len().max(1)) {
            for (v, c) in values.iter_mut().zip(chunk) {
                *v = v.max(*c);
            }
        }
    }

    fn vertex_count(&self) -> usize {
        self.vertices
    }

    fn mean_edge_length(&self) -> f64 {
        self.mean_edge
    }

    fn complete(&self, values: &mut [f64], width: usize) {
        let recv = self.exchange(values, width, |nb| &nb.1, |nb| &nb.2);
        let mut at = 0;
        for nb in &self.neighbours {
            for &k in &nb.2 {
                for c in 0..width {
                    values[width * k + c] += recv[at + c];
                }
                at += width;
            }
        }
        values[width * self.owned..]
            .iter_mut()
            .for_each(|v| *v = 0.0);
    }

    fn share(&self, values: &mut [f64], width: usize) {
        let recv = self.exchange(values, width, |nb| &nb.2, |nb| &nb.1);
        let mut at = 0;
        for nb in &self.neighbours {
            for &k in &nb.1 {
                values[width * k..width * (k + 1)].copy_from_slice(&recv[at..at + width]);
                at += width;
            }
        }
    }
}

/// Steps this rank's part; on rank 0 gathers the whole state.
pub struct MpiDriver {
    local: Simulation,
    comm: Comm,
    owned: usize,
    /// Rank 0: the whole-body vertex of each gathered entry, and each rank's owned count.
    order: Option<(Vec<usize>, Vec<usize>)>,
}

impl MpiDriver {
    /// Whether every frame is done.
    pub fn is_finished(&self) -> bool {
        self.local.is_finished()
    }

    /// This rank's simulation.
    pub fn local(&self) -> &Simulation {
        &self.local
    }
}

impl Driver for MpiDriver {
    fn step(&mut self, whole: &mut State) -> crate::error::Result<StepStats> {
        let stats = self.local.step()?;
        let s = &self.local.state;
        let mine: Vec<f64> = (0..self.owned)
            .flat_map(|k| {
                let (x, v) = (s.x[k], s.v[k]);
                [x.x, x.y, x.z, v.x, v.y, v.z]
            })
            .collect();
        let root = self.comm.0.process_at_rank(0);
        match &self.order {
            Some((order, counts)) => {
                let counts: Vec<i32> = counts.iter().map(|&c| 6 * c as i32).collect();
                let displs = displacements(&counts);
                let mut all = vec![0.0; 6 * order.len()];
                {
                    let mut p = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
                    root.gather_varcount_into_root(&mine[..], &mut p);
                }
                for (k, &v) in order.iter().enumerate() {
                    let a = &all[6 * k..6 * k + 6];
                    whole.x[v] = Vec3::new(a[0], a[1], a[2]);
                    whole.v[v] = Vec3::new(a[3], a[4], a[5]);
                }
                whole.t = s.t;
            }
            None => {
                root.gather_varcount_into(&mine[..]);
                let bytes = (8 * mine.len()) as f64;
                record(|st| st.gather_bytes += bytes);
            }
        }
        Ok(stats)
    }
}

/// METIS's partition of `mesh` over `ranks` (recursive coordinate bisection instead when
/// `TETSIM_PARTITIONER=rcb`, for comparisons: see docs/scaling.md).
fn partition(mesh: &crate::mesh::TetMesh, ranks: usize) -> Result<Partition, String> {
    if mesh.is_quadratic() {
        return Err(
            "quadratic tets ([mesh] order = 2 or a 10-node mesh file) run on one \
                    process for now: run without mpirun"
                .to_string(),
        );
    }
    if std::env::var("TETSIM_PARTITIONER").is_ok_and(|p| p == "rcb") {
        return Ok(Partition::new(mesh, ranks));
    }
    let (tet_part, _) = super::metis::partition_tets(mesh.positions.len(), &mesh.tets, ranks)?;
    Ok(Partition::from_tet_parts(mesh, ranks, tet_part))
}

/// Why distributing failed.
#[derive(Debug, thiserror::Error)]
pub enum DistributeError {
    /// A PETSc call failed.
    #[error(transparent)]
    Petsc(#[from] super::petsc::PetscError),
    /// The parts could not be made.
    #[error("{0}")]
    Setup(String),
}

/// Put a simulation on the ranks of `world`. On rank 0 `whole` is the scene's simulation,
/// built as a serial run builds it: it is partitioned, every rank gets its part, and `whole`
/// is handed a [`Driver`] (it then only gathers and writes). Other ranks pass None and get
/// their driver back. `params` are the scene's solver settings; `pc` PETSc's preconditioner
/// (then the options database). Every rank must call it.
pub fn distribute(
    whole: Option<&mut Simulation>,
    world: SimpleCommunicator,
    petsc: &Petsc,
    pc: &str,
    params: SolverParams,
) -> Result<Option<MpiDriver>, DistributeError> {
    let rank = world.rank() as usize;
    let size = world.size() as usize;
    let root = world.process_at_rank(0);
    let mut order = None;
    let (setup, setup_bytes) = match &whole {
        Some(sim) => {
            let partition = partition(&sim.body.mesh, size).map_err(DistributeError::Setup)?;
            let whole = Whole {
                body: &sim.body,
                boundary: &sim.boundary,
                state: &sim.state,
                params: &sim.params,
            };
            let cutter = match wire::Cutter::new(&whole, &partition) {
                Ok(c) => c,
                Err(e) => {
                    // Tell the others (an empty message) before failing.
                    for r in 1..size {
                        world.process_at_rank(r as i32).send(&[0u8; 0][..]);
                    }
                    return Err(DistributeError::Setup(e));
                }
            };
            // One rank's set-up at a time: rank 0 never holds them all.
            let mut sent = 0;
            for r in 1..size {
                let bytes = cutter.setup(r).to_bytes();
                sent += bytes.len();
                world.process_at_rank(r as i32).send(&bytes[..]);
            }
            let mine = cutter.setup(0);
            drop(cutter);
            let (global, _) = partition.global_order();
            order = Some((global, partition.owned_counts()));
            (mine, sent)
        }
        None => {
            let (bytes, _) = root.receive_vec::<u8>();
            if bytes.is_empty() {
                return Err(DistributeError::Setup(
                    "rank 0 could not make the parts".into(),
                ));
            }
            let n = bytes.len();
            (
                RankSetup::from_bytes(&bytes).map_err(DistributeError::Setup)?,
                n,
            )
        }
    };
    let mut local = setup.simulation(params).map_err(DistributeError::Setup)?;
    let owned = setup.owned as usize;
    let comm = world.as_raw();
    let ranks = Arc::new(MpiRanks {
        comm: Comm(SimpleCommunicator::world()),
        size,
        owned,
        vertices: setup.total_vertices as usize,
        mean_edge: setup.mean_edge_length,
        neighbours: setup
            .neighbours
            .iter()
            .map(|(r, g, s)| {
                (
                    *r as usize,
                    g.iter().map(|&k| k as usize).collect(),
                    s.iter().map(|&k| k as usize).collect(),
                )
            })
            .collect(),
    });
    let total = setup.total_vertices as usize;
    let diagonal: Vec<usize> = setup.diagonal.iter().map(|&k| k as usize).collect();
    let off: Vec<usize> = setup.off.iter().map(|&k| k as usize).collect();
    let matrix = Matrix::new(petsc, comm, total, &diagonal, &off)?;
    let mut coords = Vector::new(petsc, comm, owned, total)?;
    let rest: Vec<f64> = setup.positions[..owned].iter().flat_map(|p| *p).collect();
    let shared = Arc::new(Mutex::new(Shared::new(matrix)));
    shared
        .lock()
        .expect("fresh")
        .matrix
        .set_rigid_body_modes(&mut coords, &rest)?;
    let ksp = Ksp::new(petsc, comm, pc)?;
    let b = Vector::new(petsc, comm, owned, total)?;
    let x = Vector::new(petsc, comm, owned, total)?;
    *STATS.lock().expect("stats lock") = Some(Stats {
        rank,
        ranks: size,
        tets: setup.tets.len(),
        owned,
        ghosts: setup.positions.len() - owned,
        setup_bytes,
        ..Default::default()
    });
    let rows: Vec<usize> = setup.rows.iter().map(|&r| r as usize).collect();
    let solver = PetscSolver::new(
        petsc.clone(),
        shared.clone(),
        ksp,
        (b, x),
        owned,
        setup.first_row as usize,
        ranks.clone(),
    );
    drop(setup);
    let definiteness = local.params.definiteness;
    let elasticity = Elasticity::partitioned(
        &local.body,
        definiteness,
        Ghosts::new(ranks.clone(), shared, rows),
    );
    let newton = local.newton_mut();
    newton.potential_mut().elasticity = elasticity;
    newton.set_linear_solver(Box::new(solver));
    local.set_ranks(ranks);
    let driver = MpiDriver {
        local,
        comm: Comm(world),
        owned,
        order,
    };
    Ok(match whole {
        Some(sim) => {
            sim.set_driver(Box::new(driver));
            None
        }
        None => Some(driver),
    })
}
