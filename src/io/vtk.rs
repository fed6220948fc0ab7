//! Legacy VTK `.vtk` unstructured grids, ASCII or binary (big-endian), in both cell layouts:
//! `CELLS n size` with per-cell counts (versions ≤ 4.2) and `OFFSETS`/`CONNECTIVITY` (5.x, as
//! VTK 9 and meshio write). Read and written (4.2 layout, read by every VTK version).
//!
//! Our own reader: `vtkio` 0.6 does not read the 5.x layout. Tets (`VTK_TETRA`) or 10-node tets
//! (`VTK_QUADRATIC_TETRA`, whose mid-edge order is tetsim's), never both in one file, are kept;
//! other cells reported as ignored; data arrays after the cells are not read.
//! Elements and nodes are named by their 0-based index in the file, as ParaView shows them.

use std::path::Path;

use super::text::{Cursor, Endian, Scalar, Value, decode_all, shorten};
use super::{Ignored, Parsed, atomic_write, fmt_f64, missing_node, read_bytes};
use crate::error::Result;
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// VTK cell type of a linear tet.
pub(crate) const VTK_TETRA: i64 = 10;
/// VTK cell type of a 10-node tet: four corners, then the nodes on edges 01, 12, 02, 03, 13, 23.
pub(crate) const VTK_QUADRATIC_TETRA: i64 = 24;

/// The name of a VTK cell type, for the ignored-elements report.
pub(crate) fn cell_name(ty: i64) -> &'static str {
    match ty {
        1 => "vertex",
        2 => "poly-vertex",
        3 => "line",
        4 => "poly-line",
        5 => "triangle",
        6 => "triangle strip",
        7 => "polygon",
        8 => "pixel",
        9 => "quad",
        11 => "voxel",
        12 => "hexahedron",
        13 => "wedge",
        14 => "pyramid",
        21 => "quadratic edge",
        22 => "quadratic triangle",
        23 => "quadratic quad",
        25 => "quadratic hexahedron",
        _ => "other cell",
    }
}

/// Legacy type names → scalar type.
fn legacy_type(name: &str) -> Option<Scalar> {
    Some(match name {
        "bit" | "unsigned_char" => Scalar::U8,
        "char" => Scalar::I8,
        "unsigned_short" => Scalar::U16,
        "short" => Scalar::I16,
        "unsigned_int" | "vtktypeuint32" => Scalar::U32,
        "int" | "vtktypeint32" => Scalar::I32,
        "unsigned_long" | "vtktypeuint64" => Scalar::U64,
        "long" | "vtktypeint64" | "vtkIdType" => Scalar::I64,
        "float" => Scalar::F32,
        "double" => Scalar::F64,
        _ => return None,
    })
}

struct Reader<'a> {
    c: Cursor<'a>,
    binary: bool,
}

impl Reader<'_> {
    /// `n` values of the named legacy type.
    fn values(&mut self, n: usize, ty_name: &str, what: &str) -> Result<Vec<Value>> {
        let ty = legacy_type(ty_name).ok_or_else(|| {
            self.c.error(format!(
                "unknown data type `{}` for {what}",
                shorten(ty_name)
            ))
        })?;
        if self.binary {
            self.c.skip_line();
            let bytes = self.c.bytes(n.saturating_mul(ty.size()), what)?;
            Ok(decode_all(bytes, ty, Endian::Big))
        } else {
            let limit = self.c.remaining().len() / 2 + 1;
            if n > limit {
                return Err(self
                    .c
                    .error(format!("{what}: {n} values cannot fit in the file")));
            }
            let mut out = Vec::with_capacity(n);
            for _ in 0..n {
                out.push(if ty.is_integer() {
                    Value::Int(self.c.parse::<i64>(what)? as i128)
                } else {
                    Value::Float(self.c.parse(what)?)
                });
            }
            Ok(out)
        }
    }

    fn ints(&mut self, n: usize, ty_name: &str, what: &str) -> Result<Vec<i64>> {
        let line = self.c.line_here();
        let values = self.values(n, ty_name, what)?;
        values
            .into_iter()
            .map(|v| match v {
                Value::Int(i) => i64::try_from(i).map_err(|_| {
                    self.c
                        .error_at(line, format!("{what}: {i} is out of range"))
                }),
                Value::Float(_) => Err(self.c.error_at(line, format!("{what} must be integers"))),
            })
            .collect()
    }
}

/// Read a legacy `.vtk` unstructured grid. Returns the parsed mesh and the format's name.
pub fn read(path: &Path) -> Result<(Parsed, String)> {
    let data = read_bytes(path)?;
    let mut c = Cursor::new(path, &data);
    let first = c.rest_of_line();
    let version = first
        .strip_prefix("# vtk DataFile Version")
        .map(str::trim)
        .ok_or_else(|| {
            c.error_at(
                1,
                format!(
                    "not a legacy VTK file: expected `# vtk DataFile Version`, found `{}`",
                    shorten(first)
                ),
            )
        })?
        .to_string();
    c.rest_of_line(); // the title
    let encoding = c.token("ASCII or BINARY")?;
    let binary = match encoding.to_ascii_uppercase().as_str() {
        "ASCII" => false,
        "BINARY" => true,
        _ => {
            return Err(c.error(format!(
                "expected ASCII or BINARY, found `{}`",
                shorten(encoding)
            )));
        }
    };
    c.expect("DATASET")?;
    let kind = c.token("the dataset type")?;
    if kind != "UNSTRUCTURED_GRID" {
        return Err(c.error(format!(
            "dataset {} is not an UNSTRUCTURED_GRID of tets",
            shorten(kind)
        )));
    }
    let mut r = Reader { c, binary };
    let mut points: Vec<Vec3> = Vec::new();
    let mut cells: Option<(Vec<i64>, Vec<i64>)> = None; // (offsets, connectivity)
    let mut types: Vec<i64> = Vec::new();
    while let Some(keyword) = r.c.next_token() {
        match keyword {
            "POINTS" => {
                let n = r.c.count("the number of points", data.len())?;
                let ty = r.c.token("the points' data type")?;
                let v = r.values(3 * n, ty, "point coordinates")?;
                points = v
                    .chunks_exact(3)
                    .map(|p| Vec3::new(p[0].as_f64(), p[1].as_f64(), p[2].as_f64()))
                    .collect();
            }
            "METADATA" => {
                // Ends at the first blank line.
                r.c.skip_line();
                while !r.c.rest_of_line().is_empty() {}
            }
            "CELLS" => {
                let line = r.c.line();
                let n = r.c.count("the number of cells", data.len())?;
                let size = r.c.count("the cell list size", data.len())?;
                if r.c.peek_token() == Some("OFFSETS") {
                    r.c.expect("OFFSETS")?;
                    let ty = r.c.token("the offsets' data type")?;
                    let offsets = r.ints(n, ty, "cell offsets")?;
                    r.c.expect("CONNECTIVITY")?;
                    let ty = r.c.token("the connectivity's data type")?;
                    let connectivity = r.ints(size, ty, "cell connectivity")?;
                    cells = Some((offsets, connectivity));
                } else {
                    let list = r.ints(size, "int", "the cell list")?;
                    let mut offsets = vec![0];
                    let mut connectivity = Vec::with_capacity(size);
                    let mut k = 0;
                    for cell in 0..n {
                        let count = list.get(k).copied().unwrap_or(-1);
                        let end = usize::try_from(count)
                            .ok()
                            .and_then(|c| c.checked_add(k + 1));
                        match end.filter(|&e| e <= list.len()) {
                            Some(end) => {
                                connectivity.extend_from_slice(&list[k + 1..end]);
                                offsets.push(connectivity.len() as i64);
                                k = end;
                            }
                            None => {
                                return Err(r.c.error_at(
                                    line,
                                    format!("cell {cell}: bad point count {count} in CELLS"),
                                ));
                            }
                        }
                    }
                    cells = Some((offsets, connectivity));
                }
            }
            "CELL_TYPES" => {
                let n = r.c.count("the number of cell types", data.len())?;
                types = r.ints(n, "int", "cell types")?;
            }
            "POINT_DATA" | "CELL_DATA" | "FIELD" => break,
            other => {
                return Err(r.c.error(format!(
                    "unexpected `{}` (expected POINTS, CELLS or CELL_TYPES)",
                    shorten(other)
                )));
            }
        }
    }
    let (offsets, connectivity) = cells.unwrap_or_else(|| (vec![0], Vec::new()));
    let parsed = tets_from_cells(path, points, &offsets, &connectivity, &types)?;
    let name = format!(
        "legacy VTK {version} {}",
        if binary { "binary" } else { "ASCII" }
    );
    Ok((parsed, name))
}

/// Keep the tets of a VTK cell list (`offsets` has one more entry than there are cells; a
/// leading 0 is optional, as in VTU where offsets are the cells' ends). Cells are named by
/// their 0-based index, as ParaView shows them.
pub(crate) fn tets_from_cells(
    path: &Path,
    points: Vec<Vec3>,
    offsets: &[i64],
    connectivity: &[i64],
    types: &[i64],
) -> Result<Parsed> {
    let ends = if offsets.len() == types.len() + 1 {
        &offsets[1..]
    } else {
        offsets
    };
    if ends.len() != types.len() {
        return Err(crate::error::Error::parse(
            path,
            None,
            format!("{} cell types for {} cells", types.len(), ends.len()),
        ));
    }
    let mut ignored = Ignored::default();
    let mut tets = Vec::new();
    let mut edge_nodes = Vec::new();
    let mut tet_ids = Vec::new();
    // The first linear and the first quadratic tet: a mesh with both is refused.
    let (mut first_linear, mut first_quadratic) = (None, None);
    let mut start = if offsets.len() == types.len() + 1 {
        offsets[0]
    } else {
        0
    };
    let err = |message: String| crate::error::Error::parse(path, None, message);
    for (cell, (&end, &ty)) in ends.iter().zip(types).enumerate() {
        let range = usize::try_from(start)
            .ok()
            .zip(usize::try_from(end).ok())
            .filter(|&(s, e)| s <= e && e <= connectivity.len());
        let Some((s, e)) = range else {
            return Err(err(format!(
                "cell {cell}: offsets {start}..{end} outside the connectivity (length {})",
                connectivity.len()
            )));
        };
        start = end;
        if ty != VTK_TETRA && ty != VTK_QUADRATIC_TETRA {
            ignored.add(cell_name(ty), 1);
            continue;
        }
        let quadratic = ty == VTK_QUADRATIC_TETRA;
        let needed = if quadratic { 10 } else { 4 };
        if e - s < needed || (quadratic && e - s != needed) {
            let kind = if quadratic { "quadratic tet" } else { "tet" };
            return Err(err(format!(
                "cell {cell}: a {kind} (VTK type {ty}) with {} points ({needed} needed)",
                e - s
            )));
        }
        let (mine, other) = if quadratic {
            (&mut first_quadratic, first_linear)
        } else {
            (&mut first_linear, first_quadratic)
        };
        mine.get_or_insert(cell);
        if let Some(other) = other {
            return Err(err(format!(
                "cell {cell} is a {} tet but cell {other} is a {} one: a mesh must have tets \
                 of one order",
                if quadratic { "10-node" } else { "4-node" },
                if quadratic { "4-node" } else { "10-node" },
            )));
        }
        let mut nodes = [0usize; 10];
        for (slot, &v) in nodes.iter_mut().zip(&connectivity[s..s + needed]) {
            *slot = usize::try_from(v)
                .ok()
                .filter(|&v| v < points.len())
                .ok_or_else(|| missing_node(path, cell as u64, v as u64))?;
        }
        tets.push([nodes[0], nodes[1], nodes[2], nodes[3]]);
        if quadratic {
            // VTK_QUADRATIC_TETRA's mid-edge order is tetsim's.
            edge_nodes.push([nodes[4], nodes[5], nodes[6], nodes[7], nodes[8], nodes[9]]);
        }
        tet_ids.push(cell as u64);
    }
    let mut mesh = TetMesh::new(points, tets);
    mesh.edge_nodes = edge_nodes;
    mesh.tet_ids = Some(tet_ids);
    Ok(Parsed {
        mesh,
        ignored: ignored.finish(),
        element_path: path.to_path_buf(),
        node_path: path.to_path_buf(),
    })
}

/// Write `mesh` as a legacy VTK 4.2 unstructured grid of tets (10-node `VTK_QUADRATIC_TETRA`
/// cells when the mesh is quadratic), binary (big-endian) or ASCII.
pub fn write(path: &Path, mesh: &TetMesh, binary: bool) -> Result<()> {
    atomic_write(path, |w| {
        let n = mesh.positions.len();
        let m = mesh.tets.len();
        writeln!(w, "# vtk DataFile Version 4.2\nwritten by tetsim")?;
        writeln!(w, "{}", if binary { "BINARY" } else { "ASCII" })?;
        writeln!(w, "DATASET UNSTRUCTURED_GRID\nPOINTS {n} double")?;
        if binary {
            for x in &mesh.positions {
                for c in x.iter() {
                    w.write_all(&c.to_be_bytes())?;
                }
            }
            writeln!(w)?;
        } else {
            for x in &mesh.positions {
                writeln!(w, "{} {} {}", fmt_f64(x.x), fmt_f64(x.y), fmt_f64(x.z))?;
            }
        }
        let per = mesh.nodes_per_tet();
        let cell_type = if mesh.is_quadratic() {
            VTK_QUADRATIC_TETRA
        } else {
            VTK_TETRA
        };
        writeln!(w, "CELLS {m} {}", (per + 1) * m)?;
        for t in 0..m {
            let nodes = mesh.element_nodes(t);
            if binary {
                w.write_all(&(per as i32).to_be_bytes())?;
                for &v in &nodes {
                    w.write_all(&(v as i32).to_be_bytes())?;
                }
            } else {
                let list: Vec<String> = nodes.iter().map(usize::to_string).collect();
                writeln!(w, "{per} {}", list.join(" "))?;
            }
        }
        if binary {
            writeln!(w)?;
        }
        writeln!(w, "CELL_TYPES {m}")?;
        for _ in 0..m {
            if binary {
                w.write_all(&(cell_type as i32).to_be_bytes())?;
            } else {
                writeln!(w, "{cell_type}")?;
            }
        }
        if binary {
            writeln!(w)?;
        }
        Ok(())
    })
}
