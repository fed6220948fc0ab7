//! The VTU writer: binary appended raw data (or inline base64), optionally zlib-compressed, f64
//! point and cell data, linear or 10-node tets; the same input always gives the same bytes.

use std::io::Write;
use std::path::Path;

use base64::Engine;
use base64::engine::general_purpose::STANDARD as BASE64;

use super::vtk::{VTK_QUADRATIC_TETRA, VTK_TETRA};
use super::vtu::Field;
use super::{atomic_write, xml};
use crate::error::{Error, Result};
use crate::math::Vec3;

/// How [`write_vtu_with`] stores the arrays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VtuOptions {
    /// Inline base64 `binary` arrays instead of one raw `<AppendedData>` block (default false:
    /// raw appended is the smallest and fastest, and ParaView and meshio read it).
    pub base64: bool,
    /// zlib-compress the arrays (default false: frames are rewritten often, and compression
    /// costs more time than the disk saves).
    pub zlib: bool,
}

/// Write a VTU file of tets with point and cell data (raw appended binary, uncompressed).
/// Every field must have one entry per point (per tet for cell data).
pub fn write_vtu(
    path: &Path,
    points: &[Vec3],
    tets: &[[usize; 4]],
    point_data: &[(&str, Field)],
    cell_data: &[(&str, Field)],
) -> Result<()> {
    write_vtu_with(
        path,
        points,
        tets,
        point_data,
        cell_data,
        VtuOptions::default(),
    )
}

/// Write a VTU file of 10-node tets (`VTK_QUADRATIC_TETRA`, which ParaView draws curved), each
/// given as its four corners then the nodes on edges 01, 12, 02, 03, 13, 23
/// ([`crate::TetMesh::quadratic_nodes`]), with point and cell data as in [`write_vtu`].
pub fn write_quadratic_vtu(
    path: &Path,
    points: &[Vec3],
    tets: &[[usize; 10]],
    point_data: &[(&str, Field)],
    cell_data: &[(&str, Field)],
) -> Result<()> {
    write_cells(
        path,
        points,
        tets,
        VTK_QUADRATIC_TETRA as u8,
        point_data,
        cell_data,
        VtuOptions::default(),
    )
}

/// Size of the blocks zlib compresses (VTK's default).
const ZLIB_BLOCK: usize = 1 << 15;

/// A binary array's payload: UInt64 header, then the data, compressed in blocks or not.
fn payload(data: &[u8], zlib: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() + 32);
    if !zlib {
        out.extend_from_slice(&(data.len() as u64).to_le_bytes());
        out.extend_from_slice(data);
        return out;
    }
    let blocks: Vec<Vec<u8>> = data
        .chunks(ZLIB_BLOCK)
        .map(|chunk| {
            let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            e.write_all(chunk).expect("writing to a Vec cannot fail");
            e.finish().expect("writing to a Vec cannot fail")
        })
        .collect();
    let last = match data.len() % ZLIB_BLOCK {
        0 if !data.is_empty() => ZLIB_BLOCK,
        r => r,
    };
    for h in [blocks.len(), ZLIB_BLOCK, last]
        .into_iter()
        .chain(blocks.iter().map(Vec::len))
    {
        out.extend_from_slice(&(h as u64).to_le_bytes());
    }
    blocks.iter().for_each(|b| out.extend_from_slice(b));
    out
}

/// [`write_vtu`] with a choice of encoding and compression.
pub fn write_vtu_with(
    path: &Path,
    points: &[Vec3],
    tets: &[[usize; 4]],
    point_data: &[(&str, Field)],
    cell_data: &[(&str, Field)],
    options: VtuOptions,
) -> Result<()> {
    write_cells(
        path,
        points,
        tets,
        VTK_TETRA as u8,
        point_data,
        cell_data,
        options,
    )
}

/// A VTU file of cells of one VTK type with `N` nodes each (tets, triangles).
pub(super) fn write_cells<const N: usize>(
    path: &Path,
    points: &[Vec3],
    tets: &[[usize; N]],
    cell_type: u8,
    point_data: &[(&str, Field)],
    cell_data: &[(&str, Field)],
    options: VtuOptions,
) -> Result<()> {
    for (what, data, n) in [
        ("point", point_data, points.len()),
        ("cell", cell_data, tets.len()),
    ] {
        if let Some((name, f)) = data.iter().find(|(_, f)| f.len() != n) {
            return Err(Error::parameter(
                format!("{what} data `{name}`"),
                format!("has {} entries for {n} {what}s", f.len()),
            ));
        }
    }
    let f64s = |v: &mut Vec<u8>, x: f64| v.extend_from_slice(&x.to_le_bytes());
    let vec_bytes = |vs: &[Vec3]| {
        let mut b = Vec::with_capacity(24 * vs.len());
        vs.iter()
            .for_each(|p| p.iter().for_each(|&c| f64s(&mut b, c)));
        b
    };
    let field_bytes = |f: &Field| match f {
        Field::Scalar(s) => {
            let mut b = Vec::with_capacity(8 * s.len());
            s.iter().for_each(|&x| f64s(&mut b, x));
            (b, 1)
        }
        Field::Vector(v) => (vec_bytes(v), 3),
    };
    let mut arrays: Vec<Array> = Vec::new();
    for (section, data) in [("PointData", point_data), ("CellData", cell_data)] {
        for (name, f) in data {
            let (bytes, components) = field_bytes(f);
            arrays.push(Array {
                section,
                name: name.to_string(),
                ty: "Float64",
                components,
                bytes,
            });
        }
    }
    let conn: Vec<i64> = tets.iter().flatten().map(|&v| v as i64).collect();
    let ends: Vec<i64> = (1..=tets.len() as i64).map(|k| N as i64 * k).collect();
    arrays.extend(geometry(points, &conn, &ends, vec![cell_type; tets.len()]));
    write_arrays(path, points.len(), tets.len(), &arrays, options)
}

/// One data array of a VTU file: its section (`PointData`, `CellData`, `Points`, `Cells`;
/// consecutive arrays of a section are written in one element), name, XML type, components
/// per item, and little-endian bytes.
pub(super) struct Array {
    pub section: &'static str,
    pub name: String,
    pub ty: &'static str,
    pub components: usize,
    pub bytes: Vec<u8>,
}

/// The `Points` and `Cells` arrays: positions, connectivity, cell ends and VTK cell types.
pub(super) fn geometry(
    points: &[Vec3],
    connectivity: &[i64],
    ends: &[i64],
    types: Vec<u8>,
) -> [Array; 4] {
    let ints = |v: &[i64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let array = |section, name: &str, ty, components, bytes| Array {
        section,
        name: name.into(),
        ty,
        components,
        bytes,
    };
    let xyz = points
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    [
        array("Points", "Points", "Float64", 3, xyz),
        array("Cells", "connectivity", "Int64", 1, ints(connectivity)),
        array("Cells", "offsets", "Int64", 1, ints(ends)),
        array("Cells", "types", "UInt8", 1, types),
    ]
}

/// Write `arrays` (in section order) as a VTU file of one piece.
pub(super) fn write_arrays(
    path: &Path,
    points: usize,
    cells: usize,
    arrays: &[Array],
    options: VtuOptions,
) -> Result<()> {
    let payloads: Vec<Vec<u8>> = arrays
        .iter()
        .map(|a| payload(&a.bytes, options.zlib))
        .collect();
    atomic_write(path, |w| {
        let compressor = if options.zlib {
            " compressor=\"vtkZLibDataCompressor\""
        } else {
            ""
        };
        writeln!(w, "<?xml version=\"1.0\"?>")?;
        writeln!(
            w,
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"{compressor}>"
        )?;
        writeln!(
            w,
            "  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
            points, cells
        )?;
        let mut offset = 0;
        let mut open: Option<&str> = None;
        for (a, p) in arrays.iter().zip(&payloads) {
            if open != Some(a.section) {
                if let Some(s) = open {
                    writeln!(w, "      </{s}>")?;
                }
                writeln!(w, "      <{}>", a.section)?;
                open = Some(a.section);
            }
            let comps = if a.components == 1 {
                String::new()
            } else {
                format!(" NumberOfComponents=\"{}\"", a.components)
            };
            let head = format!(
                "        <DataArray type=\"{}\" Name=\"{}\"{comps}",
                a.ty,
                xml::escape(&a.name)
            );
            if options.base64 {
                // Compressed: header and data encoded apart, as VTK does and meshio expects.
                let split = if options.zlib {
                    let blocks = u64::from_le_bytes(p[..8].try_into().expect("an 8-byte header"));
                    8 * (3 + blocks as usize)
                } else {
                    0
                };
                write!(w, "{head} format=\"binary\">")?;
                if split > 0 {
                    write!(w, "{}", BASE64.encode(&p[..split]))?;
                }
                writeln!(w, "{}</DataArray>", BASE64.encode(&p[split..]))?;
            } else {
                writeln!(w, "{head} format=\"appended\" offset=\"{offset}\"/>")?;
                offset += p.len();
            }
        }
        if let Some(s) = open {
            writeln!(w, "      </{s}>")?;
        }
        writeln!(w, "    </Piece>\n  </UnstructuredGrid>")?;
        if !options.base64 {
            write!(w, "  <AppendedData encoding=\"raw\">\n   _")?;
            for p in &payloads {
                w.write_all(p)?;
            }
            writeln!(w, "\n  </AppendedData>")?;
        }
        writeln!(w, "</VTKFile>")
    })
}
