//! `tetsim bench`: the benchmark cantilever workload at several sizes (see `tetsim::bench`).

use std::path::PathBuf;
use std::process::ExitCode;

use tetsim::bench::{self, BenchParams};
use tetsim::mesh::ordering::VertexOrder;

/// Arguments of `tetsim bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Mesh sizes n (4n×n×n cubes, 24n³ tets).
    #[arg(long, value_delimiter = ',', default_value = "6,12,20")]
    pub sizes: Vec<usize>,
    /// Frames per run (the workload has 30).
    #[arg(long, default_value_t = 30)]
    pub frames: usize,
    /// Runs per size (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Extra `[solver]` settings, e.g. --solver 'preconditioner = "block-jacobi"'.
    #[arg(long, default_value = "")]
    pub solver: String,
    /// Internal vertex order: auto (default; the generator's x-fastest order), rcm, morton, none
    /// or random (a shuffled mesh: what a badly numbered input costs).
    #[arg(long, default_value = "auto", value_parser = parse_order)]
    pub reorder: VertexOrder,
    /// Element order of the beam: 1 (linear tets) or 2 (quadratic tets; `--sizes 6` has the
    /// nodes of linear `--sizes 12`, for comparisons per degree of freedom).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub order: u8,
    /// The contact workload: the beam droops onto a ground plane (IPC barrier, friction 0.3);
    /// compare with the same sizes without it for the cost of contact.
    #[arg(long)]
    pub contact: bool,
    /// The scene: beam (the cantilever, default), stack (three soft blocks on the ground,
    /// 9n³ tets: n = 18 is 52k, 28 is 198k) or coil (a beam twisted until it coils, 96n³ tets:
    /// n = 8 is 49k, 13 is 211k; it coils from about frame 150: use --frames 250); stack and coil
    /// always have contact.
    #[arg(long, default_value = "beam", value_parser = parse_workload)]
    pub workload: bench::Workload,
    /// Time only the step loop: skip the whole run with outputs that each size gets once.
    #[arg(long)]
    pub loop_only: bool,
    /// Print JSON instead of the table (to stdout), for comparing runs.
    #[arg(long)]
    pub json: bool,
    /// Also write the JSON report to this file.
    #[arg(long)]
    pub save: Option<PathBuf>,
}

pub fn run(args: BenchArgs, quiet: bool) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        args.repeats > 0 && args.frames > 0,
        "--repeats and --frames must be at least 1"
    );
    let params = BenchParams {
        sizes: args.sizes,
        frames: args.frames,
        repeats: args.repeats,
        solver_overrides: args.solver,
        reorder: args.reorder,
        order: args.order,
        contact: args.contact,
        workload: args.workload,
        whole: !args.loop_only,
    };
    let report = bench::run(&params, |line| {
        if !quiet {
            eprintln!("{line}");
        }
    })?;
    let json = serde_json::to_string_pretty(&report)?;
    if let Some(path) = &args.save {
        std::fs::write(path, &json).map_err(|e| tetsim::Error::io(path, e))?;
    }
    if args.json {
        println!("{json}");
    } else {
        print!("{}", report.table());
    }
    Ok(ExitCode::SUCCESS)
}

fn parse_order(name: &str) -> Result<VertexOrder, String> {
    VertexOrder::from_name(name)
        .ok_or_else(|| format!("{name:?}: expected auto, rcm, morton, none or random"))
}

fn parse_workload(name: &str) -> Result<bench::Workload, String> {
    bench::Workload::from_name(name)
        .ok_or_else(|| format!("{name:?}: expected beam, stack or coil"))
}
