//! `tetsim run [SCENE] [--out DIR]`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tetsim::output::Recorder;
use tetsim::{Scene, Simulation};

/// Arguments of `tetsim run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Scene file (TOML). Without it, the built-in default scene runs.
    pub scene: Option<PathBuf>,
    /// Output folder (overrides [output] dir).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Number of frames (overrides [solver] frames).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Run on a mesh the mesh doctor refuses (sets [mesh] force).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: RunArgs, quiet: bool) -> anyhow::Result<ExitCode> {
    let mut scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default(),
    };
    scene.mesh.force |= args.force;
    if let Some(frames) = args.frames {
        anyhow::ensure!(frames > 0, "--frames must be at least 1");
        scene.solver.frames = frames;
    }
    let out = args.out.clone().unwrap_or_else(|| scene.output.dir.clone());
    let started = Instant::now();
    let mut sim = Simulation::from_scene(&scene)?;
    let mut recorder = Recorder::create(&out, &sim.body, scene.output.obj)?;
    recorder
        .write_frame(&sim, None)
        .context("writing frame 0")?;
    let frames = sim.params.frames;
    let bar = if !quiet && std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(frames as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{bar:30.cyan/blue} {pos}/{len} frames  {per_sec}  ETA {eta}  {msg}",
            )
            .expect("valid template"),
        );
        Some(bar)
    } else {
        None
    };
    let (mut newton, mut cg, mut unconverged) = (0, 0, Vec::new());
    let mut worst_residual: f64 = 0.0;
    let mut min_j = f64::INFINITY;
    while !sim.is_finished() {
        let stats = sim.step()?;
        recorder.write_frame(&sim, Some(&stats))?;
        newton += stats.newton_iterations;
        cg += stats.cg_iterations;
        worst_residual = worst_residual.max(stats.relative_residual);
        min_j = min_j.min(stats.min_j);
        if !stats.converged {
            unconverged.push(stats.frame);
        }
        let line = format!(
            "frame {}/{}: {} Newton, {} CG, residual {:.1e}, min J {:.3}{}",
            stats.frame,
            frames,
            stats.newton_iterations,
            stats.cg_iterations,
            stats.relative_residual,
            stats.min_j,
            if stats.converged {
                ""
            } else {
                "  NOT CONVERGED"
            }
        );
        match &bar {
            Some(bar) => {
                bar.set_message(format!(
                    "Newton {} CG {}",
                    stats.newton_iterations, stats.cg_iterations
                ));
                bar.inc(1);
            }
            None if !quiet => eprintln!("{line}"),
            None => {}
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    if !quiet {
        let wall = started.elapsed().as_secs_f64();
        eprintln!(
            "{frames} frames in {wall:.2} s ({:.1} frames/s): {newton} Newton iterations ({:.1}/frame), {cg} CG iterations ({:.0}/Newton), worst relative residual {worst_residual:.1e}, min J {min_j:.3}",
            frames as f64 / wall,
            newton as f64 / frames as f64,
            cg as f64 / newton.max(1) as f64,
        );
        if !unconverged.is_empty() {
            eprintln!("frames that did not converge: {unconverged:?}");
        }
        eprintln!(
            "wrote {} files to {}",
            recorder.files().len(),
            recorder.dir().display()
        );
    }
    Ok(ExitCode::SUCCESS)
}
