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
    self, FieldChoice, FieldKind, FrameSource, MotionSummary, ObstacleView, OwnedFrame, RenderMesh,
    RunPictureParams,
};

/// The chosen frames of a saved run.
pub struct SavedRun {
    dir: PathBuf,
    /// (frame index, time, file) of the chosen frames.
    frames: Vec<(usize, f64, String)>,
    obstacle_files: Vec<(f64, String)>,
    field: Option<FieldKind>,
    /// The pictures' up direction (which plane obstacle is the ground depends on it).
    up: Vec3,
    /// The obstacles file read last, and what it holds (moving obstacles have one per frame).
    obstacles: Option<(String, ObstacleView)>,
}

impl SavedRun {
    /// The frames of the run in `dir` whose index `choose` accepts (frames.pvd lists them).
    pub fn open(
        dir: &Path,
        field: Option<FieldKind>,
        up: Vec3,
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
            up,
            obstacles: None,
        })
    }

    /// Colour by `field` from now on.
    pub fn set_field(&mut self, field: Option<FieldKind>) {
        self.field = field;
    }

    /// The field that shows what the bodies did ([`MotionSummary::choose`]), from a pass over
    /// the chosen frames, and the reason in a few words.
    pub fn choose_field(&self) -> anyhow::Result<(FieldKind, &'static str)> {
        let mut summary = MotionSummary::default();
        for (_, _, file) in &self.frames {
            let path = self.dir.join(file);
            let frame = read_vtu_frame(&path)?;
            let rest = rest_positions(&path, &frame)?;
            let fixed = flags(&frame.point_data, "fixed");
            summary.add_frame(&rest, &frame.points, &bodies(&frame.point_data), &fixed);
        }
        log::debug!("pictures: {summary:?}");
        Ok(summary.choose())
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
        let magnitudes = |name| -> anyhow::Result<Vec<f64>> {
            Ok(vectors(&path, &frame.point_data, name)?
                .iter()
                .map(|d| d.norm())
                .collect())
        };
        let field = match self.field {
            None => Vec::new(),
            Some(FieldKind::Displacement) => magnitudes("displacement")?,
            Some(FieldKind::Velocity) => magnitudes("velocity")?,
            // A run without contact writes no contact force: zero everywhere.
            Some(FieldKind::ContactForce) => match frame.point_field("contact_force") {
                Some(_) => magnitudes("contact_force")?,
                None => vec![0.0; frame.points.len()],
            },
            Some(FieldKind::RelativeDisplacement) => render::relative_displacements(
                &rest_positions(&path, &frame)?,
                &frame.points,
                &bodies(&frame.point_data),
            ),
            Some(kind) => scalars(&path, &frame.cell_data, cell_array(kind))?.to_vec(),
        };
        // The obstacles file of this frame: the last one written at or before its time.
        let (obstacles, ground) = match self.obstacle_files.iter().rev().find(|o| o.0 <= time) {
            None => (Vec::new(), None),
            Some((_, name)) => {
                if self.obstacles.as_ref().is_none_or(|o| &o.0 != name) {
                    let view = read_obstacles(&self.dir.join(name), self.up)?;
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
/// `out`, one frame in memory at a time, coloured by `field` (`Auto`: the field
/// [`SavedRun::choose_field`] picks, named in the caption with its reason). Returns the paths
/// written and the colour used, in words ("colour: von-mises (auto: …)").
pub fn render_saved(
    dir: &Path,
    out: &Path,
    params: &RunPictureParams,
    field: FieldChoice,
    choose: impl Fn(usize) -> bool,
) -> anyhow::Result<(Vec<PathBuf>, String)> {
    let mut run = SavedRun::open(dir, None, params.preview.up, choose)?;
    let mut params = params.clone();
    let mut reason = String::new();
    params.preview.field = match field {
        FieldChoice::None => None,
        FieldChoice::Kind(kind) => Some(kind),
        FieldChoice::Auto => {
            let (kind, why) = run.choose_field()?;
            reason = format!(" (auto: {why})");
            if !params.preview.title.is_empty() {
                params.preview.title.push_str("   ");
            }
            params
                .preview
                .title
                .push_str(&format!("auto colour: {why}"));
            Some(kind)
        }
    };
    run.set_field(params.preview.field);
    let (mesh, fixed) = run.mesh()?;
    let written = render::render_run_from(&mesh, &fixed, &mut run, &params, out)?;
    let name = params.preview.field.map_or("none", |k| k.name());
    Ok((written, format!("colour: {name}{reason}")))
}

/// The up direction of a saved run's pictures: against the gravity its manifest.json records
/// (`parameters.gravity`), +y when there is none or it cannot be read.
pub fn saved_up(dir: &Path) -> Vec3 {
    let gravity = std::fs::read(dir.join("manifest.json"))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).ok())
        .and_then(|m| {
            let g = m.get("parameters")?.get("gravity")?.as_array()?.clone();
            let c: Vec<f64> = g.iter().filter_map(|v| v.as_f64()).collect();
            (c.len() == 3).then(|| Vec3::new(c[0], c[1], c[2]))
        });
    gravity.map_or_else(Vec3::y, render::up_from_gravity)
}

/// An `obstacles_NNNN.vtu` read back and split into the ground and the other obstacles.
fn read_obstacles(path: &Path, up: Vec3) -> anyhow::Result<ObstacleView> {
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
        up,
    ))
}

/// The VTU cell array holding a field.
fn cell_array(kind: FieldKind) -> &'static str {
    match kind {
        FieldKind::J => "J",
        FieldKind::VonMises => "von_mises",
        FieldKind::EnergyDensity => "strain_energy_density",
        _ => "displacement",
    }
}

/// Rest positions (points − displacement) and tets of a frame, and its fixed vertices.
fn rest_mesh(path: &Path, frame: &tetsim::io::Frame) -> anyhow::Result<(RenderMesh, Vec<bool>)> {
    let rest = rest_positions(path, frame)?;
    let fixed = flags(&frame.point_data, "fixed");
    let mut mesh = TetMesh::new(rest, frame.tets.clone());
    // 10-node cells: their faces drawn as four sub-triangles each, through the mid-edge nodes.
    mesh.edge_nodes = frame.edge_nodes.clone();
    Ok((RenderMesh::new(&mesh), fixed))
}

/// A frame's rest positions: points − displacement.
fn rest_positions(path: &Path, frame: &tetsim::io::Frame) -> anyhow::Result<Vec<Vec3>> {
    let displacement = vectors(path, &frame.point_data, "displacement")?;
    Ok(frame
        .points
        .iter()
        .zip(displacement)
        .map(|(x, d)| x - d)
        .collect())
}

/// A 0/1 point array as flags (all false when the frame has none).
fn flags(data: &[(String, FieldData)], name: &str) -> Vec<bool> {
    match data.iter().find(|f| f.0 == name) {
        Some((_, FieldData::Scalar(v))) => v.iter().map(|&c| c > 0.0).collect(),
        _ => Vec::new(),
    }
}

/// The body of every point (empty for a one-body run, which writes no `body` array).
fn bodies(data: &[(String, FieldData)]) -> Vec<usize> {
    match data.iter().find(|f| f.0 == "body") {
        Some((_, FieldData::Scalar(v))) => v.iter().map(|&b| b.max(0.0) as usize).collect(),
        _ => Vec::new(),
    }
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
