//! The scene schema: the serde structs and enums a scene file deserializes into, one per TOML
//! table, with a default for every key and unknown keys rejected (`deny_unknown_fields`).
//! Value ranges are checked by `validate`, not here; `docs/scene-reference.md` lists every key.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::integrator::{MatrixPrecision, SolverParams};
use crate::material::{DampingStiffness, Definiteness, ModelKind};
use crate::mesh::ordering::VertexOrder;

use super::units;

mod output;
pub use output::OutputSpec;

/// A parsed, validated scene. Every field mirrors a TOML table or key of SPEC §10.
///
/// Defaults are per field (not `Scene::default()`, which is the built-in default *scene*).
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Gravitational acceleration, m/s². Default [0, −9.81, 0].
    #[serde(default = "default_gravity")]
    #[serde(deserialize_with = "units::three::<_, units::Acceleration>")]
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
    /// `[[body]]`: more deformable bodies (SPEC §11); any of them turns contact on. Left out of
    /// the manifest's parameters when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub body: Vec<BodySpec>,
    /// `[[obstacle]]`: rigid obstacles (SPEC §11); any of them turns contact on. Left out of
    /// the manifest's parameters when empty, so scenes without contact keep their bytes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub obstacle: Vec<ObstacleEntry>,
    /// `[contact]`: contact settings (SPEC §11); the table alone turns contact on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactSpec>,
    /// `[[probe]]`: points whose displacement goes to probes.csv every frame (SPEC §13). Left
    /// out of the manifest's parameters when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probe: Vec<ProbeSpec>,
    /// The scene file (for messages); not a TOML key.
    #[serde(skip)]
    pub path: PathBuf,
    /// The folder relative paths are resolved against; not a TOML key.
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// The scene's text, to point messages at lines; not a TOML key.
    #[serde(skip)]
    pub(crate) source: String,
}

/// Exactly three entries: serde's arrays read the first three and ignore the rest, so
/// `gravity = [0, -9.81, 0, 500]` would silently lose its fourth.
fn three<'de, D, T>(d: D) -> Result<[T; 3], D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v: Vec<T> = Vec::deserialize(d)?;
    let n = v.len();
    <[T; 3]>::try_from(v)
        .map_err(|_| serde::de::Error::invalid_length(n, &"exactly 3 entries [x, y, z]"))
}

fn default_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}

fn one() -> f64 {
    1.0
}

fn z_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// `[[body]]`: another deformable body, with its own mesh, material, placement and velocity.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Name in messages, outputs and `body = "..."` keys. Default "body1", "body2", ...
    pub name: Option<String>,
    /// Its mesh: the keys of `[mesh]` (a file or a generator).
    pub mesh: MeshSpec,
    /// Its material: the keys of `[material]`.
    #[serde(default)]
    pub material: MaterialSpec,
    /// Scale of the rest mesh about the origin (a change of units), > 0. Default 1.
    #[serde(default = "one", deserialize_with = "units::scalar::<_, units::Ratio>")]
    pub scale: f64,
    /// Rotation of the (scaled) rest mesh about `axis` through its centroid, degrees.
    #[serde(default, deserialize_with = "units::scalar::<_, units::Degrees>")]
    pub rotate_degrees: f64,
    /// Rotation axis. Default [0, 0, 1].
    #[serde(
        default = "z_axis",
        deserialize_with = "units::three::<_, units::Ratio>"
    )]
    pub axis: [f64; 3],
    /// Translation after scaling and rotating, m.
    #[serde(default, deserialize_with = "units::three::<_, units::Length>")]
    pub translate: [f64; 3],
    /// Initial velocity of its free vertices, m/s.
    #[serde(default, deserialize_with = "units::three::<_, units::Velocity>")]
    pub velocity: [f64; 3],
    /// A detailed surface (.obj) embedded in the body's tets and written deformed every frame
    /// (`render_NNNN.obj`, `render.glb`); relative to the scene, in the mesh's unit, placed
    /// with the body. Same as `mesh = { render = ... }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render: Option<PathBuf>,
}

/// `[mesh]`: a file, a generator or a surface to fill with tets (exactly one).
#[derive(Clone, Debug, Default, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Mesh file: .msh (v2/v4), .node (+ .ele), .vtk, .vtu, .mesh; relative to the scene.
    pub file: Option<PathBuf>,
    /// Built-in generator.
    pub generator: Option<Generator>,
    /// A closed triangle surface (.obj, .stl, .ply; relative to the scene) filled with tets at
    /// load by isosurface stuffing, at lattice spacing `size`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<PathBuf>,
    /// Lattice spacing for `surface`, m (or with a unit: "5 mm"): the tets' edge length inside.
    /// Required with `surface`.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "units::optional::<_, units::Length>"
    )]
    pub size: Option<f64>,
    /// Load a mesh the doctor finds bad (degenerate or duplicate tets, …) anyway. Default false;
    /// `tetsim run --force` sets it.
    #[serde(default)]
    pub force: bool,
    /// Internal vertex and tet numbering for memory locality (output keeps the file's):
    /// "auto" (default: a generator's order, RCM for files), "rcm", "morton", "none", or
    /// "random" (the worst case, for benchmarks).
    #[serde(default)]
    pub reorder: VertexOrder,
    /// Element order: 1 (linear tets, the default) or 2 (quadratic tets: a node on every edge,
    /// elements that bend without locking). A mesh file of 10-node tets is quadratic whatever
    /// this says. Top-level `[mesh]` only: it applies to every body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<u8>,
    /// The body's name in messages, outputs and `body = "..."` keys (top-level `[mesh]` only).
    /// Default "body0".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The length unit of the mesh file's coordinates (and, for the top-level `[mesh]`, of
    /// `[initial] positions`): "mm", "cm", "µm", "m", … (see `units`). Default: metres.
    /// Outputs stay SI. A generator's `min` and `max` take units in their own values instead.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// A detailed surface (.obj) embedded in the body's tets: each vertex bound to the rest tet
    /// that holds it, moved with it, written every frame (`render_NNNN.obj`) and into one
    /// animation (`render.glb`), and drawn in the pictures instead of the tets' boundary.
    /// Relative to the scene; in the mesh file's unit; placed with the body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render: Option<PathBuf>,
}

impl MeshSpec {
    /// The element order asked for: 1 (the default) or 2.
    pub fn element_order(&self) -> u8 {
        self.order.unwrap_or(1)
    }
}

/// `[[probe]]`: a rest position whose displacement (interpolated linearly in the tet holding
/// it) goes to probes.csv as `<name>_x,<name>_y,<name>_z` every frame.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    /// The column prefix: letters, digits, `_`, `-`, `.`; unique among the probes.
    pub name: String,
    /// The point at rest (after the bodies are placed), m.
    #[serde(deserialize_with = "units::three::<_, units::Length>")]
    pub point: [f64; 3],
    /// Only look in this body (its `[[body]] name` or `[mesh] name`). Default: every body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<String>,
}

/// Built-in mesh generators.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub enum Generator {
    /// A box of `cells` cubes, each split into 6 Kuhn tets; face groups xmin … zmax.
    Box {
        /// Lower corner, m.
        #[serde(deserialize_with = "units::three::<_, units::Length>")]
        min: [f64; 3],
        /// Upper corner, m.
        #[serde(deserialize_with = "units::three::<_, units::Length>")]
        max: [f64; 3],
        /// Cubes along x, y, z.
        #[serde(deserialize_with = "three")]
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
    #[serde(deserialize_with = "units::optional::<_, units::Pressure>")]
    pub youngs_modulus: Option<f64>,
    /// Poisson ratio ν, in (−1, 0.5). Default 0.3.
    #[serde(deserialize_with = "units::optional::<_, units::Ratio>")]
    pub poisson_ratio: Option<f64>,
    /// Lamé μ, Pa (instead of E, ν).
    #[serde(deserialize_with = "units::optional::<_, units::Pressure>")]
    pub mu: Option<f64>,
    /// Lamé λ, Pa (instead of E, ν).
    #[serde(deserialize_with = "units::optional::<_, units::Pressure>")]
    pub lambda: Option<f64>,
    /// Density, kg/m³. Default 1000.
    #[serde(deserialize_with = "units::scalar::<_, units::Density>")]
    pub density: f64,
    /// The stretch (unit-free, in (0, 0.9]) below which the model's inversion extension acts:
    /// the model is exactly its formula wherever every principal stretch is at least this.
    /// Default 0.1 (90 % compression along one axis). Models without an extension ignore it.
    #[serde(
        deserialize_with = "units::optional::<_, units::Ratio>",
        skip_serializing_if = "Option::is_none"
    )]
    pub inversion_threshold: Option<f64>,
    /// The stretch (unit-free, in [0, 0.95]) below which a *tangled* element (inverted, or in a
    /// body that overlaps itself) is evaluated with Irving's clamp until the body is untangled;
    /// 0 turns this recovery off. Default 0.6.
    #[serde(
        deserialize_with = "units::optional::<_, units::Ratio>",
        skip_serializing_if = "Option::is_none"
    )]
    pub recovery_threshold: Option<f64>,
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
            inversion_threshold: None,
            recovery_threshold: None,
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
    /// Only this body's part (its `[[body]] name` or `[mesh] name`). Default: every body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<String>,
    /// Constitutive model.
    pub model: Option<ModelKind>,
    /// Young's modulus, Pa.
    #[serde(default, deserialize_with = "units::optional::<_, units::Pressure>")]
    pub youngs_modulus: Option<f64>,
    /// Poisson ratio.
    #[serde(default, deserialize_with = "units::optional::<_, units::Ratio>")]
    pub poisson_ratio: Option<f64>,
    /// Lamé μ, Pa.
    #[serde(default, deserialize_with = "units::optional::<_, units::Pressure>")]
    pub mu: Option<f64>,
    /// Lamé λ, Pa.
    #[serde(default, deserialize_with = "units::optional::<_, units::Pressure>")]
    pub lambda: Option<f64>,
    /// Density, kg/m³.
    #[serde(default, deserialize_with = "units::optional::<_, units::Density>")]
    pub density: Option<f64>,
    /// The inversion threshold (see `[material]`).
    #[serde(
        default,
        deserialize_with = "units::optional::<_, units::Ratio>",
        skip_serializing_if = "Option::is_none"
    )]
    pub inversion_threshold: Option<f64>,
    /// The recovery threshold (see `[material]`).
    #[serde(
        default,
        deserialize_with = "units::optional::<_, units::Ratio>",
        skip_serializing_if = "Option::is_none"
    )]
    pub recovery_threshold: Option<f64>,
}

/// A region, as TOML writes it: `{ box = { min, max } }`, `{ plane = { point, normal } }`,
/// `{ vertices = [...] }` or `{ physical = "name" }`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub enum RegionSpec {
    /// Axis-aligned box, inclusive.
    Box {
        /// Lower corner, m.
        #[serde(deserialize_with = "units::three::<_, units::Length>")]
        min: [f64; 3],
        /// Upper corner, m.
        #[serde(deserialize_with = "units::three::<_, units::Length>")]
        max: [f64; 3],
    },
    /// On the plane or on the side its normal points to.
    Plane {
        /// A point on the plane, m.
        #[serde(deserialize_with = "units::three::<_, units::Length>")]
        point: [f64; 3],
        /// Normal.
        #[serde(deserialize_with = "units::three::<_, units::Ratio>")]
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
    #[serde(deserialize_with = "units::three::<_, units::Length>")]
    pub translate: [f64; 3],
    /// Rotation angle, degrees. Default 0.
    #[serde(deserialize_with = "units::scalar::<_, units::Degrees>")]
    pub rotate_degrees: f64,
    /// Rotation axis. Default [1, 0, 0].
    #[serde(deserialize_with = "units::three::<_, units::Ratio>")]
    pub axis: [f64; 3],
    /// A point on the axis, m. Default the origin.
    #[serde(deserialize_with = "units::three::<_, units::Length>")]
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

/// `[[obstacle]]`: a rigid obstacle as the scene writes it, exactly one shape key (`plane`,
/// `box`, `sphere`, `mesh`); [`Scene::contact_setup`] makes a [`crate::contact::ObstacleSpec`] of it.
#[derive(Clone, Debug, Default, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleEntry {
    /// Name in messages. Default "obstacle N" (1-based, in file order).
    pub name: Option<String>,
    /// A plane; the normal points to the free side.
    pub plane: Option<PlaneSpec>,
    /// An axis-aligned box; bodies stay outside.
    #[serde(rename = "box")]
    pub cuboid: Option<BoxSpec>,
    /// A ball; bodies stay outside.
    pub sphere: Option<SphereSpec>,
    /// A triangle surface file relative to the scene: `.obj`, `.stl`, or a tet mesh file
    /// (its boundary).
    pub mesh: Option<PathBuf>,
    /// Coulomb coefficient against this obstacle, ≥ 0. Default `[contact] friction`.
    #[serde(default, deserialize_with = "units::optional::<_, units::Ratio>")]
    pub friction: Option<f64>,
    /// Scripted rigid motion, as for `[[fixed]]`. Default: at rest.
    pub motion: Option<MotionSpec>,
    /// Ramp duration of the motion, s (backward Euler). Default: the whole run.
    #[serde(default, deserialize_with = "units::optional::<_, units::Time>")]
    pub duration: Option<f64>,
}

/// `plane = { point, normal }` of an obstacle.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneSpec {
    /// A point on the plane, m.
    #[serde(deserialize_with = "units::three::<_, units::Length>")]
    pub point: [f64; 3],
    /// The normal (any non-zero length), towards the side bodies live on.
    #[serde(deserialize_with = "units::three::<_, units::Ratio>")]
    pub normal: [f64; 3],
}

/// `box = { min, max }` of an obstacle.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Lower corner, m.
    #[serde(deserialize_with = "units::three::<_, units::Length>")]
    pub min: [f64; 3],
    /// Upper corner, m.
    #[serde(deserialize_with = "units::three::<_, units::Length>")]
    pub max: [f64; 3],
}

/// `sphere = { center, radius }` of an obstacle.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Center, m.
    #[serde(deserialize_with = "units::three::<_, units::Length>")]
    pub center: [f64; 3],
    /// Radius, m (> 0).
    #[serde(deserialize_with = "units::scalar::<_, units::Length>")]
    pub radius: f64,
}

/// `[contact]`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ContactSpec {
    /// d̂, m (> 0): the gap below which contact acts. Default: 1e-3 × the scene's bounding-box
    /// diagonal.
    #[serde(deserialize_with = "units::optional::<_, units::Length>")]
    pub distance: Option<f64>,
    /// Coulomb coefficient between bodies and for obstacles without their own, ≥ 0. Default 0.
    #[serde(deserialize_with = "units::scalar::<_, units::Ratio>")]
    pub friction: f64,
    /// Self-contact inside each body. Default true.
    #[serde(rename = "self")]
    pub self_contact: bool,
}

impl Default for ContactSpec {
    fn default() -> Self {
        ContactSpec {
            distance: None,
            friction: 0.0,
            self_contact: true,
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
    /// A name: the constraint's total reaction force on the body (N) goes to reactions.csv as
    /// `<name>_fx,<name>_fy,<name>_fz` every frame. Unique among the `[[fixed]]` entries.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Which vertices.
    pub region: RegionSpec,
    /// Only this body's part (its `[[body]] name` or `[mesh] name`). Default: every body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<String>,
    /// Constrained components. Default all three.
    pub components: Option<Vec<Component>>,
    /// Prescribed motion. Default: held in place.
    pub motion: Option<MotionSpec>,
    /// Ramp duration, s (backward Euler). Default: the whole run.
    #[serde(default, deserialize_with = "units::optional::<_, units::Time>")]
    pub duration: Option<f64>,
    /// Release time, s (quasistatic: load factor): after it the vertices are free. Default:
    /// never released.
    #[serde(default, deserialize_with = "units::optional::<_, units::Time>")]
    pub until: Option<f64>,
}

/// `[[load]]`: one of traction, total_force, point_force.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// Which vertices (and the boundary faces among them).
    pub region: RegionSpec,
    /// Only this body's part (its `[[body]] name` or `[mesh] name`). Default: every body.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body: Option<String>,
    /// Force per unit rest area on the region's boundary faces, Pa.
    #[serde(
        default,
        deserialize_with = "units::optional_three::<_, units::Pressure>"
    )]
    pub traction: Option<[f64; 3]>,
    /// Total force spread over the region's boundary faces by area (or its vertices), N.
    #[serde(default, deserialize_with = "units::optional_three::<_, units::Force>")]
    pub total_force: Option<[f64; 3]>,
    /// Force on each selected vertex, N.
    #[serde(default, deserialize_with = "units::optional_three::<_, units::Force>")]
    pub point_force: Option<[f64; 3]>,
    /// Ramp duration, s (backward Euler). Default: the whole run; 0: at once.
    #[serde(default, deserialize_with = "units::optional::<_, units::Time>")]
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
    #[serde(deserialize_with = "units::three::<_, units::Velocity>")]
    pub velocity: [f64; 3],
}

/// `[solver]`.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSpec {
    /// "backward-euler" (default), "bdf2", "newmark" or "quasistatic".
    pub integrator: IntegratorName,
    /// Newmark's β (with `integrator = "newmark"`), in [γ/2, 1]. Default 0.25.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "units::optional::<_, units::Ratio>"
    )]
    pub newmark_beta: Option<f64>,
    /// Newmark's γ (with `integrator = "newmark"`), in [0.5, 1]. Default 0.5.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "units::optional::<_, units::Ratio>"
    )]
    pub newmark_gamma: Option<f64>,
    /// Seconds per frame. Default 1/30.
    #[serde(deserialize_with = "units::scalar::<_, units::Time>")]
    pub dt: f64,
    /// Frames (dynamic) or load steps (quasistatic). Default 60.
    pub frames: usize,
    /// Time steps per frame. Default 1.
    pub substeps: usize,
    /// Rayleigh stiffness damping γ, s. Default 0.
    #[serde(deserialize_with = "units::scalar::<_, units::Time>")]
    pub rayleigh_stiffness: f64,
    /// Rayleigh mass damping α, 1/s. Default 0.
    #[serde(deserialize_with = "units::scalar::<_, units::Frequency>")]
    pub rayleigh_mass: f64,
    /// Damping ratio ζ (SPEC §13): sets `rayleigh_mass` and `rayleigh_stiffness` so that
    /// motion at both `damping_frequencies` is damped by ζ. Default: none.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "units::optional::<_, units::Ratio>"
    )]
    pub damping_ratio: Option<f64>,
    /// f₁ < f₂ (Hz) where the damping ratio holds exactly. Default: the body's lowest elastic
    /// mode and ten times its frequency.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "units::optional_two::<_, units::Frequency>"
    )]
    pub damping_frequencies: Option<[f64; 2]>,
    /// The K of the stiffness damping force: "projected" (default) or "exact". Left out of
    /// manifests when default.
    #[serde(skip_serializing_if = "DampingStiffness::is_default")]
    pub damping_stiffness: DampingStiffness,
    /// Newton's treatment of the damping force's ∂K/∂x: "shifted" (default) or "frozen".
    #[serde(skip_serializing_if = "DampingTangentName::is_default")]
    pub damping_tangent: DampingTangentName,
    /// Newton tolerance relative to the step's first residual. Default 1e-6.
    #[serde(deserialize_with = "units::scalar::<_, units::Ratio>")]
    pub newton_tolerance: f64,
    /// Newton iterations per step. Default 20.
    pub newton_max_iterations: usize,
    /// CG tolerance relative to the right-hand side. Default 1e-6.
    #[serde(deserialize_with = "units::scalar::<_, units::Ratio>")]
    pub cg_tolerance: f64,
    /// CG iterations per solve. Default 2000.
    pub cg_max_iterations: usize,
    /// Per-element fix of an indefinite tangent: "adaptive" (default), "teran" (alias
    /// "projected"), "analytic", "abs" or "none" (alias "exact"). See [`Definiteness`].
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
    /// How the assembled system matrix is stored: "auto" (default: f32 in dynamic steps, f64
    /// in quasistatic ones), "f32" or "f64". See [`MatrixPrecision`].
    pub matrix_precision: MatrixPrecision,
    /// "cholesky": keep the factor while CG converges fast (default true) or factor at every
    /// Newton iterate (false).
    pub cholesky_reuse: bool,
    /// "retry" (default), "continue" or "stop".
    pub on_failure: OnFailureName,
    /// Step halvings allowed by "retry". Default 4.
    pub max_step_cuts: usize,
    /// PETSc options for runs under `mpirun` (feature `mpi`), in PETSc's command-line syntax:
    /// "-ksp_type minres -pc_type hypre". They take precedence over PETSC_OPTIONS. Serial runs
    /// ignore them. Default "" (CG with GAMG).
    #[serde(skip_serializing_if = "String::is_empty")]
    pub petsc_options: String,
}

impl Default for SolverSpec {
    fn default() -> Self {
        let p = SolverParams::default();
        SolverSpec {
            integrator: IntegratorName::BackwardEuler,
            newmark_beta: None,
            newmark_gamma: None,
            dt: p.dt,
            frames: p.frames,
            substeps: p.substeps,
            rayleigh_stiffness: p.rayleigh_stiffness,
            rayleigh_mass: p.rayleigh_mass,
            damping_ratio: None,
            damping_frequencies: None,
            damping_stiffness: p.damping_stiffness,
            damping_tangent: DampingTangentName::default(),
            newton_tolerance: p.newton_tolerance,
            newton_max_iterations: p.newton_max_iterations,
            cg_tolerance: p.cg.tolerance,
            cg_max_iterations: p.cg.max_iterations,
            definiteness: p.definiteness,
            preconditioner: PreconditionerName::Amg,
            line_search: p.line_search,
            inexact_newton: p.inexact_newton,
            f32_matrix: p.f32_matrix,
            matrix_precision: p.matrix_precision,
            cholesky_reuse: p.cholesky_reuse,
            on_failure: OnFailureName::Retry,
            max_step_cuts: p.max_step_cuts,
            petsc_options: String::new(),
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
    /// BDF2.
    Bdf2,
    /// Newmark.
    Newmark,
    /// Quasistatic.
    Quasistatic,
}

/// Scene names of the damping tangents (see [`crate::integrator::DampingTangent`]).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DampingTangentName {
    /// Newton's tangent at x + θ·v.
    #[default]
    Shifted,
    /// K(x) frozen.
    Frozen,
}

impl DampingTangentName {
    /// True for the default (left out of manifests then).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
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
