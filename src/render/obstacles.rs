//! Obstacles in the pictures: a ground plane becomes the floor (at its place, in its
//! orientation), every other obstacle a shaded surface.

use super::Plane;
use super::camera::{Bounds, Camera};
use crate::math::Vec3;

/// The plane that cuts away the near half of the obstacles when they surround the body (its
/// centre lies inside their bounding box, as a ball in a bowl does), so that the body shows:
/// upright (perpendicular to the floor), through the body's centre, facing the camera. The
/// normal points to the removed side, towards the camera. None when nothing surrounds the body.
pub(crate) fn cut_plane(body: &[Vec3], obstacles: &[[Vec3; 3]], camera: &Camera) -> Option<Plane> {
    if obstacles.is_empty() {
        return None;
    }
    let centre = Bounds::of(body).center();
    let mut around = Bounds::empty();
    for t in obstacles {
        around.include(t);
    }
    let inside = (0..3).all(|i| around.min[i] <= centre[i] && centre[i] <= around.max[i]);
    if !inside || !centre.iter().all(|c| c.is_finite()) {
        return None;
    }
    let back = -camera.forward;
    let level = back - camera.world_up * back.dot(&camera.world_up);
    let normal = level.try_normalize(1e-6).unwrap_or(back);
    Some(Plane::new(centre, normal))
}

/// Obstacle triangles of one frame, split for drawing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObstacleView {
    /// Triangles of every obstacle but the ground (m).
    pub triangles: Vec<[Vec3; 3]>,
    /// The ground plane, normal to the free side, if a plane obstacle can be the floor.
    pub ground: Option<Plane>,
}

impl ObstacleView {
    /// Split an obstacle surface (as in `obstacles_NNNN.vtu`: points, triangles, the obstacle
    /// index and whether it is a plane, per triangle): the plane whose normal is closest to
    /// `up` (within 60°, see [`super::ground_plane`]) becomes the ground, the rest triangles.
    pub fn new(
        points: &[Vec3],
        triangles: &[[usize; 3]],
        obstacle: &[usize],
        is_plane: &[bool],
        up: Vec3,
    ) -> ObstacleView {
        let corners = |t: &[usize; 3]| t.map(|v| points[v]);
        // Each plane obstacle's first triangle gives its point and free-side normal.
        let mut planes: Vec<(usize, Plane)> = Vec::new();
        for (k, t) in triangles.iter().enumerate() {
            if is_plane[k] && planes.last().is_none_or(|p| p.0 != obstacle[k]) {
                let p = corners(t);
                planes.push((
                    obstacle[k],
                    Plane::new(p[0], (p[1] - p[0]).cross(&(p[2] - p[0]))),
                ));
            }
        }
        let list: Vec<Plane> = planes.iter().map(|p| p.1).collect();
        let ground = super::ground_plane(&list, up).map(|i| planes[i]);
        ObstacleView {
            triangles: triangles
                .iter()
                .enumerate()
                .filter(|&(k, _)| ground.is_none_or(|g| !is_plane[k] || obstacle[k] != g.0))
                .map(|(_, t)| corners(t))
                .collect(),
            ground: ground.map(|g| g.1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_upward_plane_is_the_ground_and_a_wall_stays_a_surface() {
        let points = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        // Obstacle 0: a wall (normal +x), obstacle 1: the floor (normal +y).
        let triangles = [[0, 3, 1], [0, 1, 2]];
        let view = ObstacleView::new(&points, &triangles, &[0, 1], &[true, true], Vec3::y());
        let ground = view.ground.unwrap();
        assert!(ground.normal.normalize().dot(&Vec3::y()) > 0.99);
        assert_eq!(view.triangles.len(), 1);
        let none = ObstacleView::new(&points, &triangles[..1], &[0], &[true], Vec3::y());
        assert!(none.ground.is_none());
    }
}
