//! Wavefront `.obj` surfaces: the outward boundary of a tet mesh, for Blender and friends.

use std::path::Path;

use super::{atomic_write, fmt_f64};
use crate::error::Result;
use crate::math::Vec3;

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
