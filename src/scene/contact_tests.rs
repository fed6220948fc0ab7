//! The `[[obstacle]]` and `[contact]` keys: every bad value named at its line and key, and the
//! contact setup a valid scene builds.

use std::path::Path;

use super::Scene;
use crate::contact::obstacle::Shape;
use crate::error::Error;

const MESH: &str =
    "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [1,1,1] } }\n";

fn parse(rest: &str) -> crate::error::Result<Scene> {
    Scene::parse(
        &format!("{rest}{MESH}"),
        Path::new("s.toml"),
        Path::new("."),
    )
}

#[test]
fn every_bad_contact_value_is_named_at_its_key_line() {
    let cases: &[(&str, usize, &str, &str)] = &[
        (
            "[contact]\ndistance = 0\n",
            2,
            "contact.distance: ",
            "positive",
        ),
        (
            "[contact]\ndistance = -1e-3\n",
            2,
            "contact.distance: ",
            "got -0.001",
        ),
        (
            "[contact]\ndistance = nan\n",
            2,
            "contact.distance: ",
            "NaN",
        ),
        (
            "[contact]\nself = false\nfriction = -0.1\n",
            3,
            "contact.friction: ",
            "got -0.1",
        ),
        (
            "[contact]\nfrobnicate = 1\n",
            2,
            "contact.frobnicate: ",
            "unknown field",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,0,0], normal = [0,0,0] }\n",
            2,
            "[[obstacle]] #1 plane.normal: ",
            "non-zero",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,nan,0], normal = [0,1,0] }\n",
            2,
            "[[obstacle]] #1 plane.point: ",
            "NaN",
        ),
        (
            "[[obstacle]]\nsphere = { center = [0,0,0], radius = 0 }\n",
            2,
            "[[obstacle]] #1 sphere.radius: ",
            "positive",
        ),
        (
            "[[obstacle]]\nsphere = { center = [0,0,0], radius = -2 }\n",
            2,
            "[[obstacle]] #1 sphere.radius: ",
            "got -2",
        ),
        (
            "[[obstacle]]\nbox = { min = [0,0,0], max = [1,0,1] }\n",
            2,
            "[[obstacle]] #1 box.max: ",
            "exceed min",
        ),
        (
            "[[obstacle]]\nbox = { min = [0,0,0], max = [1,nan,1] }\n",
            2,
            "[[obstacle]] #1 box.max: ",
            "NaN",
        ),
        (
            "[[obstacle]]\nname = \"floor\"\n",
            1,
            "[[obstacle]] #1: ",
            "got none",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,0,0], normal = [0,1,0] }\nsphere = { center = [0,0,0], radius = 1 }\n",
            3,
            "[[obstacle]] #1 sphere: ",
            "got plane and sphere",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,0,0], normal = [0,1,0] }\n\n[[obstacle]]\nsphere = { center = [0,2,0], radius = 1 }\nfriction = -1\n",
            6,
            "[[obstacle]] #2 friction: ",
            "got -1",
        ),
        (
            "[[obstacle]]\nsphere = { center = [0,2,0], radius = 1 }\nfriction = nan\n",
            3,
            "[[obstacle]] #1 friction: ",
            "NaN",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,0,0], normal = [0,1,0] }\nduration = -1\n",
            3,
            "[[obstacle]] #1 duration: ",
            "got -1",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,0,0], normal = [0,1,0] }\nmotion = { translate = [0, inf, 0] }\n",
            3,
            "[[obstacle]] #1 motion.translate: ",
            "inf",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,0,0], normal = [0,1,0] }\nmotion = { rotate_degrees = nan }\n",
            3,
            "[[obstacle]] #1 motion.rotate_degrees: ",
            "finite",
        ),
        (
            "[[obstacle]]\nplane = { point = [0,0,0], normal = [0,1,0], size = 3 }\n",
            2,
            "[[obstacle]] #1 plane.size: ",
            "unknown field",
        ),
        (
            "[[obstacle]]\ncylinder = { radius = 1 }\n",
            2,
            "[[obstacle]] #1 cylinder: ",
            "unknown field",
        ),
        (
            "[[obstacle]]\nmesh = \"\"\n",
            2,
            "[[obstacle]] #1 mesh: ",
            "a file",
        ),
    ];
    for &(rest, line, key, word) in cases {
        match parse(rest) {
            Err(Error::Scene {
                line: l, message, ..
            }) => {
                assert_eq!(l, line, "line of {key} in\n{rest}\n{message}");
                assert!(message.starts_with(key), "{message}");
                assert!(message.contains(word), "{word:?} missing in {message}");
            }
            other => panic!("expected a scene error for\n{rest}\ngot {other:?}"),
        }
    }
}

#[test]
fn a_scene_without_contact_keys_has_no_contact_setup() {
    let scene = parse("").unwrap();
    assert!(!scene.has_contact());
    assert!(scene.contact_setup().unwrap().is_none());
    // Nor do the new keys show in the manifest's parameters.
    let json = serde_json::to_string(&scene).unwrap();
    assert!(
        !json.contains("obstacle") && !json.contains("contact"),
        "{json}"
    );
}

#[test]
fn contact_table_alone_turns_contact_on_with_defaults() {
    let setup = parse("[contact]\n")
        .unwrap()
        .contact_setup()
        .unwrap()
        .unwrap();
    assert!(setup.obstacles.is_empty());
    assert_eq!(setup.params, crate::contact::ContactParams::default());
    let setup = parse("[contact]\ndistance = 2e-3\nfriction = 0.3\nself = false\n")
        .unwrap()
        .contact_setup()
        .unwrap()
        .unwrap();
    assert_eq!(setup.params.distance, Some(2e-3));
    assert_eq!(setup.params.friction, 0.3);
    assert!(!setup.params.self_contact);
}

#[test]
fn obstacles_are_built_with_names_friction_motion_and_duration() {
    let scene = parse(
        "[[obstacle]]\nplane = { point = [0,-1,0], normal = [0,2,0] }\nfriction = 0.5\n\n\
         [[obstacle]]\nname = \"ball\"\nsphere = { center = [0,3,0], radius = 0.5 }\n\
         motion = { translate = [0,-1,0] }\nduration = 0.5\n\n\
         [[obstacle]]\nbox = { min = [2,0,0], max = [3,1,1] }\n",
    )
    .unwrap();
    let setup = scene.contact_setup().unwrap().unwrap();
    let names: Vec<_> = setup.obstacles.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["obstacle 1", "ball", "obstacle 3"]);
    assert_eq!(setup.obstacles[0].friction, Some(0.5));
    assert!(matches!(
        setup.obstacles[0].obstacle.shape,
        Shape::Plane { .. }
    ));
    assert_eq!(setup.obstacles[1].duration, Some(0.5));
    let (center, radius) = setup.obstacles[1].obstacle.sphere_at(1.0).unwrap();
    assert_eq!((center.y, radius), (2.0, 0.5));
    assert_eq!(setup.obstacles[2].obstacle.triangles().faces.len(), 12);
}

#[test]
fn a_missing_or_bad_mesh_file_is_named_at_the_mesh_key_and_in_the_file() {
    let dir = std::env::temp_dir().join(format!("tetsim-contact-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    std::fs::write(dir.join("ok.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let load = |file: &str| {
        let text = format!("{MESH}\n[[obstacle]]\nname = \"bowl\"\nmesh = \"{file}\"\n");
        Scene::parse(&text, Path::new("s.toml"), &dir).unwrap()
    };
    for (file, word) in [("missing.obj", "missing.obj"), ("bad.obj", "bad.obj:4")] {
        let msg = load(file).contact_setup().unwrap_err().to_string();
        assert!(
            msg.starts_with("s.toml:6:1: [[obstacle]] #1 mesh: "),
            "{msg}"
        );
        assert!(msg.contains(word), "{word} missing in {msg}");
    }
    let setup = load("ok.obj").contact_setup().unwrap().unwrap();
    assert_eq!(setup.obstacles[0].obstacle.triangles().faces.len(), 1);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn contact_raises_the_default_newton_cap_but_never_a_given_one() {
    let cap = |rest: &str| parse(rest).unwrap().solver_params().newton_max_iterations;
    assert_eq!(cap(""), 20);
    assert_eq!(cap("[solver]\ndt = 0.01\n"), 20);
    assert_eq!(cap("[contact]\n"), super::CONTACT_NEWTON_MAX_ITERATIONS);
    assert_eq!(
        cap("[[obstacle]]\nplane = { point = [0, -1, 0], normal = [0, 1, 0] }\n"),
        super::CONTACT_NEWTON_MAX_ITERATIONS
    );
    assert_eq!(cap("[contact]\n[solver]\nnewton_max_iterations = 20\n"), 20);
    assert_eq!(cap("[contact]\n[solver]\nnewton_max_iterations = 7\n"), 7);
}
