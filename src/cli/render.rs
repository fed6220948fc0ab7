//! `tetsim render OUT_DIR`: re-render a saved run from its VTU frames (frames.pvd), with a
//! different field, camera, size or frame range, without re-simulating.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use tetsim::io::surface_vtu::read_surface_vtu;
use tetsim::io::vtu::read_pvd;
use tetsim::io::{FieldData, read_vtu_frame};
use tetsim::math::Vec3;
use tetsim::mesh::TetMesh;
use tetsim::render::{
    self, FieldKind, ObstacleView, RenderMesh, RenderParams, RunFrame, RunPictureParams,
};

/// Arguments of `tetsim render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// A run's output folder (holding frames.pvd and its frame_NNNN.vtu).
    pub dir: PathBuf,
    /// Where to write preview.png and animation.gif (default: the run's folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Colour field: displacement, J, von-mises, energy-density or none.
    #[arg(long, default_value = "displacement")]
    pub field: String,
    /// Camera azimuth about +y, degrees.
    #[arg(long, default_value_t = -35.0, allow_hyphen_values = true)]
    pub azimuth: f64,
    /// Camera elevation, degrees.
    #[arg(long, default_value_t = 22.0, allow_hyphen_values = true)]
    pub elevation: f64,
    /// Preview width and height in pixels.
    #[arg(long, default_value_t = 800)]
    pub width: u32,
    /// See --width.
    #[arg(long, default_value_t = 600)]
    pub height: u32,
    /// GIF frame width and height in pixels.
    #[arg(long, default_value_t = 480)]
    pub gif_width: u32,
    /// See --gif-width.
    #[arg(long, default_value_t = 360)]
    pub gif_height: u32,
    /// Frames to draw: FIRST..LAST (inclusive) or a single frame; default all.
    #[arg(long)]
    pub frames: Option<String>,
    /// Draw every k-th frame (the last one always).
    #[arg(long, default_value_t = 1)]
    pub stride: usize,
    /// Draw tet edges.
    #[arg(long)]
    pub wireframe: bool,
    /// Cut the body open along a plane through the centre of the run with this normal (x, y or
    /// z), to see inside.
    #[arg(long)]
    pub cut: Option<char>,
}

/// A frame kept for drawing: (frame, time, positions, field values, index into the obstacles
/// read, `usize::MAX` for none).
type Kept = (usize, f64, Vec<Vec3>, Vec<f64>, usize);

pub fn run(args: RenderArgs, quiet: bool) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(args.stride > 0, "--stride must be at least 1");
    let pvd = args.dir.join("frames.pvd");
    let entries = read_pvd(&pvd)?;
    anyhow::ensure!(!entries.is_empty(), "{}: lists no frames", pvd.display());
    let (first, last) = frame_range(args.frames.as_deref(), entries.len())?;
    let field = match args.field.as_str() {
        "none" => None,
        name => Some(name.parse::<FieldKind>()?),
    };
    let mut mesh: Option<(RenderMesh, Vec<bool>)> = None;
    let obstacle_files = obstacle_files(&args.dir)?;
    let mut obstacles: Vec<(String, ObstacleView)> = Vec::new();
    let mut kept: Vec<Kept> = Vec::new();
    for (index, (time, file)) in entries.iter().enumerate().take(last + 1).skip(first) {
        if (index - first) % args.stride != 0 && index != last {
            continue;
        }
        let path = args.dir.join(file);
        let frame = read_vtu_frame(&path)?;
        if mesh.is_none() {
            mesh = Some(rest_mesh(&path, &frame)?);
        }
        let values = match field {
            None => Vec::new(),
            Some(FieldKind::Displacement) => vectors(&path, &frame.point_data, "displacement")?
                .iter()
                .map(|d| d.norm())
                .collect(),
            Some(kind) => scalars(&path, &frame.cell_data, cell_array(kind))?.to_vec(),
        };
        // The obstacles file of this frame: the last one written at or before its time.
        let view = match obstacle_files.iter().rev().find(|o| o.0 <= *time) {
            None => usize::MAX,
            Some((_, file)) => match obstacles.iter().position(|o| &o.0 == file) {
                Some(k) => k,
                None => {
                    obstacles.push((file.clone(), read_obstacles(&args.dir.join(file))?));
                    obstacles.len() - 1
                }
            },
        };
        kept.push((index, *time, frame.points, values, view));
    }
    let (mesh, fixed) = mesh.context("no frame in the range")?;
    let frames: Vec<RunFrame<'_>> = kept
        .iter()
        .map(|(frame, time, positions, field, view)| {
            let view = obstacles.get(*view).map(|o| &o.1);
            RunFrame {
                frame: *frame,
                time: *time,
                positions,
                field,
                obstacles: view.map_or(&[], |v| &v.triangles),
                ground: view.and_then(|v| v.ground),
            }
        })
        .collect();
    let step = if kept.len() > 1 {
        (kept[kept.len() - 1].1 - kept[0].1) / (kept.len() - 1) as f64
    } else {
        0.04
    };
    let clip = match args.cut {
        None => None,
        Some(axis) => {
            let normal = match axis {
                'x' => Vec3::x(),
                'y' => Vec3::y(),
                'z' => Vec3::z(),
                other => bail!("--cut takes x, y or z, not {other}"),
            };
            let mut bounds = render::Bounds::empty();
            for f in &frames {
                bounds.include(f.positions);
            }
            Some(render::Plane::new(bounds.center(), normal))
        }
    };
    let params = RunPictureParams {
        preview: RenderParams {
            width: args.width,
            height: args.height,
            azimuth_deg: args.azimuth,
            elevation_deg: args.elevation,
            field,
            wireframe: args.wireframe,
            clip,
            ..Default::default()
        },
        gif_width: args.gif_width,
        gif_height: args.gif_height,
        gif_delay_cs: render::gif_delay_cs(step),
    };
    params.preview.validate()?;
    let out = args.out.unwrap_or(args.dir);
    std::fs::create_dir_all(&out).map_err(|e| tetsim::Error::io(&out, e))?;
    let written = render::render_run(&mesh, &fixed, &frames, &params, &out)?;
    if !quiet {
        for path in &written {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The entries of the run's `obstacles.pvd` (none when the run had no contact).
fn obstacle_files(dir: &Path) -> anyhow::Result<Vec<(f64, String)>> {
    let pvd = dir.join("obstacles.pvd");
    if !pvd.exists() {
        return Ok(Vec::new());
    }
    Ok(read_pvd(&pvd)?)
}

/// An `obstacles_NNNN.vtu` read back and split into the ground and the other obstacles.
fn read_obstacles(path: &Path) -> anyhow::Result<ObstacleView> {
    let surface = read_surface_vtu(path)?;
    let per_triangle = |name: &str| match surface.cell_field(name) {
        Some(FieldData::Scalar(v)) if v.len() == surface.triangles.len() => Some(v.clone()),
        _ => None,
    };
    let n = surface.triangles.len();
    let obstacle = per_triangle("obstacle")
        .map_or_else(|| vec![0; n], |v| v.iter().map(|&k| k as usize).collect());
    // Without `shape` (another writer), nothing is taken for the ground.
    let is_plane: Vec<bool> = per_triangle("shape")
        .map_or_else(|| vec![false; n], |v| v.iter().map(|&s| s == 0.0).collect());
    Ok(ObstacleView::new(
        &surface.points,
        &surface.triangles,
        &obstacle,
        &is_plane,
        RenderParams::default().up,
    ))
}

/// The VTU cell array holding a field.
fn cell_array(kind: FieldKind) -> &'static str {
    match kind {
        FieldKind::J => "J",
        FieldKind::VonMises => "von_mises",
        FieldKind::EnergyDensity => "strain_energy_density",
        FieldKind::Displacement => "displacement",
    }
}

/// Rest positions (points − displacement) and tets of a frame, and its fixed vertices.
fn rest_mesh(path: &Path, frame: &tetsim::io::Frame) -> anyhow::Result<(RenderMesh, Vec<bool>)> {
    let displacement = vectors(path, &frame.point_data, "displacement")?;
    let rest: Vec<Vec3> = frame
        .points
        .iter()
        .zip(displacement)
        .map(|(x, d)| x - d)
        .collect();
    let fixed = match frame.point_data.iter().find(|f| f.0 == "fixed") {
        Some((_, FieldData::Scalar(v))) => v.iter().map(|&c| c > 0.0).collect(),
        _ => vec![false; rest.len()],
    };
    Ok((
        RenderMesh::new(&TetMesh::new(rest, frame.tets.clone())),
        fixed,
    ))
}

fn vectors<'a>(
    path: &Path,
    data: &'a [(String, FieldData)],
    name: &str,
) -> anyhow::Result<&'a [Vec3]> {
    match data.iter().find(|f| f.0 == name) {
        Some((_, FieldData::Vector(v))) => Ok(v),
        _ => bail!(
            "{}: no 3-component point array \"{name}\" (not a tetsim frame?)",
            path.display()
        ),
    }
}

fn scalars<'a>(
    path: &Path,
    data: &'a [(String, FieldData)],
    name: &str,
) -> anyhow::Result<&'a [f64]> {
    match data.iter().find(|f| f.0 == name) {
        Some((_, FieldData::Scalar(v))) => Ok(v),
        _ => bail!("{}: no cell array \"{name}\"", path.display()),
    }
}

/// Parse `FIRST..LAST` or `N` into an inclusive index range within `count` frames.
fn frame_range(spec: Option<&str>, count: usize) -> anyhow::Result<(usize, usize)> {
    let parse = |s: &str| {
        s.trim()
            .parse::<usize>()
            .with_context(|| format!("--frames: not a frame number: {s:?}"))
    };
    let (first, last) = match spec {
        None => (0, count - 1),
        Some(s) => match s.split_once("..") {
            Some((a, b)) => (
                if a.is_empty() { 0 } else { parse(a)? },
                if b.is_empty() { count - 1 } else { parse(b)? },
            ),
            None => {
                let n = parse(s)?;
                (n, n)
            }
        },
    };
    anyhow::ensure!(
        first <= last && last < count,
        "--frames {first}..{last} is outside the run's {count} frames (0..{})",
        count - 1
    );
    Ok((first, last))
}
