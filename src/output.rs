//! The on-disk contract (SPEC §8, §10): `frame_NNNN.vtu`, `frames.pvd`, `surface_NNNN.obj` and
//! `steps.csv` in the output folder, every file written atomically (temp + rename) so that an
//! interrupted run leaves valid files behind.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::elastic::ElasticBody;
use crate::error::{Error, Result};
use crate::integrator::StepStats;
use crate::io::obj::write_obj;
use crate::io::{Field, atomic_write, write_pvd, write_vtu};
use crate::math::Vec3;
use crate::sim::Simulation;

/// The steps.csv header. The first eleven columns are the SPEC §10 contract; columns after them
/// are extensions (new ones are only ever appended).
pub const STEPS_HEADER: &str = "frame,time,newton_iterations,cg_iterations,residual,converged,elastic_energy,kinetic_energy,min_J,inverted_elements,wall_seconds,relative_residual,substeps,line_search_cuts,cg_breakdowns,cg_capped,clamped_tets";

/// Writes a run's files as it goes.
pub struct Recorder {
    dir: PathBuf,
    write_obj: bool,
    surface: Vec<[usize; 3]>,
    pvd: Vec<(f64, String)>,
    csv: String,
    written: Vec<PathBuf>,
}

impl Recorder {
    /// Create (or reuse) the output folder.
    pub fn create(dir: &Path, body: &ElasticBody, write_obj: bool) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        Ok(Recorder {
            dir: dir.to_path_buf(),
            write_obj,
            surface: body.mesh.boundary_faces(),
            pvd: Vec::new(),
            csv: format!("{STEPS_HEADER}\n"),
            written: Vec::new(),
        })
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
        let x = &sim.state.x;
        let name = format!("frame_{frame:04}.vtu");
        let displacement: Vec<Vec3> = x
            .iter()
            .zip(&body.mesh.positions)
            .map(|(x, rest)| x - rest)
            .collect();
        let j = body.jacobians(x);
        let psi = body.energy_densities(x);
        let von_mises = body.von_mises_stresses(x);
        // How many components of each vertex are prescribed (0–3): lets `tetsim render` mark
        // fixed vertices from the frames alone.
        let fixed: Vec<f64> = sim.free_mask().iter().map(|m| 3.0 - m.sum()).collect();
        let path = self.dir.join(&name);
        write_vtu(
            &path,
            x,
            &body.mesh.tets,
            &[
                ("displacement", Field::Vector(&displacement)),
                ("velocity", Field::Vector(&sim.state.v)),
                ("fixed", Field::Scalar(&fixed)),
            ],
            &[
                ("J", Field::Scalar(&j)),
                ("strain_energy_density", Field::Scalar(&psi)),
                ("von_mises", Field::Scalar(&von_mises)),
            ],
        )?;
        self.note(path);
        if self.write_obj {
            let path = self.dir.join(format!("surface_{frame:04}.obj"));
            write_obj(&path, x, &self.surface)?;
            self.note(path);
        }
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
                elastic_energy: body.energy(x),
                kinetic_energy: sim.kinetic_energy(),
                min_j: j.iter().copied().fold(f64::INFINITY, f64::min),
                inverted_elements: j.iter().filter(|&&j| j <= 0.0).count(),
                ..Default::default()
            },
        };
        push_row(&mut self.csv, &row);
        let path = self.dir.join("steps.csv");
        let csv = &self.csv;
        atomic_write(&path, |w| w.write_all(csv.as_bytes()))?;
        self.note(path);
        Ok(())
    }

    fn note(&mut self, path: PathBuf) {
        if !self.written.contains(&path) {
            self.written.push(path);
        }
    }
}

/// One steps.csv row.
fn push_row(csv: &mut String, s: &StepStats) {
    let _ = writeln!(
        csv,
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
        s.frame,
        num(s.time),
        s.newton_iterations,
        s.cg_iterations,
        num(s.residual),
        s.converged,
        num(s.elastic_energy),
        num(s.kinetic_energy),
        num(s.min_j),
        s.inverted_elements,
        num(s.wall_seconds),
        num(s.relative_residual),
        s.substeps,
        s.line_search_cuts,
        s.cg_breakdowns,
        s.cg_capped,
        s.clamped_tets,
    );
}

/// A number for CSV: plain for ordinary magnitudes, exponent form otherwise, always
/// round-trip exact.
fn num(x: f64) -> String {
    if x == 0.0 || (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}
