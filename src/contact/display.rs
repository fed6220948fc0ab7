//! The obstacles as triangles to look at (`obstacles_NNNN.vtu`, the pictures): boxes and meshes
//! as their own triangles, a sphere as a subdivided icosahedron with its vertices on the sphere,
//! and a plane as a finite square 4× the scene's bounding-box diagonal wide, centred at the
//! foot of the scene's centre on the plane. Contact never uses these (planes and spheres stay
//! analytic there).
//!
//! Each shape is triangulated once at rest ([`DisplaySurface::new`]) and moved rigidly by its
//! obstacle's motion ([`DisplaySurface::positions_at`]), so a moving plane's square moves with
//! it instead of sliding to stay under the scene.

use super::obstacle::{Obstacle, Shape};
use super::setup::ContactSetup;
use crate::math::Vec3;
use crate::mesh::bounding_box;

/// Icosahedron subdivisions of a sphere: 2 gives 320 triangles (vertices 19° apart).
const SPHERE_SUBDIVISIONS: usize = 2;

/// A plane is drawn this many times the scene's bounding-box diagonal wide.
const PLANE_WIDTH_IN_DIAGONALS: f64 = 4.0;

/// Every obstacle of a setup as one triangle surface at rest, each triangle tagged with its
/// obstacle's index.
#[derive(Clone, Debug, PartialEq)]
pub struct DisplaySurface {
    /// Rest positions, obstacle after obstacle.
    pub positions: Vec<Vec3>,
    /// Triangles into `positions`, normals towards the free side.
    pub triangles: Vec<[usize; 3]>,
    /// The obstacle index of each triangle.
    pub obstacle: Vec<usize>,
    /// The shape of each triangle's obstacle: [`shape_code`].
    pub shape: Vec<f64>,
    /// Which obstacle each position belongs to.
    vertex_obstacle: Vec<usize>,
}

impl DisplaySurface {
    /// Triangulate `setup`'s obstacles at rest; `scene_box` (the bodies' and finite obstacles'
    /// bounding box, see [`scene_box`]) sizes and places the planes.
    pub fn new(setup: &ContactSetup, scene_box: (Vec3, Vec3)) -> Self {
        let mut out = DisplaySurface {
            positions: Vec::new(),
            triangles: Vec::new(),
            obstacle: Vec::new(),
            shape: Vec::new(),
            vertex_obstacle: Vec::new(),
        };
        for (k, spec) in setup.obstacles.iter().enumerate() {
            let (positions, triangles) = rest_triangles(&spec.obstacle, scene_box);
            let base = out.positions.len();
            out.positions.extend(positions.iter().copied());
            out.vertex_obstacle.extend(positions.iter().map(|_| k));
            out.triangles
                .extend(triangles.iter().map(|t| t.map(|v| v + base)));
            out.obstacle.extend(triangles.iter().map(|_| k));
            let code = shape_code(&spec.obstacle.shape);
            out.shape.extend(triangles.iter().map(|_| code));
        }
        out
    }

    /// The positions with obstacle k moved to its ramp `ramps[k]`.
    pub fn positions_at(&self, setup: &ContactSetup, ramps: &[f64]) -> Vec<Vec3> {
        self.positions
            .iter()
            .zip(&self.vertex_obstacle)
            .map(|(x, &k)| setup.obstacles[k].obstacle.motion.apply(ramps[k], x))
            .collect()
    }
}

/// The `shape` cell data of `obstacles_NNNN.vtu`: 0 plane, 1 box, 2 sphere, 3 mesh (so that
/// `tetsim render` finds the ground plane again).
pub fn shape_code(shape: &Shape) -> f64 {
    match shape {
        Shape::Plane { .. } => 0.0,
        Shape::Box { .. } => 1.0,
        Shape::Sphere { .. } => 2.0,
        Shape::Mesh(_) => 3.0,
    }
}

/// True when an obstacle's motion moves it at all (a non-zero translation or rotation).
pub fn moves(obstacle: &Obstacle) -> bool {
    let m = &obstacle.motion;
    m.translate != Vec3::zeros() || (m.rotate_degrees != 0.0 && m.axis != Vec3::zeros())
}

/// The scene's bounding box at rest: `body` points and the finite obstacles (boxes, spheres,
/// meshes; planes are infinite).
pub fn scene_box(body: &[Vec3], setup: &ContactSetup) -> (Vec3, Vec3) {
    let mut points = body.to_vec();
    for spec in &setup.obstacles {
        let o = &spec.obstacle;
        points.extend(o.triangles().positions.iter().copied());
        if let Some((c, r)) = o.sphere_at(0.0) {
            points.extend([c - Vec3::repeat(r), c + Vec3::repeat(r)]);
        }
    }
    bounding_box(&points)
}

fn rest_triangles(obstacle: &Obstacle, (lo, hi): (Vec3, Vec3)) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    match &obstacle.shape {
        Shape::Plane { point, normal } => {
            let n = normal.normalize();
            let center = 0.5 * (lo + hi);
            let foot = center - (center - point).dot(&n) * n;
            // The axis least aligned with n gives a well-conditioned tangent.
            let k = n.iamin();
            let u = n.cross(&Vec3::ith(k, 1.0)).normalize();
            let v = n.cross(&u);
            let diagonal = (hi - lo).norm();
            let half = 0.5 * PLANE_WIDTH_IN_DIAGONALS * if diagonal > 0.0 { diagonal } else { 1.0 };
            let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .map(|(a, b)| foot + half * (a * u + b * v));
            // u × v = n: counter-clockwise about n, so the normal points to the free side.
            (corners.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
        }
        Shape::Sphere { center, radius } => {
            let (unit, triangles) = crate::mesh::generate::icosphere(SPHERE_SUBDIVISIONS);
            let positions = unit.iter().map(|p| center + *radius * p).collect();
            (positions, triangles)
        }
        Shape::Box { .. } | Shape::Mesh(_) => {
            let t = obstacle.triangles();
            (t.positions.clone(), t.faces.clone())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary::Motion;
    use crate::contact::ObstacleSpec;

    fn setup(shapes: Vec<(Shape, Motion)>) -> ContactSetup {
        ContactSetup {
            obstacles: shapes
                .into_iter()
                .map(|(shape, motion)| ObstacleSpec {
                    name: "o".into(),
                    obstacle: Obstacle::new(shape, motion).unwrap(),
                    friction: None,
                    duration: None,
                })
                .collect(),
            ..Default::default()
        }
    }

    #[test]
    fn sphere_vertices_lie_on_the_sphere_and_triangles_face_out() {
        let center = Vec3::new(1.0, 2.0, 3.0);
        let s = setup(vec![(
            Shape::Sphere {
                center,
                radius: 0.5,
            },
            Motion::default(),
        )]);
        let d = DisplaySurface::new(&s, (Vec3::zeros(), Vec3::repeat(1.0)));
        assert_eq!(d.triangles.len(), 320);
        assert_eq!(d.positions.len(), 162);
        for p in &d.positions {
            assert!(((p - center).norm() - 0.5).abs() < 1e-14);
        }
        for t in &d.triangles {
            let x = t.map(|v| d.positions[v]);
            let n = (x[1] - x[0]).cross(&(x[2] - x[0]));
            assert!(n.dot(&(x[0] - center)) > 0.0);
        }
    }

    #[test]
    fn a_plane_is_a_square_under_the_scene_centre_facing_the_free_side() {
        let s = setup(vec![(
            Shape::Plane {
                point: Vec3::new(0.0, -1.0, 0.0),
                normal: Vec3::new(0.0, 3.0, 0.0),
            },
            Motion {
                translate: Vec3::new(0.0, -0.5, 0.0),
                ..Default::default()
            },
        )]);
        let scene = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(4.0, 1.0, 1.0));
        let d = DisplaySurface::new(&s, scene);
        let diagonal = 18f64.sqrt();
        let center: Vec3 = d.positions.iter().sum::<Vec3>() / 4.0;
        assert!((center - Vec3::new(2.0, -1.0, 0.5)).norm() < 1e-12);
        let side = (d.positions[1] - d.positions[0]).norm();
        assert!((side - 4.0 * diagonal).abs() < 1e-12);
        for t in &d.triangles {
            let x = t.map(|v| d.positions[v]);
            assert!((x[1] - x[0]).cross(&(x[2] - x[0])).y > 0.0);
        }
        assert!(moves(&s.obstacles[0].obstacle));
        let moved = d.positions_at(&s, &[1.0]);
        assert!(moved.iter().all(|p| (p.y + 1.5).abs() < 1e-12));
    }

    #[test]
    fn boxes_keep_their_triangles_and_still_obstacles_do_not_move() {
        let s = setup(vec![(
            Shape::Box {
                min: Vec3::zeros(),
                max: Vec3::repeat(1.0),
            },
            Motion::default(),
        )]);
        let d = DisplaySurface::new(&s, scene_box(&[], &s));
        assert_eq!((d.positions.len(), d.triangles.len()), (8, 12));
        assert!(!moves(&s.obstacles[0].obstacle));
        assert_eq!(scene_box(&[], &s), (Vec3::zeros(), Vec3::repeat(1.0)));
    }
}
