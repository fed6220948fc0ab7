//! Body–body and self-contact: pairs between the mesh's own surface primitives through the same
//! barrier as obstacles (Li et al. 2020), their CCD bound, their lagged friction, and the check
//! that an initial state does not pass through itself.
//!
//! Every body shares one mesh (disjoint components; [`ContactSetup::vertex_body`] says which
//! vertex is whose), so the candidates are the surface's own point–triangle and edge–edge pairs
//! ([`self_candidates`]: pairs sharing a vertex are left out, as in IPC), kept when the two
//! primitives belong to different bodies, or to one body with `self_contact`. All four blocks of
//! such a pair are unknowns, and they couple vertices the mesh does not: those blocks are held
//! in the matrix pattern by [`super::held`].

use super::held::normalize;
use super::*;
use crate::contact::broad::{Bvh, self_candidates};
use crate::contact::distance::{
    edge_edge_distance, point_triangle_distance, segment_crosses_triangle, solid_angle,
};

/// A pair of body surface primitives: point–triangle `[p, t₀, t₁, t₂]` (`split` 1) or edge–edge
/// `[a₀, a₁, b₀, b₁]` (`split` 2), by mesh vertex ids.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct BodyPair {
    pub vertices: [usize; 4],
    pub split: usize,
}

impl BodyPair {
    pub(super) fn is_edge_edge(&self) -> bool {
        self.split == 2
    }

    /// The squared distance at x.
    pub fn distance(&self, x: &[Vec3]) -> f64 {
        let [a, b, c, d] = self.vertices.map(|v| x[v]);
        if self.is_edge_edge() {
            edge_edge_distance(&a, &b, &c, &d)
        } else {
            point_triangle_distance(&a, &b, &c, &d)
        }
    }

    /// The blocks (i, j), i < j, between one side's vertices and the other's.
    pub fn couplings(&self, out: &mut Vec<(u32, u32)>) {
        let (a, b) = self.vertices.split_at(self.split);
        for &i in a {
            for &j in b {
                out.push((i.min(j) as u32, i.max(j) as u32));
            }
        }
    }
}

/// What [`ContactTerm::collect_body_pairs`] found at x.
pub(super) struct BodyFound {
    /// Pairs within d̂, with derivatives (κ not applied), in candidate order.
    pub pairs: Vec<Pair>,
    /// The smallest gap (m) below √d̂, ∞ without one.
    pub min_gap: f64,
    /// Candidates examined.
    pub examined: usize,
    /// Seconds in the broad phase, and in all.
    pub broad_seconds: f64,
    pub seconds: f64,
    /// The couplings of the pairs within d̂ (sorted, unique).
    pub active: Vec<(u32, u32)>,
    /// The couplings of the pairs within the hold radius (sorted, unique).
    pub near: Vec<(u32, u32)>,
}

impl ContactTerm {
    /// Whether pairs between primitives of vertex a's body and vertex b's body count: always
    /// between bodies, inside one body with `self_contact`.
    fn pair_allowed(&self, a: usize, b: usize) -> bool {
        self.setup.params.self_contact || self.setup.body_of(a) != self.setup.body_of(b)
    }

    /// The radius (m) within which pairs' couplings are held in the pattern: 2√d̂.
    pub(super) fn hold_radius(&self) -> f64 {
        2.0 * self.dhat.sqrt()
    }

    /// Candidate body pairs within `r` (m) over the move x0 → x1, by the body rules, in a fixed
    /// order (point–triangle pairs, then edge–edge, each sorted), from the list kept between
    /// evaluations ([`super::candidate_cache`]; the same pairs as [`Self::search_body_candidates`]).
    pub(super) fn body_candidates(&self, x0: &[Vec3], x1: &[Vec3], r: f64) -> Vec<BodyPair> {
        if !self.body_pairs {
            return Vec::new();
        }
        let mut cache = self.body_cache.lock().expect("not poisoned");
        cache.candidates(
            &self.surface.vertices,
            x0,
            x1,
            r,
            self.candidate_margin,
            |a, b, r| self.search_body_candidates(a, b, r),
        )
    }

    /// The smallest gap (m) between two primitives of one body's surface at rest (not sharing a
    /// vertex, as self-contact sees them) when it is below the contact distance d̂: the rest
    /// shape then already holds barrier energy and self-contact pushes it apart from the first
    /// step. None without self-contact or when every such gap is at least d̂.
    pub fn rest_self_gap(&self) -> Option<f64> {
        if !self.setup.params.self_contact {
            return None;
        }
        let rest = &self.rest;
        self.search_body_candidates(rest, rest, self.dhat.sqrt())
            .par_iter()
            .filter(|p| self.setup.body_of(p.vertices[0]) == self.setup.body_of(p.vertices[3]))
            .map(|p| p.distance(rest))
            .filter(|&d| d < self.dhat)
            .reduce_with(f64::min)
            .map(f64::sqrt)
    }

    /// [`Self::body_candidates`] by a search of the surface's own tree.
    pub(super) fn search_body_candidates(&self, x0: &[Vec3], x1: &[Vec3], r: f64) -> Vec<BodyPair> {
        if !self.body_pairs {
            return Vec::new();
        }
        let s = &self.surface;
        let c = self_candidates(&s.primitives(x0, x1), r);
        let pt = c.point_triangle.iter().map(|&[v, f]| {
            let [a, b, cc] = s.faces[f];
            BodyPair {
                vertices: [s.vertices[v], a, b, cc],
                split: 1,
            }
        });
        let ee = c.edge_edge.iter().map(|&[i, j]| {
            let ([a0, a1], [b0, b1]) = (s.edges[i], s.edges[j]);
            BodyPair {
                vertices: [a0, a1, b0, b1],
                split: 2,
            }
        });
        pt.chain(ee)
            .filter(|p| self.pair_allowed(p.vertices[0], p.vertices[p.split]))
            .collect()
    }

    /// The body pairs within d̂ at x with their barrier derivatives (edge–edge mollified with
    /// εₓ of the rest shape), evaluated in parallel and kept in candidate order.
    pub(super) fn collect_body_pairs(&self, x: &[Vec3]) -> BodyFound {
        let broad = std::time::Instant::now();
        let hold = self.hold_radius();
        let candidates = self.body_candidates(x, x, hold);
        let broad_seconds = broad.elapsed().as_secs_f64();
        let dhat = self.dhat;
        // Distances first (most candidates are neighbours far beyond d̂), derivatives only for
        // the few within it: a `Pair` is 2 kB, too big to carry for every candidate.
        let distances: Vec<f64> = candidates.par_iter().map(|c| c.distance(x)).collect();
        let within: Vec<usize> = (0..candidates.len())
            .filter(|&k| distances[k] < dhat)
            .collect();
        let pairs: Vec<Pair> = within
            .par_iter()
            .map(|&k| {
                let (c, d) = (&candidates[k], distances[k]);
                let [a, b, cc, dd] = c.vertices.map(|v| x[v]);
                let slots = c.vertices.map(Some);
                if c.is_edge_edge() {
                    let rest = c.vertices.map(|v| self.rest[v]);
                    let eps_x =
                        edge_edge_mollifier_threshold(&rest[0], &rest[1], &rest[2], &rest[3]);
                    let mut p = pair_of(
                        &slots,
                        &edge_edge_mollified_barrier(&[a, b, cc, dd], dhat, eps_x),
                        true,
                    );
                    p.distance = d;
                    p
                } else {
                    pair(
                        &slots,
                        &point_triangle_distance_derivatives(&a, &b, &cc, &dd),
                        dhat,
                    )
                }
            })
            .collect();
        let mut near = Vec::new();
        let mut active = Vec::new();
        for (c, &d) in candidates.iter().zip(&distances) {
            if d < hold * hold {
                c.couplings(&mut near);
            }
        }
        let mut min_gap = f64::INFINITY;
        for &k in &within {
            candidates[k].couplings(&mut active);
            min_gap = min_gap.min(distances[k].sqrt());
        }
        normalize(&mut near);
        normalize(&mut active);
        BodyFound {
            pairs,
            min_gap,
            examined: candidates.len(),
            broad_seconds,
            seconds: broad.elapsed().as_secs_f64(),
            active,
            near,
        }
    }

    /// The conservative time of impact (0..=1) of the body pairs moving x0 → x1 (additive CCD
    /// over the pairs whose swept boxes meet), with the number of pairs tested.
    pub(super) fn body_time_of_impact(&self, x0: &[Vec3], x1: &[Vec3]) -> (f64, usize) {
        let candidates = self.body_candidates(x0, x1, 0.0);
        let params = CcdParams::default();
        let t = candidates
            .par_iter()
            .map(|c| {
                let (s, e) = (c.vertices.map(|v| x0[v]), c.vertices.map(|v| x1[v]));
                if c.is_edge_edge() {
                    edge_edge_ccd(&s, &e, &params)
                } else {
                    point_triangle_ccd(&s, &e, &params)
                }
            })
            .reduce(|| 1.0, f64::min);
        if log::log_enabled!(log::Level::Trace) && t < 1.0 {
            // Which pair limits the step, how far apart, how far it moves (debugging impacts).
            for c in &candidates {
                let (s, e) = (c.vertices.map(|v| x0[v]), c.vertices.map(|v| x1[v]));
                let tc = if c.is_edge_edge() {
                    edge_edge_ccd(&s, &e, &params)
                } else {
                    point_triangle_ccd(&s, &e, &params)
                };
                if tc == t {
                    let moved = (0..4).map(|k| (e[k] - s[k]).norm()).fold(0.0, f64::max);
                    let rest = c.vertices.map(|v| self.rest[v]);
                    let eps_x =
                        edge_edge_mollifier_threshold(&rest[0], &rest[1], &rest[2], &rest[3]);
                    let cross = (s[1] - s[0]).cross(&(s[3] - s[2])).norm_squared();
                    log::trace!("  |ea x eb|^2 / eps_x = {:.3e}", cross / eps_x);
                    log::trace!(
                        "CCD limit {t:.3e} by {:?} (split {}): gap {:.3e} m, active {}, moves {:.3e} m",
                        c.vertices,
                        c.split,
                        c.distance(x0).sqrt(),
                        c.distance(x0) < self.dhat,
                        moved
                    );
                    break;
                }
            }
        }
        (t, candidates.len())
    }

    /// Friction between bodies and in self-contact, lagged at `xn` (coefficient
    /// `[contact] friction`): appended to the obstacles' lagged pairs.
    pub(super) fn lag_body_friction(&mut self, xn: &[Vec3]) {
        self.friction_blocks.clear();
        let mu = self.setup.params.friction;
        if mu <= 0.0 {
            return;
        }
        let dhat = self.dhat;
        let mut blocks = Vec::new();
        let lags: Vec<FrictionLag> = self
            .body_candidates(xn, xn, dhat.sqrt())
            .into_iter()
            .filter_map(|c| {
                let d = c.distance(xn);
                if !(d > 0.0 && d < dhat) {
                    return None;
                }
                let [a, b, cc, dd] = c.vertices.map(|v| xn[v]);
                let frame = if c.is_edge_edge() {
                    edge_edge_frame(&a, &b, &cc, &dd)
                } else {
                    point_triangle_frame(&a, &b, &cc, &dd)
                };
                let normal_force = normal_force_magnitude(d, dhat, self.kappa);
                c.couplings(&mut blocks);
                Some(FrictionLag::between_bodies(
                    FrictionPair {
                        frame,
                        mu,
                        normal_force,
                    },
                    c,
                ))
            })
            .collect();
        normalize(&mut blocks);
        self.friction.extend(lags);
        self.friction_blocks = blocks;
    }

    /// Why the bodies at x pass through each other or themselves, or None: a surface edge that
    /// crosses a surface face it does not share a vertex with, or a pair touching (distance 0),
    /// under the body rules. The message names both bodies and an element of each.
    pub(super) fn body_intersection(&self, x: &[Vec3]) -> Option<String> {
        if !self.body_pairs {
            return None;
        }
        let s = &self.surface;
        let prim = s.primitives(x, x);
        let faces = Bvh::build(&prim.face_boxes(0.0));
        let crossing = prim
            .edge_boxes(0.0)
            .par_iter()
            .enumerate()
            .find_map_first(|(e, b)| {
                let mut hits = Vec::new();
                faces.query(b, &mut hits);
                hits.sort_unstable();
                let [p, q] = s.edges[e];
                hits.into_iter()
                    .map(|f| s.faces[f])
                    .find(|f| {
                        !f.contains(&p)
                            && !f.contains(&q)
                            && self.pair_allowed(p, f[0])
                            && segment_crosses_triangle(&x[p], &x[q], &x[f[0]], &x[f[1]], &x[f[2]])
                    })
                    .map(|f| (e, f))
            });
        if let Some((e, f)) = crossing {
            let [p, q] = s.edges[e];
            return Some(self.pass_through(
                p,
                &format!("its surface edge of vertices {p} and {q}"),
                f[0],
                &format!("the face of vertices {}, {} and {}", f[0], f[1], f[2]),
                "crosses",
            ));
        }
        if let Some(message) = self.nested_body(x) {
            return Some(message);
        }
        let touching = self
            .search_body_candidates(x, x, 0.0)
            .into_par_iter()
            .find_first(|c| c.distance(x) <= 0.0)?;
        let [a, b, c, d] = touching.vertices;
        Some(if touching.is_edge_edge() {
            self.pass_through(
                a,
                &format!("its surface edge of vertices {a} and {b}"),
                c,
                &format!("the edge of vertices {c} and {d}"),
                "touches",
            )
        } else {
            self.pass_through(
                a,
                &format!("its surface vertex {a}"),
                b,
                &format!("the face of vertices {b}, {c} and {d}"),
                "touches",
            )
        })
    }

    /// A body lying wholly inside another (no surface crossing, so only the winding number of
    /// the other's closed surface about one of its vertices tells), as the message of
    /// [`Self::body_intersection`], or None.
    fn nested_body(&self, x: &[Vec3]) -> Option<String> {
        let s = &self.surface;
        let bodies = s
            .vertices
            .iter()
            .map(|&v| self.setup.body_of(v))
            .max()
            .map_or(0, |b| b as usize + 1);
        if bodies < 2 {
            return None;
        }
        // One surface vertex of each body, and each body's faces.
        let mut first = vec![None; bodies];
        for &v in &s.vertices {
            first[self.setup.body_of(v) as usize].get_or_insert(v);
        }
        let mut faces: Vec<Vec<[usize; 3]>> = vec![Vec::new(); bodies];
        for f in &s.faces {
            faces[self.setup.body_of(f[0]) as usize].push(*f);
        }
        for (inner, v) in first.iter().enumerate() {
            let Some(v) = *v else { continue };
            for (outer, outer_faces) in faces.iter().enumerate() {
                if outer == inner || outer_faces.is_empty() {
                    continue;
                }
                let winding: f64 = outer_faces
                    .iter()
                    .map(|&[a, b, c]| solid_angle(&x[v], &x[a], &x[b], &x[c]))
                    .sum::<f64>()
                    / (4.0 * std::f64::consts::PI);
                if winding.abs() > 0.5 {
                    let (ni, no) = (
                        self.setup.body_name(inner as u32),
                        self.setup.body_name(outer as u32),
                    );
                    return Some(format!(
                        "the initial state has body \"{ni}\" inside body \"{no}\": its surface \
                         vertex {v} at ({:.4}, {:.4}, {:.4}) lies within the surface of \"{no}\"",
                        x[v].x, x[v].y, x[v].z
                    ));
                }
            }
        }
        None
    }

    /// "the initial state intersects: body "a" (its ...) crosses body "b" (...)", or "... passes
    /// through itself" for one body.
    pub(super) fn pass_through(
        &self,
        a: usize,
        what_a: &str,
        b: usize,
        what_b: &str,
        verb: &str,
    ) -> String {
        let (ba, bb) = (self.setup.body_of(a), self.setup.body_of(b));
        let (na, nb) = (self.setup.body_name(ba), self.setup.body_name(bb));
        if ba == bb {
            format!(
                "the initial state passes body \"{na}\" through itself: {what_a} {verb} {what_b}"
            )
        } else {
            format!(
                "the initial state has body \"{na}\" passing through body \"{nb}\": {what_a} of \
                 \"{na}\" {verb} {what_b} of \"{nb}\""
            )
        }
    }
}
