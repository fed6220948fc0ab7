//! The contact term's lagged friction: the pairs at the start of a step, their frames and normal
//! forces, and the friction potential's pairs at x (see [`crate::contact::friction`]).

use super::*;

/// One pair's lagged friction: slots of body vertices (Some) or obstacle points (None, moving by
/// `moved` over the step).
#[derive(Clone, Debug)]
pub(super) struct FrictionLag {
    pair: FrictionPair<12>,
    slots: [Option<usize>; 4],
    moved: [Vec3; 4],
}

impl FrictionLag {
    /// A pair between body primitives: every slot a body vertex.
    pub(super) fn between_bodies(pair: FrictionPair<12>, c: super::bodies::BodyPair) -> Self {
        FrictionLag {
            pair,
            slots: c.vertices.map(Some),
            moved: [Vec3::zeros(); 4],
        }
    }
}

impl ContactTerm {
    /// The friction pairs at `xn` against the obstacles as they were (`start`), with each
    /// obstacle point's move to where it is now.
    pub(super) fn lag_friction(&mut self, xn: &[Vec3], start: &[Placed]) {
        self.friction.clear();
        let dhat = self.dhat;
        let surface = &self.surface;
        for (o, spec) in self.setup.obstacles.iter().enumerate() {
            let mu = spec.friction.unwrap_or(self.setup.params.friction);
            if mu <= 0.0 {
                continue;
            }
            let (then, now) = (&start[o], &self.placed[o]);
            let lag = |d: f64, frame: TangentFrame<12>, slots, moved| FrictionLag {
                pair: FrictionPair {
                    frame,
                    mu,
                    normal_force: normal_force_magnitude(d, dhat, self.kappa),
                },
                slots,
                moved,
            };
            match (&spec.obstacle.shape, then.plane, then.sphere) {
                (Shape::Plane { .. }, Some((origin, normal)), _) => {
                    let shift = now.plane.map_or(Vec3::zeros(), |(o1, _)| o1 - origin);
                    for &v in &surface.vertices {
                        let g = crate::contact::distance::point_plane_gap(&xn[v], &origin, &normal);
                        if g > 0.0 && g * g < dhat {
                            let frame = TangentFrame {
                                basis: plane_basis(&normal),
                                coefficients: [1.0, -1.0, 0.0, 0.0],
                            };
                            let moved = [Vec3::zeros(), shift, Vec3::zeros(), Vec3::zeros()];
                            self.friction.push(lag(
                                g * g,
                                frame,
                                [Some(v), None, None, None],
                                moved,
                            ));
                        }
                    }
                }
                (Shape::Sphere { .. }, _, Some((center, radius))) => {
                    let shift = now.sphere.map_or(Vec3::zeros(), |(c1, _)| c1 - center);
                    for f in &surface.faces {
                        let [a, b, c] = f.map(|v| xn[v]);
                        let g = crate::contact::distance::sphere_triangle_gap(
                            &center, radius, &a, &b, &c,
                        );
                        if g > 0.0 && g * g < dhat {
                            let frame = point_triangle_frame(&center, &a, &b, &c);
                            let moved = [shift, Vec3::zeros(), Vec3::zeros(), Vec3::zeros()];
                            let slots = [None, Some(f[0]), Some(f[1]), Some(f[2])];
                            self.friction.push(lag(g * g, frame, slots, moved));
                        }
                    }
                }
                _ => {
                    let os = spec.obstacle.contact_surface();
                    let (y, y1) = (&then.positions, &now.positions);
                    let body = surface.primitives(xn, xn);
                    let c = cross_candidates(&body, &os.primitives(y, y), dhat.sqrt());
                    for &[v, f] in &c.point_triangle {
                        let v = surface.vertices[v];
                        let face = os.faces[f];
                        let [a, b, cc] = face.map(|i| y[i]);
                        let d =
                            crate::contact::distance::point_triangle_distance(&xn[v], &a, &b, &cc);
                        if d > 0.0 && d < dhat {
                            let moved = [
                                Vec3::zeros(),
                                y1[face[0]] - a,
                                y1[face[1]] - b,
                                y1[face[2]] - cc,
                            ];
                            let frame = point_triangle_frame(&xn[v], &a, &b, &cc);
                            self.friction
                                .push(lag(d, frame, [Some(v), None, None, None], moved));
                        }
                    }
                    for &[f, v] in &c.triangle_point {
                        let face = surface.faces[f];
                        let i = os.vertices[v];
                        let [a, b, cc] = face.map(|k| xn[k]);
                        let d =
                            crate::contact::distance::point_triangle_distance(&y[i], &a, &b, &cc);
                        if d > 0.0 && d < dhat {
                            let moved = [y1[i] - y[i], Vec3::zeros(), Vec3::zeros(), Vec3::zeros()];
                            let frame = point_triangle_frame(&y[i], &a, &b, &cc);
                            let slots = [None, Some(face[0]), Some(face[1]), Some(face[2])];
                            self.friction.push(lag(d, frame, slots, moved));
                        }
                    }
                    for &[ea, eb] in &c.edge_edge {
                        let [a0, a1] = surface.edges[ea];
                        let [b0, b1] = os.edges[eb];
                        let d = crate::contact::distance::edge_edge_distance(
                            &xn[a0], &xn[a1], &y[b0], &y[b1],
                        );
                        if d > 0.0 && d < dhat {
                            let moved =
                                [Vec3::zeros(), Vec3::zeros(), y1[b0] - y[b0], y1[b1] - y[b1]];
                            let frame = edge_edge_frame(&xn[a0], &xn[a1], &y[b0], &y[b1]);
                            self.friction.push(lag(
                                d,
                                frame,
                                [Some(a0), Some(a1), None, None],
                                moved,
                            ));
                        }
                    }
                }
            }
        }
    }

    /// Friction pairs at x: potential, dissipation rate's work Σ μλ f₁(y) y, and their pairs.
    pub(super) fn friction_pairs(&self, x: &[Vec3]) -> (f64, f64, Vec<Pair>) {
        let eps = self.friction_eps;
        let lagged = &self.lagged;
        let results: Vec<(f64, f64, Pair)> = self
            .friction
            .par_iter()
            .map(|lag| {
                let dx: [Vec3; 4] = std::array::from_fn(|k| match lag.slots[k] {
                    Some(v) => x[v] - lagged[v],
                    None => lag.moved[k],
                });
                let u = lag.pair.frame.relative_displacement(&dx);
                let y = u.norm();
                let work = lag.pair.mu * lag.pair.normal_force * f1(y, eps) * y;
                let d = Derivatives {
                    value: lag.pair.potential(&dx, eps),
                    gradient: lag.pair.gradient(&dx, eps),
                    hessian: lag.pair.hessian(&dx, eps),
                };
                // Already PSD (see `friction`): the exact Hessian is the projected one.
                let mut p = pair_of(&lag.slots, &d, false);
                p.distance = f64::INFINITY;
                (d.value, work, p)
            })
            .collect();
        let mut energy = 0.0;
        let mut work = 0.0;
        let mut pairs = Vec::with_capacity(results.len());
        for (e, w, p) in results {
            energy += e;
            work += w;
            pairs.push(p);
        }
        (energy, work, pairs)
    }

    /// Energy friction dissipated over the step at the last evaluation (Σ μλ f₁(‖u‖)‖u‖), J.
    pub fn friction_dissipation(&self) -> f64 {
        self.dissipation
    }
}

/// An orthonormal basis (3×2) of the plane with normal n.
fn plane_basis(n: &Vec3) -> nalgebra::Matrix3x2<f64> {
    let n = n.normalize();
    let a = if n.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    let t1 = n.cross(&a).normalize();
    let t2 = n.cross(&t1);
    nalgebra::Matrix3x2::from_columns(&[t1, t2])
}
