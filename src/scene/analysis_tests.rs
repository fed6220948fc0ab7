//! Scene keys of SPEC §13 that this module reads: quantities with units, `[mesh] unit`,
//! `[[probe]]` and `[[fixed]] name`, each bad value named at its key's line.

use std::path::Path;

use crate::error::Error;
use crate::scene::Scene;

const MESH: &str =
    "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n";

fn parse(text: &str) -> crate::error::Result<Scene> {
    Scene::parse(text, Path::new("s.toml"), Path::new("."))
}

/// The line, key and message of the error `text` (with a mesh after it) gives.
fn error(text: &str) -> (usize, Option<String>, String) {
    match parse(&format!("{text}{MESH}")) {
        Err(Error::Scene {
            line, key, message, ..
        }) => (line, key, message),
        other => panic!("expected a scene error for\n{text}\ngot {other:?}"),
    }
}

#[test]
fn quantities_with_units_read_as_their_si_values() {
    let text = format!(
        "gravity = [0, \"-9.81 m/s^2\", 0]\n\
         [material]\nyoungs_modulus = \"1.2 MPa\"\ndensity = \"1100 kg/m^3\"\n\
         [solver]\ndt = \"2 ms\"\nrayleigh_mass = \"0.5 Hz\"\n\
         [[load]]\nregion = {{ vertices = [0] }}\ntotal_force = [\"1 kN\", 0, \"-5 mN\"]\n\
         [[fixed]]\nregion = {{ box = {{ min = [\"-10 mm\", 0, 0], max = [\"1 cm\", 1, 1] }} }}\n\
         motion = {{ rotate_degrees = \"0.5 rad\", axis = [1, 0, 0] }}\n{MESH}"
    );
    let s = parse(&text).unwrap();
    assert_eq!(s.gravity, [0.0, -9.81, 0.0]);
    assert_eq!(s.material.youngs_modulus, Some(1.2e6));
    assert_eq!(s.material.density, 1100.0);
    assert_eq!(s.solver.dt, 0.002);
    assert_eq!(s.solver.rayleigh_mass, 0.5);
    assert_eq!(s.load[0].total_force, Some([1000.0, 0.0, -0.005]));
    match &s.fixed[0].region {
        crate::scene::RegionSpec::Box { min, max } => {
            assert_eq!((min[0], max[0]), (-0.01, 0.01));
        }
        other => panic!("{other:?}"),
    }
    let degrees = s.fixed[0].motion.as_ref().unwrap().rotate_degrees;
    assert!((degrees - 28.64788975654116).abs() < 1e-12, "{degrees}");
}

#[test]
fn wrong_dimensions_and_unknown_units_name_key_and_line() {
    let (line, key, message) = error("[material]\ndensity = 1000\nyoungs_modulus = \"5 N\"\n");
    assert_eq!((line, key.as_deref()), (3, Some("material.youngs_modulus")));
    assert!(
        message.contains("\"5 N\" is a force") && message.contains("pressure"),
        "{message}"
    );

    let (line, key, message) =
        error("[[load]]\nregion = { vertices = [0] }\n\ntraction = [0, \"5 N\", 0]\n");
    assert_eq!((line, key.as_deref()), (4, Some("[[load]] #1 traction")));
    assert!(
        message.contains("entry 2 of the array") && message.contains("is a force"),
        "{message}"
    );

    let (line, key, message) = error("[solver]\nframes = 3\ndt = \"5 mss\"\n");
    assert_eq!((line, key.as_deref()), (3, Some("solver.dt")));
    assert!(message.contains("unknown unit \"mss\""), "{message}");

    let (line, key, message) = error("\n[solver]\nrayleigh_mass = \"2 rad/s\"\n");
    assert_eq!((line, key.as_deref()), (3, Some("solver.rayleigh_mass")));
    assert!(message.contains("frequency"), "{message}");

    // A negative frequency passes the unit check and is refused by the range check, at its line.
    let (line, key, message) = error("[solver]\nrayleigh_mass = \"-2 Hz\"\n");
    assert_eq!((line, key.as_deref()), (2, Some("solver.rayleigh_mass")));
    assert!(message.contains("zero or positive"), "{message}");

    // Counts take no unit.
    let (line, key, _) = error("[solver]\nframes = \"3 s\"\n");
    assert_eq!((line, key.as_deref()), (2, Some("solver.frames")));
}

#[test]
fn mesh_unit_must_be_a_length_for_a_file() {
    let text = "[mesh]\nfile = \"beam.msh\"\nunit = \"kg\"\n";
    let err = parse(text).unwrap_err().to_string();
    assert!(
        err.starts_with("s.toml:3:1: mesh.unit: \"kg\" is a mass"),
        "{err}"
    );
    let text = "[mesh]\nfile = \"beam.msh\"\nunit = \"MM\"\n";
    let err = parse(text).unwrap_err().to_string();
    assert!(err.contains("mesh.unit: unknown unit \"MM\""), "{err}");
    let text = "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\nunit = \"mm\"\n";
    let err = parse(text).unwrap_err().to_string();
    assert!(
        err.contains("mesh.unit: a unit applies to a mesh file"),
        "{err}"
    );
}

#[test]
fn probe_and_fixed_names_are_checked() {
    let (line, key, message) = error(
        "[[probe]]\nname = \"tip\"\npoint = [0, 0, 0]\n[[probe]]\nname = \"tip\"\npoint = [1, 1, 1]\n",
    );
    assert_eq!((line, key.as_deref()), (5, Some("[[probe]] #2 name")));
    assert!(message.contains("names two probes"), "{message}");
    let (line, key, message) = error("[[probe]]\nname = \"a,b\"\npoint = [0, 0, 0]\n");
    assert_eq!((line, key.as_deref()), (2, Some("[[probe]] #1 name")));
    assert!(message.contains("letters, digits"), "{message}");
    let (line, key, _) = error("[[probe]]\nname = \"p\"\npoint = [0, \"1 s\", 0]\n");
    assert_eq!((line, key.as_deref()), (3, Some("[[probe]] #1 point")));
    let (line, key, message) = error(
        "[[fixed]]\nname = \"clamp\"\nregion = { vertices = [0] }\n[[fixed]]\nname = \"clamp\"\nregion = { vertices = [1] }\n",
    );
    assert_eq!((line, key.as_deref()), (5, Some("[[fixed]] #2 name")));
    assert!(message.contains("names two [[fixed]]"), "{message}");
}

#[test]
fn a_load_factor_takes_no_unit() {
    let (line, key, message) = error(
        "[solver]\nintegrator = \"quasistatic\"\n[[fixed]]\nregion = { vertices = [0] }\nuntil = \"0.5 s\"\n",
    );
    assert_eq!((line, key.as_deref()), (5, Some("[[fixed]] #1 until")));
    assert!(message.contains("load factor"), "{message}");
    // In backward Euler it is a time, and a unit is welcome.
    let ok = parse(&format!(
        "[[fixed]]\nregion = {{ vertices = [0] }}\nuntil = \"500 ms\"\n{MESH}"
    ))
    .unwrap();
    assert_eq!(ok.fixed[0].until, Some(0.5));
}

#[test]
fn a_probe_outside_the_mesh_is_refused_at_its_point() {
    let text = format!("[[probe]]\nname = \"far\"\npoint = [\"2 m\", 0.5, 0.5]\n{MESH}");
    let scene = parse(&text).unwrap();
    let err = match crate::sim::Simulation::from_scene(&scene) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a probe outside the mesh was accepted"),
    };
    assert!(
        err.starts_with("s.toml:3:1: [[probe]] #1 point: [2, 0.5, 0.5] m lies outside the mesh (1.000e0 m beyond"),
        "{err}"
    );
    let text = format!("[[probe]]\nname = \"corner\"\npoint = [1, 1, 1]\n{MESH}");
    let sim = crate::sim::Simulation::from_scene(&parse(&text).unwrap()).unwrap();
    assert_eq!(sim.monitors().probes.len(), 1);
}

#[test]
fn a_mesh_unit_scales_the_mesh_file_and_the_initial_positions() {
    // The Gmsh beam fixture ([0,4]×[0,1]×[0,1]) read as if in millimetres, and initial
    // positions 1 (mm) above the rest shape.
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/beam_v41.msh");
    let dir = tempfile::tempdir().unwrap();
    let mesh = crate::io::read_mesh(&fixture).unwrap().mesh;
    let lifted: String = mesh
        .positions
        .iter()
        .map(|p| format!("{:?} {:?} {:?}\n", p[0], p[1] + 1.0, p[2]))
        .collect();
    std::fs::write(dir.path().join("lifted.txt"), lifted).unwrap();
    let text = format!(
        "[mesh]\nfile = {:?}\nunit = \"mm\"\n[initial]\npositions = \"lifted.txt\"\n",
        fixture.display().to_string()
    );
    let scene = Scene::parse(&text, Path::new("s.toml"), dir.path()).unwrap();
    let sim = crate::sim::Simulation::from_scene(&scene).unwrap();
    let (lo, hi) = sim.body.mesh.bounding_box();
    assert_eq!((lo[0], hi[0]), (0.0, 0.004), "the rest mesh in metres");
    let x = sim.to_input_order(&sim.state.x);
    for (v, p) in mesh.positions.iter().enumerate() {
        let expected = crate::math::Vec3::new(p[0] / 1000.0, (p[1] + 1.0) / 1000.0, p[2] / 1000.0);
        assert!(
            (x[v] - expected).norm() < 1e-18,
            "vertex {v}: {} vs {expected}",
            x[v]
        );
    }
}

/// The damping frequencies take units (Hz, kHz, 1/s); a length there is refused at its line.
#[test]
fn damping_frequencies_take_units() {
    let s = parse(&format!(
        "[solver]\ndamping_ratio = 0.02\ndamping_frequencies = [\"5 Hz\", \"0.05 kHz\"]\n{MESH}"
    ))
    .unwrap();
    assert_eq!(s.solver.damping_frequencies, Some([5.0, 50.0]));
    assert_eq!(s.solver.damping_ratio, Some(0.02));
    let (line, key, message) =
        error("[solver]\ndamping_ratio = 0.02\ndamping_frequencies = [\"5 m\", 50]\n");
    assert_eq!(
        (line, key.as_deref()),
        (3, Some("solver.damping_frequencies"))
    );
    assert!(message.contains("frequency"), "{message}");
}
