//! `tetsim run [SCENE] [--out DIR]`: run a scene, write its frames, then its pictures and plots.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use tetsim::contact::display::{DisplaySurface, scene_box};
use tetsim::diagnose::{RunSummary, plausibility_warnings};
use tetsim::math::Vec3;
use tetsim::output::Recorder;
use tetsim::progress::{DisplayMode, FrameReport, RunDisplay};
use tetsim::render::{
    self, FieldKind, ObstacleView, RenderMesh, RenderParams, RunFrame, RunPictureParams,
};
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
    /// Skip preview.png, animation.gif and the plots (sets [output] pictures and plots off).
    #[arg(long)]
    pub no_pictures: bool,
    /// Byte-identical output files across runs: steps.csv's wall_seconds written as 0 (sets
    /// [output] deterministic; the times still go to timings.csv).
    #[arg(long)]
    pub deterministic: bool,
}

/// Frames kept in memory for the pictures: (frame, time, positions, field values, obstacles).
type Kept = Vec<(usize, f64, Vec<Vec3>, Vec<f64>, ObstacleView)>;

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
    if args.no_pictures {
        scene.output.pictures = false;
        scene.output.plots = false;
    }
    let out = args.out.clone().unwrap_or_else(|| scene.output.dir.clone());
    let mut sim = Simulation::from_scene(&scene)?;
    #[cfg(feature = "mpi")]
    super::mpirun::attach(&mut sim, &scene)?;
    let mut warnings = plausibility_warnings(&sim.body, &sim.boundary, &sim.params);
    for w in &warnings {
        log::warn!("{w}");
    }
    let mut recorder = Recorder::create(&out, &sim.body, scene.output.obj)?
        .deterministic(scene.output.deterministic);
    recorder
        .write_frame(&sim, None)
        .context("writing frame 0")?;
    let field = match scene.output.field.as_str() {
        "none" => None,
        name => Some(name.parse::<FieldKind>()?),
    };
    let mut kept: Kept = Vec::new();
    let obstacles = sim.contact_setup().map(|setup| {
        let surface = DisplaySurface::new(setup, scene_box(sim.initial_positions(), setup));
        let is_plane: Vec<bool> = surface.shape.iter().map(|&s| s == 0.0).collect();
        (surface, is_plane)
    });
    let up = RenderParams::default().up;
    let keep = |sim: &Simulation, kept: &mut Kept| {
        if scene.output.pictures {
            let values = field.map_or_else(Vec::new, |kind| {
                render::field_values(kind, &sim.body, &sim.state.x)
            });
            let view = match (&obstacles, sim.contact_setup()) {
                (Some((surface, is_plane)), Some(setup)) => {
                    let ramps: Vec<f64> = setup
                        .obstacles
                        .iter()
                        .map(|o| sim.motion_ramp(o.duration))
                        .collect();
                    let points = surface.positions_at(setup, &ramps);
                    ObstacleView::new(&points, &surface.triangles, &surface.obstacle, is_plane, up)
                }
                _ => ObstacleView::default(),
            };
            kept.push((sim.frame(), sim.state.t, sim.state.x.clone(), values, view));
        }
    };
    keep(&sim, &mut kept);

    let frames = sim.params.frames;
    let mut display = RunDisplay::new(
        frames,
        if quiet {
            DisplayMode::Quiet
        } else {
            DisplayMode::Auto
        },
    );
    let mut failure = None;
    let (lo, hi) = sim.body.mesh.bounding_box();
    let body_size = (hi - lo).norm();
    let mut summary = RunSummary::default();
    let outcome = sim.run_with(&mut recorder, |sim, stats| {
        summary.add(stats, sim.params.substeps);
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
                    "frame 1 moved a vertex {moved:.3e} m, more than the body's size ({body_size:.3e} m): \
                     the body may be far too soft for its weight or loads, or dt far too large"
                );
                log::warn!("{w}");
                warnings.push(w);
            }
        }
        display.frame_done(&FrameReport {
            frame: stats.frame,
            time: stats.time,
            newton_iterations: stats.newton_iterations,
            cg_iterations: stats.cg_iterations,
            residual: stats.relative_residual,
            converged: stats.converged,
            min_j: stats.min_j,
            wall_seconds: stats.wall_seconds,
        });
        if sim.frame() % scene.output.gif_stride == 0 {
            keep(sim, &mut kept);
        }
    });
    match outcome {
        Ok(()) => {}
        // Stop, but keep what the run produced: frames are on disk; draw them too.
        Err(error @ tetsim::Error::Solve { .. }) => failure = Some(error),
        Err(error) => return Err(error.into()),
    }
    // The last frame reached is always drawn (it is the preview).
    if kept.last().is_some_and(|k| k.0 != sim.frame()) {
        keep(&sim, &mut kept);
    }

    let mut pictures = Vec::new();
    if scene.output.pictures && !kept.is_empty() {
        pictures.extend(draw(&scene, &sim, field, &kept, &out).context("rendering the pictures")?);
    }
    if scene.output.plots && sim.frame() > 0 {
        pictures.extend(
            render::plot_steps(&out.join("steps.csv"), &out).context("plotting steps.csv")?,
        );
    }
    let status = failure
        .as_ref()
        .map_or("complete".to_string(), |e| format!("stopped: {e}"));
    recorder.write_manifest(&scene, &sim, &status)?;
    let mut files = recorder.files().to_vec();
    files.extend(pictures);
    let text = display.finish(&out, &files);
    if !quiet {
        eprintln!("{text}");
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        for finding in summary.findings(&sim.body, &sim.state.x, &sim.params) {
            eprintln!("note: {finding}");
        }
    }
    match failure {
        Some(error) => Err(error.into()),
        None => Ok(ExitCode::SUCCESS),
    }
}

/// preview.png and animation.gif from the kept frames, one camera and colour range for all.
fn draw(
    scene: &Scene,
    sim: &Simulation,
    field: Option<FieldKind>,
    kept: &Kept,
    out: &std::path::Path,
) -> anyhow::Result<Vec<PathBuf>> {
    let mesh = RenderMesh::new(&sim.body.mesh);
    let fixed: Vec<bool> = sim.free_mask().iter().map(|m| m.sum() < 3.0).collect();
    let frames: Vec<RunFrame<'_>> = kept
        .iter()
        .map(|(frame, time, positions, values, obstacles)| RunFrame {
            frame: *frame,
            time: *time,
            positions,
            field: values,
            obstacles: &obstacles.triangles,
            ground: obstacles.ground,
        })
        .collect();
    let o = &scene.output;
    let params = RunPictureParams {
        preview: RenderParams {
            width: o.width,
            height: o.height,
            azimuth_deg: o.azimuth,
            elevation_deg: o.elevation,
            field,
            ..Default::default()
        },
        gif_width: o.gif_width,
        gif_height: o.gif_height,
        gif_delay_cs: render::gif_delay_cs(scene.solver.dt * o.gif_stride as f64),
    };
    Ok(render::render_run(&mesh, &fixed, &frames, &params, out)?)
}
