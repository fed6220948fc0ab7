//! Meshes in and out: Gmsh `.msh` (2.2 and 4.1, ASCII and binary), TetGen `.node/.ele/.face`,
//! legacy VTK and VTU, MEDIT `.mesh`; VTU frames with data arrays, PVD collections, surface OBJ.
//!
//! [`read_mesh`] picks the reader by extension and then runs the same steps on every mesh, so
//! that no format can let a bad mesh through:
//! 1. the reader keeps the tets (linear, or 10-node with their mid-edge nodes, never both in one
//!    file); triangles, lines and points only define groups (Gmsh physical
//!    groups, TetGen markers, MEDIT references), and other cells are reported as ignored;
//! 2. non-finite coordinates are rejected, naming the node;
//! 3. vertices no tet uses are dropped and the others renumbered in file order (reported; the
//!    file's ids stay in `TetMesh::vertex_ids` / `tet_ids` for messages);
//! 4. negatively oriented tets are reoriented (counted);
//! 5. the [mesh doctor](crate::mesh::doctor) diagnoses the result, and a mesh with errors (e.g.
//!    degenerate tets) is refused unless [`ReadOptions::force`] is set.
//!
//! Every reader error names the file and the line (the byte offset inside binary data) or the
//! element or node by its id in the file. No input bytes make a reader panic (fuzzed in tests).

pub mod gltf;
pub mod gmsh;
pub mod medit;
pub mod obj;
pub mod ply;
pub mod pvd;
pub mod render_obj;
pub mod stl;
pub mod surface_vtu;
pub mod tetgen;
pub(crate) mod text;
pub mod vtk;
pub mod vtu;
mod vtu_groups;
mod vtu_write;
mod xml;

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, MeshProblem, Result};
use crate::mesh::doctor::{Diagnosis, diagnose};
use crate::mesh::{Group, TetMesh};

pub use vtu::{Field, FieldData, Frame, read_vtu_frame, write_pvd, write_vtu};

/// What a reader produced, before the common checks of [`read_mesh`].
#[derive(Clone, Debug, Default)]
pub struct Parsed {
    /// The tets, positions, groups and file ids, as in the file (nothing dropped yet).
    pub mesh: TetMesh,
    /// Elements that are not tets, by kind, with their counts (used for groups only).
    pub ignored: Vec<(String, usize)>,
    /// The file that holds the elements (TetGen: the `.ele`), for element errors.
    pub element_path: PathBuf,
    /// The file that holds the nodes (TetGen: the `.node`), for node errors.
    pub node_path: PathBuf,
}

/// How [`read_mesh_with`] treats a mesh the doctor finds bad.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// Accept a mesh whose diagnosis has errors (degenerate or duplicate tets, non-manifold
    /// faces, …). Default false: such a mesh is refused with the list of problems.
    pub force: bool,
}

/// What [`read_mesh`] changed while loading, so that nothing happens silently.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadReport {
    /// The format that was read (e.g. `Gmsh 4.1 binary`).
    pub format: String,
    /// Elements that are not tets, by kind and count: used only to build groups.
    pub ignored: Vec<(String, usize)>,
    /// File ids of the vertices no tet uses; they were dropped, and the remaining vertices
    /// renumbered 0..n in file order (`TetMesh::vertex_ids` maps back to the file's ids).
    pub dropped_vertices: Vec<u64>,
    /// How many negatively oriented tets were reoriented (two vertices swapped).
    pub reoriented: usize,
}

impl fmt::Display for LoadReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "format: {}", self.format)?;
        for (kind, n) in &self.ignored {
            writeln!(f, "ignored {n} {kind} element(s) (used for groups only)")?;
        }
        if !self.dropped_vertices.is_empty() {
            let n = self.dropped_vertices.len();
            let ids: Vec<String> = self
                .dropped_vertices
                .iter()
                .take(10)
                .map(u64::to_string)
                .collect();
            let more = if n > 10 {
                format!(" and {} more", n - 10)
            } else {
                String::new()
            };
            writeln!(
                f,
                "dropped {n} vertices no tet uses (file ids {}{more}); the others renumbered in file order",
                ids.join(", ")
            )?;
        }
        if self.reoriented > 0 {
            writeln!(
                f,
                "reoriented {} negatively oriented tet(s)",
                self.reoriented
            )?;
        }
        Ok(())
    }
}

/// A mesh read from a file, with what loading changed and the doctor's diagnosis.
#[derive(Clone, Debug)]
pub struct MeshRead {
    /// The mesh: tets positively oriented, every vertex used by a tet.
    pub mesh: TetMesh,
    /// What was dropped, renumbered and reoriented.
    pub report: LoadReport,
    /// The doctor's findings on `mesh`.
    pub diagnosis: Diagnosis,
}

/// The mesh formats, recognised by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Gmsh `.msh` (read: 2.2 and 4.1, ASCII or binary; written as 4.1 ASCII).
    Gmsh,
    /// TetGen `.node` + `.ele` (+ `.face`), either file named.
    TetGen,
    /// Legacy VTK `.vtk` (ASCII or binary, 4.x or 5.x cell layout).
    Vtk,
    /// VTK XML unstructured grid `.vtu`.
    Vtu,
    /// MEDIT `.mesh` (ASCII).
    Medit,
    /// Wavefront `.obj` surface (write only: the boundary faces).
    Obj,
}

impl Format {
    /// The format of `path` by its extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        Ok(match ext.as_str() {
            "msh" => Format::Gmsh,
            "node" | "ele" | "face" => Format::TetGen,
            "vtk" => Format::Vtk,
            "vtu" => Format::Vtu,
            "mesh" => Format::Medit,
            "obj" => Format::Obj,
            _ => {
                return Err(Error::parse(
                    path,
                    None,
                    format!(
                        "unknown mesh format `.{ext}`: expected .msh, .node/.ele, .vtk, .vtu or .mesh"
                    ),
                ));
            }
        })
    }
}

/// Read a triangle surface by extension: `.obj`, `.stl` or `.ply` (case-insensitive).
pub fn read_surface(path: &Path) -> Result<obj::TriangleSurface> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    match ext.as_str() {
        "obj" => obj::read_obj(path),
        "stl" => stl::read_stl(path),
        "ply" => ply::read_ply(path),
        _ => Err(Error::parse(
            path,
            None,
            format!("unknown surface format `.{ext}`: expected .obj, .stl or .ply"),
        )),
    }
}

/// Read a tet mesh, refusing meshes the doctor finds bad (see [`read_mesh_with`]).
pub fn read_mesh(path: &Path) -> Result<MeshRead> {
    read_mesh_with(path, ReadOptions::default())
}

/// Read a tet mesh by extension and run the common steps of the module doc: drop and renumber
/// unused vertices, reorient, diagnose, and refuse a mesh with errors unless `options.force`.
pub fn read_mesh_with(path: &Path, options: ReadOptions) -> Result<MeshRead> {
    let (parsed, format) = parse_mesh(path)?;
    finish(parsed, format, options)
}

/// Only the format reader: the mesh as in the file, with nothing dropped, reoriented or checked
/// beyond what parsing needs. Returns the reader's output and the format's name.
pub fn parse_mesh(path: &Path) -> Result<(Parsed, String)> {
    // TetGen's other file (.ele beside a .node) is checked when it is read.
    if path.exists() {
        regular_file(path)?;
    }
    match Format::from_path(path)? {
        Format::Gmsh => gmsh::read(path),
        Format::TetGen => tetgen::read(path).map(|p| (p, "TetGen".to_string())),
        Format::Vtk => vtk::read(path),
        Format::Vtu => vtu::read(path).map(|p| (p, "VTU".to_string())),
        Format::Medit => medit::read(path).map(|p| (p, "MEDIT".to_string())),
        Format::Obj => Err(Error::parse(
            path,
            None,
            "an OBJ file is a surface: tetsim writes it but cannot simulate it",
        )),
    }
}

/// The common checks and fixes of [`read_mesh_with`] on a reader's output.
fn finish(parsed: Parsed, format: String, options: ReadOptions) -> Result<MeshRead> {
    let Parsed {
        mut mesh,
        ignored,
        element_path,
        node_path,
    } = parsed;
    let located = |problem| Error::Mesh {
        path: Some(element_path.clone()),
        problem,
    };
    if mesh.tets.is_empty() {
        return Err(located(MeshProblem::NoTetrahedra));
    }
    if let Some(v) = mesh
        .positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(Error::Mesh {
            path: Some(node_path),
            problem: MeshProblem::NonFinite {
                vertex: mesh.vertex_id(v),
            },
        });
    }
    let dropped = mesh.drop_unreferenced_vertices();
    let reoriented = mesh.reorient();
    let diagnosis = diagnose(&mesh);
    if !options.force
        && let Some(problem) = diagnosis.refusal()
    {
        return Err(located(problem));
    }
    Ok(MeshRead {
        mesh,
        report: LoadReport {
            format,
            ignored,
            dropped_vertices: dropped,
            reoriented,
        },
        diagnosis,
    })
}

/// Write `mesh` in the format of `path`'s extension: `.msh` (Gmsh 4.1 ASCII, with groups),
/// `.vtu` (binary appended), `.vtk` (legacy binary), `.node`/`.ele` (TetGen, both written),
/// `.mesh` (MEDIT), `.obj` (the outward boundary surface). A quadratic mesh keeps its 10-node
/// cells in .msh, .vtu and .vtk (its OBJ surface is the faces split in four) and is refused for
/// TetGen and MEDIT. The file is written atomically.
pub fn write_mesh(path: &Path, mesh: &TetMesh) -> Result<()> {
    let format = Format::from_path(path)?;
    if mesh.is_quadratic() && matches!(format, Format::TetGen | Format::Medit) {
        // Writing the corners alone would turn the mesh linear behind the user's back.
        return Err(Error::parameter(
            path.display().to_string(),
            "tetsim writes 10-node tets only as .msh, .vtu or .vtk",
        ));
    }
    match format {
        Format::Gmsh => gmsh::write(path, mesh, gmsh::Version::V41, false),
        Format::TetGen => tetgen::write(path, mesh),
        Format::Vtk => vtk::write(path, mesh, true),
        Format::Vtu => vtu_groups::write_mesh_vtu(path, mesh),
        Format::Medit => medit::write(path, mesh),
        Format::Obj => obj::write_obj(path, &mesh.positions, &mesh.boundary_faces()),
    }
}

/// Write a file so that it is either fully there or not changed at all (SPEC §9): `f` writes
/// into a temporary file beside `path`, which is renamed over `path` only when `f` succeeded.
/// A run that dies mid-write leaves the previous file (or none) and a stray `.tmp`, never a
/// truncated frame. No fsync: this protects against our own crash, not power loss, and an
/// fsync per frame would cost more than writing it.
pub fn atomic_write(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = BufWriter::with_capacity(1 << 16, file);
        f(&mut w)?;
        w.flush()?;
        drop(w);
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// Read a whole file, naming it in the error. Only a regular file is read, and no further than
/// the size it had when opened: a directory, a FIFO (which would block), or a device such as
/// /dev/zero or /dev/urandom (which would be read until memory runs out) is refused in words.
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    use std::io::Read;
    // Asked before opening: opening a FIFO blocks until a writer comes.
    regular_file(path)?;
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path));
    }
    let len = meta.len();
    let mut out = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
    file.take(len)
        .read_to_end(&mut out)
        .map_err(|e| Error::io(path, e))?;
    Ok(out)
}

/// Ok when `path` names a regular file (symbolic links followed); a directory, FIFO, device or
/// socket is refused in words, without opening it.
pub fn regular_file(path: &Path) -> Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        Err(Error::parse(path, None, "is a directory, not a file"))
    } else if !meta.is_file() {
        Err(not_regular(path))
    } else {
        Ok(())
    }
}

fn not_regular(path: &Path) -> Error {
    Error::parse(
        path,
        None,
        "is not a regular file (a FIFO, device or socket): tetsim reads only regular files, \
         whose size is known before reading",
    )
}

/// [`read_bytes`] as UTF-8 text.
pub fn read_text(path: &Path) -> Result<String> {
    String::from_utf8(read_bytes(path)?)
        .map_err(|e| Error::parse(path, None, format!("is not UTF-8 text: {e}")))
}

/// File ids → 0-based indices, dense when the ids are (as they almost always are).
pub(crate) struct IdMap {
    kind: IdKind,
}

enum IdKind {
    /// ids are `first..first + n`.
    Range {
        first: u64,
        n: usize,
    },
    /// `slots[id]` is index + 1, or 0 when unused.
    Dense(Vec<u32>),
    Sparse(HashMap<u64, usize>),
}

impl IdMap {
    /// The map of `ids` (index i has id `ids[i]`); the first repeated id is returned as error.
    pub fn new(ids: &[u64]) -> std::result::Result<IdMap, u64> {
        let n = ids.len();
        if let Some(&first) = ids.first()
            && ids
                .iter()
                .enumerate()
                .all(|(i, &id)| id == first + i as u64)
        {
            return Ok(IdMap {
                kind: IdKind::Range { first, n },
            });
        }
        let max = ids.iter().copied().max().unwrap_or(0);
        if max < 4 * n as u64 + 1024 && n < u32::MAX as usize {
            let mut slots = vec![0u32; max as usize + 1];
            for (i, &id) in ids.iter().enumerate() {
                if slots[id as usize] != 0 {
                    return Err(id);
                }
                slots[id as usize] = i as u32 + 1;
            }
            return Ok(IdMap {
                kind: IdKind::Dense(slots),
            });
        }
        let mut map = HashMap::with_capacity(n);
        for (i, &id) in ids.iter().enumerate() {
            if map.insert(id, i).is_some() {
                return Err(id);
            }
        }
        Ok(IdMap {
            kind: IdKind::Sparse(map),
        })
    }

    /// The index of file id `id`.
    #[inline]
    pub fn get(&self, id: u64) -> Option<usize> {
        match &self.kind {
            IdKind::Range { first, n } => {
                let i = id.checked_sub(*first)?;
                (i < *n as u64).then_some(i as usize)
            }
            IdKind::Dense(slots) => match slots.get(usize::try_from(id).ok()?) {
                Some(&s) if s > 0 => Some(s as usize - 1),
                _ => None,
            },
            IdKind::Sparse(map) => map.get(&id).copied(),
        }
    }
}

/// Collects groups keyed by (dimension, tag) while a reader walks the elements.
#[derive(Default)]
pub(crate) struct Groups {
    groups: BTreeMap<(usize, i64), Group>,
}

impl Groups {
    /// The group (dim, tag), created with `name` when new.
    pub fn entry(&mut self, dim: usize, tag: i64, name: &str) -> &mut Group {
        self.groups.entry((dim, tag)).or_insert_with(|| Group {
            name: name.to_string(),
            tag,
            dim,
            ..Default::default()
        })
    }

    /// The groups sorted by (dim, tag), each group's vertices sorted and unique.
    pub fn finish(self) -> Vec<Group> {
        self.groups
            .into_values()
            .map(|mut g| {
                g.vertices.sort_unstable();
                g.vertices.dedup();
                g
            })
            .collect()
    }
}

/// Counts of ignored elements by kind, in first-seen order.
#[derive(Default)]
pub(crate) struct Ignored(Vec<(String, usize)>);

impl Ignored {
    /// Count one more element of `kind`.
    pub fn add(&mut self, kind: &str, n: usize) {
        if n == 0 {
            return;
        }
        match self.0.iter_mut().find(|(k, _)| k == kind) {
            Some((_, count)) => *count += n,
            None => self.0.push((kind.to_string(), n)),
        }
    }

    /// The counts.
    pub fn finish(self) -> Vec<(String, usize)> {
        self.0
    }
}

/// `Error::Mesh` for an element naming a node that does not exist.
pub(crate) fn missing_node(path: &Path, element: u64, node: u64) -> Error {
    Error::Mesh {
        path: Some(path.to_path_buf()),
        problem: MeshProblem::IndexOutOfRange {
            tet: element,
            vertex: node,
        },
    }
}

/// `i x y z` lines, i from 1: the node lists of MSH 2.2 and TetGen.
pub(crate) fn write_numbered_points(
    w: &mut dyn Write,
    points: &[crate::math::Vec3],
) -> std::io::Result<()> {
    for (i, x) in points.iter().enumerate() {
        writeln!(
            w,
            "{} {} {} {}",
            i + 1,
            fmt_f64(x.x),
            fmt_f64(x.y),
            fmt_f64(x.z)
        )?;
    }
    Ok(())
}

/// The faces of the dimension-2 groups with their group's tag as marker (at least 1, since 0
/// means "no marker" in TetGen and MEDIT).
pub(crate) fn marked_faces(mesh: &TetMesh) -> Vec<([usize; 3], i64)> {
    mesh.groups
        .iter()
        .filter(|g| g.dim == 2)
        .flat_map(|g| g.faces.iter().map(move |f| (*f, g.tag.max(1))))
        .collect()
}

/// Format f64 so that it reads back bit-exactly (Rust's shortest round-trip representation).
pub(crate) fn fmt_f64(x: f64) -> String {
    format!("{x:?}")
}

/// Initial positions for `[initial] positions`: any mesh file (its vertices, in file order) or a
/// text file of one `x y z` line per vertex (blank lines and `#` comments skipped). There must
/// be exactly `count` of them, in the simulated mesh's vertex order.
pub fn read_positions(path: &Path, count: usize) -> Result<Vec<crate::math::Vec3>> {
    let positions = if Format::from_path(path).is_ok() {
        parse_mesh(path)?.0.mesh.positions
    } else {
        read_position_text(path)?
    };
    if positions.len() != count {
        return Err(Error::parse(
            path,
            None,
            format!(
                "{} positions for a mesh of {count} vertices (same count and order needed)",
                positions.len()
            ),
        ));
    }
    if let Some(v) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(Error::parse(
            path,
            None,
            format!("position {v} is not finite"),
        ));
    }
    Ok(positions)
}

fn read_position_text(path: &Path) -> Result<Vec<crate::math::Vec3>> {
    let text = read_text(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let values: Vec<f64> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| Error::parse(path, Some(i + 1), format!("expected three numbers: {e}")))?;
        if values.len() != 3 || !values.iter().all(|v| v.is_finite()) {
            return Err(Error::parse(
                path,
                Some(i + 1),
                format!("expected three finite numbers, got \"{line}\""),
            ));
        }
        out.push(crate::math::Vec3::new(values[0], values[1], values[2]));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn id_maps_cover_range_dense_sparse_and_duplicates() {
        let range = IdMap::new(&[1, 2, 3]).unwrap();
        assert_eq!(
            (range.get(1), range.get(3), range.get(0)),
            (Some(0), Some(2), None)
        );
        let dense = IdMap::new(&[5, 2, 9]).unwrap();
        assert_eq!(
            (dense.get(9), dense.get(3), dense.get(u64::MAX)),
            (Some(2), None, None)
        );
        let sparse = IdMap::new(&[1 << 40, 7]).unwrap();
        assert_eq!((sparse.get(1 << 40), sparse.get(8)), (Some(0), None));
        assert_eq!(IdMap::new(&[4, 5, 4]).err(), Some(4));
    }

    #[test]
    fn atomic_write_leaves_the_old_file_on_failure() {
        let dir = std::env::temp_dir().join(format!("tetsim-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.txt");
        atomic_write(&path, |w| w.write_all(b"old")).unwrap();
        let err = atomic_write(&path, |w| {
            w.write_all(b"new but broken")?;
            Err(std::io::Error::other("disk on fire"))
        });
        assert!(err.unwrap_err().to_string().contains("disk on fire"));
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
