//! `tetsim compare SCENE --definiteness adaptive,teran,analytic,abs,none`: run one scene with each
//! definiteness strategy and tabulate what it cost (nothing is written to disk).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use tetsim::{Definiteness, Scene, Simulation};

/// Arguments of `tetsim compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// Scene file (TOML). Without it, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Strategies to compare (teran, analytic, abs, none).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "adaptive,teran,analytic,abs,none"
    )]
    pub definiteness: Vec<String>,
    /// Number of frames (overrides [solver] frames).
    #[arg(long)]
    pub frames: Option<usize>,
}

/// One row of the table.
struct Row {
    name: &'static str,
    frames: usize,
    newton: usize,
    cg: usize,
    seconds: f64,
    energy: f64,
    clamped_per_step: f64,
    unconverged: usize,
    breakdowns: usize,
    error: Option<String>,
}

pub fn run(args: CompareArgs, quiet: bool) -> anyhow::Result<ExitCode> {
    let mut scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default(),
    };
    if let Some(frames) = args.frames {
        anyhow::ensure!(frames > 0, "--frames must be at least 1");
        scene.solver.frames = frames;
    }
    let strategies: Vec<Definiteness> = args
        .definiteness
        .iter()
        .map(|name| {
            Definiteness::from_name(name).ok_or_else(|| {
                let names: Vec<&str> = Definiteness::ALL.iter().map(|d| d.name()).collect();
                anyhow::anyhow!("unknown strategy {name:?}: expected {}", names.join(", "))
            })
        })
        .collect::<anyhow::Result<_>>()?;
    let mut rows = Vec::new();
    for strategy in strategies {
        scene.solver.definiteness = strategy;
        let mut sim = Simulation::from_scene(&scene)?;
        let started = Instant::now();
        let mut row = Row {
            name: strategy.name(),
            frames: 0,
            newton: 0,
            cg: 0,
            seconds: 0.0,
            energy: 0.0,
            clamped_per_step: 0.0,
            unconverged: 0,
            breakdowns: 0,
            error: None,
        };
        let mut clamped = 0;
        while !sim.is_finished() {
            match sim.step() {
                Ok(stats) => {
                    row.frames += 1;
                    row.newton += stats.newton_iterations;
                    row.cg += stats.cg_iterations;
                    row.energy = stats.elastic_energy;
                    row.unconverged += (!stats.converged) as usize;
                    row.breakdowns += stats.cg_breakdowns;
                    clamped += stats.clamped_tets;
                }
                Err(e) => {
                    row.error = Some(e.to_string());
                    break;
                }
            }
        }
        row.seconds = started.elapsed().as_secs_f64();
        row.clamped_per_step = clamped as f64 / row.frames.max(1) as f64;
        if !quiet {
            eprintln!(
                "{}: {} frames in {:.2} s",
                row.name, row.frames, row.seconds
            );
        }
        rows.push(row);
    }
    println!(
        "{} ({} tets, {} frames)",
        args.scene
            .as_ref()
            .map_or("default scene".into(), |p| p.display().to_string()),
        Simulation::from_scene(&scene)?.body.tet_count(),
        scene.solver.frames
    );
    println!(
        "strategy   Newton  Newton/fr      CG  CG/Newton  wall s  final E (J)  clamped tets/frame  unconverged  CG breakdowns"
    );
    for r in &rows {
        println!(
            "{:<9} {:>7} {:>10.2} {:>7} {:>10.1} {:>7.2} {:>12.5e} {:>19.1} {:>12} {:>14}{}",
            r.name,
            r.newton,
            r.newton as f64 / r.frames.max(1) as f64,
            r.cg,
            r.cg as f64 / r.newton.max(1) as f64,
            r.seconds,
            r.energy,
            r.clamped_per_step,
            r.unconverged,
            r.breakdowns,
            r.error
                .as_ref()
                .map_or(String::new(), |e| format!("  stopped: {e}"))
        );
    }
    Ok(ExitCode::SUCCESS)
}
