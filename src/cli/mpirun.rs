//! `mpirun -n N tetsim run SCENE` (feature `mpi`): rank 0 runs `tetsim run` as usual (it writes
//! every file), the other ranks run the same frames without writing; all of them evaluate
//! their own tets and solve with PETSc (see `tetsim::parallel`).

use std::process::ExitCode;

use anyhow::Context;
use mpi::traits::*;
use tetsim::parallel::petsc::Petsc;
use tetsim::{Scene, Simulation};

use super::run::RunArgs;

/// Whether this process was started by mpirun (Open MPI or an MPICH-style launcher).
pub fn launched() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE"]
        .iter()
        .any(|k| std::env::var_os(k).is_some())
}

/// Run on every rank; MPI lives for the whole run (PETSc and the simulation are gone before it
/// finalises).
pub fn run(args: RunArgs, quiet: bool, verbose: u8) -> anyhow::Result<ExitCode> {
    let universe = mpi::initialize().context("MPI could not be initialised")?;
    let world = universe.world();
    let rank = world.rank();
    let result = if rank == 0 {
        super::run::run(args, quiet, verbose)
    } else {
        worker(args)
    };
    if let Some(stats) = tetsim::parallel::stats()
        && std::env::var_os("TETSIM_MPI_STATS").is_some()
    {
        eprintln!("mpi stats: {stats:?}");
    }
    result
}

/// The scene as `tetsim run` reads it, with the same overrides.
pub fn load(args: &RunArgs) -> anyhow::Result<Scene> {
    let mut scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default(),
    };
    scene.mesh.force |= args.force;
    if let Some(frames) = args.frames {
        anyhow::ensure!(frames > 0, "--frames must be at least 1");
        scene.solver.frames = frames;
    }
    Ok(scene)
}

/// Put `sim` on the ranks when started by mpirun (nothing otherwise). Refuses contact, which
/// is not distributed yet.
pub fn attach(sim: &mut Simulation, scene: &Scene) -> anyhow::Result<()> {
    if !launched() {
        return Ok(());
    }
    anyhow::ensure!(
        sim.contact_setup().is_none(),
        "this scene has obstacles: contact is not distributed yet under mpirun; run it without mpirun"
    );
    let petsc = Petsc::init(&scene.solver.petsc_options).context("initialising PETSc")?;
    let world = mpi::topology::SimpleCommunicator::world();
    tetsim::parallel::distribute(sim, world, &petsc, "gamg")
        .context("distributing the simulation over the MPI ranks")?;
    Ok(())
}

/// A rank other than 0: the same frames, nothing written. A scene that fails to load fails on
/// every rank alike (rank 0 reports it); a frame that fails stops every rank alike.
fn worker(args: RunArgs) -> anyhow::Result<ExitCode> {
    let Ok(scene) = load(&args) else {
        return Ok(ExitCode::FAILURE);
    };
    let Ok(mut sim) = Simulation::from_scene(&scene) else {
        return Ok(ExitCode::FAILURE);
    };
    if attach(&mut sim, &scene).is_err() {
        return Ok(ExitCode::FAILURE);
    }
    while !sim.is_finished() {
        if sim.step().is_err() {
            return Ok(ExitCode::FAILURE);
        }
    }
    Ok(ExitCode::SUCCESS)
}
