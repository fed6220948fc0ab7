//! `tetsim modes [SCENE] [--count K] [--out DIR]`: the K lowest vibration modes of the scene's
//! body at rest (SPEC §13, [`tetsim::modes`]): `modes.csv`, `mode_NN.vtu` (the rest mesh with
//! the mass-normalised `shape`), `modes.pvd` and an animated `mode_NN.gif` per mode.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use tetsim::io::vtu::{Field, write_pvd, write_quadratic_vtu, write_vtu};
use tetsim::modes::{Mode, Modes, ModesParams, VibrationProblem};
use tetsim::render::{self, Bounds, FieldKind, RenderMesh, RenderParams, SceneView};
use tetsim::{Scene, Simulation, Vec3};

/// Arguments of `tetsim modes`.
#[derive(Debug, clap::Args)]
pub struct ModesArgs {
    /// Scene file (TOML). Without it, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// How many modes, the lowest first (a free body's first six are its rigid-body motions at
    /// 0 Hz).
    #[arg(long, default_value_t = 6)]
    pub count: usize,
    /// Output folder (default: the scene's [output] dir, then `modes`). Earlier mode files
    /// there are removed first.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Relative residual every mode must reach.
    #[arg(long, default_value_t = 1e-6)]
    pub tolerance: f64,
    /// Skip the GIFs.
    #[arg(long)]
    pub no_pictures: bool,
    /// Run on a mesh the mesh doctor refuses (sets [mesh] force).
    #[arg(long)]
    pub force: bool,
}

/// Frames of one period in each GIF.
const GIF_FRAMES: usize = 24;

/// The largest displacement drawn, as a fraction of the bounding box's diagonal.
const GIF_AMPLITUDE: f64 = 0.1;

pub fn run(args: ModesArgs, quiet: bool) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(args.count >= 1, "--count must be at least 1");
    anyhow::ensure!(
        args.tolerance > 0.0 && args.tolerance < 1.0,
        "--tolerance must lie in (0, 1), got {}",
        args.tolerance
    );
    let mut scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::default(),
    };
    scene.mesh.force |= args.force;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| scene.output.dir.join("modes"));
    let sim = Simulation::from_scene(&scene)?;
    let started = std::time::Instant::now();
    let mut problem = VibrationProblem::new(&sim.body, sim.free_mask())?;
    let modes = problem.solve(&ModesParams {
        count: args.count,
        tolerance: args.tolerance,
        ..Default::default()
    })?;
    let seconds = started.elapsed().as_secs_f64();

    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    clear_previous_modes(&out)?;
    let written = write_modes(&sim, &modes, &out)?;
    let mut pictures = 0;
    if !args.no_pictures {
        for (i, mode) in modes.modes.iter().enumerate() {
            draw_mode(&sim, i, mode, &out.join(format!("mode_{i:02}.gif")))
                .with_context(|| format!("drawing mode {i}"))?;
            pictures += 1;
        }
    }
    if !quiet {
        print_summary(&problem, &modes, seconds, &out, written + pictures);
    }
    Ok(ExitCode::SUCCESS)
}

/// modes.csv, mode_NN.vtu (in the input mesh's numbering) and modes.pvd; returns how many files.
fn write_modes(sim: &Simulation, modes: &Modes, out: &Path) -> anyhow::Result<usize> {
    let mut csv = String::from("mode,frequency_hz\n");
    for (i, mode) in modes.modes.iter().enumerate() {
        csv.push_str(&format!("{i},{:?}\n", mode.frequency_hz));
    }
    let path = out.join("modes.csv");
    tetsim::io::atomic_write(&path, |w| w.write_all(csv.as_bytes()))?;
    let body = &sim.body;
    let (rest, tets) = match sim.renumbering() {
        Some(r) => (
            r.vertices_to_old(&body.mesh.positions),
            r.tets_to_old_mesh(&body.mesh.tets),
        ),
        None => (body.mesh.positions.clone(), body.mesh.tets.clone()),
    };
    // Quadratic tets: 10-node cells, so that a mode's bent elements are drawn curved.
    let quadratic = sim.input_quadratic_tets();
    let mut entries = Vec::with_capacity(modes.modes.len());
    for (i, mode) in modes.modes.iter().enumerate() {
        let shape = match sim.renumbering() {
            Some(r) => r.vertices_to_old(&mode.shape),
            None => mode.shape.clone(),
        };
        let name = format!("mode_{i:02}.vtu");
        let point_data = [("shape", Field::Vector(&shape))];
        match &quadratic {
            Some(cells) => write_quadratic_vtu(&out.join(&name), &rest, cells, &point_data, &[])?,
            None => write_vtu(&out.join(&name), &rest, &tets, &point_data, &[])?,
        }
        entries.push((i as f64, name));
    }
    write_pvd(&out.join("modes.pvd"), &entries)?;
    Ok(modes.modes.len() + 2)
}

/// One period of the mode as a looping GIF: the rest mesh plus `s·sin(2πk/N)·φ`, s chosen so
/// the largest displacement is [`GIF_AMPLITUDE`] of the bounding box's diagonal, coloured by the
/// displacement's magnitude.
fn draw_mode(sim: &Simulation, index: usize, mode: &Mode, path: &Path) -> anyhow::Result<()> {
    let rest = &sim.body.mesh.positions;
    let diagonal = Bounds::of(rest).diagonal();
    let largest = mode.shape.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let scale = if largest > 0.0 {
        GIF_AMPLITUDE * diagonal / largest
    } else {
        0.0
    };
    let period = if mode.frequency_hz > 0.0 {
        1.0 / mode.frequency_hz
    } else {
        0.0
    };
    let frames: Vec<(Vec<Vec3>, Vec<f64>)> = (0..GIF_FRAMES)
        .map(|k| {
            let s = scale * (2.0 * std::f64::consts::PI * k as f64 / GIF_FRAMES as f64).sin();
            let x: Vec<Vec3> = rest
                .iter()
                .zip(&mode.shape)
                .map(|(p, phi)| p + phi * s)
                .collect();
            let magnitude = mode.shape.iter().map(|phi| phi.norm() * s.abs()).collect();
            (x, magnitude)
        })
        .collect();
    let mut bounds = Bounds::empty();
    for (x, _) in &frames {
        bounds.include(x);
    }
    let params = RenderParams {
        width: 480,
        height: 360,
        field: Some(FieldKind::Displacement),
        title: format!(
            "mode {index}   {:.4} Hz{}",
            mode.frequency_hz,
            if mode.rigid { " (rigid)" } else { "" }
        ),
        ..Default::default()
    };
    let camera = render::fit_camera(&bounds, &params);
    let mesh = RenderMesh::new(&sim.body.mesh);
    let fixed: Vec<bool> = sim.free_mask().iter().map(|m| m.sum() < 3.0).collect();
    let range = (0.0, scale * largest);
    let images = frames
        .iter()
        .enumerate()
        .map(|(k, (x, magnitude))| {
            let view = SceneView {
                mesh: &mesh,
                positions: x,
                field: magnitude,
                fixed: &fixed,
                time: period * k as f64 / GIF_FRAMES as f64,
                frame: k,
            };
            render::render(&view, &camera, &params, range)
        })
        .collect::<tetsim::Result<Vec<_>>>()?;
    render::write_gif(path, &images, 4)?;
    Ok(())
}

/// Remove an earlier `tetsim modes`' files (modes.csv, modes.pvd, mode_NN.vtu, mode_NN.gif), so
/// that the folder never mixes two sets of modes. Other files stay.
fn clear_previous_modes(dir: &Path) -> anyhow::Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let entry = entry?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let numbered = name
            .strip_prefix("mode_")
            .and_then(|rest| {
                rest.strip_suffix(".vtu")
                    .or_else(|| rest.strip_suffix(".gif"))
            })
            .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()));
        if (numbered || name == "modes.csv" || name == "modes.pvd")
            && entry.file_type().is_ok_and(|t| t.is_file())
        {
            std::fs::remove_file(entry.path())
                .with_context(|| format!("removing {}", entry.path().display()))?;
        }
    }
    Ok(())
}

fn print_summary(
    problem: &VibrationProblem,
    modes: &Modes,
    seconds: f64,
    out: &Path,
    files: usize,
) {
    println!("mode  frequency (Hz)");
    for (i, mode) in modes.modes.iter().enumerate() {
        println!(
            "{i:>4}  {:<14.6e}{}",
            mode.frequency_hz,
            if mode.rigid {
                "  rigid-body motion"
            } else {
                ""
            }
        );
    }
    let rigid = problem.rigid_count();
    if rigid > 0 {
        eprintln!(
            "note: the constraints leave {rigid} rigid-body motion(s) free; they come first, at 0 Hz"
        );
    }
    match &modes.info {
        Some(info) => eprintln!(
            "{} free DOFs; LOBPCG: block of {}, {} iterations, {} products, {} multigrid cycles, \
             largest relative residual {:.1e}; setup {:.2} s, solve {:.2} s (multigrid {:.2} s, \
             products {:.2} s, block work {:.2} s), total {:.2} s",
            problem.free_dofs(),
            info.block_size,
            info.iterations,
            info.operator_products,
            info.preconditioner_applications,
            info.relative_residuals
                .iter()
                .fold(0.0_f64, |a, &b| a.max(b)),
            problem.setup_seconds,
            modes.solve_seconds,
            info.preconditioner_seconds,
            info.operator_seconds,
            info.seconds - info.preconditioner_seconds - info.operator_seconds,
            seconds
        ),
        None => eprintln!(
            "{} free DOFs; every mode asked for is rigid",
            problem.free_dofs()
        ),
    }
    eprintln!("wrote {files} files to {}", out.display());
}
