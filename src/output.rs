//! The on-disk contract (SPEC §8, §10): `frame_NNNN.vtu`, `frames.pvd`, `surface_NNNN.obj` and
//! `steps.csv` in the output folder, every file written atomically (temp + rename) so that an
//! interrupted run leaves valid files behind.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::elastic::ElasticBody;
use crate::error::{Error, Result};
use crate::integrator::StepStats;
use crate::io::atomic_write;
use crate::math::{Mat3, Vec3};
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
        let von_mises: Vec<f64> = body
            .stresses(x)
            .iter()
            .enumerate()
            .map(|(t, p)| von_mises(&body.deformation_gradient(x, t), p))
            .collect();
        let path = self.dir.join(&name);
        write_vtu(
            &path,
            x,
            &body.mesh.tets,
            &[
                ("displacement", Field::Vector(&displacement)),
                ("velocity", Field::Vector(&sim.state.v)),
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

/// Von Mises stress of the Cauchy stress σ = P·Fᵀ/J, Pa. For inverted or crushed tets J is
/// floored at 1e-3 (the Cauchy stress is meaningless there; the field stays finite).
pub fn von_mises(f: &Mat3, p: &Mat3) -> f64 {
    let j = f.determinant().max(1e-3);
    let sigma = p * f.transpose() / j;
    let dev = sigma - Mat3::identity() * (sigma.trace() / 3.0);
    (1.5 * dev.norm_squared()).sqrt()
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

/// A data array attached to points or cells.
#[derive(Clone, Copy, Debug)]
pub enum Field<'a> {
    /// One number per entity.
    Scalar(&'a [f64]),
    /// One 3-vector per entity.
    Vector(&'a [Vec3]),
}

/// VTK XML unstructured grid, binary (base64, UInt64 headers), ParaView- and meshio-readable.
pub fn write_vtu(
    path: &Path,
    points: &[Vec3],
    tets: &[[usize; 4]],
    point_data: &[(&str, Field<'_>)],
    cell_data: &[(&str, Field<'_>)],
) -> Result<()> {
    let mut s = String::with_capacity(64 * points.len() + 64 * tets.len());
    s.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<UnstructuredGrid>\n");
    let _ = writeln!(
        s,
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
        points.len(),
        tets.len()
    );
    s.push_str("<Points>\n");
    data_array(
        &mut s,
        "Points",
        3,
        "Float64",
        &points
            .iter()
            .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
            .collect::<Vec<u8>>(),
    );
    s.push_str("</Points>\n<Cells>\n");
    let conn: Vec<u8> = tets
        .iter()
        .flatten()
        .flat_map(|&v| (v as i64).to_le_bytes())
        .collect();
    data_array(&mut s, "connectivity", 1, "Int64", &conn);
    let offsets: Vec<u8> = (1..=tets.len())
        .flat_map(|k| (4 * k as i64).to_le_bytes())
        .collect();
    data_array(&mut s, "offsets", 1, "Int64", &offsets);
    data_array(&mut s, "types", 1, "UInt8", &vec![10u8; tets.len()]);
    s.push_str("</Cells>\n<PointData>\n");
    for (name, field) in point_data {
        field_array(&mut s, name, field);
    }
    s.push_str("</PointData>\n<CellData>\n");
    for (name, field) in cell_data {
        field_array(&mut s, name, field);
    }
    s.push_str("</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    atomic_write(path, |w| w.write_all(s.as_bytes()))
}

fn field_array(s: &mut String, name: &str, field: &Field<'_>) {
    match field {
        Field::Scalar(v) => data_array(
            s,
            name,
            1,
            "Float64",
            &v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>(),
        ),
        Field::Vector(v) => data_array(
            s,
            name,
            3,
            "Float64",
            &v.iter()
                .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
                .collect::<Vec<u8>>(),
        ),
    }
}

fn data_array(s: &mut String, name: &str, components: usize, ty: &str, bytes: &[u8]) {
    let _ = write!(
        s,
        "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{components}\" format=\"binary\">"
    );
    let mut block = (bytes.len() as u64).to_le_bytes().to_vec();
    block.extend_from_slice(bytes);
    base64(s, &block);
    s.push_str("</DataArray>\n");
}

fn base64(out: &mut String, bytes: &[u8]) {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(TABLE[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
}

/// A ParaView collection of (time, file) entries.
pub fn write_pvd(path: &Path, entries: &[(f64, String)]) -> Result<()> {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n<Collection>\n",
    );
    for (time, file) in entries {
        let _ = writeln!(
            s,
            "<DataSet timestep=\"{time}\" group=\"\" part=\"0\" file=\"{file}\"/>"
        );
    }
    s.push_str("</Collection>\n</VTKFile>\n");
    atomic_write(path, |w| w.write_all(s.as_bytes()))
}

/// Wavefront OBJ of a triangle surface (1-based indices), outward-oriented faces as given.
pub fn write_obj(path: &Path, positions: &[Vec3], faces: &[[usize; 3]]) -> Result<()> {
    let mut s = String::with_capacity(40 * positions.len() + 24 * faces.len());
    s.push_str("# tetsim surface\n");
    // Only the vertices the surface uses, renumbered in order, so files stay small.
    let mut index = vec![0usize; positions.len()];
    let mut used = 0;
    for f in faces {
        for &v in f {
            if index[v] == 0 {
                used += 1;
                index[v] = used;
                let p = positions[v];
                let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
            }
        }
    }
    for f in faces {
        let _ = writeln!(s, "f {} {} {}", index[f[0]], index[f[1]], index[f[2]]);
    }
    atomic_write(path, |w| w.write_all(s.as_bytes()))
}
