//! What a scene asks of contact: the rigid obstacles with their friction, and the `[contact]`
//! settings (SPEC §11).

use super::obstacle::Obstacle;

/// The `[contact]` settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactParams {
    /// d̂ (m, unsquared): the gap below which contact acts. None: 1e-3 × the scene's bounding-box
    /// diagonal (obstacles' finite extents and the bodies).
    pub distance: Option<f64>,
    /// Coulomb coefficient between bodies and for obstacles without their own. Default 0.
    pub friction: f64,
    /// Self-contact inside each body (Contact II). Default true.
    pub self_contact: bool,
}

impl Default for ContactParams {
    fn default() -> Self {
        ContactParams {
            distance: None,
            friction: 0.0,
            self_contact: true,
        }
    }
}

/// One `[[obstacle]]`: the shape with its motion, its name in messages, and its friction.
#[derive(Clone, Debug, PartialEq)]
pub struct ObstacleSpec {
    /// "obstacle 1", "obstacle 2", ... or the scene's `name`.
    pub name: String,
    /// The shape and its scripted motion.
    pub obstacle: Obstacle,
    /// Coulomb coefficient against this obstacle (None: `[contact] friction`).
    pub friction: Option<f64>,
    /// Seconds over which the motion ramps (None: the whole run), like `[[fixed]]`.
    pub duration: Option<f64>,
}

/// Everything contact needs from a scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactSetup {
    /// The rigid obstacles.
    pub obstacles: Vec<ObstacleSpec>,
    /// `[contact]`.
    pub params: ContactParams,
    /// The deformable bodies sharing the mesh (SPEC §11 `[[body]]`): their names, body 0 first.
    /// Empty means one unnamed body.
    pub body_names: Vec<String>,
    /// The body of every mesh vertex, in the mesh's (internal) vertex order. Empty means every
    /// vertex is body 0. Body–body pairs always count; pairs inside one body only with
    /// `params.self_contact`.
    pub vertex_body: Vec<u32>,
}

impl ContactSetup {
    /// The body of mesh vertex `v` (0 when the setup names no bodies).
    pub fn body_of(&self, v: usize) -> u32 {
        self.vertex_body.get(v).copied().unwrap_or(0)
    }

    /// The name of body `b` in messages ("body0" style when unnamed).
    pub fn body_name(&self, b: u32) -> String {
        self.body_names
            .get(b as usize)
            .cloned()
            .unwrap_or_else(|| format!("body{b}"))
    }
}
