//! From a valid scene to the things that run: the mesh, the materials, the boundary conditions,
//! the initial state and the solver settings, and [`Simulation::from_scene`] putting them
//! together. Errors only building can find (a region that selects nothing, a group the mesh
//! lacks) are located at their key like the validator's.

use crate::boundary::{Boundary, Constraint, Load, Motion, Region};
use crate::contact::obstacle::{Obstacle, Shape};
use crate::contact::{ContactParams, ContactSetup, ObstacleSpec};
use crate::elastic::{ElasticBody, MaterialRegion};
use crate::error::{Error, Result};
use crate::integrator::{Integrator, OnFailure, PreconditionerKind, SolverParams};
use crate::material::{Lame, Model};
use crate::math::Vec3;
use crate::mesh::TetMesh;
use crate::mesh::generate::box_mesh;
use crate::mesh::ordering::{Renumbering, VertexOrder};
use crate::modes::DampingResolution;
use crate::sim::{Simulation, State};

use super::bodies::Membership;
use super::locate::{Seg, key};
use super::schema::{
    DampingTangentName, Generator, IntegratorName, MeshSpec, MotionSpec, OnFailureName,
    PreconditionerName, RegionSpec, Scene,
};
use super::units::{Unit, length_unit};

impl Scene {
    /// Lamé parameters from (E, ν) or (μ, λ), with the range checks of each.
    pub fn lame(&self) -> std::result::Result<Lame, String> {
        let m = &self.material;
        lame_from(m.youngs_modulus, m.poisson_ratio, m.mu, m.lambda)
    }

    /// Model and density of the i-th `[[volume]]`, with its body's `[material]` values where it
    /// is silent.
    pub fn volume_material(&self, i: usize) -> std::result::Result<(Model, f64, f64), String> {
        let v = &self.volume[i];
        let m = self.body_material(self.body_index(v.body.as_deref()));
        let own = v.youngs_modulus.is_some()
            || v.poisson_ratio.is_some()
            || v.mu.is_some()
            || v.lambda.is_some();
        let lame = if own {
            lame_from(v.youngs_modulus, v.poisson_ratio, v.mu, v.lambda)?
        } else {
            lame_from(m.youngs_modulus, m.poisson_ratio, m.mu, m.lambda)?
        };
        let density = v.density.unwrap_or(m.density);
        if !(density > 0.0 && density.is_finite()) {
            return Err(format!("density must be positive (kg/m³), got {density}"));
        }
        let (threshold, recovery) = thresholds(
            v.inversion_threshold.or(m.inversion_threshold),
            v.recovery_threshold.or(m.recovery_threshold),
        )?;
        let model = Model::with_threshold(v.model.unwrap_or(m.model), lame, threshold);
        Ok((model, density, recovery))
    }

    /// The model of a `[material]` table (of body 0 or a `[[body]]`) and its recovery threshold.
    pub fn material_model(
        m: &super::schema::MaterialSpec,
    ) -> std::result::Result<(Model, f64), String> {
        let lame = lame_from(m.youngs_modulus, m.poisson_ratio, m.mu, m.lambda)?;
        let (threshold, recovery) = thresholds(m.inversion_threshold, m.recovery_threshold)?;
        Ok((Model::with_threshold(m.model, lame, threshold), recovery))
    }

    /// Build the mesh of `[mesh]` (body 0): read the file or run the generator.
    pub fn build_mesh(&self) -> Result<TetMesh> {
        self.build_mesh_spec(&self.mesh, &key!["mesh"])
    }

    /// Build the mesh `spec` describes (at key `at`, for messages).
    pub(super) fn build_mesh_spec(&self, spec: &MeshSpec, at: &[Seg]) -> Result<TetMesh> {
        match (&spec.file, &spec.generator) {
            (Some(file), _) => {
                let path = self.resolve(file);
                let read = crate::io::read_mesh_with(
                    &path,
                    crate::io::ReadOptions {
                        force: self.mesh.force || spec.force,
                    },
                )
                .map_err(|e| self.unreadable(&[at, &key!["file"]].concat(), e))?;
                log::info!(
                    "{}: {}",
                    path.display(),
                    read.report.to_string().trim_end().replace('\n', "; ")
                );
                for (severity, problem) in read.diagnosis.problems() {
                    log::warn!("{}: {severity:?}: {problem}", path.display());
                }
                if let Some(why) = crate::resources::memory_shortfall(read.mesh.tets.len() as f64) {
                    return Err(self.error_at(&key!["mesh", "file"], why));
                }
                let mut mesh = read.mesh;
                let unit = self.length_unit(spec, at)?;
                if let Some(unit) = unit {
                    for p in &mut mesh.positions {
                        *p = p.map(|c| unit.to_si(c));
                    }
                }
                if let Some(problem) = super::validate::beyond_length_cap(&mesh.positions) {
                    let key = if unit.is_some() { "unit" } else { "file" };
                    return Err(self.error_at(
                        &[at, &key![key]].concat(),
                        format!("{}: {problem}", path.display()),
                    ));
                }
                Ok(mesh)
            }
            (None, Some(Generator::Box { min, max, cells })) => {
                Ok(box_mesh(Vec3::from(*min), Vec3::from(*max), *cells))
            }
            (None, None) => match (&spec.surface, spec.size) {
                (Some(surface), Some(size)) => self.fill_surface(spec, at, surface, size),
                _ => Err(self.error_at(
                    &[at, &key!["file"]].concat(),
                    "give a mesh file or a generator (or a surface to fill with tets)",
                )),
            },
        }
    }

    /// Read `surface` (in the spec's `unit`) and fill it with tets at lattice spacing `size`.
    fn fill_surface(
        &self,
        spec: &MeshSpec,
        at: &[Seg],
        surface: &std::path::Path,
        size: f64,
    ) -> Result<TetMesh> {
        use crate::mesh::stuff::{StuffError, StuffParams, tetrahedralize};
        let path = self.resolve(surface);
        let surface_key = [at, &key!["surface"]].concat();
        let mut triangles =
            crate::io::read_surface(&path).map_err(|e| self.unreadable(&surface_key, e))?;
        if let Some(unit) = self.length_unit(spec, at)? {
            for p in &mut triangles.positions {
                *p = p.map(|c| unit.to_si(c));
            }
        }
        let (mesh, info) =
            tetrahedralize(&triangles, &StuffParams::with_size(size)).map_err(|e| {
                let key = match e {
                    StuffError::NonPositiveSize { .. }
                    | StuffError::EmptyInside { .. }
                    | StuffError::TooLarge { .. } => [at, &key!["size"]].concat(),
                    _ => surface_key.clone(),
                };
                self.error_at(&key, format!("{}: {e}", path.display()))
            })?;
        log::info!(
            "{}: filled with {} tets, {} vertices at size {size} m (closure {:.3})",
            path.display(),
            mesh.tets.len(),
            mesh.positions.len(),
            info.closure
        );
        if let Some(why) = crate::resources::memory_shortfall(mesh.tets.len() as f64) {
            return Err(self.error_at(&[at, &key!["size"]].concat(), why));
        }
        Ok(mesh)
    }

    /// The unit of a mesh's `unit` key (None: metres already).
    fn length_unit(&self, spec: &MeshSpec, at: &[Seg]) -> Result<Option<Unit>> {
        spec.unit
            .as_deref()
            .map(length_unit)
            .transpose()
            .map_err(|e| self.error_at(&[at, &key!["unit"]].concat(), e))
    }

    /// The solver settings.
    pub fn solver_params(&self) -> SolverParams {
        let s = &self.solver;
        SolverParams {
            integrator: match s.integrator {
                IntegratorName::BackwardEuler => Integrator::BackwardEuler,
                IntegratorName::Bdf2 => Integrator::Bdf2,
                IntegratorName::Newmark => Integrator::Newmark {
                    beta: s
                        .newmark_beta
                        .unwrap_or(crate::integrator::scheme::NEWMARK_BETA),
                    gamma: s
                        .newmark_gamma
                        .unwrap_or(crate::integrator::scheme::NEWMARK_GAMMA),
                },
                IntegratorName::Quasistatic => Integrator::Quasistatic,
            },
            dt: s.dt,
            frames: s.frames,
            substeps: s.substeps,
            rayleigh_stiffness: s.rayleigh_stiffness,
            rayleigh_mass: s.rayleigh_mass,
            damping_stiffness: s.damping_stiffness,
            damping_tangent: match s.damping_tangent {
                DampingTangentName::Shifted => crate::integrator::DampingTangent::Shifted,
                DampingTangentName::Frozen => crate::integrator::DampingTangent::Frozen,
            },
            newton_tolerance: s.newton_tolerance,
            newton_max_iterations: s.newton_max_iterations,
            cg: crate::linear::cg::CgParams {
                tolerance: s.cg_tolerance,
                max_iterations: s.cg_max_iterations,
            },
            definiteness: s.definiteness,
            preconditioner: match s.preconditioner {
                PreconditionerName::BlockJacobi => PreconditionerKind::BlockJacobi,
                PreconditionerName::Jacobi => PreconditionerKind::Jacobi,
                PreconditionerName::None => PreconditionerKind::Identity,
                PreconditionerName::Amg => PreconditionerKind::Amg,
                #[cfg(feature = "direct")]
                PreconditionerName::Cholesky => PreconditionerKind::Cholesky,
                // `validate` rejects it; only a scene changed in code after loading gets here.
                #[cfg(not(feature = "direct"))]
                PreconditionerName::Cholesky => {
                    log::warn!("preconditioner = \"cholesky\" needs --features direct; using amg");
                    PreconditionerKind::Amg
                }
            },
            amg: crate::linear::amg::AmgParams::default(),
            line_search: s.line_search,
            inexact_newton: s.inexact_newton,
            f32_matrix: s.f32_matrix,
            matrix_precision: s.matrix_precision,
            cholesky_reuse: s.cholesky_reuse,
            on_failure: match s.on_failure {
                OnFailureName::Retry => OnFailure::Retry,
                OnFailureName::Continue => OnFailure::Continue,
                OnFailureName::Stop => OnFailure::Stop,
            },
            max_step_cuts: s.max_step_cuts,
        }
    }

    /// The Rayleigh coefficients `[solver] damping_ratio` resolves to on `body` with the free
    /// DOFs `free` (None without a ratio). Without `damping_frequencies`, f₁ is the body's
    /// lowest elastic vibration mode ([`crate::modes`]), found by an eigen-solve.
    pub fn resolve_damping(
        &self,
        body: &ElasticBody,
        free: &[Vec3],
    ) -> Result<Option<DampingResolution>> {
        let Some(zeta) = self.solver.damping_ratio else {
            return Ok(None);
        };
        let resolved = match self.solver.damping_frequencies {
            Some(f) => Ok(DampingResolution::new(zeta, f, false)),
            None => DampingResolution::from_lowest_mode(zeta, body, free).map_err(|e| {
                self.error_at(
                    &key!["solver", "damping_ratio"],
                    format!(
                        "the default damping_frequencies need the lowest vibration mode, \
                             which was not found ({e}): give damping_frequencies = [f1, f2] (Hz)"
                    ),
                )
            }),
        }?;
        let [f1, f2] = resolved.frequencies_hz;
        match super::validate::derived_damping_problem(zeta, f1, f2) {
            Some(problem) => Err(self.error_at(&key!["solver", "damping_ratio"], problem)),
            None => Ok(Some(resolved)),
        }
    }

    /// Constraints, loads and gravity on `mesh`.
    pub fn build_boundary(&self, mesh: &TetMesh) -> Result<Boundary> {
        self.build_boundary_renumbered(mesh, None)
    }

    /// [`Scene::build_boundary`] on a renumbered mesh: `vertices = [...]` lists name the input
    /// mesh's vertices and are mapped through `renumbering`.
    pub fn build_boundary_renumbered(
        &self,
        mesh: &TetMesh,
        renumbering: Option<&Renumbering>,
    ) -> Result<Boundary> {
        self.build_boundary_of(mesh, renumbering, None)
    }

    /// [`Scene::build_boundary_renumbered`] on the merged mesh of several bodies: a region with
    /// `body = "..."` keeps only that body's vertices.
    pub(super) fn build_boundary_of(
        &self,
        mesh: &TetMesh,
        renumbering: Option<&Renumbering>,
        bodies: Option<&Membership>,
    ) -> Result<Boundary> {
        let mut boundary = Boundary {
            gravity: Vec3::from(self.gravity),
            ..Default::default()
        };
        for (i, fixed) in self.fixed.iter().enumerate() {
            let vertices = region(&fixed.region, renumbering)
                .select(mesh)
                .and_then(|v| Membership::keep_vertices(bodies, fixed.body.as_deref(), v))
                .map_err(|m| self.error_at(&key!["fixed", i, "region"], m))?;
            let mut components = [true; 3];
            if let Some(list) = &fixed.components {
                components = [false; 3];
                for c in list {
                    components[*c as usize] = true;
                }
            }
            let motion = motion(fixed.motion.as_ref());
            boundary.constraints.push(Constraint {
                vertices,
                components,
                motion,
                duration: fixed.duration,
                until: fixed.until,
                targets: None,
            });
        }
        for (i, spec) in self.load.iter().enumerate() {
            let vertices = region(&spec.region, renumbering)
                .select(mesh)
                .and_then(|v| Membership::keep_vertices(bodies, spec.body.as_deref(), v))
                .map_err(|m| self.error_at(&key!["load", i, "region"], m))?;
            let mut load = if let Some(t) = spec.traction {
                Load::traction(mesh, &vertices, Vec3::from(t))
                    .map_err(|m| self.error_at(&key!["load", i, "traction"], m))?
            } else if let Some(f) = spec.total_force {
                Load::total_force(mesh, &vertices, Vec3::from(f))
            } else {
                Load::point_force(&vertices, Vec3::from(spec.point_force.unwrap_or_default()))
            };
            load.duration = spec.duration;
            boundary.loads.push(load);
        }
        Ok(boundary)
    }

    /// True when the scene turns contact on: it has `[contact]`, an `[[obstacle]]` or a
    /// `[[body]]`.
    pub fn has_contact(&self) -> bool {
        self.contact.is_some() || !self.obstacle.is_empty() || !self.body.is_empty()
    }

    /// What the scene asks of contact (None: no `[contact]`, no `[[obstacle]]`): the obstacles
    /// with their shapes, motions and friction, and the `[contact]` settings. Mesh obstacles
    /// are read here; a file that cannot be read or holds no usable triangles is reported at
    /// the line of its `mesh` key, followed by the file's own location.
    pub fn contact_setup(&self) -> Result<Option<ContactSetup>> {
        if !self.has_contact() {
            return Ok(None);
        }
        let spec = self.contact.clone().unwrap_or_default();
        let mut obstacles = Vec::with_capacity(self.obstacle.len());
        for (i, o) in self.obstacle.iter().enumerate() {
            let motion = motion(o.motion.as_ref());
            let (shape_key, built) = if let Some(p) = &o.plane {
                let shape = Shape::Plane {
                    point: Vec3::from(p.point),
                    normal: Vec3::from(p.normal),
                };
                ("plane", Obstacle::new(shape, motion))
            } else if let Some(b) = &o.cuboid {
                let shape = Shape::Box {
                    min: Vec3::from(b.min),
                    max: Vec3::from(b.max),
                };
                ("box", Obstacle::new(shape, motion))
            } else if let Some(sphere) = &o.sphere {
                let shape = Shape::Sphere {
                    center: Vec3::from(sphere.center),
                    radius: sphere.radius,
                };
                ("sphere", Obstacle::new(shape, motion))
            } else if let Some(file) = &o.mesh {
                ("mesh", Obstacle::from_file(&self.resolve(file), motion))
            } else {
                // `validate` refuses an obstacle without a shape.
                return Err(self.error_at(&key!["obstacle", i], "needs a shape key"));
            };
            let obstacle = built.map_err(|e| {
                let message = match e {
                    Error::Parameter { message, .. } => message,
                    other => other.to_string(),
                };
                self.error_at(&key!["obstacle", i, shape_key], message)
            })?;
            obstacles.push(ObstacleSpec {
                name: o
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("obstacle {}", i + 1)),
                obstacle,
                friction: o.friction,
                duration: o.duration,
            });
        }
        Ok(Some(ContactSetup {
            obstacles,
            params: ContactParams {
                distance: spec.distance,
                friction: spec.friction,
                self_contact: spec.self_contact,
            },
            ..Default::default()
        }))
    }

    /// A file the scene names at `key` that cannot be opened is reported at that key's line;
    /// errors inside the file keep the file's own location.
    fn unreadable(&self, key: &[Seg], error: Error) -> Error {
        match error {
            Error::Io { path, source } => {
                self.error_at(key, format!("{}: {source}", path.display()))
            }
            // A problem with the whole file (no line of its own): located at the scene key.
            Error::Parse {
                path,
                line: None,
                message,
            } => self.error_at(key, format!("{}: {message}", path.display())),
            other => other,
        }
    }

    /// The initial state: rest or file positions, the initial velocity on free components.
    pub fn initial_state(&self, body: &ElasticBody) -> Result<State> {
        self.initial_state_renumbered(body, None)
    }

    /// [`Scene::initial_state`] for a body on a renumbered mesh: the positions file lists the
    /// input mesh's vertices in its order.
    pub fn initial_state_renumbered(
        &self,
        body: &ElasticBody,
        renumbering: Option<&Renumbering>,
    ) -> Result<State> {
        let whole = crate::mesh::bodies::Bodies::single("", &body.mesh);
        self.initial_state_of(body, renumbering, &whole)
    }

    /// The initial state of the merged mesh of `bodies`: `[initial] positions` lists body 0's
    /// vertices (in its file's order), every body starts with its own velocity.
    pub(super) fn initial_state_of(
        &self,
        body: &ElasticBody,
        renumbering: Option<&Renumbering>,
        bodies: &crate::mesh::bodies::Bodies,
    ) -> Result<State> {
        let mut state = Simulation::rest_state(body);
        // Input order first, then into the internal numbering.
        let mut x = match renumbering {
            Some(r) => r.vertices_to_old(&state.x),
            None => state.x.clone(),
        };
        let mut v = vec![Vec3::zeros(); x.len()];
        // A mesh elevated to quadratic tets takes the positions of its file's vertices (its
        // corners, listed first): the mid-edge nodes then start halfway along their edges.
        let mut corners_only = false;
        if let Some(file) = &self.initial.positions {
            let first = bodies.vertices(0);
            let path = self.resolve(file);
            let corners = self.elevated_corners(body, renumbering, first.clone());
            let mut given = match crate::io::read_positions(&path, first.len()) {
                Err(e) if corners < first.len() => {
                    corners_only = true;
                    crate::io::read_positions(&path, corners).map_err(|_| e)
                }
                read => read,
            }
            .map_err(|e| self.unreadable(&key!["initial", "positions"], e))?;
            // In the mesh file's unit, like the mesh it lists the vertices of.
            if let Some(unit) = self.length_unit(&self.mesh, &key!["mesh"])? {
                for p in &mut given {
                    *p = p.map(|c| unit.to_si(c));
                }
            }
            if let Some(problem) = super::validate::beyond_length_cap(&given) {
                return Err(self.error_at(
                    &key!["initial", "positions"],
                    format!("{}: {problem}", path.display()),
                ));
            }
            x[first.start..first.start + given.len()].copy_from_slice(&given);
        }
        for b in 0..bodies.count() {
            let velocity = self.body_velocity(b);
            v[bodies.vertices(b)].iter_mut().for_each(|v| *v = velocity);
        }
        (state.x, state.v) = match renumbering {
            Some(r) => (r.to_new(&x), r.to_new(&v)),
            None => (x, v),
        };
        if corners_only {
            let mesh = &body.mesh;
            let first = bodies.vertices(0);
            let input = |n: usize| renumbering.map_or(n, |r| r.vertex_old[n]);
            for (t, tet) in mesh.tets.iter().enumerate() {
                for (k, [i, j]) in crate::mesh::quadratic::EDGES.iter().enumerate() {
                    let n = mesh.edge_nodes[t][k];
                    if first.contains(&input(n)) {
                        state.x[n] = 0.5 * (state.x[tet[*i]] + state.x[tet[*j]]);
                    }
                }
            }
        }
        Ok(state)
    }

    /// How many of body 0's vertices (input range `first`) are corners of a mesh elevated to
    /// quadratic tets: all of them when the mesh is linear or was read quadratic.
    fn elevated_corners(
        &self,
        body: &ElasticBody,
        renumbering: Option<&Renumbering>,
        first: std::ops::Range<usize>,
    ) -> usize {
        if self.mesh.element_order() != 2 {
            return first.len();
        }
        let mut corner = vec![false; body.vertex_count()];
        for &v in body.mesh.tets.iter().flatten() {
            corner[v] = true;
        }
        let corner = match renumbering {
            Some(r) => r.vertices_to_old(&corner),
            None => corner,
        };
        first.filter(|&v| corner[v]).count()
    }
}

/// A scene motion (None: at rest).
fn motion(spec: Option<&MotionSpec>) -> Motion {
    spec.map_or(Motion::default(), |m| Motion {
        translate: Vec3::from(m.translate),
        rotate_degrees: m.rotate_degrees,
        axis: Vec3::from(m.axis),
        center: Vec3::from(m.center),
    })
}

fn region(spec: &RegionSpec, renumbering: Option<&Renumbering>) -> Region {
    match spec {
        RegionSpec::Box { min, max } => Region::Box {
            min: Vec3::from(*min),
            max: Vec3::from(*max),
        },
        RegionSpec::Plane { point, normal } => Region::Plane {
            point: Vec3::from(*point),
            normal: Vec3::from(*normal),
        },
        RegionSpec::Vertices(v) => Region::Vertices(match renumbering {
            // Out-of-range indices stay as given, for the error message.
            Some(r) => v
                .iter()
                .map(|&i| r.vertex_new.get(i).copied().unwrap_or(i))
                .collect(),
            None => v.clone(),
        }),
        RegionSpec::Physical(name) => Region::Physical(name.clone()),
    }
}

impl Simulation {
    /// Everything a scene describes, ready to step.
    pub fn from_scene(scene: &Scene) -> Result<Simulation> {
        let (file_mesh, bodies, placements) = scene.build_bodies()?;
        let generated =
            scene.mesh.generator.is_some() && scene.body.iter().all(|b| b.mesh.generator.is_some());
        let order = match scene.mesh.reorder {
            // A generator's lattice order is already local (see `mesh::ordering`).
            VertexOrder::Auto if generated => VertexOrder::None,
            order => order,
        };
        let renumbering = Renumbering::new(&file_mesh, order);
        let mesh = match &renumbering {
            Some(r) => r.apply(&file_mesh),
            None => file_mesh,
        };
        let (model, recovery) =
            Scene::material_model(&scene.material).map_err(|m| Error::parameter("material", m))?;
        let mut recoveries = vec![recovery];
        let mesh_path = scene.mesh.file.as_ref().map(|f| scene.resolve(f));
        let membership = Membership::new(&bodies, renumbering.as_ref());
        let mut regions = Vec::with_capacity(bodies.count() - 1 + scene.volume.len());
        // Bodies after the first are material regions of the merged mesh; `[[volume]]`s after
        // them, so that a volume inside a body overrides the body's material.
        for (b, spec) in scene.body.iter().enumerate() {
            let m = &spec.material;
            let (model, recovery) = Scene::material_model(m)
                .map_err(|e| scene.error_at(&key!["body", b, "material"], e))?;
            recoveries.push(recovery);
            regions.push(MaterialRegion {
                model,
                density: m.density,
                tets: membership.tets_of(b as u32 + 1),
            });
        }
        for (i, volume) in scene.volume.iter().enumerate() {
            let (model, density, recovery) = scene
                .volume_material(i)
                .map_err(|m| scene.error_at(&key!["volume", i], m))?;
            recoveries.push(recovery);
            let tets = select_tets(&volume.region, &mesh)
                .and_then(|t| membership.keep_tets(volume.body.as_deref(), t))
                .map_err(|m| scene.error_at(&key!["volume", i, "region"], m))?;
            regions.push(MaterialRegion {
                model,
                density,
                tets,
            });
        }
        let mut body = ElasticBody::with_regions(mesh, model, scene.material.density, regions)
            .map_err(|e| match e {
                Error::Mesh { problem, .. } => Error::Mesh {
                    path: mesh_path.clone(),
                    problem,
                },
                other => other,
            })?;
        for (k, recovery) in recoveries.into_iter().enumerate() {
            body.set_recovery_threshold(k, recovery);
        }
        let boundary =
            scene.build_boundary_of(&body.mesh, renumbering.as_ref(), Some(&membership))?;
        let initial = scene.initial_state_of(&body, renumbering.as_ref(), &bodies)?;
        let monitors = scene.build_monitors(&body, &membership)?;
        let render = scene.build_render(
            &body,
            &bodies.names,
            |b| membership.tets_of(b as u32),
            &placements,
        )?;
        let contact = scene.contact_setup()?.map(|setup| ContactSetup {
            body_names: bodies.names.clone(),
            vertex_body: membership.vertex_body.clone(),
            ..setup
        });
        let mut params = scene.solver_params();
        let damping = scene.resolve_damping(&body, &boundary.free_mask(body.vertex_count()))?;
        if let Some(d) = &damping {
            params.rayleigh_mass = d.rayleigh_mass;
            params.rayleigh_stiffness = d.rayleigh_stiffness;
        }
        let sim = Simulation::new(body, boundary, params, initial)?
            .with_renumbering(renumbering)
            .with_bodies(bodies)
            .with_damping(damping)
            .with_monitors(monitors)
            .with_render(render);
        match contact {
            Some(setup) => sim.with_contact(setup).map_err(|e| match &e {
                Error::Parameter { name, message } => match name
                    .strip_prefix("obstacle.")
                    .and_then(|i| i.parse::<usize>().ok())
                {
                    Some(i) => scene.error_at(&key!["obstacle", i], message),
                    None if name == "contact.distance" => {
                        scene.error_at(&key!["contact", "distance"], message)
                    }
                    // Bodies passing through each other or themselves at the start: located at
                    // [contact], which asks for the check (the bodies' placements are theirs).
                    None if name == "contact" => scene.error_at(&key!["contact"], message),
                    None => e,
                },
                _ => e,
            }),
            None => Ok(sim),
        }
    }
}

/// Lamé parameters from (E, ν) (defaults 1e5 Pa, 0.3) or (μ, λ), range-checked.
/// The inversion and recovery thresholds of a material, defaults filled in and ranges checked.
fn thresholds(
    inversion: Option<f64>,
    recovery: Option<f64>,
) -> std::result::Result<(f64, f64), String> {
    use crate::material::{DEFAULT_INVERSION_THRESHOLD, DEFAULT_RECOVERY_THRESHOLD};
    let inversion = inversion.unwrap_or(DEFAULT_INVERSION_THRESHOLD);
    if !(inversion > 0.0 && inversion <= 0.9) {
        return Err(format!(
            "inversion_threshold is a stretch in (0, 0.9] (0.1: the model is its formula down to \
             90 % compression), got {inversion}"
        ));
    }
    let recovery = recovery.unwrap_or(DEFAULT_RECOVERY_THRESHOLD);
    if !(0.0..=0.95).contains(&recovery) {
        return Err(format!(
            "recovery_threshold is a stretch in [0, 0.95] (0 turns the recovery of tangled \
             elements off), got {recovery}"
        ));
    }
    Ok((inversion, recovery))
}

fn lame_from(
    e: Option<f64>,
    nu: Option<f64>,
    mu: Option<f64>,
    lambda: Option<f64>,
) -> std::result::Result<Lame, String> {
    match (e, nu, mu, lambda) {
        (e, nu, None, None) => {
            let (e, nu) = (e.unwrap_or(1e5), nu.unwrap_or(0.3));
            if !(e > 0.0 && e.is_finite()) {
                return Err(format!("Young's modulus must be positive (Pa), got {e}"));
            }
            if !(nu > -1.0 && nu < 0.5) {
                return Err(format!(
                    "Poisson ratio must lie in (-1, 0.5), got {nu} (0.5 is incompressible: λ would be infinite)"
                ));
            }
            Ok(Lame::from_young_poisson(e, nu))
        }
        (None, None, Some(mu), Some(lambda)) => {
            if !(mu > 0.0 && mu.is_finite() && lambda.is_finite() && 3.0 * lambda + 2.0 * mu > 0.0)
            {
                return Err(format!(
                    "need μ > 0 and 3λ + 2μ > 0 (Pa), got μ = {mu}, λ = {lambda}"
                ));
            }
            Ok(Lame { mu, lambda })
        }
        _ => {
            Err("give youngs_modulus and poisson_ratio, or mu and lambda (both of one pair)".into())
        }
    }
}

/// The tets a `[[volume]]` region selects: a named group's tets, or the tets whose centroid
/// lies in a box or on/behind a plane.
fn select_tets(spec: &RegionSpec, mesh: &TetMesh) -> std::result::Result<Vec<usize>, String> {
    let centroid = |t: usize| {
        mesh.tets[t]
            .iter()
            .map(|&v| mesh.positions[v])
            .sum::<Vec3>()
            / 4.0
    };
    let tets: Vec<usize> = match spec {
        RegionSpec::Physical(name) => match mesh.group(name) {
            Some(g) if !g.tets.is_empty() => g.tets.clone(),
            Some(g) => {
                return Err(format!(
                    "group \"{}\" holds no tets (a dimension-{} group); a material needs a volume group",
                    crate::error::clip(name),
                    g.dim
                ));
            }
            None => return region(spec, None).select(mesh).map(|_| Vec::new()),
        },
        RegionSpec::Box { min, max } => (0..mesh.tets.len())
            .filter(|&t| (0..3).all(|k| centroid(t)[k] >= min[k] && centroid(t)[k] <= max[k]))
            .collect(),
        RegionSpec::Plane { point, normal } => {
            let n = Vec3::from(*normal);
            (0..mesh.tets.len())
                .filter(|&t| (centroid(t) - Vec3::from(*point)).dot(&n) >= 0.0)
                .collect()
        }
        RegionSpec::Vertices(_) => {
            return Err("a material region needs tets: use physical, box or plane".into());
        }
    };
    if tets.is_empty() {
        return Err("the region selects no tets".into());
    }
    Ok(tets)
}
