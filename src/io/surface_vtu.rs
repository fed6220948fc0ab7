//! Triangle surfaces as VTU files (`obstacles_NNNN.vtu`): the same raw appended writer as the
//! tet frames, with VTK_TRIANGLE cells, and a reader that keeps the triangle cells.

use std::path::Path;

use super::vtu::{Field, FieldData, VtuOptions, parse_grid, write_cells};
use crate::error::{Error, Result};
use crate::math::Vec3;

/// VTK's cell type of a linear triangle.
const VTK_TRIANGLE: u8 = 5;

/// A triangle-surface VTU read back: points, the triangle cells, and the cell data restricted
/// to those triangles (in the same order). Cells of other types are skipped.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceFrame {
    /// All points, in file order.
    pub points: Vec<Vec3>,
    /// The triangle cells.
    pub triangles: Vec<[usize; 3]>,
    /// Cell data arrays by name, one entry per triangle.
    pub cell_data: Vec<(String, FieldData)>,
}

impl SurfaceFrame {
    /// The cell data array `name`.
    pub fn cell_field(&self, name: &str) -> Option<&FieldData> {
        self.cell_data.iter().find(|f| f.0 == name).map(|f| &f.1)
    }
}

/// Write a VTU file of triangles with f64 point and cell data (raw appended binary), atomically.
/// Every field must have one entry per point (per triangle for cell data).
pub fn write_surface_vtu(
    path: &Path,
    points: &[Vec3],
    triangles: &[[usize; 3]],
    point_data: &[(&str, Field)],
    cell_data: &[(&str, Field)],
) -> Result<()> {
    write_cells(
        path,
        points,
        triangles,
        VTK_TRIANGLE,
        point_data,
        cell_data,
        VtuOptions::default(),
    )
}

/// Read the triangles of a VTU file (e.g. tetsim's `obstacles_NNNN.vtu`).
pub fn read_surface_vtu(path: &Path) -> Result<SurfaceFrame> {
    let g = parse_grid(path)?;
    let n = g.points.len();
    let mut cells = Vec::new();
    let mut triangles = Vec::new();
    for (c, &ty) in g.types.iter().enumerate() {
        if ty != i64::from(VTK_TRIANGLE) {
            continue;
        }
        let (start, end) = (g.offsets[c], g.offsets[c + 1]);
        let nodes = usize::try_from(start)
            .ok()
            .zip(usize::try_from(end).ok())
            .and_then(|(s, e)| g.connectivity.get(s..e))
            .filter(|nodes| nodes.len() == 3)
            .ok_or_else(|| Error::parse(path, None, format!("triangle cell {c} is malformed")))?;
        let mut triangle = [0; 3];
        for (slot, &v) in triangle.iter_mut().zip(nodes) {
            *slot = usize::try_from(v).ok().filter(|&v| v < n).ok_or_else(|| {
                Error::parse(path, None, format!("cell {c} names a missing point {v}"))
            })?;
        }
        cells.push(c);
        triangles.push(triangle);
    }
    let pick = |f: FieldData| match f {
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
    Ok(SurfaceFrame {
        points: g.points,
        triangles,
        cell_data: g.cell_data.into_iter().map(|(k, f)| (k, pick(f))).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangles_and_cell_data_round_trip() {
        let dir = std::env::temp_dir().join(format!("tetsim-surface-vtu-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("s.vtu");
        let points = [Vec3::zeros(), Vec3::x(), Vec3::y(), Vec3::z()];
        let triangles = [[0, 1, 2], [0, 3, 1]];
        write_surface_vtu(
            &path,
            &points,
            &triangles,
            &[],
            &[("obstacle", Field::Scalar(&[0.0, 1.0]))],
        )
        .unwrap();
        let back = read_surface_vtu(&path).unwrap();
        assert_eq!(back.points, points);
        assert_eq!(back.triangles, triangles);
        assert_eq!(
            back.cell_field("obstacle"),
            Some(&FieldData::Scalar(vec![0.0, 1.0]))
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
