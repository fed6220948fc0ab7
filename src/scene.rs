//! The user contract (SPEC §10): a TOML scene parsed with serde into [`Scene`], with a default
//! for every key, unknown keys rejected by name, file and line, relative paths resolved against
//! the scene's folder, and values range-checked. [`Simulation::from_scene`] turns it into a
//! running simulation; the schema is not the solver's internals, so those can change freely.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::boundary::{Boundary, Constraint, Load, Motion, Region};
use crate::elastic::{ElasticBody, MaterialRegion};
use crate::error::{Error, Result};
use crate::integrator::{Integrator, OnFailure, PreconditionerKind, SolverParams};
use crate::material::{Definiteness, Lame, Model, ModelKind};
use crate::math::Vec3;
use crate::mesh::TetMesh;
use crate::mesh::generate::box_mesh;
use crate::mesh::ordering::{Renumbering, VertexOrder};
use crate::sim::{Simulation, State};

/// The built-in default scene (also `scenes/default.toml`, embedded so they never diverge).
pub const DEFAULT_SCENE: &str = include_str!("../scenes/default.toml");

/// A parsed, validated scene. Every field mirrors a TOML table or key of SPEC §10.
///
/// Defaults are per field (not `Scene::default()`, which is the built-in default *scene*).
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Gravitational acceleration, m/s². Default [0, −9.81, 0].
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// `[mesh]`.
    #[serde(default)]
    pub mesh: MeshSpec,
    /// `[material]`.
    #[serde(default)]
    pub material: MaterialSpec,
    /// `[[fixed]]`: Dirichlet conditions.
    #[serde(default)]
    pub fixed: Vec<FixedSpec>,
    /// `[[load]]`: dead loads.
    #[serde(default)]
    pub load: Vec<LoadSpec>,
    /// `[[volume]]`: other materials on parts of the mesh.
    #[serde(default)]
    pub volume: Vec<VolumeSpec>,
    /// `[initial]`.
    #[serde(default)]
    pub initial: InitialSpec,
    /// `[solver]`.
    #[serde(default)]
    pub solver: SolverSpec,
    /// `[output]`.
    #[serde(default)]
    pub output: OutputSpec,
    /// The scene file (for messages); not a TOML key.
    #[serde(skip)]
    pub path: PathBuf,
    /// The folder relative paths are resolved against; not a TOML key.
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// The scene's text, to point messages at lines; not a TOML key.
    #[serde(skip)]
    source: String,
}

fn default_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

impl Default for Scene {
    /// The built-in default scene.
    fn default() -> Self {
        Scene::parse(
            DEFAULT_SCENE,
            Path::new("<built-in default scene>"),
            Path::new("."),
        )
        .expect("the embedded default scene is valid")
    }
}

/// `[mesh]`: a file or a generator (exactly one).
#[derive(Clone, Debug, Default, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Mesh file: .msh (v2/v4), .node (+ .ele), .vtk, .vtu, .mesh; relative to the scene.
    pub file: Option<PathBuf>,
    /// Built-in generator.
    pub generator: Option<Generator>,
    /// Load a mesh the doctor finds bad (degenerate or duplicate tets, …) anyway. Default false;
    /// `tetsim run --force` sets it.
    #[serde(default)]
    pub force: bool,
    /// Internal vertex and tet numbering for memory locality (output keeps the file's):
    /// "auto" (default: a generator's order, RCM for files), "rcm", "morton", "none", or
    /// "random" (the worst case, for benchmarks).
    #[serde(default)]
    pub reorder: VertexOrder,
}

/// Built-in mesh generators.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub enum Generator {
    /// A box of `cells` cubes, each split into 6 Kuhn tets; face groups xmin … zmax.
    Box {
        /// Lower corner, m.
        min: [f64; 3],
        /// Upper corner, m.
        max: [f64; 3],
        /// Cubes along x, y, z.
        cells: [usize; 3],
    },
}

/// `[material]`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct MaterialSpec {
    /// Constitutive model: "neo-hookean" (default), "neo-hookean-clamped", "corotated",
    /// "stable-neo-hookean",
    /// "st-venant-kirchhoff", "mooney-rivlin", "linear".
    pub model: ModelKind,
    /// Young's modulus E, Pa. Default 1e5 (when neither E, ν nor μ, λ are given).
    pub youngs_modulus: Option<f64>,
    /// Poisson ratio ν, in (−1, 0.5). Default 0.3.
    pub poisson_ratio: Option<f64>,
    /// Lamé μ, Pa (instead of E, ν).
    pub mu: Option<f64>,
    /// Lamé λ, Pa (instead of E, ν).
    pub lambda: Option<f64>,
    /// Density, kg/m³. Default 1000.
    pub density: f64,
}

impl Default for MaterialSpec {
    fn default() -> Self {
        MaterialSpec {
            model: ModelKind::NeoHookean,
            youngs_modulus: None,
            poisson_ratio: None,
            mu: None,
            lambda: None,
            density: 1000.0,
        }
    }
}

/// `[[volume]]`: a material and density for part of the mesh. Keys left out take the value of
/// `[material]`; E, ν and μ, λ follow the same rules as there.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeSpec {
    /// Which tets: `{ physical = "name" }` (the tets of a Gmsh physical volume), or a `box` /
    /// `plane` region (the tets whose centroid it holds).
    pub region: RegionSpec,
    /// Constitutive model.
    pub model: Option<ModelKind>,
    /// Young's modulus, Pa.
    pub youngs_modulus: Option<f64>,
    /// Poisson ratio.
    pub poisson_ratio: Option<f64>,
    /// Lamé μ, Pa.
    pub mu: Option<f64>,
    /// Lamé λ, Pa.
    pub lambda: Option<f64>,
    /// Density, kg/m³.
    pub density: Option<f64>,
}

/// A region, as TOML writes it: `{ box = { min, max } }`, `{ plane = { point, normal } }`,
/// `{ vertices = [...] }` or `{ physical = "name" }`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub enum RegionSpec {
    /// Axis-aligned box, inclusive.
    Box {
        /// Lower corner, m.
        min: [f64; 3],
        /// Upper corner, m.
        max: [f64; 3],
    },
    /// On the plane or on the side its normal points to.
    Plane {
        /// A point on the plane, m.
        point: [f64; 3],
        /// Normal.
        normal: [f64; 3],
    },
    /// 0-based vertex indices.
    Vertices(Vec<usize>),
    /// A named mesh group (Gmsh physical group, or xmin … zmax of the box generator).
    Physical(String),
}

/// `motion = { translate, rotate_degrees, axis, center }`, reached at full ramp.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionSpec {
    /// Translation, m. Default 0.
    pub translate: [f64; 3],
    /// Rotation angle, degrees. Default 0.
    pub rotate_degrees: f64,
    /// Rotation axis. Default [1, 0, 0].
    pub axis: [f64; 3],
    /// A point on the axis, m. Default the origin.
    pub center: [f64; 3],
}

impl Default for MotionSpec {
    fn default() -> Self {
        MotionSpec {
            translate: [0.0; 3],
            rotate_degrees: 0.0,
            axis: [1.0, 0.0, 0.0],
            center: [0.0; 3],
        }
    }
}

/// A constrained component name.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Component {
    /// x
    X,
    /// y
    Y,
    /// z
    Z,
}

/// `[[fixed]]`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FixedSpec {
    /// Which vertices.
    pub region: RegionSpec,
    /// Constrained components. Default all three.
    pub components: Option<Vec<Component>>,
    /// Prescribed motion. Default: held in place.
    pub motion: Option<MotionSpec>,
    /// Ramp duration, s (backward Euler). Default: the whole run.
    pub duration: Option<f64>,
    /// Release time, s (quasistatic: load factor): after it the vertices are free. Default:
    /// never released.
    pub until: Option<f64>,
}

/// `[[load]]`: one of traction, total_force, point_force.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// Which vertices (and the boundary faces among them).
    pub region: RegionSpec,
    /// Force per unit rest area on the region's boundary faces, Pa.
    pub traction: Option<[f64; 3]>,
    /// Total force spread over the region's boundary faces by area (or its vertices), N.
    pub total_force: Option<[f64; 3]>,
    /// Force on each selected vertex, N.
    pub point_force: Option<[f64; 3]>,
    /// Ramp duration, s (backward Euler). Default: the whole run; 0: at once.
    pub duration: Option<f64>,
}

/// `[initial]`.
#[derive(Clone, Debug, Default, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitialSpec {
    /// Initial positions: a text file of one "x y z" line per vertex (same count and order as
    /// the mesh); relative to the scene. Default: the rest positions.
    pub positions: Option<PathBuf>,
    /// Initial velocity of every free vertex, m/s. Default 0.
    pub velocity: [f64; 3],
}

/// `[solver]`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSpec {
    /// "backward-euler" (default) or "quasistatic".
    pub integrator: IntegratorName,
    /// Seconds per frame. Default 1/30.
    pub dt: f64,
    /// Frames (backward Euler) or load steps (quasistatic). Default 60.
    pub frames: usize,
    /// Time steps per frame. Default 1.
    pub substeps: usize,
    /// Rayleigh stiffness damping γ, s. Default 0.
    pub rayleigh_stiffness: f64,
    /// Rayleigh mass damping α, 1/s. Default 0.
    pub rayleigh_mass: f64,
    /// Newton tolerance relative to the step's first residual. Default 1e-6.
    pub newton_tolerance: f64,
    /// Newton iterations per step. Default 20.
    pub newton_max_iterations: usize,
    /// CG tolerance relative to the right-hand side. Default 1e-6.
    pub cg_tolerance: f64,
    /// CG iterations per solve. Default 2000.
    pub cg_max_iterations: usize,
    /// "teran" (default; alias "projected"), "analytic", "abs" or "none" (alias "exact").
    pub definiteness: Definiteness,
    /// "amg" (default), "jacobi", "block-jacobi", "none", or "cholesky" (built with
    /// `--features direct`).
    pub preconditioner: PreconditionerName,
    /// Backtracking line search. Default true.
    pub line_search: bool,
    /// Inexact Newton (CG only as tight as the Newton target needs). Default true.
    pub inexact_newton: bool,
    /// Assembled matrix CG multiplies with (AMG path): false f64 full, true f32 upper triangle.
    pub f32_matrix: bool,
    /// "cholesky": keep the factor while CG converges fast (default true) or factor at every
    /// Newton iterate (false).
    pub cholesky_reuse: bool,
    /// "retry" (default), "continue" or "stop".
    pub on_failure: OnFailureName,
    /// Step halvings allowed by "retry". Default 4.
    pub max_step_cuts: usize,
}

impl Default for SolverSpec {
    fn default() -> Self {
        let p = SolverParams::default();
        SolverSpec {
            integrator: IntegratorName::BackwardEuler,
            dt: p.dt,
            frames: p.frames,
            substeps: p.substeps,
            rayleigh_stiffness: p.rayleigh_stiffness,
            rayleigh_mass: p.rayleigh_mass,
            newton_tolerance: p.newton_tolerance,
            newton_max_iterations: p.newton_max_iterations,
            cg_tolerance: p.cg.tolerance,
            cg_max_iterations: p.cg.max_iterations,
            definiteness: p.definiteness,
            preconditioner: PreconditionerName::Amg,
            line_search: p.line_search,
            inexact_newton: p.inexact_newton,
            f32_matrix: p.f32_matrix,
            cholesky_reuse: p.cholesky_reuse,
            on_failure: OnFailureName::Retry,
            max_step_cuts: p.max_step_cuts,
        }
    }
}

/// Scene names of the integrators.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorName {
    /// Backward Euler.
    #[default]
    BackwardEuler,
    /// Quasistatic.
    Quasistatic,
}

/// Scene names of the preconditioners.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PreconditionerName {
    /// Jacobi.
    Jacobi,
    /// Block Jacobi.
    BlockJacobi,
    /// None.
    None,
    /// Smoothed-aggregation algebraic multigrid on the assembled system.
    #[default]
    Amg,
    /// Sparse Cholesky of the assembled system (only in builds with the `direct` feature; the
    /// scene is rejected otherwise).
    Cholesky,
}

/// Scene names of the failure policies.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OnFailureName {
    /// Retry with smaller steps, then continue.
    #[default]
    Retry,
    /// Continue.
    Continue,
    /// Stop.
    Stop,
}

/// `[output]`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    /// Output folder, relative to the working directory. Default "out".
    pub dir: PathBuf,
    /// Write a surface OBJ per frame. Default true.
    pub obj: bool,
    /// Render `preview.png` (last frame) and `animation.gif` after the run. Default true.
    pub pictures: bool,
    /// Plot steps.csv into `steps_*.png` after the run. Default true.
    pub plots: bool,
    /// Colour field of the pictures: "displacement" (default), "J", "von-mises",
    /// "energy-density" or "none".
    pub field: String,
    /// Size of `preview.png` in pixels. Default 800 × 600.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// Size of the GIF frames in pixels. Default 480 × 360.
    pub gif_width: u32,
    /// See `gif_width`.
    pub gif_height: u32,
    /// Every k-th frame goes into the GIF (the last frame always does). Default 1.
    pub gif_stride: usize,
    /// Camera azimuth about the up (+y) axis, degrees. Default −35.
    pub azimuth: f64,
    /// Camera elevation above the horizon, degrees. Default 22.
    pub elevation: f64,
    /// Write 0 in steps.csv's wall_seconds column, so that every output file is byte-identical
    /// across runs and thread counts (the times go to timings.csv either way). Default false.
    pub deterministic: bool,
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            dir: PathBuf::from("out"),
            obj: true,
            pictures: true,
            plots: true,
            field: "displacement".into(),
            width: 800,
            height: 600,
            gif_width: 480,
            gif_height: 360,
            gif_stride: 1,
            azimuth: -35.0,
            elevation: 22.0,
            deterministic: false,
        }
    }
}

impl Scene {
    /// Read and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::parse(&text, path, &base)
    }

    /// Parse and validate scene text; `path` names it in messages, `base_dir` resolves paths.
    pub fn parse(text: &str, path: &Path, base_dir: &Path) -> Result<Scene> {
        let mut scene: Scene = toml::from_str(text).map_err(|e| {
            let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
            Error::Scene {
                path: path.to_path_buf(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        scene.path = path.to_path_buf();
        scene.base_dir = base_dir.to_path_buf();
        scene.source = text.to_string();
        scene.validate(text)?;
        Ok(scene)
    }

    /// Range checks with the key's line in the message.
    fn validate(&self, text: &str) -> Result<()> {
        let fail = |table: &str, key: &str, message: String| {
            let line = locate_key(text, table, key).unwrap_or(1);
            Err(Error::Scene {
                path: self.path.clone(),
                line,
                column: 1,
                message: format!("{table}.{key}: {message}"),
            })
        };
        let m = &self.material;
        if let Err(message) = self.lame() {
            let key = if m.mu.is_some() || m.lambda.is_some() {
                "mu"
            } else {
                "poisson_ratio"
            };
            let key = if message.contains("Young") {
                "youngs_modulus"
            } else {
                key
            };
            return fail("material", key, message);
        }
        if !(m.density > 0.0 && m.density.is_finite()) {
            return fail(
                "material",
                "density",
                format!("must be positive (kg/m³), got {}", m.density),
            );
        }
        match (&self.mesh.file, &self.mesh.generator) {
            (Some(_), Some(_)) => {
                return fail(
                    "mesh",
                    "file",
                    "give either file or generator, not both".into(),
                );
            }
            (None, None) => return fail("mesh", "file", "give a mesh file or a generator".into()),
            (None, Some(Generator::Box { min, max, cells }))
                if cells.contains(&0) || (0..3).any(|k| max[k] <= min[k] || max[k].is_nan()) =>
            {
                return fail(
                    "mesh",
                    "generator",
                    "box needs max > min and at least one cell per axis".into(),
                );
            }
            _ => {}
        }
        for (i, fixed) in self.fixed.iter().enumerate() {
            let bad = |v: Option<f64>| v.is_some_and(|v| !(v >= 0.0 && v.is_finite()));
            if bad(fixed.until) || bad(fixed.duration) {
                return Err(Error::Scene {
                    path: self.path.clone(),
                    line: nth_table_line(text, "fixed", i).unwrap_or(1),
                    column: 1,
                    message: format!(
                        "[[fixed]] #{}: duration and until must be zero or positive (s)",
                        i + 1
                    ),
                });
            }
        }
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err(Error::Scene {
                path: self.path.clone(),
                line: 1,
                column: 1,
                message: "gravity must be finite (m/s²)".into(),
            });
        }
        for (i, load) in self.load.iter().enumerate() {
            let given = [
                load.traction.is_some(),
                load.total_force.is_some(),
                load.point_force.is_some(),
            ];
            if given.iter().filter(|&&g| g).count() != 1 {
                let line = nth_table_line(text, "load", i).unwrap_or(1);
                return Err(Error::Scene {
                    path: self.path.clone(),
                    line,
                    column: 1,
                    message:
                        "each [[load]] needs exactly one of traction, total_force, point_force"
                            .into(),
                });
            }
        }
        let s = &self.solver;
        if !(s.dt > 0.0 && s.dt.is_finite()) {
            return fail(
                "solver",
                "dt",
                format!("must be positive (s), got {}", s.dt),
            );
        }
        if s.frames == 0 {
            return fail("solver", "frames", "must be at least 1".into());
        }
        if s.preconditioner == PreconditionerName::Cholesky && !cfg!(feature = "direct") {
            return fail(
                "solver",
                "preconditioner",
                "\"cholesky\" needs the sparse direct solver, which this tetsim was built \
                 without: rebuild with `cargo build --release --features direct`"
                    .into(),
            );
        }
        let o = &self.output;
        if let Some(Err(e)) =
            (o.field != "none").then(|| o.field.parse::<crate::field::FieldKind>())
        {
            return fail("output", "field", e.to_string());
        }
        for (key, value) in [
            ("width", o.width),
            ("height", o.height),
            ("gif_width", o.gif_width),
            ("gif_height", o.gif_height),
        ] {
            if !(16..=8192).contains(&value) {
                return fail(
                    "output",
                    key,
                    format!("must be between 16 and 8192 pixels, got {value}"),
                );
            }
        }
        if o.gif_stride == 0 {
            return fail("output", "gif_stride", "must be at least 1".into());
        }
        Ok(())
    }

    /// Lamé parameters from (E, ν) or (μ, λ), with the range checks of each.
    pub fn lame(&self) -> std::result::Result<Lame, String> {
        let m = &self.material;
        lame_from(m.youngs_modulus, m.poisson_ratio, m.mu, m.lambda)
    }

    /// Model and density of the i-th `[[volume]]`, with `[material]`'s values where it is silent.
    pub fn volume_material(&self, i: usize) -> std::result::Result<(Model, f64), String> {
        let v = &self.volume[i];
        let m = &self.material;
        let own = v.youngs_modulus.is_some()
            || v.poisson_ratio.is_some()
            || v.mu.is_some()
            || v.lambda.is_some();
        let lame = if own {
            lame_from(v.youngs_modulus, v.poisson_ratio, v.mu, v.lambda)?
        } else {
            self.lame()?
        };
        let density = v.density.unwrap_or(m.density);
        if !(density > 0.0 && density.is_finite()) {
            return Err(format!("density must be positive (kg/m³), got {density}"));
        }
        Ok((Model::new(v.model.unwrap_or(m.model), lame), density))
    }

    /// The scene's TOML text (the embedded text for the built-in default scene).
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Resolve a scene-relative path.
    pub fn resolve(&self, path: &Path) -> PathBuf {
        if path.is_absolute() {
            path.to_path_buf()
        } else {
            self.base_dir.join(path)
        }
    }

    /// Build the mesh: read the file or run the generator.
    pub fn build_mesh(&self) -> Result<TetMesh> {
        match (&self.mesh.file, &self.mesh.generator) {
            (Some(file), _) => {
                let path = self.resolve(file);
                let read = crate::io::read_mesh_with(
                    &path,
                    crate::io::ReadOptions {
                        force: self.mesh.force,
                    },
                )?;
                log::info!(
                    "{}: {}",
                    path.display(),
                    read.report.to_string().trim_end().replace('\n', "; ")
                );
                for (severity, problem) in read.diagnosis.problems() {
                    log::warn!("{}: {severity:?}: {problem}", path.display());
                }
                Ok(read.mesh)
            }
            (None, Some(Generator::Box { min, max, cells })) => {
                Ok(box_mesh(Vec3::from(*min), Vec3::from(*max), *cells))
            }
            (None, None) => Err(Error::parameter("mesh", "give a mesh file or a generator")),
        }
    }

    /// The solver settings.
    pub fn solver_params(&self) -> SolverParams {
        let s = &self.solver;
        SolverParams {
            integrator: match s.integrator {
                IntegratorName::BackwardEuler => Integrator::BackwardEuler,
                IntegratorName::Quasistatic => Integrator::Quasistatic,
            },
            dt: s.dt,
            frames: s.frames,
            substeps: s.substeps,
            rayleigh_stiffness: s.rayleigh_stiffness,
            rayleigh_mass: s.rayleigh_mass,
            newton_tolerance: s.newton_tolerance,
            newton_max_iterations: s.newton_max_iterations,
            cg: crate::cg::CgParams {
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
            amg: crate::amg::AmgParams::default(),
            line_search: s.line_search,
            inexact_newton: s.inexact_newton,
            f32_matrix: s.f32_matrix,
            cholesky_reuse: s.cholesky_reuse,
            on_failure: match s.on_failure {
                OnFailureName::Retry => OnFailure::Retry,
                OnFailureName::Continue => OnFailure::Continue,
                OnFailureName::Stop => OnFailure::Stop,
            },
            max_step_cuts: s.max_step_cuts,
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
        let region_error = |what: &str, i: usize, message: String| Error::Scene {
            path: self.path.clone(),
            line: nth_table_line(&self.source, what, i).unwrap_or(1),
            column: 1,
            message: format!("[[{what}]] #{}: {message}", i + 1),
        };
        let mut boundary = Boundary {
            gravity: Vec3::from(self.gravity),
            ..Default::default()
        };
        for (i, fixed) in self.fixed.iter().enumerate() {
            let vertices = region(&fixed.region, renumbering)
                .select(mesh)
                .map_err(|m| region_error("fixed", i, m))?;
            let mut components = [true; 3];
            if let Some(list) = &fixed.components {
                components = [false; 3];
                for c in list {
                    components[*c as usize] = true;
                }
            }
            let motion = fixed.motion.as_ref().map_or(Motion::default(), |m| Motion {
                translate: Vec3::from(m.translate),
                rotate_degrees: m.rotate_degrees,
                axis: Vec3::from(m.axis),
                center: Vec3::from(m.center),
            });
            boundary.constraints.push(Constraint {
                vertices,
                components,
                motion,
                duration: fixed.duration,
                until: fixed.until,
            });
        }
        for (i, spec) in self.load.iter().enumerate() {
            let vertices = region(&spec.region, renumbering)
                .select(mesh)
                .map_err(|m| region_error("load", i, m))?;
            let mut load = if let Some(t) = spec.traction {
                Load::traction(mesh, &vertices, Vec3::from(t))
                    .map_err(|m| region_error("load", i, m))?
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
        let mut state = Simulation::rest_state(body);
        if let Some(file) = &self.initial.positions {
            let x = crate::io::read_positions(&self.resolve(file), body.vertex_count())?;
            state.x = match renumbering {
                Some(r) => r.to_new(&x),
                None => x,
            };
        }
        state
            .v
            .iter_mut()
            .for_each(|v| *v = Vec3::from(self.initial.velocity));
        Ok(state)
    }
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
        let file_mesh = scene.build_mesh()?;
        let order = match scene.mesh.reorder {
            // A generator's lattice order is already local (see `mesh::ordering`).
            VertexOrder::Auto if scene.mesh.generator.is_some() => VertexOrder::None,
            order => order,
        };
        let renumbering = Renumbering::new(&file_mesh, order);
        let mesh = match &renumbering {
            Some(r) => r.apply(&file_mesh),
            None => file_mesh,
        };
        let lame = scene.lame().map_err(|m| Error::parameter("material", m))?;
        let model = Model::new(scene.material.model, lame);
        let mesh_path = scene.mesh.file.as_ref().map(|f| scene.resolve(f));
        let mut regions = Vec::with_capacity(scene.volume.len());
        for (i, volume) in scene.volume.iter().enumerate() {
            let located = |message: String| Error::Scene {
                path: scene.path.clone(),
                line: nth_table_line(&scene.source, "volume", i).unwrap_or(1),
                column: 1,
                message: format!("[[volume]] #{}: {message}", i + 1),
            };
            let (model, density) = scene.volume_material(i).map_err(located)?;
            let tets = select_tets(&volume.region, &mesh).map_err(located)?;
            regions.push(MaterialRegion {
                model,
                density,
                tets,
            });
        }
        let body = ElasticBody::with_regions(mesh, model, scene.material.density, regions)
            .map_err(|e| match e {
                Error::Mesh { problem, .. } => Error::Mesh {
                    path: mesh_path.clone(),
                    problem,
                },
                other => other,
            })?;
        let boundary = scene.build_boundary_renumbered(&body.mesh, renumbering.as_ref())?;
        let initial = scene.initial_state_renumbered(&body, renumbering.as_ref())?;
        Ok(
            Simulation::new(body, boundary, scene.solver_params(), initial)?
                .with_renumbering(renumbering),
        )
    }
}

/// Lamé parameters from (E, ν) (defaults 1e5 Pa, 0.3) or (μ, λ), range-checked.
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
                    "group \"{name}\" holds no tets (a dimension-{} group); a material needs a volume group",
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

/// 1-based line and column of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before
        .rfind('\n')
        .map_or(before.len(), |nl| before.len() - nl - 1)
        + 1;
    (line, column)
}

/// The line of `key = ...` inside `[table]` (first match), for messages about values.
fn locate_key(text: &str, table: &str, key: &str) -> Option<usize> {
    let mut in_table = false;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.starts_with('[') {
            in_table = trimmed.trim_matches(['[', ']']).trim() == table;
            continue;
        }
        if in_table && trimmed.split('=').next().map(str::trim) == Some(key) {
            return Some(i + 1);
        }
    }
    None
}

/// The line of the `n`-th `[[table]]` header.
fn nth_table_line(text: &str, table: &str, n: usize) -> Option<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| {
            l.trim().trim_matches(['[', ']']).trim() == table && l.trim().starts_with("[[")
        })
        .nth(n)
        .map(|(i, _)| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_scene_parses() {
        let scene = Scene::default();
        assert!(scene.mesh.generator.is_some());
        assert_eq!(scene.material.model, ModelKind::NeoHookean);
    }

    #[test]
    fn unknown_key_is_named_with_its_line() {
        let text = "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n\n[solver]\ndt = 0.1\nfrobnicate = 3\n";
        let err = Scene::parse(text, Path::new("s.toml"), Path::new(".")).unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with("s.toml:6:"), "{msg}");
        assert!(msg.contains("frobnicate"), "{msg}");
    }

    #[test]
    fn bad_values_are_located() {
        let text = "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n[material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.5\n";
        let msg = Scene::parse(text, Path::new("s.toml"), Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("s.toml:5:") && msg.contains("Poisson"),
            "{msg}"
        );
        let text = "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n[material]\ndensity = -3\n";
        let msg = Scene::parse(text, Path::new("s.toml"), Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("s.toml:4:") && msg.contains("density"),
            "{msg}"
        );
    }
}
