//! The run manifest, `manifest.json`: what ran (tetsim version, scene and mesh hashes, every
//! resolved parameter) and what it wrote (a SHA-256 per output file, per frame), so that two runs
//! can be compared, and a result traced to its inputs, without the files themselves.
//!
//! Determinism: every output file a run lists here is byte-identical for any `--threads` and
//! across repeated runs, with one documented exception: the `wall_seconds` column of steps.csv
//! (wall-clock time) — and so the hash of steps.csv. With `[output] deterministic = true` (or
//! `tetsim run --deterministic`) that column is written as 0 and there is no exception.
//! `timings.csv` holds the real times either way and is never hashed.

use std::path::Path;

use serde_json::{Value, json};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::sim::Simulation;

/// Lower-case hex SHA-256 of bytes.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// SHA-256 of a file's bytes.
pub fn sha256_file(path: &Path) -> Result<String> {
    Ok(sha256_hex(&crate::io::read_bytes(path)?))
}

/// The files a scene reads, with their hashes: the mesh (for TetGen both .node and .ele) and the
/// initial positions. Paths are as the scene names them (relative to the scene).
pub fn input_hashes(scene: &Scene) -> Result<Value> {
    let mut inputs = serde_json::Map::new();
    let mut add = |name: &str, path: &Path| -> Result<()> {
        let resolved = scene.resolve(path);
        inputs.insert(
            name.to_string(),
            json!({
                "path": path.display().to_string(),
                "sha256": sha256_file(&resolved)?,
            }),
        );
        Ok(())
    };
    if let Some(file) = &scene.mesh.file {
        add("mesh", file)?;
        let ext = file.extension().and_then(|e| e.to_str()).unwrap_or("");
        let sibling = match ext {
            "node" => Some(file.with_extension("ele")),
            "ele" => Some(file.with_extension("node")),
            _ => None,
        };
        if let Some(sibling) = sibling.filter(|s| scene.resolve(s).exists()) {
            add("mesh_companion", &sibling)?;
        }
    }
    if let Some(file) = &scene.initial.positions {
        add("initial_positions", file)?;
    }
    for (i, obstacle) in scene.obstacle.iter().enumerate() {
        if let Some(file) = &obstacle.mesh {
            add(&format!("obstacle_{}_mesh", i + 1), file)?;
        }
    }
    Ok(Value::Object(inputs))
}

/// Everything a run resolved from its scene (defaults filled in): the scene's tables, the Lamé
/// parameters, the mesh size.
pub fn resolved_parameters(scene: &Scene, sim: &Simulation) -> Result<Value> {
    let mut value = serde_json::to_value(scene)
        .map_err(|e| Error::parameter("scene", format!("cannot serialise: {e}")))?;
    if let (Value::Object(map), Ok(lame)) = (&mut value, scene.lame()) {
        map.insert(
            "resolved".into(),
            json!({
                "mu": lame.mu,
                "lambda": lame.lambda,
                "youngs_modulus": lame.youngs_modulus(),
                "poisson_ratio": lame.poisson_ratio(),
                "vertices": sim.body.vertex_count(),
                "tets": sim.body.tet_count(),
                "constrained_components": sim.boundary.constrained_dofs(sim.body.vertex_count()),
                "mean_edge_length": sim.body.mesh.mean_edge_length(),
            }),
        );
        // A damping ratio: the coefficients it resolved to replace the tables' defaults.
        if let Some(d) = sim.damping() {
            if let Some(Value::Object(solver)) = map.get_mut("solver") {
                solver.insert("rayleigh_mass".into(), d.rayleigh_mass.into());
                solver.insert("rayleigh_stiffness".into(), d.rayleigh_stiffness.into());
            }
            map["resolved"]["damping"] = json!({
                "damping_ratio": d.ratio,
                "damping_frequencies": d.frequencies_hz,
                "frequencies_from": if d.from_modes { "lowest mode" } else { "scene" },
                "rayleigh_mass": d.rayleigh_mass,
                "rayleigh_stiffness": d.rayleigh_stiffness,
            });
        }
    }
    Ok(value)
}

/// The determinism rule, as written into every manifest.
pub const DETERMINISM_NOTE: &str = "Every file under `outputs` is byte-identical for any \
--threads and across repeated runs of the same tetsim version, scene and inputs, except \
steps.csv's wall_seconds column (wall-clock time; written as 0 when `deterministic` is true, \
which removes the exception). timings.csv is wall-clock time and is not listed.";
