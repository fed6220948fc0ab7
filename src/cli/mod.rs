//! Subcommands: argument structs and dispatch, no physics.

mod bench;
mod check;
mod compare;
mod info;
pub mod mesh;
mod modes;
#[cfg(feature = "mpi")]
mod mpirun;
mod render;
mod run;
mod saved;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// tetsim: large elastic deformation on tetrahedral meshes.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
pub struct Cli {
    /// Print only errors.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// More log output (-v: one line per frame, -vv: one per Newton iteration, -vvv: everything).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    pub threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene (no SCENE: the built-in default scene) and write frames.
    Run(run::RunArgs),
    /// The lowest vibration modes of the scene's body at rest: modes.csv, mode_NN.vtu, GIFs.
    Modes(modes::ModesArgs),
    /// Check and convert meshes.
    #[command(subcommand)]
    Mesh(mesh::MeshCommand),
    /// Re-render a saved run (its frames.pvd and VTU frames) into preview.png and animation.gif.
    Render(render::RenderArgs),
    /// Run a scene with several definiteness strategies and tabulate their cost.
    Compare(compare::CompareArgs),
    /// Check derivatives (forces, stiffness) against finite differences on a scene's material.
    Check(check::CheckArgs),
    /// Time the benchmark cantilever (a 4 × 1 × 1 m beam drooping under gravity) at several mesh
    /// sizes.
    Bench(bench::BenchArgs),
    /// Describe a scene without running it: mass, volume, wave speeds, the lowest frequency
    /// (estimated) and suggested time steps.
    Info(info::InfoArgs),
}

/// Log level from -q/-v (RUST_LOG overrides).
pub fn init_logging(cli: &Cli) {
    let level = match (cli.quiet, cli.verbose) {
        (true, _) => "error",
        (false, 0) => "warn",
        (false, 1) => "info",
        (false, 2) => "debug",
        _ => "trace",
    };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(level))
        .format_timestamp(None)
        .init();
}

/// Dispatch.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    if let Some(threads) = cli.threads {
        anyhow::ensure!(threads > 0, "--threads must be at least 1");
        // More threads than cores only adds switching and waiting (2 frames of the default
        // scene took 19 s at --threads 1000 against 0.3 s on 2 cores).
        let cores = tetsim::resources::available_cores();
        let threads = if threads > cores {
            log::warn!(
                "--threads {threads}: only {cores} core(s) are available to tetsim; using {cores}"
            );
            cores
        } else {
            threads
        };
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()?;
    }
    match cli.command {
        #[cfg(feature = "mpi")]
        Command::Run(args) if mpirun::launched() => mpirun::run(args, cli.quiet, cli.verbose),
        Command::Run(args) => run::run(args, cli.quiet, cli.verbose),
        Command::Modes(args) => modes::run(args, cli.quiet),
        Command::Mesh(cmd) => mesh::run(cmd).map(|()| ExitCode::SUCCESS),
        Command::Render(args) => render::run(args, cli.quiet),
        Command::Compare(args) => compare::run(args, cli.quiet),
        Command::Bench(args) => bench::run(args, cli.quiet),
        Command::Check(args) => check::run(args),
        Command::Info(args) => info::run(args).map(|()| ExitCode::SUCCESS),
    }
}
