//! `tetsim run [SCENE] [--out DIR]` and `tetsim run --resume DIR`: run a scene (or go on with a
//! stopped run), writing each frame, `checkpoint.bin` after it and `manifest.json` (`running`,
//! then `complete`, `interrupted` or why it stopped); then the pictures and plots, drawn from
//! the frames on disk.
//!
//! Ctrl-C and SIGTERM stop the frame being computed within one Newton iteration (it is not
//! written: the files end at the last complete frame), write the summary and the manifest
//! (`interrupted`), say how to resume and exit 130 / 143; a second one stops at once (the
//! checkpoint of the last frame still allows resuming). Under mpirun the frame loop is not
//! stopped from inside a step: mpirun ends the job.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use anyhow::Context;
use tetsim::checkpoint::{Checkpoint, FILE_NAME, RunRecord};
use tetsim::diagnose::{RunSummary, folded_finding, plausibility_warnings};
use tetsim::output::{Recorder, clear_previous_run};
use tetsim::progress::{DisplayMode, FrameReport, RunDisplay};
use tetsim::render::{self, FieldChoice, RenderParams, RunPictureParams};
use tetsim::runner::{CheckpointInterval, Ending, Runner};
use tetsim::{Scene, Simulation, Vec3};

/// Arguments of `tetsim run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Scene file (TOML). Without it, the built-in default scene runs.
    pub scene: Option<PathBuf>,
    /// Output folder (overrides [output] dir). An earlier run's files there are removed first.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Number of frames (overrides [solver] frames; with --resume: go on to this frame).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Run on a mesh the mesh doctor refuses (sets [mesh] force).
    #[arg(long)]
    pub force: bool,
    /// Skip preview.png, animation.gif and the plots (sets [output] pictures and plots off).
    #[arg(long)]
    pub no_pictures: bool,
    /// Byte-identical output files across runs: steps.csv's wall_seconds written as 0 (sets
    /// [output] deterministic; the times still go to timings.csv).
    #[arg(long)]
    pub deterministic: bool,
    /// Go on with the stopped run in DIR from its checkpoint.bin, with the scene and options
    /// kept there, to its last frame (or --frames N).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["scene", "out", "force", "no_pictures", "deterministic"])]
    pub resume: Option<PathBuf>,
}

pub fn run(args: RunArgs, quiet: bool, verbose: u8) -> anyhow::Result<ExitCode> {
    let stop = watch_signals()?;
    let (scene, mut record, checkpoint) = match &args.resume {
        Some(dir) => resumed(dir, args.frames)?,
        None => fresh(&args)?,
    };
    let out = PathBuf::from(&record.out);
    // Everything about the pictures is checked before the first frame: a bad camera must not
    // cost a whole run.
    let pictures = picture_params(&scene);
    if scene.output.pictures {
        check_pictures(&pictures)?;
    }

    let mut sim = Simulation::from_scene(&scene)?;
    sim.set_interrupt(Arc::clone(&stop.flag));
    #[cfg(feature = "mpi")]
    super::mpirun::attach(&mut sim, &scene)?;
    if checkpoint.is_none() {
        // After building: a missing file is reported at its scene key by the build.
        record.inputs = tetsim::manifest::input_hashes(&scene)?.to_string();
    }
    if let Some(d) = sim.damping()
        && !quiet
    {
        eprintln!(
            "damping ratio {} at {:.6} Hz and {:.6} Hz ({}): rayleigh_mass = {:.6e} 1/s, rayleigh_stiffness = {:.6e} s",
            d.ratio,
            d.frequencies_hz[0],
            d.frequencies_hz[1],
            if d.from_modes {
                "the lowest mode and ten times it"
            } else {
                "damping_frequencies"
            },
            d.rayleigh_mass,
            d.rayleigh_stiffness
        );
    }
    let mut warnings = plausibility_warnings(&sim.body, &sim.boundary, &sim.params);
    for w in &warnings {
        log::warn!("{w}");
    }
    let recorder = match &checkpoint {
        Some(c) => {
            sim.restore(&c.simulation)?;
            Recorder::resume(&out, &sim, scene.output.obj, &c.recorder)?
        }
        None => {
            let removed = clear_previous_run(&out)?;
            if removed > 0 && !quiet {
                eprintln!(
                    "note: removed {removed} files of an earlier run from {}",
                    out.display()
                );
            }
            let mut r = Recorder::create(&out, &sim.body, scene.output.obj)?
                .deterministic(scene.output.deterministic);
            r.write_frame(&sim, None).context("writing frame 0")?;
            r
        }
    }
    .deterministic(scene.output.deterministic)
    .named(&record.out);
    let mut runner = Runner::new(recorder)
        .with_checkpoint(record.clone())
        .with_interval(CheckpointInterval::of(&scene))
        .with_stop(Arc::clone(&stop.flag));
    if checkpoint.is_none() {
        runner.save(&sim).context("writing the checkpoint")?;
    }
    let recorder = &mut runner.recorder;
    recorder.write_manifest(&scene, &sim, "running")?;

    let first = sim.frame();
    let frames = sim.params.frames;
    // A finished run resumed: its files are checked (above) and its manifest rewritten, but
    // nothing is computed or drawn again unless its pictures are missing.
    let complete = checkpoint.is_some() && first >= frames;
    if checkpoint.is_some() && !complete && !quiet {
        eprintln!("resuming {} after frame {first} of {frames}", out.display());
    }
    let mut display = RunDisplay::resumed(
        first,
        frames,
        // -v logs one line per frame (below); a progress display beside it would interleave.
        if quiet || verbose > 0 {
            DisplayMode::Quiet
        } else {
            DisplayMode::Auto
        },
    );
    let (lo, hi) = sim.body.mesh.bounding_box();
    let body_size = (hi - lo).norm();
    let mut summary = RunSummary::default();
    let ending = runner.run(&mut sim, |sim, stats| {
        summary.add(stats, sim.params.substeps);
        if stats.frame == 1 {
            // How far a vertex moved apart from the body's mean motion: a body launched at
            // 1e4 m/s moves far, rigidly, and that is no sign of a wrong unit.
            let n = sim.state.x.len().max(1) as f64;
            let mean = sim
                .state
                .x
                .iter()
                .zip(sim.initial_positions())
                .fold(Vec3::zeros(), |s, (x, x0)| s + (x - x0))
                / n;
            let moved = sim
                .state
                .x
                .iter()
                .zip(sim.initial_positions())
                .map(|(x, x0)| (x - x0 - mean).norm())
                .fold(0.0, f64::max);
            if moved > body_size {
                let w = format!(
                    "frame 1 moved a vertex {moved:.3e} m relative to the body's mean motion, more than the body's size ({body_size:.3e} m): \
                     the body may be far too soft for its weight or loads, or dt far too large"
                );
                log::warn!("{w}");
                warnings.push(w);
            }
        }
        log::info!(
            "frame {}/{frames}  t={:.4} s  Newton {}  CG {}  relative residual {:.1e}  residual {:.2e} N  min J {:.3}{}",
            stats.frame,
            stats.time,
            stats.newton_iterations,
            stats.cg_iterations,
            stats.relative_residual,
            stats.residual,
            stats.min_j,
            if stats.converged {
                ""
            } else {
                "  NOT CONVERGED"
            }
        );
        display.frame_done(&FrameReport {
            frame: stats.frame,
            time: stats.time,
            newton_iterations: stats.newton_iterations,
            cg_iterations: stats.cg_iterations,
            residual: stats.relative_residual,
            absolute_residual: stats.residual,
            converged: stats.converged,
            within_floor: stats.converged
                && stats.relative_residual > sim.params.newton_tolerance,
            min_j: stats.min_j,
            wall_seconds: stats.wall_seconds,
        });
    })?;
    let signal = stop.which.load(Ordering::SeqCst);
    let interrupted = matches!(ending, Ending::Interrupted) && signal != 0;
    let status = ending.status();
    let failure = match ending {
        Ending::Stopped(error) => Some(error),
        _ => None,
    };
    let recorder = &mut runner.recorder;
    // The render surfaces' animation over every frame on disk (a resumed run's too).
    recorder
        .write_animation()
        .context("writing the render surfaces' animation")?;
    // The manifest first: whatever happens to the pictures, the run's record is written.
    recorder.write_manifest(&scene, &sim, &status)?;

    let mut files = recorder.files().to_vec();
    let mut picture_error = None;
    let drawing = std::time::Instant::now();
    let drawn = !scene.output.pictures || out.join("preview.png").is_file();
    if complete && drawn {
        if !quiet {
            eprintln!(
                "the run in {} is already complete ({frames} frames, its files checked); \
                 nothing to do. To go on: tetsim run --resume {} --frames N",
                out.display(),
                shell_word(&out)
            );
        }
        return Ok(ExitCode::SUCCESS);
    }
    if !interrupted {
        match draw(&scene, &pictures, &out, sim.frame()) {
            Ok(written) => files.extend(written),
            Err(e) => {
                picture_error = Some(format!("{e:#}"));
                recorder.note_problem(&format!("pictures: {e:#}"));
                recorder.write_manifest(&scene, &sim, &status)?;
            }
        }
    }
    if scene.output.pictures && !interrupted {
        display.add_pictures(drawing.elapsed());
    }
    let text = display.finish(&out, &files);
    if !quiet {
        eprintln!("{text}");
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        for finding in summary.findings(&sim.body, &sim.state.x, &sim.params) {
            eprintln!("note: {finding}");
        }
        if let Some(folded) = folded_finding(
            &sim.body,
            &sim.boundary,
            sim.contact_setup().is_some(),
            &sim.state.x,
            sim.kinetic_energy(),
        ) {
            eprintln!("note: {folded}");
        }
    }
    if interrupted {
        let name = if signal == SIGTERM {
            "SIGTERM"
        } else {
            "Ctrl-C"
        };
        eprintln!(
            "interrupted ({name}) after frame {} of {frames}; the run's files are written up to it.\n\
             resume with: tetsim run --resume {}",
            sim.frame(),
            shell_word(&out)
        );
        return Ok(ExitCode::from(if signal == SIGTERM { 143 } else { 130 }));
    }
    if let Some(error) = failure {
        return Err(error.into());
    }
    if let Some(e) = picture_error {
        anyhow::bail!(
            "drawing the pictures failed: {e} (the frames, steps.csv and manifest.json are written)"
        );
    }
    Ok(ExitCode::SUCCESS)
}

const SIGTERM: usize = signal_hook::consts::SIGTERM as usize;

/// The stop request: set by Ctrl-C or SIGTERM, with the signal's number.
struct Stop {
    flag: Arc<AtomicBool>,
    which: Arc<AtomicUsize>,
}

/// Ctrl-C and SIGTERM set a flag the frame loop and Newton read; a second one exits at
/// once (130 / 143), leaving the checkpoint of the last frame written.
fn watch_signals() -> anyhow::Result<Stop> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    let stop = Stop {
        flag: Arc::new(AtomicBool::new(false)),
        which: Arc::new(AtomicUsize::new(0)),
    };
    for (signal, code) in [(SIGINT, 130), (SIGTERM, 143)] {
        // Registered first, so it sees the flag as the previous signal left it.
        flag::register_conditional_shutdown(signal, code, Arc::clone(&stop.flag))?;
        flag::register(signal, Arc::clone(&stop.flag))?;
        flag::register_usize(signal, Arc::clone(&stop.which), signal as usize)?;
    }
    Ok(stop)
}

/// A new run: the scene and options from the command line.
fn fresh(args: &RunArgs) -> anyhow::Result<(Scene, RunRecord, Option<Checkpoint>)> {
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
    if args.no_pictures {
        scene.output.pictures = false;
        scene.output.plots = false;
    }
    let out = args.out.clone().unwrap_or_else(|| scene.output.dir.clone());
    let base = match &args.scene {
        Some(path) => path.parent().map(Path::to_path_buf).unwrap_or_default(),
        None => PathBuf::from("."),
    };
    let record = tetsim::runner::fresh_record(&scene, &base, &out);
    Ok((scene, record, None))
}

/// A stopped run: its scene and options from its checkpoint, its inputs checked unchanged.
fn resumed(
    dir: &Path,
    frames: Option<usize>,
) -> anyhow::Result<(Scene, RunRecord, Option<Checkpoint>)> {
    anyhow::ensure!(dir.is_dir(), "--resume {}: no such folder", dir.display());
    let checkpoint = Checkpoint::read(&dir.join(FILE_NAME))?;
    let mut record = checkpoint.run.clone();
    let mut scene = Scene::parse(
        &record.scene_source,
        Path::new(&record.scene_path),
        Path::new(&record.scene_base),
    )?;
    let inputs = tetsim::manifest::input_hashes(&scene)?.to_string();
    anyhow::ensure!(
        inputs == record.inputs,
        "--resume {}: the scene's input files changed since the run started (now {inputs}, then {}); \
         start the run again",
        dir.display(),
        record.inputs
    );
    let done = checkpoint.simulation.frame;
    if let Some(frames) = frames {
        anyhow::ensure!(
            frames >= done,
            "--frames {frames}: the run in {} is already at frame {done}",
            dir.display()
        );
        record.frames = frames;
    }
    scene.solver.frames = record.frames;
    scene.mesh.force = record.force;
    scene.output.pictures = record.pictures;
    scene.output.plots = record.plots;
    scene.output.deterministic = record.deterministic;
    // The folder as given now: the run may have been moved, or resumed from elsewhere.
    record.out = dir.display().to_string();
    Ok((scene, record, Some(checkpoint)))
}

/// The pictures' settings from the scene's [output].
fn picture_params(scene: &Scene) -> RunPictureParams {
    let o = &scene.output;
    RunPictureParams {
        preview: RenderParams {
            width: o.width,
            height: o.height,
            azimuth_deg: o.azimuth,
            elevation_deg: o.elevation,
            up: render::up_from_gravity(Vec3::from(scene.gravity)),
            ..Default::default()
        },
        gif_width: o.gif_width,
        gif_height: o.gif_height,
        gif_delay_cs: render::gif_delay_cs(scene.solver.dt * gif_stride(scene) as f64),
    }
}

/// The scene's `[output] field` (validated with the scene).
fn field_choice(scene: &Scene) -> anyhow::Result<FieldChoice> {
    Ok(scene.output.field.parse::<FieldChoice>()?)
}

/// Refuse picture settings that could only fail after the run.
fn check_pictures(p: &RunPictureParams) -> anyhow::Result<()> {
    p.preview.validate().context("[output] picture settings")?;
    RenderParams {
        width: p.gif_width,
        height: p.gif_height,
        ..p.preview.clone()
    }
    .validate()
    .context("[output] gif_width, gif_height")?;
    Ok(())
}

/// The GIF's stride: `gif_stride`, made larger as `gif_frames` needs for the run's frames.
fn gif_stride(scene: &Scene) -> usize {
    let o = &scene.output;
    render::gif_stride(scene.solver.frames, o.gif_stride, o.gif_frames)
}

/// preview.png and animation.gif (every gif_stride-th frame and the last), drawn from the
/// frames on disk one at a time, and the plots of steps.csv.
fn draw(
    scene: &Scene,
    params: &RunPictureParams,
    out: &Path,
    last: usize,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    if scene.output.pictures {
        let stride = gif_stride(scene);
        written.extend(
            super::saved::render_saved(out, out, params, field_choice(scene)?, |frame| {
                frame.is_multiple_of(stride) || frame == last
            })
            .context("rendering the pictures")?
            .0,
        );
    }
    if scene.output.plots && last > 0 {
        written
            .extend(render::plot_steps(&out.join("steps.csv"), out).context("plotting steps.csv")?);
        // SPEC §13: probes.csv and reactions.csv, when the run writes them.
        for (csv, png, title, axis) in [
            (
                "probes.csv",
                "probes.png",
                "probe displacements",
                "displacement [m]",
            ),
            (
                "reactions.csv",
                "reactions.png",
                "reaction forces",
                "force [N]",
            ),
        ] {
            let csv = out.join(csv);
            if csv.exists() {
                let plot = render::plot_series(&csv, &out.join(png), title, axis)
                    .with_context(|| format!("plotting {}", csv.display()))?;
                written.push(plot);
            }
        }
    }
    Ok(written)
}

/// A path as one shell word (quoted when it needs to be).
fn shell_word(path: &Path) -> String {
    let s = path.display().to_string();
    if !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"/._-+=:,@".contains(&b))
    {
        s
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}
