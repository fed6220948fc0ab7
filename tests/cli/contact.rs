//! `[[obstacle]]` and `[contact]` through the real binary: every bad value refused at its file,
//! line and key; with contact on, the obstacle files, `contact_force` and the four steps.csv
//! columns; without it, none of them (the old files, byte for byte in layout).
//!
//! Until the contact term lands, bodies still fall through obstacles: these tests look at the
//! files and columns, not the physics.

use std::path::Path;

use super::{stderr, tetsim};
use tetsim::io::FieldData;
use tetsim::io::surface_vtu::read_surface_vtu;
use tetsim::output::{STEPS_HEADER, steps_header};

const MESH: &str = "[mesh]\ngenerator = { box = { min = [0,0,0], max = [1,1,1], cells = [2,2,2] } }\n\
                    [solver]\nframes = 2\n";

/// Run `text` (a scene) in `dir` with `--no-pictures`; the output folder.
fn run(dir: &Path, text: &str) -> std::path::PathBuf {
    std::fs::write(dir.join("s.toml"), text).unwrap();
    let out = tetsim(
        dir,
        &["run", "s.toml", "--out", "out", "-q", "--no-pictures"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    dir.join("out")
}

fn names(dir: &Path, prefix: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix))
        .collect();
    names.sort();
    names
}

#[test]
fn bad_obstacle_and_contact_values_name_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap();
    // (scene text after MESH, line of the key in the whole file, key, a word of the why)
    let cases: &[(&str, usize, &str, &str)] = &[
        (
            "[contact]\ndistance = 0\n",
            6,
            "contact.distance",
            "positive",
        ),
        (
            "[contact]\ndistance = -1\n",
            6,
            "contact.distance",
            "got -1",
        ),
        (
            "[contact]\nfriction = -0.5\n",
            6,
            "contact.friction",
            "got -0.5",
        ),
        ("[contact]\ndistance = nan\n", 6, "contact.distance", "NaN"),
        (
            "[contact]\nstiffness = 1\n",
            6,
            "contact.stiffness",
            "unknown field",
        ),
        (
            "[[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 0, 0] }\n",
            6,
            "[[obstacle]] #1 plane.normal",
            "non-zero",
        ),
        (
            "[[obstacle]]\nsphere = { center = [0, 0, 0], radius = 0 }\n",
            6,
            "[[obstacle]] #1 sphere.radius",
            "positive",
        ),
        (
            "[[obstacle]]\nbox = { min = [0, 0, 0], max = [0, 1, 1] }\n",
            6,
            "[[obstacle]] #1 box.max",
            "exceed min",
        ),
        (
            "[[obstacle]]\nsphere = { center = [0, 3, 0], radius = 1 }\nfriction = -1\n",
            7,
            "[[obstacle]] #1 friction",
            "got -1",
        ),
        (
            "[[obstacle]]\nname = \"floor\"\n",
            5,
            "[[obstacle]] #1",
            "got none",
        ),
        (
            "[[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 1, 0] }\nmesh = \"bowl.obj\"\n",
            7,
            "[[obstacle]] #1 mesh",
            "got plane and mesh",
        ),
        (
            "[[obstacle]]\nmesh = \"nowhere.obj\"\n",
            6,
            "[[obstacle]] #1 mesh",
            "nowhere.obj",
        ),
        (
            "[[obstacle]]\nmesh = \"bad.obj\"\n",
            6,
            "[[obstacle]] #1 mesh",
            "bad.obj:3:",
        ),
    ];
    for (i, &(text, line, key, why)) in cases.iter().enumerate() {
        let name = format!("bad{i}.toml");
        std::fs::write(dir.path().join(&name), format!("{MESH}{text}")).unwrap();
        let out = tetsim(dir.path(), &["run", &name, "--out", "out", "-q"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{name}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        let message = err
            .lines()
            .find(|l| l.starts_with(&format!("error: {name}:{line}:")))
            .unwrap_or_else(|| panic!("{name}: line {line} not named in: {err}"));
        let (_, what) = message.split_once(": ").unwrap();
        let what = what.split_once(": ").map_or(what, |(_, w)| w);
        assert!(what.starts_with(key), "{name}: not {key}: {message}");
        assert!(what.contains(why), "{name}: no `{why}` in: {message}");
    }
    assert!(
        !dir.path().join("out").exists(),
        "a refused scene wrote output"
    );
}

#[test]
fn still_obstacles_are_written_once_and_frames_gain_contact_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        dir.path(),
        &format!(
            "{MESH}[[obstacle]]\nplane = {{ point = [0, -0.5, 0], normal = [0, 1, 0] }}\n\
             [[obstacle]]\nname = \"ball\"\nsphere = {{ center = [3, 0, 0], radius = 0.5 }}\n\
             friction = 0.2\n[[obstacle]]\nbox = {{ min = [-3, 0, 0], max = [-2, 1, 1] }}\n"
        ),
    );
    assert_eq!(
        names(&out, "obstacles"),
        ["obstacles.pvd", "obstacles_0000.vtu"]
    );
    let pvd = std::fs::read_to_string(out.join("obstacles.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 1, "{pvd}");
    let surface = read_surface_vtu(&out.join("obstacles_0000.vtu")).unwrap();
    // plane square (2) + icosphere (320) + box (12)
    assert_eq!(surface.triangles.len(), 2 + 320 + 12);
    let Some(FieldData::Scalar(index)) = surface.cell_field("obstacle") else {
        panic!("no obstacle cell data");
    };
    assert_eq!((index[0], index[2], index[333]), (0.0, 1.0, 2.0));
    // The plane's square lies on the plane, 4 diagonals wide.
    let square = &surface.points[..4];
    assert!(square.iter().all(|p| (p.y + 0.5).abs() < 1e-12));
    let width = (square[1] - square[0]).norm();
    assert!(width > 4.0 * 3f64.sqrt(), "{width}");
    for frame in 0..=2 {
        let vtu = tetsim::io::read_vtu_frame(&out.join(format!("frame_{frame:04}.vtu"))).unwrap();
        match vtu.point_field("contact_force") {
            Some(FieldData::Vector(f)) => assert_eq!(f.len(), vtu.points.len()),
            other => panic!("frame {frame}: contact_force is {other:?}"),
        }
    }
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), steps_header(true));
    // The contract's columns, the four contact columns, then tangled_elements.
    let columns = STEPS_HEADER.split(',').count() + 5;
    for row in lines {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells.len(), columns, "{row}");
        assert!(cells[columns - 5].parse::<usize>().is_ok(), "{row}");
        assert!(cells[columns - 1].parse::<usize>().is_ok(), "{row}");
        for cell in &cells[columns - 3..columns - 1] {
            assert!(cell.parse::<f64>().unwrap().is_finite(), "{row}");
        }
    }
}

#[test]
fn a_moving_obstacle_is_written_every_frame_where_its_motion_has_taken_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        dir.path(),
        &format!(
            "{MESH}[[obstacle]]\nbox = {{ min = [0, 2, 0], max = [1, 3, 1] }}\n\
             motion = {{ translate = [0, -1, 0] }}\n"
        ),
    );
    assert_eq!(
        names(&out, "obstacles"),
        [
            "obstacles.pvd",
            "obstacles_0000.vtu",
            "obstacles_0001.vtu",
            "obstacles_0002.vtu"
        ]
    );
    let pvd = std::fs::read_to_string(out.join("obstacles.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 3, "{pvd}");
    let lowest = |frame: usize| {
        let s = read_surface_vtu(&out.join(format!("obstacles_{frame:04}.vtu"))).unwrap();
        s.points.iter().map(|p| p.y).fold(f64::INFINITY, f64::min)
    };
    // Ramped over the whole run (2 frames).
    assert_eq!((lowest(0), lowest(1), lowest(2)), (2.0, 1.5, 1.0));
}

#[test]
fn contact_table_alone_turns_contact_output_on() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(dir.path(), &format!("{MESH}[contact]\nself = false\n"));
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    assert!(csv.starts_with(&format!("{}\n", steps_header(true))));
    // No obstacles: an empty surface, still listed so that readers find the file.
    assert_eq!(
        names(&out, "obstacles"),
        ["obstacles.pvd", "obstacles_0000.vtu"]
    );
}

#[test]
fn a_scene_without_contact_writes_no_contact_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(dir.path(), MESH);
    assert!(names(&out, "obstacles").is_empty());
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    assert!(
        csv.starts_with(&format!("{}\n", steps_header(false))),
        "{csv}"
    );
    let columns = STEPS_HEADER.split(',').count() + 1;
    assert!(csv.lines().all(|l| l.split(',').count() == columns));
    let vtu = tetsim::io::read_vtu_frame(&out.join("frame_0002.vtu")).unwrap();
    assert!(vtu.point_field("contact_force").is_none());
    let manifest = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    assert!(!manifest.contains("obstacle"), "{manifest}");
}

#[test]
fn pictures_draw_the_obstacles_and_render_reads_them_back() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        format!(
            "{MESH}[[obstacle]]\nplane = {{ point = [0, -0.2, 0], normal = [0, 1, 0.2] }}\n\
             [[obstacle]]\nsphere = {{ center = [2, 0.5, 0.5], radius = 0.5 }}\n\
             motion = {{ translate = [0, 1, 0] }}\n[output]\nplots = false\nwidth = 160\n\
             height = 120\ngif_width = 80\ngif_height = 60\n"
        ),
    )
    .unwrap();
    let out = tetsim(dir.path(), &["run", "s.toml", "--out", "out", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(dir.path().join("out/preview.png").exists());
    let out = tetsim(
        dir.path(),
        &[
            "render", "out", "--out", "again", "--width", "160", "--height", "120",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    // Same obstacles, same camera, same look: the re-rendered preview matches the run's.
    let a = std::fs::read(dir.path().join("out/preview.png")).unwrap();
    let b = std::fs::read(dir.path().join("again/preview.png")).unwrap();
    assert_eq!(
        a, b,
        "tetsim render drew the obstacles differently from tetsim run"
    );
}
