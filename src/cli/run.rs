//! `tetsim run [SCENE] [--out DIR]`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tetsim::diagnose::{RunSummary, plausibility_warnings};
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
    /// Byte-identical output files across runs: steps.csv's wall_seconds written as 0 (sets
    /// [output] deterministic; the times still go to timings.csv).
    #[arg(long)]
    pub deterministic: bool,
}

pub fn run(args: RunArgs, quiet: bool) -> anyhow::Result<ExitCode> {
    let mut scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default(),
    };
    scene.mesh.force |= args.force;
    scene.output.deterministic |= args.deterministic;
    if let Some(frames) = args.frames {
        anyhow::ensure!(frames > 0, "--frames must be at least 1");
        scene.solver.frames = frames;
    }
    let out = args.out.clone().unwrap_or_else(|| scene.output.dir.clone());
    let started = Instant::now();
    let mut sim = Simulation::from_scene(&scene)?;
    let warnings = plausibility_warnings(&sim.body, &sim.boundary, &sim.params);
    for w in &warnings {
        log::warn!("{w}");
    }
    let mut recorder = Recorder::create(&out, &sim.body, scene.output.obj)?
        .deterministic(scene.output.deterministic);
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
    let (lo, hi) = sim.body.mesh.bounding_box();
    let body_size = (hi - lo).norm();
    let mut summary = RunSummary::default();
    let mut late_warnings = Vec::new();
    while !sim.is_finished() {
        let stats = match sim.step() {
            Ok(stats) => stats,
            Err(error) => {
                let status = format!("stopped: {error}");
                recorder.write_manifest(&scene, &sim, &status)?;
                if let Some(bar) = &bar {
                    bar.finish_and_clear();
                }
                return Err(error.into());
            }
        };
        recorder.write_frame(&sim, Some(&stats))?;
        summary.add(&stats, sim.params.substeps);
        if stats.frame == 1 {
            let moved = sim
                .state
                .x
                .iter()
                .zip(sim.initial_positions())
                .map(|(x, x0)| (x - x0).norm())
                .fold(0.0, f64::max);
            if moved > body_size {
                let w = format!(
                    "frame 1 moved a vertex {moved:.3e} m, more than the body's size \
                     ({body_size:.3e} m): the body may be far too soft for its weight or loads, \
                     or dt far too large"
                );
                log::warn!("{w}");
                late_warnings.push(w);
            }
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
    recorder.write_manifest(&scene, &sim, "complete")?;
    if !quiet {
        let wall = started.elapsed().as_secs_f64();
        eprintln!(
            "{summary} in {wall:.2} s ({:.1} frames/s)",
            frames as f64 / wall
        );
        for w in warnings.iter().chain(&late_warnings) {
            eprintln!("warning: {w}");
        }
        for finding in summary.findings(&sim.body, &sim.state.x, &sim.params) {
            eprintln!("note: {finding}");
        }
        eprintln!(
            "wrote {} files to {}",
            recorder.files().len(),
            recorder.dir().display()
        );
    }
    Ok(ExitCode::SUCCESS)
}
