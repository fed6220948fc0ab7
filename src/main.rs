//! The `tetsim` command: parse arguments, set up logging, dispatch, map errors to an exit code.

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Large elastic deformation on tetrahedral meshes.
#[derive(Debug, Parser)]
#[command(name = "tetsim", version)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Check and convert meshes.
    #[command(subcommand)]
    Mesh(cli::mesh::MeshCommand),
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info")).init();
    let args = Args::parse();
    let result = match args.command {
        Command::Mesh(cmd) => cli::mesh::run(cmd),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
