//! How well a tet mesh represents a surface: dihedral angles, volume against the volume the
//! surface encloses, and the Hausdorff distance between the mesh's boundary and the surface
//! (sampled at vertices and triangle centroids, both ways).

use rayon::prelude::*;

use super::bvh::TriangleBvh;
use crate::io::obj::TriangleSurface;
use crate::math::Vec3;
use crate::mesh::TetMesh;

/// The measures of [`assess`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quality {
    /// Smallest dihedral angle over all tets, degrees.
    pub min_dihedral: f64,
    /// Largest dihedral angle over all tets, degrees.
    pub max_dihedral: f64,
    /// Tets with non-positive volume.
    pub inverted: usize,
    /// Σ of the tets' volumes, m³.
    pub volume: f64,
    /// The volume the surface encloses (divergence theorem, orientation-free), m³.
    pub surface_volume: f64,
    /// Largest distance from a sample of the mesh's boundary to the surface, m.
    pub boundary_to_surface: f64,
    /// Largest distance from a sample of the surface to the mesh's boundary, m.
    pub surface_to_boundary: f64,
}

impl Quality {
    /// Relative volume error |V_mesh − V_surface| / V_surface.
    pub fn volume_error(&self) -> f64 {
        (self.volume - self.surface_volume).abs() / self.surface_volume.abs().max(f64::MIN_POSITIVE)
    }

    /// The Hausdorff distance: the larger of the two directions.
    pub fn hausdorff(&self) -> f64 {
        self.boundary_to_surface.max(self.surface_to_boundary)
    }
}

/// Signed volume enclosed by the triangles (positive for outward orientation).
pub fn enclosed_volume(surface: &TriangleSurface) -> f64 {
    let p = &surface.positions;
    surface
        .faces
        .iter()
        .filter(|f| f.iter().all(|&v| v < p.len()))
        .map(|f| p[f[0]].dot(&p[f[1]].cross(&p[f[2]])) / 6.0)
        .sum()
}

/// Total area of the triangles.
pub fn surface_area(surface: &TriangleSurface) -> f64 {
    let p = &surface.positions;
    surface
        .faces
        .iter()
        .filter(|f| f.iter().all(|&v| v < p.len()))
        .map(|f| 0.5 * (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]])).norm())
        .sum()
}

/// Smallest and largest dihedral angle of one tet, degrees, and its signed volume.
pub fn tet_angles(p: &[Vec3; 4]) -> (f64, f64, f64) {
    let volume = (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(p[3] - p[0])) / 6.0;
    const OPPOSITE: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];
    let normals = [0, 1, 2, 3].map(|i| {
        let [a, b, c] = OPPOSITE[i];
        let n = (p[b] - p[a]).cross(&(p[c] - p[a]));
        if n.dot(&(p[a] - p[i])) < 0.0 { -n } else { n }
    });
    let (mut lo, mut hi) = (180.0f64, 0.0f64);
    for k in 0..4 {
        for l in k + 1..4 {
            let denom = normals[k].norm() * normals[l].norm();
            let angle = if denom > 0.0 {
                (-normals[k].dot(&normals[l]) / denom)
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees()
            } else {
                0.0
            };
            lo = lo.min(angle);
            hi = hi.max(angle);
        }
    }
    (lo, hi, volume)
}

/// Measure `mesh` against the surface it was made from.
pub fn assess(mesh: &TetMesh, surface: &TriangleSurface) -> Quality {
    let x = &mesh.positions;
    // Min, max and counts are exact in any order; the volume is summed in tet order.
    let (min_dihedral, max_dihedral, inverted) = mesh
        .tets
        .par_iter()
        .map(|t| {
            let (lo, hi, v) = tet_angles(&t.map(|i| x[i]));
            (lo, hi, usize::from(v <= 0.0))
        })
        .reduce(
            || (180.0f64, 0.0f64, 0usize),
            |a, b| (a.0.min(b.0), a.1.max(b.1), a.2 + b.2),
        );
    let volume: f64 = mesh
        .tets
        .iter()
        .map(|t| tet_angles(&t.map(|i| x[i])).2)
        .sum();
    let boundary: Vec<[Vec3; 3]> = mesh
        .boundary_faces()
        .iter()
        .map(|f| f.map(|v| x[v]))
        .collect();
    let surface_triangles: Vec<[Vec3; 3]> = surface
        .faces
        .iter()
        .filter(|f| f.iter().all(|&v| v < surface.positions.len()))
        .map(|f| f.map(|v| surface.positions[v]))
        .collect();
    let samples = |tris: &[[Vec3; 3]]| -> Vec<Vec3> {
        let mut s: Vec<Vec3> = tris.iter().flat_map(|t| t.iter().copied()).collect();
        s.extend(tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0));
        s
    };
    let farthest = |points: Vec<Vec3>, target: &TriangleBvh| {
        points
            .par_iter()
            .map(|p| target.distance(p))
            .reduce(|| 0.0, f64::max)
    };
    let boundary_samples = samples(&boundary);
    let surface_samples = samples(&surface_triangles);
    let boundary_bvh = TriangleBvh::new(boundary);
    let surface_bvh = TriangleBvh::new(surface_triangles);
    Quality {
        min_dihedral,
        max_dihedral,
        inverted,
        volume,
        surface_volume: enclosed_volume(surface).abs(),
        boundary_to_surface: farthest(boundary_samples, &surface_bvh),
        surface_to_boundary: farthest(surface_samples, &boundary_bvh),
    }
}
