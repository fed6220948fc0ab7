//! The validator's cases: every bad value named at its key's line.
use std::path::Path;

use super::*;

const MESH: &str =
    "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n";

/// Parse `rest` + `MESH`; the error's line and message.
fn error(rest: &str) -> (usize, String) {
    let text = format!("{rest}{MESH}");
    match Scene::parse(&text, Path::new("s.toml"), Path::new(".")) {
        Err(Error::Scene { line, message, .. }) => (line, message),
        other => panic!("expected a scene error for\n{text}\ngot {other:?}"),
    }
}

/// Each bad value: the scene text before `[mesh]`, the line of the offending key in it, and
/// the start of the message (the key path) plus a word it must contain.
#[test]
fn every_bad_value_is_named_at_its_key_line() {
    let cases: &[(&str, usize, &str, &str)] = &[
        (
            "[solver]\nnewton_tolerance = 0\n",
            2,
            "solver.newton_tolerance: ",
            "got 0",
        ),
        (
            "[solver]\ndt = 0.1\ncg_tolerance = -1\n",
            3,
            "solver.cg_tolerance: ",
            "got -1",
        ),
        (
            "[solver]\nsubsteps = 0\n",
            2,
            "solver.substeps: ",
            "at least 1",
        ),
        ("solver.dt = 0\n", 1, "solver.dt: ", "positive"),
        (
            "[solver]\nrayleigh_mass = -0.5\n",
            2,
            "solver.rayleigh_mass: ",
            "-0.5",
        ),
        (
            "[solver]\nnewmark_beta = 0.3\n",
            2,
            "solver.newmark_beta: ",
            "only to integrator = \"newmark\"",
        ),
        (
            "[solver]\nintegrator = \"newmark\"\nnewmark_gamma = 0.4\n",
            3,
            "solver.newmark_gamma: ",
            "between 0.5 and 1",
        ),
        (
            "[solver]\nintegrator = \"newmark\"\nnewmark_gamma = 0.6\nnewmark_beta = 0.2\n",
            4,
            "solver.newmark_beta: ",
            "between γ/2 = 0.3 and 1",
        ),
        (
            "[solver]\nrayleigh_stiffness = inf\n",
            2,
            "solver.rayleigh_stiffness: ",
            "inf",
        ),
        (
            "[solver]\ndamping_ratio = 0.02\nrayleigh_mass = 0.5\n",
            3,
            "solver.rayleigh_mass: ",
            "damping_ratio (line 2)",
        ),
        (
            "[solver]\nrayleigh_stiffness = 0.01\ndt = 0.1\ndamping_ratio = 0.02\n",
            2,
            "solver.rayleigh_stiffness: ",
            "not both",
        ),
        (
            "[solver]\ndamping_ratio = -0.1\n",
            2,
            "solver.damping_ratio: ",
            "got -0.1",
        ),
        (
            "[solver]\ndamping_ratio = 0.02\ndamping_frequencies = [-1.0, 10.0]\n",
            3,
            "solver.damping_frequencies: ",
            "positive",
        ),
        (
            "[solver]\ndamping_ratio = 0.02\ndamping_frequencies = [0.0, 10.0]\n",
            3,
            "solver.damping_frequencies: ",
            "positive",
        ),
        (
            "[solver]\ndamping_ratio = 0.02\ndamping_frequencies = [5.0, 5.0]\n",
            3,
            "solver.damping_frequencies: ",
            "above the first",
        ),
        (
            "[solver]\ndt = 0.1\ndamping_frequencies = [1.0, 10.0]\n",
            3,
            "solver.damping_frequencies: ",
            "needs solver.damping_ratio",
        ),
        (
            "[solver]\nnewton_max_iterations = 0\n",
            2,
            "solver.newton_max_iterations: ",
            "at least 1",
        ),
        (
            "[solver]\ncg_max_iterations = 0\n",
            2,
            "solver.cg_max_iterations: ",
            "at least 1",
        ),
        (
            "[solver]\nmax_step_cuts = 21\n",
            2,
            "solver.max_step_cuts: ",
            "at most 20",
        ),
        ("[solver]\nframes = 0\n", 2, "solver.frames: ", "at least 1"),
        (
            "[material]\ndensity = -1\n",
            2,
            "material.density: ",
            "got -1",
        ),
        (
            "[material]\npoisson_ratio = 0.5\n",
            2,
            "material.poisson_ratio: ",
            "incompressible",
        ),
        (
            "[material]\nyoungs_modulus = 0\n",
            2,
            "material.youngs_modulus: ",
            "Young",
        ),
        ("[material]\nmu = 1e4\n", 2, "material.mu: ", "lambda"),
        (
            "[material]\nmu = 1e4\nlambda = -1e4\n",
            3,
            "material.lambda: ",
            "3λ + 2μ",
        ),
        (
            "[material]\npoisson_ratio = 0.3\nlambda = 1\n",
            3,
            "material.lambda: ",
            "not both",
        ),
        ("gravity = [0, nan, 0]\n", 1, "gravity: ", "NaN"),
        (
            "[[fixed]]\nregion = { vertices = [0] }\n\n[[fixed]]\nregion = { vertices = [1] }\nduration = -1\n",
            6,
            "[[fixed]] #2 duration: ",
            "got -1",
        ),
        (
            "[[fixed]]\nregion = { vertices = [0] }\nuntil = nan\n",
            3,
            "[[fixed]] #1 until: ",
            "NaN",
        ),
        (
            "[[fixed]]\nregion = { vertices = [0] }\nmotion = { translate = [0, 0, inf] }\n",
            3,
            "[[fixed]] #1 motion.translate: ",
            "inf",
        ),
        (
            "[[fixed]]\nregion = { plane = { point = [0,0,0],\n  normal = [0,0,0] } }\n",
            3,
            "[[fixed]] #1 region.plane.normal: ",
            "non-zero",
        ),
        (
            "[[fixed]]\nregion = { vertices = [] }\n",
            2,
            "[[fixed]] #1 region.vertices: ",
            "empty",
        ),
        (
            "[[load]]\nregion = { vertices = [0] }\ntraction = [0, 1, 0]\ntotal_force = [1, 0, 0]\n",
            4,
            "[[load]] #1 total_force: ",
            "exactly one",
        ),
        (
            "[[load]]\nregion = { vertices = [0] }\n",
            1,
            "[[load]] #1: ",
            "exactly one",
        ),
        (
            "[[load]]\nregion = { vertices = [0] }\npoint_force = [0, 1, 0]\nduration = -2\n",
            4,
            "[[load]] #1 duration: ",
            "got -2",
        ),
        (
            "[[volume]]\nregion = { box = { min = [0,0,0], max = [1,1,1] } }\ndensity = 0\n",
            3,
            "[[volume]] #1 density: ",
            "positive",
        ),
        (
            "[[volume]]\nregion = { vertices = [0, 1] }\n",
            2,
            "[[volume]] #1 region.vertices: ",
            "needs tets",
        ),
        (
            "[[volume]]\nregion = { physical = \"xmin\" }\npoisson_ratio = -1\n",
            3,
            "[[volume]] #1 poisson_ratio: ",
            "(-1, 0.5)",
        ),
        (
            "[initial]\nvelocity = [nan, 0, 0]\n",
            2,
            "initial.velocity: ",
            "NaN",
        ),
        (
            "[output]\nfield = \"colour\"\n",
            2,
            "output.field: ",
            "unknown field",
        ),
        (
            "[output]\n\nwidth = 8\n",
            3,
            "output.width: ",
            "between 16 and 8192",
        ),
        (
            "[output]\ngif_stride = 0\n",
            2,
            "output.gif_stride: ",
            "at least 1",
        ),
        ("[output]\nazimuth = nan\n", 2, "output.azimuth: ", "finite"),
        (
            "[solver]\nframes = 1\n[solver.frobnicate]\nx = 1\n",
            3,
            "solver.frobnicate: ",
            "unknown field",
        ),
        (
            "[material]\nmodel = \"rubber\"\n",
            2,
            "material.model: ",
            "unknown material model",
        ),
    ];
    for &(rest, line, key, word) in cases {
        let (l, message) = error(rest);
        assert_eq!(l, line, "line of {key} in\n{rest}\n{message}");
        assert!(message.starts_with(key), "{message}");
        assert!(message.contains(word), "{word:?} missing in {message}");
    }
}

#[test]
fn mesh_keys_are_named_at_their_line() {
    let generator = |g: &str| format!("[solver]\ndt = 0.1\n[mesh]\ngenerator = {g}\n");
    for (g, key, column) in [
        (
            "{ box = { min = [0,0,0], max = [1,0,1], cells = [1,1,1] } }",
            "mesh.generator.box.max",
            38,
        ),
        (
            "{ box = { min = [0,0,0], max = [1,1,1], cells = [1,0,1] } }",
            "mesh.generator.box.cells",
            53,
        ),
    ] {
        match Scene::parse(&generator(g), Path::new("s.toml"), Path::new(".")) {
            Err(Error::Scene {
                line: 4,
                column: c,
                message,
                ..
            }) => {
                assert!(message.starts_with(key), "{message}");
                assert_eq!(c, column, "{message}");
            }
            other => panic!("{other:?}"),
        }
    }
    let msg = Scene::parse("[solver]\ndt = 0.1\n", Path::new("s.toml"), Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        msg.starts_with("s.toml:1:1: mesh.file: give a mesh file"),
        "{msg}"
    );
}

#[test]
fn the_first_problem_in_the_file_is_reported() {
    let (line, message) = error("[solver]\nsubsteps = 0\n[material]\ndensity = -1\n");
    assert_eq!((line, message.starts_with("solver.substeps")), (2, true));
    let (line, message) = error("[material]\ndensity = -1\n[solver]\nsubsteps = 0\n");
    assert_eq!((line, message.starts_with("material.density")), (2, true));
}

#[test]
fn every_sample_scene_is_valid() {
    for dir in ["scenes", "scenes/bench"] {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            }
        }
    }
}
