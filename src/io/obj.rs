//! Wavefront `.obj` surfaces: the outward boundary of a tet mesh, for Blender and friends; and
//! triangle surfaces read back (rigid contact obstacles).

use std::path::Path;

use super::{atomic_write, fmt_f64, read_bytes};
use crate::error::{Error, Result};
use crate::math::Vec3;

/// A triangle surface (open or closed), as read from `.obj` or `.stl`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleSurface {
    /// Vertex positions, m.
    pub positions: Vec<Vec3>,
    /// Triangles as 0-based indices into `positions`, orientation as in the file.
    pub faces: Vec<[usize; 3]>,
}

/// Read the triangles of a Wavefront `.obj`: `v x y z [w]` and `f` lines (indices 1-based or
/// negative = relative, `i/t/n` forms accepted; polygons are split into fans). Other statements
/// (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `l`, …) are ignored. Errors name the file and line:
/// a malformed or non-finite coordinate, a face with fewer than 3 vertices or naming a missing
/// vertex, or a file without any triangle.
pub fn read_obj(path: &Path) -> Result<TriangleSurface> {
    let data = read_bytes(path)?;
    let text = String::from_utf8_lossy(&data);
    let mut surface = TriangleSurface::default();
    // Faces are checked once all vertices are known (an OBJ may list faces first); keep lines.
    let mut pending: Vec<(usize, Vec<i64>)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = line.split('#').next().unwrap_or("");
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut c = [0.0; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let token = tokens.next().ok_or_else(|| {
                        Error::parse(path, Some(line_no), "vertex with fewer than 3 coordinates")
                    })?;
                    *slot = token.parse::<f64>().map_err(|_| {
                        Error::parse(
                            path,
                            Some(line_no),
                            format!("coordinate {} `{token}` is not a number", k + 1),
                        )
                    })?;
                }
                if c.iter().any(|x| !x.is_finite()) {
                    return Err(Error::parse(
                        path,
                        Some(line_no),
                        format!(
                            "vertex {} has a non-finite coordinate",
                            surface.positions.len() + 1
                        ),
                    ));
                }
                surface.positions.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let mut ids = Vec::new();
                for token in tokens {
                    let first = token.split('/').next().unwrap_or("");
                    let id: i64 = first.parse().map_err(|_| {
                        Error::parse(
                            path,
                            Some(line_no),
                            format!("face index `{token}` is not an integer"),
                        )
                    })?;
                    // Negative indices count back from the vertices read so far.
                    let absolute = if id < 0 {
                        surface.positions.len() as i64 + id + 1
                    } else {
                        id
                    };
                    ids.push(absolute);
                }
                if ids.len() < 3 {
                    return Err(Error::parse(
                        path,
                        Some(line_no),
                        format!("face with {} vertices (at least 3 needed)", ids.len()),
                    ));
                }
                pending.push((line_no, ids));
            }
            _ => {}
        }
    }
    let n = surface.positions.len() as i64;
    for (line_no, ids) in pending {
        if let Some(&bad) = ids.iter().find(|&&id| id < 1 || id > n) {
            return Err(Error::parse(
                path,
                Some(line_no),
                format!("face refers to vertex {bad}, but the file has {n} vertices"),
            ));
        }
        let ids: Vec<usize> = ids.iter().map(|&id| (id - 1) as usize).collect();
        for k in 1..ids.len() - 1 {
            surface.faces.push([ids[0], ids[k], ids[k + 1]]);
        }
    }
    if surface.faces.is_empty() {
        return Err(Error::parse(path, None, "no triangles (no `f` lines)"));
    }
    Ok(surface)
}

/// Write the triangles `faces` over `points` as an OBJ surface. Only the points the faces use
/// are written, renumbered in increasing index order; faces keep their orientation (pass
/// `TetMesh::boundary_faces()` for outward normals). Positions may be deformed ones.
pub fn write_obj(path: &Path, points: &[Vec3], faces: &[[usize; 3]]) -> Result<()> {
    let mut index = vec![0usize; points.len()];
    for f in faces {
        for &v in f {
            if let Some(slot) = index.get_mut(v) {
                *slot = 1;
            }
        }
    }
    let mut next = 0;
    for slot in &mut index {
        if *slot == 1 {
            next += 1;
            *slot = next;
        }
    }
    atomic_write(path, |w| {
        writeln!(
            w,
            "# tetsim boundary surface: {} vertices, {} faces",
            next,
            faces.len()
        )?;
        for (p, &i) in points.iter().zip(&index) {
            if i > 0 {
                writeln!(w, "v {} {} {}", fmt_f64(p.x), fmt_f64(p.y), fmt_f64(p.z))?;
            }
        }
        for f in faces {
            let [a, b, c] = f.map(|v| index.get(v).copied().unwrap_or(0));
            if a > 0 && b > 0 && c > 0 {
                writeln!(w, "f {a} {b} {c}")?;
            }
        }
        Ok(())
    })
}
