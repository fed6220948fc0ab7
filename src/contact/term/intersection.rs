//! Whether a state passes through an obstacle, another body or itself: the check that refuses an
//! intersecting start, and the one every step's end must pass ([`ContactTerm::step_violation`]).

use super::*;
use crate::contact::broad::{Aabb, Bvh};
use crate::contact::distance::{segment_crosses_triangle, solid_angle};

impl ContactTerm {
    /// Why the bodies at x pass through an obstacle (naming the obstacle and a body vertex),
    /// each other or themselves (naming the bodies and an element of each), or None. Checked:
    /// every vertex of every body, interior ones included, against the half-space behind a
    /// plane, the inside of a sphere or a box (exactly, in the obstacle's own frame) and the
    /// inside of a closed mesh (by its winding number); every surface edge of a body crossing an
    /// obstacle triangle, and every obstacle edge crossing a body's surface face; and a surface
    /// edge crossing a face of the mesh's surface it shares no vertex with (inside one body only
    /// with `self_contact`). Messages start with "the initial state".
    pub fn intersection(&self, x: &[Vec3]) -> Option<String> {
        self.located_intersection(x).map(|(_, message)| message)
    }

    /// [`ContactTerm::intersection`] with the index of the obstacle passed through (None when
    /// bodies pass through each other or themselves).
    pub fn located_intersection(&self, x: &[Vec3]) -> Option<(Option<usize>, String)> {
        for (o, (spec, placed)) in self.setup.obstacles.iter().zip(&self.placed).enumerate() {
            if let Some(message) = self.obstacle_intersection(x, o, spec, placed) {
                return Some((Some(o), message));
            }
        }
        self.body_intersection(x).map(|message| (None, message))
    }

    /// Points of obstacle `o` where it stands (a sphere's centre, the vertices of a box or a
    /// mesh; none for a plane): an obstacle placed wholly inside a body crosses none of its
    /// faces, but these lie in its tets.
    pub fn obstacle_points(&self, o: usize) -> Vec<Vec3> {
        let placed = &self.placed[o];
        match placed.sphere {
            Some((c, _)) => vec![c],
            None => placed.positions.clone(),
        }
    }

    /// Why the end of a step, from x0 to x1 (the obstacles where the step ends), is not one a
    /// converged step may have: x1 passes through something ([`ContactTerm::intersection`]), or
    /// two body primitives pass through each other on the straight way from x0 to x1 (the
    /// frames a user sees are joined by straight lines: a body that went around another within
    /// one step, as two cubes thrown at each other with a large step did, lands on the far side
    /// of it).
    pub fn step_violation(&self, x0: &[Vec3], x1: &[Vec3]) -> Option<String> {
        if let Some(message) = self.intersection(x1) {
            return Some(message.replacen("the initial state", "the step's end", 1));
        }
        self.straight_path_crossing(x0, x1)
    }

    fn obstacle_intersection(
        &self,
        x: &[Vec3],
        o: usize,
        spec: &crate::contact::ObstacleSpec,
        placed: &Placed,
    ) -> Option<String> {
        let obstacle = &spec.obstacle;
        let ramp = self.ramp_now.get(o).copied().unwrap_or(0.0);
        let closed =
            matches!(obstacle.shape, Shape::Mesh(_)) && is_closed(obstacle.contact_surface());
        let bounds = Aabb::from_points(placed.positions.iter());
        let inside = |p: &Vec3| -> bool {
            match &obstacle.shape {
                Shape::Plane { .. } => placed.plane.is_some_and(|(o, n)| {
                    crate::contact::distance::point_plane_gap(p, &o, &n) <= 0.0
                }),
                Shape::Sphere { .. } => placed.sphere.is_some_and(|(c, r)| (p - c).norm() <= r),
                Shape::Box { min, max } => {
                    let q = obstacle.motion.unapply(ramp, p);
                    (0..3).all(|k| q[k] > min[k] && q[k] < max[k])
                }
                Shape::Mesh(_) => {
                    closed
                        && bounds.overlaps(&Aabb::from_points([p]))
                        && winding_number(p, obstacle.contact_surface(), &placed.positions).abs()
                            > 0.5
                }
            }
        };
        if let Some(v) = (0..x.len()).into_par_iter().find_first(|&v| inside(&x[v])) {
            return Some(format!(
                "the initial state passes through {}: vertex {v} at ({:.4}, {:.4}, {:.4}) is inside it",
                spec.name, x[v].x, x[v].y, x[v].z
            ));
        }
        if !matches!(obstacle.shape, Shape::Box { .. } | Shape::Mesh(_)) {
            return None;
        }
        let other = obstacle.contact_surface();
        let y = &placed.positions;
        let body = self.surface.primitives(x, x);
        // Every surface edge of the body against the obstacle's triangles near it, and every
        // obstacle edge against the body's surface faces near it.
        let obstacle_faces = Bvh::build(&other.primitives(y, y).face_boxes(0.0));
        let crossing = (0..self.surface.edges.len())
            .into_par_iter()
            .find_first(|&e| {
                let [a, b] = self.surface.edges[e];
                let mut hits = Vec::new();
                obstacle_faces.query(&Aabb::from_points([&x[a], &x[b]]), &mut hits);
                hits.iter().any(|&f| {
                    let [p, q, r] = other.faces[f].map(|i| y[i]);
                    segment_crosses_triangle(&x[a], &x[b], &p, &q, &r)
                })
            });
        if let Some(e) = crossing {
            let [a, b] = self.surface.edges[e];
            return Some(format!(
                "the initial state passes through {}: the surface edge of vertices {a} and {b} \
                 crosses it",
                spec.name
            ));
        }
        let mut hits = Vec::new();
        let body_faces = Bvh::build(&body.face_boxes(0.0));
        for [p, q] in &other.edges {
            hits.clear();
            body_faces.query(&Aabb::from_points([&y[*p], &y[*q]]), &mut hits);
            hits.sort_unstable();
            if let Some(&f) = hits.iter().find(|&&f| {
                let [a, b, cc] = self.surface.faces[f].map(|v| x[v]);
                segment_crosses_triangle(&y[*p], &y[*q], &a, &b, &cc)
            }) {
                let v = self.surface.faces[f][0];
                return Some(format!(
                    "the initial state passes through {}: one of its edges crosses the body's surface face of vertices {}, {} and {} (vertex {v})",
                    spec.name,
                    self.surface.faces[f][0],
                    self.surface.faces[f][1],
                    self.surface.faces[f][2]
                ));
            }
        }
        let c = cross_candidates(&body, &other.primitives(y, y), 0.0);
        for &[v, f] in &c.point_triangle {
            let v = self.surface.vertices[v];
            let [a, b, cc] = other.faces[f].map(|i| y[i]);
            if crate::contact::distance::point_triangle_distance(&x[v], &a, &b, &cc) <= 0.0 {
                return Some(format!(
                    "the initial state passes through {}: vertex {v} lies on it",
                    spec.name
                ));
            }
        }
        None
    }

    /// Two body primitives (between bodies, or inside one with `self_contact`) that meet on the
    /// straight way from x0 to x1: additive CCD restarted from where it stops until it reaches
    /// x1 (free) or the gap falls below a millionth of the smaller end gap (they meet).
    fn straight_path_crossing(&self, x0: &[Vec3], x1: &[Vec3]) -> Option<String> {
        if !self.body_pairs {
            return None;
        }
        let params = CcdParams::default();
        let candidates = self.search_body_candidates(x0, x1, 0.0);
        let crossing = candidates.par_iter().find_first(|c| {
            let (s, e) = (c.vertices.map(|v| x0[v]), c.vertices.map(|v| x1[v]));
            let distance = |p: &[Vec3; 4]| {
                if c.is_edge_edge() {
                    crate::contact::distance::edge_edge_distance(&p[0], &p[1], &p[2], &p[3])
                } else {
                    crate::contact::distance::point_triangle_distance(&p[0], &p[1], &p[2], &p[3])
                }
            };
            let floor = 1e-12 * distance(&s).min(distance(&e));
            let mut t = 0.0;
            for _ in 0..200 {
                let at: [Vec3; 4] = std::array::from_fn(|k| s[k] + t * (e[k] - s[k]));
                if distance(&at) <= floor {
                    return true;
                }
                let tau = if c.is_edge_edge() {
                    edge_edge_ccd(&at, &e, &params)
                } else {
                    point_triangle_ccd(&at, &e, &params)
                };
                if tau >= 1.0 {
                    return false;
                }
                t += tau * (1.0 - t);
            }
            // Still closing in after 200 restarts: the gap shrank a hundredfold 200 times.
            true
        });
        crossing.map(|c| {
            let (a, b) = (c.vertices[0], c.vertices[c.split]);
            self.pass_through(
                a,
                &format!("its surface vertex {a}"),
                b,
                &format!("the surface element of vertex {b}"),
                "meets",
            )
            .replacen(
                "the initial state",
                "the straight way from the step's start to its end",
                1,
            )
        })
    }
}

/// Whether every edge of a triangle surface has exactly two faces (a closed surface, whose
/// winding number tells inside from outside).
fn is_closed(surface: &ContactSurface) -> bool {
    let mut count = std::collections::HashMap::new();
    for f in &surface.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0u32) += 1;
        }
    }
    !count.is_empty() && count.values().all(|&n| n == 2)
}

/// The winding number of a closed triangle surface (at `y`) about p: ±1 inside, 0 outside.
fn winding_number(p: &Vec3, surface: &ContactSurface, y: &[Vec3]) -> f64 {
    surface
        .faces
        .iter()
        .map(|f| solid_angle(p, &y[f[0]], &y[f[1]], &y[f[2]]))
        .sum::<f64>()
        / (4.0 * std::f64::consts::PI)
}
