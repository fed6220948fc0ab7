//! STL triangle surfaces, ASCII and binary, read as a [`TriangleSurface`] (rigid obstacles).
//!
//! STL stores every triangle with its own three corners; corners with bit-identical coordinates
//! are merged (in order of first appearance), so a closed STL becomes a closed surface whose
//! edges are shared, as contact needs. The format is recognised by size, not by the leading
//! `solid` (which binary exporters often write too): a file of exactly 84 + 50·n bytes, n the
//! count at byte 80, is binary; anything else is read as ASCII.

use std::collections::HashMap;
use std::path::Path;

use super::obj::TriangleSurface;
use super::read_bytes;
use crate::error::{Error, Result};
use crate::math::Vec3;

/// Read an ASCII or binary `.stl`. Errors name the file and the line (ASCII) or the triangle and
/// byte offset (binary): malformed numbers, non-finite coordinates, a facet without exactly
/// three vertices, truncated data, or no triangles at all.
pub fn read_stl(path: &Path) -> Result<TriangleSurface> {
    let data = read_bytes(path)?;
    let corners = if is_binary(&data) {
        binary_corners(path, &data)?
    } else {
        ascii_corners(path, &data)?
    };
    if corners.is_empty() {
        return Err(Error::parse(path, None, "no triangles"));
    }
    let mut surface = TriangleSurface::default();
    let mut index: HashMap<[u64; 3], usize> = HashMap::new();
    for tri in corners {
        let face = tri.map(|p| {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            *index.entry(key).or_insert_with(|| {
                surface.positions.push(p);
                surface.positions.len() - 1
            })
        });
        surface.faces.push(face);
    }
    Ok(surface)
}

fn is_binary(data: &[u8]) -> bool {
    data.len() >= 84 && {
        let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as usize;
        n.checked_mul(50).and_then(|b| b.checked_add(84)) == Some(data.len())
    }
}

fn binary_corners(path: &Path, data: &[u8]) -> Result<Vec<[Vec3; 3]>> {
    let n = (data.len() - 84) / 50;
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        let base = 84 + 50 * t;
        let f = |k: usize| {
            let o = base + 12 + 4 * k;
            f32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]]) as f64
        };
        let tri: [Vec3; 3] =
            std::array::from_fn(|v| Vec3::new(f(3 * v), f(3 * v + 1), f(3 * v + 2)));
        if tri.iter().any(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(Error::parse(
                path,
                None,
                format!(
                    "binary triangle {} (byte offset {}) has a non-finite coordinate",
                    t + 1,
                    base + 12
                ),
            ));
        }
        out.push(tri);
    }
    Ok(out)
}

fn ascii_corners(path: &Path, data: &[u8]) -> Result<Vec<[Vec3; 3]>> {
    let text = String::from_utf8_lossy(data);
    let mut out = Vec::new();
    let mut facet: Vec<Vec3> = Vec::new();
    let mut facet_line = 0;
    let mut in_facet = false;
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("facet") => {
                in_facet = true;
                facet_line = line_no;
                facet.clear();
            }
            Some("vertex") => {
                if !in_facet {
                    return Err(Error::parse(
                        path,
                        Some(line_no),
                        "`vertex` outside a facet",
                    ));
                }
                let mut c = [0.0; 3];
                for slot in &mut c {
                    let token = tokens.next().ok_or_else(|| {
                        Error::parse(path, Some(line_no), "vertex with fewer than 3 coordinates")
                    })?;
                    *slot = token.parse::<f64>().map_err(|_| {
                        Error::parse(
                            path,
                            Some(line_no),
                            format!("coordinate `{token}` is not a number"),
                        )
                    })?;
                }
                if c.iter().any(|x| !x.is_finite()) {
                    return Err(Error::parse(
                        path,
                        Some(line_no),
                        "vertex has a non-finite coordinate",
                    ));
                }
                facet.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("endfacet") => {
                if facet.len() != 3 {
                    return Err(Error::parse(
                        path,
                        Some(facet_line),
                        format!("facet with {} vertices (STL needs exactly 3)", facet.len()),
                    ));
                }
                out.push([facet[0], facet[1], facet[2]]);
                in_facet = false;
            }
            _ => {}
        }
    }
    if in_facet {
        return Err(Error::parse(
            path,
            Some(facet_line),
            "facet not closed by `endfacet` (truncated file?)",
        ));
    }
    Ok(out)
}
