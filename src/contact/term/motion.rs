//! Where the obstacles stand during a step, how a moving obstacle carries the body's surface, and
//! the conservative time of impact the line search and the pushes are limited by.

use super::*;
use crate::contact::distance::{edge_edge_distance, point_triangle_distance};

/// Solves a step may take while moving obstacles push the body out of their way.
pub const MAX_OBSTACLE_PUSHES: usize = 64;

impl ContactTerm {
    /// A step's start (see [`Term::begin_step`]): moving obstacles placed at the step's start
    /// and end, and the guess no further than CCD finds free, carried along by moving obstacles.
    pub(super) fn start_step(&mut self, start: &StepStart<'_>, guess: &mut [Vec3]) {
        self.pushes = 0;
        self.begin_step(start.xn, start.h, start.ramp_start, start.ramp_end);
        self.prepare_guess(start.xn, guess, start.free);
    }

    /// After a converged solve (see [`Term::continue_step`]): moving obstacles go as far as
    /// they can without passing through the body, Newton moves the body out of their way, and
    /// so on until they arrive; an obstacle that cannot get through within
    /// [`MAX_OBSTACLE_PUSHES`] solves (or stops moving) ends the step.
    pub(super) fn push_obstacles(&mut self, x: &[Vec3]) -> Result<bool, String> {
        if self.obstacles_arrived() {
            return Ok(false);
        }
        self.pushes += 1;
        let moved = self.advance_obstacles(x);
        if self.pushes > MAX_OBSTACLE_PUSHES || (moved < 1e-6 && self.pushes > 1) {
            let name = self.blocking_obstacle().unwrap_or("a moving obstacle");
            return Err(format!(
                "{name} could not push the body out of its way within \
                 {MAX_OBSTACLE_PUSHES} solves"
            ));
        }
        Ok(true)
    }

    /// Put every moving obstacle where `ramp` (the ramp factor of a motion of the given
    /// duration) puts it: where the run starts, for the check of the initial state.
    pub fn place_obstacles(&mut self, ramp: impl Fn(Option<f64>) -> f64) {
        self.place(ramp);
    }

    pub(super) fn place(&mut self, ramp: impl Fn(Option<f64>) -> f64) {
        // A still obstacle stays at ramp 0: it never has anywhere to go.
        let ramps: Vec<f64> = self
            .setup
            .obstacles
            .iter()
            .map(|o| {
                let still = o.obstacle.motion.translate == Vec3::zeros()
                    && o.obstacle.motion.rotate_degrees == 0.0;
                if still { 0.0 } else { ramp(o.duration) }
            })
            .collect();
        self.place_at(&ramps);
    }

    /// Put every obstacle at its ramp factor.
    pub(super) fn place_at(&mut self, ramps: &[f64]) {
        self.placed = self
            .setup
            .obstacles
            .iter()
            .zip(ramps)
            .map(|(spec, &s)| Placed {
                positions: spec.obstacle.positions_at(s),
                plane: spec.obstacle.plane_at(s),
                sphere: spec.obstacle.sphere_at(s),
            })
            .collect();
        self.ramp_now = ramps.to_vec();
    }

    /// The step's first guess: x (the predictor, moving from `xn`) cut back to what CCD finds
    /// free of the obstacles where they stand, then the body's surface vertices that a moving
    /// obstacle sweeps over this step carried along with it (their place relative to the
    /// obstacle kept, for the free components), and the obstacles moved to where the step
    /// ends. Rigid motions keep a carried vertex's gap, so the guess is feasible and Newton's
    /// iterates never pass through; should the carried guess still touch an obstacle, the
    /// obstacles stay where they stand and [`ContactTerm::advance_obstacles`] brings them on.
    pub fn prepare_guess(&mut self, xn: &[Vec3], x: &mut [Vec3], free: &[Vec3]) {
        let dx: Vec<Vec3> = x.iter().zip(xn).map(|(x, xn)| x - xn).collect();
        let t = ContactTerm::max_step(self, xn, &dx);
        if t < 1.0 {
            // Prescribed components keep their prescribed values.
            for (((x, xn), dx), m) in x.iter_mut().zip(xn).zip(&dx).zip(free) {
                *x += (xn + t * dx - *x).component_mul(m);
            }
        }
        if self.obstacles_arrived() {
            return;
        }
        let before = x.to_vec();
        let start = std::mem::take(&mut self.placed);
        let start_ramps = self.ramp_now.clone();
        let target = self.ramp_target.clone();
        self.place_at(&target);
        let params = CcdParams::default();
        for (o, spec) in self.setup.obstacles.iter().enumerate() {
            let (s0, s1) = (start_ramps[o], target[o]);
            if s0 == s1 {
                continue;
            }
            let (a, b) = (&start[o], &self.placed[o]);
            let swept: Vec<usize> =
                match (&spec.obstacle.shape, a.plane, b.plane, a.sphere, b.sphere) {
                    (Shape::Plane { .. }, Some((o0, n)), Some((o1, _)), _, _) => self
                        .surface
                        .vertices
                        .iter()
                        .copied()
                        .filter(|&v| {
                            point_plane_ccd(&before[v], &before[v], &o0, &o1, &n, &params) < 1.0
                        })
                        .collect(),
                    (Shape::Sphere { .. }, _, _, Some((c0, r)), Some((c1, _))) => self
                        .surface
                        .vertices
                        .iter()
                        .copied()
                        .filter(|&v| {
                            let p = [before[v]; 3];
                            sphere_triangle_ccd(&c0, &c1, r, &p, &p, &params) < 1.0
                        })
                        .collect(),
                    _ => {
                        let os = spec.obstacle.contact_surface();
                        let (y0, y1) = (&a.positions, &b.positions);
                        let body = self.surface.primitives(&before, &before);
                        let c = cross_candidates(&body, &os.primitives(y0, y1), self.dhat.sqrt());
                        let mut swept: Vec<usize> = c
                            .point_triangle
                            .iter()
                            .filter(|&&[v, f]| {
                                let p = before[self.surface.vertices[v]];
                                let (s, e) =
                                    (os.faces[f].map(|i| y0[i]), os.faces[f].map(|i| y1[i]));
                                point_triangle_ccd(
                                    &[p, s[0], s[1], s[2]],
                                    &[p, e[0], e[1], e[2]],
                                    &params,
                                ) < 1.0
                            })
                            .map(|&[v, _]| self.surface.vertices[v])
                            .collect();
                        swept.dedup();
                        swept
                    }
                };
            let motion = &spec.obstacle.motion;
            for v in swept {
                let carried = motion.apply(s1, &motion.unapply(s0, &before[v]));
                x[v] += (carried - before[v]).component_mul(&free[v]);
            }
        }
        if self.intersection(x).is_some() {
            x.copy_from_slice(&before);
            self.placed = start;
            self.ramp_now = start_ramps;
        }
    }

    /// The obstacle that held up the last push ([`ContactTerm::advance_obstacles`]), by name.
    pub fn blocking_obstacle(&self) -> Option<&str> {
        self.blocker.map(|o| self.setup.obstacles[o].name.as_str())
    }

    /// Whether every obstacle is where the step ends.
    pub fn obstacles_arrived(&self) -> bool {
        self.ramp_now == self.ramp_target
    }

    /// Move the obstacles from where they are towards where the step ends, as far as continuous
    /// collision detection against the body at x (held still) allows, and return the fraction
    /// of the remaining move made. A moving obstacle pushes the body this way: Newton solves
    /// with the obstacles part of the way, the barrier moves the body out of their path, and the
    /// next call moves them on (IPC's kinematic obstacles without a penalty on their DOFs).
    pub fn advance_obstacles(&mut self, x: &[Vec3]) -> f64 {
        if self.obstacles_arrived() {
            return 1.0;
        }
        let from = std::mem::take(&mut self.placed);
        let from_ramps = self.ramp_now.clone();
        let target = self.ramp_target.clone();
        self.place_at(&target);
        let times: Vec<f64> = self
            .setup
            .obstacles
            .iter()
            .zip(&from)
            .zip(&self.placed)
            .enumerate()
            .map(|(o, ((spec, a), b))| {
                let shape = &spec.obstacle.shape;
                if spec.obstacle.motion.rotate_degrees != 0.0 && from_ramps[o] != target[o] {
                    return rotating_time_of_impact(
                        &self.surface,
                        x,
                        &spec.obstacle,
                        (from_ramps[o], target[o]),
                        self.dhat.sqrt(),
                    );
                }
                time_of_impact(
                    &self.surface,
                    x,
                    x,
                    shape,
                    spec.obstacle.contact_surface(),
                    a,
                    b,
                )
            })
            .collect();
        let t = times.iter().copied().fold(1.0, f64::min);
        self.blocker = times.iter().position(|&ti| ti == t && t < 1.0);
        if t < 1.0 {
            let ramps: Vec<f64> = from_ramps
                .iter()
                .zip(&target)
                .map(|(a, b)| a + t * (b - a))
                .collect();
            self.place_at(&ramps);
        }
        t
    }
}

/// The conservative time of impact (0..=1) of the body's surface moving from `x0` to `x1`
/// against one obstacle moving from `from` to `to` (planes and spheres may only translate
/// within a step), by additive CCD over every vertex (planes), face (spheres) or broad-phase
/// pair (boxes and meshes: point–triangle both ways and edge–edge).
pub(super) fn time_of_impact(
    surface: &ContactSurface,
    x0: &[Vec3],
    x1: &[Vec3],
    shape: &Shape,
    obstacle: &ContactSurface,
    from: &Placed,
    to: &Placed,
) -> f64 {
    let params = CcdParams::default();
    match (shape, from.plane, to.plane, from.sphere, to.sphere) {
        (Shape::Plane { .. }, Some((o0, n)), Some((o1, _)), _, _) => surface
            .vertices
            .par_iter()
            .map(|&v| point_plane_ccd(&x0[v], &x1[v], &o0, &o1, &n, &params))
            .reduce(|| 1.0, f64::min),
        (Shape::Sphere { .. }, _, _, Some((c0, r)), Some((c1, _))) => surface
            .faces
            .par_iter()
            .map(|f| {
                sphere_triangle_ccd(&c0, &c1, r, &f.map(|v| x0[v]), &f.map(|v| x1[v]), &params)
            })
            .reduce(|| 1.0, f64::min),
        _ => {
            let (y0, y1) = (&from.positions, &to.positions);
            let c = cross_candidates(
                &surface.primitives(x0, x1),
                &obstacle.primitives(y0, y1),
                0.0,
            );
            let pt = c.point_triangle.par_iter().map(|&[v, f]| {
                let v = surface.vertices[v];
                let (s, e) = (
                    obstacle.faces[f].map(|i| y0[i]),
                    obstacle.faces[f].map(|i| y1[i]),
                );
                point_triangle_ccd(
                    &[x0[v], s[0], s[1], s[2]],
                    &[x1[v], e[0], e[1], e[2]],
                    &params,
                )
            });
            let tp = c.triangle_point.par_iter().map(|&[f, v]| {
                let i = obstacle.vertices[v];
                let face = surface.faces[f];
                let (s, e) = (face.map(|k| x0[k]), face.map(|k| x1[k]));
                point_triangle_ccd(
                    &[y0[i], s[0], s[1], s[2]],
                    &[y1[i], e[0], e[1], e[2]],
                    &params,
                )
            });
            let ee = c.edge_edge.par_iter().map(|&[ea, eb]| {
                let [a0, a1] = surface.edges[ea];
                let [b0, b1] = obstacle.edges[eb];
                edge_edge_ccd(
                    &[x0[a0], x0[a1], y0[b0], y0[b1]],
                    &[x1[a0], x1[a1], y1[b0], y1[b1]],
                    &params,
                )
            });
            pt.chain(tp).chain(ee).reduce(|| 1.0, f64::min)
        }
    }
}

/// The conservative time of impact (0..=1) of an obstacle that turns while it moves from ramp
/// `s0` to `s1`, against the body's surface held still at `x`. In the obstacle's own frame the
/// obstacle is still and each surface vertex travels on a curve q(s) = Rᵀ(s)(x − c − sT) + c.
/// The move is cut into pieces over which every curve stays within `tol` of its chord (the
/// chord error of a curve is at most |q″|·Δs²/8, and |q″| ≤ ω²(ρ + |T|) + 2ω|T| with ω the
/// angle of the whole ramp in radians and ρ the farthest vertex from c), and CCD keeps every
/// chord at least `tol` from the obstacle, so no curve reaches it: rotation is never treated
/// as a translation. `tol` is a hundredth of d̂ (`dhat_m`, unsquared) or half the smallest gap
/// at the start, whichever is smaller.
pub(super) fn rotating_time_of_impact(
    surface: &ContactSurface,
    x: &[Vec3],
    obstacle: &crate::contact::obstacle::Obstacle,
    (s0, s1): (f64, f64),
    dhat_m: f64,
) -> f64 {
    let motion = &obstacle.motion;
    let in_frame = |s: f64| -> Vec<Vec3> {
        let mut q = x.to_vec();
        for &v in &surface.vertices {
            q[v] = motion.unapply(s, &x[v]);
        }
        q
    };
    let rest = obstacle.contact_surface();
    let y = obstacle.positions_at(0.0);
    let plane = obstacle.plane_at(0.0);
    let sphere = obstacle.sphere_at(0.0);
    let gap_at = |q: &[Vec3]| -> f64 {
        match (&obstacle.shape, plane, sphere) {
            (Shape::Plane { .. }, Some((o, n)), _) => surface
                .vertices
                .par_iter()
                .map(|&v| n.dot(&(q[v] - o)))
                .reduce(|| f64::INFINITY, f64::min),
            (Shape::Sphere { .. }, _, Some((c, r))) => surface
                .vertices
                .par_iter()
                .map(|&v| (q[v] - c).norm() - r)
                .reduce(|| f64::INFINITY, f64::min),
            _ => {
                let c =
                    cross_candidates(&surface.primitives(q, q), &rest.primitives(&y, &y), dhat_m);
                let pt = c.point_triangle.iter().map(|&[v, f]| {
                    let [a, b, cc] = rest.faces[f].map(|i| y[i]);
                    point_triangle_distance(&q[surface.vertices[v]], &a, &b, &cc)
                });
                let tp = c.triangle_point.iter().map(|&[f, v]| {
                    let [a, b, cc] = surface.faces[f].map(|k| q[k]);
                    point_triangle_distance(&y[rest.vertices[v]], &a, &b, &cc)
                });
                let ee = c.edge_edge.iter().map(|&[ea, eb]| {
                    let ([a0, a1], [b0, b1]) = (surface.edges[ea], rest.edges[eb]);
                    edge_edge_distance(&q[a0], &q[a1], &y[b0], &y[b1])
                });
                pt.chain(tp)
                    .chain(ee)
                    .fold(dhat_m * dhat_m, f64::min)
                    .sqrt()
            }
        }
    };
    let g_start = gap_at(&in_frame(s0));
    if g_start.is_nan() || g_start <= 0.0 {
        return 0.0;
    }
    let tol = (0.01 * dhat_m).min(0.5 * g_start);
    let omega = motion.rotate_degrees.to_radians().abs();
    let t_norm = motion.translate.norm();
    let rho = surface
        .vertices
        .iter()
        .map(|&v| (x[v] - motion.center).norm())
        .fold(0.0, f64::max)
        + t_norm;
    let curvature = omega * omega * (rho + t_norm) + 2.0 * omega * t_norm;
    let span = (s1 - s0).abs();
    let pieces = ((span * (curvature / (8.0 * tol)).sqrt()).ceil() as usize).clamp(1, 10_000);
    let params = CcdParams {
        min_distance: tol,
        ..CcdParams::default()
    };
    let mut qa = in_frame(s0);
    for j in 0..pieces {
        let sb = s0 + (s1 - s0) * (j + 1) as f64 / pieces as f64;
        let qb = in_frame(sb);
        let t = match (&obstacle.shape, plane, sphere) {
            (Shape::Plane { .. }, Some((o, n)), _) => surface
                .vertices
                .par_iter()
                .map(|&v| point_plane_ccd(&qa[v], &qb[v], &o, &o, &n, &params))
                .reduce(|| 1.0, f64::min),
            (Shape::Sphere { .. }, _, Some((c, r))) => surface
                .faces
                .par_iter()
                .map(|f| {
                    sphere_triangle_ccd(&c, &c, r, &f.map(|v| qa[v]), &f.map(|v| qb[v]), &params)
                })
                .reduce(|| 1.0, f64::min),
            _ => {
                let c =
                    cross_candidates(&surface.primitives(&qa, &qb), &rest.primitives(&y, &y), tol);
                let pt = c.point_triangle.par_iter().map(|&[v, f]| {
                    let v = surface.vertices[v];
                    let face = rest.faces[f].map(|i| y[i]);
                    point_triangle_ccd(
                        &[qa[v], face[0], face[1], face[2]],
                        &[qb[v], face[0], face[1], face[2]],
                        &params,
                    )
                });
                let tp = c.triangle_point.par_iter().map(|&[f, v]| {
                    let p = y[rest.vertices[v]];
                    let face = surface.faces[f];
                    let (a, b) = (face.map(|k| qa[k]), face.map(|k| qb[k]));
                    point_triangle_ccd(&[p, a[0], a[1], a[2]], &[p, b[0], b[1], b[2]], &params)
                });
                let ee = c.edge_edge.par_iter().map(|&[ea, eb]| {
                    let ([a0, a1], [b0, b1]) = (surface.edges[ea], rest.edges[eb]);
                    edge_edge_ccd(
                        &[qa[a0], qa[a1], y[b0], y[b1]],
                        &[qb[a0], qb[a1], y[b0], y[b1]],
                        &params,
                    )
                });
                pt.chain(tp).chain(ee).reduce(|| 1.0, f64::min)
            }
        };
        if t < 1.0 {
            return (j as f64 + t) / pieces as f64;
        }
        qa = qb;
    }
    1.0
}
