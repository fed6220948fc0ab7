//! Rigid obstacles (SPEC §11): a plane, a box, a sphere, or any triangle surface, moved by the
//! same scripted [`Motion`] as `[[fixed]]` regions.
//!
//! Planes and spheres stay analytic (exact distances, see
//! [`point_plane_distance_derivatives`](super::distance::point_plane_distance_derivatives) and
//! [`sphere_triangle_distance_derivatives`](super::distance::sphere_triangle_distance_derivatives));
//! a box is a closed triangle surface (12 triangles, normals outward: bodies live outside it), and
//! a mesh obstacle is the triangle surface of a `.obj`, a `.stl` (ASCII or binary), or the
//! boundary of a tet mesh file read by [`crate::io::read_mesh`]; it may be open or closed.
//! Triangle obstacles take part in contact through their [`ContactSurface`] exactly like a body,
//! with positions from [`Obstacle::positions_at`] and no dofs.

use std::path::Path;

use super::surface::ContactSurface;
use crate::boundary::Motion;
use crate::error::{Error, Result};
use crate::io::obj::TriangleSurface;
use crate::math::Vec3;

/// An obstacle's shape at rest (before its motion).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// The half-space boundary through `point`; `normal` points to the free side.
    Plane {
        /// A point on the plane, m.
        point: Vec3,
        /// The normal (any nonzero length), towards the side bodies live on.
        normal: Vec3,
    },
    /// An axis-aligned box, a closed surface; bodies stay outside.
    Box {
        /// Lower corner, m.
        min: Vec3,
        /// Upper corner, m.
        max: Vec3,
    },
    /// A ball; bodies stay outside.
    Sphere {
        /// Center, m.
        center: Vec3,
        /// Radius, m (> 0).
        radius: f64,
    },
    /// Any triangle surface, open or closed.
    Mesh(TriangleSurface),
}

/// A rigid obstacle: a validated shape, its motion, and (for boxes and meshes) the triangles
/// contact uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    /// The shape at rest.
    pub shape: Shape,
    /// Scripted rigid motion, applied at ramp s ∈ [0, 1] by [`Motion::apply`].
    pub motion: Motion,
    /// Rest triangles (boxes and meshes; empty for planes and spheres).
    triangles: TriangleSurface,
    /// Vertices, edges and faces of `triangles` for the broad phase.
    surface: ContactSurface,
}

impl Obstacle {
    /// Validate `shape` and build its triangles. Refused: non-finite numbers, a zero normal, a
    /// box with min ≥ max on some axis, a radius ≤ 0, a mesh with no triangles or with faces
    /// naming missing vertices.
    pub fn new(shape: Shape, motion: Motion) -> Result<Obstacle> {
        let finite = |name: &str, v: &Vec3| {
            if v.iter().all(|c| c.is_finite()) {
                Ok(())
            } else {
                Err(Error::parameter(name, "must be finite"))
            }
        };
        let triangles = match &shape {
            Shape::Plane { point, normal } => {
                finite("obstacle.plane.point", point)?;
                finite("obstacle.plane.normal", normal)?;
                if normal.norm() == 0.0 {
                    return Err(Error::parameter(
                        "obstacle.plane.normal",
                        "must not be zero",
                    ));
                }
                TriangleSurface::default()
            }
            Shape::Box { min, max } => {
                finite("obstacle.box.min", min)?;
                finite("obstacle.box.max", max)?;
                if (0..3).any(|i| min[i] >= max[i]) {
                    return Err(Error::parameter(
                        "obstacle.box",
                        "min must be below max on every axis",
                    ));
                }
                box_surface(min, max)
            }
            Shape::Sphere { center, radius } => {
                finite("obstacle.sphere.center", center)?;
                if !(radius.is_finite() && *radius > 0.0) {
                    return Err(Error::parameter("obstacle.sphere.radius", "must be > 0"));
                }
                TriangleSurface::default()
            }
            Shape::Mesh(surface) => {
                if surface.faces.is_empty() {
                    return Err(Error::parameter("obstacle.mesh", "has no triangles"));
                }
                if let Some(v) = surface
                    .positions
                    .iter()
                    .position(|p| !p.iter().all(|c| c.is_finite()))
                {
                    return Err(Error::parameter(
                        "obstacle.mesh",
                        format!("vertex {v} has a non-finite coordinate"),
                    ));
                }
                let n = surface.positions.len();
                if let Some(f) = surface.faces.iter().position(|f| f.iter().any(|&v| v >= n)) {
                    return Err(Error::parameter(
                        "obstacle.mesh",
                        format!("triangle {f} refers to a missing vertex"),
                    ));
                }
                surface.clone()
            }
        };
        finite("obstacle.motion.translate", &motion.translate)?;
        let surface = ContactSurface::from_triangles(triangles.faces.clone());
        Ok(Obstacle {
            shape,
            motion,
            triangles,
            surface,
        })
    }

    /// A mesh obstacle from a file: `.obj`, `.stl`, or any tet mesh [`crate::io::read_mesh`]
    /// reads (its outward boundary).
    pub fn from_file(path: &Path, motion: Motion) -> Result<Obstacle> {
        Obstacle::new(Shape::Mesh(read_surface(path)?), motion)
    }

    /// The rest triangles (boxes and meshes; empty for planes and spheres).
    pub fn triangles(&self) -> &TriangleSurface {
        &self.triangles
    }

    /// Vertices, edges and faces of the triangles for contact (empty for planes and spheres).
    pub fn contact_surface(&self) -> &ContactSurface {
        &self.surface
    }

    /// Triangle vertex positions at ramp s (empty for planes and spheres).
    pub fn positions_at(&self, s: f64) -> Vec<Vec3> {
        self.triangles
            .positions
            .iter()
            .map(|x| self.motion.apply(s, x))
            .collect()
    }

    /// A plane's point and unit normal at ramp s (None for other shapes). The normal turns
    /// with the motion's rotation: n(s) = apply(s, p + n̂) − apply(s, p).
    pub fn plane_at(&self, s: f64) -> Option<(Vec3, Vec3)> {
        match &self.shape {
            Shape::Plane { point, normal } => {
                let n = normal.normalize();
                let p = self.motion.apply(s, point);
                Some((p, (self.motion.apply(s, &(point + n)) - p).normalize()))
            }
            _ => None,
        }
    }

    /// A sphere's center and radius at ramp s (None for other shapes).
    pub fn sphere_at(&self, s: f64) -> Option<(Vec3, f64)> {
        match &self.shape {
            Shape::Sphere { center, radius } => Some((self.motion.apply(s, center), *radius)),
            _ => None,
        }
    }
}

/// The 12 triangles of an axis-aligned box, each oriented so its normal points out of the box.
fn box_surface(min: &Vec3, max: &Vec3) -> TriangleSurface {
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        })
        .collect();
    let center = 0.5 * (min + max);
    // Each side: the 4 corners with bit `axis` equal to `side`, in cyclic order.
    let mut faces = Vec::with_capacity(12);
    for axis in 0..3 {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in 0..2 {
            let corner = |i: usize, j: usize| (side << axis) | (i << a) | (j << b);
            let quad = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
            for tri in [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]] {
                let x = tri.map(|v| positions[v]);
                let n = (x[1] - x[0]).cross(&(x[2] - x[0]));
                faces.push(if n.dot(&(x[0] - center)) > 0.0 {
                    tri
                } else {
                    [tri[0], tri[2], tri[1]]
                });
            }
        }
    }
    TriangleSurface { positions, faces }
}

/// The triangle surface of a file, by extension: a surface file (`.obj`, `.stl`, `.ply`, read
/// by [`crate::io::read_surface`]), or else the outward boundary of the tet mesh
/// [`crate::io::read_mesh`] reads (only the boundary's vertices are kept, renumbered in mesh
/// order). A tet mesh file without tets is refused by `read_mesh`.
pub fn read_surface(path: &Path) -> Result<TriangleSurface> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    match ext.as_str() {
        "obj" | "stl" | "ply" => crate::io::read_surface(path),
        _ => {
            let mesh = crate::io::read_mesh(path)?.mesh;
            let boundary = ContactSurface::from_mesh(&mesh);
            let mut index = vec![usize::MAX; mesh.positions.len()];
            let mut positions = Vec::with_capacity(boundary.vertices.len());
            for (k, &v) in boundary.vertices.iter().enumerate() {
                index[v] = k;
                positions.push(mesh.positions[v]);
            }
            let faces = boundary.faces.iter().map(|f| f.map(|v| index[v])).collect();
            let surface = TriangleSurface { positions, faces };
            if surface.faces.is_empty() {
                return Err(Error::parse(
                    path,
                    None,
                    "the mesh has no boundary triangles",
                ));
            }
            Ok(surface)
        }
    }
}

#[cfg(test)]
mod tests;
