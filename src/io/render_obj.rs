//! Render surfaces in Wavefront `.obj`: everything a modelling tool puts in the file that a
//! deformed copy must keep to read back the same way: positions, texture coordinates, polygons
//! with their `v/vt/vn` corners, objects and groups (`o`, `g`), smoothing groups (`s`),
//! materials (`usemtl`, `mtllib`). Normals in the file (`vn`) are read for their count only:
//! they are recomputed from the deformed positions every frame ([`vertex_normals`]).
//!
//! [`write_render_obj`] writes the surface back with new positions, one normal per position
//! and the statements in their order, so that Blender, Maya or MeshLab read the same objects,
//! groups, materials and UV layout as in the input file.

use std::io::Write;
use std::path::Path;

use super::{atomic_write, read_bytes};
use crate::error::{Error, Result};
use crate::math::Vec3;

/// One corner of a polygon: its position and, when the file gives one, its texture coordinate
/// (0-based indices).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Corner {
    /// Index into [`RenderSurface::positions`].
    pub v: u32,
    /// Index into [`RenderSurface::texcoords`].
    pub vt: Option<u32>,
}

/// A statement of the file, in order: polygons and the statements that name what follows them.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    /// A polygon (3 or more corners, orientation as in the file).
    Face(Vec<Corner>),
    /// `o name`: a new object.
    Object(String),
    /// `g names…`: the groups of what follows.
    Group(String),
    /// `usemtl name`: the material of what follows.
    Material(String),
    /// `s …`: the smoothing group of what follows.
    Smoothing(String),
}

/// A detailed surface for rendering, as read from an OBJ.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderSurface {
    /// Vertex positions (in the file's unit until the scene places them).
    pub positions: Vec<Vec3>,
    /// Texture coordinates (u, v); a third coordinate in the file is dropped.
    pub texcoords: Vec<[f64; 2]>,
    /// Faces and naming statements, in file order.
    pub items: Vec<Item>,
    /// The `mtllib` file names, in order.
    pub mtllibs: Vec<String>,
}

impl RenderSurface {
    /// The polygons, fan-split into triangles (position indices).
    pub fn triangles(&self) -> Vec<[usize; 3]> {
        let mut out = Vec::new();
        for item in &self.items {
            if let Item::Face(c) = item {
                for k in 1..c.len() - 1 {
                    out.push([c[0].v as usize, c[k].v as usize, c[k + 1].v as usize]);
                }
            }
        }
        out
    }

    /// How many polygons.
    pub fn face_count(&self) -> usize {
        self.items
            .iter()
            .filter(|i| matches!(i, Item::Face(_)))
            .count()
    }
}

/// Area-weighted vertex normals of the triangles over `positions` (unit length; zero for a
/// vertex no triangle with area uses).
pub fn vertex_normals(positions: &[Vec3], triangles: &[[usize; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::zeros(); positions.len()];
    for &[a, b, c] in triangles {
        // The cross product's length is twice the area: larger triangles weigh more.
        let w = (positions[b] - positions[a]).cross(&(positions[c] - positions[a]));
        for v in [a, b, c] {
            n[v] += w;
        }
    }
    for v in &mut n {
        let len = v.norm();
        *v = if len > 0.0 { *v / len } else { Vec3::zeros() };
    }
    n
}

/// Read a render surface. Errors name the file and line: a malformed or non-finite number, a
/// polygon with fewer than 3 corners or naming a missing position or texture coordinate, a
/// file without any polygon.
pub fn read_render_obj(path: &Path) -> Result<RenderSurface> {
    let data = read_bytes(path)?;
    let text = String::from_utf8_lossy(&data);
    let mut s = RenderSurface::default();
    let mut normals = 0usize;
    // Faces are checked once every vertex is known; keep their lines.
    let mut face_lines: Vec<(usize, usize)> = Vec::new();
    let err = |line: usize, m: String| Error::parse(path, Some(line), m);
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let (keyword, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        let rest = rest.trim();
        match keyword {
            "v" => {
                let c = numbers::<3>(rest, 3, "vertex", line_no, path)?;
                s.positions.push(Vec3::new(c[0], c[1], c[2]));
            }
            "vt" => {
                let c = numbers::<2>(rest, 1, "texture coordinate", line_no, path)?;
                s.texcoords.push(c);
            }
            "vn" => {
                numbers::<3>(rest, 3, "normal", line_no, path)?;
                normals += 1;
            }
            "f" => {
                let mut corners = Vec::new();
                for token in rest.split_whitespace() {
                    let mut parts = token.split('/');
                    let index = |part: Option<&str>, count: usize, what: &str| {
                        resolve(part, count, what, token, line_no, path)
                    };
                    let v = index(parts.next(), s.positions.len(), "vertex")?
                        .ok_or_else(|| err(line_no, format!("corner `{token}` has no vertex")))?;
                    let vt = index(parts.next(), s.texcoords.len(), "texture coordinate")?;
                    index(parts.next(), normals, "normal")?;
                    corners.push(Corner { v, vt });
                }
                if corners.len() < 3 {
                    return Err(err(
                        line_no,
                        format!("face with {} vertices (at least 3 needed)", corners.len()),
                    ));
                }
                face_lines.push((s.items.len(), line_no));
                s.items.push(Item::Face(corners));
            }
            "o" => s.items.push(Item::Object(rest.to_string())),
            "g" => s.items.push(Item::Group(rest.to_string())),
            "usemtl" => s.items.push(Item::Material(rest.to_string())),
            "s" => s.items.push(Item::Smoothing(rest.to_string())),
            "mtllib" => s.mtllibs.push(rest.to_string()),
            _ => {}
        }
    }
    // Indices may name vertices listed after the face: check them all at the end.
    let (nv, nt) = (s.positions.len(), s.texcoords.len());
    for (item, line_no) in face_lines {
        let Item::Face(corners) = &s.items[item] else {
            continue;
        };
        for c in corners {
            if c.v as usize >= nv {
                return Err(err(
                    line_no,
                    format!(
                        "face refers to vertex {}, but the file has {nv} vertices",
                        c.v + 1
                    ),
                ));
            }
            if let Some(t) = c.vt.filter(|&t| t as usize >= nt) {
                return Err(err(
                    line_no,
                    format!(
                        "face refers to texture coordinate {}, but the file has {nt}",
                        t + 1
                    ),
                ));
            }
        }
    }
    if s.face_count() == 0 {
        return Err(Error::parse(path, None, "no faces (no `f` lines)"));
    }
    Ok(s)
}

/// Parse up to N numbers of which at least `least` must be there; finite ones only.
fn numbers<const N: usize>(
    rest: &str,
    least: usize,
    what: &str,
    line: usize,
    path: &Path,
) -> Result<[f64; N]> {
    let mut out = [0.0; N];
    let mut count = 0;
    for (k, token) in rest.split_whitespace().enumerate().take(N) {
        let x: f64 = token.parse().map_err(|_| {
            Error::parse(
                path,
                Some(line),
                format!("{what}: coordinate {} `{token}` is not a number", k + 1),
            )
        })?;
        if !x.is_finite() {
            return Err(Error::parse(
                path,
                Some(line),
                format!("{what}: coordinate {} is not finite", k + 1),
            ));
        }
        out[k] = x;
        count += 1;
    }
    if count < least {
        return Err(Error::parse(
            path,
            Some(line),
            format!("{what} with {count} coordinates (at least {least} needed)"),
        ));
    }
    Ok(out)
}

/// One index of a corner (`7`, `-1` relative to the `count` read so far, or empty): 0-based.
fn resolve(
    part: Option<&str>,
    count: usize,
    what: &str,
    token: &str,
    line: usize,
    path: &Path,
) -> Result<Option<u32>> {
    let Some(part) = part.filter(|p| !p.is_empty()) else {
        return Ok(None);
    };
    let id: i64 = part.parse().map_err(|_| {
        Error::parse(
            path,
            Some(line),
            format!("face corner `{token}`: {what} index `{part}` is not an integer"),
        )
    })?;
    let absolute = if id < 0 { count as i64 + id } else { id - 1 };
    if absolute < 0 || absolute > u32::MAX as i64 {
        return Err(Error::parse(
            path,
            Some(line),
            format!("face corner `{token}`: {what} index {id} names no {what}"),
        ));
    }
    Ok(Some(absolute as u32))
}

/// Write `surface` with `positions` (same count as its own) as an OBJ: the `mtllib` lines
/// (`mtllibs`, as the caller renamed them), `v` lines, `vt` lines, one `vn` per vertex
/// (recomputed from `positions`), then the statements in file order, polygons as
/// `f v/vt/vn …`. `object` is written as `o object` before the first face when the surface
/// names no object before it (so that several surfaces in one file stay apart), and prefixes
/// the surface's own object names (`object.name`).
pub fn write_render_obj(
    w: &mut dyn Write,
    surface: &RenderSurface,
    positions: &[Vec3],
    mtllibs: &[String],
    object: Option<&str>,
    offsets: [usize; 2],
) -> std::io::Result<()> {
    let normals = vertex_normals(positions, &surface.triangles());
    for lib in mtllibs {
        writeln!(w, "mtllib {lib}")?;
    }
    let mut line = String::with_capacity(96);
    for p in positions {
        line.clear();
        push_numbers(&mut line, "v", p.as_slice());
        w.write_all(line.as_bytes())?;
    }
    for t in &surface.texcoords {
        line.clear();
        push_numbers(&mut line, "vt", t);
        w.write_all(line.as_bytes())?;
    }
    for n in &normals {
        line.clear();
        push_numbers(&mut line, "vn", n.as_slice());
        w.write_all(line.as_bytes())?;
    }
    let [v0, t0] = offsets;
    let mut named = false;
    for item in &surface.items {
        match item {
            Item::Face(corners) => {
                if !named && let Some(o) = object {
                    writeln!(w, "o {o}")?;
                }
                named = true;
                line.clear();
                line.push('f');
                for c in corners {
                    let v = v0 + c.v as usize + 1;
                    match c.vt {
                        Some(t) => line.push_str(&format!(" {v}/{}/{v}", t0 + t as usize + 1)),
                        None => line.push_str(&format!(" {v}//{v}")),
                    }
                }
                line.push('\n');
                w.write_all(line.as_bytes())?;
            }
            Item::Object(name) => {
                named = true;
                match object {
                    Some(o) => writeln!(w, "o {o}.{name}")?,
                    None => writeln!(w, "o {name}")?,
                }
            }
            Item::Group(name) => writeln!(w, "g {name}")?,
            Item::Material(name) => writeln!(w, "usemtl {name}")?,
            Item::Smoothing(name) => writeln!(w, "s {name}")?,
        }
    }
    Ok(())
}

/// `keyword x y z\n` with shortest round-trip numbers.
fn push_numbers(line: &mut String, keyword: &str, values: &[f64]) {
    use std::fmt::Write as _;
    line.push_str(keyword);
    for x in values {
        // −0 reads back the same as 0 and is noise.
        let x = if *x == 0.0 { 0.0 } else { *x };
        let _ = write!(line, " {x:?}");
    }
    line.push('\n');
}

/// Write one surface alone to `path` (atomically), for tools and tests.
pub fn write_render_obj_file(
    path: &Path,
    surface: &RenderSurface,
    positions: &[Vec3],
) -> Result<()> {
    atomic_write(path, |w| {
        write_render_obj(w, surface, positions, &surface.mtllibs, None, [0, 0])
    })
}

/// The `v` lines of an OBJ (as [`write_render_obj`] writes them), for rebuilding an animation
/// from the frames on disk: positions only, in order.
pub fn read_obj_positions(path: &Path) -> Result<Vec<Vec3>> {
    let data = read_bytes(path)?;
    let mut out = Vec::new();
    for (i, line) in data.split(|&b| b == b'\n').enumerate() {
        let Some(rest) = line.strip_prefix(b"v ") else {
            continue;
        };
        let text = std::str::from_utf8(rest).unwrap_or("");
        let c = numbers::<3>(text, 3, "vertex", i + 1, path)?;
        out.push(Vec3::new(c[0], c[1], c[2]));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_of_a_flat_square_point_up() {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let n = vertex_normals(&p, &[[0, 1, 2], [0, 2, 3]]);
        assert!(n.iter().all(|n| (n - Vec3::z()).norm() < 1e-15));
    }
}
