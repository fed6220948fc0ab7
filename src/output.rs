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
use crate::io::{Field, atomic_write, write_pvd, write_vtu};
use crate::math::Vec3;
use crate::sim::Simulation;

/// The steps.csv header. The first eleven columns are the SPEC §10 contract; columns after them
/// are extensions (new ones are only ever appended).
pub const STEPS_HEADER: &str = "frame,time,newton_iterations,cg_iterations,residual,converged,elastic_energy,kinetic_energy,min_J,inverted_elements,wall_seconds,relative_residual,substeps,line_search_cuts,cg_breakdowns,cg_capped,clamped_tets,gravitational_energy,load_work,boundary_work,damping_dissipation,numerical_dissipation,energy_tolerance";

/// The steps.csv columns appended after [`STEPS_HEADER`]'s when contact is on: active contact
/// pairs at the end of the frame, the smallest gap then (m; empty when None), the contact
/// energy and the friction dissipated over the frame (J).
pub const CONTACT_COLUMNS: &str = "contacts,min_distance,contact_energy,friction_dissipation";

/// The header of timings.csv: wall-clock seconds per frame, split by phase (never deterministic,
/// never hashed in the manifest).
pub const TIMINGS_HEADER: &str =
    "frame,wall_seconds,evaluate_seconds,preconditioner_seconds,cg_seconds";

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
    /// Whether `surface` names the input mesh's vertices (set at the first frame of a
    /// simulation on a renumbered mesh).
    surface_in_file_order: bool,
    pvd: Vec<(f64, String)>,
    csv: String,
    timings: String,
    frames: Vec<FrameFiles>,
    written: Vec<PathBuf>,
    /// Set at the first frame: None without contact.
    contact: Option<ContactOutput>,
}

/// What the recorder keeps when contact is on.
struct ContactOutput {
    /// The obstacles' triangles at rest.
    surface: DisplaySurface,
    /// Whether any obstacle moves (then every frame gets its obstacles file).
    moving: bool,
    /// `obstacles.pvd`'s entries.
    pvd: Vec<(f64, String)>,
}

impl Recorder {
    /// Create (or reuse) the output folder.
    pub fn create(dir: &Path, body: &ElasticBody, write_obj: bool) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        Ok(Recorder {
            dir: dir.to_path_buf(),
            write_obj,
            surface: body.mesh.boundary_faces(),
            surface_in_file_order: false,
            deterministic: false,
            pvd: Vec::new(),
            // The header waits for the first frame, which says whether contact is on.
            csv: String::new(),
            timings: format!("{TIMINGS_HEADER}\n"),
            frames: Vec::new(),
            written: Vec::new(),
            contact: None,
        })
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
        let frame = sim.frame();
        let body = &sim.body;
        let name = format!("frame_{frame:04}.vtu");
        let mut x = sim.state.x.clone();
        let mut v = sim.state.v.clone();
        let mut rest = body.mesh.positions.clone();
        let mut j = body.jacobians(&x);
        let mut psi = body.energy_densities(&x);
        let mut von_mises = body.von_mises_stresses(&x);
        // How many components of each vertex are prescribed (0–3): lets `tetsim render` mark
        // fixed vertices from the frames alone.
        let mut fixed: Vec<f64> = sim.free_mask().iter().map(|m| 3.0 - m.sum()).collect();
        let mut tets = body.mesh.tets.clone();
        // A simulation on a renumbered mesh writes in the input mesh's numbering.
        if let Some(r) = sim.renumbering() {
            for field in [&mut x, &mut v, &mut rest] {
                *field = r.vertices_to_old(field);
            }
            fixed = r.vertices_to_old(&fixed);
            for field in [&mut j, &mut psi, &mut von_mises] {
                *field = r.tets_to_old(field);
            }
            tets = r.tets_to_old_mesh(&tets);
            if !self.surface_in_file_order {
                self.surface =
                    crate::mesh::TetMesh::new(rest.clone(), tets.clone()).boundary_faces();
                self.surface_in_file_order = true;
            }
        }
        let displacement: Vec<Vec3> = x.iter().zip(&rest).map(|(x, rest)| x - rest).collect();
        if self.csv.is_empty() {
            self.start(sim);
        }
        let mut point_data = vec![
            ("displacement", Field::Vector(&displacement)),
            ("velocity", Field::Vector(&v)),
            ("fixed", Field::Scalar(&fixed)),
        ];
        let contact_force = self.contact.as_ref().map(|_| {
            let f = sim.contact_forces();
            let f = if f.len() == x.len() {
                f.to_vec()
            } else {
                vec![Vec3::zeros(); x.len()]
            };
            match sim.renumbering() {
                Some(r) => r.vertices_to_old(&f),
                None => f,
            }
        });
        if let Some(f) = &contact_force {
            point_data.push(("contact_force", Field::Vector(f)));
        }
        let path = self.dir.join(&name);
        write_vtu(
            &path,
            &x,
            &tets,
            &point_data,
            &[
                ("J", Field::Scalar(&j)),
                ("strain_energy_density", Field::Scalar(&psi)),
                ("von_mises", Field::Scalar(&von_mises)),
            ],
        )?;
        let mut files = vec![(name.clone(), crate::manifest::sha256_file(&path)?)];
        self.note(path);
        if self.write_obj {
            let obj = format!("surface_{frame:04}.obj");
            let path = self.dir.join(&obj);
            write_obj(&path, &x, &self.surface)?;
            files.push((obj, crate::manifest::sha256_file(&path)?));
            self.note(path);
        }
        if let Some(setup) = sim.contact_setup() {
            self.write_obstacles(sim, setup, &mut files)?;
        }
        self.frames.push(FrameFiles {
            frame,
            time: sim.state.t,
            files,
        });
        self.pvd.push((sim.state.t, name));
        let path = self.dir.join("frames.pvd");
        write_pvd(&path, &self.pvd)?;
        self.note(path);
        let row = match stats {
            Some(s) => s.clone(),
            None => StepStats {
                frame,
                time: sim.state.t,
                converged: true,
                elastic_energy: body.energy(&sim.state.x),
                kinetic_energy: sim.kinetic_energy(),
                min_j: j.iter().copied().fold(f64::INFINITY, f64::min),
                inverted_elements: j.iter().filter(|&&j| j <= 0.0).count(),
                energy: crate::audit::EnergyAudit {
                    gravitational: sim.gravitational_energy(),
                    ..Default::default()
                },
                ..Default::default()
            },
        };
        let mut csv_row = row.clone();
        if self.deterministic {
            csv_row.wall_seconds = 0.0;
        }
        push_row(&mut self.csv, &csv_row, self.contact.is_some());
        let path = self.dir.join("steps.csv");
        let csv = &self.csv;
        atomic_write(&path, |w| w.write_all(csv.as_bytes()))?;
        self.note(path);
        let t = &row.timings;
        let _ = writeln!(
            self.timings,
            "{frame},{},{},{},{}",
            num(row.wall_seconds),
            num(t.evaluate),
            num(t.preconditioner),
            num(t.cg)
        );
        let path = self.dir.join("timings.csv");
        let timings = &self.timings;
        atomic_write(&path, |w| w.write_all(timings.as_bytes()))?;
        self.note(path);
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
        for name in ["frames.pvd", "steps.csv", "obstacles.pvd"] {
            let path = self.dir.join(name);
            if path.exists() {
                collected.insert(name.into(), sha256_file(&path)?.into());
            }
        }
        let manifest = serde_json::json!({
            "tetsim_version": env!("CARGO_PKG_VERSION"),
            "status": status,
            "deterministic": self.deterministic,
            "determinism": DETERMINISM_NOTE,
            "scene": {
                "path": scene.path.display().to_string(),
                "sha256": crate::manifest::sha256_hex(scene.source().as_bytes()),
            },
            "inputs": input_hashes(scene)?,
            "parameters": resolved_parameters(scene, sim)?,
            "outputs": { "files": collected, "frames": frames },
        });
        let text = serde_json::to_string_pretty(&manifest)
            .map_err(|e| Error::parameter("manifest", e.to_string()))?;
        let path = self.dir.join("manifest.json");
        atomic_write(&path, |w| writeln!(w, "{text}"))?;
        self.note(path);
        Ok(())
    }

    /// At the first frame: the steps.csv header, and with contact the obstacles at rest.
    fn start(&mut self, sim: &Simulation) {
        self.csv = format!("{STEPS_HEADER}\n");
        if let Some(setup) = sim.contact_setup() {
            self.csv = format!("{STEPS_HEADER},{CONTACT_COLUMNS}\n");
            let scene = scene_box(sim.initial_positions(), setup);
            self.contact = Some(ContactOutput {
                surface: DisplaySurface::new(setup, scene),
                moving: setup.obstacles.iter().any(|o| moves(&o.obstacle)),
                pvd: Vec::new(),
            });
        }
    }

    /// `obstacles_NNNN.vtu` (every frame when an obstacle moves, else only the first) and
    /// `obstacles.pvd`.
    fn write_obstacles(
        &mut self,
        sim: &Simulation,
        setup: &ContactSetup,
        files: &mut Vec<(String, String)>,
    ) -> Result<()> {
        let Some(out) = &mut self.contact else {
            return Ok(());
        };
        if !out.moving && !out.pvd.is_empty() {
            return Ok(());
        }
        let ramps: Vec<f64> = setup
            .obstacles
            .iter()
            .map(|o| sim.motion_ramp(o.duration))
            .collect();
        let points = out.surface.positions_at(setup, &ramps);
        let index: Vec<f64> = out.surface.obstacle.iter().map(|&k| k as f64).collect();
        let name = format!("obstacles_{:04}.vtu", sim.frame());
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
        out.pvd.push((sim.state.t, name));
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
/// [`CONTACT_COLUMNS`] when `contact`), in order: the one list both the CSV row and the Python
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
