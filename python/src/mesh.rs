//! `tetsim.read_mesh` and `tetsim.write_mesh`: tet meshes in the formats tetsim reads and writes;
//! `tetsim.tetrahedralize`: a tet mesh of the solid a triangle surface bounds.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use tetsim::TetMesh;
use tetsim::mesh::Group;

use crate::args::{self, Signature};
use crate::arrays;
use crate::errors::{Origin, argument, for_path};

/// A tet mesh read from a file: vertices (n, 3) float64, tets (m, 4) int64 ((m, 10) for 10-node
/// tets: corners, then the nodes on edges 01, 12, 02, 03, 13, 23), groups (dict: name
/// → sorted vertex ids, int64), tet_groups (dict: name → tet ids, for volume groups), format.
#[pyclass(module = "tetsim", frozen, get_all)]
pub struct Mesh {
    /// (n, 3) float64 vertex positions, m.
    vertices: Py<PyAny>,
    /// (m, 4) int64 vertex indices of each tet.
    tets: Py<PyAny>,
    /// Named groups (Gmsh physical groups): name → sorted vertex ids.
    groups: Py<PyDict>,
    /// Named volume groups: name → tet ids.
    tet_groups: Py<PyDict>,
    /// The format read, e.g. 'Gmsh 4.1 ASCII'.
    format: String,
}

#[pymethods]
impl Mesh {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "Mesh(vertices={}, tets={}, groups={}, format={:?})",
            self.vertices.bind(py).len()?,
            self.tets.bind(py).len()?,
            self.groups.bind(py).keys(),
            self.format
        ))
    }
}

/// A group's name as a dict key: its name, or its tag when the file gives none.
fn group_name(g: &Group) -> String {
    if g.name.is_empty() {
        g.tag.to_string()
    } else {
        g.name.clone()
    }
}

/// Read a tet mesh: Gmsh .msh (2.2, 4.1; ASCII or binary), TetGen .node/.ele, VTK .vtk/.vtu,
/// MEDIT .mesh. Vertices no tet uses are dropped, tets reoriented to positive volume, and a mesh
/// with degenerate or duplicate tets refused unless force=True (as `tetsim mesh check` reports).
///
/// Raises tetsim.Error naming the file and line of a malformed file.
#[pyfunction]
#[pyo3(signature = (path=None, force=None, *extra, **unknown), text_signature = "(path, force=False)")]
pub fn read_mesh(
    py: Python<'_>,
    path: Option<&Bound<'_, PyAny>>,
    force: Option<&Bound<'_, PyAny>>,
    extra: &Bound<'_, PyTuple>,
    unknown: Option<&Bound<'_, PyDict>>,
) -> PyResult<Mesh> {
    let call = "read_mesh";
    Signature {
        call,
        positional: &["path", "force"],
        keyword: &[],
    }
    .check(extra, unknown)?;
    let path = args::path(args::required(path, "path", call, "the mesh file")?, "path")?;
    let force = args::optional_flag(force, "force")?.unwrap_or(false);
    let read = py
        .detach(|| tetsim::io::read_mesh_with(&path, tetsim::io::ReadOptions { force }))
        .map_err(|e| for_path(e, Origin::File, "path", &path))?;
    let mesh = read.mesh;
    let groups = PyDict::new(py);
    let tet_groups = PyDict::new(py);
    for g in &mesh.groups {
        groups.set_item(group_name(g), arrays::from_indices(py, &g.vertices)?)?;
        if !g.tets.is_empty() {
            tet_groups.set_item(group_name(g), arrays::from_indices(py, &g.tets)?)?;
        }
    }
    Ok(Mesh {
        vertices: arrays::from_vec3s(py, &mesh.positions)?.unbind(),
        tets: if mesh.is_quadratic() {
            let nodes: Vec<[usize; 10]> = (0..mesh.tets.len())
                .map(|t| mesh.quadratic_nodes(t))
                .collect();
            arrays::from_tets(py, &nodes)?.unbind()
        } else {
            arrays::from_tets(py, &mesh.tets)?.unbind()
        },
        groups: groups.unbind(),
        tet_groups: tet_groups.unbind(),
        format: read.report.format,
    })
}

/// Write a tet mesh in the format of path's extension: .msh (Gmsh 4.1 ASCII), .vtu, .vtk,
/// .node/.ele (TetGen), .mesh (MEDIT), .obj (the boundary surface). vertices: (n, 3) float64;
/// tets: (m, 4) int64 indices into vertices; groups: optional dict name → vertex ids (int64),
/// written as Gmsh physical groups of points in a .msh (read_mesh reads them back; the other
/// formats have no groups). The file is written atomically (a temp file renamed).
#[pyfunction]
#[pyo3(
    signature = (path=None, vertices=None, tets=None, groups=None, *extra, **unknown),
    text_signature = "(path, vertices, tets, groups=None)"
)]
pub fn write_mesh(
    py: Python<'_>,
    path: Option<&Bound<'_, PyAny>>,
    vertices: Option<&Bound<'_, PyAny>>,
    tets: Option<&Bound<'_, PyAny>>,
    groups: Option<&Bound<'_, PyAny>>,
    extra: &Bound<'_, PyTuple>,
    unknown: Option<&Bound<'_, PyDict>>,
) -> PyResult<()> {
    let call = "write_mesh";
    Signature {
        call,
        positional: &["path", "vertices", "tets", "groups"],
        keyword: &[],
    }
    .check(extra, unknown)?;
    let path = args::path(
        args::required(path, "path", call, "the file to write")?,
        "path",
    )?;
    let vertices = args::required(vertices, "vertices", call, "a (n, 3) float64 array")?;
    let tets = args::required(tets, "tets", call, "a (m, 4) int64 array")?;
    let groups = match groups {
        Some(g) if !g.is_none() => Some(g.cast::<PyDict>().map_err(|_| {
            argument(
                "groups",
                format!(
                    "expected a dict of group name -> int64 vertex ids, got {}",
                    args::describe(g)
                ),
            )
        })?),
        _ => None,
    };
    let positions = arrays::vec3s(vertices, "vertices", None)?;
    let n = positions.len();
    if let Some(v) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(argument("vertices", format!("vertex {v} is not finite")));
    }
    let index = |value: i64, what: String| -> PyResult<usize> {
        usize::try_from(value)
            .ok()
            .filter(|&v| v < n)
            .ok_or_else(|| {
                argument(
                    &what,
                    format!("vertex {value} does not exist (there are {n} vertices)"),
                )
            })
    };
    let mut tet_list = Vec::new();
    for (t, tet) in arrays::tets(tets, "tets")?.into_iter().enumerate() {
        let mut out = [0; 4];
        for (slot, v) in out.iter_mut().zip(tet) {
            *slot = index(v, "tets".into()).map_err(|_| {
                argument(
                    "tets",
                    format!("tet {t} refers to vertex {v}, which does not exist (there are {n} vertices)"),
                )
            })?;
        }
        tet_list.push(out);
    }
    if tet_list.is_empty() {
        return Err(argument("tets", "the mesh has no tetrahedra"));
    }
    let mut mesh = TetMesh::new(positions, tet_list);
    if let Some(groups) = groups {
        for (name, ids) in groups.iter() {
            if !name.is_instance_of::<pyo3::types::PyString>() {
                return Err(argument(
                    "groups",
                    format!("group names must be strings, got {}", args::describe(&name)),
                ));
            }
            let name = args::text(&name, "groups", "a group name")?;
            let key = format!("groups[{name:?}]");
            let mut vertices = Vec::new();
            for v in arrays::indices(&ids, &key)? {
                vertices.push(index(v, key.clone())?);
            }
            vertices.sort_unstable();
            vertices.dedup();
            mesh.groups.push(Group {
                name,
                dim: 0,
                vertices,
                ..Default::default()
            });
        }
    }
    py.detach(|| tetsim::io::write_mesh(&path, &mesh))
        .map_err(|e| for_path(e, Origin::File, "path", &path))
}

/// Fill the solid a closed triangle surface bounds with tets (isosurface stuffing on a BCC
/// lattice of spacing `size`, m): vertices (n, 3) float64, faces (k, 3) int64 → (vertices (p, 3)
/// float64, tets (m, 4) int64), tets positively oriented. Small holes and self-intersections are
/// tolerated (generalized winding numbers); a surface too open, a size with no lattice point
/// inside, or one that would not fit in memory raises tetsim.Error.
#[pyfunction]
#[pyo3(signature = (vertices, faces, size, min_closure=0.8))]
pub fn tetrahedralize<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    size: f64,
    min_closure: f64,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    use tetsim::mesh::stuff::{self, StuffError, StuffParams};
    let positions = arrays::vec3s(vertices, "vertices", None)?;
    let n = positions.len();
    let mut triangles = Vec::new();
    for (f, face) in arrays::triangles(faces, "faces")?.into_iter().enumerate() {
        let mut out = [0usize; 3];
        for (slot, v) in out.iter_mut().zip(face) {
            *slot = usize::try_from(v).ok().filter(|&v| v < n).ok_or_else(|| {
                argument(
                    "faces",
                    format!("face {f} refers to vertex {v}, which does not exist (there are {n} vertices)"),
                )
            })?;
        }
        triangles.push(out);
    }
    let surface = tetsim::io::obj::TriangleSurface {
        positions,
        faces: triangles,
    };
    let params = StuffParams {
        size,
        min_closure,
        ..Default::default()
    };
    let (mesh, _) = py
        .detach(|| stuff::tetrahedralize(&surface, &params))
        .map_err(|e| match e {
            StuffError::NonPositiveSize { .. }
            | StuffError::EmptyInside { .. }
            | StuffError::TooLarge { .. } => argument("size", e),
            _ => argument("faces", e),
        })?;
    Ok((
        arrays::from_vec3s(py, &mesh.positions)?,
        arrays::from_tets(py, &mesh.tets)?,
    ))
}
