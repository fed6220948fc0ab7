//! `mpirun -n N tetsim run SCENE` (feature `mpi`): rank 0 runs `tetsim run` as usual: it reads
//! the scene and the mesh, sends every rank its part, and writes every file from the state it
//! gathers; the other ranks read only the scene file's settings and receive their part. All of
//! them step their own part and solve with PETSc (see `tetsim::parallel`). A failure on any
//! rank aborts the job (the others would wait for it forever).

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
    let result = if args.resume.is_some() {
        Err(anyhow::anyhow!(
            "--resume is not supported under mpirun yet; resume without mpirun"
        ))
    } else if rank == 0 {
        super::run::run(args, quiet, verbose)
    } else {
        worker(args)
    };
    if let Some(stats) = tetsim::parallel::stats()
        && std::env::var_os("TETSIM_MPI_STATS").is_some()
    {
        // Peak resident memory of this rank (Linux: VmHWM).
        let peak = std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("VmHWM:"))
                    .map(|l| l.trim_start_matches("VmHWM:").trim().to_string())
            })
            .unwrap_or_default();
        // One write, so that mpirun does not interleave the ranks' lines.
        let line = format!("mpi stats: {stats:?}, peak RSS {peak}\n");
        use std::io::Write;
        let _ = std::io::stderr().lock().write_all(line.as_bytes());
    }
    match result {
        Ok(code) if code == ExitCode::SUCCESS => Ok(code),
        Ok(_) => world.abort(1),
        Err(e) => {
            // Rank 0 reports; every rank stops the job.
            if rank == 0 || !e.to_string().is_empty() {
                eprintln!("error (rank {rank}): {e:#}");
            }
            world.abort(1)
        }
    }
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

/// On rank 0: put `sim` (the whole scene) on the ranks when started by mpirun (nothing
/// otherwise). Refuses contact, which is not distributed yet.
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
    let params = sim.params.clone();
    tetsim::parallel::distribute(Some(sim), world, &petsc, "gamg", params)
        .context("distributing the simulation over the MPI ranks")?;
    Ok(())
}

/// A rank other than 0: reads the scene file's settings (not its mesh), receives its part from
/// rank 0 and steps it; writes nothing. A frame that fails fails on every rank alike (their
/// decisions are made on the same sums).
fn worker(args: RunArgs) -> anyhow::Result<ExitCode> {
    let scene = load(&args)?;
    let petsc = Petsc::init(&scene.solver.petsc_options).context("initialising PETSc")?;
    let world = mpi::topology::SimpleCommunicator::world();
    let mut driver =
        tetsim::parallel::distribute(None, world, &petsc, "gamg", scene.solver_params())
            .context("receiving this rank's part")?
            .expect("a rank other than 0 drives its own part");
    let mut nothing = tetsim::State::default();
    while !driver.is_finished() {
        tetsim::parallel::Driver::step(&mut driver, &mut nothing)?;
    }
    Ok(ExitCode::SUCCESS)
}
