//! VTK XML unstructured grids (`.vtu`) and ParaView collections (`.pvd`).
//!
//! Read: `ascii`, inline `binary` (base64) and `appended` (raw or base64) data arrays, optionally
//! zlib-compressed, UInt32 or UInt64 headers, either byte order: what ParaView, VTK and meshio
//! write. Our own reader, because `vtkio` 0.6.3 fails on meshio's files (see the tests) and its
//! 0.7 is not released. Write: binary appended raw data (or inline base64), optionally
//! compressed, with f64 point and cell data; the same input always gives the same bytes.

use std::io::Read;
use std::path::Path;

use base64::Engine;
use base64::engine::general_purpose::STANDARD as BASE64;

use super::text::{Endian, Scalar, Value, decode, decode_all, shorten};
use super::vtk::tets_from_cells;
use super::xml::{self, Appended, Element};
use super::{Parsed, read_bytes};
use crate::error::{Error, Result};
use crate::math::Vec3;

pub use super::pvd::{read_pvd, write_pvd};
pub(super) use super::vtu_write::write_cells;
pub use super::vtu_write::{VtuOptions, write_quadratic_vtu, write_vtu, write_vtu_with};

/// A data array to write: one f64 per point (or cell), or one vector.
#[derive(Clone, Copy, Debug)]
pub enum Field<'a> {
    /// One value per item.
    Scalar(&'a [f64]),
    /// One 3-vector per item.
    Vector(&'a [Vec3]),
}

impl Field<'_> {
    pub(super) fn len(&self) -> usize {
        match self {
            Field::Scalar(s) => s.len(),
            Field::Vector(v) => v.len(),
        }
    }
}

/// A data array read back from a VTU file (any numeric type, as f64).
#[derive(Clone, Debug, PartialEq)]
pub enum FieldData {
    /// One component.
    Scalar(Vec<f64>),
    /// Three components.
    Vector(Vec<Vec3>),
    /// Any other number of components, item-major.
    Other {
        /// Components per item.
        components: usize,
        /// The values.
        values: Vec<f64>,
    },
}

/// A VTU file read back: points, the tet cells, and the data arrays (cell data restricted to
/// the tet cells, in the same order).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    /// All points, in file order.
    pub points: Vec<Vec3>,
    /// The tet cells (their corners, for 10-node cells).
    pub tets: Vec<[usize; 4]>,
    /// 10-node cells only (empty otherwise): each cell's mid-edge nodes, in
    /// [`crate::mesh::quadratic::EDGES`] order.
    pub edge_nodes: Vec<[usize; 6]>,
    /// Point data arrays by name, in file order.
    pub point_data: Vec<(String, FieldData)>,
    /// Cell data arrays by name, in file order, one entry per tet.
    pub cell_data: Vec<(String, FieldData)>,
}

impl Frame {
    /// The point data array `name`.
    pub fn point_field(&self, name: &str) -> Option<&FieldData> {
        self.point_data.iter().find(|f| f.0 == name).map(|f| &f.1)
    }

    /// The cell data array `name`.
    pub fn cell_field(&self, name: &str) -> Option<&FieldData> {
        self.cell_data.iter().find(|f| f.0 == name).map(|f| &f.1)
    }
}

/// Header and array layout of one file.
struct Layout<'a> {
    path: &'a Path,
    data: &'a [u8],
    endian: Endian,
    header: Scalar,
    zlib: bool,
    appended: Option<Appended>,
}

/// XML type names → scalar type.
fn xml_type(name: &str) -> Option<Scalar> {
    Some(match name {
        "Int8" => Scalar::I8,
        "UInt8" => Scalar::U8,
        "Int16" => Scalar::I16,
        "UInt16" => Scalar::U16,
        "Int32" => Scalar::I32,
        "UInt32" => Scalar::U32,
        "Int64" => Scalar::I64,
        "UInt64" => Scalar::U64,
        "Float32" => Scalar::F32,
        "Float64" => Scalar::F64,
        _ => return None,
    })
}

/// Base64 text that may be several encodings one after the other (VTK encodes a compressed
/// array's header apart from its data): decode each padded piece in turn.
fn decode_base64(text: &[u8]) -> std::result::Result<Vec<u8>, String> {
    let clean: Vec<u8> = text
        .iter()
        .copied()
        .filter(|b| !b.is_ascii_whitespace())
        .collect();
    let mut out = Vec::with_capacity(clean.len() / 4 * 3);
    let mut start = 0;
    while start < clean.len() {
        // A piece ends after its padding, or at the end.
        let mut end = start;
        while end < clean.len() && clean[end] != b'=' {
            end += 1;
        }
        while end < clean.len() && clean[end] == b'=' {
            end += 1;
        }
        BASE64
            .decode_vec(&clean[start..end], &mut out)
            .map_err(|e| format!("bad base64 data: {e}"))?;
        start = end;
    }
    Ok(out)
}

impl Layout<'_> {
    fn err(&self, line: usize, message: impl Into<String>) -> Error {
        Error::parse(self.path, Some(line), message)
    }

    fn header_value(&self, bytes: &[u8], k: usize) -> Option<usize> {
        let size = self.header.size();
        let v = bytes.get(k * size..(k + 1) * size)?;
        match decode(v, self.header, self.endian) {
            Value::Int(i) => usize::try_from(i).ok(),
            Value::Float(_) => None,
        }
    }

    /// The payload of a binary array (header + data, compressed or not) → the data bytes, and
    /// how many payload bytes that took.
    fn unpack(&self, payload: &[u8], line: usize, name: &str) -> Result<(Vec<u8>, usize)> {
        let size = self.header.size();
        let short = || self.err(line, format!("array `{name}`: data cut short"));
        if !self.zlib {
            let n = self.header_value(payload, 0).ok_or_else(short)?;
            let data = payload
                .get(size..size.checked_add(n).ok_or_else(short)?)
                .ok_or_else(short)?;
            return Ok((data.to_vec(), size + n));
        }
        let blocks = self.header_value(payload, 0).ok_or_else(short)?;
        let block_size = self.header_value(payload, 1).ok_or_else(short)?;
        let last = self.header_value(payload, 2).ok_or_else(short)?;
        if blocks > payload.len() / size {
            return Err(self.err(
                line,
                format!("array `{name}`: {blocks} compressed blocks cannot fit"),
            ));
        }
        let mut offset = (3 + blocks) * size;
        let mut out = Vec::new();
        for b in 0..blocks {
            let csize = self.header_value(payload, 3 + b).ok_or_else(short)?;
            let block = payload
                .get(offset..offset.checked_add(csize).ok_or_else(short)?)
                .ok_or_else(short)?;
            // zlib expands at most ~1032:1; a larger claim is a corrupt header, not a reason
            // to allocate without bound.
            let expected = if b + 1 == blocks && last > 0 {
                last
            } else {
                block_size
            };
            if expected > 1100 * csize + 1024 {
                return Err(self.err(
                    line,
                    format!(
                        "array `{name}`: block of {csize} bytes claims {expected} uncompressed"
                    ),
                ));
            }
            let before = out.len();
            flate2::read::ZlibDecoder::new(block)
                .take(expected as u64)
                .read_to_end(&mut out)
                .map_err(|e| self.err(line, format!("array `{name}`: bad zlib data: {e}")))?;
            if out.len() - before != expected {
                return Err(self.err(line, format!("array `{name}`: a compressed block is short")));
            }
            offset += csize;
        }
        Ok((out, offset))
    }

    /// The values of a `<DataArray>`, with its number of components.
    fn array(&self, e: &Element, offsets: &[usize]) -> Result<(Vec<Value>, usize)> {
        let name = e.attr("Name").unwrap_or("(unnamed)");
        let ty_name = e.attr("type").unwrap_or("");
        let ty = xml_type(ty_name).ok_or_else(|| {
            self.err(
                e.line,
                format!("array `{name}`: unknown type `{}`", shorten(ty_name)),
            )
        })?;
        let components: usize = e
            .attr("NumberOfComponents")
            .unwrap_or("1")
            .parse()
            .ok()
            .filter(|&c| c > 0)
            .ok_or_else(|| self.err(e.line, format!("array `{name}`: bad NumberOfComponents")))?;
        let text = e.text.clone().map_or(&[][..], |r| &self.data[r]);
        let format = e.attr("format").unwrap_or("ascii");
        let bytes = match format {
            "ascii" => {
                let text = std::str::from_utf8(text)
                    .map_err(|_| self.err(e.line, format!("array `{name}`: not text")))?;
                let values = text
                    .split_ascii_whitespace()
                    .map(|t| {
                        if ty.is_integer() {
                            t.parse::<i64>().map(|i| Value::Int(i as i128)).ok()
                        } else {
                            t.parse::<f64>().map(Value::Float).ok()
                        }
                        .ok_or_else(|| {
                            self.err(
                                e.line,
                                format!("array `{name}`: bad number `{}`", shorten(t)),
                            )
                        })
                    })
                    .collect::<Result<Vec<_>>>()?;
                return Ok((values, components));
            }
            "binary" => {
                let payload = decode_base64(text)
                    .map_err(|m| self.err(e.line, format!("array `{name}`: {m}")))?;
                self.unpack(&payload, e.line, name)?.0
            }
            "appended" => {
                let appended = self.appended.as_ref().ok_or_else(|| {
                    self.err(
                        e.line,
                        format!("array `{name}` is appended, but there is no <AppendedData>"),
                    )
                })?;
                let offset: usize = e
                    .attr("offset")
                    .and_then(|o| o.trim().parse().ok())
                    .ok_or_else(|| self.err(e.line, format!("array `{name}`: bad offset")))?;
                let region = &self.data[appended.data.clone()];
                let start = offset.min(region.len());
                if appended.encoding == "base64" {
                    // Up to the next array's offset (or the end).
                    let end = offsets
                        .iter()
                        .copied()
                        .find(|&o| o > offset)
                        .unwrap_or(region.len());
                    let payload = decode_base64(&region[start..end.min(region.len())])
                        .map_err(|m| self.err(e.line, format!("array `{name}`: {m}")))?;
                    self.unpack(&payload, e.line, name)?.0
                } else if appended.encoding == "raw" {
                    self.unpack(&region[start..], e.line, name)?.0
                } else {
                    return Err(self.err(
                        appended.line,
                        format!(
                            "unknown AppendedData encoding `{}`",
                            shorten(&appended.encoding)
                        ),
                    ));
                }
            }
            f => {
                return Err(self.err(
                    e.line,
                    format!("array `{name}`: unknown format `{}`", shorten(f)),
                ));
            }
        };
        if bytes.len() % ty.size() != 0 {
            return Err(self.err(
                e.line,
                format!(
                    "array `{name}`: {} bytes is not a whole number of {ty_name}",
                    bytes.len()
                ),
            ));
        }
        Ok((decode_all(&bytes, ty, self.endian), components))
    }
}

fn ints(values: Vec<Value>, layout: &Layout, e: &Element) -> Result<Vec<i64>> {
    values
        .into_iter()
        .map(|v| match v {
            Value::Int(i) => i64::try_from(i).ok(),
            Value::Float(_) => None,
        })
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| {
            layout.err(
                e.line,
                format!(
                    "array `{}` must hold integers",
                    e.attr("Name").unwrap_or("")
                ),
            )
        })
}

fn field(values: Vec<Value>, components: usize) -> FieldData {
    let f: Vec<f64> = values.into_iter().map(Value::as_f64).collect();
    match components {
        1 => FieldData::Scalar(f),
        3 => FieldData::Vector(
            f.chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect(),
        ),
        _ => FieldData::Other {
            components,
            values: f,
        },
    }
}

/// Everything in a VTU file: points, raw cells (`offsets` starts with 0), data arrays.
pub(super) struct Grid {
    pub points: Vec<Vec3>,
    pub offsets: Vec<i64>,
    pub connectivity: Vec<i64>,
    pub types: Vec<i64>,
    pub point_data: Vec<(String, FieldData)>,
    pub cell_data: Vec<(String, FieldData)>,
    /// (cell data?, name) of the `UInt8` data arrays: group flags (see [`super::vtu_groups`]).
    pub flags: Vec<(bool, String)>,
}

pub(super) fn parse_grid(path: &Path) -> Result<Grid> {
    let data = read_bytes(path)?;
    let (root, appended) = xml::parse(path, &data)?;
    let err = |line: usize, m: String| Error::parse(path, Some(line), m);
    if root.name != "VTKFile" || root.attr("type") != Some("UnstructuredGrid") {
        return Err(err(
            root.line,
            "not a VTU file: expected <VTKFile type=\"UnstructuredGrid\">".into(),
        ));
    }
    let endian = match root.attr("byte_order").unwrap_or("LittleEndian") {
        "BigEndian" => Endian::Big,
        _ => Endian::Little,
    };
    let header = match root.attr("header_type").unwrap_or("UInt32") {
        "UInt64" => Scalar::U64,
        "UInt32" => Scalar::U32,
        h => {
            return Err(err(
                root.line,
                format!("unknown header_type `{}`", shorten(h)),
            ));
        }
    };
    let zlib = match root.attr("compressor").unwrap_or("") {
        "" => false,
        "vtkZLibDataCompressor" => true,
        c => {
            return Err(err(
                root.line,
                format!(
                    "compressor `{}` is not supported (zlib is); re-save without compression or with zlib",
                    shorten(c)
                ),
            ));
        }
    };
    let layout = Layout {
        path,
        data: &data,
        endian,
        header,
        zlib,
        appended,
    };
    let grid = root
        .child("UnstructuredGrid")
        .ok_or_else(|| err(root.line, "no <UnstructuredGrid>".into()))?;
    // Every appended offset, sorted, to bound base64 arrays.
    let mut offsets: Vec<usize> = Vec::new();
    fn collect(e: &Element, out: &mut Vec<usize>) {
        if let Some(o) = e.attr("offset").and_then(|o| o.trim().parse().ok()) {
            out.push(o);
        }
        e.children.iter().for_each(|c| collect(c, out));
    }
    collect(grid, &mut offsets);
    offsets.sort_unstable();
    let mut g = Grid {
        points: Vec::new(),
        offsets: vec![0],
        connectivity: Vec::new(),
        types: Vec::new(),
        point_data: Vec::new(),
        cell_data: Vec::new(),
        flags: Vec::new(),
    };
    for piece in grid.children.iter().filter(|c| c.name == "Piece") {
        let count = |name: &str| -> Result<usize> {
            piece
                .attr(name)
                .and_then(|n| n.trim().parse().ok())
                .ok_or_else(|| err(piece.line, format!("<Piece> has no valid {name}")))
        };
        let (np, nc) = (count("NumberOfPoints")?, count("NumberOfCells")?);
        let base = g.points.len() as i64;
        let pts = piece
            .child("Points")
            .and_then(|p| p.child("DataArray"))
            .ok_or_else(|| err(piece.line, "<Piece> has no <Points> array".into()))?;
        let (values, comps) = layout.array(pts, &offsets)?;
        if comps != 3 || values.len() != 3 * np {
            return Err(err(
                pts.line,
                format!(
                    "points: expected {np} points of 3 components, found {} values of {comps}",
                    values.len()
                ),
            ));
        }
        g.points.extend(
            values
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0].as_f64(), c[1].as_f64(), c[2].as_f64())),
        );
        let cells = piece
            .child("Cells")
            .ok_or_else(|| err(piece.line, "<Piece> has no <Cells>".into()))?;
        let named = |n: &str| {
            cells
                .children
                .iter()
                .find(|c| c.attr("Name") == Some(n))
                .ok_or_else(|| err(cells.line, format!("<Cells> has no `{n}` array")))
        };
        let (conn_e, off_e, ty_e) = (named("connectivity")?, named("offsets")?, named("types")?);
        let connectivity = ints(layout.array(conn_e, &offsets)?.0, &layout, conn_e)?;
        let ends = ints(layout.array(off_e, &offsets)?.0, &layout, off_e)?;
        let types = ints(layout.array(ty_e, &offsets)?.0, &layout, ty_e)?;
        if ends.len() != nc || types.len() != nc {
            return Err(err(
                cells.line,
                format!(
                    "{nc} cells announced, but {} offsets and {} types",
                    ends.len(),
                    types.len()
                ),
            ));
        }
        let conn_base = g.connectivity.len() as i64;
        g.connectivity
            .extend(connectivity.iter().map(|&v| v.saturating_add(base)));
        g.offsets
            .extend(ends.iter().map(|&o| o.saturating_add(conn_base)));
        g.types.extend(types);
        for (section, n, out) in [
            ("PointData", np, &mut g.point_data),
            ("CellData", nc, &mut g.cell_data),
        ] {
            for a in piece.child(section).map_or(&[][..], |s| &s.children[..]) {
                let name = a.attr("Name").unwrap_or("").to_string();
                let flag = (section == "CellData", name.clone());
                if a.attr("type") == Some("UInt8") && !g.flags.contains(&flag) {
                    g.flags.push(flag);
                }
                let (values, comps) = layout.array(a, &offsets)?;
                if values.len() != n * comps {
                    return Err(err(
                        a.line,
                        format!(
                            "array `{}`: {} values for {n} items of {comps} components",
                            shorten(&name),
                            values.len()
                        ),
                    ));
                }
                let f = field(values, comps);
                match out.iter_mut().find(|(k, _)| *k == name) {
                    Some((_, existing)) => append_field(existing, f),
                    None => out.push((name, f)),
                }
            }
        }
    }
    Ok(g)
}

fn append_field(a: &mut FieldData, b: FieldData) {
    match (a, b) {
        (FieldData::Scalar(a), FieldData::Scalar(b)) => a.extend(b),
        (FieldData::Vector(a), FieldData::Vector(b)) => a.extend(b),
        (FieldData::Other { values: a, .. }, FieldData::Other { values: b, .. }) => a.extend(b),
        _ => {}
    }
}

/// Read a `.vtu` file as a tet mesh (for [`super::read_mesh`]).
pub fn read(path: &Path) -> Result<Parsed> {
    let g = parse_grid(path)?;
    let mut parsed = tets_from_cells(path, g.points, &g.offsets, &g.connectivity, &g.types)?;
    if !g.flags.is_empty() {
        // The cells as (type, nodes); offsets were checked by `tets_from_cells`.
        let cells: Vec<(i64, Vec<usize>)> = g
            .types
            .iter()
            .zip(g.offsets.windows(2))
            .map(|(&ty, w)| {
                let nodes = g.connectivity[w[0] as usize..w[1] as usize]
                    .iter()
                    .map(|&v| v as usize)
                    .collect();
                (ty, nodes)
            })
            .collect();
        let tet_cells = tet_cells(&parsed);
        parsed.mesh.groups = super::vtu_groups::read_groups(
            &g.flags,
            &g.point_data,
            &g.cell_data,
            &cells,
            &tet_cells,
        );
    }
    Ok(parsed)
}

/// The file cell each tet was read from (tets are the cells of tet types, in file order).
fn tet_cells(parsed: &Parsed) -> Vec<usize> {
    let ids = parsed.mesh.tet_ids.iter().flatten();
    ids.map(|&c| c as usize).collect()
}

/// Read a `.vtu` frame back: points, tets and data arrays (e.g. tetsim's `frame_NNNN.vtu`).
pub fn read_vtu_frame(path: &Path) -> Result<Frame> {
    let g = parse_grid(path)?;
    let parsed = tets_from_cells(path, g.points, &g.offsets, &g.connectivity, &g.types)?;
    let cells = tet_cells(&parsed);
    let cell_data = g
        .cell_data
        .into_iter()
        .map(|(name, f)| {
            let f = match f {
                FieldData::Scalar(v) => FieldData::Scalar(cells.iter().map(|&c| v[c]).collect()),
                FieldData::Vector(v) => FieldData::Vector(cells.iter().map(|&c| v[c]).collect()),
                FieldData::Other { components, values } => FieldData::Other {
                    components,
                    values: cells
                        .iter()
                        .flat_map(|&c| values[c * components..(c + 1) * components].iter().copied())
                        .collect(),
                },
            };
            (name, f)
        })
        .collect();
    Ok(Frame {
        points: parsed.mesh.positions,
        tets: parsed.mesh.tets,
        edge_nodes: parsed.mesh.edge_nodes,
        point_data: g.point_data,
        cell_data,
    })
}
