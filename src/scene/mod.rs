//! The user contract (SPEC §10): a TOML scene parsed with serde into [`Scene`], with a default
//! for every key, unknown keys rejected by name, file and line, relative paths resolved against
//! the scene's folder, and values range-checked. [`Simulation::from_scene`] turns it into a
//! running simulation; the schema is not the solver's internals, so those can change freely.
//!
//! The module is four rooms:
//! - `schema`: the serde structs and enums (one per table), their defaults and
//!   `deny_unknown_fields`; every key is listed in `docs/scene-reference.md`;
//! - `validate`: the one validator, which checks every value the schema lets through and names
//!   the file, line and key of the first bad one (`s.toml:12:1: solver.dt: must be positive…`);
//! - `build`: mesh, materials, boundary conditions, initial state and solver settings from a
//!   valid scene, and [`Simulation::from_scene`];
//! - `locate`: where a key path (`["fixed", 1, "duration"]`) sits in the TOML text, from the
//!   spans of toml's own parse, so inline tables, dotted keys and `[[table]]` entries are found.
//!
//! [`Simulation::from_scene`]: crate::sim::Simulation::from_scene

mod bodies;
mod build;
pub(crate) mod locate;
mod monitors;
mod render;
mod schema;
pub mod units;
mod validate;

use std::fmt::Display;
use std::path::{Path, PathBuf};

pub use schema::{
    BodySpec, BoxSpec, Component, ContactSpec, FixedSpec, Generator, InitialSpec, IntegratorName,
    LoadSpec, MaterialSpec, MeshSpec, MotionSpec, ObstacleEntry, OnFailureName, OutputSpec,
    PlaneSpec, PreconditionerName, ProbeSpec, RegionSpec, Scene, SolverSpec, SphereSpec,
    VolumeSpec,
};

use crate::error::{Error, Result};
use locate::{Dotted, Locator, Seg, line_column};
pub(crate) use validate::{beyond_limit, body_names};

/// The built-in default scene (also `scenes/default.toml`, embedded so they never diverge).
pub const DEFAULT_SCENE: &str = include_str!("../../scenes/default.toml");

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

/// `[solver] newton_max_iterations` when the scene has contact and does not give it: where
/// bodies first press on each other or an obstacle Newton walks the barrier down to where it
/// holds, which takes more than the default 20 iterations, and the retry with halved steps that
/// follows a capped step starts each approach over. Measured with the stiffness-matched barrier
/// (`contact::barrier::stiffness_matched_barrier_stiffness`) on the sample scenes: with 100,
/// the three-block stack took 386 Newton iterations over 60 frames, none retried (602 with 20,
/// retries up to 16 substeps and one frame unconverged); the folded strip 824 over 100 (1,087
/// and one unconverged); the jelly drop 697 over 80 (1,213 and two unconverged).
pub const CONTACT_NEWTON_MAX_ITERATIONS: usize = 100;

/// Whether the scene text sets `[solver] newton_max_iterations` itself.
fn names_newton_cap(text: &str) -> bool {
    text.parse::<toml::Table>().is_ok_and(|t| {
        t.get("solver")
            .and_then(|s| s.get("newton_max_iterations"))
            .is_some()
    })
}

impl Scene {
    /// Read and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        let text = crate::io::read_text(path)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::parse(&text, path, &base)
    }

    /// Parse and validate scene text; `path` names it in messages, `base_dir` resolves paths.
    pub fn parse(text: &str, path: &Path, base_dir: &Path) -> Result<Scene> {
        let mut scene: Scene = toml::from_str(text).map_err(|e| {
            // toml's own errors (syntax, unknown key, wrong type) carry a span; name the key
            // there too, when the text is valid TOML and the span falls on one.
            let offset = e.span().map(|s| s.start);
            let (line, column) = offset.map_or((1, 1), |o| line_column(text, o));
            let at = Locator::new(text);
            let mut key = offset.map(|o| at.path_at(o)).unwrap_or_default();
            // serde quotes the offending value whole (`unknown variant `…``): clip long words.
            let mut message = crate::error::clip_words(e.message().trim());
            // An entry of a plain array (`gravity = [0, "9.81 m/s", 0]`): the key, and which
            // entry in words (`[[gravity]] #2` would read as an array of tables).
            if let Some(&Seg::Index(n)) = key.last()
                && !at.is_table(&key)
            {
                key.pop();
                message = format!("entry {} of the array: {message}", n + 1);
            }
            let message = message.as_str();
            let key = (!key.is_empty()).then(|| Dotted(&key).to_string());
            Error::Scene {
                path: path.to_path_buf(),
                line,
                column,
                message: match &key {
                    Some(key) => format!("{key}: {message}"),
                    None => message.to_string(),
                },
                key,
            }
        })?;
        scene.path = path.to_path_buf();
        scene.base_dir = base_dir.to_path_buf();
        scene.source = text.to_string();
        if scene.has_contact() && !names_newton_cap(text) {
            scene.solver.newton_max_iterations = CONTACT_NEWTON_MAX_ITERATIONS;
        }
        validate::validate(&scene)?;
        Ok(scene)
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

    /// An error about the value at `key` (e.g. `["fixed", 1, "region"]`), at its line in the
    /// scene text: for what only building can find (a region that selects nothing).
    pub(crate) fn error_at(&self, key: &[Seg], message: impl Display) -> Error {
        Locator::new(&self.source).error(&self.path, key, message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::ModelKind;

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
        assert!(msg.starts_with("s.toml:6:1: solver.frobnicate: "), "{msg}");
        assert!(msg.contains("unknown field `frobnicate`"), "{msg}");
        assert_eq!(err.key(), Some("solver.frobnicate"));
    }

    #[test]
    fn unknown_key_in_an_inline_table_is_named_with_its_path() {
        let text = "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n[[fixed]]\nregion = { box = { min = [0,0,0], max = [1,1,1], maximum = [2,2,2] } }\n";
        let msg = Scene::parse(text, Path::new("s.toml"), Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("s.toml:4:50: [[fixed]] #1 region.box.maximum: unexpected key"),
            "{msg}"
        );
    }

    #[test]
    fn syntax_errors_keep_toml_s_location() {
        let msg = Scene::parse("[solver]\ndt = = 1\n", Path::new("s.toml"), Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(msg.starts_with("s.toml:2:"), "{msg}");
    }
}

#[cfg(test)]
mod contact_tests;

#[cfg(test)]
mod analysis_tests;
