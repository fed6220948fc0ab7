//! Whether a state passes through an obstacle, another body or itself: the check that refuses an intersecting start.

use super::*;

impl ContactTerm {
    /// Why the bodies at x pass through an obstacle (naming the obstacle and a body vertex),
    /// each other or themselves (naming the bodies and an element of each), or None: a vertex on
    /// the wrong side of a plane or inside a sphere or box, a surface edge crossing an obstacle
    /// triangle, or a surface edge crossing a face of the mesh's surface it shares no vertex with
    /// (inside one body only with `self_contact`).
    pub fn intersection(&self, x: &[Vec3]) -> Option<String> {
        for (spec, placed) in self.setup.obstacles.iter().zip(&self.placed) {
            let inside = |v: usize| -> bool {
                let p = x[v];
                match &spec.obstacle.shape {
                    Shape::Plane { .. } => placed.plane.is_some_and(|(o, n)| {
                        crate::contact::distance::point_plane_gap(&p, &o, &n) <= 0.0
                    }),
                    Shape::Sphere { .. } => placed.sphere.is_some_and(|(c, r)| (p - c).norm() <= r),
                    Shape::Box { min, max } => (0..3).all(|k| p[k] > min[k] && p[k] < max[k]),
                    Shape::Mesh(_) => false,
                }
            };
            if let Some(&v) = self.surface.vertices.iter().find(|&&v| inside(v)) {
                return Some(format!(
                    "the initial state passes through {}: vertex {v} at ({:.4}, {:.4}, {:.4}) is inside it",
                    spec.name, x[v].x, x[v].y, x[v].z
                ));
            }
            if matches!(spec.obstacle.shape, Shape::Box { .. } | Shape::Mesh(_)) {
                let obstacle_surface = spec.obstacle.contact_surface();
                let y = &placed.positions;
                let body = self.surface.primitives(x, x);
                let other = obstacle_surface.primitives(y, y);
                let c = cross_candidates(&body, &other, 0.0);
                for &[ea, eb] in &c.edge_edge {
                    let [a0, a1] = self.surface.edges[ea];
                    let [b0, b1] = obstacle_surface.edges[eb];
                    let d = crate::contact::distance::edge_edge_distance(
                        &x[a0], &x[a1], &y[b0], &y[b1],
                    );
                    if d <= 0.0 {
                        return Some(format!(
                            "the initial state passes through {}: the surface edge of vertices {a0} and {a1} touches it",
                            spec.name
                        ));
                    }
                }
                for &[v, f] in &c.point_triangle {
                    let v = self.surface.vertices[v];
                    let [a, b, cc] = obstacle_surface.faces[f].map(|i| y[i]);
                    if crate::contact::distance::point_triangle_distance(&x[v], &a, &b, &cc) <= 0.0
                    {
                        return Some(format!(
                            "the initial state passes through {}: vertex {v} lies on it",
                            spec.name
                        ));
                    }
                }
            }
        }
        self.body_intersection(x)
    }
}
