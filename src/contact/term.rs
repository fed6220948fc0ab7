//! Contact as a term of the incremental potential: the IPC barrier between the bodies' surface
//! and rigid obstacles, between bodies, and of a body with itself,
//! `B(x) = κ Σₖ mₖ b(dₖ(x))` over the pairs closer than d̂ (see [`super`]), plus lagged friction
//! ([`super::friction`]) on the same pairs.
//!
//! Every body lives in one mesh (disjoint components, [`ContactSetup::vertex_body`]), so the
//! term sees one surface. Obstacles sit where their motion puts them at the end of the step
//! ([`ContactTerm::begin_step`]); their pairs' Hessians live on one body vertex, edge or face,
//! inside the mesh's own adjacency. Pairs between body primitives ([`bodies`]: between two
//! bodies always, inside one body when `self_contact`, never two primitives sharing a vertex)
//! couple vertices the mesh does not: their blocks are held in the pattern as a superset
//! ([`held`]), so the pattern changes rarely. Each pair's Hessian is projected to PSD.
//! [`ContactTerm::max_step`] is the CCD bound the line search starts from, over obstacle and body
//! pairs alike, so no accepted iterate passes through an obstacle, another body or itself.

use nalgebra::{SMatrix, SVector};
use rayon::prelude::*;

use super::ContactSetup;
use super::barrier::{
    barrier_derivatives, edge_edge_mollified_barrier, edge_edge_mollifier_threshold,
    initial_barrier_stiffness, min_barrier_stiffness, project_psd,
    stiffness_matched_barrier_stiffness,
};
use super::broad::cross_candidates;
use super::ccd::{
    CcdParams, edge_edge_ccd, point_plane_ccd, point_triangle_ccd, sphere_triangle_ccd,
};
use super::distance::{
    Derivatives, point_plane_distance_derivatives, point_triangle_distance_derivatives,
    sphere_triangle_distance_derivatives,
};
use super::friction::{
    FrictionPair, TangentFrame, edge_edge_frame, f1, normal_force_magnitude, point_triangle_frame,
};
use super::obstacle::Shape;
use super::surface::ContactSurface;
use crate::integrator::{HessianShape, StepContext, StepKind, StepStart, Term};
use crate::linear::sparse::BlockCsr;
use crate::math::{Mat3, Vec3};

mod account;
mod bodies;
mod candidate_cache;
mod friction;
mod held;
mod intersection;
mod motion;
mod stiffness;

pub use account::ContactAccount;
use friction::FrictionLag;
use motion::time_of_impact;

/// Where contact's time goes: the broad phase, the barrier's pairs (distances, derivatives,
/// projection, scatter), and continuous collision detection, with counts to divide by.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactCosts {
    /// Seconds in the broad phase (BVH build and queries; meshes and boxes only).
    pub broad_seconds: f64,
    /// Seconds evaluating pairs (beyond the broad phase).
    pub barrier_seconds: f64,
    /// Primitive pairs examined by the barrier (within reach of d̂ after the broad phase, every
    /// surface vertex for a plane, every face for a sphere).
    pub pairs_examined: usize,
    /// Seconds in CCD line-search bounds.
    pub ccd_seconds: f64,
    /// CCD bound computations (each over every primitive pair in reach).
    pub ccd_calls: usize,
    /// Evaluations of the term.
    pub evaluations: usize,
    /// Of the above, the part for pairs between body primitives (body–body and self-contact):
    /// broad-phase seconds, barrier seconds, pairs examined, CCD seconds and CCD pairs tested.
    pub body_broad_seconds: f64,
    /// See [`ContactCosts::body_broad_seconds`].
    pub body_barrier_seconds: f64,
    /// See [`ContactCosts::body_broad_seconds`].
    pub body_pairs_examined: usize,
    /// See [`ContactCosts::body_broad_seconds`] (broad phase over swept boxes included).
    pub body_ccd_seconds: f64,
    /// See [`ContactCosts::body_broad_seconds`].
    pub body_ccd_pairs: usize,
    /// Searches of the surface's tree for body pairs (the rest reuse a kept list).
    pub body_searches: usize,
}

/// The contact term's state that carries over from one step to the next (see
/// [`ContactTerm::saved_state`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactState {
    /// Barrier stiffness κ.
    pub kappa: f64,
    /// The squared smallest gap when κ was last adapted (m²).
    pub previous_min_distance: f64,
    /// The smallest gap at the last evaluation (m).
    pub min_distance: Option<f64>,
    /// The body-pair blocks held in the matrix pattern, with their generation: the set carries
    /// its history (it grows and starts over, see [`held`]), so a resumed run must start from it
    /// to assemble on the pattern, and build the preconditioner, of the run never stopped.
    pub held: (Vec<(u32, u32)>, u64),
}

/// One active pair: up to four body vertices and the pair's energy derivatives over them.
#[derive(Clone, Debug)]
struct Pair {
    vertices: [usize; 4],
    count: usize,
    energy: f64,
    gradient: SVector<f64, 12>,
    projected: SMatrix<f64, 12, 12>,
    exact: SMatrix<f64, 12, 12>,
    distance: f64,
    /// The obstacle of an obstacle pair (None between body primitives and for friction).
    obstacle: Option<usize>,
}

/// An obstacle's geometry at the end of the current step.
struct Placed {
    positions: Vec<Vec3>,
    plane: Option<(Vec3, Vec3)>,
    sphere: Option<(Vec3, f64)>,
}

/// The barrier term between the bodies, themselves and the scene's rigid obstacles.
pub struct ContactTerm {
    setup: ContactSetup,
    surface: ContactSurface,
    /// Whether any pair between body primitives can count (several bodies, or self-contact).
    body_pairs: bool,
    /// The body–body and self-contact blocks held in the matrix pattern.
    held: held::HeldBlocks,
    /// The blocks of the lagged body friction pairs (sorted, unique).
    friction_blocks: Vec<(u32, u32)>,
    placed: Vec<Placed>,
    /// d̂, squared (m²).
    dhat: f64,
    kappa: f64,
    /// κ_min of IPC (from the mass and d̂), κ_max = 100 κ_min.
    kappa_min: f64,
    kappa_max: f64,
    /// Whether κ was balanced against the other forces in this step already
    /// ([`ContactTerm::balance_stiffness`]).
    balanced: bool,
    bbox_diagonal: f64,
    pairs: Vec<Pair>,
    exact: bool,
    energy: f64,
    min_distance: Option<f64>,
    previous_min_distance: f64,
    forces: Vec<Vec3>,
    /// Lagged friction: the pairs at the start of the step with their frames and normal forces.
    friction: Vec<FrictionLag>,
    /// Positions at the start of the step (the friction's lagged state).
    lagged: Vec<Vec3>,
    /// Smoothing ε = ε_v·h of friction (m).
    friction_eps: f64,
    friction_energy: f64,
    dissipation: f64,
    barrier_pairs: usize,
    /// The body's rest positions.
    rest: Vec<Vec3>,
    costs: ContactCosts,
    /// The body pair candidates kept between evaluations, and how far (m) a surface vertex may
    /// stray before they are searched again (see [`candidate_cache`]).
    body_cache: std::sync::Mutex<candidate_cache::CandidateCache>,
    candidate_margin: f64,
    /// CCD seconds and calls, and of those body pairs' seconds and pairs tested (`max_step`
    /// takes `&self`).
    ccd_costs: std::sync::Mutex<(f64, usize, f64, usize)>,
    /// Ramp factors of the obstacles: at the step's start, now, and where the step ends.
    ramp_start: Vec<f64>,
    ramp_now: Vec<f64>,
    ramp_target: Vec<f64>,
    /// The obstacle whose CCD bound held up the last push, if one did.
    blocker: Option<usize>,
    /// Pushes of moving obstacles in the current step.
    pushes: usize,
}

impl ContactTerm {
    /// The term for the surface of `mesh` (every body; rest positions, vertex masses `masses`)
    /// against `setup`'s obstacles, between its bodies and (with `self_contact`) inside each.
    pub fn new(setup: ContactSetup, mesh: &crate::mesh::TetMesh, masses: &[f64]) -> Self {
        let surface = ContactSurface::from_mesh(mesh);
        let first = surface.vertices.first().map_or(0, |&v| setup.body_of(v));
        let several = surface.vertices.iter().any(|&v| setup.body_of(v) != first);
        let body_pairs = setup.params.self_contact || several;
        let (lo, hi) = mesh.bounding_box();
        let bbox_diagonal = (hi - lo).norm();
        let dhat_m = setup.params.distance.unwrap_or(1e-3 * bbox_diagonal);
        let dhat = dhat_m * dhat_m;
        let average_mass = masses.iter().sum::<f64>() / masses.len().max(1) as f64;
        let kappa = min_barrier_stiffness(dhat, bbox_diagonal, average_mass, 1e11);
        let mut term = ContactTerm {
            setup,
            surface,
            body_pairs,
            held: held::HeldBlocks::default(),
            friction_blocks: Vec::new(),
            placed: Vec::new(),
            dhat,
            kappa,
            kappa_min: kappa,
            kappa_max: 100.0 * kappa,
            balanced: false,
            bbox_diagonal,
            pairs: Vec::new(),
            exact: false,
            energy: 0.0,
            min_distance: None,
            previous_min_distance: f64::INFINITY,
            forces: vec![Vec3::zeros(); mesh.positions.len()],
            friction: Vec::new(),
            lagged: mesh.positions.clone(),
            friction_eps: 1e-3 * bbox_diagonal,
            friction_energy: 0.0,
            dissipation: 0.0,
            barrier_pairs: 0,
            rest: mesh.positions.clone(),
            costs: ContactCosts::default(),
            body_cache: std::sync::Mutex::new(candidate_cache::CandidateCache::new()),
            candidate_margin: 2.0 * dhat_m,
            ccd_costs: std::sync::Mutex::new((0.0, 0, 0.0, 0)),
            ramp_start: Vec::new(),
            ramp_now: Vec::new(),
            ramp_target: Vec::new(),
            pushes: 0,
            blocker: None,
        };
        term.place(|_| 0.0);
        term
    }

    /// The obstacles and settings this term was made from.
    pub fn setup(&self) -> &ContactSetup {
        &self.setup
    }

    /// d̂ (m, unsquared).
    pub fn activation_distance(&self) -> f64 {
        self.dhat.sqrt()
    }

    /// Move the obstacles to where their motions put them at the end of the coming step (`ramp`
    /// gives the ramp factor of a motion with the given duration) and adapt κ: doubled (up to
    /// 100× its start) when the smallest gap is tiny and still closing (IPC).
    ///
    /// Friction is lagged here: the pairs within d̂ at `xn` (obstacles where the last step left
    /// them), their tangent frames and normal forces λ = −2κ√d b′(d), and the smoothing
    /// ε = ε_v·h with ε_v = 10⁻³ bounding-box diagonals per second (`h` the step, s; 1 s when
    /// quasistatic).
    pub fn begin_step(
        &mut self,
        xn: &[Vec3],
        h: f64,
        ramp_start: impl Fn(Option<f64>) -> f64,
        ramp_end: impl Fn(Option<f64>) -> f64,
    ) {
        // Both ends from the clock, not from where the last attempt left the obstacles: a step
        // retried with smaller substeps starts where the frame started.
        self.place(ramp_start);
        self.ramp_start.clone_from(&self.ramp_now);
        let start = std::mem::take(&mut self.placed);
        self.place(ramp_end);
        self.ramp_target.clone_from(&self.ramp_now);
        self.friction_eps = 1e-3 * self.bbox_diagonal * h;
        self.balanced = false;
        self.lag_friction(xn, &start);
        self.lag_body_friction(xn);
        self.lagged.copy_from_slice(xn);
        // The blocks of the body pairs near now (and of friction's) held for the whole step.
        if self.body_pairs {
            let mut near = self.collect_body_pairs(xn).near;
            near.extend_from_slice(&self.friction_blocks);
            held::normalize(&mut near);
            self.held.renew(&near);
        }
        // The step's solves start with the obstacles where they were: see `advance_obstacles`.
        self.place_at(&self.ramp_start.clone());
        if let Some(d) = self.min_distance {
            let d2 = d * d;
            self.kappa = super::barrier::update_barrier_stiffness(
                self.previous_min_distance,
                d2,
                self.kappa_max,
                self.kappa,
                self.bbox_diagonal,
            );
            self.previous_min_distance = d2;
        }
    }

    /// The diagonal of the body's rest bounding box, m (the length IPC's tolerances scale with).
    pub fn bounding_box_diagonal(&self) -> f64 {
        self.bbox_diagonal
    }

    /// Active pairs at the last evaluation.
    pub fn active_pairs(&self) -> usize {
        self.barrier_pairs
    }

    /// The smallest gap found at the last evaluation (m; among the pairs within reach of d̂,
    /// all vertices for planes, all faces for spheres), None when nothing was within reach.
    pub fn min_distance(&self) -> Option<f64> {
        self.min_distance
    }

    /// What the next step reads of the past: κ and the smallest gaps that adapt it (a
    /// checkpoint stores it; everything else is recomputed at the step's start).
    pub fn saved_state(&self) -> ContactState {
        ContactState {
            kappa: self.kappa,
            previous_min_distance: self.previous_min_distance,
            min_distance: self.min_distance,
            held: (self.held.blocks().to_vec(), self.held.generation()),
        }
    }

    /// Take up a [`ContactTerm::saved_state`].
    pub fn restore_state(&mut self, state: &ContactState) {
        self.kappa = state.kappa;
        self.previous_min_distance = state.previous_min_distance;
        self.min_distance = state.min_distance;
        self.held = held::HeldBlocks::restored(state.held.0.clone(), state.held.1);
    }

    /// Barrier energy at the last evaluation, J.
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// Contact forces per vertex at the last evaluation, N.
    pub fn forces(&self) -> &[Vec3] {
        &self.forces
    }

    /// The pairs within d̂ at x, with their derivatives (κ not applied), in a fixed order:
    /// obstacle pairs, then body pairs (whose findings come back in `body`).
    fn collect_pairs(
        &self,
        x: &[Vec3],
        body: &mut Option<bodies::BodyFound>,
    ) -> (Vec<Pair>, Option<f64>, usize, f64) {
        let mut examined = 0;
        let mut broad_seconds = 0.0;
        let dhat = self.dhat;
        let reach = dhat.sqrt();
        let mut pairs: Vec<Pair> = Vec::new();
        let mut min_d = f64::INFINITY;
        let surface = &self.surface;
        for (o, (spec, placed)) in self.setup.obstacles.iter().zip(&self.placed).enumerate() {
            let first = pairs.len();
            match (&spec.obstacle.shape, placed.plane, placed.sphere) {
                (Shape::Plane { .. }, Some((origin, normal)), _) => {
                    let found: Vec<(f64, Option<Pair>)> = surface
                        .vertices
                        .par_iter()
                        .map(|&v| {
                            let gap = super::distance::point_plane_gap(&x[v], &origin, &normal);
                            let p = (gap * gap < dhat).then(|| {
                                let d = point_plane_distance_derivatives(&x[v], &origin, &normal);
                                pair(&[Some(v)], &d, dhat)
                            });
                            (gap, p)
                        })
                        .collect();
                    examined += found.len();
                    for (gap, p) in found {
                        min_d = min_d.min(gap);
                        pairs.extend(p);
                    }
                }
                (Shape::Sphere { .. }, _, Some((center, radius))) => {
                    let found: Vec<(f64, Option<Pair>)> = surface
                        .faces
                        .par_iter()
                        .map(|f| {
                            let [a, b, c] = f.map(|v| x[v]);
                            let gap =
                                super::distance::sphere_triangle_gap(&center, radius, &a, &b, &c);
                            let near = gap * gap < dhat && gap > 0.0;
                            let p = near.then(|| {
                                let d = sphere_triangle_distance_derivatives(
                                    &center, radius, &a, &b, &c,
                                );
                                pair(&[Some(f[0]), Some(f[1]), Some(f[2])], &d, dhat)
                            });
                            (gap, p)
                        })
                        .collect();
                    examined += found.len();
                    for (gap, p) in found {
                        min_d = min_d.min(gap);
                        pairs.extend(p);
                    }
                }
                _ => {
                    let obstacle_surface = spec.obstacle.contact_surface();
                    let y = &placed.positions;
                    let body = surface.primitives(x, x);
                    let other = obstacle_surface.primitives(y, y);
                    let broad = std::time::Instant::now();
                    let candidates = cross_candidates(&body, &other, reach);
                    broad_seconds += broad.elapsed().as_secs_f64();
                    let rest_y = spec.obstacle.positions_at(0.0);
                    let mut found: Vec<(f64, Option<Pair>)> = candidates
                        .point_triangle
                        .par_iter()
                        .map(|&[v, f]| {
                            let v = surface.vertices[v];
                            let [a, b, c] = obstacle_surface.faces[f].map(|i| y[i]);
                            let d2 = super::distance::point_triangle_distance(&x[v], &a, &b, &c);
                            let p = (d2 < dhat).then(|| {
                                let d = point_triangle_distance_derivatives(&x[v], &a, &b, &c);
                                pair(&[Some(v), None, None, None], &d, dhat)
                            });
                            (d2.sqrt(), p)
                        })
                        .collect();
                    found.par_extend(candidates.triangle_point.par_iter().map(|&[f, v]| {
                        let face = surface.faces[f];
                        let p = y[obstacle_surface.vertices[v]];
                        let [a, b, c] = face.map(|i| x[i]);
                        let d2 = super::distance::point_triangle_distance(&p, &a, &b, &c);
                        let q = (d2 < dhat).then(|| {
                            let d = point_triangle_distance_derivatives(&p, &a, &b, &c);
                            pair(
                                &[None, Some(face[0]), Some(face[1]), Some(face[2])],
                                &d,
                                dhat,
                            )
                        });
                        (d2.sqrt(), q)
                    }));
                    found.par_extend(candidates.edge_edge.par_iter().map(|&[ea, eb]| {
                        let [a0, a1] = surface.edges[ea];
                        let [b0, b1] = obstacle_surface.edges[eb];
                        let ends = [x[a0], x[a1], y[b0], y[b1]];
                        let distance = super::distance::edge_edge_distance(
                            &ends[0], &ends[1], &ends[2], &ends[3],
                        );
                        if distance >= dhat {
                            return (distance.sqrt(), None);
                        }
                        let rest = &self.surface_rest_edge(ea);
                        let eps_x = edge_edge_mollifier_threshold(
                            &rest[0],
                            &rest[1],
                            &rest_y[b0],
                            &rest_y[b1],
                        );
                        let b = edge_edge_mollified_barrier(&ends, dhat, eps_x);
                        let mut p = pair_of(&[Some(a0), Some(a1), None, None], &b, true);
                        p.distance = distance;
                        (distance.sqrt(), Some(p))
                    }));
                    examined += found.len();
                    for (gap, p) in found {
                        min_d = min_d.min(gap);
                        pairs.extend(p);
                    }
                }
            }
            for p in &mut pairs[first..] {
                p.obstacle = Some(o);
            }
        }
        if self.body_pairs {
            let mut found = self.collect_body_pairs(x);
            examined += found.examined;
            broad_seconds += found.broad_seconds;
            // Only gaps under d̂ count: a body's own surface always has neighbours close by.
            min_d = min_d.min(found.min_gap);
            pairs.append(&mut found.pairs);
            *body = Some(found);
        }
        (
            pairs,
            min_d.is_finite().then_some(min_d),
            examined,
            broad_seconds,
        )
    }

    /// The rest positions of a body surface edge (the mollifier's threshold ε_x is a constant
    /// of the rest shape, so that the energy's gradient is the barrier's).
    fn surface_rest_edge(&self, e: usize) -> [Vec3; 2] {
        let [a, b] = self.surface.edges[e];
        [self.rest[a], self.rest[b]]
    }

    /// The largest fraction t ∈ (0, 1] of the move from x to x + dx that passes through no
    /// obstacle, other body or (with `self_contact`) the body itself (conservative CCD; 1 when
    /// nothing is in the way).
    pub fn max_step(&self, x: &[Vec3], dx: &[Vec3]) -> f64 {
        let started = std::time::Instant::now();
        let end: Vec<Vec3> = x.iter().zip(dx).map(|(x, d)| x + d).collect();
        let obstacles = self
            .setup
            .obstacles
            .iter()
            .zip(&self.placed)
            .map(|(spec, placed)| {
                time_of_impact(
                    &self.surface,
                    x,
                    &end,
                    &spec.obstacle.shape,
                    spec.obstacle.contact_surface(),
                    placed,
                    placed,
                )
            })
            .fold(1.0, f64::min);
        let body_started = std::time::Instant::now();
        let (bodies, tested) = if self.body_pairs {
            self.body_time_of_impact(x, &end)
        } else {
            (1.0, 0)
        };
        let mut costs = self.ccd_costs.lock().expect("not poisoned");
        costs.0 += started.elapsed().as_secs_f64();
        costs.1 += 1;
        costs.2 += body_started.elapsed().as_secs_f64();
        costs.3 += tested;
        obstacles.min(bodies)
    }

    /// Where contact's time went so far (for `tetsim bench`).
    pub fn costs(&self) -> ContactCosts {
        let ccd = *self.ccd_costs.lock().expect("not poisoned");
        ContactCosts {
            ccd_seconds: ccd.0,
            ccd_calls: ccd.1,
            body_ccd_seconds: ccd.2,
            body_ccd_pairs: ccd.3,
            body_searches: self.body_cache.lock().expect("not poisoned").searches,
            ..self.costs
        }
    }
}

/// A pair from distance derivatives over blocks (Some(body vertex) or None for obstacle
/// points), barrier applied.
fn pair<const N: usize>(blocks: &[Option<usize>], d: &Derivatives<N>, dhat: f64) -> Pair {
    let mut p = pair_of(blocks, &barrier_derivatives(d, dhat), true);
    p.distance = d.value;
    p
}

/// Keep the body blocks of a pair's derivatives (value, gradient, Hessian); `project` the
/// Hessian to PSD (false where it is PSD already).
fn pair_of<const N: usize>(blocks: &[Option<usize>], b: &Derivatives<N>, project: bool) -> Pair {
    let mut p = Pair {
        vertices: [0; 4],
        count: 0,
        energy: b.value,
        gradient: SVector::zeros(),
        projected: SMatrix::zeros(),
        exact: SMatrix::zeros(),
        distance: 0.0,
        obstacle: None,
    };
    let body: Vec<(usize, usize)> = blocks
        .iter()
        .enumerate()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .collect();
    for (slot, &(k, v)) in body.iter().enumerate() {
        p.vertices[slot] = v;
        for r in 0..3 {
            p.gradient[3 * slot + r] = b.gradient[3 * k + r];
        }
        for (slot2, &(l, _)) in body.iter().enumerate() {
            for r in 0..3 {
                for c in 0..3 {
                    p.exact[(3 * slot + r, 3 * slot2 + c)] = b.hessian[(3 * k + r, 3 * l + c)];
                }
            }
        }
    }
    p.count = body.len();
    p.projected = if project {
        project_psd(&p.exact)
    } else {
        p.exact
    };
    p
}

impl Term for ContactTerm {
    fn name(&self) -> &'static str {
        "contact"
    }

    /// The first residual can be small (a body coming to rest on an obstacle) while the
    /// barrier's stiffness puts rounding far above a fraction of it: the tolerance then also
    /// counts against the loads (‖f_ext‖, the weight), as users of the peers expect.
    fn residual_floor(&mut self, ctx: &StepContext<'_>) -> f64 {
        let mut partials = vec![0.0; ctx.f_ext.len().div_ceil(crate::linear::cg::CHUNK).max(1)];
        let loads = crate::linear::cg::dot(ctx.f_ext, ctx.f_ext, &mut partials).sqrt();
        ctx.params.newton_tolerance * loads
    }

    fn begin_step(&mut self, start: &StepStart<'_>, guess: &mut [Vec3]) {
        self.start_step(start, guess);
    }

    fn continue_step(&mut self, x: &[Vec3]) -> Result<bool, String> {
        self.push_obstacles(x)
    }

    fn add_stats(&self, stats: &mut crate::integrator::StepStats) {
        stats.contacts = self.active_pairs();
        stats.min_distance = self.min_distance();
        stats.contact_energy = self.energy();
        stats.friction_dissipation += self.friction_dissipation();
    }

    /// IPC's balanced barrier stiffness, once a step (see [`ContactTerm::balance_stiffness`]).
    fn after_first_evaluation(&mut self, ctx: &StepContext<'_>, force: &[Vec3]) -> bool {
        self.balance_stiffness(force, ctx.free)
    }

    /// In a dynamic step, IPC's stopping rule (Li et al. 2020): the Newton step is below
    /// ε_d·h, a velocity change of 1e-5 bounding-box diagonals per second. Against a stiff
    /// barrier the residual cannot fall below the rounding of the contact forces (two cubes
    /// meeting at 0.45 m/s stalled at relative residual 1e-6 for 200 iterations) while the step
    /// it asks for is already nothing.
    fn step_converged(&self, ctx: &StepContext<'_>, dx: &[Vec3]) -> bool {
        let StepKind::Dynamic(step) = ctx.kind else {
            return false;
        };
        let limit = 1e-5 * self.bounding_box_diagonal() * step.h;
        let largest = dx.iter().map(|d| d.amax()).fold(0.0, f64::max);
        self.active_pairs() > 0 && largest <= limit
    }

    fn evaluate(
        &mut self,
        _ctx: &StepContext<'_>,
        x: &[Vec3],
        _v: &[Vec3],
        force: &mut [Vec3],
        _partials: &mut [f64],
    ) -> f64 {
        let started = std::time::Instant::now();
        let mut body = None;
        let (pairs, min_d, examined, broad_seconds) = self.collect_pairs(x, &mut body);
        let seconds = started.elapsed().as_secs_f64();
        self.costs.broad_seconds += broad_seconds;
        self.costs.barrier_seconds += seconds - broad_seconds;
        self.costs.pairs_examined += examined;
        self.costs.evaluations += 1;
        if let Some(found) = body {
            self.costs.body_broad_seconds += found.broad_seconds;
            self.costs.body_barrier_seconds += found.seconds - found.broad_seconds;
            self.costs.body_pairs_examined += found.examined;
            // An active pair whose blocks are not held: hold every pair near now.
            if !self.held.covers(&found.active) {
                self.held.grow(&found.near);
            }
        }
        self.pairs = pairs;
        self.min_distance = min_d;
        let barrier_pairs = self.pairs.len();
        self.barrier_pairs = barrier_pairs;
        // Every stored pair carries its full scale: κ for the barrier's, 1 for friction's.
        let kappa = self.kappa;
        for p in &mut self.pairs {
            p.energy *= kappa;
            p.gradient *= kappa;
            p.projected *= kappa;
            p.exact *= kappa;
        }
        let energy: f64 = self.pairs.iter().map(|p| p.energy).sum();
        let (friction_energy, work, friction) = self.friction_pairs(x);
        self.friction_energy = friction_energy;
        self.dissipation = work;
        self.pairs.extend(friction);
        self.forces.iter_mut().for_each(|f| *f = Vec3::zeros());
        for p in &self.pairs {
            for k in 0..p.count {
                let g = p.gradient.fixed_rows::<3>(3 * k);
                self.forces[p.vertices[k]] -= g;
            }
        }
        for (f, c) in force.iter_mut().zip(&self.forces) {
            *f += c;
        }
        self.energy = energy;
        energy + friction_energy
    }

    fn hessian_shape(&self, _ctx: &StepContext<'_>) -> HessianShape {
        if self.pairs.is_empty() {
            HessianShape::Zero
        } else {
            HessianShape::Blocks
        }
    }

    fn add_hessian_product(&mut self, _ctx: &StepContext<'_>, p: &[Vec3], out: &mut [Vec3]) {
        for pair in &self.pairs {
            let h = if self.exact {
                &pair.exact
            } else {
                &pair.projected
            };
            for k in 0..pair.count {
                let mut sum = Vec3::zeros();
                for l in 0..pair.count {
                    sum += block(h, k, l) * p[pair.vertices[l]];
                }
                out[pair.vertices[k]] += sum;
            }
        }
    }

    fn add_diagonal_blocks(&mut self, _ctx: &StepContext<'_>, out: &mut [Mat3]) {
        for pair in &self.pairs {
            let h = if self.exact {
                &pair.exact
            } else {
                &pair.projected
            };
            for k in 0..pair.count {
                out[pair.vertices[k]] += block(h, k, k);
            }
        }
    }

    fn extra_blocks(&self, out: &mut Vec<(u32, u32)>) {
        out.extend_from_slice(self.held.blocks());
    }

    fn pattern_generation(&self) -> u64 {
        self.held.generation()
    }

    fn add_to_matrix(&mut self, _ctx: &StepContext<'_>, a: &mut BlockCsr) {
        for pair in &self.pairs {
            let h = if self.exact {
                &pair.exact
            } else {
                &pair.projected
            };
            for k in 0..pair.count {
                for l in 0..pair.count {
                    let (i, j) = (pair.vertices[k], pair.vertices[l]);
                    let at = a
                        .pattern
                        .find(i, j)
                        .expect("obstacle pairs couple one face or edge, body pairs are held");
                    a.blocks_mut().add(at, &block(h, k, l));
                }
            }
        }
    }

    fn use_exact(&mut self, exact: bool) {
        self.exact = exact;
    }

    fn max_step(&mut self, _ctx: &StepContext<'_>, x: &[Vec3], dx: &[Vec3]) -> f64 {
        ContactTerm::max_step(self, x, dx)
    }
}

fn block(h: &SMatrix<f64, 12, 12>, k: usize, l: usize) -> Mat3 {
    h.fixed_view::<3, 3>(3 * k, 3 * l).into_owned()
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod body_tests;
