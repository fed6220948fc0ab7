//! MEDIT `.mesh` files (ASCII), read and written; as Mmg, TetGen (`-g`) and CGAL write them.
//!
//! Tetrahedra become the mesh; triangles and tets with a non-zero reference number become groups
//! `ref_<r>` (dimension 2 and 3). Other sections are skipped. The binary `.meshb` variant is not
//! supported: no maintained Rust crate reads it, and the tools that write it also write `.mesh`.

use std::path::Path;

use super::text::{Cursor, shorten};
use super::{
    Groups, Ignored, Parsed, atomic_write, fmt_f64, marked_faces, missing_node, read_bytes,
};
use crate::error::Result;
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// Numbers per entry of the sections we skip, by lower-case keyword.
fn skipped_width(keyword: &str) -> Option<(usize, &'static str)> {
    Some(match keyword {
        "edges" => (3, "edge"),
        "quadrilaterals" => (5, "quadrilateral"),
        "hexahedra" => (9, "hexahedron"),
        "prisms" => (7, "prism"),
        "pyramids" => (6, "pyramid"),
        "corners"
        | "ridges"
        | "requiredvertices"
        | "requirededges"
        | "requiredtriangles"
        | "requiredquadrilaterals"
        | "requiredtetrahedra" => (1, ""),
        "normals" | "tangents" => (3, ""),
        "normalatvertices" | "tangentatvertices" => (2, ""),
        "normalattrianglevertices" => (3, ""),
        _ => return None,
    })
}

/// Read a MEDIT `.mesh` file.
pub fn read(path: &Path) -> Result<Parsed> {
    let data = read_bytes(path)?;
    let mut c = Cursor::new(path, &data).with_comment(b'#');
    let first_line = c.line();
    match c.next_token() {
        Some(t) if t.eq_ignore_ascii_case("MeshVersionFormatted") => {}
        Some(t) => {
            return Err(c.error_at(
                first_line,
                format!(
                    "not a MEDIT mesh: expected `MeshVersionFormatted`, found `{}`",
                    shorten(t)
                ),
            ));
        }
        None => return Err(c.error_at(first_line, "not a MEDIT mesh: the file is empty")),
    }
    c.parse::<u32>("the format version")?;
    let mut positions = Vec::new();
    let mut tets = Vec::new();
    let mut groups = Groups::default();
    let mut ignored = Ignored::default();
    let index = |c: &mut Cursor, n: usize, element: u64| -> Result<usize> {
        let v: u64 = c.parse("a vertex number")?;
        v.checked_sub(1)
            .map(|v| v as usize)
            .filter(|&v| v < n)
            .ok_or_else(|| missing_node(path, element, v))
    };
    while let Some(keyword) = c.next_token() {
        let lower = keyword.to_ascii_lowercase();
        match lower.as_str() {
            "end" => break,
            "dimension" => {
                let d: u32 = c.parse("the dimension")?;
                if d != 3 {
                    return Err(c.error(format!("dimension is {d}: tetsim needs 3D meshes")));
                }
            }
            "vertices" => {
                let n = c.count("the number of vertices", data.len() / 8 + 1)?;
                positions.reserve(n);
                for _ in 0..n {
                    positions.push(Vec3::new(
                        c.parse("an x coordinate")?,
                        c.parse("a y coordinate")?,
                        c.parse("a z coordinate")?,
                    ));
                    c.parse::<i64>("a vertex reference")?;
                }
            }
            "triangles" => {
                let n = c.count("the number of triangles", data.len() / 8 + 1)?;
                for k in 0..n {
                    let id = k as u64 + 1;
                    let mut f = [0usize; 3];
                    for slot in &mut f {
                        *slot = index(&mut c, positions.len(), id)?;
                    }
                    let r: i64 = c.parse("a triangle reference")?;
                    if r != 0 {
                        let g = groups.entry(2, r, &format!("ref_{r}"));
                        g.faces.push(f);
                        g.vertices.extend_from_slice(&f);
                    }
                }
                ignored.add("triangle", n);
            }
            "tetrahedra" => {
                let n = c.count("the number of tetrahedra", data.len() / 10 + 1)?;
                tets.reserve(n);
                for k in 0..n {
                    let id = k as u64 + 1;
                    let mut t = [0usize; 4];
                    for slot in &mut t {
                        *slot = index(&mut c, positions.len(), id)?;
                    }
                    let r: i64 = c.parse("a tetrahedron reference")?;
                    if r != 0 {
                        let g = groups.entry(3, r, &format!("ref_{r}"));
                        g.tets.push(tets.len());
                        g.vertices.extend_from_slice(&t);
                    }
                    tets.push(t);
                }
            }
            other => {
                let (width, name) = skipped_width(other).ok_or_else(|| {
                    c.error(format!("unknown MEDIT keyword `{}`", shorten(keyword)))
                })?;
                let n = c.count(&format!("the number of {keyword}"), data.len() / 2 + 1)?;
                for _ in 0..n * width {
                    c.parse::<f64>(&format!("a number of {keyword}"))?;
                }
                if !name.is_empty() {
                    ignored.add(name, n);
                }
            }
        }
    }
    let mut mesh = TetMesh::new(positions, tets);
    mesh.vertex_ids = Some((1..=mesh.positions.len() as u64).collect());
    mesh.tet_ids = Some((1..=mesh.tets.len() as u64).collect());
    mesh.groups = groups.finish();
    Ok(Parsed {
        mesh,
        ignored: ignored.finish(),
        element_path: path.to_path_buf(),
        node_path: path.to_path_buf(),
    })
}

/// Write `mesh` as MEDIT: dimension-2 group faces as referenced triangles, tets referenced by
/// their first dimension-3 group's tag (0 when none).
pub fn write(path: &Path, mesh: &TetMesh) -> Result<()> {
    let mut reference = vec![0i64; mesh.tets.len()];
    for g in mesh.groups.iter().filter(|g| g.dim == 3).rev() {
        for &t in &g.tets {
            if let Some(r) = reference.get_mut(t) {
                *r = g.tag;
            }
        }
    }
    let faces = marked_faces(mesh);
    atomic_write(path, |w| {
        writeln!(
            w,
            "MeshVersionFormatted 2\nDimension 3\nVertices\n{}",
            mesh.positions.len()
        )?;
        for x in &mesh.positions {
            writeln!(w, "{} {} {} 0", fmt_f64(x.x), fmt_f64(x.y), fmt_f64(x.z))?;
        }
        if !faces.is_empty() {
            writeln!(w, "Triangles\n{}", faces.len())?;
            for (f, r) in &faces {
                writeln!(w, "{} {} {} {r}", f[0] + 1, f[1] + 1, f[2] + 1)?;
            }
        }
        writeln!(w, "Tetrahedra\n{}", mesh.tets.len())?;
        for (t, r) in mesh.tets.iter().zip(&reference) {
            writeln!(w, "{} {} {} {} {r}", t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1)?;
        }
        writeln!(w, "End")
    })
}
