//! A saved run's frames (frames.pvd, frame_NNNN.vtu, obstacles.pvd) as a [`FrameSource`]: read
//! one at a time, so drawing a long run's pictures holds one frame in memory. Shared by
//! `tetsim run` (its pictures, drawn after the frames, from disk, so a resumed run's pictures
//! cover the frames before the stop too) and `tetsim render`.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use tetsim::io::surface_vtu::read_surface_vtu;
use tetsim::io::vtu::read_pvd;
use tetsim::io::{FieldData, read_vtu_frame};
use tetsim::math::Vec3;
use tetsim::mesh::TetMesh;
use tetsim::render::{
    self, FieldKind, FrameSource, ObstacleView, OwnedFrame, RenderMesh, RenderParams,
    RunPictureParams,
};

/// The chosen frames of a saved run.
pub struct SavedRun {
    dir: PathBuf,
    /// (frame index, time, file) of the chosen frames.
    frames: Vec<(usize, f64, String)>,
    obstacle_files: Vec<(f64, String)>,
    field: Option<FieldKind>,
    /// The obstacles file read last, and what it holds (moving obstacles have one per frame).
    obstacles: Option<(String, ObstacleView)>,
}

impl SavedRun {
    /// The frames of the run in `dir` whose index `choose` accepts (frames.pvd lists them).
    pub fn open(
        dir: &Path,
        field: Option<FieldKind>,
        choose: impl Fn(usize) -> bool,
    ) -> anyhow::Result<Self> {
        let pvd = dir.join("frames.pvd");
        let entries = read_pvd(&pvd)?;
        anyhow::ensure!(!entries.is_empty(), "{}: lists no frames", pvd.display());
        let frames = entries
            .into_iter()
            .enumerate()
            .filter(|(i, _)| choose(*i))
            .map(|(i, (time, file))| (i, time, file))
            .collect();
        let obstacles_pvd = dir.join("obstacles.pvd");
        let obstacle_files = if obstacles_pvd.exists() {
            read_pvd(&obstacles_pvd)?
        } else {
            Vec::new()
        };
        Ok(SavedRun {
            dir: dir.to_path_buf(),
            frames,
            obstacle_files,
            field,
            obstacles: None,
        })
    }

    /// The rest mesh (points − displacement, and the tets) and fixed vertices of the first
    /// chosen frame.
    pub fn mesh(&self) -> anyhow::Result<(RenderMesh, Vec<bool>)> {
        let (_, _, file) = self.frames.first().context("no frame in the range")?;
        let path = self.dir.join(file);
        rest_mesh(&path, &read_vtu_frame(&path)?)
    }

    /// The times of the first and last chosen frames.
    pub fn time_span(&self) -> (f64, f64) {
        let t = |k: Option<&(usize, f64, String)>| k.map_or(0.0, |f| f.1);
        (t(self.frames.first()), t(self.frames.last()))
    }

    fn load_frame(&mut self, i: usize) -> anyhow::Result<OwnedFrame> {
        let (index, time, file) = self.frames[i].clone();
        let path = self.dir.join(&file);
        let frame = read_vtu_frame(&path)?;
        let field = match self.field {
            None => Vec::new(),
            Some(FieldKind::Displacement) => vectors(&path, &frame.point_data, "displacement")?
                .iter()
                .map(|d| d.norm())
                .collect(),
            Some(kind) => scalars(&path, &frame.cell_data, cell_array(kind))?.to_vec(),
        };
        // The obstacles file of this frame: the last one written at or before its time.
        let (obstacles, ground) = match self.obstacle_files.iter().rev().find(|o| o.0 <= time) {
            None => (Vec::new(), None),
            Some((_, name)) => {
                if self.obstacles.as_ref().is_none_or(|o| &o.0 != name) {
                    let view = read_obstacles(&self.dir.join(name))?;
                    self.obstacles = Some((name.clone(), view));
                }
                let view = &self.obstacles.as_ref().expect("read above").1;
                (view.triangles.clone(), view.ground)
            }
        };
        Ok(OwnedFrame {
            frame: index,
            time,
            positions: frame.points,
            field,
            obstacles,
            ground,
        })
    }
}

impl FrameSource for SavedRun {
    fn len(&self) -> usize {
        self.frames.len()
    }

    fn load(&mut self, i: usize) -> tetsim::Result<OwnedFrame> {
        self.load_frame(i)
            .map_err(|e| tetsim::Error::parameter("render", format!("{e:#}")))
    }
}

/// Draw preview.png and animation.gif of the run in `dir` (the frames `choose` accepts) into
/// `out`, one frame in memory at a time.
pub fn render_saved(
    dir: &Path,
    out: &Path,
    params: &RunPictureParams,
    choose: impl Fn(usize) -> bool,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut run = SavedRun::open(dir, params.preview.field, choose)?;
    let (mesh, fixed) = run.mesh()?;
    Ok(render::render_run_from(
        &mesh, &fixed, &mut run, params, out,
    )?)
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
    let mut mesh = TetMesh::new(rest, frame.tets.clone());
    // 10-node cells: their faces drawn as four sub-triangles each, through the mid-edge nodes.
    mesh.edge_nodes = frame.edge_nodes.clone();
    Ok((RenderMesh::new(&mesh), fixed))
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
