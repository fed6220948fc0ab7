//! The on-disk contract (SPEC §8, §10, §11): `frame_NNNN.vtu`, `frames.pvd`, `surface_NNNN.obj`
//! and `steps.csv` in the output folder, every file written atomically (temp + rename) so that
//! an interrupted run leaves valid files behind.
//!
//! With contact on (SPEC §11), frames gain point data `contact_force`, steps.csv the columns of
//! [`CONTACT_COLUMNS`] after all others, and the obstacles go to `obstacles_NNNN.vtu` (every
//! frame when one moves, else frame 0 only) and `obstacles.pvd`. Without contact none of these
//! appear: the contact columns are left out rather than written empty, so that a scene without
//! contact writes the same bytes as before contact existed.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::contact::ContactSetup;
use crate::contact::display::{DisplaySurface, moves, scene_box};
use crate::elastic::ElasticBody;
use crate::error::{Error, Result};
use crate::integrator::StepStats;
use crate::io::obj::write_obj;
use crate::io::surface_vtu::write_surface_vtu;
use crate::io::vtu::write_quadratic_vtu;
use crate::io::{Field, atomic_write, write_pvd, write_vtu};
use crate::math::Vec3;
use crate::sim::Simulation;

mod fields;
mod frame;
pub mod render;
mod timings;
mod verify;

pub use frame::{FrameData, FrameTaker};
use timings::TimingsCsv;
pub use timings::{CONTACT_TIMING_COLUMNS, TIMINGS_HEADER};

/// The steps.csv header. The first eleven columns are the SPEC §10 contract; columns after them
/// are extensions (new ones are only ever appended).
pub const STEPS_HEADER: &str = "frame,time,newton_iterations,cg_iterations,residual,converged,elastic_energy,kinetic_energy,min_J,inverted_elements,wall_seconds,relative_residual,substeps,line_search_cuts,cg_breakdowns,cg_capped,clamped_tets,gravitational_energy,load_work,boundary_work,damping_dissipation,numerical_dissipation,energy_tolerance";

/// The steps.csv columns appended after [`STEPS_HEADER`]'s when contact is on: active contact
/// pairs at the end of the frame, the smallest gap then (m; empty when None), the contact
/// energy and the friction dissipated over the frame (J).
pub const CONTACT_COLUMNS: &str = "contacts,min_distance,contact_energy,friction_dissipation";

/// The steps.csv column appended last (after [`CONTACT_COLUMNS`] when contact is on): elements
/// evaluated with their model's recovery form at the end of the frame (see
/// [`crate::elastic::recovery`]).
pub const RECOVERY_COLUMNS: &str = "tangled_elements";

/// The whole steps.csv header: [`STEPS_HEADER`], then [`CONTACT_COLUMNS`] when `contact`, then
/// [`RECOVERY_COLUMNS`].
pub fn steps_header(contact: bool) -> String {
    if contact {
        format!("{STEPS_HEADER},{CONTACT_COLUMNS},{RECOVERY_COLUMNS}")
    } else {
        format!("{STEPS_HEADER},{RECOVERY_COLUMNS}")
    }
}

/// One frame's output files with their SHA-256, for the manifest.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFiles {
    /// Frame number.
    pub frame: usize,
    /// Time (s; quasistatic: the load factor).
    pub time: f64,
    /// (file name, SHA-256) of the frame's VTU and OBJ.
    pub files: Vec<(String, String)>,
}

/// Writes a run's files as it goes.
pub struct Recorder {
    dir: PathBuf,
    write_obj: bool,
    deterministic: bool,
    surface: Vec<[usize; 3]>,
    pvd: Vec<(f64, String)>,
    csv: String,
    timings: TimingsCsv,
    /// probes.csv and reactions.csv (SPEC §13): empty when the run has none.
    probes_csv: String,
    reactions_csv: String,
    frames: Vec<FrameFiles>,
    written: Vec<PathBuf>,
    /// Set at the first frame: None without contact.
    contact: Option<ContactOutput>,
    /// The output folder as the user named it, for the manifest.
    named: Option<String>,
    /// Problems the manifest reports (a picture that could not be drawn).
    problems: Vec<String>,
    /// The manifest's `info` object (see [`crate::info`]), made at the first manifest.
    info: Option<serde_json::Value>,
    /// Set at the first frame: None without render surfaces.
    render: Option<render::RenderOutput>,
}

/// What the recorder keeps when contact is on.
struct ContactOutput {
    /// The obstacles' triangles at rest.
    surface: DisplaySurface,
    /// Whether any obstacle moves (then every frame gets its obstacles file).
    moving: bool,
    /// `obstacles.pvd`'s entries.
    pvd: Vec<(f64, String)>,
    /// The obstacles and their motions.
    setup: ContactSetup,
}

impl Recorder {
    /// Create (or reuse) the output folder.
    pub fn create(dir: &Path, body: &ElasticBody, write_obj: bool) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        Ok(Recorder {
            dir: dir.to_path_buf(),
            write_obj,
            surface: body.mesh.boundary_faces(),
            deterministic: false,
            pvd: Vec::new(),
            // The header waits for the first frame, which says whether contact is on.
            csv: String::new(),
            timings: TimingsCsv::new(false),
            probes_csv: String::new(),
            reactions_csv: String::new(),
            frames: Vec::new(),
            written: Vec::new(),
            contact: None,
            named: None,
            problems: Vec::new(),
            info: None,
            render: None,
        })
    }

    /// Name the output folder in the manifest as the user named it (`--out`; default: the
    /// path the recorder was made with).
    pub fn named(mut self, name: impl Into<String>) -> Self {
        self.named = Some(name.into());
        self
    }

    /// Report a problem in the manifest (`problems`), e.g. pictures that could not be drawn.
    pub fn note_problem(&mut self, problem: &str) {
        self.problems.push(problem.to_string());
    }

    /// The bookkeeping a checkpoint stores (see [`crate::checkpoint::RecorderState`]).
    pub fn snapshot(&self) -> crate::checkpoint::RecorderState {
        crate::checkpoint::RecorderState {
            pvd: self.pvd.clone(),
            obstacles_pvd: self.contact.as_ref().map(|c| c.pvd.clone()),
            frames: self
                .frames
                .iter()
                .map(|f| (f.frame, f.time, f.files.clone()))
                .collect(),
            steps_csv: (self.csv.len() as u64, crc32fast::hash(self.csv.as_bytes())),
        }
    }

    /// Write `render.glb`, the animation of the render surfaces over every frame written (also
    /// those before a resume), when the run has render surfaces. Call it after the last frame.
    pub fn write_animation(&mut self) -> Result<()> {
        let Some(out) = &self.render else {
            return Ok(());
        };
        let frames: Vec<(usize, f64)> = self
            .frames
            .iter()
            .filter(|f| f.files.iter().any(|(n, _)| n.starts_with("render_")))
            .map(|f| (f.frame, f.time))
            .collect();
        if let Some(path) = out.write_animation(&self.dir, &frames)? {
            self.note(path);
        }
        Ok(())
    }

    /// Take up a run in `dir` from its checkpoint's bookkeeping, `sim` being restored to the
    /// checkpoint's frame: steps.csv and timings.csv are cut back to that frame (a frame written
    /// after the checkpoint is written again), frames.pvd and obstacles.pvd rewritten, and the
    /// files of later frames removed.
    pub fn resume(
        dir: &Path,
        sim: &Simulation,
        write_obj: bool,
        saved: &crate::checkpoint::RecorderState,
    ) -> Result<Self> {
        let mut r = Recorder::create(dir, &sim.body, write_obj)?;
        r.start(sim)?;
        let steps = dir.join("steps.csv");
        let text = std::fs::read(&steps).map_err(|e| Error::io(&steps, e))?;
        let (len, crc) = saved.steps_csv;
        let head = text.get(..len as usize).ok_or_else(|| {
            Error::parameter(
                "resume",
                format!("{}: shorter than the checkpoint's frame", steps.display()),
            )
        })?;
        if crc32fast::hash(head) != crc {
            return Err(Error::parameter(
                "resume",
                format!(
                    "{}: its rows up to the checkpoint's frame were changed since",
                    steps.display()
                ),
            ));
        }
        r.csv = String::from_utf8_lossy(head).into_owned();
        // timings.csv (wall-clock times, never in the checkpoint): its rows up to the frame.
        let last = sim.frame();
        let timings = std::fs::read_to_string(dir.join("timings.csv")).unwrap_or_default();
        r.timings.keep_rows(&timings, last);
        // probes.csv and reactions.csv: their rows up to the frame, like timings.csv.
        let monitors = [
            ("probes.csv", r.probes_csv.clone()),
            ("reactions.csv", r.reactions_csv.clone()),
        ];
        for (name, header) in monitors {
            if header.is_empty() {
                continue;
            }
            let kept = rows_up_to(&dir.join(name), &header, last)?;
            match name {
                "probes.csv" => r.probes_csv = kept,
                _ => r.reactions_csv = kept,
            }
        }
        r.pvd.clone_from(&saved.pvd);
        r.frames = saved
            .frames
            .iter()
            .map(|(frame, time, files)| FrameFiles {
                frame: *frame,
                time: *time,
                files: files.clone(),
            })
            .collect();
        verify::verify_frames(dir, &r.frames)?;
        if let (Some(out), Some(pvd)) = (&mut r.contact, &saved.obstacles_pvd) {
            out.pvd.clone_from(pvd);
        }
        for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
            let path = entry.map_err(|e| Error::io(dir, e))?.path();
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            // Frames after the checkpoint's, and what a killed run left half-written.
            let later = frame_number(&name).is_some_and(|k| k > last);
            let stray = temporary_of(&name)
                .is_some_and(|n| frame_number(n).is_some() || RUN_FILES.contains(&n));
            if later || stray {
                std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            }
        }
        let names: Vec<PathBuf> = r
            .frames
            .iter()
            .flat_map(|f| f.files.iter().map(|(name, _)| dir.join(name)))
            .collect();
        names.into_iter().for_each(|path| r.note(path));
        let csv = &r.csv;
        atomic_write(&steps, |w| w.write_all(csv.as_bytes()))?;
        let timings = r.timings.text();
        atomic_write(&dir.join("timings.csv"), |w| {
            w.write_all(timings.as_bytes())
        })?;
        write_pvd(&dir.join("frames.pvd"), &r.pvd)?;
        if let Some(out) = &r.contact {
            write_pvd(&dir.join("obstacles.pvd"), &out.pvd)?;
        }
        for name in ["frames.pvd", "steps.csv", "timings.csv"] {
            r.note(dir.join(name));
        }
        for (name, text) in [
            ("probes.csv", r.probes_csv.clone()),
            ("reactions.csv", r.reactions_csv.clone()),
        ] {
            if !text.is_empty() {
                let path = dir.join(name);
                atomic_write(&path, |w| w.write_all(text.as_bytes()))?;
                r.note(path);
            }
        }
        Ok(r)
    }

    /// Write 0 in steps.csv's wall_seconds column (the times still go to timings.csv), so that
    /// every file the manifest lists is byte-identical across runs. See [`crate::manifest`].
    pub fn deterministic(mut self, on: bool) -> Self {
        self.deterministic = on;
        self
    }

    /// The files of every frame written so far, with their SHA-256.
    pub fn frame_files(&self) -> &[FrameFiles] {
        &self.frames
    }

    /// The output folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Every file written so far (each path once).
    pub fn files(&self) -> &[PathBuf] {
        &self.written
    }

    /// Write the current frame of `sim`: its VTU (and OBJ), then the updated PVD and steps.csv.
    /// `stats` is None for frame 0 (the initial state).
    pub fn write_frame(&mut self, sim: &Simulation, stats: Option<&StepStats>) -> Result<()> {
        if self.csv.is_empty() {
            self.start(sim)?;
        }
        self.write(FrameTaker::new(sim).take(sim, stats))
    }

    /// Whether the first frame (or a resume) has set the recorder up: only then can
    /// [`Recorder::write`] take frames without the simulation.
    pub fn is_started(&self) -> bool {
        !self.csv.is_empty()
    }

    /// Write a frame taken from the simulation (see [`FrameTaker`]): its VTU (and OBJ, and the
    /// obstacles' file), then the updated PVD, steps.csv, timings.csv and the probes' and
    /// reactions' rows. The recorder must be started ([`Recorder::is_started`]).
    pub fn write(&mut self, data: FrameData) -> Result<()> {
        let frame = data.frame;
        let name = format!("frame_{frame:04}.vtu");
        let mut point_data = vec![
            ("displacement", Field::Vector(&data.displacement)),
            ("velocity", Field::Vector(&data.v)),
            ("fixed", Field::Scalar(&data.fixed)),
        ];
        if let Some(f) = &data.contact_force {
            point_data.push(("contact_force", Field::Vector(f)));
        }
        let mut cell_data = vec![
            ("J", Field::Scalar(&data.j)),
            ("strain_energy_density", Field::Scalar(&data.psi)),
            ("von_mises", Field::Scalar(&data.von_mises)),
        ];
        // Several bodies: which body each point and cell is (output order is body after body).
        if let Some(tags) = &data.tags {
            point_data.push(("body", Field::Scalar(&tags.0)));
            cell_data.push(("body", Field::Scalar(&tags.1)));
        }
        let path = self.dir.join(&name);
        if data.edge_nodes.is_empty() {
            write_vtu(&path, &data.x, &data.tets, &point_data, &cell_data)?;
        } else {
            // 10-node cells, so that ParaView draws the bent elements curved.
            let cells: Vec<[usize; 10]> = data
                .tets
                .iter()
                .zip(data.edge_nodes.iter())
                .map(|(c, e)| [c[0], c[1], c[2], c[3], e[0], e[1], e[2], e[3], e[4], e[5]])
                .collect();
            write_quadratic_vtu(&path, &data.x, &cells, &point_data, &cell_data)?;
        }
        let mut files = vec![(name.clone(), crate::manifest::sha256_file(&path)?)];
        self.note(path);
        if self.write_obj {
            let obj = format!("surface_{frame:04}.obj");
            let path = self.dir.join(&obj);
            write_obj(&path, &data.x, &self.surface)?;
            files.push((obj, crate::manifest::sha256_file(&path)?));
            self.note(path);
        }
        if let Some(out) = &self.render {
            let path = out.write_frame(&self.dir, frame, &data.render)?;
            let name = render::render_file(frame);
            files.push((name, crate::manifest::sha256_file(&path)?));
            self.note(path);
        }
        self.write_obstacles(frame, data.time, &data.obstacle_ramps, &mut files)?;
        self.frames.push(FrameFiles {
            frame,
            time: data.time,
            files,
        });
        self.pvd.push((data.time, name));
        let path = self.dir.join("frames.pvd");
        write_pvd(&path, &self.pvd)?;
        self.note(path);
        let row = &data.row;
        let mut csv_row = row.clone();
        if self.deterministic {
            csv_row.wall_seconds = 0.0;
        }
        push_row(&mut self.csv, &csv_row, self.contact.is_some());
        let path = self.dir.join("steps.csv");
        let csv = &self.csv;
        atomic_write(&path, |w| w.write_all(csv.as_bytes()))?;
        self.note(path);
        self.timings
            .push(frame, row.wall_seconds, &row.timings, data.contact_costs);
        let path = self.dir.join("timings.csv");
        let timings = self.timings.text();
        atomic_write(&path, |w| w.write_all(timings.as_bytes()))?;
        self.note(path);
        self.write_monitors(frame, data.time, &data.probes, &data.reactions)
    }

    /// A row of probes.csv (each probe's displacement, m) and of reactions.csv (each named
    /// constraint's reaction force, N) for the current frame, when the run has them.
    fn write_monitors(
        &mut self,
        frame: usize,
        time: f64,
        probes: &[Vec3],
        reactions: &[Vec3],
    ) -> Result<()> {
        let start = format!("{frame},{}", num(time));
        let rows = [("probes.csv", probes), ("reactions.csv", reactions)];
        for (name, values) in rows {
            if values.is_empty() {
                continue;
            }
            let text = match name {
                "probes.csv" => &mut self.probes_csv,
                _ => &mut self.reactions_csv,
            };
            text.push_str(&start);
            for c in values.iter().flat_map(|v| v.iter()) {
                text.push(',');
                text.push_str(&num(*c));
            }
            text.push('\n');
            let path = self.dir.join(name);
            let bytes = text.as_bytes();
            atomic_write(&path, |w| w.write_all(bytes))?;
            self.note(path);
        }
        Ok(())
    }

    /// Write `manifest.json`: tetsim's version, the scene's and inputs' hashes, every resolved
    /// parameter, the hash of every output file per frame, and `status` (e.g. "complete" or why
    /// the run stopped). Call it after the last frame (or when the run stops early).
    pub fn write_manifest(
        &mut self,
        scene: &crate::scene::Scene,
        sim: &Simulation,
        status: &str,
    ) -> Result<()> {
        use crate::manifest::{DETERMINISM_NOTE, input_hashes, resolved_parameters, sha256_file};
        let frames: Vec<serde_json::Value> = self
            .frames
            .iter()
            .map(|f| {
                let files: serde_json::Map<String, serde_json::Value> = f
                    .files
                    .iter()
                    .map(|(name, hash)| (name.clone(), hash.clone().into()))
                    .collect();
                serde_json::json!({ "frame": f.frame, "time": f.time, "files": files })
            })
            .collect();
        let mut collected = serde_json::Map::new();
        for name in [
            "frames.pvd",
            "steps.csv",
            "obstacles.pvd",
            "probes.csv",
            "reactions.csv",
            render::ANIMATION_FILE,
        ] {
            let path = self.dir.join(name);
            if path.exists() {
                collected.insert(name.into(), sha256_file(&path)?.into());
            }
        }
        let manifest = serde_json::json!({
            "tetsim_version": env!("CARGO_PKG_VERSION"),
            "status": status,
            "frame": self.frames.last().map(|f| f.frame),
            "output_dir": self.named.clone().unwrap_or_else(|| self.dir.display().to_string()),
            "deterministic": self.deterministic,
            "determinism": DETERMINISM_NOTE,
            "scene": {
                "path": scene.path.display().to_string(),
                "sha256": crate::manifest::sha256_hex(scene.source().as_bytes()),
            },
            "inputs": input_hashes(scene)?,
            "parameters": resolved_parameters(scene, sim)?,
            "info": self
                .info
                .get_or_insert_with(|| {
                    crate::info::describe_with(scene, sim, crate::info::Effort::Bounded).to_json()
                }),
            "outputs": { "files": collected, "frames": frames },
        });
        let mut manifest = manifest;
        if !self.problems.is_empty() {
            manifest["problems"] = self.problems.clone().into();
        }
        let text = serde_json::to_string_pretty(&manifest)
            .map_err(|e| Error::parameter("manifest", e.to_string()))?;
        let path = self.dir.join("manifest.json");
        atomic_write(&path, |w| writeln!(w, "{text}"))?;
        self.note(path);
        Ok(())
    }

    /// At the first frame: the steps.csv header (and probes.csv's and reactions.csv's when the
    /// run has them), and with contact the obstacles at rest.
    fn start(&mut self, sim: &Simulation) -> Result<()> {
        self.render = render::RenderOutput::new(sim, &self.dir)?;
        self.csv = format!("{}\n", steps_header(false));
        let monitors = sim.monitors();
        if !monitors.probes.is_empty() {
            self.probes_csv = format!("{}\n", monitors.probes_header());
        }
        if !monitors.reactions.is_empty() {
            self.reactions_csv = format!("{}\n", monitors.reactions_header());
        }
        self.timings = TimingsCsv::new(sim.contact().is_some());
        // A simulation on a renumbered mesh writes in the input mesh's numbering.
        if sim.renumbering().is_some() {
            let taker = FrameTaker::new(sim);
            self.surface = taker.mesh().boundary_faces();
        }
        if let Some(setup) = sim.contact_setup() {
            self.csv = format!("{}\n", steps_header(true));
            let scene = scene_box(sim.initial_positions(), setup);
            self.contact = Some(ContactOutput {
                surface: DisplaySurface::new(setup, scene),
                moving: setup.obstacles.iter().any(|o| moves(&o.obstacle)),
                pvd: Vec::new(),
                setup: setup.clone(),
            });
        }
        Ok(())
    }

    /// `obstacles_NNNN.vtu` (every frame when an obstacle moves, else only the first) and
    /// `obstacles.pvd`.
    fn write_obstacles(
        &mut self,
        frame: usize,
        time: f64,
        ramps: &[f64],
        files: &mut Vec<(String, String)>,
    ) -> Result<()> {
        let Some(out) = &mut self.contact else {
            return Ok(());
        };
        if !out.moving && !out.pvd.is_empty() {
            return Ok(());
        }
        let points = out.surface.positions_at(&out.setup, ramps);
        let index: Vec<f64> = out.surface.obstacle.iter().map(|&k| k as f64).collect();
        let name = format!("obstacles_{frame:04}.vtu");
        let path = self.dir.join(&name);
        write_surface_vtu(
            &path,
            &points,
            &out.surface.triangles,
            &[],
            &[
                ("obstacle", Field::Scalar(&index)),
                ("shape", Field::Scalar(&out.surface.shape)),
            ],
        )?;
        files.push((name.clone(), crate::manifest::sha256_file(&path)?));
        out.pvd.push((time, name));
        self.note(path);
        let path = self.dir.join("obstacles.pvd");
        write_pvd(&path, &self.contact.as_ref().expect("set above").pvd)?;
        self.note(path);
        Ok(())
    }

    fn note(&mut self, path: PathBuf) {
        if !self.written.contains(&path) {
            self.written.push(path);
        }
    }
}

/// The names of every file a tetsim run writes into its output folder, besides numbered frames.
pub const RUN_FILES: &[&str] = &[
    "frames.pvd",
    "obstacles.pvd",
    "steps.csv",
    "timings.csv",
    "probes.csv",
    "reactions.csv",
    "manifest.json",
    render::ANIMATION_FILE,
    crate::checkpoint::FILE_NAME,
    "preview.png",
    "animation.gif",
    "steps_newton.png",
    "steps_cg.png",
    "steps_residual.png",
    "steps_energy.png",
    "probes.png",
    "reactions.png",
];

/// The frame number of a numbered output file (`frame_0012.vtu` → 12; also `.pvtu`,
/// `surface_NNNN.obj`, `render_NNNN.obj` and `obstacles_NNNN.vtu`), None for any other name.
pub fn frame_number(name: &str) -> Option<usize> {
    let (stem, ext) = name.rsplit_once('.')?;
    let digits = match ext {
        "vtu" | "pvtu" => stem
            .strip_prefix("frame_")
            .or_else(|| stem.strip_prefix("obstacles_"))?,
        "obj" => stem
            .strip_prefix("surface_")
            .or_else(|| stem.strip_prefix("render_"))?,
        _ => return None,
    };
    // A piece of a split frame (frame_0012_3.vtu) belongs to frame 12.
    let digits = digits.split('_').next()?;
    (digits.len() >= 4 && digits.bytes().all(|b| b.is_ascii_digit()))
        .then(|| digits.parse().ok())
        .flatten()
}

/// A per-frame CSV of a stopped run cut back to frames 0..=`last` (its header first, which must
/// be `header`): a frame written after the checkpoint is written again.
fn rows_up_to(path: &Path, header: &str, last: usize) -> Result<String> {
    let problem = |what: &str| {
        Error::parameter(
            "resume",
            format!("{}: {what} since the run stopped", path.display()),
        )
    };
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut lines = text.lines();
    if lines.next() != Some(header.trim_end()) {
        return Err(problem("its header changed"));
    }
    let mut kept = format!("{}\n", header.trim_end());
    let mut expected = 0;
    for row in lines {
        let frame = row.split(',').next().and_then(|f| f.parse::<usize>().ok());
        match frame {
            Some(f) if f == expected && f <= last => {
                kept.push_str(row);
                kept.push('\n');
                expected += 1;
            }
            Some(f) if f > last => break,
            _ => return Err(problem("its rows were changed")),
        }
    }
    if expected != last + 1 {
        return Err(problem("rows up to the checkpoint's frame went missing"));
    }
    Ok(kept)
}

/// The file a temporary file of ours is for: `.NAME.PID.tmp` (see `io::atomic_write`) → NAME.
fn temporary_of(name: &str) -> Option<&str> {
    name.strip_prefix('.')
        .and_then(|n| n.strip_suffix(".tmp"))
        .and_then(|n| n.rsplit_once('.').map(|(b, _)| b))
}

/// Remove an earlier run's files from `dir` (numbered frames, [`RUN_FILES`] and leftover
/// temporary files of ours), so that the folder never holds two runs. Other files stay.
/// Returns how many were removed.
pub fn clear_previous_run(dir: &Path) -> Result<usize> {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(Error::io(dir, e)),
    };
    let mut removed = 0;
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let base = temporary_of(&name).unwrap_or(&name);
        let ours = frame_number(base).is_some() || RUN_FILES.contains(&base);
        if ours && entry.file_type().is_ok_and(|t| t.is_file()) {
            let path = entry.path();
            std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// One value of a steps.csv row, typed: what [`step_columns`] hands to callers that want the
/// numbers rather than the text (the Python module's `Simulation.step()` dict).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cell {
    /// A count (frame, iterations, elements).
    Count(usize),
    /// A real number.
    Real(f64),
    /// A flag (`converged`).
    Flag(bool),
    /// No value (`min_distance` when nothing is near); written as an empty field.
    Empty,
}

/// The steps.csv columns of one frame, named by the header ([`STEPS_HEADER`], then
/// [`CONTACT_COLUMNS`] when `contact`, then [`RECOVERY_COLUMNS`]), in order: the one list both the CSV row and the Python
/// module's `step()` dict are made from, so they cannot disagree.
pub fn step_columns(s: &StepStats, contact: bool) -> Vec<(&'static str, Cell)> {
    use Cell::{Count, Flag, Real};
    let mut values = vec![
        Count(s.frame),
        Real(s.time),
        Count(s.newton_iterations),
        Count(s.cg_iterations),
        Real(s.residual),
        Flag(s.converged),
        Real(s.elastic_energy),
        Real(s.kinetic_energy),
        Real(s.min_j),
        Count(s.inverted_elements),
        Real(s.wall_seconds),
        Real(s.relative_residual),
        Count(s.substeps),
        Count(s.line_search_cuts),
        Count(s.cg_breakdowns),
        Count(s.cg_capped),
        Count(s.clamped_tets),
        Real(s.energy.gravitational),
        Real(s.energy.load_work),
        Real(s.energy.boundary_work),
        Real(s.energy.damping_dissipation),
        Real(s.energy.numerical_dissipation),
        Real(s.energy.tolerance),
    ];
    let mut names: Vec<&'static str> = STEPS_HEADER.split(',').collect();
    if contact {
        values.extend([
            Count(s.contacts),
            s.min_distance.map_or(Cell::Empty, Real),
            Real(s.contact_energy),
            Real(s.friction_dissipation),
        ]);
        names.extend(CONTACT_COLUMNS.split(','));
    }
    values.push(Count(s.tangled_elements));
    names.extend(RECOVERY_COLUMNS.split(','));
    debug_assert_eq!(names.len(), values.len(), "a column without a name");
    names.into_iter().zip(values).collect()
}

/// One steps.csv row (with the contact columns when `contact`).
fn push_row(csv: &mut String, s: &StepStats, contact: bool) {
    let cells: Vec<String> = step_columns(s, contact)
        .into_iter()
        .map(|(_, cell)| match cell {
            Cell::Count(n) => n.to_string(),
            Cell::Real(x) => num(x),
            Cell::Flag(b) => b.to_string(),
            Cell::Empty => String::new(),
        })
        .collect();
    let _ = writeln!(csv, "{}", cells.join(","));
}

/// A number for CSV: plain for ordinary magnitudes, exponent form otherwise, always
/// round-trip exact.
fn num(x: f64) -> String {
    if x == 0.0 {
        // −0 too: the sign of a zero is noise.
        "0".into()
    } else if (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}
